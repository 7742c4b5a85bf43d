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
    # and the set-up's own steps (HeatDistance's), as they happen
    assert r.stderr.splitlines() == [f"tetlap geodesic: {step} ..." for step in (
        "read", "assemble", "factorize the heat step (Neumann)", "factorize the Poisson step",
        "distance", "write")]
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
                       tetlap.heat_distance(V, T, 1, boundary_condition="average"))


@pytest.mark.parametrize("flags, message", [
    (["--source", "-1"], "--source must be a non-negative integer"),
    (["--source", "0", "--time", "0"], "--time must be a positive number"),
    (["--source", "0", "--time", "nan"], "--time must be a positive number"),
    (["--source", "0", "--threads", "0"], "--threads"),
    (["--source", "0", "--laplacian", "cotan"], "--laplacian"),
    (["--source", "0", "--out", "/proc/nonexistent/f.vtu"], "--out /proc/nonexistent/f.vtu: cannot be written"),
    (["--source", "0", "--out", "f.txt"], "not a mesh format meshio writes tets in"),
    (["--source", "0", "--out", "f.stl"], "not a mesh format that holds tets"),
    (["--source", "100000"], "--source 100000: not a vertex (there are 64 vertices, 0 to 63)"),
    (["--source", str(10**30)], f"--source {10**30}: not a vertex"),
    (["--source", "1e20"], "--source must be a vertex index, a point x,y,z or 'boundary'"),
    (["--source", "nan,0,0"], "--source nan,0,0: a point must be finite numbers"),
    (["--source", "0.5,0.5"], "--source 0.5,0.5: a point of the mesh has 3 coordinates"),
    (["--source", "0", "--boundary", "average", "--boundary-condition", "average"],
     "--boundary is the old name of --boundary-condition"),
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


def test_a_point_source_takes_the_nearest_vertex_and_says_which(cube_file, tmp_path):
    cube_file, V, T = cube_file
    out = tmp_path / "d.vtu"
    point = V[37] + [0.01, -0.02, 0.005]
    r = run_tetlap("geodesic", str(cube_file), f"--source={','.join(map(str, point))}",
                   "--out", str(out))
    assert r.returncode == 0, r.stderr
    gap = np.linalg.norm(V[37] - point)
    assert f"the nearest vertex is 37, at distance {gap:.4g}" in r.stdout
    assert "sources: 37;" in r.stdout
    meshio = pytest.importorskip("meshio")
    assert np.array_equal(meshio.read(out).point_data["distance"], tetlap.heat_distance(V, T, 37))


def test_boundary_is_an_extreme_vertex_whatever_the_numbering(cube_file, tmp_path):
    meshio = pytest.importorskip("meshio")
    cube_file, V, T = cube_file
    expected = int(np.lexsort(V.T[::-1])[0])          # the smallest x, then y, then z
    perm = np.random.default_rng(2).permutation(len(V))
    renumbered = tmp_path / "renumbered.vtu"
    inverse = np.argsort(perm)
    tetlap.io.write(renumbered, V[perm], inverse[T])
    for path, vertex in ((cube_file, expected), (renumbered, int(inverse[expected]))):
        out = tmp_path / "d.vtu"
        r = run_tetlap("geodesic", str(path), "--source", "boundary", "--out", str(out))
        assert r.returncode == 0, r.stderr
        assert f"--source boundary: vertex {vertex} at" in r.stdout
        assert meshio.read(out).point_data["distance"][vertex] == 0


def test_the_order_of_sources_does_not_matter(cube_file, tmp_path):
    meshio = pytest.importorskip("meshio")
    cube_file, V, T = cube_file
    fields = []
    for order in (["3", "40", "boundary"], ["boundary", "3", "40", "3"]):
        out = tmp_path / "d.vtu"
        flags = [x for s in order for x in ("--source", s)]
        assert run_tetlap("geodesic", str(cube_file), *flags, "--out", str(out)).returncode == 0
        fields.append(meshio.read(out).point_data["distance"])
    assert np.array_equal(*fields)


def test_the_old_boundary_flag_still_works_with_a_warning(cube_file, tmp_path):
    meshio = pytest.importorskip("meshio")
    cube_file, V, T = cube_file
    out = tmp_path / "d.vtu"
    r = run_tetlap("geodesic", str(cube_file), "--source", "1", "--boundary", "average",
                   "--out", str(out))
    assert r.returncode == 0
    assert r.stderr.splitlines()[0] == ("tetlap: warning: --boundary is deprecated, use "
                                        "--boundary-condition (it takes the same values)")
    assert "boundary condition: average" in r.stdout
    assert np.array_equal(meshio.read(out).point_data["distance"],
                          tetlap.heat_distance(V, T, 1, boundary_condition="average"))


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_h_and_t_are_printed_right_at_any_scale(tmp_path, scale):
    # h**2 overflowed into a traceback from 1.3e154, and t printed as 0 at 1e-200
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3, jitter=0.1, seed=1)
    path = tmp_path / "tiny.vtu"
    tetlap.io.write(path, V * scale, T)
    r = run_tetlap("geodesic", str(path), "--source", "0")
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    h = tetlap.HeatDistance(V, T).h * scale
    assert f"h = {h:.4g}, t = " in r.stdout
    t_text = r.stdout.split("t = ")[1].split(" =")[0]
    mantissa, exponent = t_text.split("e")
    assert abs(float(mantissa) * 10 ** (int(exponent) - 2 * round(np.log10(scale)))
               - (h / scale) ** 2) < 1e-3 * (h / scale) ** 2
    assert "= 1 h^2" in r.stdout
