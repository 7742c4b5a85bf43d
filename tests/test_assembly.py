"""tetlap.assembly: the one-shot functions (laplacian, mass, operators, triplets,
edge_weights, element_contributions): every route gives the same operator, the output layout
is the documented one, the result does not depend on the thread count, and the options
do what they say. (The paper's properties of the operators: test_invariants.py; inputs
and their errors: test_arrays.py.)"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from conftest import jittered_cube, non_delaunay, random_ball
from tetlap.benchmark import shuffled
from tetlap.diagnostics import (boundary_faces, faces, interior_vertices, mesh_edges,
                                signed_volumes)

KINDS = ["primal", "dual", 0.3]
MASSES = ["barycentric", "circumcentric", "fem"]
LOCAL_EDGES = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
CORNER_V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]


def shuffled_ball():
    """The ball with its vertices and tets in random order (no memory locality)."""
    return shuffled(*random_ball(), seed=5)


MESHES = {"cube": jittered_cube, "ball": random_ball, "non_delaunay": non_delaunay,
          "shuffled_ball": shuffled_ball}


@pytest.fixture(params=list(MESHES))
def mesh(request):
    return MESHES[request.param]()


def scale_of(L):
    return float(abs(L).max())


def same_csr(A, B):
    """Bitwise equal CSR arrays: shape, pattern and values."""
    return (A.shape == B.shape and np.array_equal(A.indptr, B.indptr)
            and np.array_equal(A.indices, B.indices) and A.data.tobytes() == B.data.tobytes())


# ---- routes ---------------------------------------------------------------------------


def test_all_routes_agree(mesh):
    V, T = mesh
    L = tetlap.laplacian(V, T, "dual")
    L2, M2 = tetlap.operators(V, T, laplacian="dual", mass="circumcentric")
    assert (L != L2).nnz == 0
    assert (M2 != tetlap.mass(V, T, "circumcentric")).nnz == 0
    r, c, v, shape = tetlap.triplets(V, T, "dual")
    assert len(v) == 16 * len(T)
    assert abs(sp.coo_array((v, (r, c)), shape=shape).tocsr() - L).max() <= 1e-14 * scale_of(L)
    edges, w = tetlap.edge_weights(V, T, "dual")
    np.testing.assert_array_equal(w, L[edges[:, 0], edges[:, 1]])
    W = tetlap.element_contributions(V, T, "dual")
    local = LOCAL_EDGES
    rows = np.concatenate([T[:, a] for a, b in local])
    cols = np.concatenate([T[:, b] for a, b in local])
    summed = sp.coo_array((W.T.ravel(), (rows, cols)), shape=L.shape).tocsr()
    summed = summed + summed.T
    assert abs(summed - (L - sp.diags_array(L.diagonal()))).max() <= 1e-14 * scale_of(L)


@pytest.mark.parametrize("lap", KINDS)
@pytest.mark.parametrize("mass", MASSES)
def test_operators_is_laplacian_and_mass_bitwise(lap, mass):
    V, T = jittered_cube()
    L, M = tetlap.operators(V, T, lap, mass)
    assert same_csr(L, tetlap.laplacian(V, T, lap))
    assert same_csr(M, tetlap.mass(V, T, mass))


def test_affine_endpoints_are_the_primal_and_the_dual():
    V, T = non_delaunay()
    for t, kind in ((0.0, "primal"), (1.0, "dual")):
        A, B = tetlap.laplacian(V, T, t), tetlap.laplacian(V, T, kind)
        assert abs(A - B).max() <= 1e-15 * scale_of(B), kind


def test_triplets_are_each_tets_local_laplacian_in_the_documented_order():
    V, T = non_delaunay()
    trip = tetlap.triplets(V, T, "dual")
    assert isinstance(trip, tetlap.Triplets)
    assert trip.rows.dtype == trip.cols.dtype == np.int64 and trip.vals.dtype == np.float64
    assert trip.shape == (len(V), len(V))
    # entry 16 t + 4 a + b is corners (a, b) of tet t
    rows, cols, vals = (x.reshape(len(T), 4, 4) for x in trip[:3])
    np.testing.assert_array_equal(rows, np.repeat(T[:, :, None], 4, axis=2))
    np.testing.assert_array_equal(cols, np.repeat(T[:, None, :], 4, axis=1))
    W = tetlap.element_contributions(V, T, "dual")
    for e, (a, b) in enumerate(LOCAL_EDGES):
        np.testing.assert_array_equal(vals[:, a, b], W[:, e])
        np.testing.assert_array_equal(vals[:, b, a], W[:, e])
    np.testing.assert_allclose(vals.sum(axis=2), 0, atol=1e-14 * np.abs(vals).max())


def test_edge_weights_are_the_unique_sorted_edges():
    V, T = random_ball()
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert edges.dtype == np.int64 and w.dtype == np.float64 and edges.shape == (len(w), 2)
    assert (edges[:, 0] < edges[:, 1]).all()
    keys = edges[:, 0] * len(V) + edges[:, 1]
    assert (np.diff(keys) > 0).all()  # sorted lexicographically, each once
    # the edges of the tets, computed here from T
    pairs = np.sort(np.concatenate([T[:, [a, b]] for a, b in LOCAL_EDGES]), axis=1)
    np.testing.assert_array_equal(edges, np.unique(pairs, axis=0))


def test_element_contributions_of_the_corner_tet():
    """By hand: the primal weight of edge ij is |e_kl| cot(theta_kl) / 6 for the opposite
    edge kl and its dihedral angle: 1/6 on the three edges at the right-angled corner
    (|e_kl| = sqrt 2, cot theta_kl = 1 / sqrt 2), 0 on the others (theta_kl = 90 deg)."""
    W = tetlap.element_contributions(CORNER_V, [[0, 1, 2, 3]], "primal")
    assert W.shape == (1, 6)
    np.testing.assert_allclose(W[0], [1 / 6] * 3 + [0] * 3, atol=1e-16)
    # the corners in another order: the weights follow their edges
    W2 = tetlap.element_contributions(CORNER_V, [[1, 2, 3, 0]], "primal")
    np.testing.assert_allclose(W2[0], [0, 0, 1 / 6, 0, 1 / 6, 1 / 6], atol=1e-16)


def test_tet_contributions_is_the_old_name_of_element_contributions():
    from tetlap import assembly

    assert tetlap.tet_contributions is tetlap.element_contributions
    assert assembly.tet_contributions is assembly.element_contributions


# ---- output layout --------------------------------------------------------------------


def test_csr_layout_is_canonical(mesh):
    V, T = mesh
    L = tetlap.laplacian(V, T, "dual")
    assert L.format == "csr" and L.dtype == np.float64
    assert L.has_sorted_indices
    copy = L.copy()
    copy.sum_duplicates()
    copy.sort_indices()
    np.testing.assert_array_equal(copy.indices, L.indices)
    np.testing.assert_array_equal(copy.indptr, L.indptr)
    edges = tetlap.diagnostics.mesh_edges(T)
    assert L.nnz == len(V) + 2 * len(edges)


def test_sparse_arrays_and_mass_layouts():
    V = np.array(CORNER_V + [[7, 7, 7]], dtype=float)  # vertex 4 is unreferenced
    V2, T = jittered_cube()
    for f in (lambda: tetlap.laplacian(V2, T), lambda: tetlap.mass(V2, T),
              lambda: tetlap.mass(V2, T, "fem"), lambda: tetlap.operators(V2, T)[1]):
        A = f()
        assert isinstance(A, sp.csr_array) and A.dtype == np.float64
    for kind in ("barycentric", "circumcentric"):  # lumped: diagonal
        M = tetlap.mass(V2, T, kind)
        assert (M != sp.diags_array(M.diagonal())).nnz == 0
        assert tetlap.mass(V, [[0, 1, 2, 3]], kind).diagonal()[4] == 0
    L, F = tetlap.laplacian(V2, T), tetlap.mass(V2, T, "fem")
    np.testing.assert_array_equal(F.indptr, L.indptr)  # fem: the pattern of L
    np.testing.assert_array_equal(F.indices, L.indices)


def test_unreferenced_vertices_get_empty_rows_and_zero_mass():
    V = np.array(CORNER_V + [[7, 7, 7]], dtype=float)
    L = tetlap.laplacian(V, [[0, 1, 2, 3]], "dual")
    assert L.shape == (5, 5) and L[[4], :].nnz == 1 and L[4, 4] == 0
    assert tetlap.mass(V, [[0, 1, 2, 3]], "circumcentric").diagonal()[4] == 0


def test_a_mesh_object_stands_for_v_and_t():
    meshio = pytest.importorskip("meshio")
    V, T = jittered_cube()
    obj = meshio.Mesh(V, [("tetra", T)])
    assert same_csr(tetlap.laplacian(obj, kind="dual"), tetlap.laplacian(V, T, "dual"))
    assert same_csr(tetlap.mass(obj, kind="fem"), tetlap.mass(V, T, "fem"))
    np.testing.assert_array_equal(tetlap.element_contributions(obj), tetlap.element_contributions(V, T))
    np.testing.assert_array_equal(tetlap.edge_weights(obj)[1], tetlap.edge_weights(V, T)[1])
    np.testing.assert_array_equal(tetlap.triplets(obj).vals, tetlap.triplets(V, T).vals)


def test_duplicate_and_nonmanifold_tets_follow_the_documented_policy():
    V, T = tetlap.meshes.cube(2)
    T2 = np.vstack([T, T[:1][:, ::-1]])  # tet 0 again, reversed: counted twice
    assert tetlap.diagnostics.duplicate_tets(T2).tolist() == [False] * len(T) + [True]
    # its 3 interior faces are now in 3 tets; its boundary face only in 2
    assert len(tetlap.diagnostics.nonmanifold_faces(T2)) == 3
    L, L2 = tetlap.laplacian(V, T), tetlap.laplacian(V, T2)
    extra = tetlap.laplacian(V, T[:1])
    assert abs(L2 - (L + extra)).max() < 1e-15
    assert tetlap.mass(V, T2).sum() == pytest.approx(tetlap.mass(V, T).sum() + 1 / 48)


# ---- threads --------------------------------------------------------------------------


def test_bitwise_identical_for_any_thread_count(mesh):
    V, T = mesh

    def arrays(threads):
        L, M = tetlap.operators(V, T, "dual", "circumcentric", threads=threads)
        F = tetlap.mass(V, T, "fem", threads=threads)
        P = tetlap.laplacian(V, T, "primal", threads=threads)
        e, w = tetlap.edge_weights(V, T, "dual", threads=threads)
        return [L.data, L.indices, L.indptr, M.data, F.data, P.data, w,
                tetlap.triplets(V, T, threads=threads).vals]

    reference = arrays(1)
    for threads in (2, 4, None):
        for a, b in zip(reference, arrays(threads)):
            assert a.tobytes() == b.tobytes()


def test_thread_counts_up_to_max_threads_are_accepted():
    V, T = jittered_cube()
    reference = tetlap.laplacian(V, T, "dual", threads=1)
    assert same_csr(tetlap.laplacian(V, T, "dual", threads=tetlap.MAX_THREADS), reference)
    with pytest.raises(tetlap.OptionError, match="threads"):
        tetlap.laplacian(V, T, "dual", threads=tetlap.MAX_THREADS + 1)


# ---- options --------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs, match", [
    ({"kind": "cotan"}, "kind"),
    ({"kind": 1.5}, r"\[0, 1\]"),
    ({"kind": -0.1}, r"\[0, 1\]"),
    ({"kind": True}, "kind"),
    ({"threads": 0}, "threads"),
    ({"threads": -2}, "threads"),
    ({"threads": 1.5}, "threads"),
    ({"degenerate": "ignore"}, "degenerate"),
])
def test_bad_options_raise_option_error(kwargs, match):
    with pytest.raises(tetlap.OptionError, match=match):
        tetlap.laplacian(CORNER_V, [[0, 1, 2, 3]], **kwargs)


def test_bad_mass_kind():
    with pytest.raises(tetlap.OptionError, match="mass kind"):
        tetlap.mass(CORNER_V, [[0, 1, 2, 3]], kind="voronoi")


def test_degenerate_skip_drops_only_the_flat_tet():
    V = np.array(CORNER_V + [[0.5, 0.5, 0], [0.2, 0.2, -1]], dtype=float)
    T = [[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]]
    for kind in ("primal", "dual"):
        L = tetlap.laplacian(V, T, kind, degenerate="skip")
        expected = tetlap.laplacian(V, [T[0], T[2]], kind).toarray()
        np.testing.assert_array_equal(L.toarray(), expected)
        assert np.isfinite(L.data).all()
        assert L[0, 4] == 0 and L.nnz > expected.astype(bool).sum()  # explicit zeros kept
    m = tetlap.mass(V, T, "circumcentric", degenerate="skip").diagonal()
    assert m[4] == 0 and m.sum() == pytest.approx(1 / 6 + 1 / 6 * 1)


# ---- vertex weights (power-diagram duals) and the barycentric boundary (Sec. 6, 9) -------


def interior_edge_mask(T, edges):
    bf = np.sort(boundary_faces(T), axis=1)
    on_boundary = {(a, b) for f in bf for a, b in ((f[0], f[1]), (f[0], f[2]), (f[1], f[2]))}
    return np.array([(i, j) not in on_boundary for i, j in edges])


@pytest.fixture
def ball():
    return tetlap.meshes.ball(700, seed=5)


def test_zero_weights_reproduce_the_plain_dual(ball):
    V, T = ball
    zeros = np.zeros(len(V))
    for f in (lambda **kw: tetlap.laplacian(V, T, "dual", **kw),
              lambda **kw: tetlap.mass(V, T, "circumcentric", **kw)):
        A, B = f(), f(weights=zeros)
        assert abs(A - B).max() <= 1e-12 * abs(A).max()
    # constant weights change nothing either (only differences of powers matter)
    A = tetlap.laplacian(V, T, "dual")
    B = tetlap.laplacian(V, T, "dual", weights=np.full(len(V), 0.37))
    assert abs(A - B).max() <= 1e-12 * abs(A).max()


@pytest.mark.parametrize("scale", [0.01, 0.1, 1.0])
def test_weighted_dual_linear_precision_and_volume_for_any_weights(ball, scale, rng):
    V, T = ball
    h2 = (np.linalg.norm(V[T[:, 0]] - V[T[:, 1]], axis=1) ** 2).mean()
    w = rng.uniform(-scale, scale, size=len(V)) * h2
    L = tetlap.laplacian(V, T, "dual", weights=w)
    plain = tetlap.laplacian(V, T, "dual")
    assert abs(L - plain).max() > 1e-6 * abs(plain).max()  # the weights do something
    s = abs(L).max()
    assert abs(L - L.T).max() <= 1e-13 * s
    inner = interior_vertices(T, len(V))
    assert np.abs((L @ V)[inner]).max() <= 1e-11 * s
    M = tetlap.mass(V, T, "circumcentric", weights=w)
    assert M.sum() == pytest.approx(np.abs(signed_volumes(V, T)).sum(), rel=1e-12)
    # pyramid identity does NOT hold for weighted duals (the dual face is off-centre),
    # but the mass is still the sum of the signed pieces: check against the unweighted
    # decomposition of the same tets being a different split of the same volume
    assert not np.allclose(M.diagonal(), tetlap.mass(V, T, "circumcentric").diagonal())


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_regular_triangulation_has_non_negative_interior_weights(seed):
    """Weighted analogue of the Delaunay result: on the regular triangulation of the
    weights, every interior edge's dual face is a power-diagram face, area >= 0."""
    rng = np.random.default_rng(seed)
    V = rng.uniform(-1, 1, size=(250, 3))
    w = rng.uniform(0, 0.05, size=len(V))
    T = tetlap.meshes.regular_triangulation(V, w)
    edges, weights = tetlap.edge_weights(V, T, "dual", weights=w)
    inner = interior_edge_mask(T, edges)
    assert inner.sum() > 100
    assert weights[inner].min() >= -1e-10 * np.abs(weights).max()
    # ... while the unweighted dual of the same (non-Delaunay) mesh has negative ones
    _, plain = tetlap.edge_weights(V, T, "dual")
    assert plain[inner].min() < -1e-6 * np.abs(plain).max()


def test_weights_are_validated(ball):
    V, T = ball
    with pytest.raises(tetlap.ShapeError, match="one per vertex"):
        tetlap.laplacian(V, T, "dual", weights=np.zeros(3))
    w = np.zeros(len(V))
    w[7] = np.nan
    with pytest.raises(tetlap.NonFiniteError, match="vertex 7") as e:
        tetlap.laplacian(V, T, "dual", weights=w)
    assert e.value.vertex == 7
    with pytest.raises(tetlap.OptionError, match="boundary"):
        tetlap.laplacian(V, T, "dual", boundary_centres="voronoi")


def test_primal_refuses_the_boundary_treatment_and_weights(ball):
    """The primal has no dual centres: a boundary treatment or weights given with it would
    be ignored silently, so both are refused."""
    V, T = ball
    with pytest.raises(tetlap.OptionError, match="would ignore it"):
        tetlap.laplacian(V, T, "primal", boundary_centres="barycentric")
    with pytest.raises(tetlap.OptionError, match="belong to the dual"):   # issue 37: ignored
        tetlap.laplacian(V, T, "primal", weights=np.ones(len(V)))


def boundary_tet_mask(T):
    F = np.sort(faces(T), axis=1)
    _, inverse, counts = np.unique(F, axis=0, return_inverse=True, return_counts=True)
    return (counts[inverse.ravel()] == 1).reshape(-1, 4).any(axis=1)


def test_barycentric_boundary_guarantees_and_cost():
    V, T = tetlap.meshes.ball(1500, seed=8)
    fixed = boundary_tet_mask(T)
    W = tetlap.element_contributions(V, T, "dual", boundary_centres="barycentric")
    W0 = tetlap.element_contributions(V, T, "dual")
    assert (W0[fixed] < 0).any()  # the plain construction has negative boundary weights
    assert (W[fixed] >= 0).all()  # guarantee: non-negative contributions in fixed tets
    np.testing.assert_array_equal(W[~fixed], W0[~fixed])  # other tets untouched
    L, M = tetlap.operators(V, T, "dual", "circumcentric", boundary_centres="barycentric")
    m = M.diagonal()
    assert (m > 0).all()  # guarantee: positive mass everywhere
    assert m.sum() == pytest.approx(np.abs(signed_volumes(V, T)).sum(), rel=1e-12)
    # cost: linear precision survives at interior vertices away from the boundary tets...
    touched = np.zeros(len(V), dtype=bool)
    touched[T[fixed].ravel()] = True
    inner = interior_vertices(T, len(V))
    s = abs(L).max()
    assert np.abs((L @ V)[inner & ~touched]).max() <= 1e-12 * s
    # ... and is lost at (some) interior vertices of boundary tets
    assert np.abs((L @ V)[inner & touched]).max() > 1e-6 * s
    edges = mesh_edges(T)
    w = L[edges[:, 0], edges[:, 1]]
    on_fixed = np.isin(edges, np.unique(T[fixed])).all(axis=1)
    plain = tetlap.laplacian(V, T, "dual")[edges[:, 0], edges[:, 1]]
    assert (w < 0).sum() < (plain < 0).sum()
    assert on_fixed.any()


def test_mesh_with_weights_and_boundary_matches_one_shot(ball, rng):
    V, T = ball
    w = rng.uniform(0, 1e-3, size=len(V))
    kw = dict(weights=w, boundary_centres="barycentric")
    mesh = tetlap.Mesh(V, T, **kw)
    assert (mesh.laplacian("dual") != tetlap.laplacian(V, T, "dual", **kw)).nnz == 0
    V2 = V.copy()
    V2[:20] *= 1.01
    mesh.update(V2)
    assert (mesh.laplacian("dual") != tetlap.laplacian(V2, T, "dual", **kw)).nnz == 0
    assert (mesh.mass("circumcentric") != tetlap.mass(V2, T, "circumcentric", **kw)).nnz == 0


# ---- weights= where nothing uses them --------------------------------------------------


def test_weights_are_refused_wherever_nothing_uses_them(ball):
    """Issue 37.10: ``weights=`` with the primal was ignored silently (and with the
    barycentric, mixed and FEM masses, which do not depend on them either), and so was
    ``boundary_centres="barycentric"``. Every function that takes them refuses them, naming the keyword and that they belong to the
    dual, where the result would not depend on them; where a part uses them, they are
    used (and change the result)."""
    V, T = ball
    w = np.random.default_rng(0).uniform(0, 1e-2, len(V))
    f = V[:, 0] ** 2
    edges = tetlap.diagnostics.mesh_edges(V, T)
    refused = {
        "laplacian primal": lambda **k: tetlap.laplacian(V, T, "primal", **k),
        "laplacian default": lambda **k: tetlap.laplacian(V, T, **k),
        "laplacian t = 0": lambda **k: tetlap.laplacian(V, T, 0.0, **k),
        "mass barycentric": lambda **k: tetlap.mass(V, T, "barycentric", **k),
        "mass mixed": lambda **k: tetlap.mass(V, T, "mixed", **k),
        "mass fem": lambda **k: tetlap.mass(V, T, "fem", **k),
        "operators": lambda **k: tetlap.operators(V, T, "primal", "mixed", **k),
        "triplets": lambda **k: tetlap.triplets(V, T, "primal", **k),
        "edge_weights": lambda **k: tetlap.edge_weights(V, T, "primal", **k),
        "element_contributions": lambda **k: tetlap.element_contributions(V, T, **k),
        "tet_contributions": lambda **k: tetlap.tet_contributions(V, T, **k),
        "Mesh.laplacian": lambda **k: tetlap.Mesh(V, T, **k).laplacian(),
        "Mesh.mass": lambda **k: tetlap.Mesh(V, T, **k).mass("barycentric"),
        "Mesh.operators": lambda **k: tetlap.Mesh(V, T, **k).operators("primal", "fem"),
        "vjp": lambda **k: tetlap.vjp(V, T, "primal", dL=(edges, np.ones(len(edges))), **k),
        "dirichlet_energy": lambda **k: tetlap.dirichlet_energy(V, T, f, "primal", **k),
        "mass_energy": lambda **k: tetlap.mass_energy(V, T, f, "barycentric", **k),
        "HeatDistance": lambda **k: tetlap.HeatDistance(V, T, **k),
        "harmonic": lambda **k: tetlap.harmonic(V, T, [0], [1.0], laplacian="primal", **k),
        "check": lambda **k: tetlap.check(tetlap.laplacian(V, T), V, T, nsd=False, **k),
    }
    for name, call in refused.items():
        call()                                                   # fine without weights
        with pytest.raises(tetlap.OptionError, match="weights") as e:
            call(weights=w)
        assert "dual" in str(e.value), name
        if name == "check":                                      # takes no boundary_centres
            continue
        # the barycentric boundary centres move the same centres: refused by the same rule
        with pytest.raises(tetlap.OptionError, match='boundary_centres="barycentric"') as e:
            call(boundary_centres="barycentric")
        assert "would ignore it" in str(e.value), name
        call(boundary_centres="circumcentric")                   # the default passes
    used = {
        "laplacian dual": lambda **k: tetlap.laplacian(V, T, "dual", **k),
        "laplacian t = 0.5": lambda **k: tetlap.laplacian(V, T, 0.5, **k),
        "mass circumcentric": lambda **k: tetlap.mass(V, T, "circumcentric", **k),
        "operators, the mass weighted": lambda **k: tetlap.operators(V, T, "primal",
                                                                     "circumcentric", **k)[1],
        "Mesh.laplacian dual": lambda **k: tetlap.Mesh(V, T, **k).laplacian("dual"),
        "dirichlet_energy dual": lambda **k: tetlap.dirichlet_energy(V, T, f, "dual", **k)[0],
    }
    for name, call in used.items():
        a, b = call(), call(weights=w)
        assert (abs(a - b).max() if hasattr(a, "nnz") else abs(a - b)) > 0, name
        if name == "dirichlet_energy dual":                      # not differentiated
            continue
        a, b = call(), call(boundary_centres="barycentric")
        assert (abs(a - b).max() if hasattr(a, "nnz") else abs(a - b)) > 0, name
