"""Mesh diagnostics: boundary, orientation, dihedral angles, Delaunay, well-centeredness."""

from __future__ import annotations

import itertools

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
    assert_interior_faces(T, tets, opposite)


def assert_interior_faces(T, tets, opposite):
    """Each interior face: two different tets, each opposite vertex in its own tet and not
    on the shared face, which is the other three vertices of both tets."""
    assert (tets[:, 0] != tets[:, 1]).all()
    A, B = T[tets[:, 0]], T[tets[:, 1]]
    assert (A == opposite[:, :1]).any(axis=1).all() and (B == opposite[:, 1:]).any(axis=1).all()
    assert not (A == opposite[:, 1:]).any(axis=1).any()  # the other tet's opposite vertex
    assert not (B == opposite[:, :1]).any(axis=1).any()  # is not on the face
    face_a = np.sort(np.where(A == opposite[:, :1], -1, A), axis=1)[:, 1:]
    face_b = np.sort(np.where(B == opposite[:, 1:], -1, B), axis=1)[:, 1:]
    np.testing.assert_array_equal(face_a, face_b)
    # faces in lexicographic order of their sorted vertices, each once
    keys = [tuple(f) for f in face_a]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)


@pytest.mark.parametrize("scale", [1.0, 1e-150, 1e150])
def test_degenerate_is_decided_per_tet_at_any_scale(scale):
    # the tolerance was relative to the mean volume: a unit tet beside a large one was
    # "degenerate", and info counted every tet of a cube with one needle at 1e20
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0], [10, 0, 0], [10 + 1e5, 0, 0],
                  [10, 1e5, 0], [10, 0, 1e5], [0, 0, 1e-13]]) * scale
    T = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 2, 8], [0, 1, 4, 5]])  # last: flat
    assert d.degenerate_tets(V, T).tolist() == [False, False, True, True]
    assert d.degenerate_tets(V, T, rtol=0).tolist() == [False, False, False, True]
    assert d.summary(V, T)["n_degenerate_tets"] == 1
    Vc, Tc = tetlap.meshes.cube(3)
    far = [int(np.argmin(np.abs(Vc - c).sum(axis=1)))            # a triangle of the top face
           for c in ([0, 0, 1], [1, 0, 1], [0, 1, 1])]
    Vn, Tn = np.vstack([Vc, [[0.2, 0.3, 1e20]]]), np.vstack([Tc, [[*far, len(Vc)]]])
    assert not d.degenerate_tets(Vn * scale, Tn)[:-1].any()
    assert d.summary(Vn * scale, Tn)["n_degenerate_tets"] == 0


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
    # moved by 1e-13: every cube's corners are cospherical only up to rounding-size
    # errors, which the tolerance absorbs; without it, about half the faces flip
    V2 = V + np.random.default_rng(0).uniform(-1e-13, 1e-13, size=V.shape)
    assert d.non_delaunay_faces(V2, T).sum() == 0
    flagged = d.non_delaunay_faces(V2, T, rtol=0.0)
    assert 0 < flagged.sum() < len(flagged)


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
    W = tetlap.element_contributions(V, T[good], "dual")
    assert (W > 0).all()
    M = np.array([tetlap.mass(V, [t], "circumcentric").diagonal()[t] for t in T[good][:50]])
    assert (M > 0).all()


def test_interior_faces_of_random_and_shuffled_meshes():
    V, T = random_delaunay()
    for tets_in in (T, T[np.random.default_rng(2).permutation(len(T))][:, [2, 0, 3, 1]]):
        tets, opposite = d.interior_faces(tets_in)
        assert len(tets) > 0
        assert_interior_faces(tets_in, tets, opposite)


def test_boundary_faces_with_their_tets_and_corners():
    V, T = tetlap.meshes.ball(300, seed=1)
    F, tets, corners = d.boundary_faces(T, return_tets=True)
    np.testing.assert_array_equal(F, d.boundary_faces(T))
    assert len(F) == len(tets) == len(corners)
    assert (np.diff(tets) >= 0).all()  # in the order of their tets
    rest = np.sort(np.where(np.arange(4) == corners[:, None], -1, T[tets]), axis=1)[:, 1:]
    np.testing.assert_array_equal(np.sort(F, axis=1), rest)
    # exactly the faces in one tet, counted here
    all_faces = np.sort(d.faces(T), axis=1)
    keys, counts = np.unique(all_faces, axis=0, return_counts=True)
    assert {tuple(f) for f in keys[counts == 1]} == {tuple(f) for f in np.sort(F, axis=1)}
    # the boundary of a ball is closed: the outward area vectors sum to zero
    normals = d.face_normals(V, F)
    assert np.abs(normals.sum(axis=0)).max() < 1e-12
    centroid_out = np.einsum("ij,ij->i", normals, V[F].mean(axis=1))
    assert (centroid_out > 0).all()  # outward for positively oriented tets


def test_face_normals_are_area_vectors():
    V = np.array([[0, 0, 0], [2, 0, 0], [0, 3, 0], [0, 0, 1]], dtype=float)
    np.testing.assert_array_equal(d.face_normals(V, [[0, 1, 2], [0, 2, 1]]),
                                  [[0, 0, 3], [0, 0, -3]])


def test_volumes_and_angles_agree_with_numpy_and_in_r4(rng):
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=6)
    T = np.take_along_axis(T, np.array([rng.permutation(4) for _ in T]), axis=1)
    X = V[T]
    np.testing.assert_allclose(d.signed_volumes(V, T), np.linalg.det(X[:, 1:] - X[:, :1]) / 6,
                               rtol=1e-12, atol=1e-17)
    np.testing.assert_array_equal(d.orientation(V, T), np.sign(d.signed_volumes(V, T)))
    np.testing.assert_array_equal(d.min_dihedral_angles(V, T), d.dihedral_angles(V, T).min(axis=1))
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    V4 = np.column_stack([V, np.zeros(len(V))]) @ Q.T
    np.testing.assert_allclose(d.signed_volumes(V4, T), np.abs(d.signed_volumes(V, T)), rtol=1e-12)
    np.testing.assert_allclose(d.dihedral_angles(V4, T), d.dihedral_angles(V, T), atol=1e-9)
    # well-centredness is decided without a tolerance: compare on a mesh without the
    # exact right angles of the cube's boundary faces (where rounding in R^4 decides)
    V, T = tetlap.meshes.ball(300, seed=1)
    V4 = np.column_stack([V, np.zeros(len(V))]) @ Q.T
    assert 0 < d.well_centered(V, T).sum() < len(T)
    np.testing.assert_array_equal(d.well_centered(V4, T), d.well_centered(V, T))


def test_non_delaunay_tets_are_the_tets_of_non_delaunay_faces():
    V, T = tetlap.meshes.weighted_ball(400, 0.5, seed=2)
    flags = d.non_delaunay_faces(V, T)
    tets, _ = d.interior_faces(T)
    expected = np.zeros(len(T), dtype=bool)
    expected[tets[flags].ravel()] = True
    assert flags.any()
    np.testing.assert_array_equal(d.non_delaunay_tets(V, T), expected)


def test_edges_duplicates_and_nonmanifold_faces():
    T = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [3, 2, 1, 0], [1, 2, 3, 5]])
    np.testing.assert_array_equal(d.duplicate_tets(T), [False, False, True, False])
    np.testing.assert_array_equal(d.nonmanifold_faces(T), [[1, 2, 3]])  # in 4 tets
    np.testing.assert_array_equal(d.referenced_vertices(T, 8), [True] * 6 + [False] * 2)
    np.testing.assert_array_equal(d.interior_vertices(T, 8), [True] + [False] * 7)  # 0: twice
    triangles = [[0, 1, 2], [2, 1, 3]]
    np.testing.assert_array_equal(d.mesh_edges(triangles), [[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]])


def test_summary_counts_every_kind_of_problem():
    V, T = tetlap.meshes.cube(2)
    V = np.vstack([V, [[0.5, 0.5, 0.0], [9, 9, 9]]])  # a point on the bottom, one unused
    # tet 0 again, tet 1 flipped (a second duplicate), and a flat tet on z = 0
    T = np.vstack([T, T[:1], T[1:2, [1, 0, 2, 3]], [[0, 3, 9, 27]]])
    s = d.summary(V, T)
    vol = np.linalg.det(V[T][:, 1:] - V[T][:, :1]) / 6
    assert (s["n_vertices"], s["n_tets"]) == (len(V), len(T))
    assert s["n_positive_tets"] == (vol > 1e-15).sum() and s["n_negative_tets"] == (vol < -1e-15).sum()
    assert s["n_degenerate_tets"] == 1 and s["n_duplicate_tets"] == 2  # the copy and the flip
    assert s["n_unreferenced_vertices"] == 1
    assert s["mesh_volume"] == pytest.approx(np.abs(vol).sum(), rel=1e-12)
    keys, counts = np.unique(np.sort(d.faces(T), axis=1), axis=0, return_counts=True)
    assert s["n_boundary_faces"] == (counts == 1).sum()
    assert s["n_nonmanifold_faces"] == (counts > 2).sum() > 0
    assert s["n_boundary_vertices"] == len(np.unique(keys[counts == 1]))
    angles = d.dihedral_angles(V, T)
    assert s["min_dihedral_deg"] == np.nanmin(angles) and s["max_dihedral_deg"] == np.nanmax(angles)
    assert 0 <= s["non_delaunay_face_fraction"] <= 1
    # an immersed copy: the R^3-only entries are None
    s4 = d.summary(np.column_stack([V, V[:, 0] ** 2]), T)
    assert s4["n_positive_tets"] is None and s4["non_delaunay_face_fraction"] is None


def test_a_mesh_object_stands_for_t_or_for_v_and_t():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(2, jitter=0.1, seed=1)
    obj = meshio.Mesh(V, [("tetra", T)])
    np.testing.assert_array_equal(d.boundary_faces(obj), d.boundary_faces(T))
    np.testing.assert_array_equal(d.mesh_edges(obj), d.mesh_edges(T))
    np.testing.assert_array_equal(d.signed_volumes(obj), d.signed_volumes(V, T))
    assert d.summary(obj) == d.summary(V, T)


def test_topology_functions_take_v_and_t_a_mesh_object_or_t_and_n():
    # issue 30: boundary_vertices(T, n) broke the (V, T) order of every other function, and
    # boundary_vertices(V, T) blamed T for V's float dtype
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=1)
    V = np.vstack([V, [[9.0, 9.0, 9.0]]])  # an unreferenced last vertex: n = len(V)
    mesh = meshio.Mesh(V, [("tetra", T)])
    n = len(V)
    for f in (d.boundary_vertices, d.interior_vertices, d.referenced_vertices):
        expected = f(T, n)
        assert expected.shape == (n,) and not expected[-1]
        for args in ((V, T), (mesh,), (V, T.tolist())):
            np.testing.assert_array_equal(f(*args), expected)
        np.testing.assert_array_equal(f(T), expected[:-1])  # n = T.max() + 1
    for f in (d.faces, d.boundary_faces, d.nonmanifold_faces, d.mesh_edges, d.duplicate_tets):
        np.testing.assert_array_equal(f(V, T), f(T))
        np.testing.assert_array_equal(f(mesh), f(T))
    for a, b in zip(d.interior_faces(V, T), d.interior_faces(T)):
        np.testing.assert_array_equal(a, b)
    # errors name the argument at fault
    with pytest.raises(tetlap.DtypeError, match="^V must"):
        d.boundary_vertices(V.astype(str), T)
    with pytest.raises(tetlap.DtypeError, match="^T must"):
        d.boundary_vertices(V, T.astype(float))
    with pytest.raises(tetlap.OptionError, match="n must be an integer >= "):
        d.referenced_vertices(T, 5)  # an n below an index of T (a bare IndexError once)
    np.testing.assert_array_equal(d.referenced_vertices(T, n=n), d.referenced_vertices(V, T))
    with pytest.raises(tetlap.IndexRangeError, match=f"there are {n - 30} vertices"):
        d.interior_vertices(V[:-30], T)
    with pytest.raises(TypeError, match="mesh object"):
        d.boundary_vertices(mesh, T)


# ---- folds ------------------------------------------------------------------------------


def folded_cube():
    """A jittered grid with one interior vertex pulled through its star (past a
    neighbour): the tets around it overlap their neighbours."""
    V, T = tetlap.meshes.cube(4, jitter=0.1, seed=5)
    i = int(np.flatnonzero(d.interior_vertices(V, T))[7])
    j = next(int(v) for v in T[(T == i).any(axis=1)].ravel() if v != i and d.interior_vertices(V, T)[v])
    V = V.copy()
    V[i] += 1.6 * (V[j] - V[i])
    return V, T


def same_side(V, T):
    """Per interior face, with NumPy determinants: the two opposite vertices on one side."""
    tets, opposite = d.interior_faces(V, T)
    face = np.array([[v for v in T[s] if v != o] for s, o in zip(tets[:, 0], opposite[:, 0])])
    P = V[face]
    side = lambda q: np.sign(np.einsum("ij,ij->i", np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]),
                                       V[q] - P[:, 0]))
    return side(opposite[:, 0]) == side(opposite[:, 1])


def interior_vertices_without_linear_precision(V, T, kind):
    L = tetlap.laplacian(V, T, kind)
    used = d.referenced_vertices(V, T)
    low, high = V[used].min(axis=0), V[used].max(axis=0)
    r = np.abs(L @ (V - (low + high) / 2)).max(axis=1) / (abs(L).max() * np.linalg.norm(high - low))
    return np.flatnonzero((r > 1e-10) & d.interior_vertices(V, T))


def test_folds_are_decided_by_the_geometry_not_the_vertex_order():
    """Issue 37.11: a fold (two tets on one side of their face: the mesh overlaps itself)
    is what spoils linear precision; a tet whose vertex order alone is reversed is no
    fold. The folded faces against NumPy determinants, under every vertex order; the
    folded tets are the smaller side; the vertices of folded faces are exactly the
    interior vertices where linear precision fails."""
    rng = np.random.default_rng(3)
    V, T = folded_cube()
    folded = d.folded_faces(V, T)
    assert folded.any() and (folded == same_side(V, T)).all()
    tets = d.folded_tets(V, T)
    assert 0 < tets.sum() < 12
    orders = np.array(list(itertools.permutations(range(4))))
    for _ in range(3):                                   # any vertex order of any tet
        T2 = np.take_along_axis(T, orders[rng.integers(0, 24, len(T))], axis=1)
        assert (d.folded_faces(V, T2) == folded).all()
        assert (d.folded_tets(V, T2) == tets).all()
    # every folded face has exactly one named tet (the sides differ across it)
    pairs, _ = d.interior_faces(V, T)
    assert (tets[pairs[folded]].sum(axis=1) == 1).all()
    spoiled = np.flatnonzero(d.folded_vertices(V, T) & d.interior_vertices(V, T))
    for kind in ("primal", "dual"):
        assert interior_vertices_without_linear_precision(V, T, kind).tolist() == spoiled.tolist()
        # check's failed linear precision names the folds
        r = tetlap.check(tetlap.laplacian(V, T, kind), V, T, nsd=False)
        assert r.linear_precision_ok is False
        (note,) = [n for n in r.notes if "folds over itself" in n]
        assert ", ".join(map(str, np.flatnonzero(tets))) in note
    # a mesh of mixed vertex order, unfolded: nothing
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=2)
    T = T.copy()
    T[::3, [0, 1]] = T[::3, [1, 0]]
    assert d.orientation(V, T).min() < 0
    assert not d.folded_faces(V, T).any() and not d.folded_tets(V, T).any()
    assert not d.folded_vertices(V, T).any()
    s = d.summary(V, T)
    assert (s["n_folded_faces"], s["n_folded_tets"], s["folded_tets"]) == (0, 0, [])


def test_folded_tets_of_the_polyfem_microstructure():
    """The corpus mesh of the issue: 8 tets inverted against their neighbours (its 8
    negative tets), folding 32 faces; check fails linear precision exactly at the
    interior vertices of those faces."""
    from conftest import corpus_mesh

    V, T = corpus_mesh("polyfem_microstructure_p1.msh")
    tets = np.flatnonzero(d.folded_tets(V, T))
    assert tets.tolist() == np.flatnonzero(d.signed_volumes(V, T) < 0).tolist()
    assert len(tets) == 8 and d.folded_faces(V, T).sum() == 32
    spoiled = np.flatnonzero(d.folded_vertices(V, T) & d.interior_vertices(V, T))
    for kind in ("primal", "dual"):
        assert interior_vertices_without_linear_precision(V, T, kind).tolist() == spoiled.tolist()
    # reordering the vertices of every tet changes nothing
    assert (d.folded_tets(V, T[:, [1, 0, 2, 3]]) == d.folded_tets(V, T)).all()


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e-120, 1.0, 1e150, 1e300])
def test_orientation_and_folds_are_exact_at_any_scale(scale):
    """The sign of a tet is decided exactly, not from its volume, which leaves the float64
    range below about 1e-103 in size (it read 0, "flat", and no fold was found)."""
    V, T = tetlap.meshes.cube(2)
    T = T.copy()
    T[::3] = T[::3, [1, 0, 2, 3]]                       # some vertex orders reversed
    expected = tetlap.diagnostics.orientation(V, T)
    assert set(expected.tolist()) == {-1, 1}
    np.testing.assert_array_equal(tetlap.diagnostics.orientation(V * scale, T), expected)
    s = tetlap.diagnostics.summary(V * scale, T)
    assert (s["n_positive_tets"], s["n_negative_tets"]) == ((expected > 0).sum(), (expected < 0).sum())
    folded = V.copy()
    folded[13] = [0.5, 0.5, 1.2]                        # the centre pulled out through the top
    np.testing.assert_array_equal(tetlap.diagnostics.folded_tets(folded * scale, T),
                                  tetlap.diagnostics.folded_tets(folded, T))
    assert tetlap.diagnostics.folded_tets(folded * scale, T).sum() == 6
