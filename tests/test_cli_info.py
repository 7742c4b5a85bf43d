"""``tetlap info`` (tetlap.cli.info): the text and JSON reports as printed, the regular
section, ``--plot``, and meshes near the float64 range. The numbers are tested in
test_info.py."""

from __future__ import annotations

import json
import sys
import warnings

import numpy as np
import pytest

import tetlap
import tetlap.io
from tetlap import cli
from tetlap.cli import _mesh

from conftest import run_tetlap as run, strict_json
from test_info import check_report_of_a_delaunay_ball







@pytest.fixture
def given_mesh(monkeypatch):
    """Make ``tetlap info`` (without a file) report on a mesh of the test's choosing."""
    def use(V, T, source="test mesh"):
        monkeypatch.setattr(_mesh, "load", lambda path: (V, T, source))
    return use


def test_info_json_on_the_built_in_mesh():
    out = run("info", "--json")
    assert out.returncode == 0, out.stderr
    result = strict_json(out.stdout)
    assert list(result)[:2] == ["schema_version", "source"]
    assert result["schema_version"] == tetlap.info.SCHEMA_VERSION == 5
    assert result["source"] == _mesh.BUILT_IN
    for key in ("n_vertices", "n_tets", "n_boundary_vertices", "non_delaunay_face_fraction",
                "min_dihedral_deg"):
        assert key in result["mesh"]
    for kind in ("primal", "dual"):
        for key in ("symmetric", "max_row_sum", "linear_precision_residual", "nsd",
                    "min_weight", "negative_fraction", "negative_fraction_interior", "finite",
                    "mass_total", "mesh_volume"):
            assert key in result[kind]
    check_report_of_a_delaunay_ball(result, *tetlap.meshes.ball(2000, seed=0))


def test_the_built_in_mesh_is_decided_without_dense_eigenvalues(monkeypatch, capsys):
    """Issue 30.10: dense eigenvalues of the 2,000-vertex ball were 95% of the 15-20 s of
    `tetlap info`; the element certificates decide both Laplacians (in 0.05 s)."""
    import numpy as np

    def dense(*args, **kwargs):
        raise AssertionError("dense eigenvalues computed")

    monkeypatch.setattr(np.linalg, "eigvalsh", dense)
    assert cli.main(["info", "--json", "--no-regular"]) == 0
    result = json.loads(capsys.readouterr().out)
    for kind in ("primal", "dual"):
        assert result[kind]["nsd"] is True
        assert result[kind]["nsd_method"].startswith("element certificate: L is the "
                                                     f"{kind} Laplacian")


def test_progress_is_one_line_per_step_on_stderr_when_it_is_not_a_terminal():
    """Issue 30.10: `tetlap info` was silent in a pipe; now each step is a whole line on
    stderr (no carriage returns, no partial lines), and stdout holds the report alone.
    With --json, stderr stays quiet."""
    out = run("info", "--no-regular")
    assert out.returncode == 0, out.stderr
    assert "\r" not in out.stderr and out.stderr.endswith("...\n")
    assert out.stderr.splitlines() == [
        "tetlap info: make the built-in mesh ...", "tetlap info: mesh diagnostics ...",
        "tetlap info: primal Laplacian and barycentric mass ...",
        "tetlap info: checks of the primal Laplacian ...",
        "tetlap info: dual Laplacian and circumcentric mass ...",
        "tetlap info: checks of the dual Laplacian ..."]
    assert out.stdout.startswith("mesh: ") and "tetlap info:" not in out.stdout
    quiet = run("info", "--json", "--no-regular", "--no-nsd")
    assert quiet.returncode == 0 and quiet.stderr == ""


def test_info_table_is_human_readable():
    out = run("info", "--no-nsd")
    assert out.returncode == 0, out.stderr
    assert "negative semidefinite" in out.stdout and "primal" in out.stdout
    assert "semidefinite (dual): skipped (nsd=False)" in out.stdout


def test_info_regular_section_and_no_regular(given_mesh, capsys):
    given_mesh(*tetlap.meshes.weighted_ball(400, 1.0, seed=0))      # regular, not Delaunay

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
    assert "semidefinite (primal): element certificate: L is the primal Laplacian" in out
    assert "mesh diagnostics" not in out  # progress (if any) goes to stderr


def test_info_json_of_a_file_has_only_json_on_stdout(cube_file, capsys):
    path, V, T = cube_file
    assert cli.main(["info", str(path), "--json", "--no-nsd"]) == 0
    out, err = capsys.readouterr()
    result = strict_json(out)
    assert result["source"] == str(path) and result["mesh"]["n_tets"] == len(T)
    assert result["primal"]["nsd"] is None


def test_the_semidefiniteness_reason_is_printed_whole(given_mesh, capsys):
    """A jittered grid of 3,375 vertices: the element certificate groups failing tets;
    the reason ends its sentence, in the JSON and in the text."""
    given_mesh(*tetlap.meshes.cube(14, jitter=0.2, seed=0))
    assert cli.main(["info", "--json", "--no-regular"]) == 0
    method = json.loads(capsys.readouterr().out)["dual"]["nsd_method"]
    assert "groups of <=" in method and method.endswith("whose sums are positive semidefinite")
    assert cli.main(["info", "--no-regular"]) == 0
    assert f"semidefinite (dual): {method}\n" in capsys.readouterr().out


# ---- near the float64 range ------------------------------------------------------------


@pytest.mark.parametrize("scale", [1e200, 1e-200, 1e104, 1e-110])
def test_a_mesh_beyond_the_float_range_is_refused_naming_the_limit(scale, given_mesh, capsys):
    """Issue 24.4: cube(2) * 1e200 gave "mesh_volume": Infinity (not JSON), "48
    degenerate" tets and NumPy warnings; now one line naming the limit, as assemble."""
    V, T = tetlap.meshes.cube(2)
    given_mesh(V * scale, T)
    for flags in (["--json"], []):
        assert cli.main(["info", *flags]) == 2
        out, err = capsys.readouterr()
        *steps, err = err.splitlines()   # the text report's steps come first
        assert out == "" and steps == ([] if flags else ["tetlap info: make the built-in mesh ..."])
        assert err.startswith("tetlap: error: tet 0 has volume ") and "float64 range" in err
        assert "1e-100 to 1e100" in err


def test_a_mesh_beyond_the_float_range_as_users_type_it(tmp_path):
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(2)
    path = tmp_path / "big.vtu"
    tetlap.io.write(path, V * 1e200, T)
    for command in (["info", "--json"], ["improve", "-o", str(tmp_path / "out.vtu")],
                    ["assemble", "-o", str(tmp_path / "ops")]):
        out = run(command[0], str(path), *command[1:])
        assert out.returncode == 2 and out.stdout == ""
        assert out.stderr.startswith("tetlap: error: ") and out.stderr.count("\n") == 1, out.stderr
        assert "float64 range" in out.stderr
    assert not (tmp_path / "out.vtu").exists()


@pytest.mark.parametrize("scale", [1e100, 1e-100, 2.0**200, 2.0**-200])
def test_meshes_near_the_float_range_give_valid_json_and_no_warnings(scale, given_mesh, capsys):
    """In range but far from everyday units: the report is complete, strictly valid JSON,
    the regular section decided as on the unscaled mesh, and no warning (any warning
    would be an error here)."""
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
    given_mesh(V * scale, T)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cli.main(["info", "--json", "--no-nsd", "--regular-time", "60"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    result = strict_json(out)
    plain = tetlap.info.report(V, T, nsd=False, progress=False, regular_time_limit=60)
    assert "non_finite" not in result
    assert result["mesh"]["n_degenerate_tets"] == 0
    assert result["mesh"]["mesh_volume"] == pytest.approx(plain["mesh"]["mesh_volume"] * scale**3)
    assert result["dual"]["n_negative_interior"] == plain["dual"]["n_negative_interior"]
    assert result["regular"]["status"] == plain["regular"]["status"] == "regular"
    assert result["regular"]["mass_min"]["dual"] == pytest.approx(
        plain["regular"]["mass_min"]["dual"] * scale**3, rel=1e-9)


# ---- --plot ----------------------------------------------------------------------------


def test_plot_without_matplotlib_fails_before_any_analysis(monkeypatch, tmp_path, capsys):
    def analysis(*args, **kwargs):
        raise AssertionError("the analysis ran before matplotlib was checked")

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setattr(_mesh, "load", analysis)
    monkeypatch.setattr(tetlap.info, "report", analysis)
    assert cli.main(["info", "--plot", str(tmp_path / "plots")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == ("tetlap: error: info plots need matplotlib: "
                                 'pip install ".[experiments]"\n')


@pytest.mark.slow
def test_plots_are_named_after_the_mesh(tmp_path, monkeypatch, capsys):
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    folder = tmp_path / "new" / "plots"
    for name in ("first", "second"):
        path = tmp_path / f"{name}.vtu"
        tetlap.io.write(path, *tetlap.meshes.cube(2, jitter=0.1))
        assert cli.main(["info", str(path), "--no-nsd", "--no-regular", "--plot", str(folder)]) == 0
        assert f"plots: {folder / name}_dihedral_angles.png" in capsys.readouterr().out
    assert sorted(p.name for p in folder.iterdir()) == [
        f"{name}_{what}.png" for name in ("first", "second")
        for what in ("dihedral_angles", "masses", "weights")]
    V, T = tetlap.meshes.cube(2, jitter=0.1)
    monkeypatch.setattr(_mesh, "load", lambda path: (V, T, _mesh.BUILT_IN))
    assert cli.main(["info", "--no-nsd", "--no-regular", "--json", "--plot", str(folder)]) == 0
    out, err = capsys.readouterr()
    json.loads(out)                                   # the file list goes to stderr
    assert "ball_weights.png" in err and (folder / "ball_weights.png").is_file()


# ---- verdicts, folds and what to do ---------------------------------------------------


def table(out: str) -> dict:
    """{property: (primal cell, dual cell)} of the text report's table."""
    lines = out.split("\nproperty")[1].split("\n(mass:")[0].splitlines()[1:]
    rows = {}
    for line in lines:
        label, cells = line[:34].strip(), line[34:].split()
        half = len(cells) // 2
        rows[label] = (" ".join(cells[:half]), " ".join(cells[half:]))
    return rows


def test_every_row_with_a_verdict_shows_it_and_the_folds_are_named(given_mesh, capsys):
    """Issue 37.11: on a folded mesh `info` printed the linear-precision residual bare
    (3.081e-05) where `check` and `--json` said it fails. Every row whose JSON has a
    verdict shows it beside its number, as --json decides it; the folded tets and the
    vertices they spoil are named."""
    from test_diagnostics import folded_cube

    V, T = folded_cube()
    given_mesh(V, T)
    assert cli.main(["info", "--no-regular", "--no-nsd"]) == 0
    out = capsys.readouterr().out
    assert cli.main(["info", "--no-regular", "--no-nsd", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    rows = table(out)
    for label, (ok, value) in {"zero row sums (max |row sum|)": ("row_sums_ok", "max_row_sum"),
                               "linear precision (residual)": ("linear_precision_ok",
                                                               "linear_precision_residual")}.items():
        for cell, kind in zip(rows[label], ("primal", "dual")):
            r = result[kind]
            assert cell == f"{'yes' if r[ok] else 'NO'} {r[value]:.3e}", (label, kind)
    assert rows["linear precision (residual)"][0].startswith("NO ")
    m = result["mesh"]
    tets = np.flatnonzero(tetlap.diagnostics.folded_tets(V, T))
    vertices = np.flatnonzero(tetlap.diagnostics.folded_vertices(V, T))
    assert m["folded_tets"] == tets[:10].tolist() and m["n_folded_tets"] == len(tets) > 0
    assert m["folded_vertices"] == vertices[:10].tolist() and m["n_folded_vertices"] == len(vertices)
    line = next(line for line in out.splitlines() if line.startswith("folded: "))
    assert ", ".join(map(str, tets)) in line and ", ".join(map(str, vertices[:10])) in line
    assert "untangle" in out.split("what to do:")[1]


def test_info_of_the_polyfem_microstructure_says_no(capsys):
    from conftest import MESH_DIR, corpus_mesh

    corpus_mesh("polyfem_microstructure_p1.msh")                 # skips without the corpus
    assert cli.main(["info", str(MESH_DIR / "polyfem_microstructure_p1.msh")]) == 0
    out = capsys.readouterr().out
    primal, dual = table(out)["linear precision (residual)"]
    assert primal.startswith("NO 3.08") and dual.startswith("NO ")
    assert "folded: 8 tets" in out and "298, 624, 630, 728, 952, 2380, 2590, 5722;" in out


def advice(out: str) -> list[str]:
    return [line[2:] for line in out.split("\nwhat to do:\n")[1].splitlines()] if (
        "\nwhat to do:\n" in out) else []


def test_info_says_what_to_do_and_each_step_fixes_what_it_found(given_mesh, capsys):
    """Issue 37.23: `tetlap info` listed problems and no way out. It now advises the
    primal where the dual is indefinite, mass="mixed" where circumcentric masses are not
    positive, and regular_weights where they remove the negative interior weights; each
    step, done, fixes what it names. In plain words: no "margin ... (0 non-zero)" or
    "certificate: N faces"; --no-regular is named beside the search's time."""
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)             # regular, not Delaunay
    given_mesh(V, T)
    assert cli.main(["info"]) == 0
    out = capsys.readouterr().out
    steps = advice(out)
    assert len(steps) == 3, steps
    primal, mixed, weights = steps
    assert 'tetlap.laplacian(V, T, "primal")' in primal
    assert tetlap.check(tetlap.laplacian(V, T, "primal"), V, T).nsd is True
    assert 'mass="mixed"' in mixed
    used = tetlap.diagnostics.referenced_vertices(V, T)
    assert tetlap.mass(V, T, "mixed").diagonal()[used].min() > 0
    assert "tetlap.regular_weights(V, T).weights" in weights and "weights=w" in weights
    w = tetlap.regular_weights(V, T).weights
    assert tetlap.check(tetlap.laplacian(V, T, "dual", weights=w), V, T,
                        nsd=False).n_negative_interior == 0
    section = out.split("regular (weighted Delaunay):")[1]
    assert "non-zero)" not in section and "certificate" not in section
    assert "margin" not in section and "(--no-regular skips it)" in section
    # without the search, the advice says how to get it
    assert cli.main(["info", "--no-regular", "--no-nsd"]) == 0
    assert any("without --no-regular" in step for step in advice(capsys.readouterr().out))
    # a mesh with nothing to fix gets no advice
    given_mesh(*tetlap.meshes.cube(3))
    assert cli.main(["info"]) == 0
    assert advice(capsys.readouterr().out) == []


def test_a_mesh_that_is_not_regular_is_said_so_in_plain_words(given_mesh, capsys):
    from test_diagnostics import folded_cube

    given_mesh(*folded_cube())
    assert cli.main(["info", "--no-nsd"]) == 0
    out = capsys.readouterr().out
    section = out.split("regular (weighted Delaunay):")[1]
    assert "no (proved)" in section and "proof: " in section
    assert "certificate" not in section and "margin" not in section
