"""Moving interior vertices to remove negative dual weights, with tetlap's gradients.

The dual Laplacian has non-negative weights on the interior of a Delaunay mesh (a maximum
principle), and negative ones on many real meshes. :func:`improve` keeps the connectivity
and the boundary and moves the interior vertices to reduce the negative interior weights,
minimising with SciPy's L-BFGS-B (a quasi-Newton method) the objective

.. math::

    \\Phi(X) = \\sum_{e} \\max(0, \\delta - w_e(X) / h)^2
             + \\mu \\sum_t \\beta(q_t(X) / q_t(X_0))
             + \\lambda \\sum_i |x_i - x_i^0|^2 / h^2

* the first sum runs over the edges whose endpoints are not both on the boundary (the
  edges of the paper's Fig. 12 statistic and of :func:`tetlap.check`), ``w_e`` the summed
  dual weight, ``h`` the mean edge length of the input, ``delta`` the ``margin``: a squared
  hinge that pushes every weight above ``delta h``, with the gradient of
  :func:`tetlap.vjp`;
* ``q_t = vol_t / (sum of its squared edge lengths)^(3/2)`` is a scale-invariant shape
  quality (signed like the volume, zero for a flat tet) and ``beta(r) = (r0 / r - 1)^2``
  for ``r < r0 = 1/2``, zero above: every tet may change its shape freely until its
  quality halves, then the barrier keeps it from flattening (and so from inverting);
  below ``r = 10^-3`` it continues as its quadratic Taylor polynomial, so that the line
  search sees a huge but finite value at an inverted tet and steps back;
* the last term (``regularization``) keeps the vertices near the input and makes the
  minimum well defined for vertices that no weight depends on.

The boundary vertices (those on a boundary face), the vertices of degenerate tets and any
vertex in ``fixed`` do not move. Every vertex stays in a box of half-width ``step`` times
its shortest edge around its start. No tet is inverted: if the optimiser's result turned
any tet over (or flattened it to below ``10^-3`` of its quality), the move is scaled back
(halved) until none is. The penalty cannot tell a weight of ``-10^-9 h`` from one of
``+10^-9 h`` (meshes with many zero weights, such as structured grids, would trade them),
so the move is finally scaled by the factor among ``1, 1/2, ..., 1/64, 0`` that leaves the
fewest negative interior weights (the largest such factor): the result never has more
negative interior weights than the input.

The objective is :class:`Objective`; the two safeguards are :func:`keep_orientation` and
:func:`fewest_negative_weights`. A mesh far outside everyday units (a bounding box beyond
``2^64`` or below ``2^-64``) is moved in a copy rescaled by a power of two (exact), and a
mesh whose tet volumes leave the float64 range is refused
(:class:`tetlap.DegenerateElementError`), as the assembly refuses it.

>>> import tetlap
>>> from tetlap.improve import improve
>>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
>>> result = improve(V, T, max_iterations=30)
>>> result.after["negative_interior"] < result.before["negative_interior"]
True
>>> bool((tetlap.diagnostics.signed_volumes(result.V, T) > 0).all())  # no tet inverted
True
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from . import _arrays, _options, assembly, derivatives, diagnostics
from ._float_range import check_float_range, unit_scale
from .errors import ShapeError
from .analysis import negative_weights
from ._names import public_dir

__all__ = ["improve", "Improvement", "Objective", "keep_orientation",
           "fewest_negative_weights", "dual_statistics", "MAX_MARGIN", "MAX_WEIGHT"]
__dir__ = public_dir(globals())

#: Tets may lose this fraction of their quality before the barrier acts.
R0 = 0.5
#: Below this quality ratio the barrier is quadratic (finite at inverted tets).
R1 = 1e-3


def dual_statistics(V, T) -> dict:
    """Numbers :func:`improve` reports: negative dual weights over the edges not both on
    the boundary (:func:`tetlap.check`'s count), non-Delaunay interior faces, the minimum
    dihedral angle (degrees) and the smallest tet volume, for ``(V, T)`` in R^3."""
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    edges, w = assembly.edge_weights(V, T, "dual", degenerate="skip")
    on_boundary = diagnostics.boundary_vertices(V, T)
    inner = ~(on_boundary[edges[:, 0]] & on_boundary[edges[:, 1]])
    L = assembly.laplacian(V, T, "dual", degenerate="skip")
    vol = np.abs(diagnostics.signed_volumes(V, T))
    return {
        "interior_edges": int(inner.sum()),
        "negative_interior": negative_weights(L, V, T, on_boundary)[1],
        "min_interior_weight": float(w[inner].min()) if inner.any() else 0.0,
        "non_delaunay_faces": int(diagnostics.non_delaunay_faces(V, T).sum()),
        "interior_faces": int(len(diagnostics.interior_faces(T)[0])),
        "min_dihedral_deg": float(np.nanmin(diagnostics.dihedral_angles(V, T))),
        "min_volume": float(vol.min()),
    }


@dataclass
class Improvement:
    """The result of :func:`improve`."""

    V: np.ndarray
    """(n, 3) float64: the improved positions (a new array)."""
    before: dict
    """:func:`dual_statistics` of the input."""
    after: dict
    """:func:`dual_statistics` of the result."""
    objective: tuple[float, float]
    """The objective before and after."""
    iterations: int
    evaluations: int
    seconds: float
    """Wall time of the optimisation (statistics excluded)."""
    message: str
    """The optimiser's message, and any scaling back of the move."""
    moved: int
    """Number of vertices allowed to move."""
    history: list = field(default_factory=list)
    """The objective after every iteration."""


def _barrier(r):
    """``beta(r)`` and ``beta'(r)`` (see the module docs), elementwise."""
    r = np.asarray(r, dtype=np.float64)
    b = np.zeros_like(r)
    db = np.zeros_like(r)
    mid = (r < R0) & (r >= R1)
    u = R0 / r[mid] - 1
    b[mid] = u * u
    db[mid] = -2 * u * R0 / r[mid] ** 2
    low = r < R1
    if low.any():
        u1 = R0 / R1 - 1
        d1 = -2 * u1 * R0 / R1**2
        d2 = 2 * (R0 / R1**2) ** 2 + 4 * u1 * R0 / R1**3
        x = r[low] - R1
        b[low] = u1 * u1 + d1 * x + d2 * x * x / 2
        db[low] = d1 + d2 * x
    return b, db


def _quality_and_gradient(X, T):
    """Signed qualities ``q = vol / S^(3/2)`` (m,), ``S`` the sum of the squared edge
    lengths, and their gradients per corner (m, 4, 3)."""
    P = X[T]
    P = P - P.mean(axis=1, keepdims=True)  # centred: S = 4 sum |p_a|^2, dS/dp_a = 8 p_a
    e1, e2, e3 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]
    g1, g2, g3 = np.cross(e2, e3), np.cross(e3, e1), np.cross(e1, e2)
    vol = np.einsum("ij,ij->i", e1, g1) / 6
    dvol = np.stack([-(g1 + g2 + g3), g1, g2, g3], axis=1) / 6
    S = 4 * np.einsum("ijk,ijk->i", P, P)
    q = vol / S**1.5
    dq = dvol / S[:, None, None] ** 1.5 - (1.5 * 8 * vol / S**2.5)[:, None, None] * P
    return q, dq


def _scatter(T, per_corner, n):
    """Sum (m, 4, 3) per-corner values onto the (n, 3) vertices."""
    flat = T.ravel()
    return np.stack([np.bincount(flat, per_corner[:, :, c].ravel(), minlength=n)
                     for c in range(3)], axis=1)


class Objective:
    """The objective ``Phi`` of the module docs on one mesh, as L-BFGS-B calls it.

    ``x`` holds the coordinates of the free vertices, flattened: (3 k,) float64, ``k`` =
    ``len(self.free)``; ``positions(x)`` puts them into a copy of ``V0``. Calling the
    objective returns ``(Phi, dPhi/dx)`` and counts the evaluation.

    Parameters
    ----------
    V0 : (n, 3) float64, T : (m, 4) int64
        The validated input mesh.
    fixed : (n,) bool
        Vertices that must not move besides the boundary and the vertices of flat tets.
    margin, barrier, regularization : float
        ``delta``, ``mu`` and ``lambda`` of the module docs.
    threads : int or None
        Worker threads of the core.
    """

    def __init__(self, V0, T, fixed, *, margin, barrier, regularization, threads):
        n = len(V0)
        self.V0, self.T, self.threads = V0, T, threads
        self.margin, self.barrier, self.regularization = margin, barrier, regularization
        self.edges = diagnostics.mesh_edges(T)
        self.lengths = np.linalg.norm(V0[self.edges[:, 0]] - V0[self.edges[:, 1]], axis=1)
        self.h = float(self.lengths.mean())
        with np.errstate(invalid="ignore", divide="ignore"):
            q0, _ = _quality_and_gradient(V0, T)
        # flat tets (and tets with coincident corners, q = NaN) neither move nor count
        size = np.abs(q0)
        largest = 0.0 if np.isnan(size).all() else np.nanmax(size)
        flat = ~(size > 1e-12 * largest)
        self.on_boundary = diagnostics.boundary_vertices(T, n)
        self.inner = ~(self.on_boundary[self.edges[:, 0]] & self.on_boundary[self.edges[:, 1]])
        free = diagnostics.referenced_vertices(T, n) & ~self.on_boundary & ~fixed
        free[T[flat].ravel()] = False
        self.free = np.flatnonzero(free)
        self.kept, self.q0 = T[~flat], q0[~flat]
        self.evaluations = 0

    def start(self) -> np.ndarray:
        """The free vertices' input coordinates, (3 k,)."""
        return self.V0[self.free].ravel()

    def bounds(self, step: float) -> np.ndarray:
        """(3 k, 2) L-BFGS-B bounds: a box of half-width ``step`` times each free vertex's
        shortest edge around its start."""
        shortest = np.full(len(self.V0), np.inf)
        np.minimum.at(shortest, self.edges[:, 0], self.lengths)
        np.minimum.at(shortest, self.edges[:, 1], self.lengths)
        half = np.repeat(step * shortest[self.free], 3)
        x0 = self.start()
        return np.column_stack([x0 - half, x0 + half])

    def positions(self, x) -> np.ndarray:
        """(n, 3): ``V0`` with the free vertices at ``x``."""
        X = self.V0.copy()
        X[self.free] = x.reshape(-1, 3)
        return X

    def quality_ratios(self, X) -> np.ndarray:
        """``q_t(X) / q_t(V0)`` of the tets that count (not flat at the start)."""
        return _quality_and_gradient(X, self.kept)[0] / self.q0

    def negative_interior(self, X) -> int:
        """Negative dual weights at ``X`` on the edges not both on the boundary."""
        L = assembly.laplacian(X, self.T, "dual", degenerate="skip", threads=self.threads)
        return negative_weights(L, X, self.T, self.on_boundary)[1]

    def __call__(self, x) -> tuple[float, np.ndarray]:
        self.evaluations += 1
        X, T, h, n = self.positions(x), self.T, self.h, len(self.V0)
        _, w = assembly.edge_weights(X, T, "dual", degenerate="skip", threads=self.threads)
        gap = np.maximum(0.0, self.margin - w[self.inner] / h)
        phi = float(gap @ gap)
        g = np.zeros_like(X)
        if gap.any():
            g += derivatives.vjp(X, T, "dual", dL=(self.edges[self.inner], -2 * gap / h),
                                 degenerate="skip", threads=self.threads).dV
        q, dq = _quality_and_gradient(X, self.kept)
        b, db = _barrier(q / self.q0)
        phi += self.barrier * float(b.sum())
        g += self.barrier * _scatter(self.kept, dq * (db / self.q0)[:, None, None], n)
        d = (X[self.free] - self.V0[self.free]) / h
        phi += self.regularization * float((d * d).sum())
        grad = g[self.free] + 2 * self.regularization * d / h
        return phi, grad.ravel()


def keep_orientation(objective: Objective, x0, x) -> float:
    """The largest factor ``alpha`` among ``1, 1/2, ..., 2^-30, 0`` for which the move
    ``x0 + alpha (x - x0)`` turns no tet over nor flattens one below ``R1`` of its
    starting quality."""
    alpha = 1.0
    while alpha > 0:
        if np.all(objective.quality_ratios(objective.positions(x0 + alpha * (x - x0))) > R1):
            break
        alpha = alpha / 2 if alpha > 2**-30 else 0.0
    return alpha


def fewest_negative_weights(objective: Objective, x0, x, alpha: float) -> float:
    """The factor among ``alpha, alpha / 2, ..., alpha / 64, 0`` whose move leaves the
    fewest negative interior weights (the largest such): the penalty cannot tell a weight
    of ``-1e-9 h`` from one of ``+1e-9 h``, the count can, so the result never has more
    than the input (factor 0)."""
    if alpha == 0:
        return alpha
    candidates = [alpha * 0.5**k for k in range(7)] + [0.0]
    counts = [objective.negative_interior(objective.positions(x0 + a * (x - x0)))
              for a in candidates]
    return candidates[int(np.argmin(counts))]  # the first, largest, of the fewest


#: The largest ``margin``: the squared hinge of a larger one leaves the float range.
MAX_MARGIN = 1e6
#: The largest ``barrier`` and ``regularization``: weights beyond make the objective
#: overflow (1e300 did, with a NumPy warning, and nothing moved).
MAX_WEIGHT = 1e12


def _check_options(margin, barrier, regularization, step, max_iterations, threads) -> None:
    _options.at_most(_options.non_negative(margin, "margin"), MAX_MARGIN, "margin")
    _options.at_most(_options.non_negative(barrier, "barrier"), MAX_WEIGHT, "barrier")
    _options.at_most(_options.non_negative(regularization, "regularization"), MAX_WEIGHT,
                     "regularization")
    _options.positive(step, "step")
    _options.count(max_iterations, "max_iterations")
    _options.threads(threads)


def improve(V, T, *, fixed=None, margin: float = 0.02, barrier: float = 10.0,
            regularization: float = 1e-4, step: float = 0.3, max_iterations: int = 200,
            threads: int | None = None, progress=None) -> Improvement:
    """Move interior vertices to reduce the negative interior dual weights.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers
        Vertex positions (never modified).
    T : (m, 4) array-like of integers
        Tets, any orientation (each keeps its own).
    fixed : (n,) bool mask or integer vertex indices, optional
        Vertices that must not move, besides the boundary (e.g. vertices on an interior
        interface); ``[]`` is none.
    margin : float in [0, 1e6], default 0.02
        ``delta``: weights below ``delta h`` are penalised (``h`` the mean edge length);
        at most :data:`MAX_MARGIN`.
    barrier : float in [0, 1e12], default 10
        ``mu``, the weight of the quality barrier; at most :data:`MAX_WEIGHT`.
    regularization : float in [0, 1e12], default 1e-4
        ``lambda``, the weight of the displacement term; at most :data:`MAX_WEIGHT`.
    step : float > 0, default 0.3
        Every vertex stays within a box of half-width ``step`` times its shortest edge (a
        box below the rounding of its coordinates: the vertex does not move).
    max_iterations : int >= 1, default 200
        L-BFGS-B iterations.
    threads : int, optional
        Worker threads of tetlap's core (the result does not depend on it).
    progress : callable, optional
        Called as ``progress(iteration, objective)`` after every iteration.

    Returns
    -------
    Improvement
        The new positions ``V``, :func:`dual_statistics` ``before`` and ``after``, the
        objective, counts and time. Deterministic for a given input.

    Raises
    ------
    OptionError
        An option outside its range (NaN and infinities included), before any work.
    ShapeError, DtypeError, IndexRangeError
        Points not in R^3, or a ``fixed`` mask of the wrong shape, of the wrong type or
        naming a vertex the mesh does not have.
    DegenerateElementError
        A tet whose volume leaves the float64 range (see the module docs).

    Notes
    -----
    The objective and its safeguards are in the module docs. It needs SciPy's optimiser;
    the gradient of the weight term is one :func:`tetlap.vjp` per evaluation, so an
    evaluation costs about two assemblies of the dual Laplacian.
    """
    from scipy.optimize import minimize

    _check_options(margin, barrier, regularization, step, max_iterations, threads)
    V0 = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V0.shape[1] != 3:
        raise ShapeError(f"improve needs points in R^3, got dimension {V0.shape[1]}")
    n = len(V0)
    fixed = _arrays.vertex_mask([] if fixed is None else fixed, n, "fixed")
    check_float_range(V0, T)
    before = dual_statistics(V0, T)
    # vertices in no tet take no part (they stay where they are)
    used, T_used = _arrays.used_vertices(V0, T)
    scale = unit_scale(V0[used], T_used)
    objective = Objective(V0[used] / scale, T_used, fixed[used], margin=margin,
                          barrier=barrier, regularization=regularization, threads=threads)
    x0 = objective.start()
    history: list[float] = []
    phi0 = objective(x0)[0]
    start = time.perf_counter()

    def after_iteration(intermediate_result):
        history.append(float(intermediate_result.fun))
        if progress is not None:
            progress(len(history), history[-1])

    bounds = objective.bounds(step)
    if (bounds[:, 0] < bounds[:, 1]).any():
        res = minimize(objective, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                       callback=after_iteration,
                       options={"maxiter": max_iterations, "maxcor": 20})
        x, iterations, message = res.x, int(res.nit), str(res.message)
    elif len(objective.free):  # every box below the rounding of its coordinates
        x, iterations, message = x0, 0, f"step {step:g} leaves no vertex room to move"
    else:
        x, iterations, message = x0, 0, "no vertex can move"
    alpha = keep_orientation(objective, x0, x)
    if alpha < 1:
        message += f"; move scaled by {alpha:g} to keep every tet's orientation"
    best = fewest_negative_weights(objective, x0, x, alpha)
    if best < alpha:
        message += f"; move scaled by {best / alpha:g} for fewer negative weights"
    seconds = time.perf_counter() - start
    x = x0 + best * (x - x0)
    phi1 = objective(x)[0]
    X = V0.copy()
    moved = used[objective.free]
    X[moved] = objective.positions(x)[objective.free] * scale
    return Improvement(V=X, before=before, after=dual_statistics(X, T), objective=(phi0, phi1),
                       iterations=iterations, evaluations=objective.evaluations,
                       seconds=seconds, message=message, moved=len(objective.free),
                       history=history)
