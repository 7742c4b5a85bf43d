"""tetlap.dual_geometry: the orthogonal dual as geometry, one code path with the dual
Laplacian and the circumcentric mass; exact rationals; bad input."""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np
import pytest

import tetlap
from exact_reference import (cross, dot, sub, tet_barycentric, tet_circumcenter,
                             triangle_circumcenter, vec)
from test_exact_rational import non_delaunay_mesh
from tetlap.dual import OUTSIDE_TOL

# Small integer meshes: two tets across a face, a mixed-orientation fan, and a
# non-Delaunay ball rounded to integers (centres outside, negative dual edges).
INTEGER_MESHES = {
    "pair": ([[0, 0, 0], [4, 0, 0], [0, 4, 0], [1, 1, 3], [3, 2, -2]], [[0, 1, 2, 3], [1, 0, 2, 4]]),
    "fan": ([[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [2, 2, 2], [-1, -1, 3]],
            [[0, 1, 2, 3], [4, 2, 1, 3], [0, 3, 2, 5], [1, 0, 3, 5]]),
    "non-Delaunay": non_delaunay_mesh(),
}


def small_weights(V, T, seed=0):
    """Random vertex weights of 1% of the squared mean edge length."""
    edges = tetlap.dual_geometry(V, T).edge_length
    return 0.01 * edges.mean() ** 2 * np.random.default_rng(seed).uniform(-1, 1, len(V))


def with_weights(mesh_list):
    """pytest params ``(V, T, w)``: every mesh plain (``w`` None) and with small weights."""
    return [pytest.param(V, T, small_weights(V, T) if weighted else None,
                         id=f"{name}-{'weighted' if weighted else 'plain'}")
            for name, (V, T) in mesh_list for weighted in (False, True)]


def meshes():
    yield "ball", tetlap.meshes.ball(400, seed=4)
    yield "jittered cube", tetlap.meshes.cube(3, jitter=0.2, seed=1)
    yield "non-Delaunay", tetlap.meshes.weighted_ball(300, 0.5, seed=3)


@pytest.mark.parametrize("V,T,w", with_weights(meshes()))
def test_edges_and_vertices_are_the_laplacian_and_the_mass(V, T, w):
    g = tetlap.dual_geometry(V, T, weights=w)
    edges, weight = tetlap.edge_weights(V, T, "dual", weights=w)
    np.testing.assert_array_equal(g.edges, edges)
    np.testing.assert_array_equal(g.transmissibility, weight)  # bit for bit
    M = tetlap.mass(V, T, "circumcentric", weights=w).diagonal()
    np.testing.assert_array_equal(g.control_volume, M)
    length = np.linalg.norm(V[edges[:, 1]] - V[edges[:, 0]], axis=1)
    np.testing.assert_allclose(g.edge_length, length, rtol=1e-15)
    np.testing.assert_allclose(g.dual_area / g.edge_length, weight, rtol=1e-14, atol=0)
    # the pyramid identity: a cell is the cones of its dual faces over the vertex, of
    # height the distance to the edge's (power) point
    tau = 0.5 if w is None else 0.5 + (w[edges[:, 0]] - w[edges[:, 1]]) / (2 * length**2)
    height = np.column_stack([tau * length, (1 - tau) * length])
    cones = np.bincount(edges.ravel(), (g.dual_area[:, None] * height / 3).ravel(), len(V))
    np.testing.assert_allclose(cones, M, rtol=1e-12, atol=1e-14 * np.abs(M).max())


@pytest.mark.parametrize("V,T,w", with_weights(meshes()))
def test_centres_faces_and_dual_edges_are_orthogonal(V, T, w):
    g = tetlap.dual_geometry(V, T, weights=w)
    w = np.zeros(len(V)) if w is None else w
    # every centre has equal power to its corners
    power = np.sum((g.centres[:, None] - V[T]) ** 2, axis=2) - w[T]
    size = np.sum((g.centres - V[T[:, 0]]) ** 2, axis=1)
    assert (np.abs(power - power[:, :1]) <= 1e-10 * size[:, None]).all()
    np.testing.assert_allclose(np.einsum("tk,tkc->tc", g.barycentric, V[T]), g.centres,
                               atol=1e-9 * np.abs(g.centres).max())
    np.testing.assert_array_equal(g.outside, (g.barycentric < -OUTSIDE_TOL).any(axis=1))
    # the face topology: tet_faces and face_tets agree, faces sorted
    F = g.faces
    assert (F[:, 0] < F[:, 1]).all() and (F[:, 1] < F[:, 2]).all()
    assert (np.lexsort(F.T[::-1]) == np.arange(len(F))).all()
    for l, corners in enumerate([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]):
        np.testing.assert_array_equal(F[g.tet_faces[:, l]], np.sort(T[:, corners], axis=1))
        assert (g.face_tets[g.tet_faces[:, l]] == np.arange(len(T))[:, None]).any(axis=1).all()
    # interior faces: the dual edge is the segment between the centres, along the normal
    inner = ~g.boundary_faces
    s, t = g.face_tets[inner].T
    a, b, c = (V[F[inner, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1) / 2, g.face_area[inner], rtol=1e-12)
    n /= np.linalg.norm(n, axis=1)[:, None]
    gap = g.centres[t] - g.centres[s]
    across = np.abs(gap - np.einsum("ij,ij->i", gap, n)[:, None] * n).max(axis=1)
    assert (across <= 1e-9 * np.abs(g.centres).max()).all()
    np.testing.assert_allclose(np.abs(g.dual_length[inner]), np.linalg.norm(gap, axis=1),
                               rtol=1e-9, atol=1e-12 * np.abs(g.centres).max())
    # signed: the centres' distances from the plane, each positive on its own tet's side
    side = np.sign(np.einsum("ij,ij->i", V[T[s]].mean(axis=1) - a, n))  # n * side: towards s
    expected = np.einsum("ij,ij->i", g.centres[s] - g.centres[t], n) * side
    np.testing.assert_allclose(g.dual_length[inner], expected, rtol=1e-9,
                               atol=1e-12 * np.abs(g.centres).max())
    # every face centre is where the dual edge crosses the face's plane
    foot = g.centres[s] - np.einsum("ij,ij->i", g.centres[s] - a, n)[:, None] * n
    np.testing.assert_allclose(foot, g.face_centres[inner], atol=1e-9 * np.abs(g.centres).max())


@pytest.mark.parametrize("name", list(INTEGER_MESHES))
@pytest.mark.parametrize("weighted", [False, True])
def test_exact_rationals(name, weighted):
    """Centres, barycentric coordinates, face centres, face areas (squared) and dual-edge
    lengths times the face normal (rational) against fractions.Fraction."""
    V, T = INTEGER_MESHES[name]
    W = [Fraction(k % 3 - 1, 4) for k in range(len(V))] if weighted else [Fraction(0)] * len(V)
    g = tetlap.dual_geometry(V, T, weights=[float(x) for x in W] if weighted else None)
    X = [vec(p) for p in V]
    faces = {tuple(f): k for k, f in enumerate(g.faces.tolist())}
    exact_length = {}
    for t, tet in enumerate(T):
        P = [X[i] for i in tet]
        c = tet_circumcenter(*P, *[W[i] for i in tet])
        point = lambda q: np.array([float(x) for x in q])
        size = np.abs(np.array(V)[tet]).max()  # to 1e-15 of the tet's and the point's sizes
        close = lambda got, q: np.testing.assert_allclose(
            got, point(q), rtol=0, atol=1e-15 * max(size, np.abs(point(q)).max()))
        close(g.centres[t], c)
        np.testing.assert_allclose(g.barycentric[t], [float(x) for x in tet_barycentric(P, c)],
                                   rtol=1e-14, atol=1e-15)
        for l in range(4):
            face = sorted(tet[:l] + tet[l + 1:])
            f = faces[tuple(face)]
            Q = [X[i] for i in face]
            n = cross(sub(Q[1], Q[0]), sub(Q[2], Q[0]))
            towards = 1 if dot(n, sub(P[l], Q[0])) > 0 else -1
            # height * |n|: rational; the sum of the parts' sizes sets the accuracy
            part = towards * dot(n, sub(c, Q[0]))
            total, parts = exact_length.get(f, (0, 0))
            exact_length[f] = (total + part, parts + abs(part))
            fc = triangle_circumcenter(*Q, *[W[i] for i in face])
            close(g.face_centres[f], fc)
            assert g.face_area[f] ** 2 == pytest.approx(float(dot(n, n) / 4), rel=1e-15)
    for f, (r, parts) in exact_length.items():
        norm = float(dot(*[cross(sub(X[g.faces[f][1]], X[g.faces[f][0]]),
                                 sub(X[g.faces[f][2]], X[g.faces[f][0]]))] * 2)) ** 0.5
        assert g.dual_length[f] == pytest.approx(float(r) / norm, rel=1e-13,
                                                 abs=1e-13 * float(parts) / norm)


def test_single_corner_tet_golden_values():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    g = tetlap.dual_geometry(V, [[0, 1, 2, 3]])
    assert g.centres.tolist() == [[0.5, 0.5, 0.5]] and g.outside.tolist() == [True]
    assert g.control_volume.tolist() == pytest.approx([1 / 8, 1 / 72, 1 / 72, 1 / 72])
    # the faces at the right-angled corner: the centre lies 1/2 above each, on the tet's side
    assert g.dual_length[:3].tolist() == [0.5, 0.5, 0.5]
    assert g.dual_length[3] == pytest.approx(-(1.5 - 1) / 3**0.5, rel=1e-15)
    assert g.face_tets.tolist() == [[0, -1]] * 4 and g.boundary_faces.all()


def test_results_are_bitwise_the_same_for_any_thread_count():
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=5)
    w = small_weights(V, T)
    g = [tetlap.dual_geometry(V, T, weights=w, threads=k) for k in (1, 2, 4)]
    for field in dataclasses.fields(tetlap.DualGeometry):
        for h in g[1:]:
            np.testing.assert_array_equal(getattr(g[0], field.name), getattr(h, field.name))


def test_results_do_not_depend_on_orientation():
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=5)
    w = small_weights(V, T)
    g = tetlap.dual_geometry(V, T, weights=w)
    flipped = T.copy()
    flipped[::2, [2, 3]] = flipped[::2, [3, 2]]
    h = tetlap.dual_geometry(V, flipped, weights=w)
    for name in ("edges", "faces", "face_tets", "outside"):
        np.testing.assert_array_equal(getattr(g, name), getattr(h, name), err_msg=name)
    for name in ("transmissibility", "control_volume", "centres", "face_area", "face_centres",
                 "dual_length", "volume"):
        a, b = getattr(g, name), getattr(h, name)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13 * np.abs(a).max(), err_msg=name)
    swapped = g.barycentric.copy()
    swapped[::2] = swapped[::2][:, [0, 1, 3, 2]]
    np.testing.assert_allclose(h.barycentric, swapped, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(h.tet_faces[::2], g.tet_faces[::2][:, [0, 1, 3, 2]])
    np.testing.assert_array_equal(g.orientation, np.sign(tetlap.diagnostics.signed_volumes(V, T)))
    np.testing.assert_array_equal(h.orientation, g.orientation * np.where(np.arange(len(T)) % 2, 1, -1))


def test_immersed_mesh_has_the_rotated_centres():
    V, T = tetlap.meshes.ball(200, seed=2)
    Q = np.linalg.qr(np.random.default_rng(1).normal(size=(4, 4)))[0][:, :3]
    g, h = tetlap.dual_geometry(V, T), tetlap.dual_geometry(V @ Q.T + 1.0, T)
    np.testing.assert_allclose(h.centres, g.centres @ Q.T + 1.0, atol=1e-10)
    np.testing.assert_allclose(h.dual_length, g.dual_length, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(h.control_volume, g.control_volume, rtol=1e-9, atol=1e-14)


def test_unreferenced_vertices_take_no_part():
    V, T = tetlap.meshes.ball(100, seed=3)
    V2 = np.vstack([V, [[5.0, 5, 5]]])
    T2 = np.where(T >= 10, T + 1, T)  # a vertex 10 no tet uses, one at the end
    V2 = np.insert(V2, 10, [[-7.0, 1, 2]], axis=0)
    g, h = tetlap.dual_geometry(V, T), tetlap.dual_geometry(V2, T2)
    assert h.control_volume[10] == 0 and h.control_volume[-1] == 0
    np.testing.assert_array_equal(np.delete(h.control_volume, [10, len(V2) - 1]), g.control_volume)
    np.testing.assert_array_equal(h.centres, g.centres)
    assert not np.isin([10, len(V2) - 1], h.edges).any()


def test_bad_input_gets_clear_errors():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]]
    with pytest.raises(tetlap.DegenerateElementError) as e:
        tetlap.dual_geometry(V, [[0, 1, 2, 3], [0, 1, 2, 4]])
    assert e.value.element == 1
    with pytest.raises(tetlap.ShapeError, match=r"\(m, 4\)"):
        tetlap.dual_geometry([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.dual_geometry([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]], [[0, 1, 2, 3]])
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.dual_geometry(V[:4], [[0, 1, 2, 3]], weights=[0, 0, np.inf, 0])
    with pytest.raises(tetlap.ShapeError):
        tetlap.dual_geometry(V[:4], [[0, 1, 2, 3]], weights=[0, 0, 0])
    # a face of three tets has no dual edge
    V3 = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1]]
    with pytest.raises(tetlap.DegenerateElementError, match="shared by 3 tets"):
        tetlap.dual_geometry(V3, [[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]])
    V0 = np.array(V, dtype=float)
    tetlap.dual_geometry(V0, [[0, 1, 2, 3]])
    np.testing.assert_array_equal(V0, np.array(V, dtype=float))  # inputs are not modified


def test_mesh_objects_are_accepted():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.ball(100, seed=1)
    g = tetlap.dual_geometry(meshio.Mesh(V, [("tetra", T)]))
    np.testing.assert_array_equal(g.centres, tetlap.dual_geometry(V, T).centres)


def test_faces_sort_the_same_by_one_key_or_two():
    """The face order does not depend on how the records are sorted: one integer key
    while n^3 fits in int64, two beyond (exercised here with a larger n than the mesh's)."""
    from tetlap.dual import _Faces

    V, T = tetlap.meshes.ball(300, seed=2)
    one, two = _Faces(T, len(V)), _Faces(T, 2**22)
    for name in ("faces", "tet_faces", "records", "counts"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    assert (np.lexsort(one.faces.T[::-1]) == np.arange(len(one.faces))).all()
