"""PyVista objects for plotting: the mesh with its data, and chosen edges as lines."""

from __future__ import annotations

import importlib

import numpy as np

from .. import _arrays, _extras
from ..errors import ShapeError
from ._write import _checked


def _pyvista():
    """pyvista, or an ImportError naming the extra that installs it (an optional
    dependency: plotting is not the main job)."""
    try:
        return importlib.import_module("pyvista")
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError(f"pyvista grids need pyvista: {_extras.hint('pyvista')}") from None


def _points3d(V: np.ndarray) -> np.ndarray:
    if V.shape[1] == 2:
        return np.column_stack([V, np.zeros(len(V))])
    if V.shape[1] != 3:
        raise ShapeError(f"pyvista needs 2-D or 3-D points, V has shape {V.shape}; project "
                         "an immersed mesh to 3-D first")
    return V


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

