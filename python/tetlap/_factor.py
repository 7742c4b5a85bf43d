"""The one factorization the jobs (:mod:`tetlap.heat`, :mod:`tetlap.fields`) use.

A stand-in for ``tetlap.solve.factorize`` (issue 28), which the solver layer provides:
**at merge time, replace the body of** :func:`factorize` **by** ``return
tetlap.solve.factorize(A)`` (or import it under this name) and delete the rest of this
module; every caller factors through this one function and uses only ``.solve(b)`` on
``(n,)`` and ``(n, k)`` right-hand sides.

Until then it is SciPy's SuperLU with a symmetric ordering (the jobs' matrices are
symmetric: Laplacians, mass plus Laplacian, their restrictions to free vertices), its
factorization and solves run so that Ctrl-C answers (:mod:`tetlap._interrupt`).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ._interrupt import interruptible
from .errors import SolveError


class _Factor:
    """A factorization of a square sparse ``A``: ``.solve(b)`` for ``(n,)`` or ``(n, k)``
    ``b``."""

    def __init__(self, A) -> None:
        A = sp.csc_array(A, dtype=np.float64)
        self.shape = A.shape
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self._lu = interruptible(splu, A, permc_spec="MMD_AT_PLUS_A",
                                         diag_pivot_thresh=0.1,
                                         options={"SymmetricMode": True})
        except RuntimeError as e:  # "Factor is exactly singular"
            raise SolveError(f"the matrix cannot be factorized: {e}") from None

    def solve(self, b) -> np.ndarray:
        x = interruptible(self._lu.solve, np.asarray(b, dtype=np.float64))
        if not np.isfinite(x).all():
            raise SolveError("the matrix is singular (the solution is not finite)")
        return x


def factorize(A) -> _Factor:
    """A reusable factorization of the square sparse matrix ``A`` (see the module
    docstring: at merge time this becomes ``tetlap.solve.factorize``).

    >>> import numpy as np, scipy.sparse as sp
    >>> F = factorize(sp.diags_array([2.0, 4.0]).tocsc())
    >>> F.solve(np.array([1.0, 1.0])).tolist()
    [0.5, 0.25]
    """
    return _Factor(A)
