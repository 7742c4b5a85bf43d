"""tetlap.HeatDistance / tetlap.heat_distance: accuracy on convex meshes (the geodesic
distance is the Euclidean one), convergence, LaPy, options, bad input, disconnected and
unused vertices."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.heat import BOUNDARY_CONDITIONS, HeatDistance


def mean_error(V, d, s):
    exact = np.linalg.norm(V - V[s], axis=1)
    return np.abs(d - exact).mean() / exact.max()


def centre_and_boundary(V):
    return int(np.argmin((V ** 2).sum(1))), int(np.argmax(V[:, 0]))


@pytest.mark.parametrize("boundary", ["neumann", "average"])
def test_close_to_euclidean_on_a_ball(boundary):
    V, T = tetlap.meshes.ball(2000, seed=0)
    heat = HeatDistance(V, T, boundary_condition=boundary)
    for s in centre_and_boundary(V):
        d = heat.distance(s)
        assert d[s] == 0 and np.all(d >= -1e-12)
        assert mean_error(V, d, s) < 0.03


def test_dirichlet_is_accurate_from_an_interior_source():
    V, T = tetlap.meshes.ball(2000, seed=0)
    c, _ = centre_and_boundary(V)
    assert mean_error(V, tetlap.heat_distance(V, T, c, boundary_condition="dirichlet"), c) < 0.03


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
    assert HeatDistance(V, T, boundary_condition="average").n_factorizations == 3
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
    ({"t": 10**400}, tetlap.OptionError), ({"progress": 1}, tetlap.OptionError),
    ({"boundary_condition": "robin"}, tetlap.OptionError), ({"mass": "fem"}, tetlap.OptionError),
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
        assert mean_error(P, tetlap.heat_distance(P, F, centre, boundary_condition=boundary), centre) < 0.05


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
        heat = HeatDistance(V, T, boundary_condition=boundary)
        scaled = HeatDistance(V * scale, T, boundary_condition=boundary)
        assert scaled.h == pytest.approx(heat.h * scale, rel=1e-14)
        assert scaled.t == pytest.approx(heat.t * scale**2, rel=1e-14)
        for s in (0, [5, 20]):
            d = heat.distance(s)
            assert d.max() > 0.5
            np.testing.assert_allclose(scaled.distance(s) / scale, d, rtol=0, atol=1e-13)


# ---- the heat step is a heat flow, and a distance is never negative ------------------------

def octopus():
    from conftest import MESH_DIR, read_mesh

    path = MESH_DIR / "libigl_octopus_low.mesh"
    if not path.exists():
        pytest.skip(f"corpus mesh {path} not found (set TETLAP_MESHES)")
    return read_mesh(path)


def negative_eigenvalues(V, T, t, **options) -> int:
    """The negative eigenvalues of ``M - t L`` on the used vertices (dense, small meshes)."""
    L, M = tetlap.operators(V, T, options.get("laplacian", "primal"),
                            options.get("mass", "barycentric"))
    used = np.unique(T)
    A = (M - t * L)[used][:, used].toarray()
    return int((np.linalg.eigvalsh(A) < 0).sum())


@pytest.mark.parametrize("mesh, options", [
    ("flipped", {"laplacian": "dual"}), ("flipped", {"laplacian": "dual", "t_over_h2": 1e12}),
    ("octopus", {"laplacian": "dual"}), ("octopus", {"laplacian": 0.5}),
    ("octopus", {"laplacian": "dual", "t_over_h2": 1e12})])
def test_an_indefinite_heat_step_is_refused_counting_its_negative_eigenvalues(mesh, options):
    # the dual of a non-Delaunay mesh made M - t L indefinite (90 negative eigenvalues on
    # the octopus) and the distances ran from -20.8 to 15.3 with no error
    options = dict(options)
    c = options.pop("t_over_h2", 1.0)
    for V, T in [octopus() if mesh == "octopus" else tetlap.meshes.weighted_ball(600, 0.5,
                                                                                 seed=1)]:
        t = c * HeatDistance(V, T).h ** 2
        expected = negative_eigenvalues(V, T, t, **options) if c < 1e6 else None
        with pytest.raises(tetlap.SolveError, match="not positive definite") as e:
            HeatDistance(V, T, t=t, **options)
        negative = int(str(e.value).split(" has ")[1].split(" negative")[0])
        assert negative > 0 and (expected is None or negative == expected)
        assert "laplacian='primal'" in str(e.value) and "regular_weights" in str(e.value)
    # the primal and the weighted dual of the same meshes are heat flows
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    w = tetlap.regular_weights(V, T).weights
    for kwargs in ({}, {"laplacian": "dual", "weights": w}):
        assert negative_eigenvalues(V, T, HeatDistance(V, T).t, **{
            k: v for k, v in kwargs.items() if k != "weights"}) >= 0
        d = tetlap.heat_distance(V, T, 0, **kwargs)
        assert d.min() == 0 and np.isfinite(d[np.unique(T)]).all()


def test_a_negative_circumcentric_mass_that_breaks_the_heat_step_is_named():
    V, T = octopus()
    L, M = tetlap.operators(V, T, "primal", "circumcentric")
    assert (M.diagonal() < 0).any()
    with pytest.raises(tetlap.SolveError, match="mass='circumcentric' has negative entries"):
        HeatDistance(V, T, mass="circumcentric", t=1e-3 * HeatDistance(V, T).t)


BALL = tetlap.meshes.ball(500, seed=3)


@pytest.mark.parametrize("boundary_condition", BOUNDARY_CONDITIONS)
@pytest.mark.parametrize("options", [
    {}, {"laplacian": "dual"}, {"laplacian": 0.5}, {"mass": "mixed"},
    {"mass": "circumcentric"}, {"boundary_centres": "barycentric", "laplacian": "dual"},
    {"t_over_h2": 0.3}, {"t_over_h2": 30.0}, {"t_over_h2": 1e13}, {"weighted": True},
], ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()) or "default")
def test_distances_are_never_negative_and_their_minimum_is_zero(boundary_condition, options):
    # boundary="dirichlet" gave -7% of the largest distance on Delaunay balls: the
    # potential was shifted so that the source is 0, not so that the minimum is
    V, T = BALL
    options = dict(options)
    if options.pop("weighted", False):
        options.update(laplacian="dual", weights=tetlap.regular_weights(V, T).weights)
    if "t_over_h2" in options:
        options["t"] = options.pop("t_over_h2") * HeatDistance(V, T).t
    heat = HeatDistance(V, T, boundary_condition=boundary_condition, **options)
    for sources in [*range(0, len(V), 21), 343, [343, 21, 7]]:   # boundary and interior
        d = heat.distance(sources)
        assert np.isfinite(d).all() and (d >= 0).all() and d.min() == 0.0, sources
        assert d.max() > 0.5, (sources, d.max())


def test_the_minimum_is_zero_on_every_component_with_a_source():
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=4)
    V2, T2 = np.vstack([V, V + 3.0]), np.vstack([T, T + len(V)])
    for boundary_condition in BOUNDARY_CONDITIONS:
        d = tetlap.heat_distance(V2, T2, [5, len(V) + 40], boundary_condition=boundary_condition)
        assert d[:len(V)].min() == 0 and d[len(V):].min() == 0 and (d >= 0).all()


# ---- any t, any scale -----------------------------------------------------------------------

#: t / h^2 from 1e-300 to 1e300
T_OVER_H2 = [10.0 ** k for k in range(-300, 301, 20)] + [1e170, 2.0 ** 1000]


@pytest.mark.parametrize("boundary_condition", BOUNDARY_CONDITIONS)
def test_every_t_from_1e_300_to_1e300_h2_is_computed_or_refused(boundary_condition):
    # the distances were noise from t ~ 1e15 h^2 and exactly 0 from 1e170, with no error
    V, T = tetlap.meshes.cube(5, jitter=0.15, seed=2)
    h2 = HeatDistance(V, T).t
    limit = HeatDistance(V, T, t=1e300 * h2,
                         boundary_condition=boundary_condition).distance([0, 30])
    refused = []
    for c in T_OVER_H2:
        try:
            heat = HeatDistance(V, T, t=c * h2, boundary_condition=boundary_condition)
            d = heat.distance([0, 30])
        except tetlap.OptionError as e:
            assert "does not reach vertex" in str(e) and "take a larger t" in str(e)
            refused.append(c)
            continue
        assert heat.t == c * h2
        assert np.isfinite(d).all() and (d >= 0).all() and d.min() == 0 and d.max() > 0.1
        if c >= 1e4:   # the limit of a flat heat, approached as 1 / t
            assert np.abs(d - limit).max() < 1e2 / c + 1e-13, c
    # refused: every t below some bound, none near h^2
    assert refused and max(refused) < 1e-2
    assert refused == [c for c in T_OVER_H2 if c <= max(refused)]


def test_a_huge_t_is_the_limit_that_the_direct_factorization_approaches():
    import tetlap.heat as heat_module

    V, T = tetlap.meshes.ball(800, seed=1)
    h2 = HeatDistance(V, T).t
    for c in (1e8, 1e9, 1e10):
        default = HeatDistance(V, T, t=c * h2)
        d = default.distance(3)
        original = heat_module.MASS_RESOLUTION
        try:
            heat_module.MASS_RESOLUTION = 0.0       # always factorize M - t L
            direct = HeatDistance(V, T, t=c * h2)
            heat_module.MASS_RESOLUTION = 1.0       # always the limit
            limit = HeatDistance(V, T, t=c * h2)
        finally:
            heat_module.MASS_RESOLUTION = original
        assert direct.n_factorizations == 2 and limit.n_factorizations == 1
        assert np.abs(direct.distance(3) - d).max() < 1e-12
        assert np.abs(limit.distance(3) - d).max() < 1e-12


def test_a_heat_that_does_not_reach_a_vertex_is_refused_naming_it():
    # from a corner of a Kuhn grid the Dirichlet heat is 0 on every inner vertex (the
    # primal's weight on the cells' diagonals is 0): the distance was 0.33 everywhere
    V, T = tetlap.meshes.cube(3)
    with pytest.raises(tetlap.OptionError, match=r"does not reach vertex \d+ .*'neumann'"):
        tetlap.heat_distance(V, T, 0, boundary_condition="dirichlet")
    assert tetlap.heat_distance(V, T, 0, boundary_condition="average").min() == 0
    with pytest.raises(tetlap.OptionError, match=r"t = .* = 1e-100 h\^2\) does not reach"):
        tetlap.heat_distance(V, T, 0, t=1e-100 * HeatDistance(V, T).t)


K = [-500, -401, -300, -64, -63, -7, -1, 1, 2, 63, 64, 65, 200, 333, 500]


@pytest.mark.parametrize("boundary_condition", BOUNDARY_CONDITIONS)
def test_power_of_two_scalings_are_exact(boundary_condition):
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    w = np.random.default_rng(0).uniform(0, 1e-3, len(V))
    for options in ({}, {"t": 0.37}, {"t": 1e14}, {"laplacian": "dual", "weights": w}):
        # t = 1e14 is 6e14 h^2: the limit
        base = HeatDistance(V, T, boundary_condition=boundary_condition, **options)
        d = base.distance([0, 13])
        for k in K:
            if "t" in options and np.log2(options["t"]) + 2 * k > 1023:
                continue       # beyond float64
            scaled = dict(options)
            for key in ("t", "weights"):
                if key in scaled:
                    scaled[key] = np.ldexp(scaled[key], 2 * k)
            heat = HeatDistance(np.ldexp(V, k), T, boundary_condition=boundary_condition,
                                **scaled)
            assert heat.h == np.ldexp(base.h, k) and heat.t == np.ldexp(base.t, 2 * k), k
            assert np.array_equal(heat.distance([0, 13]), np.ldexp(d, k)), (options, k)


@pytest.mark.parametrize("scale", [1e-150, 1e-100, 1e-40, 3.0, 1e40, 1e100, 1e150])
def test_any_scale_from_1e_150_to_1e150(scale):
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    base, heat = HeatDistance(V, T), HeatDistance(V * scale, T)
    assert heat.h == pytest.approx(base.h * scale, rel=1e-15)
    assert heat.t == pytest.approx(base.t * scale**2, rel=1e-15)
    np.testing.assert_allclose(heat.distance(4) / scale, base.distance(4), rtol=0, atol=1e-13)


@pytest.mark.parametrize("scale", [1e-200, 1e-160, 1e155, 1e200])
def test_a_t_beyond_float64_is_said_so_and_the_distance_is_computed(scale):
    # h**2 raised OverflowError in the constructor once h passed 1.3e154; at 1e-200, t read 0.0
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    heat = HeatDistance(V * scale, T)
    assert heat.h == pytest.approx(HeatDistance(V, T).h * scale, rel=1e-15)
    with pytest.raises(OverflowError, match=r"t = h\^2 = \d\.\d+e[+-]\d+ is beyond the float64"):
        heat.t
    np.testing.assert_allclose(heat.distance(4) / scale, HeatDistance(V, T).distance(4),
                               rtol=0, atol=1e-13)
    exponent = int(heat._t_text().split("e")[1].split()[0])
    assert abs(exponent - 2 * np.log10(heat.h)) < 1


# ---- sources: a set, any integer, and the set-up's progress ---------------------------------

def test_sources_are_a_set_their_order_and_repeats_do_not_matter():
    V, T = tetlap.meshes.ball(400, seed=2)
    heat = HeatDistance(V, T, boundary_condition="average")
    sources = np.array([3, 50, 7, 211])
    d = heat.distance(sources)
    rng = np.random.default_rng(5)
    for _ in range(4):
        shuffled = rng.permutation(np.concatenate([sources, sources[:2]]))
        assert np.array_equal(heat.distance(shuffled), d)
        assert np.array_equal(heat.distance(list(shuffled.astype(np.int32))), d)


@pytest.mark.parametrize("sources", [[2**70], (0, -2**70), [0, 10**30]])
def test_python_integers_beyond_64_bits_are_named(sources):
    V, T = tetlap.meshes.cube(2)
    bad = [s for s in sources if not 0 <= s < len(V)][0]
    with pytest.raises(tetlap.IndexRangeError, match=f"sources holds {bad}, not a vertex"):
        HeatDistance(V, T).distance(sources)


def test_the_set_up_reports_its_steps(capsys):
    V, T = tetlap.meshes.cube(3)
    HeatDistance(V, T, progress=True, boundary_condition="average")
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"HeatDistance: {step} ..." for step in (
        "assemble", "factorize the heat step (Neumann)", "factorize the heat step (Dirichlet)",
        "factorize the Poisson step")]
    HeatDistance(V, T, progress=True, t=1e20)       # the limit: no Neumann factorization
    assert "Neumann" not in capsys.readouterr().err
    HeatDistance(V, T, progress=False)
    assert capsys.readouterr().err == ""
    with pytest.raises(tetlap.OptionError, match="progress"):
        HeatDistance(V, T, progress="yes")


# ---- the accuracy that the guide and the docstring quote --------------------------------------

def accuracy(V, T, s, **options):
    d = tetlap.heat_distance(V, T, s, **options)
    exact = np.linalg.norm(V - V[s], axis=1)
    big = exact.max()
    return (np.abs(d - exact).mean() / big, np.abs(d - exact).max() / big,
            (d < exact).mean(), (exact - d).max() / big)


def readme_table():
    """``{(mesh, source): (mean, worst, below, by)}`` of the accuracy table of the guide's
    page on distances, in fractions (None where a cell is empty)."""
    import pathlib
    import re

    root = pathlib.Path(__file__).resolve().parent.parent
    text = (root / "docs" / "guide" / "fields.md").read_text()
    section = text.split("## Geodesic distance (heat method)")[1].split("\n## ")[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[0].startswith("`"):
            continue
        numbers = [float(x) / 100 for x in re.findall(r"([\d.]+)%", " ".join(cells[1:]))]
        rows[cells[0]] = ([None, None] + numbers) if len(numbers) == 2 else numbers
    return rows


def close_to(measured, quoted) -> bool:
    """The measured mean, worst, fraction below and its worst against the table's row, to the
    digits it prints (0.1% for the errors, 1% for the fraction of vertices)."""
    return all(q is None or abs(m - q) <= tol for m, q, tol in
               zip(measured, quoted, (0.0006, 0.0006, 0.006, 0.0006)))


def test_the_readme_accuracy_table_is_measured():
    rows = readme_table()
    V, T = tetlap.meshes.ball(2000, seed=0)
    centre, side = int(np.argmin((V ** 2).sum(1))), int(np.argmax(V[:, 0]))
    for key, source in (("`ball(2000)` (the example below), centre", centre),
                        ("`ball(2000)`, a boundary vertex", side)):
        assert close_to(accuracy(V, T, source), rows[key]), key


@pytest.mark.slow
def test_the_readme_accuracy_table_is_measured_on_the_large_meshes():
    from conftest import MESH_DIR, read_mesh
    from tetlap.cli.geodesic import vertices

    rows = readme_table()
    V, T = tetlap.meshes.ball(30000, seed=0)
    centre, side = int(np.argmin((V ** 2).sum(1))), int(np.argmax(V[:, 0]))
    for key, source, options in (
            ("`ball(30000)`, centre", centre, {}),
            ("`ball(30000)`, a boundary vertex", side, {}),
            ("`ball(30000)`, boundary vertex, `\"average\"`", side,
             {"boundary_condition": "average"})):
        assert close_to(accuracy(V, T, source, **options), rows[key]), key
    for name in ("ipc_armadillo_13k.msh", "libigl_bunny.mesh"):
        if not (MESH_DIR / name).exists():
            pytest.skip(f"corpus mesh {name} not found")
        V, T = read_mesh(MESH_DIR / name)
        (source,), _ = vertices(["boundary"], V, T)
        key = next(k for k in rows if k.startswith(f"`{name}`"))
        assert close_to(accuracy(V, T, source), rows[key]), name
