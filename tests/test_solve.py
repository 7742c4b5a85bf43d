"""tetlap.solve: boundary-value and eigenvalue problems (paper Sec. 6, 8; Eq. 23-30), and
the checks of what they take and what they return."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import diagnostics as d
from tetlap import solve

GRAD = np.array([1.0, 2.0, -1.0])


@pytest.fixture(scope="module")
def ball():
    return tetlap.meshes.ball(1500, seed=1)


@pytest.mark.parametrize("kind", ["primal", "dual", 0.4])
@pytest.mark.parametrize("method", ["eliminate", "replace"])
def test_dirichlet_reproduces_linear_functions(ball, kind, method):
    V, T = ball
    L = tetlap.laplacian(V, T, kind)
    fixed = d.boundary_vertices(T, len(V))
    u = V @ GRAD + 3
    f = solve.dirichlet(L, fixed, u, method=method)
    assert np.abs(f - u).max() < 1e-11
    # values given per fixed vertex and as an index array work the same
    g = solve.dirichlet(L, np.flatnonzero(fixed), u[fixed], method=method)
    np.testing.assert_allclose(g, f, atol=1e-12)


def test_dirichlet_methods_agree_on_a_poisson_problem(ball):
    V, T = ball
    L, M = tetlap.operators(V, T, "dual", "circumcentric")
    fixed = d.boundary_vertices(T, len(V))
    rhs = M @ np.sin(3 * V[:, 0])
    a = solve.dirichlet(L, fixed, 0.5, rhs)
    b = solve.dirichlet(L, fixed, 0.5, rhs, method="replace")
    np.testing.assert_allclose(a, b, atol=1e-12)
    assert (a[fixed] == 0.5).all() and np.abs(a[~fixed] - 0.5).max() > 1e-3


def test_dirichlet_rejects_bad_input(ball):
    V, T = ball
    L = tetlap.laplacian(V, T)
    with pytest.raises(tetlap.ShapeError):
        solve.dirichlet(L, np.ones(3, dtype=bool), 0.0)
    with pytest.raises(tetlap.ShapeError):
        solve.dirichlet(L, [0, 1], [1.0, 2.0, 3.0])
    with pytest.raises(tetlap.OptionError):
        solve.dirichlet(L, [0], 0.0, method="lu")
    with pytest.raises(tetlap.IndexRangeError):
        solve.dirichlet(L, [len(V)], 0.0)


def shell_errors(n, kind, seed=0):
    V, T, s = tetlap.meshes.shell(n, seed=seed)
    r = np.linalg.norm(V, axis=1)
    fixed = (s == 0) | (s == 2)
    f = solve.dirichlet(tetlap.laplacian(V, T, kind), fixed, np.where(s == 0, 1.0, 0.0))
    h = np.mean(np.linalg.norm(V[T[:, 0]] - V[T[:, 1]], axis=1))
    rms = np.sqrt(((f - (1 / r - 1))[~fixed] ** 2).mean())
    return h, rms, f[s == 1].var()


@pytest.mark.parametrize("kind", ["primal", "dual"])
@pytest.mark.parametrize("seed", [0, 1])
def test_shell_dirichlet_converges_to_the_exact_solution(kind, seed):
    """Eq. 28 on the shell 0.5 < r < 1: f = 1/r - 1 exactly; the error shrinks with h.

    Measured RMS orders from 1500 to 6000 vertices on random Delaunay shells: 0.54-0.78
    (pre-asymptotic; the polyhedral spheres and slivers); max-error orders about 1.5
    from 8000 to 32000 vertices."""
    (h1, e1, v1), (h2, e2, v2) = shell_errors(1500, kind, seed), shell_errors(6000, kind, seed)
    order = np.log(e1 / e2) / np.log(h1 / h2)
    assert e2 < e1 and order > 0.4, (e1, e2, order)


def test_shell_dual_variance_below_primal_on_delaunay_meshes():
    """Paper Fig. 8 (random Delaunay): the dual's variance on r = 0.75 is lower."""
    for seed in (0, 1, 2):
        _, _, vp = shell_errors(3000, "primal", seed)
        _, _, vd = shell_errors(3000, "dual", seed)
        assert vd < vp


@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_neumann_reproduces_linear_functions(ball, kind):
    V, T = ball
    L = tetlap.laplacian(V, T, kind)
    u = V @ GRAD
    flux = solve.dual_boundary_areas if kind == "dual" else solve.fem_boundary_areas
    g = flux(V, T, GRAD)
    assert np.abs(g[d.interior_vertices(T, len(V))]).max() == 0
    f = solve.neumann(L, g)
    assert abs(f.mean()) < 1e-12
    assert np.abs(f - (u - u.mean())).max() < 1e-10
    f0 = solve.neumann(L, g, gauge=0)
    assert f0[0] == pytest.approx(0, abs=1e-12)
    assert np.abs(f0 - (u - u[0])).max() < 1e-10


def test_primal_kkt_gradient_constraints_reproduce_linear_functions(ball):
    V, T = ball
    L = tetlap.laplacian(V, T, "primal")
    f = solve.neumann_primal_kkt(L, V, T, lambda p, n: n @ GRAD)
    u = V @ GRAD
    assert np.abs(f - (u - u.mean())).max() < 1e-9


@pytest.mark.slow  # a convergence study to 6000 vertices (the KKT one: 35-40 s alone)
@pytest.mark.parametrize("kind, bound", [("primal", 0.02), ("dual", 0.02), ("primal-kkt", 0.15)])
def test_neumann_harmonic_quadratic_converges(kind, bound):
    """u = x^2 - y^2 (harmonic) on the ball from its normal derivative.

    Measured max errors at 1000 / 6000 / 20000 vertices: primal weak 0.045 / 0.011 /
    0.0065, dual 0.031 / 0.0082 / 0.0030, primal KKT 0.18 / 0.11 / 0.063."""
    grad = lambda p: np.column_stack([2 * p[:, 0], -2 * p[:, 1], 0 * p[:, 2]])
    dn = lambda p, n: np.einsum("ij,ij->i", grad(p), n)
    errors = []
    for n in (1000, 6000):
        V, T = tetlap.meshes.ball(n, seed=3)
        u = V[:, 0] ** 2 - V[:, 1] ** 2
        L = tetlap.laplacian(V, T, "primal" if kind != "dual" else "dual")
        if kind == "primal-kkt":
            f = solve.neumann_primal_kkt(L, V, T, dn)
        else:
            flux = solve.dual_boundary_areas if kind == "dual" else solve.fem_boundary_areas
            g = flux(V, T, dn)
            f = solve.neumann(L, g, rtol=1e-3)  # quadrature: compatible to O(h^2) only
        errors.append(np.abs((f - f.mean()) - (u - u.mean())).max())
    assert errors[1] < errors[0] and errors[1] < bound, errors


def test_neumann_compatibility_is_checked(ball):
    V, T = ball
    L = tetlap.laplacian(V, T, "dual")
    g = np.zeros(len(V))
    g[0] = 1.0
    with pytest.raises(solve.CompatibilityError, match="integrate to zero"):
        solve.neumann(L, g)


def test_neumann_handles_components_and_unreferenced_vertices():
    V, T = tetlap.meshes.cube(2)
    V2 = np.vstack([V, V + 5, [[9, 9, 9]]])
    T2 = np.vstack([T, T + len(V)])
    L = tetlap.laplacian(V2, T2, "primal")
    u = V2 @ GRAD
    g = solve.fem_boundary_areas(V2, T2, GRAD)
    f = solve.neumann(L, g)
    for part in (slice(0, len(V)), slice(len(V), 2 * len(V))):
        np.testing.assert_allclose(f[part], u[part] - u[part].mean(), atol=1e-10)
    assert f[-1] == 0


BALL_EIGENVALUES = np.array([9.8696, 20.1907, 20.1907, 20.1907] + [33.2175] * 5 + [39.4784])


@pytest.mark.parametrize("kind, mass", [("primal", "barycentric"), ("dual", "circumcentric")])
def test_ball_dirichlet_eigenvalues(kind, mass):
    errors = []
    for n, tol in ((3000, 0.06), (10000, 0.03)):
        V, T = tetlap.meshes.ball(n, seed=1)
        L, M = tetlap.operators(V, T, kind, mass)
        fixed = d.boundary_vertices(T, len(V))
        lam, vec = solve.eigs(L, M, 10, fixed)
        rel = np.abs(lam / BALL_EIGENVALUES - 1)
        assert rel.max() < tol, rel
        errors.append(rel.mean())
        assert (vec[fixed] == 0).all()
        free = ~fixed
        gram = vec[free].T @ (M[free][:, free] @ vec[free])
        np.testing.assert_allclose(gram, np.eye(10), atol=1e-8)
        np.testing.assert_allclose(-L @ vec[:, 0], lam[0] * (M @ vec[:, 0]) * free + (-L @ vec[:, 0]) * fixed, atol=1e-8)
    assert errors[1] < errors[0]


def test_eigs_refuses_a_non_positive_mass():
    V, T = tetlap.meshes.weighted_ball(600, 1.0, seed=3)
    M = tetlap.mass(V, T, "circumcentric")
    fixed = d.boundary_vertices(T, len(V))
    assert (M.diagonal()[~fixed] <= 0).any()
    with pytest.raises(tetlap.TetlapError, match="not positive"):
        solve.eigs(tetlap.laplacian(V, T, "dual"), M, 5, fixed)
    with pytest.raises(tetlap.OptionError):
        solve.eigs(tetlap.laplacian(V, T, "dual"), M, 0, fixed)


# ---- what solve takes and returns: checked like the operators' inputs ------------------

VC, TC = tetlap.meshes.cube(3, jitter=0.1, seed=1)
LC = tetlap.laplacian(VC, TC, "dual")
MC = tetlap.mass(VC, TC, "barycentric")
BC = tetlap.diagnostics.boundary_vertices(TC, len(VC))
NC = len(VC)


def two_components():
    V2 = np.vstack([VC, VC + 5])
    T2 = np.vstack([TC, TC + NC])
    fixed = np.zeros(2 * NC, dtype=bool)
    fixed[:NC] = BC
    return tetlap.laplacian(V2, T2), fixed


@pytest.mark.parametrize("method", ["eliminate", "replace"])
def test_a_component_without_a_fixed_vertex_is_named(method):
    L2, fixed = two_components()
    with pytest.raises(tetlap.SolveError, match=f"component of vertex {NC}"):
        solve.dirichlet(L2, fixed, 1.0, rhs=np.ones(2 * NC), method=method)
    with pytest.raises(tetlap.SolveError, match="no fixed vertex"):
        solve.dirichlet(L2, fixed, 1.0, method=method)


def test_a_singular_system_is_reported_with_its_residual():
    # a Laplacian with a row of zeros inside a component: not solvable for rhs != 0 there
    A = LC.tolil()
    free = np.flatnonzero(~BC)
    A[free[0], :] = 0
    A[:, free[0]] = 0
    A[free[0], free[1]] = 1e-300
    with pytest.raises(tetlap.SolveError, match="residual|singular"):
        solve.dirichlet(A.tocsr(), BC, 0.0, rhs=np.ones(NC))


@pytest.mark.parametrize("bad, error", [
    (lambda: solve.neumann(LC, np.r_[np.nan, np.zeros(NC - 1)]), tetlap.NonFiniteError),
    (lambda: solve.neumann(LC, np.zeros(NC), rhs=np.r_[np.inf, np.zeros(NC - 1)]), tetlap.NonFiniteError),
    (lambda: solve.neumann(LC, np.zeros(NC - 1)), tetlap.ShapeError),
    (lambda: solve.neumann(LC, np.zeros(NC), gauge=NC), tetlap.IndexRangeError),
    (lambda: solve.neumann(LC, np.zeros(NC), gauge=-1), tetlap.IndexRangeError),
    (lambda: solve.neumann(LC, np.zeros(NC), gauge=2.5), tetlap.OptionError),
    (lambda: solve.neumann(LC, np.zeros(NC), gauge="median"), tetlap.OptionError),
    (lambda: solve.neumann(LC, np.ones(NC)), tetlap.CompatibilityError),
    (lambda: solve.dirichlet(LC, BC, np.nan), tetlap.NonFiniteError),
    (lambda: solve.dirichlet(LC, [0, NC], 1.0), tetlap.IndexRangeError),
    (lambda: solve.dirichlet(LC, [-1], 1.0), tetlap.IndexRangeError),
    (lambda: solve.dirichlet(LC, BC[:-1], 1.0), tetlap.ShapeError),
    # a vertex given twice: the values follow the indices (it was de-duplicated, then its
    # values were "not one per fixed vertex")
    (lambda: solve.dirichlet(LC, [0, 0, 5], [0.0, 1.0, 2.0]), tetlap.OptionError),
    (lambda: solve.eigs(LC, MC, k=2, fixed=[0, 1, 1]), tetlap.OptionError),
    (lambda: solve.dirichlet(LC, [[0, 5]], 1.0), tetlap.ShapeError),   # was read flat
    (lambda: solve.dirichlet(LC, BC, 1.0, method="lu"), tetlap.OptionError),
    (lambda: solve.dirichlet(sp.eye_array(3) * np.nan, [0], 1.0), tetlap.NonFiniteError),
    (lambda: solve.dirichlet("LC", [0], 1.0), TypeError),
    (lambda: solve.dirichlet(sp.random_array((3, 4)), [0], 1.0), tetlap.ShapeError),
    (lambda: solve.eigs(LC, MC, k=2.5, fixed=BC), tetlap.OptionError),
    (lambda: solve.eigs(LC, MC, k=0, fixed=BC), tetlap.OptionError),
    (lambda: solve.eigs(LC, MC, k=True, fixed=BC), tetlap.OptionError),
    (lambda: solve.eigs(LC, MC[:5, :5], k=2, fixed=BC), tetlap.ShapeError),
    (lambda: solve.eigs(LC, -MC, k=2, fixed=BC), tetlap.SolveError),
    (lambda: solve.eigs(LC, MC, k=2, fixed=BC, sigma=np.nan), tetlap.OptionError),
    (lambda: solve.dual_boundary_areas(VC, TC, [1.0, np.nan, 0]), tetlap.NonFiniteError),
    (lambda: solve.dual_boundary_areas(VC, TC, lambda p, n: np.full(len(p), np.nan)), tetlap.NonFiniteError),
    (lambda: solve.dual_boundary_areas(VC, TC), TypeError),
    (lambda: solve.neumann_primal_kkt(LC, VC, TC, lambda p, n: n[:, 0], gauge=10**9), tetlap.IndexRangeError),
    (lambda: solve.neumann_primal_kkt(LC[:-1, :-1], VC, TC, lambda p, n: n[:, 0]), tetlap.ShapeError),
])
def test_bad_input_gets_a_named_error(bad, error):
    with pytest.raises(error):
        bad()


def test_inputs_are_not_modified():
    L0, g = LC.copy(), np.zeros(NC)
    fixed = BC.copy()
    solve.dirichlet(LC, fixed, VC[:, 0])
    solve.neumann(LC, g)
    assert (LC != L0).nnz == 0 and np.array_equal(fixed, BC) and not g.any()


def test_a_degenerate_boundary_face_is_an_error_not_nan():
    V2 = VC.copy()
    # squash one boundary face onto a line: move one of its vertices between the others
    F = tetlap.diagnostics.boundary_faces(TC)
    a, b, c = F[0]
    V2[c] = (V2[a] + V2[b]) / 2
    with pytest.raises(tetlap.TetlapError):
        solve.dual_boundary_areas(V2, TC, [1.0, 0.0, 0.0])


def test_good_problems_still_solve_exactly():
    f = solve.dirichlet(LC, BC, VC[:, 0] - 2 * VC[:, 2])
    np.testing.assert_allclose(f, VC[:, 0] - 2 * VC[:, 2], atol=1e-12)
    f = solve.dirichlet(LC, BC, VC[:, 0] - 2 * VC[:, 2], method="replace")
    np.testing.assert_allclose(f, VC[:, 0] - 2 * VC[:, 2], atol=1e-12)
    g = solve.dual_boundary_areas(VC, TC, [1.0, 0.0, 0.0])
    f = solve.neumann(LC, g)
    np.testing.assert_allclose(f - f.mean(), VC[:, 0] - VC[:, 0].mean(), atol=1e-10)
    lam, vecs = solve.eigs(LC, MC, 3, BC)
    assert (lam > 0).all() and np.isfinite(vecs).all()
