"""The orthogonal dual of a tet mesh as geometry: what a finite-volume code needs.

The dual of the circumcentric Laplacian (or, with vertex weights, of the power-diagram
Laplacian) is an orthogonal dual: its cell centres are the tets' circumcentres (power
centres), and every dual edge crosses its face at right angles at the face's centre. This
module hands that dual out as numbers with their signs (:func:`dual_geometry`), computed by
the same core kernels as :func:`tetlap.laplacian` and :func:`tetlap.mass`, so that the two
never disagree.

>>> import tetlap
>>> V, T = tetlap.meshes.ball(300, seed=1)
>>> g = tetlap.dual_geometry(V, T)
>>> edges, w = tetlap.edge_weights(V, T, "dual")
>>> bool((g.edges == edges).all() and abs(g.dual_area / g.edge_length - w).max() < 1e-12)
True
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from . import _arrays, _core, _dual_faces, _sparse
from ._docs import shared_docs
from ._dual_faces import _FACES
from ._dual_faces import outward as _outward  # noqa: F401 (cells, dec)
from ._float_range import unit_scale
from .errors import DegenerateElementError
from ._names import public_dir

__all__ = ["dual_geometry", "DualGeometry", "DualFaces", "OUTSIDE_TOL"]
__dir__ = public_dir(globals())

#: A centre counts as outside its tet when one of its barycentric coordinates is below
#: ``-OUTSIDE_TOL`` (2^-40, the core's documented accuracy): a centre on a face or an edge
#: (a right-angled corner, a Kuhn grid) is not flagged for its rounding.
OUTSIDE_TOL = 2.0**-40



@dataclasses.dataclass(frozen=True, eq=False)
class DualFaces:
    """The faces of the dual cells, one row each: what a vertex-centred two-point-flux
    (TPFA) finite-volume code loops over (see :attr:`DualGeometry.dual_faces`).

    Rows ``0 .. E-1`` are the interior faces, row ``k`` the dual face of the edge
    ``DualGeometry.edges[k]``; then 3 rows per boundary face of the mesh (in the order of
    ``DualGeometry.faces``, its corners ascending): the piece ``(x_a, c_ab, c_abc, c_ac)``
    of the face that closes the cell of its corner ``a`` (``c``: the edge's midpoint, or
    power point, and the face's centre). ``K = E + 3 * (number of boundary faces)``.

    vertices : (K, 2) int64
        ``(i, j)``: the control volume (vertex) ``i`` the face bounds and ``j`` across it,
        ``i < j``; ``j = -1`` on the boundary.
    area : (K,) float64
        Signed area: for an interior face ``DualGeometry.dual_area`` (bit for bit),
        negative where the centres around the edge wind backwards (not Delaunay); for a
        boundary piece its area in the face's plane, negative where the face's centre lies
        beyond the edges at ``a`` (an obtuse boundary triangle). Their sums per vertex are
        the circumcentric boundary areas of :func:`tetlap.solve.dual_boundary_areas`.
    normal : (K, d) float64
        Unit normal, so that ``area * normal`` is the face's vector area: from ``i``
        towards ``j`` (``(x_j - x_i) / |x_j - x_i|``: the dual face is orthogonal to its
        edge) inside, out of the mesh on the boundary.
    centroid : (K, d) float64
        The face's centroid (each of its triangles weighted by its signed area); for a face
        of zero area to rounding (cospherical vertices, as in Kuhn grids), the mean of its
        triangles' corners.
    transmissibility : (K,) float64
        ``area / |x_j - x_i|``: the two-point flux coefficient, ``DualGeometry
        .transmissibility[k]`` and the dual Laplacian's ``L[i, j]`` (bit for bit); 0 on the
        boundary, whose pieces carry a prescribed flux (``area * g``), no coupling.
    edge : (K,) int64
        The row's edge in ``DualGeometry.edges``; -1 on the boundary.
    face : (K,) int64
        The boundary face in ``DualGeometry.faces`` of a boundary row; -1 inside.

    With a flux ``q_k = transmissibility_k (u_j - u_i)`` from ``i`` to ``j`` per interior
    row and the boundary's ``area_k * g_k`` (``g``: the outward normal derivative), the
    balance of every control volume is ``sum(into it) - sum(out of it)``: the interior rows
    give ``L u``. On a mesh whose tets fold over one another (two on the same side of their
    face), the control volumes count the overlap twice; the fold's pieces carry no flux and
    are not rows (:func:`tetlap.io.dual_cells` closes the cells with them).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp, tetlap
    >>> V, T = tetlap.meshes.ball(300, seed=1)
    >>> g = tetlap.dual_geometry(V, T)
    >>> f = g.dual_faces
    >>> inner = ~f.boundary
    >>> i, j = f.vertices[inner].T
    >>> t = f.transmissibility[inner]
    >>> L = sp.coo_array((np.r_[t, t, -t, -t], (np.r_[i, j, i, j], np.r_[j, i, i, j])),
    ...                  shape=(len(V), len(V))).tocsr()
    >>> bool(abs(L - tetlap.laplacian(V, T, "dual")).max() < 1e-12)
    True
    >>> b = f.boundary                                  # pieces of the boundary: closed cells
    >>> closure = np.zeros((len(V), 3))
    >>> np.add.at(closure, i, f.area[inner, None] * f.normal[inner])
    >>> np.add.at(closure, j, -f.area[inner, None] * f.normal[inner])
    >>> np.add.at(closure, f.vertices[b, 0], f.area[b, None] * f.normal[b])
    >>> bool(abs(closure).max() < 1e-12)
    True
    """

    vertices: np.ndarray
    area: np.ndarray
    normal: np.ndarray
    centroid: np.ndarray
    transmissibility: np.ndarray
    edge: np.ndarray
    face: np.ndarray

    @property
    def boundary(self) -> np.ndarray:
        """(K,) bool: the rows on the mesh's boundary (``vertices[:, 1] == -1``)."""
        return self.vertices[:, 1] < 0

    def __len__(self) -> int:
        return len(self.area)

    def __repr__(self) -> str:
        return (f"DualFaces({len(self)} faces: {int((~self.boundary).sum())} interior, "
                f"{int(self.boundary.sum())} on the boundary)")


@dataclasses.dataclass(frozen=True, eq=False)
class DualGeometry:
    """The orthogonal dual of a tet mesh (see :func:`dual_geometry`).

    Per edge (the unique edges, in the order of :func:`tetlap.edge_weights`):

    edges : (E, 2) int64
        ``i < j``, sorted lexicographically.
    edge_length : (E,) float64
        ``|x_j - x_i|``.
    dual_area : (E,) float64
        The signed area of the edge's dual face (the polygon of the centres around it,
        closed by face centres on the boundary): positive on a Delaunay mesh, negative
        where the centres around the edge wind backwards.
    transmissibility : (E,) float64
        ``dual_area / edge_length``: the dual Laplacian's weight ``L[i, j]`` (bit for bit)
        and the two-point flux coefficient of a vertex-centred finite-volume scheme.

    Per vertex:

    control_volume : (n,) float64
        The signed volume of the vertex's dual cell: the diagonal of
        ``tetlap.mass(V, T, "circumcentric", weights=...)`` (bit for bit); 0 for a vertex
        no tet uses.

    Per tet (the cells of a cell-centred scheme):

    centres : (m, d) float64
        The circumcentre, or with vertex weights the power centre (the point of equal
        power ``|c - x_i|^2 - w_i`` to the four corners, in the tet's 3-space).
    barycentric : (m, 4) float64
        The centre's barycentric coordinates in the tet (corner order of ``T``).
    outside : (m,) bool
        The centre lies outside its tet: a barycentric coordinate below ``-OUTSIDE_TOL``.
        The two-point flux stays consistent (the dual is orthogonal), but the centre is
        not a point of its cell.
    volume : (m,) float64
        The tet's volume, positive whatever its orientation.
    orientation : (m,) int8
        The sign of ``det[x1 - x0, x2 - x0, x3 - x0]`` (exact): +1 or -1; +1 for every tet
        of an immersed mesh (``d > 3``: no orientation of R^d is at hand).

    Per face (the unique faces, boundary faces included):

    faces : (F, 3) int64
        Sorted vertex triples ``a < b < c``, sorted lexicographically.
    face_tets : (F, 2) int64
        The tets on the two sides of the face, ascending; ``[t, -1]`` for a boundary face.
    tet_faces : (m, 4) int64
        ``tet_faces[t, l]``: the face of tet ``t`` opposite its corner ``l``.
    face_area : (F,) float64
        The face's area.
    face_centres : (F, d) float64
        The face's circumcentre (power centre), where its dual edge crosses its plane at
        right angles.
    dual_length : (F,) float64
        The signed length of the face's dual edge: the sum, over the face's tets, of the
        signed distance of the tet's centre from the face's plane, each positive on its
        own tet's side. For an interior face, ``|dual_length|`` is the distance between
        the two centres and its sign is negative when they lie the wrong way round (not
        locally Delaunay, or not locally regular with weights); for a boundary face it
        is the distance from the tet's centre to the face's centre, signed the same way.
        ``face_area / dual_length`` is the two-point flux coefficient of the face.

    The faces of the dual cells, for a vertex-centred finite-volume code (computed on
    first use):

    dual_faces : DualFaces
        One row per dual face: the two control volumes it separates (-1 for the
        boundary), its signed area, unit normal, centroid and transmissibility.
    """

    edges: np.ndarray
    edge_length: np.ndarray
    dual_area: np.ndarray
    transmissibility: np.ndarray
    control_volume: np.ndarray
    centres: np.ndarray
    barycentric: np.ndarray
    outside: np.ndarray
    volume: np.ndarray
    orientation: np.ndarray
    faces: np.ndarray
    face_tets: np.ndarray
    tet_faces: np.ndarray
    face_area: np.ndarray
    face_centres: np.ndarray
    dual_length: np.ndarray
    _mesh = None  # (V, T, weights), copies, set by dual_geometry: for dual_faces

    @functools.cached_property
    def dual_faces(self) -> DualFaces:
        """The faces of the dual cells, one row each (:class:`DualFaces`), computed on
        first use (two to three times the cost of :func:`dual_geometry` itself) in a frame
        of about unit edges (a power of two, so any scale is exact)."""
        if self._mesh is None:
            raise TypeError("dual_faces needs the mesh: take it from a DualGeometry that "
                            "tetlap.dual_geometry made, not a copy of one")
        V, T, w = self._mesh
        used = np.unique(T)
        s = unit_scale(V[used], np.searchsorted(used, T))
        vertices, normal, centroid, edge, face, boundary_area = _dual_faces.table(
            V / s, None if w is None else w / s**2, T, self.orientation, self.edges,
            self.edge_length / s, self.faces, self.face_tets, self.tet_faces,
            self.face_centres / s, self.centres / s)
        inner = edge >= 0
        return DualFaces(
            vertices=vertices,
            area=np.concatenate([self.dual_area, boundary_area * s**2]),
            normal=normal,
            centroid=centroid * s,
            transmissibility=np.where(inner, self.transmissibility[np.maximum(edge, 0)], 0.0),
            edge=edge,
            face=face,
        )

    @property
    def boundary_faces(self) -> np.ndarray:
        """(F,) bool: the faces of one tet."""
        return self.face_tets[:, 1] < 0

    def __repr__(self) -> str:
        return (f"DualGeometry({len(self.control_volume)} vertices, {len(self.edges)} edges, "
                f"{len(self.faces)} faces ({int(self.boundary_faces.sum())} on the boundary), "
                f"{len(self.volume)} tets ({int(self.outside.sum())} centres outside))")


@_arrays.takes_mesh_object
@shared_docs
def dual_geometry(V, T=None, *, weights=None, threads=None) -> DualGeometry:
    """The geometry of the orthogonal (circumcentric or power) dual of a tet mesh.

    Parameters
    ----------
    {dual_mesh}

    Returns
    -------
    DualGeometry
        Per edge the dual face's signed area, the edge's length and their ratio (the
        dual Laplacian's weight); per vertex the control volume (the circumcentric mass);
        per tet the centre, its barycentric coordinates and whether it lies outside; per
        face its area, centre and signed dual-edge length. See :class:`DualGeometry` for
        every array's shape and sign.

    Raises
    ------
    tetlap.DegenerateElementError
        A zero-volume tet (named), or a face shared by more than two tets (it has no dual
        edge; ``.element`` is its first tet).
    tetlap.TetlapError
        Any other bad input, as :func:`tetlap.laplacian` raises it.

    Notes
    -----
    The edge and vertex values are those of ``tetlap.operators(V, T, "dual",
    "circumcentric", weights=weights)``, one pass of the core: ``transmissibility`` is
    ``L[i, j]`` and ``control_volume`` the mass diagonal, bit for bit, and ``dual_area``
    is ``transmissibility * edge_length``. The centres come from the same closed forms
    and the same precise path (double-double for tets that are not well shaped) as those
    weights, so the identities of :mod:`tetlap.dec` hold to rounding.

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> g = tetlap.dual_geometry(V, [[0, 1, 2, 3]])
    >>> g.centres.tolist(), g.outside.tolist()
    ([[0.5, 0.5, 0.5]], [True])
    >>> g.faces[3].tolist(), round(float(g.dual_length[3]), 12)  # centre beyond face (1, 2, 3)
    ([1, 2, 3], -0.288675134595)
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    n = V.shape[0]
    w = _arrays.vertex_weights(weights, n)
    options = {"threads": threads}
    L, M = _core.assemble(V, T, ("operators", "dual", "circumcentric"), weights=w,
                          options=options)
    L = _sparse.csr(L, n)
    points, barycentric, heights, areas, volumes = _core.dual_centres(V, T, weights=w,
                                                                      options=options)
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(L.indptr))
    upper = L.indices > rows
    edges = np.column_stack([rows[upper], L.indices[upper].astype(np.int64)])
    transmissibility = L.data[upper]
    edge_length = np.linalg.norm(V[edges[:, 1]] - V[edges[:, 0]], axis=1)
    topology = _Faces(T, n)
    topology.refuse_nonmanifold()
    first, second = topology.records[:, 0], topology.records[:, 1]
    t, corner = first // 4, first % 4
    heights, areas = heights.reshape(-1), areas.reshape(-1)
    dual_length = heights[first] + np.where(second >= 0, heights[np.maximum(second, 0)], 0.0)
    g = DualGeometry(
        edges=edges,
        edge_length=edge_length,
        dual_area=transmissibility * edge_length,
        transmissibility=transmissibility,
        control_volume=M[1],  # ("lumped", diagonal): the circumcentric mass is diagonal
        centres=points[:, 0],
        barycentric=barycentric,
        outside=(barycentric < -OUTSIDE_TOL).any(axis=1),
        volume=np.abs(volumes),
        orientation=np.sign(volumes).astype(np.int8),
        faces=topology.faces,
        face_tets=np.where(topology.records >= 0, topology.records // 4, -1),
        tet_faces=topology.tet_faces,
        face_area=areas[first],
        face_centres=points[t, 1 + corner],
        dual_length=dual_length,
    )
    object.__setattr__(g, "_mesh", (V.copy(), T.copy(), None if w is None else w.copy()))
    return g


class _Faces:
    """The unique faces of tets ``T`` (validated (m, 4) int64).

    ``faces`` (F, 3) sorted vertex triples in lexicographic order; ``tet_faces`` (m, 4) the
    face opposite each corner; ``records`` (F, 2) the first two of the face's records
    ``4 t + l`` (tet ``t``, corner ``l`` opposite), ascending, ``-1`` for a face of one
    tet; ``counts`` (F,) how many tets share the face."""

    def __init__(self, T: np.ndarray, n: int) -> None:
        # the sorted triples (smallest, middle, largest) of the 4 m records, row 4 t + l
        x, y, z = (T[:, _FACES[:, k]].reshape(-1) for k in range(3))
        low, high = np.minimum(np.minimum(x, y), z), np.maximum(np.maximum(x, y), z)
        F = np.column_stack([low, x + y + z - low - high, high])
        # a stable sort (records ascend within a face) by one integer key while n^3 fits
        # in int64, else by two
        head = F[:, 0] * n + F[:, 1]
        order = (np.argsort(head * n + F[:, 2], kind="stable") if n < 2**21
                 else np.lexsort((F[:, 2], head)))
        S = F[order]
        new = np.ones(len(S), dtype=bool)
        new[1:] = (S[1:] != S[:-1]).any(axis=1)
        self.faces = S[new]
        self.tet_faces = np.empty(len(F), dtype=np.int64)
        self.tet_faces[order] = np.cumsum(new) - 1
        self.tet_faces = self.tet_faces.reshape(-1, 4)
        start = np.flatnonzero(new)
        self.counts = np.diff(np.append(start, len(S)))
        self.records = np.column_stack([
            order[start],
            np.where(self.counts >= 2, order[np.minimum(start + 1, len(S) - 1)], -1)])
        self._order, self._start = order, start

    def refuse_nonmanifold(self) -> None:
        """DegenerateElementError for the first face shared by more than two tets."""
        bad = np.flatnonzero(self.counts > 2)
        if len(bad):
            f = int(bad[0])
            tets = (self._order[self._start[f]:self._start[f] + self.counts[f]] // 4).tolist()
            raise DegenerateElementError(
                f"face {tuple(self.faces[f].tolist())} is shared by {len(tets)} tets {tets}: a "
                "non-manifold face has no dual edge", element=tets[0])
