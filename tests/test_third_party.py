"""The primal Laplacian and the masses against libigl and scikit-fem (when installed)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.meshes import orient

from conftest import MESH_DIR, read_mesh


def meshes():
    out = {"jittered cube": tetlap.meshes.cube(4, jitter=0.2, seed=1),
           "random ball": tetlap.meshes.ball(800, seed=2)}
    for name in ("vtkdata_tetramesh_mixed_orient.vtk", "sfepy_elbow2_inverted.mesh",
                 "libigl_octopus_low.mesh"):
        if (MESH_DIR / name).is_file():
            out[name] = read_mesh(MESH_DIR / name)
    return out


MESHES = meshes()


@pytest.mark.parametrize("name", list(MESHES))
def test_primal_equals_igl_cotmatrix_and_barycentric_equals_igl_massmatrix(name):
    igl = pytest.importorskip("igl")
    V, T = MESHES[name]
    T = orient(V, T)  # libigl assumes positively oriented tets; tetlap does not care
    A = tetlap.laplacian(V, T, "primal")
    B = igl.cotmatrix(V, T)  # same convention: L[i,j] = w_ij, NSD, no factor
    assert abs(A - B).max() <= 1e-12 * abs(A).max()
    M = igl.massmatrix(V, T, igl.MASSMATRIX_TYPE_BARYCENTRIC)
    assert abs(tetlap.mass(V, T, "barycentric") - M).max() <= 1e-12 * M.max()


@pytest.mark.parametrize("name", list(MESHES))
def test_primal_is_minus_the_scikit_fem_p1_stiffness(name):
    skfem = pytest.importorskip("skfem")
    from skfem.models.poisson import laplace, mass

    V, T = MESHES[name]
    used = np.unique(T)
    if len(used) != len(V):  # scikit-fem wants every vertex in a tet
        remap = np.full(len(V), -1)
        remap[used] = np.arange(len(used))
        V, T = V[used], remap[T]
    basis = skfem.Basis(skfem.MeshTet(V.T.copy(), orient(V, T).T.copy()), skfem.ElementTetP1())
    A = tetlap.laplacian(V, T, "primal")  # T in the file's orientation
    K = skfem.asm(laplace, basis)
    assert abs(A + K).max() <= 1e-12 * abs(A).max()
    F = skfem.asm(mass, basis)
    assert abs(tetlap.mass(V, T, "fem") - F).max() <= 1e-12 * abs(F).max()
