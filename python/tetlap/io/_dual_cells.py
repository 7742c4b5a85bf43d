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

import meshio

from .. import _arrays
from ..dual import _parity, dual_geometry
from ..errors import ShapeError

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


def dual_cells(V, T=None, *, weights=None, threads=None):
    """The dual cells (Voronoi cells, or power cells with vertex weights) of a tet mesh as
    VTK polyhedra in a ``meshio.Mesh``: ``tetlap.io.dual_cells(V, T).write("cells.vtu")``.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers
        Vertex positions in R^3.
    T : (m, 4) array-like of integers, optional
        Tets, any orientation; leave it out to pass a mesh object as ``V``.
    weights : (n,) array-like of real numbers, optional
        Vertex weights: power cells (see :func:`tetlap.dual_geometry`).
    threads : int, optional
        Worker threads of the core.

    Returns
    -------
    meshio.Mesh
        Points: the vertices, then one point per edge (its midpoint, the power point with
        weights), per face and per tet (their centres, as :func:`tetlap.dual_geometry`
        gives them). One ``"polyhedron"`` cell per vertex used by a tet, in blocks by
        number of points (meshio's layout), each a closed surface of triangles oriented
        outward where the cell is positively oriented: per tet around the vertex ``a`` and
        per face ``abc`` of it, ``(c_ab, c_abc, c_abcd)``, and per boundary face ``abc``
        at ``a`` also ``(a, c_ab, c_abc)`` and ``(a, c_ac, c_abc)`` (centres ``c``). Cell
        data ``"vertex"`` (the vertex of each cell: blocks do not keep the vertex order)
        and ``"control_volume"`` (the circumcentric mass). The divergence theorem over
        each surface gives the signed control volume exactly (to rounding): a cell whose
        pieces are negative (centres outside their tets) turns partly inside out, so it
        is a correct chain but not always a valid solid for a viewer.

    Raises
    ------
    ShapeError
        ``V`` not in R^3 (VTK points are 3-D).
    tetlap.TetlapError
        As :func:`tetlap.dual_geometry` raises it.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.ball(200, seed=1)
    >>> cells = tetlap.io.dual_cells(V, T)
    >>> sum(len(block) for block in cells.cells) == len(V)
    True
    >>> cells.write("cells.vtu")  # doctest: +SKIP
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise ShapeError(f"dual cells are VTK polyhedra in R^3, V has shape {V.shape}")
    points, triangles, owner, volume = surfaces(V, T, weights, threads)
    vertices, start = np.unique(owner, return_index=True)
    groups = np.split(triangles, start[1:])
    size = np.array([len(np.unique(g)) for g in groups])
    blocks, vertex, control = [], [], []
    for k in np.unique(size):  # meshio reads polyhedra back in blocks of ascending size
        members = np.flatnonzero(size == k)
        blocks.append((f"polyhedron{k}", [list(groups[i]) for i in members]))
        vertex.append(vertices[members])
        control.append(volume[vertices[members]])
    return meshio.Mesh(points, blocks, cell_data={"vertex": vertex, "control_volume": control})

