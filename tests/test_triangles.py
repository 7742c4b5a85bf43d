"""Triangle meshes: the cotan Laplacian, where primal (Eq. 6) and dual (Eq. 16) coincide."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial import ConvexHull, Delaunay

import tetlap


def planar(n=300, seed=0):
    rng = np.random.default_rng(seed)
    V = rng.uniform(size=(n, 2))
    return V, Delaunay(V).simplices


def sphere(n=400, seed=0):
    rng = np.random.default_rng(seed)
    V = rng.normal(size=(n, 3))
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    return V, ConvexHull(V).simplices


def grid(k=6, jitter=0.2, seed=0):
    g = np.linspace(0, 1, k + 1)
    V = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    inner = np.all((V > 0) & (V < 1), axis=1)
    V[inner] += np.random.default_rng(seed).uniform(-jitter, jitter, (inner.sum(), 2)) / k
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    return V, np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])


MESHES = {"planar Delaunay": planar, "sphere": sphere, "jittered grid": grid}


@pytest.fixture(params=list(MESHES))
def mesh(request):
    return MESHES[request.param]()


def test_primal_and_dual_coincide(mesh):
    V, T = mesh
    P, D = tetlap.laplacian(V, T, "primal"), tetlap.laplacian(V, T, "dual")
    assert abs(P - D).max() <= 1e-12 * abs(P).max()
    W = tetlap.element_contributions(V, T, "dual")
    assert W.shape == (len(T), 3)
    np.testing.assert_allclose(W, tetlap.element_contributions(V, T, "primal"), atol=1e-12)


def test_invariants_and_masses(mesh):
    V, T = mesh
    L = tetlap.laplacian(V, T)
    s = abs(L).max()
    assert abs(L - L.T).max() <= 1e-14 * s and np.abs(L.sum(axis=1)).max() <= 1e-13 * s
    area = 0.5 * np.abs(np.linalg.norm(np.cross(
        np.pad(V[T[:, 1]] - V[T[:, 0]], ((0, 0), (0, 3 - V.shape[1]))),
        np.pad(V[T[:, 2]] - V[T[:, 0]], ((0, 0), (0, 3 - V.shape[1])))), axis=1)).sum()
    for kind in ("barycentric", "circumcentric", "fem"):
        assert tetlap.mass(V, T, kind).sum() == pytest.approx(area, rel=1e-12)
    np.testing.assert_allclose(tetlap.mass(V, T, "fem").sum(axis=1),
                               tetlap.mass(V, T, "barycentric").diagonal(), rtol=1e-13)
    # pyramid identity in 2D: Vol(*i) = sum_j |x_i - x_j|^2 w_ij / 4
    coo = L.tocoo()
    off = coo.row != coo.col
    sq = ((V[coo.row[off]] - V[coo.col[off]]) ** 2).sum(axis=1)
    cells = np.bincount(coo.row[off], weights=sq * coo.data[off], minlength=len(V)) / 4
    np.testing.assert_allclose(cells, tetlap.mass(V, T, "circumcentric").diagonal(), rtol=1e-11,
                               atol=1e-15)


def test_planar_linear_precision_and_delaunay_weights():
    V, T = planar()
    L = tetlap.laplacian(V, T)
    tri_edges = np.sort(np.concatenate([T[:, [0, 1]], T[:, [0, 2]], T[:, [1, 2]]]), axis=1)
    keys, counts = np.unique(tri_edges, axis=0, return_counts=True)
    boundary = np.zeros(len(V), dtype=bool)
    boundary[keys[counts == 1].ravel()] = True
    assert np.abs((L @ V)[~boundary]).max() <= 1e-12 * abs(L).max()
    interior_edges = keys[counts == 2]
    w = L[interior_edges[:, 0], interior_edges[:, 1]]
    assert w.min() >= -1e-12  # interior Delaunay edges: cot a + cot b >= 0 (Sec. 7.3)


def test_embedding_and_orientation_do_not_matter(rng):
    V, T = grid()
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    V4 = np.column_stack([V, np.zeros((len(V), 2))]) @ Q.T
    T2 = T.copy()
    T2[::2] = T2[::2, ::-1]
    A = tetlap.laplacian(V, T)
    for B in (tetlap.laplacian(V4, T), tetlap.laplacian(V, T2)):
        assert abs(A - B).max() <= 1e-12 * abs(A).max()


def test_exact_rationals_on_integer_triangles():
    """cot of the angle at c = (a - c).(b - c) / |det[a - c, b - c]|, in Fractions."""
    V = np.array([[0, 0], [4, 0], [1, 3], [5, 4], [0, 1]])  # obtuse at vertex 4
    T = np.array([[0, 1, 2], [1, 3, 2], [0, 2, 4]])
    F = [[Fraction(int(x)) for x in p] for p in V]

    def half_cot(c, a, b):
        u = [F[a][0] - F[c][0], F[a][1] - F[c][1]]
        v = [F[b][0] - F[c][0], F[b][1] - F[c][1]]
        return (u[0] * v[0] + u[1] * v[1]) / (2 * abs(u[0] * v[1] - u[1] * v[0]))

    exact = [[Fraction(0)] * 5 for _ in range(5)]
    for i, j, k in T:
        for a, b, c in ((i, j, k), (j, k, i), (k, i, j)):
            exact[a][b] += half_cot(c, a, b)
            exact[b][a] += half_cot(c, a, b)
    for i in range(5):
        exact[i][i] = -sum(exact[i][j] for j in range(5) if j != i)
    assert any(exact[a][b] < 0 for a in range(5) for b in range(5) if a != b)  # obtuse
    for kind in ("primal", "dual"):
        L = tetlap.laplacian(V, T, kind).toarray()
        np.testing.assert_allclose(L, np.array(exact, dtype=float), rtol=1e-14, atol=1e-15)


def test_triangle_bad_input():
    with pytest.raises(tetlap.ShapeError, match="at least 2"):
        tetlap.laplacian(np.zeros((3, 1)), [[0, 1, 2]])
    with pytest.raises(tetlap.DegenerateElementError, match="element 1"):
        tetlap.laplacian([[0, 0], [1, 0], [0, 1], [2, 0]], [[0, 1, 2], [0, 1, 3]])
    L = tetlap.laplacian([[0, 0], [1, 0], [0, 1], [2, 0]], [[0, 1, 2], [0, 1, 3]], degenerate="skip")
    assert np.isfinite(L.data).all()
    with pytest.raises(tetlap.OptionError, match="tet meshes only"):
        tetlap.laplacian([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], weights=[0, 0, 0])


def test_cached_mesh_of_triangles_equals_one_shot():
    V, T = grid()
    mesh = tetlap.Mesh(V, T)
    V2 = V.copy()
    V2[len(V) // 2] += 0.01
    mesh.laplacian("primal"), mesh.mass("circumcentric")
    info = mesh.update(V2)
    assert info.moved_vertices == 1 and 0 < info.recomputed_tets < len(T)
    assert (mesh.laplacian("primal") != tetlap.laplacian(V2, T, "primal")).nnz == 0
    assert (mesh.mass("circumcentric") != tetlap.mass(V2, T, "circumcentric")).nnz == 0
    np.testing.assert_array_equal(mesh.T, T)


def test_triplets_and_edges_for_triangles():
    V, T = grid()
    L = tetlap.laplacian(V, T)
    r, c, v, shape = tetlap.triplets(V, T)
    assert len(v) == 9 * len(T)
    assert abs(sp.coo_array((v, (r, c)), shape=shape).tocsr() - L).max() <= 1e-14
    edges, w = tetlap.edge_weights(V, T)
    np.testing.assert_array_equal(w, L[edges[:, 0], edges[:, 1]])


def test_against_libigl_cotmatrix():
    igl = pytest.importorskip("igl")
    V, T = sphere()
    A = tetlap.laplacian(V, T)
    B = igl.cotmatrix(V, T.astype(np.int64))
    assert abs(A - B).max() <= 1e-12 * abs(A).max()  # libigl: same sign and scale
