"""Issue 30, items 8 and 11: every flag of every command, read from the argparse parser
itself (a new flag cannot be forgotten), with absurd values ends in a result or in a
one-line error with exit code 2, never a traceback; every output path is checked before
any work."""

from __future__ import annotations

import argparse
import os
import pathlib

import numpy as np
import pytest

import tetlap
import tetlap.benchmark
import tetlap.experiments
import tetlap.improve
import tetlap.info
from tetlap import _options, cli
from tetlap.cli import _mesh, _paths

#: Values that no flag should crash on: numbers at and beyond every range, integers beyond
#: 64 bits, and paths that are not what a flag wants (filled in by ``values``).
NUMBERS = ["0", "-1", "1e-17", "1e-320", "1e20", "1e308", "-1e308", "nan", "inf", "-inf",
           str(10**20), str(-(10**20)), str(2**63)]
#: A file name that is not UTF-8, as Python passes it on (lone surrogates).
NOT_UTF8 = os.fsdecode(b"mesh-\xff\xfe")


def values(folder: pathlib.Path) -> list[str]:
    (folder / "a folder").mkdir(exist_ok=True)
    (folder / "a file").write_text("not a mesh\n")
    return NUMBERS + ["", NOT_UTF8, NOT_UTF8 + ".vtu", str(folder / "a folder"),
                      str(folder / "a file"), str(folder / "a file" / "below.vtu"),
                      "/proc/nonexistent/x.vtu", "x.xyz", "x.stl"]


def subparsers():
    """``{name: parser}`` of every command, with its arguments added."""
    parser = cli.parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for sub in action.choices.values():
        sub._add_arguments()
    return action.choices


def flags_taking_values():
    """``(command, action)`` for every argument that takes a value other than a choice."""
    for name, sub in subparsers().items():
        for action in sub._actions:
            if action.nargs == 0 or action.choices is not None:
                continue  # store_true / help, or a choice that argparse checks itself
            yield name, action


FLAGS = [pytest.param(name, action, id=f"{name} {'/'.join(action.option_strings) or action.dest}")
         for name, action in flags_taking_values()]


def test_the_walk_sees_every_command_and_its_numeric_flags():
    seen = {(name, action.dest) for name, action in flags_taking_values()}
    assert {name for name, _ in seen} == {c.NAME for c in cli.COMMANDS}
    for expected in [("improve", "step"), ("improve", "margin"), ("bench", "repeat"),
                     ("bench", "cap"), ("info", "plot"), ("assemble", "output"),
                     ("geodesic", "time"), ("experiment", "seed")]:
        assert expected in seen


@pytest.fixture
def workplace(tmp_path, monkeypatch):
    """A working folder with a small mesh file, and the commands' slow parts (plots, the
    experiments) replaced by stand-ins that write the same files."""
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(2, jitter=0.1, seed=1)
    tetlap.io.write(tmp_path / "cube.vtu", V, T)
    np.save(tmp_path / "points.npy", V)
    np.save(tmp_path / "tets.npy", T)
    monkeypatch.chdir(tmp_path)

    def plot(V, T, folder, name):
        folder = pathlib.Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        for file in tetlap.info.plot_names(name):
            (folder / file).write_bytes(b"")
        return [folder / file for file in tetlap.info.plot_names(name)]

    def experiment(name, *, quick, out, seed, meshes):
        folder = tetlap.experiments.folder(name, out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "summary.txt").write_text(f"{name} with seed {seed}\n")
        return folder

    monkeypatch.setattr(tetlap.info, "plot", plot)
    monkeypatch.setattr(tetlap.experiments, "run", experiment)
    return tmp_path


#: A command line that works, per command: small and quick (the value under test replaces
#: the argument's own, or is added).
BASE = {
    "info": {"mesh": "cube.vtu", "--no-regular": None},
    "assemble": {"mesh": "cube.vtu", "-o": "ops"},
    "bench": {"--mesh": "cube.vtu", "--repeat": "1", "--operators": "primal"},
    "experiment": {"name": "flips", "--quick": None},
    "improve": {"mesh": "cube.vtu", "-o": "out.vtu", "--iterations": "2"},
    "distributed-info": {"points": "points.npy", "tets": "tets.npy"},
    "geodesic": {"mesh": "cube.vtu", "--source": "0"},
}


def command_line(name: str, action, value: str) -> list[str]:
    args = dict(BASE[name])
    key = action.option_strings[0] if action.option_strings else action.dest
    if action.dest == "regular_time":
        args.pop("--no-regular")
    for other in [k for k in args if k in action.option_strings]:
        args.pop(other)
    args[key] = value
    line = [name]
    for k, v in args.items():  # positionals by their dest, in order
        if not k.startswith("-"):
            line.append(v)
    for k, v in args.items():
        if k.startswith("-"):
            line += [k] if v is None else [k, v]
    return line


@pytest.mark.slow  # 15 s in all
@pytest.mark.filterwarnings("error")  # an overflow on the way is a failure too
@pytest.mark.parametrize("name, action", FLAGS)
def test_absurd_values_end_in_a_result_or_one_line_error(name, action, workplace, capsys):
    for value in values(workplace):
        line = command_line(name, action, value)
        try:
            code = cli.main(line)
        except SystemExit as e:  # argparse: usage and "tetlap COMMAND: error: ..."
            code = e.code
            err = capsys.readouterr().err
            last = err.splitlines()[-1]
            assert code == 2 and last.startswith("tetlap") and ": error: " in last, (line, err)
            continue
        out, err = capsys.readouterr()
        assert code in (0, 2), (line, code, err)
        if code == 2:
            last = err.splitlines()[-1]
            assert last.startswith("tetlap: error: ") and "Traceback" not in err, (line, err)


def test_improve_with_a_step_below_the_rounding_does_not_move():
    """Issue 30.8: ``improve(step=1e-17)`` gave ``AttributeError: nit`` (L-BFGS-B with
    every variable fixed by its bounds returns no iteration count)."""
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=0)
    for step in (1e-17, 1e-300, 5e-324):
        r = tetlap.improve.improve(V + 10, T, step=step)  # every box below the rounding
        assert np.array_equal(r.V, V + 10) and r.iterations == 0
        assert "leaves no vertex room to move" in r.message
        r = tetlap.improve.improve(V, T, step=step)  # near 0, some boxes are not
        assert np.abs(r.V - V).max() <= step and r.after["negative_interior"] <= r.before[
            "negative_interior"]
    moved = tetlap.improve.improve(V + 10, T, step=1e-3, max_iterations=5)
    assert not np.array_equal(moved.V, V + 10)


@pytest.mark.parametrize("line, message", [
    (["improve", "M", "-o", "o.vtu", "--margin", "1e308"], "--margin must be at most 1e+06"),
    (["improve", "M", "-o", "o.vtu", "--step", "1e-17", "--iterations", "3"], None),
    (["bench", "--repeat", str(10**20)], "--repeat must be at most 10000"),
    (["bench", "--solve", "--cap", "1e20"], "--cap must be at most 1e+06"),
    (["bench", "--mesh", "cube.vtu", "missing.vtu"], "--mesh missing.vtu: cannot be read"),
])
def test_the_issues_examples(line, message, workplace, capsys, monkeypatch):
    def no_work(*args, **kwargs):
        raise AssertionError("the work started")

    monkeypatch.setattr(tetlap.benchmark, "run", no_work)
    line = [str(workplace / "cube.vtu") if x == "M" else x for x in line]
    code = cli.main(line)
    out, err = capsys.readouterr()
    if message is None:
        assert code == 0 and "leaves no vertex room to move" in out
    else:
        assert code == 2 and err.startswith(f"tetlap: error: {message}") and err.count("\n") == 1


def test_library_margin_and_heat_time_that_overflow_are_option_errors():
    """``improve --margin 1e308`` and ``geodesic --time 1e308`` overflowed (NumPy warnings,
    then an error about a non-finite Laplacian or matrix)."""
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(tetlap.OptionError, match="margin must be at most"):
        tetlap.improve.improve(V, T, margin=1e308)
    # a t whose mass term is below the rounding of t L is solved as its limit
    huge = tetlap.HeatDistance(V, T, t=1e308)
    assert huge.t == 1e308 and np.abs(
        huge.distance(0) - tetlap.HeatDistance(V, T, t=1e300).distance(0)).max() < 1e-14
    assert _options.at_most(1e6, _options.MAX_SECONDS, "x") == 1e6


# ---- item 8: a file name that is not UTF-8 -----------------------------------------------


@pytest.mark.slow
def test_a_file_name_that_is_not_utf8_is_shown_escaped_and_plots(tmp_path, capsys):
    """Issue 30.8: ``info --plot`` on such a file printed the report, then a matplotlib
    traceback (the title held a lone surrogate)."""
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    path = tmp_path / (NOT_UTF8 + ".vtu")
    tetlap.io.write(path, *tetlap.meshes.cube(2, jitter=0.1))
    assert cli.main(["info", str(path), "--no-nsd", "--no-regular", "--plot",
                     str(tmp_path / "plots")]) == 0
    out, err = capsys.readouterr()
    assert "mesh-\\xff\\xfe.vtu" in out.splitlines()[0]
    assert sorted(os.fsencode(p.name) for p in (tmp_path / "plots").iterdir()) == sorted(
        os.fsencode(name) for name in tetlap.info.plot_names(NOT_UTF8))
    out_mesh = tmp_path / (NOT_UTF8 + "-improved.vtu")
    assert cli.main(["improve", str(path), "-o", str(out_mesh), "--iterations", "2"]) == 0
    assert "mesh-\\xff\\xfe-improved.vtu" in capsys.readouterr().out and out_mesh.is_file()


# ---- item 11: every output checked before the work ----------------------------------------


@pytest.fixture
def no_work(monkeypatch):
    """Every command's work replaced by a failure: an output error must come first."""
    def work(*args, **kwargs):
        raise AssertionError("the work started before the output was checked")

    for target, name in [(_mesh, "load"), (tetlap.improve, "improve"),
                         (tetlap.info, "report"), (tetlap.experiments, "run"),
                         (tetlap.assembly, "operators")]:
        monkeypatch.setattr(target, name, work)


def commands_with_outputs(tmp_path):
    """``{command: (argv of an output path, [(bad path, message)])}``."""
    (tmp_path / "a file").write_text("x")
    for name in ("a folder.vtu", "a folder.npz"):
        (tmp_path / name).mkdir()
    mesh = str(tmp_path / "cube.vtu")
    files = [("/proc/nonexistent/x.vtu", "cannot be written (No such file or directory)"),
             (str(tmp_path / "a file" / "x.vtu"), "cannot be written (Not a directory)")]
    meshes = files + [(str(tmp_path / "a folder.vtu"), "is a folder, not a file"),
                      (str(tmp_path / "x"), "not a mesh format meshio writes tets in"),
                      (str(tmp_path / "x.xyz"), "not a mesh format meshio writes tets in"),
                      (str(tmp_path / "x.stl"), "not a mesh format that holds tets")]
    folders = [("/proc/nonexistent", "cannot be written (No such file or directory)"),
               (str(tmp_path / "a file"), "is a file, not a folder"),
               (str(tmp_path / "a file" / "below"), "cannot be written (Not a directory)")]
    return {
        "assemble -o": (lambda p: ["assemble", mesh, "-o", p],
                        files + [(str(tmp_path / "a folder.npz"), "is a folder, not a file")]),
        "improve -o": (lambda p: ["improve", mesh, "-o", p], meshes),
        "geodesic --out": (lambda p: ["geodesic", mesh, "--source", "0", "--out", p], meshes),
        "info --plot": (lambda p: ["info", mesh, "--plot", p], folders),
        "experiment --out": (lambda p: ["experiment", "flips", "--out", p], folders),
    }


@pytest.mark.parametrize("command", ["assemble -o", "improve -o", "geodesic --out",
                                     "info --plot", "experiment --out"])
def test_every_output_is_checked_before_the_work(command, tmp_path, no_work, capsys):
    """Issue 30.11: ``improve -o out.xyz``, an unwritable folder, ``info --plot /proc/x``
    and ``assemble -o BAD`` failed after the computation."""
    pytest.importorskip("matplotlib")
    pytest.importorskip("meshio")
    line, cases = commands_with_outputs(tmp_path)[command]
    flag = command.split()[1]
    before = sorted(tmp_path.rglob("*"))
    for path, message in cases:
        assert cli.main(line(path)) == 2, path
        out, err = capsys.readouterr()
        assert out == "" and err.count("\n") == 1, (path, err)
        assert err.startswith(f"tetlap: error: {flag} ") and message in err, (path, err)
    assert sorted(tmp_path.rglob("*")) == before  # the checks left nothing behind


def test_a_new_folder_is_allowed_and_the_check_leaves_nothing(tmp_path, no_work, capsys):
    pytest.importorskip("meshio")
    tetlap.io.write(tmp_path / "cube.vtu", *tetlap.meshes.cube(2))
    for argv in (["improve", str(tmp_path / "cube.vtu"), "-o", str(tmp_path / "new" / "a" / "o.vtu")],
                 ["experiment", "flips", "--out", str(tmp_path / "new" / "b")]):
        with pytest.raises(AssertionError, match="the work started"):
            cli.main(argv)
        assert not (tmp_path / "new").exists()
    capsys.readouterr()


def test_an_existing_output_that_cannot_be_replaced_is_refused(tmp_path, no_work, capsys):
    if os.geteuid() == 0:
        pytest.skip("root writes read-only files")
    target = tmp_path / "o.vtu"
    target.write_text("old")
    target.chmod(0o444)
    assert cli.main(["improve", str(tmp_path / "cube.vtu"), "-o", str(target)]) == 2
    assert "cannot be written" in capsys.readouterr().err and target.read_text() == "old"


def test_the_output_checks_name_the_path_printably(tmp_path):
    with pytest.raises(tetlap.OptionError, match=r"--out .*mesh-\\xff\\xfe: is a file"):
        bad = tmp_path / NOT_UTF8
        bad.write_text("x")
        _paths.output_folder(bad, "--out")
