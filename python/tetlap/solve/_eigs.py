"""Eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30): the k smallest, the k nearest a
shift, or every pair in an interval, each set proved complete by Sylvester's law of
inertia, independently of the search that found it."""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import scipy.sparse as sp

from .. import _arrays, _interrupt, _options
from .._blas import one_blas_thread
from .._progress import Stages
from ..errors import NonFiniteError, OptionError, SolveError
from . import _amg, _checks, _lanczos
from .factor import Factor
from .info import SolveInfo

#: Up to this many free vertices eigs solves the dense generalized problem (all
#: eigenvalues, so the selection needs no further proof).
DENSE_MAX = 400
#: The search stops when every wanted Ritz pair of the shift-inverted operator ``T`` has
#: ``|T y - theta y|_B <= SEARCH_TOL |theta|`` (pair residuals of the pencil then near
#: 1e-13; every pair is checked against :data:`tetlap.solve.RESIDUAL_TOL` afterwards).
SEARCH_TOL = 3e-11
#: Eigenvalues closer than this (relative to the largest magnitude involved) are a
#: cluster: no count is placed between them.
CLUSTER_RTOL = 1e-6
#: A connected component without a fixed vertex whose constant vector ``1`` has
#: ``|A 1|_inf <= NULL_RTOL |A|_inf`` (zero row sums, up to rounding) has the eigenvalue 0
#: with the constant mode, returned exactly.
NULL_RTOL = 1e-10
#: Up to this many free vertices, a search whose basis would hold most of them (many pairs
#: of a small problem) is replaced by the dense problem.
DENSE_LARGE = 6000
#: The most pairs one search wants: more pairs are found in segments (spectrum slicing),
#: each certified by a count at its end, whose factorization serves the next search.
SEGMENT = 10**9
#: Restarts after which a search of a sweep that is still short of its pairs returns the
#: ones it found first, and the sweep moves its shift to them (an indefinite dual whose
#: negative eigenvalues spread far below 0; many pairs).
PATIENCE = 6
#: The first shift of the search for the smallest lies this fraction of an upper bound of
#: the smallest eigenvalue below 0 (:meth:`_Problem.start`).
START_RTOL = 1e-3
#: Pairs a search of the k smallest wants beyond k (none: a value of a cluster beyond the
#: k-th would have to converge too, and the proof places its count just above the k-th).
GUARD = 0
#: The basis of a search holds about this many vectors per wanted pair.
BASIS = 2.0
#: Searches after the first when the inertia shows eigenvalues the search missed (each
#: with twice the block and more wanted pairs).
RETRIES = 2


def eigs(L, M, k: int | None = None, fixed=None, *, sigma: float | None = None,
         interval=None, solver: str = "auto", progress=None, return_info: bool = False):
    """Eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30): the ``k`` smallest, the ``k``
    nearest ``sigma``, or every pair in ``interval``.

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian in tetlap's sign (``L[i, i] = -sum_j w_ij``; a stiffness matrix ``K =
        -L`` as LaPy and scikit-fem hold it is refused with an :class:`tetlap.OptionError`:
        pass ``-K``), symmetric on the free vertices, not modified; it may be indefinite
        (the dual of a non-Delaunay mesh): its negative eigenvalues are the smallest and are
        returned. Its stored pattern says which vertices belong to an element.
    M : (n, n) SciPy sparse array or matrix
        A mass matrix; ``M_II`` must be positive definite: a mass with a non-positive free
        diagonal entry (circumcentric masses on non-Delaunay meshes) raises
        :class:`tetlap.SolveError` naming the vertex and the mass that works, ``"mixed"``.
        Lumped (diagonal) or consistent (``"fem"``).
    k : int, optional
        Number of eigenpairs, ``1 <= k < n_free`` (default 10; not with ``interval``).
    fixed : (n,) bool mask or integer array, optional
        Dirichlet vertices (e.g. the boundary; ``None``: no constraint). ``I`` are the
        others that belong to an element, i.e. whose row of ``L`` stores an entry off the
        diagonal (vertices in no element take no part, whatever ``M`` holds for them: their
        eigenvector entries are 0).
    sigma : float, optional
        Return the ``k`` eigenpairs nearest ``sigma`` (interior modes; ties at the same
        distance are taken lower first) instead of the smallest.
    interval : (float, float), optional
        Return every eigenpair with ``a <= lambda <= b`` for ``interval=(a, b)``, however
        many (none: empty arrays); their number is certified. The ends are compared with
        the computed eigenvalues: one within rounding of an end may fall on either side
        (put the ends in gaps of the spectrum).
    solver : {"auto", "cholesky", "lu", "amg"}, default "auto"
        The factorization of ``A - s B`` for the shift-invert search: the core's sparse
        ``LL^T``/``LDL^T`` with nested dissection (``"auto"``, ``"cholesky"``) or SuperLU
        (``"lu"``, minutes at 1M tets); the inertia proof always uses the core's
        ``LDL^T``. ``"amg"``: LOBPCG preconditioned by smoothed aggregation for the k
        smallest of a positive definite ``A`` (no factorization for the search; the proof
        still needs one).
    progress : bool, optional
        Phases on stderr, with the pairs converged and the solves done during the search
        (default: when stderr is a terminal).
    return_info : bool, default False
        Also return a :class:`tetlap.solve.SolveInfo`; ``info.verification`` says how the
        set was shown to be complete.

    Returns
    -------
    eigenvalues : (p,) float64, ascending (``p = k``, or the count in ``interval``).
    eigenvectors : (n, p) float64, zero on ``fixed`` and unreferenced vertices,
        M-orthonormal on the free ones; each has its entry of largest magnitude positive
        (the first such entry, in vertex order, when several tie). Without fixed vertices,
        each connected component of the mesh has the eigenvalue 0 exactly, with the
        constant mode ``1 / sqrt(mass of the component)`` on it. Every pair is checked:
        ``|A v - lambda B v| <= 1e-8 (|A| + |lambda| |B|) |v|`` (infinity norms), else
        :class:`tetlap.SolveError`.
    info : SolveInfo, with ``return_info=True``.

    Notes
    -----
    The pencil is solved scaled by powers of two (exact) that bring ``|L|`` and ``|M|``
    near 1, so the answer does not depend on the units: ``L 2^a`` and ``M 2^b`` give the
    eigenvalues times ``2^(a - b)`` and the vectors times ``2^(-b / 2)``
    (:class:`tetlap.NonFiniteError` when the eigenvalues leave the float64 range).

    The search is a block Lanczos iteration on ``(A - s B)^-1 B`` (thick restarts, full
    ``B``-orthogonalization; :mod:`tetlap.solve._lanczos`) with the factorization's
    many-right-hand-side solves; the number of eigenvalues below a shift ``s`` is the
    number of negative pivots of an ``LDL^T`` of ``A - s B`` (Sylvester), whose accuracy a
    solve checks. The set is proved complete by such counts at shifts in gaps between the
    returned values: below the k smallest, around the k nearest ``sigma``, at the ends of
    ``interval``. When ``k`` cuts a cluster of (near-)equal eigenvalues (closer than
    ``1e-6`` relative), a second count below the cluster must find exactly the values
    below it. Otherwise :class:`tetlap.SolveError` says the set could not be certified.
    Up to 400 free vertices the dense generalized problem is solved instead (all
    eigenvalues).

    The result is bitwise the same for any number of threads (the search runs on one BLAS
    thread, in a fixed order). Memory: the factor, the basis (``n_free`` by about ``2 k +
    4 b`` doubles, ``b`` the block size: 4-16), its product with the mass for a consistent
    mass, and the returned vectors: about 3 (lumped mass) to 5 (consistent) ``n`` by ``k``
    blocks beyond the factor. Cost: ``k = 200`` on the 189k-tet ball 14-21 s, 11-16x
    faster than LaPy 1.7 (:doc:`/project/benchmarks`, "Eigenpairs"; the workflow:
    :doc:`/guide/eigenmodes`).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(6)
    >>> L, M = tetlap.operators(V, T, "primal", "barycentric")
    >>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
    >>> lam, vec, info = tetlap.solve.eigs(L, M, 3, fixed, return_info=True)
    >>> bool(lam[0] > 3 * 3.14159**2 * 0.9), vec.shape, info.verification is not None
    (True, (343, 3), True)
    >>> lam, vec = tetlap.solve.eigs(L, M, 2)                 # no fixed vertex
    >>> float(lam[0]), bool(np.allclose(vec[:, 0], 1 / np.sqrt(M.sum())))
    (0.0, True)
    """
    L = _arrays.laplacian(L)
    n = L.shape[0]
    M = _arrays.matrix(M, n, "M")
    fixed = np.zeros(n, dtype=bool) if fixed is None else _checks.mask(fixed, n)
    referenced = _in_elements(L)
    free = np.flatnonzero(~fixed & referenced)
    return_info = _checks.flag(return_info, "return_info", unset=False)
    if len(free) < 2:
        raise OptionError(f"eigs needs at least 2 free vertices (in an element and not fixed), "
                          f"got {len(free)}: the matrices are {n}x{n}")
    if interval is not None:
        if k is not None or sigma is not None:
            raise OptionError("interval= returns every pair in the interval: pass neither k "
                              "nor sigma with it")
        interval = _interval(interval)
    else:
        k = int(_options.count(10 if k is None else k, "k", 1, len(free) - 1))
    if sigma is not None:
        sigma = float(_options.finite(sigma, "sigma"))
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    if solver == "amg" and (sigma is not None or interval is not None):
        raise OptionError('solver="amg" finds the k smallest only (not sigma or interval)')
    A = sp.csr_array(-L[free][:, free])
    B = sp.csr_array(M[free][:, free])
    _symmetric(A, free, "L")
    _symmetric(B, free, "M")
    _positive_diagonal(B, free)
    # the pencil scaled by powers of two (exact): |A|, |B| in [1, 4), so that no tolerance
    # or shift depends on the units; the eigenvalues scale by 2^(eA - eB), the vectors by
    # 2^(-eB / 2) (eB even)
    eA, eB = _exponent(A), _exponent(B, even=True)
    A.data, B.data = np.ldexp(A.data, -eA), np.ldexp(B.data, -eB)
    with np.errstate(over="ignore", under="ignore"):
        if sigma is not None:
            sigma = float(np.ldexp(sigma, eB - eA))
        if interval is not None:
            interval = tuple(float(np.ldexp(x, eB - eA)) for x in interval)
    info = SolveInfo()
    problem = _Problem(A, B, info, Stages("eigs", progress), progress, eA - eB)
    with one_blas_thread():
        if interval is not None:
            lam, vec = problem.interval(*interval, solver)
        elif sigma is not None:
            lam, vec = problem.nearest(k, sigma, solver)
        else:
            lam, vec = problem.smallest(k, solver)
        problem.stages.done()
        if problem.F is not None:
            for name, seconds in problem.F.info.phases.items():
                info.phases[name] = info.phases.get(name, 0.0) + seconds
        _check_pairs(A, B, lam, vec, info, eA - eB, problem.residuals)
        vec = _signs(vec)
    with np.errstate(over="ignore"):
        lam, vec = np.ldexp(lam, eA - eB), np.ldexp(vec, -eB // 2)
    if not (np.isfinite(lam).all() and np.isfinite(vec).all()):
        raise NonFiniteError("the eigenvalues leave the float64 range (|L| / |M| is too large "
                             "for them); scale L or M")
    full = np.zeros((n, len(lam)))
    full[free] = vec
    return (lam, full, info) if return_info else (lam, full)


def _interval(interval) -> tuple[float, float]:
    try:
        a, b = interval
    except (TypeError, ValueError):
        raise OptionError(f"interval must be a pair (a, b), got {interval!r}") from None
    a, b = _options.finite(a, "interval"), _options.finite(b, "interval")
    if not a <= b:
        raise OptionError(f"interval must have a <= b, got {interval!r}")
    return float(a), float(b)


def _in_elements(L) -> np.ndarray:
    """(n,) bool: the vertices of an element, those whose row of ``L`` stores an entry off
    the diagonal (explicit zeros included: tetlap assembles the pattern from the
    elements, and stores a zero diagonal for a vertex in none). Not the non-empty rows of
    ``L`` or ``M``: a mass such as the identity has rows for every vertex."""
    rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
    referenced = np.zeros(L.shape[0], dtype=bool)
    referenced[rows[L.indices != rows]] = True
    return referenced


def _exponent(X, even: bool = False) -> int:
    """The power of two ``e`` with ``|X|_max 2^-e`` in ``[1, 2)`` (``[1, 4)``, ``e`` even,
    with ``even``); 0 for a zero matrix."""
    largest = float(np.abs(X.data).max()) if X.nnz else 0.0
    e = int(np.frexp(largest)[1]) - 1 if largest > 0 else 0
    return e - e % 2 if even else e


def _symmetric(X, free, name: str) -> None:
    """SolveError naming the largest asymmetry of ``X`` (the free block of ``name``) beyond
    ``1e-12 |X|_max``: the problem is the symmetric ``-L f = lambda M f``."""
    asym = sp.coo_array(X - X.T)
    if not asym.nnz:
        return
    worst = int(np.argmax(np.abs(asym.data)))
    if abs(asym.data[worst]) <= 1e-12 * np.abs(X.data).max():
        return
    i, j = int(asym.row[worst]), int(asym.col[worst])
    sign = -1 if name == "L" else 1
    raise SolveError(
        f"{name} is not symmetric on the free vertices: {name}[{free[i]}, {free[j]}] = "
        f"{sign * X[i, j]:.6g} but {name}[{free[j]}, {free[i]}] = {sign * X[j, i]:.6g}; eigs "
        "solves the symmetric problem -L f = lambda M f (pass L and M themselves, not "
        "M^-1 L)")


def _positive_diagonal(B, free) -> None:
    """SolveError naming a free vertex whose mass ``M[i, i]`` is not positive (no positive
    definite mass has one), however the mass is stored."""
    d = B.diagonal()
    if len(d) and (d <= 0).any():
        bad = int(free[np.argmin(d)])
        raise SolveError(
            f"the mass matrix is not positive on the free vertices: M[{bad}, {bad}] = "
            f"{d.min():.3e} ({int((d <= 0).sum())} entries <= 0); circumcentric masses "
            'can be negative on non-Delaunay meshes: use the mixed mass, '
            'tetlap.mass(V, T, "mixed") (positive on every mesh)')


def _signs(vec: np.ndarray) -> np.ndarray:
    """Each column with its entry of largest magnitude positive (the first, in vertex
    order, among equal magnitudes)."""
    if not vec.size:
        return vec
    top = np.argmax(np.abs(vec), axis=0)
    flip = vec[top, np.arange(vec.shape[1])] < 0
    vec[:, flip] *= -1
    return vec


class _Missed(SolveError):
    """The inertia shows eigenvalues that the search did not return."""


def _null_modes(A: sp.csr_array, B: sp.csr_array) -> np.ndarray:
    """(n, c): the constant mode ``1 / sqrt(1^T B_c 1)`` of every connected component
    ``c`` (of the graph of ``A`` and ``B``) that ``A`` annihilates (zero row sums: no
    fixed vertex; :data:`NULL_RTOL`), zero elsewhere: exact eigenvectors for the
    eigenvalue 0, ``B``-orthonormal (no entry of ``B`` couples two components)."""
    from scipy.sparse import csgraph

    n = A.shape[0]
    G = sp.csr_array(abs(A) + abs(B))
    G.eliminate_zeros()
    count, labels = csgraph.connected_components(G, directed=False)
    worst = np.zeros(count)                 # the largest |row sum| of A in each component
    np.maximum.at(worst, labels, np.abs(np.asarray(A.sum(axis=1)).ravel()))
    null = np.flatnonzero(worst <= NULL_RTOL * _checks.row_norm(A))
    if not len(null):
        return np.zeros((n, 0))
    X = np.zeros((n, len(null)))
    pick = np.searchsorted(null, labels)
    inside = (pick < len(null)) & (null[np.minimum(pick, len(null) - 1)] == labels)
    X[np.flatnonzero(inside), pick[inside]] = 1.0
    mass = np.einsum("ij,ij->j", X, B @ X)
    return X / np.sqrt(mass)[None, :]


class _Problem:
    """``A v = lambda B v`` (scaled) with the pieces every search shares: the exact null
    modes, the factorizations, the counts, the stages and the record."""

    def __init__(self, A, B, info: SolveInfo, stages: Stages, progress, unit: int = 0) -> None:
        self.A, self.B, self.info, self.stages, self.progress = A, B, info, stages, progress
        self.unit = unit                  # eigenvalues in the caller's units: x 2^unit
        self.n = A.shape[0]
        self.X0 = _null_modes(A, B)
        self.mass = _lanczos.Mass(B)
        self.F: Factor | None = None      # the core's factorization (search and counts)
        self.residuals = None             # of the pairs returned, when already computed
        self.scale = float(np.abs(A.data).max(initial=0.0) / np.abs(B.data).max())

    def dense_enough(self, want: int) -> bool:
        """Whether the dense path takes ``want`` pairs: few free vertices, or a ``want``
        whose search basis would hold most of them."""
        if self.n <= DENSE_MAX:
            return True
        if 2 * want + 64 < self.n:
            return False
        if self.n <= DENSE_LARGE:
            return True
        raise OptionError(f"{want} pairs are more than half of the {self.n} free vertices: "
                          "ask for fewer, or an interval")

    def show(self, x: float) -> str:
        """An eigenvalue or shift as the caller reads it (in the units of ``L`` and ``M``)."""
        with np.errstate(over="ignore", under="ignore"):
            return f"{float(np.ldexp(x, self.unit)):.6g}"

    # -- the dense path ---------------------------------------------------------------
    def dense(self):
        """All eigenpairs: the null modes, and LAPACK's on their ``B``-complement."""
        from scipy.linalg import LinAlgError, eigh, null_space

        info = self.info
        info.solver, info.method = "lu", "dense generalized eigensolver (LAPACK)"
        info.verification = "all eigenvalues of the dense generalized problem"
        A, B = self.A.toarray(), self.B.toarray()
        Z = null_space((B @ self.X0).T) if self.X0.shape[1] else np.eye(self.n)
        with info.phase("solve"):
            try:
                lam, y = eigh(Z.T @ A @ Z, Z.T @ B @ Z)
            except LinAlgError as e:
                raise SolveError(f"the eigenproblem could not be solved (the mass is not "
                                 f"positive definite? {e})") from None
        lam = np.concatenate([np.zeros(self.X0.shape[1]), lam])
        vec = np.hstack([self.X0, Z @ y])
        order = np.argsort(lam, kind="stable")
        return lam[order], vec[:, order]

    # -- factorizations and counts ----------------------------------------------------
    def factor(self, s: float) -> Factor:
        """The core's factorization of ``A - s B`` (the ordering and the analysis once)."""
        if self.F is None:
            self.stages("ordering and factorization")
            self.F = Factor(sp.csr_array(self.A - s * self.B), "cholesky", "auto",
                            self.progress, method="ldlt")
            self.info.ordering = self.F.info.ordering
        else:
            self.stages(f"factorization at {self.show(s)}")
            self.F.refactor(self.A - s * self.B)
        return self.F

    def count(self, s: float) -> int:
        """Eigenvalues below ``s``: the negative pivots of an ``LDL^T`` of ``A - s B``,
        whose accuracy a solve of a random right-hand side checks (SolveError if it
        fails)."""
        F = self.factor(s)
        with self.info.phase("inertia"):
            negative = F.inertia()[0]
            probe = np.random.default_rng(1).standard_normal(self.n)
            x = F._raw(probe[:, None])[:, 0]
            res = _checks.relative_residual(sp.csr_array(self.A - s * self.B), x, probe)
        if res > _checks.RESIDUAL_TOL:
            raise SolveError(f"the eigenvalue count could not be certified: the LDL^T of "
                             f"A - s B at s = {self.show(s)} is inaccurate (relative residual "
                             f"{res:.1e})")
        return negative

    def start(self) -> float:
        """The first shift of the search for the smallest: below 0 by :data:`START_RTOL` of
        a Rayleigh quotient ``x^T A x / x^T B x``, an upper bound of the smallest
        eigenvalue that is not a null mode (Courant-Fischer) for a vector ``x`` orthogonal
        to the null modes: ``1`` on the free vertices, or, without fixed vertices, ``+1`` on
        the first half of a breadth-first order of the graph and ``-1`` on the rest. A
        shift far below the smallest eigenvalue squeezes the wanted ones together (a shift
        of -1e-6 of |A| / |B| lay 100 times below it on a 1M-tet cube: 5x the solves)."""
        from scipy.sparse import csgraph

        x = np.ones(self.n)
        if self.X0.shape[1]:
            order = csgraph.breadth_first_order(abs(self.A), 0, directed=False,
                                                return_predecessors=False)
            x = np.zeros(self.n)
            x[order[:len(order) // 2]] = 1.0
            x[order[len(order) // 2:]] = -1.0
            x -= self.X0 @ (self.X0.T @ (self.B @ x))
        with np.errstate(all="ignore"):
            rq = float(x @ (self.A @ x)) / float(x @ (self.B @ x))
        floor = 1e-12 * self.scale
        return -max(START_RTOL * rq, floor) if np.isfinite(rq) and rq > 0 else -1e-6 * self.scale

    def bottom(self) -> float:
        """A shift below the whole spectrum, proved by a count of 0: Gershgorin's bound."""
        bound = _lower_bound(self.A, self.B, self.mass.diagonal is not None)
        shift = bound - 1e-3 * abs(bound) - 1e-12 * self.scale
        if self.count(shift):
            raise SolveError("eigs could not find a shift below the spectrum (the Gershgorin "
                             "bound failed the inertia test)")
        return shift

    # -- the search -------------------------------------------------------------------
    def search(self, shift: float, want: int, key, solver: str, attempt: int,
               deflate: np.ndarray | None = None, patience: int | None = None):
        """``want`` eigenpairs ``B``-orthogonal to ``deflate`` (default: the null modes),
        first by ``key`` (of the eigenvalues; :data:`_lanczos.FAR` and more: unwanted), by
        block Lanczos on ``(A - shift B)^-1 B``: ``(lam, vec)`` unsorted."""
        info = self.info
        deflate = self.X0 if deflate is None else deflate
        n_free = self.n - deflate.shape[1]
        block = _block(want) << attempt
        basis = -(-max(int(BASIS * want) + 2 * block, want + 6 * block) // block) * block
        basis = min(basis, (n_free - 1) // block * block)
        if solver == "lu":
            with info.phase("factorization"):
                lu = _interrupt.splu(sp.csc_array(self.A - shift * self.B))
            solve = lu.solve
            info.solver, info.method = "lu", "block shift-invert Lanczos on SuperLU"
        else:
            F = self.F
            solve = F._raw
            info.solver = "cholesky"
            info.method = f"block shift-invert Lanczos on {F.info.method}"
        self.stages(f"block Lanczos (blocks of {block})")
        ticker = _Ticker(self.stages)

        def report(st):
            ticker(f"{st.converged}/{st.want} pairs converged, {st.solves} solves")

        def keyed(theta):
            with np.errstate(divide="ignore"):
                return key(shift + 1.0 / theta)

        def tol(theta):
            # |A y - lambda B y| = |(A - shift B) r| / |theta| for r = T y - theta y: the
            # pencil's residual relative to |A| + |lambda| |B| is at most SEARCH_TOL
            with np.errstate(divide="ignore"):
                lam = np.abs(shift + 1.0 / theta)
            # (far from the shift this may be out of reach: the sweep then moves its shift)
            return SEARCH_TOL * np.abs(theta) * np.minimum(
                (self.scale + lam) / (self.scale + abs(shift)), 1.0)

        with info.phase("solve"):
            theta, Y, _, st = _lanczos.search(
                solve, self.mass, self.n, want=want, key=keyed, block=block, basis=basis,
                tol=tol, X0=deflate, rng=np.random.default_rng(attempt),
                progress=report, patience=patience)
        ticker.close(f"{st.converged}/{st.want} pairs converged, {st.solves} solves")
        info.iterations = (info.iterations or 0) + st.solves
        if st.converged < want and patience is None:
            raise _Missed(f"the search did not converge: {st.converged} of {want} pairs after "
                          f"{st.restarts} restarts")
        return shift + 1.0 / theta, np.asarray(Y)

    def found(self, lam, vec):
        """The search's pairs with the null modes, ascending."""
        lam = np.concatenate([np.zeros(self.X0.shape[1]), lam])
        vec = np.hstack([self.X0, vec])
        order = np.argsort(lam, kind="stable")
        return lam[order], vec[:, order]

    def gap(self, lam: np.ndarray, s: float) -> float:
        """The cluster width at ``s``: :data:`CLUSTER_RTOL` of the magnitudes involved."""
        top = float(np.abs(lam).max()) if len(lam) else 0.0
        return CLUSTER_RTOL * max(abs(s), top) + 1e-9 * self.scale

    # -- the three selections ---------------------------------------------------------
    def retried(self, attempt_once):
        """``attempt_once(attempt)`` until it returns: a search that missed pairs (the
        inertia says so, or it did not converge) is repeated up to :data:`RETRIES` times
        with twice the block and more pairs; then SolveError."""
        for attempt in range(RETRIES + 1):
            try:
                return attempt_once(attempt)
            except _Missed as e:
                if attempt == RETRIES:
                    raise SolveError(str(e)) from None
                self.info.fallbacks.append(f"search {attempt + 1}: {e}")

    def smallest(self, k: int, solver: str):
        if self.dense_enough(k):
            lam, vec = self.dense()
            return lam[:k], vec[:, :k]
        if solver == "amg":
            return self.smallest_amg(k)
        start = self.start()
        negative = self.count(start)
        if negative:
            # an indefinite A: the sweep starts below the spectrum (the eigenvalues below
            # 0 can lie far below, where a search from near 0 cannot resolve them)
            self.info.fallbacks.append(f"{negative} eigenvalues lie below the shift "
                                       f"{self.show(start)}")
            start = self.bottom()
        return self.sweep(start, 0, k, None, None, solver)

    def sweep(self, lo: float, nlo: int, k: int, hi: float | None, nhi: int | None,
              solver: str):
        """The ``k`` smallest eigenpairs above ``lo`` (below ``hi`` when given), ascending;
        ``nlo`` (``nhi``) eigenvalues lie below ``lo`` (``hi``). Segments of at most
        :data:`SEGMENT` pairs: a search at the segment's start ``s`` (its factorization in
        ``self.F``) for the pairs just above it, the previous segment's pairs deflated; the
        next start ``s'`` in a gap above the values found, where a count must find exactly
        the eigenvalues below ``s'`` found so far (and its factorization serves the next
        search). Spectrum slicing: every segment is certified as it is computed, and the
        basis holds one segment."""
        shifts = [lo]
        lam_all, vec_all, res_all = [np.zeros(0)], [np.zeros((self.n, 0))], [np.zeros(0)]
        s, ns, need = lo, nlo, k
        last = np.zeros((self.n, 0))            # the previous segment's vectors
        note = ""
        while need > 0:
            m = min(need, SEGMENT)
            zeros = self.X0.shape[1] if s < 0 else 0   # null modes above s (0 < the next)

            def once(attempt, s=s, ns=ns, m=m, zeros=zeros, last=last, need=need):
                if attempt:
                    self.factor(s)
                guard = GUARD + 8 * attempt
                above = lambda lam: np.where(lam > s, lam - s, _lanczos.FAR + s - lam)  # noqa: E731
                want = max(m - zeros, 0) + guard
                lam, vec = self.search(s, want, above, solver, attempt,
                                       deflate=np.hstack([self.X0, last]), patience=PATIENCE)
                keep = lam > s
                lam, vec = lam[keep], vec[:, keep]
                if zeros and (lam > 0).any():      # the null modes lie among the values
                    lam, vec = self.found(lam, vec)
                order = np.argsort(lam, kind="stable")
                lam, vec = lam[order], vec[:, order]
                # pairs far from the shift may miss the accuracy rule: the sweep takes the
                # ones before the first that does, and moves its shift to the others
                res = _residuals(self.A, self.B, lam, vec)
                good = res <= _checks.RESIDUAL_TOL / 16
                usable = int(np.argmin(good)) if not good.all() else len(lam)
                lam, vec, s_next, n_next, note = self.segment(s, ns, lam, vec, m, need, hi,
                                                              nhi, usable)
                return lam, vec, res[:len(lam)], s_next, n_next, note

            lam, vec, res, s_next, n_next, note = self.retried(once)
            lam_all.append(lam)
            vec_all.append(vec)
            res_all.append(res)
            shifts.append(s_next)
            need -= len(lam)
            last = vec[:, lam != 0] if zeros else vec
            s, ns = s_next, n_next
            if hi is not None and s >= hi:
                break
        lam = np.concatenate(lam_all)
        vec = np.hstack(vec_all)
        res = np.concatenate(res_all)
        if len(shifts) > 2:
            lam, vec, res = self.separate(lam, vec, res)
        total = len(lam)
        lam, vec = lam[:k], vec[:, :k]
        self.residuals = res[:k]
        self.info.verification = (
            f"Sylvester inertia: the LDL^T of A - s B at s = {self.show(s)} has {ns} negative "
            f"pivots, {ns - nlo} above s = {self.show(lo)}, and all {total} were found (counts at "
            f"{len(shifts)} shifts){note}")
        return lam, vec

    def segment(self, s, ns, lam, vec, m, need, hi, nhi, usable=None):
        """One segment of :meth:`sweep`: ``(lam, vec, s', n', note)`` for the values above
        ``s`` found (ascending; ``m`` wanted, ``need`` still missing in the sweep; the first
        ``usable`` accurate enough), or _Missed when a count shows values the search did
        not return."""
        usable = len(lam) if usable is None else usable
        m = min(m, usable)            # a search that stalled: the pairs it found first
        if m:
            delta = self.gap(lam[:m], lam[m - 1])
            end = m
            while end < len(lam) and lam[end] - lam[end - 1] <= delta:
                end += 1
            if end > usable:          # a cluster with an inaccurate member: all or none
                m = end = int(np.searchsorted(lam, lam[m - 1] - delta))
        if not m:
            raise _Missed(f"the search found no accurate pair above s = {self.show(s)}")
        delta = self.gap(lam[:m], lam[m - 1])
        if (hi is not None and (lam[end - 1] >= hi or end >= need)
                and (lam < hi).sum() <= usable):
            end = int((lam < hi).sum())
            s_next, n_next = hi, nhi
        else:
            s_next = (lam[end - 1] + lam[end]) / 2 if end < len(lam) else lam[end - 1] + delta
            n_next = self.count(s_next)
        between = f"between s = {self.show(s)} and {self.show(s_next)}"
        if n_next - ns == end:
            return lam[:end], vec[:, :end], s_next, n_next, ""
        if n_next - ns < end:
            raise SolveError(f"the eigenvalues could not be certified: {n_next - ns} lie "
                             f"{between}, {end} were found")
        if end < len(lam) or hi is not None:
            raise _Missed(f"the eigenvalues could not be certified: {n_next - ns} lie "
                          f"{between}, but {end} were found (the search missed some)")
        # the cluster of lam[m-1] reaches past the values found (m cuts a cluster): a count
        # just below the cluster must find exactly the values below it; the others lie
        # within the cluster's width
        top = lam[m - 1]
        low = top - delta
        start = int(np.searchsorted(lam, low))
        below = self.count(low)
        if below - ns != start:
            raise _Missed(f"the eigenvalues could not be certified: {below - ns} lie between "
                          f"s = {self.show(s)} and {self.show(low)}, but {start} were found "
                          "(the search missed some)")
        note = (f"; a cluster of {n_next - below} values at {self.show(top)}, {m - start} of "
                "them returned")
        self.factor(s_next)
        return lam[:m], vec[:, :m], s_next, n_next, note

    def smallest_amg(self, k: int):
        sizes = sorted({k, min(k + 4, self.n - 1), min(2 * k + 8, self.n - 1)})

        def once(attempt):
            m = sizes[min(attempt, len(sizes) - 1)]
            lam, vec = _lobpcg(self.A, self.B, m - self.X0.shape[1], self.info, self.X0)
            lam, vec = self.found(lam, vec)
            self.stages("inertia proof")
            lam, vec, s, n, note = self.segment(-np.inf, 0, lam, vec, k, k, None, None)
            self.info.verification = (f"Sylvester inertia: the LDL^T of A - s B at s = "
                                      f"{self.show(s)} has {n} negative pivots, all found{note}")
            return lam[:k], vec[:, :k]

        return self.retried(once)

    def counted(self, lo: float, hi: float) -> int:
        """The eigenvalues in ``(lo, hi)``, by two counts (none below a ``lo`` under the
        spectrum: zero when the factorization at ``lo`` is positive definite)."""
        return self.count(hi) - self.count(lo)

    def nearest(self, k: int, sigma: float, solver: str):
        if self.dense_enough(k):
            lam, vec = self.dense()
            pick = np.sort(np.argsort(np.abs(lam - sigma), kind="stable")[:k])
            return lam[pick], vec[:, pick]
        F = self.factor(sigma)
        shift = sigma
        if F._smallest_pivot() is not None:     # sigma is (nearly) an eigenvalue
            shift = sigma + self.gap(np.array([sigma]), sigma)
            self.info.fallbacks.append(f"sigma = {self.show(sigma)} is (nearly) an eigenvalue: the "
                                       f"search shifts to {self.show(shift)}")

        def once(attempt):
            self.factor(shift)
            guard = min(max(2, k // 50), 8) + 8 * attempt
            lam, vec = self.search(shift, k + guard, lambda x: np.abs(x - sigma), solver,
                                   attempt)
            lam, vec = self.found(lam, vec)
            pick = np.sort(np.argsort(np.abs(lam - sigma), kind="stable")[:k])
            r = float(np.abs(lam[pick] - sigma).max())
            delta = self.gap(lam[pick], r + abs(sigma))
            lo, hi = sigma - r - delta, sigma + r + delta
            self.stages("inertia proof")
            inside = int(((lam > lo) & (lam < hi)).sum())
            counted = self.counted(lo, hi)
            between = f"between s = {self.show(lo)} and {self.show(hi)}"
            if counted < inside:
                raise SolveError(f"the k nearest could not be certified: {counted} eigenvalues "
                                 f"lie {between}, {inside} were found")
            if counted > inside:
                raise _Missed(f"the k nearest could not be certified: {counted} eigenvalues "
                              f"lie {between}, but {inside} were found (the search missed some)")
            self.info.verification = (
                f"Sylvester inertia: {counted} eigenvalues {between} (negative pivots of LDL^T "
                "factorizations at both), all found")
            return lam[pick], vec[:, pick]

        return self.retried(once)

    def interval(self, a: float, b: float, solver: str):
        if self.n <= DENSE_MAX:
            lam, vec = self.dense()
            pick = (lam >= a) & (lam <= b)
            return lam[pick], vec[:, pick]
        delta = self.gap(np.array([a, b]), max(abs(a), abs(b)))
        lo, hi = a - delta, b + delta
        self.stages("inertia count")
        nhi, nlo = self.count(hi), self.count(lo)
        if self.dense_enough(nhi - nlo):
            lam, vec = self.dense()
            pick = (lam >= a) & (lam <= b)
            return lam[pick], vec[:, pick]
        if nhi == nlo:
            self.info.verification = (f"Sylvester inertia: {nlo} negative pivots at s = "
                                      f"{self.show(lo)} and at {self.show(hi)}: no eigenvalue "
                                      "between")
            return np.zeros(0), np.zeros((self.n, 0))
        lam, vec = self.sweep(lo, nlo, nhi - nlo, hi, nhi, solver)
        pick = (lam >= a) & (lam <= b)
        return lam[pick], vec[:, pick]

    def separate(self, lam, vec, res):
        """Pairs from different segments made ``B``-orthonormal where they are not (close
        eigenvalues on both sides of a shift): Rayleigh-Ritz on the pairs involved, whose
        residuals are computed anew."""
        if len(lam) < 2:
            return lam, vec, res
        G = vec.T @ (self.B @ vec)
        off = np.abs(G - np.eye(len(lam))) > 1e-12
        bad = np.flatnonzero(off.any(axis=0))
        if not len(bad):
            return lam, vec, res
        from scipy.linalg import eigh

        Y = vec[:, bad]
        theta, U = eigh(Y.T @ (self.A @ Y), Y.T @ (self.B @ Y))
        vec, lam, res = vec.copy(), lam.copy(), res.copy()
        vec[:, bad] = Y @ U
        lam[bad] = theta
        res[bad] = _residuals(self.A, self.B, lam[bad], vec[:, bad])
        order = np.argsort(lam, kind="stable")
        return lam[order], vec[:, order], res[order]


def _block(want: int) -> int:
    """The block size of the search for ``want`` pairs."""
    return 4 if want <= 16 else 8 if want <= 64 else 16


def _lower_bound(A, B, diagonal: bool) -> float:
    """A proven lower bound of the eigenvalues of ``A v = lambda B v`` (Gershgorin on
    ``B^-1/2 A B^-1/2`` for a diagonal ``B``; ``lambda_min(A) / lambda_min(B)`` bounds
    otherwise), or SolveError when none is available."""
    absA = abs(A)
    if diagonal:
        s = 1 / np.sqrt(B.diagonal())
        S = sp.diags_array(s) @ absA @ sp.diags_array(s)
        c = A.diagonal() * s * s
        return float((c - (np.asarray(S.sum(axis=1)).ravel() - np.abs(c))).min())
    gershgorin = lambda X, a: (X.diagonal() - (np.asarray(a.sum(axis=1)).ravel()
                                                - np.abs(X.diagonal()))).min()
    gA, gB = float(gershgorin(A, absA)), float(gershgorin(B, abs(B)))
    if gB <= 0:
        raise SolveError("eigenvalues lie below the shift and no lower bound of the spectrum is "
                         "known for this (non-diagonal) mass: pass a lumped mass")
    return min(gA / gB, 0.0) if gA < 0 else 0.0


class _Ticker:
    """The running count of a long step of ``stages`` (a :class:`Stages`): on a terminal,
    its line updated in place (at most every 0.2 s); elsewhere a whole line every 10 s and
    one at the end."""

    def __init__(self, stages: Stages) -> None:
        self.stages, self.last = stages, time.perf_counter()

    def __call__(self, text: str, final: bool = False) -> None:
        st = self.stages
        if not st.enabled or st.current is None:
            return
        now = time.perf_counter()
        if now - self.last < (0.2 if st.live else 10.0) and not final:
            return
        self.last = now
        if st.live:
            print(f"\r{st.title}: {st.current[0]} ... {text}", end="", file=sys.stderr, flush=True)
        else:
            print(f"{st.title}: {st.current[0]}: {text}", file=sys.stderr, flush=True)

    def close(self, text: str) -> None:
        self(text, final=True)


def _lobpcg(A, B, m, info, X0):
    from scipy.sparse.linalg import lobpcg

    info.solver, info.method = "amg", "LOBPCG preconditioned by smoothed aggregation"
    with info.phase("setup"):
        ml = _amg.hierarchy(A)
    X = np.random.default_rng(0).standard_normal((A.shape[0], m))
    with info.phase("solve"), warnings.catch_warnings():
        # its "not reaching the requested tolerance": every pair is residual-checked and
        # the inertia proves the count, which say it in the error
        warnings.simplefilter("ignore", UserWarning)
        lam, vec, history = lobpcg(A, X, B=B, M=ml.aspreconditioner(),
                                   Y=X0 if X0.shape[1] else None, largest=False,
                                   tol=1e-9, maxiter=500, retLambdaHistory=True)
    info.iterations = len(history)
    return lam, vec


def _residuals(A, B, lam, vec) -> np.ndarray:
    """``|A v - lambda B v|_inf / ((|A|_inf + |lambda| |B|_inf) |v|_inf)`` of each pair (inf
    where not finite): the one accuracy rule of the pairs."""
    if not len(lam):
        return np.zeros(0)
    norm_a, norm_b = _checks.row_norm(A), _checks.row_norm(B)
    scale = (norm_a + np.abs(lam) * norm_b) * np.abs(vec).max(axis=0)
    residual = np.empty(len(lam))
    for j in range(0, len(lam), 16):        # column blocks: Ctrl-C is answered between
        X = vec[:, j:j + 16]
        residual[j:j + 16] = np.abs(A @ X - (B @ X) * lam[None, j:j + 16]).max(axis=0)
    relative = residual / np.maximum(scale, 1e-300)
    return np.where(np.isfinite(lam) & np.isfinite(relative), relative, np.inf)


def _check_pairs(A, B, lam, vec, info, unit: int = 0, relative=None):
    """SolveError unless every pair's relative residual (:func:`_residuals`, computed here
    unless given) is at most RESIDUAL_TOL; the largest goes into ``info``."""
    relative = _residuals(A, B, lam, vec) if relative is None else relative
    if not len(lam):
        return
    info.residual = max(info.residual, float(relative.max()))
    bad = ~(relative <= _checks.RESIDUAL_TOL)
    if bad.any():
        j = int(np.argmax(bad))
        raise SolveError(f"eigenpair {j} (lambda = {np.ldexp(lam[j], unit):.6g}) has relative "
                         f"residual {relative[j]:.1e}")
