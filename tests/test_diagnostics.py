"""Mesh diagnostics: boundary, orientation, dihedral angles, Delaunay, well-centeredness."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

import tetlap
from tetlap import diagnostics as d


def random_delaunay(n=300, seed=0):
    V = np.random.default_rng(seed).uniform(size=(n, 3))
    T = Delaunay(V).simplices
    return V, T[np.abs(d.signed_volumes(V, T)) > 1e-12]


def test_boundary_of_a_cube_grid():
    V, T = tetlap.meshes.cube(3)
    bf = d.boundary_faces(T)
    assert len(bf) == 6 * 2 * 3 * 3  # two triangles per boundary square
    on_boundary = np.any((V == 0) | (V == 1), axis=1)
    np.testing.assert_array_equal(d.boundary_vertices(T, len(V)), on_boundary)
    np.testing.assert_array_equal(d.interior_vertices(T, len(V)), ~on_boundary)
    # boundary faces are oriented outward for positively oriented tets
    centroid = V[bf].mean(axis=1)
    normal = np.cross(V[bf[:, 1]] - V[bf[:, 0]], V[bf[:, 2]] - V[bf[:, 0]])
    assert (np.einsum("ij,ij->i", normal, centroid - 0.5) > 0).all()
    tets, opposite = d.interior_faces(T)
    assert len(tets) == (4 * len(T) - len(bf)) // 2
    assert all(o not in T[t[0]] or o == T[t[1]][np.isin(T[t[1]], T[t[0]], invert=True)][0]
               for t, o in zip(tets[:50], opposite[:50, 1]))


def test_orientation_and_degenerate():
    V, T = tetlap.meshes.cube(2)
    T2 = T.copy()
    T2[::2, [2, 3]] = T2[::2, [3, 2]]
    o = d.orientation(V, T2)
    assert (o[::2] == -1).all() and (o[1::2] == 1).all()
    V3 = np.vstack([V, [[0.5, 0.5, 0.0]]])
    T3 = np.vstack([T, [[0, 6, 18, len(V)]]])  # flat: all on z = 0
    assert d.degenerate_tets(V3, T3).tolist() == [False] * len(T) + [True]


def test_dihedral_angles_of_known_tets():
    V, T = tetlap.meshes.single_tet("regular")
    np.testing.assert_allclose(d.dihedral_angles(V, T), np.degrees(np.arccos(1 / 3)), rtol=1e-12)
    V, T = tetlap.meshes.single_tet("corner")
    slanted = np.degrees(np.arccos(1 / np.sqrt(3)))
    np.testing.assert_allclose(d.dihedral_angles(V, T)[0], [90, 90, 90] + [slanted] * 3, atol=1e-12)
    # the six angles of any tet sum to between 2 pi and 3 pi
    V, T = tetlap.meshes.ball(300, seed=3)
    s = d.dihedral_angles(V, T).sum(axis=1)
    assert (s > 360 - 1e-9).all() and (s < 540 + 1e-9).all()


def test_delaunay_meshes_have_no_non_delaunay_faces_and_perturbed_ones_do():
    V, T = random_delaunay()
    assert d.non_delaunay_faces(V, T).sum() == 0
    V2 = V + np.random.default_rng(1).normal(scale=0.02, size=V.shape)
    assert d.non_delaunay_faces(V2, T).sum() > 0
    # orientation does not matter
    T3 = T.copy()
    T3[:, [0, 1]] = T3[:, [1, 0]]
    np.testing.assert_array_equal(d.non_delaunay_faces(V2, T3), d.non_delaunay_faces(V2, T))


def test_cospherical_kuhn_grid_is_delaunay_within_tolerance():
    V, T = tetlap.meshes.cube(3)
    assert d.non_delaunay_faces(V, T).sum() == 0
    assert d.non_delaunay_faces(V, T, rtol=-1.0).sum() > 0  # without tolerance: flagged


def test_non_delaunay_bipyramid():
    h = 0.1
    V = np.array([[1, 0, 0], [-0.5, 0.866, 0], [-0.5, -0.866, 0], [0, 0, h], [0, 0, -h]])
    # the apexes are close to the face: each lies in the other tet's huge circumsphere
    assert d.non_delaunay_faces(V, [[0, 1, 2, 3], [0, 1, 2, 4]]).sum() == 1
    assert d.non_delaunay_faces(V, [[3, 4, 0, 1], [3, 4, 1, 2], [3, 4, 2, 0]]).sum() == 0


def test_well_centered():
    V, T = tetlap.meshes.single_tet("regular")
    assert d.well_centered(V, T).all()
    V, T = tetlap.meshes.single_tet("corner")  # right angles: circumcenter on a face
    assert not d.well_centered(V, T).any()
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0.9, 0], [0.5, 0.3, 0.8]])
    assert d.well_centered(V, [[0, 1, 2, 3]]).all()


def test_dual_weights_of_well_centered_tets_are_positive():
    """A well-centered tet has all 24 circumcentric pieces positive."""
    rng = np.random.default_rng(5)
    V = rng.normal(size=(4000, 3))
    T = np.arange(4000).reshape(-1, 4)
    good = d.well_centered(V, T)
    assert 0 < good.sum() < len(T)
    W = tetlap.tet_contributions(V, T[good], "dual")
    assert (W > 0).all()
    M = np.array([tetlap.mass(V, [t], "circumcentric").diagonal()[t] for t in T[good][:50]])
    assert (M > 0).all()
