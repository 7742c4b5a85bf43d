"""The API reference documents every public name once, under the name a user types
(``tetlap.HeatDistance``, ``tetlap.solve.eigs``), never under the module that happens to
define it (``tetlap.heat.HeatDistance``, ``tetlap.calculus.gradient``); and the user guide
and the gallery hold what the site's pages link to.

A public name is one in the ``__all__`` of a public module (walked from the package, less
the implementation modules listed in ``INTERNAL``). Its documented path is the shortest:
the first package on the way from ``tetlap`` to its module that exports the same object
under the same name (``tetlap.solve.SolveError`` is ``tetlap.SolveError``). The reference
is read from the directives of ``docs/api/*.rst`` (``autofunction``, ``autoclass``,
``autodata``, ``autoexception``, ``automodule``), so these tests need no Sphinx build.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pathlib
import pkgutil
import re
import sys
import types

import pytest

import tetlap

ROOT = pathlib.Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: Public modules whose names are not API of their own, each with why.
INTERNAL = {
    "tetlap.properties": "the deprecated alias of tetlap.analysis",
    "tetlap.benchmark": "the implementation of `tetlap bench`",
    "tetlap.benchmark_solve": "the implementation of `tetlap bench --solve`",
    "tetlap.cli.*": "one module per command: the commands' help is in the reference",
    "tetlap.experiments.*": "one module per experiment: tetlap.experiments runs them",
    "tetlap.regular.*": "the steps of tetlap.regular_weights",
    "tetlap.solve.*": "the solver layer behind tetlap.solve",
}
DIRECTIVE = re.compile(r"^\.\. (auto(?:function|class|data|exception|module))::\s+(\S+)",
                       re.MULTILINE)
#: An automodule with its members, which autodoc documents under the module's path.
MODULE_MEMBERS = re.compile(r"^\.\. automodule::\s+(\S+)\n(?:[ \t]+:[\w-]+:.*\n)*?"
                            r"[ \t]+:(?:members|imported-members|undoc-members):",
                            re.MULTILINE)


def internal(name: str) -> bool:
    return name in INTERNAL or any(
        key.endswith(".*") and name.startswith(key[:-1]) for key in INTERNAL)


def api_modules() -> list[str]:
    names = ["tetlap"]
    for info in pkgutil.walk_packages(tetlap.__path__, prefix="tetlap."):
        parts = info.name.split(".")[1:]
        if (info.name != "tetlap.__main__" and not any(p.startswith("_") for p in parts)
                and not internal(info.name)):
            names.append(info.name)
    return sorted(names)


def exported(name: str) -> list[str]:
    """``__all__`` of module ``name``, read from its source when it cannot be imported (an
    adapter whose framework is not installed)."""
    spec = importlib.util.find_spec(name)
    try:
        return list(importlib.import_module(name).__all__)
    except ImportError:
        tree = ast.parse(pathlib.Path(spec.origin).read_text())
        (node,) = [n for n in tree.body if isinstance(n, ast.Assign)
                   and any(getattr(t, "id", None) == "__all__" for t in n.targets)]
        return list(ast.literal_eval(node.value))


def canonical(module: str, name: str) -> str:
    """The documented path of ``module.name``: the shortest package path on the way to
    ``module`` that exports the same object as ``name``."""
    try:
        obj = getattr(importlib.import_module(module), name)
    except ImportError:
        return f"{module}.{name}"
    parts = module.split(".")
    for k in range(1, len(parts)):
        package = importlib.import_module(".".join(parts[:k]))
        if name in package.__all__ and getattr(package, name) is obj:
            return f"{package.__name__}.{name}"
    return f"{module}.{name}"


def public_names() -> dict[str, str]:
    """{documented path: "module" or "object"} of every public name (a module: a public
    submodule its package exports, such as ``tetlap.solve``)."""
    names = {}
    for module in api_modules():
        for name in exported(module):
            path = canonical(module, name)
            is_module = (importlib.util.find_spec(module) and path == f"{module}.{name}"
                         and isinstance(getattr(importlib.import_module(module), name, None)
                                        if module != "tetlap.torch" else None,
                                        types.ModuleType))
            names.setdefault(path, "module" if is_module else "object")
    return names


def documented() -> dict[str, tuple[str, str]]:
    """{target: (directive, page)} of every autodoc directive of the reference."""
    found: dict[str, tuple[str, str]] = {}
    for page in sorted((DOCS / "api").glob("*.rst")):
        for directive, target in DIRECTIVE.findall(page.read_text()):
            assert target not in found, f"{target} documented twice ({page.name}, {found[target][1]})"
            found[target] = (directive, page.name)
    return found


def test_the_public_names_include_the_examples():
    names = public_names()
    assert {"tetlap.HeatDistance", "tetlap.gradient", "tetlap.solve.eigs", "tetlap.io.read",
            "tetlap.SolveError", "tetlap.fields.RANGE_RTOL", "tetlap.torch.laplacian",
            "tetlap.solve"} <= set(names)
    assert not {"tetlap.heat.HeatDistance", "tetlap.calculus.gradient",
                "tetlap.solve.SolveError", "tetlap.regular.regular_weights"} & set(names)
    assert names["tetlap.solve"] == "module" and names["tetlap.laplacian"] == "object"


def test_every_public_name_is_in_the_reference():
    missing = sorted(set(public_names()) - set(documented()))
    assert not missing, f"public names missing from docs/api/*.rst: {missing}"


def test_the_reference_documents_names_where_users_type_them():
    names = public_names()
    for page in sorted((DOCS / "api").glob("*.rst")):
        listed = MODULE_MEMBERS.findall(page.read_text())
        assert not listed, f"{page.name}: automodule {listed} with members (name each instead)"
    for target, (directive, page) in documented().items():
        assert not any(p.startswith("_") for p in target.split(".")), (target, page)
        if directive == "automodule":
            assert target in api_modules(), f"{page}: {target} is no public module"
            continue
        module, _, name = target.rpartition(".")
        assert not internal(module), f"{page}: {target} is in an implementation module"
        path = canonical(module, name)
        assert path == target, f"{page}: {target} is documented under a private path: {path}"
        assert target in names, f"{page}: {target} is not in its module's __all__"


def test_a_private_path_is_caught():
    """The check above, on the paths of the old reference."""
    assert canonical("tetlap.heat", "HeatDistance") == "tetlap.HeatDistance"
    assert canonical("tetlap.calculus", "gradient") == "tetlap.gradient"
    assert canonical("tetlap.solve", "SolveError") == "tetlap.SolveError"
    assert canonical("tetlap.calculus", "element_gradients") == "tetlap.calculus.element_gradients"


# ---- the guide and the gallery ------------------------------------------------------------

#: The jobs of the user guide, one page each.
JOBS = ["getting-started", "which-operator", "solving", "eigenmodes", "fields",
        "finite-volumes", "media", "derivatives", "accuracy", "scale", "cli"]
#: A page named in plain text, which the HTML documentation cannot follow: a docstring
#: points at a page of the site with ``:doc:`` instead.
PLAIN_POINTER = re.compile(r"README|BENCHMARKS\.md|SCALING\.md|EXPERIMENTS\.md|CHANGELOG")
DOC_ROLE = re.compile(r":doc:`(?:[^`<]*<)?([^`>]+)>?`")
ROLE = re.compile(r"\{(doc|func|class|mod|data)\}`(?:[^`<]*<)?([^`>]+)>?`")


def test_the_guide_has_a_page_per_job_in_its_table_of_contents():
    index = (DOCS / "guide" / "index.md").read_text()
    toc = index.split("```{toctree}")[1].split("```")[0].splitlines()
    assert [t for t in toc if t and not t.startswith(":")] == JOBS
    for job in JOBS:
        text = (DOCS / "guide" / f"{job}.md").read_text()
        assert text.startswith("# ") and len(text.split("\n\n")) >= 2, job
        assert "TODO" not in text, job
        assert "{doc}`../api/" in text or "{func}`" in text, f"{job}: no link to the API"


@pytest.mark.parametrize("page", sorted(DOCS.glob("*.md")) + sorted(DOCS.glob("*/*.md"))
                         + sorted(DOCS.glob("*/*.rst")),
                         ids=lambda p: str(p.relative_to(DOCS)))
def test_every_link_of_a_page_resolves(page):
    """``{doc}`` links name a page or a gallery example; ``{func}``, ``{class}``, ``{mod}``
    name an entry of the reference; no page names a file (README, SCALING.md) in plain
    text where a page of the site is meant (an included file is the page)."""
    text = "\n".join(line for line in page.read_text().splitlines()
                     if not line.startswith("```{include}"))
    assert not PLAIN_POINTER.findall(text), f"{page.name}: a file named where a page is meant"
    reference = documented()
    examples = {p.stem for p in (ROOT / "examples").glob("plot_*.py")}
    for role, target in ROLE.findall(page.read_text()):
        if role == "doc":
            path = (page.parent / target).resolve().relative_to(DOCS.resolve())
            if path.parts[0] == "gallery":
                assert path.name in examples | {"index"}, (page.name, target)
            else:
                assert any((DOCS / path).with_suffix(s).is_file() for s in (".md", ".rst")), (
                    page.name, target)
        else:
            assert target in reference, f"{page.name}: {target} is not in the reference"


def test_every_example_has_a_title_a_paragraph_and_one_figure():
    scripts = sorted((ROOT / "examples").glob("plot_*.py"))
    assert {s.stem for s in scripts} >= {"plot_eigenmodes", "plot_geodesic_distance",
                                          "plot_harmonic", "plot_dual_cells",
                                          "plot_negative_weights"}
    for script in scripts:
        source = script.read_text()
        doc = ast.get_docstring(ast.parse(source))
        title, underline, *rest = doc.splitlines()
        assert set(underline) == {"="} and len(underline) == len(title), script.name
        assert len(" ".join(rest).split()) >= 30, f"{script.name}: say what it shows and why"
        assert source.count("plt.show()") == 1, script.name
        assert "tetlap." in source and len(source.splitlines()) < 100, script.name


# ---- the docstrings' pointers ---------------------------------------------------------------



def rendered_docstrings() -> dict[str, str]:
    """{path: text} of what the reference renders: each documented object's docstring and
    its public members', the ``#:`` comments of documented constants, modules' docstrings."""
    import inspect

    texts = {}
    for target, (directive, _) in documented().items():
        if directive == "automodule":
            spec = importlib.util.find_spec(target)
            texts[target] = ast.get_docstring(ast.parse(pathlib.Path(spec.origin).read_text()))
            continue
        module, _, name = target.rpartition(".")
        try:
            obj = getattr(importlib.import_module(module), name)
        except ImportError:                      # an adapter whose framework is missing
            continue
        if directive == "autodata":                # the comment where it is defined
            owners = [m for n, m in sorted(sys.modules.items()) if n.startswith("tetlap")
                      and getattr(m, "__file__", "").endswith(".py")
                      and getattr(m, name, None) is obj]
            comments = [re.search(rf"((?:^#:.*\n)+){name}\s*[:=]",
                                  pathlib.Path(m.__file__).read_text(), re.MULTILINE)
                        for m in owners]
            texts[target] = "".join(c.group(1) for c in comments if c)
            continue
        texts[target] = inspect.getdoc(obj) or ""
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                if not member.startswith("_") and getattr(value, "__doc__", None):
                    texts[f"{target}.{member}"] = inspect.getdoc(value) or ""
    return texts


def test_every_pointer_of_a_docstring_resolves_to_a_page():
    texts = rendered_docstrings()
    assert "tetlap.solve.dirichlet" in texts and "tetlap.HeatDistance.distance" in texts
    for path, text in texts.items():
        plain = PLAIN_POINTER.findall(DOC_ROLE.sub("", text or ""))
        assert not plain, f"{path} names {plain} in plain text: point at the page with :doc:"
        for page in DOC_ROLE.findall(text or ""):
            assert page.startswith("/"), f"{path}: :doc:`{page}` must be absolute"
            assert any((DOCS / page[1:]).with_suffix(s).is_file() for s in (".md", ".rst")), (
                f"{path}: :doc:`{page}` names no page of docs/")
