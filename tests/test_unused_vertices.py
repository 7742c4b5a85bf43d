"""A vertex in no tet takes part in no computation (issue 30, item 5): for every public
function of a mesh, the mesh plus one unused vertex, far away or tiny, gives the same
answer, bit for bit, as the mesh without it, and the unused vertex gets the documented
neutral value (an empty row, weight 0, its own position, ...)."""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import cli, solve
from tetlap import diagnostics as dg
from tetlap.cli import _mesh

#: A small mesh that is not Delaunay (the regular-weights search and improve both work).
V, T = tetlap.meshes.cube(3, jitter=0.25, seed=2)
N = len(V)
FAR = [1e100, 1e155, 1e160, 1e300, -1e300, 1e-300]
FLUX = lambda centroids, normals: normals[:, 0]  # noqa: E731
#: Report fields that count the vertices (the unused one included) or time the call.
COUNTS = {"n_vertices", "n_unreferenced_vertices", "seconds"}

#: name -> (function of (V, T), the neutral value of the unused vertex's entries, or None
#: for a result without per-vertex entries).
FUNCTIONS = {
    "laplacian dual": (lambda V, T: tetlap.laplacian(V, T, "dual"), 0.0),
    "operators primal": (lambda V, T: tetlap.operators(V, T, "primal", "mixed"), 0.0),
    "mass circumcentric": (lambda V, T: tetlap.mass(V, T, "circumcentric"), 0.0),
    "mass fem": (lambda V, T: tetlap.mass(V, T, "fem"), 0.0),
    "Mesh": (lambda V, T: tetlap.Mesh(V, T).operators("dual", "circumcentric"), 0.0),
    "vjp": (lambda V, T: tetlap.vjp(V, T, "dual", dL=tetlap.laplacian(V, T, "dual")).dV, 0.0),
    "gradient": (lambda V, T: tetlap.gradient(V, T), 0.0),
    "divergence": (lambda V, T: tetlap.divergence(V, T), 0.0),
    "heat_distance": (lambda V, T: tetlap.heat_distance(V, T, [0]), np.inf),
    "harmonic": (lambda V, T: tetlap.harmonic(V, T, [0, 5], [0.0, 1.0]).field, 0.0),
    "check": (lambda V, T: tetlap.check(tetlap.laplacian(V, T, "dual"), V, T,
                                        tetlap.mass(V, T, "circumcentric")), None),
    "summary": (lambda V, T: dg.summary(V, T), None),
    "non_delaunay_faces": (lambda V, T: dg.non_delaunay_faces(V, T), None),
    "degenerate_tets": (lambda V, T: dg.degenerate_tets(V, T), None),
    "dual_boundary_areas": (lambda V, T: solve.dual_boundary_areas(V, T, FLUX), 0.0),
    "neumann_primal_kkt": (lambda V, T: solve.neumann_primal_kkt(
        tetlap.laplacian(V, T), V, T, FLUX), 0.0),
    "regular_weights": (lambda V, T: tetlap.regular_weights(V, T), 0.0),
    "face_margins": (lambda V, T: tetlap.regular.face_margins(V, T), None),
    "improve": (lambda V, T: tetlap.improve.improve(V, T, max_iterations=5), "position"),
    "info.report": (lambda V, T: tetlap.info.report(V, T, progress=False), None),
}


def _split(value, far):
    """``value`` on the mesh with the unused vertex (index N) -> (the value without it, the
    entries of that vertex, or None)."""
    if sp.issparse(value):
        A, extra = sp.csr_array(value), None
        if N + 1 in A.shape:
            extra = 0.0                 # asserted below: no entry in its row and column
        if A.shape[0] == N + 1:
            assert A[[N]].count_nonzero() == 0, "the unused vertex's row has entries"
            A = A[:N]
        if A.shape[1] == N + 1:
            assert A[:, [N]].count_nonzero() == 0, "the unused vertex's column has entries"
            A = A[:, :N]
        return A, extra
    if isinstance(value, tuple):
        parts = [_split(v, far) for v in value]
        return tuple(p for p, _ in parts), next((e for _, e in parts if e is not None), None)
    if dataclasses.is_dataclass(value):
        fields = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
        parts = {k: _split(v, far) for k, v in fields.items() if k not in COUNTS}
        extra = next((e for _, e in parts.values() if e is not None), None)
        return {k: p for k, (p, _) in parts.items()}, extra
    if isinstance(value, dict):
        return {k: _split(v, far)[0] for k, v in value.items() if k not in COUNTS}, None
    if isinstance(value, np.ndarray) and value.ndim and len(value) == N + 1:
        return value[:N], value[N]
    return value, None


def _same(a, b, where="result"):
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif sp.issparse(a):
        a, b = sp.csr_array(a), sp.csr_array(b)
        assert a.shape == b.shape and (a != b).nnz == 0, where
    elif isinstance(a, np.ndarray):
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    else:
        assert a == b or (a != a and b != b), f"{where}: {a!r} != {b!r}"


def _without_counts(value):
    if dataclasses.is_dataclass(value):
        return {f.name: _without_counts(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.name not in COUNTS}
    if isinstance(value, dict):
        return {k: _without_counts(v) for k, v in value.items() if k not in COUNTS}
    return value


@pytest.fixture(scope="module")
def without():
    """Every function's answer on the mesh without the unused vertex (computed once)."""
    return {}


@pytest.mark.parametrize("far", FAR)
@pytest.mark.parametrize("name", list(FUNCTIONS))
def test_an_unused_vertex_changes_no_answer(name, far, without):
    f, neutral = FUNCTIONS[name]
    if name not in without:
        without[name] = f(V, T)
    V1 = np.vstack([V, [[far, -far, far]]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")                  # no NumPy warning either
        value = f(V1, T)
    if name == "improve":
        assert np.array_equal(value.V[N], V1[N]), "improve moved the unused vertex"
        value.V = value.V[:N]
    reduced, extra = _split(value, far)
    _same(_without_counts(reduced), _without_counts(_split(without[name], far)[0]))
    if neutral is not None and name != "improve":
        assert extra is not None and np.all(extra == neutral), f"unused vertex: {extra}"


def test_tetlap_info_on_a_mesh_with_a_far_unused_vertex(monkeypatch, capsys):
    V1 = np.vstack([V, [[1e155, 1e155, 1e155]]])
    monkeypatch.setattr(_mesh, "load", lambda path: (V1, T, "test mesh"))
    assert cli.main(["info", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["mesh"]["n_unreferenced_vertices"] == 1
    assert report["regular"]["status"] == tetlap.info.report(V, T, progress=False)["regular"]["status"]
