"""Vertex weights that make a given tetrahedral mesh regular (weighted Delaunay).

A mesh ``(V, T)`` is *regular* for vertex weights ``w`` when it is the projection of the
lower convex hull of the lifted points ``(x_i, |x_i|^2 - w_i)``; locally, when across every
interior face ``abc`` shared by the tets ``abcp`` and ``abcq`` the lifted ``q`` lies above
the hyperplane through the lifted ``a, b, c, p``. Then its weighted dual
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
regular, strictly
    Every interior face's margin is linear in ``w`` and vanishes for ``w = |x|^2`` (a flat
    lifting: all power centers coincide, the weighted dual is the zero matrix), so "every
    margin >= 0" is always possible and says nothing. *Regular* means: some ``w`` makes
    every margin strictly positive; then ``|x|^2 + t (w - |x|^2)`` makes them as large as
    wanted. By Gordan's theorem of the alternative, a mesh is **not** regular exactly when
    some non-negative combination ``y`` of the face conditions vanishes identically in
    ``w``: that ``y`` is the certificate :func:`regular_weights` looks for.

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

import dataclasses
import time

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, _sparse, assembly
from ._interrupt import interruptible
from .diagnostics import _FACES, _face_sets, mesh_edges
from .errors import OptionError, TetlapError
from .properties import NEGATIVE_TOL

__all__ = [
    "regular_weights",
    "RegularWeights",
    "face_margins",
    "REGULAR_RTOL",
    "STATUSES",
]

#: Round-off tolerance of the regularity test, relative like
#: :data:`tetlap.diagnostics.DELAUNAY_RTOL` (same value): a face counts as locally regular
#: when its margin is ``>= -REGULAR_RTOL * bound``, ``bound`` being the face's margin
#: computed with every term of the lifted determinant taken in absolute value (so a
#: cospherical face, whose exact margin is 0, is never flagged by rounding).
REGULAR_RTOL = 1e-10

#: Margin the weights aim for on the faces they have to repair (default of
#: ``target_margin``): 0.1% of the face size. Small on purpose: the larger the target, the
#: larger the weights (large weights shrink the power cells of boundary vertices), and
#: the slower the search (10 iterations at 1e-3, thousands at 1e-2 on a weighted ball).
TARGET_MARGIN = 1e-3

#: The values of :attr:`RegularWeights.status`: ``"regular"`` (the weights returned make
#: every interior face locally regular: verified by the margin test), ``"not regular"``
#: (proved: a certificate, see :attr:`RegularWeights.certificate_faces`) and
#: ``"undecided"`` (the search stopped at ``time_limit`` or ``max_iterations`` with
#: neither).
STATUSES = ("regular", "not regular", "undecided")


# --------------------------------------------------------------------------------------
# The linear conditions
# --------------------------------------------------------------------------------------

def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _lifted(Vt, R, q):
    """Cofactors ``C`` (4, c) of the lifted column of ``det[x_i - x_q, |x_i - x_q|^2]``
    (rows: the corners ``R`` (c, 4) of a tet) and the squared lengths ``s`` (4, c).
    Coordinates as (3, n) rows: every product below is one NumPy pass over c values."""
    Xq = Vt[:, q]
    e = [Vt[:, R[:, i]] - Xq for i in range(4)]
    s = np.stack([_dot(x, x) for x in e])
    x23, x01 = _cross(e[2], e[3]), _cross(e[0], e[1])
    C = np.stack([-_dot(e[1], x23), _dot(e[0], x23), -_dot(e[3], x01), _dot(e[2], x01)])
    return C, s


@dataclasses.dataclass
class _Conditions:
    """Every local regularity condition as ``g(w) = g0 + sum_k G[:, k] * w[idx[:, k]]``.

    Condition ``f < n_faces`` is interior face ``f`` seen from its first tet; a folded
    face has a second condition (from its second tet) after those, ``face`` says whose.
    """

    idx: np.ndarray      # (c, 5) the tet's 4 vertices in T order, then the opposite one
    g0: np.ndarray       # (c,) margin at w = 0
    G: np.ndarray        # (c, 5) coefficients (1 / squared length)
    bound0: np.ndarray   # (c,) the w-independent part of the rounding bound
    face: np.ndarray     # (c,) interior face of the condition
    n_faces: int
    tri: np.ndarray      # (f, 3) vertices of every interior face
    folded: np.ndarray   # (f,) bool

    def margins(self, w: np.ndarray) -> np.ndarray:
        return self.g0 + np.einsum("ck,ck->c", self.G, w[self.idx])

    def tolerance(self, w: np.ndarray, rtol: float) -> np.ndarray:
        return rtol * (self.bound0 + np.abs(self.G * w[self.idx]).sum(axis=1))

    def per_face(self, values: np.ndarray) -> np.ndarray:
        out = values[:self.n_faces].copy()
        np.minimum.at(out, self.face[self.n_faces:], values[self.n_faces:])
        return out


def _condition_terms(Vt, R, q, norm, orient):
    C, s = _lifted(Vt, R, q)
    scale = orient / norm
    g0 = (C * s).sum(axis=0) * scale
    G = np.vstack([-C, C.sum(axis=0)[None]]) * scale
    bound0 = (np.abs(C) * s).sum(axis=0) / norm
    return np.column_stack([R, q]), g0, np.ascontiguousarray(G.T), bound0


def _conditions(V, T, interior) -> _Conditions:
    """The conditions of every interior face (``interior``: the core's face table, rows
    ``(tet, corner, tet, corner)``), vectorised: O(faces) NumPy passes, no Python loop."""
    Vt = np.ascontiguousarray(V.T)
    t1, c1, t2, c2 = interior.T
    R = T[t1]
    p, q = T[t1, c1], T[t2, c2]
    tri = T[t1[:, None], _FACES[c1]]
    F = [Vt[:, tri[:, k]] for k in range(3)]
    nrm = _cross(F[1] - F[0], F[2] - F[0])
    area2 = np.sqrt(_dot(nrm, nrm))
    with np.errstate(invalid="ignore", divide="ignore"):
        hp = _dot(Vt[:, p] - F[0], nrm) / area2
        hq = _dot(Vt[:, q] - F[0], nrm) / area2
    d01, d12, d20 = F[1] - F[0], F[2] - F[1], F[0] - F[2]
    rms = np.sqrt((_dot(d01, d01) + _dot(d12, d12) + _dot(d20, d20)) / 3)
    norm = 2 * area2 * np.abs(hp) * np.abs(hq) * rms   # 4 A h_p h_q l
    bad = ~(norm > 0) | ~np.isfinite(norm)
    if bad.any():
        f = int(np.flatnonzero(bad)[0])
        raise TetlapError(
            f"interior face {tri[f].tolist()} (tets {[int(t1[f]), int(t2[f])]}) has a flat "
            "tet on one side: regularity needs tets of non-zero volume", element=int(t1[f]))
    folded = hp * hq > 0
    # orientation of the first tet: the side of its face that p is on, relative to the
    # face's own normal, and whether its corners in T order make that normal outward
    e = [Vt[:, R[:, i]] - Vt[:, R[:, 0]] for i in (1, 2, 3)]
    orient = np.sign(_dot(e[0], _cross(e[1], e[2])))
    nf = len(interior)
    idx, g0, G, b0 = _condition_terms(Vt, R, q, norm, orient)
    face = np.arange(nf)
    fo = np.flatnonzero(folded)
    if len(fo):  # the second tet's view, of opposite sign for a folded face
        R2 = T[t2[fo]]
        e = [Vt[:, R2[:, i]] - Vt[:, R2[:, 0]] for i in (1, 2, 3)]
        o2 = np.sign(_dot(e[0], _cross(e[1], e[2])))
        idx2, g2, G2, b2 = _condition_terms(Vt, R2, p[fo], norm[fo], o2)
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


def _mesh_faces(V, T):
    """(on_boundary (n,) bool, the core's interior face table)."""
    T, (boundary, interior, _) = _face_sets(T, len(V))
    on_boundary = np.zeros(len(V), dtype=bool)
    on_boundary[T[boundary[:, 0][:, None], _FACES[boundary[:, 1]]].ravel()] = True
    return on_boundary, interior


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
    cond = _conditions(V, T, _mesh_faces(V, T)[1])
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


#: A tet counts as a sliver in the report on lost masses when its volume is below this
#: fraction of the regular tet's with the same RMS edge length.
SLIVER_QUALITY = 0.05


def _why_masses_lost(V, T, w, lost, repaired, on_boundary):
    """Why the masses of ``lost`` turned non-positive: for each, the tet whose pieces of
    its cell lost the most volume between ``w = 0`` and ``w`` (the same NumPy kernel as
    the Jacobian), and a note on those tets: how many are next to a face the weights
    repair (``repaired``: (m,) bool, tets with a face violated at ``w = 0``) and how many
    are slivers (volume below :data:`SLIVER_QUALITY` of the regular tet's with the same
    RMS edge length). Returns (tets (k,), note or None)."""
    if not len(lost):
        return np.zeros(0, dtype=np.int64), None
    is_lost = np.zeros(len(V), dtype=bool)
    is_lost[lost] = True
    tets = np.flatnonzero(is_lost[T].any(axis=1))
    X = V[T[tets]]
    drop = _cell_volumes(X, np.zeros((len(tets), 4))) - _cell_volumes(X, w[T[tets]])
    vert = T[tets]
    t_idx, c_idx = np.nonzero(is_lost[vert])
    who, how = vert[t_idx, c_idx], drop[t_idx, c_idx]
    order = np.lexsort((-how, who))                       # per vertex, largest drop first
    first = order[np.r_[True, who[order][1:] != who[order][:-1]]]
    culprit = tets[t_idx[first]]                          # in the order of ``lost``
    P = V[T[culprit]]
    vol = np.abs(np.einsum("ij,ij->i", P[:, 1] - P[:, 0],
                           np.cross(P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]))) / 6
    l2 = np.mean([((P[:, a] - P[:, b]) ** 2).sum(-1) for a, b in _EDGES], axis=0)
    sliver = 6 * np.sqrt(2) * vol / l2 ** 1.5 < SLIVER_QUALITY
    where = ("all on the boundary" if on_boundary[lost].all()
             else f"{int(on_boundary[lost].sum())} on the boundary")
    note = (f"{len(lost)} positive plain masses turned non-positive ({where}): the tet "
            "whose pieces of each cell lost most (masses_lost_tets) is next to a face the "
            f"weights repair for {int(repaired[culprit].sum())} of them, a sliver (volume "
            f"< {SLIVER_QUALITY:g} x the regular tet's) for {int(sliver.sum())}. Power "
            "centres move by ~ weight / height, so the signed pieces they cut swing far; "
            "no weights were found that keep these cells positive and the faces regular "
            "(not a proof that none exist)")
    return culprit.astype(np.int64), note

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
        folded. Always ``status == "regular"``.
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
    margin_floor : float or None, the margin the search guaranteed on the repaired faces
        (the target, or a tenth or a hundredth of it when the target was not reached in
        time); None when nothing was repaired (Delaunay) or the mesh is not regular.
    n_weighted_vertices : int, vertices with a non-zero weight.
    n_negative_interior_plain, n_negative_interior_weighted : int, negative weights (below
        ``-NEGATIVE_TOL * max|w|``, as :func:`tetlap.check` counts them) on edges whose
        endpoints are not both on the boundary, plain dual vs weighted dual.
    mass_min_plain, mass_min_weighted : float, smallest circumcentric mass (cell volume).
    masses_lost : (k,) int64, vertices whose plain circumcentric mass is positive but
        whose weighted one is not (target: none).
    masses_below_floor : (k,) int64, vertices whose weighted mass fell below
        ``mass_floor`` times their positive plain mass (``masses_lost`` included).
    masses_lost_tets : (k,) int64, for each vertex of ``masses_lost``, the tet whose
        pieces of its cell lost the most volume from ``w = 0`` to ``weights`` (a note
        counts those next to a face the weights repair, and the slivers among them).
    seconds : float, wall time.
    notes : list of str, what happened (phases, relaxations, why undecided).
    status : str, one of :data:`STATUSES`: ``"regular"``; ``"not regular"``, *proved*:
        ``certificate_faces`` is a set of interior faces that no weights make all strictly
        locally regular (non-negative multipliers ``y`` on their conditions whose
        combination vanishes for every ``w``, to rounding: ``sum_f y_f margin_f(w) = 0``,
        so one of them has a margin ``<= 0`` whatever ``w``; or folded faces); or
        ``"undecided"``: stopped at ``time_limit`` or ``max_iterations``, the weights are
        the best found (never more violated faces than ``w = 0``).
    certificate_faces : (k, 3) int64, the faces of the proof when the status is
        ``"not regular"`` (the folded faces when there are any, else the support of the
        multipliers); empty otherwise.
    certificate_multipliers : (k,) float64 >= 0, the Gordan multipliers ``y`` of
        ``certificate_faces``: ``sum_f y_f margin_f(w)`` is the same (0) for every ``w``,
        so some face of the certificate has margin ``<= 0`` whatever the weights. Check it
        with :func:`face_margins` at any two weights. Ones for folded faces.
    certificate_residual : float or None, ``|sum_f y_f grad_w margin_f|_1`` relative to
        ``sum_f y_f |grad_w margin_f|_1`` (rounding level, ~1e-14; a certificate is only
        accepted below 1e-8); 0.0 for folded faces; None without a certificate.
    iterations : int, iterations of the first-order search (L-BFGS-B).
    lp_count : int, certificate LPs solved (0 on regular meshes, as a rule).
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
    seconds: float
    notes: list[str] = dataclasses.field(default_factory=list)
    status: str = "undecided"
    certificate_faces: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    certificate_multipliers: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0))
    certificate_residual: float | None = None
    iterations: int = 0
    lp_count: int = 0
    masses_lost_tets: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))

    def to_dict(self) -> dict:
        """A JSON-ready dict of the scalar fields and counts (arrays summarised)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name in ("weights", "face_margins", "certificate_multipliers",
                          "masses_lost_tets"):
                continue
            if isinstance(v, np.ndarray):
                out[f"n_{f.name}"] = int(len(v))
            elif isinstance(v, tuple):
                out[f.name] = list(v)
            else:
                out[f.name] = v
        return out

    def __str__(self) -> str:
        verdict = {"regular": "yes", "not regular": "NO (proved)",
                   "undecided": "undecided"}[self.status]
        lines = [
            f"regular: {verdict} (margin {self.margin:.3e}; "
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
        if len(self.certificate_faces):
            lines.append(f"certificate: {len(self.certificate_faces)} faces that no weights "
                         "make all locally regular")
        return "\n".join(lines + [f"note: {n}" for n in self.notes])


# --------------------------------------------------------------------------------------
# The solver
# --------------------------------------------------------------------------------------

def _vertex_lengths(V, T) -> np.ndarray:
    """Mean length of the edges at every vertex (1 for unreferenced vertices)."""
    n = len(V)
    E = mesh_edges(T)
    d = V[E[:, 0]] - V[E[:, 1]]
    length = np.sqrt(np.einsum("ed,ed->e", d, d))
    total = np.bincount(E.ravel(), np.repeat(length, 2), minlength=n)
    count = np.bincount(E.ravel(), minlength=n)
    return np.where(count > 0, total / np.maximum(count, 1), 1.0)


def _dual(V, T, w, on_boundary):
    """The (weighted) dual's negative interior weights, as :func:`tetlap.check` counts
    them, and its circumcentric masses; one assembly and one pass of the core's checks.
    Tets the core refuses with these weights (weights far larger than their squared
    edges: its accuracy guard) are skipped in the counts."""
    L, M = assembly.operators(V, T, "dual", "circumcentric", weights=w,
                              degenerate="raise" if w is None else "skip")
    c = _core.check_operator(V, T, _sparse.arrays(L), on_boundary, NEGATIVE_TOL)
    return int(c["n_negative_inner"]), M.diagonal(), c["linear_precision"]


def _inner(a, b) -> float:
    # einsum, not a @ b: no BLAS call, so no OpenBLAS threads spinning on a busy machine
    return float(np.einsum("i,i->", a, b))


class _Problem:
    """The conditions of the non-folded faces as ``g(u) = g0 + A u`` in ``u = w / l^2``
    (``l``: a vertex's mean edge length, so that unknowns and coefficients are O(1)).

    A : (c, n) csr_array, 5 entries a row.  g0 : (c,) margins at ``w = 0``.
    wgt : (c,) ``1 / |A_c|^2``: ``sqrt(wgt) * (aim - g)`` is the distance of ``u`` to
    the half-space ``g_c >= aim``.  norm1 : (c,) ``|A_c|_1`` (for certificate residuals).
    """

    def __init__(self, idx: np.ndarray, Gs: np.ndarray, g0: np.ndarray, rows: np.ndarray,
                 n: int):
        c = len(rows)
        self.idx, self.Gs, self.g0, self.rows, self.n = idx, Gs, g0, rows, n
        self.A = sp.csr_array((Gs.ravel(), idx.ravel(), np.arange(0, 5 * c + 1, 5)),
                              shape=(c, n))
        self.At = self.A.T.tocsr()
        self.norm1 = np.abs(Gs).sum(axis=1)
        self.wgt = 1.0 / (Gs * Gs).sum(axis=1)

    @classmethod
    def of(cls, cond: _Conditions, l2: np.ndarray) -> "_Problem":
        """The conditions of ``cond`` on non-folded faces, ``rows``: their positions."""
        rows = np.flatnonzero(~cond.folded[cond.face])
        idx = cond.idx[rows]
        return cls(idx, cond.G[rows] * l2[idx], cond.g0[rows], rows, len(l2))

    def subset(self, sel: np.ndarray) -> "_Problem":
        """The conditions ``sel`` (indices into this problem) as a problem of their own."""
        return _Problem(self.idx[sel], self.Gs[sel], self.g0[sel], self.rows[sel], self.n)

    def margins(self, u: np.ndarray) -> np.ndarray:
        return self.g0 + self.A @ u

    def shortfall(self, u, aim):
        """``F(u) = 1/2 sum_c wgt_c max(0, aim_c - g_c(u))^2`` and its gradient (n,)."""
        r = np.maximum(0.0, aim - self.margins(u))
        wr = self.wgt * r
        return 0.5 * _inner(r, wr), -(self.At @ wr)

    def shortfall_rows(self, u, aim) -> np.ndarray:
        """The conditions short of their aim at ``u``, largest shortfall first."""
        d = np.sqrt(self.wgt) * (aim - self.margins(u))
        short = np.flatnonzero(d > 1e-12)
        return short[np.argsort(-d[short], kind="stable")]

    def ring(self, rows: np.ndarray) -> np.ndarray:
        """``rows`` plus every condition sharing a vertex with one of them (sorted)."""
        cols = np.unique(self.A.indices[(self.A.indptr[rows][:, None]
                                         + np.arange(5)).ravel()])
        return np.unique(self.At[cols].indices)

    def certificate(self, rows: np.ndarray, time_limit: float):
        """Gordan's alternative on the conditions ``rows`` by an LP (HiGHS): maximise
        ``sum y`` subject to ``A[rows]^T y = 0``, ``g0[rows] . y <= 0``, ``0 <= y <= 1``.
        Every weight entering those rows is free, so a solution with ``y != 0`` proves that
        no ``w`` makes them all strictly positive. Returns ``y`` (len(rows),) or None;
        ``y`` is accepted only when its residual (:meth:`residual`) is below 1e-8."""
        from scipy.optimize import linprog

        Ar = self.A[rows]
        cols, inverse = np.unique(Ar.indices, return_inverse=True)
        M = sp.csr_array((Ar.data, inverse.ravel(), Ar.indptr), shape=(len(rows), len(cols)))
        options = {"time_limit": max(time_limit, 0.01), "primal_feasibility_tolerance": 1e-10,
                   "dual_feasibility_tolerance": 1e-10}
        res = interruptible(linprog, -np.ones(len(rows)), A_ub=self.g0[rows][None, :],
                            b_ub=[0.0], A_eq=M.T.tocsr(), b_eq=np.zeros(len(cols)),
                            bounds=(0.0, 1.0), method="highs", options=options)
        if res.status != 0 or not -res.fun > 0.5:
            return None
        y = np.where(res.x > 1e-9, res.x, 0.0)
        return y if self.residual(rows, y) <= _CERT_RTOL else None

    def residual(self, rows, y) -> float:
        """``|A[rows]^T y|_1 / sum_c y_c |A_c|_1``: 0 for an exact certificate."""
        z = np.zeros(self.A.shape[0])
        z[rows] = y
        return float(np.abs(self.At @ z).sum() / _inner(self.norm1[rows], y))


#: A multiplier vector ``y >= 0`` counts as a certificate of non-regularity when its
#: combination of the face conditions vanishes to this relative residual
#: (:meth:`_Problem.residual`); HiGHS's solutions have ~1e-14.
_CERT_RTOL = 1e-8
#: Certificate LPs are tried on the conditions still short of their aim, then on one ring
#: more, when they are at most this many; else around the worst few (:data:`_CERT_SEEDS`).
_CERT_MAX_ROWS = 20000
_CERT_SEEDS = 3


def _minimise(fun, u0, lo, hi, stop, max_iterations: int):
    """L-BFGS-B (SciPy) on ``fun(u) -> (f, grad)`` within ``lo <= u <= hi`` from ``u0``,
    stopping early when ``stop(u)`` holds after an iteration, or when ``f`` fell by less
    than :data:`_STALL_DROP` over the last :data:`_STALL_WINDOW` iterations (a slow tail:
    the caller then looks for a certificate or relaxes). Returns (u, iterations)."""
    from scipy.optimize import Bounds, minimize

    history: list[float] = []

    def callback(intermediate_result):
        history.append(float(intermediate_result.fun))
        old = history[-_STALL_WINDOW - 1] if len(history) > _STALL_WINDOW else np.inf
        if stop(intermediate_result.x) or history[-1] > (1 - _STALL_DROP) * old:
            raise StopIteration

    res = minimize(fun, u0, jac=True, method="L-BFGS-B", bounds=Bounds(lo, hi),
                   callback=callback,
                   options={"maxiter": max(int(max_iterations), 1), "maxcor": 10,
                            "ftol": 1e-14, "gtol": 1e-12, "maxfun": 4 * max_iterations + 20})
    return res.x, len(history)


#: Stall test of :func:`_minimise`: the objective fell by less than this fraction...
_STALL_DROP = 0.01
#: ... over this many iterations.
_STALL_WINDOW = 100


def _aims(problem, violated, floor):
    """The floors every condition must reach for a margin ``floor`` (the violated faces:
    ``floor``; the others: half their plain margin if that is smaller) and the aims of the
    search, ``0.1 * floor`` above them so that the floors are reached in finitely many
    steps."""
    floor_t = np.where(violated, floor, np.minimum(floor, problem.g0 / 2))
    return floor_t, floor_t + 0.1 * floor


def _certificate_near(problem, u, aim, deadline):
    """Look for a certificate where the search is stuck. At a minimum of the shortfall,
    ``y = wgt * shortfall`` satisfies ``A^T y = 0`` up to the bounds, so the conditions
    short of their aim hold an obstruction when there is one. LPs on one ring around each
    of the 20 largest shortfalls, on 2 and 3 rings around the :data:`_CERT_SEEDS` largest
    first (non-regular meshes have
    small obstructions: 4-200 faces on the corpus and on jittered balls), then on all
    the short conditions and one ring more when they are few (:data:`_CERT_MAX_ROWS`).
    Returns ((rows, y) or None, LPs solved)."""
    short = problem.shortfall_rows(u, aim)
    candidates = [problem.ring(short[k:k + 1]) for k in range(min(len(short), 20))]
    for seed in short[:_CERT_SEEDS]:
        rows = problem.ring(np.array([seed]))
        for _ in range(2):
            rows = problem.ring(rows)
            candidates.append(rows)
    candidates += [short, problem.ring(short)] if len(short) <= _CERT_MAX_ROWS else []
    solved = 0
    for rows in candidates:
        left = np.inf if deadline is None else deadline - time.perf_counter()
        if left <= 0:
            break
        if not len(rows) or len(rows) > _CERT_MAX_ROWS:
            continue
        y = problem.certificate(rows, min(left, 600.0))
        solved += 1
        if y is not None:
            keep = y > 0
            return (rows[keep], y[keep]), solved
    return None, solved


def _search_floor(problem, floor_t, aim, u, lo, hi, timed_out, budget):
    """L-BFGS-B on the squared shortfall, on a working set: the conditions within
    :data:`_ACTIVE` of their aim (most faces have margins far above any floor, 90% of
    them on a random mesh), grown by the ones the weights bring near their aim and
    solved again until none is left out. Returns (u, iterations, the working set's
    problem, its indices into ``problem``)."""
    active = problem.margins(u) < aim + _ACTIVE
    used = 0
    while True:
        index = np.flatnonzero(active)
        sub = problem.subset(index)
        f_sub, a_sub = floor_t[index], aim[index]

        def stop(v):
            return bool((sub.margins(v) >= f_sub).all()) or timed_out()

        u, k = _minimise(lambda v: sub.shortfall(v, a_sub), u, lo, hi, stop, budget - used)
        used += k
        near = ~active & (problem.margins(u) < aim + _ACTIVE / 2)
        stuck = not (sub.margins(u) >= f_sub).all()   # the caller looks for a certificate
        if stuck or not near.any() or used >= budget or timed_out():
            return u, used, sub, index
        active |= near


#: Iterations of :func:`_decide` at a floor before it looks for a certificate and
#: lowers the floor (the last floor gets what is left).
_LEVEL_ITERATIONS = 2000

#: The working set of :func:`_search_floor`: conditions within this margin of their aim.
_ACTIVE = 0.05


def _decide(problem, violated, target, lo, hi, deadline, max_iterations, notes):
    """Search weights that lift every condition to its floor (:func:`_search_floor`, from
    ``u = 0``); when it converges short of them, look for a certificate there, and else
    try a floor ten, then a hundred times lower. Returns a dict: u, status ("regular",
    "not regular", "undecided"), floor, floor_t, cert (rows of ``problem``, y),
    iterations, lps.
    """
    out = {"iterations": 0, "lps": 0, "cert": None}
    u = np.zeros(problem.n)

    def timed_out():
        return deadline is not None and time.perf_counter() > deadline

    floors = (target, target / 10, target / 100)
    for level, floor in enumerate(floors):
        floor_t, aim = _aims(problem, violated, floor)
        out.update(floor=floor, floor_t=floor_t)
        budget = (max_iterations - out["iterations"]) // (len(floors) - level)
        if level < len(floors) - 1:        # a stuck search is better off certified early
            budget = min(budget, _LEVEL_ITERATIONS)
        u, used, sub, index = _search_floor(problem, floor_t, aim, u, lo, hi, timed_out,
                                            max(budget, 1))
        out["iterations"] += used
        out["u"] = u
        if (problem.margins(u) >= floor_t).all():
            return dict(out, status="regular")
        if timed_out():
            notes.append(f"stopped at the time limit after {out['iterations']} iterations")
            return dict(out, status="undecided")
        cert, solved = _certificate_near(sub, u, aim[index], deadline)
        out["lps"] += solved
        if cert is not None:
            return dict(out, status="not regular", cert=(index[cert[0]], cert[1]))
        if out["iterations"] >= max_iterations:
            notes.append(f"stopped after max_iterations = {max_iterations} iterations")
            return dict(out, status="undecided")
        notes.append(f"margin {floor:g} not reached and no certificate: trying a lower one")
    g = problem.margins(u)
    if (g[violated] > 0).all():
        out["floor"] = float(g[violated].min())
        out["floor_t"] = np.minimum(out["floor_t"], g)
        notes.append(f"repaired faces kept at margin {out['floor']:.3g}, below the floors")
        return dict(out, status="regular")
    notes.append("no floor reached and no certificate found")
    return dict(out, status="undecided")


def _mass_rows(V, T, w, l2, m_plain, rows, mass_floor, m):
    """The masses of ``rows`` linearised at ``w`` (where the masses are ``m``) as
    conditions ``B u >= aim`` in ``u`` units, each scaled by the plain mass:
    (B (k, n) csr_array, aim (k,), wgt (k,))."""
    J = _mass_jacobian(V, T, w, rows)                  # d m_rows / d w, (k, n)
    scale = 1.0 / m_plain[rows]
    B = sp.csr_array(sp.diags_array(scale) @ J @ sp.diags_array(l2))
    goal = (mass_floor + 0.1 * (1 - mass_floor)) * m_plain[rows]
    aim = (goal - m[rows] + J @ w) * scale
    norms = np.asarray((B * B).sum(axis=1)).ravel()
    return B, aim, 1.0 / np.maximum(norms, 1e-300)


def _masses(V, T, w) -> np.ndarray:
    return assembly.mass(V, T, "circumcentric", weights=w, degenerate="skip").diagonal()


def _mass_score(m, m_plain, mass_floor):
    """(masses lost, the sum of the relative deficits below ``mass_floor``) of the masses
    ``m`` (..., n) against the positive plain ones: compared lexicographically (fewer
    masses lost first). ``m`` may carry leading axes (the points of a line search)."""
    positive = m_plain > 0
    rel = m[..., positive] / m_plain[positive]
    lost = (rel <= 0).sum(axis=-1)
    deficit = np.maximum(mass_floor - rel, 0.0).sum(axis=-1)
    return lost, deficit


def _mass_low(m, m_plain, mass_floor) -> np.ndarray:
    """The vertices whose weighted mass is below ``mass_floor`` times a positive plain one."""
    return np.flatnonzero((m_plain > 0) & (m < mass_floor * m_plain))


#: The points of the line search of the mass step: ``t = 2^-k`` (the linearised step may
#: only be good very near its start) and a uniform grid of [0, 1].
_LINE_T = np.unique(np.concatenate([2.0 ** -np.arange(1, 13), np.linspace(0, 1, 65)[1:]]))
#: The cubic in ``t`` of the masses is known from these four points of the segment.
_CUBIC_T = np.array([0.0, 1 / 3, 2 / 3, 1.0])


def _line_search(V, T, w0, w1, m0, m1, m_plain, mass_floor):
    """The best point ``w0 + t (w1 - w0)``, ``0 < t <= 1``, for the masses (fewest lost,
    then smallest deficit: :func:`_mass_score`). Power centres are affine in the weights
    and every flag piece of a cell is a triple product of three of them, so every mass is
    a cubic polynomial in ``t``: two more assemblies (``t = 1/3, 2/3``; ``m0``, ``m1``
    are the ends) give all of it, scored on :data:`_LINE_T`. Returns (t, masses there,
    recomputed by the core: the cubic is only the guide)."""
    d = w1 - w0
    M = np.stack([m0, _masses(V, T, w0 + d / 3), _masses(V, T, w0 + 2 * d / 3), m1])
    C = np.linalg.solve(np.vander(_CUBIC_T, 4, increasing=True), M)        # (4, n)
    lost, deficit = _mass_score(np.vander(_LINE_T, 4, increasing=True) @ C, m_plain,
                                mass_floor)
    t = float(_LINE_T[np.lexsort((deficit, lost))[0]])
    return t, (m1 if t == 1.0 else _masses(V, T, w0 + t * d))


def _repair_masses(problem, V, T, u, l2, m_plain, mass_floor, floor_t, lo, hi, deadline,
                   notes, rounds: int = 8, iterations: int = 300):
    """Keep the weighted masses above ``mass_floor`` times the positive plain ones.

    Each round: the masses below it, linearised at the current weights ``u`` (exact
    derivatives by the complex step), join the faces' shortfall as hinge rows; L-BFGS-B
    on that gives ``v``, searched back to half the faces' floors when it broke them. The
    linearisation only holds near ``u`` (a boundary cell is a signed sum of pieces cut
    by power centres that move far for small weights), so ``v`` is not taken as it is: a line
    search on the true masses along ``u -> v`` (:func:`_line_search`) picks the point
    with the fewest masses lost, then the smallest deficit. The faces need no check
    there: their margins are affine in the weights, so every point of the segment keeps
    the floors that both ends meet. A round is kept when it improves on ``u`` (masses
    lost, then deficit); when it does not, the next one is confined to a tenth of the
    step (a trust region ``|u' - u| <= radius``). Returns u."""
    aim_faces = floor_t + 0.1 * np.maximum(floor_t, 0.0)
    floor_t = np.minimum(floor_t, floor_t / 2)    # the faces may give up half their floor
    rows = np.zeros(0, dtype=np.int64)
    m = _masses(V, T, u * l2)
    score = _mass_score(m, m_plain, mass_floor)
    low = _mass_low(m, m_plain, mass_floor)
    radius, kept = np.inf, False
    for _ in range(rounds):
        kept = False
        if not len(low) or (deadline is not None and time.perf_counter() > deadline):
            break
        rows = np.union1d(rows, low)
        B, aim, wgt = _mass_rows(V, T, u * l2, l2, m_plain, rows, mass_floor, m)
        box_lo, box_hi = np.maximum(lo, u - radius), np.minimum(hi, u + radius)

        def fun(v, B=B, aim=aim, wgt=wgt):
            f, grad = problem.shortfall(v, aim_faces)
            r = np.maximum(0.0, aim - B @ v)
            return f + 0.5 * _inner(r, wgt * r), grad - B.T @ (wgt * r)

        def stop(v, B=B, aim=aim):
            return bool((problem.margins(v) >= floor_t).all() and (B @ v >= aim).all()) or (
                deadline is not None and time.perf_counter() > deadline)

        v, _ = _minimise(fun, u, box_lo, box_hi, stop, iterations)
        if not (problem.margins(v) >= floor_t).all():      # back to the faces' floors
            v, _ = _minimise(lambda x: problem.shortfall(x, aim_faces), v, box_lo, box_hi,
                             lambda x: bool((problem.margins(x) >= floor_t).all()),
                             iterations)
        if not (problem.margins(v) >= floor_t).all():     # too far: a shorter step
            radius = 0.1 * float(np.abs(v - u).max())
            continue
        t, m_t = _line_search(V, T, u * l2, v * l2, m, _masses(V, T, v * l2), m_plain,
                              mass_floor)
        u_t = u + t * (v - u)
        score_t = _mass_score(m_t, m_plain, mass_floor)
        if not ((problem.margins(u_t) >= floor_t).all() and score_t < score):
            radius = 0.1 * float(np.abs(v - u).max())
            continue
        u, m, score, kept = u_t, m_t, score_t, True
        low = _mass_low(m, m_plain, mass_floor)
    if len(low):
        notes.append(f"{len(low)} weighted masses stay below {mass_floor:g} x their plain "
                     "value (no weights found that keep the faces regular and lift them"
                     + (f"; the mass step stopped after {rounds} rounds, the last still "
                        "improving" if kept else "") + ")")
    return u


def regular_weights(V, T, *, target_margin: float = TARGET_MARGIN, boundary: str = "free",
                    mass_floor: float | None = 0.1, max_weight: float = 10.0,
                    rtol: float = REGULAR_RTOL, time_limit: float | None = None,
                    max_iterations: int = 20000) -> RegularWeights:
    """Vertex weights that make the mesh regular, so that its weighted dual has
    non-negative interior weights, or a proof that none do.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers.  T : (m, 4) integer array-like, any orientation.
    target_margin : float > 0, the face margin (module docstring: dual-edge length over
        face size) the weights aim for on the faces they repair. Faces that are locally
        Delaunay keep at least ``min(half their plain margin, target_margin)``.
    boundary : ``"free"`` (default: boundary vertices get weights like any other) or
        ``"zero"`` (boundary weights fixed at 0). Boundary faces impose no condition, but a
        boundary vertex's weight enters the conditions of the interior faces around it and
        moves the power centers of its boundary tets (so its own and its neighbours'
        masses). ``"zero"`` keeps the boundary cells closer to the plain ones and can make
        a regular mesh non-regular.
    mass_floor : float in [0, 1) or None, keep every weighted circumcentric mass above
        ``mass_floor`` times its plain value where that is positive (0: only keep it
        positive). A soft constraint: the vertices where it fails are reported. None:
        skip that step (masses are then only reported): for a Laplacian alone, as the
        step moves weights away from the faces' smallest ones and can cost accuracy
        (EXPERIMENTS.md section 7: the Dirichlet error on strongly non-Delaunay shells).
    max_weight : bound on ``|w_i| / l_i^2`` (``l_i`` the vertex's mean edge length) in
        the search. The proofs of "not regular" do not depend on it.
    rtol : the round-off tolerance of the regularity test (:data:`REGULAR_RTOL`).
    time_limit : float or None, seconds for the whole call (None: no limit); at the
        limit the search stops with ``status == "undecided"`` unless already decided.
    max_iterations : int, cap on L-BFGS-B iterations (each a few sparse products over the
        faces); past it the status is ``"undecided"`` unless already decided.

    Returns
    -------
    :class:`RegularWeights` (``.weights``, ``.regular``, ``.status``, ``.margin``,
    ``.violated_faces``, ``.certificate_faces``, masses and counts; ``str()`` is a short
    report).

    Method
    ------
    Every local condition is linear in ``w``, so regularity is a linear feasibility
    problem; a general LP on the whole mesh needs minutes at 20k tets. Instead:

    1. ``w = 0`` first: a Delaunay mesh (no violated face) is returned as it is, for the
       cost of the face conditions (one vectorised pass) and one assembly.
    2. *Search*, first order: minimise the squared shortfalls
       ``sum_f max(0, aim_f - margin_f(w))^2`` (each normalised by the gradient of its
       margin, so it is a squared distance to the face's half-space) by L-BFGS-B
       (SciPy) from ``w = 0`` within ``|w_i| <= max_weight * l_i^2``, with ``aim_f``
       a little above ``target_margin`` on the faces violated at ``w = 0`` and above
       ``min(plain margin / 2, target_margin)`` on the others. Boundary weights are
       kept ``>= 0`` first (boundary power cells then only grow, which keeps the boundary
       masses positive: 24 masses lost -> 0 on ``flipfree_fish_blub``); when that search
       is undecided (it gets half of ``max_iterations``), it is run again with weights
       of either sign (the other half). It stops as soon as every face
       reaches its floor: *regular*, confirmed by the margin test (:data:`REGULAR_RTOL`).
       Starting from 0 keeps the weights local (zero away from the repairs) and small.
    3. *Certificate*: when the search converges short of the floors, the conditions still
       short of their aim carry the multipliers of its optimality condition; an LP
       (HiGHS) on them, then on one ring more, looks for Gordan multipliers: ``y >= 0``,
       ``y != 0`` with ``sum_f y_f grad margin_f = 0``. Found (and verified: relative
       residual below 1e-8), no weights at all make those faces strictly locally
       regular: *not regular*, proved. Else the floor is lowered to a tenth, then a
       hundredth of the target, and finally any strictly positive margin is accepted.
    4. *Masses* (regular meshes, ``mass_floor``): vertices whose weighted mass falls below
       ``mass_floor`` times a positive plain mass get a hinge row on their mass,
       linearised at the current weights (exact derivatives by the complex step of a NumPy
       copy of the core's kernel), then the faces alone back to their floors; up to 8
       rounds of 300 iterations, the faces kept at half their floors at least
       (``margin_floor`` reports the floor before that). The linearisation only holds
       near the current weights (boundary cells are signed sums of pieces cut by power
       centres that move far for small weights), so each round ends with a line
       search on the true masses along the step: every mass is a cubic polynomial of
       the weights on a segment (power centres are affine in them), known from two more
       assemblies; the point with the fewest masses lost, then the smallest deficit, is
       kept if it improves on the round's start (the faces' margins, affine, keep their
       floors on the whole segment); else the next round gets a trust region of a tenth
       of the step. Where masses are still lost, ``masses_lost_tets`` and a note say
       which tets took them.

    Near-flat tets (hull slivers) may be refused by the core's accuracy guard with the
    weights found (``DegenerateElementError``: weights far larger than their squared
    edges); pass ``degenerate="skip"`` to the operators then, as the counts here do.

    When the mesh is not regular (or undecided) the weights are the search's last ones
    (they minimise the sum of squared shortfalls, which spreads violations rather than
    minimising their number), or 0 if those violate more faces than ``w = 0``.

    Deterministic (the same input gives the same output). Inputs are not modified.

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
    >>> r.status, r.n_negative_interior_plain > 0, r.n_negative_interior_weighted
    ('regular', True, 0)
    >>> L = tetlap.laplacian(V, T, "dual", weights=r.weights)
    >>> bool(tetlap.check(L, V, T).linear_precision_ok)
    True
    """
    start = time.perf_counter()
    V, T = _validated(V, T)
    _check_options(target_margin, boundary, mass_floor, max_weight, rtol, time_limit,
                   max_iterations)
    deadline = None if time_limit is None else start + time_limit
    on_boundary, interior = _mesh_faces(V, T)
    cond = _conditions(V, T, interior)
    zero = np.zeros(len(V))
    violated0 = cond.g0 < -cond.tolerance(zero, rtol)
    notes: list[str] = []
    n_neg_plain, m_plain, _ = _dual(V, T, None, on_boundary)
    w, outcome = zero, None
    if (violated0 & ~cond.folded[cond.face]).any():
        w, outcome = _search_weights(V, T, cond, on_boundary, violated0, m_plain, deadline,
                                     target_margin, boundary, mass_floor, max_weight,
                                     max_iterations, rtol, notes)
    elif violated0.any():
        notes.append("only folded faces are violated: no weights help, w = 0")
    else:
        notes.append("Delaunay: the plain dual (w = 0) is already the answer")
    n_neg_w, m_weighted = ((n_neg_plain, m_plain) if not w.any()
                           else _dual(V, T, w, on_boundary)[:2])
    repaired = np.zeros(len(T), dtype=bool)
    repaired[interior[cond.face[violated0]][:, [0, 2]].ravel()] = True
    lost = np.flatnonzero((m_plain > 0) & (m_weighted <= 0))
    culprits, note = _why_masses_lost(V, T, w, lost, repaired, on_boundary)
    if note is not None:
        notes.append(note)
    return _result(cond, w, outcome, violated0, rtol, target_margin, mass_floor,
                   (n_neg_plain, n_neg_w), (m_plain, m_weighted), notes, start, culprits)


def _search_weights(V, T, cond, on_boundary, violated0, m_plain, deadline, target_margin,
                    boundary, mass_floor, max_weight, max_iterations, rtol, notes):
    """Steps 2-4 of :func:`regular_weights`: returns (w (n,), the outcome of
    :func:`_decide` with the problem under ``"problem"``)."""
    l2 = _vertex_lengths(V, T) ** 2
    allowed = np.ones(len(V), dtype=bool) if boundary == "free" else ~on_boundary
    hi = np.where(allowed, float(max_weight), 0.0)
    problem = _Problem.of(cond, l2)
    iterations = 0
    for lo, budget in ((np.where(on_boundary, 0.0, -hi), max_iterations // 2),
                       (-hi, max_iterations)):
        outcome = _decide(problem, violated0[problem.rows], target_margin, lo, hi, deadline,
                          budget - iterations, notes)
        iterations += outcome["iterations"]
        if (outcome["status"] != "undecided" or not (on_boundary & allowed).any()
                or iterations >= max_iterations):
            break
        notes.append("boundary weights >= 0 were not enough: weights of either sign")
    outcome["iterations"] = iterations
    outcome["problem"] = problem
    u = outcome["u"]
    if outcome["status"] == "regular" and mass_floor is not None:
        u = _repair_masses(problem, V, T, u, l2, m_plain, mass_floor, outcome["floor_t"],
                           lo, hi, deadline, notes)
    w = u * l2
    if outcome["status"] != "regular":
        violated = cond.margins(w) < -cond.tolerance(w, rtol)
        if violated.sum() > violated0.sum():
            notes.append("the search's weights violate more faces than w = 0: w = 0")
            w = np.zeros(len(V))
    return w, outcome


def _certificate_of(cond, outcome):
    """(faces (k, 3), multipliers (k,), relative residual) of the proof of non-regularity:
    the folded faces (multipliers 1, residual 0) or the LP's certificate; empty arrays
    and None when there is none."""
    if cond.folded.any():
        k = int(cond.folded.sum())
        return cond.tri[cond.folded].astype(np.int64), np.ones(k), 0.0
    if outcome is None or outcome["cert"] is None:
        return np.zeros((0, 3), dtype=np.int64), np.zeros(0), None
    problem = outcome["problem"]
    rows, y = outcome["cert"]
    faces = cond.face[problem.rows[rows]]      # non-folded: one condition per face
    return cond.tri[faces].astype(np.int64), y, problem.residual(rows, y)


def _result(cond, w, outcome, violated0, rtol, target_margin, mass_floor, negatives,
            masses, notes, start, culprits) -> RegularWeights:
    """The verdict (the margin test on ``w``, else the certificate) and the report."""
    g = cond.margins(w)
    bad = np.zeros(cond.n_faces, dtype=bool)
    bad[cond.face[g < -cond.tolerance(w, rtol)]] = True
    bad |= cond.folded
    per_face = cond.per_face(g)
    certificate, multipliers, residual = _certificate_of(cond, outcome)
    if len(certificate):
        status = "not regular"
        notes.append(f"not regular: a certificate on {len(certificate)} faces "
                     + ("(folded)" if residual == 0.0 else
                        f"(Gordan multipliers, relative residual {residual:.1e})"))
    elif not bad.any():
        status = "regular"
    else:
        status = "undecided"
        if outcome is not None and outcome["status"] == "regular":
            notes.append("the search's floors were met but the margin test (rtol) was not")
    m_plain, m_weighted = masses
    positive = m_plain > 0
    regular = status == "regular"
    return RegularWeights(
        weights=w,
        regular=regular,
        margin=float(per_face.min()) if cond.n_faces else 0.0,
        violated_faces=cond.tri[bad].astype(np.int64),
        face_margins=per_face,
        margin_plain=float(cond.per_face(cond.g0).min()) if cond.n_faces else 0.0,
        n_violated_plain=int(np.unique(cond.face[violated0]).size),
        n_folded=int(cond.folded.sum()),
        target_margin=float(target_margin),
        margin_floor=float(outcome["floor"]) if regular and outcome is not None else None,
        n_weighted_vertices=int((w != 0).sum()),
        n_negative_interior_plain=negatives[0],
        n_negative_interior_weighted=negatives[1],
        mass_min_plain=float(m_plain.min()),
        mass_min_weighted=float(m_weighted.min()),
        masses_lost=np.flatnonzero(positive & (m_weighted <= 0)).astype(np.int64),
        masses_below_floor=np.flatnonzero(
            positive & (m_weighted < (mass_floor or 0.0) * m_plain)).astype(np.int64),
        masses_lost_tets=culprits,
        seconds=time.perf_counter() - start,
        notes=notes,
        status=status,
        certificate_faces=certificate,
        certificate_multipliers=multipliers,
        certificate_residual=residual,
        iterations=0 if outcome is None else outcome["iterations"],
        lp_count=0 if outcome is None else outcome["lps"],
    )


def _check_options(target_margin, boundary, mass_floor, max_weight, rtol, time_limit,
                   max_iterations):
    def number(x):
        return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)

    if not (number(target_margin) and 0 < target_margin < np.inf):
        raise OptionError(f"target_margin must be a positive number, got {target_margin!r}")
    if boundary not in ("free", "zero"):
        raise OptionError(f'boundary must be "free" or "zero", got {boundary!r}')
    if mass_floor is not None and not (number(mass_floor) and 0 <= mass_floor < 1):
        raise OptionError(f"mass_floor must lie in [0, 1) or be None, got {mass_floor!r}")
    if not (number(max_weight) and 0 < max_weight < np.inf):
        raise OptionError(f"max_weight must be a positive number, got {max_weight!r}")
    if not (number(rtol) and 0 <= rtol < np.inf):
        raise OptionError(f"rtol must be a non-negative number, got {rtol!r}")
    if time_limit is not None and not (number(time_limit) and time_limit > 0):
        raise OptionError(f"time_limit must be positive seconds or None, got {time_limit!r}")
    if not (isinstance(max_iterations, (int, np.integer)) and not isinstance(max_iterations, bool)
            and max_iterations >= 1):
        raise OptionError(f"max_iterations must be a positive integer, got {max_iterations!r}")
