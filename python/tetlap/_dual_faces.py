"""The faces of the dual cells, as pieces of the tets (for the face table of
:class:`tetlap.DualGeometry` and for :func:`tetlap.io.dual_cells`).

The cell of vertex ``a`` is the signed union of the pieces ``(x_a, c_ab, c_abc, c_abcd)`` of
the flags ``(a, b, c, d)`` at ``a`` (paper Sec. 5; ``c`` the centres: the edge's point, the
face and tet centres), each with the sign of ``det(x_b - x_a, x_c - x_a, x_d - x_a)``. Its
surface is made of:

* the dual faces of the edges ``ab`` at ``a``: per tet at the edge, its two flags give the
  path ``c_in -> c_t -> c_out`` (an *arc*) from the centre of the face it enters by,
  through the tet's centre, to the centre of the face it leaves by, turning positively
  about ``x_b - x_a`` for ``a < b``; the arcs of consecutive tets meet at the face between
  them;
* per face ``abc`` that closes the mesh there, and corner ``a``, the piece ``(x_a, c_ab,
  c_abc, c_ac)`` of its plane: ``closing`` counts how often, with sign, a face bounds the
  union of the tets (each taken positively): 1 on the boundary, 2 on a *fold* (two tets on
  the same side of their face), 0 between two tets on opposite sides. At such a face the
  arcs of its edges close through the edge's point ``c_ab``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .assembly import _LOCAL_EDGES as _EDGES

#: The two other corners of each of a tet's local edges (``_EDGES``).
_OTHERS = np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]])
#: The faces of a tet, ``_FACES[l]`` opposite corner ``l``.
_FACES = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])
#: The three corners of a sorted face ``(u0, u1, u2)`` with their two neighbours in the
#: face's cyclic order: ``(a, b, c)`` = ``(u0, u1, u2)``, ``(u1, u2, u0)``, ``(u2, u0, u1)``.
ROTATIONS = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])


def parity(p: np.ndarray) -> np.ndarray:
    """+1 / -1: the sign of each row of ``p`` (k, 4) as a permutation of its values."""
    inversions = sum((p[:, i] > p[:, j]).astype(np.int64) for i in range(4) for j in range(i + 1, 4))
    return 1 - 2 * (inversions % 2)


def outward(T: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """(m, 4) int64: +1 where the face opposite corner ``l`` of tet ``t``, oriented by its
    sorted vertices ``(a, b, c)``, has its normal ``(x_b - x_a) x (x_c - x_a)`` pointing out
    of the tet, -1 where inward (``orientation``: the tets' signs, none 0). The face and
    the opposite corner ``o`` are the tet as ``(a, b, c, o)``, whose orientation is the
    tet's times the parity of that reordering; the normal points to ``o`` when it is +1."""
    m = len(T)
    local = np.broadcast_to(_FACES, (m, 4, 3))
    order = np.take_along_axis(local, np.argsort(T[:, _FACES], axis=2), axis=2)
    corners = np.concatenate([order, np.broadcast_to(np.arange(4)[None, :, None], (m, 4, 1))], axis=2)
    return -orientation.astype(np.int64)[:, None] * parity(corners.reshape(-1, 4)).reshape(m, 4)


def closing(T: np.ndarray, orientation: np.ndarray, tet_faces: np.ndarray, F: int) -> np.ndarray:
    """(F,) int64: how often each face, oriented by its sorted vertices, bounds the union
    of the tets (each taken positively) outward: +-1 on the boundary, +-2 on a fold, 0
    where its two tets lie on opposite sides."""
    return np.bincount(tet_faces.ravel(), outward(T, orientation).ravel(), F).astype(np.int64)


def edge_points(V: np.ndarray, edges: np.ndarray, w: np.ndarray | None) -> np.ndarray:
    """(E, d): where each edge meets its dual face: the midpoint, or with vertex weights
    ``w`` the power point ``x_a + tau (x_b - x_a)``, ``tau = 1/2 + (w_a - w_b) / (2
    |x_b - x_a|^2)``."""
    a, b = edges[:, 0], edges[:, 1]
    ab = V[b] - V[a]
    if w is None:
        return V[a] + 0.5 * ab
    tau = 0.5 + (w[a] - w[b]) / (2 * np.einsum("ij,ij->i", ab, ab))
    return V[a] + tau[:, None] * ab


@dataclasses.dataclass(frozen=True)
class Arcs:
    """One per tet and edge of it (row ``6 t + k``, the tet's local edge ``k``): the dual
    face of ``edge`` crosses ``tet`` from the face ``into`` to the face ``out``. ``node_in``
    / ``node_out``: ``3 f + k`` for the face ``f`` and its edge ``k`` (0: its vertices 0 and
    1 in sorted order, 1: 0 and 2, 2: 1 and 2), where the arc meets the next one."""

    edge: np.ndarray
    tet: np.ndarray
    into: np.ndarray
    out: np.ndarray
    node_in: np.ndarray
    node_out: np.ndarray


def arcs(T: np.ndarray, orientation: np.ndarray, edges: np.ndarray, tet_faces: np.ndarray,
         n: int) -> Arcs:
    """The arcs of the tets ``T`` (m, 4) with ``orientation`` (m,) +-1; ``edges`` (E, 2)
    sorted as :attr:`DualGeometry.edges`, ``tet_faces`` (m, 4) as
    :attr:`DualGeometry.tet_faces`."""
    m = len(T)
    p, q = _EDGES[:, 0], _EDGES[:, 1]
    r, s = _OTHERS[:, 0], _OTHERS[:, 1]
    swap = T[:, p] > T[:, q]                                        # (m, 6)
    lo, hi = np.where(swap, T[:, q], T[:, p]), np.where(swap, T[:, p], T[:, q])
    # the flag (lo, hi, T[r], T[s]) goes from face (lo, hi, T[r]) (opposite s) to face
    # (lo, hi, T[s]) (opposite r) when positive: the tet's sign times the parity of the
    # corners (p, q, r, s), reversed by a swap
    flag = parity(np.column_stack([_EDGES, _OTHERS]))              # (6,)
    forward = (orientation.astype(np.int64)[:, None] * flag * np.where(swap, -1, 1)) > 0
    into = np.where(forward, tet_faces[:, s], tet_faces[:, r])
    out = np.where(forward, tet_faces[:, r], tet_faces[:, s])
    c_in = np.where(forward, T[:, r], T[:, s])
    c_out = np.where(forward, T[:, s], T[:, r])
    which = lambda c: 2 - (lo < c).astype(np.int64) - (hi < c)     # the edge's place in a face
    key = edges[:, 0] * n + edges[:, 1]
    return Arcs(edge=np.searchsorted(key, lo * n + hi).ravel(),
                tet=np.repeat(np.arange(m, dtype=np.int64), 6),
                into=into.ravel(), out=out.ravel(),
                node_in=(3 * into + which(c_in)).ravel(),
                node_out=(3 * out + which(c_out)).ravel())


def frames(V: np.ndarray, T: np.ndarray) -> np.ndarray | None:
    """None in R^3; in R^d, d > 3, (m, d, 3): an orthonormal basis of each tet's 3-space,
    oriented as its corners ``(x1 - x0, x2 - x0, x3 - x0)`` (the orientation that
    :attr:`DualGeometry.orientation` gives immersed tets: +1)."""
    if V.shape[1] == 3:
        return None
    X = V[T]
    Q, R = np.linalg.qr(np.stack([X[:, k] - X[:, 0] for k in (1, 2, 3)], axis=2))
    return Q * np.sign(np.diagonal(R, axis1=1, axis2=2))[:, None, :]


def det(u, v, w, frame, tet) -> np.ndarray:
    """(k,): ``det(u, v, w)`` of vectors (k, d) of the 3-space of ``tet`` (k,), in its
    oriented frame (R^3: the plain determinant)."""
    if frame is not None:
        Q = frame[tet]
        u, v, w = (np.einsum("kdi,kd->ki", Q, x) for x in (u, v, w))
    return np.einsum("ij,ij->i", np.cross(u, v), w)


def centroids(owner: np.ndarray, p: np.ndarray, q: np.ndarray, r: np.ndarray,
              normal: np.ndarray, frame, tet, apex: np.ndarray):
    """``(area (K,), centroid (K, d))`` of faces made of pieces, each the triangles
    ``(apex, p, q)`` and ``(apex, q, r)`` (``p, q, r`` (k, d) relative to the apex of the
    piece's face ``owner`` (k,)), with signed areas along ``normal`` (k, d) in the frame of
    ``tet``. The centroid weighs each triangle by its signed area; a face whose area is
    zero to rounding (at most ``2^-40`` of the sum of its triangles' absolute areas) has
    the mean of its triangles' corners instead, not a division by 0."""
    K, d = apex.shape
    a1, a2 = 0.5 * det(p, q, normal, frame, tet), 0.5 * det(q, r, normal, frame, tet)
    add = lambda x: np.bincount(owner, x, K).astype(np.float64, copy=False)  # noqa: E731
    area, size = add(a1 + a2), add(np.abs(a1) + np.abs(a2))
    moment = (a1[:, None] * (p + q) + a2[:, None] * (q + r)) / 3
    corners = p + 2 * q + r
    moment = np.stack([add(moment[:, k]) for k in range(d)], axis=1)
    mean = np.stack([add(corners[:, k]) for k in range(d)], axis=1)
    mean /= np.maximum(6 * np.bincount(owner, minlength=K), 1)[:, None]
    flat = np.abs(area) <= 2.0**-40 * size
    offset = np.where(flat[:, None], mean, moment / np.where(flat, 1.0, area)[:, None])
    return area, apex + offset


def table(V, w, T, orientation, edges, edge_length, faces, face_tets, tet_faces,
          face_centres, centres):
    """The arrays of :class:`tetlap.dual.DualFaces` that the core does not give:
    ``(vertices, normal, centroid, edge, face, boundary_area)``, every length in the frame
    of ``V`` (``w`` and the centres scaled alike)."""
    n, E = len(V), len(edges)
    frame = frames(V, T)
    arc = arcs(T, orientation, edges, tet_faces, n)
    c_e = edge_points(V, edges, w)
    normal = (V[edges[:, 1]] - V[edges[:, 0]]) / edge_length[:, None]
    apex = c_e[arc.edge]
    d_in, d_t, d_out = (X - apex for X in (face_centres[arc.into], centres[arc.tet],
                                           face_centres[arc.out]))
    _, inner = centroids(arc.edge, d_in, d_t, d_out, normal[arc.edge], frame, arc.tet, c_e)
    # boundary rows: per boundary face (sorted u0 < u1 < u2) and corner a, the piece
    # (x_a, c_ab, c_f, c_ac) of the face's plane, its normal pointing out of its tet
    bf = np.flatnonzero(face_tets[:, 1] < 0)
    t = face_tets[bf, 0]
    X = V[faces[bf]]
    e1, e2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    if frame is None:
        out = np.cross(e1, e2) * closing(T, orientation, tet_faces, len(faces))[bf, None]
    else:  # minus the part of the opposite corner orthogonal to the face
        corner = np.argmax(tet_faces[t] == bf[:, None], axis=1)
        y = V[T[t, corner]] - X[:, 0]
        q1 = e1 / np.linalg.norm(e1, axis=1)[:, None]
        q2 = e2 - np.einsum("ij,ij->i", e2, q1)[:, None] * q1
        q2 /= np.linalg.norm(q2, axis=1)[:, None]
        out = -(y - np.einsum("ij,ij->i", y, q1)[:, None] * q1
                - np.einsum("ij,ij->i", y, q2)[:, None] * q2)
    out /= np.linalg.norm(out, axis=1)[:, None]
    U = faces[bf][:, ROTATIONS]                                   # (b, 3, 3): (a, b, c)
    key = edges[:, 0] * n + edges[:, 1]
    edge_of = lambda x, y: np.searchsorted(key, np.minimum(x, y) * n + np.maximum(x, y))
    x_a = V[U[:, :, 0]].reshape(-1, V.shape[1])
    d_ab, d_f, d_ac = (Y.reshape(-1, V.shape[1]) - x_a for Y in (
        c_e[edge_of(U[:, :, 0], U[:, :, 1])], np.repeat(face_centres[bf][:, None], 3, axis=1),
        c_e[edge_of(U[:, :, 0], U[:, :, 2])]))
    # the pieces turn as the face's sorted corners, whose sense is that of the outward
    # normal or the opposite: their areas are positive for a centre inside the face
    turn = np.repeat(out * np.sign(det(e1, e2, out, frame, t))[:, None], 3, axis=0)
    out = np.repeat(out, 3, axis=0)
    rows = np.arange(3 * len(bf))
    boundary_area, outer = centroids(rows, d_ab, d_f, d_ac, turn, frame, np.repeat(t, 3), x_a)
    vertices = np.concatenate([edges, np.column_stack([U[:, :, 0].ravel(),
                                                       np.full(3 * len(bf), -1)])])
    return (vertices, np.concatenate([normal, out]), np.concatenate([inner, outer]),
            np.concatenate([np.arange(E), np.full(3 * len(bf), -1)]),
            np.concatenate([np.full(E, -1), np.repeat(bf, 3)]), boundary_area)
