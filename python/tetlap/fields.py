"""Harmonic and biharmonic fields with fixed values, and whether the discrete maximum
principle is proved for the operator they were solved with.

**The proof.** Let ``F`` be the free vertices (in some element, not fixed) and ``B`` the
fixed ones. If every weight ``w_ij = L[i, j]`` on an edge with a free endpoint is ``>= 0``,
``L[i, i] = -sum_j w_ij``, and every free vertex is joined to a fixed vertex by a path of
edges with ``w > 0``, then ``-L_FF`` is an irreducibly (weakly chained) diagonally dominant
M-matrix: ``L_FF f_F = -L_FB f_B`` has one solution, and each ``f_i`` is a weighted average
of its neighbours', so ``min f_B <= f_F <= max f_B`` (for each column). :func:`harmonic`
checks these conditions on the very matrix it solves with: weights in ``[-NEGATIVE_TOL
max|w|, 0)`` (rounding of a zero weight, as :func:`tetlap.check` counts them) are set to 0
and the diagonal is the negated sum of the off-diagonals, so the proof applies to it
exactly; what is left is the linear solver's rounding, which :data:`RANGE_RTOL` allows
for when the values outside the range are counted.

Which operators qualify: the dual on a mesh whose faces at free vertices are locally
Delaunay, the weighted dual with :func:`tetlap.regular_weights` on a regular mesh, and
the primal where its cotangent weights happen to be non-negative (acute dihedral angles).

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.ball(500, seed=0)
>>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
>>> r = tetlap.harmonic(V, T, fixed, V[fixed, 0] > 0)      # 1 on one half, 0 on the other
>>> r.laplacian, r.proved, r.out_of_range
('dual', True, 0)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from . import _arrays, _core, _options, analysis, assembly
from ._float_range import frame_exponent
from .regular import regular_weights
from .solve import factorize
from .errors import DtypeError, NonFiniteError, OptionError, ShapeError, SolveError, TetlapError
from ._names import public_dir

__all__ = ["harmonic", "Harmonic", "RANGE_RTOL", "maximum_principle"]
__dir__ = public_dir(globals())

#: A value counts as outside the range ``[lo, hi]`` of the fixed values (per column) when
#: it is beyond it by more than ``RANGE_RTOL * max(hi - lo, |lo|, |hi|)``: the linear
#: solver's rounding, not a failure of the maximum principle.
RANGE_RTOL = 1e-10


class Harmonic(NamedTuple):
    """The result of :func:`harmonic`."""

    #: (n,) or (n, c) float64: the field (the fixed values on fixed vertices, 0 on
    #: vertices in no element).
    field: np.ndarray
    #: The operator solved with: "primal", "dual", an affine t, or "weighted dual".
    laplacian: str | float
    #: The vertex weights of the weighted dual (from :func:`tetlap.regular_weights` with
    #: ``"auto"``), else None.
    weights: np.ndarray | None
    #: Whether the maximum principle is proved for the matrix solved with (module docs).
    proved: bool
    #: Free values outside the range of the fixed values (per column, summed over the
    #: columns), beyond :data:`RANGE_RTOL`.
    out_of_range: int
    #: Why the principle is proved or not, in words.
    reason: str


def _fixed(fixed, values, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(indices, values)``: the fixed vertices, ``values`` float64 ``(n_fixed,)`` or
    ``(n_fixed, c)`` in the same order (ascending for a boolean mask)."""
    f = _arrays._as_array(fixed, "fixed")
    if f.size == 0:
        raise ShapeError("fixed is empty: a harmonic field needs at least one fixed vertex")
    if f.dtype == bool:
        if f.shape != (n,):
            raise ShapeError(f"a boolean `fixed` must have shape ({n},), got {f.shape}")
        idx = np.flatnonzero(f)
    elif f.dtype.kind in "iu" and f.ndim == 1:
        if f.size and (f.min() < 0 or f.max() >= n):
            bad = int(f[(f < 0) | (f >= n)][0])
            raise _arrays.not_a_vertex("fixed holds", bad, n)
        idx = f.astype(np.int64)
        if len(np.unique(idx)) != len(idx):
            raise OptionError("fixed holds a vertex twice")
    else:
        raise DtypeError("fixed must be a boolean mask (n,) or a 1-D array of vertex indices")
    if not len(idx):
        raise ShapeError("fixed holds no vertex: a harmonic field needs at least one")
    v = _arrays._as_array(values, "values")
    if v.dtype.kind not in "fiub":
        raise DtypeError(f"values must hold real numbers, got dtype {v.dtype}")
    if v.ndim not in (1, 2) or v.shape[0] != len(idx):
        raise ShapeError(f"values must have shape ({len(idx)},) or ({len(idx)}, c), one row "
                         f"per fixed vertex, got {v.shape}")
    v = np.array(v, dtype=np.float64)
    if not np.isfinite(v).all():
        row = int(np.flatnonzero(~np.isfinite(v.reshape(len(v), -1)).all(axis=1))[0])
        raise NonFiniteError(f"values[{row}] is not finite")
    return idx, v


def maximum_principle(L, fixed: np.ndarray, used: np.ndarray) -> tuple[sp.csr_array, bool, str]:
    """``(L', proved, reason)``: ``L`` with the rounding of zero weights removed (weights in
    ``[-NEGATIVE_TOL max|w|, 0)`` set to 0, the diagonal the negated sum of the
    off-diagonals), and whether the conditions of the module's proof hold for ``L'`` with
    the free vertices ``used & ~fixed`` (bool masks ``(n,)``). ``L`` (n, n) is a tetlap
    Laplacian (``L[i, i] = -sum_j w_ij``); the stiffness sign ``-L`` is refused
    (:class:`tetlap.OptionError`).

    >>> import tetlap, numpy as np
    >>> V, T = tetlap.meshes.cube(3)
    >>> fixed = np.zeros(len(V), bool); fixed[tetlap.diagnostics.boundary_vertices(V, T)] = True
    >>> maximum_principle(tetlap.laplacian(V, T, "dual"), fixed, np.ones(len(V), bool))[1:]
    (True, 'every weight at a free vertex is >= 0 and every free vertex reaches a fixed one through positive weights')
    """
    L = _arrays.laplacian(L)
    n = L.shape[0]
    return _maximum_principle(L, _arrays.vertex_mask(fixed, n, "fixed"),
                              _arrays.vertex_mask(used, n, "used"))


def _maximum_principle(L, fixed: np.ndarray, used: np.ndarray):
    """:func:`maximum_principle` of an operator that tetlap assembled (not checked)."""
    n = L.shape[0]
    A = sp.coo_array(L)
    off = A.row != A.col
    r, c, w = A.row[off], A.col[off], A.data[off].copy()
    scale = np.abs(w).max() if len(w) else 0.0
    w[(w < 0) & (w >= -analysis.NEGATIVE_TOL * scale)] = 0.0
    diag = -np.bincount(r, weights=w, minlength=n)
    clean = sp.csr_array((np.concatenate([w, diag]), (np.concatenate([r, np.arange(n)]),
                                                      np.concatenate([c, np.arange(n)]))),
                         shape=(n, n))
    free = used & ~fixed
    at_free = free[r] | free[c]
    negative = int(((w < 0) & at_free).sum()) // 2
    if negative:
        return clean, False, (f"{negative} edges with a free endpoint have a negative weight "
                              "(beyond rounding)")
    positive = at_free & (w > 0)
    graph = sp.coo_array((np.ones(int(positive.sum())), (r[positive], c[positive])), shape=(n, n))
    _, labels = csgraph.connected_components(graph, directed=False)
    reached = np.zeros(labels.max() + 1, dtype=bool)
    reached[labels[fixed]] = True
    stranded = free & ~reached[labels]
    if stranded.any():
        v = int(np.flatnonzero(stranded)[0])
        return clean, False, (f"{int(stranded.sum())} free vertices (vertex {v} first) reach "
                              "no fixed vertex through positive weights")
    return clean, True, ("every weight at a free vertex is >= 0 and every free vertex "
                         "reaches a fixed one through positive weights")


def _solve(Q, idx: np.ndarray, values: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``x`` with ``x[idx] = values`` and ``Q_FF x_F = -Q_FB x_B`` on the free vertices,
    every column with one factorization (:func:`tetlap.solve.factorize`, which checks every
    column's residual). A Laplacian ``Q`` (negative diagonal) is factorized as ``-Q``, so
    that the Cholesky sees a positive definite matrix."""
    n = Q.shape[0]
    x = np.zeros((n,) + values.shape[1:])
    x[idx] = values
    if not free.any():
        return x
    Q = sp.csr_array(Q)
    if Q.diagonal().sum() < 0:
        Q = -Q
    F = np.flatnonzero(free)
    x[F] = factorize(Q[F][:, F]).solve(-(Q[F] @ x))
    return x


def _out_of_range(x: np.ndarray, values: np.ndarray, free: np.ndarray) -> int:
    lo, hi = values.min(axis=0), values.max(axis=0)
    tol = RANGE_RTOL * np.maximum(hi - lo, np.maximum(np.abs(lo), np.abs(hi)))
    xf = x[free]
    return int(((xf < lo - tol) | (xf > hi + tol)).sum())


@_options.renamed(dual_boundary="boundary_centres")
@_arrays.takes_mesh_object
def harmonic(V, T=None, fixed=None, values=None, *, k: int = 1, laplacian="auto",
             weights=None, boundary_centres="circumcentric", degenerate="raise",
             threads=None) -> Harmonic:
    """The (k-)harmonic field with ``values`` on ``fixed`` vertices.

    ``k = 1``: ``L f = 0`` on the free vertices, the minimiser of the Dirichlet energy
    ``-f^T L f``; ``k = 2``: ``L M^-1 L f = 0`` (biharmonic, as libigl's ``harmonic(V, T,
    b, bc, 2)``: the barycentric mass ``M``), and so on for larger ``k``.

    Parameters
    ----------
    V, T
        The mesh, as :func:`tetlap.laplacian` takes it (or one mesh object as ``V``).
    fixed : (n,) bool mask or 1-D int array of distinct vertex indices
        The fixed vertices (at least one per connected component).
    values : (n_fixed,) or (n_fixed, c) array-like of real numbers
        One row per fixed vertex: ``values[i]`` is the value at ``fixed[i]``, in the order
        given (ascending vertex order for a mask); ``c`` columns give ``c`` fields at once
        (harmonic coordinates), one factorization.
    k : int >= 1, default 1
        The power of the Laplacian.
    laplacian : "auto", "primal", "dual" or float in [0, 1], default "auto"
        With ``k = 1``, ``"auto"`` takes the first operator for which the maximum principle
        is proved (module docs): the plain dual, else the weighted dual with
        :func:`tetlap.regular_weights` (tets), else the primal (then ``proved`` is False and
        ``reason`` says why the others failed, including a mesh whose regular weights
        :func:`tetlap.regular_weights` refuses, e.g. beyond the float64 range in its
        units). With ``k >= 2`` ``"auto"`` is the primal.
        Any other kind is used as given, the proof checked for it.
    weights : (n,) array-like, optional
        Vertex weights of a weighted dual for an explicit ``laplacian``.
    boundary_centres, degenerate, threads
        As for :func:`tetlap.laplacian` (``boundary_centres`` was ``dual_boundary`` until
        0.1; that name still works, deprecated).

    Returns
    -------
    Harmonic
        ``field`` (n,) or (n, c); ``laplacian``, ``weights``, ``proved``,
        ``out_of_range``, ``reason``. Vertices in no element get 0 and count nowhere. The
        operators are assembled in the mesh scaled by a power of two to unit size (exact),
        so that the field of a mesh scaled by ``2^j`` is bitwise the same and every scale
        from 1e-150 to 1e150 computes (the biharmonic's mass left float64 beyond 1e100).

    Raises
    ------
    tetlap.SolveError
        A component with free vertices and no fixed one, or a singular system.
    tetlap.TetlapError
        Bad ``fixed``, ``values`` or options (the subclass says which).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(4)
    >>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
    >>> r = tetlap.harmonic(V, T, fixed, np.stack([V[fixed, 0], V[fixed, 1] ** 2], 1))
    >>> r.field.shape, bool(np.allclose(r.field[:, 0], V[:, 0]))    # linear: reproduced
    ((125, 2), True)
    >>> tetlap.harmonic(V, T, fixed, V[fixed, 0], k=2).proved
    False
    """
    if fixed is None or values is None:
        raise TypeError("harmonic() needs fixed and values")
    k = _options.count(k, "k")
    if isinstance(laplacian, str) and laplacian not in ("auto", "primal", "dual"):
        raise OptionError(f'laplacian must be "auto", "primal", "dual" or a float in [0, 1], '
                          f'got {laplacian!r}')
    if laplacian == "auto" and weights is not None:
        raise OptionError('weights need an explicit laplacian ("dual"); "auto" finds its own')
    V, T = _arrays.mesh(V, T)
    V, T = _arrays.points(V), _arrays.elements(T)
    n = len(V)
    _arrays.in_range(T, n, "element")
    idx, vals = _fixed(fixed, values, n)
    fixed_mask = np.zeros(n, dtype=bool)
    fixed_mask[idx] = True
    options = dict(boundary_centres=boundary_centres, degenerate=degenerate, threads=threads)
    in_use, T_used = _arrays.used_vertices(V, T)
    used = np.zeros(n, dtype=bool)
    used[in_use] = True
    free = used & ~fixed_mask
    # the operators of the mesh scaled to unit size by 2^-e (exact): the field and the
    # proof do not depend on the scale, the operators' float64 range does
    e = frame_exponent(V[in_use], T_used)
    unit = np.ldexp(V, -e)

    def operator(kind, w=None):
        w = None if w is None else np.ldexp(_arrays.vertex_weights(w, n), -2 * e)
        return assembly.laplacian(unit, T, kind, weights=w, **options)

    _check_components(T, fixed_mask, free)
    L0 = operator("primal" if laplacian == "auto" else laplacian, weights)
    if k >= 2:
        kind = "primal" if laplacian == "auto" else laplacian
        M = assembly.mass(unit, T, "barycentric", **options).diagonal()
        Minv = sp.diags_array(np.divide(1.0, M, out=np.zeros(n), where=M > 0))
        Q = -L0
        for _ in range(k - 1):
            Q = Q @ Minv @ -L0
        x = _solve(Q, idx, vals, free)
        return Harmonic(x, kind, weights, False, _out_of_range(x, vals, free),
                        f"no maximum principle is known for k = {k}")
    if laplacian != "auto":
        clean, proved, reason = _maximum_principle(L0, fixed_mask, used)
        x = _solve(clean, idx, vals, free)
        w = None if weights is None else _arrays.vertex_weights(weights, n)
        return Harmonic(x, laplacian, w, proved, _out_of_range(x, vals, free), reason)
    clean, proved, reason = _maximum_principle(operator("dual"), fixed_mask, used)
    if proved:
        x = _solve(clean, idx, vals, free)
        return Harmonic(x, "dual", None, True, _out_of_range(x, vals, free), reason)
    why = [f"dual: {reason}"]
    if T.shape[1] == 4 and V.shape[1] == 3:
        try:
            r = regular_weights(V, T, threads=threads)
        except TetlapError as refused:   # the mesh's weights beyond float64, ...
            r = None
            why.append(f"regular_weights: {refused}")
        if r is None:
            pass
        elif np.any(r.weights != 0):   # "not regular" gives w = 0: the plain dual
            wclean, wproved, wreason = _maximum_principle(operator("dual", r.weights),
                                                         fixed_mask, used)
            if wproved:
                x = _solve(wclean, idx, vals, free)
                return Harmonic(x, "weighted dual", r.weights, True,
                                _out_of_range(x, vals, free),
                                f"{wreason} (weighted dual, regular_weights: {r.status})")
            why.append(f"weighted dual ({r.status}): {wreason}")
        else:
            why.append(f"regular_weights: {r.status}")
    clean, proved, reason = _maximum_principle(L0, fixed_mask, used)
    x = _solve(clean, idx, vals, free)
    text = ("no operator with the proof's conditions was found (" + "; ".join(why)
            + f"); primal: {reason}")
    return Harmonic(x, "primal", None, proved, _out_of_range(x, vals, free),
                    reason if proved else text)


def _check_components(T: np.ndarray, fixed: np.ndarray, free: np.ndarray) -> None:
    """SolveError naming a component of the mesh with free vertices and no fixed one."""
    n = len(fixed)
    E = _core.edges(T, n)
    graph = sp.coo_array((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    _, labels = csgraph.connected_components(graph, directed=False)
    has_fixed = np.zeros(labels.max() + 1, dtype=bool)
    has_fixed[labels[fixed]] = True
    stranded = free & ~has_fixed[labels]
    if stranded.any():
        v = int(np.flatnonzero(stranded)[0])
        raise SolveError(f"the component of vertex {v} has no fixed vertex: the field is "
                         "not determined there (fix a vertex of it)")
