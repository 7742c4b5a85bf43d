"""solve.neumann_primal_kkt: the least-squares gradient constraints of Eq. 25 under the
interior Laplace rows. Where the minimiser is not unique (the Kuhn grids of meshes.cube,
which it refused) the one closest to the weak solution is returned; it is checked here
against a dense computation of that definition, and where the minimiser is unique
against the plain KKT solve."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import tetlap
from tetlap import diagnostics as d
from tetlap import solve

GRAD = np.array([1.0, 2.0, -1.0])


def quadratic(c, n):
    """The normal derivative of the harmonic ``x^2 - y^2``."""
    return np.einsum("ij,ij->i", np.c_[2 * c[:, 0], -2 * c[:, 1], 0 * c[:, 0]], n)


def pieces(V, T, data):
    """``(C, A, g, load)`` of the definition, dense: the normal derivative rows ``C`` of
    the boundary faces, the constraints ``A`` (interior rows of L, the mean), the face
    data ``g`` and its P1 load per vertex."""
    n = len(V)
    L = tetlap.laplacian(V, T)
    faces = solve._boundary.boundary(V, T)
    g = data(V[faces.faces].mean(axis=1), faces.normals)
    X = V[T[faces.tets]]
    inv = np.linalg.inv(X[:, 1:] - X[:, :1])
    grads = np.concatenate([-inv.sum(axis=2, keepdims=True), inv], axis=2)
    C = np.zeros((len(g), n))
    np.add.at(C, (np.repeat(np.arange(len(g)), 4), T[faces.tets].ravel()),
              np.einsum("fd,fda->fa", faces.normals, grads).ravel())
    A = np.vstack([L.toarray()[d.interior_vertices(V, T)], np.ones((1, n))])
    load = np.bincount(faces.faces.ravel(), weights=np.repeat(faces.area / 3 * g, 3), minlength=n)
    return L, C, A, g, load


@pytest.mark.parametrize("k", [2, 3, 4, 6])
def test_kuhn_grids_are_solved_and_reproduce_linear_functions(k):
    V, T = tetlap.meshes.cube(k)
    L = tetlap.laplacian(V, T)
    u = V @ GRAD
    f, info = solve.neumann_primal_kkt(L, V, T, lambda c, n: n @ GRAD, return_info=True)
    assert np.abs(f - (u - u.mean())).max() < 1e-12
    assert info.iterations >= 1 and info.residual <= solve.RESIDUAL_TOL
    f = solve.neumann_primal_kkt(L, V, T, lambda c, n: n @ GRAD, gauge=7)
    assert np.abs(f - (u - u[7])).max() < 1e-12
    for s in (1e5, 1e-5):
        W = V * s
        f = solve.neumann_primal_kkt(tetlap.laplacian(W, T), W, T, lambda c, n: n @ GRAD / s)
        assert np.abs(f - (u - u.mean())).max() < 1e-12


def test_kuhn_grids_have_many_minimisers_and_the_closest_to_the_weak_solution_is_returned():
    V, T = tetlap.meshes.cube(3)
    L, C, A, g, load = pieces(V, T, quadratic)
    N = sl.null_space(A)
    assert np.linalg.matrix_rank(C @ N) < N.shape[1]          # many minimisers
    f0 = solve.neumann(L, load, rtol=0.5)                      # the weak solution
    # the minimiser closest to f0: f0 + (the least-norm correction)
    dp = np.linalg.lstsq(A, -A @ f0, rcond=None)[0]
    y = np.linalg.lstsq(C @ N, g - C @ (f0 + dp), rcond=None)[0]
    closest = f0 + dp + N @ y
    f = solve.neumann_primal_kkt(L, V, T, quadratic)
    assert np.abs(f - closest).max() <= 1e-9 * np.abs(closest).max()
    assert np.linalg.norm(C @ f - g) <= np.linalg.norm(C @ closest - g) + 1e-12
    assert np.abs(A @ f).max() < 1e-12
    assert np.abs(f - f0).max() > 1e-2                         # not the weak solution itself


@pytest.mark.parametrize("mesh", [lambda: tetlap.meshes.ball(400, seed=2),
                                  lambda: tetlap.meshes.cube(4, jitter=0.2, seed=3)])
def test_a_unique_minimiser_is_the_plain_kkt_solution(mesh):
    V, T = mesh()
    L, C, A, g, _ = pieces(V, T, quadratic)
    N = sl.null_space(A)
    assert np.linalg.matrix_rank(C @ N) == N.shape[1]          # one minimiser
    K = sp.csc_array(np.block([[C.T @ C, A.T], [A, np.zeros((len(A), len(A)))]]))
    plain = splu(K).solve(np.r_[C.T @ g, np.zeros(len(A))])[:len(V)]
    f = solve.neumann_primal_kkt(L, V, T, quadratic)
    assert np.abs(f - plain).max() <= 1e-9 * np.abs(plain).max()


def test_every_solver_gives_the_same_minimiser():
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    L = tetlap.laplacian(V, T)
    f = solve.neumann_primal_kkt(L, V, T, quadratic)
    lu, info = solve.neumann_primal_kkt(L, V, T, quadratic, solver="lu", return_info=True)
    np.testing.assert_array_equal(lu, f)
    assert info.solver == "lu"
    try:
        ch, info = solve.neumann_primal_kkt(L, V, T, quadratic, solver="cholesky", return_info=True)
    except tetlap.SolveError as e:          # LDL^T without pivoting, documented
        assert "pivot" in str(e)
    else:
        assert np.abs(ch - f).max() <= 1e-9 * np.abs(f).max()
