"""Textbook regular and non-regular triangulations for the tests of tetlap.regular, with an
oracle independent of its search: one dense LP on the face margins.

Imported by the other test_regular_*.py files; the tests here check the examples against
the oracle, so that the cases the other tests rely on are what they claim to be.
"""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.regular import face_margins


def best_margin(V, T, box: float = 10.0) -> float:
    """The largest smallest face margin over all weights ``|w_i| <= box`` (in squared
    units of the mesh, which is O(1) here), capped at 1: one dense LP whose rows are the
    margins, linear in ``w``, evaluated at the unit weights. Positive exactly when some
    weights make every face strictly locally regular (the box only bounds how large)."""
    from scipy.optimize import linprog

    n = len(V)
    g0 = face_margins(V, T)
    G = np.column_stack([face_margins(V, T, np.eye(n)[i]) - g0 for i in range(n)])
    c = np.zeros(n + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=np.hstack([-G, np.ones((len(g0), 1))]), b_ub=g0,
                  bounds=[(-box, box)] * n + [(None, 1.0)])
    return float(res.x[-1])


def mother(twist: float = 0.0, apexes: int = 1):
    """The "mother of all examples" (De Loera, Rambau, Santos, *Triangulations*, 2.2): an
    outer triangle, the inner one homothetic (factor 1/2) about the outer's circumcentre,
    the three trapezoids between them split by the rotational choice of diagonals, coned to
    an apex above (and one below with ``apexes=2``). Exact binary coordinates: the
    trapezoids are isosceles, so cocircular, and every diagonal face has margin exactly 0 at
    ``w = 0``. Untwisted it is not regular; the inner triangle rotated by ``twist``
    radians makes it Delaunay (``twist < 0``) or keeps it non-regular (``twist > 0``)."""
    centre = np.array([0.0, -1.0])
    outer = np.array([[0.0, 4.0], [-4.0, -4.0], [4.0, -4.0]])
    inner = centre + (outer - centre) / 2
    c, s = np.cos(twist), np.sin(twist)
    inner = centre + (inner - centre) @ np.array([[c, s], [-s, c]])
    tris = [[3, 4, 5]]
    for k in range(3):
        tris += [[k, (k + 1) % 3, 3 + (k + 1) % 3], [k, 3 + (k + 1) % 3, 3 + k]]
    plane = np.column_stack([np.vstack([outer, inner]), np.zeros(6)])
    V = np.vstack([plane, [[0.0, -1.0, 4.0], [0.0, -1.0, -4.0]][:apexes]])
    T = [t + [6] for t in tris] + ([t + [7] for t in tris] if apexes == 2 else [])
    return V, tetlap.meshes.orient(V, np.array(T))


def twisted_prism(twist: float):
    """A triangular prism whose top is rotated by ``twist`` radians, its three side
    quadrilaterals split by diagonals of one rotational sense, coned from the centre: for
    ``twist > 0`` the diagonals are reflex edges (Schönhardt's polyhedron, which has no
    triangulation without an inner point) and the cone is not regular; for ``twist < 0``
    the polyhedron is convex and the cone is regular."""
    a = np.radians([90.0, 210.0, 330.0])
    bottom = np.column_stack([np.cos(a), np.sin(a), np.zeros(3)])
    top = np.column_stack([np.cos(a + twist), np.sin(a + twist), np.ones(3)])
    V = np.vstack([bottom, top, [[0.0, 0.0, 0.5]]])
    faces = [[0, 1, 2], [3, 4, 5]]
    for i in range(3):
        j = (i + 1) % 3
        faces += [[i, j, 3 + j], [i, 3 + j, 3 + i]]
    return V, tetlap.meshes.orient(V, np.array([f + [6] for f in faces]))


def three_on_a_face():
    """Three tets on the face 012: 0123 and 0125 on the same side of it (they overlap),
    0124 on the other."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 1], [0.2, 0.2, -1],
                  [0.3, 0.3, 0.5]], dtype=float)
    return V, np.array([[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]])


def weighted_points(seed: int, n: int = 80, scale: float = 0.05):
    """A regular triangulation of random weighted points in a cube, hull slivers kept:
    ``(V, T, w)`` with the generating weights."""
    rng = np.random.default_rng(seed)
    P = rng.uniform(-1, 1, size=(n, 3))
    w = rng.uniform(0, scale, size=n)
    T = tetlap.meshes.regular_triangulation(P, w)
    return tetlap.meshes.compact(P, T, w)


@pytest.mark.parametrize("twist, regular", [(0.0, False), (1e-6, False), (0.1, False),
                                            (-1e-6, True), (-0.1, True)])
def test_the_mother_of_all_examples_is_what_it_claims(twist, regular):
    V, T = mother(twist)
    assert (best_margin(V, T) > 1e-9) == regular
    if twist == 0.0:   # cospherical: the diagonal faces have margin exactly 0
        assert np.sort(np.abs(face_margins(V, T)))[:3].max() == 0.0


@pytest.mark.parametrize("twist, regular", [(0.3, False), (0.1, False), (-0.1, True),
                                            (-0.3, True)])
def test_twisted_prisms_are_what_they_claim(twist, regular):
    V, T = twisted_prism(twist)
    assert (tetlap.diagnostics.signed_volumes(V, T) > 0).all()    # a valid triangulation
    assert (best_margin(V, T) > 1e-9) == regular


def test_random_regular_triangulations_are_certified_by_their_weights():
    V, T, w = weighted_points(5)
    assert face_margins(V, T, w).min() > 0 > face_margins(V, T).min()
