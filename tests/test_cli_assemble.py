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
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "a")]) == 0  # dual + circ.
    L, M = sp.load_npz(tmp_path / "a.npz"), sp.load_npz(tmp_path / "a.mass.npz")
    assert (L != tetlap.laplacian(V, T, "dual")).nnz == 0
    assert (M != tetlap.mass(V, T, "circumcentric")).nnz == 0
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "b.npz"), "--laplacian", "0.25"]) == 0
    assert (sp.load_npz(tmp_path / "b.npz") != tetlap.laplacian(V, T, 0.25)).nnz == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"L (dual, {len(V)} x {len(V)}, {L.nnz} entries) -> {tmp_path / 'a.npz'}"
    assert out[1] == f"M (circumcentric) -> {tmp_path / 'a.mass.npz'}"


def test_the_output_folder_is_created(cube_file, tmp_path, capsys):
    """Issue 24.8: ``-o DIR/NAME`` failed when DIR was missing (``--plot DIR`` creates it)."""
    path, V, T = cube_file
    output = tmp_path / "new" / "deeper" / "ops"
    assert cli.main(["assemble", str(path), "-o", str(output)]) == 0
    assert (sp.load_npz(f"{output}.npz") != tetlap.laplacian(V, T, "dual")).nnz == 0
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
    assert "tetlap: error: --laplacian: kind must be" in capsys.readouterr().err
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
