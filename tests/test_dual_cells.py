"""tetlap.io.dual_cells: Voronoi / power cells as VTK polyhedra whose volumes, read back
from the file, are the control volumes."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
import tetlap.io
from conftest import corpus_mesh
from tetlap.io import _dual_cells
from test_dual import small_weights

meshio = pytest.importorskip("meshio")


def volumes_read_back(path):
    """{vertex: volume} of the polyhedra of a .vtu file, by the divergence theorem over the
    faces read back (each a closed surface: the origin of the cones does not matter)."""
    mesh = meshio.read(path)
    P = mesh.points
    out = {}
    for block, vertices in zip(mesh.cells, mesh.cell_data["vertex"]):
        assert block.type.startswith("polyhedron")
        for faces, v in zip(block.data, vertices):
            # fans of the faces (the writer gives triangles), cones from one of the points
            fans = np.array([[f[0], f[k], f[k + 1]] for f in faces for k in range(1, len(f) - 1)])
            p, q, r = (P[fans[:, k]] - P[fans[0, 0]] for k in range(3))
            out[int(v)] = float(np.einsum("ij,ij->", p, np.cross(q, r))) / 6
    return out


@pytest.mark.parametrize("weighted", [False, True])
def test_cells_of_a_ball_read_back_with_the_control_volumes(tmp_path, weighted):
    V, T = tetlap.meshes.ball(300, seed=1)
    w = small_weights(V, T) if weighted else None
    cells = tetlap.io.dual_cells(V, T, weights=w)
    path = tmp_path / "cells.vtu"
    cells.write(path)
    got = volumes_read_back(path)
    M = tetlap.mass(V, T, "circumcentric", weights=w).diagonal()
    assert sorted(got) == list(range(len(V)))
    np.testing.assert_allclose([got[v] for v in range(len(V))], M, rtol=1e-12,
                               atol=1e-14 * np.abs(M).max())
    np.testing.assert_array_equal(np.concatenate(cells.cell_data["control_volume"]),
                                  M[np.concatenate(cells.cell_data["vertex"])])


def test_cells_of_a_corpus_mesh_read_back_with_the_control_volumes(tmp_path):
    """A nearly Delaunay corpus mesh (6 non-Delaunay faces of 10k)."""
    V, T = corpus_mesh("sofa_armadillo_4406.vtu")
    path = tmp_path / "cells.vtu"
    tetlap.io.dual_cells(V, T).write(path)
    got = volumes_read_back(path)
    M = tetlap.mass(V, T, "circumcentric").diagonal()
    used = np.flatnonzero(tetlap.diagnostics.referenced_vertices(T, len(V)))
    assert sorted(got) == used.tolist()
    np.testing.assert_allclose([got[v] for v in used], M[used], rtol=1e-11,
                               atol=1e-13 * np.abs(M).max())


@pytest.mark.parametrize("name,mesh", [("ball", tetlap.meshes.ball(200, seed=2)),
                                       ("non-Delaunay", tetlap.meshes.weighted_ball(200, 0.5, seed=1))])
def test_every_cell_is_a_closed_oriented_surface(name, mesh):
    """Every directed edge of a cell's triangles meets its reverse in the same cell, and the
    cones from two different points give the same (signed) volume: the mass."""
    V, T = mesh
    points, triangles, owner, volume = _dual_cells.surfaces(V, T, None, None)
    assert (np.diff(owner) >= 0).all()
    edges = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    who = np.tile(owner, 3)
    forward = np.column_stack([who, edges])
    backward = np.column_stack([who, edges[:, ::-1]])
    key = lambda rows: np.unique(rows, axis=0, return_counts=True)
    (f, fc), (b, bc) = key(forward), key(backward)
    np.testing.assert_array_equal(f, b)
    np.testing.assert_array_equal(fc, bc)
    for origin in (V[owner], np.full_like(V[owner], 3.0)):
        p, q, r = (points[triangles[:, k]] - origin for k in range(3))
        cones = np.bincount(owner, np.einsum("ij,ij->i", p, np.cross(q, r)) / 6, len(V))
        np.testing.assert_allclose(cones, volume, rtol=1e-10, atol=1e-12 * np.abs(volume).max())


def test_bad_input():
    V, T = tetlap.meshes.sphere3(40, seed=1)
    with pytest.raises(tetlap.ShapeError, match="R\\^3"):
        tetlap.io.dual_cells(V, T)
    with pytest.raises(tetlap.ShapeError):
        tetlap.io.dual_cells([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(tetlap.DegenerateElementError):
        tetlap.io.dual_cells([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2, 3]])
