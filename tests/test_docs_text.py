"""User-facing text speaks of the library, not of its history: no issue or pull-request
number and no commit hash in the README, the documentation's pages, EXPERIMENTS.md,
SCALING.md, the gallery, the experiments' summaries, the package's docstrings, messages,
``#:`` comments and the help of every command. CHANGELOG.md and BENCHMARKS.md (a record
of measurements) may cite them; links to third parties' issues are references, and URLs
are left out of the search."""

from __future__ import annotations

import argparse
import ast
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
#: Pages that keep the project's history on purpose.
HISTORY = {"CHANGELOG.md", "BENCHMARKS.md"}
URL = re.compile(r"\bhttps?://\S+|\]\([^)]*\)")
HISTORY_REFERENCES = [
    ("an issue or pull request number",
     re.compile(r"\b(?:issues?|pull requests?|PRs?|tickets?)\s*#?\d+", re.IGNORECASE)),
    ("a #number", re.compile(r"(?<![\w&#/])#\d+\b")),
    ("a commit hash", re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b")),
]


def offences(text: str) -> list[str]:
    """What in ``text`` names an issue, a pull request or a commit (URLs left out)."""
    text = " ".join(URL.sub(" ", text).split())
    found = []
    for what, pattern in HISTORY_REFERENCES:
        for m in pattern.finditer(text):
            found.append(f"{what}: ...{text[max(0, m.start() - 40):m.end() + 20]}...")
    return found


def pages() -> list[pathlib.Path]:
    found = [ROOT / name for name in ("README.md", "EXPERIMENTS.md", "SCALING.md")]
    for pattern in ("docs/**/*.md", "docs/**/*.rst", "docs/**/*.txt", "docs/**/*.py",
                    "examples/*.py", "examples/*.txt"):
        found += ROOT.glob(pattern)
    generated = ("docs/gallery/", "docs/api/backreferences/", "docs/_build/")
    return sorted(p for p in found if not str(p.relative_to(ROOT)).startswith(generated)
                  and p.name not in HISTORY)


def package_text(path: pathlib.Path) -> str:
    """The user-facing text of a module: every string constant (docstrings, messages,
    help, titles) and every ``#:`` documentation comment, not code comments."""
    source = path.read_text()
    strings = [node.value for node in ast.walk(ast.parse(source))
               if isinstance(node, ast.Constant) and isinstance(node.value, str)]
    comments = [line.strip()[2:] for line in source.splitlines() if line.strip().startswith("#:")]
    return "\n".join(strings + comments)


def test_the_search_finds_what_it_looks_for():
    assert offences("beyond the paper, issue 29)")
    assert offences("(issues 37, 35)") and offences("see #12") and offences("PR 4")
    assert offences("measured with commit 741b80f: weights")
    assert offences("Before the layer (issue\n  28), eigs")
    assert not offences("see https://github.com/scipy/scipy/issues/12345 and [x](y#12)")
    assert not offences("a 1,044 masses, 2.6e-13, cube(16), 0.5854101966249685, deadbeef")
    assert {p.name for p in pages()} >= {"README.md", "EXPERIMENTS.md", "SCALING.md",
                                        "index.md", "conventions.rst", "summary.txt"}
    assert not {p.name for p in pages()} & HISTORY


@pytest.mark.parametrize("path", pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_pages_name_no_issue_and_no_commit(path):
    assert not offences(path.read_text()), offences(path.read_text())


@pytest.mark.parametrize("path", sorted((ROOT / "python" / "tetlap").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(ROOT / "python")))
def test_the_package_text_names_no_issue_and_no_commit(path):
    found = offences(package_text(path))
    assert not found, found


def test_the_help_of_every_command_names_no_issue_and_no_commit():
    from tetlap import cli

    parser = cli.parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    helps = [parser.format_help()] + [p.format_help() for p in sub.choices.values()]
    assert len(helps) >= 8 and any("heat-distance" in h for h in helps)
    for text in helps:
        assert not offences(text), offences(text)
