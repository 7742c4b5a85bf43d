"""``tetlap geodesic``: the distance written as point data and read back, the checks of
every flag before any work, the one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from conftest import run_tetlap


def test_writes_the_distance_as_point_data(cube_file, tmp_path):
    meshio = pytest.importorskip("meshio")
    cube_file, V, T = cube_file
    out = tmp_path / "field.vtu"
    r = run_tetlap("geodesic", str(cube_file), "--source", "0", "--source", "3", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "written" in r.stdout and "0 vertices unreachable" in r.stdout
    # issue 30.10: the steps on stderr, one whole line each when it is not a terminal
    assert r.stderr.splitlines() == [f"tetlap geodesic: {step} ..." for step in (
        "read", "set-up: assemble, factorize", "distance", "write")]
    mesh = meshio.read(out)
    d = np.asarray(mesh.point_data["distance"])
    assert np.array_equal(mesh.points, V)
    assert np.array_equal(d, tetlap.heat_distance(V, T, [0, 3]))


def test_pyvista_reads_the_field(cube_file, tmp_path):
    pv = pytest.importorskip("pyvista")
    cube_file, V, T = cube_file
    out = tmp_path / "field.vtu"
    assert run_tetlap("geodesic", str(cube_file), "--source", "1", "--out", str(out),
                      "--boundary", "average").returncode == 0
    grid = pv.read(out)
    assert np.allclose(grid.point_data["distance"],
                       tetlap.heat_distance(V, T, 1, boundary="average"))


@pytest.mark.parametrize("flags, message", [
    (["--source", "-1"], "--source must be a non-negative integer"),
    (["--source", "0", "--time", "0"], "--time must be a positive number"),
    (["--source", "0", "--time", "nan"], "--time must be a positive number"),
    (["--source", "0", "--threads", "0"], "--threads"),
    (["--source", "0", "--laplacian", "cotan"], "--laplacian"),
    (["--source", "0", "--out", "/proc/nonexistent/f.vtu"], "--out /proc/nonexistent/f.vtu: cannot be written"),
    (["--source", "0", "--out", "f.txt"], "not a mesh format meshio writes tets in"),
    (["--source", "0", "--out", "f.stl"], "not a mesh format that holds tets"),
    (["--source", "100000"], "--source: sources holds 100000"),
])
def test_bad_flags_are_one_line_errors_before_any_work(cube_file, flags, message, tmp_path):
    r = run_tetlap("geodesic", str(cube_file[0]), *flags, cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    *steps, last = r.stderr.strip().splitlines()
    assert steps in ([], ["tetlap geodesic: read ..."])   # the source needs the mesh
    assert last.startswith("tetlap: error: ") and message in last
    assert not (tmp_path / "f.txt").exists() and not (tmp_path / "f.stl").exists()


def test_an_existing_output_is_kept_when_a_later_check_fails(cube_file, tmp_path):
    out = tmp_path / "keep.vtu"
    out.write_text("old")
    r = run_tetlap("geodesic", str(cube_file[0]), "--source", "0", "--time", "-1", "--out", str(out))
    assert r.returncode == 2 and out.read_text() == "old"


def test_missing_source_is_a_usage_error(cube_file):
    r = run_tetlap("geodesic", str(cube_file[0]))
    assert r.returncode == 2 and "--source" in r.stderr
