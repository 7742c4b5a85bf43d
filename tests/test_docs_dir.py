"""``dir()`` of every public module of tetlap lists its public names only: its exact
``__all__`` (every name of which exists) and its dunders, not the modules and helpers it
imports for itself (``np``, ``functools``, ``annotations``), so that tab completion offers
the API and nothing else. Public modules are found by walking the package: every module
without a leading underscore in its dotted name."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import pkgutil

import pytest

import tetlap
from tetlap import _names

#: Adapters whose import needs an optional framework (skipped when it is missing).
OPTIONAL = {"tetlap.torch": "torch", "tetlap.jax": "jax"}


def public_modules() -> list[str]:
    names = []
    for info in pkgutil.walk_packages(tetlap.__path__, prefix="tetlap."):
        parts = info.name.split(".")[1:]
        if info.name != "tetlap.__main__" and not any(p.startswith("_") for p in parts):
            names.append(info.name)
    return sorted(names)


def load(name: str):
    if name in OPTIONAL and importlib.util.find_spec(OPTIONAL[name]) is None:
        pytest.skip(f"{name} needs {OPTIONAL[name]}")
    return importlib.import_module(name)


def test_the_walk_finds_the_public_modules():
    found = public_modules()
    assert {"tetlap.meshes", "tetlap.solve", "tetlap.io", "tetlap.cli", "tetlap.regular",
            "tetlap.experiments.shell", "tetlap.solve.factor"} <= set(found)
    assert not [n for n in found if "._" in n]


@pytest.mark.parametrize("name", public_modules())
def test_dir_of_a_public_module_is_its_all(name):
    module = load(name)
    assert isinstance(module.__all__, list | tuple), name
    assert len(set(module.__all__)) == len(module.__all__), f"{name}: a name twice in __all__"
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ names what it does not have: {missing}"
    listed = {n for n in dir(module) if not (n.startswith("__") and n.endswith("__"))}
    assert listed == set(module.__all__), (
        f"dir({name}) shows {sorted(listed - set(module.__all__))} beyond __all__: give the "
        "module `__dir__ = public_dir(globals())` (tetlap._names) after its __all__")
    assert "__doc__" in dir(module) and "__name__" in dir(module)


def test_the_examples_of_the_brief():
    import tetlap.meshes
    import tetlap.solve

    assert not {"np", "functools", "itertools", "annotations"} & set(dir(tetlap.meshes))
    assert "annotations" not in dir(tetlap.solve) and "eigs" in dir(tetlap.solve)
    assert "factor" not in dir(tetlap.solve)        # an implementation module of the API


def test_the_helper_reads_all_when_called():
    namespace = {"__all__": ["a"], "__name__": "m", "np": object()}
    listing = _names.public_dir(namespace)
    assert listing() == ["__all__", "__name__", "a"]
    namespace["__all__"].append("b")
    assert listing() == ["__all__", "__name__", "a", "b"]
    assert inspect.signature(listing).parameters == {}
