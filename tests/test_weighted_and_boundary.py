"""Weighted (power-diagram) duals and the barycentric boundary treatment (Sec. 6, 9)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.diagnostics import (boundary_faces, faces, interior_vertices, mesh_edges,
                                signed_volumes)


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
        tetlap.laplacian(V, T, "dual", boundary="voronoi")


def test_primal_ignores_weights_and_boundary(ball):
    V, T = ball
    P = tetlap.laplacian(V, T, "primal")
    Q = tetlap.laplacian(V, T, "primal", weights=np.ones(len(V)), boundary="barycentric")
    assert (P != Q).nnz == 0


def boundary_tet_mask(T):
    F = np.sort(faces(T), axis=1)
    _, inverse, counts = np.unique(F, axis=0, return_inverse=True, return_counts=True)
    return (counts[inverse.ravel()] == 1).reshape(-1, 4).any(axis=1)


def test_barycentric_boundary_guarantees_and_cost():
    V, T = tetlap.meshes.ball(1500, seed=8)
    fixed = boundary_tet_mask(T)
    W = tetlap.element_contributions(V, T, "dual", boundary="barycentric")
    W0 = tetlap.element_contributions(V, T, "dual")
    assert (W0[fixed] < 0).any()  # the plain construction has negative boundary weights
    assert (W[fixed] >= 0).all()  # guarantee: non-negative contributions in fixed tets
    np.testing.assert_array_equal(W[~fixed], W0[~fixed])  # other tets untouched
    L, M = tetlap.operators(V, T, "dual", "circumcentric", boundary="barycentric")
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
    kw = dict(weights=w, boundary="barycentric")
    mesh = tetlap.Mesh(V, T, **kw)
    assert (mesh.laplacian("dual") != tetlap.laplacian(V, T, "dual", **kw)).nnz == 0
    V2 = V.copy()
    V2[:20] *= 1.01
    mesh.update(V2)
    assert (mesh.laplacian("dual") != tetlap.laplacian(V2, T, "dual", **kw)).nnz == 0
    assert (mesh.mass("circumcentric") != tetlap.mass(V2, T, "circumcentric", **kw)).nnz == 0
