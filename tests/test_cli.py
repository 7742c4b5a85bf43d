"""The tetlap command: info, assemble, bench (smoke), also as python -m tetlap."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
import tetlap.io
from tetlap import cli, diagnostics
from tetlap.meshes import orient

from conftest import real_mesh_paths


def run(*args):
    return subprocess.run([sys.executable, "-m", "tetlap", *args], capture_output=True,
                          text=True, timeout=600)


def test_info_json_on_the_built_in_mesh():
    out = run("info", "--json")
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    for key in ("n_vertices", "n_tets", "n_boundary_vertices", "non_delaunay_face_fraction",
                "min_dihedral_deg"):
        assert key in result
    for kind in ("primal", "dual"):
        for key in ("symmetric", "max_row_sum", "linear_precision_residual", "nsd",
                    "min_weight", "negative_weight_fraction",
                    "negative_weight_fraction_interior", "finite"):
            assert key in result[kind]
    V, T = tetlap.meshes.ball(2000, seed=0)
    assert result["n_tets"] == len(T)
    assert result["non_delaunay_face_fraction"] == 0.0  # a Delaunay mesh
    assert result["primal"]["nsd"] is True
    assert result["dual"]["negative_weight_fraction_interior"] == 0.0
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert result["primal"]["min_weight"] == pytest.approx(w.min(), rel=1e-12)
    for kind in ("barycentric", "circumcentric"):
        assert result["mass"][kind]["total"] == pytest.approx(result["mass"]["mesh_volume"])


def test_info_table_is_human_readable():
    out = run("info")
    assert out.returncode == 0, out.stderr
    assert "negative semidefinite" in out.stdout and "primal" in out.stdout


def test_bad_file_is_a_clean_error(tmp_path):
    out = run("info", str(tmp_path / "missing.msh"))
    assert out.returncode == 2 and "error" in out.stderr and "Traceback" not in out.stderr


def test_info_agrees_with_direct_computation_on_every_real_mesh():
    paths = real_mesh_paths()
    if not paths:
        pytest.skip("real-mesh corpus not found (set TETLAP_MESHES)")
    from conftest import read_mesh

    for path in paths:
        V, T = read_mesh(path)
        result = cli.info(V, T, nsd=len(V) <= 3000)
        assert result["n_tets"] == len(T) and result["n_vertices"] == len(V)
        for kind in ("primal", "dual"):
            L = tetlap.laplacian(V, T, kind)
            assert result[kind]["finite"] and result[kind]["symmetric"], path.name
            edges, w = tetlap.edge_weights(V, T, kind)
            assert result[kind]["min_weight"] == w.min(), path.name
            if result[kind]["nsd"] is not None and kind == "primal":
                assert result[kind]["nsd"], path.name  # the primal is always NSD
        assert result["n_positive_tets"] + result["n_negative_tets"] == len(T)
        flags = diagnostics.non_delaunay_faces(V, T)
        assert result["non_delaunay_face_fraction"] == (flags.mean() if len(flags) else 0.0)


def test_mixed_orientation_file_gives_the_numbers_of_a_reoriented_copy():
    paths = [p for p in real_mesh_paths() if "mixed_orient" in p.name or "sphshells" in p.name]
    if not paths:
        pytest.skip("real-mesh corpus not found (set TETLAP_MESHES)")
    from conftest import read_mesh

    for path in paths:
        V, T = read_mesh(path)
        a, b = cli.info(V, T, nsd=False), cli.info(V, orient(V, T), nsd=False)
        assert a["n_negative_tets"] > 0 and b["n_negative_tets"] == 0
        for kind in ("primal", "dual"):
            for key, value in a[kind].items():
                if key in ("max_row_sum", "linear_precision_residual"):
                    continue  # rounding noise, checked relative to max|L| elsewhere
                elif isinstance(value, float):
                    assert b[kind][key] == pytest.approx(value, rel=1e-9, abs=1e-15), key
                else:
                    assert b[kind][key] == value, key
        assert a["non_delaunay_face_fraction"] == b["non_delaunay_face_fraction"]


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


def test_io_roundtrip_and_dropped_cells(tmp_path):
    import meshio

    V, T = tetlap.meshes.cube(2)
    path = tmp_path / "mixed.vtu"
    meshio.Mesh(V, [("tetra", T), ("triangle", T[:3, :3])]).write(path)
    with pytest.warns(UserWarning, match="triangle"):
        V2, T2 = tetlap.io.read(path)
    np.testing.assert_array_equal(T2, T)
    np.testing.assert_allclose(V2, V)


def test_bench_quick_smoke():
    out = run("bench", "--sizes", "10k", "--repeat", "1", "--quick", "--json")
    assert out.returncode == 0, out.stderr
    records = json.loads(out.stdout)
    cases = {r["case"] for r in records}
    assert {"floor", "tetlap primal", "tetlap dual", "Mesh: update 20 vertices"} <= cases
    assert all(r["median_s"] > 0 for r in records)


def test_bench_operator_filter():
    out = run("bench", "--sizes", "10k", "--repeat", "1", "--quick", "--json", "--operators", "dual")
    assert out.returncode == 0, out.stderr
    cases = {r["case"] for r in json.loads(out.stdout)}
    assert "tetlap dual" in cases and "tetlap primal" not in cases and "floor" in cases
