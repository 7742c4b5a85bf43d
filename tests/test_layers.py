"""The layers of the Python package: every import inside ``tetlap`` points to its own layer
or a lower one, no circle of imports exists between its modules, and every module is
placed in a layer (as ``cargo test --test layers`` guards the crate's).

The imports are read from the sources with :mod:`ast`, not by importing them: those at
module level and those inside functions (the CLI's, which keep ``tetlap --help`` from
loading NumPy), relative or absolute. Only imports of ``tetlap`` itself count; lazy imports
of optional third-party packages (matplotlib, pyvista, igl, ...) are no concern here.
Importing ``tetlap.solve._amg`` from outside ``tetlap.solve`` runs ``tetlap/solve/__init__``
first, so it also counts as an import of ``tetlap.solve``. A circle is a circle wherever
its imports sit: one closed by an import inside a function is hidden, not broken.
"""

from __future__ import annotations

import ast
import pathlib

import tetlap

#: The layers from the bottom up: (what the layer is, its modules, dotted below
#: ``tetlap``; ``__init__`` is the package itself). A module imports from its own layer
#: or a lower one. A new module must be placed here. Where a module sits is decided by
#: what it does: the per-element diagnostics (boundary faces, orientation, volumes: the
#: crate's topology, below its assembly) sit with the operators that use them; turning a
#: mesh object into arrays (``_meshobj``) is part of checking the input; the mesh report
#: (``info``) and harmonic fields (``fields``) run regular weights, an application.
LAYERS = (
    ("0 foundations: errors, option and array checks, mesh objects as arrays, the float "
     "range, progress, Ctrl-C, BLAS threads, optional extras, the Rust core",
     "_core errors _names _docs _options _arrays _meshobj _float_range _sparse "
     "_progress _interrupt _blas _extras"),
    ("1 elements and operators: assembly, the dual, DEC, calculus, their derivatives, the "
     "per-element diagnostics, the built-in meshes, the Mesh object, the media's "
     "coefficients",
     "coefficient assembly dual _dual_faces dec calculus derivatives diagnostics meshes mesh"),
    ("2 what reads and solves an operator: the Table 1 check, the cell-centred operator "
     "and its report, the solvers, eigenmodes, mesh files",
     "analysis properties cells spectral "
     "solve solve._amg solve._boundary solve._checks solve._dirichlet solve._eigs "
     "solve._lanczos solve._linear solve._metis solve._neumann solve.factor solve.info "
     "io io._dual_cells io._pyvista io._read io._vtk io._write"),
    ("3 applications: geodesic distances, harmonic fields, mesh improvement, regular "
     "weights, the mesh report, MPI, the autodiff adapters, the experiments",
     "heat fields improve info distributed _adapters jax torch "
     "regular regular.conditions regular.masses regular.result regular.search "
     "regular.verify "
     "experiments experiments._corpus experiments._output experiments._plot "
     "experiments.anisotropic experiments.eigen_ball experiments.finite_volumes experiments.flips "
     "experiments.harmonic experiments.heat_distance experiments.improve "
     "experiments.negative_weights experiments.regular_weights experiments.shell "
     "experiments.sphere3"),
    ("4 the front: the command line, the benchmarks, the package's namespace",
     "__init__ __main__ benchmark benchmark_solve "
     "cli cli._mesh cli._output cli._paths cli._threads cli.assemble cli.bench "
     "cli.distributed_info cli.experiment cli.geodesic cli.improve cli.info"),
)

#: The imports of tetlap's own modules inside functions below the front layer, each with
#: its reason (the front's keep ``tetlap --help`` from loading NumPy): an import deferred
#: for no such reason would only hide where a module's dependencies lie.
LAZY = {
    ("_options", "_core"): "the CLI checks its options without loading the extension",
    ("solve.factor", "solve._metis"): "pymetis is an optional dependency",
}

LAYER = {module: i for i, (_, modules) in enumerate(LAYERS) for module in modules.split()}
PACKAGE = pathlib.Path(tetlap.__file__).resolve().parent


def modules() -> dict[str, pathlib.Path]:
    """Every module of the package (dotted below ``tetlap``) and its file."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__" and len(parts) > 1:
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def _package_of(module: str, path: pathlib.Path) -> list[str]:
    """The package a relative import of ``module`` starts from, as parts below tetlap."""
    parts = [] if module == "__init__" else module.split(".")
    return parts if path.name == "__init__.py" else parts[:-1]


def _in_function(tree: ast.AST):
    """Every import node of ``tree`` with True when it sits inside a function."""
    def walk(node, inside):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.Import | ast.ImportFrom):
                yield child, inside
            yield from walk(child, inside or isinstance(
                child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda))
    yield from walk(tree, False)


def imports(known: dict[str, pathlib.Path]):
    """Every import of a tetlap module: (importer, imported, file, line, in a function,
    why) with ``why`` empty for a direct import, else the submodule that brings in its
    package."""
    def name(parts):
        return ".".join(parts) or "__init__"

    for module, path in known.items():
        tree = ast.parse(path.read_text(), str(path))
        for node, inside in _in_function(tree):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name.split(".")[1:] for a in node.names
                           if a.name.split(".")[0] == "tetlap"]
            else:
                if node.level:
                    base = _package_of(module, path)
                    base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
                    base += node.module.split(".") if node.module else []
                elif node.module and node.module.split(".")[0] == "tetlap":
                    base = node.module.split(".")[1:]
                else:
                    continue
                for alias in node.names:
                    sub = base + [alias.name]
                    targets.append(sub if name(sub) in known or name(sub) in LAYER else base)
            for target in targets:
                yield module, name(target), path, node.lineno, inside, ""
                # importing a submodule from outside its package runs the package first
                for k in range(1, len(target)):
                    package = name(target[:k])
                    if not (module == package or module.startswith(package + ".")):
                        yield module, package, path, node.lineno, inside, name(target)


def test_every_module_is_in_a_layer():
    known = modules()
    assert {"__init__", "solve._amg", "cli.info", "analysis"} <= set(known)
    missing = sorted(set(known) - set(LAYER))
    assert not missing, f"modules in no layer (place them in LAYERS of {__file__}): {missing}"
    gone = sorted(set(LAYER) - set(known) - {"_core"})
    assert not gone, f"LAYERS names modules that do not exist: {gone}"
    assert len(LAYER) == sum(len(m.split()) for _, m in LAYERS), "a module in two layers"


def test_no_import_climbs_to_a_higher_layer():
    known = modules()
    climbs = {}
    for module, target, path, line, inside, via in imports(known):
        assert target in known or target in LAYER, f"{path}:{line} imports unknown {target}"
        if module in LAYER and target in LAYER and LAYER[target] > LAYER[module]:
            where = f"{path.relative_to(PACKAGE.parent)}:{line}"
            climbs.setdefault((where, target), f"{where}: {module} (layer {LAYER[module]}) "
                              f"imports {target} (layer {LAYER[target]})"
                              + (f", the package of {via}" if via else "")
                              + (" inside a function" if inside else ""))
    assert not climbs, f"{len(climbs)} imports climb:\n" + "\n".join(climbs.values())


def test_no_circle_of_imports():
    known = modules()
    graph: dict[str, dict[str, str]] = {m: {} for m in known}
    for module, target, path, line, inside, via in imports(known):
        if target in known and target != module:
            graph[module].setdefault(target, f"{path.relative_to(PACKAGE.parent)}:{line}"
                                     + (" (in a function)" if inside else ""))
    # Tarjan's strongly connected components; each with more than one module is a circle
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles = []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    described = []
    for component in circles:
        edges = [f"  {a} -> {b}: {graph[a][b]}" for a in component for b in component
                 if b in graph[a]]
        described.append(" <-> ".join(component) + "\n" + "\n".join(edges))
    assert not circles, "modules import each other:\n" + "\n".join(described)


def test_imports_inside_functions_below_the_front_have_a_reason():
    front = len(LAYERS) - 1
    deferred = {}
    for module, target, path, line, inside, via in imports(modules()):
        if inside and not via and LAYER.get(module, front) < front:
            deferred.setdefault((module, target), f"{path.relative_to(PACKAGE.parent)}:{line}")
    unexplained = {k: v for k, v in deferred.items() if k not in LAZY}
    assert not unexplained, ("imports inside functions with no reason in LAZY (import at "
                             f"module level, or say why not): {unexplained}")
    assert set(LAZY) <= set(deferred), f"LAZY lists what is gone: {set(LAZY) - set(deferred)}"


def test_the_walk_sees_what_it_must():
    """The walker on a few known imports, so that a reader that finds nothing cannot pass."""
    found = {(m, t, inside) for m, t, _, _, inside, _ in imports(modules())}
    assert ("assembly", "_arrays", False) in found                 # from . import _arrays
    assert ("cli.info", "info", True) in found                     # from .. import info
    assert ("solve._linear", "solve.factor", False) in found       # from .factor import Factor
    assert ("benchmark_solve", "__init__", True) in found          # import tetlap
    assert ("cli", "__init__", False) in found                     # from .. import __version__
    assert ("experiments.improve", "experiments.shell", False) in found
