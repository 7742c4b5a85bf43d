"""Every numeric keyword of the public API is checked (issue 30, item 3): one table of
(call, keyword, bad values) walked by one test, and a check that the table covers every
numeric keyword the signatures show, so that a new keyword without a check fails here."""

from __future__ import annotations

import importlib
import inspect
import math
import numbers

import numpy as np
import pytest

import tetlap
from tetlap import diagnostics as dg
from tetlap import solve

NAN, INF = math.nan, math.inf
#: What no number keyword takes.
ANY = [NAN, INF, -INF, True, "1", [1]]
POSITIVE = ANY + [0, 0.0, -1.0]                  # finite > 0
NON_NEGATIVE = ANY + [-1e-300, -1.0]             # finite >= 0
TOLERANCE = ANY + [-1e-3, 1.0, 2.5]              # relative, in [0, 1)
COUNT = ANY + [0, -1, 1.5, 2.0]                  # integer >= 1
INDEX = ANY + [-1, 1.5, 2.0]                     # integer >= 0
FINITE = ANY[:3] + [True, "1", [1]]              # any finite real

V, T = tetlap.meshes.cube(2)
L = tetlap.laplacian(V, T)
M = tetlap.mass(V, T)
G = -solve.fem_boundary_areas(V, T, [1.0, 0.0, 0.0])

#: (name, keyword, call taking the keyword's value, bad values).
TABLE = [
    ("tetlap.regular_weights", "target_margin",
     lambda x: tetlap.regular_weights(V, T, target_margin=x), POSITIVE),
    ("tetlap.regular_weights", "mass_floor",
     lambda x: tetlap.regular_weights(V, T, mass_floor=x), TOLERANCE),
    ("tetlap.regular_weights", "max_weight",
     lambda x: tetlap.regular_weights(V, T, max_weight=x), POSITIVE),
    ("tetlap.regular_weights", "max_iterations",
     lambda x: tetlap.regular_weights(V, T, max_iterations=x), COUNT),
    ("tetlap.regular_weights", "time_limit",
     lambda x: tetlap.regular_weights(V, T, time_limit=x), POSITIVE),
    ("tetlap.regular_weights", "threads",
     lambda x: tetlap.regular_weights(V, T, threads=x), COUNT),
    ("tetlap.harmonic", "k", lambda x: tetlap.harmonic(V, T, [0, 1], [0.0, 1.0], k=x), COUNT),
    ("tetlap.HeatDistance", "t", lambda x: tetlap.HeatDistance(V, T, t=x), POSITIVE),
    ("tetlap.check", "negative_tol", lambda x: tetlap.check(L, V, T, negative_tol=x), TOLERANCE),
    ("tetlap.diagnostics.degenerate_tets", "rtol", lambda x: dg.degenerate_tets(V, T, rtol=x),
     TOLERANCE),
    ("tetlap.diagnostics.non_delaunay_faces", "rtol",
     lambda x: dg.non_delaunay_faces(V, T, rtol=x), TOLERANCE),
    ("tetlap.diagnostics.non_delaunay_tets", "rtol",
     lambda x: dg.non_delaunay_tets(V, T, rtol=x), TOLERANCE),
    ("tetlap.diagnostics.summary", "rtol", lambda x: dg.summary(V, T, rtol=x), TOLERANCE),
    ("tetlap.diagnostics.boundary_vertices", "n", lambda x: dg.boundary_vertices(T, n=x),
     INDEX + [len(V) - 1]),
    ("tetlap.diagnostics.interior_vertices", "n", lambda x: dg.interior_vertices(T, n=x),
     INDEX + [len(V) - 1]),
    ("tetlap.diagnostics.referenced_vertices", "n", lambda x: dg.referenced_vertices(T, n=x),
     INDEX + [len(V) - 1]),
    ("tetlap.solve.neumann", "rtol", lambda x: solve.neumann(L, G, rtol=x), TOLERANCE),
    ("tetlap.solve.eigs", "k", lambda x: solve.eigs(L, M, x), COUNT + [len(V)]),
    ("tetlap.solve.eigs", "sigma", lambda x: solve.eigs(L, M, 3, sigma=x), FINITE),
    ("tetlap.info.report", "regular_time_limit",
     lambda x: tetlap.info.report(V, T, regular_time_limit=x), POSITIVE),
    ("tetlap.info.regular_summary", "time_limit",
     lambda x: tetlap.info.regular_summary(V, T, time_limit=x), POSITIVE),
    ("tetlap.improve.improve", "margin", lambda x: tetlap.improve.improve(V, T, margin=x),
     NON_NEGATIVE),
    ("tetlap.improve.improve", "barrier", lambda x: tetlap.improve.improve(V, T, barrier=x),
     NON_NEGATIVE + [1e13, 1e300]),     # beyond MAX_WEIGHT the objective overflowed
    ("tetlap.improve.improve", "regularization",
     lambda x: tetlap.improve.improve(V, T, regularization=x), NON_NEGATIVE + [1e13, 1e300]),
    ("tetlap.improve.improve", "step", lambda x: tetlap.improve.improve(V, T, step=x), POSITIVE),
    ("tetlap.improve.improve", "max_iterations",
     lambda x: tetlap.improve.improve(V, T, max_iterations=x), COUNT),
    ("tetlap.experiments.run", "seed",
     lambda x: tetlap.experiments.run("flips", seed=x, out="/nonexistent"), INDEX),
    ("tetlap.benchmark.delaunay", "seed", lambda x: tetlap.benchmark.delaunay(100, seed=x),
     INDEX),
    ("tetlap.benchmark.shuffled", "seed", lambda x: tetlap.benchmark.shuffled(V, T, seed=x),
     INDEX),
    ("tetlap.benchmark.time_mesh", "repeat",
     lambda x: tetlap.benchmark.time_mesh("m", V, T, repeat=x), COUNT),
    ("tetlap.benchmark.run", "repeat", lambda x: tetlap.benchmark.run(repeat=x), COUNT),
    ("tetlap.benchmark_solve.run", "cap", lambda x: tetlap.benchmark_solve.run(cap=x), POSITIVE),
    ("tetlap.distributed.dirichlet", "rtol",
     lambda x: tetlap.distributed.dirichlet(None, [0], 0.0, rtol=x), TOLERANCE),
    ("tetlap.distributed.eigs", "k", lambda x: tetlap.distributed.eigs(None, None, k=x), COUNT),
    ("tetlap.distributed.eigs", "sigma",
     lambda x: tetlap.distributed.eigs(None, None, sigma=x), FINITE),
    ("tetlap.distributed.to_scipy", "root", lambda x: tetlap.distributed.to_scipy(None, root=x),
     INDEX),
]

#: Numeric keywords that are not checked here, and why.
EXEMPT = {
    # the mesh generators' arguments: checked on their own (tests/test_meshes.py)
    **{(f"tetlap.meshes.{f}", k): "generator" for f, k in [
        ("cube", "k"), ("cube", "jitter"), ("cube", "seed"), ("ball", "n"), ("ball", "seed"),
        ("shell", "n"), ("shell", "seed"), ("shell", "weight_scale"), ("sphere3", "n"),
        ("sphere3", "seed"), ("optimized_ball", "h"), ("optimized_ball", "seed"),
        ("optimized_shell", "h"), ("optimized_shell", "seed"), ("weighted_ball", "n"),
        ("weighted_ball", "weight_scale"), ("weighted_ball", "seed")]},
    # results, not options: the fields of the dataclasses a function returns
    ("tetlap.RegularWeights", "iterations"): "result",
    ("tetlap.RegularWeights", "lp_count"): "result",
    ("tetlap.RegularWeights", "mass_rounds"): "result",
    ("tetlap.RegularWeights", "n_masses_nonpositive_plain"): "result",
    ("tetlap.Report", "negative_tol"): "result",
    ("tetlap.solve.SolveInfo", "residual"): "result",
}

#: The modules whose public callables (and their classes' methods) are walked.
MODULES = ["tetlap", "tetlap.assembly", "tetlap.derivatives", "tetlap.regular", "tetlap.mesh",
           "tetlap.calculus", "tetlap.heat", "tetlap.fields", "tetlap.analysis",
           "tetlap.diagnostics", "tetlap.solve", "tetlap.io", "tetlap.info", "tetlap.improve",
           "tetlap.experiments", "tetlap.meshes", "tetlap.benchmark", "tetlap.benchmark_solve",
           "tetlap.distributed", "tetlap.jax"]


def _numeric(default) -> bool:
    return isinstance(default, numbers.Real) and not isinstance(default, bool)


def numeric_keywords() -> set[tuple[str, str]]:
    """(owner, keyword) of every parameter of a public callable whose default is a number."""
    found, seen = set(), set()
    for name in MODULES:
        module = importlib.import_module(name)
        for attr in getattr(module, "__all__", ()):
            obj = getattr(module, attr)
            if inspect.ismodule(obj) or id(obj) in seen:
                continue
            seen.add(id(obj))
            owner = f"{name}.{attr}"
            callables = [(owner, obj)]
            if inspect.isclass(obj):
                callables += [(f"{owner}.{a}", f) for a, f in vars(obj).items()
                              if not a.startswith("_") and inspect.isfunction(f)]
            for where, f in callables:
                try:
                    parameters = inspect.signature(f).parameters.values()
                except (TypeError, ValueError):
                    continue
                found |= {(where, p.name) for p in parameters if _numeric(p.default)}
    return found


def test_the_table_covers_every_numeric_keyword():
    listed = {(name, keyword) for name, keyword, _, _ in TABLE}
    missing = numeric_keywords() - listed - set(EXEMPT)
    assert not missing, f"numeric keywords without a check in TABLE: {sorted(missing)}"


@pytest.mark.parametrize("name, keyword, call, bad",
                         [pytest.param(*row, id=f"{row[0]}({row[1]}=)") for row in TABLE])
def test_every_numeric_keyword_rejects_bad_values(name, keyword, call, bad):
    for value in bad:
        with pytest.raises(tetlap.OptionError, match=keyword):
            call(value)


@pytest.mark.parametrize("helper, good", [
    ("positive", [1e-300, 1, 2.5, np.float32(3), np.int64(2)]),
    ("non_negative", [0, 0.0, 1e300, np.float64(0.5)]),
    ("tolerance", [0, 0.0, 1e-12, 0.999, np.float64(0.5)]),
    ("finite", [0, -1e300, 1e300, np.float64(-2)]),
])
def test_the_helpers_keep_good_values(helper, good):
    from tetlap import _options

    for value in good:
        assert getattr(_options, helper)(value, "x") == value
