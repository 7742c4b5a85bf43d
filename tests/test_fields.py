"""tetlap.harmonic: the operator "auto" picks, the maximum-principle proof's conditions,
the out-of-range count, biharmonic fields against libigl, bad input."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap.fields import RANGE_RTOL, maximum_principle
from test_regular_examples import mother, twisted_prism


def boundary(T, n):
    return np.flatnonzero(tetlap.diagnostics.boundary_vertices(T, n))


def step(V, b):
    return (V[b, 0] > np.median(V[b, 0])).astype(float)


def test_auto_takes_the_dual_on_a_delaunay_ball_and_proves_the_principle():
    V, T = tetlap.meshes.ball(800, seed=1)
    b = boundary(T, len(V))
    r = tetlap.harmonic(V, T, b, step(V, b))
    assert (r.laplacian, r.proved, r.out_of_range, r.weights) == ("dual", True, 0, None)
    assert r.field.min() >= -RANGE_RTOL and r.field.max() <= 1 + RANGE_RTOL
    assert np.array_equal(r.field[b], step(V, b))
    # the same field as solve.dirichlet with the dual
    f = tetlap.solve.dirichlet(tetlap.laplacian(V, T, "dual"), b, step(V, b))
    assert np.abs(r.field - f).max() < 1e-12


def test_auto_takes_regular_weights_on_a_regular_non_delaunay_mesh():
    V, T = tetlap.meshes.weighted_ball(400, 2.0, seed=3)
    b = boundary(T, len(V))
    interior = np.setdiff1d(np.arange(len(V)), b)
    dual = tetlap.laplacian(V, T, "dual")
    assert (dual[interior].toarray()[:, b].min() < 0) or (sp.triu(dual, 1).min() < 0)
    r = tetlap.harmonic(V, T, b, step(V, b))
    assert r.laplacian == "weighted dual" and r.proved and r.out_of_range == 0
    assert r.weights is not None and np.any(r.weights != 0)
    # the signs of the operator it solved with, re-checked here independently
    W = tetlap.laplacian(V, T, "dual", weights=r.weights).tocoo()
    free = np.ones(len(V), bool)
    free[b] = False
    at_free = (W.row != W.col) & (free[W.row] | free[W.col])
    assert W.data[at_free].min() >= -1e-12 * abs(W.data).max()


def test_no_operator_found_is_said_and_the_values_outside_are_counted():
    V, T = mother(0.0, apexes=2)                      # not regular, free: the two apexes
    r = tetlap.harmonic(V, T, np.arange(6), np.arange(6.0))
    assert r.laplacian == "primal" and not r.proved
    assert "no operator" in r.reason and "not regular" in r.reason
    lo, hi = 0.0, 5.0
    assert r.out_of_range == int(((r.field[6:] < lo) | (r.field[6:] > hi)).sum())


def test_the_fixed_set_decides_which_weights_matter():
    # twisted prism: negative dual weights only on edges between fixed (boundary) vertices
    V, T = twisted_prism(0.3)
    r = tetlap.harmonic(V, T, np.arange(6), np.arange(6.0))
    assert r.laplacian == "dual" and r.proved
    assert tetlap.edge_weights(V, T, "dual")[1].min() < 0
    # a Delaunay ball fixed on half its boundary: free boundary vertices see the dual's
    # boundary weights, which the interior statistic of tetlap.check does not count
    V, T = tetlap.meshes.ball(800, seed=1)
    b = boundary(T, len(V))
    half = b[V[b, 0] > 0]
    fixed = np.zeros(len(V), bool)
    fixed[half] = True
    _, proved, reason = maximum_principle(tetlap.laplacian(V, T, "dual"), fixed,
                                          np.ones(len(V), bool))
    L = tetlap.laplacian(V, T, "dual").tocoo()
    at_free = (L.row != L.col) & (~fixed[L.row] | ~fixed[L.col])
    assert proved == (L.data[at_free].min() >= -1e-12 * abs(L.data).max())


def test_maximum_principle_conditions_on_hand_made_matrices():
    def lap(n, edges):
        W = sp.lil_array((n, n))
        for i, j, w in edges:
            W[i, j] = W[j, i] = w
        W = sp.csr_array(W)
        return W - sp.diags_array(W.sum(axis=1))

    fixed = np.array([True, False, False, True])
    used = np.ones(4, bool)
    chain = lap(4, [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (0, 3, -5.0)])
    assert maximum_principle(chain, fixed, used)[1]          # the negative is fixed-fixed
    bad = lap(4, [(0, 1, 1.0), (1, 2, -1.0), (2, 3, 1.0)])
    assert not maximum_principle(bad, fixed, used)[1]
    stranded = lap(4, [(0, 3, 1.0), (1, 2, 1.0), (0, 1, 0.0)])   # 1-2 reach nothing
    ok, why = maximum_principle(stranded, fixed, used)[1:]
    assert not ok and "reach no fixed vertex" in why
    rounding = lap(4, [(0, 1, 1.0), (1, 2, 1.0), (2, 3, 1.0), (1, 3, -1e-14)])
    clean, ok, _ = maximum_principle(rounding, fixed, used)
    assert ok and clean[1, 3] == 0 and clean.sum(axis=1).max() == 0


def test_several_columns_are_the_columns_solved_alone():
    V, T = tetlap.meshes.cube(4, jitter=0.2, seed=2)
    b = boundary(T, len(V))
    X = np.stack([step(V, b), V[b, 1] ** 2, -V[b, 2]], axis=1)
    r = tetlap.harmonic(V, T, b, X, laplacian="primal")
    assert r.field.shape == (len(V), 3)
    for j in range(3):
        alone = tetlap.harmonic(V, T, b, X[:, j], laplacian="primal")
        assert np.abs(alone.field - r.field[:, j]).max() < 1e-12


def test_values_follow_the_order_of_fixed():
    V, T = tetlap.meshes.cube(3)
    b = boundary(T, len(V))
    vals = V[b, 0] + 2 * V[b, 1]
    perm = np.random.default_rng(0).permutation(len(b))
    a = tetlap.harmonic(V, T, b, vals).field
    c = tetlap.harmonic(V, T, b[perm], vals[perm]).field
    mask = np.zeros(len(V), bool)
    mask[b] = True
    assert np.array_equal(a, c) and np.array_equal(a, tetlap.harmonic(V, T, mask, vals).field)
    assert np.allclose(a, V[:, 0] + 2 * V[:, 1])              # linear precision


@pytest.mark.parametrize("k", [1, 2, 3])
def test_k_harmonic_equals_libigl(k):
    igl = pytest.importorskip("igl")
    V, T = tetlap.meshes.ball(500, seed=0)
    T = tetlap.meshes.orient(V, T).astype(np.int64)   # libigl assumes positive orientation
    b = boundary(T, len(V))
    bc = np.stack([step(V, b), V[b, 2]], axis=1)
    ours = tetlap.harmonic(V, T, b, bc, k=k, laplacian="auto" if k > 1 else "primal")
    theirs = igl.harmonic(V, T, b, bc, k)
    assert np.abs(ours.field - theirs).max() < 1e-9 * max(1, np.abs(theirs).max())
    assert ours.laplacian == "primal"
    lo, hi = bc.min(0), bc.max(0)
    tol = RANGE_RTOL * np.maximum(hi - lo, np.maximum(abs(lo), abs(hi)))
    free = np.setdiff1d(np.arange(len(V)), b)
    outside = ((theirs[free] < lo - tol) | (theirs[free] > hi + tol)).sum()
    assert ours.out_of_range == outside
    if k > 1:
        assert not ours.proved and "k = " in ours.reason


def test_components_unused_vertices_and_mesh_objects():
    V, T = tetlap.meshes.cube(3)
    V2 = np.vstack([V, V + 3, [[9.0, 9, 9]]])
    T2 = np.vstack([T, T + len(V)])
    b = boundary(T, len(V))
    with pytest.raises(tetlap.SolveError, match="no fixed vertex"):
        tetlap.harmonic(V2, T2, b, np.ones(len(b)))
    both = np.concatenate([b, b + len(V)])
    r = tetlap.harmonic(V2, T2, both, np.ones(len(both)))
    assert r.field[-1] == 0 and np.allclose(r.field[:-1], 1) and r.proved
    meshio = pytest.importorskip("meshio")
    mesh = meshio.Mesh(V, [("tetra", T)])
    assert np.array_equal(tetlap.harmonic(mesh, b, V[b, 0]).field,
                          tetlap.harmonic(V, T, b, V[b, 0]).field)


@pytest.mark.parametrize("kwargs, error", [
    ({"fixed": []}, tetlap.ShapeError), ({"fixed": [0, 0]}, tetlap.OptionError),
    ({"fixed": [-1]}, tetlap.IndexRangeError), ({"fixed": [99]}, tetlap.IndexRangeError),
    ({"fixed": [0.5]}, tetlap.DtypeError), ({"fixed": np.ones(5, bool)}, tetlap.ShapeError),
    ({"values": [1.0, 2.0]}, tetlap.ShapeError), ({"values": [np.nan]}, tetlap.NonFiniteError),
    ({"values": ["a"]}, tetlap.DtypeError), ({"k": 0}, tetlap.OptionError),
    ({"k": 1.5}, tetlap.OptionError), ({"k": True}, tetlap.OptionError),
    ({"laplacian": "cotan"}, tetlap.OptionError), ({"laplacian": 2.0}, tetlap.OptionError),
    ({"weights": np.zeros(27)}, tetlap.OptionError), ({"threads": 0}, tetlap.OptionError),
])
def test_bad_input_is_refused(kwargs, error):
    V, T = tetlap.meshes.cube(2)
    args = {"fixed": [0], "values": [1.0], **kwargs}
    with pytest.raises(error):
        tetlap.harmonic(V, T, **args)


@pytest.mark.parametrize("bad", [27, 2**40, -1])
@pytest.mark.parametrize("k, laplacian", [(1, "auto"), (1, "primal"), (2, "dual")])
def test_an_element_index_out_of_range_is_named(bad, k, laplacian):
    # an index beyond the vertices was a bare IndexError (negative ones were named)
    V, T = tetlap.meshes.cube(2)
    T = T.copy()
    T[3, 2] = bad
    with pytest.raises(tetlap.IndexRangeError, match=f"element 3 refers to vertex {bad}"):
        tetlap.harmonic(V, T, [0], [1.0], k=k, laplacian=laplacian)


def test_inputs_are_not_modified():
    V, T = tetlap.meshes.cube(3)
    b = boundary(T, len(V))
    vals = V[b, 0].copy()
    copies = [a.copy() for a in (V, T, b, vals)]
    tetlap.harmonic(V, T, b, vals, k=2)
    assert all(np.array_equal(a, c) for a, c in zip((V, T, b, vals), copies))


@pytest.mark.slow
def test_auto_proves_the_principle_wherever_the_dual_or_regular_weights_allow(real_mesh):
    """On every corpus mesh (boundary fixed to a step): proved with 0 values outside, or
    the plain dual has a negative weight at a free vertex and regular_weights does not
    find the mesh regular (EXPERIMENTS.md section 9)."""
    name, V, T = real_mesh
    V, T = tetlap.meshes.compact(V, T)
    b = boundary(T, len(V))
    r = tetlap.harmonic(V, T, b, step(V, b), degenerate="skip")
    if r.proved:
        assert r.out_of_range == 0, name
    else:
        dual, regular = r.reason.split("(", 1)[1].split(";")[:2]
        assert "negative weight" in dual and "regular" in regular, (name, r.reason)
        assert "regular_weights: regular" not in r.reason, (name, r.reason)


def test_values_are_paired_with_fixed_as_given_whatever_the_order():
    """``f[fixed[i]] = values[i]``: shuffling the pairs changes nothing, for one column and
    several, with every operator."""
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=2)
    b = boundary(T, len(V))
    values = np.column_stack([V[b, 0], np.sin(5 * V[b, 1]), np.arange(len(b))])
    rng = np.random.default_rng(7)
    for laplacian in ("auto", "primal", "dual"):
        r = tetlap.harmonic(V, T, b, values, laplacian=laplacian)
        assert np.array_equal(r.field[b], values)
        for _ in range(3):
            p = rng.permutation(len(b))
            shuffled = tetlap.harmonic(V, T, b[p], values[p], laplacian=laplacian)
            assert np.array_equal(shuffled.field, r.field), laplacian
            assert np.array_equal(shuffled.field[b[p]], values[p])
            one = tetlap.harmonic(V, T, b[p], values[p, 1], laplacian=laplacian)
            assert np.array_equal(one.field, r.field[:, 1])


def test_auto_falls_back_when_regular_weights_refuses_the_mesh():
    # at 1e-155 the regular weights of this mesh are beyond float64 in its units:
    # regular_weights refuses (NonFiniteError), and harmonic raised it instead of falling
    # back to the primal
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
    b = boundary(T, len(V))
    assert tetlap.harmonic(V, T, b, step(V, b)).laplacian == "weighted dual"
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.regular_weights(V * 1e-155, T)
    r = tetlap.harmonic(V * 1e-155, T, b, step(V, b))
    assert r.laplacian == "primal" and not r.proved and r.weights is None
    assert "regular_weights: the regular weights of this mesh" in r.reason
    assert np.abs(r.field - tetlap.harmonic(V, T, b, step(V, b), laplacian="primal").field
                  ).max() < 1e-12


@pytest.mark.parametrize("k", [1, 2, 3])
def test_the_field_is_the_same_at_any_scale(k):
    # the biharmonic's barycentric mass left float64 beyond 1e100 (DegenerateElementError)
    V, T = tetlap.meshes.cube(4, jitter=0.2, seed=1)
    b = boundary(T, len(V))
    values = V[b, 0] ** 2 - V[b, 1]
    r = tetlap.harmonic(V, T, b, values, k=k)
    for j in (-450, -300, -64, 3, 64, 300, 450):
        scaled = tetlap.harmonic(np.ldexp(V, j), T, b, values, k=k)
        assert np.array_equal(scaled.field, r.field) and scaled.laplacian == r.laplacian, j
    # other scales: the same operator to rounding (regular_weights, an iterative search,
    # may find other weights: the primal is compared)
    primal = tetlap.harmonic(V, T, b, values, k=k, laplacian="primal").field
    for s in (1e-150, 1e-110, 1e110, 1e150):
        scaled = tetlap.harmonic(V * s, T, b, values, k=k, laplacian="primal")
        assert np.abs(scaled.field - primal).max() < 1e-12, s
        assert tetlap.harmonic(V * s, T, b, values, k=k).proved == r.proved


def test_maximum_principle_refuses_the_stiffness_sign_and_checks_its_masks():
    V, T = tetlap.meshes.cube(3)
    fixed = tetlap.diagnostics.boundary_vertices(V, T)
    L = tetlap.laplacian(V, T, "dual")
    used = np.ones(len(V), bool)
    assert maximum_principle(L, fixed, used)[1]
    with pytest.raises(tetlap.OptionError, match="non-negative diagonal.*-K"):
        maximum_principle(-L, fixed, used)
    with pytest.raises(tetlap.ShapeError):
        maximum_principle(L, fixed[:-1], used)
    with pytest.raises(tetlap.ShapeError):
        maximum_principle(L[:5, :5], fixed, used)
    # integer indices are a mask too
    assert maximum_principle(L, np.flatnonzero(fixed), used)[1:] == \
        maximum_principle(L, fixed, used)[1:]
