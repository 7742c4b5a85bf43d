"""DualGeometry.dual_faces: the face-to-neighbour table of the dual cells that a two-point
flux (TPFA) finite-volume code uses, checked against the dual Laplacian, scipy's Voronoi
diagram (qhull), the cotangent formula of the boundary pieces, closed cells and linear
exactness."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from conftest import corpus_mesh
from test_dual import small_weights


def meshes():
    yield "ball", tetlap.meshes.ball(400, seed=4)
    yield "jittered cube", tetlap.meshes.cube(3, jitter=0.2, seed=1)
    yield "non-Delaunay", tetlap.meshes.weighted_ball(300, 0.5, seed=3)
    yield "Kuhn", tetlap.meshes.cube(3)


MESHES = [pytest.param(V, T, w, id=f"{name}-{'weighted' if w else 'plain'}")
          for name, (V, T) in meshes() for w in (False, True)]


def tpfa(f, n):
    """The two-point flux matrix of the table's interior rows: the balance of each control
    volume, sum over its faces of transmissibility * (u_j - u_i)."""
    inner = ~f.boundary
    i, j = f.vertices[inner].T
    t = f.transmissibility[inner]
    return sp.coo_array((np.r_[t, t, -t, -t], (np.r_[i, j, i, j], np.r_[j, i, i, j])),
                        shape=(n, n)).tocsr()


def closure(f, n):
    """(n, 3): the sum of each cell's outward vector areas over the table's rows."""
    out = np.zeros((n, f.normal.shape[1]))
    vector = f.area[:, None] * f.normal
    np.add.at(out, f.vertices[:, 0], vector)
    inner = ~f.boundary
    np.add.at(out, f.vertices[inner, 1], -vector[inner])
    return out


@pytest.mark.parametrize("V,T,weighted", MESHES)
def test_shapes_dtypes_signs_and_links(V, T, weighted):
    w = small_weights(V, T) if weighted else None
    g = tetlap.dual_geometry(V, T, weights=w)
    f = g.dual_faces
    E, b = len(g.edges), np.flatnonzero(g.boundary_faces)
    K = E + 3 * len(b)
    assert len(f) == K
    for name, shape, dtype in [("vertices", (K, 2), np.int64), ("area", (K,), np.float64),
                               ("normal", (K, 3), np.float64), ("centroid", (K, 3), np.float64),
                               ("transmissibility", (K,), np.float64), ("edge", (K,), np.int64),
                               ("face", (K,), np.int64)]:
        a = getattr(f, name)
        assert a.shape == shape and a.dtype == dtype, name
        assert np.isfinite(a).all(), name
    np.testing.assert_array_equal(f.vertices[:E], g.edges)       # row k: edge k
    np.testing.assert_array_equal(f.edge, np.r_[np.arange(E), np.full(3 * len(b), -1)])
    np.testing.assert_array_equal(f.face, np.r_[np.full(E, -1), np.repeat(b, 3)])
    np.testing.assert_array_equal(f.vertices[E:, 0], g.faces[b].ravel())
    assert (f.vertices[E:, 1] == -1).all() and (f.boundary == (np.arange(K) >= E)).all()
    np.testing.assert_array_equal(f.area[:E], g.dual_area)          # bit for bit
    np.testing.assert_array_equal(f.transmissibility[:E], g.transmissibility)
    assert (f.transmissibility[E:] == 0).all()
    np.testing.assert_allclose(np.linalg.norm(f.normal, axis=1), 1, rtol=1e-14)
    edge = V[g.edges[:, 1]] - V[g.edges[:, 0]]
    np.testing.assert_allclose(f.normal[:E], edge / g.edge_length[:, None], rtol=0, atol=1e-15)
    # boundary normals point out: away from the fourth corner of the face's tet
    t = g.face_tets[b, 0]
    fourth = T[t, np.argmax(g.tet_faces[t] == b[:, None], axis=1)]
    assert (np.einsum("ij,ij->i", np.repeat(V[fourth] - V[g.faces[b, 0]], 3, axis=0),
                      f.normal[E:]) < 0).all()
    assert "faces" in repr(f) and f"{len(b) * 3} on the boundary" in repr(f)


@pytest.mark.parametrize("V,T,weighted", MESHES)
def test_tpfa_over_the_table_is_the_dual_laplacian_and_the_cells_close(V, T, weighted):
    """The flux balance over the interior rows is the dual Laplacian; with the boundary
    rows every cell's outward vector areas sum to zero, so a linear u is exact: L u plus
    the boundary's area * (grad u . n) vanishes at every vertex."""
    w = small_weights(V, T) if weighted else None
    f = tetlap.dual_geometry(V, T, weights=w).dual_faces
    L = tetlap.laplacian(V, T, "dual", weights=w)
    A = tpfa(f, len(V))
    scale = abs(L).max()
    assert abs(A - L).max() <= 1e-14 * scale
    D = (A - L).tocoo()
    off = D.data != 0
    assert (D.row[off] == D.col[off]).all()      # the couplings bit for bit; sums to rounding
    assert np.abs(closure(f, len(V))).max() <= 1e-14 * np.abs(f.area).max()
    grad = np.array([0.3, -1.2, 0.7])
    u = V @ grad + 2.0
    b = f.boundary
    flux = np.bincount(f.vertices[b, 0], f.area[b] * (f.normal[b] @ grad), len(V))
    np.testing.assert_allclose(L @ u + flux, 0, atol=1e-13 * scale)


def test_on_delaunay_meshes_the_interior_faces_are_scipy_s_voronoi_ridges():
    """An independent route: qhull's Voronoi diagram of the ball's points. Every interior
    edge of the (Delaunay) ball is a Voronoi ridge; its polygon's area and centroid (a fan
    of the ridge's vertices sorted by angle: the ridge is convex) are the table's."""
    from scipy.spatial import Voronoi

    V, T = tetlap.meshes.ball(500, seed=2)
    g = tetlap.dual_geometry(V, T)
    f = g.dual_faces
    boundary = tetlap.diagnostics.boundary_vertices(V, T)
    vor = Voronoi(V)
    ridges = {tuple(sorted(p)): r for p, r in zip(vor.ridge_points.tolist(), vor.ridge_vertices)}
    checked = 0
    for k, (i, j) in enumerate(g.edges.tolist()):
        if boundary[i] or boundary[j] or -1 in ridges[(i, j)]:
            continue
        P = vor.vertices[ridges[(i, j)]]
        n = f.normal[k]
        c = P.mean(axis=0)
        x = P - c
        e1 = x[0] / np.linalg.norm(x[0])
        e2 = np.cross(n, e1)
        P = P[np.argsort(np.arctan2(x @ e2, x @ e1))]
        tri = [(P[0], P[m], P[m + 1]) for m in range(1, len(P) - 1)]
        areas = np.array([np.cross(q - p, r - p) @ n / 2 for p, q, r in tri])
        centroid = sum(a * (p + q + r) / 3 for a, (p, q, r) in zip(areas, tri)) / areas.sum()
        np.testing.assert_allclose(f.area[k], areas.sum(), rtol=1e-9, atol=1e-13)
        if areas.sum() > 1e-6:  # qhull's and tetlap's centres of slivers differ by 1e-9
            np.testing.assert_allclose(f.centroid[k], centroid, rtol=0, atol=1e-11)
            checked += 1
    assert checked > 500


@pytest.mark.parametrize("weighted", [False, True])
def test_boundary_rows_are_the_cotangent_pieces(weighted):
    """Per boundary vertex the rows' flux of a constant gradient is
    ``solve.dual_boundary_areas`` (the cotangent formula of the circumcentric pieces);
    weighted, the pieces of every face still tile it."""
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    w = small_weights(V, T) if weighted else None
    g = tetlap.dual_geometry(V, T, weights=w)
    f = g.dual_faces
    b = f.boundary
    grad = np.array([0.2, 1.0, -0.5])
    flux = np.bincount(f.vertices[b, 0], f.area[b] * (f.normal[b] @ grad), len(V))
    if not weighted:
        np.testing.assert_allclose(flux, tetlap.solve.dual_boundary_areas(V, T, grad),
                                   rtol=0, atol=1e-15)
    per_face = f.area[b].reshape(-1, 3).sum(axis=1)
    np.testing.assert_allclose(per_face, g.face_area[g.boundary_faces], rtol=1e-13)


def test_the_pieces_of_one_right_tet_by_hand():
    """The face (0, 1, 2) of the right tet at the origin, in the plane z = 0: its centre is
    (1/2, 1/2, 0); corner 0 gets the square of side 1/2, corner 1 the triangle (1, 0),
    (1/2, 1/2), (1/2, 0)."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    g = tetlap.dual_geometry(V, [[0, 1, 2, 3]])
    f = g.dual_faces
    rows = np.flatnonzero(f.face == 0)           # face (0, 1, 2): the first sorted face
    assert g.faces[0].tolist() == [0, 1, 2]
    np.testing.assert_allclose(f.area[rows], [0.25, 0.125, 0.125], rtol=1e-15)
    np.testing.assert_allclose(f.centroid[rows], [[0.25, 0.25, 0], [2 / 3, 1 / 6, 0],
                                                  [1 / 6, 2 / 3, 0]], atol=1e-15)
    np.testing.assert_allclose(f.normal[rows], np.tile([0, 0, -1.0], (3, 1)), atol=1e-15)


def test_faces_of_zero_area_have_a_finite_centroid_on_their_plane():
    """Kuhn grids: the tets of each cube share one circumcentre, and the faces of the
    diagonals have zero area: their centroid is the mean of the points that span them, not
    a division by zero."""
    V, T = tetlap.meshes.cube(2)
    g = tetlap.dual_geometry(V, T)
    f = g.dual_faces
    zero = np.abs(f.area[:len(g.edges)]) < 1e-14
    assert zero.any()
    c = f.centroid[:len(g.edges)]
    mid = (V[g.edges[:, 0]] + V[g.edges[:, 1]]) / 2
    assert np.isfinite(c).all()
    # on the bisector plane of its edge
    np.testing.assert_allclose(np.einsum("ij,ij->i", c - mid, f.normal[:len(g.edges)]), 0,
                               atol=1e-15)


def test_the_same_bits_for_any_thread_count_and_scale_by_powers_of_two():
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=5)
    w = small_weights(V, T)
    tables = [tetlap.dual_geometry(V, T, weights=w, threads=k).dual_faces for k in (1, 2, 4)]
    for field in dataclasses.fields(tetlap.dual.DualFaces):
        for other in tables[1:]:
            np.testing.assert_array_equal(getattr(tables[0], field.name),
                                          getattr(other, field.name))
    f = tables[0]
    for k in (-300, -100, 100, 300):
        s = 2.0**k
        h = tetlap.dual_geometry(V * s, T, weights=w * s * s).dual_faces
        np.testing.assert_array_equal(h.area, f.area * s * s)
        np.testing.assert_array_equal(h.centroid, f.centroid * s)
        np.testing.assert_array_equal(h.normal, f.normal)


def test_an_immersed_mesh_has_its_table():
    """Tets of the 3-sphere in R^4: the flux balance is the dual Laplacian, and the
    centroids' weights (the pieces' areas, in each tet's oriented 3-space) are the dual
    areas."""
    V, T = tetlap.meshes.sphere3(200, seed=2)
    f = tetlap.dual_geometry(V, T).dual_faces
    assert f.normal.shape[1] == 4 and f.centroid.shape[1] == 4 and f.boundary.sum() == 0
    L = tetlap.laplacian(V, T, "dual")
    assert abs(tpfa(f, len(V)) - L).max() <= 1e-14 * abs(L).max()
    assert np.isfinite(f.centroid).all()
    # the pieces' signed areas, each in its tet's oriented 3-space, add up to the core's
    # dual areas: the weights of the centroids are right
    from tetlap import _dual_faces as D

    g = tetlap.dual_geometry(V, T)
    arc = D.arcs(T, g.orientation, g.edges, g.tet_faces, len(V))
    c_e = D.edge_points(V, g.edges, None)[arc.edge]
    frame = D.frames(V, T)
    d_in, d_t, d_out = (X - c_e for X in (g.face_centres[arc.into], g.centres[arc.tet],
                                          g.face_centres[arc.out]))
    pieces = (D.det(d_in, d_t, f.normal[arc.edge], frame, arc.tet)
              + D.det(d_t, d_out, f.normal[arc.edge], frame, arc.tet)) / 2
    np.testing.assert_allclose(np.bincount(arc.edge, pieces), g.dual_area, rtol=0,
                               atol=1e-13 * np.abs(g.dual_area).max())


def test_a_nearly_delaunay_corpus_mesh():
    V, T = corpus_mesh("sofa_armadillo_4406.vtu")
    f = tetlap.dual_geometry(V, T).dual_faces
    L = tetlap.laplacian(V, T, "dual")
    assert abs(tpfa(f, len(V)) - L).max() <= 1e-13 * abs(L).max()
    assert np.abs(closure(f, len(V))).max() <= 1e-13 * np.abs(f.area).max()
