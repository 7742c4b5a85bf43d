"""``tetlap bench`` (tetlap.cli.bench): smoke runs, the table and the JSON records, with and
without libigl. The cases and records are tested in test_benchmark.py."""

from __future__ import annotations

import sys

import pytest

import tetlap
import tetlap.io
from tetlap import benchmark, cli
from tetlap.cli import _output

from conftest import run_tetlap as run, strict_json





def test_bench_quick_smoke():
    out = run("bench", "--sizes", "10k", "--repeat", "1", "--quick", "--json")
    assert out.returncode == 0, out.stderr
    document = strict_json(out.stdout)
    assert list(document) == ["schema_version", "benchmark", "records"]
    assert document["schema_version"] == benchmark.SCHEMA_VERSION == 1  # issue 30: none
    assert document["benchmark"] == "assembly"
    records = document["records"]
    cases = {r["case"] for r in records}
    assert {"floor", "tetlap primal", "tetlap dual", "Mesh: update 20 vertices"} <= cases
    assert all(r["median_s"] > 0 for r in records)
    assert {r["mesh"] for r in records} == {"kuhn 10k", "delaunay 10k"}  # --quick kinds


def test_bench_operator_filter():
    out = run("bench", "--sizes", "10k", "--repeat", "1", "--quick", "--json", "--operators", "dual")
    assert out.returncode == 0, out.stderr
    cases = {r["case"] for r in strict_json(out.stdout)["records"]}
    assert "tetlap dual" in cases and "tetlap primal" not in cases and "floor" in cases


def test_bench_a_mesh_file(tmp_path, capsys):
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(4, jitter=0.1)
    path = tmp_path / "cube4.vtu"
    tetlap.io.write(path, V, T)
    assert cli.main(["bench", "--mesh", str(path), "--repeat", "1", "--json",
                     "--operators", "tetlap primal"]) == 0
    records = strict_json(capsys.readouterr().out)["records"]
    assert {r["mesh"] for r in records} == {"cube4.vtu"}  # --mesh alone: no generated kinds
    assert all(r["n_tets"] == len(T) and r["n_vertices"] == len(V) for r in records)
    assert {"floor", "tetlap primal"} <= {r["case"] for r in records}


def test_the_table():
    V, T = tetlap.meshes.cube(3)
    records = benchmark.time_mesh("cube 3", V, T, threads=1, repeat=2, only=["tetlap primal"],
                                  progress=False)
    lines = _output.bench_table(records).splitlines()
    assert lines[0].split()[:3] == ["mesh", "tets", "case"] and len(lines) == 1 + len(records)
    assert all(line.startswith("cube 3") for line in lines[1:])


def test_without_libigl_no_column_of_nan(monkeypatch, capsys):
    """Issue 24.8: without libigl the igl column was all nan (and the JSON held NaN), under
    a help text that said igl.cotmatrix always runs."""
    monkeypatch.setitem(sys.modules, "igl", None)
    V, T = tetlap.meshes.cube(3)
    records = benchmark.time_mesh("cube 3", V, T, threads=1, repeat=1, only=["tetlap primal"],
                                  progress=False)
    assert all(r["igl_cotmatrix_over_this"] is None for r in records)
    table = _output.bench_table(records)
    assert "igl" not in table.splitlines()[0] and "nan" not in table
    strict_json(_output.json_document(records, indent=1))
    with pytest.raises(SystemExit):
        cli.main(["bench", "--help"])
    assert "when libigl is installed" in " ".join(capsys.readouterr().out.split())


def test_with_libigl_its_column_is_filled():
    pytest.importorskip("igl")
    V, T = tetlap.meshes.cube(3)
    records = benchmark.time_mesh("cube 3", V, T, threads=1, repeat=1, only=["tetlap primal"],
                                  progress=False)
    table = _output.bench_table(records)
    assert table.splitlines()[0].endswith("igl.cot / this") and "nan" not in table
    assert all(r["igl_cotmatrix_over_this"] > 0 for r in records)


@pytest.mark.parametrize("cap", ["0", "-1", "nan"])
def test_bench_solve_checks_its_cap(cap):
    out = run("bench", "--solve", "--cap", cap)
    assert out.returncode != 0 and "--cap" in out.stderr and "Traceback" not in out.stderr


def test_bench_solve_runs_the_solve_benchmark(monkeypatch, capsys):
    from tetlap import benchmark_solve

    seen = {}

    def fake_run(names, cap, progress):
        seen.update(names=names, cap=cap)
        return [{"mesh": "ball 189k", "n_tets": 1, "case": "dirichlet primal", "status": "ok",
                 "seconds": 2.0, "assembly_s": 1.0, "over_assembly": 2.0, "peak_rss_mb": 10.0,
                 "info": {"solver": "amg", "iterations": 3, "residual": 1e-12, "phases": {}}}]

    monkeypatch.setattr(benchmark_solve, "run", fake_run)
    assert cli.main(["bench", "--solve", "--quick", "--cap", "30", "--json"]) == 0
    assert seen == {"names": ["ball 189k"], "cap": 30.0}
    document = strict_json(capsys.readouterr().out)
    assert (document["schema_version"], document["benchmark"]) == (benchmark.SCHEMA_VERSION, "solve")
    assert document["records"][0]["case"] == "dirichlet primal"
