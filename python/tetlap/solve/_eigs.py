"""The k smallest eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30), shown to be the k
smallest by Sylvester's law of inertia."""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np
import scipy.sparse as sp

from .. import _arrays, _options
from .._progress import Stages
from ..errors import NonFiniteError, SolveError
from . import _amg, _checks
from .factor import Factor
from .info import SolveInfo

#: Up to this many free vertices eigs solves the dense generalized problem (all
#: eigenvalues, so the k smallest need no further proof).
DENSE_MAX = 400
#: ARPACK's relative accuracy of the Ritz values of the shift-inverted operator: 25% fewer
#: solves than its default (machine precision) with pair residuals still near 1e-15
#: (measured on the 189k-tet ball).
ARPACK_TOL = 1e-10


def eigs(L, M, k: int = 10, fixed=None, *, sigma: float | None = None, solver: str = "auto",
         progress=None, return_info: bool = False):
    """The ``k`` smallest eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30).

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian in tetlap's sign (``L[i, i] = -sum_j w_ij``; a stiffness matrix ``K =
        -L`` as LaPy and scikit-fem hold it is refused with an :class:`tetlap.OptionError`:
        pass ``-K``), symmetric on the free vertices, not modified; it may be indefinite
        (the dual of a non-Delaunay mesh): its negative eigenvalues are the smallest and are
        returned. Its stored pattern says which vertices belong to an element.
    M : (n, n) SciPy sparse array or matrix
        A mass matrix; ``M_II`` must be positive definite: a lumped mass with a
        non-positive free entry (circumcentric masses on non-Delaunay meshes) raises
        :class:`tetlap.SolveError` naming the vertex and the mass that works, ``"mixed"``.
    k : int, default 10
        Number of eigenpairs, ``1 <= k < n_free``.
    fixed : (n,) bool mask or integer array, optional
        Dirichlet vertices (e.g. the boundary; ``None``: no constraint). ``I`` are the
        others that belong to an element, i.e. whose row of ``L`` stores an entry off the
        diagonal (vertices in no element take no part, whatever ``M`` holds for them: their
        eigenvector entries are 0).
    sigma : float, optional
        The first shift of the shift-invert Lanczos iteration (default slightly below 0).
        If eigenvalues lie below it (the factorization's inertia says so), a shift below
        the whole spectrum is used instead (Gershgorin's bound).
    solver : {"auto", "cholesky", "lu"}, default "auto"
        The factorization of ``A - sigma B`` for shift-invert Lanczos (ARPACK): the core's
        sparse ``LDL^T`` with nested dissection (``"auto"``, ``"cholesky"``) or SuperLU
        (``"lu"``, the old path, minutes at 1M tets); the inertia proof always uses the
        core's ``LDL^T``. ``"amg"``: LOBPCG preconditioned by smoothed aggregation, for a
        positive definite ``A`` (no factorization for the search; the proof still needs
        one).
    progress : bool, optional
        Phases on stderr, with the solves done during the search (default: when stderr is
        a terminal).
    return_info : bool, default False
        Also return a :class:`tetlap.solve.SolveInfo`; ``info.verification`` says how the
        values were shown to be the k smallest.

    Returns
    -------
    eigenvalues : (k,) float64, ascending.
    eigenvectors : (n, k) float64, zero on ``fixed`` and unreferenced vertices,
        M-orthonormal on the free ones. Every pair is checked: ``|A v - lambda B v| <=
        1e-8 (|A| + |lambda| |B|) |v|`` (infinity norms), else :class:`tetlap.SolveError`.
    info : SolveInfo, with ``return_info=True``.

    Notes
    -----
    The pencil is solved scaled by powers of two (exact) that bring ``|L|`` and ``|M|``
    near 1, so the answer does not depend on the units: ``L 2^a`` and ``M 2^b`` give the
    eigenvalues times ``2^(a - b)`` and the vectors times ``2^(-b / 2)``
    (:class:`tetlap.NonFiniteError` when the eigenvalues leave the float64 range).
    The k values are proved to be the k smallest independently of the search that found
    them: an ``LDL^T`` of ``A - s B`` at ``s`` just above ``lambda_k`` (by ``1e-6
    |lambda_k|``) must have exactly ``k`` negative pivots (Sylvester: ``k`` eigenvalues
    below ``s``), its accuracy checked by a solve; when ``k`` cuts a cluster of
    (near-)equal eigenvalues, a second count below the cluster must find exactly the
    values below it. Otherwise :class:`tetlap.SolveError` says that the k smallest could
    not be certified. Up to
    400 free vertices the dense generalized problem is solved instead (all eigenvalues).
    Cost on the 974k-tet ball with ``k=10`` and the boundary fixed: the ordering, two
    factorizations and about 40 solves, near 40x one assembly (BENCHMARKS.md).

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(6)
    >>> L, M = tetlap.operators(V, T, "primal", "barycentric")
    >>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
    >>> lam, vec, info = tetlap.solve.eigs(L, M, 3, fixed, return_info=True)
    >>> bool(lam[0] > 3 * 3.14159**2 * 0.9), vec.shape, info.verification is not None
    (True, (343, 3), True)
    """
    L = _arrays.laplacian(L)
    n = L.shape[0]
    M = _arrays.matrix(M, n, "M")
    fixed = np.zeros(n, dtype=bool) if fixed is None else _checks.mask(fixed, n)
    referenced = _in_elements(L)
    free = np.flatnonzero(~fixed & referenced)
    k = int(_options.count(k, "k", 1, len(free) - 1))
    if sigma is not None:
        _options.finite(sigma, "sigma")
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    A = sp.csr_array(-L[free][:, free])
    B = sp.csr_array(M[free][:, free])
    _symmetric(A, free, "L")
    _symmetric(B, free, "M")
    diagonal = _positive_diagonal(B, free)
    # the pencil scaled by powers of two (exact): |A|, |B| in [1, 4), so that no tolerance
    # or shift depends on the units; the eigenvalues scale by 2^(eA - eB), the vectors by
    # 2^(-eB / 2) (eB even)
    eA, eB = _exponent(A), _exponent(B, even=True)
    A.data, B.data = np.ldexp(A.data, -eA), np.ldexp(B.data, -eB)
    if sigma is not None:
        sigma = float(np.ldexp(sigma, eB - eA))
    info = SolveInfo()
    stages = Stages("eigs", progress)
    if len(free) <= DENSE_MAX:
        lam, vec = _dense(A, B, k, info)
    else:
        lam, vec = _sparse_eigs(A, B, k, sigma, solver, diagonal, info, stages, progress)
    stages.done()
    _check_pairs(A, B, lam, vec, info)
    with np.errstate(over="ignore"):
        lam, vec = np.ldexp(lam, eA - eB), np.ldexp(vec, -eB // 2)
    if not (np.isfinite(lam).all() and np.isfinite(vec).all()):
        raise NonFiniteError("the eigenvalues leave the float64 range (|L| / |M| is too large "
                             "for them); scale L or M")
    full = np.zeros((n, k))
    full[free] = vec
    return (lam, full, info) if return_info else (lam, full)


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


def _positive_diagonal(B, free) -> bool:
    """Whether the mass ``B`` (free block) is diagonal (explicit zeros off the diagonal do
    not count); SolveError naming a free vertex whose mass ``M[i, i]`` is not positive (no
    positive definite mass has one)."""
    d = B.diagonal()
    if len(d) and (d <= 0).any():
        bad = int(free[np.argmin(d)])
        raise SolveError(
            f"the mass matrix is not positive on the free vertices: M[{bad}, {bad}] = "
            f"{d.min():.3e} ({int((d <= 0).sum())} entries <= 0); circumcentric masses "
            'can be negative on non-Delaunay meshes: use the mixed mass, '
            'tetlap.mass(V, T, "mixed") (positive on every mesh)')
    return not sp.coo_array(B - sp.diags_array(d)).count_nonzero()


def _dense(A, B, k, info):
    from scipy.linalg import LinAlgError, eigh

    info.solver, info.method = "lu", "dense generalized eigensolver (LAPACK)"
    info.verification = "all eigenvalues of the dense generalized problem"
    with info.phase("solve"):
        try:
            lam, vec = eigh(A.toarray(), B.toarray(), subset_by_index=[0, k - 1])
        except LinAlgError as e:
            raise SolveError(f"the eigenproblem could not be solved (the mass is not positive "
                             f"definite? {e})") from None
    return lam, vec


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


def _sparse_eigs(A, B, k, sigma, solver, diagonal, info, stages, progress):
    from scipy.sparse.linalg import LinearOperator, eigsh

    n = A.shape[0]
    scale = abs(A).max() / max(abs(B).max(), 1e-300)
    shift = -1e-6 * scale if sigma is None else float(sigma)
    m = k
    stages("factorization")
    F = Factor(sp.csr_array(A - shift * B), "cholesky", "auto", progress, method="ldlt")
    info.ordering = F.info.ordering
    negative = F.inertia()[0]
    if negative:
        info.fallbacks.append(f"{negative} eigenvalues lie below the shift {shift:.6g}")
        bound = _lower_bound(A, B, diagonal)
        shift = bound - 1e-3 * abs(bound) - 1e-12 * scale
        F.refactor(A - shift * B)
        if F.inertia()[0]:
            raise SolveError("eigs could not find a shift below the spectrum (the Gershgorin "
                             "bound failed the inertia test)")
    v0 = np.random.default_rng(0).standard_normal(n)
    solves = [0]
    raw = lambda x: F._raw(x[:, None])[:, 0]  # noqa: E731
    info.solver, info.method = "cholesky", "shift-invert Lanczos (ARPACK) on LDL^T"
    if solver == "lu":
        from scipy.sparse.linalg import splu

        with info.phase("factorization"):
            raw = splu(sp.csc_array(A - shift * B)).solve
        info.solver, info.method = "lu", "shift-invert Lanczos (ARPACK) on SuperLU"

    def apply(x):
        solves[0] += 1
        ticker(f"{solves[0]} solves")
        return raw(np.asarray(x, dtype=np.float64).ravel())

    ticker = _Ticker(stages)

    # an exactly multiple eigenvalue (a symmetric mesh) can hide a vector from the search:
    # the proof then fails and more vectors are asked for
    sizes = sorted({k, min(k + 4, n - 1), min(2 * k + 8, n - 1)})
    for attempt, m in enumerate(sizes):
        with _amg.one_blas_thread():
            if solver == "amg":
                lam, vec = _lobpcg(A, B, m, info, v0)
            else:
                stages("shift-invert Lanczos")
                with info.phase("solve"):
                    try:
                        lam, vec = eigsh(A, k=m, M=B, sigma=shift, which="LM", v0=v0,
                                         tol=ARPACK_TOL, OPinv=LinearOperator(
                                             (n, n), matvec=apply, dtype=np.float64))
                    except Exception as e:  # ARPACK failures: no eigenpairs to return
                        raise SolveError(f"the eigenproblem could not be solved "
                                         f"({type(e).__name__}: {e})") from e
                info.iterations = solves[0]
                ticker.close(f"{solves[0]} solves, {m} pairs")
        order = np.argsort(lam)[:k]
        lam, vec = lam[order], vec[:, order]
        stages("inertia proof")
        try:
            _verify(A, B, lam, k, F, info, scale)
            break
        except _Missed as e:
            if attempt == len(sizes) - 1:
                raise SolveError(str(e)) from None    # the public class, not the signal
            info.fallbacks.append(f"{m} vectors: {e}")
            F.refactor(A - shift * B)
    for name, seconds in F.info.phases.items():
        info.phases[name] = info.phases.get(name, 0.0) + seconds
    return lam, vec


class _Ticker:
    """The running count of a long step of ``stages`` (a :class:`Stages`): on a terminal,
    its line updated in place (at most every 0.2 s); elsewhere a whole line every 10 s and
    one at the end."""

    def __init__(self, stages: Stages) -> None:
        self.stages, self.last, self.shown = stages, time.perf_counter(), ""

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


def _lobpcg(A, B, m, info, v0):
    from scipy.sparse.linalg import lobpcg

    info.solver, info.method = "amg", "LOBPCG preconditioned by smoothed aggregation"
    with info.phase("setup"):
        ml = _amg.hierarchy(A)
    X = np.random.default_rng(0).standard_normal((A.shape[0], m))
    X[:, 0] = v0
    with info.phase("solve"), warnings.catch_warnings():
        # its "not reaching the requested tolerance": every pair is residual-checked and
        # the inertia proves the count, which say it in the error
        warnings.simplefilter("ignore", UserWarning)
        lam, vec, history = lobpcg(A, X, B=B, M=ml.aspreconditioner(), largest=False,
                                   tol=1e-9, maxiter=500, retLambdaHistory=True)
    info.iterations = len(history)
    return lam, vec


class _Missed(SolveError):
    """The inertia shows eigenvalues below the k-th that the search did not return."""


def _count(F, A, B, s, info) -> int:
    """Eigenvalues below ``s``: the negative pivots of an ``LDL^T`` of ``A - s B``, whose
    accuracy a solve of a random right-hand side checks (SolveError if it fails)."""
    with info.phase("inertia"):
        F.refactor(A - s * B)
        negative = F.inertia()[0]
        probe = np.random.default_rng(1).standard_normal(A.shape[0])
        x = F._raw(probe[:, None])[:, 0]
        res = _checks.relative_residual(sp.csr_array(A - s * B), x, probe)
    if res > _checks.RESIDUAL_TOL:
        raise SolveError(f"the k smallest could not be certified: the LDL^T of A - s B at s = "
                         f"{s:.6g} is inaccurate (relative residual {res:.1e})")
    return negative


def _verify(A, B, lam, k, F, info, scale):
    """Sylvester's proof that ``lam`` (ascending, k values with checked residuals) are the
    k smallest eigenvalues: an accurate ``LDL^T`` of ``A - s B`` just above ``lam[k-1]``
    has exactly ``k`` negative pivots. When it has more, ``lam[k-1]`` lies in a cluster of
    (near-)equal eigenvalues cut by k: a second count just below the cluster must find
    exactly the values below it, and the first at least k."""
    top = lam[k - 1]
    delta = 1e-6 * max(abs(top), abs(lam[0])) + 1e-9 * scale
    above = _count(F, A, B, top + delta, info)
    if above == k:
        info.verification = (f"Sylvester inertia: the LDL^T of A - s B at s = {top + delta:.6g} "
                             f"has {k} negative pivots")
        return
    if above < k:
        raise _Missed(f"the k smallest could not be certified: only {above} eigenvalues lie "
                         f"below s = {top + delta:.6g}, {k} were found")
    start = int(np.searchsorted(lam, top - delta))  # the cluster of lam[k-1]
    low = (lam[start - 1] + lam[start]) / 2 if start else lam[0] - delta
    below = _count(F, A, B, low, info)
    if below != start:
        raise _Missed(f"the k smallest could not be certified: {below} eigenvalues lie "
                      f"below s = {low:.6g}, but {start} were found (the search missed some)")
    info.verification = (f"Sylvester inertia: {below} negative pivots at s = {low:.6g} and "
                         f"{above} at s = {top + delta:.6g} (a cluster of {above - below} values "
                         f"at {top:.6g}, {k - start} of them returned)")


def _check_pairs(A, B, lam, vec, info):
    norm_a, norm_b = _checks.row_norm(A), _checks.row_norm(B)
    for j in range(len(lam)):
        v = vec[:, j]
        scale = (norm_a + abs(lam[j]) * norm_b) * np.abs(v).max()
        residual = np.abs(A @ v - lam[j] * (B @ v)).max()
        relative = residual / max(scale, 1e-300)
        info.residual = max(info.residual, float(relative))
        if not np.isfinite(lam[j]) or relative > _checks.RESIDUAL_TOL:
            raise SolveError(f"eigenpair {j} (lambda = {lam[j]:.6g}) has relative residual "
                             f"{relative:.1e}")
