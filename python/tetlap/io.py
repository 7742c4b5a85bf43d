"""Reading and writing tetrahedral meshes (every format meshio reads).

>>> import tetlap.io  # doctest: +SKIP
>>> V, T = tetlap.io.read("part.msh")  # doctest: +SKIP
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from .errors import MeshFileError

__all__ = ["read", "write"]


def read(path: str | os.PathLike):
    """Read the linear tets of a mesh file with meshio.

    Returns
    -------
    V : (n, 3) float64 (all points of the file: unreferenced vertices are kept, so indices
        never shift; tetlap's operators give them empty rows and zero mass).
    T : (m, 4) int64, the file's orientation (tetlap does not depend on it).

    Other cell types (triangles, lines, ...) are dropped with a ``UserWarning`` naming them.
    TetGen pairs: pass the ``.ele`` path (meshio reads the ``.node`` beside it).
    Requires the optional dependency ``meshio`` (``pip install tetlap[io]``).
    """
    try:
        import meshio
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError("reading mesh files needs meshio: pip install 'tetlap[io]'") from None
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no such mesh file: {path}")
    try:
        mesh = meshio.read(path)
    except Exception as e:  # meshio raises its own ReadError, KeyError, ValueError, ...
        raise MeshFileError(f"{path}: meshio could not read it ({type(e).__name__}: {e})") from e
    tets = [c.data for c in mesh.cells if c.type == "tetra"]
    dropped = sorted({c.type for c in mesh.cells if c.type != "tetra"})
    if dropped:
        warnings.warn(f"{path}: dropped non-tet cells {dropped}", UserWarning,
                      stacklevel=2)
    T = np.concatenate(tets).astype(np.int64) if tets else np.zeros((0, 4), dtype=np.int64)
    V = np.asarray(mesh.points, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    return V, T


def write(path: str | os.PathLike, V, T, *, cell_data: dict | None = None,
          point_data: dict | None = None) -> None:
    """Write a tet mesh with optional per-tet / per-vertex arrays (for ParaView etc.).

    ``cell_data`` maps names to (m,) or (m, k) arrays (e.g. the minimum edge weight per
    tet, or a non-Delaunay flag, as in the paper's Fig. 7); ``point_data`` to (n,) or
    (n, k) arrays. The format follows the file extension (``.vtu`` recommended).

    Example
    -------
    >>> import tetlap, tetlap.io  # doctest: +SKIP
    >>> V, T = tetlap.meshes.ball(1000)  # doctest: +SKIP
    >>> W = tetlap.tet_contributions(V, T, "dual")  # doctest: +SKIP
    >>> tetlap.io.write("ball.vtu", V, T, cell_data={"min_weight": W.min(axis=1)})  # doctest: +SKIP
    """
    try:
        import meshio
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ImportError("writing mesh files needs meshio: pip install 'tetlap[io]'") from None
    T = np.asarray(T, dtype=np.int64)
    cells = {name: [np.asarray(a)] for name, a in (cell_data or {}).items()}
    for name, (a,) in cells.items():
        if len(a) != len(T):
            raise ValueError(f"cell_data[{name!r}] has {len(a)} rows, the mesh {len(T)} tets")
    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), [("tetra", T)], cell_data=cells,
                       point_data={k: np.asarray(v) for k, v in (point_data or {}).items()})
    mesh.write(os.fspath(path))
