"""regular_weights(V, T, coefficient=K): weights that make the dual in the metric K^-1
orthogonal, for a constant K. Each answer is checked independently of the search, on the
operator a user assembles: laplacian(V, T, "dual", coefficient=K, weights=w)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.regular import regular_weights

#: Test 1 of the FVCA6 3D benchmark, and a stronger shear (condition number about 40).
K_FVCA6 = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.5], [0.0, 0.5, 1.0]])
K_SHEAR = np.array([[4.0, 1.9, 0.0], [1.9, 1.0, 0.0], [0.0, 0.0, 0.25]])


def root(K, p):
    lam, Q = np.linalg.eigh(K)
    return (Q * lam**p) @ Q.T


def regular_in_metric(K, seed, n=200):
    """A mesh that is regular in the metric K^-1 and not Delaunay in it: the regular
    triangulation of weighted random points in the mapped space (where the metric is the
    Euclidean one), mapped back by K^1/2."""
    rng = np.random.default_rng(seed)
    Y = rng.uniform(-1, 1, size=(n, 3))
    T = tetlap.meshes.regular_triangulation(Y, rng.uniform(0, 0.06, size=n))
    Y, T = tetlap.meshes.compact(Y, T)
    return Y @ root(K, 0.5), T


def negative_interior(V, T, K, w):
    """Negative weights, beyond rounding, of the dual in the metric on edges not both on
    the boundary (the rule of tetlap.check)."""
    L = tetlap.laplacian(V, T, "dual", coefficient=K, weights=w)
    return tetlap.analysis.negative_weights(L, V, T)[1]


@pytest.mark.parametrize("K", [K_FVCA6, K_SHEAR], ids=["fvca6", "shear"])
@pytest.mark.parametrize("seed", [0, 1])
def test_weights_in_the_metric_make_its_dual_nonnegative(K, seed):
    V, T = regular_in_metric(K, seed)
    assert negative_interior(V, T, K, None) > 0         # the dual in the metric needs repair
    r = regular_weights(V, T, coefficient=K)
    assert r.status == "regular" and r.nonnegative_interior == "yes"
    assert r.n_negative_interior_plain > 0 and r.n_negative_interior_weighted == 0
    # independently: the operator a user assembles, and its linear precision
    assert negative_interior(V, T, K, r.weights) == 0
    L = tetlap.laplacian(V, T, "dual", coefficient=K, weights=r.weights)
    report = tetlap.check(L, V @ root(K, -0.5), T)
    assert report.linear_precision_ok


def test_the_euclidean_weights_do_not_repair_the_metric():
    """The keyword matters: the same mesh's weights for K = I leave the dual in the metric
    with negative weights (the mesh is far from Delaunay in Euclidean space)."""
    V, T = regular_in_metric(K_SHEAR, 0)
    plain = regular_weights(V, T, max_iterations=2000)
    assert negative_interior(V, T, K_SHEAR, plain.weights) > 0
    assert negative_interior(V, T, K_SHEAR, regular_weights(V, T, coefficient=K_SHEAR).weights) == 0


def test_a_constant_coefficient_in_any_form_is_the_same_metric():
    V, T = regular_in_metric(K_FVCA6, 2)
    m = len(T)
    one = regular_weights(V, T, coefficient=K_FVCA6)
    per_tet = regular_weights(V, T, coefficient=np.broadcast_to(K_FVCA6, (m, 3, 3)))
    assert np.array_equal(one.weights, per_tet.weights)
    # a scalar c: the metric of the mesh scaled by 1/sqrt(c) (exact for c = 4)
    scalar = regular_weights(V, T, coefficient=np.full(m, 4.0))
    assert np.allclose(scalar.weights, regular_weights(V / 2, T).weights, rtol=1e-12,
                       atol=1e-15)
    assert negative_interior(V, T, np.full(m, 4.0), scalar.weights) == 0


@pytest.mark.parametrize("k", [-480, 480])
def test_a_coefficient_scaled_by_a_power_of_two_scales_the_weights(k):
    """K 4^k: the mapped mesh is 2^-k times as large, its weights 4^-k times; exact, with
    no overflow or underflow at K about 1e+-289."""
    V, T = regular_in_metric(K_SHEAR, 3)
    r = regular_weights(V, T, coefficient=K_SHEAR)
    s = regular_weights(V, T, coefficient=np.ldexp(K_SHEAR, 2 * k))
    assert s.status == "regular"
    assert np.array_equal(s.weights, np.ldexp(r.weights, -2 * k))
    assert s.mass_min_weighted == r.mass_min_weighted


def test_a_varying_coefficient_is_refused_with_the_reason():
    V, T = tetlap.meshes.cube(2, jitter=0.1)
    c = np.ones(len(T))
    c[3] = 2.0
    with pytest.raises(tetlap.OptionError, match="constant coefficient only.*varies"):
        regular_weights(V, T, coefficient=c)
    K = np.broadcast_to(np.eye(3), (len(T), 3, 3)).copy()
    K[0, 2, 2] = 3.0
    with pytest.raises(tetlap.OptionError, match="no single lifting"):
        regular_weights(V, T, coefficient=K)


def test_bad_coefficients_get_the_rule_of_every_entry_point():
    V, T = tetlap.meshes.cube(2, jitter=0.1)
    bad = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # indefinite
    kept = bad.copy()
    with pytest.raises(tetlap.CoefficientError, match="smallest eigenvalue"):
        regular_weights(V, T, coefficient=bad)
    assert np.array_equal(bad, kept)
    with pytest.raises(tetlap.ShapeError, match="per vertex"):
        regular_weights(V, T, coefficient=np.ones(len(V)))
    with pytest.raises(tetlap.NonFiniteError):
        regular_weights(V, T, coefficient=np.full(len(T), np.nan))
    with pytest.raises(tetlap.CoefficientError):
        regular_weights(V, T, coefficient=np.zeros(len(T)))
    with pytest.raises(tetlap.OptionError, match="target_margin"):
        regular_weights(V, T, coefficient=np.eye(3), target_margin=-1.0)
