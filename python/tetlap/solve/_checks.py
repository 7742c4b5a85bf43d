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


def flag(value, name: str, unset: bool = True):
    """``value`` if it is True or False (or None, where ``unset`` allows it: "when stderr
    is a terminal"), else :class:`tetlap.OptionError`: a flag is never read from a truthy
    object (a string, a list, 1)."""
    if (value is None and unset) or isinstance(value, (bool, np.bool_)):
        return None if value is None else bool(value)
    choices = "True, False or None" if unset else "True or False"
    raise OptionError(f"{name} must be {choices}, got {value!r}")


def rtol(value, name: str = "rtol") -> float:
    return float(_options.tolerance(value, name))


def mask(fixed, n: int) -> np.ndarray:
    return _arrays.vertex_mask(fixed, n, "fixed", once=True)   # values may follow them


def fixed(given, n: int) -> np.ndarray:
    """The fixed vertices as int64 indices in the user's order: integer indices as given
    (each once), a boolean mask ``(n,)`` in ascending order."""
    mask(given, n)                       # the checks: shape, dtype, range, each index once
    arr = _arrays._as_array(given, "fixed")
    if arr.dtype == bool:
        return np.flatnonzero(arr)
    return arr.astype(np.int64).reshape(-1)


def values(v, fixed: np.ndarray, n: int) -> np.ndarray:
    """``values`` as an (n,) float64 array ``out`` with ``out[fixed[i]] = values[i]`` (one
    value per fixed vertex, paired in the order of ``fixed``), or ``out[j] = values[j]``
    on the fixed vertices for one value per vertex, or a scalar on all; 0 elsewhere.
    ``fixed`` int64 indices (:func:`fixed`). One value per vertex and one per fixed vertex
    have the same shape when every vertex is fixed: given in another order than
    ascending, the two readings differ and the values are refused (ShapeError)."""
    v = np.asarray(v) if np.isscalar(v) else _arrays._as_array(v, "values")
    if v.dtype.kind not in "fiub":
        raise DtypeError(f"values must hold real numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    out = np.zeros(n)
    k = len(fixed)
    if v.shape == (k,) and v.shape == (n,) and (fixed != np.arange(n)).any():
        raise ShapeError(
            f"values has one entry per vertex and one per fixed vertex ({n}): with the "
            "fixed vertices in another order than ascending, the two readings differ; pass "
            "fixed as a boolean mask or in ascending order")
    if v.ndim == 0:
        given, at = np.full(k, v), np.zeros(k, dtype=np.int64)
    elif v.shape == (k,):
        given, at = v, np.arange(k)
    elif v.shape == (n,):
        given, at = v[fixed], fixed
    else:
        raise ShapeError(
            f"values must be a scalar, one per vertex ({n}) or one per fixed vertex "
            f"({k}), got shape {v.shape}")
    bad = np.flatnonzero(~np.isfinite(given))
    if bad.size:
        where = "values" if v.ndim == 0 else f"values[{int(at[bad[0]])}]"
        raise NonFiniteError(f"{where} is not finite ({given[bad[0]]})", vertex=int(fixed[bad[0]]))
    out[fixed] = given
    return out


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
    ``x``, ``b`` of shape (n,) or (n, k) (the largest over the columns). Evaluated in
    binary exponents, so that no product or sum of norms overflows or underflows (a
    matrix scaled by ``2^1000`` or ``2^-1000`` gets the residual of the unscaled one)."""
    if not b.size:
        return 0.0
    if not np.isfinite(x).all():
        return np.inf
    norm = row_norm(A) if norm is None else norm
    with np.errstate(over="ignore", invalid="ignore"):
        r = np.abs(A @ x - b).max(axis=0)
    r = np.where(np.isnan(r), np.inf, r)
    return float(np.max(ratio(r, norm * np.ones_like(r), np.abs(x).max(axis=0),
                              np.abs(b).max(axis=0))))


def ratio(r, a, x, b) -> np.ndarray:
    """``r / (a x + b)`` for non-negative arrays, the denominator formed in frexp
    exponents (it neither overflows nor underflows); 0 where ``r = 0``, inf where ``r >
    0`` and the denominator is 0."""
    ma, ea = np.frexp(np.asarray(a, dtype=np.float64))
    mx, ex = np.frexp(np.asarray(x, dtype=np.float64))
    mb, eb = np.frexp(np.asarray(b, dtype=np.float64))
    product, ep = ma * mx, ea + ex                         # a x = product 2^ep
    lowest = np.iinfo(np.int32).min // 2
    top = np.maximum(np.where(product > 0, ep, lowest), np.where(mb > 0, eb, lowest))
    top = np.where(top == lowest, 0, top)
    denominator = np.ldexp(product, np.maximum(ep - top, lowest)) + \
        np.ldexp(mb, np.maximum(eb - top, lowest))
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        q = np.ldexp(np.asarray(r, dtype=np.float64), -top) / denominator
    return np.where(denominator > 0, q, np.where(np.asarray(r) > 0, np.inf, 0.0))


#: Data whose largest magnitude is at least this is solved scaled by a power of two (exact),
#: so that sums and residuals stay in the float64 range.
LARGE = 2.0**500


def exponent(*arrays: np.ndarray) -> int:
    """The power of two that brings the largest magnitude of ``arrays`` into ``[1, 2)``
    when it is at least :data:`LARGE`, else 0 (ordinary data are solved unscaled, bitwise
    as before)."""
    largest = max((float(np.abs(a).max()) for a in arrays if a.size), default=0.0)
    return int(np.frexp(largest)[1]) - 1 if largest >= LARGE else 0


#: A solver whose set-up multiplies entries together (pyamg's) gets a matrix and a
#: right-hand side whose largest magnitudes lie outside ``[1 / BAND, BAND]`` scaled by a
#: power of two (exact): unscaled, it failed from ``2^600`` and below ``2^-600``.
BAND = 2.0**256


def band_exponent(largest: float) -> int:
    """0 when ``largest`` is 0 or in ``[1 / BAND, BAND]`` (ordinary data, solved as
    given), else the power of two that brings it into ``[1, 2)``."""
    if largest == 0 or 1 / BAND <= largest <= BAND:
        return 0
    return int(np.frexp(largest)[1]) - 1


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


def accept(A, x, b, what: str, info, norm: float | None = None,
           condition: bool = True) -> np.ndarray:
    """``x`` if it passes the residual check (the residual goes into ``info``) and, with
    ``condition``, the condition bound (:func:`condition_bound`; off for a system solved for
    a chosen one of many solutions), else :class:`tetlap.SolveError` saying why
    (:class:`tetlap.NonFiniteError` for data so large that the solution overflows)."""
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
    if not condition:
        return x
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
    if not b.size:
        return 0.0
    d = np.abs(A.diagonal())
    s = np.where(d > 0, 1.0 / np.sqrt(np.where(d > 0, d, 1.0)), 1.0)
    with np.errstate(over="ignore"):
        norm = float((s * (abs(sp.csr_array(A)) @ s)).max())     # |S A S|_inf, one product
    x, b = x.reshape(len(b), -1), b.reshape(len(b), -1)
    top = np.abs(x / s[:, None]).max(axis=0)
    bottom = np.abs(b * s[:, None]).max(axis=0)
    # norm top / bottom, without overflow: 1 / ratio(bottom, norm, top, 0)
    with np.errstate(divide="ignore"):
        bound = 1.0 / ratio(bottom, norm * np.ones_like(top), top, np.zeros_like(top))
    return float(np.max(np.where(bottom > 0, bound, 0.0)))


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
    """Connected components of the graph of the non-zero entries of ``L`` (the equations
    that couple vertices), and the referenced vertices: those with an edge, a stored
    off-diagonal entry (explicit zeros included), as tetlap's Laplacians store every edge
    of the elements and a diagonal entry for every vertex. Vertices without an edge are
    in no element and take part in no system, whatever their diagonal holds; a vertex in
    an element whose edges all weigh 0 is a component of its own."""
    from scipy.sparse import csgraph

    rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
    edge = rows != L.indices
    referenced = np.zeros(L.shape[0], dtype=bool)
    referenced[rows[edge]] = True
    nonzero = sp.csr_array((L.data != 0, L.indices.copy(), L.indptr.copy()), shape=L.shape)
    nonzero.eliminate_zeros()
    _, labels = csgraph.connected_components(nonzero, directed=False)
    return labels, referenced


def off_the_mesh(data: np.ndarray, referenced: np.ndarray, name: str) -> None:
    """:class:`tetlap.SolveError` naming the first vertex in no element (not
    ``referenced``) where ``data`` (n,) is not 0: no equation holds it (it is never
    dropped silently)."""
    bad = ~referenced & (data != 0)
    if bad.any():
        v = int(np.argmax(bad))
        raise SolveError(f"vertex {v} belongs to no element but has {name} {data[v]:g} != 0: "
                         "no equation takes it (set it to 0, or add the vertex's elements)")
