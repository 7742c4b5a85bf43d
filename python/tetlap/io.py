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
from collections.abc import Mapping

import numpy as np

from . import _arrays, _extras
from ._meshobj import is_mesh_object, to_arrays
from .errors import DtypeError, MeshFileError, OptionError, ShapeError

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
#: open the file (:func:`_tetgen_header`). Every record of these formats takes at least two
#: bytes per count (a digit and a separator, or a binary number), so a count above half the
#: file's size is a broken header: refused before meshio allocates it (a binary ``.msh``
#: that declares 2e8 vertices made meshio build a 2e8-element array for 40 s).
_COUNT_KEYWORDS = {
    ".msh": (b"$Nodes", b"$Elements"),
    ".mesh": (b"Vertices", b"Triangles", b"Tetrahedra"),
    ".vtk": (b"POINTS", b"CELLS", b"CELL_TYPES"),
}
_COUNTS = re.compile(rb"\s*(\d+)(?:[ \t]+(\d+))?")

#: The header line of each TetGen file: its numbers, their meaning.
_TETGEN_HEADERS = {
    ".node": "4 numbers: points, dimension, attributes, boundary markers",
    ".ele": "3 numbers: tets, nodes per tet, attributes",
}

#: The sections of a gmsh file that must be closed: meshio reads a file that ends inside
#: ``$Elements`` (and takes the last numbers of a cut last line as a cell's vertices).
_GMSH_SECTIONS = ((b"$Nodes", b"$EndNodes"), (b"$Elements", b"$EndElements"))

#: Legacy VTK's declared counts of points and cells, checked against what meshio read: it
#: reads a file cut inside ``CELL_TYPES`` as a mesh of the cells whose types it got.
_VTK_POINTS = re.compile(rb"^[ \t]*POINTS[ \t]+(\d+)", re.M)
_VTK_CELL_TYPES = re.compile(rb"^[ \t]*CELL_TYPES[ \t]+(\d+)", re.M)


def _broken(p: str, what: str) -> MeshFileError:
    return MeshFileError(f"{p}: {what}: a broken or truncated file")


def _tetgen_header(p: str) -> list[int]:
    """The numbers of the TetGen file ``p``'s header, its first line that is neither blank
    nor a comment; MeshFileError when there is none or it does not hold the numbers (meshio
    would look for it past the end of the file forever)."""
    expected = _TETGEN_HEADERS[os.path.splitext(p)[1].lower()]
    with open(p, "rb") as f:
        for line in f:
            words = line.split(b"#", 1)[0].split()
            if words:
                break
        else:
            raise _broken(p, f"no header line (TetGen's first line holds {expected})")
    if len(words) != int(expected[0]) or not all(w.isdigit() for w in words):
        shown = " ".join(w.decode(errors="replace") for w in words)[:80]
        raise _broken(p, f"its header line is {shown!r}, TetGen's holds {expected}")
    return [int(w) for w in words]


def _check_declared_counts(path: str) -> None:
    """MeshFileError if a count declared by ``path``'s header cannot fit in the file (and
    for TetGen, in the ``.node`` / ``.ele`` file beside it), if a TetGen file has no
    header, or if a gmsh section is not closed."""
    stem, suffix = os.path.splitext(path)
    suffix = suffix.lower()
    paths = [stem + ".node", stem + ".ele"] if suffix in _TETGEN_HEADERS else [path]
    for p in paths:
        if not os.path.isfile(p):
            continue  # meshio reports it
        size = os.path.getsize(p)
        if suffix in _TETGEN_HEADERS:
            count = _tetgen_header(p)[0]
            if 2 * count > size:
                raise _broken(p, f"its header declares {count} records (its first line), "
                                 f"more than its {size} bytes can hold")
            continue
        keywords = _COUNT_KEYWORDS.get(suffix, ())
        if not keywords or not size:
            continue
        with open(p, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
            for keyword in keywords:
                at = m.find(keyword) + len(keyword)
                found = _COUNTS.match(m[at:at + 256]) if at >= len(keyword) else None
                for count in (int(c) for c in (found.groups() if found else ()) if c):
                    if 2 * count > size:
                        raise _broken(p, f"its header declares {count} records ("
                                         f"{keyword.decode()}), more than its {size} bytes "
                                         "can hold")
            if suffix == ".msh":
                for start, end in _GMSH_SECTIONS:
                    if m.find(start) >= 0 and m.find(end) < 0:
                        raise _broken(p, f"its {start.decode()} section is not closed by "
                                         f"{end.decode()}")


def _check_read_counts(path: str, mesh) -> None:
    """MeshFileError if meshio read fewer points or cells from a legacy VTK file than its
    header declares."""
    if os.path.splitext(path)[1].lower() != ".vtk":
        return
    read = {"POINTS": len(mesh.points), "CELL_TYPES": sum(len(c.data) for c in mesh.cells)}
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
        for keyword, pattern in (("POINTS", _VTK_POINTS), ("CELL_TYPES", _VTK_CELL_TYPES)):
            found = pattern.search(m)
            if found and int(found.group(1)) != read[keyword]:
                raise _broken(path, f"its header declares {int(found.group(1))} records "
                                    f"({keyword}), meshio read {read[keyword]}")


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
        header larger than its content or than memory, which meshio would allocate), or
        the file is cut short: a TetGen ``.node`` / ``.ele`` without its header line, a
        gmsh section not closed, a legacy VTK file with fewer points or cells than its
        header declares.
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
    _check_read_counts(path, mesh)
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
    and the data arrays (numeric, one row per vertex / per cell)."""
    V = np.array(_arrays.points(V), copy=True)
    T = np.array(_arrays.elements(T), copy=True)
    n, m = len(V), len(T)
    _arrays.in_range(T, n, "element")
    data = []
    for what, rows, given in (("point_data", n, point_data), ("cell_data", m, cell_data)):
        if given is not None and not isinstance(given, Mapping):
            raise OptionError(f"{what} must be a dict of name -> array, got "
                              f"{type(given).__name__}")
        arrays = {}
        for name, values in (given or {}).items():
            try:
                a = np.array(values, copy=True)
            except ValueError as e:  # ragged nested lists
                raise ShapeError(f"{what}[{name!r}] is not an array ({e})") from None
            if a.dtype.kind not in "biuf":
                raise DtypeError(f"{what}[{name!r}] has dtype {a.dtype}, not bool, integer "
                                 "or real numbers")
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
        Bad ``V`` / ``T``, or data with the wrong number of rows or not numeric.
    OptionError
        ``point_data`` or ``cell_data`` not a dict.

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


#: meshio's formats of points, lines and polygons only: their writers drop tets (printing
#: a warning) and write a file without them.
_SURFACE_FORMATS = frozenset({"obj", "off", "ply", "stl", "svg", "wkt"})


def _check_holds_tets(meshio, path: str, T: np.ndarray) -> None:
    """MeshFileError if ``T`` holds tets and ``path``'s extension names a surface format
    (the one rule :func:`write` and the commands' output checks follow)."""
    name = os.path.basename(path).lower()
    ext = max((e for e in meshio.extension_to_filetypes if name.endswith(e)), key=len,
              default=None)
    formats = meshio.extension_to_filetypes.get(ext, ())
    if T.shape[1] == 4 and formats and set(formats) <= _SURFACE_FORMATS:
        raise MeshFileError(
            f"{path}: not a mesh format that holds tets ({ext} is meshio's "
            f"{'/'.join(formats)}, a surface format); write .vtu, .vtk, .msh, .mesh, .ele "
            "or another volume format of meshio")


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
        E.g. the dual (circumcentric) masses. Data values are bool, integer or real
        numbers, written as given (NaN and inf too: they are the caller's values).

    Raises
    ------
    ShapeError, DtypeError, IndexRangeError
        Bad ``V`` / ``T``, or data with the wrong number of rows or not numeric.
    OptionError
        ``point_data`` or ``cell_data`` not a dict.
    MeshFileError
        meshio cannot write that format, or it is a surface format (``.stl``, ``.off``,
        ``.ply``, ``.obj``, ...) and ``T`` holds tets, which meshio would drop: refused
        before anything is written.

    Examples
    --------
    >>> import tetlap, tetlap.io
    >>> V, T = tetlap.meshes.ball(1000)
    >>> W = tetlap.element_contributions(V, T, "dual")
    >>> tetlap.io.write("ball.vtu", V, T, cell_data={"min_weight": W.min(axis=1)})  # doctest: +SKIP
    """
    mesh = to_meshio(V, T, point_data=point_data, cell_data=cell_data)
    path = os.fsdecode(path)
    _check_holds_tets(_meshio(), path, mesh.cells[0].data)
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
        Bad ``V`` / ``T``, ``d > 3``, or data with the wrong number of rows or not numeric.
    OptionError
        ``point_data`` or ``cell_data`` not a dict.

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
