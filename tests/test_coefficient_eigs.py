"""The eigenmode user's path with a heterogeneous medium: a per-vertex map averaged onto
the tets, the operators with that coefficient, then ``solve.eigs``; a constant coefficient
``c`` scales every eigenvalue by ``c`` and leaves the modes."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import diagnostics as d


@pytest.fixture(scope="module")
def ball():
    V, T = tetlap.meshes.ball(700, seed=3)
    return V, T, d.boundary_vertices(T, len(V))


@pytest.mark.parametrize("kind", ["primal", "dual"])
@pytest.mark.parametrize("boundary", ["free", "fixed"])
@pytest.mark.parametrize("c", [3.0, 4.0])
def test_a_constant_coefficient_scales_every_eigenvalue(ball, kind, boundary, c):
    V, T, on_boundary = ball
    fixed = on_boundary if boundary == "fixed" else None
    L, M = tetlap.operators(V, T, kind, "barycentric")
    lam, vec = tetlap.solve.eigs(L, M, 12, fixed)
    # the constant reached through the per-vertex path users take, and as a tensor c I
    per_tet = tetlap.coefficient.from_vertices(np.full(len(V), c), T)
    for coefficient in (per_tet, c * np.eye(3)):
        Lc, _ = tetlap.operators(V, T, kind, "barycentric", coefficient=coefficient)
        lam_c, vec_c = tetlap.solve.eigs(Lc, M, 12, fixed)
        np.testing.assert_allclose(lam_c, c * lam, rtol=1e-11, atol=1e-11 * c * lam.max())
        # each simple eigenvalue's mode is the same (signs are fixed by the convention)
        gaps = np.minimum(np.diff(lam, prepend=-np.inf), np.diff(lam, append=np.inf))
        simple = gaps > 1e-6 * lam.max()
        np.testing.assert_allclose(vec_c[:, simple], vec[:, simple], atol=1e-8)
    if c == 4.0:   # a power of two: the operator is scaled exactly, and so are the values
        Lc, _ = tetlap.operators(V, T, kind, "barycentric", coefficient=np.full(len(T), c))
        assert np.array_equal(tetlap.solve.eigs(Lc, M, 12, fixed)[0], c * lam)


def test_a_varying_coefficient_moves_the_spectrum_between_its_bounds(ball):
    """A per-vertex map in [1, 2] gives eigenvalues between those of c = 1 and c = 2
    (the Rayleigh quotient is monotone in the coefficient), and the constant mode of the
    free problem stays at 0."""
    V, T, _ = ball
    hetero = 1.5 + 0.5 * V[:, 2] / np.abs(V[:, 2]).max()
    c = tetlap.coefficient.from_vertices(hetero, T)
    assert 1 <= c.min() and c.max() <= 2
    L, M = tetlap.operators(V, T, "primal", "fem", coefficient=c)
    lam, vec = tetlap.solve.eigs(L, M, 10)
    L1, _ = tetlap.operators(V, T, "primal", "fem")
    lam1 = tetlap.solve.eigs(L1, M, 10)[0]
    assert lam[0] == 0.0
    assert np.all(lam[1:] > lam1[1:]) and np.all(lam[1:] < 2 * lam1[1:])
    np.testing.assert_allclose(vec.T @ M @ vec, np.eye(10), atol=1e-10)
