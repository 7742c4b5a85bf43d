"""``solver="amg"``: pyamg's conjugate gradients preconditioned by its smoothed
aggregation, on a positive (semi)definite system in reverse Cuthill-McKee order.

The options were measured (BENCHMARKS.md, "Solving"): the prolongation smoothed by Jacobi
with local (Gershgorin) weights, not by pyamg's default estimate of the spectral radius,
which starts from NumPy's global random state (the answer would change from call to call;
the local weights take as many iterations); one forward Gauss-Seidel sweep
before and one backward sweep after each coarse-grid correction (a symmetric V-cycle at
half the smoothing cost of pyamg's default symmetric sweeps), the rows renumbered by
reverse Cuthill-McKee (faster sweeps, and better aggregates), the BLAS held to one thread
(its threads cost more than they give on vectors of this size), and CG stopped at the
relative residual ``CG_RTOL``, which keeps solutions within 1e-8 of SuperLU's on the
corpus and on 1M tets.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp

from .._blas import one_blas_thread
from .._progress import _interactive
from . import _checks

#: The relative 2-norm residual ``|b - A x| / |b|`` at which CG stops.
CG_RTOL = 1e-10
#: The most CG iterations before giving up (the residual check decides what then).
CG_MAXITER = 400


def hierarchy(A: sp.csr_array):
    """pyamg's smoothed aggregation hierarchy of a symmetric ``A`` with the options above,
    none of which draws from NumPy's global random stream (its default prolongation
    smoother does: different bits on every call, and the caller's stream advanced)."""
    import pyamg

    return pyamg.smoothed_aggregation_solver(
        A, symmetry="symmetric", smooth=("jacobi", {"weighting": "local"}),
        presmoother=("gauss_seidel", {"sweep": "forward"}),
        postsmoother=("gauss_seidel", {"sweep": "backward"}))


class Failed(Exception):
    """CG found ``p^T A p < 0`` (a proof that ``A`` or its preconditioner is not positive
    definite), or did not reach ``CG_RTOL`` in ``CG_MAXITER`` iterations (an ill-conditioned
    system, whose answer would pass the residual check far from the solution: measured
    1e-3 off on a corpus mesh with condition number 1.6e11)."""


def solve(A: sp.csr_array, b: np.ndarray, info, progress=None) -> np.ndarray:
    """``x`` with ``A x ~ b`` for a symmetric positive definite ``A`` (n, n) and ``b``
    (n,), by AMG-preconditioned CG; the iterations go into ``info``. Unchecked: the caller
    checks the residual."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    info.solver, info.method, info.ordering = "amg", "cg + smoothed aggregation", "reverse Cuthill-McKee"
    # A 2^-a and b 2^-c in pyamg's range (exact): x = 2^(c - a) (A 2^-a)^-1 (b 2^-c)
    a = _checks.band_exponent(_checks.row_norm(A))
    c = _checks.band_exponent(float(np.abs(b).max(initial=0.0)))
    if a:
        A = sp.csr_array((np.ldexp(A.data, -a), A.indices, A.indptr), shape=A.shape)
    b = np.ldexp(b, -c)
    with one_blas_thread():
        with info.phase("ordering"):
            perm = reverse_cuthill_mckee(A, symmetric_mode=True)
            Ap = A[perm][:, perm].tocsr()
        with info.phase("setup"):
            ml = hierarchy(Ap)
        residuals: list[float] = []
        bar = _bar(progress)
        callback = _Progress(bar, residuals) if bar is not None else None
        # recorded, not shown: an indefinite matrix is reported below (pyamg's cg puts an
        # "always" filter of its own first, so an "ignore" filter would not hold)
        with info.phase("solve"), warnings.catch_warnings(record=True):
            try:
                xp, code = ml.solve(b[perm], tol=CG_RTOL, maxiter=CG_MAXITER, accel="cg",
                                    residuals=residuals, callback=callback, return_info=True)
            finally:
                if bar is not None:
                    bar.close()
    info.iterations = max(len(residuals) - 1, 0)
    if code < 0:
        raise Failed(f"CG met a direction of non-positive curvature after {info.iterations} "
                     "iterations: the system is not positive definite")
    if code > 0:
        raise Failed(f"CG did not reach the relative residual {CG_RTOL:g} in {CG_MAXITER} "
                     "iterations: the system is too ill-conditioned for it")
    x = np.empty_like(b)
    x[perm] = xp
    with np.errstate(over="ignore", under="ignore"):
        return np.ldexp(x, c - a)


#: The bar's total: the decimal digits CG gains on the relative residual.
DIGITS = -np.log10(CG_RTOL)


class _Progress:
    """CG's callback that moves ``bar`` to the most digits gained so far on the relative
    residual, ``log10(|r_0| / |r_k|)`` out of :data:`DIGITS` (full when CG converges;
    the iteration cap, ``CG_MAXITER``, is no measure of progress: CG stopped at a tenth
    of it), with the iterations beside it."""

    def __init__(self, bar, residuals: list) -> None:
        self.bar, self.residuals = bar, residuals

    def __call__(self, x) -> None:
        first, last = self.residuals[0], self.residuals[-1]
        gained = DIGITS if last <= 0 else float(np.clip(np.log10(first / last), 0.0, DIGITS))
        self.bar.set_postfix_str(f"{len(self.residuals) - 1} iterations", refresh=False)
        self.bar.update(max(gained - self.bar.n, 0.0))


def _bar(progress):
    if not (progress if progress is not None else _interactive()):
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    import sys

    return tqdm(total=DIGITS, desc="CG residual digits", file=sys.stderr, leave=False,
                bar_format="{desc}: {bar} {n:.1f}/{total:.0f} [{postfix}]")
