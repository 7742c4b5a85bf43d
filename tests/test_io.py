"""tetlap.io: mesh objects in (meshio, pyvista, look-alikes), files in and out, and the
errors of both."""

from __future__ import annotations

import types
import warnings

import meshio
import numpy as np
import pytest

import tetlap
import tetlap.io


@pytest.fixture
def cube():
    return tetlap.meshes.cube(2, jitter=0.1, seed=3)


def assert_same(a, b):
    (V, T), (V2, T2) = a, b
    assert V2.dtype == np.float64 and T2.dtype == np.int64
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(T2, T)


# ---- meshio objects -------------------------------------------------------------------


def test_from_meshio_roundtrip_returns_copies(cube):
    V, T = cube
    mesh = meshio.Mesh(V, [("tetra", T.astype(np.int32))])
    V2, T2 = tetlap.io.from_mesh(mesh)
    assert_same(cube, (V2, T2))
    assert not np.shares_memory(V2, mesh.points) and not np.shares_memory(T2, mesh.cells[0].data)


def test_from_meshio_keeps_tets_of_every_block_and_warns_about_dropped_cells(cube):
    V, T = cube
    mesh = meshio.Mesh(V, [("tetra", T[:10]), ("triangle", T[:5, :3]), ("tetra", T[10:]),
                           ("line", T[:2, :2]), ("vertex", T[:1, :1])])
    with pytest.warns(UserWarning, match=r"\['line', 'triangle', 'vertex'\]"):
        assert_same(cube, tetlap.io.from_mesh(mesh))


def test_triangles_when_there_are_no_tets():
    V = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    with pytest.warns(UserWarning, match="line"):
        V2, F2 = tetlap.io.from_mesh(meshio.Mesh(V, [("line", F[:, :2]), ("triangle", F)]))
    assert_same((V, F), (V2, F2))  # planar points stay 2-D: tetlap takes d >= 2 triangles
    assert tetlap.laplacian(V2, F2).shape == (4, 4)


def test_cell_type_triangle_takes_the_boundary_of_a_tet_file(cube):
    V, T = cube
    F = T[:4, :3]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the tets are not "dropped" when triangles are asked for
        _, F2 = tetlap.io.from_mesh(meshio.Mesh(V, [("tetra", T), ("triangle", F)]),
                                    cell_type="triangle")
    np.testing.assert_array_equal(F2, F)
    with pytest.raises(tetlap.ShapeError, match="no tetra cells"):
        tetlap.io.from_mesh(meshio.Mesh(V, [("triangle", F)]), cell_type="tetra")
    with pytest.raises(tetlap.OptionError):
        tetlap.io.from_mesh(meshio.Mesh(V, [("tetra", T)]), cell_type="hexahedron")


HEX = np.arange(8)[None, :]


@pytest.mark.parametrize("blocks, match", [
    ([("tetra", None), ("hexahedron", HEX)], r"tetra cells mixed with \['hexahedron'\]"),
    ([("tetra", None), ("wedge", HEX[:, :6])], r"mixed with \['wedge'\]"),
    ([("tetra", None), ("tetra10", np.arange(10)[None, :])], r"mixed with \['tetra10'\]"),
    ([("triangle", None), ("quad", HEX[:, :4])], r"triangle cells mixed with \['quad'\]"),
    ([("hexahedron", HEX), ("quad", HEX[:, :4])], r"no tetra cells, found hexahedron \(1\)"),
    ([("hexahedron", HEX), ("triangle", HEX[:, :3])], "no tetra cells"),
    ([("line", HEX[:, :2]), ("vertex", HEX[:, :1])], "no tets or triangles"),
    ([("tetra10", np.arange(10)[None, :])], r"\[:, :4\]"),
])
def test_unusable_cells_are_a_shape_error(cube, blocks, match):
    V, T = cube
    cells = [(t, T if d is None and t == "tetra" else T[:, :3] if d is None else d)
             for t, d in blocks]
    with pytest.raises(tetlap.ShapeError, match=match):
        tetlap.io.from_mesh(meshio.Mesh(V, cells))


def test_no_cells_and_float_cells(cube):
    V, T = cube
    with pytest.raises(tetlap.EmptyMeshError, match="no cells"):
        tetlap.io.from_mesh(meshio.Mesh(V, []))
    with pytest.raises(tetlap.DtypeError, match="integer"):
        tetlap.io.from_mesh(types.SimpleNamespace(points=V, cells=[("tetra", T + 0.5)]))
    with pytest.raises(TypeError, match="not a mesh object"):
        tetlap.io.from_mesh(types.SimpleNamespace(points=V))
    with pytest.raises(TypeError):
        tetlap.io.read(42)


# ---- look-alikes ----------------------------------------------------------------------


def test_duck_typed_objects(cube):
    V, T = cube
    as_list = V.tolist(), T.tolist()
    for obj in (
        types.SimpleNamespace(points=as_list[0], cells=[("tetra", as_list[1])]),
        types.SimpleNamespace(points=V, cells=[types.SimpleNamespace(type="tetra", data=T)]),
        types.SimpleNamespace(points=V, cells_dict={"tetra": T}),
        types.SimpleNamespace(points=V, cells_dict={10: T}),  # a VTK cell type id
        # legacy VTK layout: celltypes and a flat [k, i0, ..., k, ...] array
        types.SimpleNamespace(points=V, celltypes=np.full(len(T), 10, dtype=np.uint8),
                              cells=np.column_stack([np.full(len(T), 4), T]).ravel()),
    ):
        assert_same(cube, tetlap.io.from_mesh(obj))
        assert_same(cube, tetlap.io.read(obj))


def test_legacy_vtk_layout_with_mixed_cell_sizes(cube):
    V, T = cube
    flat = np.concatenate([[2, 0, 1], *(np.r_[4, t] for t in T), [3, 0, 1, 2]])
    obj = types.SimpleNamespace(points=V, celltypes=np.r_[3, np.full(len(T), 10), 5],
                                cells=flat)
    with pytest.warns(UserWarning, match=r"\['line', 'triangle'\]"):
        assert_same(cube, tetlap.io.from_mesh(obj))


# ---- pyvista --------------------------------------------------------------------------


def test_pyvista_roundtrip_tets_and_triangles(cube):
    pytest.importorskip("pyvista")
    V, T = cube
    assert_same(cube, tetlap.io.from_mesh(tetlap.io.to_pyvista(V, T)))
    F = T[:, :3]
    grid = tetlap.io.to_pyvista(V[:, :2], F)  # 2-D points get z = 0
    V2, F2 = tetlap.io.from_mesh(grid)
    np.testing.assert_array_equal(V2[:, :2], V[:, :2])
    assert (V2[:, 2] == 0).all()
    np.testing.assert_array_equal(F2, F)


def test_pyvista_grid_built_by_pyvista_and_surfaces():
    pv = pytest.importorskip("pyvista")
    V, T = tetlap.meshes.cube(2)
    cells = {pv.CellType.TETRA: T, pv.CellType.TRIANGLE: T[:3, :3], pv.CellType.LINE: T[:2, :2]}
    grid = pv.UnstructuredGrid(cells, V)
    with pytest.warns(UserWarning, match=r"\['line', 'triangle'\]"):
        assert_same((V, T), tetlap.io.from_mesh(grid))
    sphere = pv.Sphere()  # PolyData: cast to a grid of triangles
    V2, F = tetlap.io.from_mesh(sphere)
    assert F.shape == (sphere.n_cells, 3)
    np.testing.assert_array_equal(F, sphere.faces.reshape(-1, 4)[:, 1:])
    hexes = pv.ImageData(dimensions=(3, 3, 3)).cast_to_unstructured_grid()
    with pytest.raises(tetlap.ShapeError, match="no tetra cells, found (voxel|hexahedron)"):
        tetlap.io.from_mesh(hexes)
    mixed = pv.UnstructuredGrid({pv.CellType.TETRA: T, pv.CellType.HEXAHEDRON: HEX}, V)
    with pytest.raises(tetlap.ShapeError, match="mixed with"):
        tetlap.io.from_mesh(mixed)


def test_to_pyvista_data_copies_and_errors(cube):
    pytest.importorskip("pyvista")
    V, T = cube
    V0, T0 = V.copy(), T.copy()
    masses = tetlap.mass(V, T, "circumcentric").diagonal()
    W = tetlap.element_contributions(V, T, "dual")
    grid = tetlap.io.to_pyvista(V, T, point_data={"dual_mass": masses},
                                cell_data={"min_weight": W.min(axis=1), "w": W})
    np.testing.assert_array_equal(grid.point_data["dual_mass"], masses)
    np.testing.assert_array_equal(grid.cell_data["w"], W)
    grid.points[:] = 0.0
    grid.point_data["dual_mass"][:] = 0.0
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(T, T0)
    assert masses.any()
    with pytest.raises(tetlap.ShapeError, match=r"point_data\['m'\]"):
        tetlap.io.to_pyvista(V, T, point_data={"m": masses[:-1]})
    with pytest.raises(tetlap.ShapeError, match=r"cell_data\['c'\]"):
        tetlap.io.to_pyvista(V, T, cell_data={"c": masses})
    with pytest.raises(tetlap.ShapeError, match="3-D"):
        tetlap.io.to_pyvista(np.column_stack([V, V[:, 0]]), T)
    with pytest.raises(tetlap.IndexRangeError, match="element 1 refers to vertex 99") as e:
        tetlap.io.to_pyvista(V, [[0, 1, 2, 3], [0, 1, 2, 99]])
    assert e.value.element == 1 and e.value.index == 99
    with pytest.raises(tetlap.DtypeError):
        tetlap.io.to_pyvista(V, T.astype(float))


def test_edges_to_pyvista_shows_negative_weights():
    pytest.importorskip("pyvista")
    V, T = tetlap.meshes.ball(300, seed=0)
    edges, w = tetlap.edge_weights(V, T, "dual")
    negative = w < 0
    assert negative.any()
    lines = tetlap.io.edges_to_pyvista(V, edges[negative], w[negative], name="weight")
    assert lines.n_lines == negative.sum()
    np.testing.assert_array_equal(lines.lines.reshape(-1, 3)[:, 1:], edges[negative])
    np.testing.assert_array_equal(lines.cell_data["weight"], w[negative])
    with pytest.raises(tetlap.ShapeError, match="values"):
        tetlap.io.edges_to_pyvista(V, edges, w[:-1])
    with pytest.raises(tetlap.IndexRangeError, match="edge 0"):
        tetlap.io.edges_to_pyvista(V, [[0, len(V)]])


# ---- files ----------------------------------------------------------------------------


def test_write_refuses_float_T_and_checks_data_lengths(cube, tmp_path):
    V, T = cube
    with pytest.raises(tetlap.DtypeError, match="integer"):
        tetlap.io.write(tmp_path / "a.vtu", V, T + 0.7)
    with pytest.raises(tetlap.ShapeError, match=r"point_data\['p'\]"):
        tetlap.io.write(tmp_path / "a.vtu", V, T, point_data={"p": np.zeros(len(V) + 1)})
    with pytest.raises(tetlap.ShapeError, match=r"cell_data\['c'\]"):
        tetlap.io.write(tmp_path / "a.vtu", V, T, cell_data={"c": np.zeros(len(T) - 1)})
    with pytest.raises(tetlap.IndexRangeError):
        tetlap.io.write(tmp_path / "a.vtu", V, T + len(V))
    with pytest.raises(tetlap.MeshFileError, match="a.unknown-format"):
        tetlap.io.write(tmp_path / "a.unknown-format", V, T)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("name", ["m.vtu", "m.vtk", "m.mesh", "m.msh"])
def test_write_read_roundtrip_tets_and_triangles(cube, tmp_path, name):
    V, T = cube
    path = tmp_path / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshio's gmsh writer warns about tags
        tetlap.io.write(path, V, T, point_data={"m": np.arange(len(V), dtype=float)},
                        cell_data={"id": np.arange(len(T))})
    assert_same(cube, tetlap.io.read(path))
    tetlap.io.write(path, V, T[:, :3])
    assert_same((V, T[:, :3]), tetlap.io.read(path))


def test_read_never_exits_on_malformed_files(tmp_path):
    files = {
        "bad.vtu": "<?xml version='1.0'?>\n<VTKFile type='UnstructuredGrid'><Garbage/></VTKFile>\n",
        "bad.mesh": "MeshVersionFormatted 1\nDimension 3\nFoobar\n3\n",
        # a PolyData legacy file: meshio reads unstructured grids only
        "poly.vtk": ("# vtk DataFile Version 4.2\nsurface\nASCII\nDATASET POLYDATA\n"
                     "POINTS 3 float\n0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\n"),
        "short.vtk": ("# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                      "POINTS 3 float\n0 0 0 1 0 0\n"),
        "noise.msh": "this is not a mesh\n",
        "empty.vtu": "",
    }
    for name, text in files.items():
        path = tmp_path / name
        path.write_text(text)
        try:
            with pytest.raises(tetlap.MeshFileError, match=name.replace(".", r"\.")):
                tetlap.io.read(path)
        except SystemExit:  # pragma: no cover - the bug this test is for
            pytest.fail(f"SystemExit escaped io.read({name})")
    with pytest.raises(tetlap.MeshFileError, match="Unknown main tag 'Garbage'"):
        tetlap.io.read(tmp_path / "bad.vtu")
    with pytest.raises(FileNotFoundError):
        tetlap.io.read(tmp_path / "missing.vtu")


def test_read_keeps_stdout_clean(cube, tmp_path, capfd):
    V, T = cube
    path = tmp_path / "m.msh"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        meshio.Mesh(V, [("tetra", T)]).write(path, file_format="gmsh22", binary=False)
    capfd.readouterr()
    assert_same(cube, tetlap.io.read(path))  # meshio itself prints a blank line here
    assert capfd.readouterr().out == ""


def test_read_of_a_mesh_object_is_from_mesh(cube):
    V, T = cube
    mesh = meshio.Mesh(V, [("tetra", T), ("triangle", T[:2, :3])])
    with pytest.warns(UserWarning, match="triangle"):
        assert_same(cube, tetlap.io.read(mesh))



def test_io_roundtrip_and_dropped_cells(tmp_path):
    V, T = tetlap.meshes.cube(2)
    path = tmp_path / "mixed.vtu"
    meshio.Mesh(V, [("tetra", T), ("triangle", T[:3, :3])]).write(path)
    with pytest.warns(UserWarning, match="triangle"):
        V2, T2 = tetlap.io.read(path)
    np.testing.assert_array_equal(T2, T)
    np.testing.assert_allclose(V2, V)


def _absurd_files(big: int) -> dict[str, bytes]:
    """Small files of every corpus format whose headers declare ``big`` vertices or
    elements (meshio allocates what a header declares)."""
    import struct

    tet = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
    nodes = "".join(f"{i + 1} {p}\n" for i, p in enumerate(tet.splitlines()))
    medit = "MeshVersionFormatted 2\nDimension 3\nVertices\n{}\n" + \
        "".join(f"{p} 1\n" for p in tet.splitlines()) + "Tetrahedra\n{}\n1 2 3 4 1\nEnd\n"
    gmsh = ("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{}\n" + nodes +
            "$EndNodes\n$Elements\n{}\n1 4 2 0 0 1 2 3 4\n$EndElements\n")
    legacy = ("# vtk DataFile Version 2.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS {} float\n"
              + tet + "CELLS {} {}\n4 0 1 2 3\nCELL_TYPES 1\n10\n")
    xml = ('<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">'
           '<UnstructuredGrid><Piece NumberOfPoints="{}" NumberOfCells="1"><Points>'
           '<DataArray type="Float64" NumberOfComponents="3" format="ascii">' + tet +
           '</DataArray></Points><Cells>'
           '<DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3</DataArray>'
           '<DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>'
           '<DataArray type="UInt8" Name="types" format="ascii">10</DataArray>'
           '</Cells></Piece></UnstructuredGrid></VTKFile>\n')
    binary_gmsh = (b"$MeshFormat\n2.2 1 8\n" + struct.pack("<i", 1) + b"\n$EndMeshFormat\n"
                   b"$Nodes\n%d\n" % big + b"".join(
                       struct.pack("<i3d", i + 1, *map(float, p.split()))
                       for i, p in enumerate(tet.splitlines())) + b"\n$EndNodes\n")
    binary_vtk = (b"# vtk DataFile Version 2.0\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\n"
                  b"POINTS %d float\n" % big + np.eye(4, 3, -1, dtype=">f4").tobytes() + b"\n")
    return {
        "points.mesh": medit.format(big, 1).encode(), "tets.mesh": medit.format(4, big).encode(),
        "points.msh": gmsh.format(big, 1).encode(), "tets.msh": gmsh.format(4, big).encode(),
        "binary.msh": binary_gmsh,
        "points.vtk": legacy.format(big, 1, 5).encode(),
        "tets.vtk": legacy.format(4, big, 5 * big).encode(),
        "binary.vtk": binary_vtk,
        "points.vtu": xml.format(big).encode(),
        "points.ele": b"1 4 0\n0 0 1 2 3\n", "points.node": f"{big} 3 0 0\n{tet}".encode(),
        "tets.ele": f"{big} 4 0\n0 0 1 2 3\n".encode(), "tets.node": f"4 3 0 0\n{tet}".encode(),
    }


@pytest.mark.parametrize("big", [10**12, 2 * 10**8, 10**30])
def test_files_that_declare_absurd_sizes_are_mesh_file_errors(tmp_path, big):
    # 10^12: a bare MemoryError (29.1 TiB) before; 10^30: an OverflowError inside meshio;
    # 2e8: allocated lazily, a ValueError when the data runs out
    files = _absurd_files(big)
    for name, content in files.items():
        (tmp_path / name).write_bytes(content)
    for name in files:
        # meshio reads both files of a TetGen pair: the error names the broken one
        broken = {"points.ele": "points.node", "tets.node": "tets.ele"}.get(name, name)
        with pytest.raises(tetlap.MeshFileError, match=broken.replace(".", r"\.")):
            tetlap.io.read(tmp_path / name)


def test_readers_running_out_of_memory_are_mesh_file_errors(tmp_path, monkeypatch):
    # counts a header cannot hold are refused before reading; what meshio allocates from
    # the data (a gmsh node tag of 10^12 sizes its renumbering array) is wrapped
    path = tmp_path / "tag.msh"
    path.write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n"
                    "3 0 1 0\n1000000000000 0 0 1\n$EndNodes\n$Elements\n1\n"
                    "1 4 2 0 0 1 2 3 1000000000000\n$EndElements\n")
    with pytest.raises(tetlap.MeshFileError, match="tag.msh.*fits in memory.*Overflow"):
        tetlap.io.read(path)

    def out_of_memory(*args, **kwargs):
        raise MemoryError("Unable to allocate 29.1 TiB for an array")

    monkeypatch.setattr(meshio, "read", out_of_memory)
    with pytest.raises(tetlap.MeshFileError, match="tag.msh.*fits in memory.*29.1 TiB"):
        tetlap.io.read(path)


def test_the_command_reports_an_absurd_file_in_one_line(tmp_path):
    from conftest import run_tetlap

    path = tmp_path / "points.mesh"
    path.write_bytes(_absurd_files(10**12)["points.mesh"])
    for command in (["info", "--no-nsd", "--no-regular"], ["assemble", "-o", str(tmp_path / "L")]):
        out = run_tetlap(*command[:1], str(path), *command[1:])
        assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
        last = out.stderr.splitlines()[-1]   # after the steps info reports on stderr
        assert last.startswith("tetlap: error: ") and out.stderr.count("tetlap: error") == 1
        assert "points.mesh: its header declares 1000000000000 records" in last


# ---- cut-short files and files meshio would write without the tets (issue 30, round 4) --


def _run_bounded(*args: str, timeout: float = 120):
    """``python ARGS`` in a child process (text output), killed if it runs past ``timeout``
    (meshio loops forever on some files): (returncode, stdout, stderr)."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        out, err = child.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"python {' '.join(args)} still running after {timeout} s (a hang)")
    finally:
        child.kill()
        child.communicate()
    return child.returncode, out, err


_NODE = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n"
_ELE = "1 4 0\n0 0 1 2 3\n"
_NO_HEADER = {"empty": "", "comments": "# a comment\n\n   \n# another\n"}
_SHORT_HEADER = {".node": "4 3 0\n", ".ele": "1 4\n", "words": "points 3 0 0\n"}


def _tetgen_pairs(tmp_path) -> dict[str, str]:
    """name -> the expected start of the error: TetGen pairs with one file cut short."""
    pairs = {}
    for broken in (".node", ".ele"):
        bodies = {key: text for key, text in _NO_HEADER.items()}
        bodies["short"] = _SHORT_HEADER[broken] + (_NODE if broken == ".node" else _ELE)[8:]
        bodies["words"] = _SHORT_HEADER["words"]
        for key, text in bodies.items():
            stem = tmp_path / f"{key}{broken[1:]}"
            stem.with_suffix(".node").write_text(text if broken == ".node" else _NODE)
            stem.with_suffix(".ele").write_text(text if broken == ".ele" else _ELE)
            pairs[str(stem.with_suffix(".ele"))] = str(stem.with_suffix(broken))
            pairs[str(stem.with_suffix(".node"))] = str(stem.with_suffix(broken))
    return pairs


def test_tetgen_files_without_their_header_are_mesh_file_errors_not_hangs(tmp_path):
    # meshio skipped blank and comment lines past the end of the file forever (100% CPU)
    pairs = _tetgen_pairs(tmp_path)
    code = ("import sys, tetlap, tetlap.io\n"
            "for path in sys.argv[1:]:\n"
            "    try:\n"
            "        tetlap.io.read(path)\n"
            "        print('read', path)\n"
            "    except tetlap.MeshFileError as e:\n"
            "        print(str(e).replace(chr(10), ' '))\n")
    returncode, out, err = _run_bounded("-c", code, *pairs)
    assert returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == len(pairs)
    for line, (path, broken) in zip(lines, pairs.items()):
        assert line.startswith(f"{broken}: "), (path, line)
        assert ("no header line" in line) == ("empty" in broken or "comments" in broken), line
        assert "TetGen" in line and "header" in line
    (tmp_path / "good.node").write_text(_NODE)
    (tmp_path / "good.ele").write_text("# a comment first\n\n" + _ELE)
    V, T = tetlap.io.read(tmp_path / "good.ele")
    assert V.shape == (4, 3) and T.tolist() == [[0, 1, 2, 3]]


def test_the_command_reports_a_tetgen_file_without_header_in_one_line(tmp_path):
    (tmp_path / "f.node").write_text(_NO_HEADER["comments"])
    (tmp_path / "f.ele").write_text(_ELE)
    returncode, _, err = _run_bounded("-m", "tetlap", "info", "--no-nsd", "--no-regular",
                                      str(tmp_path / "f.ele"))
    assert returncode == 2 and "Traceback" not in err, err
    assert err.count("tetlap: error") == 1
    assert err.splitlines()[-1].startswith(f"tetlap: error: {tmp_path / 'f.node'}: no header line")


def _cuts(data: bytes, section: bytes | None = None) -> list[int]:
    """Lengths to cut ``data`` to: inside ``section`` (its keyword to the end), else
    anywhere, at fractions of it, each also snapped to a line end."""
    start = data.find(section) if section else 0
    assert start >= 0
    cuts = []
    for f in (0.3, 0.6, 0.9, 0.99):
        k = start + int((len(data) - start) * f)
        cuts += [k, data.rfind(b"\n", 0, k) + 1]
    # not inside the last line: a file cut inside its last number cannot be told from a
    # whole one where the format has no end marker (legacy VTK, TetGen)
    return sorted(set(k for k in cuts if start < k <= data.rstrip().rfind(b"\n")))


def _assert_cut_files_fail(tmp_path, name: str, data: bytes, cuts, full, partner=None):
    """Every cut of ``data`` read as ``name`` is a MeshFileError (EmptyMeshError if no
    cells are left), or (a cut in a trailer the mesh does not need) gives the whole mesh
    ``full``."""
    for k in cuts:
        path = tmp_path / name
        path.write_bytes(data[:k])
        if partner is not None:
            partner[0].write_bytes(partner[1])
        read = path.with_suffix(".ele") if path.suffix == ".node" else path
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                V, T = tetlap.io.read(read)
        except (tetlap.MeshFileError, tetlap.EmptyMeshError):  # cut before any cells
            continue
        assert V.shape == full[0].shape and T.shape == full[1].shape, (name, k, T.shape)
        np.testing.assert_array_equal(T, full[1], err_msg=f"{name} cut to {k} bytes")


@pytest.mark.parametrize("kind", ["vtk42-ascii", "vtk42-binary", "vtk51-ascii",
                                  "vtk51-binary", "gmsh22-ascii", "gmsh22-binary",
                                  "gmsh-ascii", "gmsh-binary", "medit", "vtu-ascii", "vtu"])
def test_cut_files_are_mesh_file_errors_not_fewer_tets(cube, tmp_path, kind):
    # a legacy VTK file cut inside CELL_TYPES was read as the tets whose types came
    # before the cut (3 of 160); a gmsh 2.2 file cut inside its last element line gave
    # that element the line's tags as vertices
    import contextlib
    import io

    V, T = cube
    fmt, _, encoding = kind.partition("-")
    ext = {"vtk42": ".vtk", "vtk51": ".vtk", "gmsh22": ".msh", "gmsh": ".msh",
           "medit": ".mesh", "vtu": ".vtu"}[fmt]
    whole = tmp_path / ("whole" + ext)
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        options = {"binary": encoding == "binary"} if encoding else {}
        meshio.Mesh(V, [("tetra", T)]).write(whole, file_format=fmt.replace("vtk51", "vtk"),
                                             **options)
    data = whole.read_bytes()
    section = {".vtk": b"CELL_TYPES", ".msh": b"$Elements"}.get(ext)
    cuts = _cuts(data) + (_cuts(data, section) if section else [])
    if ext == ".msh":  # inside the last element's line
        cuts.append(data.find(b"$EndElements") - 3)
    _assert_cut_files_fail(tmp_path, "cut" + ext, data, cuts, (V, T))


def test_cut_corpus_files_are_mesh_file_errors_not_fewer_tets(tmp_path):
    from conftest import read_mesh, real_mesh_paths

    paths = real_mesh_paths()
    if not paths:
        pytest.skip("real-mesh corpus not found (set TETLAP_MESHES)")
    smallest = {}
    for p in sorted(paths, key=lambda p: p.stat().st_size):
        smallest.setdefault(p.suffix, p)
    assert {".vtk", ".msh"} <= set(smallest)  # the two formats that were read cut short
    for suffix, path in smallest.items():
        full = read_mesh(path)
        files = [path] + ([path.with_suffix(".node")] if suffix == ".ele" else [])
        for cut in files:
            data = cut.read_bytes()
            partner = [p for p in files if p != cut]
            _assert_cut_files_fail(tmp_path, "cut" + cut.suffix, data, _cuts(data), full,
                                   (tmp_path / ("cut" + partner[0].suffix),
                                    partner[0].read_bytes()) if partner else None)
        if suffix == ".vtk":
            data = path.read_bytes()
            _assert_cut_files_fail(tmp_path, "cut.vtk", data, _cuts(data, b"CELL_TYPES"), full)


@pytest.mark.parametrize("name", ["c.stl", "c.off", "c.ply", "c.obj", "C.STL"])
def test_write_refuses_surface_formats_for_tets(cube, tmp_path, name):
    # meshio wrote a file without the tets and only printed a warning
    V, T = cube
    ext = name[2:].lower()
    with pytest.raises(tetlap.MeshFileError,
                       match=rf"{name}: not a mesh format that holds tets \(\.{ext} .*\.vtu"):
        tetlap.io.write(tmp_path / name, V, T)
    assert not list(tmp_path.iterdir())
    tetlap.io.write(tmp_path / name, V, T[:, :3])  # triangles: what the format holds
    assert (tmp_path / name).stat().st_size > 0


def test_write_data_must_be_a_dict_of_numeric_arrays(cube, tmp_path):
    V, T = cube
    m = len(T)
    bad = [
        ({"cell_data": [1, 2]}, tetlap.OptionError, "cell_data must be a dict"),
        ({"point_data": np.zeros(len(V))}, tetlap.OptionError, "point_data must be a dict"),
        ({"cell_data": {"c": ["x"] * m}}, tetlap.DtypeError, r"cell_data\['c'\] has dtype"),
        ({"point_data": {"p": [None] * len(V)}}, tetlap.DtypeError, r"point_data\['p'\]"),
        ({"cell_data": {"c": np.ones(m, complex)}}, tetlap.DtypeError, "complex"),
        ({"cell_data": {"c": [[1.0]] * (m - 1) + [[1.0, 2.0]]}}, tetlap.ShapeError,
         r"cell_data\['c'\] is not an array"),
        ({"cell_data": {"c": 1.0}}, tetlap.ShapeError, r"cell_data\['c'\] has shape \(\)"),
    ]
    for kwargs, error, match in bad:
        for target in (lambda: tetlap.io.write(tmp_path / "a.vtu", V, T, **kwargs),
                       lambda: tetlap.io.to_meshio(V, T, **kwargs)):
            with pytest.raises(error, match=match):
                target()
    assert not list(tmp_path.iterdir())
    # NaN is data like any other value: written as given (the docstring's policy)
    values = np.arange(m, dtype=float)
    values[0] = np.nan
    tetlap.io.write(tmp_path / "a.vtu", V, T, cell_data={"c": values})
    back = meshio.read(tmp_path / "a.vtu").cell_data["c"][0]
    np.testing.assert_array_equal(back, values)


# ---- cell data (region tags, tensors) ---------------------------------------------------


def _regions_and_tensors(cube):
    """Three regions of the cube's tets (tags 1, 2, 3, interleaved) and an SPD tensor per
    tet as 9 components; the tets of each region form one block, as gmsh writes them."""
    V, T = cube
    m = len(T)
    region = np.arange(m) % 3 + 1
    A = np.random.default_rng(4).standard_normal((m, 3, 3))
    K = (A @ A.transpose(0, 2, 1) + 3 * np.eye(3)).reshape(m, 9)
    by_region = [region == r for r in (1, 2, 3)]
    return region, K, by_region


@pytest.mark.parametrize("fmt, name, tags, tensor, triangles", [
    ("gmsh22", "m.msh", ("gmsh:physical", "gmsh:geometrical"), False, True),
    ("gmsh22", "k.msh", ("gmsh:physical", "gmsh:geometrical"), True, False),
    ("gmsh", "m41.msh", (), True, False),  # gmsh 4.1 tags entities (blocks), not tets
    ("vtu", "m.vtu", ("region",), True, True),
    ("vtk", "m.vtk", ("region",), True, True),
    ("medit", "m.mesh", ("medit:ref",), False, True),
])
def test_read_returns_the_cell_data_of_the_tets_in_their_order(cube, tmp_path, fmt, name, tags,
                                                              tensor, triangles):
    """Region tags and 9-component tensors written by meshio come back with one row per
    tet, row i for T[i], across several tet blocks (gmsh's regions) and without the rows
    of the boundary triangles a file holds before them."""
    V, T = cube
    region, K, by_region = _regions_and_tensors(cube)
    B = tetlap.diagnostics.boundary_faces(V, T)
    blocks = [("tetra", T[r]) for r in by_region] if fmt != "gmsh" else [("tetra", T)]
    per_block = (lambda a: [a[r] for r in by_region]) if fmt != "gmsh" else (lambda a: [a])
    data = {tag: per_block(region + 10 * k) for k, tag in enumerate(tags)}
    if tensor:
        data["K"] = per_block(K)
    if triangles:  # boundary triangles first, with their own values
        blocks = [("triangle", B)] + blocks
        data = {key: [np.full((len(B), *a[0].shape[1:]), -7, dtype=a[0].dtype)] + a
                for key, a in data.items()}
    meshio.write(tmp_path / name, meshio.Mesh(V, blocks, cell_data=data), file_format=fmt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the dropped triangles
        V2, T2, got = tetlap.io.read(tmp_path / name, cell_data=True)
        assert_same((V, np.concatenate([b for kind, b in blocks if kind == "tetra"])),
                    tetlap.io.read(tmp_path / name))
    order = np.concatenate([np.flatnonzero(r) for r in by_region]) if fmt != "gmsh" else \
        np.arange(len(T))
    np.testing.assert_array_equal(T2, T[order])
    assert set(tags) | ({"K"} if tensor else set()) <= set(got)
    for k, tag in enumerate(tags):
        assert got[tag].shape == (len(T),)
        np.testing.assert_array_equal(got[tag], (region + 10 * k)[order])
    if tensor:
        assert got["K"].shape == (len(T), 9) and got["K"].dtype == np.float64  # native order
        np.testing.assert_array_equal(got["K"].reshape(-1, 3, 3), K[order].reshape(-1, 3, 3))


def test_from_mesh_cell_data_of_pyvista_and_look_alikes(cube):
    """A pyvista grid's cell data (one array over all cells, tets among other cells) and
    a look-alike's ``cell_data_dict`` (per type) come back for the tets only; a (m, 3, 3)
    array stays (m, 3, 3); everything is a copy."""
    V, T = cube
    region, K, _ = _regions_and_tensors(cube)
    K3 = K.reshape(-1, 3, 3)
    obj = types.SimpleNamespace(points=V, cells_dict={"line": np.array([[0, 1]]), "tetra": T},
                                cell_data_dict={"region": {"line": [5], "tetra": region},
                                                "K": {"line": np.zeros((1, 3, 3)), "tetra": K3}})
    with pytest.warns(UserWarning, match="line"):
        V2, T2, got = tetlap.io.from_mesh(obj, cell_data=True)
    np.testing.assert_array_equal(got["region"], region)
    np.testing.assert_array_equal(got["K"], K3)
    got["K"][0] = 0
    assert (K3[0] != 0).all()
    pv = pytest.importorskip("pyvista")
    cells = np.concatenate([np.r_[3, B] for B in tetlap.diagnostics.boundary_faces(V, T)[:5]]
                           + [np.r_[4, t] for t in T])
    types_ = np.r_[np.full(5, pv.CellType.TRIANGLE), np.full(len(T), pv.CellType.TETRA)]
    grid = pv.UnstructuredGrid(cells, types_, V)
    grid.cell_data["region"] = np.r_[np.full(5, -1), region]
    grid.cell_data["K"] = np.vstack([np.zeros((5, 9)), K])
    with pytest.warns(UserWarning, match="triangle"):
        V2, T2, got = tetlap.io.from_mesh(grid, cell_data=True)
    assert_same(cube, (V2, T2))
    np.testing.assert_array_equal(got["region"], region)
    np.testing.assert_array_equal(got["K"], K)


def test_cell_data_errors_and_the_default(cube, tmp_path):
    V, T = cube
    region, _, _ = _regions_and_tensors(cube)
    mesh = meshio.Mesh(V, [("tetra", T)], cell_data={"region": [region]})
    assert len(tetlap.io.from_mesh(mesh)) == 2               # (V, T) without the keyword
    assert len(tetlap.io.from_mesh(mesh, cell_data=False)) == 2
    for bad in ("yes", 1, None):
        with pytest.raises(tetlap.OptionError, match="cell_data must be True or False"):
            tetlap.io.from_mesh(mesh, cell_data=bad)
        with pytest.raises(tetlap.OptionError, match="cell_data"):  # before the file is read
            tetlap.io.read(tmp_path / "missing.vtu", cell_data=bad)
    short = types.SimpleNamespace(points=V, cells=[("tetra", T)], cell_data={"region": [region[:-1]]})
    with pytest.raises(tetlap.ShapeError, match="'region' does not hold one row per cell"):
        tetlap.io.from_mesh(short, cell_data=True)
    _, _, none = tetlap.io.from_mesh(meshio.Mesh(V, [("tetra", T)]), cell_data=True)
    assert none == {}


# ---- packaging ------------------------------------------------------------------------


def test_meshio_is_a_core_dependency_and_the_io_extra_an_alias():
    """Reading a mesh file is the main job: ``pip install .`` brings meshio, the README asks
    for no extra before ``tetlap info MESH``, and ``pip install ".[io]"`` still works."""
    import pathlib
    import re
    import tomllib

    repo = pathlib.Path(__file__).resolve().parent.parent
    project = tomllib.loads((repo / "pyproject.toml").read_text())["project"]
    names = lambda requirements: {re.split(r"[<>=!~\[ ;]", r, maxsplit=1)[0] for r in requirements}
    assert "meshio" in names(project["dependencies"])
    assert names(project["optional-dependencies"]["io"]) == {"meshio"}
    for extra, requirements in project["optional-dependencies"].items():
        assert "meshio" not in names(requirements) or extra == "io", extra
    readme = (repo / "README.md").read_text()
    assert 'pip install ".[io' not in readme and ".[io," not in readme
    for path in pathlib.Path(tetlap.io.__file__).parent.glob("*.py"):
        assert '".[io]"' not in path.read_text() and "hint('io')" not in path.read_text(), path


def test_io_is_a_package_split_by_concept_with_the_same_public_names():
    """``tetlap.io`` is a package of one module per concept (reading, writing, PyVista
    objects, dual cells), each small; every public name still lives at ``tetlap.io.X`` and
    ``__all__`` lists exactly them; no module of the package imports the package itself
    or a module above it (the CLI, the applications)."""
    import ast
    import importlib
    import pathlib

    assert tetlap.io.__all__ == ["read", "from_mesh", "write", "to_meshio", "to_pyvista",
                                 "edges_to_pyvista", "dual_cells", "DualCells"]
    folder = pathlib.Path(tetlap.io.__file__).parent
    assert hasattr(tetlap.io, "__path__") and folder.name == "io"
    concepts = {"read": "_read", "from_mesh": "_read", "write": "_write",
                "to_meshio": "_write", "to_pyvista": "_pyvista",
                "edges_to_pyvista": "_pyvista", "dual_cells": "_dual_cells",
                "DualCells": "_dual_cells"}
    for name in tetlap.io.__all__:
        assert getattr(tetlap.io, name).__module__ == f"tetlap.io.{concepts[name]}", name
    lower = {"_arrays", "_extras", "_meshobj", "errors", "dual", "_dual_faces", "_float_range",
             "_names"}
    for path in sorted(folder.glob("*.py")):
        text = path.read_text()
        assert len(text.splitlines()) <= 400, path.name
        importlib.import_module(f"tetlap.io.{path.stem}" if path.stem != "__init__" else "tetlap.io")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom) and node.level == 2:
                assert (node.module or "") in lower or not node.module and all(
                    a.name in lower for a in node.names), (path.name, node.module)
            if isinstance(node, ast.ImportFrom) and node.level == 1 and path.stem != "__init__":
                names = [node.module] if node.module else [a.name for a in node.names]
                assert all(m.startswith("_") for m in names), (path.name, names)  # siblings
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("tetlap") for a in node.names), path.name
