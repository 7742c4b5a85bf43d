"""Geodesic distance by the heat method (Crane, Weischedel and Wardetzky, "Geodesics in
Heat", ACM TOG 2013) on tetrahedral and triangle meshes.

Three steps, for the sources ``s``:

1. the heat step ``(M - t L) u = delta_s`` (``M`` a lumped mass, ``L`` tetlap's Laplacian,
   negative semidefinite, so ``M - t L`` is positive definite for the primal), one implicit
   Euler step of the heat flow for the time ``t`` (default ``h^2``, ``h`` the mean edge
   length);
2. the normalised field ``X = -grad u / |grad u|`` per element (:func:`tetlap.gradient`);
3. the Poisson step ``L phi = div X`` (:func:`tetlap.divergence`), ``phi`` shifted so that
   its minimum is 0 (the paper's shift: a distance is never negative).

:class:`HeatDistance` builds and factorizes the matrices once; each further call of
:meth:`HeatDistance.distance` costs two solves with those factors (three with
``boundary_condition="average"``), one product with ``G`` and one with ``D``.

**Scale.** Everything is computed in a copy of the mesh scaled by a power of two (exact)
to unit size, and the heat step's matrix by another, so that distances of a mesh scaled by
``2^k`` are exactly ``2^k`` times those of the mesh, and every ``t`` from ``1e-300 h^2`` to
the largest float64 is either computed or refused, never lost:

* a heat step whose mass term is below the rounding of ``t L`` (``t`` beyond about
  ``1e10 h^2``) is solved as its limit, which the Poisson step's factorization gives
  exactly (:data:`MASS_RESOLUTION`);
* a heat step whose solution falls below the float64 range (``2.2e-308`` of its value at
  the sources) at a vertex of the sources' component, where the direction of the gradient
  is lost, is refused (:class:`tetlap.OptionError` naming ``t`` and the vertex): ``t`` far
  below ``h^2`` on a mesh many edges across.

**Accuracy.** On ``ball(2000)`` from the vertex nearest the centre, the mean error against
the exact (Euclidean) distance is 2.9% of the largest distance and the worst 12.7% (at a
boundary vertex); the distance falls below the straight-line distance, which no geodesic
distance does, at 66% of the vertices, by up to 12.7%. On ``ball(30000)``: mean 1.7%,
worst 4.5%. On a mesh graded from edges of 0.0009 to 0.15 (``libigl_bunny.mesh``) the
default ``t`` from the *mean* edge is too small for its long edges: 82% of the vertices
fall below the straight line, by up to 55.9% (``t = 100 h^2``: 34%, by up to 22%).
:doc:`/guide/fields` has the table.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.ball(2000, seed=0)
>>> centre = int(np.argmin((V ** 2).sum(1)))
>>> d = tetlap.heat_distance(V, T, centre)
>>> exact = np.linalg.norm(V - V[centre], axis=1)
>>> bool(np.abs(d - exact).mean() < 0.05 * exact.max()), float(d.min())
(True, 0.0)
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from . import _arrays, _core, _options, assembly, calculus
from ._float_range import frame_exponent
from ._progress import Stages
from .solve import factorize
from .errors import DegenerateElementError, IndexRangeError, OptionError, ShapeError, SolveError
from ._names import public_dir

__all__ = ["HeatDistance", "heat_distance", "BOUNDARY_CONDITIONS", "MASS_RESOLUTION",
           "LIMIT_ITERATIONS"]
__dir__ = public_dir(globals())

#: The boundary conditions of the heat step (Crane et al. 2013, Sec. 3.3).
BOUNDARY_CONDITIONS = ("neumann", "dirichlet", "average")

#: The Neumann heat step is factorized while, on every component, its mass term per vertex
#: (``sum_i M_ii / n``: ``M - t L``'s value on the constants, which ``L`` does not see) is at
#: least this fraction of its largest diagonal entry; below, the factorization would not
#: resolve it (its rounding is ``2^-52`` of that entry) and the step is solved as its limit
#: for large ``t``: ``(M / t - L) u = delta - mean``, by a fixed-point iteration on the
#: Poisson step's factorization that converges at the rate ``1 / (t lambda_2)``.
MASS_RESOLUTION = 2.0 ** -36

#: The most solves of that iteration before ``t`` is refused (a mesh so long that the
#: limit does not converge for a ``t`` whose mass term is not resolved either).
LIMIT_ITERATIONS = 64

#: The smallest normal float64: a heat value below it (relative to the sources') has lost
#: its digits.
_TINY = float(np.finfo(np.float64).tiny)


def _sources(sources, n: int, used: np.ndarray) -> np.ndarray:
    """``sources`` (a vertex index or a 1-D array-like of them) as sorted unique int64
    indices of vertices of the mesh: a set, so that their order and repeats do not matter."""
    if isinstance(sources, (bool, np.bool_)) or (np.isscalar(sources)
                                                 and not isinstance(sources, numbers.Integral)):
        raise OptionError(f"sources must be a vertex index or integer vertex indices, got "
                          f"{sources!r}")
    if isinstance(sources, numbers.Integral):
        if not 0 <= sources < n:        # before int64: 2**70 is not a vertex either
            raise _arrays.not_a_vertex("sources holds", int(sources), n)
        s = np.array([int(sources)], dtype=np.int64)
    else:
        if isinstance(sources, (list, tuple)):   # Python ints beyond int64 name themselves
            for x in sources:
                if (isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))
                        and not 0 <= x < n):
                    raise _arrays.not_a_vertex("sources holds", int(x), n)
        arr = _arrays._as_array(sources, "sources")
        if arr.size == 0:
            raise ShapeError("sources is empty: give at least one source vertex")
        if arr.dtype.kind not in "iu":
            raise OptionError(f"sources must be a vertex index or integer vertex indices, "
                              f"got dtype {arr.dtype}")
        if arr.ndim != 1:
            raise ShapeError(f"sources must be one index or a 1-D array, got shape {arr.shape}")
        if arr.dtype == np.uint64 and arr.max() >= n:
            raise _arrays.not_a_vertex("sources holds", int(arr.max()), n)
        s = np.unique(arr.astype(np.int64))
    bad = s[(s < 0) | (s >= n)]
    if bad.size:
        raise _arrays.not_a_vertex("sources holds", int(bad[0]), n)
    unused = s[~used[s]]
    if unused.size:
        raise IndexRangeError(f"source {int(unused[0])} is in no element of the mesh",
                              index=int(unused[0]))
    return s


def _boundary_vertices(T: np.ndarray, n: int) -> np.ndarray:
    """Mask (n,) of the vertices on a facet (triangle of a tet, edge of a triangle) that
    belongs to one element only."""
    k = T.shape[1]
    facets = np.sort(np.concatenate([np.delete(T, a, axis=1) for a in range(k)]), axis=1)
    unique, counts = np.unique(facets, axis=0, return_counts=True)
    mask = np.zeros(n, dtype=bool)
    mask[unique[counts == 1].ravel()] = True
    return mask


def _norms(X: np.ndarray) -> np.ndarray:
    """Euclidean norms of the rows of ``X`` (m, d) without overflow or underflow of the
    squares (a gradient of 1e-200 has norm 1e-200, not 0)."""
    norm = np.abs(X[:, 0])
    for c in range(1, X.shape[1]):
        norm = np.hypot(norm, X[:, c])
    return norm


def _decimal(mantissa: float, exponent: int) -> str:
    """``mantissa * 2^exponent`` in decimal with 4 digits, also beyond the float64 range
    (``"1.685e-401"``)."""
    try:
        return f"{_scaled(mantissa, exponent):.4g}"
    except OverflowError:
        pass
    log = math.log10(abs(mantissa)) + exponent * math.log10(2.0)
    power = math.floor(log)
    digits = 10 ** (log - power)
    if round(digits, 3) >= 10:
        digits, power = digits / 10, power + 1
    return f"{math.copysign(digits, mantissa):.4g}e{power:+d}"


def _scaled(value: float, exponent: int) -> float:
    """``value * 2^exponent`` as a float, or an OverflowError saying that it is beyond the
    float64 range (``ldexp`` would give inf or 0, or a subnormal without its digits)."""
    out = math.ldexp(value, exponent) if value else 0.0
    if value and not (_TINY <= abs(out) < math.inf):
        raise OverflowError
    return out


class HeatDistance:
    """The heat method's distance from any set of source vertices, factorized once.

    Parameters
    ----------
    V : (n, d) array-like, T : (m, 4) or (m, 3) array-like, optional
        The mesh, as :func:`tetlap.laplacian` takes it (or one mesh object as ``V``).
    t : float > 0, optional
        The heat step's time, in squared length units; default ``h^2`` with ``h`` the mean
        edge length (the paper's choice: the error then converges with ``h``). Any positive
        float is either computed or refused (module docs, "Scale"): far above ``h^2`` the
        distance tends to the limit of a flat heat (computed exactly), far below it the
        heat does not reach the whole mesh within float64 (an OptionError from
        :meth:`distance` naming the vertex).
    laplacian : {"primal", "dual"} or float in [0, 1], default "primal"
        The Laplacian of the heat and Poisson steps (any kind :func:`tetlap.laplacian`
        takes; ``weights=`` gives the weighted dual). The divergence is always the P1 one,
        so that for the primal ``div grad`` is exactly ``L``. The heat step needs ``M - t
        L`` positive definite (a heat flow): always so for the primal with a positive mass;
        a dual with negative weights (a mesh that is not Delaunay) usually makes it
        indefinite, which is refused (SolveError); then take the primal, or the weighted
        dual with :func:`tetlap.regular_weights` (its weights make a regular mesh's dual
        weights non-negative).
    boundary_condition : {"neumann", "dirichlet", "average"}, default "neumann"
        The heat step's boundary condition. ``"neumann"`` (no flux; the paper's default
        and LaPy's): two factorizations and two solves per call. ``"dirichlet"``: ``u = 0``
        on boundary vertices that are not sources (a boundary source keeps ``u = 1 /
        A_ss``, the value its delta gives at its own vertex to first order).
        ``"average"``: the mean of both, which the paper recommends against the bending of
        isolines that each condition causes alone; one more factorization and one more
        solve per call. The default is ``"neumann"`` for its cost: on balls it meets the
        accuracy targets with two factorizations, and ``"average"`` is slightly more
        accurate (mean error 0.80% against 0.97% of the largest distance from a boundary
        vertex of ``ball(30000)``, the same from the centre: :doc:`/project/experiments`). Pure
        ``"dirichlet"`` is poor from boundary sources (about 20%). (Called ``boundary``
        until 0.1; that name still works, deprecated.)
    mass : {"barycentric", "circumcentric", "mixed"}, default "barycentric"
        The lumped mass of the heat step (``"circumcentric"`` has negative entries on
        meshes that are not Delaunay, which can make the heat step indefinite: refused).
    weights, boundary_centres, degenerate, threads
        As for :func:`tetlap.laplacian` (``boundary_centres`` was ``dual_boundary`` until
        0.1; that name still works, deprecated). Skipped degenerate elements have no
        gradient and no volume.
    progress : bool, optional
        Report the set-up's steps on stderr (assembly, each factorization; default: when
        stderr is a terminal).

    Attributes
    ----------
    h : float
        The mean edge length (of the elements that are not skipped).
    t : float
        The heat step's time (an OverflowError when ``h^2`` is beyond the float64 range,
        edges longer than 1.3e154 or shorter than 1.5e-154: the distance is computed in a
        rescaled frame all the same, see ``t_over_h2``).
    t_over_h2 : float
        ``t / h^2`` (1.0 by default), which decides the regime of the heat step.
    n_factorizations : int
        The factorizations of the set-up: one per heat step (Neumann, Dirichlet; none for
        a Neumann step solved as its limit) and one for the Poisson step.

    Raises
    ------
    tetlap.SolveError
        The heat step's matrix ``M - t L`` is not positive definite (the inertia of its
        factorization says how many eigenvalues are negative), or the Poisson step's is
        singular.
    tetlap.TetlapError
        Bad mesh or options (the subclass says which).

    Notes
    -----
    Distances are ``inf`` on the components of the mesh without a source and on vertices
    in no element (neither is ever NaN); vertices only in skipped degenerate elements count
    as in no element. An element where ``grad u`` is exactly zero (``u``
    constant on it, or skipped as degenerate) gets ``X = 0``.

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(6)
    >>> heat = tetlap.HeatDistance(V, T)
    >>> d0, d1 = heat.distance(0), heat.distance([0, len(V) - 1])   # one factorization
    >>> round(float(d0[-1]), 2)        # the far corner, at sqrt(3) = 1.73
    1.77
    >>> float(d1.min()), bool(d1[0] < 0.02 and d1[-1] < 0.02)    # both sources near 0
    (0.0, True)
    """

    @_options.renamed(boundary="boundary_condition", dual_boundary="boundary_centres")
    @_arrays.takes_mesh_object
    def __init__(self, V, T=None, *, t=None, laplacian="primal", boundary_condition="neumann",
                 mass="barycentric", weights=None, boundary_centres="circumcentric",
                 degenerate="raise", threads=None, progress=None) -> None:
        if boundary_condition not in BOUNDARY_CONDITIONS:
            raise OptionError(f"boundary_condition must be one of "
                              f"{', '.join(BOUNDARY_CONDITIONS)}, got {boundary_condition!r}")
        if mass not in ("barycentric", "circumcentric", "mixed"):
            raise OptionError(f'mass must be a lumped kind ("barycentric", "circumcentric", '
                              f'"mixed"), got {mass!r}')
        if t is not None:
            _options.positive(t, "t")
        step = progress if isinstance(progress, Stages) else Stages(
            "HeatDistance", _options.flag(progress, "progress") if progress is not None else None)
        step("assemble")
        V, T = _arrays.mesh(V, T)
        V, T = _arrays.points(V), _arrays.elements(T)
        n = len(V)
        used, T_used = _arrays.used_vertices(V, T)
        # the frame: the mesh scaled by 2^-e to unit size (exact), so that every power of
        # two scaling of the mesh is computed bitwise alike (distances scale by 2^e back)
        self._e = frame_exponent(V[used], T_used)
        V = np.ldexp(V, -self._e)
        if weights is not None:
            weights = np.ldexp(_arrays.vertex_weights(weights, n), -2 * self._e)
        L, M = assembly.operators(V, T, laplacian, mass, boundary_centres=boundary_centres,
                                  weights=weights, degenerate=degenerate, threads=threads)
        g, vol = calculus.element_gradients(V, T, degenerate=degenerate, threads=threads)
        self._G = calculus._operator(g, T, n)
        # the divergence D = -G^T diag(vol (x) 1_d), applied through G's transpose (a CSC
        # view, no copy) rather than built
        self._vol = np.repeat(vol, V.shape[1])
        self._d = V.shape[1]
        # what takes part: the vertices and edges of elements that are not skipped
        live = T[vol > 0]
        if not len(live):
            raise DegenerateElementError("every element is degenerate: nothing to solve on")
        self._used = np.zeros(n, dtype=bool)
        self._used[live.ravel()] = True
        edges = _core.edges(live, n, options={"threads": threads})
        h = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
        self.h = math.ldexp(h, self._e)
        # t = mantissa 2^texp in the frame; the heat matrix is scaled by 2^-p (exact) so
        # that neither t L overflows nor its solution underflows, p = max(texp, 0)
        mantissa, texp = math.frexp(float(t)) if t is not None else math.frexp(h * h)
        if t is not None:
            texp -= 2 * self._e
        self._t = (mantissa, texp)
        try:
            self._t_over_h2 = math.ldexp(mantissa / (h * h), texp)
        except OverflowError:
            self._t_over_h2 = math.inf
        p = max(texp, 0)
        t_scaled = math.ldexp(mantissa, texp - p)      # t 2^-p: [0.5, 1) when p > 0
        self.boundary_condition = boundary_condition
        self.n = n
        self._laplacian, self._mass = laplacian, mass
        _, self._labels = csgraph.connected_components(
            sp.coo_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)),
            directed=False)
        L, M = sp.csr_array(L), sp.csr_array(M)
        m = M.diagonal()
        mass_scaled = np.ldexp(m, -p)
        A = sp.csr_array(sp.diags_array(mass_scaled) - t_scaled * L)
        used = np.flatnonzero(self._used)
        self._factors = 0
        self._order = None    # vertices in the elimination order of the first factorization
        # the components with vertices, and whether the Neumann step resolves their mass
        labels = self._labels[used]
        per_vertex = (np.bincount(labels, weights=mass_scaled[used])
                      / np.maximum(np.bincount(labels), 1))
        largest = np.zeros(labels.max() + 1)
        np.maximum.at(largest, labels, np.abs(A.diagonal()[used]))
        self._limit = bool(np.any(per_vertex[np.unique(labels)]
                                  < MASS_RESOLUTION * largest[np.unique(labels)]))
        self._mass_scaled = mass_scaled
        self._t_scaled = t_scaled
        if boundary_condition != "dirichlet" and not self._limit:
            step("factorize the heat step (Neumann)")
            self._heat_neumann = (used, self._factor(A, used, heat=True))
        if boundary_condition != "neumann":
            step("factorize the heat step (Dirichlet)")
            on_boundary = _boundary_vertices(live, n)
            inner = np.flatnonzero(self._used & ~on_boundary)
            self._diagonal = A.diagonal()
            self._A_inner = A[inner]          # the rows of the inner vertices, for the rhs
            self._on_boundary = on_boundary
            self._heat_dirichlet = (inner, self._factor(A, inner, heat=True)
                                    if len(inner) else None)
        # the Poisson step: one vertex pinned per component (L's null space is constants)
        step("factorize the Poisson step")
        pinned = np.zeros(n, dtype=bool)
        pinned[used[np.unique(self._labels[used], return_index=True)[1]]] = True
        free = np.flatnonzero(self._used & ~pinned)
        self._poisson = (free, self._factor(-L, free) if len(free) else None)
        if self._limit and boundary_condition != "dirichlet" and self._poisson[1] is not None:
            # M - t L = t (M / t - L), positive definite exactly when -L is semidefinite
            # with the constants as its only null space: when -L_FF is positive definite
            self._refuse_indefinite(self._poisson[1], "-L (pinned)")
        self.n_factorizations = self._factors
        step.done()

    @property
    def t(self) -> float:     # documented under Attributes
        mantissa, texp = self._t
        try:
            return _scaled(mantissa, texp + 2 * self._e)
        except OverflowError:
            raise OverflowError(
                f"t = h^2 = {_decimal(mantissa, texp + 2 * self._e)} is beyond the float64 "
                f"range (normal magnitudes {_TINY:.3g} to {np.finfo(np.float64).max:.3g}); "
                f"the distance is computed all the same, in the mesh scaled by "
                f"2^{-self._e} to unit size") from None

    def _t_text(self) -> str:
        """``t`` for messages, in decimal even beyond the float64 range:
        ``"t = 0.0016 = 1 h^2"``."""
        mantissa, texp = self._t
        return f"t = {_decimal(mantissa, texp + 2 * self._e)} = {self._t_over_h2:.3g} h^2"

    def _factor(self, A, rows: np.ndarray, heat: bool = False):
        """The factorization of ``A[rows][:, rows]``. The first one's nested dissection is
        kept as an order of vertices and restricted to the later ones' rows (the same
        graph less a few vertices), so that the set-up orders the mesh once. A heat step's
        must be positive definite."""
        self._factors += 1
        ordering = "auto"
        if self._order is not None:
            rank = np.full(self.n, -1, dtype=np.int64)
            rank[self._order] = np.arange(len(self._order))
            if (rank[rows] >= 0).all():
                ordering = np.argsort(rank[rows], kind="stable")
        F = factorize(A[rows][:, rows], ordering=ordering, progress=False)
        if self._order is None and F.permutation is not None:
            self._order = rows[F.permutation]
        if heat:
            self._refuse_indefinite(F, "M - t L")
        return F

    def _refuse_indefinite(self, F, matrix: str) -> None:
        """SolveError unless the factorization ``F`` proves its matrix positive definite:
        an ``LL^T`` does; an ``LDL^T``'s inertia counts the eigenvalue signs."""
        if F.info.method == "LL^T":
            return
        negative, zero, positive = F.inertia()
        if negative == 0 and zero == 0:
            return
        why = []
        if self._laplacian != "primal":
            why.append(f"laplacian={self._laplacian!r} has negative weights on a mesh that is "
                       "not Delaunay: use laplacian='primal', or the weighted dual with "
                       "weights=tetlap.regular_weights(V, T).weights")
        if self._mass == "circumcentric":
            why.append("mass='circumcentric' has negative entries on a mesh that is not "
                       "Delaunay: use 'barycentric' or 'mixed'")
        raise SolveError(
            f"the heat step's matrix M - t L ({self._t_text()}) is not positive definite: "
            f"the LDL^T of {matrix} has {negative} negative and {zero} zero pivots of "
            f"{negative + zero + positive} (by Sylvester's law of inertia, as "
            "many eigenvalues), so the step is no heat flow and its distances would be "
            "meaningless" + ("; " + "; ".join(why) if why else ""))

    def _heat(self, s: np.ndarray) -> np.ndarray:
        """``u`` of the heat step from the sources ``s`` (in the units of the scaled heat
        matrix, up to a constant; only its gradient's direction is used)."""
        delta = np.zeros(self.n)
        delta[s] = 1.0
        parts, plain = [], True
        if self.boundary_condition != "dirichlet":
            u, plain = self._heat_neumann_step(delta)
            parts.append(u)
        if self.boundary_condition != "neumann":
            inner, factor = self._heat_dirichlet
            u = np.zeros(self.n)
            at_boundary = s[self._on_boundary[s]]
            u[at_boundary] = 1.0 / self._diagonal[at_boundary]
            if factor is not None:
                rhs = delta[inner] - self._A_inner @ u
                u[inner] = factor.solve(rhs)
            parts.append(u)
        u = sum(parts) / len(parts)
        if plain:   # not shifted by a constant: its magnitude is the heat's
            where = np.isin(self._labels, self._labels[s]) & self._used
            if self.boundary_condition == "dirichlet":
                where &= ~self._on_boundary      # 0 there by the condition
            self._check_reach(u, where, s)
        return u

    def _deflated(self, delta: np.ndarray) -> np.ndarray:
        """``delta - a M 1`` per component, ``a`` so that each sums to 0 (orthogonal to the
        constants, the heat step's near null space for large t)."""
        labels = np.where(self._used, self._labels, self._labels.max() + 1)
        mass = np.where(self._used, self._mass_scaled, 0.0)
        a = np.bincount(labels, weights=delta) / np.maximum(np.bincount(labels, weights=mass),
                                                            _TINY)
        return delta - a[labels] * mass

    def _heat_neumann_step(self, delta) -> tuple[np.ndarray, bool]:
        """``(u, plain)``: the Neumann step's ``u``, and whether it is the plain solution
        (not shifted by a constant: the limit's and the deflated ones are)."""
        if self._limit:
            return self._heat_limit(self._deflated(delta)), False
        used, factor = self._heat_neumann
        u = np.zeros(self.n)
        u[used] = factor.solve(delta[used])
        # u spread so evenly that its common part dominates: the same gradient from delta
        # less its mean, which the near null space of M - t L does not amplify
        values = u[np.isin(self._labels, self._labels[delta > 0]) & self._used]
        if values.max() - values.min() < values.min():
            u[used] = factor.solve(self._deflated(delta)[used])
            return u, False
        return u, True

    def _heat_limit(self, r: np.ndarray) -> np.ndarray:
        """``u`` with ``(M' - t' L) u = r`` (``r`` orthogonal to the constants per
        component), up to a constant, from the Poisson factorization: the fixed point of
        ``-L z = r - M' z / t'``, ``z`` orthogonal to the constants in the ``M'`` inner
        product, which converges at the rate ``1 / (t lambda_2)``."""
        free, factor = self._poisson
        labels = np.where(self._used, self._labels, self._labels.max() + 1)
        mass = np.where(self._used, self._mass_scaled, 0.0)
        total = np.maximum(np.bincount(labels, weights=mass), _TINY)
        z = np.zeros(self.n)
        for _ in range(LIMIT_ITERATIONS):
            new = np.zeros(self.n)
            if factor is not None:
                new[free] = factor.solve((r - mass * z / self._t_scaled)[free])
            new -= (np.bincount(labels, weights=mass * new) / total)[labels]
            new[~self._used] = 0.0
            change = np.abs(new - z).max()
            z = new
            if change <= 2.0**-50 * np.abs(z).max():
                return z / self._t_scaled
        raise OptionError(
            f"{self._t_text()} is too large for this mesh: the heat step's mass "
            f"term is below the rounding of t L, and its limit did not converge in "
            f"{LIMIT_ITERATIONS} solves (a mesh very many edges across); take a smaller t")

    def _check_reach(self, u: np.ndarray, where: np.ndarray, s: np.ndarray) -> None:
        """OptionError if the heat ``u`` is 0 or below the normal float64 range at a vertex
        of ``where`` (the sources' components): its gradient's direction is lost there."""
        lost = where & (np.abs(u) < _TINY)
        if not lost.any():
            return
        v = int(np.flatnonzero(lost)[0])
        dirichlet = ("; or boundary_condition='neumann' or 'average' (the Dirichlet "
                     "condition holds the heat at 0 on the boundary)"
                     if self.boundary_condition == "dirichlet" else "")
        raise OptionError(
            f"the heat step ({self._t_text()}) does not reach vertex {v} and "
            f"{int(lost.sum()) - 1} more vertices of the sources' component within float64: "
            f"its solution is {abs(u[v]):.3g} there (against {np.abs(u[s]).max():.3g} at the "
            f"sources), so the direction to the sources is lost; take a larger t (the heat "
            f"spreads about sqrt(t) from the sources; the default is h^2){dirichlet}")

    def distance(self, sources) -> np.ndarray:
        """The distance of every vertex from the nearest of ``sources``.

        Parameters
        ----------
        sources : int or 1-D array-like of int
            One source vertex or a set (their order and repeats do not matter); every one
            a vertex of some element.

        Returns
        -------
        d : (n,) float64 array
            ``>= 0``, with minimum exactly 0 on every component with a source (the
            paper's shift; the sources themselves are near 0, within the method's error),
            ``inf`` on components without a source and on vertices in no element.

        Raises
        ------
        tetlap.IndexRangeError
            A source outside ``0..n-1`` or in no element.
        tetlap.ShapeError, tetlap.OptionError
            An empty set, or not integers.
        tetlap.OptionError
            ``t`` so small that the heat step's solution falls below the float64 range at
            a vertex of the sources' component, or so large that its limit does not
            converge (module docs, "Scale").
        tetlap.SolveError
            A singular Poisson matrix (an indefinite dual on a bad mesh).
        """
        s = _sources(sources, self.n, self._used)
        u = self._heat(s)
        grad = (self._G @ u).reshape(-1, self._d)
        norm = _norms(grad)
        X = np.divide(-grad, norm[:, None], out=np.zeros_like(grad), where=norm[:, None] > 0)
        b = -(self._G.T @ (self._vol * X.reshape(-1)))
        free, factor = self._poisson
        phi = np.zeros(self.n)
        if factor is not None:
            phi[free] = factor.solve(-b[free])   # the factor is of -L_FF
        d = np.full(self.n, np.inf)
        for label in np.unique(self._labels[s]):
            component = (self._labels == label) & self._used
            d[component] = phi[component] - phi[component].min()
        return np.ldexp(d, self._e)


@_options.renamed(boundary="boundary_condition", dual_boundary="boundary_centres")
@_arrays.takes_mesh_object
def heat_distance(V, T=None, sources=None, **options) -> np.ndarray:
    """The heat method's distance from ``sources``: ``HeatDistance(V, T, **options)
    .distance(sources)`` (build a :class:`HeatDistance` to reuse its factorizations for
    several source sets).

    Parameters
    ----------
    V, T
        The mesh (or one mesh object as ``V``).
    sources : int or 1-D array-like of int
        As :meth:`HeatDistance.distance`.
    **options
        The keywords of :class:`HeatDistance` (``t``, ``laplacian``,
        ``boundary_condition``, ...).

    Returns
    -------
    d : (n,) float64 array
        As :meth:`HeatDistance.distance`: ``>= 0``, minimum 0.

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(5)
    >>> d = tetlap.heat_distance(V, T, 0)
    >>> float(d.min()), bool(d[0] < 0.02), bool(abs(d.max() - 3 ** 0.5) < 0.1)
    (0.0, True, True)
    """
    if sources is None:
        raise TypeError("heat_distance() needs sources: a vertex index or a set of them")
    return HeatDistance(V, T, **options).distance(sources)
