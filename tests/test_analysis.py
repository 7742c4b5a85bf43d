"""tetlap.analysis (tetlap.check): every line of the report can fail, and says why; the
semidefiniteness answer against dense eigenvalues."""

from __future__ import annotations

import contextlib
import functools
import json
from unittest import mock

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from hypothesis import assume, given, settings
from scipy.sparse.linalg import splu
from hypothesis import strategies as st

import tetlap
import tetlap.analysis as analysis
from tetlap import _core


@pytest.fixture
def cube():
    return tetlap.meshes.cube(3, jitter=0.15, seed=4)


def test_good_operator_passes_everything(cube):
    V, T = cube
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    r = tetlap.check(L, V, T, M)
    assert (r.finite, r.symmetric, r.row_sums_ok, r.local, r.linear_precision_ok, r.nsd) == (
        True, True, True, True, True, True)
    # the cheap certificate decides first (issue 30.10: dense eigenvalues made `tetlap info`
    # on 2,000 vertices take 15-20 s)
    assert r.nsd_method.startswith("element certificate") and "by construction" in r.nsd_method
    assert r.mass_nonpositive == 0
    assert r.mass_total == pytest.approx(r.mesh_volume, rel=1e-12)
    assert json.loads(json.dumps(r.to_dict()))["n_tets"] == len(T)
    text = str(r)
    assert "linear precision" in text and "negative semidefinite" in text


def test_kuhn_grid_zero_weights_are_not_negative():
    V, T = tetlap.meshes.cube(3)
    L = tetlap.laplacian(V, T, "primal")
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert (w == 0).sum() + (np.abs(w) < 1e-15).sum() > 0  # right dihedral angles
    r = tetlap.check(L, V, T)
    assert r.n_negative == 0 and r.min_weight > -1e-12 * np.abs(w).max()
    # a zero weight that rounding made -1e-17: below the tolerance, it does not count;
    # with negative_tol=0 every w < 0 counts
    i, j = edges[np.flatnonzero(w == 0)[0]]
    noisy = L.tolil()
    noisy[i, j] = noisy[j, i] = -1e-17
    noisy[i, i] += 1e-17
    noisy[j, j] += 1e-17
    noisy = noisy.tocsr()
    assert tetlap.check(noisy, V, T).n_negative == 0
    strict = tetlap.check(noisy, V, T, negative_tol=0.0)
    assert strict.n_negative == 1 and strict.min_weight == -1e-17
    assert tetlap.check(L, V, T, negative_tol=0.0).n_negative == (w < 0).sum() == 0


def test_each_failure_is_detected(cube):
    V, T = cube
    L = tetlap.laplacian(V, T, "dual").tolil()
    asym = L.copy()
    asym[0, 1] += 0.5
    r = tetlap.check(asym.tocsr(), V, T)
    assert not r.symmetric and not r.row_sums_ok
    far = L.copy()
    i, j = 0, len(V) - 1
    assert j not in L.rows[i]
    far[i, j] = far[j, i] = 1e-3
    far[i, i] -= 1e-3
    far[j, j] -= 1e-3
    r = tetlap.check(far.tocsr(), V, T)
    assert r.symmetric and r.row_sums_ok and not r.local
    graph = tetlap.laplacian(V, T, "dual").copy()
    off = graph.indices != np.repeat(np.arange(len(V)), np.diff(graph.indptr))
    graph.data[off] = 1.0
    graph = sp.csr_array(graph - sp.diags_array(np.asarray(graph.sum(axis=1)).ravel()))
    r = tetlap.check(graph, V, T)
    assert r.row_sums_ok and not r.linear_precision_ok  # the uniform Laplacian
    nan = tetlap.laplacian(V, T, "dual").copy()
    nan.data[3] = np.nan
    r = tetlap.check(nan, V, T)
    assert not r.finite and r.nsd is None
    assert r.symmetric is None and r.row_sums_ok is None and r.linear_precision_ok is None
    assert "NO" in str(r) and "NaN or Inf" in str(r)


def test_non_delaunay_dual_is_reported_indefinite_with_negative_weights():
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    L, M = tetlap.operators(V, T, "dual", "circumcentric")
    r = tetlap.check(L, V, T, M)
    assert r.nsd is False and r.nsd_min_eigenvalue_upper_bound < 0
    assert r.n_negative_interior > 0 and r.linear_precision_ok
    assert "NO" in str(r)
    p = tetlap.check(tetlap.laplacian(V, T, "primal"), V, T)
    assert p.nsd is True


CERTIFICATE_CASES = {
    "Delaunay ball, primal": (lambda: tetlap.meshes.ball(700, seed=2), "primal"),
    "Delaunay ball, dual": (lambda: tetlap.meshes.ball(700, seed=2), "dual"),
    "Delaunay ball, t = 0.5": (lambda: tetlap.meshes.ball(700, seed=2), 0.5),
    "non-Delaunay ball, dual": (lambda: tetlap.meshes.weighted_ball(600, 0.5, seed=1), "dual"),
    "slightly non-Delaunay ball, dual": (lambda: tetlap.meshes.weighted_ball(600, 0.05, seed=4), "dual"),
    "jittered cube, dual": (lambda: tetlap.meshes.cube(6, jitter=0.24, seed=5), "dual"),
}


def nsd_by_definition(L) -> bool:
    """The NSD rule of ``check`` decided here from its definition, independently of the
    library's routes (dense; small ``n`` only): ``-L + 1e-9 D``, ``D = diag(|L_ii|)``, is
    positive semidefinite, i.e. the generalised eigenvalues of ``(-L) x = mu D x`` (LAPACK's
    ``sygvd``) are all ``>= -1e-9``, on the rows with entries (an all-zero row is an
    eigenvalue 0 alone; a row with entries and a zero diagonal is indefinite)."""
    A = -((L + L.T) / 2).toarray()
    live = np.abs(A).sum(axis=1) > 0
    D = np.abs(np.diag(A))[live]
    if (D == 0).any():
        return False
    mu = scipy.linalg.eigh(A[np.ix_(live, live)], np.diag(D), eigvals_only=True)
    return bool(len(mu) == 0 or mu[0] >= -1e-9)


def test_the_rule_by_definition_is_not_vacuous():
    P = sp.csr_array(np.array([[-1.0, 1.0], [1.0, -1.0]]))  # a primal edge: semidefinite
    assert nsd_by_definition(P) and not nsd_by_definition(-P)
    tiny = sp.csr_array(np.array([[-1.0, 1.0 + 1e-6], [1.0 + 1e-6, -1.0]]))
    assert not nsd_by_definition(tiny)
    assert not nsd_by_definition(sp.csr_array(np.array([[0.0, 1.0], [1.0, -1.0]])))
    assert nsd_by_definition(sp.csr_array((3, 3)))


@pytest.mark.parametrize("case", list(CERTIFICATE_CASES))
def test_certificates_never_contradict_dense_eigenvalues(monkeypatch, case):
    mesh, kind = CERTIFICATE_CASES[case]
    V, T = mesh()
    L = tetlap.laplacian(V, T, kind)
    expected = nsd_by_definition(L)
    lam = np.linalg.eigvalsh(-((L + L.T) / 2).toarray())[0]
    for dense_max in (analysis.DENSE_NSD_MAX, 10):  # 10: never dense, the certificates answer
        monkeypatch.setattr(analysis, "DENSE_NSD_MAX", dense_max)
        for hint in (None, kind):
            r = tetlap.check(L, V, T, kind=hint)
            assert r.nsd == expected, (case, hint, r.nsd_method, lam)
            assert "dense" not in r.nsd_method, r.nsd_method
            if r.nsd is False:  # the witness's Rayleigh quotient bounds the smallest eigenvalue
                assert lam <= r.nsd_min_eigenvalue_upper_bound < 0


def _random_case(data):
    """A small mesh and an operator on it, drawn by hypothesis: a primal, dual or affine
    Laplacian of a Delaunay ball, a non-Delaunay (weighted) ball, a jittered grid or a
    flipped ball (an indefinite dual)."""
    seed = data.draw(st.integers(0, 2**16), label="seed")
    shape = data.draw(st.sampled_from(["ball", "weighted ball", "cube", "flipped"]), label="mesh")
    if shape == "ball":
        V, T = tetlap.meshes.ball(data.draw(st.integers(30, 300), label="n"), seed=seed)
    elif shape == "weighted ball":
        V, T = tetlap.meshes.weighted_ball(data.draw(st.integers(30, 300), label="n"),
                                           data.draw(st.floats(0.0, 1.5), label="weights"),
                                           seed=seed)
    elif shape == "cube":
        V, T = tetlap.meshes.cube(data.draw(st.integers(2, 5), label="k"),
                                  jitter=data.draw(st.floats(0.0, 0.24), label="jitter"),
                                  seed=seed)
    else:
        V, T, _ = flipped_ball(600, skip=seed % 3)
    kind = data.draw(st.sampled_from(["primal", "dual", 0.5]), label="kind")
    return V, T, tetlap.laplacian(V, T, kind), kind


@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_the_cheap_answers_agree_with_dense_eigenvalues_on_random_small_cases(data):
    """Issue 30.10: the certificates and the LDL^T now decide before dense eigenvalues
    (their last resort); on many small meshes and matrices, semidefinite and indefinite,
    the verdict is the one of the rule decided by definition (dense, independently)."""
    V, T, L, kind = _random_case(data)
    A = -((L + L.T) / 2).toarray()
    live = np.abs(A).sum(axis=1) > 0
    D = np.abs(np.diag(A))[live]
    if (D > 0).all() and live.any():  # a verdict within rounding of the threshold: no test
        mu = scipy.linalg.eigh(A[np.ix_(live, live)], np.diag(D), eigvals_only=True)[0]
        assume(abs(mu + 1e-9) > 1e-11)
    expected = nsd_by_definition(L)
    # each route alone too: no LDL^T (dense decides what the certificates leave), no dense
    route = data.draw(st.sampled_from(["all", "no LDL^T", "no dense"]), label="route")
    limits = {"all": {}, "no LDL^T": {"SPARSE_NSD_MAX": 0}, "no dense": {"DENSE_NSD_MAX": 0}}
    with contextlib.ExitStack() as stack:
        for name, value in limits[route].items():
            stack.enter_context(mock.patch.object(analysis, name, value))
        for hint in {None, kind}:
            r = tetlap.check(L, V, T, kind=hint)
            if r.nsd is None:  # only when the LDL^T pivoted off the diagonal and no dense
                assert route == "no dense" and "pivoted" in r.nsd_method, r.nsd_method
                continue
            assert r.nsd == expected, (hint, r.nsd_method)
            if r.nsd is False and r.nsd_min_eigenvalue_upper_bound is not None:
                assert np.linalg.eigvalsh(A)[0] <= r.nsd_min_eigenvalue_upper_bound * (1 - 1e-12) + 1e-300


@functools.lru_cache
def gram_sum(seed: int):
    """``(V, T, A, E, s*)`` on a 700-vertex ball: ``A = sum_t G_t G_t^T`` (random per-tet
    Gram matrices with zero row sums: semidefinite, with negative weights; no mesh's
    operator, so no element certificate), ``E`` random on the edges with zero row sums,
    ``A + s E`` semidefinite exactly for ``s <= s*``. Beyond 600 vertices (``MAX_GROUP``)
    the local certificates cannot see the whole matrix: near ``s*`` only the LDL^T or dense
    eigenvalues decide. Cached: never modify the arrays."""
    V, T = tetlap.meshes.ball(700, seed=seed)
    rng = np.random.default_rng(seed)
    n = len(V)
    G = rng.normal(size=(len(T), 4, 3))
    G -= G.mean(axis=1, keepdims=True)
    K = np.einsum("tac,tbc->tab", G, G)
    rows, cols = np.repeat(T, 4, axis=1), np.tile(T, (1, 4))
    A = sp.coo_array((K.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr()
    edges = tetlap.diagnostics.mesh_edges(T)
    e = rng.normal(size=len(edges))
    E = sp.coo_array((np.r_[e, e], (np.r_[edges[:, 0], edges[:, 1]],
                                    np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n)).tocsr()
    E = sp.csr_array(E - sp.diags_array(np.asarray(E.sum(axis=1)).ravel()))
    Q = scipy.linalg.null_space(np.ones((1, n)))   # an orthonormal basis of 1^perp
    mu = scipy.linalg.eigh(-Q.T @ E.toarray() @ Q, Q.T @ A.toarray() @ Q, eigvals_only=True)[-1]
    return V, T, A, E, 1 / mu


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("f", [0.5, 0.99, 1.001, 2.0])
def test_matrices_only_the_whole_decides_agree_with_dense_by_every_route(monkeypatch, seed, f):
    """Issue 30.10: past the certificates, the LDL^T decides (and dense eigenvalues when it
    cannot); each route alone gives the verdict of the rule by definition."""
    V, T, A, E, critical = gram_sum(seed)
    L = sp.csr_array(-(A + f * critical * E))
    expected = nsd_by_definition(L)
    assert expected is (f < 1)
    r = tetlap.check(L, V, T)
    assert r.nsd is expected, r.nsd_method
    if f in (0.99, 1.001):  # only the whole matrix decides
        assert r.nsd_method.startswith("inertia of a sparse LDL^T"), r.nsd_method
    monkeypatch.setattr(analysis, "SPARSE_NSD_MAX", 0)
    r = tetlap.check(L, V, T)
    assert r.nsd is expected, r.nsd_method
    if f in (0.99, 1.001):
        assert r.nsd_method.startswith("dense eigenvalues"), r.nsd_method
        lam = np.linalg.eigvalsh(-L.toarray())[0]
        assert r.nsd_min_eigenvalue_upper_bound == pytest.approx(lam, abs=1e-12 * abs(L).max())


# ---- the tolerance is relative to each row: no part of a mesh hides another ------------


def local_scaled_eigenvalue(L, vertices) -> float:
    """The smallest generalised eigenvalue of ``(-L) x = mu D x`` on a principal submatrix:
    below -1e-9, it proves (by interlacing) that ``-L + 1e-9 D`` is not semidefinite."""
    A = -((L + L.T) / 2)[vertices][:, vertices].toarray()
    return float(scipy.linalg.eigh(A, np.diag(np.abs(np.diag(A))), eigvals_only=True)[0])


@functools.lru_cache
def flipped_ball(n: int, seed: int = 1, skip: int = 0):
    """A random Delaunay ball after one 2-3 flip that makes its dual indefinite: ``(V, T,
    mu)`` for the first flip (after ``skip`` such flips, in the order of the interior
    faces) whose neighbourhood's scaled eigenvalue ``mu`` is below -1e-6 while its
    unscaled one stays above -0.1 (a mild indefiniteness, in the ball's own units).
    Cached: the arrays are shared, never modify them."""
    V, T = tetlap.meshes.ball(n, seed=seed)
    tets, opposite = tetlap.diagnostics.interior_faces(T)
    for (t1, t2), (a, b) in zip(tets, opposite):
        face = [v for v in T[t1] if v != a]
        new = np.array([[face[0], face[1], a, b], [face[1], face[2], a, b],
                        [face[2], face[0], a, b]])
        volumes = tetlap.diagnostics.signed_volumes(V, new)
        if not ((volumes > 0).all() or (volumes < 0).all()):
            continue  # the edge ab misses the face: no 2-3 flip
        T2 = tetlap.meshes.orient(V, np.vstack([np.delete(T, [t1, t2], axis=0), new]))
        L = tetlap.laplacian(V, T2, "dual")
        around = np.unique(T2[np.isin(T2, [a, b, *face]).any(axis=1)])
        mu = local_scaled_eigenvalue(L, around)
        unscaled = np.linalg.eigvalsh(-L[around][:, around].toarray())[0]
        if mu < -1e-6 and unscaled > -0.1:
            if skip == 0:
                return V, T2, mu
            skip -= 1
    raise AssertionError("no 2-3 flip makes this ball's dual indefinite")


def with_far_tet(V, T, edge: float, shared_vertex: int | None = None):
    """``(V, T)`` plus a regular tet of edge ``edge``: far away (its own component), or
    sharing ``shared_vertex`` with the mesh (one component)."""
    Vr, Tr = tetlap.meshes.single_tet("regular")
    if shared_vertex is None:
        X = Vr * edge + 10 * edge
        return np.vstack([V, X]), np.vstack([T, Tr + len(V)])
    X = (Vr - Vr[0]) * edge + V[shared_vertex]
    index = np.array([shared_vertex, len(V), len(V) + 1, len(V) + 2])
    return np.vstack([V, X[1:]]), tetlap.meshes.orient(np.vstack([V, X[1:]]),
                                                       np.vstack([T, index[Tr]]))


@pytest.mark.parametrize("skip", [0, 1])
def test_a_large_component_does_not_hide_an_indefinite_one(skip):
    """Issue 24: a 4,000-vertex ball whose dual one 2-3 flip makes indefinite, and a far
    regular tet of edge 1e10 (semidefinite alone, entries 1e9 times the ball's)."""
    V, T, mu = flipped_ball(4000, skip=skip)
    V2, T2 = with_far_tet(V, T, 1e10)
    L = tetlap.laplacian(V2, T2, "dual")
    # a tolerance of 1e-9 max|L| (1.8 here) hides the ball's indefiniteness: -L + 1.8 I has
    # no negative pivot (Sylvester), while -L + 1e-9 D is indefinite on the flip (mu)
    old = 1e-9 * abs(L).max()
    lu = splu(sp.csc_array(-L + old * sp.eye_array(len(V2))), permc_spec="MMD_AT_PLUS_A",
              diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    assert np.array_equal(lu.perm_r, lu.perm_c) and (lu.U.diagonal() >= 0).all()
    assert mu < -1e-6
    for kind in (None, "dual"):
        r = tetlap.check(L, V2, T2, kind=kind)
        assert r.nsd is False, r.nsd_method
    assert tetlap.check(tetlap.laplacian(V2, T2, "primal"), V2, T2).nsd is True


def test_a_large_tet_sharing_a_vertex_does_not_hide_an_indefinite_region():
    V, T, _ = flipped_ball(4000)
    boundary = np.flatnonzero(tetlap.diagnostics.boundary_vertices(T, len(V)))
    V2, T2 = with_far_tet(V, T, 1e10, shared_vertex=int(boundary[0]))
    L = tetlap.laplacian(V2, T2, "dual")
    assert tetlap.check(L, V2, T2).nsd is False
    assert tetlap.check(tetlap.laplacian(V2, T2, "primal"), V2, T2).nsd is True


def small_meshes():
    """Small meshes for the dense comparisons: semidefinite and indefinite duals, each
    alone and beside a regular tet 1e10 or 1e-10 times its size, apart or sharing a
    vertex."""
    flipped = flipped_ball(600)[:2]
    cases = {"flipped ball": flipped, "Delaunay ball": tetlap.meshes.ball(500, seed=3),
             "jittered cube": tetlap.meshes.cube(5, jitter=0.24, seed=5)}
    out = {}
    for name, (V, T) in cases.items():
        out[name] = (V, T)
        for edge in (1e10, 1e-10):
            out[f"{name} + tet of edge {edge:g}"] = with_far_tet(V, T, edge)
        out[f"{name} + tet of edge 1e10 at vertex 0"] = with_far_tet(V, T, 1e10, 0)
    return out


SMALL = small_meshes()


@pytest.mark.parametrize("name", list(SMALL))
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_every_route_agrees_with_the_rule_by_definition(monkeypatch, name, kind):
    V, T = SMALL[name]
    L = tetlap.laplacian(V, T, kind)
    expected = nsd_by_definition(L)
    assert tetlap.check(L, V, T).nsd == expected
    if "flipped" in name:
        assert expected is (kind == "primal")
    elif kind == "primal":
        assert expected
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)  # the certificates, then LDL^T
    for hint in (None, kind):
        assert tetlap.check(L, V, T, kind=hint).nsd in (expected, None)


@pytest.mark.parametrize("name", ["flipped ball", "Delaunay ball"])
@pytest.mark.parametrize("exponent", [-12, -6, 0, 6, 12])
def test_scaling_one_component_never_changes_the_answer(name, exponent):
    V, T = SMALL[name]
    V2, T2 = with_far_tet(V, T, 10.0 ** exponent)
    alone = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T).nsd
    assert alone is (name != "flipped ball")
    assert tetlap.check(tetlap.laplacian(V2, T2, "dual"), V2, T2).nsd is alone


def test_zero_rows_are_semidefinite_and_a_zero_diagonal_with_entries_is_not(monkeypatch):
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=2)
    V = np.vstack([V, [[5.0, 5.0, 5.0]]])  # an unreferenced vertex: an all-zero row
    P = tetlap.laplacian(V, T, "primal")
    assert tetlap.check(P, V, T).nsd is True
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)
    assert tetlap.check(P, V, T).nsd is True
    bad = P.tolil()
    bad[0, 0] = 0.0  # row 0 keeps its weights
    bad = bad.tocsr()
    assert not nsd_by_definition(bad)
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 2500)
    assert tetlap.check(bad, V, T).nsd is False


def test_a_vertex_of_skipped_tets_only_has_a_zero_tolerance_and_passes(monkeypatch):
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=2)
    flat = np.array([[0.5, 0.5, 2.0], [1.5, 0.5, 2.0], [0.5, 1.5, 2.0], [1.5, 1.5, 2.0]])
    V2 = np.vstack([V, flat])
    T2 = np.vstack([T, [np.arange(len(V), len(V) + 4)]])  # a flat tet, skipped
    for kind in ("primal", "dual"):
        L = tetlap.laplacian(V2, T2, kind, degenerate="skip")
        assert np.all(L[[len(V)], :].toarray() == 0)
        r = tetlap.check(L, V2, T2, kind=kind)
        assert r.nsd is True and "element certificate" in r.nsd_method, r.nsd_method


def test_the_primal_is_semidefinite_by_construction_only_when_it_is_the_primal(monkeypatch):
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)
    V, T = tetlap.meshes.ball(700, seed=2)
    P = tetlap.laplacian(V, T, "primal")
    assert "by construction" in tetlap.check(P, V, T).nsd_method
    V2 = V.copy()
    V2[np.abs(V2).max(axis=1) < 0.5] *= 1.001  # another geometry: not this mesh's primal
    assert "by construction" not in tetlap.check(P, V2, T).nsd_method


def test_mass_lines(cube):
    V, T = tetlap.meshes.weighted_ball(600, 1.0, seed=3)
    M = tetlap.mass(V, T, "circumcentric")
    r = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T, M)
    assert r.mass_nonpositive > 0 and r.mass_min < 0
    assert r.mass_total == pytest.approx(r.mesh_volume, rel=1e-10)


def test_immersed_mesh_skips_linear_precision(cube):
    V, T = cube
    V4 = np.column_stack([V, V[:, 0] ** 2])
    r = tetlap.check(tetlap.laplacian(V4, T, "primal"), V4, T)
    assert r.linear_precision_residual is None and r.nsd
    assert any("immersed" in n for n in r.notes)


def test_tetlap_properties_is_an_alias_of_tetlap_analysis():
    import tetlap.properties as old

    for name in analysis.__all__:
        assert getattr(old, name) is getattr(analysis, name), name
    assert old.__all__ == analysis.__all__
    assert tetlap.check is analysis.check


def test_shape_mismatch(cube):
    V, T = cube
    with pytest.raises(tetlap.ShapeError):
        tetlap.check(sp.eye_array(3, format="csr"), V, T)


def _dense_minus_laplacian(n, T, W):
    """``-L = sum_t K_t`` from per-tet edge weights (local edges 01 02 03 12 13 23)."""
    A = np.zeros((n, n))
    for (a, b), w in zip([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)], W.T):
        i, j = T[:, a], T[:, b]
        np.add.at(A, (i, i), w)
        np.add.at(A, (j, j), w)
        np.add.at(A, (i, j), -w)
        np.add.at(A, (j, i), -w)
    return A


def row_tolerances(A) -> np.ndarray:
    """``1e-9 |A_ii|`` (n,): the tolerances of ``check`` for a dense ``-L``."""
    return 1e-9 * np.abs(np.diag(A))


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mean=st.floats(-0.5, 2.0), spread=st.floats(0.0, 3.0),
       per_row=st.booleans())
def test_the_element_certificate_never_certifies_an_indefinite_sum(seed, mean, spread, per_row):
    rng = np.random.default_rng(seed)
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=seed % 997)
    W = rng.normal(mean, spread, size=(len(T), 6))
    A = _dense_minus_laplacian(len(V), T, W)
    tol = row_tolerances(A) if per_row else np.full(len(V), 1e-9 * np.abs(W).max())
    verdict, name, details = _core.element_certificate(T, len(V), W, tol)
    assert verdict in (True, None)
    if verdict:
        assert name == "element certificate", details
        if per_row:
            assert nsd_by_definition(sp.csr_array(-A)), details
        else:
            assert np.linalg.eigvalsh(A)[0] >= -tol[0], details
    else:
        assert name == "undetermined" and details["uncovered"] > 0


def test_the_element_certificate_answers_when_neighbours_cover_the_negative_weights():
    V, T = tetlap.meshes.cube(8, jitter=0.24, seed=5)
    W = tetlap.element_contributions(V, T, "dual")
    assert (W < 0).any()
    A = _dense_minus_laplacian(len(V), T, W)
    verdict, _, details = _core.element_certificate(T, len(V), W, row_tolerances(A))
    assert verdict is True and details["groups"] > 0
    assert nsd_by_definition(sp.csr_array(-A))
    # the primal needs no group: every K_t is a Gram matrix
    P = tetlap.element_contributions(V, T, "primal")
    tol = row_tolerances(_dense_minus_laplacian(len(V), T, P))
    assert _core.element_certificate(T, len(V), P, tol)[2]["groups"] == 0


def test_the_element_certificate_refuses_weights_and_tolerances_of_the_wrong_shape():
    V, T = tetlap.meshes.cube(2)
    W = tetlap.element_contributions(V, T)
    with pytest.raises(tetlap.ShapeError):
        _core.element_certificate(T, len(V), np.zeros((len(T), 3)), np.zeros(len(V)))
    for tol in (np.zeros(len(V) - 1), np.full(len(V), -1e-9), np.full(len(V), np.nan)):
        with pytest.raises(tetlap.ShapeError, match="toleranc"):
            _core.element_certificate(T, len(V), W, tol)
        with pytest.raises(tetlap.ShapeError, match="toleranc"):
            _core.negative_semidefinite(len(V), (np.zeros(0), np.zeros(0, np.int64),
                                                 np.zeros(len(V) + 1, np.int64)), tol)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_the_element_certificate_never_contradicts_dense_eigenvalues_on_the_corpus(real_mesh, kind):
    name, V, T = real_mesh
    W = tetlap.element_contributions(V, T, kind, degenerate="skip")
    L = tetlap.laplacian(V, T, kind, degenerate="skip")
    tol = analysis.NSD_RTOL * np.abs(L.diagonal())
    verdict, _, _ = _core.element_certificate(T, len(V), W, tol)
    if kind == "primal":
        assert verdict is True, name  # a sum of Gram matrices
    if verdict and len(V) <= 3000:
        assert nsd_by_definition(L), name


def test_a_witness_rayleigh_quotient_is_labelled_an_upper_bound():
    """Issue 30: a witness's Rayleigh quotient was printed "min eig(-L)" and reported as
    ``nsd_min_eigenvalue``; it is an upper bound on that eigenvalue."""
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    L = tetlap.laplacian(V, T, "dual")
    r = tetlap.check(L, V, T)
    assert r.nsd is False and r.nsd_method.startswith("witness")
    bound = r.nsd_min_eigenvalue_upper_bound
    assert np.linalg.eigvalsh((-L).toarray())[0] <= bound < 0
    (row,) = [line for line in str(r).splitlines() if line.startswith("negative semidefinite")]
    assert f"min eig(-L) <= {bound:.3e}" in row
    assert "nsd_min_eigenvalue_upper_bound" in r.to_dict() and "nsd_min_eigenvalue" not in r.to_dict()
    with pytest.deprecated_call(match="upper bound"):
        assert r.nsd_min_eigenvalue == bound
    report = tetlap.info.report(V, T, regular=False)
    assert report["schema_version"] == tetlap.info.SCHEMA_VERSION >= 3
    assert report["dual"]["nsd_min_eigenvalue_upper_bound"] == bound


@pytest.mark.parametrize("scale", [1e-300, 1e-315, 1e-320, 5e-324, 1e300])
def test_any_positive_multiple_gets_a_report_and_the_same_answer_where_it_is_exact(scale):
    # SciPy's SuperLU called L * 1e-320 "exactly singular" (a bare RuntimeError): the
    # tolerances 1e-9 |L_ii| underflowed; the matrix is now decided scaled by a power of 2
    import warnings

    V, T = tetlap.meshes.ball(200, seed=3)
    for kind in ("primal", "dual"):
        L = tetlap.laplacian(V, T, kind)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            r = tetlap.check(L * scale, V, T)
        assert r.nsd in (True, False)
        with np.errstate(all="ignore"):                      # no subnormal rounding
            exact = bool((L.data * scale / scale == L.data).all())
        if exact:
            assert r.nsd is tetlap.check(L, V, T).nsd, (kind, r.nsd_method)


@pytest.mark.parametrize("bad", ["no", 0, 1, None, [True]])
def test_nsd_is_a_flag(bad):
    # nsd="no" was truthy, and checked semidefiniteness
    V, T = tetlap.meshes.cube(2)
    L = tetlap.laplacian(V, T)
    with pytest.raises(tetlap.OptionError, match="nsd must be True or False"):
        tetlap.check(L, V, T, nsd=bad)
    assert tetlap.check(L, V, T, nsd=np.bool_(False)).nsd is None


# ---- linear precision does not depend on where the mesh lies ---------------------------


def _broken(L, i):
    """``L`` with one interior edge weight at vertex (or cell) ``i`` raised by a tenth of
    the largest entry, its diagonal entries lowered to match: still symmetric with zero
    row sums, but no longer linearly precise."""
    L = sp.lil_array(L)
    j = next(int(c) for c in L.rows[i] if c != i)
    delta = 0.1 * abs(L).max()
    L[i, j] += delta
    L[j, i] += delta
    L[i, i] -= delta
    L[j, j] -= delta
    return sp.csr_array(L)


@pytest.mark.parametrize("offset", [0.0, 1e3, 1e6, 1e9, 1e12])
def test_linear_precision_does_not_depend_on_where_the_mesh_lies(offset):
    """Issue 37.6: check said NO for a mesh offset by 1e6 (5e6 for kind="cell") although
    the operator is bitwise that of the mesh translated back, where it said yes: the
    residual was measured in the frame of the origin, where each row's rounding (its sum,
    about 1e-16 of its entries) is multiplied by the offset. It is measured in a frame
    centred on the mesh; a broken operator still says NO at every offset."""
    V, T = tetlap.meshes.ball(300, seed=2)
    far = V + offset
    back = far - offset                                   # exact: the mesh translated back
    inner = int(np.flatnonzero(tetlap.diagnostics.interior_vertices(V, T))[0])
    for kind in ("primal", "dual", 0.5):
        L = tetlap.laplacian(far, T, kind)
        assert (L != tetlap.laplacian(back, T, kind)).nnz == 0
        r = tetlap.check(L, far, T, kind=kind, nsd=False)
        assert r.linear_precision_ok is True, (kind, r.linear_precision_residual)
        assert r.linear_precision_residual < 1e-13
        bad = tetlap.check(_broken(L, inner), far, T, nsd=False)
        assert (bad.linear_precision_ok, bad.symmetric, bad.row_sums_ok) == (False, True, True)
        assert bad.linear_precision_residual > 1e-3
    Lc = tetlap.cell_laplacian(far, T)
    r = tetlap.check(Lc, far, T, kind="cell", nsd=False)
    assert r.linear_precision_ok is True and r.linear_precision_residual < 1e-13
    g = tetlap.dual_geometry(V, T)
    cell = int(np.setdiff1d(np.arange(len(T)), g.face_tets[g.boundary_faces, 0])[0])
    bad = tetlap.check(_broken(Lc, cell), far, T, kind="cell", nsd=False)
    assert (bad.linear_precision_ok, bad.row_sums_ok) == (False, True)
    # tetlap info reports the same
    result = tetlap.info.report(far, T, nsd=False, regular=False, progress=False)
    assert result["primal"]["linear_precision_ok"] and result["dual"]["linear_precision_ok"]


@pytest.mark.parametrize("offset", [0.0, 1e3, 1e6, 1e9, 1e12])
def test_the_cores_linear_precision_of_planar_triangles_is_centred_too(offset):
    """The core's check is one code for tets and triangles: planar triangles (as wide as
    their ambient space) get the same centred residual; triangles in R^3 (a surface,
    curved in general) none."""
    rng = np.random.default_rng(0)
    k = 6
    x, y = np.meshgrid(np.arange(k + 1.0), np.arange(k + 1.0), indexing="ij")
    P = np.column_stack([x.ravel(), y.ravel()]) / k
    inside = ((P > 0) & (P < 1)).all(axis=1)
    P[inside] += rng.uniform(-0.2, 0.2, (inside.sum(), 2)) / k
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    F = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    P = P + offset
    L = tetlap.laplacian(P, F)
    c = _core.check_operator(P, F, tetlap._sparse.arrays(L), ~inside, 1e-12)
    assert c["linear_precision"] < 1e-13, c["linear_precision"]
    lifted = np.column_stack([P, np.zeros(len(P))])
    c = _core.check_operator(lifted, F, tetlap._sparse.arrays(tetlap.laplacian(lifted, F)),
                             ~inside, 1e-12)
    assert c["linear_precision"] is None
