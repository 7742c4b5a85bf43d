"""Vertex weights that make a given tetrahedral mesh regular (weighted Delaunay).

A mesh ``(V, T)`` is *regular* for vertex weights ``w`` when it is the projection of the
lower convex hull of the lifted points ``(x_i, |x_i|^2 - w_i)``; locally, when across every
interior face ``abc`` shared by the tets ``abcp`` and ``abcq`` the lifted ``q`` lies
strictly above the hyperplane through the lifted ``a, b, c, p``. Then its weighted dual
(``tetlap.laplacian(V, T, "dual", weights=w)``, the power diagram) is an orthogonal dual
whose interior edge weights are all non-negative: with linear precision (which every
weighted dual has) that is a Laplacian with the maximum principle, as the plain dual is on
Delaunay meshes. :func:`regular_weights` finds such weights, or proves that none exist.

Conventions
-----------
V, T
    (n, 3) float64 positions; (m, 4) integer tets, any orientation.
w
    (n,) vertex weights in squared-length units, exactly as ``weights=`` of
    :func:`tetlap.laplacian`: larger ``w_i`` means a bigger power cell for vertex ``i``;
    the lifting map is ``x -> (x, |x|^2 - w)``. Only differences matter up to an affine
    function: ``w + a + b . x`` gives the same regularity and the same interior weights.
face margin
    Per interior face, the signed length of its power-diagram edge over the face's RMS
    edge length, affine in ``w`` (:mod:`~tetlap.regular.conditions`,
    :func:`face_margins`); ``> 0``: strictly locally regular.
regular, strictly
    Every margin vanishes for ``w = |x|^2`` (a flat lifting), so "every margin >= 0" is
    always possible and says nothing. *Regular* means: some ``w`` makes every margin
    strictly positive (then ``|x|^2 + t (w - |x|^2)`` makes them as large as wanted), every
    face is shared by at most two tets and none is folded. By Gordan's theorem of the
    alternative a mesh of manifold, unfolded faces is **not** regular exactly when some
    non-negative combination of the face conditions vanishes identically in ``w``: that
    combination is the certificate :func:`regular_weights` looks for. A cospherical
    configuration (every margin 0 at ``w = 0``, as in a Kuhn grid) is regular only if
    some weights make its margins strictly positive.

The modules: :mod:`~tetlap.regular.conditions` (the margins, from the core),
:mod:`~tetlap.regular.search` (the search and its certificates),
:mod:`~tetlap.regular.masses` (the mass step), :mod:`~tetlap.regular.verify` (the checks
of every answer, independent of the search), :mod:`~tetlap.regular.result`.

>>> import tetlap
>>> from tetlap.regular import regular_weights
>>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)   # a non-Delaunay mesh
>>> r = regular_weights(V, T)
>>> r.status, r.margin > 0, r.n_violated_plain > 0
('regular', True, True)
>>> r.n_negative_interior_plain > 0, r.n_negative_interior_weighted
(True, 0)
"""

from __future__ import annotations

import contextlib
import dataclasses
import time

import numpy as np

from .. import _arrays, _options, analysis, assembly, diagnostics
from .. import coefficient as _coefficient
from .._float_range import LARGEST, SMALLEST, unit_scale
from ..errors import DegenerateElementError, NonFiniteError, OptionError
from ..analysis import negative_weights
from . import masses, search, verify
from .conditions import Conditions, _validated, face_margins
from .result import ANSWERS, STATUSES, RegularWeights
from .search import TARGET_MARGIN, Budget, Certificate, Problem
from .._names import public_dir

__all__ = [
    "regular_weights",
    "RegularWeights",
    "face_margins",
    "STATUSES",
    "TARGET_MARGIN",
    "MAX_ITERATIONS",
]
__dir__ = public_dir(globals())

#: The default work budget of :func:`regular_weights` (``max_iterations``): L-BFGS
#: iterations of the search and the mass step together. Every corpus mesh (up to 205k
#: tets) is decided well within it.
MAX_ITERATIONS = 20000


def _vertex_scale(V, T) -> np.ndarray:
    """The search's unit per vertex: the squared mean length of its edges (1 for
    unreferenced vertices)."""
    n = len(V)
    E = diagnostics.mesh_edges(T)
    d = V[E[:, 0]] - V[E[:, 1]]
    length = np.sqrt(np.einsum("ed,ed->e", d, d))
    total = np.bincount(E.ravel(), np.repeat(length, 2), minlength=n)
    count = np.bincount(E.ravel(), minlength=n)
    mean = np.where(count > 0, total / np.maximum(count, 1), 1.0)
    return mean * mean


@dataclasses.dataclass(frozen=True)
class Settings:
    """The options of :func:`regular_weights`, checked (:meth:`of`)."""

    target_margin: float
    boundary_weights: str
    mass_floor: float | None
    max_weight: float
    max_iterations: int
    time_limit: float | None
    threads: int | None

    @classmethod
    def of(cls, **options) -> Settings:
        """The settings, or an :class:`tetlap.OptionError` naming the first bad option."""
        o = cls(**options)
        _options.positive(o.target_margin, "target_margin")
        if o.boundary_weights not in ("free", "zero"):
            raise OptionError(f'boundary_weights must be "free" or "zero", got '
                              f'{o.boundary_weights!r}')
        if o.mass_floor is not None:
            _options.tolerance(o.mass_floor, "mass_floor")
        _options.positive(o.max_weight, "max_weight")
        _options.count(o.max_iterations, "max_iterations")
        if o.time_limit is not None:
            _options.positive(o.time_limit, "time_limit")
        _options.threads(o.threads)
        return o


@dataclasses.dataclass
class Decision:
    """What :func:`regular_weights` decided, before the report: the weights, the status,
    the checks of ``w = 0`` (``plain``) and of the weights (``final``), the certificate (of
    a "not regular"), the search and the mass step (when they ran), the notes."""

    w: np.ndarray
    status: str
    plain: verify.MarginCheck
    final: verify.MarginCheck
    certificate: Certificate | None = None
    outcome: search.Outcome | None = None
    mass_step: masses.MassStep | None = None
    notes: list[str] = dataclasses.field(default_factory=list)
    #: The plain dual and its circumcentric mass, once assembled (the mass step and the
    #: report share them).
    plain_dual: tuple | None = None


def _answer(value: bool | None) -> str:
    """``"yes"``, ``"no"`` or ``"not checked"`` (None) of :data:`ANSWERS`."""
    return ANSWERS[2] if value is None else ANSWERS[0] if value else ANSWERS[1]


@dataclasses.dataclass(frozen=True)
class DualReport:
    """What the report needs of a (weighted) dual: its negative interior weights, its
    circumcentric masses (n,), and (for the weights returned) whether it is negative
    semidefinite (None: undecided) and how that was decided."""

    n_negative_interior: int
    masses: np.ndarray
    semidefinite: bool | None = None
    semidefinite_method: str = ""


def _plain_dual(V, T, d: Decision, threads) -> tuple:
    """``(L, M)`` of the plain dual, assembled once into ``d.plain_dual``."""
    if d.plain_dual is None:
        d.plain_dual = assembly.operators(V, T, "dual", "circumcentric", threads=threads)
    return d.plain_dual


def _dual_report(V, T, w, on_boundary, threads, semidefinite: bool,
                 operators: tuple | None = None) -> DualReport:
    """The (weighted, ``w``; None: plain) dual and its mass (``operators``, or assembled
    here), checked by :func:`tetlap.check`'s one rule (its certificates of
    semidefiniteness when ``semidefinite``)."""
    L, M = operators or assembly.operators(V, T, "dual", "circumcentric", weights=w,
                                           threads=threads)
    if not semidefinite:
        return DualReport(negative_weights(L, V, T, on_boundary)[1], M.diagonal())
    report = analysis._check(L, V, T, None, kind="dual", negative_tol=analysis.NEGATIVE_TOL,
                             nsd=True, boundary=on_boundary, assembled=True, weights=w)
    return DualReport(report.n_negative_interior, M.diagonal(), report.nsd, report.nsd_method)


@_options.renamed(boundary="boundary_weights")
def regular_weights(V, T, *, coefficient=None, target_margin: float = TARGET_MARGIN,
                    boundary_weights: str = "free",
                    mass_floor: float | None = 0.1, max_weight: float = 10.0,
                    max_iterations: int = MAX_ITERATIONS,
                    time_limit: float | None = None,
                    threads: int | None = None) -> RegularWeights:
    """Vertex weights that make the mesh regular, so that its weighted dual has
    non-negative interior weights, or a proof that none do.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers.  T : (m, 4) integer array-like, any orientation.
    coefficient : None or a constant coefficient ``K`` (as ``coefficient=`` of
        :func:`tetlap.laplacian`): one ``(3, 3)`` symmetric positive definite tensor, or
        ``(m,)`` scalars or ``(m, 3, 3)`` tensors that are all equal. The weights then make
        the mesh regular *in the metric* ``K^-1``, so that
        ``laplacian(V, T, "dual", coefficient=K, weights=r.weights)`` (the dual in that
        metric, vertex weights as powers in it) has non-negative interior weights. For a
        constant ``K`` that dual is ``sqrt(det K)`` times the plain weighted dual of the mesh
        mapped by ``K^-1/2`` (rows are points: ``V @ K^-1/2``), with the same weights, so the
        weights are those of the mapped mesh (computed in float64) and every statement below
        holds of it: margins, counts and the semidefiniteness are those of the dual in the
        metric; masses are the volumes of the power cells in the metric, mapped back
        (``sqrt(det K)`` times the mapped mesh's). A coefficient that varies from tet to tet
        raises :class:`tetlap.OptionError`: its dual has no single lifting (neighbouring
        tets' power centres are computed in different metrics), so no weights certify it.
    target_margin : float > 0, the face margin (dual-edge length over face size) the weights
        aim for on the faces they repair. Faces that are strictly locally Delaunay keep at
        least ``min(half their plain margin, target_margin)``.
    boundary_weights : ``"free"`` (default: boundary vertices get weights like any other)
        or ``"zero"`` (boundary weights fixed at 0, which can make a regular mesh
        non-regular). (Called ``boundary`` until 0.1; that name still works, deprecated.)
    mass_floor : float in [0, 1) or None, keep every weighted circumcentric mass above
        ``mass_floor`` times its plain value where that is positive (0: only positive). A
        soft goal: the vertices where it fails are reported. None: skip the mass step.
    max_weight : bound on ``|w_i| / l_i^2`` (``l_i`` the vertex's mean edge length) in the
        search. The proofs of "not regular" do not depend on it.
    max_iterations : int, the work budget: L-BFGS iterations of the search and the mass
        step together (:data:`MAX_ITERATIONS`); certificate LPs are bounded by their own
        simplex iteration limit and run only after 300 iterations or where the search
        stalls. Past it the status is ``"undecided"`` unless already decided. The same
        input gives the same result on any machine and under any load. The work outside
        the budget (see Cost) does not depend on it.
    time_limit : float or None, an optional wall-clock limit in seconds for the whole call,
        set-up included (None, the default: none). An explicit opt-in: with it the result
        depends on the machine's speed and load. The set-up (the face conditions and the
        check of ``w = 0``, about ten assemblies' time) runs before the search can stop,
        and the check of the weights and the final report (two assemblies of the dual and
        their checks; past the limit, the weighted dual's semidefiniteness is "not
        checked") after it: ``time_limit=0.05`` takes about as long as
        ``max_iterations=1`` (see Cost).
    threads : int or None, the core's worker threads (None: all cores). The result does
        not depend on it.

    Returns
    -------
    :class:`RegularWeights` (``.weights``, ``.status``, ``.regular``, ``.margin``,
    ``.violated_faces``, ``.certificate_kind``, ``.certificate_faces``, ``.verification``,
    masses and counts; ``str()`` is a short report).

    Method
    ------
    1. The conditions of every interior face (the core). Faces of more than two tets, or
       folded faces, prove the mesh not regular (checked on ``T`` itself, and by exact
       orientation signs).
    2. ``w = 0``: when every face is strictly locally Delaunay (checked as in step 5) the
       plain dual is the answer.
    3. The search (:mod:`~tetlap.regular.search`): first a quadratic lifting (structured
       meshes with cospherical faces are Delaunay in a sheared metric); else projected
       L-BFGS in the core on the squared shortfall of the faces that are not strictly
       Delaunay (aim ``target_margin``) and of the others (aim ``min(plain margin / 2,
       target_margin)``), from ``w = 0``, boundary weights ``>= 0`` for 300 iterations
       (boundary power cells then only grow), then of either sign. After 300 iterations,
       and where it sticks, certificate LPs (HiGHS) on the faces left short; a certificate
       counts only once checked in exact arithmetic
       (:func:`~tetlap.regular.verify.check_certificate`). Else lower floors, then any
       positive margin.
    4. The mass step (:mod:`~tetlap.regular.masses`), when ``mass_floor`` is not None.
    5. The check: ``"regular"`` only if the weights make every interior face strictly
       locally regular from both of its tets, by the lifted determinant in float64 against
       its permanent and, within rounding of 0, in exact rational arithmetic
       (:func:`~tetlap.regular.verify.check_margins`); else ``"undecided"``, the reason in
       the notes.

    When the mesh is not regular the weights are 0 (the plain dual); when undecided, the
    search's last ones, or 0 if those leave more faces not strictly regular than ``w = 0``.
    The weights of every status assemble wherever the plain dual does (hull slivers
    included): ``laplacian(V, T, "dual", weights=r.weights)``.

    Deterministic: the same input gives the same output (weights bitwise) for any thread
    count and any load, unless ``time_limit`` is given. Inputs are not modified.

    Vertices in no tet take no part (their weight is 0). The mesh of the used vertices is
    computed in units of a power of two when its bounding box is outside
    ``2^-64 .. 2^64`` (the geometric mean of its shortest and longest edge; exact; the
    weights are returned in the caller's units, times ``scale^2``), so the answer does not
    depend on the unit; weights beyond the float64 range in the caller's units, or a mesh
    whose edges span too many orders of magnitude for weights (a needle of 1e300 on a
    unit base), raise :class:`tetlap.NonFiniteError`.

    Cost: besides the budgeted iterations, every call computes the face conditions and
    checks ``w = 0`` (in the core, one pass each); a mesh with cospherical faces solves one
    LP with 7 unknowns (the quadratic lifting); and the report assembles the dual twice,
    checks both and decides the weighted dual's semidefiniteness by :func:`tetlap.check`'s
    certificates. All of it is linear in the mesh: with ``max_iterations=1``, 0.9 s on 94k
    tets and 2.7 s on 384k (jittered Kuhn grids, ``meshes.cube(25 | 40, jitter=0.2)``, on a
    loaded 2-core machine: 25-30 assemblies of the dual). A search iteration costs the
    faces near their aims and their vertices, not the mesh (about 5 ms on the 215k-tet
    ``meshes.weighted_ball(34000, 0.01)``, which needs 288: 25-46 assemblies in all).

    Raises
    ------
    tetlap.ShapeError, DtypeError, IndexRangeError, NonFiniteError, RepeatedVertexError,
    EmptyMeshError (bad input, as for the operators); DegenerateElementError (an exactly
    flat tet next to an interior face: it has no power centre; needles and slivers are
    computed exactly); NonFiniteError (also: a face's margin row beyond the float64 range);
    OptionError (a bad option).

    Examples
    --------
    A regular triangulation of random weighted points is recognised; the weights found
    make every interior weighted-dual weight non-negative while the plain dual has
    negative ones:

    >>> import numpy as np, tetlap
    >>> from tetlap.regular import regular_weights
    >>> rng = np.random.default_rng(0)
    >>> P = rng.uniform(-1, 1, size=(300, 3))
    >>> T = tetlap.meshes.regular_triangulation(P, rng.uniform(0, 0.05, size=300))
    >>> V, T = tetlap.meshes.compact(P, T)
    >>> r = regular_weights(V, T)
    >>> r.status, r.n_negative_interior_plain > 0, r.n_negative_interior_weighted
    ('regular', True, 0)
    >>> L = tetlap.laplacian(V, T, "dual", weights=r.weights)
    >>> bool(tetlap.check(L, V, T).linear_precision_ok)
    True
    """
    if coefficient is not None:
        return _in_metric(V, T, coefficient, target_margin=target_margin,
                          boundary_weights=boundary_weights, mass_floor=mass_floor,
                          max_weight=max_weight, max_iterations=max_iterations,
                          time_limit=time_limit, threads=threads)
    start = time.perf_counter()
    settings = Settings.of(target_margin=target_margin, boundary_weights=boundary_weights,
                           mass_floor=mass_floor, max_weight=max_weight,
                           max_iterations=max_iterations, time_limit=time_limit,
                           threads=threads)
    V, T = _validated(V, T)
    used, T_used = _arrays.used_vertices(V, T)
    scale = unit_scale(V[used], T_used)
    X = V[used] / scale                 # exact: a power of two
    budget = Budget(iterations=int(max_iterations),
                    deadline=None if time_limit is None else start + float(time_limit))
    with _no_degenerate_advice():
        cond = Conditions.of(X, T_used, threads)
        decision = _decide(X, T_used, cond, settings, budget)
        result = _report(X, T_used, cond, settings, decision, start, late=budget.late())
    return _in_user_units(result, used, len(V), scale)


def _constant_tensor(coefficient, V, T) -> np.ndarray:
    """The one (3, 3) tensor of a constant coefficient, validated by the rule of every
    entry point (:func:`tetlap.coefficient.check`); OptionError when it varies per tet."""
    K = _coefficient.check(coefficient, V, T)
    if K.shape == (3, 3):
        return K
    if not (K == K[0]).all():
        raise OptionError(
            "regular_weights takes a constant coefficient only (one (3, 3) tensor, or equal "
            "values for every tet): this one varies from tet to tet, and the dual of a "
            "varying metric has no single lifting (neighbouring tets' power centres are "
            "computed in different metrics), so no vertex weights certify it")
    return K[0] * np.eye(3) if K.ndim == 1 else K[0]


def _in_metric(V, T, coefficient, **options) -> RegularWeights:
    """:func:`regular_weights` in the metric ``K^-1`` of a constant ``K``: of the mesh
    mapped by ``K^-1/2``. ``K = 4^j K'`` with ``K'`` of unit size (exact), so the map is
    ``2^-j K'^-1/2``: the weights of ``V K'^-1/2`` times ``4^-j``, its masses times
    ``sqrt(det K')`` (the ``2^-3j`` of the map and the ``2^3j`` of ``sqrt(det K)`` cancel)."""
    V, T = _validated(V, T)
    K = _constant_tensor(coefficient, V, T)
    j = (int(np.frexp(np.abs(K).max())[1]) - 1) // 2
    K = np.ldexp(K, -2 * j)                         # exact
    lam, Q = np.linalg.eigh(K)
    inverse_root = (Q / np.sqrt(lam)) @ Q.T
    r = regular_weights(V @ inverse_root, T, **options)
    with np.errstate(over="ignore", under="ignore"):
        weights = np.ldexp(r.weights, -2 * j)
    size = np.abs(weights[r.weights != 0])
    if not ((size >= SMALLEST) & (size <= LARGEST)).all():
        raise NonFiniteError(
            f"the regular weights in the metric of this coefficient (squared lengths, about "
            f"2^{-2 * j} times those of the mesh mapped by (K / 4^{j})^-1/2) leave the float64 "
            "range: rescale the mesh or the coefficient")
    root_det = float(np.sqrt(np.prod(lam)))
    return dataclasses.replace(
        r, weights=weights, mass_min_plain=r.mass_min_plain * root_det,
        mass_min_weighted=r.mass_min_weighted * root_det,
        notes=r.notes + ["in the metric K^-1 of the coefficient: the mesh mapped by K^-1/2"])


@contextlib.contextmanager
def _no_degenerate_advice():
    """A DegenerateElementError of the assemblies inside without the core's advice to pass
    ``degenerate="skip"``, an option :func:`regular_weights` does not have."""
    try:
        yield
    except DegenerateElementError as e:
        message = str(e).split('; pass degenerate="skip"')[0]
        raise DegenerateElementError(message, element=e.element) from None


def _in_user_units(r: RegularWeights, used: np.ndarray, n: int, scale: float
                   ) -> RegularWeights:
    """``r`` of the mesh of the used vertices in units of ``scale``, for the caller's mesh of
    ``n`` vertices: weights (0 on unused vertices) times ``scale^2``, masses times
    ``scale^3`` (inf or 0 beyond the float64 range), vertex indices mapped back; margins
    are scale-free. NonFiniteError when a non-zero weight leaves the normal float64 range
    in the caller's units (coordinates beyond about ``1e150`` or below ``1e-150``)."""
    if scale == 1.0 and len(used) == n:
        return r
    exponent = int(np.frexp(scale)[1]) - 1          # scale = 2^exponent
    with np.errstate(over="ignore", under="ignore"):
        weights = np.zeros(n)
        weights[used] = np.ldexp(r.weights, 2 * exponent)
        size = np.abs(weights[used][r.weights != 0])
        if not ((size >= SMALLEST) & (size <= LARGEST)).all():
            raise NonFiniteError(
                f"the regular weights of this mesh (squared lengths, about 2^{2 * exponent} "
                f"times those of V / 2^{exponent}) leave the float64 range: rescale the mesh")
        volume = lambda m: float(np.ldexp(m, 3 * exponent))  # noqa: E731
        return dataclasses.replace(
            r, weights=weights, violated_faces=used[r.violated_faces],
            certificate_faces=used[r.certificate_faces],
            masses_lost=used[r.masses_lost], masses_below_floor=used[r.masses_below_floor],
            mass_min_plain=volume(r.mass_min_plain),
            mass_min_weighted=volume(r.mass_min_weighted))


def _decide(V, T, cond: Conditions, settings: Settings, budget: Budget) -> Decision:
    """Steps 1-5 of :func:`regular_weights`."""
    zero = np.zeros(len(V))
    plain = verify.check_margins(V, T, cond.interior, zero, exact=False,
                                 threads=settings.threads)
    d = Decision(w=zero, status="undecided", plain=plain, final=plain)
    if len(cond.nonmanifold):
        triangles = cond.nonmanifold
        if verify.check_nonmanifold(T, triangles):
            d.certificate = Certificate("non-manifold", np.arange(len(triangles)),
                                        np.ones(len(triangles)))
            d.notes.append(f"{len(triangles)} faces are shared by more than two tets: not a "
                           "triangulation, so not regular (w = 0)")
    elif cond.folded.any():
        faces = np.flatnonzero(cond.folded)
        if verify.check_folded(V, T, cond.interior, faces):
            d.certificate = Certificate("folded", faces, np.ones(len(faces)))
            d.notes.append(f"{len(faces)} folded faces (both tets on one side): no weights "
                           "repair them (w = 0)")
        else:
            d.notes.append("folded faces in float64 that exact orientation signs do not "
                           "confirm (w = 0)")
    elif plain.proved:
        d.notes.append("strictly Delaunay: the plain dual (w = 0) is the answer")
    else:
        _find(V, T, cond, settings, budget, d)
    if d.certificate is not None:
        d.status = "not regular"
    elif d.final.proved:
        d.status = "regular"
    elif d.outcome is not None and d.outcome.status == "reached":
        d.notes.append(f"{len(d.final.failed)} faces fail the check of the weights found "
                       "(margins within rounding of 0 or below)")
    return d


def _find(V, T, cond: Conditions, settings: Settings, budget: Budget, d: Decision) -> None:
    """Steps 3-4 of :func:`regular_weights`: the search, the mass step and the check of the
    weights, into ``d``."""
    scale = _vertex_scale(V, T)
    problem = Problem.of(cond, scale)
    sign = d.plain.sign[cond.face[problem.rows]]
    allowed = (np.ones(len(V), dtype=bool) if settings.boundary_weights == "free"
               else ~cond.on_boundary)
    hi = np.where(allowed, float(settings.max_weight), 0.0)
    lo = -hi
    d.outcome = search.search(V, T, cond, problem, sign, settings.target_margin, lo, hi,
                              budget, d.notes, settings.threads)
    u = d.outcome.u
    if d.outcome.status == "reached" and settings.mass_floor is not None:
        plain_masses = _plain_dual(V, T, d, settings.threads)[1].diagonal()
        u, d.mass_step = masses.keep_masses(V, T, problem, d.outcome, lo, hi, plain_masses,
                                            settings.mass_floor, budget, settings.threads)
        if d.mass_step.lost or d.mass_step.deficit:
            d.notes.append(f"mass step: {d.mass_step.lost} positive plain masses lost, deficit "
                           f"{d.mass_step.deficit:.3g} below {settings.mass_floor:g} x plain "
                           f"after {d.mass_step.rounds} rounds ({d.mass_step.kept} kept)")
    d.certificate = d.outcome.certificate
    if d.certificate is not None:       # not regular: the plain dual is what is left
        return
    d.w = u * scale
    # w = 0 (a search stopped before its first step): the check of w = 0 is done already,
    # but in float64 only; the faces it left undecided are decided exactly when the search
    # reached its aims there (few: the rows put them at or above their aims)
    undecided = not d.w.any() and (d.plain.sign == 0).any() and d.outcome.status == "reached"
    d.final = (d.plain if not d.w.any() and not undecided
               else verify.check_margins(V, T, cond.interior, d.w, threads=settings.threads))
    if d.outcome.status != "reached" and len(d.final.failed) > len(d.plain.failed):
        d.notes.append("the search's weights leave more faces not strictly regular than "
                       "w = 0: w = 0")
        d.w, d.final = np.zeros(len(V)), d.plain


def _report(V, T, cond: Conditions, settings: Settings, d: Decision, start: float,
            late: bool = False) -> RegularWeights:
    """The counts and the result; ``late``: past the caller's time limit, so the
    semidefiniteness of the weighted dual is not checked."""
    w, threads = d.w, settings.threads
    check = not late
    plain = _dual_report(V, T, None, cond.on_boundary, threads, check and not w.any(),
                         _plain_dual(V, T, d, threads))
    weighted = (plain if not w.any()
                else _dual_report(V, T, w, cond.on_boundary, threads, check))
    if late:
        weighted = dataclasses.replace(weighted, semidefinite_method="not checked: past the "
                                       "time limit")
    n_neg_plain, m_plain = plain.n_negative_interior, plain.masses
    n_neg_w, m_weighted = weighted.n_negative_interior, weighted.masses
    masses_lost = np.flatnonzero((m_plain > 0) & (m_weighted <= 0)).astype(np.int64)
    g = cond.per_face(cond.margins(w))
    g_plain = cond.per_face(cond.g0)
    positive = m_plain > 0
    certificate = d.certificate
    if certificate is None:
        cert_faces = np.zeros((0, 3), dtype=np.int64)
        verification = (f"every face strictly locally regular from both tets: float64 "
                        f"lifted determinants against their permanents, {d.final.exact} "
                        "within rounding of 0 decided exactly") if d.status == "regular" else ""
    elif certificate.kind == "non-manifold":
        cert_faces = cond.nonmanifold[certificate.faces]
        verification = "faces of more than two tets, counted on T"
    else:
        cert_faces = cond.triangles[certificate.faces]
        verification = ("folded faces: exact orientation signs" if certificate.kind == "folded"
                        else "Gordan multipliers on the faces' lifted determinants, exact "
                             "rational arithmetic")
    iterations = ((d.outcome.iterations if d.outcome else 0)
                  + (d.mass_step.iterations if d.mass_step else 0))
    mass_floor = settings.mass_floor or 0.0
    return RegularWeights(
        weights=w,
        status=d.status,
        margin=float(g.min()) if len(g) else 0.0,
        violated_faces=cond.triangles[d.final.failed],
        face_margins=g,
        margin_plain=float(g_plain.min()) if len(g_plain) else 0.0,
        n_violated_plain=int((d.plain.sign < 0).sum()),
        n_cospherical_plain=int((d.plain.sign == 0).sum()),
        n_folded=int(cond.folded.sum()),
        n_nonmanifold=int(len(cond.nonmanifold)),
        target_margin=float(settings.target_margin),
        margin_floor=(float(d.outcome.floor) if d.status == "regular" and d.outcome is not None
                      else None),
        n_weighted_vertices=int((w != 0).sum()),
        n_negative_interior_plain=n_neg_plain,
        n_negative_interior_weighted=n_neg_w,
        mass_min_plain=float(m_plain.min()),
        mass_min_weighted=float(m_weighted.min()),
        masses_lost=masses_lost,
        masses_below_floor=np.flatnonzero(
            positive & (m_weighted < mass_floor * m_plain)).astype(np.int64),
        seconds=time.perf_counter() - start,
        notes=d.notes,
        certificate_kind=None if certificate is None else certificate.kind,
        certificate_faces=cert_faces.astype(np.int64),
        certificate_multipliers=(np.zeros(0) if certificate is None
                                 else certificate.multipliers),
        verification=verification,
        iterations=iterations,
        lp_count=d.outcome.lps if d.outcome else 0,
        mass_rounds=d.mass_step.rounds if d.mass_step else 0,
        nonnegative_interior=_answer(n_neg_w == 0),
        positive_masses=_answer(not len(masses_lost)),
        semidefinite=_answer(weighted.semidefinite),
        semidefinite_method=weighted.semidefinite_method,
        n_masses_nonpositive_plain=int((m_plain <= 0).sum()),
    )

