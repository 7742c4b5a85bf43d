"""Reading: mesh files (through meshio) and mesh objects to ``(V, T)`` arrays, with the
checks that keep a broken file from becoming a smaller mesh or a hang."""

from __future__ import annotations

import contextlib
import io as _stdio
import mmap
import os
import re
import sys

import meshio

from .._meshobj import check_options, is_mesh_object, to_arrays
from ..errors import MeshFileError


def from_mesh(obj, cell_type=None, *, cell_data=False):
    """The vertices and linear tets (or triangles) of a mesh object, and with
    ``cell_data=True`` the object's per-cell arrays for those tets.

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
    cell_data : bool, default False
        Also return the object's cell data (meshio's ``cell_data``, one array per block;
        pyvista's ``cell_data``, one array per cell; ``cell_data_dict`` beside cells given
        as a dict by type).

    Returns
    -------
    V : (n, d) float64 ndarray
        All points of the object, a copy (unreferenced points are kept, so indices never
        shift; tetlap's operators give them empty rows and zero mass).
    T : (m, 4) or (m, 3) int64 ndarray
        The cells in the object's order and orientation (tetlap does not depend on it).
    data : dict of str -> (m, ...) ndarray, only with ``cell_data=True``
        Every cell-data array of the object, a copy with its dtype, cut to the kept cells:
        row ``i`` belongs to ``T[i]`` (blocks of several tet blocks are joined in the
        object's order, as ``T``'s rows are). The arrays of dropped (lower-dimensional)
        cells are dropped with them. Values come back as stored, never reinterpreted: a
        tensor per tet that a file holds as 9 components is ``(m, 9)``, row-major, so
        ``data[name].reshape(-1, 3, 3)`` gives the ``(m, 3, 3)`` tensors; a ``(m, 3, 3)``
        array of a mesh object stays ``(m, 3, 3)``.

    Raises
    ------
    ShapeError
        Other cells of the kept dimension (hexahedra, wedges or quadratic tets next to tets;
        quads or polygons next to triangles), or no tets or triangles at all (e.g. only
        hexahedra or lines). It is the class ``tetlap.laplacian(V, hexes)`` raises for an
        ``(m, 8)`` array: the cells have the wrong number of vertices. With
        ``cell_data=True``, a cell-data array without one row per cell of a kept block.
    DtypeError
        Cells whose vertex indices are not integers.
    OptionError
        ``cell_type`` or ``cell_data`` not one of the values above.
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
    >>> import meshio, numpy as np, tetlap, tetlap.io
    >>> V, T = tetlap.meshes.cube(2)
    >>> mesh = meshio.Mesh(V, [("tetra", T)])
    >>> V2, T2 = tetlap.io.from_mesh(mesh)
    >>> V2.shape, T2.shape, T2.dtype.name
    ((27, 3), (48, 4), 'int64')
    >>> L = tetlap.laplacian(*tetlap.io.from_mesh(mesh), kind="dual")

    Region tags and tensors come with ``cell_data=True``, one row per tet:

    >>> K = np.broadcast_to(np.diag([1.0, 2.0, 3.0]).ravel(), (len(T), 9))
    >>> tagged = meshio.Mesh(V, [("tetra", T)], cell_data={"region": [np.arange(48) % 2],
    ...                                                    "K": [K]})
    >>> V2, T2, data = tetlap.io.from_mesh(tagged, cell_data=True)
    >>> data["region"][:4].tolist(), data["K"].shape, data["K"].reshape(-1, 3, 3).shape
    ([0, 1, 0, 1], (48, 9), (48, 3, 3))

    A pyvista grid goes the same way (see :func:`to_pyvista`).
    """
    return to_arrays(obj, cell_type, cell_data=cell_data, stacklevel=2)


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


def read(path, cell_type=None, *, cell_data=False):
    """Read the vertices and linear tets (or triangles) of a mesh file with meshio, and
    with ``cell_data=True`` the file's per-cell arrays for those tets.

    Parameters
    ----------
    path : str, os.PathLike, or a mesh object
        A file in any format meshio reads; TetGen pairs: pass the ``.ele`` path (meshio
        reads the ``.node`` beside it). A mesh object (``meshio.Mesh``, pyvista grid, ...)
        is passed to :func:`from_mesh`.
    cell_type : None, "tetra" or "triangle"
        None (default): the tets if there are any, else the triangles.
    cell_data : bool, default False
        Also return the file's cell data: region tags (gmsh's ``"gmsh:physical"`` and
        ``"gmsh:geometrical"``, Medit's ``"medit:ref"``, a ``.vtu``'s named arrays) and
        per-tet fields such as conductivity tensors.

    Returns
    -------
    V : (n, d) float64 ndarray
        All points of the file (unreferenced vertices are kept, so indices never shift;
        tetlap's operators give them empty rows and zero mass).
    T : (m, 4) or (m, 3) int64 ndarray
        The file's cells in the order read, and their orientation (tetlap does not depend
        on it).
    data : dict of str -> (m, ...) ndarray, only with ``cell_data=True``
        Every cell-data array meshio read, under meshio's name, with its dtype: row ``i``
        belongs to ``T[i]`` (see :func:`from_mesh`). A tensor per tet stored as 9
        components (a ``.vtu`` array, gmsh ``$ElementData``) comes back as ``(m, 9)``,
        row-major: ``data[name].reshape(-1, 3, 3)`` gives ``(m, 3, 3)``. The data of the
        dropped lower-dimensional cells (a ``.msh`` file's boundary triangles) is not
        returned.

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
        The file holds no usable cells, or (``cell_data=True``) a cell-data array without a
        row per cell; see :func:`from_mesh`.
    OptionError
        ``cell_type`` or ``cell_data`` not one of the values above.

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
    >>> V, T, data = tetlap.io.read("head.msh", cell_data=True)  # doctest: +SKIP
    >>> regions = data["gmsh:physical"]          # (m,) int, one tag per tet  # doctest: +SKIP
    """
    check_options(cell_type, cell_data)
    if not isinstance(path, (str, bytes, os.PathLike)):
        if is_mesh_object(path):
            return to_arrays(path, cell_type, cell_data=cell_data, stacklevel=2)
        raise TypeError(f"read takes a file path or a mesh object, got {type(path).__name__}")
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
    return to_arrays(mesh, cell_type, cell_data=cell_data, source=path, stacklevel=2)

