"""The solver layer against the old path (SuperLU, ``solver="lu"``) on every corpus mesh and
on the 189k-tet ball: the same solutions to 1e-8 relative (slow).

The reference is SuperLU's answer refined in extended precision: on a mesh whose Dirichlet
block has a condition number near 1e11 (``mmc_sphshells.vtu``) SuperLU's own answer is
4.5e-8 from the refined one, so no other solver can agree with it to 1e-8; the solver
layer's answers agree with the refined reference, and so with SuperLU's to within its own
error."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import diagnostics as d
from tetlap import solve
from tetlap.solve import _checks, _linear


def _relative(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


def _reference(L, fixed, u):
    """SuperLU's solution (the old path), refined in extended precision."""
    from scipy.sparse.linalg import splu

    f = solve.dirichlet(L, fixed, u, solver="lu")
    free = ~fixed & _checks.components(L)[1]
    A = -L[free][:, free]
    b = L[free][:, fixed] @ u[fixed]
    lu = splu(sp.csc_array(A))
    f[free] = _checks.refine(A, f[free], b, lu.solve)
    return f


def _agree(L, fixed, u, **kwargs):
    try:
        reference = _reference(L, fixed, u)
    except tetlap.SolveError:
        with pytest.raises(tetlap.SolveError):
            solve.dirichlet(L, fixed, u, **kwargs)
        return
    f, info = solve.dirichlet(L, fixed, u, return_info=True, **kwargs)
    assert _relative(f, reference) <= 1e-8, info
    assert info.residual <= solve.RESIDUAL_TOL


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_every_solver_agrees_with_superlu_on_the_corpus(real_mesh, kind, monkeypatch):
    name, V, T = real_mesh
    L = tetlap.laplacian(V, T, kind, degenerate="skip")
    fixed = d.boundary_vertices(T, len(V))
    if not fixed.any():
        pytest.skip(f"{name}: no boundary")
    u = np.sin(3 * V[:, 0] / np.ptp(V)) + V[:, 1] / np.ptp(V)
    _agree(L, fixed, u)  # the default choice on this size
    _agree(L, fixed, u, solver="cholesky")
    monkeypatch.setattr(_linear, "AUTO_AMG_MIN", 0)
    _agree(L, fixed, u)  # auto through AMG (or its fallbacks)


@pytest.mark.slow
def test_the_189k_tet_ball_agrees_with_superlu():
    V, T = tetlap.meshes.ball(30000, seed=0)
    L = tetlap.laplacian(V, T, "primal")
    fixed = d.boundary_vertices(T, len(V))
    u = np.exp(V[:, 2]) + V[:, 0] ** 2
    f, info = solve.dirichlet(L, fixed, u, return_info=True)
    assert info.solver == "amg"
    g = solve.dirichlet(L, fixed, u, solver="cholesky")
    reference = _reference(L, fixed, u)
    assert _relative(f, reference) <= 1e-8 and _relative(g, reference) <= 1e-8
