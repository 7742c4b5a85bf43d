"""tetlap.HeatDistance / tetlap.heat_distance: accuracy on convex meshes (the geodesic
distance is the Euclidean one), convergence, LaPy, options, bad input, disconnected and
unused vertices."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.heat import HeatDistance


def mean_error(V, d, s):
    exact = np.linalg.norm(V - V[s], axis=1)
    return np.abs(d - exact).mean() / exact.max()


def centre_and_boundary(V):
    return int(np.argmin((V ** 2).sum(1))), int(np.argmax(V[:, 0]))


@pytest.mark.parametrize("boundary", ["neumann", "average"])
def test_close_to_euclidean_on_a_ball(boundary):
    V, T = tetlap.meshes.ball(2000, seed=0)
    heat = HeatDistance(V, T, boundary=boundary)
    for s in centre_and_boundary(V):
        d = heat.distance(s)
        assert d[s] == 0 and np.all(d >= -1e-12)
        assert mean_error(V, d, s) < 0.03


def test_dirichlet_is_accurate_from_an_interior_source():
    V, T = tetlap.meshes.ball(2000, seed=0)
    c, _ = centre_and_boundary(V)
    assert mean_error(V, tetlap.heat_distance(V, T, c, boundary="dirichlet"), c) < 0.03


def test_error_decreases_under_refinement_on_boxes():
    errors = []
    for k in (4, 7, 12):
        V, T = tetlap.meshes.cube(k, jitter=0.2, seed=1)
        errors.append(mean_error(V, tetlap.heat_distance(V, T, 0), 0))
    assert errors[0] > errors[1] > errors[2], errors


@pytest.mark.slow
def test_ball_30000_meets_the_target_and_beats_or_ties_lapy():
    lapy = pytest.importorskip("lapy")
    from lapy.diffgeo import compute_geodesic_f
    from lapy.heat import diffusion

    coarse, fine = [], []
    for N, out in ((2000, coarse), (30000, fine)):
        V, T = tetlap.meshes.ball(N, seed=0)
        heat = HeatDistance(V, T)
        mesh = lapy.TetMesh(V, T)
        for s in centre_and_boundary(V):
            ours = mean_error(V, heat.distance(s), s)
            theirs = mean_error(V, compute_geodesic_f(mesh, diffusion(mesh, s)), s)
            assert ours <= theirs * (1 + 1e-6), (N, s, ours, theirs)
            out.append(ours)
    assert max(fine) <= 0.025
    assert all(f < c for f, c in zip(fine, coarse))


def test_many_sources_reuse_the_factorizations_and_take_the_minimum():
    V, T = tetlap.meshes.cube(6)
    heat = HeatDistance(V, T)
    assert heat.n_factorizations == 2
    assert HeatDistance(V, T, boundary="average").n_factorizations == 3
    a, b = heat.distance(0), heat.distance(len(V) - 1)
    both = heat.distance([0, len(V) - 1, 0])
    assert np.abs(both - np.minimum(a, b)).max() < 0.1
    assert np.array_equal(heat.distance(np.int32(0)), a)   # repeatable, any integer type


def test_every_laplacian_kind_works():
    V, T = tetlap.meshes.ball(1000, seed=2)
    s = centre_and_boundary(V)[0]
    r = tetlap.regular_weights(V, T)
    for kwargs in ({"laplacian": "dual"}, {"laplacian": 0.5},
                   {"laplacian": "dual", "weights": r.weights}, {"mass": "mixed"}):
        assert mean_error(V, tetlap.heat_distance(V, T, s, **kwargs), s) < 0.05, kwargs


def test_t_changes_the_field_and_defaults_to_h_squared():
    V, T = tetlap.meshes.cube(5)
    heat = HeatDistance(V, T)
    edges = tetlap.diagnostics.mesh_edges(T)
    assert heat.h == pytest.approx(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
    assert heat.t == heat.h ** 2
    assert np.array_equal(HeatDistance(V, T, t=heat.t).distance(3), heat.distance(3))
    assert not np.array_equal(HeatDistance(V, T, t=4 * heat.t).distance(3), heat.distance(3))


def test_disconnected_mesh_and_unused_vertices_get_inf():
    V, T = tetlap.meshes.cube(3)
    V2 = np.vstack([V, V + 5.0, [[9.0, 9.0, 9.0]]])       # two cubes and a lone vertex
    T2 = np.vstack([T, T + len(V)])
    d = tetlap.heat_distance(V2, T2, 0)
    assert np.isfinite(d[:len(V)]).all() and np.isinf(d[len(V):]).all()
    assert not np.isnan(d).any()
    assert np.abs(d[:len(V)] - tetlap.heat_distance(V, T, 0)).max() < 1e-12
    both = tetlap.heat_distance(V2, T2, [0, len(V)])     # one source in each: all finite
    assert np.isfinite(both[:-1]).all() and both[0] == both[len(V)] == 0
    with pytest.raises(tetlap.IndexRangeError, match="in no element"):
        tetlap.heat_distance(V2, T2, len(V2) - 1)


def test_degenerate_elements_follow_the_policy():
    V, T = tetlap.meshes.cube(3)
    bottom = np.flatnonzero(V[:, 2] == 0)[[0, 1, 4]]
    V = np.vstack([V, V[bottom].mean(0)])
    T = np.vstack([T, [[*bottom, len(V) - 1]]])           # a flat tet on the bottom face
    with pytest.raises(tetlap.DegenerateElementError, match=f"element {len(T) - 1}"):
        HeatDistance(V, T)
    d = tetlap.heat_distance(V, T, 0, degenerate="skip")
    assert np.isfinite(d[:-1]).all() and np.isinf(d[-1])    # the flat tet's own vertex
    assert np.abs(d[:-1] - tetlap.heat_distance(V[:-1], T[:-1], 0)).max() < 1e-12


@pytest.mark.parametrize("bad, error", [
    ({"t": 0.0}, tetlap.OptionError), ({"t": -1.0}, tetlap.OptionError),
    ({"t": float("nan")}, tetlap.OptionError), ({"t": float("inf")}, tetlap.OptionError),
    ({"t": "1"}, tetlap.OptionError), ({"t": True}, tetlap.OptionError),
    ({"boundary": "robin"}, tetlap.OptionError), ({"mass": "fem"}, tetlap.OptionError),
    ({"laplacian": "cotan"}, tetlap.OptionError), ({"laplacian": 1.5}, tetlap.OptionError),
    ({"threads": 0}, tetlap.OptionError), ({"degenerate": "x"}, tetlap.OptionError),
])
def test_bad_options_are_refused(bad, error):
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(error):
        HeatDistance(V, T, **bad)


@pytest.mark.parametrize("sources, error", [
    (-1, tetlap.IndexRangeError), (27, tetlap.IndexRangeError), ([], tetlap.ShapeError),
    ([[0, 1]], tetlap.ShapeError), ([0.0], tetlap.OptionError), (True, tetlap.OptionError),
    ("0", tetlap.OptionError), (np.array([2**63], dtype=np.uint64), tetlap.IndexRangeError),
    (2**70, tetlap.IndexRangeError), (-2**70, tetlap.IndexRangeError),
    (0.5, tetlap.OptionError), (np.float64(1.0), tetlap.OptionError),
])
def test_bad_sources_are_refused(sources, error):
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(error):
        HeatDistance(V, T).distance(sources)


def test_inputs_are_not_modified_and_mesh_objects_work():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3)
    V0, T0, s = V.copy(), T.copy(), np.array([0, 5])
    d = tetlap.heat_distance(V, T, s)
    assert np.array_equal(V, V0) and np.array_equal(T, T0) and s.tolist() == [0, 5]
    mesh = meshio.Mesh(V, [("tetra", T)])
    assert np.array_equal(tetlap.heat_distance(mesh, s), d)
    assert np.array_equal(HeatDistance(mesh).distance(s), d)
    with pytest.raises(TypeError):
        tetlap.heat_distance(V, T)


def test_triangle_surface():
    """On the boundary sphere of a ball the heat distance approximates the great-circle
    distance."""
    V, T = tetlap.meshes.ball(3000, seed=0)
    F = tetlap.diagnostics.boundary_faces(T)
    s = int(np.argmax(V[:, 2]))
    d = tetlap.heat_distance(V, F, s)
    on = np.unique(F)
    R = np.linalg.norm(V[on], axis=1).mean()
    exact = R * np.arccos(np.clip(V[on] @ V[s] / (np.linalg.norm(V[on], axis=1) * np.linalg.norm(V[s])), -1, 1))
    assert np.abs(d[on] - exact).mean() < 0.03 * exact.max()


def test_triangle_meshes_take_every_boundary_condition():
    P = np.array([[x, y] for y in np.linspace(0, 1, 12) for x in np.linspace(0, 1, 12)])
    F = np.array([[i + 12 * j, i + 1 + 12 * j, i + 12 * (j + 1)] for j in range(11) for i in range(11)]
                 + [[i + 1 + 12 * j, i + 13 + 12 * j, i + 12 * (j + 1)] for j in range(11) for i in range(11)])
    centre = int(np.argmin(((P - 0.5) ** 2).sum(1)))
    for boundary in ("neumann", "average", "dirichlet"):
        assert mean_error(P, tetlap.heat_distance(P, F, centre, boundary=boundary), centre) < 0.05


def test_the_boundary_vertices_of_tets_are_the_diagnostics_ones():
    from tetlap.heat import _boundary_vertices
    V, T = tetlap.meshes.ball(300, seed=1)
    assert np.array_equal(_boundary_vertices(T, len(V)),
                          tetlap.diagnostics.boundary_vertices(T, len(V)))


@pytest.mark.parametrize("scale", [1e40, 1e-40, 1e150, 1e-140, 2.0**300])
def test_the_distance_is_the_same_at_any_scale(scale):
    # the heat step's powers of lengths left float64 from about 1e40: the distance was 0
    # everywhere, with only a NumPy warning
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    for boundary in ("neumann", "dirichlet", "average"):
        heat = HeatDistance(V, T, boundary=boundary)
        scaled = HeatDistance(V * scale, T, boundary=boundary)
        assert scaled.h == pytest.approx(heat.h * scale, rel=1e-14)
        assert scaled.t == pytest.approx(heat.t * scale**2, rel=1e-14)
        for s in (0, [5, 20]):
            d = heat.distance(s)
            assert d.max() > 0.5
            np.testing.assert_allclose(scaled.distance(s) / scale, d, rtol=0, atol=1e-13)
