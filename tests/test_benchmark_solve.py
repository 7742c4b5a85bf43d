"""tetlap.benchmark_solve (``tetlap bench --solve``, ``benches/solve.py``): every case runs
and reports on a small mesh, a case past its cap is killed, and the table prints."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import benchmark_solve


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    V, T = tetlap.meshes.ball(2000, seed=0)
    path = tmp_path_factory.mktemp("bench") / "mesh.npz"
    np.savez(path, V=V, T=T)
    return str(path)


@pytest.mark.parametrize("case", [c for c in benchmark_solve.CASES if not c.startswith("igl.")])
def test_every_case_runs_and_reports(small, case):
    r = benchmark_solve.run_case(case, small)
    assert r["seconds"] > 0 and r["assembly_s"] > 0 and r["peak_rss_mb"] > 0
    if case.startswith("dirichlet") or case in ("eigs k=10", "factorize"):
        assert r["info"]["residual"] <= tetlap.solve.RESIDUAL_TOL
    if case == "factorize":
        assert r["solve_s"] > 0


def test_a_case_past_its_cap_is_killed_and_reported(small):
    r = benchmark_solve._child("eigs k=10", small, cap=0.05)
    assert r == {"status": "timeout (> 0.05 s)"}
    record = {"mesh": "m", "n_tets": 1, "case": "eigs k=10", **r}
    assert "timeout" in benchmark_solve.table([record])


def test_a_child_reports_its_record(small):
    r = benchmark_solve._child("dirichlet dual", small, cap=120)
    assert r["status"] == "ok" and r["info"]["solver"] in ("amg", "cholesky")
    r["mesh"], r["n_tets"], r["case"], r["over_assembly"] = "m", 1, "dirichlet dual", 1.0
    assert "dirichlet dual" in benchmark_solve.table([r])
