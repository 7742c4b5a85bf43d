"""The checks of what the solvers take (masks, values, options) and of what they return
(the one residual rule)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _arrays, _options
from ..errors import DtypeError, NonFiniteError, OptionError, ShapeError, SolveError

#: Largest relative residual ``|A x - b|_inf / (|A|_inf |x|_inf + |b|_inf)`` accepted.
RESIDUAL_TOL = 1e-8
#: A matrix is singular to working precision when its Jacobi-scaled condition number is
#: proved to be at least ``1 / PIVOT_RTOL`` (7e13), where an answer may be wrong in its
#: leading digits although its residual is small (the pure Neumann ``-L``, singular, gave
#: answers of 1e17 that passed the residual check). Two proofs: a pivot of a factorization
#: at most this fraction of its row's diagonal entry (the ratio does not change under a
#: diagonal scaling; ``Factor``), and an answer ``x`` much larger than its data
#: (:func:`condition_bound`, every solve).
PIVOT_RTOL = 64 * float(np.finfo(np.float64).eps)
#: The solvers of every function of :mod:`tetlap.solve`.
SOLVERS = ("auto", "amg", "cholesky", "lu")


def solver(name, allowed=SOLVERS) -> str:
    if not isinstance(name, str) or name not in allowed:
        raise OptionError(f"solver must be one of {', '.join(map(repr, allowed))}, got {name!r}")
    return name


def flag(value, name: str):
    """``value`` if it is True, False (or None where None means "when stderr is a terminal")."""
    if value is not None and not isinstance(value, (bool, np.bool_)):
        raise OptionError(f"{name} must be True, False or None, got {value!r}")
    return value


def rtol(value, name: str = "rtol") -> float:
    return float(_options.tolerance(value, name))


def mask(fixed, n: int) -> np.ndarray:
    return _arrays.vertex_mask(fixed, n, "fixed", once=True)   # values may follow them


def values(v, fixed: np.ndarray) -> np.ndarray:
    n = len(fixed)
    v = np.asarray(v) if np.isscalar(v) else _arrays._as_array(v, "values")
    if v.dtype.kind not in "fiub":
        raise DtypeError(f"values must hold real numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    if v.ndim == 0:
        out = np.zeros(n)
        out[fixed] = v
    elif v.shape == (n,):
        out = np.where(fixed, v, 0.0)
    elif v.shape == (int(fixed.sum()),):
        out = np.zeros(n)
        out[fixed] = v
    else:
        raise ShapeError(
            f"values must be a scalar, one per vertex ({n}) or one per fixed vertex "
            f"({int(fixed.sum())}), got shape {v.shape}")
    return _arrays.vector(out, n, "values")


def gauge(g, n: int):
    """``"mean"`` or a checked vertex index."""
    if isinstance(g, str):
        if g != "mean":
            raise OptionError(f'gauge must be "mean" or a vertex index, got {g!r}')
        return g
    return _arrays.vertex_index(g, n, "gauge")


def row_norm(A) -> float:
    """``|A|_inf``: the largest absolute row sum."""
    return float(np.abs(A).sum(axis=1).max()) if A.shape[0] else 0.0


def relative_residual(A, x: np.ndarray, b: np.ndarray, norm: float | None = None) -> float:
    """``|A x - b|_inf / (|A|_inf |x|_inf + |b|_inf)`` (0 for an empty or all-zero system);
    ``x``, ``b`` of shape (n,) or (n, k) (the largest over the columns)."""
    if not len(b):
        return 0.0
    if not np.isfinite(x).all():
        return np.inf
    norm = row_norm(A) if norm is None else norm
    r = np.abs(A @ x - b).max(axis=0)
    scale = norm * np.abs(x).max(axis=0) + np.abs(b).max(axis=0)
    return float(np.max(np.where(scale > 0, r / np.maximum(scale, 1e-300), np.where(r > 0, np.inf, 0.0))))


#: Data whose largest magnitude is at least this is solved scaled by a power of two (exact),
#: so that sums and residuals stay in the float64 range.
LARGE = 2.0**500


def exponent(*arrays: np.ndarray) -> int:
    """The power of two that brings the largest magnitude of ``arrays`` into ``[1, 2)``
    when it is at least :data:`LARGE`, else 0 (ordinary data are solved unscaled, bitwise
    as before)."""
    largest = max((float(np.abs(a).max()) for a in arrays if a.size), default=0.0)
    return int(np.frexp(largest)[1]) - 1 if largest >= LARGE else 0


def unscaled(x: np.ndarray, e: int, what: str) -> np.ndarray:
    """``x 2^e``, or :class:`tetlap.NonFiniteError` when that leaves the float64 range."""
    if e == 0:
        return x
    with np.errstate(over="ignore"):
        x = np.ldexp(x, e)
    if not np.isfinite(x).all():
        raise NonFiniteError(f"the solution of the {what} leaves the float64 range (the "
                             "data are too large for it); scale them down")
    return x


def accept(A, x, b, what: str, info, norm: float | None = None) -> np.ndarray:
    """``x`` if it passes the residual check (the residual goes into ``info``), else
    :class:`tetlap.SolveError` saying why (:class:`tetlap.NonFiniteError` for data so
    large that the solution overflows)."""
    if not np.isfinite(b).all():
        raise NonFiniteError(f"the right-hand side of the {what} leaves the float64 range "
                             "(the values or the right-hand side are too large); scale them "
                             "down")
    with info.phase("check"), np.errstate(over="ignore"):
        res = relative_residual(A, x, b, norm)
    info.residual = max(info.residual, res)
    if not np.isfinite(x).all():
        if exponent(b):
            raise NonFiniteError(f"the solution of the {what} leaves the float64 range (the "
                                 "right-hand side is too large for it); scale the data down")
        raise SolveError(f"the {what} is singular (the solution is not finite)")
    if res > RESIDUAL_TOL:
        raise SolveError(f"the {what} is singular or too ill-conditioned: relative residual "
                         f"{res:.1e} (tolerance {RESIDUAL_TOL:g})")
    with info.phase("check"), np.errstate(over="ignore"):
        kappa = condition_bound(A, x, b)
    if kappa * PIVOT_RTOL >= 1:
        raise SolveError(f"the {what} is singular to working precision: the answer's size "
                         f"proves a (Jacobi-scaled) condition number of at least {kappa:.1e}, "
                         f"where an answer may be wrong in its leading digits (limit "
                         f"{1 / PIVOT_RTOL:.1e})")
    return x


def condition_bound(A, x: np.ndarray, b: np.ndarray) -> float:
    """A lower bound of the condition number of ``S A S`` (``S = diag(|a_ii|^-1/2)``, 1
    where ``a_ii = 0``) proved by ``x`` (n,) or (n, k), with ``A x ~ b``: ``|S A S|_inf
    |S^-1 x|_inf / |S b|_inf``, since ``S^-1 x`` solves ``(S A S) y = S b`` (the largest
    over the columns; 0 for columns with ``b = 0``). Large only when ``x`` is much larger
    than ``b`` in the matrix's own scaling: a direction near the null space."""
    if not len(b):
        return 0.0
    d = np.abs(A.diagonal())
    s = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    norm = float((s * (abs(sp.csr_array(A)) @ s)).max())     # |S A S|_inf, one product
    x, b = x.reshape(len(b), -1), b.reshape(len(b), -1)
    top = norm * np.abs(x / s[:, None]).max(axis=0)
    bottom = np.abs(b * s[:, None]).max(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.max(np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), 0.0)))


def extended_residual(A: sp.csr_array, x: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``b - A x`` (n,) accumulated in extended precision (``np.longdouble``: 64-bit
    mantissas on x86), rounded to float64: the residual of iterative refinement."""
    A = sp.csr_array(A)
    products = A.data.astype(np.longdouble) * np.asarray(x, dtype=np.longdouble)[A.indices]
    sums = np.zeros(A.shape[0], dtype=np.longdouble)
    rows = np.diff(A.indptr) > 0
    if products.size:
        sums[rows] = np.add.reduceat(products, A.indptr[:-1][rows])
    return np.asarray(np.asarray(b, dtype=np.longdouble) - sums, dtype=np.float64)


#: Steps of iterative refinement after a direct solve.
REFINE_STEPS = 2


def refine(A, x: np.ndarray, b: np.ndarray, solve) -> np.ndarray:
    """``x`` improved by ``REFINE_STEPS`` steps of iterative refinement with the residual in
    extended precision: the forward error of a direct solve falls from ``cond(A) * eps``
    towards ``eps`` (measured: 4.5e-8 -> 1e-12 relative on a corpus mesh with
    ``cond(-L_FF) = 1.6e11``)."""
    for _ in range(REFINE_STEPS):
        x = x + solve(extended_residual(A, x, b))
    return x


def components(L: sp.csr_array):
    """Connected components of the graph of the non-zero entries of ``L``, and the
    referenced vertices (rows with a non-zero entry): unreferenced vertices take part in
    no system."""
    from scipy.sparse import csgraph

    nonzero = sp.csr_array((L.data != 0, L.indices.copy(), L.indptr.copy()), shape=L.shape)
    nonzero.eliminate_zeros()
    referenced = np.diff(nonzero.indptr) > 0
    _, labels = csgraph.connected_components(nonzero, directed=False)
    return labels, referenced
