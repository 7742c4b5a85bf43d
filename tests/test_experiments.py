"""Smoke runs of every experiment (quick sizes) and the robust facts they show.

The runs that take more than a few seconds are marked slow (`.ci/run` runs them)."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import tetlap
from tetlap import experiments
from tetlap.experiments import finite_volumes, flips

from conftest import MESH_DIR


def rows(folder):
    with open(folder / "results.csv") as f:
        return list(csv.DictReader(f))


def run(name, tmp_path, **kw):
    folder = experiments.run(name, quick=True, out=tmp_path / name, **kw)
    assert (folder / "results.csv").is_file() and (folder / "summary.txt").is_file()
    pytest.importorskip("matplotlib")
    assert any(p.suffix == ".png" and p.stat().st_size > 5000 for p in folder.iterdir())
    return folder


@pytest.mark.slow
def test_dirichlet_shell(tmp_path):
    folder = run("dirichlet-shell", tmp_path)
    data = rows(folder)
    random = [r for r in data if r["family"] == "random Delaunay"]
    assert all(float(r["variance_dual"]) < float(r["variance_primal"]) for r in random)
    assert "median variance ratio" in (folder / "summary.txt").read_text()


@pytest.mark.slow
def test_eigen_ball(tmp_path):
    data = rows(run("eigen-ball", tmp_path))
    mine = [r for r in data if r["family"] == "random Delaunay" and r["laplacian"] == "primal"
            and r["mass"] == "barycentric"]
    deviations = [float(r["mean_relative_deviation"]) for r in mine]
    assert len(deviations) == 2 and deviations[1] < deviations[0] < 0.2


def test_negative_weights_built_in(tmp_path):
    data = rows(run("negative-weights", tmp_path))
    assert all(int(r["nan_inf_primal"]) == 0 and int(r["nan_inf_dual"]) == 0 for r in data)
    ball = next(r for r in data if r["mesh"].startswith("ball"))
    assert float(ball["negative_fraction_dual"]) == 0.0 < float(ball["negative_fraction_primal"])


@pytest.mark.slow
def test_negative_weights_on_a_folder(tmp_path):
    if not MESH_DIR.is_dir():
        pytest.skip(f"real-mesh corpus not found at {MESH_DIR}")
    data = rows(run("negative-weights", tmp_path, meshes=MESH_DIR))
    assert len(data) == 12  # quick: the first 12 files
    assert all(int(r["nan_inf_primal"]) == 0 and int(r["nan_inf_dual"]) == 0 for r in data)


def test_sphere3(tmp_path):
    data = rows(run("sphere3", tmp_path))
    first, last = data[0], data[-1]
    for kind in ("primal", "dual"):  # normals converge for both
        assert float(last[f"normal_angle_mean_deg_{kind}"]) < float(first[f"normal_angle_mean_deg_{kind}"])
    # pointwise mean curvature converges for the dual only (paper Fig. 14)
    assert float(last["curvature_error_mean_dual"]) < 0.5 * float(first["curvature_error_mean_dual"])
    assert float(last["curvature_error_mean_primal"]) > 0.05
    assert all(float(r["min_weight_dual"]) > 0 for r in data)
    summary = (tmp_path / "sphere3" / "summary.txt").read_text()
    assert f"dual, {first['n_vertices']} -> {last['n_vertices']} samples:" in summary


@pytest.mark.slow
def test_flips(tmp_path):
    data = rows(run("flips", tmp_path))
    assert all(float(r["rank_gap_dual"]) < 1e-6 and float(r["rank_gap_primal"]) < 1e-6 for r in data)


def test_flip_energy_change_vanishes_for_cospherical_points_with_the_dual():
    """Paper Sec. 9: for co-spherical points the dual energy does not depend on the split."""
    for z0 in (0.0, 0.3, -0.5):
        r = np.sqrt(1 - z0**2)
        angle = np.array([0.1, 2.2, 4.3])
        X = np.vstack([np.column_stack([r * np.cos(angle), r * np.sin(angle), np.full(3, z0)]),
                       [[0, 0, 1], [0, 0, -1]]])
        D = {k: (tetlap.laplacian(X, flips.TWO, k) - tetlap.laplacian(X, flips.THREE, k)).toarray()
             for k in ("primal", "dual")}
        assert np.abs(D["dual"]).max() < 1e-12
        assert np.abs(D["primal"]).max() > 0.1


@pytest.mark.slow
def test_regular_weights(tmp_path):
    folder = run("regular-weights", tmp_path, meshes=MESH_DIR)
    table = rows(folder)
    generated = [r for r in table if r.get("family") == "regular triangulation"]
    assert generated and all(r["regular"] == "True" for r in generated)
    assert all(int(r["negative_interior_weighted"]) == 0 for r in generated)
    assert all(int(r["negative_interior_dual"]) > 0 for r in generated)  # not Delaunay


@pytest.mark.slow
def test_improve(tmp_path):
    folder = run("improve", tmp_path, meshes=MESH_DIR)
    shell = [r for r in rows(folder) if r["part"] == "shell"]
    assert shell and all(int(r["negative_after"]) < int(r["negative_before"]) for r in shell)


@pytest.mark.slow
def test_heat_distance(tmp_path):
    table = rows(run("heat-distance", tmp_path))
    for family in ("ball", "box"):
        for source in ("centre", "boundary"):
            errors = [float(r["error"]) for r in table if r["family"] == family
                      and r["source"] == source and r["boundary"] == "neumann"]
            assert len(errors) == 2 and errors[1] < errors[0] < 0.05


def test_heat_distance_records_a_baseline_that_fails(monkeypatch):
    """LaPy's Neumann Poisson solve is singular, and SuperLU says so on small boxes: the
    experiment keeps the error as a row value instead of stopping (CI failed on it)."""
    pytest.importorskip("lapy")
    import lapy.diffgeo

    from tetlap.experiments import heat_distance

    def singular(*args, **kwargs):
        raise RuntimeError("Factor is exactly singular")

    monkeypatch.setattr(lapy.diffgeo, "compute_geodesic_f", singular)
    V, T = tetlap.meshes.cube(3)
    assert heat_distance.lapy_distance(V, T, 0) == "RuntimeError: Factor is exactly singular"


@pytest.mark.slow
def test_harmonic_built_in(tmp_path):
    table = rows(run("harmonic", tmp_path))
    assert table and all(r["proved"] == "True" and int(r["auto_outside"]) == 0 for r in table)


@pytest.mark.slow
def test_finite_volumes(tmp_path):
    """Three refinements per family; every scheme's L2 error falls from the coarsest to the
    finest mesh at a rate of at least 1 (about 2 is what the full run measures)."""
    table = rows(run("finite-volumes", tmp_path))
    for family in {r["family"] for r in table}:
        for scheme in finite_volumes.SCHEMES:
            mine = [r for r in table if r["family"] == family and r["scheme"] == scheme]
            assert len(mine) == 3 and all(r["l2_error"] != "nan" for r in mine), (family, scheme)
            e = [float(r["l2_error"]) for r in mine]
            h = [float(r["h"]) for r in mine]
            assert np.log(e[0] / e[-1]) / np.log(h[0] / h[-1]) > 1, (family, scheme, e)
    assert "rates" in (tmp_path / "finite-volumes" / "summary.txt").read_text()


def test_finite_volume_schemes_are_exact_where_they_should_be():
    """The vertex dual reproduces |x|^2 (its pyramid identity: L |x|^2 = 6 M); both cell
    schemes reproduce linear functions (the dual edges are orthogonal to the faces)."""
    V, T = tetlap.meshes.ball(300, seed=4)
    square = lambda x: np.sum(x * x, axis=-1)
    six = lambda x: np.full(x.shape[:-1], 6.0)
    worst, _, _ = finite_volumes.vertex_dual(V, T, square, six)
    assert worst < 1e-12
    g = tetlap.dual_geometry(V, T)
    linear = np.array([0.3, -1.0, 2.0])
    Lc = tetlap.cell_laplacian(V, T)
    inner = np.setdiff1d(np.arange(len(T)), g.face_tets[g.boundary_faces, 0])
    assert np.abs(Lc @ (g.centres @ linear))[inner].max() < 1e-12 * abs(Lc).max()


# ---- the registry, the corpus listing, the summaries -----------------------------------


def test_the_registry_lists_each_experiment_once_with_its_runner():
    import importlib
    import inspect

    assert len(set(experiments.NAMES)) == len(experiments.EXPERIMENTS) == 11
    for e in experiments.EXPERIMENTS:
        run = importlib.import_module(f"tetlap.experiments.{e.module}").run
        assert ("meshes" in inspect.signature(run).parameters) == e.corpus, e.name
    with pytest.raises(tetlap.OptionError, match="unknown experiment"):
        experiments.run("nonsense")


def test_mesh_files_of_a_folder(tmp_path):
    from tetlap.experiments._corpus import mesh_files

    for name in ("b.vtu", "a.msh", "notes.txt", "c.ele", "c.node"):
        (tmp_path / name).write_text("")
    assert [p.name for p in mesh_files(tmp_path)] == ["a.msh", "b.vtu", "c.ele"]
    assert [p.name for p in mesh_files(tmp_path, only={"b.vtu", "x.vtu"})] == ["b.vtu"]


def test_a_failed_case_is_explained_in_the_summary_not_printed_as_nan(monkeypatch, tmp_path):
    """Issue 24.8: eigen-ball printed ``nan`` where an eigenproblem failed; the reason was
    only in results.csv, and cut at its first ';'."""
    from tetlap.experiments import eigen_ball

    exact = eigen_ball.ball_eigenvalues()
    barycentric = tetlap.mass(*tetlap.meshes.weighted_ball(3000, 1.0, seed=0)).diagonal()

    def eigs(L, M, k, fixed):      # the weighted ball's circumcentric mass fails, as at 64k
        d = M.diagonal()
        if len(d) == len(barycentric) and not np.array_equal(d, barycentric):
            raise tetlap.SolveError("the mass matrix is not positive; M[3, 3] = -1e-05")
        return exact * 1.01, None

    def no_gmsh():
        raise ImportError("gmsh is not installed")

    monkeypatch.setattr(eigen_ball.solve, "eigs", eigs)
    monkeypatch.setattr(eigen_ball.meshes, "_gmsh", no_gmsh)
    folder = experiments.run("eigen-ball", quick=True, out=tmp_path / "eigen")
    summary = (folder / "summary.txt").read_text()
    data = rows(folder)
    failed = [r for r in data if r["note"]]
    assert failed and all(r["note"] == "the mass matrix is not positive; M[3, 3] = -1e-05"
                          for r in failed)
    assert "nan" not in summary
    assert "n/a (the mass matrix is not positive; M[3, 3] = -1e-05)" in summary
    # issue 30: the summary names the sizes ("by size: 0.0938, 0.0425" did not)
    counts = ", ".join(dict.fromkeys(r["n_vertices"] for r in data
                                     if r["family"] == "random Delaunay"))
    assert f"random Delaunay, meshes of {counts} vertices:" in summary


def test_summaries_name_their_sizes_and_hint_at_the_readme_s_install(monkeypatch, tmp_path):
    """Issue 30: heat-distance listed errors 'by size' without the sizes and dropped LaPy
    without a word; the install hints of the summaries are the README's."""
    import sys

    for module in ("lapy", "matplotlib"):
        monkeypatch.setitem(sys.modules, module, None)
    folder = experiments.run("heat-distance", quick=True, out=tmp_path / "heat")
    summary = (folder / "summary.txt").read_text()
    data = rows(folder)
    for family in ("ball", "box"):
        counts = ", ".join(dict.fromkeys(r["n_vertices"] for r in data if r["family"] == family))
        assert f"  {family}, meshes of {counts} vertices:" in summary
    assert '(LaPy is not installed: pip install ".[baselines]")' in summary
    assert ('(figure distance_slice.png skipped: matplotlib is not installed: '
            'pip install ".[experiments]")') in summary


def test_every_install_hint_is_the_readme_s(monkeypatch):
    import pathlib
    import re
    import tomllib

    root = pathlib.Path(tetlap.__file__).parent  # the installed package's sources
    repo = pathlib.Path(__file__).resolve().parent.parent  # the checkout; CI installs a wheel
    extras = tomllib.loads((repo / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    readme = "".join((repo / name).read_text()      # the extras: the guide's first page
                     for name in ("README.md", "docs/guide/getting-started.md"))
    assert 'pip install ".[experiments,' in readme and "tetlap[" not in readme
    for extra in re.findall(r'pip install "\.\[([\w,]+)\]"', readme):
        assert set(extra.split(",")) <= set(extras), extra
    for path in root.rglob("*.py"):
        text = path.read_text()
        assert "pip install 'tetlap[" not in text, path  # not the README's (nor on PyPI)
        for extra in re.findall(r'pip install "\.\[(\w+)\]"', text):
            assert extra in extras, (path, extra)
    assert tetlap._extras.hint("meshing") == 'pip install ".[meshing]"'
    import sys

    monkeypatch.setitem(sys.modules, "gmsh", None)
    with pytest.raises(ImportError, match=r'need gmsh: pip install "\.\[meshing\]"'):
        tetlap.meshes._gmsh()
