"""Sparse factorizations users can keep: :func:`factorize` and :class:`Factor`.

A :class:`Factor` holds the core's sparse ``LL^T`` or ``LDL^T`` (faer, run without the GIL
on one thread, bitwise reproducible) of a symmetric matrix, or SciPy's SuperLU of any
square one, with the fill-reducing ordering computed once: nested dissection (METIS,
through pymetis) by default, whose factors of 3-D meshes hold 2.5x fewer entries than
AMD's (BENCHMARKS.md, "Solving"). :meth:`Factor.refactor` takes new values on the same
pattern (a time step ``M - t L``, a moved mesh) and reuses the symbolic analysis.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.cube(4)
>>> L, M = tetlap.operators(V, T, "primal", "barycentric")
>>> F = tetlap.solve.factorize(M - 0.01 * L)             # an implicit heat step
>>> u = F.solve(np.ones(len(V)))                          # (n,) -> (n,)
>>> U = F.solve(np.eye(len(V))[:, :3])                    # (n, k) -> (n, k)
>>> bool(np.allclose((M - 0.01 * L) @ U, np.eye(len(V))[:, :3]))
True
>>> F.refactor(M - 0.02 * L)                              # same pattern: no new analysis
>>> F.info.solver, F.info.method
('cholesky', 'LL^T')
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _arrays, _core, _interrupt, _sparse
from .._progress import Stages
from ..errors import DtypeError, OptionError, ShapeError, SolveError
from . import _checks
from .info import SolveInfo
from .._names import public_dir

__all__ = ["factorize", "Factor", "ORDERINGS", "nested_dissection"]
__dir__ = public_dir(globals())

#: Fill-reducing orderings of :func:`factorize`.
ORDERINGS = ("auto", "nd", "amd")


#: A pivot at most :data:`PIVOT_RTOL` of its row's diagonal entry makes a factorization
#: singular to working precision (``Factor.solve`` refuses it). An ``LDL^T`` (no pivoting)
#: with such a pivot hands over to SuperLU, whose pivots are measured against
#: ``sqrt(|a_ii a_jj|)`` of their row ``i`` and column ``j``.
PIVOT_RTOL = _checks.PIVOT_RTOL


#: From this many rows on, METIS runs in a forked child process (0.05 to 0.2 s to fork) so
#: that Ctrl-C is answered during it (pymetis holds the GIL: 0.35 s at 24k rows, 1.7 s at
#: 100k, 2.4 s at 1M tets).
METIS_CHILD_MIN = 20_000


def nested_dissection(A: sp.csr_array) -> np.ndarray | None:
    """The METIS nested-dissection order of the graph of ``A`` (int64 permutation: entry
    ``k`` is the row eliminated ``k``-th), or None when pymetis is not installed."""
    try:
        import pymetis  # noqa: F401
    except ImportError:
        return None
    from . import _metis

    G = sp.csr_array((np.ones(A.nnz), A.indices.copy(), A.indptr.copy()), shape=A.shape)
    G = sp.csr_array(G + G.T)  # METIS reads a symmetric graph only (else: hangs, crashes)
    G.setdiag(0)
    G.eliminate_zeros()
    G.sort_indices()
    if G.nnz == 0:
        return np.arange(A.shape[0], dtype=np.int64)
    xadj, adjncy = G.indptr.astype(np.int32), G.indices.astype(np.int32)
    if A.shape[0] >= METIS_CHILD_MIN:
        return _metis.order_in_child(xadj, adjncy)
    return _metis.order(xadj, adjncy)


def canonical(A) -> sp.csr_array:
    """``A`` as a float64 csr_array with summed duplicates, sorted indices and no spare
    capacity (the layout the core reads)."""
    A = sp.csr_array(A, dtype=np.float64)
    A.sum_duplicates()
    A.sort_indices()
    A.prune()
    return A


def _symmetric(A: sp.csr_array) -> bool:
    asym = abs(A - A.T)
    return not asym.nnz or asym.max() <= 1e-12 * abs(A).max()


class Factor:
    """A factorization of an ``(n, n)`` matrix, made by :func:`factorize`.

    ``solve(b)`` solves for ``(n,)`` or ``(n, k)`` right-hand sides and checks every
    answer's residual (:data:`tetlap.solve.RESIDUAL_TOL`); ``refactor(A)`` factorizes new
    values on the same pattern (entries may be missing, none may be added); ``inertia()``
    counts the eigenvalue signs; ``info`` is a :class:`tetlap.solve.SolveInfo`.
    """

    def __init__(self, A: sp.csr_array, solver: str, ordering, progress,
                 method: str = "auto") -> None:
        A = canonical(A)
        self.n = A.shape[0]
        self.info = SolveInfo(solver=solver)
        self._progress = progress
        self._A = A
        self._norm = _checks.row_norm(A)
        self._core = None
        self._lu = None
        self._order = None
        self._tiny: str | None = None      # why the factorization is singular, if it is
        if solver == "cholesky":
            self._factor_core(A, ordering, method)
        else:
            self._factor_lu(A)

    def _factor_core(self, A, ordering, method):
        stages = Stages("factorize", self._progress)
        if not isinstance(ordering, str):
            self._order = ordering
            self.info.ordering = "given"
        else:
            if ordering in ("auto", "nd"):
                stages("nested dissection")
                with self.info.phase("ordering"):
                    self._order = nested_dissection(A)
                if self._order is None and ordering == "nd":
                    raise OptionError('ordering="nd": METIS failed, or pymetis is not '
                                      'installed (pip install pymetis)')
            self.info.ordering = "amd" if self._order is None else "nested dissection (METIS)"
        stages("factorization")
        with self.info.phase("factorization"):
            try:
                if method == "ldlt":
                    raise SolveError("an LDL^T was asked for")
                self._core = _core.Factor(self.n, _sparse.arrays(A), "cholesky", self._order)
                self.info.method = "LL^T"
            except SolveError as e:
                if method != "ldlt":
                    self.info.fallbacks.append(f"LL^T: {e}")
                self._core = _core.Factor(self.n, _sparse.arrays(A), "ldlt", self._order)
                self.info.method = "LDL^T"
        self._tiny = self._smallest_pivot()
        stages.done()

    def _smallest_pivot(self) -> str | None:
        """Why the factorization is singular to working precision (:data:`PIVOT_RTOL`), or
        None."""
        if self._core is not None:
            row, ratio = self._core.smallest_pivot()
        else:
            # Pr A Pc = L U: pivot k sits in row argsort(perm_r)[k], column argsort(perm_c)[k]
            rows, cols = np.argsort(self._lu.perm_r), np.argsort(self._lu.perm_c)
            root = np.sqrt(np.abs(self._A.diagonal()))
            # |u_kk| / sqrt(|a_ii a_jj|) as two divisions: no product overflows (a
            # diagonal of 1e155) or underflows
            with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
                ratios = np.abs(self._lu.U.diagonal()) / root[rows] / root[cols]
            ratios = np.where((root[rows] > 0) & (root[cols] > 0), ratios, np.inf)
            k = int(np.argmin(ratios)) if len(ratios) else 0
            row, ratio = (int(rows[k]), float(ratios[k])) if len(ratios) else (0, np.inf)
        if ratio > PIVOT_RTOL:
            return None
        return (f"the matrix is singular to working precision: the pivot of row {row} is "
                f"{ratio:.1e} of its diagonal entry ({self.info.method})")

    def _factor_lu(self, A):
        self.info.solver, self.info.method, self.info.ordering = "lu", "SuperLU", "colamd"
        with self.info.phase("factorization"):
            try:
                self._lu = _interrupt.splu(sp.csc_array(A))
            except RuntimeError as e:  # "Factor is exactly singular"
                raise SolveError(f"the matrix is singular (SuperLU: {e})") from None
            self._tiny = self._smallest_pivot()

    def refactor(self, A) -> None:
        """Factorizes new values ``A`` (``(n, n)``, non-zeros within the pattern of the
        factorized matrix), reusing the ordering and the symbolic analysis; a cholesky
        factorization takes symmetric values only (:class:`tetlap.OptionError`)."""
        A = _arrays.matrix(A, self.n, "A")
        if self._core is None:
            # no factor until the new one is complete: one interrupted or refused leaves a
            # Factor that says so, not the old factor checked against the new values
            self._A, self._norm, self._lu = A, _checks.row_norm(A), None
            self._tiny = "the last refactor did not complete: refactor again before solving"
            self._factor_lu(A)
            return
        data = _within(A, self._A)
        if not _symmetric(A):
            raise OptionError("refactor: the matrix is not symmetric, and this factorization "
                              f"is a {self.info.method} of symmetric ones; factorize it anew "
                              "with solver=\"lu\"")
        old = self._A
        self._A = sp.csr_array((data, old.indices, old.indptr), shape=old.shape)
        self._norm = _checks.row_norm(self._A)
        with self.info.phase("factorization"):
            try:
                self._core.refactor(self.n, _sparse.arrays(self._A))
            except SolveError as e:
                if self.info.method != "LL^T":
                    raise
                self.info.fallbacks.append(f"LL^T: {e}")
                self._core = _core.Factor(self.n, _sparse.arrays(self._A), "ldlt", self._order)
                self.info.method = "LDL^T"
        self._tiny = self._smallest_pivot()

    def _raw(self, b: np.ndarray) -> np.ndarray:
        """The solution for ``b`` (n, k), unchecked."""
        if self._lu is not None:
            return self._lu.solve(b)
        return self._core.solve(np.ascontiguousarray(b.T)).T

    def _to_lu(self, why: str) -> None:
        """SuperLU instead of an ``LDL^T`` without pivoting, which is not backward stable on
        indefinite matrices."""
        self.info.fallbacks.append(f"LDL^T: {why}")
        self._core = None
        self._factor_lu(self._A)

    def solve(self, b) -> np.ndarray:
        """``x`` with ``A x = b`` for ``b`` of shape ``(n,)`` or ``(n, k)`` (float64, a new
        array of the shape of ``b``; ``k = 0`` and ``n = 0`` give an empty one), each column
        residual-checked; :class:`tetlap.SolveError` if one fails or the matrix is singular
        to working precision (:data:`PIVOT_RTOL`)."""
        arr = _arrays._as_array(b, "b")
        if arr.ndim not in (1, 2) or arr.shape[0] != self.n:
            raise ShapeError(f"b must have shape ({self.n},) or ({self.n}, k), got {arr.shape}")
        if arr.size == 0:               # n = 0, or no column: nothing to solve
            if arr.dtype.kind not in "fiub":
                raise DtypeError(f"b must hold real numbers, got dtype {arr.dtype}")
            return np.zeros(arr.shape)
        flat = arr.reshape(self.n, -1)
        flat = np.column_stack([_arrays.vector(flat[:, j], self.n, "b") for j in range(flat.shape[1])]) \
            if flat.shape[1] else np.zeros((self.n, 0))
        if self._tiny is not None and self._core is not None and self.info.method == "LDL^T":
            self._to_lu(self._tiny)
        if self._tiny is not None:
            raise SolveError(self._tiny)
        with self.info.phase("solve"):
            x = self._raw(flat) if flat.shape[1] else flat.copy()
        try:
            _checks.accept(self._A, x, flat, "factorized system", self.info, self._norm)
        except SolveError:
            if self._core is None or self.info.method == "LL^T":
                raise
            self._to_lu("the residual check failed")
            if self._tiny is not None:
                raise SolveError(self._tiny) from None
            with self.info.phase("solve"):
                x = self._raw(flat)
            _checks.accept(self._A, x, flat, "factorized system", self.info, self._norm)
        return x.reshape(arr.shape)

    @property
    def permutation(self) -> np.ndarray | None:
        """The fill-reducing order of the cholesky factorization (int64 ``(n,)``: entry
        ``k`` is the row eliminated ``k``-th; a copy), or None (faer's AMD, or ``"lu"``).
        Pass it (restricted and renumbered as needed) as ``ordering=`` of another
        factorization of the same graph to skip the nested dissection."""
        return None if self._order is None else self._order.copy()

    def inertia(self) -> tuple[int, int, int]:
        """``(negative, zero, positive)`` pivots of the ``LDL^T`` (``LL^T``: all positive):
        by Sylvester's law of inertia, the eigenvalue signs of the matrix. Not available
        for ``"lu"``."""
        if self._core is None:
            raise OptionError("inertia() needs the cholesky factorization (solver='cholesky')")
        return self._core.inertia()

    def __repr__(self) -> str:
        return f"<Factor n={self.n} {self.info.solver} {self.info.method} ordering={self.info.ordering}>"


def _within(A: sp.csr_array, pattern: sp.csr_array) -> np.ndarray:
    """The values of ``A`` on the stored entries of ``pattern`` (zero where ``A`` has none);
    ShapeError if ``A`` has a non-zero outside it."""
    n = A.shape[0]
    rows = lambda M: np.repeat(np.arange(n, dtype=np.int64), np.diff(M.indptr))
    old = rows(pattern) * n + pattern.indices
    new = rows(A) * n + A.indices
    pos = np.minimum(np.searchsorted(old, new), max(len(old) - 1, 0))
    outside = (old[pos] != new) & (A.data != 0) if len(old) else A.data != 0
    if outside.any():
        raise ShapeError("refactor: the matrix has a non-zero outside the factorized pattern "
                         "(call factorize for the new pattern)")
    data = np.zeros(len(old))
    keep = old[pos] == new if len(old) else np.zeros(len(new), dtype=bool)
    data[pos[keep]] = A.data[keep]
    return data


def _ordering(ordering, n: int):
    """``ordering`` checked: one of :data:`ORDERINGS`, or a permutation of ``0..n-1`` as
    a new int64 array."""
    if isinstance(ordering, str):
        if ordering not in ORDERINGS:
            raise OptionError(f"ordering must be one of {', '.join(map(repr, ORDERINGS))} or a "
                              f"permutation, got {ordering!r}")
        return ordering
    perm = _arrays._as_array(ordering, "ordering")
    if perm.dtype.kind not in "iu" or perm.shape != (n,):
        raise OptionError(f"ordering must be one of {', '.join(map(repr, ORDERINGS))} or a "
                          f"permutation of 0..{n - 1} (an integer array of shape ({n},))")
    perm = perm.astype(np.int64)
    seen = np.zeros(n, dtype=bool)
    inside = (perm >= 0) & (perm < n)
    seen[perm[inside]] = True
    if not (inside.all() and seen.all()):
        raise OptionError(f"ordering is not a permutation of 0..{n - 1}")
    return perm


def factorize(A, *, solver: str = "auto", ordering="auto", progress=None) -> Factor:
    """A reusable factorization of the square sparse matrix ``A``.

    Parameters
    ----------
    A : (n, n) SciPy sparse array or matrix
        Any square real matrix (not modified), e.g. ``M - t L`` of a heat step.
    solver : {"auto", "cholesky", "lu"}, default "auto"
        ``"cholesky"``: the core's sparse ``LL^T`` of a symmetric matrix, or its
        ``LDL^T`` (no pivoting) when the ``LL^T`` finds it indefinite; ``"lu"``: SciPy's
        SuperLU (any square matrix, far more fill on 3-D meshes); ``"auto"``: cholesky for
        symmetric matrices, else lu. ``"amg"`` is not a factorization.
    ordering : {"auto", "nd", "amd"} or (n,) integer array, default "auto"
        The fill-reducing ordering of the cholesky factorization: METIS nested dissection
        (``"nd"``; ``"auto"`` uses it when pymetis is installed), faer's AMD, or a
        permutation of ``0..n-1`` (entry ``k`` the row eliminated ``k``-th), such as the
        :attr:`Factor.permutation` of a factorization of the same graph.
    progress : bool, optional
        Report the phases on stderr (default: when stderr is a terminal).

    Returns
    -------
    Factor
        ``.solve(b)``, ``.refactor(A)``, ``.inertia()``, ``.info``.

    Cost: :doc:`/guide/solving` (the nested dissection and the ``LL^T``, each further solve
    and the factor's memory on a 974k-tet ball, as multiples of one assembly, with the
    command to rerun). Ctrl-C is answered within 0.1 s and leaves nothing running: on
    Linux a large factorization (and METIS) runs in a child process, killed on Ctrl-C.
    Where fork is not available (Windows, macOS), Ctrl-C waits for the cholesky
    factorization and METIS to end, and an interrupted SuperLU finishes in the background.
    """
    A = _arrays.matrix(A, None, "A")
    _checks.solver(solver, ("auto", "cholesky", "lu"))
    ordering = _ordering(ordering, A.shape[0])
    _checks.flag(progress, "progress")
    symmetric = _symmetric(A)
    if solver == "cholesky" and not symmetric:
        raise OptionError('solver="cholesky" needs a symmetric matrix; use solver="lu"')
    if solver == "auto":
        solver = "cholesky" if symmetric else "lu"
    if not isinstance(ordering, str) and solver == "lu":
        raise OptionError("a permutation as ordering= is for the cholesky factorization of a "
                          "symmetric matrix")
    return Factor(A, solver, ordering, progress)
