"""tetlap.solve checks what it takes (like the operators) and what it returns."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import solve

V, T = tetlap.meshes.cube(3, jitter=0.1, seed=1)
L = tetlap.laplacian(V, T, "dual")
M = tetlap.mass(V, T, "barycentric")
BOUNDARY = tetlap.diagnostics.boundary_vertices(T, len(V))
N = len(V)


def two_components():
    V2 = np.vstack([V, V + 5])
    T2 = np.vstack([T, T + N])
    fixed = np.zeros(2 * N, dtype=bool)
    fixed[:N] = BOUNDARY
    return tetlap.laplacian(V2, T2), fixed


@pytest.mark.parametrize("method", ["eliminate", "replace"])
def test_a_component_without_a_fixed_vertex_is_named(method):
    L2, fixed = two_components()
    with pytest.raises(tetlap.SolveError, match=f"component of vertex {N}"):
        solve.dirichlet(L2, fixed, 1.0, rhs=np.ones(2 * N), method=method)
    with pytest.raises(tetlap.SolveError, match="no fixed vertex"):
        solve.dirichlet(L2, fixed, 1.0, method=method)


def test_a_singular_system_is_reported_with_its_residual():
    # a Laplacian with a row of zeros inside a component: not solvable for rhs != 0 there
    A = L.tolil()
    free = np.flatnonzero(~BOUNDARY)
    A[free[0], :] = 0
    A[:, free[0]] = 0
    A[free[0], free[1]] = 1e-300
    with pytest.raises(tetlap.SolveError, match="residual|singular"):
        solve.dirichlet(A.tocsr(), BOUNDARY, 0.0, rhs=np.ones(N))


@pytest.mark.parametrize("bad, error", [
    (lambda: solve.neumann(L, np.r_[np.nan, np.zeros(N - 1)]), tetlap.NonFiniteError),
    (lambda: solve.neumann(L, np.zeros(N), rhs=np.r_[np.inf, np.zeros(N - 1)]), tetlap.NonFiniteError),
    (lambda: solve.neumann(L, np.zeros(N - 1)), tetlap.ShapeError),
    (lambda: solve.neumann(L, np.zeros(N), gauge=N), tetlap.IndexRangeError),
    (lambda: solve.neumann(L, np.zeros(N), gauge=-1), tetlap.IndexRangeError),
    (lambda: solve.neumann(L, np.zeros(N), gauge=2.5), tetlap.OptionError),
    (lambda: solve.neumann(L, np.zeros(N), gauge="median"), tetlap.OptionError),
    (lambda: solve.neumann(L, np.ones(N)), tetlap.CompatibilityError),
    (lambda: solve.dirichlet(L, BOUNDARY, np.nan), tetlap.NonFiniteError),
    (lambda: solve.dirichlet(L, [0, N], 1.0), tetlap.IndexRangeError),
    (lambda: solve.dirichlet(L, [-1], 1.0), tetlap.IndexRangeError),
    (lambda: solve.dirichlet(L, BOUNDARY[:-1], 1.0), tetlap.ShapeError),
    (lambda: solve.dirichlet(L, BOUNDARY, 1.0, method="lu"), tetlap.OptionError),
    (lambda: solve.dirichlet(sp.eye_array(3) * np.nan, [0], 1.0), tetlap.NonFiniteError),
    (lambda: solve.dirichlet("L", [0], 1.0), TypeError),
    (lambda: solve.dirichlet(sp.random_array((3, 4)), [0], 1.0), tetlap.ShapeError),
    (lambda: solve.eigs(L, M, k=2.5, fixed=BOUNDARY), tetlap.OptionError),
    (lambda: solve.eigs(L, M, k=0, fixed=BOUNDARY), tetlap.OptionError),
    (lambda: solve.eigs(L, M, k=True, fixed=BOUNDARY), tetlap.OptionError),
    (lambda: solve.eigs(L, M[:5, :5], k=2, fixed=BOUNDARY), tetlap.ShapeError),
    (lambda: solve.eigs(L, -M, k=2, fixed=BOUNDARY), tetlap.SolveError),
    (lambda: solve.eigs(L, M, k=2, fixed=BOUNDARY, sigma=np.nan), tetlap.OptionError),
    (lambda: solve.dual_boundary_areas(V, T, [1.0, np.nan, 0]), tetlap.NonFiniteError),
    (lambda: solve.dual_boundary_areas(V, T, lambda p, n: np.full(len(p), np.nan)), tetlap.NonFiniteError),
    (lambda: solve.dual_boundary_areas(V, T), TypeError),
    (lambda: solve.neumann_primal_kkt(L, V, T, lambda p, n: n[:, 0], gauge=10**9), tetlap.IndexRangeError),
    (lambda: solve.neumann_primal_kkt(L[:-1, :-1], V, T, lambda p, n: n[:, 0]), tetlap.ShapeError),
])
def test_bad_input_gets_a_named_error(bad, error):
    with pytest.raises(error):
        bad()


def test_inputs_are_not_modified():
    L0, g = L.copy(), np.zeros(N)
    fixed = BOUNDARY.copy()
    solve.dirichlet(L, fixed, V[:, 0])
    solve.neumann(L, g)
    assert (L != L0).nnz == 0 and np.array_equal(fixed, BOUNDARY) and not g.any()


def test_a_degenerate_boundary_face_is_an_error_not_nan():
    V2 = V.copy()
    corner = np.flatnonzero((V == 0).all(axis=1))[0]
    neighbours = np.unique(T[(T == corner).any(axis=1)])
    # squash one boundary face onto a line: pick a boundary face and move a vertex
    F = tetlap.diagnostics.boundary_faces(T)
    a, b, c = F[0]
    V2[c] = (V2[a] + V2[b]) / 2
    with pytest.raises(tetlap.TetlapError):
        solve.dual_boundary_areas(V2, T, [1.0, 0.0, 0.0])
    del neighbours


def test_good_problems_still_solve_exactly():
    f = solve.dirichlet(L, BOUNDARY, V[:, 0] - 2 * V[:, 2])
    np.testing.assert_allclose(f, V[:, 0] - 2 * V[:, 2], atol=1e-12)
    f = solve.dirichlet(L, BOUNDARY, V[:, 0] - 2 * V[:, 2], method="replace")
    np.testing.assert_allclose(f, V[:, 0] - 2 * V[:, 2], atol=1e-12)
    g = solve.dual_boundary_areas(V, T, [1.0, 0.0, 0.0])
    f = solve.neumann(L, g)
    np.testing.assert_allclose(f - f.mean(), V[:, 0] - V[:, 0].mean(), atol=1e-10)
    lam, vecs = solve.eigs(L, M, 3, BOUNDARY)
    assert (lam > 0).all() and np.isfinite(vecs).all()
