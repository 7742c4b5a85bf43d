"""The local regularity condition of every interior face, affine in the vertex weights.

For the interior face ``abc`` of the tets ``abcp`` (the first) and ``abcq``, the *margin*
is the signed length of the face's power-diagram edge, from the power centre of the first
tet to that of the second, measured along the face normal towards the second, over the
face's RMS edge length. It is ``> 0`` exactly when the lifted ``q`` lies above the plane
of the lifted ``a, b, c, p`` (lifting ``x -> (x, |x|^2 - w)``): the face is *locally
regular* (for ``w = 0``, locally Delaunay). Scale-free (rigid motions; ``V -> s V, w -> s^2
w``) and affine in ``w``, five weights entering it; it vanishes for ``w = |x|^2`` (a flat
lifting). A *folded* face (both tets on one side of it, as around an inverted tet) has two
conditions, one per tet, of opposite signs for every ``w``.

The conditions are computed by the core (``tetlap._core.regular_conditions``: every face
in its own frame, in parallel), with the mesh's face table.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import _arrays, _core
from ..errors import DegenerateElementError, NonFiniteError, ShapeError
from .verify import exact_orientation
from .._names import public_dir

__all__ = ["Conditions", "face_margins"]
__dir__ = public_dir(globals())


def _validated(V, T):
    """``V`` (n, 3) float64 and ``T`` (m, 4) int64 (the core checks indices, finiteness
    and repeated corners when it computes the conditions)."""
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise ShapeError(f"regular weights need points in R^3, got V of shape {V.shape}")
    return V, T


def _face_vertices(T: np.ndarray, tets: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(k, 3) the vertices of the face of every tet ``tets`` opposite ``corners``, in the
    tet's order."""
    keep = np.arange(4)[None, :] != corners[:, None]
    return T[tets][keep].reshape(-1, 3)


@dataclasses.dataclass(frozen=True)
class Conditions:
    """Every interior face's margin as ``g(w) = g0 + sum_k coefficients[:, k] w[vertices[:, k]]``.

    Row ``f < n_faces`` is interior face ``f`` seen from its first tet; the rows after those
    are the folded faces seen from their second tet (``face`` says whose).

    Attributes
    ----------
    vertices : (c, 5) int64, the first tet's corners in its order, then the opposite vertex.
    g0 : (c,) float64, the margins at ``w = 0``.
    coefficients : (c, 5) float64, ``d margin / d w`` (units 1 / length^2).
    face : (c,) int64, the interior face of every row.
    interior : (f, 4) int64, the face table ``[tet, corner, tet, corner]`` (order of
        :func:`tetlap.diagnostics.interior_faces`).
    triangles : (f, 3) int64, the vertices of every interior face.
    folded : (f,) bool.
    nonmanifold : (k, 3) int64, faces of more than two tets (sorted vertex triples).
    on_boundary : (n,) bool, vertices on a boundary face.
    """

    vertices: np.ndarray
    g0: np.ndarray
    coefficients: np.ndarray
    face: np.ndarray
    interior: np.ndarray
    triangles: np.ndarray
    folded: np.ndarray
    nonmanifold: np.ndarray
    on_boundary: np.ndarray

    @property
    def n_faces(self) -> int:
        return len(self.interior)

    @classmethod
    def of(cls, V: np.ndarray, T: np.ndarray, threads: int | None = None) -> Conditions:
        """The conditions of a validated mesh (``V`` (n, 3) float64, ``T`` (m, 4) int64).

        Raises :class:`tetlap.DegenerateElementError` naming the first interior face with an
        exactly flat tet (it has no power centre; a needle or a sliver is computed exactly
        instead), :class:`tetlap.NonFiniteError` the first whose margin row leaves the
        float64 range."""
        c = _core.regular_conditions(V, T, options={"threads": threads})
        interior = c["interior"]
        triangles = _face_vertices(T, interior[:, 0], interior[:, 1])
        if len(c["flat"]):
            f = int(c["flat"][0])
            pair = [int(interior[f, 0]), int(interior[f, 2])]
            flat = next(t for t in pair if exact_orientation(V, T[t]) == 0)
            raise DegenerateElementError(
                f"tet {flat} is flat (zero volume, exactly): the interior face "
                f"{triangles[f].tolist()} between tets {pair[0]} and {pair[1]} has no power "
                "centre on that side, and regularity needs tets of non-zero volume",
                element=flat)
        if len(c["beyond_range"]):
            f = int(c["beyond_range"][0])
            raise NonFiniteError(
                f"the margin of the interior face {triangles[f].tolist()} between tets "
                f"{int(interior[f, 0])} and {int(interior[f, 2])} or its derivatives leave the "
                "float64 range (a needle or sliver beyond it): rescale or repair the mesh")
        on_boundary = np.zeros(len(V), dtype=bool)
        boundary = c["boundary"]
        on_boundary[_face_vertices(T, boundary[:, 0], boundary[:, 1]).ravel()] = True
        return cls(vertices=c["vertices"], g0=c["g0"], coefficients=c["coefficients"],
                   face=c["face"], interior=interior, triangles=triangles,
                   folded=c["folded"], nonmanifold=c["nonmanifold"], on_boundary=on_boundary)

    def margins(self, w: np.ndarray) -> np.ndarray:
        """(c,) every row's margin for the weights ``w`` (n,)."""
        return self.g0 + np.einsum("ck,ck->c", self.coefficients, w[self.vertices])

    def per_face(self, values: np.ndarray) -> np.ndarray:
        """(f,) per interior face, the smaller of its rows' ``values`` (c,)."""
        out = values[:self.n_faces].copy()
        np.minimum.at(out, self.face[self.n_faces:], values[self.n_faces:])
        return out


def face_margins(V, T, weights=None) -> np.ndarray:
    """The margin of every interior face for the weights (``None``: zeros).

    Parameters
    ----------
    V : (n, 3) array-like.  T : (m, 4) integer array-like, any orientation.
    weights : optional (n,) vertex weights, squared-length units (larger: a bigger power
        cell), as ``weights=`` of :func:`tetlap.laplacian`.

    Returns
    -------
    (f,) float64 in the order of :func:`tetlap.diagnostics.interior_faces`: the signed
    power-diagram edge over the face's RMS edge length (module docstring); negative:
    locally non-regular. A folded face gets the smaller of its two (opposite) margins.

    Example
    -------
    >>> import tetlap
    >>> from tetlap.regular import face_margins
    >>> V, T = tetlap.meshes.ball(300, seed=1)        # Delaunay: all margins > 0
    >>> bool(face_margins(V, T).min() > 0)
    True
    """
    V, T = _validated(V, T)
    w = _arrays.vertex_weights(weights, len(V))
    if w is not None and not np.isfinite(w).all():
        i = int(np.flatnonzero(~np.isfinite(w))[0])
        raise NonFiniteError(f"vertex {i} has a non-finite weight {w[i]}", vertex=i)
    cond = Conditions.of(V, T)
    return cond.per_face(cond.margins(np.zeros(len(V)) if w is None else w))
