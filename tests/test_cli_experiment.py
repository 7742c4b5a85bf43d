"""``tetlap experiment`` (tetlap.cli.experiment): what it prints and which flags it takes.
The experiments themselves are tested in test_experiments.py."""

from __future__ import annotations

import pytest

from tetlap import cli, experiments


def test_experiment_prints_the_summary_and_the_files(monkeypatch, tmp_path, capsys):
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


def test_meshes_only_for_the_experiments_that_read_a_folder(tmp_path, capsys):
    assert cli.main(["experiment", "flips", "--meshes", str(tmp_path), "--out",
                     str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == ("tetlap: error: experiment flips reads no mesh folder (--meshes is for "
                   "negative-weights, improve, regular-weights, harmonic, anisotropic)\n")
    assert not (tmp_path / "out").exists()          # refused before any work
    with pytest.raises(SystemExit):
        cli.main(["experiment", "--help"])
    assert ("negative-weights, improve, regular-weights, harmonic, anisotropic: a folder"
            in " ".join(capsys.readouterr().out.split()))
