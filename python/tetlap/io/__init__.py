"""Mesh files and mesh objects in, meshio and pyvista objects out.

Reading: :func:`read` takes a file in any format meshio reads (``.msh``, ``.mesh``,
``.vtu``, ``.vtk``, TetGen ``.ele``, ...) or a mesh object; :func:`from_mesh` takes a
``meshio.Mesh``, a ``pyvista.UnstructuredGrid`` (or any pyvista dataset) or any object with
``points`` and cells. Both return ``(V, T)``: the linear tets if there are any, else the
triangles; with ``cell_data=True`` also the per-tet arrays (region tags, tensors). Writing: :func:`write` (a file), :func:`to_meshio`, :func:`to_pyvista` and
:func:`edges_to_pyvista` (e.g. the negative-weight edges) for plotting; :func:`dual_cells`
(the Voronoi / power cells as polyhedra with shared faces, written to ``.vtu`` / ``.vtk``).

meshio comes with tetlap; :func:`to_pyvista` and :func:`edges_to_pyvista` need the
optional ``pyvista`` (``pip install ".[pyvista]"``).

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

from ._dual_cells import DualCells, dual_cells
from ._pyvista import edges_to_pyvista, to_pyvista
from ._read import from_mesh, read
from ._write import to_meshio, write
from .._names import public_dir

__all__ = ["read", "from_mesh", "write", "to_meshio", "to_pyvista", "edges_to_pyvista",
           "dual_cells", "DualCells"]
__dir__ = public_dir(globals())
