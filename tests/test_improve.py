"""tetlap.improve: fewer negative interior dual weights, boundary and fixed vertices kept,
no tet inverted, inputs untouched, deterministic; the objective's gradient and its two
safeguards; options and meshes near the float range refused before any work. The command
is tested in test_cli_improve.py."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import tetlap
from tetlap import improve as imp


@pytest.fixture(scope="module")
def mesh():
    return tetlap.meshes.weighted_ball(500, 1.0, seed=3)


@pytest.fixture(scope="module")
def result(mesh):
    V, T = mesh
    return imp.improve(V, T, max_iterations=30)


def test_fewer_negative_weights_and_nothing_inverted(mesh, result):
    V, T = mesh
    assert result.before == imp.dual_statistics(V, T)
    assert result.after == imp.dual_statistics(result.V, T)
    assert result.after["negative_interior"] < result.before["negative_interior"]
    assert result.objective[1] < result.objective[0]
    s0 = np.sign(tetlap.diagnostics.signed_volumes(V, T))
    s1 = np.sign(tetlap.diagnostics.signed_volumes(result.V, T))
    assert np.array_equal(s0, s1)
    boundary = tetlap.diagnostics.boundary_vertices(T, len(V))
    assert np.array_equal(result.V[boundary], V[boundary])
    assert (result.V != V).any(axis=1).sum() > 0.5 * (~boundary).sum()
    assert result.history and result.iterations <= 30


def test_fixed_vertices_stay_and_inputs_are_untouched(mesh):
    V, T = mesh
    V0, T0 = V.copy(), T.copy()
    fixed = np.zeros(len(V), dtype=bool)
    fixed[::3] = True
    r = imp.improve(V, T, fixed=fixed, max_iterations=5)
    assert np.array_equal(r.V[fixed], V[fixed])
    assert np.array_equal(V, V0) and np.array_equal(T, T0)
    # deterministic, whatever the thread count
    r2 = imp.improve(V, T, fixed=fixed, max_iterations=5, threads=1)
    assert np.array_equal(r.V, r2.V)


def test_barrier_derivative_and_quality_gradient():
    r = np.array([-0.5, 1e-4, 1e-3 + 1e-9, 0.01, 0.3, 0.49, 0.7])
    b, db = imp._barrier(r)
    h = 1e-9
    fd = (imp._barrier(r + h)[0] - imp._barrier(r - h)[0]) / (2 * h)
    assert np.allclose(db, fd, rtol=1e-5)
    assert b[-1] == 0 and np.all(np.diff(b[:-1]) < 0)
    V, T = tetlap.meshes.cube(1, jitter=0.0)
    V = V + np.random.default_rng(0).uniform(-0.1, 0.1, V.shape)
    q, dq = imp._quality_and_gradient(V, T)
    for t, a, c in [(0, 1, 2), (3, 0, 0), (5, 3, 1)]:
        X = V.copy()
        X[T[t, a], c] += 1e-6
        Y = V.copy()
        Y[T[t, a], c] -= 1e-6
        fd = (imp._quality_and_gradient(X, T)[0][t] - imp._quality_and_gradient(Y, T)[0][t]) / 2e-6
        assert abs(fd - dq[t, a, c]) < 1e-6 * np.abs(dq[t]).max()


def test_experiment_quick(tmp_path):
    from tetlap.experiments import improve as experiment

    class Out:
        quick, seed, rows, lines = True, 0, [], []

        def row(self, **kw):
            self.rows.append(kw)

        def say(self, line=""):
            self.lines.append(line)

        def figure(self, name, draw):
            return None

    out = Out()
    experiment.run(out, meshes=str(tmp_path))  # an empty corpus: the shell part only
    (shell,) = [r for r in out.rows if r["part"] == "shell"]
    assert shell["negative_after"] < shell["negative_before"]
    assert any("variance ratio" in line for line in out.lines)


@pytest.mark.slow  # 9 s; the default run has improve()'s example in test_docstrings
def test_docstring_example_runs():
    import doctest

    result = doctest.testmod(imp)
    assert result.attempted >= 4 and result.failed == 0


def test_never_more_negative_weights_than_the_input():
    """A Kuhn grid has many zero interior weights (right dihedral angles): the penalty
    would trade them for tiny negative ones; the final scaling keeps the count."""
    V, T = tetlap.meshes.cube(4)
    r = imp.improve(V, T, max_iterations=10)
    assert r.before["negative_interior"] == 0
    assert r.after["negative_interior"] == 0


def test_the_negative_count_is_that_of_check(mesh, result):
    V, T = mesh
    for X in (V, result.V):
        L = tetlap.laplacian(X, T, "dual", degenerate="skip")
        assert imp.dual_statistics(X, T)["negative_interior"] == tetlap.check(
            L, X, T, nsd=False).n_negative_interior


def test_the_objective_gradient_against_finite_differences(mesh):
    V, T = mesh
    objective = imp.Objective(V, T, np.zeros(len(V), dtype=bool), margin=0.5, barrier=10.0,
                              regularization=1e-2, threads=None)
    rng = np.random.default_rng(0)
    x = objective.start() + rng.uniform(-1e-3, 1e-3, len(objective.start()))
    phi, grad = objective(x)
    assert objective.evaluations == 1 and phi > 0
    for k in rng.choice(len(x), 8, replace=False):
        e = np.zeros_like(x)
        e[k] = 1e-7
        fd = (objective(x + e)[0] - objective(x - e)[0]) / 2e-7
        assert fd == pytest.approx(grad[k], rel=1e-4, abs=1e-6 * np.abs(grad).max())
    boundary = tetlap.diagnostics.boundary_vertices(T, len(V))
    assert not boundary[objective.free].any()
    assert np.array_equal(objective.positions(objective.start()), V)


def test_keep_orientation_scales_back_a_move_that_inverts_a_tet(mesh):
    V, T = mesh
    objective = imp.Objective(V, T, np.zeros(len(V), dtype=bool), margin=0.02, barrier=10.0,
                              regularization=1e-4, threads=None)
    x0 = objective.start()
    assert imp.keep_orientation(objective, x0, x0) == 1.0
    v = objective.free[0]
    tet = T[np.flatnonzero((T == v).any(axis=1))[0]]
    others = V[tet[tet != v]]
    X = V.copy()
    X[v] = 2 * others.mean(axis=0) - V[v]          # through the opposite face: inverted
    x = X[objective.free].ravel()
    alpha = imp.keep_orientation(objective, x0, x)
    assert 0 <= alpha < 1
    ratios = objective.quality_ratios(objective.positions(x0 + alpha * (x - x0)))
    assert (ratios > imp.R1).all()


def test_fewest_negative_weights_never_adds_any():
    V, T = tetlap.meshes.cube(4)                     # zero weights, no negative one
    objective = imp.Objective(V, T, np.zeros(len(V), dtype=bool), margin=0.02, barrier=10.0,
                              regularization=1e-4, threads=None)
    x0 = objective.start()
    x = x0 + np.random.default_rng(1).uniform(-0.02, 0.02, len(x0))
    assert objective.negative_interior(objective.positions(x)) > 0
    assert imp.fewest_negative_weights(objective, x0, x, 1.0) == 0.0
    assert imp.fewest_negative_weights(objective, x0, x, 0.0) == 0.0


@pytest.mark.parametrize("option, value", [
    ("step", 0), ("step", -1), ("step", np.nan), ("step", np.inf), ("margin", np.nan),
    ("margin", -0.1), ("barrier", np.inf), ("regularization", -1), ("max_iterations", 0),
    ("max_iterations", 2.5), ("threads", 0), ("step", "0.3"), ("margin", True),
])
def test_impossible_options_raise_option_error_before_any_work(option, value, mesh, monkeypatch):
    """Issue 24.3: step=0 gave an AttributeError from SciPy, -1 SciPy's words, NaN and
    inf were taken, margin=NaN was reported as an internal cotangent."""
    def work(*args, **kwargs):
        raise AssertionError("work started before the options were checked")

    monkeypatch.setattr(imp, "dual_statistics", work)
    V, T = mesh
    with pytest.raises(tetlap.OptionError, match=f"^{option} must be|^threads must be"):
        imp.improve(V, T, **{option: value})


def test_a_mesh_beyond_the_float_range_is_refused(mesh):
    V, T = mesh
    for scale in (1e200, 1e-200):
        with pytest.raises(tetlap.DegenerateElementError, match="beyond the float64 range"):
            imp.improve(V * scale, T, max_iterations=3)


def test_far_from_everyday_units_the_same_moves_without_warnings(mesh):
    """A mesh scaled by 2^200 or 2^-200 is moved in the same rescaled copy: the same result,
    scaled back exactly; no NumPy overflow on the way."""
    V, T = mesh
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        big = imp.improve(V * 2.0**200, T, max_iterations=5)
        small = imp.improve(V * 2.0**-200, T, max_iterations=5)
        huge = imp.improve(V * 1e100, T, max_iterations=5)
    assert np.array_equal(big.V / 2.0**200, small.V * 2.0**200)
    assert big.after["negative_interior"] == small.after["negative_interior"]
    assert big.after["negative_interior"] < big.before["negative_interior"]
    assert np.isfinite(huge.after["min_volume"]) and huge.after["min_volume"] > 0


def test_fixed_is_a_set_its_order_and_form_do_not_matter():
    """``fixed`` pairs no data with its vertices: any order, repeats, or the mask give the
    same moves (it is read as a mask, never sorted against other data)."""
    V, T = tetlap.meshes.weighted_ball(120, 1.0, seed=1)
    inner = np.flatnonzero(~tetlap.diagnostics.boundary_vertices(V, T))[:6]
    base = imp.improve(V, T, fixed=inner, max_iterations=3)
    assert np.array_equal(base.V[inner], V[inner]) and not np.array_equal(base.V, V)
    mask = np.zeros(len(V), bool)
    mask[inner] = True
    shuffled = np.random.default_rng(3).permutation(np.concatenate([inner, inner[:2]]))
    for fixed in (shuffled.astype(np.int32), mask):
        assert np.array_equal(imp.improve(V, T, fixed=fixed, max_iterations=3).V, base.V)
