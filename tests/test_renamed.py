"""The three ``boundary=`` keywords, each under its own name: ``boundary_centres`` (the
operators: the dual's centres in tets with a boundary face), ``boundary_condition`` (the
heat step of HeatDistance) and ``boundary_weights`` (regular_weights). The old names keep
working through one helper (``tetlap._options.renamed``), with a DeprecationWarning that
names the new one and points at the caller's line; both names at once are a TypeError."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap

V, T = tetlap.meshes.cube(2, jitter=0.1, seed=1)
F = V[:, 0] ** 2
FIXED = tetlap.diagnostics.boundary_vertices(V, T)


def same(a, b) -> bool:
    """Equal results of any of the calls below (arrays, sparse, tuples, NamedTuples)."""
    if isinstance(a, tetlap.HeatDistance):
        return np.array_equal(a.distance(0), b.distance(0))
    if isinstance(a, tetlap.Mesh):
        return (a.laplacian("dual") != b.laplacian("dual")).nnz == 0
    if sp.issparse(a):
        return (a != b).nnz == 0
    if hasattr(a, "field"):
        return np.array_equal(a.field, b.field)
    if hasattr(a, "weights") and hasattr(a, "status"):
        return np.array_equal(a.weights, b.weights)
    if isinstance(a, tuple):
        return all(same(x, y) for x, y in zip(a, b))
    if hasattr(a, "todense") or hasattr(a, "to_dense"):
        return np.array_equal(np.asarray(a.todense() if hasattr(a, "todense") else a.to_dense()),
                              np.asarray(b.todense() if hasattr(b, "todense") else b.to_dense()))
    if a is None or isinstance(a, float):
        return a == b
    return np.array_equal(np.asarray(a), np.asarray(b))


#: ``(name, call(**keyword), old name, new name, a value)`` for every renamed keyword.
CASES = [
    ("laplacian", lambda **k: tetlap.laplacian(V, T, "dual", **k), "boundary",
     "boundary_centres", "barycentric"),
    ("mass", lambda **k: tetlap.mass(V, T, "circumcentric", **k), "boundary",
     "boundary_centres", "barycentric"),
    ("operators", lambda **k: tetlap.operators(V, T, "dual", "circumcentric", **k),
     "boundary", "boundary_centres", "barycentric"),
    ("triplets", lambda **k: tetlap.triplets(V, T, "dual", **k), "boundary",
     "boundary_centres", "barycentric"),
    ("edge_weights", lambda **k: tetlap.edge_weights(V, T, "dual", **k), "boundary",
     "boundary_centres", "barycentric"),
    ("element_contributions", lambda **k: tetlap.element_contributions(V, T, "dual", **k),
     "boundary", "boundary_centres", "barycentric"),
    ("Mesh", lambda **k: tetlap.Mesh(V, T, **k), "boundary", "boundary_centres",
     "barycentric"),
    # the derivatives take the circumcentric boundary only (the barycentric one is not
    # differentiated, and refused where nothing would use it)
    ("vjp", lambda **k: tetlap.vjp(V, T, "dual", dL=sp.eye_array(len(V)), **k).dV,
     "boundary", "boundary_centres", "circumcentric"),
    ("dirichlet_energy", lambda **k: tetlap.dirichlet_energy(V, T, F, "dual", **k),
     "boundary", "boundary_centres", "circumcentric"),
    ("mass_energy", lambda **k: tetlap.mass_energy(V, T, F, "circumcentric", **k), "boundary",
     "boundary_centres", "circumcentric"),
    ("HeatDistance", lambda **k: tetlap.HeatDistance(V, T, **k), "boundary",
     "boundary_condition", "average"),
    ("HeatDistance", lambda **k: tetlap.HeatDistance(V, T, laplacian="dual", **k),
     "dual_boundary", "boundary_centres", "barycentric"),
    ("heat_distance", lambda **k: tetlap.heat_distance(V, T, 0, **k), "boundary",
     "boundary_condition", "dirichlet"),
    ("heat_distance", lambda **k: tetlap.heat_distance(V, T, 0, laplacian="dual", **k),
     "dual_boundary", "boundary_centres", "barycentric"),
    ("harmonic", lambda **k: tetlap.harmonic(V, T, FIXED, V[FIXED, 0], laplacian="dual", **k),
     "dual_boundary",
     "boundary_centres", "barycentric"),
    ("regular_weights", lambda **k: tetlap.regular_weights(V, T, **k), "boundary",
     "boundary_weights", "zero"),
]


def adapter_cases(module_name: str):
    module = pytest.importorskip(f"tetlap.{module_name}")
    kinds = {"operators": "dual", "edge_weights": "dual", "mass": "circumcentric",
             "laplacian": "dual"}
    return [
        (name, lambda name=name, **k: getattr(module, name)(V, T, kinds[name], **k),
         "boundary", "boundary_centres", "barycentric")
        for name in kinds]


def check(name, call, old, new, value):
    expected = call(**{new: value})
    with pytest.warns(DeprecationWarning) as caught:
        got = call(**{old: value})
    (warning,) = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert str(warning.message) == (f"{name}(): the keyword {old}= is deprecated, use {new}= "
                                    "(it takes the same values)")
    assert warning.filename == __file__         # the caller's line, not tetlap's
    assert same(got, expected), name
    with pytest.raises(TypeError, match=f"got both {old}= .deprecated. and {new}="):
        call(**{old: value, new: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # the new name: no warning
        call(**{new: value})


@pytest.mark.parametrize("name, call, old, new, value", CASES,
                         ids=[f"{c[0]}-{c[2]}" for c in CASES])
def test_every_old_name_warns_and_does_what_the_new_one_does(name, call, old, new, value):
    check(name, call, old, new, value)


@pytest.mark.parametrize("module_name", ["jax", "torch"])
def test_the_adapters_take_the_new_name_too(module_name):
    if module_name == "jax":
        pytest.importorskip("jax")
    else:
        pytest.importorskip("torch")
    for case in adapter_cases(module_name):
        check(*case)


def test_no_public_function_takes_a_bare_boundary_keyword_any_more():
    """The ambiguity cannot come back: no parameter of the public API is called
    ``boundary`` or ``dual_boundary`` (the old names live in ``renamed`` only)."""
    found = []
    names = ["tetlap"] + [f"tetlap.{m.name}" for m in pkgutil.iter_modules(tetlap.__path__)
                          if not m.name.startswith("_") and m.name not in ("jax", "torch")]
    for module_name in names:
        module = importlib.import_module(module_name)
        for attribute in dir(module):
            if attribute.startswith("_"):
                continue
            obj = getattr(module, attribute)
            target = obj.__init__ if inspect.isclass(obj) else obj
            if not callable(target):
                continue
            try:
                parameters = inspect.signature(target).parameters
            except (TypeError, ValueError):
                continue
            found += [f"{module_name}.{attribute}({p})" for p in parameters
                      if p in ("boundary", "dual_boundary")]
    assert found == []
