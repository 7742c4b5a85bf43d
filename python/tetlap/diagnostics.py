"""Mesh diagnostics: boundary, interior, volumes, orientation, dihedral angles, the
local Delaunay property and well-centeredness of tetrahedral meshes.

All functions take ``T`` as an (m, 4) integer array (any orientation) and, where geometry
is involved, ``V`` as (n, 3) float64. Nothing is modified.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "faces",
    "interior_faces",
    "orientation",
    "degenerate_tets",
    "dihedral_angles",
    "min_dihedral_angles",
    "non_delaunay_faces",
    "non_delaunay_tets",
    "well_centered",
    "duplicate_tets",
    "nonmanifold_faces",
    "DELAUNAY_RTOL",
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


def _edge_vectors(V, T):
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    X = V[T]
    return X, X[:, 1:] - X[:, :1]


def orientation(V, T) -> np.ndarray:
    """Sign of ``det[x1-x0, x2-x0, x3-x0]`` per tet, (m,) int8: +1, -1 or 0 (flat)."""
    return np.sign(signed_volumes(V, T)).astype(np.int8)


def degenerate_tets(V, T, rtol: float = 1e-12) -> np.ndarray:
    """Boolean (m,): tets with ``|Vol| <= rtol * mean|Vol|`` (exactly flat ones included)."""
    vol = np.abs(signed_volumes(V, T))
    return vol <= rtol * vol.mean()


def dihedral_angles(V, T) -> np.ndarray:
    """The six dihedral angles of every tet in degrees, (m, 6), at the local edges
    ``(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)``. NaN for flat tets. R^3 only."""
    _, E = _edge_vectors(V, T)
    g = np.stack([np.cross(E[:, 2] - E[:, 0], E[:, 1] - E[:, 0]), np.cross(E[:, 1], E[:, 2]),
                  np.cross(E[:, 2], E[:, 0]), np.cross(E[:, 0], E[:, 1])], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = g / np.linalg.norm(g, axis=2, keepdims=True)
        # the dihedral angle at edge (a, b) is between the faces opposite the other two
        # corners k, l: cos(theta) = -n_k . n_l for the gradient directions n
        opposite = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)]
        cos = np.stack([-np.einsum("ij,ij->i", g[:, k], g[:, l]) for k, l in opposite], axis=1)
        return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def min_dihedral_angles(V, T) -> np.ndarray:
    """Smallest dihedral angle of every tet in degrees, (m,)."""
    return np.nanmin(dihedral_angles(V, T), axis=1) if len(T) else np.zeros(0)


def interior_faces(T):
    """Faces shared by two tets.

    Returns
    -------
    tets : (f, 2) int64, the two tets of each interior face.
    opposite : (f, 2) int64, the vertex of each of them that is not on the face.
    Faces shared by more than two tets (non-manifold) are reported once per pair of
    consecutive tets in the sorted order.
    """
    T = np.asarray(T, dtype=np.int64)
    F = np.sort(faces(T), axis=1)
    order = np.lexsort(F.T[::-1])
    Fs = F[order]
    same = np.all(Fs[1:] == Fs[:-1], axis=1)
    first = order[:-1][same]
    second = order[1:][same]
    tets = np.column_stack([first // 4, second // 4])
    opposite = np.column_stack([T[first // 4, first % 4], T[second // 4, second % 4]])
    return tets, opposite


#: Relative tolerance of the Delaunay test: a point counts as inside a circumsphere only
#: if the lifted determinant exceeds ``DELAUNAY_RTOL`` times its Hadamard bound, so
#: cospherical points (a Kuhn grid's cubes) are not flagged.
DELAUNAY_RTOL = 1e-10


def non_delaunay_faces(V, T, rtol: float = DELAUNAY_RTOL) -> np.ndarray:
    """Boolean per interior face (order of :func:`interior_faces`): the opposite vertex of
    the second tet lies strictly inside the circumsphere of the first (up to ``rtol``
    relative to the determinant's Hadamard bound). In exact arithmetic the test is
    symmetric in the two tets. R^3 only."""
    V = np.asarray(V, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    tets, opposite = interior_faces(T)
    if len(tets) == 0:
        return np.zeros(0, dtype=bool)
    X = V[T[tets[:, 0]]] - V[opposite[:, 1]][:, None, :]  # (f, 4, 3), relative to q
    lifted = np.concatenate([X, (X**2).sum(axis=2, keepdims=True)], axis=2)
    det = np.linalg.det(lifted)
    E = X[:, 1:] - X[:, :1]
    orient = np.sign(np.einsum("ij,ij->i", E[:, 0], np.cross(E[:, 1], E[:, 2])))
    bound = np.prod(np.linalg.norm(lifted, axis=2), axis=1)
    # det[x_i - q, |x_i - q|^2] has the sign of -orient when q is inside the sphere
    return -orient * det > rtol * bound


def non_delaunay_tets(V, T, rtol: float = DELAUNAY_RTOL) -> np.ndarray:
    """Boolean (m,): tets with a face whose neighbour's opposite vertex is inside their
    circumsphere (either side of the face counts)."""
    T = np.asarray(T)
    bad = np.zeros(len(T), dtype=bool)
    tets, _ = interior_faces(T)
    flags = non_delaunay_faces(V, T, rtol)
    bad[tets[flags].ravel()] = True
    return bad


def well_centered(V, T) -> np.ndarray:
    """Boolean (m,): the tet's circumcenter is strictly inside it and every face's
    circumcenter strictly inside that face (all face angles acute). R^3 only."""
    X, E = _edge_vectors(V, T)
    n = np.stack([np.cross(E[:, 2] - E[:, 0], E[:, 1] - E[:, 0]), np.cross(E[:, 1], E[:, 2]),
                  np.cross(E[:, 2], E[:, 0]), np.cross(E[:, 0], E[:, 1])], axis=1)
    det = np.einsum("ij,ij->i", E[:, 0], n[:, 1])
    sq = (E**2).sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = (sq[:, 0, None] * n[:, 1] + sq[:, 1, None] * n[:, 2] + sq[:, 2, None] * n[:, 3]) / (
            2 * det[:, None])
        lam = np.stack([np.einsum("ij,ij->i", n[:, 0], c - E[:, 0])] +
                       [np.einsum("ij,ij->i", n[:, k], c) for k in (1, 2, 3)], axis=1) / det[:, None]
    inside = np.all(lam > 0, axis=1)
    # every face angle acute: for each corner a and pair (b, c) of others, (b-a).(c-a) > 0
    for a in range(4):
        others = [b for b in range(4) if b != a]
        for i in range(3):
            for j in range(i + 1, 3):
                d = np.einsum("ij,ij->i", X[:, others[i]] - X[:, a], X[:, others[j]] - X[:, a])
                inside &= d > 0
    return inside


def duplicate_tets(T) -> np.ndarray:
    """Boolean (m,): tets whose vertex set appeared in an earlier row (any order)."""
    S = np.sort(np.asarray(T, dtype=np.int64), axis=1)
    _, first = np.unique(S, axis=0, return_index=True)
    dup = np.ones(len(S), dtype=bool)
    dup[first] = False
    return dup


def nonmanifold_faces(T) -> np.ndarray:
    """Faces shared by more than two tets, (f, 3) sorted vertex triples."""
    F = np.sort(faces(T), axis=1)
    keys, counts = np.unique(F, axis=0, return_counts=True)
    return keys[counts > 2]
