"""Numbers at the edges of float64: sums that overflow, volumes that leave the range,
extreme needles, weights far beyond the squared edges. Every function gives a finite,
accurate result or a documented error, and ``degenerate="skip"`` follows one rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import tetlap

CUBE = tetlap.meshes.cube(2)


def every_output(V, T, **options):
    """Every public operator output of the mesh (L of three kinds, M of three kinds)."""
    out = [tetlap.laplacian(V, T, k, **options) for k in ("primal", "dual", 0.5)]
    out += [tetlap.mass(V, T, k, **options) for k in ("barycentric", "circumcentric", "fem")]
    out += list(tetlap.operators(V, T, "dual", "circumcentric", **options))
    return out


@pytest.mark.parametrize("call", [
    lambda V, T: tetlap.mass(V, T, "barycentric"),
    lambda V, T: tetlap.mass(V, T, "circumcentric"),
    lambda V, T: tetlap.mass(V, T, "fem"),
    lambda V, T: tetlap.operators(V, T, "primal", "barycentric"),
    lambda V, T: tetlap.Mesh(V, T).mass("barycentric"),
], ids=["barycentric", "circumcentric", "fem", "operators", "Mesh"])
def test_mass_sums_that_overflow_are_an_error_not_inf(call):
    V, T = CUBE
    # every tet's volume is finite (~1e308 / 48), their sums at a vertex are not
    with pytest.raises(tetlap.NonFiniteError, match="sum beyond") as e:
        call(V * 1.6e103, T)
    assert e.value.vertex is not None and 0 <= e.value.vertex < len(V)


def test_laplacian_sums_that_overflow_are_an_error_not_inf():
    V, T = CUBE
    with pytest.raises(tetlap.NonFiniteError, match="sum beyond"):
        tetlap.laplacian(V * 1e308, T)
    with pytest.raises(tetlap.NonFiniteError, match="sum beyond"):
        tetlap.edge_weights(V * 1e308, T)
    # the per-tet values themselves are finite there: nothing is summed, nothing overflows
    assert np.isfinite(tetlap.element_contributions(V * 1e300, T)).all()


def test_an_update_that_would_overflow_leaves_the_mesh_unchanged():
    V, T = CUBE
    mesh = tetlap.Mesh(V, T)
    L, M = mesh.laplacian("dual"), mesh.mass("barycentric")
    with pytest.raises(tetlap.NonFiniteError):
        mesh.update(V * 1.6e103)
    assert (mesh.laplacian("dual") != L).nnz == 0 and (mesh.mass("barycentric") != M).nnz == 0
    np.testing.assert_array_equal(mesh.V, V)
    V2 = V.copy()
    V2[13] *= 1.6e103  # one vertex far away: its own tets' masses overflow first
    with pytest.raises(tetlap.TetlapError):
        mesh.update(V2)
    assert (mesh.mass("barycentric") != M).nnz == 0


@pytest.mark.parametrize("scale", [1e-110, 1e-120, 1e104, 1e110])
def test_masses_outside_the_float64_range_are_errors_or_skipped(scale):
    V, T = CUBE
    for kind in ("barycentric", "circumcentric", "fem"):
        with pytest.raises(tetlap.DegenerateElementError, match="float64 range"):
            tetlap.mass(V * scale, T, kind)
        M = tetlap.mass(V * scale, T, kind, degenerate="skip")
        assert np.isfinite(M.data).all() and (M.data == 0).all()
    # the Laplacian scales like a length and stays exact
    L = tetlap.laplacian(V * scale, T, "dual")
    ref = tetlap.laplacian(V, T, "dual")
    assert abs(L / scale - ref).max() <= 1e-13 * abs(ref).max()


@pytest.mark.parametrize("kind", ["barycentric", "circumcentric", "fem"])
def test_volumes_near_the_top_of_the_range_are_exact(kind):
    """A tet of volume ~2e307: finite, although the power-of-two scale the kernels
    normalise by, cubed (~2^1026), is not."""
    s = 5e102
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * s
    M = tetlap.mass(V, np.array([[0, 1, 2, 3]]), kind)
    assert np.isfinite(M.data).all()
    assert M.sum() == pytest.approx(s**3 / 6, rel=1e-14)


def test_skip_drops_an_element_from_exactly_the_outputs_it_fails():
    """One rule: an output of operators() equals that output computed alone."""
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=1)
    V = V * 1e120  # every volume overflows (~1e360), every weight (~1e120) is finite
    for lap, mass in (("primal", "barycentric"), ("dual", "circumcentric"), (0.3, "fem")):
        L, M = tetlap.operators(V, T, lap, mass, degenerate="skip")
        assert (L != tetlap.laplacian(V, T, lap, degenerate="skip")).nnz == 0
        assert (M != tetlap.mass(V, T, mass, degenerate="skip")).nnz == 0
        assert np.isfinite(L.data).all() and np.isfinite(M.data).all()
        assert abs(L).max() > 1e100 and abs(M).max() == 0  # weights kept, masses dropped
        with pytest.raises(tetlap.DegenerateElementError):
            tetlap.operators(V, T, lap, mass)


@pytest.mark.parametrize("h", [1e-10, 1e-40, 1e-80, 1e-100, 1e-120, 1e-150])
def test_needles_keep_full_precision(h):
    """(0,0,0), (h,0,0), (0,h,0), (0,0,1): exact weights for every h (rational values)."""
    V = np.array([[0, 0, 0], [h, 0, 0], [0, h, 0], [0, 0, 1.0]])
    T = [[0, 1, 2, 3]]
    dual = tetlap.element_contributions(V, T, "dual")[0]
    primal = tetlap.element_contributions(V, T, "primal")[0]
    # the corner tet scaled by (h, h, 1): primal = dual-of-edge-01 style closed forms
    assert dual[0] == pytest.approx(0.25, rel=1e-12)
    assert dual[1] == pytest.approx(0.25, rel=1e-12)
    assert primal[0] == pytest.approx(1 / 6, rel=1e-12)
    assert primal[1] == pytest.approx(1 / 6, rel=1e-12)
    assert primal[2] == pytest.approx(h * h / 6, rel=1e-12)
    L = tetlap.laplacian(V, T, "dual")
    assert np.abs(L.sum(axis=1)).max() <= 1e-15 * abs(L).max()
    if h >= 1e-100:  # the volume h^2 / 6 is a normal float64
        m = tetlap.mass(V, T, "circumcentric").diagonal()
        assert m.sum() == pytest.approx(h * h / 6, rel=1e-12)


@pytest.mark.parametrize("h", [1e-10, 1e-80, 1e-150])
def test_needle_triangles_keep_full_precision(h):
    for V in ([[0, 0], [1, 0], [0, h]], [[0, 0, 0], [1, 0, 0], [0, 0, h]]):
        W = tetlap.element_contributions(V, [[0, 1, 2]], "primal")[0]
        assert W[0] == pytest.approx(h / 2, rel=1e-12) and W[1] == pytest.approx(1 / (2 * h), rel=1e-12)
        np.testing.assert_allclose(tetlap.element_contributions(V, [[0, 1, 2]], "dual")[0], W, rtol=1e-12)


def test_weights_far_beyond_the_squared_edges_are_computed_accurately():
    """Weights of 1e10 squared edges put the power centres far outside every tet; the dual
    goes through products of barycentric coordinates, so the values keep their accuracy
    (against exact rationals) and the cell volumes still sum to the volume."""
    import exact_reference as ex

    V, T = tetlap.meshes.ball(400, seed=0)
    w = np.random.default_rng(0).uniform(0, 0.04, len(V)) * 1e10
    W = tetlap.element_contributions(V, T, "dual", weights=w) if hasattr(
        tetlap, "element_contributions") else tetlap.tet_contributions(V, T, "dual", weights=w)
    for t in range(0, len(T), 97):
        exact, _ = ex.dual_tet([ex.vec(V[i]) for i in T[t]], [w[i] for i in T[t]])
        scale = max(abs(float(x)) for x in exact)
        assert max(abs(a - float(b)) for a, b in zip(W[t], exact)) <= 1e-12 * scale
    M = tetlap.mass(V, T, "circumcentric", weights=w).diagonal()
    assert abs(M.sum() - tetlap.mass(V, T).sum()) <= 1e-12 * np.abs(M).sum()


@settings(max_examples=60, deadline=None)
@given(exponent=st.integers(-330, 330), kind=st.sampled_from(["primal", "dual", 0.5]),
       mass=st.sampled_from(["barycentric", "circumcentric", "fem"]),
       degenerate=st.sampled_from(["raise", "skip"]))
def test_fuzz_any_scale_gives_finite_operators_or_a_documented_error(exponent, kind, mass,
                                                                    degenerate):
    """Sums included: whatever the scale, never Inf/NaN in an output."""
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=exponent % 7)
    with np.errstate(over="ignore", invalid="ignore"):  # beyond 1e308: Inf/NaN coordinates
        scale = 10.0 ** exponent if abs(exponent) < 308 else np.float64(2.0) ** (exponent * 3.32)
        V = V * scale
    try:
        L, M = tetlap.operators(V, T, kind, mass, degenerate=degenerate)
    except (tetlap.DegenerateElementError, tetlap.NonFiniteError, tetlap.EmptyMeshError):
        return
    assert np.isfinite(L.data).all() and np.isfinite(M.data).all()


@settings(max_examples=60, deadline=None)
@given(log_ratio=st.floats(-170, 0), seed=st.integers(0, 2**16),
       kind=st.sampled_from(["primal", "dual"]))
@example(log_ratio=-8.0, seed=431, kind="dual")     # found by Hypothesis: 1.8e-13
def test_fuzz_extreme_anisotropy_keeps_row_sums_and_linear_precision(log_ratio, seed, kind):
    """A grid squashed along one axis by up to 1e-170: rows still sum to zero (to 1e-12 of
    their largest entry, the stated limit) and linear functions are still reproduced at
    interior vertices (relative to the row scale), or,
    when a flat tet's own dual weights leave the float64 range (their size grows like the
    inverse square of the flatness: beyond ~1e-150), a documented error."""
    V, T = tetlap.meshes.cube(3, jitter=0.15, seed=seed % 97)
    V = V * np.array([1.0, 1.0, 10.0 ** log_ratio])
    try:
        L = tetlap.laplacian(V, T, kind)
    except tetlap.DegenerateElementError:
        assert kind == "dual" and log_ratio < -150
        return
    assert np.isfinite(L.data).all()
    scale = np.abs(L).max(axis=1).toarray().ravel()
    # the stated limit (docs/guide/accuracy.md): rows sum to zero within 1e-12 of their largest
    # entry; the dual of seed 431 squashed by 1e-8 has 1.8e-13 (tets' weights of either
    # sign on an edge: the diagonal's grouping of the sums rounds apart from the row's)
    assert (np.abs(L.sum(axis=1)) <= 1e-12 * scale).all()
    inner = tetlap.diagnostics.interior_vertices(T, len(V))
    LV = L @ V
    for axis in range(3):
        extent = np.ptp(V[:, axis])
        assert (np.abs(LV[inner, axis]) <= 1e-10 * scale[inner] * extent).all()
