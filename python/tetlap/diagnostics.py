"""Mesh diagnostics: boundary, interior, volumes and orientation of tetrahedral meshes.

All functions take ``T`` as an (m, 4) integer array (any orientation) and, where geometry
is involved, ``V`` as (n, 3) float64. Nothing is modified.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "faces",
    "boundary_faces",
    "boundary_vertices",
    "interior_vertices",
    "referenced_vertices",
    "mesh_edges",
    "signed_volumes",
]

# Face opposite corner c, in an order that keeps the tet's orientation (outward for c).
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def faces(T) -> np.ndarray:
    """All 4 m tet faces, (4 m, 3), row ``4 t + c`` the face opposite corner c of tet t."""
    T = np.asarray(T)
    return T[:, _FACES].reshape(-1, 3)


def _face_keys(T) -> tuple[np.ndarray, np.ndarray]:
    F = np.sort(faces(T), axis=1).astype(np.int64)
    n = int(F.max()) + 1
    key = (F[:, 0] * n + F[:, 1]) * n + F[:, 2] if n < 2**21 else None
    if key is None:
        _, inverse = np.unique(F, axis=0, return_inverse=True)
        key = inverse.ravel()
    return F, key


def boundary_faces(T) -> np.ndarray:
    """Faces that belong to exactly one tet, (f, 3) int64, oriented like their tet."""
    _, key = _face_keys(T)
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    once = counts[inverse.ravel()] == 1
    return faces(T)[once].astype(np.int64)


def boundary_vertices(T, n: int | None = None) -> np.ndarray:
    """Boolean mask (n,) of vertices on a boundary face."""
    T = np.asarray(T)
    n = int(T.max()) + 1 if n is None else n
    mask = np.zeros(n, dtype=bool)
    mask[boundary_faces(T).ravel()] = True
    return mask


def referenced_vertices(T, n: int | None = None) -> np.ndarray:
    """Boolean mask (n,) of vertices that belong to at least one tet."""
    T = np.asarray(T)
    n = int(T.max()) + 1 if n is None else n
    mask = np.zeros(n, dtype=bool)
    mask[T.ravel()] = True
    return mask


def interior_vertices(T, n: int | None = None) -> np.ndarray:
    """Boolean mask (n,) of referenced vertices not on the boundary."""
    return referenced_vertices(T, n) & ~boundary_vertices(T, n)


def mesh_edges(T) -> np.ndarray:
    """Unique edges, (E, 2) int64 with ``i < j``, sorted lexicographically."""
    T = np.asarray(T, dtype=np.int64)
    E = T[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]].reshape(-1, 2)
    return np.unique(np.sort(E, axis=1), axis=0)


def signed_volumes(V, T) -> np.ndarray:
    """Signed volume per tet, (m,): ``det[x1-x0, x2-x0, x3-x0] / 6``; positive means the
    VTK/gmsh/Medit orientation. For immersed meshes (d > 3) the unsigned volume."""
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T)
    e = V[T[:, 1:]] - V[T[:, :1]]
    if V.shape[1] == 3:
        return np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2])) / 6
    gram = np.einsum("tid,tjd->tij", e, e)
    return np.sqrt(np.maximum(np.linalg.det(gram), 0.0)) / 6
