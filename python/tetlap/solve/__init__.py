"""Boundary-value and eigenvalue problems with tetlap's operators (paper Sec. 6, 8), on a
solver layer chosen for the problem.

Sign convention as everywhere in tetlap: ``L`` is the paper's Laplacian (``L[i, i] =
-sum_j w_ij``), so ``-L`` is positive semidefinite for the primal; ``L f = b`` discretises
``Laplace(f) = b`` integrated over vertex cells. A matrix with the other sign (a stiffness
matrix, non-negative diagonal) is refused with an :class:`tetlap.OptionError`. Data paired
with vertex indices keep the user's order: ``f[fixed[i]] = values[i]``.

Every function takes ``solver=`` (``"auto"``, ``"amg"``, ``"cholesky"``, ``"lu"``: what each
costs and when to pick it is in :func:`dirichlet` and :doc:`/project/scaling`), ``progress=`` and
``return_info=`` (a :class:`SolveInfo`: solver, ordering, iterations, residual, phase
times). Every function checks its input like the operators do (shapes, finiteness, index
ranges, options: the :mod:`tetlap.errors` classes) and checks what it returns: a
solution is finite and its relative residual ``|A x - b| / (|A| |x| + |b|)`` (infinity
norms) is at most ``RESIDUAL_TOL`` (1e-8), else :class:`tetlap.SolveError` says why; a
component of the mesh without a constraint where one is needed is named before anything
is solved. CG is used where the system is positive definite, which it proves to be by
running (a direction of negative curvature stops it, and ``"auto"`` moves on to a
factorization); its answers pass the same residual check as every other. Vertices in no
element (no edge in ``L``) take part in no system, and data there other than 0 are
refused. Matrices scaled by ``2^-1000 .. 2^1000`` and meshes from 1e-150 to 1e150 are
solved in frames scaled by powers of two (exact), with the unit answers scaled. Long solves answer Ctrl-C within a second. What each
solver costs: :doc:`/guide/solving`.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.cube(4, jitter=0.2)
>>> L = tetlap.laplacian(V, T, "dual")
>>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
>>> f = tetlap.solve.dirichlet(L, fixed, V[:, 0] + 2 * V[:, 1])   # a linear function
>>> bool(np.allclose(f, V[:, 0] + 2 * V[:, 1]))                   # is reproduced
True
"""

from __future__ import annotations

from ..errors import CompatibilityError, SolveError
from ._checks import RESIDUAL_TOL, SOLVERS
from ._boundary import dual_boundary_areas, fem_boundary_areas
from ._dirichlet import dirichlet
from ._eigs import eigs
from .factor import PIVOT_RTOL, Factor, factorize
from .info import SolveInfo
from ._neumann import neumann, neumann_primal_kkt
from .._names import public_dir

__all__ = [
    "dirichlet",
    "neumann",
    "neumann_primal_kkt",
    "eigs",
    "factorize",
    "Factor",
    "SolveInfo",
    "dual_boundary_areas",
    "fem_boundary_areas",
    "CompatibilityError",
    "SolveError",
    "RESIDUAL_TOL",
    "PIVOT_RTOL",
    "SOLVERS",
]
__dir__ = public_dir(globals())
