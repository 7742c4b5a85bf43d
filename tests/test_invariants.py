"""Invariants of both Laplacians and the masses on generated meshes (paper Sec. 7), and the
order of V and T: any numbering of the vertices and any order of the elements gives the
same operators, permuted (the internal locality order decides where things are in
memory, never what is computed)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

import tetlap
from conftest import jittered_cube, non_delaunay, random_ball
from tetlap import benchmark
from tetlap.diagnostics import boundary_faces, interior_vertices, signed_volumes

KINDS = ["primal", "dual", 0.3]


def weighted_ball():
    """A regular triangulation with large weights: a non-Delaunay ball whose dual
    Laplacian is indefinite (dense eigenvalues: lambda_min(-L) = -0.12 lambda_max)."""
    return tetlap.meshes.weighted_ball(600, 0.5, seed=1)


MESHES = {"cube": jittered_cube, "ball": random_ball, "non_delaunay": non_delaunay,
          "weighted_ball": weighted_ball}
#: The meshes of MESHES whose dual Laplacian is indefinite.
INDEFINITE_DUAL = {"weighted_ball"}


@pytest.fixture(params=list(MESHES))
def mesh_name(request):
    return request.param


@pytest.fixture
def mesh(mesh_name):
    return MESHES[mesh_name]()


def scale_of(L):
    return float(abs(L).max())


@pytest.mark.parametrize("kind", KINDS)
def test_symmetric_zero_row_sums_and_linear_precision(mesh, kind):
    V, T = mesh
    L = tetlap.laplacian(V, T, kind)
    s = scale_of(L)
    assert abs(L - L.T).max() <= 1e-14 * s
    assert np.abs(L.sum(axis=1)).max() <= 1e-13 * s
    interior = interior_vertices(T, len(V))
    assert interior.sum() > 10
    residual = np.abs((L @ V)[interior]).max()
    assert residual <= 1e-12 * s, residual
    # and the boundary rows are *not* reproduced: the check above can fail
    assert np.abs((L @ V)[~interior]).max() > 1e-3 * s


def test_primal_is_negative_semidefinite_and_dual_is_not_always(mesh, mesh_name):
    V, T = mesh
    lam = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "primal").toarray())
    assert lam[0] >= -1e-12 * lam[-1]
    assert abs(lam[0]) <= 1e-12 * lam[-1]  # constants are in the null space
    # the dual on the same mesh: constants in its null space too (zero row sums), and
    # on the non-Delaunay weighted ball a clearly negative eigenvalue of -L
    lam_d = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "dual").toarray())
    assert np.abs(lam_d).min() <= 1e-12 * np.abs(lam_d).max()
    if mesh_name in INDEFINITE_DUAL:
        assert lam_d[0] < -1e-2 * lam_d[-1]
        assert tetlap.diagnostics.non_delaunay_faces(V, T).any()


def test_dual_indefinite_with_boundary_primal_never():
    """A flat bipyramid split into 3 tets around its short axis (its Delaunay split):
    all edges but the axis are on the boundary, where dual weights may be negative, and
    the dual is indefinite (Table 1: NSD only without boundary); the primal stays NSD.
    The non-Delaunay 2-tet split happens to keep the dual semidefinite."""
    h = 0.1
    V = np.array([[1, 0, 0], [-0.5, 0.866, 0], [-0.5, -0.866, 0], [0, 0, h], [0, 0, -h]])
    T = np.array([[3, 4, 0, 1], [3, 4, 1, 2], [3, 4, 2, 0]])
    lam = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "dual").toarray())
    assert lam[0] < -1e-2 * lam[-1]
    lam_p = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "primal").toarray())
    assert lam_p[0] >= -1e-12 * lam_p[-1]
    lam_d = np.linalg.eigvalsh(-tetlap.laplacian(V, [[0, 1, 2, 3], [0, 1, 2, 4]], "dual").toarray())
    assert lam_d[0] >= -1e-12 * lam_d[-1]


def test_masses_sum_to_the_volume_and_pyramid_identity(mesh):
    V, T = mesh
    volume = np.abs(signed_volumes(V, T)).sum()
    for kind in ("barycentric", "circumcentric", "fem"):
        assert tetlap.mass(V, T, kind).sum() == pytest.approx(volume, rel=1e-12)
    L = tetlap.laplacian(V, T, "dual").tocoo()
    m = tetlap.mass(V, T, "circumcentric").diagonal()
    off = L.row != L.col
    sq = ((V[L.row[off]] - V[L.col[off]]) ** 2).sum(axis=1)
    pyramid = np.bincount(L.row[off], weights=sq * L.data[off], minlength=len(V)) / 6
    np.testing.assert_allclose(pyramid, m, rtol=1e-12, atol=1e-15 * np.abs(m).max())


def test_fem_mass_rows_sum_to_the_barycentric_mass(mesh):
    V, T = mesh
    fem = tetlap.mass(V, T, "fem")
    assert fem.nnz > len(V)  # consistent, not diagonal
    np.testing.assert_allclose(fem.sum(axis=1), tetlap.mass(V, T, "barycentric").diagonal(),
                               rtol=1e-13)


def test_affine_family_is_the_affine_combination(mesh):
    V, T = mesh
    P, D = tetlap.laplacian(V, T, "primal"), tetlap.laplacian(V, T, "dual")
    for t in (0.0, 0.25, 1.0):
        A = tetlap.laplacian(V, T, t)
        assert abs(A - ((1 - t) * P + t * D)).max() <= 1e-13 * scale_of(P)


def test_vertex_order_and_orientation_do_not_matter(mesh, rng):
    V, T = mesh
    perm = np.array([rng.permutation(4) for _ in range(len(T))])
    T2 = np.take_along_axis(T, perm, axis=1)
    assert (signed_volumes(V, T2) < 0).any() and (signed_volumes(V, T2) > 0).any()
    for kind in KINDS:
        A, B = tetlap.laplacian(V, T, kind), tetlap.laplacian(V, T2, kind)
        assert abs(A - B).max() <= 1e-14 * scale_of(A)
    for kind in ("barycentric", "circumcentric"):
        a, b = tetlap.mass(V, T, kind).diagonal(), tetlap.mass(V, T2, kind).diagonal()
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-16)
    # per-tet weights follow the permutation of the corners
    W, W2 = tetlap.element_contributions(V, T, "dual"), tetlap.element_contributions(V, T2, "dual")
    edges = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    for t in range(0, len(T), 17):
        by_edge = {frozenset((T[t, a], T[t, b])): W[t, e] for e, (a, b) in enumerate(edges)}
        for e, (a, b) in enumerate(edges):
            assert W2[t, e] == pytest.approx(by_edge[frozenset((T2[t, a], T2[t, b]))],
                                             rel=1e-12, abs=1e-14)


def test_immersed_in_r4_gives_the_same_operators(mesh, rng):
    V, T = mesh
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    V4 = np.column_stack([V, np.zeros(len(V))]) @ Q.T + rng.normal(size=4)
    for kind in KINDS:
        A, B = tetlap.laplacian(V, T, kind), tetlap.laplacian(V4, T, kind)
        assert abs(A - B).max() <= 1e-11 * scale_of(A)
    for kind in ("barycentric", "circumcentric"):
        np.testing.assert_allclose(tetlap.mass(V4, T, kind).diagonal(),
                                   tetlap.mass(V, T, kind).diagonal(), rtol=1e-10, atol=1e-15)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(20, 150))
def test_dual_weights_of_interior_delaunay_edges_are_non_negative(seed, n):
    """Sec. 7.3: an interior Delaunay edge's dual face is a Voronoi face, area >= 0."""
    rng = np.random.default_rng(seed)
    V = rng.uniform(-1, 1, size=(n, 3))
    T = Delaunay(V).simplices
    vol = np.abs(signed_volumes(V, T))
    T = T[vol > 1e-10]  # qhull may emit flat hull slivers
    edges, w = tetlap.edge_weights(V, T, "dual")
    bf = np.sort(boundary_faces(T), axis=1)
    on_boundary = {(a, b) for f in bf for a, b in ((f[0], f[1]), (f[0], f[2]), (f[1], f[2]))}
    interior = np.array([(i, j) not in on_boundary for i, j in edges])
    assert interior.any()
    assert w[interior].min() >= -1e-12 * np.abs(w).max()


def test_dual_indefinite_on_non_delaunay_ball_but_not_on_the_delaunay_one():
    for weight_scale, nsd in ((0.0, True), (0.5, False)):
        V, T = tetlap.meshes.weighted_ball(600, weight_scale, seed=1)
        lam = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "dual").toarray())
        assert (lam[0] >= -1e-12 * lam[-1]) == nsd
        lam_p = np.linalg.eigvalsh(-tetlap.laplacian(V, T, "primal").toarray())
        assert lam_p[0] >= -1e-12 * lam_p[-1]


# ---- the order of V and T ------------------------------------------------------------


def renumbered(V, T, seed):
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))  # new vertex k is old vertex perm[k]
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(V))
    order = rng.permutation(len(T))
    return V[perm], inverse[T][order], perm, order


ORDER_MESHES = {
    "kuhn": lambda: tetlap.meshes.cube(7, jitter=0.2, seed=1),
    "qhull order": lambda: benchmark.delaunay(6000, seed=2),
    "real-mesh like (ball)": lambda: tetlap.meshes.ball(1500, seed=3),
}


@pytest.mark.parametrize("mesh", list(ORDER_MESHES))
@pytest.mark.parametrize("seed", [0, 1])
def test_shuffled_input_gives_the_permuted_operators(mesh, seed):
    V, T = ORDER_MESHES[mesh]()
    V2, T2, perm, order = renumbered(V, T, seed)
    for kind, mass in (("primal", "barycentric"), ("dual", "circumcentric"), (0.4, "fem")):
        L, M = tetlap.operators(V, T, kind, mass)
        L2, M2 = tetlap.operators(V2, T2, kind, mass)
        # new vertex k is old vertex perm[k]; indexing keeps explicit zeros (a product of
        # permutation matrices would drop them)
        expected_L, expected_M = L[perm][:, perm], M[perm][:, perm]
        # the same pattern, exactly
        for A, B in ((L2, expected_L), (M2, expected_M)):
            B = sp.csr_array(B)
            B.sort_indices()
            np.testing.assert_array_equal(A.indptr, B.indptr)
            np.testing.assert_array_equal(A.indices, B.indices)
            # the same values up to the order of the sums (a few units in the last place)
            scale = np.abs(B.data).max()
            assert np.abs(A.data - B.data).max() <= 4e-16 * scale * 16
    # per-element values follow the elements exactly (each is computed from its own corners)
    W, W2 = tetlap.element_contributions(V, T, "dual"), tetlap.element_contributions(V2, T2, "dual")
    np.testing.assert_array_equal(W2, W[order])


def test_renumbering_only_the_vertices_changes_no_off_diagonal_bit():
    """With the elements in the same order, every edge's sum runs in the same order (the
    diagonal sums a row in column order, so it may differ in the last place)."""
    V, T = tetlap.meshes.ball(1500, seed=4)
    rng = np.random.default_rng(0)
    perm = rng.permutation(len(V))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(V))
    L = tetlap.laplacian(V, T, "dual")
    L2 = tetlap.laplacian(V[perm], inverse[T], "dual")
    # row inverse[i] of L2 is row i of L, with its columns renumbered and re-sorted
    for i in range(0, len(V), 37):
        a = L[[i], :].tocoo()
        b = L2[[inverse[i]], :].tocoo()
        by_old = dict(zip(inverse[a.col], a.data))
        by_new = dict(zip(b.col, b.data))
        diagonal = inverse[i]
        assert by_new.pop(diagonal) == pytest.approx(by_old.pop(diagonal), rel=1e-14)
        assert by_new == by_old
