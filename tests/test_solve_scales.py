"""tetlap.solve at extreme scales: meshes from 1e-150 to 1e150 (boundary areas, the primal
KKT) and matrices scaled by 2^k for k in -1000..1000 (factorize, Factor.solve, dirichlet,
neumann, every solver) give the unit answers scaled, bitwise where the scaling is exact.
The rule is the operators': compute in a frame scaled by a power of two, scale back."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import diagnostics as d
from tetlap import solve

GRAD = np.array([1.0, 2.0, -1.0])
VC, TC = tetlap.meshes.cube(3, jitter=0.1, seed=1)
SCALES = [1e-150, 1e-100, 1e-82, 1e-80, 1e-5, 1e5, 1e78, 1e100, 1e150]
AREAS = [solve.dual_boundary_areas, solve.fem_boundary_areas]


def _quadratic_flux(s=1.0):
    """The normal derivative of ``(x^2 - y^2) / s`` at points of a mesh scaled by ``s``."""
    return lambda c, n: np.einsum("ij,ij->i", np.c_[2 * c[:, 0], -2 * c[:, 1], 0 * c[:, 0]], n) / s**2


@pytest.mark.parametrize("areas", AREAS)
@pytest.mark.parametrize("s", SCALES)
def test_boundary_areas_at_any_scale_are_the_unit_ones_scaled(areas, s):
    unit = areas(VC, TC, GRAD)
    scaled = areas(VC * s, TC, GRAD / s)              # the flux of the same function
    assert np.isfinite(scaled).all()
    np.testing.assert_allclose(scaled / s, unit, rtol=1e-13, atol=1e-15 * np.abs(unit).max())
    q = areas(VC * s, TC, _quadratic_flux(s))
    np.testing.assert_allclose(q / s, areas(VC, TC, _quadratic_flux()), rtol=1e-13,
                               atol=1e-15 * np.abs(q / s).max())


@pytest.mark.parametrize("areas", AREAS)
@pytest.mark.parametrize("k", [-500, -299, -1, 1, 272, 500])
def test_boundary_areas_scale_bitwise_by_powers_of_two(areas, k):
    np.testing.assert_array_equal(areas(np.ldexp(VC, k), TC, np.ldexp(GRAD, -k)),
                                  np.ldexp(areas(VC, TC, GRAD), k))


@pytest.mark.parametrize("areas", AREAS)
def test_boundary_areas_beyond_the_range_are_refused_naming_the_element(areas):
    for s in (1e-160, 1e160):
        with pytest.raises(tetlap.DegenerateElementError, match="beyond the normal float64") as e:
            areas(VC * s, TC, GRAD)
        assert e.value.element is not None


@pytest.mark.parametrize("areas", AREAS)
def test_boundary_areas_do_not_depend_on_the_orientation_of_the_tets(areas):
    # the normals were taken from the faces' vertex order: inward for negative tets
    T2 = TC.copy()
    T2[::2, [0, 1]] = T2[::2, [1, 0]]
    assert (d.orientation(VC, T2) < 0).any()
    np.testing.assert_array_equal(areas(VC, T2, GRAD), areas(VC, TC, GRAD))
    np.testing.assert_array_equal(areas(VC, T2, _quadratic_flux()), areas(VC, TC, _quadratic_flux()))


@pytest.fixture(scope="module")
def ball():
    V, T = tetlap.meshes.ball(800, seed=5)
    L = tetlap.laplacian(V, T)
    return V, T, solve.neumann_primal_kkt(L, V, T, _quadratic_flux())


@pytest.mark.parametrize("s", [1e-100, 1e100, 1e-150, 1e150, 1e5, 1e-5])
def test_the_primal_kkt_does_not_depend_on_the_unit(ball, s):
    V, T, unit = ball
    W = V * s
    f = solve.neumann_primal_kkt(tetlap.laplacian(W, T), W, T, _quadratic_flux(s))
    assert np.abs(f - unit).max() <= 1e-13 * np.abs(unit).max()


@pytest.mark.parametrize("k", [-400, -7, 3, 330])
def test_the_primal_kkt_is_bitwise_invariant_under_powers_of_two(ball, k):
    V, T, unit = ball
    W = np.ldexp(V, k)
    f = solve.neumann_primal_kkt(tetlap.laplacian(W, T), W, T, _quadratic_flux(2.0**k))
    np.testing.assert_array_equal(f, unit)


# ---- matrices scaled by 2^k ------------------------------------------------------------

V, T = tetlap.meshes.cube(4, jitter=0.2, seed=1)
N = len(V)
L = tetlap.laplacian(V, T, "dual")
FIXED = d.boundary_vertices(V, T)
U = np.sin(V[:, 0]) + V[:, 1]
G = solve.dual_boundary_areas(V, T, [1.0, 2.0, 0.0])
A = -L + 0.3 * tetlap.mass(V, T)
NONSYMMETRIC = sp.csr_array(A + sp.csr_array(([0.01], ([0], [1])), shape=A.shape))
B = np.cos(np.arange(N))
K = [-1000, -999, -777, -512, -1, 1, 154, 155, 511, 512, 999, 1000]

CASES = {
    "factorize": lambda s: solve.factorize(A * s).solve(B) * s,
    "factorize-block": lambda s: solve.factorize(A * s).solve(np.c_[B, 2 * B]) * s,
    "factorize-lu": lambda s: solve.factorize(A * s, solver="lu").solve(B) * s,
    "factorize-nonsymmetric": lambda s: solve.factorize(NONSYMMETRIC * s).solve(B) * s,
    "refactor": lambda s: _refactored(s),
    **{f"dirichlet-{m}": (lambda m: lambda s: solve.dirichlet(L * s, FIXED, U, solver=m))(m)
       for m in ("amg", "cholesky", "lu")},
    "dirichlet-replace": lambda s: solve.dirichlet(L * s, FIXED, U, method="replace"),
    **{f"neumann-{m}": (lambda m: lambda s: solve.neumann(L * s, G * s, solver=m))(m)
       for m in ("amg", "cholesky", "lu")},
}


def _refactored(s):
    F = solve.factorize(A)
    F.refactor(A * s)
    return F.solve(B) * s


@pytest.mark.parametrize("case", CASES)
def test_matrices_scaled_by_powers_of_two_give_the_same_answer(case):
    # the pivot test multiplied two diagonal entries (overflow from 1.3e154: "singular"),
    # pyamg's set-up failed beyond 2^600, and the identity rows of method="replace" beside
    # rows of 2^100 made its system look singular
    unit = CASES[case](1.0)
    for k in K:
        x = CASES[case](2.0**k)
        if k % 2 == 0:
            np.testing.assert_array_equal(x, unit, err_msg=f"2^{k}")
        else:   # an LL^T of 2^k A takes square roots of odd powers of two: rounding only
            np.testing.assert_allclose(x, unit, rtol=0, atol=1e-13 * np.abs(unit).max(),
                                       err_msg=f"2^{k}")


def test_the_residual_and_the_condition_bound_do_not_overflow():
    x = solve.factorize(A).solve(B)
    res = solve._checks.relative_residual(A, x, B)
    bound = solve._checks.condition_bound(A, x, B)
    for k in (-1000, 1000):
        As = A * 2.0**k
        assert solve._checks.relative_residual(As, np.ldexp(x, -k), B) == res
        assert solve._checks.condition_bound(As, np.ldexp(x, -k), B) == bound
        assert solve._checks.relative_residual(As, x, np.ldexp(B, k)) == res
    # |A| |x| beyond the float64 range: a wrong answer's residual was r / inf = 0
    As, xs, bs = A * 2.0**990, np.ldexp(x + 1e-3, 29), np.ldexp(B, 1019)
    with np.errstate(over="ignore"):
        assert np.isfinite(As @ xs).all() and np.isinf(solve._checks.row_norm(As) * xs.max())
    wrong = solve._checks.relative_residual(As, xs, bs)
    assert wrong == solve._checks.relative_residual(A, x + 1e-3, B) > solve.RESIDUAL_TOL
