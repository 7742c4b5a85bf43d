"""Paired data keep the user's order in tetlap.solve: ``f[fixed[i]] = values[i]`` for every
method, whatever order the indices come in (they were paired with the indices sorted)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import diagnostics as d
from tetlap import solve

V, T = tetlap.meshes.cube(4, jitter=0.2, seed=3)
N = len(V)
L = tetlap.laplacian(V, T, "dual")
BOUNDARY = np.flatnonzero(d.boundary_vertices(V, T))


@pytest.mark.parametrize("method", ["eliminate", "replace"])
def test_values_follow_their_indices_as_given(method):
    f = solve.dirichlet(L, [5, 2], [1.0, 0.0], method=method)
    assert (f[5], f[2]) == (1.0, 0.0)
    f = solve.dirichlet(L, np.array([5, 2], dtype=np.uint16), np.array([1, 0]), method=method)
    assert (f[5], f[2]) == (1.0, 0.0)


@pytest.mark.parametrize("method", ["eliminate", "replace"])
@pytest.mark.parametrize("seed", [0, 1])
def test_a_shuffled_boundary_gives_the_sorted_answer(method, seed):
    rng = np.random.default_rng(seed)
    u = np.sin(3 * V[:, 0]) + V[:, 1] * V[:, 2]
    sorted_answer = solve.dirichlet(L, BOUNDARY, u[BOUNDARY], method=method)
    perm = rng.permutation(len(BOUNDARY))
    shuffled = solve.dirichlet(L, BOUNDARY[perm], u[BOUNDARY[perm]], method=method)
    np.testing.assert_array_equal(shuffled, sorted_answer)
    np.testing.assert_array_equal(sorted_answer[BOUNDARY], u[BOUNDARY])
    # one value per vertex reads the same whatever the order of the indices
    np.testing.assert_array_equal(solve.dirichlet(L, BOUNDARY[perm], u, method=method),
                                  sorted_answer)


def test_a_mask_pairs_its_values_in_ascending_vertex_order():
    mask = np.zeros(N, dtype=bool)
    mask[BOUNDARY] = True
    u = np.cos(V[:, 2]) + V[:, 0]
    np.testing.assert_array_equal(solve.dirichlet(L, mask, u[mask]),
                                  solve.dirichlet(L, BOUNDARY, u[BOUNDARY]))


def test_all_vertices_fixed_in_another_order_is_ambiguous_and_refused():
    # (n,) values are one per vertex and one per fixed vertex at once: the readings differ
    perm = np.random.default_rng(2).permutation(N)
    with pytest.raises(tetlap.ShapeError, match="two readings differ"):
        solve.dirichlet(L, perm, V[:, 0])
    # in ascending order (or as a mask) both readings agree
    np.testing.assert_array_equal(solve.dirichlet(L, np.arange(N), V[:, 0]), V[:, 0])
    np.testing.assert_array_equal(solve.dirichlet(L, np.ones(N, dtype=bool), V[:, 0]), V[:, 0])


def test_a_non_finite_value_is_named_by_its_position():
    with pytest.raises(tetlap.NonFiniteError, match=r"values\[1\]") as e:
        solve.dirichlet(L, [5, 2], [1.0, np.nan])
    assert e.value.vertex == 2
    # a NaN at a free vertex of a per-vertex array is ignored, as documented
    u = V[:, 0].copy()
    free = np.setdiff1d(np.arange(N), BOUNDARY)
    u[free[0]] = np.nan
    assert np.isfinite(solve.dirichlet(L, BOUNDARY, u)).all()


def test_kkt_face_data_pair_with_the_faces_in_their_order():
    Vb, Tb = tetlap.meshes.ball(300, seed=2)
    Lb = tetlap.laplacian(Vb, Tb)
    grad = np.array([0.5, -1.0, 2.0])
    F, tets, corners = d.boundary_faces(Tb, return_tets=True)
    by_callable = solve.neumann_primal_kkt(Lb, Vb, Tb, lambda c, n: n @ grad)
    normals = solve._boundary.boundary(Vb, Tb).normals
    by_array = solve.neumann_primal_kkt(Lb, Vb, Tb, normals @ grad)
    np.testing.assert_array_equal(by_array, by_callable)
