"""The examples in the docstrings of the installed package run and print what they show.

Every module of ``tetlap`` (found by walking the installed package, so that a new module
with examples is picked up) is run through :mod:`doctest` with NumPy's current printing
(``legacy=False``) and ``NORMALIZE_WHITESPACE | ELLIPSIS``, one test per docstring.
Examples that need a file are marked ``# doctest: +SKIP`` in the docstring; a docstring
whose examples use an optional package (PyVista) is skipped, with the package's name,
where it is not installed (``pip install ".[test]"`` alone).
"""

from __future__ import annotations

import doctest
import importlib
import importlib.util
import pkgutil

import numpy as np
import pytest

import tetlap

FLAGS = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
#: Modules that must not be imported by the test (``python -m tetlap`` runs the command).
NOT_IMPORTED = {"tetlap.__main__"}
#: Adapters whose import needs an optional framework (skipped when it is missing).
OPTIONAL = {"tetlap.torch": "torch", "tetlap.jax": "jax"}
#: Optional packages that examples use, by the name their code mentions.
EXTRAS = ("pyvista",)
#: Modules known to have examples: discovery must find at least these.
KNOWN = {"tetlap", "tetlap.assembly", "tetlap.diagnostics", "tetlap.errors", "tetlap.info",
         "tetlap.io", "tetlap.mesh", "tetlap.meshes", "tetlap.analysis", "tetlap.solve"}


def module_names() -> list[str]:
    names = ["tetlap"]
    for info in pkgutil.walk_packages(tetlap.__path__, prefix="tetlap."):
        if info.name not in NOT_IMPORTED:
            names.append(info.name)
    return sorted(names)


def examples(name: str) -> list[doctest.DocTest]:
    if name in OPTIONAL and importlib.util.find_spec(OPTIONAL[name]) is None:
        return []
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    return [t for t in tests if t.examples]


MODULES = [name for name in module_names() if examples(name)]
DOCSTRINGS = {test.name: test for name in MODULES for test in examples(name)}


def extras(test: doctest.DocTest) -> list[str]:
    """The optional packages that the examples of ``test`` that run use."""
    code = "".join(e.source for e in test.examples if not e.options.get(doctest.SKIP))
    return [extra for extra in EXTRAS if extra in code]


def test_discovery_finds_every_module_with_examples():
    assert KNOWN <= set(MODULES), sorted(KNOWN - set(MODULES))
    pyvista = DOCSTRINGS["tetlap.io._pyvista.to_pyvista"]  # tetlap.io.to_pyvista
    assert extras(pyvista)


@pytest.fixture
def numpy_defaults():
    """NumPy's own printing defaults (another test or a user's setup may change them)."""
    saved = np.get_printoptions()
    np.set_printoptions(legacy=False, precision=8, threshold=1000, linewidth=75,
                        suppress=False, floatmode="maxprec", sign="-")
    yield
    np.set_printoptions(**saved)


@pytest.mark.parametrize("name", list(DOCSTRINGS))
def test_docstring_examples_run(name, numpy_defaults, tmp_path, monkeypatch):
    test = DOCSTRINGS[name]
    for extra in extras(test):
        pytest.importorskip(extra)
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    # the docstring sees a fresh copy of the module's globals, as doctest.testmod does
    test.globs = dict(test.globs)
    out: list[str] = []
    result = runner.run(test, out=out.append, clear_globs=True)
    assert not result.failed, f"the examples of {name} failed:\n" + "".join(out)


def test_the_io_examples_run_in_full(numpy_defaults, tmp_path, monkeypatch):
    """The io package's examples, pyvista ones included: more than 10 of them run."""
    pytest.importorskip("pyvista")
    import tetlap.io

    monkeypatch.chdir(tmp_path)
    attempted = 0
    for name in ["tetlap.io"] + [f"tetlap.io.{m.name}" for m in pkgutil.iter_modules(tetlap.io.__path__)]:
        result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
        assert result.failed == 0, name
        attempted += result.attempted
    assert attempted > 10
