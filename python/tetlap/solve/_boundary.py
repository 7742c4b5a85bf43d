"""Boundary data of the Neumann problems: the integrated normal flux per vertex, for the
dual (:func:`dual_boundary_areas`) and for the primal (:func:`fem_boundary_areas`)."""

from __future__ import annotations

import numpy as np

from .. import _arrays, diagnostics
from ..errors import DegenerateElementError


def _unit_normals(V, F, tets) -> np.ndarray:
    """Unit normals of the faces ``F``; a degenerate face (zero area) raises
    :class:`tetlap.DegenerateElementError` naming its tet."""
    n = diagnostics.face_normals(V, F)
    area = np.linalg.norm(n, axis=1)
    if not (area > 0).all():
        t = int(tets[np.argmin(area > 0)])
        raise DegenerateElementError(f"element {t} has a boundary face of zero area",
                                     element=t)
    return n / area[:, None]


def _geometry(V, T, normal_derivative):
    """``(V, T)`` arrays (or those of one mesh object passed as ``V``), checked."""
    if normal_derivative is None:
        raise TypeError("normal_derivative is missing: a constant gradient (3,) or a callable")
    V, T = _arrays.mesh(V, T)
    return _arrays.points(V), _arrays.elements(T, 4)


def _boundary_pieces(V, T):
    """Boundary faces (F, 3), outward unit normals, and per corner the circumcentric
    (signed) and the barycentric areas of the face."""
    bf, tets, _ = diagnostics.boundary_faces(T, return_tets=True)
    P = V[bf]
    unit = _unit_normals(V, bf, tets)
    area = np.linalg.norm(diagnostics.face_normals(V, bf), axis=1)
    # circumcentric piece of corner a: triangles (x_a, c_ab, c) and (x_a, c_ac, c), signed
    # area = (|ab|^2 cot(angle at c) + |ac|^2 cot(angle at b)) / 8
    cot = np.empty((len(bf), 3))
    for k in range(3):
        u, w = P[:, (k + 1) % 3] - P[:, k], P[:, (k + 2) % 3] - P[:, k]
        cot[:, k] = np.einsum("ij,ij->i", u, w) / np.linalg.norm(np.cross(u, w), axis=1)
    sq = lambda a, b: ((P[:, a] - P[:, b]) ** 2).sum(axis=1)
    circ = np.stack([(sq(0, 1) * cot[:, 2] + sq(0, 2) * cot[:, 1]) / 8,
                     (sq(1, 0) * cot[:, 2] + sq(1, 2) * cot[:, 0]) / 8,
                     (sq(2, 0) * cot[:, 1] + sq(2, 1) * cot[:, 0]) / 8], axis=1)
    return bf, unit, circ, np.repeat(area[:, None] / 3, 3, axis=1), P


def _flux(V, T, normal_derivative, which: int) -> np.ndarray:
    V, T = _geometry(V, T, normal_derivative)
    bf, unit, circ, bary, P = _boundary_pieces(V, T)
    area = (circ, bary)[which]
    n = len(V)
    if callable(normal_derivative):
        # one quadrature point per corner piece: its own corner's sub-region centroid
        centroid = P.mean(axis=1)
        values = np.stack([_arrays.vector(normal_derivative((P[:, k] + centroid) / 2, unit),
                                          len(bf), "normal_derivative(...)") for k in range(3)],
                          axis=1)
    else:
        grad = _arrays.vector(normal_derivative, 3, "normal_derivative (a constant gradient)")
        values = np.repeat((unit @ grad)[:, None], 3, axis=1)
    return np.bincount(bf.ravel(), weights=(area * values).ravel(), minlength=n)


@_arrays.takes_mesh_object
def dual_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """Integrated normal flux ``g`` per vertex for the dual Neumann problem ``L f = -g``.

    Each boundary face is split into the circumcentric pieces of its corners (signed, the
    faces that close the dual cells of boundary vertices); ``normal_derivative`` is a
    constant gradient (3,) (exact) or a callable ``(points (k, 3), normals (k, 3)) ->
    (k,)`` evaluated once per piece. Returns (n,), zero at interior vertices.
    """
    return _flux(V, T, normal_derivative, 0)


@_arrays.takes_mesh_object
def fem_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """The P1 boundary load ``g_i = int_boundary (n . grad u) phi_i``: the natural Neumann
    condition of the primal (each face's flux shared equally by its corners)."""
    return _flux(V, T, normal_derivative, 1)
