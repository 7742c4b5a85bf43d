"""What every function of tetlap.solve refuses, and how it says so: the stiffness sign
``-L``, data at a vertex in no element, flags that are not booleans, non-symmetric values
for a cholesky factorization; and which vertices take part in a system (those of the
elements, read from the stored pattern of ``L``, never from its non-zero values)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import diagnostics as d
from tetlap import solve

GRAD = np.array([1.0, -2.0, 0.5])
V, T = tetlap.meshes.cube(3, jitter=0.1, seed=4)
N = len(V)
L = tetlap.laplacian(V, T, "primal")
FIXED = d.boundary_vertices(V, T)
G = solve.fem_boundary_areas(V, T, GRAD)
FLUX = lambda c, n: n @ GRAD  # noqa: E731

# a vertex in no element, appended
V1 = np.vstack([V, [[3.0, 3.0, 3.0]]])
L1 = tetlap.laplacian(V1, T, "primal")
FIXED1 = np.r_[FIXED, False]

EVERY = {
    "dirichlet": lambda A, **kw: solve.dirichlet(A, FIXED, V[:, 0], **kw),
    "dirichlet-replace": lambda A, **kw: solve.dirichlet(A, FIXED, V[:, 0], method="replace", **kw),
    "neumann": lambda A, **kw: solve.neumann(A, G, **kw),
    "neumann_primal_kkt": lambda A, **kw: solve.neumann_primal_kkt(A, V, T, FLUX, **kw),
}


@pytest.mark.parametrize("name", EVERY)
def test_the_stiffness_sign_is_refused_naming_the_convention(name):
    with pytest.raises(tetlap.OptionError, match="non-negative diagonal.*L\\[i, i\\] = -sum_j w_ij"):
        EVERY[name](-L)
    EVERY[name](L)          # the tetlap sign is solved


@pytest.mark.parametrize("name", EVERY)
@pytest.mark.parametrize("bad", [1, "yes", [True], np.array([1, 0]), None])
def test_return_info_is_a_strict_flag(name, bad):
    with pytest.raises(tetlap.OptionError, match="return_info must be True or False"):
        EVERY[name](L, return_info=bad)
    assert isinstance(EVERY[name](L, return_info=np.True_)[1], solve.SolveInfo)


def test_flux_on_a_vertex_in_no_element_is_refused_by_every_solve():
    g = np.r_[solve.fem_boundary_areas(V, T, GRAD), 0.0]
    f = solve.neumann(L1, g)                         # 0 there: solved, the vertex gets 0
    assert f[-1] == 0
    bad = g.copy()
    bad[-1] = 0.25
    with pytest.raises(tetlap.SolveError, match=f"vertex {N} belongs to no element"):
        solve.neumann(L1, bad)
    with pytest.raises(tetlap.SolveError, match=f"vertex {N} belongs to no element"):
        solve.neumann(L1, g, rhs=np.r_[np.zeros(N), 1.0])
    with pytest.raises(tetlap.SolveError, match=f"vertex {N} belongs to no element"):
        solve.dirichlet(L1, FIXED1, 0.0, rhs=np.r_[np.zeros(N), 1.0])
    with pytest.raises(tetlap.SolveError, match=f"vertex {N} belongs to no element"):
        solve.neumann_primal_kkt(L1, V1, T, FLUX, rhs=np.r_[np.zeros(N), 1.0])
    # a value given at a fixed vertex in no element is kept, as given
    f = solve.dirichlet(L1, np.r_[FIXED, True], np.r_[V[:, 0], 7.0])
    assert f[-1] == 7.0


def test_vertices_in_no_element_are_read_from_the_pattern_not_the_values():
    # "M = I style" data: a non-zero diagonal at the vertex in no element (L - I, a
    # screened problem) leaves it out of every system, as with the plain L
    shifted = L1 - 0.5 * sp.eye_array(N + 1)
    a = solve.dirichlet(L1, FIXED1, np.r_[V[:, 0], 0.0], rhs=np.r_[np.ones(N), 0.0])
    b = solve.dirichlet(shifted, FIXED1, np.r_[V[:, 0], 0.0], rhs=np.r_[np.ones(N), 0.0])
    assert a[-1] == 0 and b[-1] == 0
    assert np.abs(a[:N] - b[:N]).max() > 1e-3      # the shift does act on the mesh
    with pytest.raises(tetlap.SolveError, match=f"vertex {N} belongs to no element"):
        solve.dirichlet(shifted, FIXED1, 0.0, rhs=np.r_[np.zeros(N), 1.0])
    # the primal's explicit zeros (cube grids) keep their vertices in the system
    assert (L.data == 0).any()
    labels, referenced = solve._checks.components(L)
    assert referenced.all()


def test_a_vertex_whose_edges_all_weigh_zero_is_its_own_component():
    # it is in elements (stored edges) but no equation couples it: the Dirichlet problem
    # is singular there and says so, instead of giving it 0 as if it were in no element
    free = np.flatnonzero(~FIXED)
    v = int(free[0])
    A = L.copy()
    rows = np.repeat(np.arange(N), np.diff(A.indptr))
    A.data[((rows == v) | (A.indices == v)) & (rows != A.indices)] = 0.0   # explicit zeros
    off = A.copy()
    off.data[rows == off.indices] = 0.0
    A.data[rows == A.indices] = -np.asarray(off.sum(axis=1)).ravel()[rows[rows == A.indices]]
    pattern = sp.csr_array((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    assert pattern[[v]].nnz > 1 and not A[[v]].count_nonzero()   # stored, all zero
    with pytest.raises(tetlap.SolveError, match=f"component of vertex {v} has no fixed vertex"):
        solve.dirichlet(A, FIXED, V[:, 0])


def test_refactor_with_non_symmetric_values_says_so():
    A = -L + sp.eye_array(N)
    F = solve.factorize(A)
    assert F.info.solver == "cholesky"
    B = A.tolil()
    B[0, 1] += 0.5
    with pytest.raises(tetlap.OptionError, match="not symmetric"):
        F.refactor(sp.csr_array(B))
    # an LU takes them
    lu = solve.factorize(A, solver="lu")
    lu.refactor(sp.csr_array(B))
    x = lu.solve(np.ones(N))
    np.testing.assert_allclose(sp.csr_array(B) @ x, np.ones(N), atol=1e-12)


def test_an_interrupted_lu_refactor_leaves_a_factor_that_says_so(monkeypatch):
    """A SuperLU refactor cut short (Ctrl-C) or refused keeps no old factor: solving then
    says to refactor, instead of failing the residual check of the old factor against the
    new values."""
    from tetlap.solve import factor as factor_module

    A = sp.csr_array(sp.random(30, 30, density=0.2, random_state=1) + 4 * sp.eye(30))
    F = tetlap.solve.factorize(A, solver="lu")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(factor_module._interrupt, "splu", interrupted)
    with pytest.raises(KeyboardInterrupt):
        F.refactor(2 * A)
    with pytest.raises(tetlap.SolveError, match="refactor again"):
        F.solve(np.ones(30))
    monkeypatch.undo()
    F.refactor(2 * A)
    np.testing.assert_allclose(2 * A @ F.solve(np.ones(30)), np.ones(30), atol=1e-12)
