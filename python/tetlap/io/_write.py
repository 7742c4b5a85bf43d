"""Writing: ``(V, T)`` with per-vertex / per-cell arrays to a ``meshio.Mesh`` or a file."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Mapping

import meshio
import numpy as np

from .. import _arrays
from ..errors import DtypeError, MeshFileError, OptionError, ShapeError


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
    V, T, points, cells = _checked(V, T, point_data, cell_data)
    kind = "tetra" if T.shape[1] == 4 else "triangle"
    return meshio.Mesh(V, [(kind, T)], point_data=points,
                       cell_data={name: [a] for name, a in cells.items()})


#: meshio's formats of points, lines and polygons only: their writers drop tets (printing
#: a warning) and write a file without them.
_SURFACE_FORMATS = frozenset({"obj", "off", "ply", "stl", "svg", "wkt"})


def _check_holds_tets(path: str, T: np.ndarray) -> None:
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
    _check_holds_tets(path, mesh.cells[0].data)
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

