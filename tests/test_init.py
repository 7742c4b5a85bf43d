"""The package's lazy namespace (python/tetlap/__init__.py): ``import tetlap`` loads no
NumPy or SciPy, yet every public name and submodule is an attribute, ``from tetlap import
*`` and ``dir(tetlap)`` see them all, and type checkers see the same names."""

from __future__ import annotations

import ast
import pathlib
import pkgutil
import subprocess
import sys

import pytest

import tetlap


def test_import_tetlap_loads_neither_numpy_nor_scipy():
    code = ("import sys, tetlap\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stdout + out.stderr


def test_every_public_name_resolves_and_star_import_sees_them():
    namespace: dict = {}
    exec("from tetlap import *", namespace)
    assert set(tetlap.__all__) <= set(namespace) and len(set(tetlap.__all__)) == len(tetlap.__all__)
    assert set(tetlap.__all__) <= set(dir(tetlap))
    assert tetlap.laplacian is tetlap.assembly.laplacian and tetlap.check is tetlap.properties.check
    assert tetlap.meshes.__name__ == "tetlap.meshes" and tetlap.MAX_THREADS >= 1
    assert issubclass(tetlap.OptionError, tetlap.TetlapError)


def test_dir_lists_public_names_only():
    import tetlap.cli  # noqa: F401 - an imported public submodule is listed

    listed = set(dir(tetlap))
    assert not {"TYPE_CHECKING", "annotations", "importlib"} & listed  # issue 30
    others = {name for name in listed - set(tetlap.__all__) if not name.startswith("__")}
    assert "cli" in others and all(
        getattr(tetlap, name).__name__ == f"tetlap.{name}" for name in others), others


def test_every_submodule_is_an_attribute():
    for module in pkgutil.iter_modules(tetlap.__path__):
        if module.name in ("__main__", "jax", "torch", "distributed"):
            continue                       # a command, and optional frameworks
        assert getattr(tetlap, module.name).__name__ == f"tetlap.{module.name}"
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        tetlap.nonsense


def test_type_checkers_see_the_same_names():
    tree = ast.parse(pathlib.Path(tetlap.__file__).read_text())
    (block,) = [node for node in tree.body if isinstance(node, ast.If)
                and getattr(node.test, "id", None) == "TYPE_CHECKING"]
    names = [alias.asname or alias.name for node in block.body for alias in node.names]
    assert sorted(names) == sorted(tetlap.__all__)
