"""The README's examples run as written: every ```python block on its own (a fresh
namespace) and every ```pycon block as a doctest, so the numbers it shows are the ones the
code prints. A block whose first line is ``# requires: MODULE`` runs only when MODULE can
be imported."""

from __future__ import annotations

import doctest
import importlib.util
import os
import pathlib
import re

import numpy as np
import pytest

README = pathlib.Path(__file__).resolve().parent.parent / "README.md"
BLOCK = re.compile(r"^```(python|pycon)\n(.*?)^```", re.MULTILINE | re.DOTALL)


def blocks():
    text = README.read_text()
    found = []
    for match in BLOCK.finditer(text):
        line = text[:match.start()].count("\n") + 1
        found.append(pytest.param(match.group(1), match.group(2), id=f"line {line}"))
    return found


def test_the_readme_has_examples():
    kinds = [p.values[0] for p in blocks()]
    assert kinds.count("pycon") >= 3 and kinds.count("python") >= 1


@pytest.mark.parametrize("kind, code", blocks())
def test_readme_block_runs_as_written(kind, code):
    first = code.splitlines()[0]
    if first.startswith("# requires:"):
        module = first.split(":", 1)[1].strip()
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"needs {module}")
    if kind == "python":
        exec(compile(code, str(README), "exec"), {})
        return
    np.set_printoptions(legacy=False)
    test = doctest.DocTestParser().get_doctest(code, {}, "README", str(README), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)  # the output as printed
    out: list[str] = []
    runner.run(test, out=out.append)
    assert runner.failures == 0, "".join(out)


def test_the_bad_input_table_cites_tests_that_exist():
    """Every ``[test_x, ...]`` of the table names a test file of this suite (or a Rust
    test file), and every row cites at least one or says ``[untested: why]``."""
    text = README.read_text()
    table = text.split("<!-- bad-input-table -->")[1].split("<!-- /bad-input-table -->")[0]
    rows = [r for r in table.splitlines() if r.startswith("| ") and not r.startswith("| input")]
    assert len(rows) >= 20
    here = pathlib.Path(__file__).parent
    for row in rows:
        if re.search(r"\[untested: [^\]]+\]", row):
            continue
        cited = re.findall(r"\[(?:Rust: )?([\w, .]+)\]", row)
        names = [n.strip() for group in cited for n in group.split(",")]
        assert names, f"no test cited: {row}"
        for name in names:
            if name.endswith(".rs"):
                assert (here.parent / "rust" / "tests" / name).exists(), (name, row)
            else:
                assert (here / f"{name}.py").exists(), (name, row)


# ---- the statements around the examples, as written -----------------------------------


def section(title: str) -> str:
    text = README.read_text()
    start = text.index(f"\n## {title}\n")
    return text[start:text.index("\n## ", start + 1)]


def test_the_command_summary_lists_every_flag_and_no_other():
    """Each ``tetlap COMMAND`` line of "Commands" names exactly the command's flags."""
    import argparse

    from tetlap import cli

    block = section("Commands").split("```sh\n")[1].split("```")[0]
    listed = {line.split()[1]: set(re.findall(r"(?<![\w-])(--?[a-z][\w-]*)", line.split("#")[0]))
              for line in block.splitlines() if line.startswith("tetlap ") and
              not line.startswith("tetlap --")}
    (sub,) = [a for a in cli.parser()._actions if isinstance(a, argparse._SubParsersAction)]
    assert set(listed) == set(sub.choices)
    for name, parser in sub.choices.items():
        parser.format_help()                                     # adds its arguments
        flags = {a.option_strings[-1] if a.option_strings[-1] != "--output" else "-o"
                 for a in parser._actions if a.option_strings and a.dest != "help"
                 and a.help != argparse.SUPPRESS}    # deprecated names, not advertised
        assert listed[name] == flags, name


def test_the_command_text_names_every_experiment():
    from tetlap import experiments

    text = " ".join(section("Commands").split())
    named = re.search(r"`experiment` runs one of (.*?) and writes", text).group(1)
    assert re.findall(r"`([\w-]+)`", named) == list(experiments.NAMES)


def test_the_info_table_of_the_readme_is_what_tetlap_info_prints(capsys):
    """"Which operator?" shows part of ``tetlap info`` on the built-in ball: every line of
    it is a line of the real output."""
    from tetlap import cli

    shown = section("Which operator?").split("```\n")[1].split("```")[0].splitlines()
    assert cli.main(["info", "--no-regular"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert len(shown) >= 8 and all(line in printed for line in shown), (shown, printed)


def test_independent_of_orientation_numbering_and_order_to_rounding():
    """The first bullet: a reoriented, renumbered and reordered mesh gives operators that
    differ by less than 1e-13 of their largest entry (measured: 2e-14 on the hammer)."""
    import tetlap

    text = " ".join(README.read_text().split())
    assert ("to rounding, not bitwise: a reoriented, renumbered or reordered mesh gives "
            "operators that differ by less than `1e-13` of their largest entry") in text
    meshes = [tetlap.meshes.cube(6, jitter=0.25, seed=1), tetlap.meshes.weighted_ball(800, 1.0)]
    hammer = pathlib.Path(os.environ.get("TETLAP_MESHES", "")) / "ipc_hammer.msh"
    if hammer.is_file() and importlib.util.find_spec("meshio"):
        import tetlap.io

        meshes.append(tetlap.io.read(hammer))
    rng = np.random.default_rng(0)
    for V, T in meshes:
        perm = rng.permutation(len(V))
        new = np.empty_like(perm)
        new[perm] = np.arange(len(V))
        T2 = new[T][rng.permutation(len(T))]
        flip = rng.random(len(T2)) < 0.5
        T2[flip] = T2[flip][:, [1, 0, 2, 3]]
        for kind in ("primal", "dual"):
            A = tetlap.laplacian(V, T, kind)
            B = tetlap.laplacian(V[perm], T2, kind)[np.ix_(new, new)]
            assert abs(A - B).max() < 1e-13 * abs(A).max(), kind
        for kind in ("barycentric", "circumcentric"):
            a = tetlap.mass(V, T, kind).diagonal()
            b = tetlap.mass(V[perm], T2, kind).diagonal()[new]
            assert np.abs(a - b).max() < 1e-13 * np.abs(a).max(), kind
