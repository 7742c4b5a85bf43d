"""Reading tetrahedral meshes from files (every format meshio reads).

>>> import tetlap.io  # doctest: +SKIP
>>> V, T = tetlap.io.read("part.msh")  # doctest: +SKIP
"""

from __future__ import annotations

import os
import warnings

import numpy as np

__all__ = ["read"]


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
    mesh = meshio.read(os.fspath(path))
    tets = [c.data for c in mesh.cells if c.type == "tetra"]
    dropped = sorted({c.type for c in mesh.cells if c.type != "tetra"})
    if dropped:
        warnings.warn(f"{os.fspath(path)}: dropped non-tet cells {dropped}", UserWarning,
                      stacklevel=2)
    T = np.concatenate(tets).astype(np.int64) if tets else np.zeros((0, 4), dtype=np.int64)
    V = np.asarray(mesh.points, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    return V, T
