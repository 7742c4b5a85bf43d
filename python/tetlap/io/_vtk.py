"""Polyhedral grids in VTK's file formats, written with NumPy (meshio's legacy writer fails
on polyhedra, and its XML writer loops over every face in Python).

A grid is its points (P, 3), every cell as a polyhedron face stream ``[number of faces,
size of face 0, its points, ...]`` (all cells in one array, ``ends`` where each ends),
each cell's distinct points (for the XML format) and per-cell arrays.

* ``.vtu``: VTK XML, version 1.0 (64-bit headers), its arrays zlib-compressed in the raw
  appended section; the polyhedra as ``faces`` / ``faceoffsets`` arrays, the layout
  every VTK since 6 reads (VTK 9.4 writes a newer one that older readers do not).
* ``.vtk``: legacy VTK 5.1, binary (big-endian), the face stream of each polyhedron as its
  cell's connectivity, as VTK's own writer stores it.
"""

from __future__ import annotations

import zlib

import numpy as np

#: VTK's cell type of a polyhedron.
POLYHEDRON = 42
#: The uncompressed size of the blocks of a compressed XML array.
BLOCK = 2**20
#: VTK XML's type and the little-endian dtype of each kind of array.
_XML_TYPES = {"f": ("Float64", "<f8"), "i": ("Int64", "<i8"), "u": ("UInt8", "u1")}


def _compressed(a: np.ndarray) -> bytes:
    """An array as VTK XML's compressed binary: the header (UInt64: number of blocks,
    block size, size of the last block, each block's compressed size), then the
    zlib-compressed blocks."""
    raw = np.ascontiguousarray(a).tobytes()
    blocks = [raw[i:i + BLOCK] for i in range(0, len(raw), BLOCK)] or [b""]
    packed = [zlib.compress(b, 1) for b in blocks]   # level 1: faster, as small here
    header = np.array([len(blocks), BLOCK, len(blocks[-1]), *map(len, packed)], dtype="<u8")
    return header.tobytes() + b"".join(packed)


def write_vtu(path: str, points, stream, ends, cell_points, data: dict) -> None:
    """A ``.vtu`` file of polyhedra (see the module's docstring): the arrays compressed,
    raw, in the file's appended section."""
    connectivity, point_ends = cell_points
    k = len(ends)
    arrays = [("Points", np.asarray(points, dtype="<f8"), 3),
              ("connectivity", connectivity, 1), ("offsets", point_ends, 1),
              ("types", np.full(k, POLYHEDRON, dtype=np.uint8), 1),
              ("faces", stream, 1), ("faceoffsets", ends, 1),
              *((name, np.asarray(a), 1) for name, a in data.items())]
    tags, blobs, offset = [], [], 0
    for name, a, components in arrays:
        kind, dtype = _XML_TYPES[a.dtype.kind]
        blob = _compressed(a.astype(dtype, copy=False))
        shape = f' NumberOfComponents="{components}"' if components > 1 else ""
        tags.append(f'<DataArray type="{kind}" Name="{name}"{shape} format="appended" '
                    f'offset="{offset}"/>\n')
        blobs.append(blob)
        offset += len(blob)
    points_tag, cell_tags, data_tags = tags[0], tags[1:6], tags[6:]
    head = ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
            'byte_order="LittleEndian" header_type="UInt64" '
            'compressor="vtkZLibDataCompressor">\n<UnstructuredGrid>\n'
            f'<Piece NumberOfPoints="{len(points)}" NumberOfCells="{k}">\n'
            f'<Points>\n{points_tag}</Points>\n<Cells>\n{"".join(cell_tags)}</Cells>\n'
            f'<CellData>\n{"".join(data_tags)}</CellData>\n</Piece>\n</UnstructuredGrid>\n'
            '<AppendedData encoding="raw">\n_')
    with open(path, "wb") as f:
        f.writelines([head.encode(), *blobs, b"\n</AppendedData>\n</VTKFile>\n"])


def write_legacy(path: str, points, stream, ends, cell_points, data: dict) -> None:
    """A legacy ``.vtk`` file (5.1, binary) of polyhedra (see the module's docstring)."""
    k = len(ends)
    big = lambda a, t: np.ascontiguousarray(a, dtype=t).tobytes() + b"\n"  # noqa: E731
    parts = [
        b"# vtk DataFile Version 5.1\ntetlap dual cells\nBINARY\nDATASET UNSTRUCTURED_GRID\n",
        f"POINTS {len(points)} double\n".encode(), big(points, ">f8"),
        f"CELLS {k + 1} {len(stream)}\nOFFSETS vtktypeint64\n".encode(),
        big(np.r_[0, ends], ">i8"),
        b"CONNECTIVITY vtktypeint64\n", big(stream, ">i8"),
        f"CELL_TYPES {k}\n".encode(), big(np.full(k, POLYHEDRON), ">i4"),
        f"CELL_DATA {k}\n".encode(),
    ]
    for name, a in data.items():
        a = np.asarray(a)
        vtk, dtype = ("double", ">f8") if a.dtype.kind == "f" else ("vtktypeint64", ">i8")
        parts += [f"SCALARS {name} {vtk} 1\nLOOKUP_TABLE default\n".encode(), big(a, dtype)]
    with open(path, "wb") as f:
        f.writelines(parts)
