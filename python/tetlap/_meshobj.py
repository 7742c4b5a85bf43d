"""Mesh objects (meshio, pyvista, look-alikes) to ``(V, T)`` arrays, without importing
either library unless the object needs it.

An object is read as a list of cell blocks ``(name, dimension, data, count, where)`` in
meshio's vocabulary (``"tetra"``, ``"triangle"``, ``"hexahedron"``, ...; VTK cell type ids
are translated to those names; ``where`` finds the block's rows of the object's cell data).
Then one rule picks the cells: the linear tets if there are any, else the triangles; cells
of a lower dimension are dropped with a ``UserWarning``; other
cells of the kept dimension (hexahedra next to tets, quads next to triangles, quadratic
tets) are a :class:`tetlap.ShapeError` — the same class as passing an ``(m, 8)`` array as
``T`` — because dropping them would leave holes in the mesh.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from . import _options
from .errors import DtypeError, EmptyMeshError, OptionError, ShapeError

# VTK cell type ids (vtkCellType.h) of the common cells, named as meshio names them.
_VTK_NAMES = {
    1: "vertex", 2: "poly_vertex", 3: "line", 4: "poly_line", 5: "triangle",
    6: "triangle_strip", 7: "polygon", 8: "pixel", 9: "quad", 10: "tetra", 11: "voxel",
    12: "hexahedron", 13: "wedge", 14: "pyramid", 15: "pentagonal_prism",
    16: "hexagonal_prism", 21: "line3", 22: "triangle6", 23: "quad8", 24: "tetra10",
    25: "hexahedron20", 26: "wedge15", 27: "pyramid13", 28: "quad9", 29: "hexahedron27",
    42: "polyhedron",
}
_VTK_IDS = {"tetra": 10, "triangle": 5}

# Topological dimension by the start of a cell name (meshio names "polyhedron8" etc.).
_DIMENSION_PREFIXES = (
    ("vertex", 0), ("poly_vertex", 0),
    ("line", 1), ("poly_line", 1),
    ("triangle", 2), ("quad", 2), ("polygon", 2), ("pixel", 2),
    ("tetra", 3), ("hexahedron", 3), ("wedge", 3), ("pyramid", 3), ("polyhedron", 3),
    ("voxel", 3), ("pentagonal_prism", 3), ("hexagonal_prism", 3),
)
_CORNERS = {"tetra": 4, "triangle": 3}
_WANTED = {None: None, "tetra": "tetra", "tet": "tetra", "tetrahedron": "tetra",
           "triangle": "triangle", "tri": "triangle"}


def _dimension(name: str) -> int | None:
    for prefix, dim in _DIMENSION_PREFIXES:
        if name.startswith(prefix):
            return dim
    return None


def _vtk_name(type_id: int) -> tuple[str, int | None]:
    """meshio-style name and dimension of a VTK cell type id."""
    if type_id in _VTK_NAMES:
        name = _VTK_NAMES[type_id]
        return name, _dimension(name)
    try:  # anything rarer: ask pyvista, which knows every VTK type
        import pyvista

        cell_type = pyvista.CellType(type_id)
        return cell_type.name.lower(), getattr(cell_type, "dimension", None)
    except Exception:
        return f"VTK cell type {type_id}", None


def is_mesh_object(obj) -> bool:
    """True for objects :func:`to_arrays` understands: anything with ``points`` and cells
    (``celltypes``, ``cells_dict`` or ``cells``), and pyvista datasets."""
    if isinstance(obj, (str, bytes, np.ndarray, list, tuple, dict)):
        return False
    if hasattr(obj, "cast_to_unstructured_grid"):  # any pyvista dataset
        return True
    return hasattr(obj, "points") and any(
        hasattr(obj, a) for a in ("celltypes", "cells_dict", "cells"))


def _describe(obj) -> str:
    cls = type(obj)
    return f"{cls.__module__.split('.')[0]}.{cls.__name__}"


def _vtk_blocks(obj, wanted_names):
    """Blocks of a pyvista ``UnstructuredGrid`` (or anything with ``celltypes`` and VTK
    connectivity), in the grid's cell order within each type."""
    types = np.asarray(obj.celltypes).astype(np.int64, copy=False)
    if hasattr(obj, "cell_connectivity"):
        offsets = getattr(obj, "cell_offsets", None)
        if offsets is None:
            offsets = obj.offset
        offsets = np.asarray(offsets, dtype=np.int64)
        connectivity = np.asarray(obj.cell_connectivity)
    else:  # legacy flat layout [k, i_0, ..., i_{k-1}, k, ...]
        flat = np.asarray(obj.cells)
        starts = np.empty(len(types) + 1, dtype=np.int64)
        position = 0
        for c in range(len(types)):
            starts[c] = position + 1
            position += int(flat[position]) + 1
        starts[-1] = position + 1
        keep = np.ones(len(flat), dtype=bool)
        keep[starts[:-1] - 1] = False
        connectivity = flat[keep]
        offsets = starts - 1 - np.arange(len(types) + 1)
    blocks = []
    for type_id in np.unique(types):
        name, dim = _vtk_name(int(type_id))
        cells = np.flatnonzero(types == type_id)
        data = None
        if name in wanted_names:
            k = _CORNERS[name]
            sizes = offsets[cells + 1] - offsets[cells]
            if np.any(sizes != k):
                raise ShapeError(f"{_describe(obj)}: a {name} cell with {sizes[sizes != k][0]}"
                                 f" vertices instead of {k}")
            data = connectivity[offsets[cells][:, None] + np.arange(k)]
        blocks.append((name, dim, data, len(cells), ("rows", cells)))
    return blocks


def _named_blocks(pairs):
    blocks = []
    for where, (cell_type, data) in enumerate(pairs):
        if isinstance(cell_type, str):
            name, dim = cell_type, _dimension(cell_type)
        else:
            name, dim = _vtk_name(int(cell_type))
        blocks.append((name, dim, data, len(data), ("list", where)))
    return blocks


def _blocks(obj, wanted_names):
    if hasattr(obj, "celltypes") and (hasattr(obj, "cell_connectivity")
                                      or not isinstance(getattr(obj, "cells", None), list)):
        return _vtk_blocks(obj, wanted_names)
    cells = getattr(obj, "cells", None)
    if isinstance(cells, (list, tuple)):
        pairs = []
        for block in cells:
            if hasattr(block, "type") and hasattr(block, "data"):  # meshio.CellBlock
                pairs.append((block.type, block.data))
            else:
                cell_type, data = block
                pairs.append((cell_type, data))
        return _named_blocks(pairs)
    for attr in ("cells_dict", "cells"):
        cells = getattr(obj, attr, None)
        if isinstance(cells, Mapping):
            return [(*b[:4], ("dict", cell_type))
                    for b, cell_type in zip(_named_blocks(cells.items()), cells)]
    raise TypeError(f"{_describe(obj)} is not a mesh object tetlap understands: it needs "
                    "`points` and cells (`cells` as (type, data) blocks, `cells_dict`, or "
                    "pyvista's `celltypes`)")


def _block_rows(data, name: str, block, source: str) -> np.ndarray:
    """A copy of the rows of the cell-data array ``name`` that belong to ``block`` (in the
    machine's byte order): by
    its ``where``, ``("list", k)`` (meshio: one array per block), ``("dict", type)`` (one
    array per cell type) or ``("rows", indices)`` (pyvista: one array for every cell)."""
    how, key = block[4]
    try:
        rows = np.asarray(data[name])[key] if how == "rows" else data[name][key]
    except (KeyError, IndexError, TypeError):
        rows = None
    rows = np.array(rows, copy=True)
    rows = rows.astype(rows.dtype.newbyteorder("="), copy=False)  # legacy VTK: big-endian
    if rows.ndim == 0 or len(rows) != block[3]:
        raise ShapeError(f"{source}: cell data {name!r} does not hold one row per cell of "
                         f"its {block[0]} block ({block[3]} cells)")
    return rows


def _cell_data(obj, kept, source: str) -> dict[str, np.ndarray]:
    """``{name: array}``: the object's cell data, the rows of the ``kept`` blocks in their
    order (the order of ``T``'s rows)."""
    by_type = kept[0][4][0] == "dict"
    data = getattr(obj, "cell_data_dict" if by_type else "cell_data", None) or {}
    out = {}
    for name in data.keys():
        parts = [_block_rows(data, name, block, source) for block in kept]
        out[str(name)] = np.concatenate(parts) if len(parts) > 1 else parts[0]
    return out


def check_options(cell_type, cell_data) -> str | None:
    """The meshio name of the cells ``cell_type`` asks for (None: tets, else triangles);
    OptionError for a ``cell_type`` or ``cell_data`` that is not one of the values
    :func:`tetlap.io.read` takes."""
    if not isinstance(cell_type, (str, type(None))) or cell_type not in _WANTED:
        raise OptionError(f"cell_type must be None, 'tetra' or 'triangle', got {cell_type!r}")
    _options.flag(cell_data, "cell_data")
    return _WANTED[cell_type]


def to_arrays(obj, cell_type=None, *, cell_data: bool = False, source: str | None = None,
              stacklevel: int = 2):
    """``(V, T)`` of a mesh object: ``V`` (n, d) float64 and ``T`` (m, 4) or (m, 3) int64,
    both new arrays; with ``cell_data=True`` also ``{name: (m, ...) array}``, copies of
    the object's cell data for the rows of ``T``. See :func:`tetlap.io.from_mesh`."""
    want = check_options(cell_type, cell_data)
    source = source or _describe(obj)
    if hasattr(obj, "cast_to_unstructured_grid") and not hasattr(obj, "celltypes"):
        obj = obj.cast_to_unstructured_grid()  # pyvista PolyData, ImageData, ...
    if not hasattr(obj, "points"):
        raise TypeError(f"{source} is not a mesh object: it has no `points`")
    V = np.array(obj.points, dtype=np.float64, copy=True)
    if V.ndim != 2:
        raise ShapeError(f"{source}: points must have shape (n, d), got {V.shape}")
    V = np.ascontiguousarray(V)
    blocks = [b for b in _blocks(obj, {want} if want else set(_CORNERS)) if b[3] > 0]
    if not blocks:
        raise EmptyMeshError(f"{source} has no cells")
    present = {b[0] for b in blocks}
    found = ", ".join(f"{b[0]} ({b[3]})" for b in blocks)
    unknown = sorted({b[0] for b in blocks if b[1] is None})
    if unknown:
        raise ShapeError(f"{source}: cell types of unknown dimension {unknown}; tetlap takes "
                         "linear tets or triangles")
    if want is None:  # the cells of the highest dimension present
        want = {3: "tetra", 2: "triangle"}.get(max(b[1] for b in blocks))
    level = _dimension(want) if want else None
    if want not in present:
        hint = (" (quadratic tets: their first 4 vertices are the corners, e.g. "
                "mesh.cells_dict['tetra10'][:, :4])" if "tetra10" in present else "")
        what = f"no {want} cells" if want else "no tets or triangles"
        raise ShapeError(f"{source}: {what}, found {found}; tetlap takes linear tets, or "
                         f"triangles{hint}")
    same = sorted({b[0] for b in blocks if b[1] == level and b[0] != want})
    if same:
        raise ShapeError(f"{source}: {want} cells mixed with {same} cells ({found}); tetlap "
                         "cannot use those, and dropping them would leave holes in the mesh")
    dropped = sorted({b[0] for b in blocks if b[1] < level})
    if dropped:
        warnings.warn(f"{source}: dropped lower-dimensional cells {dropped}", UserWarning,
                      stacklevel=stacklevel + 1)
    kept = [b for b in blocks if b[0] == want]
    parts = []
    for name, _, data, _, _ in kept:
        arr = np.asarray(data)
        if arr.dtype.kind not in "iu":
            raise DtypeError(f"{source}: {name} cells must hold integer vertex indices, got "
                             f"dtype {arr.dtype}")
        if arr.ndim != 2 or arr.shape[1] != _CORNERS[name]:
            raise ShapeError(f"{source}: {name} cells must have shape (m, {_CORNERS[name]}), "
                             f"got {arr.shape}")
        parts.append(arr.astype(np.int64))
    T = np.ascontiguousarray(np.concatenate(parts))
    if cell_data:
        return V, T, _cell_data(obj, kept, source)
    return V, T
