"""tetlap.benchmark (run by ``tetlap bench``): the mesh kinds, the case selection and the
records. The command and its table are tested in test_cli_bench.py."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial import Delaunay

import tetlap
from tetlap import benchmark


def sorted_tets(T):
    return {tuple(t) for t in np.sort(T, axis=1)}


# ---- mesh kinds -----------------------------------------------------------------------


def test_kuhn_is_the_jittered_cube():
    V, T = benchmark.mesh("kuhn", "10k")
    V2, T2 = tetlap.meshes.cube(benchmark.SIZES["10k"], jitter=0.2, seed=0)
    np.testing.assert_array_equal(V, V2)
    np.testing.assert_array_equal(T, T2)
    assert len(T) == 6 * 12**3


def test_delaunay_is_qhulls_tetrahedralisation_in_qhulls_order():
    V, T = benchmark.mesh("delaunay", "10k")
    n_tets = 6 * benchmark.SIZES["10k"] ** 3
    assert V.shape == (round(n_tets / benchmark.TETS_PER_POINT), 3)
    assert (V >= 0).all() and (V <= 1).all()
    D = Delaunay(V).simplices
    X = V[D]
    vol = np.abs(np.linalg.det(X[:, 1:] - X[:, :1]))
    np.testing.assert_array_equal(T, D[vol > 1e-12 * vol.mean()])  # same tets, same order
    assert abs(len(T) - n_tets) < 0.05 * n_tets


def test_ordered_is_a_local_renumbering_of_the_delaunay_mesh():
    V, T = benchmark.mesh("delaunay", "10k")
    V2, T2 = benchmark.mesh("ordered", "10k")
    order, order2 = np.lexsort(V.T), np.lexsort(V2.T)
    np.testing.assert_array_equal(V[order], V2[order2])
    new_of_old = np.empty(len(V), dtype=np.int64)
    new_of_old[order] = order2
    assert sorted_tets(new_of_old[T]) == sorted_tets(T2)  # the same tets
    assert (np.diff(T2.min(axis=1)) >= 0).all()  # tets by smallest vertex
    # locality: consecutive vertices are near each other, unlike in qhull's order
    step = lambda V: np.linalg.norm(np.diff(V, axis=0), axis=1).mean()  # noqa: E731
    assert step(V2) < 0.3 * step(V)


def test_shuffled_is_a_renumbering_of_the_delaunay_mesh():
    V, T = benchmark.mesh("delaunay", "10k")
    V2, T2 = benchmark.mesh("shuffled", "10k")
    assert V2.shape == V.shape and T2.shape == T.shape
    # the vertex of V2 at each row of V: match coordinates (all distinct)
    order, order2 = np.lexsort(V.T), np.lexsort(V2.T)
    np.testing.assert_array_equal(V[order], V2[order2])
    new_of_old = np.empty(len(V), dtype=np.int64)
    new_of_old[order] = order2
    assert sorted_tets(new_of_old[T]) == sorted_tets(T2)  # the same tets
    assert (new_of_old != np.arange(len(V))).mean() > 0.9  # really shuffled
    assert not np.array_equal(np.sort(new_of_old[T], axis=1), np.sort(T2, axis=1))
    # the same operator up to the renumbering
    A = tetlap.laplacian(V, T, "dual")
    B = tetlap.laplacian(V2, T2, "dual")[np.ix_(new_of_old, new_of_old)]
    assert abs(A - B).max() <= 1e-12 * abs(A).max()


def test_shuffled_keeps_coordinates_and_tets_and_is_seeded():
    V, T = tetlap.meshes.cube(2)
    a, b = benchmark.shuffled(V, T, seed=3), benchmark.shuffled(V, T, seed=3)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    V2, T2 = a
    assert {tuple(p) for p in V2} == {tuple(p) for p in V}
    assert {tuple(sorted(map(tuple, V2[t]))) for t in T2} == {tuple(sorted(map(tuple, V[t]))) for t in T}


# ---- cases, records, table -------------------------------------------------------------


def test_case_selection():
    names = ["floor", "tetlap primal", "tetlap dual", "tetlap.check dual", "numpy primal",
             "igl.cotmatrix", "igl.massmatrix voronoi", "Mesh: update 20 vertices"]
    assert benchmark._selected(names, None) == [
        "floor", "tetlap primal", "tetlap dual", "igl.cotmatrix", "Mesh: update 20 vertices"]
    assert benchmark._selected(names, ["dual"]) == [
        "floor", "tetlap dual", "tetlap.check dual", "igl.cotmatrix"]
    assert benchmark._selected(names, ["numpy", "Mesh"]) == [
        "floor", "numpy primal", "igl.cotmatrix", "Mesh: update 20 vertices"]


def test_every_case_runs_and_the_numpy_primal_is_the_primal():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    cases = benchmark._cases(V, T, threads=1)
    assert set(benchmark.DEFAULT_CASES) - {"igl.cotmatrix", "igl.massmatrix barycentric"} <= set(cases)
    for name, case in cases.items():
        case()
    P = benchmark.numpy_primal(V, T)
    assert abs(P - tetlap.laplacian(V, T, "primal")).max() <= 1e-13 * abs(P).max()


def test_records_and_table():
    V, T = tetlap.meshes.cube(3)
    records = benchmark.time_mesh("cube 3", V, T, threads=1, repeat=2, only=["tetlap primal"],
                                  progress=False)
    by_case = {r["case"]: r for r in records}
    assert "floor" in by_case and "tetlap primal" in by_case
    assert by_case["floor"]["vs_floor"] == 1.0
    for r in records:
        assert (r["mesh"], r["n_tets"], r["n_vertices"], r["threads"]) == ("cube 3", len(T), len(V), 1)
        assert r["median_s"] > 0
        assert r["mtets_per_s"] == pytest.approx(len(T) / r["median_s"] / 1e6)
        assert r["vs_floor"] == pytest.approx(r["median_s"] / by_case["floor"]["median_s"])
    json.dumps(records, allow_nan=False)
