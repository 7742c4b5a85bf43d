"""The dual cells of a tet mesh as closed triangulated surfaces (for
:func:`tetlap.io.dual_cells`).

The cell of vertex ``a`` is the union of the pieces ``(x_a, c_ab, c_abc, c_abcd)`` of the
flags at ``a`` (paper Sec. 5; ``c`` the centres: edge points, face and tet centres). Its
boundary is made of the triangles ``(c_ab, c_abc, c_abcd)`` of those flags (the dual faces
of the edges at ``a``, one triangle per tet and face at the edge) and, where ``abc`` is a
boundary face, of the triangles ``(x_a, c_ab, c_abc)`` and ``(x_a, c_ac, c_abc)``. The
piece of the flag ``(a, b, c)`` with fourth corner ``d`` carries the sign ``s`` of the
orientation of ``(x_a, x_b, x_c, x_d)`` (SPEC section 2), so each triangle is oriented as
the outward face of the piece taken with that sign; the triangles through ``x_a`` inside
the cell then cancel in pairs, and the divergence theorem over the surface gives the
signed cell volume: the circumcentric mass.
"""

from __future__ import annotations

import itertools

import numpy as np

from .dual import _parity, dual_geometry

#: The flags of a tet at its corners: ``(a, b, c, d)`` for every ordering of the corners.
_FLAGS = np.array(list(itertools.permutations(range(4))))


def surfaces(V: np.ndarray, T: np.ndarray, weights, threads):
    """``(points (P, 3), triangles (k, 3) int64, owner (k,) int64, control_volume (n,))``:
    the dual cells' boundary triangles as rows of point indices, each owned by the vertex
    whose cell it bounds, grouped by owner (ascending). The points are the vertices, then
    the edge points (one per edge of :attr:`DualGeometry.edges`), the face centres, the
    tet centres. ``V`` (n, 3) float64 and ``T`` (m, 4) int64 validated."""
    g = dual_geometry(V, T, weights=weights, threads=threads)
    n, m = len(V), len(T)
    E, F = len(g.edges), len(g.faces)
    w = np.zeros(n) if weights is None else np.asarray(weights, dtype=np.float64)
    a, b = g.edges[:, 0], g.edges[:, 1]
    ab = V[b] - V[a]
    tau = 0.5 + (w[a] - w[b]) / (2 * np.einsum("ij,ij->i", ab, ab))
    points = np.concatenate([V, V[a] + tau[:, None] * ab, g.face_centres, g.centres])
    edge_point, face_point, tet_point = n, n + E, n + E + F
    key = a * n + b
    edge = lambda p, q: edge_point + np.searchsorted(key, np.minimum(p, q) * n + np.maximum(p, q))
    # the piece of every flag: (tet, (a, b, c, d) as corners)
    sign = g.orientation.astype(np.int64)[:, None] * _parity(_FLAGS)[None, :]  # (m, 24)
    va, vb = T[:, _FLAGS[:, 0]], T[:, _FLAGS[:, 1]]
    p_edge = edge(va, vb)
    p_face = face_point + g.tet_faces[:, _FLAGS[:, 3]]
    p_tet = np.broadcast_to((tet_point + np.arange(m))[:, None], (m, 24))
    positive = sign > 0
    inner = np.stack([p_edge, np.where(positive, p_face, p_tet), np.where(positive, p_tet, p_face)],
                     axis=-1).reshape(-1, 3)
    owners = [va.reshape(-1)]
    triangles = [inner]
    # boundary faces: the flags whose face (a, b, c) is a boundary face
    boundary = g.boundary_faces[g.tet_faces[:, _FLAGS[:, 3]]]  # (m, 24)
    t, k = np.nonzero(boundary)
    if len(t):
        pos = positive[t, k]
        x_a = T[t, _FLAGS[k, 0]]
        c_ab, c_abc = p_edge[t, k], p_face[t, k]
        triangles.append(np.column_stack([x_a, np.where(pos, c_abc, c_ab), np.where(pos, c_ab, c_abc)]))
        owners.append(x_a)
    triangles = np.concatenate(triangles)
    owner = np.concatenate(owners)
    order = np.argsort(owner, kind="stable")
    return points, triangles[order], owner[order], g.control_volume

