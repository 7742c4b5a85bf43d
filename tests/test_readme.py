"""The README's examples run as written: every ```python block on its own (a fresh
namespace) and every ```pycon block as a doctest, so the numbers it shows are the ones the
code prints. A block whose first line is ``# requires: MODULE`` runs only when MODULE can
be imported."""

from __future__ import annotations

import doctest
import importlib.util
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
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS)
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
