"""The tetlap command as a whole (tetlap.cli and tetlap.cli._output): the parser built from
the command modules, exit codes, one-line errors, every numeric flag of every command
checked before any work, the JSON writer, and a fast ``--version``.

Each command has its own file (test_cli_info.py, test_cli_assemble.py, ...); the numbers
it prints are tested where they are computed (test_info.py, test_improve.py, ...). Most
tests call ``cli.main`` in-process; a few run ``python -m tetlap`` as users do.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys

import pytest

import tetlap
from tetlap import benchmark_solve
from tetlap import cli, experiments
from tetlap.cli import _output

from conftest import run_tetlap as run




def subparsers(parser):
    """{command: its parser, with its arguments added (they are added on first use)}."""
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for command in action.choices.values():
        command.format_help()
    return action.choices


# ---- the parser ------------------------------------------------------------------------


def test_version_and_help():
    out = run("--version")
    assert out.returncode == 0 and out.stdout.strip() == f"tetlap {tetlap.__version__}"
    out = run("--help")
    assert out.returncode == 0
    for command in cli.COMMANDS:
        assert command.NAME in out.stdout and command.HELP in out.stdout


def test_one_module_per_command_each_with_its_arguments_check_and_run():
    names = [c.NAME for c in cli.COMMANDS]
    assert names == ["info", "assemble", "bench", "experiment", "improve", "distributed-info",
                     "geodesic"]
    assert list(subparsers(cli.parser())) == names
    for command in cli.COMMANDS:
        assert command.__name__ == "tetlap.cli." + command.NAME.replace("-", "_")
        assert callable(command.arguments) and callable(command.check) and callable(command.run)


def test_version_and_help_import_neither_numpy_nor_scipy():
    """What makes ``tetlap --version`` instant: 0.34 s before the lazy imports, 0.06 s
    after (median of 3 on 2 cores, warm cache; NumPy and SciPy cost 0.3 s)."""
    code = ("import sys\nfrom tetlap import cli\n"
            "for argv in (['--version'], ['--help']):\n"
            "    try:\n        cli.main(argv)\n    except SystemExit:\n        pass\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_the_parser_knows_the_defaults():
    args = cli.parser().parse_args(["assemble", "m.vtu", "-o", "x"])
    assert (args.laplacian, args.mass, args.degenerate) == ("primal", "barycentric", "raise")
    args = cli.parser().parse_args(["bench", "--threads", str(tetlap.MAX_THREADS)])
    assert args.threads == tetlap.MAX_THREADS and args.quick is False and args.repeat is None
    args = cli.parser().parse_args(["info"])
    assert (args.no_regular, args.regular_time) == (False, None)  # None: info's own budget
    args = cli.parser().parse_args(["experiment", "flips", "--quick", "--seed", "3"])
    assert (args.name, args.quick, args.seed, args.out) == ("flips", True, 3, None)
    args = cli.parser().parse_args(["improve", "m.vtu", "-o", "x"])
    assert (args.margin, args.iterations, args.step, args.threads) == (0.02, 200, 0.3, None)


def test_every_command_describes_itself_and_each_experiment_its_quick_time():
    # issue 30: distributed-info --help and experiment --help had no descriptions
    parsers = subparsers(cli.parser())
    for command in cli.COMMANDS:
        assert command.DESCRIPTION and len(command.DESCRIPTION) > 40, command.NAME
        assert command.DESCRIPTION.split()[0] in parsers[command.NAME].format_help()
    text = " ".join(parsers["experiment"].format_help().split())
    for e in experiments.EXPERIMENTS:
        assert f"{e.name} {e.about} (--quick: {e.quick} s)" in text
        assert 0 < e.quick < 120


def test_the_experiment_names_come_from_the_registry():
    (experiment,) = [a for a in subparsers(cli.parser())["experiment"]._actions
                     if a.dest == "name"]
    assert tuple(experiment.choices) == experiments.NAMES
    assert experiments.NAMES == tuple(e.name for e in experiments.EXPERIMENTS)


@pytest.mark.parametrize("argv, message", [
    ([], "required"),
    (["frobnicate"], "invalid choice"),
    (["assemble", "m.vtu"], "-o/--output"),
    (["assemble", "m.vtu", "-o", "x", "--mass", "voronoi"], "invalid choice"),
    (["bench", "--threads", "two"], "invalid int value"),
    (["bench", "--sizes", "5k"], "invalid choice"),
    (["improve", "m.vtu", "-o", "x", "--step", "far"], "invalid float value"),
    (["experiment", "nonsense"], "invalid choice"),
    (["experiment", "flips", "--meshes", "/no/such/folder"], "no such folder"),
])
def test_malformed_arguments_are_usage_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: tetlap") and message in err


# ---- every numeric flag, before any work -----------------------------------------------

#: The smallest command line of each command (a missing mesh file: reading it would be
#: the first work).
MINIMAL = {"info": ["missing.vtu"], "assemble": ["missing.vtu", "-o", "x"], "bench": [],
           "experiment": ["flips"], "improve": ["missing.vtu", "-o", "x"],
           "geodesic": ["missing.vtu", "--source", "0"]}
#: Numeric flags for which 0 is a valid value.
ZERO_OK = {"--margin", "--seed", "--source"}


def numeric_flags():
    for name, parser in subparsers(cli.parser()).items():
        for action in parser._actions:
            if action.type in (int, float):
                yield name, action.option_strings[-1], action.type


NUMERIC = sorted(numeric_flags())


def test_the_numeric_flags_are_known():
    assert {f"{c} {f}" for c, f, _ in NUMERIC} == {
        "info --regular-time", "info --threads", "assemble --threads",
        "bench --threads", "bench --repeat", "bench --cap", "experiment --seed",
        "improve --margin", "improve --iterations", "improve --step", "improve --threads",
        "geodesic --time", "geodesic --threads"}   # --source: an index, a point or "boundary"


@pytest.mark.parametrize("command, flag, kind", NUMERIC)
def test_every_impossible_numeric_flag_is_one_line_before_any_work(command, flag, kind,
                                                                   monkeypatch, capsys):
    """nan, inf, negative and (mostly) zero values: ``tetlap: error: FLAG ...``, exit 2,
    and neither a mesh is read nor an experiment or benchmark started."""
    def work(*args, **kwargs):
        raise AssertionError("work started before the flags were checked")

    monkeypatch.setattr(tetlap.io, "read", work)
    monkeypatch.setattr(tetlap.meshes, "ball", work)
    monkeypatch.setattr(experiments, "run", work)
    monkeypatch.setattr(tetlap.benchmark, "run", work)
    monkeypatch.setattr(benchmark_solve, "run", work)
    bad = ["-1", "-2.5"] if kind is float else ["-1"]
    bad += ["nan", "inf", "-inf", "1e999"] if kind is float else []
    bad += [] if flag in ZERO_OK else ["0", "0.0"] if kind is float else ["0"]
    if flag == "--threads":
        bad.append(str(tetlap.MAX_THREADS + 1))
    for value in bad:
        assert cli.main([command, *MINIMAL[command], f"{flag}={value}"]) == 2, value
        out, err = capsys.readouterr()
        assert out == "" and err.startswith(f"tetlap: error: {flag}") and err.count("\n") == 1, err


def test_the_messages_of_the_issue(capsys):
    for argv, message in [
        (["improve", "m.vtu", "-o", "x", "--step", "0"], "--step must be a positive number"),
        (["improve", "m.vtu", "-o", "x", "--step", "nan"], "--step must be a positive number"),
        (["improve", "m.vtu", "-o", "x", "--margin", "nan"], "--margin must be a non-negative number"),
        (["info", "--regular-time", "0"], "--regular-time must be a positive number"),
        (["bench", "--repeat", "0"], "--repeat must be a positive integer"),
        (["experiment", "flips", "--seed", "-1"], "--seed must be a non-negative integer"),
    ]:
        assert cli.main(argv) == 2
        assert capsys.readouterr().err == f"tetlap: error: {message}\n"
    assert cli.main(["bench", "--threads", "0"]) == 2
    err = capsys.readouterr().err       # the core's one check of thread counts
    assert err.startswith("tetlap: error: --threads: threads must be None or an integer from 1")


def test_threads_is_the_count_of_every_computation_of_a_command(monkeypatch, cube_file):
    # issue 30: info and assemble had no --threads; the count reaches the computations
    # that take no threads= (the diagnostics) through the variable threads=None follows
    import os

    path, V, T = cube_file
    seen = []

    def spy(*args, **kwargs):
        seen.append(os.environ.get("RAYON_NUM_THREADS"))
        raise tetlap.OptionError("stop here")

    monkeypatch.delenv("RAYON_NUM_THREADS", raising=False)
    monkeypatch.setattr(tetlap.info, "report", spy)
    monkeypatch.setattr(tetlap.assembly, "operators", spy)
    assert cli.main(["info", str(path), "--threads", "1"]) == 2
    assert cli.main(["assemble", str(path), "-o", "x", "--threads", "2"]) == 2
    assert cli.main(["info", str(path)]) == 2
    assert seen == ["1", "2", None] and "RAYON_NUM_THREADS" not in os.environ


def test_step_zero_as_users_type_it(tmp_path):
    out = run("improve", str(tmp_path / "m.vtu"), "-o", str(tmp_path / "o.vtu"), "--step", "0")
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr == "tetlap: error: --step must be a positive number\n"


# ---- errors, interrupts ----------------------------------------------------------------


def test_bad_file_is_a_clean_error(tmp_path):
    out = run("info", str(tmp_path / "missing.msh"))
    assert out.returncode == 2 and "error" in out.stderr and "Traceback" not in out.stderr


def test_unreadable_file_is_one_line_on_stderr(tmp_path, capsys):
    pytest.importorskip("meshio")
    path = tmp_path / "noise.msh"
    path.write_text("this is not a mesh\n")
    assert cli.main(["info", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    *steps, last = err.splitlines()  # the steps before it (stderr is no terminal here)
    assert steps == ["tetlap info: read the mesh ..."] and err.endswith("\n")
    assert last.startswith("tetlap: error: ") and "noise.msh" in last


def test_error_lines_are_one_line():
    assert _output.error_line(ValueError("a\n  b\n")) == "tetlap: error: a b"


def test_ctrl_c_exits_130(monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tetlap.info, "report", interrupted)
    assert cli.main(["info"]) == 130
    assert capsys.readouterr().err.endswith("...\ntetlap: interrupted\n")


def test_distributed_info_without_mpi4py_is_exit_code_2(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "mpi4py", None)
    assert cli.main(["distributed-info", str(tmp_path / "p.npy"), str(tmp_path / "t.npy")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("tetlap: error: ") and "mpi4py" in err


# ---- JSON ------------------------------------------------------------------------------


def test_json_documents_are_valid_json_and_name_what_is_out_of_range():
    doc = {"a": 1.0, "b": {"c": math.inf, "d": [1, math.nan]}, "e": None, "f": True}
    text = _output.json_document(doc)
    result = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert result == {"a": 1.0, "b": {"c": None, "d": [1, None]}, "e": None, "f": True,
                      "non_finite": ["b.c", "b.d.1"]}
    assert doc["b"]["c"] == math.inf  # the input is untouched
    assert "non_finite" not in json.loads(_output.json_document({"a": 2.0}))
