"""tetlap.solve.eigs: the k smallest pairs, negative ones of indefinite duals included,
against dense generalized eigenvalues, and the inertia proof that they are the smallest."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

import tetlap
from tetlap import diagnostics as d
from tetlap import solve
from tetlap.solve import _eigs


def _dense(L, M, fixed):
    free = ~fixed
    return eigh((-L[free][:, free]).toarray(), M[free][:, free].toarray(), eigvals_only=True)


@pytest.fixture(scope="module")
def indefinite():
    """A weighted ball whose dual Dirichlet block has 3 negative eigenvalues (443 free
    vertices: above the dense limit, so the sparse path runs)."""
    V, T = tetlap.meshes.weighted_ball(800, 1.0, seed=1)
    L, M = tetlap.operators(V, T, "dual", "mixed")
    return L, M, d.boundary_vertices(T, len(V))


@pytest.mark.parametrize("solver", ["auto", "cholesky", "lu"])
def test_eigs_returns_the_negative_eigenvalues_of_an_indefinite_dual(indefinite, solver):
    L, M, fixed = indefinite
    reference = _dense(L, M, fixed)
    assert (reference < 0).sum() == 3 and (~fixed).sum() > _eigs.DENSE_MAX
    lam, vec, info = solve.eigs(L, M, 6, fixed, solver=solver, return_info=True)
    np.testing.assert_allclose(lam, reference[:6], rtol=1e-9, atol=1e-9 * abs(reference[0]))
    assert "Sylvester" in info.verification and "6 negative pivots" in info.verification
    assert info.fallbacks and "below the shift" in info.fallbacks[0]
    assert (vec[fixed] == 0).all()
    free = ~fixed
    np.testing.assert_allclose(vec[free].T @ M[free][:, free] @ vec[free], np.eye(6), atol=1e-9)


def test_eigs_on_a_small_mesh_uses_all_dense_eigenvalues():
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=2)
    L, M = tetlap.operators(V, T, "dual", "mixed")
    fixed = d.boundary_vertices(T, len(V))
    lam, _, info = solve.eigs(L, M, 4, fixed, return_info=True)
    np.testing.assert_allclose(lam, _dense(L, M, fixed)[:4], rtol=1e-9)
    assert info.verification.startswith("all eigenvalues")


@pytest.mark.parametrize("fixed_boundary", [True, False])
def test_eigs_without_and_with_fixed_agree_with_dense(fixed_boundary):
    V, T = tetlap.meshes.ball(900, seed=5)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = d.boundary_vertices(T, len(V)) if fixed_boundary else np.zeros(len(V), dtype=bool)
    lam, _, info = solve.eigs(L, M, 5, fixed if fixed_boundary else None, return_info=True)
    reference = _dense(L, M, fixed)
    np.testing.assert_allclose(lam, reference[:5], rtol=1e-9, atol=1e-9)
    assert info.solver == "cholesky" and info.iterations > 0


def test_a_missed_eigenvalue_is_caught_by_the_inertia_proof(monkeypatch):
    V, T = tetlap.meshes.ball(900, seed=5)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = d.boundary_vertices(T, len(V))
    from tetlap.solve import _lanczos

    real = _lanczos.search

    def missing_the_first(*args, want, **kwargs):  # a search that skips the smallest pair
        theta, Y, res, stats = real(*args, want=want + 1, **kwargs)
        drop = np.argmax(theta)
        keep = np.arange(len(theta)) != drop
        return theta[keep], Y[:, keep], res[keep], stats

    monkeypatch.setattr(_lanczos, "search", missing_the_first)
    with pytest.raises(tetlap.SolveError, match="could not be certified.*missed"):
        solve.eigs(L, M, 4, fixed)


def test_eigs_refusal_of_a_non_positive_mass_names_the_mixed_mass():
    V, T = tetlap.meshes.weighted_ball(800, 1.0, seed=1)
    L, M = tetlap.operators(V, T, "dual", "circumcentric")
    fixed = d.boundary_vertices(T, len(V))
    if (M.diagonal()[~fixed] > 0).all():
        pytest.skip("this mesh has no non-positive free mass")
    with pytest.raises(tetlap.SolveError, match='"mixed"') as e:
        solve.eigs(L, M, 3, fixed)
    assert "barycentric" not in str(e.value).split("mixed")[0]


def test_eigs_is_deterministic():
    V, T = tetlap.meshes.ball(900, seed=5)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    a = solve.eigs(L, M, 4)
    b = solve.eigs(L, M, 4)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


@pytest.mark.parametrize("k", [2, 4, 10])
def test_exactly_multiple_eigenvalues_are_found_and_proved(k):
    """A Kuhn cube's spectrum has exact 3-fold values: the search may miss a vector of one
    (the proof then asks for more), and k may cut a cluster (the proof counts it)."""
    V, T = tetlap.meshes.cube(9)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = d.boundary_vertices(T, len(V))
    lam, _, info = solve.eigs(L, M, k, fixed, return_info=True)
    np.testing.assert_allclose(lam, _dense(L, M, fixed)[:k], rtol=1e-9)
    assert info.verification.startswith("Sylvester")
