"""tetlap.meshes: every generator gives the mesh it documents.

Shapes and dtypes, positive orientation, vertices on the spheres where promised, the
(weighted) Delaunay property checked here with NumPy (empty (ortho)spheres), seeded
determinism, and the helpers orient and compact.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial import Delaunay

import tetlap
from tetlap import meshes
from tetlap.diagnostics import non_delaunay_tets


def volumes(V, T):
    """Signed volumes det[x1-x0, x2-x0, x3-x0] / 6, computed here."""
    X = V[T]
    return np.linalg.det(X[:, 1:] - X[:, :1]) / 6


def face_counts(T):
    """How many tets share each face (sorted vertex triples)."""
    F = np.sort(np.concatenate([T[:, list(f)] for f in itertools.combinations(range(4), 3)]), axis=1)
    return np.unique(F, axis=0, return_counts=True)[1]


def assert_mesh(V, T, dim=3):
    assert V.dtype == np.float64 and V.ndim == 2 and V.shape[1] == dim
    assert T.dtype == np.int64 and T.ndim == 2 and T.shape[1] == 4
    assert T.min() >= 0 and T.max() < len(V)
    assert (np.sort(T, axis=1)[:, 1:] != np.sort(T, axis=1)[:, :-1]).all()  # distinct corners
    counts = face_counts(T)
    assert counts.max() <= 2  # conforming: no face in three tets


def assert_positive(V, T):
    vol = volumes(V, T)
    assert (vol > 0).all(), (vol <= 0).sum()


def power_violation(V, T, w):
    """max over tets of how far a point lies inside the tet's orthosphere (the weighted
    circumsphere: |c - x_i|^2 - w_i equal at its 4 corners), relative to its radius^2.
    <= 0 (to rounding) for a regular triangulation of (V, w): the lifted lower hull."""
    X, W = V[T], w[T]
    A = 2 * (X[:, 1:] - X[:, :1])
    b = ((X[:, 1:] ** 2).sum(axis=2) - (X[:, :1] ** 2).sum(axis=2)) - (W[:, 1:] - W[:, :1])
    c = np.linalg.solve(A, b[..., None])[..., 0]
    power = ((c - X[:, 0]) ** 2).sum(axis=1) - W[:, 0]
    worst = -np.inf
    for start in range(0, len(V), 256):
        P, wp = V[start:start + 256], w[start:start + 256]
        d = ((c[:, None, :] - P[None]) ** 2).sum(axis=2) - wp[None] - power[:, None]
        worst = max(worst, float((-d / np.abs(power)[:, None]).max()))
    return worst


# ---- single tets, cubes ---------------------------------------------------------------


def test_single_tets():
    V, T = meshes.single_tet("corner")
    assert_mesh(V, T)
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert volumes(V, T)[0] == pytest.approx(1 / 6)
    V, T = meshes.single_tet("regular")
    assert_mesh(V, T)
    edges = [np.linalg.norm(V[a] - V[b]) for a, b in itertools.combinations(range(4), 2)]
    np.testing.assert_allclose(edges, 1.0, rtol=1e-15)
    with pytest.raises(ValueError, match="corner"):
        meshes.single_tet("cube")


def test_the_regular_tet_is_positively_oriented():
    assert_positive(*meshes.single_tet("regular"))


@pytest.mark.parametrize("k", [1, 2, 5])
def test_cube_is_a_kuhn_grid_of_the_unit_cube(k):
    V, T = meshes.cube(k)
    assert_mesh(V, T)
    assert V.shape == ((k + 1) ** 3, 3) and T.shape == (6 * k**3, 4)
    assert_positive(V, T)
    np.testing.assert_allclose(volumes(V, T), 1 / (6 * k**3), rtol=1e-12)  # all equal
    np.testing.assert_array_equal(np.unique(V), np.arange(k + 1) / k)
    counts = face_counts(T)
    assert (counts == 1).sum() == 6 * 2 * k * k  # two triangles per boundary square


def test_cube_jitter_moves_only_interior_vertices_seeded():
    k, jitter = 4, 0.2
    V0, T0 = meshes.cube(k)
    V, T = meshes.cube(k, jitter=jitter, seed=3)
    np.testing.assert_array_equal(T, meshes.orient(V, T0))  # the same tets, oriented
    assert_positive(V, T)
    interior = np.all((V0 > 0) & (V0 < 1), axis=1)
    np.testing.assert_array_equal(V[~interior], V0[~interior])
    moved = np.abs(V - V0)[interior]
    assert moved.min() > 0 and moved.max() <= jitter / k
    assert volumes(V, T).sum() == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_array_equal(meshes.cube(k, jitter=jitter, seed=3)[0], V)
    assert not np.array_equal(meshes.cube(k, jitter=jitter, seed=4)[0], V)
    with pytest.raises(ValueError):
        meshes.cube(0)


# ---- balls and shells -----------------------------------------------------------------


def test_ball_is_a_delaunay_mesh_of_the_unit_ball():
    n = 400
    V, T = meshes.ball(n, seed=2)
    assert_mesh(V, T)
    assert_positive(V, T)
    assert V.shape == (n, 3)
    r = np.linalg.norm(V, axis=1)
    on_sphere = np.abs(r - 1) < 1e-14
    assert on_sphere.sum() == int(4 * n ** (2 / 3))  # the Fibonacci lattice
    assert r[~on_sphere].max() <= 0.97
    # Delaunay: no vertex inside any tet's circumsphere (zero weights)
    assert power_violation(V, T, np.zeros(n)) <= 1e-9
    # the polyhedral ball: nearly the volume of the unit ball
    assert 0.9 * 4 / 3 * np.pi < volumes(V, T).sum() < 4 / 3 * np.pi
    np.testing.assert_array_equal(meshes.ball(n, seed=2)[1], T)
    assert not np.array_equal(meshes.ball(n, seed=3)[0], V)


def test_shell_vertices_lie_on_the_three_spheres():
    V, T, spheres = meshes.shell(1500, seed=1)
    assert_mesh(V, T)
    assert_positive(V, T)
    assert spheres.dtype == np.int8 and spheres.shape == (len(V),)
    r = np.linalg.norm(V, axis=1)
    for k, radius in enumerate((0.5, 0.75, 1.0)):
        assert (spheres == k).sum() > 12
        np.testing.assert_allclose(r[spheres == k], radius, rtol=1e-14)
    inside = spheres == -1
    assert inside.any() and (r[inside] > 0.5).all() and (r[inside] < 1).all()
    assert (np.abs(r[inside, None] - [0.5, 0.75, 1.0]) > 1e-3).all()
    # nothing inside the inner sphere: no tet has all four corners on it
    assert not (spheres[T] == 0).all(axis=1).any()
    np.testing.assert_array_equal(np.unique(T), np.arange(len(V)))  # compact
    assert power_violation(V, T, np.zeros(len(V))) <= 1e-9  # Delaunay
    shell_volume = 4 / 3 * np.pi * (1 - 0.125)
    assert 0.85 * shell_volume < volumes(V, T).sum() < 1.01 * shell_volume


def test_weighted_shell_keeps_the_sphere_vertices():
    V, T, spheres = meshes.shell(1500, seed=1, weight_scale=0.5)
    assert_positive(V, T)
    assert non_delaunay_tets(V, T).any()
    r = np.linalg.norm(V, axis=1)
    for k, radius in enumerate((0.5, 0.75, 1.0)):
        np.testing.assert_allclose(r[spheres == k], radius, rtol=1e-14)


def test_sphere3_is_a_closed_3_manifold_on_the_unit_3_sphere():
    V, T = meshes.sphere3(300, seed=0)
    assert_mesh(V, T, dim=4)
    np.testing.assert_allclose(np.linalg.norm(V, axis=1), 1.0, rtol=1e-14)
    assert (face_counts(T) == 2).all()  # every face in exactly two tets: no boundary
    np.testing.assert_array_equal(np.unique(T), np.arange(len(V)))


# ---- regular triangulations -----------------------------------------------------------


def test_regular_triangulation_is_the_lifted_lower_hull():
    rng = np.random.default_rng(4)
    V = rng.uniform(-1, 1, size=(250, 3))
    w = rng.uniform(0, 0.05, size=len(V))
    T = meshes.regular_triangulation(V, w)
    assert_mesh(V, T)
    assert_positive(V, T)
    assert power_violation(V, T, w) <= 1e-9  # every orthosphere is empty
    assert power_violation(V, T, np.zeros(len(V))) > 1e-3  # ... but not Delaunay
    # its tets fill the convex hull of the points that appear
    hull = Delaunay(V)
    full = np.abs(volumes(V, hull.simplices)).sum()
    assert volumes(V, T).sum() == pytest.approx(full, rel=1e-9)


def test_zero_weights_give_the_delaunay_tetrahedralisation():
    V = np.random.default_rng(5).uniform(size=(200, 3))
    T = meshes.regular_triangulation(V, np.zeros(len(V)))
    D = Delaunay(V).simplices
    D = D[np.abs(volumes(V, D)) > 1e-12]
    assert {tuple(t) for t in np.sort(T, axis=1)} == {tuple(t) for t in np.sort(D, axis=1)}


def test_a_point_with_a_small_weight_can_disappear():
    """A point inside the orthosphere of its neighbours (here: a low weight among high
    ones) is not a vertex of the regular triangulation."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1], [0.3, 0.3, 0.3]],
                 dtype=float)
    w = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    T = meshes.regular_triangulation(V, w)
    assert 5 not in T
    V2, T2 = meshes.compact(V, T)
    assert len(V2) == 5 and (V2[T2] == V[T]).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_weighted_ball_non_delaunay_fraction_grows_with_the_weight_scale(seed):
    fractions = []
    for scale in (0.0, 0.1, 0.5, 1.0):
        V, T = meshes.weighted_ball(800, scale, seed=seed)
        assert_mesh(V, T)
        assert_positive(V, T)
        np.testing.assert_array_equal(np.unique(T), np.arange(len(V)))  # compact
        # the boundary stays the sphere of the ball (zero weights there)
        r = np.linalg.norm(V, axis=1)
        assert (np.abs(r - 1) < 1e-14).sum() == int(4 * 800 ** (2 / 3))
        fractions.append(non_delaunay_tets(V, T).mean())
    assert fractions[0] == 0
    assert all(a < b for a, b in zip(fractions, fractions[1:])), fractions
    assert fractions[-1] > 0.3


def test_weighted_ball_with_zero_weights_is_the_ball():
    V, T = meshes.weighted_ball(500, 0.0, seed=2)
    V2, T2 = meshes.ball(500, seed=2)
    np.testing.assert_array_equal(V, V2)
    assert {tuple(t) for t in np.sort(T, axis=1)} == {tuple(t) for t in np.sort(T2, axis=1)}


# ---- helpers --------------------------------------------------------------------------


def test_orient_makes_every_tet_positive_and_keeps_its_vertices():
    V, T = meshes.cube(2, jitter=0.1, seed=1)
    rng = np.random.default_rng(0)
    mixed = np.take_along_axis(T, np.array([rng.permutation(4) for _ in T]), axis=1)
    assert (volumes(V, mixed) < 0).any()
    before = mixed.copy()
    oriented = meshes.orient(V, mixed)
    np.testing.assert_array_equal(mixed, before)  # a copy; the input is unchanged
    assert_positive(V, oriented)
    np.testing.assert_array_equal(np.sort(oriented, axis=1), np.sort(mixed, axis=1))
    positive = volumes(V, mixed) > 0
    np.testing.assert_array_equal(oriented[positive], mixed[positive])  # untouched
    assert oriented.dtype == np.int64


def test_compact_drops_unreferenced_vertices_in_order():
    V = np.arange(24, dtype=float).reshape(8, 3)
    T = np.array([[6, 1, 3, 4], [1, 3, 4, 7]])
    labels = np.arange(8) * 10
    V2, T2, labels2 = meshes.compact(V, T, labels)
    np.testing.assert_array_equal(V2, V[[1, 3, 4, 6, 7]])  # order preserved
    np.testing.assert_array_equal(labels2, [10, 30, 40, 60, 70])
    np.testing.assert_array_equal(V2[T2], V[T])
    assert T2.dtype == np.int64 and T2.max() == 4


def test_gmsh_meshes_are_positive_and_on_their_spheres():
    pytest.importorskip("gmsh")
    V, T = meshes.optimized_ball(0.3)
    assert_mesh(V, T)
    assert_positive(V, T)
    assert np.linalg.norm(V, axis=1).max() <= 1 + 1e-9
    # a quality mesh: no slivers (a random Delaunay ball of this size has angles < 1 deg)
    assert tetlap.diagnostics.min_dihedral_angles(V, T).min() > 10
    V, T, spheres = meshes.optimized_shell(0.25)
    assert_mesh(V, T)
    assert_positive(V, T)
    r = np.linalg.norm(V, axis=1)
    for k, radius in enumerate((0.5, 0.75, 1.0)):
        assert (spheres == k).any()
        np.testing.assert_allclose(r[spheres == k], radius, atol=1e-9)
    assert (r > 0.5 - 1e-9).all()
    assert tetlap.diagnostics.min_dihedral_angles(V, T).min() > 10


# ---- options checked, no third-party exception (issue 30 item 13) -----------------------


@pytest.mark.parametrize("call, match", [
    (lambda: meshes.ball(0), "n must be an integer >= 4"),           # was a QhullError
    (lambda: meshes.shell(0), "n must be a positive integer"),       # ZeroDivisionError
    (lambda: meshes.cube(jitter=float("nan")), "jitter"),            # OverflowError
    (lambda: meshes.cube(3, jitter=1e308), "jitter must be at most 0.25"),
    (lambda: meshes.cube(10**6), "k must be at most 563"),           # MemoryError
    (lambda: meshes.cube(2.5), "k must be a positive integer"),      # accepted
    (lambda: meshes.cube(True), "k must be a positive integer"),
    (lambda: meshes.ball(1000.0), "n must be an integer"),
    (lambda: meshes.ball(10**12), "n must be at most"),
    (lambda: meshes.cube(3, seed=-1), "seed must be a non-negative integer"),
    (lambda: meshes.ball(100, seed=0.5), "seed"),
    (lambda: meshes.weighted_ball(500, 1e300), "weight_scale must be at most"),  # QhullError
    (lambda: meshes.weighted_ball(4), "n must be an integer >= 5"),
    (lambda: meshes.shell(100, weight_scale=-1), "weight_scale"),
    (lambda: meshes.sphere3(4), "n must be an integer >= 5"),
    (lambda: meshes.optimized_ball(1e-5), "h must be at least"),
    (lambda: meshes.optimized_shell(float("nan")), "h must be a positive number"),
    (lambda: meshes.single_tet("square"), "kind"),
])
def test_generator_options_are_option_errors_before_any_work(call, match):
    with pytest.raises(tetlap.OptionError, match=match):
        call()


def test_generators_leak_no_third_party_exception(monkeypatch):
    with pytest.raises(tetlap.ShapeError, match="span no tetrahedralisation"):
        meshes.regular_triangulation(np.zeros((6, 3)), np.zeros(6))   # was a QhullError
    with pytest.raises(tetlap.NonFiniteError):
        meshes.regular_triangulation(np.full((6, 3), np.nan), np.zeros(6))
    with pytest.raises(tetlap.ShapeError, match="weights"):
        meshes.regular_triangulation(np.eye(4, 3), np.zeros(3))

    def out_of_memory(*args, **kwargs):
        raise MemoryError("Unable to allocate 24.0 GiB for an array")

    monkeypatch.setattr(meshes, "_ball_points", out_of_memory)
    with pytest.raises(tetlap.OptionError, match=r"ball\(100\): the mesh does not fit in memory"):
        meshes.ball(100)
    assert meshes.cube(np.int64(2))[1].shape == (48, 4)   # NumPy integers are integers


@pytest.mark.parametrize("generator, steps", [
    (lambda p: meshes.ball(300, progress=p),
     ["points", "Delaunay tetrahedralisation (Qhull)", "orient, drop flat tets"]),
    (lambda p: meshes.weighted_ball(300, 0.5, progress=p),
     ["points", "regular tetrahedralisation (Qhull)", "orient, drop flat tets"]),
    (lambda p: meshes.shell(400, progress=p),
     ["points", "regular tetrahedralisation (Qhull)", "orient, drop flat tets"]),
    (lambda p: meshes.sphere3(100, progress=p), ["points", "convex hull (Qhull)"]),
])
def test_the_generators_report_their_steps(generator, steps, capsys):
    """``ball(10**6)`` ran 2 minutes in silence; its steps go to stderr when asked (by
    default when stderr is a terminal), one whole line each off a terminal."""
    name = generator.__code__.co_names[-1]
    plain = generator(False)
    assert capsys.readouterr().err == ""
    told = generator(True)
    assert capsys.readouterr().err.splitlines() == [
        f"tetlap.meshes.{name}: {step} ..." for step in steps]
    assert all(np.array_equal(a, b) for a, b in zip(plain, told))
    with pytest.raises(tetlap.OptionError, match="progress must be True or False"):
        generator("yes")
