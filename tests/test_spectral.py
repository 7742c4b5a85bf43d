"""tetlap.spectral: derivatives of eigenvalues against central differences of
tetlap.solve.eigs on random meshes, the scaling identity, clusters, and the VJP form."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import diagnostics as d
from tetlap import solve, spectral


def _eigs(V, T, kind, mass, k, fixed):
    L, M = tetlap.operators(V, T, kind, mass)
    return solve.eigs(L, M, k, fixed)


def _difference(V, T, D, kind, mass, k, fixed, h=1e-6):
    up = _eigs(V + h * D, T, kind, mass, k, fixed)[0]
    down = _eigs(V - h * D, T, kind, mass, k, fixed)[0]
    return (up - down) / (2 * h)


CASES = [("primal", "barycentric", "fixed"), ("primal", "fem", "fixed"),
         ("primal", "fem", "free"), ("dual", "circumcentric", "fixed"),
         ("dual", "barycentric", "free")]


@pytest.mark.parametrize("kind, mass, boundary", CASES)
@pytest.mark.parametrize("seed", [1, 2])
def test_gradients_match_central_differences(kind, mass, boundary, seed):
    V, T = tetlap.meshes.ball(500, seed=seed)
    fixed = d.boundary_vertices(T, len(V)) if boundary == "fixed" else None
    k = 6
    lam, vec = _eigs(V, T, kind, mass, k, fixed)
    groups = spectral.clusters(lam)
    assert len(np.unique(groups)) == k            # random meshes: simple eigenvalues
    G = spectral.eigenvalue_gradients(V, T, lam, vec, kind, mass)
    D = np.random.default_rng(seed).standard_normal(V.shape)
    fd = _difference(V, T, D, kind, mass, k, fixed)
    exact = np.einsum("knd,nd->k", G, D)
    start = 1 if fixed is None else 0             # lambda = 0 of the constant mode
    np.testing.assert_allclose(exact[start:], fd[start:], rtol=1e-6,
                               atol=1e-6 * np.abs(fd).max())
    if fixed is None:
        assert lam[0] == 0.0 and np.abs(G[0]).max() < 1e-12 * np.abs(G).max()


def test_the_scaling_identity():
    """lambda(V (1 + t)) = lambda(V) / (1 + t)^2: sum_n G[n] . V[n] = -2 lambda."""
    V, T = tetlap.meshes.ball(800, seed=3)
    for kind, mass in (("primal", "fem"), ("dual", "circumcentric")):
        lam, vec = _eigs(V, T, kind, mass, 8, d.boundary_vertices(T, len(V)))
        G = spectral.eigenvalue_gradients(V, T, lam, vec, kind, mass)
        np.testing.assert_allclose(np.einsum("knd,nd->k", G, V), -2 * lam, rtol=1e-10)
        # and rigid motions change nothing
        np.testing.assert_allclose(G.sum(axis=1), 0, atol=1e-10 * np.abs(G).max())


def _sym_cube():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_solve_eigs_engine import _sym_cube as build

    return build(4)


def test_a_cluster_gets_the_derivative_of_its_mean():
    """An exact triple on a mesh with the cube's symmetries: the members have no
    derivatives of their own, their mean has (central differences of the mean)."""
    V, T = _sym_cube()
    fixed = d.boundary_vertices(T, len(V))
    lam, vec = _eigs(V, T, "primal", "fem", 4, fixed)
    groups = spectral.clusters(lam)
    assert list(groups) == [0, 1, 1, 1]
    G = spectral.eigenvalue_gradients(V, T, lam, vec, "primal", "fem")
    assert np.array_equal(G[1], G[2]) and np.array_equal(G[2], G[3])
    D = np.random.default_rng(4).standard_normal(V.shape) * (~fixed)[:, None]
    fd = _difference(V, T, D, "primal", "fem", 4, fixed)
    np.testing.assert_allclose(np.sum(G[1] * D), fd[1:4].mean(), rtol=1e-6)
    np.testing.assert_allclose(np.sum(G[0] * D), fd[0], rtol=1e-6)
    # the same from any orthonormal basis of the triple: rotate it
    Q = np.linalg.qr(np.random.default_rng(5).standard_normal((3, 3)))[0]
    turned = vec.copy()
    turned[:, 1:4] = vec[:, 1:4] @ Q
    G2 = spectral.eigenvalue_gradients(V, T, lam, turned, "primal", "fem")
    np.testing.assert_allclose(G2[1], G[1], atol=1e-12 * np.abs(G).max())


def test_the_vjp_is_the_weighted_sum_of_the_gradients():
    V, T = tetlap.meshes.ball(700, seed=6)
    lam, vec = _eigs(V, T, "primal", "fem", 7, d.boundary_vertices(T, len(V)))
    G = spectral.eigenvalue_gradients(V, T, lam, vec, "primal", "fem")
    g = np.random.default_rng(7).standard_normal(7)
    np.testing.assert_allclose(spectral.eigenvalue_vjp(V, T, lam, vec, g, "primal", "fem"),
                               np.einsum("k,knd->nd", g, G), atol=1e-12 * np.abs(G).max())


def test_bad_input_is_named():
    V, T = tetlap.meshes.ball(300, seed=1)
    lam, vec = _eigs(V, T, "primal", "barycentric", 3, d.boundary_vertices(T, len(V)))
    with pytest.raises(tetlap.ShapeError):
        spectral.eigenvalue_gradients(V, T, lam, vec[:, :2])
    with pytest.raises(tetlap.ShapeError, match="ascending"):
        spectral.eigenvalue_gradients(V, T, lam[::-1], vec)
    with pytest.raises(tetlap.ShapeError):
        spectral.eigenvalue_vjp(V, T, lam, vec, np.ones(2))
    with pytest.raises(tetlap.NonFiniteError):
        spectral.eigenvalue_vjp(V, T, lam, vec, [1.0, np.nan, 0.0])
    with pytest.raises(tetlap.OptionError):
        spectral.eigenvalue_gradients(V, T, lam, vec, mass="mixed")


# ---- with respect to the coefficient -----------------------------------------------------


def _eigs_with(V, T, kind, coefficient, fixed, k):
    L, M = tetlap.operators(V, T, kind, "barycentric", coefficient=coefficient)
    return tetlap.solve.eigs(L, M, k, fixed)


@pytest.mark.parametrize("kind", ["primal", "dual", 0.5])
def test_coefficient_gradients_match_central_differences(kind):
    """d lambda / dc against central differences of eigs along a random direction, for
    per-tet scalars in both constructions; a cluster's members get its mean's."""
    V, T = tetlap.meshes.ball(500, seed=11)
    rng = np.random.default_rng(11)
    c = rng.uniform(0.5, 2.0, len(T))
    fixed = d.boundary_vertices(T, len(V))
    lam, vec = _eigs_with(V, T, kind, c, fixed, 6)
    G = tetlap.spectral.coefficient_gradients(V, T, lam, vec, kind)
    assert G.shape == (6, len(T))
    delta = rng.uniform(-1, 1, len(T)) * c
    h = 1e-5
    up = _eigs_with(V, T, kind, c + h * delta, fixed, 6)[0]
    down = _eigs_with(V, T, kind, c - h * delta, fixed, 6)[0]
    groups = tetlap.spectral.clusters(lam)
    fd = (up - down) / (2 * h)
    fd_mean = (np.bincount(groups, fd) / np.bincount(groups))[groups]
    np.testing.assert_allclose(G @ delta, fd_mean, rtol=1e-6, atol=1e-8 * lam.max())
    # Euler: the eigenvalues are homogeneous of degree 1 in the coefficient
    np.testing.assert_allclose(G @ c, lam, rtol=1e-9)


def test_coefficient_gradients_of_tensors_match_central_differences():
    V, T = tetlap.meshes.ball(400, seed=12)
    rng = np.random.default_rng(12)
    A = rng.normal(size=(len(T), 3, 3))
    K = np.einsum("mij,mkj->mik", A, A) + np.eye(3)
    fixed = d.boundary_vertices(T, len(V))
    lam, vec = _eigs_with(V, T, "primal", K, fixed, 5)
    G = tetlap.spectral.coefficient_gradients(V, T, lam, vec, tensor=True)
    assert G.shape == (5, len(T), 3, 3)
    assert np.allclose(G, G.swapaxes(-1, -2))
    assert (np.linalg.eigvalsh(G) > -1e-12 * np.abs(G).max()).all()   # PSD per tet
    D = rng.normal(size=(len(T), 3, 3))
    D = (D + D.swapaxes(-1, -2)) / 2
    h = 1e-4
    up = _eigs_with(V, T, "primal", K + h * D, fixed, 5)[0]
    down = _eigs_with(V, T, "primal", K - h * D, fixed, 5)[0]
    groups = tetlap.spectral.clusters(lam)
    fd = (up - down) / (2 * h)
    fd_mean = (np.bincount(groups, fd) / np.bincount(groups))[groups]
    np.testing.assert_allclose(np.einsum("kmij,mij->k", G, D), fd_mean, rtol=1e-6)
    np.testing.assert_allclose(np.einsum("kmij,mij->k", G, K), lam, rtol=1e-9)


def test_coefficient_gradients_refuse_what_they_cannot_differentiate():
    V, T = tetlap.meshes.ball(300, seed=13)
    L, M = tetlap.operators(V, T, "dual", "barycentric")
    lam, vec = tetlap.solve.eigs(L, M, 3, d.boundary_vertices(T, len(V)))
    with pytest.raises(tetlap.OptionError, match="primal only"):
        tetlap.spectral.coefficient_gradients(V, T, lam, vec, "dual", tensor=True)
    with pytest.raises(tetlap.OptionError, match="tensor must be True or False"):
        tetlap.spectral.coefficient_gradients(V, T, lam, vec, "dual", tensor=1)
    with pytest.raises(tetlap.ShapeError):
        tetlap.spectral.coefficient_gradients(V, T, lam, vec[:, :2], "dual")


@pytest.mark.parametrize("kind, mass, form", [("primal", "fem", "scalars"),
                                              ("dual", "barycentric", "scalars"),
                                              ("primal", "barycentric", "tensors")])
def test_vertex_gradients_with_a_coefficient_match_central_differences(kind, mass, form):
    """d lambda / dV of the operators built with a per-tet coefficient (held fixed per tet
    while the vertices move), against central differences of eigs."""
    V, T = tetlap.meshes.ball(400, seed=14)
    rng = np.random.default_rng(14)
    c = rng.uniform(0.5, 2.0, len(T))
    if form == "tensors":
        A = rng.normal(size=(len(T), 3, 3))
        c = np.einsum("mij,mkj->mik", A, A) + np.eye(3)
    fixed = d.boundary_vertices(T, len(V))

    def spectrum(X):
        L, M = tetlap.operators(X, T, kind, mass, coefficient=c)
        return tetlap.solve.eigs(L, M, 5, fixed)

    lam, vec = spectrum(V)
    G = tetlap.spectral.eigenvalue_gradients(V, T, lam, vec, kind, mass, coefficient=c)
    D = rng.normal(size=V.shape)
    h = 1e-6
    fd = (spectrum(V + h * D)[0] - spectrum(V - h * D)[0]) / (2 * h)
    groups = tetlap.spectral.clusters(lam)
    fd = (np.bincount(groups, fd) / np.bincount(groups))[groups]
    np.testing.assert_allclose(np.einsum("knd,nd->k", G, D), fd, rtol=1e-5)
    g = tetlap.spectral.eigenvalue_vjp(V, T, lam, vec, np.ones(5), kind, mass, coefficient=c)
    np.testing.assert_allclose(g, G.sum(axis=0), rtol=1e-10, atol=1e-10 * np.abs(g).max())
    # ones: the plain gradients
    L1, M1 = tetlap.operators(V, T, kind, mass)
    lam1, vec1 = tetlap.solve.eigs(L1, M1, 5, fixed)
    ones = tetlap.spectral.eigenvalue_gradients(
        V, T, lam1, vec1, kind, mass,
        coefficient=np.ones(len(T)) if form == "scalars" else np.eye(3))
    plain = tetlap.spectral.eigenvalue_gradients(V, T, lam1, vec1, kind, mass)
    np.testing.assert_allclose(ones, plain, rtol=0, atol=1e-10 * np.abs(plain).max())
