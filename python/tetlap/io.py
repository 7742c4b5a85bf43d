"""Mesh files and mesh objects in, meshio and pyvista objects out.

Reading: :func:`read` takes a file in any format meshio reads (``.msh``, ``.mesh``,
``.vtu``, ``.vtk``, TetGen ``.ele``, ...) or a mesh object; :func:`from_mesh` takes a
``meshio.Mesh``, a ``pyvista.UnstructuredGrid`` (or any pyvista dataset) or any object with
``points`` and cells. Both return ``(V, T)``: the linear tets if there are any, else the
triangles. Writing: :func:`write` (a file), :func:`to_meshio`, :func:`to_pyvista` and
:func:`edges_to_pyvista` (e.g. the negative-weight edges) for plotting; :func:`dual_cells`
(the Voronoi / power cells as VTK polyhedra).

Needs the optional dependencies ``meshio`` (``pip install ".[io]"``) for files and
``pyvista`` (``pip install ".[pyvista]"``) for :func:`to_pyvista`.

Examples
--------
>>> import meshio, tetlap, tetlap.io
>>> V, T = tetlap.meshes.cube(2)
>>> V2, T2 = tetlap.io.from_mesh(meshio.Mesh(V, [("tetra", T)]))
>>> bool((V2 == V).all() and (T2 == T).all())
True
>>> V, T = tetlap.io.read("part.msh")  # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import importlib
import io as _stdio
import mmap
import os
import re
import sys

import numpy as np

from . import _arrays, _extras
from ._meshobj import is_mesh_object, to_arrays
from .errors import MeshFileError, ShapeError

__all__ = ["read", "from_mesh", "write", "to_meshio", "to_pyvista", "edges_to_pyvista",
           "dual_cells"]


def _optional(module: str, extra: str, what: str):
    """The optional ``module``, or an ImportError naming the extra that installs it."""
    try:
        return importlib.import_module(module)
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError(f"{what} need {module}: {_extras.hint(extra)}") from None


def _meshio():
    return _optional("meshio", "io", "mesh files")


def _pyvista():
    return _optional("pyvista", "pyvista", "pyvista grids")


def from_mesh(obj, cell_type=None):
    """The vertices and linear tets (or triangles) of a mesh object.

    Parameters
    ----------
    obj : meshio.Mesh, pyvista dataset, or any object with ``points`` and cells
        ``cells`` may be a list of meshio ``CellBlock`` s or ``(type, data)`` pairs, or a
        dict (also as ``cells_dict``) from a meshio type name (``"tetra"``) or a VTK cell
        type id (10) to an ``(m, k)`` integer array; pyvista grids are read through their
        ``celltypes`` and connectivity arrays. Any pyvista dataset (``PolyData``, ...) is
        cast to an ``UnstructuredGrid`` first.
    cell_type : None, "tetra" or "triangle"
        None (default): the tets if there are any, else the triangles.

    Returns
    -------
    V : (n, d) float64 ndarray
        All points of the object, a copy (unreferenced points are kept, so indices never
        shift; tetlap's operators give them empty rows and zero mass).
    T : (m, 4) or (m, 3) int64 ndarray
        The cells in the object's order and orientation (tetlap does not depend on it).

    Raises
    ------
    ShapeError
        Other cells of the kept dimension (hexahedra, wedges or quadratic tets next to tets;
        quads or polygons next to triangles), or no tets or triangles at all (e.g. only
        hexahedra or lines). It is the class ``tetlap.laplacian(V, hexes)`` raises for an
        ``(m, 8)`` array: the cells have the wrong number of vertices.
    DtypeError
        Cell data that is not integer.
    EmptyMeshError
        No cells.
    TypeError
        Not a mesh object.

    Warns
    -----
    UserWarning
        Naming the lower-dimensional cells that were dropped (e.g. the boundary triangles
        and lines a ``.msh`` file stores next to its tets).

    Examples
    --------
    >>> import meshio, tetlap, tetlap.io
    >>> V, T = tetlap.meshes.cube(2)
    >>> mesh = meshio.Mesh(V, [("tetra", T)])
    >>> V2, T2 = tetlap.io.from_mesh(mesh)
    >>> V2.shape, T2.shape, T2.dtype.name
    ((27, 3), (48, 4), 'int64')
    >>> L = tetlap.laplacian(*tetlap.io.from_mesh(mesh), kind="dual")

    A pyvista grid goes the same way (see :func:`to_pyvista`).
    """
    return to_arrays(obj, cell_type, stacklevel=2)


#: The keywords of the formats whose headers declare counts of records (the one or two
#: numbers right after a keyword: ``$Nodes`` / ``n``, ``CELLS n size``); TetGen's counts
#: open the file. Every record of these formats takes at least two bytes per count (a
#: digit and a separator, or a binary number), so a count above half the file's size is a
#: broken header: refused before meshio allocates it (a binary ``.msh`` that declares 2e8
#: vertices made meshio build a 2e8-element array for 40 s).
_COUNT_KEYWORDS = {
    ".msh": (b"$Nodes", b"$Elements"),
    ".mesh": (b"Vertices", b"Triangles", b"Tetrahedra"),
    ".vtk": (b"POINTS", b"CELLS", b"CELL_TYPES"),
    ".node": (b"",), ".ele": (b"",),
}
_COUNTS = re.compile(rb"\s*(\d+)(?:[ \t]+(\d+))?")


def _check_declared_counts(path: str) -> None:
    """MeshFileError if a count declared by ``path``'s header cannot fit in the file (and
    for TetGen, in the ``.node`` / ``.ele`` file beside it)."""
    stem, suffix = os.path.splitext(path)
    paths = [path] + ([stem + ".node"] if suffix == ".ele" else [])
    for p in paths:
        keywords = _COUNT_KEYWORDS.get(os.path.splitext(p)[1].lower(), ())
        if not keywords or not os.path.isfile(p) or not os.path.getsize(p):
            continue
        with open(p, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
            size = len(m)
            for keyword in keywords:
                at = m.find(keyword) if keyword else 0
                found = _COUNTS.match(m[at + len(keyword):at + len(keyword) + 256]) if at >= 0 else None
                for count in (int(c) for c in (found.groups() if found else ()) if c):
                    if 2 * count > size:
                        what = keyword.decode() or "its first line"
                        raise MeshFileError(
                            f"{p}: its header declares {count} records ({what}), more than "
                            f"its {size} bytes can hold: a broken or truncated file")


def read(path, cell_type=None):
    """Read the vertices and linear tets (or triangles) of a mesh file with meshio.

    Parameters
    ----------
    path : str, os.PathLike, or a mesh object
        A file in any format meshio reads; TetGen pairs: pass the ``.ele`` path (meshio
        reads the ``.node`` beside it). A mesh object (``meshio.Mesh``, pyvista grid, ...)
        is passed to :func:`from_mesh`.
    cell_type : None, "tetra" or "triangle"
        None (default): the tets if there are any, else the triangles.

    Returns
    -------
    V : (n, d) float64 ndarray
        All points of the file (unreferenced vertices are kept, so indices never shift;
        tetlap's operators give them empty rows and zero mass).
    T : (m, 4) or (m, 3) int64 ndarray
        The file's cells and orientation (tetlap does not depend on it).

    Raises
    ------
    FileNotFoundError
        No such file.
    MeshFileError
        meshio cannot read the file (unknown format, malformed content, or counts in its
        header larger than its content or than memory, which meshio would allocate).
        meshio's own ``sys.exit`` on some malformed files is caught: it never ends the
        program.
    ShapeError, EmptyMeshError
        The file holds no usable cells; see :func:`from_mesh`.

    Warns
    -----
    UserWarning
        Naming the lower-dimensional cells that were dropped.

    Notes
    -----
    meshio prints to stdout while reading some formats (a blank line for ``.msh``). That
    output is captured, so a caller's own stdout (e.g. JSON) stays clean; non-blank text is
    passed on to stderr. The capture swaps ``sys.stdout`` / ``sys.stderr`` for the duration
    of the call.

    Examples
    --------
    >>> import tetlap.io
    >>> V, T = tetlap.io.read("part.msh")  # doctest: +SKIP
    >>> V, T = tetlap.io.read("deer.ele")  # TetGen .node/.ele  # doctest: +SKIP
    """
    if not isinstance(path, (str, bytes, os.PathLike)):
        if is_mesh_object(path):
            return to_arrays(path, cell_type, stacklevel=2)
        raise TypeError(f"read takes a file path or a mesh object, got {type(path).__name__}")
    meshio = _meshio()
    path = os.fsdecode(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no such mesh file: {path}")
    _check_declared_counts(path)
    out, err = _stdio.StringIO(), _stdio.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            mesh = meshio.read(path)
    except KeyboardInterrupt:
        raise
    except BaseException as e:  # ReadError, KeyError, ValueError, ... and SystemExit
        said = " ".join(out.getvalue().split())
        if isinstance(e, SystemExit):
            reason = said or "meshio gave up on it"
        else:
            reason = f"{type(e).__name__}: {e}" + (f"; {said}" if said else "")
        if isinstance(e, (MemoryError, OverflowError)):  # a header's count of 10^12 vertices
            reason = (f"it declares more data than fits in memory, in a file of "
                      f"{os.path.getsize(path)} bytes: {reason}")
        raise MeshFileError(f"{path}: meshio could not read it ({reason})") from None
    printed = (out.getvalue() + err.getvalue()).strip()
    if printed:
        print(printed, file=sys.stderr)
    return to_arrays(mesh, cell_type, source=path, stacklevel=2)


def _points3d(V: np.ndarray) -> np.ndarray:
    if V.shape[1] == 2:
        return np.column_stack([V, np.zeros(len(V))])
    if V.shape[1] != 3:
        raise ShapeError(f"pyvista needs 2-D or 3-D points, V has shape {V.shape}; project "
                         "an immersed mesh to 3-D first")
    return V


def _checked(V, T, point_data, cell_data):
    """Validated copies: ``V`` (n, d) float64, ``T`` (m, 3|4) int64 with indices in range,
    and the data arrays with one row per vertex / per cell."""
    V = np.array(_arrays.points(V), copy=True)
    T = np.array(_arrays.elements(T), copy=True)
    n, m = len(V), len(T)
    _arrays.in_range(T, n, "element")
    data = []
    for what, rows, given in (("point_data", n, point_data), ("cell_data", m, cell_data)):
        arrays = {}
        for name, values in (given or {}).items():
            a = np.array(values, copy=True)
            if a.ndim == 0 or len(a) != rows:
                unit = "vertices" if what == "point_data" else "cells"
                raise ShapeError(f"{what}[{name!r}] has shape {a.shape}, the mesh {rows} {unit}")
            arrays[str(name)] = a
        data.append(arrays)
    return V, T, data[0], data[1]


def to_meshio(V, T, point_data=None, cell_data=None):
    """A ``meshio.Mesh`` of the tets (or triangles) with per-vertex / per-cell arrays.

    Parameters
    ----------
    V : (n, d) array-like of float
    T : (m, 4) or (m, 3) array-like of int
        Tets or triangles. A float ``T`` is refused (:class:`tetlap.DtypeError`), never
        truncated.
    point_data : dict of name -> (n,) or (n, k) array-like, optional
    cell_data : dict of name -> (m,) or (m, k) array-like, optional

    Returns
    -------
    meshio.Mesh
        One cell block (``"tetra"`` or ``"triangle"``); every array is a copy.

    Raises
    ------
    ShapeError, DtypeError, IndexRangeError
        Bad ``V`` / ``T``, or data with the wrong number of rows.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.cube(2)
    >>> M = tetlap.mass(V, T, "circumcentric")
    >>> mesh = tetlap.io.to_meshio(V, T, point_data={"dual_mass": M.diagonal()})
    >>> mesh.cells[0].type, mesh.point_data["dual_mass"].shape
    ('tetra', (27,))
    """
    meshio = _meshio()
    V, T, points, cells = _checked(V, T, point_data, cell_data)
    kind = "tetra" if T.shape[1] == 4 else "triangle"
    return meshio.Mesh(V, [(kind, T)], point_data=points,
                       cell_data={name: [a] for name, a in cells.items()})


def write(path, V, T, *, cell_data=None, point_data=None) -> None:
    """Write a tet (or triangle) mesh with optional per-cell / per-vertex arrays.

    The format follows the file extension (``.vtu`` recommended, for ParaView etc.).

    Parameters
    ----------
    path : str or os.PathLike
    V : (n, d) array-like of float
    T : (m, 4) or (m, 3) array-like of int
        A float ``T`` is refused (:class:`tetlap.DtypeError`), never truncated.
    cell_data : dict of name -> (m,) or (m, k) array-like, optional
        E.g. the minimum edge weight per tet, or a non-Delaunay flag (the paper's Fig. 7).
    point_data : dict of name -> (n,) or (n, k) array-like, optional
        E.g. the dual (circumcentric) masses.

    Raises
    ------
    ShapeError, DtypeError, IndexRangeError
        Bad ``V`` / ``T``, or data with the wrong number of rows.
    MeshFileError
        meshio cannot write that format.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.ball(1000)
    >>> W = tetlap.element_contributions(V, T, "dual")
    >>> tetlap.io.write("ball.vtu", V, T, cell_data={"min_weight": W.min(axis=1)})  # doctest: +SKIP
    """
    mesh = to_meshio(V, T, point_data=point_data, cell_data=cell_data)
    path = os.fspath(path)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            mesh.write(path)
    except (KeyboardInterrupt, MemoryError):
        raise
    except OSError:
        raise
    except BaseException as e:
        raise MeshFileError(f"{path}: meshio could not write it ({type(e).__name__}: {e})"
                            ) from None


def to_pyvista(V, T, point_data=None, cell_data=None):
    """A ``pyvista.UnstructuredGrid`` of the tets (or triangles), for plotting.

    Parameters
    ----------
    V : (n, 2) or (n, 3) array-like of float
        2-D points get a zero z coordinate. (Immersed meshes, d > 3, need a projection
        first: pyvista is 3-D.)
    T : (m, 4) or (m, 3) array-like of int
        Tets (``CellType.TETRA``) or triangles (``CellType.TRIANGLE``).
    point_data : dict of name -> (n,) or (n, k) array-like, optional
        E.g. the dual masses ``tetlap.mass(V, T, "circumcentric").diagonal()``.
    cell_data : dict of name -> (m,) or (m, k) array-like, optional
        E.g. the minimum dual edge weight per tet.

    Returns
    -------
    pyvista.UnstructuredGrid
        Every array is a copy: changing the grid never changes ``V``, ``T`` or the data.

    Raises
    ------
    ShapeError, DtypeError, IndexRangeError
        Bad ``V`` / ``T``, ``d > 3``, or data with the wrong number of rows.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    >>> masses = tetlap.mass(V, T, "circumcentric").diagonal()
    >>> grid = tetlap.io.to_pyvista(V, T, point_data={"dual_mass": masses})
    >>> grid.n_cells == len(T), bool(abs(grid["dual_mass"].sum() - 1.0) < 1e-12)
    (True, True)
    >>> grid.plot(scalars="dual_mass")  # doctest: +SKIP

    And back, as any mesh object (:func:`from_mesh`):

    >>> V2, T2 = tetlap.io.from_mesh(grid)
    >>> bool((V2 == V).all() and (T2 == T).all())
    True
    """
    pv = _pyvista()
    V, T, points, cells = _checked(V, T, point_data, cell_data)
    V = _points3d(V)
    kind = pv.CellType.TETRA if T.shape[1] == 4 else pv.CellType.TRIANGLE
    grid = pv.UnstructuredGrid({kind: T}, V)
    for name, a in points.items():
        grid.point_data[name] = a
    for name, a in cells.items():
        grid.cell_data[name] = a
    return grid


def edges_to_pyvista(V, edges, values=None, name="value"):
    """A ``pyvista.PolyData`` of line cells, one per edge, e.g. the negative-weight edges.

    Parameters
    ----------
    V : (n, 2) or (n, 3) array-like of float
    edges : (E, 2) array-like of int
        As :func:`tetlap.edge_weights` returns them.
    values : (E,) or (E, k) array-like, optional
        Stored as cell data under ``name`` (e.g. the weights, to colour the lines).
    name : str

    Returns
    -------
    pyvista.PolyData
        All of ``V`` as points and ``E`` line cells; arrays are copies.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.ball(300, seed=0)
    >>> edges, w = tetlap.edge_weights(V, T, "dual")
    >>> negative = w < 0
    >>> lines = tetlap.io.edges_to_pyvista(V, edges[negative], w[negative], name="weight")
    >>> lines.n_cells == int(negative.sum()), bool((lines["weight"] < 0).all())
    (True, True)
    >>> import pyvista as pv  # doctest: +SKIP
    >>> p = pv.Plotter(); p.add_mesh(tetlap.io.to_pyvista(V, T), opacity=0.1)  # doctest: +SKIP
    >>> p.add_mesh(lines, scalars="weight", line_width=3); p.show()  # doctest: +SKIP
    """
    pv = _pyvista()
    V = _points3d(np.array(_arrays.points(V), copy=True))
    E = _arrays.edges(edges, len(V))
    poly = pv.PolyData(V, lines=np.column_stack([np.full(len(E), 2), E]).ravel())
    if values is not None:
        a = np.array(values, copy=True)
        if a.ndim == 0 or len(a) != len(E):
            raise ShapeError(f"values has shape {a.shape}, but there are {len(E)} edges")
        poly.cell_data[name] = a
    return poly


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
    from ._dual_cells import surfaces

    meshio = _meshio()
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
