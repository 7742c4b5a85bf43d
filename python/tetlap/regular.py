"""Vertex weights that make a given tetrahedral mesh regular (weighted Delaunay).

A mesh ``(V, T)`` is *regular* for vertex weights ``w`` when it is the projection of the
lower convex hull of the lifted points ``(x_i, |x_i|^2 - w_i)``; locally, when across every
interior face ``abc`` shared by the tets ``abcp`` and ``abcq`` the lifted ``q`` lies above
the hyperplane through the lifted ``a, b, c, p``. Then its weighted dual
(``tetlap.laplacian(V, T, "dual", weights=w)``, the power diagram) is an orthogonal dual
whose interior edge weights are all non-negative: with linear precision (which every
weighted dual has) that is a Laplacian with the maximum principle, as the plain dual is on
Delaunay meshes. :func:`regular_weights` finds such weights, or says that none exist.

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
    Per interior face (order of :func:`tetlap.diagnostics.interior_faces`), the
    signed length of its dual (power-diagram) edge, from the power center of the first tet
    to that of the second, measured along the face normal pointing from the first tet to
    the second, divided by the root-mean-square edge length of the face. Scale-free:
    invariant under rigid motions and under ``V -> s V, w -> s^2 w``. It is ``>= 0``
    exactly when the face is locally regular (for ``w = 0``: locally Delaunay), ``0`` for
    cospherical configurations (the cubes of a Kuhn grid). The condition is linear in
    ``w``: five weights enter it. A *folded* face (both tets on the same side of it, as
    around an inverted tet) gets the smaller of the two tets' conditions, which are of
    opposite signs: its margin is ``<= 0`` for every ``w``.

>>> import tetlap
>>> from tetlap.regular import regular_weights
>>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)   # a non-Delaunay mesh
>>> r = regular_weights(V, T)
>>> bool(r.regular), r.margin > 0, r.n_violated_plain > 0
(True, True, True)
>>> r.n_negative_interior_plain > 0, r.n_negative_interior_weighted
(True, 0)
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import scipy.sparse as sp

from . import _arrays, assembly
from .diagnostics import boundary_vertices, interior_faces
from .errors import OptionError, TetlapError
from .properties import NEGATIVE_TOL

__all__ = [
    "regular_weights",
    "RegularWeights",
    "face_margins",
    "summary",
    "REGULAR_RTOL",
]

#: Round-off tolerance of the regularity test, relative like
#: :data:`tetlap.diagnostics.DELAUNAY_RTOL` (same value): a face counts as locally regular
#: when its margin is ``>= -REGULAR_RTOL * bound``, ``bound`` being the face's margin
#: computed with every term of the lifted determinant taken in absolute value (so a
#: cospherical face, whose exact margin is 0, is never flagged by rounding).
REGULAR_RTOL = 1e-10

#: Margin the weights aim for on the faces they have to repair (default of
#: ``target_margin``): 1% of the face size. Small on purpose: the larger the target, the
#: larger the weights, and large weights shrink the power cells of boundary vertices.
TARGET_MARGIN = 0.01

# HiGHS feasibility tolerance for our LPs (its default is 1e-7): margins are O(1).
_LP_TOL = 1e-9


# --------------------------------------------------------------------------------------
# The linear conditions
# --------------------------------------------------------------------------------------

@dataclasses.dataclass
class _Conditions:
    """Every local regularity condition as ``g(w) = g0 + sum_k G[:, k] * w[idx[:, k]]``."""

    idx: np.ndarray      # (c, 5) the tet's 4 vertices in T order, then the opposite one
    g0: np.ndarray       # (c,) margin at w = 0
    G: np.ndarray        # (c, 5) coefficients (1 / squared length)
    bound0: np.ndarray   # (c,) the w-independent part of the rounding bound
    face: np.ndarray     # (c,) interior face of the condition
    n_faces: int
    tri: np.ndarray      # (f, 3) vertices of every interior face
    folded: np.ndarray   # (f,) bool

    def margins(self, w: np.ndarray) -> np.ndarray:
        return self.g0 + (self.G * w[self.idx]).sum(axis=1)

    def tolerance(self, w: np.ndarray, rtol: float) -> np.ndarray:
        return rtol * (self.bound0 + np.abs(self.G * w[self.idx]).sum(axis=1))

    def per_face(self, values: np.ndarray) -> np.ndarray:
        out = np.full(self.n_faces, np.inf)
        np.minimum.at(out, self.face, values)
        return out


def _condition(V, T, tet, q, norm):
    """Condition "lifted q above the lifted plane of tet" as coefficients, see _Conditions.

    ``D = det[x_i - x_q, |x_i - x_q|^2 - w_i + w_q]`` (rows: the tet's corners in T
    order) is, times the tet's orientation sign, ``4 A h_p h_q`` times the signed length of
    the dual edge; ``norm`` (``4 A h_p h_q l``) makes it the margin.
    """
    R = T[tet]
    E = V[R] - V[q][:, None, :]                        # (c, 4, 3), relative to q
    sq = np.einsum("cid,cid->ci", E, E)
    C = np.empty((len(q), 4))                          # cofactors of the lifted column
    for i in range(4):
        M = E[:, [k for k in range(4) if k != i]]
        C[:, i] = (-1) ** (i + 1) * np.einsum("cd,cd->c", M[:, 0], np.cross(M[:, 1], M[:, 2]))
    e = E[:, 1:] - E[:, :1]
    orient = np.sign(np.einsum("cd,cd->c", e[:, 0], np.cross(e[:, 1], e[:, 2])))
    scale = orient / norm
    g0 = (C * sq).sum(axis=1) * scale
    G = np.concatenate([-C, C.sum(axis=1, keepdims=True)], axis=1) * scale[:, None]
    bound0 = (np.abs(C) * sq).sum(axis=1) / norm
    return np.concatenate([R, q[:, None]], axis=1), g0, G, bound0


def _conditions(V, T) -> _Conditions:
    tets, opposite = interior_faces(T)
    R = T[tets[:, 0]]
    on_face = R != opposite[:, :1]
    tri = R[on_face].reshape(-1, 3)
    F = V[tri]
    n = np.cross(F[:, 1] - F[:, 0], F[:, 2] - F[:, 0])
    area2 = np.linalg.norm(n, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = n / area2[:, None]
    sp_ = np.einsum("fd,fd->f", V[opposite[:, 0]] - F[:, 0], unit)
    sq_ = np.einsum("fd,fd->f", V[opposite[:, 1]] - F[:, 0], unit)
    rms = np.sqrt(((F - np.roll(F, 1, axis=1)) ** 2).sum(axis=2).mean(axis=1))
    norm = 2 * area2 * np.abs(sp_) * np.abs(sq_) * rms   # 4 A h_p h_q l
    bad = ~(norm > 0) | ~np.isfinite(norm)
    if bad.any():
        f = int(np.flatnonzero(bad)[0])
        raise TetlapError(
            f"interior face {tri[f].tolist()} (tets {tets[f].tolist()}) has a flat tet on "
            "one side: regularity needs tets of non-zero volume",
            element=int(tets[f, 0]))
    folded = sp_ * sq_ > 0
    nf = len(tets)
    idx, g0, G, b0 = _condition(V, T, tets[:, 0], opposite[:, 1], norm)
    face = np.arange(nf)
    fo = np.flatnonzero(folded)
    if len(fo):  # the second tet's view, of opposite sign for a folded face
        idx2, g2, G2, b2 = _condition(V, T, tets[fo, 1], opposite[fo, 0], norm[fo])
        idx, g0, G, b0 = (np.concatenate([a, b]) for a, b in
                          ((idx, idx2), (g0, g2), (G, G2), (b0, b2)))
        face = np.concatenate([face, fo])
    return _Conditions(idx=idx, g0=g0, G=G, bound0=b0, face=face, n_faces=nf, tri=tri,
                       folded=folded)


def _validated(V, T):
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise _arrays.ShapeError(f"regular weights need points in R^3, got V of shape {V.shape}")
    # the core validates indices, finiteness, repeated corners and flat tets, naming them
    assembly.tet_contributions(V, T, "primal")
    return V, T


def face_margins(V, T, weights=None) -> np.ndarray:
    """The margin of every interior face for the weights (``None``: zeros).

    Parameters
    ----------
    V : (n, 3) array-like.  T : (m, 4) integer array-like.
    weights : optional (n,) vertex weights, squared-length units (module docstring).

    Returns
    -------
    (f,) float64 in the order of :func:`tetlap.diagnostics.interior_faces`: the signed
    dual-edge length over the face's RMS edge length. Negative: locally non-regular.

    Example
    -------
    >>> import tetlap
    >>> from tetlap.regular import face_margins
    >>> V, T = tetlap.meshes.ball(300, seed=1)        # Delaunay: all margins >= 0
    >>> bool(face_margins(V, T).min() > 0)
    True
    """
    V, T = _validated(V, T)
    w = _arrays.vertex_weights(weights, len(V))
    cond = _conditions(V, T)
    return cond.per_face(cond.margins(np.zeros(len(V)) if w is None else w))


# --------------------------------------------------------------------------------------
# Masses: the weighted circumcentric cell volumes and their derivatives
# --------------------------------------------------------------------------------------

_EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
_OPPOSITE = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))
_FACE = ([1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2])


def _power_center(X, W):
    """The point of the affine hull of X (t, k, 3) with equal power to its k corners."""
    o = X[:, 0]
    E = X[:, 1:] - o[:, None]
    r = ((E * E).sum(-1) + W[:, :1] - W[:, 1:]) / 2
    if X.shape[1] == 2:
        e = E[:, 0]
        return o + e * (r[:, 0] / (e * e).sum(-1))[:, None]
    if X.shape[1] == 3:
        a, b = E[:, 0], E[:, 1]
        n = np.cross(a, b)
        num = r[:, :1] * np.cross(b, n) + r[:, 1:2] * np.cross(n, a)
        return o + num / (n * n).sum(-1)[:, None]
    a, b, c = E[:, 0], E[:, 1], E[:, 2]
    det = (a * np.cross(b, c)).sum(-1)
    return o + (r[:, :1] * np.cross(b, c) + r[:, 1:2] * np.cross(c, a)
                + r[:, 2:3] * np.cross(a, b)) / det[:, None]


def _cell_volumes(X, W):
    """Weighted circumcentric cell volumes of every corner of every tet, (t, 4): the signed
    flag pieces of the core's ``dual_from_centers``, here in NumPy so that they can be
    differentiated (complex W gives exact derivatives by the complex step)."""
    X = X - X[:, :1]
    ce = [_power_center(X[:, list(e)], W[:, list(e)]) for e in _EDGES]
    cf = [_power_center(X[:, f], W[:, f]) for f in _FACE]
    ct = _power_center(X, W)

    def piece(a, e, f):
        o = X[:, a]
        return ((ce[e] - o) * np.cross(cf[f] - o, ct - o)).sum(-1) / 6

    def sign(p, q, r, u):
        e = X[:, [q, r, u]] - X[:, p][:, None]
        return np.sign((e[:, 0] * np.cross(e[:, 1], e[:, 2])).sum(-1))

    vol = np.zeros(W.shape, dtype=W.dtype)
    for e, ((a, b), (k, l)) in enumerate(zip(_EDGES, _OPPOSITE)):
        vol[:, a] += piece(a, e, l) * sign(a, b, k, l) + piece(a, e, k) * sign(a, b, l, k)
        vol[:, b] += piece(b, e, l) * sign(b, a, k, l) + piece(b, e, k) * sign(b, a, l, k)
    return vol


def _mass_jacobian(V, T, w, rows: np.ndarray) -> sp.csr_array:
    """d m_i / d w_j for the vertices ``rows``, (len(rows), n), exact (complex step)."""
    n = len(V)
    pick = np.zeros(n, dtype=bool)
    pick[rows] = True
    tets = np.flatnonzero(pick[T].any(axis=1))
    Tt = T[tets]
    X, W = V[Tt], w[Tt].astype(complex)
    h = 1e-30 * max(float(np.abs(w).max()), float(np.ptp(V) ** 2), 1e-300)
    D = np.empty((len(tets), 4, 4))                   # D[t, a, b] = d vol_a / d w_b
    for b in range(4):
        Wb = W.copy()
        Wb[:, b] += 1j * h
        D[:, :, b] = _cell_volumes(X, Wb).imag / h
    a_idx = np.repeat(Tt[:, :, None], 4, axis=2)
    b_idx = np.repeat(Tt[:, None, :], 4, axis=1)
    keep = pick[a_idx]
    row_of = np.full(n, -1)
    row_of[rows] = np.arange(len(rows))
    J = sp.coo_array((D[keep], (row_of[a_idx[keep]], b_idx[keep])), shape=(len(rows), n))
    return J.tocsr()


# --------------------------------------------------------------------------------------
# The result
# --------------------------------------------------------------------------------------

@dataclasses.dataclass
class RegularWeights:
    """Result of :func:`regular_weights`.

    Attributes
    ----------
    weights : (n,) float64, squared-length units, sign convention of ``weights=`` (larger
        = bigger power cell). Zero on unreferenced vertices, and everywhere when the mesh
        is Delaunay. Pass them on: ``tetlap.laplacian(V, T, "dual", weights=r.weights)``.
    regular : bool, every interior face locally regular for ``weights`` up to
        :data:`REGULAR_RTOL` (then every interior weighted-dual weight is >= 0) and no face
        folded.
    margin : float, the smallest face margin (scale-free; module docstring). ``> 0``
        means every interior face is strictly locally regular; a regular mesh has
        ``margin <= 0`` only at rounding level, for cospherical faces (Kuhn grids). 0.0
        for a mesh without interior faces.
    violated_faces : (k, 3) int64, vertices of the interior faces that are not locally
        regular for ``weights`` (folded faces included).
    face_margins : (f,) float64, every interior face's margin for ``weights``, order of
        :func:`tetlap.diagnostics.interior_faces`.
    margin_plain : float, the smallest margin at ``w = 0`` (``< 0``: not Delaunay).
    n_violated_plain : int, interior faces violated at ``w = 0`` (non-Delaunay faces).
    n_folded : int, folded interior faces (no weights can repair them).
    target_margin : float, the margin aimed for on repaired faces.
    margin_floor : float or None, the margin the LP imposed on the repaired faces: the
        target, or a tenth or a hundredth of it when the target is out of reach; None when
        nothing was repaired (Delaunay) or the mesh is not regular.
    n_weighted_vertices : int, vertices with a non-zero weight.
    n_negative_interior_plain, n_negative_interior_weighted : int, negative weights (below
        ``-NEGATIVE_TOL * max|w|``, as :func:`tetlap.check` counts them) on edges whose
        endpoints are not both on the boundary, plain dual vs weighted dual.
    mass_min_plain, mass_min_weighted : float, smallest circumcentric mass (cell volume).
    masses_lost : (k,) int64, vertices whose plain circumcentric mass is positive but
        whose weighted one is not (target: none).
    masses_below_floor : (k,) int64, vertices whose weighted mass fell below
        ``mass_floor`` times their positive plain mass (``masses_lost`` included).
    lp_rounds : int, LPs solved.  lp_max_size : (rows, columns) of the largest LP.
    seconds : float, wall time.
    notes : list of str, what happened (phases, relaxations).
    """

    weights: np.ndarray
    regular: bool
    margin: float
    violated_faces: np.ndarray
    face_margins: np.ndarray
    margin_plain: float
    n_violated_plain: int
    n_folded: int
    target_margin: float
    margin_floor: float | None
    n_weighted_vertices: int
    n_negative_interior_plain: int
    n_negative_interior_weighted: int
    mass_min_plain: float
    mass_min_weighted: float
    masses_lost: np.ndarray
    masses_below_floor: np.ndarray
    lp_rounds: int
    lp_max_size: tuple[int, int]
    seconds: float
    notes: list[str] = dataclasses.field(default_factory=list)

    def to_dict(self) -> dict:
        """A JSON-ready dict of the scalar fields and counts (arrays summarised)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name in ("weights", "face_margins"):
                continue
            if isinstance(v, np.ndarray):
                out[f"n_{f.name}"] = int(len(v))
            elif isinstance(v, tuple):
                out[f.name] = list(v)
            else:
                out[f.name] = v
        return out

    def __str__(self) -> str:
        lines = [
            f"regular: {'yes' if self.regular else 'NO'} (margin {self.margin:.3e}; "
            f"plain dual {self.margin_plain:.3e}, {self.n_violated_plain} non-Delaunay faces)",
            f"weights: {self.n_weighted_vertices} non-zero; negative interior weights "
            f"{self.n_negative_interior_plain} (plain dual) -> "
            f"{self.n_negative_interior_weighted} (weighted dual)",
            f"masses: min {self.mass_min_plain:.3e} -> {self.mass_min_weighted:.3e}; "
            f"{len(self.masses_lost)} turned non-positive, {len(self.masses_below_floor)} "
            "below the floor",
        ]
        if len(self.violated_faces):
            lines.append(f"violated faces: {len(self.violated_faces)} "
                         f"({self.n_folded} folded)")
        return "\n".join(lines + [f"note: {n}" for n in self.notes])


# --------------------------------------------------------------------------------------
# The solver
# --------------------------------------------------------------------------------------

def _vertex_lengths(V, T) -> np.ndarray:
    """Mean length of the edges at every vertex (1 for unreferenced vertices)."""
    n = len(V)
    E = np.sort(T[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2), axis=1)
    key = np.unique(E[:, 0] * n + E[:, 1])          # n^2 < 2^63 for any float64 mesh
    E = np.column_stack([key // n, key % n])
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    total = np.bincount(E.ravel(), np.repeat(length, 2), minlength=n)
    count = np.bincount(E.ravel(), minlength=n)
    return np.where(count > 0, total / np.maximum(count, 1), 1.0)


def _negative_interior(V, T, w, on_boundary) -> int:
    edges, weights = assembly.edge_weights(V, T, "dual", weights=w)
    inner = ~(on_boundary[edges[:, 0]] & on_boundary[edges[:, 1]])
    scale = float(np.abs(weights).max()) if len(weights) else 1.0
    return int(((weights < -NEGATIVE_TOL * scale) & inner).sum())


def _masses(V, T, w) -> np.ndarray:
    return assembly.mass(V, T, "circumcentric", weights=w).diagonal()


class _Problem:
    """The LPs over a growing set of variable vertices and active conditions.

    Unknowns: ``u = w / l^2`` per variable vertex (l: the vertex's mean edge length, so
    that every unknown and every coefficient is O(1)), split ``u = p - n`` with
    ``0 <= p, n <= max_weight`` so that ``sum |u|`` is linear.
    """

    def __init__(self, cond: _Conditions, l2: np.ndarray, allowed: np.ndarray,
                 max_weight: float, deadline: float | None):
        self.cond, self.l2, self.allowed, self.U = cond, l2, allowed, max_weight
        self.deadline = deadline
        n = len(l2)
        c = len(cond.g0)
        self.Gs = cond.G * l2[cond.idx]                # coefficients on u
        # vertex -> conditions incidence, to find the conditions a vertex set touches
        self.incidence = sp.csr_array(
            (np.ones(cond.idx.size), (cond.idx.ravel(), np.repeat(np.arange(c), 5))),
            shape=(n, c))
        self.usable = ~cond.folded[cond.face]
        self.rounds = 0
        self.max_size = (0, 0)

    def touched(self, S: np.ndarray) -> np.ndarray:
        """Conditions with a vertex in S (folded faces' never: no weights repair them)."""
        return ((self.incidence.T @ S.astype(np.float64)) > 0) & self.usable

    def solve(self, S, active, *, margin_floor=None, hinge_target=None, hinge_cost=None,
              mass_rows=None, weight_cost=1.0):
        """One LP over the variable vertices S and the active conditions; the weights of
        all other vertices stay 0. Returns (HiGHS status, u (n,) or None, t or None).

        margin_floor : margin >= floor on the active conditions (hard); a scalar or one
            value per condition.
        hinge_target : minimise sum c max(0, target - margin) + weight_cost * sum |u|,
            ``c = hinge_cost`` (per active condition; default 1); margin_floor None: no
            hard floor.
        mass_rows : (J (r, n) in w units, rhs (r,), scale (r,) > 0): soft rows
            ``J w >= rhs`` with slack cost 100 per unit of ``slack / scale``.
        Otherwise: minimise sum |u| (the minimum-weight LP).
        """
        from scipy.optimize import linprog

        cond = self.cond
        sv = np.flatnonzero(S)
        k = len(sv)
        col = np.full(len(S), -1)
        col[sv] = np.arange(k)
        ca = np.flatnonzero(active)
        cs = col[cond.idx[ca]]
        var = cs >= 0
        na = len(ca)
        Aw = sp.csr_array((self.Gs[ca][var], (np.repeat(np.arange(na), 5)[var.ravel()],
                                              cs[var])), shape=(na, k))  # margin - g0
        g0 = cond.g0[ca]
        if margin_floor is not None and np.ndim(margin_floor):
            margin_floor = np.asarray(margin_floor)[ca]
        # columns: p (k), n (k), then hinge slacks (na), then mass slacks (r). (No
        # max-margin LP "margin >= t": its t column is dense, which makes HiGHS's interior
        # point minutes slow at 60k rows.)
        cost = [np.full(2 * k, weight_cost)]
        bounds = [(0.0, self.U)] * (2 * k)
        if hinge_target is not None:              # target - s - (g0 + Aw u) <= 0
            cost.append(np.ones(na) if hinge_cost is None else hinge_cost)
            bounds += [(0.0, None)] * na
            eye = sp.eye_array(na, format="csr")
            A_ub = sp.hstack([-Aw, Aw, -eye], format="csr")
            b_ub = [g0 - hinge_target]
            if margin_floor is not None:
                A_ub = sp.vstack([A_ub, sp.hstack([-Aw, Aw, sp.csr_array((na, na))])],
                                 format="csr")
                b_ub.append(g0 - margin_floor)
        else:                                       # floor - (g0 + Aw u) <= 0
            A_ub = sp.hstack([-Aw, Aw], format="csr")
            b_ub = [g0 - margin_floor]
        if mass_rows is not None:                   # rhs - J w - scale sigma <= 0
            J, rhs, scale = mass_rows
            Ju = sp.csr_array(sp.diags_array(1 / scale) @ J[:, sv] @ sp.diags_array(self.l2[sv]))
            r = J.shape[0]
            extra = A_ub.shape[1] - 2 * k
            A_ub = sp.vstack([sp.hstack([A_ub, sp.csr_array((A_ub.shape[0], r))]),
                              sp.hstack([-Ju, Ju, sp.csr_array((r, extra)),
                                         -sp.eye_array(r, format="csr")])], format="csr")
            b_ub.append(-rhs / scale)
            cost.append(np.full(r, 100.0))
            bounds += [(0.0, None)] * r
        c = np.concatenate([np.asarray(x, dtype=np.float64) for x in cost])
        self.rounds += 1
        self.max_size = max(self.max_size, A_ub.shape)
        # dual simplex for the minimum-weight LP (sparse, exact vertex solutions, fast
        # there); interior point (with crossover) for the hinge LPs
        methods = ("highs-ds", "highs-ipm") if hinge_target is None else (
            "highs-ipm", "highs-ds")
        for method in methods:     # the other method when one reports numerical trouble
            options = {"primal_feasibility_tolerance": _LP_TOL,
                       "dual_feasibility_tolerance": _LP_TOL}
            if self.deadline is not None:
                options["time_limit"] = max(self.deadline - time.perf_counter(), 0.01)
            res = linprog(c, A_ub=A_ub, b_ub=np.concatenate(b_ub), bounds=bounds,
                          method=method, options=options)
            if res.status != 4:
                break
        if res.status != 0:
            return res.status, None, None
        u = np.zeros(len(S))
        u[sv] = res.x[:k] - res.x[k:2 * k]
        return 0, u, None


def regular_weights(V, T, *, target_margin: float = TARGET_MARGIN, boundary: str = "free",
                    mass_floor: float = 0.1, max_weight: float = 10.0,
                    rtol: float = REGULAR_RTOL, max_rounds: int = 60,
                    time_limit: float | None = None) -> RegularWeights:
    """Vertex weights that make the mesh regular, so that its weighted dual has
    non-negative interior weights, or the proof (within the weight bound) that none do.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers.  T : (m, 4) integer array-like, any orientation.
    target_margin : float > 0, the face margin (module docstring: dual-edge length over
        face size) the weights aim for on the faces they repair. Faces that are locally
        Delaunay and away from the repairs keep their plain margin, whatever it is.
    boundary : ``"free"`` (default: boundary vertices get weights like any other) or
        ``"zero"`` (boundary weights fixed at 0). Boundary faces impose no condition, but a
        boundary vertex's weight enters the conditions of the interior faces around it and
        moves the power centers of its boundary tets (so its own and its neighbours'
        masses). ``"zero"`` keeps the boundary cells closer to the plain ones and can make
        a regular mesh look non-regular.
    mass_floor : float in [0, 1) or None, keep every weighted circumcentric mass above
        ``mass_floor`` times its plain value where that is positive (0: only keep it
        positive). A soft constraint: the vertices where it fails are reported. None:
        skip step 4 (masses are then only reported).
    max_weight : bound on ``|w_i| / l_i^2`` (``l_i`` the vertex's mean edge length): the
        LPs need a box, and the verdict "not regular" means "not with weights this big".
    rtol : the round-off tolerance of the regularity test (:data:`REGULAR_RTOL`).
    max_rounds : cap on LPs solved (constraint generation rarely needs more than 10).
    time_limit : float or None, in seconds. At the limit the LP stops and the weights are those of
        the last complete LP, or 0 if none or if those violate more conditions than
        ``w = 0``, with a note; ``.regular`` is then only what the weights achieve (a "no"
        means "undecided").

    Returns
    -------
    :class:`RegularWeights` (``.weights``, ``.regular``, ``.margin``,
    ``.violated_faces``, masses and counts; ``str()`` is a short report).

    Method
    ------
    Every local condition is linear in ``w``, so regularity is an LP feasibility problem,
    but the mesh-wide LP is slow (tens of seconds at 8k tets) and most of it is idle: only
    faces near the non-Delaunay ones ever bind. So, by constraint generation:

    1. ``w = 0`` first: a Delaunay mesh is returned as it is.
    2. Variables are the weights of the vertices of the violated faces (of the boundary
       too unless ``boundary="zero"``); constraints the conditions that touch them and
       are not comfortably satisfied. *Minimum-weight LP*: minimise ``sum |w_i| / l_i^2``
       subject to margin ``>= target_margin`` (HiGHS dual simplex). Conditions that the
       new weights push below the target join, and the LP is solved again, until none do.
       The smallest weights have two virtues: the result is local (the weighted dual
       equals the plain one away from the repairs) and the power cells stay close to the
       plain ones. Weights are not unique (the margin grows without bound with the
       weights on a regular mesh); the target margin and the L1 norm pick them.
    3. If that LP is infeasible, the variables grow by one ring of vertices (every vertex
       of an active condition) and step 2 is repeated, up to 3 rings; then with the
       target lowered to a tenth, a hundredth and ``1e-7``. If even that fails the mesh is
       reported *not regular* (strictly: no weights within ``max_weight`` on these rings
       give a margin of ``1e-7``; meshes whose best margin is exactly 0, as in the
       degenerate cases of the "mother of all examples", count as not regular); the
       weights then minimise, by reweighted L1 (three LPs, Candes-Wakin-Boyd), the
       shortfall ``sum max(0, target / 10 - margin)``: a proxy for *the number of
       violated faces*, which is what they try to make small (not the largest
       violation). Masses are not repaired in that case.
       (A max-margin LP, "margin >= t, maximise t", would decide regularity more
       directly, but its ``t`` column is dense and HiGHS needs minutes at 60k rows.)
    4. *Masses*: large or unbalanced weights shrink power cells, at the boundary (inside,
       a regular mesh's cells are convex polytopes of positive volume, since the dual
       faces around an interior vertex close up convexly). Vertices whose
       weighted mass falls below ``mass_floor`` times a positive plain mass get a linear
       constraint (the mass linearised at the current weights, exact derivatives by the
       complex step of a NumPy copy of the core's kernel), soft with a large penalty;
       repeated until the masses hold (sequential LP).

    Deterministic: the same input gives the same output.

    Raises
    ------
    tetlap.ShapeError, DtypeError, IndexRangeError, NonFiniteError, RepeatedVertexError,
    DegenerateElementError (bad input, as for the operators); OptionError (bad option);
    TetlapError (a face whose tet is flat to float64).

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
    >>> bool(r.regular), r.n_negative_interior_plain > 0, r.n_negative_interior_weighted
    (True, True, 0)
    >>> L = tetlap.laplacian(V, T, "dual", weights=r.weights)
    >>> bool(tetlap.check(L, V, T).linear_precision_ok)
    True
    """
    start = time.perf_counter()
    V, T = _validated(V, T)
    if not (isinstance(target_margin, (int, float)) and 0 < target_margin < np.inf):
        raise OptionError(f"target_margin must be a positive number, got {target_margin!r}")
    if boundary not in ("free", "zero"):
        raise OptionError(f'boundary must be "free" or "zero", got {boundary!r}')
    if mass_floor is not None and not (0 <= mass_floor < 1):
        raise OptionError(f"mass_floor must lie in [0, 1), got {mass_floor!r}")
    if not (max_weight > 0 and np.isfinite(max_weight)):
        raise OptionError(f"max_weight must be a positive number, got {max_weight!r}")
    if not (rtol >= 0 and np.isfinite(rtol)):
        raise OptionError(f"rtol must be a non-negative number, got {rtol!r}")
    if time_limit is not None and not (time_limit > 0):
        raise OptionError(f"time_limit must be positive seconds or None, got {time_limit!r}")
    if not (isinstance(max_rounds, (int, np.integer)) and max_rounds >= 1):
        raise OptionError(f"max_rounds must be a positive integer, got {max_rounds!r}")

    n = len(V)
    on_boundary = boundary_vertices(T, n)
    cond = _conditions(V, T)
    zero = np.zeros(n)
    g0 = cond.margins(zero)
    tol0 = cond.tolerance(zero, rtol)
    notes: list[str] = []
    m_plain = _masses(V, T, zero)
    w = zero
    max_reached = None
    problem = None
    violated0 = g0 < -tol0
    if (violated0 & ~cond.folded[cond.face]).any():
        l2 = _vertex_lengths(V, T) ** 2
        allowed = np.ones(n, dtype=bool) if boundary == "free" else ~on_boundary
        deadline = None if time_limit is None else start + time_limit
        problem = _Problem(cond, l2, allowed, max_weight, deadline)
        u, max_reached = _solve(problem, cond, g0, violated0, target_margin, mass_floor,
                                m_plain, V, T, l2, allowed, max_rounds, notes)
        w = u * l2
        if any(note.startswith("stopped") for note in notes):
            # an interrupted run: keep the weights only if they violate fewer faces
            if (cond.margins(w) < -cond.tolerance(w, rtol)).sum() > violated0.sum():
                w = zero
                notes.append("the interrupted weights were worse than w = 0: w = 0")
    elif violated0.any():
        notes.append("only folded faces are violated: no weights help, w = 0")
    else:
        notes.append("Delaunay: the plain dual (w = 0) is already the answer")

    g = cond.margins(w)
    tol = cond.tolerance(w, rtol)
    bad_cond = g < -tol
    bad = np.zeros(cond.n_faces, dtype=bool)
    bad[cond.face[bad_cond]] = True
    bad |= cond.folded
    per_face = cond.per_face(g)
    m_weighted = _masses(V, T, w) if problem is not None else m_plain
    positive = m_plain > 0
    lost = np.flatnonzero(positive & (m_weighted <= 0))
    below = np.flatnonzero(positive & (m_weighted < (mass_floor or 0.0) * m_plain))
    n_neg_plain = _negative_interior(V, T, None, on_boundary)
    n_neg_w = n_neg_plain if problem is None else _negative_interior(V, T, w, on_boundary)
    if cond.folded.any():
        notes.append(f"{int(cond.folded.sum())} folded faces (both tets on one side): "
                     "no weights make them regular")
    return RegularWeights(
        weights=w,
        regular=not bad.any(),
        margin=float(per_face.min()) if cond.n_faces else 0.0,
        violated_faces=cond.tri[bad].astype(np.int64),
        face_margins=per_face,
        margin_plain=float(cond.per_face(g0).min()) if cond.n_faces else 0.0,
        n_violated_plain=int(np.unique(cond.face[violated0]).size),
        n_folded=int(cond.folded.sum()),
        target_margin=float(target_margin),
        margin_floor=max_reached,
        n_weighted_vertices=int((w != 0).sum()),
        n_negative_interior_plain=n_neg_plain,
        n_negative_interior_weighted=n_neg_w,
        mass_min_plain=float(m_plain.min()),
        mass_min_weighted=float(m_weighted.min()),
        masses_lost=lost.astype(np.int64),
        masses_below_floor=below.astype(np.int64),
        lp_rounds=0 if problem is None else problem.rounds,
        lp_max_size=(0, 0) if problem is None else tuple(int(x) for x in problem.max_size),
        seconds=time.perf_counter() - start,
        notes=notes,
    )


def _solve(problem, cond, g0, violated0, target, mass_floor, m_plain, V, T, l2, allowed,
           max_rounds, notes):
    """Steps 2-4 of :func:`regular_weights`; returns (u = w / l^2, margin floor reached
    or None when the mesh is not regular)."""
    n = len(l2)
    S = np.zeros(n, dtype=bool)                      # variable vertices
    S[cond.idx[violated0 & problem.usable].ravel()] = True
    S &= allowed
    near = 2 * target + 0.02         # touched conditions below this margin are active
    active = problem.touched(S) & (g0 < near)
    slack = 10 * _LP_TOL
    # the floors tried in turn: the target, then smaller ones, each after growing the
    # variables ring by ring (an infeasible LP over a few rings is the usual sign that
    # the repair needs more room, not that the mesh is not regular)
    floors = [target, target / 10, target / 100, _TINY_MARGIN]
    state = {"mode": "min-weight", "floor": floors[0], "mass": None, "hinge_cost": None}

    def lp():
        if state["mode"] == "min-weight":
            return problem.solve(S, active, margin_floor=state["floor"],
                                 mass_rows=state["mass"])[:2]
        cost = state["hinge_cost"]
        return problem.solve(S, active, hinge_target=0.1 * target, weight_cost=1e-3,
                             hinge_cost=None if cost is None else cost[active],
                             mass_rows=state["mass"])[:2]

    def grow_ring():
        """Let every vertex of an active condition join; False when none is new."""
        ring = np.zeros(n, dtype=bool)
        ring[cond.idx[active].ravel()] = True
        ring &= allowed & ~S
        if not ring.any():
            return False
        S[ring] = True
        active[problem.touched(S) & (g0 < near)] = True
        return True

    rings = 0

    def generate():
        """Solve; add the touched conditions that the solution pushes below the floor;
        repeat. On infeasibility grow the variables, then lower the floor, then give up
        on regularity (hinge mode)."""
        nonlocal rings
        while problem.rounds < max_rounds:
            status, u = lp()
            if status == 2 and state["mode"] == "min-weight":
                if rings < _RINGS and grow_ring():
                    rings += 1
                    continue
                lower = [f for f in floors if f < np.min(state["floor"])]
                if lower and state["mass"] is None:
                    state["floor"] = lower[0]
                    rings = 0
                    continue
                if state["mass"] is not None:
                    return None          # the mass rows made it infeasible: keep the last
                state["mode"] = "hinge"
                continue
            if status == 1:
                notes.append("stopped at the time limit (the weights are those of the last "
                             "complete LP, or 0)")
                return state.get("last")
            if status != 0:
                raise TetlapError(f"the LP solver failed (HiGHS status {status})")
            state["last"] = u
            g = cond.margins(u * l2)
            low = state["floor"] if state["mode"] == "min-weight" else 0.1 * target
            new = problem.touched(S) & ~active & (g < np.minimum(low, target) - slack)
            if not new.any():
                return u
            active[new] = True
        notes.append(f"stopped after max_rounds = {max_rounds} LPs")
        return None

    u = generate()
    if u is None:
        return np.zeros(n), None
    if state["mode"] == "hinge":
        notes.append("not regular within max_weight (no weights found with margin "
                     f"{floors[-1]:g} on {_RINGS} rings around the violations): the "
                     "weights reduce the number of violated faces instead")
        # reweighted L1 (Candes, Wakin & Boyd 2008): fewer, larger violations
        for _ in range(2):
            g = cond.margins(u * l2)
            shortfall = np.maximum(0.0, 0.1 * target - g)
            state["hinge_cost"] = 1.0 / (shortfall / (0.1 * target) + 1e-3)
            u_new = generate()
            if u_new is None:
                break
            u = u_new
        return u, None
    if state["floor"] < target:
        notes.append(f"target margin {target:g} out of reach: margin {state['floor']:g}")
    reached = float(state["floor"])

    # -- 4: masses (sequential LP, linearised mass rows accumulated as cuts) ------------
    positive = m_plain > 0
    cuts = []
    for _ in range(0 if mass_floor is None else 8):
        m = _masses(V, T, u * l2)
        low = np.flatnonzero(positive & (m < mass_floor * m_plain))
        if not len(low) or problem.rounds >= max_rounds:
            break
        w_now = u * l2
        R = np.union1d(low, cuts[-1][3]) if cuts else low
        J = _mass_jacobian(V, T, w_now, R)
        # m(w) ~ m(w_now) + J (w - w_now) >= goal, a little above the floor
        goal = (mass_floor + 0.1 * (1 - mass_floor)) * m_plain[R]
        cuts.append((J, goal - m[R] + J @ w_now, m_plain[R], R))
        state["mass"] = (sp.vstack([c[0] for c in cuts], format="csr"),
                         np.concatenate([c[1] for c in cuts]),
                         np.concatenate([c[2] for c in cuts]))
        ring = np.zeros(n, dtype=bool)               # the mass rows' weights join
        ring[J.indices] = True
        S[ring & allowed] = True
        active |= problem.touched(S) & (cond.margins(w_now) < near)
        u_new = generate()
        if u_new is None:
            break
        u = u_new
    return u, reached


#: Rings of vertices the variables may grow by before a lower floor is tried.
_RINGS = 3
#: The last floor tried: strictly positive (above the LP tolerance), so that "regular"
#: always means a strictly positive margin was found.
_TINY_MARGIN = 1e-7


# --------------------------------------------------------------------------------------
# What `tetlap info` prints
# --------------------------------------------------------------------------------------

def summary(V, T, result: RegularWeights | None = None, *, nsd: bool = False) -> dict:
    """Regularity and what the weighted dual gains, as a JSON-ready dict for ``tetlap info``.

    Parameters
    ----------
    V : (n, 3) array-like.  T : (m, 4) integer array-like.
    result : a :class:`RegularWeights` of this mesh (computed with defaults when None).
    nsd : also check negative semidefiniteness of the three Laplacians (slow on big meshes).

    Returns
    -------
    dict with ``regular`` (bool), ``margin``, ``margin_plain``, ``n_non_delaunay_faces``,
    ``n_weighted_vertices``, ``negative_interior_weights`` ({"dual", "weighted_dual",
    "primal"}: counts on edges not both on the boundary), ``nsd`` (same keys, or None),
    ``linear_precision_weighted_dual`` (bool, None without interior vertices), ``masses_lost`` (count of positive plain
    circumcentric masses that the weights make non-positive), ``mass_min`` ({"dual",
    "weighted_dual"}), ``violated_faces`` (count), ``seconds``.

    Example
    -------
    >>> import tetlap
    >>> from tetlap.regular import summary
    >>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    >>> s = summary(V, T)
    >>> s["regular"], s["negative_interior_weights"]["weighted_dual"]
    (True, 0)
    """
    from .properties import check

    V, T = _validated(V, T)
    r = regular_weights(V, T) if result is None else result
    if len(r.weights) != len(V):
        raise _arrays.ShapeError(f"the result has {len(r.weights)} weights, the mesh "
                                 f"{len(V)} vertices")
    operators = {
        "dual": assembly.laplacian(V, T, "dual"),
        "weighted_dual": assembly.laplacian(V, T, "dual", weights=r.weights),
        "primal": assembly.laplacian(V, T, "primal"),
    }
    reports = {k: check(L, V, T, nsd=nsd) for k, L in operators.items()}
    return {
        "regular": bool(r.regular),
        "margin": r.margin,
        "margin_plain": r.margin_plain,
        "n_non_delaunay_faces": r.n_violated_plain,
        "n_weighted_vertices": r.n_weighted_vertices,
        "negative_interior_weights": {k: rep.n_negative_interior for k, rep in reports.items()},
        "nsd": {k: rep.nsd for k, rep in reports.items()} if nsd else None,
        "linear_precision_weighted_dual": reports["weighted_dual"].linear_precision_ok,
        "masses_lost": int(len(r.masses_lost)),
        "mass_min": {"dual": r.mass_min_plain, "weighted_dual": r.mass_min_weighted},
        "violated_faces": int(len(r.violated_faces)),
        "seconds": r.seconds,
    }
