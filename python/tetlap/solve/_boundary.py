"""Boundary data of the Neumann problems: the integrated normal flux per vertex, for the
dual (:func:`dual_boundary_areas`) and for the primal (:func:`fem_boundary_areas`).

Every boundary face is computed in its own frame, as the operators' kernels compute a
tet: its sides are divided by the power of two that brings their largest component into
``[1/2, 1)``, and its areas multiplied back by its square (both exact), so that the areas
of faces of 1e-150 or 1e150 neither underflow nor overflow. Normals point out of the
mesh whatever the orientation of the face's tet.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import _arrays, _float_range, diagnostics
from ..errors import DegenerateElementError, NonFiniteError, ShapeError


class Faces(NamedTuple):
    """The boundary faces of a mesh and their geometry, in the user's units."""

    faces: np.ndarray      # (F, 3) int64, as diagnostics.boundary_faces orders them
    tets: np.ndarray       # (F,) the tet of each face
    corners: np.ndarray    # (F,) the corner of that tet opposite the face
    normals: np.ndarray    # (F, 3) outward unit normals
    circumcentric: np.ndarray  # (F, 3) per corner, the signed circumcentric area piece
    area: np.ndarray       # (F,) the face's area


def frame_exponents(D: np.ndarray) -> np.ndarray:
    """Per element, the power of two ``2^s`` that brings the largest component of its
    difference vectors ``D`` (k, ..., 3) into ``[1/2, 1)`` (``s = 0`` for all-zero ones):
    the frame rule of the operators' kernels."""
    largest = np.abs(D).reshape(len(D), -1).max(axis=1) if D.size else np.zeros(len(D))
    return np.frexp(np.where(largest > 0, largest, 1.0))[1]


def boundary(V: np.ndarray, T: np.ndarray) -> Faces:
    """:class:`Faces` of the mesh ``V`` (n, 3) float64, ``T`` (m, 4) int64 (checked): each
    face in its own power-of-two frame (exact), so that areas from ``1e-150`` to
    ``1e150`` are right to rounding. A face of zero area is a
    :class:`tetlap.DegenerateElementError` naming its tet, as is one whose area leaves
    the normal float64 range."""
    bf, tets, corners = diagnostics.boundary_faces(T, return_tets=True)
    P = V[bf]
    sides = np.stack([P[:, (k + 1) % 3] - P[:, k] for k in range(3)], axis=1)  # (F, 3, 3)
    s = frame_exponents(sides)
    D = np.ldexp(sides, -s[:, None, None])
    cross = np.cross(D[:, 0], -D[:, 2])               # (x1 - x0) x (x2 - x0), scaled
    twice = np.linalg.norm(cross, axis=1)
    if not (twice > 0).all():
        t = int(tets[np.argmin(twice > 0)])
        raise DegenerateElementError(f"element {t} has a boundary face of zero area",
                                     element=t)
    # outward: away from the tet's opposite corner (a face is oriented like its tet, so a
    # negatively oriented tet's faces point in), in the face's frame
    with np.errstate(over="ignore"):
        away = np.ldexp(P[:, 0] - V[T[tets, corners]], -s[:, None])
    sign = np.sign(np.einsum("ij,ij->i", cross, away))
    if not sign.all():
        t = int(tets[np.argmin(sign != 0)])
        raise DegenerateElementError(f"element {t} is flat: its boundary face has no "
                                     "outward side", element=t)
    normals = cross / twice[:, None] * sign[:, None]
    # circumcentric piece of corner a: triangles (x_a, c_ab, c) and (x_a, c_ac, c), signed
    # area = (|ab|^2 cot(angle at c) + |ac|^2 cot(angle at b)) / 8
    cot = np.empty((len(bf), 3))
    for k in range(3):
        u, w = D[:, k], -D[:, (k + 2) % 3]
        cot[:, k] = np.einsum("ij,ij->i", u, w) / np.linalg.norm(np.cross(u, w), axis=1)
    sq = np.einsum("fkd,fkd->fk", D, D)               # |x_(k+1) - x_k|^2, scaled
    circ = np.stack([(sq[:, 0] * cot[:, 2] + sq[:, 2] * cot[:, 1]) / 8,
                     (sq[:, 0] * cot[:, 2] + sq[:, 1] * cot[:, 0]) / 8,
                     (sq[:, 2] * cot[:, 1] + sq[:, 1] * cot[:, 0]) / 8], axis=1)
    with np.errstate(over="ignore"):
        area = np.ldexp(twice / 2, 2 * s)
    outside = ~(area <= _float_range.LARGEST) | (area < _float_range.SMALLEST)
    if outside.any():
        k = int(np.argmax(outside))
        size = (f"above {_float_range.LARGEST:.3g}" if area[k] > 1 else
                f"below {_float_range.SMALLEST:.3g}")
        raise DegenerateElementError(
            f"element {int(tets[k])} has a boundary face of area {size}, beyond the normal "
            f"float64 range: rescale the mesh (faces of unit shape allow coordinates from "
            f"about 1e-150 to 1e150)", element=int(tets[k]))
    return Faces(bf, tets, corners, normals, np.ldexp(circ, 2 * s[:, None]), area)


def _geometry(V, T, normal_derivative):
    """``(V, T)`` arrays (or those of one mesh object passed as ``V``), checked."""
    if normal_derivative is None:
        raise TypeError("normal_derivative is missing: a constant gradient (3,) or a callable")
    V, T = _arrays.mesh(V, T)
    V, T = _arrays.points(V), _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise ShapeError(f"V must have shape (n, 3): boundary normals need 3-space, got {V.shape}")
    _arrays.used_vertices(V, T)     # indices in range, coordinates finite (of any vertex)
    return V, T


def _flux(V, T, normal_derivative, which: int) -> np.ndarray:
    V, T = _geometry(V, T, normal_derivative)
    b = boundary(V, T)
    area = b.circumcentric if which == 0 else np.repeat(b.area[:, None] / 3, 3, axis=1)
    n = len(V)
    if callable(normal_derivative):
        # one quadrature point per corner piece: its own corner's sub-region centroid
        P = V[b.faces]
        centroid = P.mean(axis=1)
        values = np.stack([_arrays.vector(normal_derivative((P[:, k] + centroid) / 2, b.normals),
                                          len(b.faces), "normal_derivative(...)")
                           for k in range(3)], axis=1)
    else:
        grad = _arrays.vector(normal_derivative, 3, "normal_derivative (a constant gradient)")
        values = np.repeat((b.normals @ grad)[:, None], 3, axis=1)
    with np.errstate(over="ignore", invalid="ignore"):
        g = np.bincount(b.faces.ravel(), weights=(area * values).ravel(), minlength=n)
    if not np.isfinite(g).all():
        v = int(np.argmin(np.isfinite(g)))
        raise NonFiniteError(f"the flux of vertex {v} leaves the float64 range (the normal "
                             "derivative times the face areas); scale them down", vertex=v)
    return g


@_arrays.takes_mesh_object
def dual_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """Integrated normal flux ``g`` per vertex for the dual Neumann problem ``L f = -g``.

    Each boundary face is split into the circumcentric pieces of its corners (signed, the
    faces that close the dual cells of boundary vertices); ``normal_derivative`` is a
    constant gradient (3,) (exact) or a callable ``(points (k, 3), normals (k, 3)) ->
    (k,)`` evaluated once per piece (outward unit normals). Returns (n,) float64, zero at
    interior vertices and at vertices in no tet; in the units of the mesh and the data
    at any scale (each face is computed in its own power-of-two frame: coordinates from
    1e-150 to 1e150).

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> g = tetlap.solve.dual_boundary_areas(V, T, [1.0, 0.0, 0.0])
    >>> float(g.sum()), float(g[V[:, 0] == 1].sum())      # the flux of x: 1 out, 1 in
    (0.0, 1.0)
    """
    return _flux(V, T, normal_derivative, 0)


@_arrays.takes_mesh_object
def fem_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """The P1 boundary load ``g_i = int_boundary (n . grad u) phi_i``: the natural Neumann
    condition of the primal (each face's flux shared equally by its corners). Arguments,
    units and scales as :func:`dual_boundary_areas`."""
    return _flux(V, T, normal_derivative, 1)
