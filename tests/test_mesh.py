"""tetlap.mesh (tetlap.Mesh): cached topology, updates equal to fresh assembly to the last bit."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap

KINDS = ["primal", "dual", 0.5]
MASSES = ["barycentric", "circumcentric", "fem"]


def fresh(V, T):
    return ([tetlap.laplacian(V, T, k) for k in KINDS], [tetlap.mass(V, T, k) for k in MASSES])


def cached(mesh):
    return [mesh.laplacian(k) for k in KINDS], [mesh.mass(k) for k in MASSES]


def assert_bitwise(a, b):
    for A, B in zip(a[0] + a[1], b[0] + b[1]):
        assert A.shape == B.shape
        np.testing.assert_array_equal(A.indptr, B.indptr)
        np.testing.assert_array_equal(A.indices, B.indices)
        assert A.data.tobytes() == B.data.tobytes()


@pytest.mark.parametrize("n_moved", [1, 5, 40, "all"])
def test_update_equals_fresh_assembly_bitwise(n_moved, rng):
    V, T = tetlap.meshes.ball(800, seed=2)
    mesh = tetlap.Mesh(V, T)
    assert_bitwise(cached(mesh), fresh(V, T))
    for step in range(3):
        V = V.copy()
        moved = np.arange(len(V)) if n_moved == "all" else rng.choice(len(V), n_moved, replace=False)
        V[moved] += rng.normal(scale=2e-3, size=(len(moved), 3))
        info = mesh.update(V)
        assert info.moved_vertices == len(moved)
        assert_bitwise(cached(mesh), fresh(V, T))
        np.testing.assert_array_equal(mesh.V, V)


def test_update_recomputes_only_the_star():
    V, T = tetlap.meshes.cube(4, jitter=0.2)
    mesh = tetlap.Mesh(V, T)
    mesh.laplacian("dual")
    V2 = V.copy()
    V2[62] += 0.01  # interior vertex (2, 2, 2) of the 5^3 grid
    info = mesh.update(V2)
    assert info == (1, 24, 15)
    assert mesh.update(V2) == (0, 0, 0)  # nothing moved


def test_failed_update_changes_nothing():
    V, T = tetlap.meshes.cube(2)
    mesh = tetlap.Mesh(V, T)
    L = mesh.laplacian("dual")
    bad = V.copy()
    bad[13] = bad[0]  # the centre vertex collapses onto a corner: zero-volume tets
    with pytest.raises(tetlap.DegenerateElementError):
        mesh.update(bad)
    nan = V.copy()
    nan[3, 1] = np.nan
    with pytest.raises(tetlap.NonFiniteError, match="vertex 3"):
        mesh.update(nan)
    with pytest.raises(tetlap.ShapeError):
        mesh.update(V[:-1])
    with pytest.raises(tetlap.ShapeError):
        mesh.update(np.column_stack([V, V[:, :1]]))
    np.testing.assert_array_equal(mesh.V, V)
    assert (mesh.laplacian("dual") != L).nnz == 0


def test_skip_policy_survives_updates():
    V, T = tetlap.meshes.cube(2)
    mesh = tetlap.Mesh(V, T, degenerate="skip")
    mesh.laplacian("primal")
    flat = V.copy()
    flat[13] = flat[0]
    mesh.update(flat)
    L = mesh.laplacian("primal")
    assert np.isfinite(L.data).all()
    assert (L != tetlap.laplacian(flat, T, "primal", degenerate="skip")).nnz == 0


def test_matrices_are_independent_of_later_updates():
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    mesh = tetlap.Mesh(V, T)
    L = mesh.laplacian("dual")
    before = L.data.copy()
    mesh.update(V * 1.5)
    np.testing.assert_array_equal(L.data, before)
    assert not L.indices.flags.writeable  # shared pattern, documented read-only


def test_immersed_mesh_updates(rng):
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    V4 = np.column_stack([V, np.zeros(len(V))])
    mesh = tetlap.Mesh(V4, T)
    mesh.laplacian("dual")
    V4[:, 3] = 0.1 * V4[:, 0] ** 2
    mesh.update(V4)
    assert (mesh.laplacian("dual") != tetlap.laplacian(V4, T, "dual")).nnz == 0


def test_properties_copies_and_shared_read_only_pattern():
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    mesh = tetlap.Mesh(V, T)
    assert mesh.n_vertices == len(V)
    V_copy = mesh.V
    V_copy[:] = 0  # a copy: the mesh keeps its coordinates
    np.testing.assert_array_equal(mesh.V, V)
    assert mesh.T.dtype == np.int64
    np.testing.assert_array_equal(mesh.T, T)
    L, M = mesh.operators("dual", "circumcentric")
    assert (L != mesh.laplacian("dual")).nnz == 0 and (M != mesh.mass("circumcentric")).nnz == 0
    F = mesh.mass("fem")
    assert np.shares_memory(L.indices, F.indices) and np.shares_memory(L.indptr, F.indptr)
    assert not F.indices.flags.writeable and not F.indptr.flags.writeable
    assert (M != tetlap.mass(V, T, "circumcentric")).nnz == 0
    assert (M != sp.diags_array(M.diagonal())).nnz == 0  # lumped: diagonal
    L.data[:] = 0  # the values are the caller's own
    assert mesh.laplacian("dual").nnz and abs(mesh.laplacian("dual")).max() > 0


def test_mesh_of_a_mesh_object_and_options_apply_to_every_operator():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.ball(300, seed=4)
    mesh = tetlap.Mesh(meshio.Mesh(V, [("tetra", T)]), boundary_centres="barycentric", threads=2)
    for kind in KINDS:
        if kind == "primal":                    # no dual centres: refused as ignored
            with pytest.raises(tetlap.OptionError, match="would ignore it"):
                mesh.laplacian(kind)
            continue
        expected = tetlap.laplacian(V, T, kind, boundary_centres="barycentric")
        assert_bitwise(([mesh.laplacian(kind)], []), ([expected], []))
    assert (mesh.mass("circumcentric") != tetlap.mass(V, T, "circumcentric",
                                                      boundary_centres="barycentric")).nnz == 0
    with pytest.raises(tetlap.OptionError):
        mesh.laplacian("cotan")
    with pytest.raises(tetlap.OptionError):
        tetlap.Mesh(V, T, threads=0)
