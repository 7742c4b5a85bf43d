"""Mesh diagnostics: boundary and interior, orientation and volumes, dihedral angles, the
local Delaunay property, well-centredness, duplicate and non-manifold elements, folds.

Every function is computed by the parallel Rust core in ``O(m)`` (faces are matched by a
counting sort on their smallest vertex, not by a global sort), answers Ctrl-C, validates
its input like :func:`tetlap.laplacian` and never modifies it. ``T`` is an (m, 4) integer
array of tets in any orientation; where geometry is involved, ``V`` is (n, 3) (the
dihedral angles, volumes and well-centredness also work for tets immersed in R^d). Every
function takes ``(V, T)`` or one mesh object (meshio, PyVista, ...); the ones that need no
coordinates (faces, vertex masks, edges, duplicates) also take ``T`` alone, and the vertex
masks ``(T, n)`` (``n`` vertices), their older form.

Example
-------
>>> import tetlap
>>> V, T = tetlap.meshes.cube(2)
>>> tetlap.diagnostics.boundary_faces(V, T).shape, int(tetlap.diagnostics.interior_vertices(V, T).sum())
((48, 3), 1)
"""

from __future__ import annotations

import numbers

import numpy as np

from . import _arrays, _core, _meshobj, _options
from . import coefficient as _coefficient
from ._names import public_dir

__all__ = [
    "DELAUNAY_RTOL",
    "faces",
    "boundary_faces",
    "interior_faces",
    "nonmanifold_faces",
    "boundary_vertices",
    "interior_vertices",
    "referenced_vertices",
    "mesh_edges",
    "duplicate_tets",
    "signed_volumes",
    "orientation",
    "degenerate_tets",
    "dihedral_angles",
    "min_dihedral_angles",
    "well_centered",
    "non_delaunay_faces",
    "non_delaunay_tets",
    "folded_faces",
    "folded_tets",
    "folded_vertices",
    "face_normals",
    "summary",
]
__dir__ = public_dir(globals())

#: Relative tolerance of the Delaunay test: a point counts as inside a circumsphere only
#: if the lifted determinant exceeds ``DELAUNAY_RTOL`` times its Hadamard bound, so
#: cospherical points (a Kuhn grid's cubes) are not flagged.
DELAUNAY_RTOL = _core.DELAUNAY_RTOL

#: How many folded tets and vertices :func:`summary` (and ``tetlap info``) names.
LISTED = 10

# Face opposite corner c, in an order that keeps the tet's orientation (outward for c).
_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def _topology(first, second=None, n=None, n_columns=4) -> tuple[np.ndarray, int]:
    """``(T, n)``: the elements (``(m, k)`` int64, ``k`` in ``n_columns``) and the vertex
    count of ``(V, T)``, of one mesh object, of ``T`` alone (``n = T.max() + 1``) or of
    ``(T, n)`` (``n`` positional or keyword, an integer at least ``T.max() + 1``); errors
    name the argument at fault."""
    if _meshobj.is_mesh_object(first):
        if second is not None or n is not None:
            raise TypeError("a mesh object carries its cells and vertices; pass it alone")
        V, T = _meshobj.to_arrays(first, stacklevel=4)
        return _arrays.elements(T, n_columns), len(V)
    if second is not None and np.ndim(second) == 0:  # (T, n), the older form
        if n is not None:
            raise TypeError("n is given twice")
        second, n = None, second
    if second is None:
        T = _arrays.elements(first, n_columns)
        needed = int(T.max()) + 1
        n = needed if n is None else int(_options.count(n, "n", needed))  # T's indices < n
        _arrays.in_range(T, n, "element")                                  # and >= 0
        return T, n
    if n is not None:
        raise TypeError("n goes with (T, n): (V, T) has len(V) vertices")
    n = len(_arrays.points(first))
    T = _arrays.elements(second, n_columns)
    _arrays.in_range(T, n, "element")
    return T, n


def faces(V, T=None) -> np.ndarray:
    """All 4 m faces of the tets, (4 m, 3) int64; row ``4 t + c`` is the face opposite
    corner ``c`` of tet ``t``, oriented outward for a positively oriented tet."""
    T, _ = _topology(V, T)
    return T[:, _FACES].reshape(-1, 3)


def boundary_faces(V, T=None, *, return_tets: bool = False):
    """Faces that belong to exactly one tet, (f, 3) int64, oriented like their tet (outward
    for positively oriented tets), in the order of their tets.

    With ``return_tets=True`` also the tet of every face (f,) and the corner of that tet
    opposite the face (f,).
    """
    T, n = _topology(V, T)
    boundary = _core.faces(T, n)[0]
    F = T[boundary[:, 0][:, None], _FACES[boundary[:, 1]]]
    return (F, boundary[:, 0], boundary[:, 1]) if return_tets else F


def interior_faces(V, T=None):
    """Faces shared by two tets.

    Returns
    -------
    tets : (f, 2) int64
        The two tets of each interior face.
    opposite : (f, 2) int64
        The vertex of each of them that is not on the face.

    Faces come in lexicographic order of their sorted vertex indices. A face shared by
    more than two tets (non-manifold) is reported once per pair of consecutive tets
    (ordered by tet index).
    """
    T, n = _topology(V, T)
    interior = _core.faces(T, n)[1]
    tets = interior[:, [0, 2]]
    opposite = np.column_stack([T[interior[:, 0], interior[:, 1]], T[interior[:, 2], interior[:, 3]]])
    return tets, opposite


def nonmanifold_faces(V, T=None) -> np.ndarray:
    """Faces shared by more than two tets, (k, 3) int64 sorted vertex triples, ascending."""
    return _core.faces(*_topology(V, T))[2]


def _on_boundary(T: np.ndarray, n: int) -> np.ndarray:
    boundary = _core.faces(T, n)[0]
    mask = np.zeros(n, dtype=bool)
    mask[T[boundary[:, 0][:, None], _FACES[boundary[:, 1]]].ravel()] = True
    return mask


def _referenced(T: np.ndarray, n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[T.ravel()] = True
    return mask


def boundary_vertices(V, T=None, *, n=None) -> np.ndarray:
    """Boolean mask (n,) of the vertices on a boundary face, for ``(V, T)`` (n = len(V)),
    a mesh object, or ``(T, n)`` / ``T`` alone (``n``, also by keyword, defaults to
    ``T.max() + 1``).

    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> int(tetlap.diagnostics.boundary_vertices(V, T).sum())
    26
    """
    return _on_boundary(*_topology(V, T, n))


def referenced_vertices(V, T=None, *, n=None) -> np.ndarray:
    """Boolean mask (n,) of the vertices that belong to at least one element, tet or
    triangle (arguments as :func:`boundary_vertices`)."""
    return _referenced(*_topology(V, T, n, n_columns=(3, 4)))


def interior_vertices(V, T=None, *, n=None) -> np.ndarray:
    """Boolean mask (n,) of referenced vertices not on the boundary (arguments as
    :func:`boundary_vertices`)."""
    T, n = _topology(V, T, n)
    return _referenced(T, n) & ~_on_boundary(T, n)


def mesh_edges(V, T=None) -> np.ndarray:
    """Unique edges, (E, 2) int64 with ``i < j``, sorted lexicographically (tets or
    triangles)."""
    return _core.edges(*_topology(V, T, n_columns=(3, 4)))


def duplicate_tets(V, T=None) -> np.ndarray:
    """Boolean (m,): tets whose vertex set appeared in an earlier row (any order)."""
    return _core.duplicates(*_topology(V, T))


def _geometry(V, T):
    """``(V, T)`` arrays (or those of one mesh object passed as ``V``), checked."""
    V, T = _arrays.mesh(V, T)
    return _arrays.points(V), _arrays.elements(T, 4)


def _quality(V, T=None):
    return _core.quality(*_geometry(V, T))


@_arrays.takes_mesh_object
def signed_volumes(V, T=None) -> np.ndarray:
    """Signed volume per tet, (m,) float64: ``det[x1-x0, x2-x0, x3-x0] / 6``; positive means
    the VTK/gmsh/Medit orientation. For immersed meshes (d > 3) the unsigned volume."""
    return _quality(V, T)[0]


@_arrays.takes_mesh_object
def orientation(V, T=None) -> np.ndarray:
    """Sign of ``det[x1-x0, x2-x0, x3-x0]`` per tet, (m,) int8: +1, -1 or 0 (exactly flat),
    decided exactly at any scale (a tet of size ``1e-150`` has a volume below the float64
    range, 0 in :func:`signed_volumes`, and its sign all the same); +1 for a tet immersed in
    R^d, d > 3, that is not flat.

    >>> import numpy as np, tetlap
    >>> V = 1e-150 * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    >>> tetlap.diagnostics.signed_volumes(V, [[0, 1, 2, 3]]), tetlap.diagnostics.orientation(V, [[1, 0, 2, 3]])
    (array([0.]), array([-1], dtype=int8))
    """
    return _quality(V, T)[3]


@_arrays.takes_mesh_object
def degenerate_tets(V, T=None, rtol: float = 1e-12) -> np.ndarray:
    """Boolean (m,): the tets flat to within ``rtol`` of their own size, ``|Vol| <= rtol *
    l^3 / (6 sqrt 2)`` with ``l`` the tet's longest edge (the right side is ``rtol`` times
    the volume of the regular tet on that edge), so that a tet's answer depends on no other
    tet and on no unit; the exactly flat tets (which the operators refuse, or skip with
    ``degenerate="skip"``) always, and only they for ``rtol = 0``. ``rtol`` a relative
    tolerance in [0, 1).

    >>> import numpy as np, tetlap
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1e-13], [0, 0, 1.0]])
    >>> tetlap.diagnostics.degenerate_tets(V, [[0, 1, 2, 3], [0, 1, 2, 4]]).tolist()
    [True, False]
    """
    rtol = _options.tolerance(rtol, "rtol")
    V, T = _geometry(V, T)
    flat = _flat(_core.quality(V, T)[1])
    if rtol == 0:
        return flat
    X = V[T]
    E = X[:, 1:] - X[:, :1]                                     # (m, 3, d)
    pairs = np.stack([E[:, 0], E[:, 1], E[:, 2], E[:, 1] - E[:, 0], E[:, 2] - E[:, 0],
                      E[:, 2] - E[:, 1]], axis=1)
    longest = np.abs(pairs).max(axis=(1, 2))
    # each tet in a frame scaled by a power of two (exact) to edges of about 1: no
    # overflow or underflow of the volume of a needle or a tiny tet
    shift = np.frexp(np.where(longest > 0, longest, 1.0))[1]
    E = np.ldexp(E, -shift[:, None, None])
    l = np.linalg.norm(np.ldexp(pairs, -shift[:, None, None]), axis=2).max(axis=1)
    gram = np.linalg.det(E @ E.transpose(0, 2, 1))              # (6 Vol)^2, scaled
    six_vol = np.sqrt(np.maximum(gram, 0.0))
    return flat | (six_vol <= rtol * l**3 / np.sqrt(2))


def _flat(dihedral: np.ndarray) -> np.ndarray:
    """The exactly flat tets, (m,) bool: those without dihedral angles (the core decides
    flatness exactly, as the operators do)."""
    return np.isnan(dihedral).any(axis=1)


@_arrays.takes_mesh_object
def dihedral_angles(V, T=None, *, coefficient=None) -> np.ndarray:
    """The six dihedral angles of every tet in degrees, (m, 6) float64, at the local edges
    ``(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)``. NaN for flat tets.

    With ``coefficient=K`` (as :func:`tetlap.laplacian` takes it: ``(m,)``, ``(m, 3, 3)``
    or ``(3, 3)``, validated by :func:`tetlap.coefficient.check`), the angles *in the
    metric* ``K^-1``: those of each tet mapped by its ``K_t^-1/2``, whose cotangents the
    primal with ``K`` is made of (a tet is non-obtuse in the metric when none exceeds 90
    degrees). A scalar per tet changes no angle; a tensor's scale does not either (each
    ``K_t`` is scaled by a power of two before its inverse square root is taken, exactly).

    >>> import numpy as np, tetlap
    >>> V, T = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]]
    >>> tetlap.diagnostics.dihedral_angles(V, T).round(1)
    array([[90. , 90. , 90. , 54.7, 54.7, 54.7]])
    >>> K = np.diag([1.0, 1.0, 4.0])   # the tet mapped by K^-1/2: z halved
    >>> tetlap.diagnostics.dihedral_angles(V, T, coefficient=K).round(1)
    array([[90. , 90. , 90. , 35.3, 65.9, 65.9]])
    """
    V, T = _geometry(V, T)
    K = _metric(coefficient, V, T)
    if K is None:
        return _core.quality(V, T)[1]
    return _core.quality(*_mapped(V, T, K))[1]


@_arrays.takes_mesh_object
def min_dihedral_angles(V, T=None, *, coefficient=None) -> np.ndarray:
    """Smallest dihedral angle of every tet in degrees, (m,) (NaN for flat tets); in the
    metric of ``coefficient`` as :func:`dihedral_angles`."""
    return dihedral_angles(V, T, coefficient=coefficient).min(axis=1)


def _metric(coefficient, V, T) -> np.ndarray | None:
    """The coefficient's tensors, (m, 3, 3) float64 (one ``(3, 3)`` repeated), validated
    by the one rule (:func:`tetlap.coefficient.check`); None without one or for scalars,
    which leave every angle and every Delaunay test as they are. ``V``, ``T`` validated."""
    if coefficient is None:
        return None
    K = _coefficient.check(coefficient, V, T)
    if K.ndim == 1:
        return None
    return np.broadcast_to(K, (len(T), 3, 3))


def _normalised(K: np.ndarray) -> np.ndarray:
    """SPD tensors (m, 3, 3), each ``K_t`` scaled by an even power of two ``4^-e`` (exact)
    to a largest entry near 1. The angles, the Delaunay test and the contributions of
    :func:`_metric_face_weights` do not depend on a scale of ``K_t``: scaled, they are
    computed with no overflow or underflow at any scale of ``K``."""
    e = np.frexp(np.abs(K).max(axis=(1, 2)))[1] // 2
    return np.ldexp(K, -2 * e[:, None, None])


def _mapped(V: np.ndarray, T: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tets mapped by their metrics, as a mesh of disjoint tets: points (4 m, 3), tet
    ``t`` is ``(4t, 4t+1, 4t+2, 4t+3)`` with corner 0 at the origin (a translation, which
    keeps the geometry of a tet far from the origin accurate) and ``x -> K_t^-1/2 x``
    applied, ``K_t`` :func:`_normalised` (the mapped tet is then a power of two times the
    one mapped by ``K_t^-1/2``: the same shape). Vectorized over the tets."""
    lam, Q = np.linalg.eigh(_normalised(K))
    roots = (Q / np.sqrt(lam)[:, None, :]) @ Q.transpose(0, 2, 1)   # K^-1/2, symmetric
    X = V[T] - V[T[:, :1]]                                          # (m, 4, 3)
    return np.ascontiguousarray((X @ roots).reshape(-1, 3)), np.arange(4 * len(T)).reshape(-1, 4)


def _metric_face_weights(V: np.ndarray, T: np.ndarray, K: np.ndarray, interior: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """``(w, size)``, each (f, 2): each interior face's two contributions in the metric
    (rows of the core's ``interior`` pairs ``[s, a, t, b]``) and their scales. For tet
    ``s`` and its face opposite corner ``a``, ``w = sqrt(det K_s) |f'| h' / 3``, with ``h'``
    the signed distance of the circumcentre of the mapped tet from the mapped face
    (positive on the tet's side) and ``|f'|`` its area: the signed volume, in physical
    space, of the pyramid on the face whose apex is the tet's circumcentre in its metric,
    which does not depend on the scale of ``K_s`` (a scalar coefficient changes nothing).
    ``size`` is the same with the circumradius ``R' >= |h'|`` for ``h'``: the scale of
    the rounding of ``w``. The face is locally Delaunay in the metric when the sum of its
    two contributions is >= 0; for one constant ``K`` that is the sign of the dual edge of
    the mesh mapped by ``K^-1/2``, its plain Delaunay test. A flat tet contributes 0."""
    P, C = _mapped(V, T, K)
    flat = _flat(_core.quality(P, C)[1])        # no circumcentre: no contribution
    P.reshape(-1, 4, 3)[flat] = np.eye(4, 3, -1)  # a unit tet in their place, then 0
    centres, _, heights, areas = _core.dual_centres(P, C)[:4]   # (m, 5, 3), (m, 4) ...
    radius = np.linalg.norm(centres[:, 0] - P.reshape(-1, 4, 3)[:, 0], axis=1)
    scale = np.where(flat, 0.0, np.sqrt(np.linalg.det(_normalised(K)))) * radius
    pyramid = scale[:, None] * areas * (heights / radius[:, None]) / 3      # (m, 4)
    size = scale[:, None] * areas / 3
    s, a, t, b = interior.T
    return (np.column_stack([pyramid[s, a], pyramid[t, b]]),
            np.column_stack([size[s, a], size[t, b]]))


@_arrays.takes_mesh_object
def well_centered(V, T=None) -> np.ndarray:
    """Boolean (m,): the tet's circumcenter is strictly inside it and every face's
    circumcenter strictly inside that face (all face angles acute)."""
    return _quality(V, T)[2]


@_arrays.takes_mesh_object
def non_delaunay_faces(V, T=None, rtol: float = DELAUNAY_RTOL, *, coefficient=None) -> np.ndarray:
    """Boolean per interior face (order of :func:`interior_faces`): the opposite vertex of
    the second tet lies strictly inside the circumsphere of the first (up to ``rtol``
    relative to the lifted determinant's Hadamard bound). In exact arithmetic the test is
    symmetric in the two tets. R^3 only. ``rtol``: a relative tolerance in [0, 1).

    With a tensor ``coefficient=K`` (as :func:`tetlap.laplacian` takes it), the faces that
    are not locally Delaunay *in the metric* ``K^-1``, each tet in its own: the face's
    weight, the sum of its two tets' contributions (each the signed volume of the pyramid
    on the face whose apex is the tet's circumcentre in its metric, that is of the tet
    mapped by ``K_t^-1/2``, pulled back), is below ``-rtol`` times the sum of their
    scales (the same volumes with each circumradius in the metric for the centre's
    distance from the face, so that cospherical points are not flagged). For one constant ``K`` this is the Delaunay test of the mesh mapped
    by ``K^-1/2``; the dual in the metric needs it as the plain dual needs a Delaunay
    mesh. A scalar coefficient changes no face's answer (the plain test is returned).

    >>> import numpy as np, tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.2]]
    >>> T = [[0, 1, 2, 3], [1, 2, 3, 4]]
    >>> tetlap.diagnostics.non_delaunay_faces(V, T).tolist()
    [False]
    >>> K = [[1.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]]
    >>> tetlap.diagnostics.non_delaunay_faces(V, T, coefficient=K).tolist()
    [True]
    """
    return _non_delaunay(V, T, rtol, coefficient)[0]


@_arrays.takes_mesh_object
def non_delaunay_tets(V, T=None, rtol: float = DELAUNAY_RTOL, *, coefficient=None) -> np.ndarray:
    """Boolean (m,): tets with a face whose neighbour's opposite vertex is inside their
    circumsphere (either side of the face counts); ``rtol`` and ``coefficient`` (the test
    in the metric) as for :func:`non_delaunay_faces`."""
    flags, interior, T = _non_delaunay(V, T, rtol, coefficient)
    bad = np.zeros(len(T), dtype=bool)
    bad[interior[flags][:, [0, 2]].ravel()] = True
    return bad


def _non_delaunay(V, T, rtol, coefficient):
    """``(flags, interior, T)``: :func:`non_delaunay_faces`, the core's interior face pairs
    ``[s, a, t, b]`` and the validated tets."""
    _options.tolerance(rtol, "rtol")
    V, T = _geometry(V, T)
    K = _metric(coefficient, V, T)
    interior = _core.faces(T, len(V))[1]
    if K is None:
        return _core.non_delaunay(V, T, interior, float(rtol)), interior, T
    return _delaunay_in_metric(V, T, K, interior, rtol)[0], interior, T


def _delaunay_in_metric(V, T, K, interior, rtol: float = DELAUNAY_RTOL):
    """``(flags, margin)`` per row of ``interior``: not locally Delaunay in the metric (the
    sum of the two contributions of :func:`_metric_face_weights` below ``-rtol`` times the
    sum of their sizes), and that sum relative to the sum of the sizes, in [-1, 1] (the
    most negative, the worst face; 0 between two flat tets)."""
    w, size = _metric_face_weights(V, T, K, interior)
    total, size = w.sum(axis=1), size.sum(axis=1)
    margin = np.divide(total, size, out=np.zeros_like(total), where=size > 0)
    return margin < -rtol, margin


def _folds(V, T, interior, sign) -> np.ndarray:
    """Boolean per row of the core's ``interior`` face pairs ``[s, a, t, b]`` (tet ``s``,
    its corner ``a`` opposite the face, tet ``t``, its corner ``b``): the apexes of the
    two tets lie on the same side of the face. From the tets' exact orientation ``sign``
    (the core's, exact at any scale) and the parity of
    each tet's vertex order against the face's; a flat tet folds nothing."""
    s, a, t, b = interior.T
    face = T[s[:, None], _FACES[a]]               # outward for a positive tet s: its apex
    side_s = -sign[s].astype(np.int64)             # lies on the negative side
    # tet t as (face in s's order, apex of t): the parity of that reordering of T[t]
    order = np.column_stack([(T[t][:, None, :] == face[:, :, None]).argmax(axis=2), b])
    inversions = sum((order[:, i] > order[:, j]) for i in range(4) for j in range(i + 1, 4))
    side_t = sign[t].astype(np.int64) * (1 - 2 * (inversions % 2))
    return (side_s == side_t) & (side_s != 0)


@_arrays.takes_mesh_object
def folded_faces(V, T=None) -> np.ndarray:
    """Boolean per interior face (order of :func:`interior_faces`): its two tets lie on the
    same side of it, so they overlap and the mesh folds over itself there. Decided from
    exact orientation signs, and by the geometry only: a tet whose vertex order alone is
    reversed (a negative signed volume) folds nothing, a tet inverted against its
    neighbours folds every face it shares with them. Every Laplacian loses linear precision at
    the vertices of a folded face (:func:`folded_vertices`). False for a flat tet and for
    an immersed mesh (d > 3, no sides).

    >>> import numpy as np, tetlap
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [0.2, 0.2, 0.5]])
    >>> tetlap.diagnostics.folded_faces(V, [[0, 1, 2, 3], [0, 2, 1, 4]]).tolist()  # any order
    [False]
    >>> tetlap.diagnostics.folded_faces(V, [[0, 1, 2, 3], [0, 1, 2, 5]]).tolist()  # overlap
    [True]
    """
    V, T = _geometry(V, T)
    interior = _core.faces(T, len(V))[1]
    if V.shape[1] != 3:
        return np.zeros(len(interior), dtype=bool)
    return _folds(V, T, interior, _core.quality(V, T)[3])


def _folded_tets(T, interior, folded, volume, sign) -> np.ndarray:
    """:func:`folded_tets` from the interior face pairs and their fold flags: the tets on
    the smaller side (fewer tets, then less volume; both on a tie) of the folds of each
    face-connected part. The sides are a two-colouring of the tets in which neighbours
    across a folded face differ and across any other face agree: the components of the
    double cover (tet, side) whose edges keep or swap the side. A part without such a
    colouring (a fold that closes on itself) names each tet with a folded face."""
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components

    m = len(T)
    if not folded.any():
        return np.zeros(m, dtype=bool)
    s, t = interior[:, 0], interior[:, 2]
    live = (sign[s] != 0) & (sign[t] != 0)
    s, t, swap = s[live], t[live], folded[live].astype(np.int64)
    rows = np.concatenate([s, s + m])
    cols = np.concatenate([t + m * swap, t + m * (1 - swap)])
    graph = coo_array((np.ones(len(rows)), (rows, cols)), shape=(2 * m, 2 * m))
    _, label = connected_components(graph, directed=False)
    mine, mirror = label[:m], label[m:]
    part = np.minimum(mine, mirror)                 # one id per face-connected part
    side = (mine != part).astype(np.int64)          # 0 or 1 within it
    count = np.zeros((2 * m, 2))
    size = np.zeros((2 * m, 2))
    np.add.at(count, (part, side), 1)
    np.add.at(size, (part, side), np.abs(volume))
    (c0, c1), (v0, v1) = count.T, size.T            # fewer tets, then less volume
    smaller = np.select([c0 < c1, c1 < c0, v0 < v1, v1 < v0], [0, 1, 0, 1], -1)
    named = (smaller[part] == side) | (smaller[part] == -1)
    named &= count[part].min(axis=1) > 0            # a part without folds names nothing
    closed = mine == mirror                         # no two-colouring
    if closed.any():
        touched = np.zeros(m, dtype=bool)
        touched[np.concatenate([s[swap == 1], t[swap == 1]])] = True
        named = np.where(closed, touched, named)
    return named


@_arrays.takes_mesh_object
def folded_tets(V, T=None) -> np.ndarray:
    """Boolean (m,): the tets folded against their neighbours. Across an interior face of
    an unfolded mesh the two tets lie on opposite sides; where they lie on the same side
    (:func:`folded_faces`) one of them is inverted relative to the other. In each
    face-connected part of the mesh the tets split into two sides, neighbours across a
    folded face on different sides; the folded tets are those of the smaller side (fewer
    tets, then less volume; both sides on an exact tie). A tet whose vertex order alone
    is reversed is not folded: only the geometry counts. All False for an immersed mesh
    (d > 3).

    >>> import numpy as np, tetlap
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.2, 0.2, 0.5]])
    >>> tetlap.diagnostics.folded_tets(V, [[0, 1, 2, 3], [0, 1, 2, 4]]).tolist()
    [False, True]
    >>> V, T = tetlap.meshes.cube(2)
    >>> V[13] = [0.5, 0.5, 1.2]       # the centre pulled out through the top
    >>> np.flatnonzero(tetlap.diagnostics.folded_tets(V, T)).tolist()
    [1, 11, 17, 29, 39, 47]
    """
    V, T = _geometry(V, T)
    interior = _core.faces(T, len(V))[1]
    if V.shape[1] != 3:
        return np.zeros(len(T), dtype=bool)
    volume, _, _, sign = _core.quality(V, T)
    return _folded_tets(T, interior, _folds(V, T, interior, sign), volume, sign)


@_arrays.takes_mesh_object
def folded_vertices(V, T=None) -> np.ndarray:
    """Boolean (n,): the vertices of folded faces (:func:`folded_faces`), where the mesh
    folds over itself. At such a vertex the tets around it do not tile a neighbourhood,
    so neither Laplacian is linearly precise there, whatever the tets' vertex order:
    ``L x`` misses by about the folded tets' share of the vertex's row (``tetlap.check``
    fails at the interior ones, unless the folded tets are so small that this stays
    within its tolerance).

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> V[13] = [0.5, 0.5, 1.2]       # the centre pulled out through the top
    >>> np.flatnonzero(tetlap.diagnostics.folded_vertices(V, T)).tolist()
    [1, 4, 10, 13, 14, 17, 23, 26]
    """
    V, T = _geometry(V, T)
    interior = _core.faces(T, len(V))[1]
    mask = np.zeros(len(V), dtype=bool)
    if V.shape[1] == 3:
        mask[_fold_vertices(T, interior, _folds(V, T, interior, _core.quality(V, T)[3]))] = True
    return mask


def _fold_vertices(T, interior, folds) -> np.ndarray:
    """The vertices of the folded faces, ascending (the core's ``interior`` pairs and their
    fold flags)."""
    return np.unique(T[interior[folds, 0][:, None], _FACES[interior[folds, 1]]])


def face_normals(V, F) -> np.ndarray:
    """Area vectors of triangles ``F`` (k, 3) over ``V`` (n, 3): ``(x1 - x0) x (x2 - x0) /
    2``, (k, 3) float64 (length = area, direction by the right-hand rule)."""
    P = _arrays.points(V)[np.asarray(F)]
    return np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]) / 2


@_arrays.takes_mesh_object
def summary(V, T=None, rtol: float = DELAUNAY_RTOL) -> dict:
    """Counts and extremes of every diagnostic at once (one pass of each core routine), as
    a JSON-ready dict: vertices (on the boundary, unreferenced), tets (positive, negative,
    degenerate, duplicate), faces (boundary, interior, non-manifold), the fraction of
    non-Delaunay interior faces and tets, the dihedral range in degrees, the fraction of
    well-centred tets, the mesh volume, and the folds (:func:`folded_faces`,
    :func:`folded_tets`, :func:`folded_vertices`: counts, and the first
    :data:`LISTED` tets and vertices by index). Geometric entries that need R^3 are None
    (the lists empty) for an immersed mesh.

    Example
    -------
    >>> import tetlap
    >>> s = tetlap.diagnostics.summary(*tetlap.meshes.cube(2))
    >>> s["n_tets"], s["n_boundary_faces"], s["non_delaunay_face_fraction"]
    (48, 48, 0.0)
    """
    _options.tolerance(rtol, "rtol")
    return _summary(*_geometry(V, T), rtol)[0]


def _summary(V, T, rtol: float = DELAUNAY_RTOL) -> tuple[dict, np.ndarray]:
    """:func:`summary` of validated arrays, and the (n,) bool mask of boundary vertices."""
    n, in_r3 = len(V), V.shape[1] == 3
    boundary, interior, nonmanifold = _core.faces(T, n)
    volume, dihedral, well, sign = _core.quality(V, T)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[T[boundary[:, 0][:, None], _FACES[boundary[:, 1]]].ravel()] = True
    referenced = _referenced(T, n)
    flat = _flat(dihedral)
    result = {
        "n_vertices": n,
        "n_tets": len(T),
        "n_boundary_vertices": int(on_boundary.sum()),
        "n_unreferenced_vertices": int((~referenced).sum()),
        "n_positive_tets": int((sign > 0).sum()) if in_r3 else None,
        "n_negative_tets": int((sign < 0).sum()) if in_r3 else None,
        "n_degenerate_tets": int(flat.sum()),
        "n_duplicate_tets": int(_core.duplicates(T, n).sum()),
        "n_boundary_faces": len(boundary),
        "n_interior_faces": len(interior),
        "n_nonmanifold_faces": len(nonmanifold),
        "min_dihedral_deg": float(np.nanmin(dihedral)) if not np.isnan(dihedral).all() else None,
        "max_dihedral_deg": float(np.nanmax(dihedral)) if not np.isnan(dihedral).all() else None,
        "well_centered_tet_fraction": float(well.mean()),
        "mesh_volume": float(np.abs(volume).sum()),
        "non_delaunay_face_fraction": None,
        "non_delaunay_tet_fraction": None,
        "n_non_delaunay_faces": None,
        "n_folded_faces": None,
        "n_folded_tets": None,
        "folded_tets": [],
        "n_folded_vertices": None,
        "folded_vertices": [],
    }
    if in_r3:
        folds = _folds(V, T, interior, sign)
        tets = np.flatnonzero(_folded_tets(T, interior, folds, volume, sign))
        vertices = _fold_vertices(T, interior, folds)
        result.update(n_folded_faces=int(folds.sum()), n_folded_tets=len(tets),
                      folded_tets=tets[:LISTED].tolist(), n_folded_vertices=len(vertices),
                      folded_vertices=vertices[:LISTED].tolist())
        flags = _core.non_delaunay(V, T, interior, float(rtol))
        bad = np.zeros(len(T), dtype=bool)
        bad[interior[flags][:, [0, 2]].ravel()] = True
        result["n_non_delaunay_faces"] = int(flags.sum())
        result["non_delaunay_face_fraction"] = float(flags.mean()) if len(flags) else 0.0
        result["non_delaunay_tet_fraction"] = float(bad.mean())
    return result, on_boundary
