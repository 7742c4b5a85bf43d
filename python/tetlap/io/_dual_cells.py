"""The dual cells of a tet mesh as polyhedra, one per control volume, with shared faces
(:func:`dual_cells`), for VTK and ParaView.

A cell's faces are the dual faces of the edges at its vertex, one polygon per edge (the
tet centres around the edge, in order), shared with the cell across the edge, and the
pieces ``(x_a, c_ab, c_abc, c_ac)`` of the mesh faces that close it (see
:mod:`tetlap._dual_faces`). Every piece carries its sign, so the divergence theorem over a
cell's faces gives its signed control volume exactly (to rounding), on any mesh.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from .. import _arrays, _dual_faces
from .._float_range import unit_scale
from ..dual import dual_geometry
from ..errors import MeshFileError, ShapeError
from . import _vtk
from ._pyvista import _pyvista

#: The file formats that hold VTK polyhedra: what :meth:`DualCells.write` writes.
FORMATS = {".vtu": "VTK XML, compressed", ".vtk": "legacy VTK 5.1, binary"}


@dataclasses.dataclass(frozen=True, eq=False)
class DualCells:
    """The dual cells of a tet mesh as polyhedra (see :func:`dual_cells`).

    points : (P, 3) float64
        The corners of the faces: tet centres, and where a cell meets the mesh's
        boundary, vertices, edge points and face centres.
    faces, face_offsets : (S,) int64, (F + 1,) int64
        Face ``f`` is the polygon ``points[faces[face_offsets[f]:face_offsets[f + 1]]]``,
        each face once: the dual face of an edge (its normal, by the right-hand rule, from
        the edge's lower vertex to its higher one), or a piece of a boundary face (its
        normal out of the mesh).
    cell_faces, cell_sides, cell_offsets : (J,) int64, (J,) int8, (k + 1,) int64
        Cell ``c`` has the faces ``cell_faces[cell_offsets[c]:cell_offsets[c + 1]]``,
        each as stored (side +1) or reversed (-1) so that its normal points out of the
        cell; a face between two cells is in both, once each way.
    vertex : (k,) int64
        The vertex of each cell: every vertex in a tet, ascending.
    control_volume : (k,) float64
        Its signed control volume, the circumcentric mass (``DualGeometry
        .control_volume[vertex]``).

    Examples
    --------
    >>> import numpy as np, tetlap, tetlap.io
    >>> cells = tetlap.io.dual_cells(*tetlap.meshes.cube(2))
    >>> cells                      # 98 edges' faces; 144 pieces of the 48 boundary faces
    DualCells(27 cells, 242 faces, 194 points)
    >>> c = 13                                      # the cell of the cube's centre vertex
    >>> int(cells.vertex[c]), float(cells.control_volume[c]), round(float(cells.volumes()[c]), 12)
    (13, 0.125, 0.125)
    >>> faces = cells.cell_faces[cells.cell_offsets[c]:cells.cell_offsets[c + 1]]
    >>> len(faces)                                  # one per edge at the vertex
    14
    >>> cells.write("cells.vtu")  # doctest: +SKIP
    """

    points: np.ndarray
    faces: np.ndarray
    face_offsets: np.ndarray
    cell_faces: np.ndarray
    cell_sides: np.ndarray
    cell_offsets: np.ndarray
    vertex: np.ndarray
    control_volume: np.ndarray

    def __len__(self) -> int:
        return len(self.vertex)

    def __repr__(self) -> str:
        return (f"DualCells({len(self)} cells, {len(self.face_offsets) - 1} faces, "
                f"{len(self.points)} points)")

    def face_streams(self) -> tuple[np.ndarray, np.ndarray]:
        """``(stream, ends)``: every cell as VTK's polyhedron face stream ``[number of
        faces, size of face 0, its points, size of face 1, ...]`` with its faces turned
        outward, all cells in one int64 array; ``ends`` (k,): where each cell's ends."""
        stream, ends, _, _ = self._streams()
        return stream, ends

    def _streams(self):
        """``(stream, ends, head, owner)``: :meth:`face_streams` and, per face of a cell
        (in ``cell_faces`` order), where its size stands in the stream and its cell."""
        per_cell = np.diff(self.cell_offsets)
        owner = np.repeat(np.arange(len(self)), per_cell)
        size = np.diff(self.face_offsets)[self.cell_faces]
        before = np.cumsum(size + 1) - (size + 1)          # the faces' sizes and points
        first = before[self.cell_offsets[:-1]]
        cell_start = np.arange(len(self)) + first          # one number of faces per cell
        head = cell_start[owner] + 1 + before - first[owner]
        ends = np.r_[cell_start[1:], len(self) + (size + 1).sum()]
        stream = np.empty(ends[-1], dtype=np.int64)
        stream[cell_start] = per_cell
        stream[head] = size
        k = np.arange(size.sum()) - np.repeat(np.cumsum(size) - size, size)
        flip = np.repeat(self.cell_sides < 0, size)
        at = np.repeat(self.face_offsets[self.cell_faces], size) + np.where(
            flip, np.repeat(size, size) - 1 - k, k)
        stream[np.repeat(head + 1, size) + k] = self.faces[at]
        return stream, ends, head, owner

    def volumes(self) -> np.ndarray:
        """(k,) float64: each cell's signed volume by the divergence theorem over its
        faces (cones from a point of the cell): ``control_volume`` to rounding."""
        stream, _, head, owner = self._streams()
        size = stream[head]
        fan = size - 2                                     # triangles from the first point
        j = np.repeat(np.arange(len(head)), fan)
        k = np.arange(fan.sum()) - np.repeat(np.cumsum(fan) - fan, fan)
        apex = self.points[stream[head[self.cell_offsets[:-1]] + 1]][owner[j]]
        u, v, w = (self.points[stream[at]] - apex
                   for at in (head[j] + 1, head[j] + 2 + k, head[j] + 3 + k))
        return np.bincount(owner[j], np.einsum("ij,ij->i", u, np.cross(v, w)) / 6, len(self))

    def write(self, path) -> None:
        """Write the cells to ``.vtu`` (VTK XML, zlib-compressed) or ``.vtk`` (legacy VTK
        5.1, binary): VTK polyhedra with the cell data ``"vertex"`` (int64) and
        ``"control_volume"`` (float64), for ParaView, VTK, PyVista and meshio (``.vtu``).
        The file holds the cells grouped by their number of points (meshio reads them in
        such blocks), each with its ``"vertex"``.

        Raises
        ------
        MeshFileError
            Another extension (no other format holds polyhedra with their faces; meshio's
            writers drop them or fail), before anything is written.
        OSError
            The file cannot be written.
        """
        path = os.fsdecode(path)
        ext = os.path.splitext(path)[1].lower()
        if ext not in FORMATS:
            kinds = ", ".join(f"{e} ({what})" for e, what in FORMATS.items())
            raise MeshFileError(f"{path}: dual cells are VTK polyhedra, which only {kinds} "
                                f"hold; not {ext or 'a file without extension'}")
        # grouped by number of points, as meshio's reader needs (it files cells in blocks
        # by that number and would misplace their data)
        points, point_offsets = self._cell_points()
        order = np.lexsort((self.vertex, np.diff(point_offsets)))
        cells = self._taken(order)
        stream, ends = cells.face_streams()
        data = {"vertex": cells.vertex, "control_volume": cells.control_volume}
        points, point_offsets = _rows(points, point_offsets, order)
        (_vtk.write_vtu if ext == ".vtu" else _vtk.write_legacy)(
            path, cells.points, stream, ends, (points, point_offsets[1:]), data)

    def _taken(self, cells: np.ndarray) -> DualCells:
        """The cells ``cells`` (indices), in that order."""
        faces, offsets = _rows(self.cell_faces, self.cell_offsets, cells)
        sides, _ = _rows(self.cell_sides, self.cell_offsets, cells)
        return dataclasses.replace(self, cell_faces=faces, cell_sides=sides,
                                   cell_offsets=offsets, vertex=self.vertex[cells],
                                   control_volume=self.control_volume[cells])

    def _cell_points(self) -> tuple[np.ndarray, np.ndarray]:
        """``(points, offsets)``: each cell's distinct points, ascending, as rows."""
        size = np.diff(self.face_offsets)[self.cell_faces]
        owner = np.repeat(np.repeat(np.arange(len(self)), np.diff(self.cell_offsets)), size)
        start = np.repeat(self.face_offsets[self.cell_faces], size)
        k = np.arange(size.sum()) - np.repeat(np.cumsum(size) - size, size)
        pairs = np.sort(owner * len(self.points) + self.faces[start + k])
        pairs = pairs[np.r_[True, pairs[1:] != pairs[:-1]]]
        count = np.bincount(pairs // len(self.points), minlength=len(self))
        return pairs % len(self.points), np.r_[0, np.cumsum(count)]

    def to_pyvista(self):
        """A ``pyvista.UnstructuredGrid`` of the cells (``CellType.POLYHEDRON``) with the
        cell data ``"vertex"`` and ``"control_volume"``; needs pyvista."""
        pv = _pyvista()
        stream, ends = self.face_streams()
        lengths = np.diff(np.r_[0, ends])
        cells = np.insert(stream, ends - lengths, lengths)
        grid = pv.UnstructuredGrid(cells, np.full(len(self), pv.CellType.POLYHEDRON, np.uint8),
                                   self.points.copy())
        grid.cell_data["vertex"] = self.vertex.copy()
        grid.cell_data["control_volume"] = self.control_volume.copy()
        return grid


def _rows(values: np.ndarray, offsets: np.ndarray, rows: np.ndarray):
    """``(values, offsets)`` of the rows ``rows`` of a ragged array, in that order."""
    count = np.diff(offsets)[rows]
    at = np.repeat(offsets[rows] - (np.cumsum(count) - count), count) + np.arange(count.sum())
    return values[at], np.r_[0, np.cumsum(count)]


def _ranks(sorted_keys: np.ndarray) -> np.ndarray:
    """0, 1, ... within each run of equal values of ``sorted_keys``."""
    position = np.arange(len(sorted_keys))
    new = np.r_[True, sorted_keys[1:] != sorted_keys[:-1]]
    return position - np.maximum.accumulate(np.where(new, position, 0))


def _successors(arc) -> tuple[np.ndarray, np.ndarray]:
    """``(next, through)``: the arc that follows each arc around its edge, and whether the
    dual face closes between them through the edge's point (the arc leaves by a face no
    arc enters by: the boundary, or a fold). At every (edge, face) meeting point the arcs
    that leave are matched with those that enter, in order; the rest, per edge, through
    the edge's point, in order of their faces."""
    A = len(arc.edge)
    leave = np.argsort(arc.node_out, kind="stable")
    enter = np.argsort(arc.node_in, kind="stable")
    out_key = 2 * arc.node_out[leave] + _ranks(arc.node_out[leave])  # a node has <= 2 arcs
    in_key = 2 * arc.node_in[enter] + _ranks(arc.node_in[enter])
    at = np.minimum(np.searchsorted(in_key, out_key), A - 1)
    met = in_key[at] == out_key
    nxt = np.empty(A, dtype=np.int64)
    nxt[leave[met]] = enter[at[met]]
    entered = np.zeros(A, dtype=bool)
    entered[at[met]] = True
    lonely_out, lonely_in = leave[~met], enter[~entered]
    lonely_out = lonely_out[np.lexsort((arc.node_out[lonely_out], arc.edge[lonely_out]))]
    lonely_in = lonely_in[np.lexsort((arc.node_in[lonely_in], arc.edge[lonely_in]))]
    nxt[lonely_out] = lonely_in                # as many per edge: the flow around it balances
    through = np.zeros(A, dtype=bool)
    through[lonely_out] = True
    return nxt, through


def _cycles(nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(order, lowest)``: the arcs in cycle order (cycles by their lowest arc, each from
    that arc on) and each arc's lowest arc, by pointer doubling: about log2 of the longest
    cycle rounds."""
    lowest, jump = np.arange(len(nxt)), nxt
    while True:
        new = np.minimum(lowest, lowest[jump])
        jump = jump[jump]
        if (new == lowest).all():  # the lowest of 2^(k+1) steps is that of 2^k: converged
            break
        lowest = new
    # steps to the cycle's last arc (the one before its lowest), by pointer jumping:
    # togo[i] counts the steps from i to succ[i], until every succ is a last arc
    last = nxt == lowest[nxt]
    succ = np.where(last, np.arange(len(nxt)), nxt)
    togo = (~last).astype(np.int64)
    while not (succ[succ] == succ).all():
        togo = togo + togo[succ]
        succ = succ[succ]
    return np.lexsort((-togo, lowest)), lowest


def _polyhedra(V, T, g, w, scale: float) -> DualCells:
    """The cells of the tets ``T`` with the dual geometry ``g`` (weights ``w`` or None;
    ``scale``: a power of two that brings the edges to about unit length)."""
    n, E, F = len(V), len(g.edges), len(g.faces)
    arc = _dual_faces.arcs(T, g.orientation, g.edges, g.tet_faces, n)
    nxt, through = _successors(arc)
    order, lowest = _cycles(nxt)
    # the polygons: per arc its tet's centre, and where the face closes through the edge
    # point, the face centre it leaves by, the edge point, the face centre the next enters
    edge_pt, face_pt, tet_pt = n, n + E, n + E + F         # the blocks of point numbers
    extra = np.where(through[order], 3, 0)
    starts = np.cumsum(1 + extra) - (1 + extra)
    poly = np.empty((1 + extra).sum(), dtype=np.int64)
    poly[starts] = tet_pt + arc.tet[order]
    o, at = order[through[order]], starts[through[order]]
    poly[at + 1] = face_pt + arc.out[o]
    poly[at + 2] = edge_pt + arc.edge[o]
    poly[at + 3] = face_pt + arc.into[nxt[o]]
    first = np.r_[True, lowest[order][1:] != lowest[order][:-1]]
    poly_edge = arc.edge[order[first]]
    poly_offsets = np.r_[starts[first], len(poly)]
    # the pieces (x_a, c_ab, c_abc, c_ac) of the faces that close the cells, as often as
    # they close them (twice on a fold), turned out of the union of the tets
    kappa = _dual_faces.closing(T, g.orientation, g.tet_faces, F)
    closed = np.repeat(np.flatnonzero(kappa), np.abs(kappa[kappa != 0]))
    U = g.faces[closed][:, _dual_faces.ROTATIONS]                   # (q, 3, 3): (a, b, c)
    key = g.edges[:, 0] * n + g.edges[:, 1]
    edge_of = lambda x, y: edge_pt + np.searchsorted(key, np.minimum(x, y) * n + np.maximum(x, y))
    ab, ac = edge_of(U[..., 0], U[..., 1]), edge_of(U[..., 0], U[..., 2])
    out = (kappa[closed] > 0)[:, None]
    quads = np.stack([U[..., 0], np.where(out, ab, ac),
                      np.broadcast_to((face_pt + closed)[:, None], ab.shape),
                      np.where(out, ac, ab)], axis=-1).reshape(-1, 4)
    faces = np.concatenate([poly, quads.ravel()])
    face_offsets = np.r_[poly_offsets, len(poly) + 4 * np.arange(1, len(quads) + 1)]
    # every face in its cells: a polygon in the cells of its edge's two ends, a piece in its
    # corner's
    P = len(poly_edge)
    cell = np.concatenate([g.edges[poly_edge, 0], g.edges[poly_edge, 1], quads[:, 0]])
    face = np.concatenate([np.arange(P), np.arange(P), P + np.arange(len(quads))])
    side = np.concatenate([np.ones(P), -np.ones(P), np.ones(len(quads))]).astype(np.int8)
    by_cell = np.lexsort((face, cell))
    vertex, per_cell = np.unique(cell, return_counts=True)
    # the points the faces use, numbered anew; the edge points in a frame of about unit
    # edges (a power of two: exact both ways), for the weights' term
    used, faces = np.unique(faces, return_inverse=True)
    s = scale
    sources = [V, lambda e: s * _dual_faces.edge_points(V / s, g.edges[e], None if w is None
                                                         else w / s**2),
               g.face_centres, g.centres]
    block = np.searchsorted([edge_pt, face_pt, tet_pt], used, side="right")
    points = np.empty((len(used), 3))
    for k, (source, start) in enumerate(zip(sources, (0, edge_pt, face_pt, tet_pt))):
        rows = used[block == k] - start
        points[block == k] = source(rows) if callable(source) else source[rows]
    return DualCells(points=points, faces=faces.astype(np.int64, copy=False), face_offsets=face_offsets,
                     cell_faces=face[by_cell], cell_sides=side[by_cell],
                     cell_offsets=np.r_[0, np.cumsum(per_cell)], vertex=vertex,
                     control_volume=g.control_volume[vertex])


def dual_cells(V, T=None, *, weights=None, threads=None) -> DualCells:
    """The dual cells (Voronoi cells, or power cells with vertex weights) of a tet mesh as
    polyhedra, one per control volume, with shared faces:
    ``tetlap.io.dual_cells(V, T).write("cells.vtu")``.

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
    DualCells
        One cell per vertex in a tet (ascending; ``.vertex``), with its control volume
        (``.control_volume``, the circumcentric mass). Its faces are the dual faces of the
        edges at the vertex (the polygon of the tet centres around each edge, shared with
        the cell at the edge's other end) and, at the mesh's boundary, the pieces ``(x_a,
        c_ab, c_abc, c_ac)`` of the boundary faces (``c``: edge points, face centres).
        ``.write("cells.vtu")`` or ``.write("cells.vtk")`` writes VTK polyhedra with the
        cell data ``"vertex"`` and ``"control_volume"``; ``.to_pyvista()`` gives a
        ``pyvista.UnstructuredGrid``.

    Notes
    -----
    The cells are exact as signed chains: the divergence theorem over each cell's faces
    gives its control volume to rounding (:meth:`DualCells.volumes`), on any mesh. Where
    centres lie outside their tets (not Delaunay, or obtuse at the boundary) a cell turns
    partly inside out: a correct signed region, not always a valid solid for a viewer.
    Where two tets lie on the same side of their common face (a mesh folded over itself),
    the union of the tets covers the overlap twice, and so do the control volumes: the
    face closes the cells of its corners twice, so their pieces of it are in those cells
    twice.

    Raises
    ------
    ShapeError
        ``V`` not in R^3 (VTK points are 3-D).
    tetlap.TetlapError
        As :func:`tetlap.dual_geometry` raises it.

    Examples
    --------
    >>> import numpy as np, tetlap, tetlap.io
    >>> V, T = tetlap.meshes.ball(200, seed=1)
    >>> cells = tetlap.io.dual_cells(V, T)
    >>> len(cells) == len(V), bool(np.allclose(cells.volumes(), cells.control_volume))
    (True, True)
    >>> cells.write("cells.vtu")  # doctest: +SKIP
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise ShapeError(f"dual cells are VTK polyhedra in R^3, V has shape {V.shape}")
    g = dual_geometry(V, T, weights=weights, threads=threads)
    used = np.unique(T)
    scale = unit_scale(V[used], np.searchsorted(used, T))
    w = _arrays.vertex_weights(weights, len(V))
    return _polyhedra(V, T, g, w, scale)
