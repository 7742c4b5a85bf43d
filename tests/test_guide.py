"""The user guide's pages (docs/guide/*.md) hold what they show: every ```python block runs
on its own (a fresh namespace) and every ```pycon block as a doctest, so the numbers a page
shows are the ones the code prints, as the README's are (tests/test_readme.py runs its
blocks with the same functions). A block whose first line is ``# requires: MODULE`` runs
only when MODULE can be imported. The statements around the examples that can be checked
against the library (the command summary, the experiments' names, ``tetlap info``'s table,
the bad-input table's tests) are checked here, and each piece of text has one home: no
paragraph stands in two of the README, the guide and the project's pages."""

from __future__ import annotations

import argparse
import doctest
import importlib.util
import pathlib
import re

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "guide"
BLOCK = re.compile(r"^```(python|pycon)\n(.*?)^```", re.MULTILINE | re.DOTALL)
#: The guide's table of contents: the one page without an example of its own.
WITHOUT_EXAMPLES = {"index"}


def code_blocks(path: pathlib.Path) -> list:
    """Every ```python and ```pycon block of the Markdown file ``path``, as pytest params
    (kind, code, path) with the block's line as its id."""
    text = path.read_text()
    found = []
    for match in BLOCK.finditer(text):
        line = text[:match.start()].count("\n") + 1
        found.append(pytest.param(match.group(1), match.group(2), path,
                                  id=f"{path.name}:{line}"))
    return found


def run_block(kind: str, code: str, path: pathlib.Path) -> None:
    """Runs one block as written: a script in a fresh namespace, or a doctest with NumPy's
    own printing and ``...`` for elided output."""
    first = code.splitlines()[0]
    if first.startswith("# requires:"):
        module = first.split(":", 1)[1].strip()
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"needs {module}")
    if kind == "python":
        exec(compile(code, str(path), "exec"), {})
        return
    saved = np.get_printoptions()
    np.set_printoptions(legacy=False)
    try:
        test = doctest.DocTestParser().get_doctest(code, {}, path.name, str(path), 0)
        runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)  # the output as printed
        out: list[str] = []
        runner.run(test, out=out.append)
    finally:
        np.set_printoptions(**saved)
    assert runner.failures == 0, "".join(out)


def pages() -> list[pathlib.Path]:
    return sorted(GUIDE.glob("*.md"))


def guide_blocks() -> list:
    return [block for page in pages() for block in code_blocks(page)]


def test_every_page_of_a_job_has_examples():
    with_blocks = {p.values[2].stem for p in guide_blocks()}
    without = {page.stem for page in pages()} - with_blocks
    assert without <= WITHOUT_EXAMPLES, f"pages without a runnable example: {sorted(without)}"
    assert len(guide_blocks()) >= 12


@pytest.mark.parametrize("kind, code, path", guide_blocks())
def test_guide_block_runs_as_written(kind, code, path, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)                 # a block that writes files writes them here
    run_block(kind, code, path)


def test_a_wrong_output_fails_the_block():
    """The runner compares what the code prints: a block that shows another number fails."""
    with pytest.raises(AssertionError, match="Expected"):
        run_block("pycon", ">>> 1 + 1\n3\n", GUIDE / "index.md")
    with pytest.raises(ZeroDivisionError):
        run_block("python", "1 / 0\n", GUIDE / "index.md")


# ---- the statements around the examples, as written -----------------------------------


def page(name: str) -> str:
    return (GUIDE / f"{name}.md").read_text()


def test_the_command_summary_lists_every_flag_and_no_other():
    """Each ``tetlap COMMAND`` line of the command line's summary names exactly the
    command's flags."""
    from tetlap import cli

    block = page("cli").split("```sh\n")[1].split("```")[0]
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

    text = " ".join(page("cli").split())
    named = re.search(r"`experiment` runs one of (.*?) and writes", text).group(1)
    assert re.findall(r"`([\w-]+)`", named) == list(experiments.NAMES)


def test_the_info_table_is_what_tetlap_info_prints(capsys):
    """"Which operator?" shows part of ``tetlap info`` on the built-in ball: every line of
    it is a line of the real output."""
    from tetlap import cli

    (table,) = re.findall(r"^```\n(property .*?)^```", page("which-operator"),
                          re.MULTILINE | re.DOTALL)
    shown = table.splitlines()
    assert len(shown) >= 8
    assert cli.main(["info", "--no-regular"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert all(line in printed for line in shown), (shown, printed)


def test_the_bad_input_table_cites_tests_that_exist():
    """Every ``[test_x, ...]`` of the table names a test file of this suite (or a Rust
    test file), and every row cites at least one or says ``[untested: why]``."""
    text = page("accuracy")
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


# ---- one home for each piece of text ---------------------------------------------------


def prose_files() -> list[pathlib.Path]:
    """Where the project's prose lives (a page that includes a file is no copy of it)."""
    files = [ROOT / name for name in ("README.md", "EXPERIMENTS.md", "SCALING.md",
                                      "BENCHMARKS.md", "CHANGELOG.md")]
    generated = ("docs/gallery/", "docs/api/backreferences/", "docs/experiments/")
    files += [p for p in sorted((ROOT / "docs").rglob("*.md"))
              if not str(p.relative_to(ROOT)).startswith(generated)]
    return files


def paragraphs(path: pathlib.Path) -> list[str]:
    """The paragraphs of a Markdown file of at least 200 characters, whitespace collapsed:
    pieces of text long enough that two copies are a copy, not a shared phrase."""
    found = []
    for chunk in re.split(r"\n\s*\n", path.read_text()):
        text = " ".join(chunk.split())
        if len(text) >= 200:
            found.append(text)
    return found


def duplicates(files: list[pathlib.Path]) -> list[tuple[str, str, str]]:
    seen: dict[str, str] = {}
    found = []
    for path in files:
        name = str(path)
        for text in paragraphs(path):
            if text in seen and seen[text] != name:
                found.append((seen[text], name, text[:80]))
            seen.setdefault(text, name)
    return found


def test_each_paragraph_has_one_home():
    """What moved from the README to the guide was moved, not copied: no paragraph of 200
    characters or more stands in two files of the README, the guide and the project."""
    files = prose_files()
    assert {"README.md", "getting-started.md", "accuracy.md", "layout.md"} <= {
        p.name for p in files}
    assert not duplicates(files), duplicates(files)


def test_a_copied_paragraph_is_found(tmp_path):
    text = "A paragraph long enough to count as content of its own. " * 5
    (tmp_path / "a.md").write_text(f"# A\n\n{text}\n")
    (tmp_path / "b.md").write_text(f"# B\n\nother\n\n{text.replace(' ', chr(10), 3)}\n")
    assert len(duplicates([tmp_path / "a.md", tmp_path / "b.md"])) == 1
    assert not duplicates([tmp_path / "a.md"])
