"""tetlap.io.dual_cells: the Voronoi / power cells as polyhedra with shared faces, one per
control volume, written to .vtu and .vtk and read back by VTK (PyVista) and meshio with
their control volumes, on any mesh: not Delaunay, Kuhn grids, weighted, folded."""

from __future__ import annotations

import os

import meshio
import numpy as np
import pytest

import tetlap
import tetlap.io
from conftest import corpus_mesh
from test_dual import small_weights

#: Two tets on the same side of their common face (0, 1, 2): the mesh folds over itself.
FOLDED = (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 1], [0.3, 0.1, 0.5]]),
          np.array([[0, 1, 2, 3], [0, 1, 2, 4]]))
#: Two tets that share only the edge (0, 1): its dual face closes through its point twice.
PINCHED = (np.array([[0.0, 0, 0], [1, 0, 0], [0.3, 1, 0], [0.4, 0.3, 1], [0.5, -1, 0.1],
                     [0.6, -0.3, -1]]), np.array([[0, 1, 2, 3], [0, 1, 4, 5]]))


def meshes():
    ball = tetlap.meshes.ball(300, seed=1)
    yield "ball", (*ball, None)
    yield "ball-weighted", (*ball, small_weights(*ball))
    yield "non-Delaunay", (*tetlap.meshes.weighted_ball(200, 0.5, seed=1), None)
    yield "Kuhn", (*tetlap.meshes.cube(3), None)
    yield "folded", (*FOLDED, None)
    yield "pinched", (*PINCHED, None)
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=4)
    yield "a vertex in no tet", (np.vstack([[5.0, 5, 5], V]), T + 1, None)


MESHES = [pytest.param(*mesh, id=name) for name, mesh in meshes()]


def divergence_volumes(P, cells, origin):
    """{vertex: volume} of cells given as (vertex, faces: lists of point indices), by the
    divergence theorem: cones from ``origin`` over a fan of every face."""
    out = {}
    for vertex, faces in cells:
        fans = np.array([[f[0], f[k], f[k + 1]] for f in faces for k in range(1, len(f) - 1)])
        p, q, r = (P[fans[:, k]] - origin for k in range(3))
        out[int(vertex)] = float(np.einsum("ij,ij->", p, np.cross(q, r))) / 6
    return out


def read_with_vtk(path):
    """(points, [(vertex, faces)], control volumes) as VTK reads the file (PyVista)."""
    pv = pytest.importorskip("pyvista")
    grid = pv.read(path)
    assert (grid.celltypes == pv.CellType.POLYHEDRON).all()
    cells = [(v, [face.point_ids for face in grid.get_cell(c).faces])
             for c, v in enumerate(grid.cell_data["vertex"])]
    return np.asarray(grid.points), cells, dict(zip(grid.cell_data["vertex"].tolist(),
                                                    grid.cell_data["control_volume"]))


def read_with_meshio(path):
    mesh = meshio.read(path)
    cells, volume = [], {}
    for block, vertices, cv in zip(mesh.cells, mesh.cell_data["vertex"],
                                   mesh.cell_data["control_volume"]):
        assert block.type.startswith("polyhedron")
        cells += list(zip(vertices, block.data))
        volume.update(zip(np.ravel(vertices).tolist(), np.ravel(cv)))
    return mesh.points, cells, volume


def assert_the_control_volumes(V, T, w, P, cells, volume):
    """Every vertex in a tet has one cell, whose volume from two far apart origins is the
    circumcentric mass, and whose cell data says so."""
    M = tetlap.mass(V, T, "circumcentric", weights=w).diagonal()
    used = np.flatnonzero(tetlap.diagnostics.referenced_vertices(V, T))
    assert sorted(int(v) for v, _ in cells) == used.tolist()
    np.testing.assert_array_equal([volume[v] for v in used], M[used])
    # a surface that is not closed gives a volume that depends on the origin: from a
    # second one 3 diameters away (cancellation there costs about 1e-11)
    for origin, tol in ((P.mean(axis=0), 1e-12), (P.mean(axis=0) + 3 * np.ptp(P, axis=0), 1e-9)):
        got = divergence_volumes(P, cells, origin)
        np.testing.assert_allclose([got[v] for v in used], M[used], rtol=0,
                                   atol=tol * np.abs(M).max())


@pytest.mark.parametrize("ext", [".vtu", ".vtk"])
@pytest.mark.parametrize("V,T,w", MESHES)
def test_files_read_back_by_vtk_hold_the_control_volumes(tmp_path, V, T, w, ext):
    """Both formats, read by VTK: the divergence theorem over each cell's faces gives its
    control volume from any origin (the folded mesh's cells hold its fold twice; the
    triangle fans written before missed 3.6% of a folded mesh's volumes and the .vtk
    writer raised AttributeError)."""
    path = tmp_path / f"cells{ext}"
    tetlap.io.dual_cells(V, T, weights=w).write(path)
    assert_the_control_volumes(V, T, w, *read_with_vtk(path))


@pytest.mark.parametrize("V,T,w", MESHES)
def test_vtu_files_read_back_by_meshio_hold_the_control_volumes(tmp_path, V, T, w):
    path = tmp_path / "cells.vtu"
    tetlap.io.dual_cells(V, T, weights=w).write(path)
    assert_the_control_volumes(V, T, w, *read_with_meshio(path))


def test_a_folded_corpus_mesh(tmp_path):
    """8 tets of this mesh fold against their neighbours (32 faces with both tets on one
    side): its cells hold their control volumes, read back from the file."""
    V, T = corpus_mesh("polyfem_microstructure_p1.msh")
    path = tmp_path / "cells.vtu"
    tetlap.io.dual_cells(V, T).write(path)
    assert_the_control_volumes(V, T, None, *read_with_meshio(path))


def test_vtk_s_own_volumes_of_the_convex_cells(tmp_path):
    """An independent volume: VTK's, of the cells of interior vertices of a Delaunay ball
    (Voronoi cells: convex polyhedra)."""
    pv = pytest.importorskip("pyvista")
    V, T = tetlap.meshes.ball(300, seed=1)
    grid = tetlap.io.dual_cells(V, T).to_pyvista()
    inside = ~tetlap.diagnostics.boundary_vertices(V, T)[grid.cell_data["vertex"]]
    sizes = grid.compute_cell_sizes(length=False, area=False, volume=True)["Volume"]
    assert isinstance(grid, pv.UnstructuredGrid) and inside.sum() > 100
    np.testing.assert_allclose(sizes[inside], grid.cell_data["control_volume"][inside],
                               rtol=1e-12)


@pytest.mark.parametrize("V,T,w", MESHES)
def test_one_cell_per_control_volume_with_shared_faces(V, T, w):
    """A polygon per edge (a cycle of the tet centres around it: as many as the edge's
    star has, one on a manifold), in the cells of the edge's two ends, once each way; the
    pieces of the mesh's boundary faces in their corner's cell (twice on a fold); every
    cell a closed surface (each directed side of its faces meets its reverse)."""
    cells = tetlap.io.dual_cells(V, T, weights=w)
    g = tetlap.dual_geometry(V, T, weights=w)
    F = len(cells.face_offsets) - 1
    owner = np.repeat(cells.vertex, np.diff(cells.cell_offsets))
    uses = np.zeros((F, 2), dtype=np.int64)
    np.add.at(uses, (cells.cell_faces, (cells.cell_sides < 0).astype(int)), 1)
    polygon = uses[:, 1] > 0
    assert (uses[polygon] == 1).all()                      # in two cells, once each way
    n_polygons = int(polygon.sum())
    assert np.array_equal(polygon, np.arange(F) < n_polygons)
    plus, minus = np.full(F, -1), np.full(F, -1)
    plus[cells.cell_faces[cells.cell_sides > 0]] = owner[cells.cell_sides > 0]
    minus[cells.cell_faces[cells.cell_sides < 0]] = owner[cells.cell_sides < 0]
    pairs = np.column_stack([plus, minus])[:n_polygons]    # turned from the lower end
    key = lambda e: e[:, 0] * len(V) + e[:, 1]              # noqa: E731
    assert np.isin(key(pairs), key(g.edges)).all()
    assert np.unique(key(pairs)).size == len(g.edges)      # every edge has its polygon
    if len(T) > 2:
        assert n_polygons == len(g.edges)                   # one each on these manifolds
    stream, stream_ends = cells.face_streams()
    starts = np.r_[0, stream_ends[:-1]]
    for c in range(len(cells)):
        s, sides = starts[c] + 1, []
        for _ in range(stream[starts[c]]):
            face = stream[s + 1:s + 1 + stream[s]]
            sides += list(zip(face, np.roll(face, -1)))
            s += 1 + stream[s]
        sides = [(a, b) for a, b in sides if a != b]
        assert sorted(sides) == sorted((b, a) for a, b in sides), c
    np.testing.assert_allclose(cells.volumes(), g.control_volume[cells.vertex], rtol=1e-12,
                               atol=1e-13 * np.abs(g.control_volume).max())
    np.testing.assert_array_equal(cells.control_volume, g.control_volume[cells.vertex])
    assert repr(cells).startswith(f"DualCells({len(cells)} cells, {F} faces")


def test_only_formats_that_hold_polyhedra_are_written(tmp_path):
    """Every extension meshio knows: .vtu and .vtk are written (and read back above);
    every other is refused before a file exists (meshio's writers dropped the polyhedra,
    writing the points alone, or failed inside meshio)."""
    cells = tetlap.io.dual_cells(*tetlap.meshes.ball(60, seed=1))
    for ext in sorted(set(meshio.extension_to_filetypes) | {".VTU", ".txt", ""}):
        path = tmp_path / f"cells{ext}"
        if ext.lower() in (".vtu", ".vtk"):
            cells.write(path)
            assert path.stat().st_size > 0
            continue
        with pytest.raises(tetlap.MeshFileError, match=r"\.vtu .* \.vtk"):
            cells.write(path)
        assert not path.exists(), ext


def test_files_stay_a_few_times_the_mesh_s_size(tmp_path):
    """One polyhedron per vertex with shared faces: a Delaunay ball's cells.vtu is 5 times
    its mesh.vtu (the triangle fans written before were 20 times)."""
    V, T = tetlap.meshes.ball(2000, seed=0)
    tetlap.io.write(tmp_path / "mesh.vtu", V, T)
    tetlap.io.dual_cells(V, T).write(tmp_path / "cells.vtu")
    ratio = os.path.getsize(tmp_path / "cells.vtu") / os.path.getsize(tmp_path / "mesh.vtu")
    assert ratio < 8, ratio


def test_to_pyvista_copies_the_cells():
    pytest.importorskip("pyvista")
    V, T = tetlap.meshes.ball(100, seed=3)
    cells = tetlap.io.dual_cells(V, T)
    grid = cells.to_pyvista()
    grid.cell_data["control_volume"][0] = 99.0
    assert cells.control_volume[0] != 99.0
    P = np.asarray(grid.points)
    faces = [(v, [f.point_ids for f in grid.get_cell(c).faces])
             for c, v in enumerate(grid.cell_data["vertex"])]
    got = divergence_volumes(P, faces, P.mean(axis=0))
    np.testing.assert_allclose([got[v] for v in cells.vertex], cells.volumes(), rtol=1e-12,
                               atol=1e-15)


def test_bad_input():
    V, T = tetlap.meshes.sphere3(40, seed=1)
    with pytest.raises(tetlap.ShapeError, match="R\\^3"):
        tetlap.io.dual_cells(V, T)
    with pytest.raises(tetlap.ShapeError):
        tetlap.io.dual_cells([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(tetlap.DegenerateElementError):
        tetlap.io.dual_cells([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2, 3]])
