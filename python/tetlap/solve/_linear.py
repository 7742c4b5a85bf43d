"""The solver layer: one linear system by the solver asked for, or by ``"auto"``'s choice
and fallbacks, and what every answer passes (the residual check).

``"auto"`` tries, in order: ``"amg"`` for symmetric systems of at least ``AUTO_AMG_MIN``
unknowns (CG stops with an error on a direction of negative curvature, a proof of
indefiniteness, and when it does not converge; a CG answer is returned only when CG
converged and the answer passes the residual check), then
``"cholesky"`` (``LL^T``, or ``LDL^T`` when that finds the system indefinite), then
``"lu"``; each failure is recorded in ``info.fallbacks``. A solver asked for by name is the
only one tried.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp

from .. import _interrupt
from ..analysis import NSD_RTOL
from ..errors import SolveError
from . import _amg, _checks
from .factor import Factor

#: Smallest system (unknowns) for which ``"auto"`` tries AMG first: below it a sparse
#: Cholesky is faster (measured: 26k unknowns, AMG 0.5 s, nested dissection + LL^T 0.9 s;
#: 1.5k unknowns, the factorization is 5x faster) and exact to rounding.
AUTO_AMG_MIN = 10_000


def certified(A: sp.csr_array) -> bool:
    """Whether the symmetric ``A`` is certified positive semidefinite by diagonal
    dominance (Gershgorin), up to the tolerance of :func:`tetlap.check`:
    ``A_ii (1 + NSD_RTOL) >= sum_j |A_ij|`` for every row. It holds for the Dirichlet
    block of every operator with non-negative weights (the dual of a Delaunay mesh)."""
    diagonal = A.diagonal()
    off = np.asarray(abs(A).sum(axis=1)).ravel() - np.abs(diagonal)
    return bool((diagonal >= 0).all() and (diagonal * (1 + NSD_RTOL) >= off).all())


def _lu(A, b, info):
    info.solver, info.method, info.ordering, info.iterations = "lu", "SuperLU", "colamd", None
    with info.phase("factorization"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a singular matrix is reported by the check
        return np.atleast_1d(_interrupt.spsolve(sp.csc_array(A), b))


def _refined(A, b, info, progress):
    """The cholesky solve, refined in extended precision when its answer is finite."""
    F = factor(A, "cholesky", info, progress)
    if F._tiny is not None:
        raise SolveError(F._tiny)
    with info.phase("solve"):
        x = F._raw(b[:, None])[:, 0]
        if np.isfinite(x).all():
            x = _checks.refine(A, x, b, lambda r: F._raw(r[:, None])[:, 0])
    return x


def factor(A, solver: str, info, progress) -> Factor:
    """The :class:`Factor` of ``A`` by ``solver`` ("cholesky" or "lu"), its phases, method
    and fallbacks recorded in ``info``."""
    F = Factor(A, solver, "auto", progress)
    for name, seconds in F.info.phases.items():
        info.phases[name] = info.phases.get(name, 0.0) + seconds
    info.solver, info.method, info.ordering, info.iterations = F.info.solver, F.info.method, F.info.ordering, None
    info.fallbacks += F.info.fallbacks
    return F


def solve(A: sp.csr_array, b: np.ndarray, what: str, *, solver: str, info, progress=None,
          symmetric: bool = True) -> np.ndarray:
    """``x`` with ``A x = b`` that passes the residual check, by ``solver`` (see the module
    docstring); ``A`` is the positive form of the system (e.g. ``-L_FF``) when symmetric."""
    n = A.shape[0]
    if solver == "auto":
        order = (["amg"] if symmetric and n >= AUTO_AMG_MIN else []) + \
            (["cholesky"] if symmetric else []) + ["lu"]
    else:
        order = [solver]
    if symmetric and "amg" in order:
        info.certified = certified(A)
    norm = _checks.row_norm(A)
    for k, name in enumerate(order):
        try:
            if name == "amg":
                x = _amg.solve(A, b, info, progress)
            elif name == "cholesky":
                x = _refined(A, b, info, progress)
            else:
                x = _lu(A, b, info)
            info.residual = 0.0
            return _checks.accept(A, x, b, what, info, norm)
        except (SolveError, _amg.Failed) as e:
            if k == len(order) - 1:
                if solver == "auto" or isinstance(e, SolveError):
                    raise SolveError(str(e) + _tried(info)) from None
                raise SolveError(f"the {what}: {e}; solver=\"cholesky\" or \"lu\" solve "
                                 "indefinite and ill-conditioned systems") from None
            info.fallbacks.append(f"{name}: {e}")
    raise AssertionError("unreachable")


def _tried(info) -> str:
    return f" (after {'; '.join(info.fallbacks)})" if info.fallbacks else ""
