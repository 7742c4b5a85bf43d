"""``tetlap bench``: tetlap against the floor and the baselines installed, side by side, on
the kinds of mesh users bring.

Every case is timed in the same process, interleaved (one repetition of every case, then
the next repetition), and reported as the median with its ratio to the floor (gathering
``V[T]`` in the mesh's own order and writing the three CSR arrays of the result: the
memory traffic any assembler must do) and to ``igl.cotmatrix`` (pip ``libigl``) when it is
installed (``igl_cotmatrix_over_this`` is None without it). ``tetlap bench`` (in
:mod:`tetlap.cli.bench`) runs it and prints the records as a table or JSON.

Mesh kinds: ``kuhn`` (a jittered Kuhn grid of the unit cube, near-perfect memory order),
``delaunay`` (``scipy.spatial.Delaunay`` of uniform random points, in qhull's own order),
``shuffled`` (that mesh with its vertices and tets randomly renumbered), ``ordered`` (that
mesh with its vertices renumbered along a Morton curve and its tets sorted by smallest
vertex: the well-ordered reference for the cost of random order) and any mesh file
(``--mesh FILE``).
"""

from __future__ import annotations

import pathlib
import statistics
import time
from typing import Callable

import numpy as np
import scipy.sparse as sp

from . import _options, assembly, meshes
from ._progress import bar
from .info import report
from .mesh import Mesh
from .analysis import check
from ._names import public_dir

__all__ = ["SCHEMA_VERSION", "SIZES", "TETS_PER_POINT", "KINDS", "DEFAULT_CASES",
           "delaunay", "shuffled", "ordered", "mesh", "numpy_primal", "floor", "time_mesh",
           "document", "run"]
__dir__ = public_dir(globals())

#: The version of the layout of ``tetlap bench --json`` (:func:`document`), its first key;
#: raised with every change of it or of the records' keys, each in the CHANGELOG. 1: one
#: object ``{"schema_version", "benchmark": "assembly" | "solve", "records"}`` (before:
#: the bare list of records).
SCHEMA_VERSION = 1

# Kuhn grids: 6 k^3 tets.
SIZES = {"10k": 12, "100k": 26, "1M": 55, "4M": 87}
#: Tets per point of the Delaunay tetrahedralisation of uniform points in a cube.
TETS_PER_POINT = 6.73
KINDS = ("kuhn", "delaunay", "shuffled", "ordered")
#: Cases that run unless ``--operators`` asks for others.
DEFAULT_CASES = ("floor", "tetlap primal", "tetlap dual", "tetlap L+M primal+barycentric",
                 "tetlap L+M dual+circumcentric", "Mesh: update all + L+M dual",
                 "Mesh: update 20 vertices", "igl.cotmatrix", "igl.massmatrix barycentric")


def delaunay(n_tets: int, seed: int = 0):
    """``scipy.spatial.Delaunay`` of ``n_tets / 6.73`` uniform points in the unit cube, in
    qhull's order (flat hull slivers removed)."""
    from scipy.spatial import Delaunay

    _options.count(n_tets, "n_tets")
    _options.count(seed, "seed", 0)
    points = np.random.default_rng(seed).uniform(size=(round(n_tets / TETS_PER_POINT), 3))
    T = Delaunay(points).simplices.astype(np.int64)
    e = points[T[:, 1:]] - points[T[:, :1]]
    volume = np.abs(np.einsum("ij,ij->i", e[:, 0], np.cross(e[:, 1], e[:, 2])))
    return points, T[volume > 1e-12 * volume.mean()]


def shuffled(V, T, seed: int = 1):
    """The mesh with its vertices and its tets in random order."""
    _options.count(seed, "seed", 0)
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(V))
    return V[perm], inverse[T][rng.permutation(len(T))]


def ordered(V, T):
    """The mesh with its vertices along a Morton (Z-order) curve of their coordinates
    quantised to 2^21 cells per axis, and its tets sorted by their smallest vertex."""
    q = ((V - V.min(axis=0)) / max(np.ptp(V, axis=0).max(), 1e-300) * (2**21 - 1)).astype(np.uint64)
    code = np.zeros(len(V), dtype=np.uint64)
    for bit in range(21):
        for axis in range(3):
            code |= ((q[:, axis] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + axis)
    perm = np.argsort(code, kind="stable")
    new_of_old = np.empty(len(V), dtype=np.int64)
    new_of_old[perm] = np.arange(len(V))
    T2 = new_of_old[T]
    return V[perm], T2[np.argsort(T2.min(axis=1), kind="stable")]


def mesh(kind: str, size: str):
    """The benchmark mesh of ``kind`` (one of ``KINDS``) and ``size``."""
    if kind == "kuhn":
        return meshes.cube(SIZES[size], jitter=0.2, seed=0)
    n_tets = 6 * SIZES[size] ** 3
    V, T = delaunay(n_tets)
    return {"shuffled": shuffled, "ordered": ordered}.get(kind, lambda V, T: (V, T))(V, T)


def numpy_primal(V, T):
    """Reference primal Laplacian in plain NumPy: minus the P1 stiffness, COO -> CSR."""
    X = V[T]
    E = X[:, 1:] - X[:, :1]
    normals = np.stack([np.cross(E[:, 2] - E[:, 0], E[:, 1] - E[:, 0]),
                        np.cross(E[:, 1], E[:, 2]), np.cross(E[:, 2], E[:, 0]),
                        np.cross(E[:, 0], E[:, 1])], axis=1)
    det = np.abs(np.einsum("ij,ij->i", E[:, 0], normals[:, 1]))
    K = np.einsum("tad,tbd->tab", normals, normals) / (6 * det)[:, None, None]
    rows = np.repeat(T, 4, axis=1).ravel()
    cols = np.tile(T, (1, 4)).ravel()
    return sp.coo_array((-K.ravel(), (rows, cols)), shape=(len(V),) * 2).tocsr()


def floor(V, T, nnz):
    """Gather ``V[T]`` once and write CSR arrays of ``nnz`` entries: the memory traffic
    floor of an assembly."""
    X = V[T]
    data = np.empty(nnz)
    data[:] = X[0, 0, 0]
    indices = np.empty(nnz, dtype=np.int32)
    indices[:] = 1
    indptr = np.arange(len(V) + 1, dtype=np.int32)
    return X, data, indices, indptr


def _cases(V, T, threads) -> dict[str, Callable[[], object]]:
    nnz = assembly.laplacian(V, T, degenerate="skip").nnz
    opts = {"threads": threads, "degenerate": "skip"}
    cases: dict[str, Callable[[], object]] = {
        "floor": lambda: floor(V, T, nnz),
        "tetlap primal": lambda: assembly.laplacian(V, T, "primal", **opts),
        "tetlap dual": lambda: assembly.laplacian(V, T, "dual", **opts),
        "tetlap L+M primal+barycentric": lambda: assembly.operators(
            V, T, "primal", "barycentric", **opts),
        "tetlap L+M dual+circumcentric": lambda: assembly.operators(
            V, T, "dual", "circumcentric", **opts),
    }
    # Two cached meshes, each toggling between two geometries: every vertex moves, or 20.
    rng = np.random.default_rng(0)
    few = V.copy()
    few[rng.choice(len(V), 20, replace=False)] *= 1 + 1e-9
    toggles = {"all": (Mesh(V, T, **opts), [V * (1 + 1e-6), V * (1 + 2e-6)]),
               "few": (Mesh(V, T, **opts), [few, V])}
    for cached, _ in toggles.values():
        cached.operators("dual", "circumcentric")
    state = {"all": 0, "few": 0}

    def toggle(which):
        cached, geometries = toggles[which]
        state[which] ^= 1
        return cached, cached.update(geometries[state[which]])

    cases["Mesh: update all + L+M dual"] = lambda: toggle("all")[0].operators("dual", "circumcentric")
    cases["Mesh: update 20 vertices"] = lambda: toggle("few")
    cases["numpy primal"] = lambda: numpy_primal(V, T)
    L = assembly.laplacian(V, T, "dual", **opts)
    cases["tetlap.check dual"] = lambda: check(L, V, T, kind="dual")
    cases["tetlap info (report)"] = lambda: report(V, T, progress=False)
    try:
        import igl

        cases["igl.cotmatrix"] = lambda: igl.cotmatrix(V, T)
        cases["igl.massmatrix barycentric"] = lambda: igl.massmatrix(
            V, T, igl.MASSMATRIX_TYPE_BARYCENTRIC)
        cases["igl.massmatrix voronoi"] = lambda: igl.massmatrix(
            V, T, igl.MASSMATRIX_TYPE_VORONOI)
    except ImportError:
        pass
    try:
        import skfem
        from skfem.models.poisson import laplace

        tets = meshes.orient(V, T)
        basis = skfem.Basis(skfem.MeshTet(V.T.copy(), tets.T.copy()), skfem.ElementTetP1())
        cases["scikit-fem P1 stiffness"] = lambda: skfem.asm(laplace, basis)
    except ImportError:
        pass
    return cases


def random_tensors(m: int, seed: int = 0, decades: float = 1.0) -> np.ndarray:
    """``m`` random SPD tensors ``R diag(l) R^T`` (eigenvalues from 1 to ``10^decades``,
    random rotations), as the benchmarks' per-tet conductivity."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(m, 3, 3)))
    lam = 10.0 ** (decades * rng.random((m, 3)))
    K = np.einsum("mij,mj,mkj->mik", Q, lam, Q)
    return (K + K.swapaxes(-1, -2)) / 2


def _coefficient_cases(V, T, opts) -> dict[str, Callable[[], object]]:
    """The operators with a per-tet scalar and tensor coefficient, and a cached mesh given
    a new coefficient (on 20 tets, or on every tet)."""
    m = len(T)
    rng = np.random.default_rng(0)
    c = rng.uniform(0.5, 2.0, m)
    K = random_tensors(m)
    cases: dict[str, Callable[[], object]] = {}
    for kind in ("primal", "dual"):
        cases[f"tetlap {kind}, scalar coefficient"] = (
            lambda kind=kind: assembly.laplacian(V, T, kind, coefficient=c, **opts))
        cases[f"tetlap {kind}, tensor coefficient"] = (
            lambda kind=kind: assembly.laplacian(V, T, kind, coefficient=K, **opts))
    few = c.copy()
    few[rng.choice(m, 20, replace=False)] *= 2.0
    toggles = {"few": (Mesh(V, T, coefficient=c, **opts), [few, c]),
               "all": (Mesh(V, T, coefficient=c, **opts), [1.5 * c, c])}
    for cached, _ in toggles.values():
        cached.laplacian("dual")
    state = {"few": 0, "all": 0}

    def toggle(which):
        cached, coefficients = toggles[which]
        state[which] ^= 1
        return cached, cached.update(coefficient=coefficients[state[which]])

    cases["Mesh: new coefficient on 20 tets"] = lambda: toggle("few")
    cases["Mesh: new coefficient on every tet + L dual"] = lambda: toggle("all")[0].laplacian("dual")
    return cases


def _selected(names, only) -> list[str]:
    if not only:
        return [n for n in names if n in DEFAULT_CASES]
    keep = ("floor", "igl.cotmatrix")
    return [n for n in names if n in keep or any(word in n for word in only)]


def time_mesh(label: str, V, T, threads=None, repeat: int = 5, only=None,
              progress: bool = True) -> list[dict]:
    """Time the cases on one mesh; one record per case."""
    _options.count(repeat, "repeat")
    _options.threads(threads)
    cases = _cases(V, T, threads)
    if only and any("coefficient" in word for word in only):
        cases |= _coefficient_cases(V, T, {"threads": threads, "degenerate": "skip"})
    names = _selected(list(cases), only)
    times: dict[str, list[float]] = {name: [] for name in names}
    rounds = bar(range(repeat), desc=f"{label}") if progress else range(repeat)
    for _ in rounds:
        for name in names:
            start = time.perf_counter()
            cases[name]()
            times[name].append(time.perf_counter() - start)
    medians = {name: statistics.median(t) for name, t in times.items()}
    return [{
        "mesh": label, "n_tets": int(len(T)), "n_vertices": int(len(V)), "case": name,
        "threads": threads, "median_s": t, "mtets_per_s": len(T) / t / 1e6,
        "vs_floor": t / medians["floor"],
        "igl_cotmatrix_over_this": (medians["igl.cotmatrix"] / t
                                    if "igl.cotmatrix" in medians else None),
    } for name, t in medians.items()]


def document(benchmark: str, records: list[dict]) -> dict:
    """The JSON document of ``tetlap bench --json``: ``{"schema_version":``
    :data:`SCHEMA_VERSION` ``, "benchmark": benchmark, "records": records}``, ``benchmark``
    "assembly" (records of :func:`time_mesh`) or "solve" (of
    :func:`tetlap.benchmark_solve.run`)."""
    return {"schema_version": SCHEMA_VERSION, "benchmark": benchmark, "records": records}


def run(kinds=KINDS, sizes=("100k",), files=(), threads=None, repeat=5, only=None,
        progress=True) -> list[dict]:
    """Time every selected case on every (kind, size) mesh and every file."""
    from . import io

    _options.count(repeat, "repeat")
    _options.threads(threads)
    records = []
    for size in sizes:
        for kind in kinds:
            V, T = mesh(kind, size)
            records += time_mesh(f"{kind} {size}", V, T, threads, repeat, only, progress)
    for path in files:
        V, T = io.read(path)
        records += time_mesh(pathlib.Path(path).name, V, T, threads, repeat, only, progress)
    return records
