"""``tetlap experiment anisotropic``: -div(K grad u) = f on the FVCA6 tetrahedral family.

The meshes are read from ``$TETLAP_FVCA6`` (default ``../shared/data/fvca6``); the tests
skip with the reason when they are missing."""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest

import tetlap
from tetlap import experiments
from tetlap.experiments import anisotropic

FOLDER = anisotropic.fvca6_folder()
needs_meshes = pytest.mark.skipif(not (FOLDER / "tet_2.msh").is_file(),
                                  reason=f"FVCA6 meshes not found in {FOLDER}")


def mesh(i):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        V, T = tetlap.io.read(FOLDER / f"tet_{i}.msh", "tetra")[:2]
    return V, T


@pytest.mark.parametrize("case", anisotropic.CASES, ids=lambda c: c.name)
def test_the_source_is_minus_div_k_grad_u(case):
    """f against central differences of K grad u (an independent route to the Hessian)."""
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, size=(20, 3))
    h = 1e-5
    div = np.zeros(len(x))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        flux = lambda p: case.gradient(p) @ case.K.T  # noqa: E731
        div += (flux(x + e)[:, i] - flux(x - e)[:, i]) / (2 * h)
    scale = np.abs(case.K).max() * case.k**2
    assert np.allclose(case.f(x), -div, atol=1e-6 * scale)
    g = np.array([(case.u(x + np.eye(3)[i] * h) - case.u(x - np.eye(3)[i] * h)) / (2 * h)
                  for i in range(3)]).T
    assert np.allclose(case.gradient(x), g, atol=1e-7 * case.k)


@needs_meshes
def test_the_primal_converges_at_second_order_on_test_1():
    """The P1 solve with K on tet_0 .. tet_2: L2 rate near 2 from the first to the last."""
    case = anisotropic.CASES[0]
    errors, sizes = [], []
    for i in range(3):
        V, T = mesh(i)
        L = tetlap.laplacian(V, T, coefficient=case.K)
        errors.append(anisotropic._Vertex(V, T, L).solve(case)[0])
        E = tetlap.diagnostics.mesh_edges(T)
        sizes.append(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean())
    rate = np.log(errors[0] / errors[-1]) / np.log(sizes[0] / sizes[-1])
    assert 1.7 < rate < 2.6, (errors, rate)


@needs_meshes
@pytest.mark.slow
def test_the_quick_run_writes_the_table(tmp_path):
    folder = experiments.run("anisotropic", quick=True, out=tmp_path / "a")
    with open(folder / "results.csv") as f:
        table = list(csv.DictReader(f))
    columns = {"case", "mesh", "h", "operator", "l2_error", "l2_rate", "gradient_error",
               "gradient_rate", "negative_fraction", "outside", "note"}
    assert columns <= set(table[0])
    assert {r["operator"] for r in table} == set(anisotropic.OPERATORS)
    primal = [r for r in table if r["case"] == "test 1" and r["operator"] == "primal"]
    assert [r["mesh"] for r in primal] == ["tet_0", "tet_1", "tet_2"]
    e0, e2 = float(primal[0]["l2_error"]), float(primal[-1]["l2_error"])
    h0, h2 = float(primal[0]["h"]), float(primal[-1]["h"])
    assert 1.7 < np.log(e0 / e2) / np.log(h0 / h2) < 2.6
    # the maximum principle of the weighted dual where its weights are regular
    for r in table:
        if r["operator"] == "dual, regular weights" and r["note"] == "regular":
            assert float(r["negative_fraction"]) == 0.0 and int(r["outside"]) == 0
    assert "test 1" in (folder / "summary.txt").read_text()


def test_missing_meshes_are_reported_not_raised(tmp_path):
    folder = experiments.run("anisotropic", quick=True, out=tmp_path / "a",
                             meshes=tmp_path)
    assert "FVCA6 meshes not found" in (folder / "summary.txt").read_text()
