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

import sys
import time
from dataclasses import dataclass, field

import numpy as np

from . import _arrays, assembly, derivatives, diagnostics
from .errors import ShapeError

__all__ = ["improve", "Improvement", "dual_statistics", "format_table"]

#: A weight counts as negative when ``w < -NEGATIVE_TOL * max|w|`` (as in tetlap.check).
NEGATIVE_TOL = 1e-12
#: Tets may lose this fraction of their quality before the barrier acts.
R0 = 0.5
#: Below this quality ratio the barrier is quadratic (finite at inverted tets).
R1 = 1e-3


def dual_statistics(V, T) -> dict:
    """Numbers :func:`improve` reports: negative dual weights over the edges not both on
    the boundary, non-Delaunay interior faces, the minimum dihedral angle (degrees) and
    the smallest tet volume, for ``(V, T)`` in R^3."""
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    edges, w = assembly.edge_weights(V, T, "dual", degenerate="skip")
    on_boundary = diagnostics.boundary_vertices(T, len(V))
    inner = ~(on_boundary[edges[:, 0]] & on_boundary[edges[:, 1]])
    negative = w < -NEGATIVE_TOL * np.abs(w).max()
    vol = np.abs(diagnostics.signed_volumes(V, T))
    return {
        "interior_edges": int(inner.sum()),
        "negative_interior": int((negative & inner).sum()),
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
    fixed : (n,) bool array-like, optional
        Vertices that must not move, besides the boundary (e.g. vertices on an interior
        interface).
    margin : float, default 0.02
        ``delta``: weights below ``delta h`` are penalised (``h`` the mean edge length).
    barrier : float, default 10
        ``mu``, the weight of the quality barrier.
    regularization : float, default 1e-4
        ``lambda``, the weight of the displacement term.
    step : float, default 0.3
        Every vertex stays within a box of half-width ``step`` times its shortest edge.
    max_iterations : int, default 200
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

    Notes
    -----
    The objective and its safeguards are in the module docs. It needs SciPy's optimiser;
    the gradient of the weight term is one :func:`tetlap.vjp` per evaluation, so an
    evaluation costs about two assemblies of the dual Laplacian.
    """
    from scipy.optimize import minimize

    V0 = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V0.shape[1] != 3:
        raise ShapeError(f"improve needs points in R^3, got dimension {V0.shape[1]}")
    n = len(V0)
    before = dual_statistics(V0, T)
    edges = diagnostics.mesh_edges(T)
    lengths = np.linalg.norm(V0[edges[:, 0]] - V0[edges[:, 1]], axis=1)
    h = float(lengths.mean())
    with np.errstate(invalid="ignore", divide="ignore"):
        q0, _ = _quality_and_gradient(V0, T)
    # flat tets (and tets with coincident corners, q = NaN) neither move nor count
    degenerate = ~(np.abs(q0) > 1e-12 * np.nanmax(np.abs(q0)))
    on_boundary = diagnostics.boundary_vertices(T, n)
    inner = ~(on_boundary[edges[:, 0]] & on_boundary[edges[:, 1]])
    edges_in = edges[inner]
    free = diagnostics.referenced_vertices(T, n) & ~on_boundary
    free[T[degenerate].ravel()] = False
    if fixed is not None:
        fixed = np.asarray(fixed, dtype=bool)
        if fixed.shape != (n,):
            raise ShapeError(f"fixed must have shape ({n},), got {fixed.shape}")
        free &= ~fixed
    idx = np.flatnonzero(free)
    shortest = np.full(n, np.inf)
    np.minimum.at(shortest, edges[:, 0], lengths)
    np.minimum.at(shortest, edges[:, 1], lengths)
    half = step * shortest[idx]
    x0 = V0[idx].ravel()
    bounds = np.column_stack([x0 - np.repeat(half, 3), x0 + np.repeat(half, 3)])
    keep = ~degenerate
    Tk, q0k = T[keep], q0[keep]
    counter = {"evaluations": 0}

    def positions(x):
        X = V0.copy()
        X[idx] = x.reshape(-1, 3)
        return X

    def objective(x):
        counter["evaluations"] += 1
        X = positions(x)
        _, w = assembly.edge_weights(X, T, "dual", degenerate="skip", threads=threads)
        s = w[inner] / h
        gap = np.maximum(0.0, margin - s)
        phi = float(gap @ gap)
        g = np.zeros_like(X)
        if gap.any():
            dw = -2 * gap / h
            g += derivatives.vjp(X, T, "dual", dL=(edges_in, dw), degenerate="skip",
                                 threads=threads).dV
        q, dq = _quality_and_gradient(X, Tk)
        b, db = _barrier(q / q0k)
        phi += barrier * float(b.sum())
        g += barrier * _scatter(Tk, dq * (db / q0k)[:, None, None], n)
        d = (X[idx] - V0[idx]) / h
        phi += regularization * float((d * d).sum())
        grad = g[idx] + 2 * regularization * d / h
        return phi, grad.ravel()

    history: list[float] = []
    phi0 = objective(x0)[0]
    start = time.perf_counter()

    def after_iteration(intermediate_result):
        history.append(float(intermediate_result.fun))
        if progress is not None:
            progress(len(history), history[-1])

    if len(idx):
        res = minimize(objective, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                       callback=after_iteration,
                       options={"maxiter": max_iterations, "maxcor": 20})
        x, iterations, message = res.x, int(res.nit), str(res.message)
    else:
        x, iterations, message = x0, 0, "no vertex can move"
    # never return an inverted (or collapsed) tet: scale the move back until none is
    alpha = 1.0
    while alpha > 0:
        X = positions(x0 + alpha * (x - x0))
        q, _ = _quality_and_gradient(X, Tk)
        if np.all(q / q0k > R1):
            break
        alpha = alpha / 2 if alpha > 2**-30 else 0.0
    if alpha < 1:
        message += f"; move scaled by {alpha:g} to keep every tet's orientation"
    # never return more negative weights than the input: the penalty cannot tell a weight
    # of -1e-9 h from one of +1e-9 h, the count can; keep the scaled move with the fewest
    def negatives(a):
        _, w = assembly.edge_weights(positions(x0 + a * (x - x0)), T, "dual",
                                     degenerate="skip", threads=threads)
        return int((w[inner] < -NEGATIVE_TOL * np.abs(w).max()).sum())

    if alpha > 0:
        candidates = [alpha * 0.5**k for k in range(7)] + [0.0]
        counts = [negatives(a) for a in candidates]
        best = candidates[int(np.argmin(counts))]  # the first, largest, of the fewest
        if best < alpha:
            message += f"; move scaled by {best / alpha if alpha else 0:g} for fewer negative weights"
        alpha = best
    seconds = time.perf_counter() - start
    x = x0 + alpha * (x - x0)
    phi1 = objective(x)[0]
    X = positions(x)
    return Improvement(V=X, before=before, after=dual_statistics(X, T), objective=(phi0, phi1),
                       iterations=iterations, evaluations=counter["evaluations"],
                       seconds=seconds, message=message, moved=len(idx),
                       history=history)


# ------------------------------------------------------------------ report

_ROWS = [
    ("negative interior dual weights", "negative_interior", "{:d}"),
    ("min interior dual weight", "min_interior_weight", "{:.3e}"),
    ("non-Delaunay interior faces", "non_delaunay_faces", "{:d}"),
    ("min dihedral angle (deg)", "min_dihedral_deg", "{:.2f}"),
    ("min tet volume", "min_volume", "{:.3e}"),
]


def format_table(result: Improvement) -> str:
    """The before/after numbers as a small text table."""
    width = max(len(r[0]) for r in _ROWS)
    lines = [f"{'':<{width}}  {'before':>12}  {'after':>12}"]
    for label, key, fmt in _ROWS:
        lines.append(f"{label:<{width}}  {fmt.format(result.before[key]):>12}  "
                     f"{fmt.format(result.after[key]):>12}")
    lines.append(f"{result.moved} vertices free to move, {result.iterations} iterations, "
                 f"{result.evaluations} evaluations, {result.seconds:.2f} s "
                 f"(objective {result.objective[0]:.4g} -> {result.objective[1]:.4g}); "
                 f"{result.message}")
    return "\n".join(lines)
