"""The search for weights that lift every face margin to a floor, and the certificates
that no weights can.

Every margin is affine in the weights, so regularity is a linear feasibility problem; a
general LP on a whole mesh takes minutes at 20k tets. Instead (the per-face work in the
core, ``tetlap._core.regular_search``): projected L-BFGS on the squared shortfall of the
margins below their aims, in ``u = w / l^2`` (``l`` a vertex's mean edge length, so that
unknowns and coefficients are O(1)), from ``u = 0``, on a working set of the faces near
their aim. It is done as soon as every face reaches its floor. Where it sticks (a stall,
or :data:`LEVEL_ITERATIONS`), the faces left short carry the multipliers of its
optimality condition, and small LPs (HiGHS) on them and their neighbourhoods look for a
Gordan certificate, which :mod:`~tetlap.regular.verify` checks exactly; none found, the
floor drops to a tenth, then a hundredth of the target, then any positive margin.
"""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np
import scipy.sparse as sp

from .. import _core
from .._interrupt import interruptible
from ..errors import NonFiniteError
from . import verify
from .conditions import Conditions
from .._names import public_dir

__all__ = ["TARGET_MARGIN", "LEVEL_ITERATIONS", "Problem", "Budget", "Certificate",
           "Outcome", "search"]
__dir__ = public_dir(globals())

#: Margin the weights aim for on the faces they have to repair (default of
#: ``target_margin``): 0.1% of the face size. Small on purpose: the larger the target, the
#: larger the weights (large weights shrink the power cells of boundary vertices) and the
#: slower the search.
TARGET_MARGIN = 1e-3
#: Iterations at one floor before a certificate is looked for and the floor is lowered
#: (the last floor gets what is left).
LEVEL_ITERATIONS = 2000
#: At the first floor, a first look for a certificate after this many iterations (and the
#: iterations of the first pass, with boundary weights ``>= 0``).
CHECKPOINT = 300
#: Candidate sets for a certificate LP are at most this many faces.
CERT_MAX_ROWS = 5000
#: LPs on 2 and 3 rings are tried around this many of the largest shortfalls.
CERT_SEEDS = 3
#: Simplex iterations of one certificate LP at most (a deterministic budget).
LP_ITERATIONS = 200000
#: Certificate LPs of one stall at most, and of one call of
#: :func:`tetlap.regular.regular_weights` at most.
STALL_LPS = 4
MAX_LPS = 12


@dataclasses.dataclass(frozen=True)
class Problem:
    """The conditions of the non-folded faces in the search's units ``u = w / scale``.

    Attributes
    ----------
    rows : (c,) int64, the conditions' rows (one per face).
    vertices : (c, 5) int64.  g0 : (c,) float64.
    coefficients : (c, 5) float64, ``d margin / d u`` (the conditions' times ``scale``).
    scale : (n,) float64, ``l^2`` per vertex (1 for unreferenced vertices).
    """

    rows: np.ndarray
    vertices: np.ndarray
    g0: np.ndarray
    coefficients: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, cond: Conditions, scale: np.ndarray) -> Problem:
        """The problem of ``cond``; :class:`tetlap.NonFiniteError` where a row's
        coefficients in these units leave float64 (edges spanning about 300 orders of
        magnitude: a needle of 1e300 on a unit base)."""
        if not cond.folded.any():       # every row (no copies)
            rows, vertices, g0 = np.arange(len(cond.g0)), cond.vertices, cond.g0
            coefficients = cond.coefficients
        else:
            rows = np.flatnonzero(~cond.folded[cond.face])
            vertices, g0 = cond.vertices[rows], cond.g0[rows]
            coefficients = cond.coefficients[rows]
        with np.errstate(over="ignore"):
            coefficients = coefficients * scale[vertices]
        bad = ~np.isfinite(coefficients).all(axis=1)
        if bad.any():
            face = int(cond.face[rows[np.argmax(bad)]])
            raise NonFiniteError(
                f"interior face {face}: its regularity condition in the units of the weights "
                f"(squared edge lengths at its vertices, {scale[vertices[bad][0]].min():.3g} to "
                f"{scale[vertices[bad][0]].max():.3g}) leaves the float64 range: the mesh's "
                "edges span too many orders of magnitude for vertex weights")
        return cls(rows=rows, vertices=vertices, g0=g0, coefficients=coefficients, scale=scale)

    @property
    def n(self) -> int:
        return len(self.scale)

    @property
    def core_rows(self):
        return self.vertices, self.g0, self.coefficients

    def margins(self, u: np.ndarray) -> np.ndarray:
        return self.g0 + np.einsum("ck,ck->c", self.coefficients, u[self.vertices])

    @functools.cached_property
    def matrix(self) -> sp.csr_array:
        """(c, n) the coefficients as a sparse matrix, five entries a row."""
        c = len(self.rows)
        return sp.csr_array((self.coefficients.ravel(), self.vertices.ravel(),
                             np.arange(0, 5 * c + 1, 5)), shape=(c, self.n))

    @functools.cached_property
    def transpose(self) -> sp.csr_array:
        return self.matrix.T.tocsr()

    def ring(self, rows: np.ndarray) -> np.ndarray:
        """``rows`` and every row sharing a vertex with one of them, ascending."""
        cols = np.unique(self.vertices[rows])
        return np.unique(self.transpose[cols].indices)


@dataclasses.dataclass
class Budget:
    """What the search may still spend: L-BFGS iterations and certificate LPs (both
    deterministic), and, only when the caller opts in, a wall-clock deadline
    (``time.perf_counter()`` seconds). ``tried`` holds the candidate sets already solved
    (an LP on the same faces is not solved twice)."""

    iterations: int
    deadline: float | None = None
    lps: int = MAX_LPS
    tried: set = dataclasses.field(default_factory=set)

    def seconds(self) -> float | None:
        """Seconds left before the deadline (None: no deadline)."""
        return None if self.deadline is None else max(self.deadline - time.perf_counter(), 0.0)

    def late(self) -> bool:
        return self.deadline is not None and time.perf_counter() >= self.deadline


@dataclasses.dataclass(frozen=True)
class Certificate:
    """A proof that no weights make the mesh regular, checked by :mod:`.verify`.

    Attributes
    ----------
    kind : ``"gordan"`` (multipliers on face margins that cancel for every weight),
        ``"folded"`` (faces with both tets on one side) or ``"non-manifold"`` (faces of
        more than two tets).
    faces : (k,) int64, interior faces (indices of the face table), or for
        ``"non-manifold"`` indices into the non-manifold faces.
    multipliers : (k,) float64 > 0 (``"gordan"``: the exact multipliers, rounded and
        normalised to sum 1; ones otherwise).
    """

    kind: str
    faces: np.ndarray
    multipliers: np.ndarray


@dataclasses.dataclass
class Outcome:
    """The result of :func:`search`.

    ``status``: ``"reached"`` (every condition at its floor), ``"not regular"`` (with a
    checked ``certificate``) or ``"undecided"``. ``floor``: the margin reached on the
    repaired faces; ``floors``/``aims`` (c,): per condition, what it reached and what the
    search aimed for (the mass step keeps them).
    """

    status: str
    u: np.ndarray
    iterations: int = 0
    lps: int = 0
    floor: float | None = None
    floors: np.ndarray | None = None
    aims: np.ndarray | None = None
    certificate: Certificate | None = None


#: Cospherical faces (margin 0 at ``w = 0``, to rounding) only need to leave 0: they aim
#: for this fraction of the target margin.
COSPHERICAL = 0.01


def _aims(problem: Problem, sign: np.ndarray, floor: float):
    """The floors every condition must reach for a margin ``floor``, by the sign of its
    face at ``w = 0`` (``sign`` (c,): -1 violated, 0 cospherical, 1 strictly regular): the
    violated faces ``floor``, the cospherical ones :data:`COSPHERICAL` times it, the others
    half their plain margin if that is smaller; and the aims of the squared shortfall, a
    tenth of their floor above them, so that the floors are reached in finitely many
    steps."""
    floors = np.where(sign < 0, floor, np.where(sign == 0, COSPHERICAL * floor,
                                                np.minimum(floor, problem.g0 / 2)))
    return floors, floors + 0.1 * floors


def _highs_options(budget: Budget | None, **options) -> dict:
    """``options`` of HiGHS, with the time left to ``budget``'s deadline if it has one."""
    seconds = None if budget is None else budget.seconds()
    if seconds is not None:
        options["time_limit"] = max(seconds, 0.01)
    return options


def _lp(problem: Problem, rows: np.ndarray, budget: Budget) -> np.ndarray | None:
    """Gordan's alternative on the conditions ``rows`` by an LP (HiGHS dual simplex): ``y
    >= 0`` with ``sum y = 1`` and ``A[rows]^T y = 0``. Every weight entering those rows is
    free, so such a ``y`` (checked exactly afterwards) proves that no weights make them all
    strictly positive. Returns ``y`` (len(rows),) or None."""
    from scipy.optimize import linprog

    A = problem.matrix[rows]
    cols, inverse = np.unique(A.indices, return_inverse=True)
    M = sp.csr_array((A.data, inverse.ravel(), A.indptr), shape=(len(rows), len(cols)))
    A_eq = sp.vstack([M.T, sp.csr_array(np.ones((1, len(rows))))]).tocsr()
    b_eq = np.zeros(len(cols) + 1)
    b_eq[-1] = 1.0
    options = _highs_options(budget, maxiter=LP_ITERATIONS, primal_feasibility_tolerance=1e-10,
                             dual_feasibility_tolerance=1e-10)
    res = interruptible(linprog, np.zeros(len(rows)), A_eq=A_eq, b_eq=b_eq, bounds=(0.0, None),
                        method="highs-ds", options=options)
    if res.status != 0:
        return None
    return np.where(res.x > 1e-12, res.x, 0.0)


def _certificate(V, T, cond: Conditions, problem: Problem, short: np.ndarray, budget: Budget,
                 first: bool = False) -> tuple[Certificate | None, int]:
    """Look for a certificate where the search is stuck: LPs on 2 and 3 rings around each
    of the :data:`CERT_SEEDS` largest shortfalls ``short`` (rows of ``problem``, largest
    first), then on all of them and one ring more (non-regular meshes have small
    obstructions: 4-220 faces on the corpus, all found by the first or second LP). A set
    already tried is not solved again; at most :data:`STALL_LPS` LPs here and
    ``budget.lps`` in all. Each LP's support is checked exactly
    (:func:`.verify.check_certificate`). Returns (the certificate or None, LPs solved)."""
    candidates = []
    for seed in short[:1 if first else CERT_SEEDS]:
        rows = problem.ring(problem.ring(np.array([seed])))
        candidates += [rows] if first else [rows, problem.ring(rows)]
    candidates += [] if first else [short, problem.ring(short)]
    solved = 0
    for rows in candidates:
        key = np.sort(rows).tobytes()
        if solved == STALL_LPS or budget.lps == 0 or budget.late():
            break
        if not len(rows) or len(rows) > CERT_MAX_ROWS or key in budget.tried:
            continue
        budget.tried.add(key)
        budget.lps -= 1
        y = _lp(problem, rows, budget)
        solved += 1
        if y is None:
            continue
        support = rows[y > 0]
        conditions = problem.rows[support]
        check = verify.check_certificate(V, T, cond.interior, cond.face[conditions], y[y > 0],
                                         cond.vertices[conditions], cond.coefficients[conditions])
        if check is not None:
            faces = cond.face[conditions]
            order = np.argsort(faces, kind="stable")
            return Certificate("gordan", faces[order], check.multipliers[order]), solved
    return None, solved


def quadratic(V, problem: Problem, floors: np.ndarray, aims: np.ndarray, lo: np.ndarray,
              hi: np.ndarray, budget: Budget | None = None) -> np.ndarray | None:
    """Weights ``w = eps x^T Q x`` (``Q`` symmetric), in problem units, that lift every
    condition to its floor, or None. A quadratic lifting ``|x|^2 - x^T Q x`` makes the mesh
    regular exactly when it is Delaunay in the metric ``I - Q``: the structured meshes whose
    faces are cospherical (Kuhn grids: every cube's eight corners on a sphere) are, and a
    first-order search from ``w = 0`` is slow on them. One LP with 7 unknowns: the
    direction ``Q`` (``|Q_ij| <= 1``) maximising the smallest rise of the conditions below
    their floors at ``w = 0``; then the smallest ``eps`` that lifts those to their aims,
    if it keeps the others at their floors and ``w`` within the bounds. The LP stops at
    ``budget``'s deadline, if it has one (then None)."""
    from scipy.optimize import linprog

    low = problem.g0 < floors
    if not low.any():
        return None
    X = V - (V.max(axis=0) + V.min(axis=0)) / 2
    size = float(np.abs(X).max()) or 1.0
    X = X / size
    phi = np.column_stack([X[:, 0] ** 2, X[:, 1] ** 2, X[:, 2] ** 2, 2 * X[:, 0] * X[:, 1],
                           2 * X[:, 0] * X[:, 2], 2 * X[:, 1] * X[:, 2]])     # (n, 6)
    # the rise of the low conditions per unit Q, in problem units (w = size^2 x^T Q x)
    coefficients = problem.coefficients / problem.scale[problem.vertices]
    rows = np.einsum("ck,ckp->cp", coefficients[low], phi[problem.vertices[low]]) * size ** 2
    res = linprog(np.r_[np.zeros(6), -1.0], A_ub=np.hstack([-rows, np.ones((len(rows), 1))]),
                  b_ub=np.zeros(len(rows)), bounds=[(-1.0, 1.0)] * 6 + [(None, 1.0)],
                  method="highs-ds", options=_highs_options(budget, presolve=False))
    rise = rows @ res.x[:6] if res.status == 0 else None
    if rise is None or not -res.fun > 0 or not (rise > 0).all():  # (within HiGHS' tolerance)
        return None
    eps = float(np.max((aims[low] - problem.g0[low]) / rise))
    u = eps * size ** 2 * (phi @ res.x[:6]) / problem.scale
    ok = (problem.margins(u) >= floors).all() and (u >= lo).all() and (u <= hi).all()
    return u if ok else None


def search(V, T, cond: Conditions, problem: Problem, sign: np.ndarray, target: float,
           lo: np.ndarray, hi: np.ndarray, budget: Budget, notes: list[str],
           threads: int | None = None) -> Outcome:
    """Weights ``u`` (problem units) with every condition at its floor for the margin
    ``target`` (:func:`_aims`), or a checked certificate that none exist, from ``u = 0``
    within ``lo <= u <= hi``; ``sign`` (c,) is the sign of every condition's face at
    ``w = 0`` (:class:`~tetlap.regular.verify.MarginCheck`, ``<= 0``: to repair). Spends
    ``budget`` (counted down); appends what happened to ``notes``. ``threads``: the core's
    worker threads (the result does not depend on them).

    First a quadratic lifting (:func:`quadratic`), when some faces are cospherical; then
    boundary weights ``>= 0`` at the target (:data:`CHECKPOINT` iterations at most, no
    certificate: boundary power cells then only grow, which keeps boundary masses); then
    weights of either sign, at the target, a tenth and a hundredth of it, with certificate
    LPs after :data:`CHECKPOINT` iterations and where the search sticks, and finally any
    positive margin."""
    out = Outcome(status="undecided", u=np.zeros(problem.n))
    floors, aims = _aims(problem, sign, target)
    u = quadratic(V, problem, floors, aims, lo, hi, budget) if (sign == 0).any() else None
    if u is not None:
        out.status, out.u, out.floor, out.floors, out.aims = "reached", u, target, floors, aims
        notes.append("a quadratic lifting makes it regular (Delaunay in some metric)")
        return out
    inward = np.where(cond.on_boundary, np.maximum(lo, 0.0), lo)
    if (inward != lo).any():
        u, stop, used, _, _ = _core.regular_search(
            problem.core_rows, (floors, aims, inward, hi), out.u,
            (max(min(budget.iterations, CHECKPOINT), 1), budget.seconds()),
            options={"threads": threads})
        budget.iterations = max(budget.iterations - used, 0)
        out.iterations += used
        if stop == "done":
            out.status, out.u, out.floor, out.floors, out.aims = "reached", u, target, floors, aims
            return out
        if stop == "deadline" or budget.late():
            notes.append(f"stopped at the time limit after {out.iterations} iterations")
            return out
        notes.append("boundary weights >= 0 were not enough: weights of either sign")
    floors_tried = (target, target / 10, target / 100)
    for level, floor in enumerate(floors_tried):
        if budget.iterations == 0:
            notes.append(f"stopped at the iteration budget ({out.iterations} iterations)")
            return out
        floors, aims = _aims(problem, sign, floor)
        out.floor, out.floors, out.aims = floor, floors, aims
        iterations = budget.iterations // (len(floors_tried) - level)
        if level < len(floors_tried) - 1:          # a stuck search is better off certified early
            iterations = min(iterations, LEVEL_ITERATIONS)
        if iterations == 0:                        # a small budget: the lower floors get it
            continue
        # a first look for a certificate early in the first level: most non-regular meshes
        # show their obstruction within a few hundred iterations
        checkpoints = [CHECKPOINT, iterations] if level == 0 and iterations > CHECKPOINT else [iterations]
        spent = 0
        for checkpoint in checkpoints:
            u, stop, used, short, _ = _core.regular_search(
                problem.core_rows, (floors, aims, lo, hi), out.u,
                (max(checkpoint - spent, 1), budget.seconds()), options={"threads": threads})
            spent += used
            budget.iterations = max(budget.iterations - used, 0)
            out.u, out.iterations = u, out.iterations + used
            if stop == "done":
                out.status = "reached"
                return out
            if stop == "deadline" or budget.late():
                notes.append(f"stopped at the time limit after {out.iterations} iterations")
                return out
            early = stop == "iterations" and checkpoint < iterations
            if stop != "stalled" and out.iterations < CHECKPOINT:
                continue    # LPs cost far more than an iteration: not within a small budget
            certificate, solved = _certificate(V, T, cond, problem, short, budget, first=early)
            out.lps += solved
            if certificate is not None:
                out.status, out.certificate = "not regular", certificate
                return out
            if stop == "stalled":
                break
        if budget.iterations == 0:
            notes.append(f"stopped at the iteration budget ({out.iterations} iterations)")
            return out
        notes.append(f"margin {floor:g} not reached and no certificate: trying a lower one")
    g = problem.margins(out.u)
    repaired = sign <= 0
    if len(g) and (g[repaired] > 0).all():
        out.floor = float(g[repaired].min())
        out.floors = np.minimum(out.floors, g)
        notes.append(f"repaired faces kept at margin {out.floor:.3g}, below the floors")
        out.status = "reached"
        return out
    notes.append("no floor reached and no certificate found")
    return out
