"""``tetlap assemble`` (tetlap.cli.assemble): the files it writes, their names and folder,
and its errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
import tetlap.io
from tetlap import cli
from tetlap.cli import assemble

from conftest import run_tetlap as run


def test_assemble_writes_load_npz_files(tmp_path):
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    mesh_file = tmp_path / "cube.vtu"
    tetlap.io.write(mesh_file, V, T, cell_data={"min_weight": tetlap.tet_contributions(
        V, T, "dual").min(axis=1)})
    out = tmp_path / "ops.npz"
    res = run("assemble", str(mesh_file), "-o", str(out), "--laplacian", "primal", "--mass", "fem")
    assert res.returncode == 0, res.stderr
    L, M = sp.load_npz(out), sp.load_npz(tmp_path / "ops.mass.npz")
    assert abs(L - tetlap.laplacian(V, T, "primal")).max() == 0
    assert abs(M - tetlap.mass(V, T, "fem")).max() == 0


def test_assemble_defaults_an_affine_kind_and_the_output_names(cube_file, tmp_path, capsys):
    path, V, T = cube_file
    assert assemble.output_names("ops") == ("ops.npz", "ops.mass.npz")
    assert assemble.output_names("ops.npz") == ("ops.npz", "ops.mass.npz")
    # the API's defaults, primal + barycentric (issue 30: it was dual + circumcentric)
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "a")]) == 0
    L, M = sp.load_npz(tmp_path / "a.npz"), sp.load_npz(tmp_path / "a.mass.npz")
    reference = tetlap.operators(V, T)
    assert (L != reference[0]).nnz == 0 and (M != reference[1]).nnz == 0
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "b.npz"), "--laplacian", "0.25"]) == 0
    assert (sp.load_npz(tmp_path / "b.npz") != tetlap.laplacian(V, T, 0.25)).nnz == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"L (primal, {len(V)} x {len(V)}, {L.nnz} entries) -> {tmp_path / 'a.npz'}"
    assert out[1] == f"M (barycentric) -> {tmp_path / 'a.mass.npz'}"


def test_a_mass_with_non_positive_entries_is_a_warning_naming_the_mixed_mass(tmp_path, capsys):
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)   # non-Delaunay: negative dual cells
    V = np.vstack([V, [[5.0, 5.0, 5.0]]])                  # an unused vertex has mass 0: no count
    path = tmp_path / "ball.vtu"
    tetlap.io.write(path, V, T)
    masses = tetlap.mass(V, T, "circumcentric").diagonal()[:-1]
    bad = int((masses <= 0).sum())
    assert bad > 0
    for mass, warned in (("circumcentric", True), ("mixed", False), ("barycentric", False)):
        assert cli.main(["assemble", str(path), "-o", str(tmp_path / mass), "--mass", mass]) == 0
        err = capsys.readouterr().err
        if warned:
            assert err == (f"tetlap: warning: M (circumcentric) has {bad} non-positive diagonal "
                           "entries at vertices of the mesh (circumcentres outside their "
                           "elements: a mesh that is not Delaunay, or obtuse elements at its "
                           "boundary); --mass mixed gives positive dual masses\n")
        else:
            assert err == ""


@pytest.mark.parametrize("output", ["out/", "out/.npz", ".", "./"])
def test_an_output_folder_gets_files_named_after_the_mesh(output, cube_file, tmp_path,
                                                         monkeypatch):
    # issue 30: -o out/ wrote the hidden files out/.npz and out/.mass.npz
    path, V, T = cube_file
    monkeypatch.chdir(tmp_path)
    assert assemble.output_names(output, str(path)) == (
        f"{output.removesuffix('.npz').rstrip('/') or '.'}/cube.npz".replace("./.", "."),
        f"{output.removesuffix('.npz').rstrip('/') or '.'}/cube.mass.npz".replace("./.", "."))
    assert cli.main(["assemble", str(path), "-o", output]) == 0
    folder = tmp_path / output.removesuffix(".npz")
    assert sorted(p.name for p in folder.glob("*.npz")) == ["cube.mass.npz", "cube.npz"]


def test_the_output_folder_is_created(cube_file, tmp_path, capsys):
    """Issue 24.8: ``-o DIR/NAME`` failed when DIR was missing (``--plot DIR`` creates it)."""
    path, V, T = cube_file
    output = tmp_path / "new" / "deeper" / "ops"
    assert cli.main(["assemble", str(path), "-o", str(output)]) == 0
    assert (sp.load_npz(f"{output}.npz") != tetlap.laplacian(V, T)).nnz == 0
    assert (tmp_path / "new" / "deeper" / "ops.mass.npz").is_file()


def test_an_unwritable_output_is_one_line(cube_file, tmp_path, capsys):
    path, V, T = cube_file
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert cli.main(["assemble", str(path), "-o", str(blocker / "ops")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tetlap: error: ") and err.count("\n") == 1


def test_assemble_errors_are_exit_code_2(cube_file, tmp_path, capsys):
    path, V, T = cube_file
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "x"), "--laplacian", "cotan"]) == 2
    assert "tetlap: error: --laplacian: Laplacian kind must be" in capsys.readouterr().err
    flat = tmp_path / "flat.vtu"
    tetlap.io.write(flat, V, np.vstack([T, [[0, 4, 16, 20]]]))  # four vertices on z = 0
    assert cli.main(["assemble", str(flat), "-o", str(tmp_path / "y")]) == 2
    assert "degenerate" in capsys.readouterr().err
    assert cli.main(["assemble", str(flat), "-o", str(tmp_path / "y"), "--degenerate", "skip"]) == 0
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize("value", ["1.5", "-0.5", "nan", "inf", "cotan"])
def test_a_bad_laplacian_is_refused_before_the_mesh_is_read(value, monkeypatch, capsys):
    def read(*args, **kwargs):
        raise AssertionError("the mesh was read before --laplacian was checked")

    monkeypatch.setattr(tetlap.io, "read", read)
    assert cli.main(["assemble", "m.vtu", "-o", "x", f"--laplacian={value}"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tetlap: error: --laplacian: ") and err.count("\n") == 1


def _triangle_files(tmp_path):
    """``{name: (path, V, T)}``: a plane Delaunay triangulation with a vertex in no
    triangle (2-D points), and the boundary surface of a cube (triangles in R^3)."""
    import scipy.spatial

    rng = np.random.default_rng(5)
    P = rng.random((60, 2))
    plane = (np.vstack([P, [[3.0, 3.0]]]), scipy.spatial.Delaunay(P).simplices.astype(np.int64))
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=2)
    surface = (V, tetlap.diagnostics.boundary_faces(V, T))
    files = {}
    for name, (V, T) in {"plane": plane, "surface": surface}.items():
        path = tmp_path / f"{name}.vtu"
        tetlap.io.write(path, V, T)
        files[name] = (path, *tetlap.io.read(path))
    return files


@pytest.mark.parametrize("mesh", ["tets", "plane", "surface"])
@pytest.mark.parametrize("laplacian", ["primal", "dual", "0.25"])
def test_every_flag_combination_on_tets_and_triangles(mesh, laplacian, cube_file, tmp_path,
                                                       capsys):
    """Every --mass, --degenerate and --threads with every kind of --laplacian, on tets, on
    plane triangles and on a triangulated surface in R^3: exit 0, the two files hold
    ``tetlap.operators``' matrices bit for bit, and the warning counts the non-positive
    masses of vertices in an element (a triangle mesh wrote both files, then exited 2)."""
    path, V, T = cube_file if mesh == "tets" else _triangle_files(tmp_path)[mesh]
    capsys.readouterr()
    t = float(laplacian) if laplacian[0].isdigit() else laplacian
    for mass in ("barycentric", "circumcentric", "mixed", "fem"):
        for degenerate in ("raise", "skip"):
            for threads in ([], ["--threads", "1"], ["--threads", "2"]):
                out = tmp_path / f"{mass}-{degenerate}-{len(threads)}"
                code = cli.main(["assemble", str(path), "-o", str(out), "--laplacian", laplacian,
                                 "--mass", mass, "--degenerate", degenerate, *threads])
                printed = capsys.readouterr()
                assert code == 0, printed.err
                L, M = tetlap.operators(V, T, t, mass, degenerate=degenerate)
                assert (sp.load_npz(f"{out}.npz") != L).nnz == 0
                assert (sp.load_npz(f"{out}.mass.npz") != M).nnz == 0
                assert printed.out.splitlines()[1] == f"M ({mass}) -> {out}.mass.npz"
                used = np.zeros(len(V), dtype=bool)
                used[T.ravel()] = True
                assert (tetlap.diagnostics.referenced_vertices(V, T) == used).all()
                bad = int((M.diagonal()[used] <= 0).sum())
                assert (f"has {bad} non-positive" in printed.err) == (bad > 0), printed.err
                assert printed.err == "" or bad > 0


@pytest.mark.parametrize("mesh", ["tets", "triangles"])
def test_a_flat_element_is_refused_before_any_file_or_skipped(mesh, cube_file, tmp_path,
                                                               capsys):
    path, V, T = cube_file
    if mesh == "triangles":
        T = tetlap.diagnostics.boundary_faces(V, T)
        flat = [[0, 1, 2]]                 # three vertices on one edge of the cube
    else:
        flat = [[0, 4, 16, 20]]            # four vertices on z = 0
    flat_file = tmp_path / "flat.vtu"
    tetlap.io.write(flat_file, V, np.vstack([T, flat]))
    assert cli.main(["assemble", str(flat_file), "-o", str(tmp_path / "y")]) == 2
    assert "degenerate" in capsys.readouterr().err
    assert not list(tmp_path.glob("y*"))
    assert cli.main(["assemble", str(flat_file), "-o", str(tmp_path / "y"),
                     "--degenerate", "skip"]) == 0
    L = tetlap.laplacian(V, np.vstack([T, flat]), degenerate="skip")
    assert (sp.load_npz(tmp_path / "y.npz") != L).nnz == 0
