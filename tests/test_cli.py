"""The tetlap command (also python -m tetlap): parsing, printing and exit codes.

The numbers it prints are tested where they are computed (test_info.py, test_assembly.py,
test_benchmark.py, test_experiments.py); here: what reaches stdout and stderr, and how.
Most tests call ``cli.main`` in-process; a few run ``python -m tetlap`` as users do.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
import tetlap.io
from tetlap import cli


def run(*args):
    return subprocess.run([sys.executable, "-m", "tetlap", *args], capture_output=True,
                          text=True, timeout=600)


@pytest.fixture
def cube_file(tmp_path):
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    path = tmp_path / "cube.vtu"
    tetlap.io.write(path, V, T)
    return path, V, T


# ---- tetlap info ----------------------------------------------------------------------


def test_info_json_on_the_built_in_mesh():
    out = run("info", "--json")
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["source"] == cli.BUILT_IN
    for key in ("n_vertices", "n_tets", "n_boundary_vertices", "non_delaunay_face_fraction",
                "min_dihedral_deg"):
        assert key in result["mesh"]
    for kind in ("primal", "dual"):
        for key in ("symmetric", "max_row_sum", "linear_precision_residual", "nsd",
                    "min_weight", "negative_fraction", "negative_fraction_interior", "finite",
                    "mass_total", "mesh_volume"):
            assert key in result[kind]
    V, T = tetlap.meshes.ball(2000, seed=0)
    assert result["mesh"]["n_tets"] == len(T)
    assert result["mesh"]["non_delaunay_face_fraction"] == 0.0  # a Delaunay mesh
    assert result["primal"]["nsd"] is True
    assert result["dual"]["negative_fraction_interior"] == 0.0
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert result["primal"]["min_weight"] == pytest.approx(w.min(), rel=1e-12)
    for kind in ("primal", "dual"):
        assert result[kind]["mass_total"] == pytest.approx(result[kind]["mesh_volume"])


def test_info_table_is_human_readable():
    out = run("info", "--no-nsd")
    assert out.returncode == 0, out.stderr
    assert "negative semidefinite" in out.stdout and "primal" in out.stdout
    assert "semidefinite (dual): skipped (nsd=False)" in out.stdout


def test_info_regular_section_and_no_regular(monkeypatch, capsys):
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)      # regular, not Delaunay
    monkeypatch.setattr(cli, "_load", lambda mesh: (V, T, "test mesh"))

    def info(*flags):
        assert cli.main(["info", "--no-nsd", *flags]) == 0
        return capsys.readouterr().out

    out = info()
    assert "regular (weighted Delaunay): yes" in out
    assert "negative interior weights: dual" in out and "weighted dual 0," in out
    assert "regular (weighted Delaunay)" not in info("--no-regular")
    out = info("--regular-time", "1e-9")
    assert "regular (weighted Delaunay): undecided" in out and "--regular-time" in out
    result = json.loads(info("--json"))
    assert result["regular"]["status"] == "regular"
    assert result["regular"]["negative_interior_weights"]["weighted_dual"] == 0


def test_info_table_of_a_file(cube_file, capsys):
    path, V, T = cube_file
    assert cli.main(["info", str(path)]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    assert lines[0] == f"mesh: {path}"
    assert lines[1].startswith(f"{len(V)} vertices (") and f", {len(T)} tets (" in lines[1]
    header = next(line for line in lines if line.startswith("property"))
    assert header.split() == ["property", "primal", "dual"]
    nsd_row = next(line for line in lines if line.startswith("negative semidefinite"))
    assert nsd_row.split()[-2:] == ["yes", "yes"]  # a Kuhn-type grid: both NSD
    assert "semidefinite (primal): dense eigenvalues" in out
    assert "mesh diagnostics" not in out  # progress (if any) goes to stderr


def test_info_json_of_a_file_has_only_json_on_stdout(cube_file, capsys):
    path, V, T = cube_file
    assert cli.main(["info", str(path), "--json", "--no-nsd"]) == 0
    out, err = capsys.readouterr()
    result = json.loads(out)
    assert result["source"] == str(path) and result["mesh"]["n_tets"] == len(T)
    assert result["primal"]["nsd"] is None


def test_bad_file_is_a_clean_error(tmp_path):
    out = run("info", str(tmp_path / "missing.msh"))
    assert out.returncode == 2 and "error" in out.stderr and "Traceback" not in out.stderr


def test_unreadable_file_is_one_line_on_stderr(tmp_path, capsys):
    pytest.importorskip("meshio")
    path = tmp_path / "noise.msh"
    path.write_text("this is not a mesh\n")
    assert cli.main(["info", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("tetlap: error: ") and "noise.msh" in err and err.count("\n") == 1


def test_ctrl_c_exits_130(monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tetlap.info, "report", interrupted)
    assert cli.main(["info"]) == 130
    assert capsys.readouterr().err == "tetlap: interrupted\n"


# ---- tetlap assemble ------------------------------------------------------------------


def test_assemble_writes_load_npz_files(tmp_path):
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
    assert cli.output_names("ops") == ("ops.npz", "ops.mass.npz")
    assert cli.output_names("ops.npz") == ("ops.npz", "ops.mass.npz")
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "a")]) == 0  # dual + circ.
    L, M = sp.load_npz(tmp_path / "a.npz"), sp.load_npz(tmp_path / "a.mass.npz")
    assert (L != tetlap.laplacian(V, T, "dual")).nnz == 0
    assert (M != tetlap.mass(V, T, "circumcentric")).nnz == 0
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "b.npz"), "--laplacian", "0.25"]) == 0
    assert (sp.load_npz(tmp_path / "b.npz") != tetlap.laplacian(V, T, 0.25)).nnz == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"L (dual, {len(V)} x {len(V)}, {L.nnz} entries) -> {tmp_path / 'a.npz'}"
    assert out[1] == f"M (circumcentric) -> {tmp_path / 'a.mass.npz'}"


def test_assemble_errors_are_exit_code_2(cube_file, tmp_path, capsys):
    path, V, T = cube_file
    assert cli.main(["assemble", str(path), "-o", str(tmp_path / "x"), "--laplacian", "cotan"]) == 2
    assert "tetlap: error: " in capsys.readouterr().err
    flat = tmp_path / "flat.vtu"
    tetlap.io.write(flat, V, np.vstack([T, [[0, 4, 16, 20]]]))  # four vertices on z = 0
    assert cli.main(["assemble", str(flat), "-o", str(tmp_path / "y")]) == 2
    assert "degenerate" in capsys.readouterr().err
    assert cli.main(["assemble", str(flat), "-o", str(tmp_path / "y"), "--degenerate", "skip"]) == 0
    assert not (tmp_path / "x.npz").exists()


# ---- parsing --------------------------------------------------------------------------


def test_version_and_help():
    out = run("--version")
    assert out.returncode == 0 and out.stdout.strip() == f"tetlap {tetlap.__version__}"
    out = run("--help")
    assert out.returncode == 0
    for command in ("info", "assemble", "bench", "experiment", "distributed-info"):
        assert command in out.stdout


@pytest.mark.parametrize("argv, message", [
    ([], "required"),
    (["frobnicate"], "invalid choice"),
    (["assemble", "m.vtu"], "-o/--output"),
    (["assemble", "m.vtu", "-o", "x", "--mass", "voronoi"], "invalid choice"),
    (["bench", "--threads", "0"], "must be between 1 and"),
    (["bench", "--threads", "9999"], "must be between 1 and"),
    (["bench", "--repeat", "0"], "must be at least 1"),
    (["bench", "--sizes", "5k"], "invalid choice"),
    (["experiment", "nonsense"], "invalid choice"),
    (["experiment", "flips", "--meshes", "/no/such/folder"], "no such folder"),
])
def test_bad_arguments_are_usage_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: tetlap") and message in err


def test_the_parser_knows_the_defaults():
    args = cli.parser().parse_args(["assemble", "m.vtu", "-o", "x"])
    assert (args.laplacian, args.mass, args.degenerate) == ("dual", "circumcentric", "raise")
    args = cli.parser().parse_args(["bench", "--threads", str(tetlap.MAX_THREADS)])
    assert args.threads == tetlap.MAX_THREADS and args.quick is False and args.repeat is None
    args = cli.parser().parse_args(["info"])
    assert (args.no_regular, args.regular_time) == (False, None)  # None: info's own budget
    args = cli.parser().parse_args(["experiment", "flips", "--quick", "--seed", "3"])
    assert (args.name, args.quick, args.seed, args.out) == ("flips", True, 3, None)


# ---- tetlap experiment, distributed-info ----------------------------------------------


def test_experiment_prints_the_summary_and_the_files(monkeypatch, tmp_path, capsys):
    from tetlap import experiments

    folder = tmp_path / "flips"
    folder.mkdir()
    (folder / "summary.txt").write_text("the summary\n")
    (folder / "results.csv").write_text("a,b\n")
    calls = []

    def fake_run(name, **kwargs):
        calls.append((name, kwargs))
        return folder

    monkeypatch.setattr(experiments, "run", fake_run)
    assert cli.main(["experiment", "flips", "--quick", "--seed", "2", "--out", str(folder)]) == 0
    assert calls == [("flips", {"quick": True, "out": str(folder), "seed": 2, "meshes": None})]
    out = capsys.readouterr().out
    assert out == f"the summary\nfiles: results.csv, summary.txt in {folder}\n"


def test_distributed_info_without_mpi4py_is_exit_code_2(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "mpi4py", None)
    assert cli.main(["distributed-info", str(tmp_path / "p.npy"), str(tmp_path / "t.npy")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tetlap: error: ") and "mpi4py" in err
