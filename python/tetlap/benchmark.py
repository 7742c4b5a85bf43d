"""``tetlap bench``: tetlap against the floor and the baselines installed, side by side.

Every case is timed in the same process, interleaved (one repetition of every
implementation, then the next repetition), and reported as the median with its ratio to
the floor (gathering ``V[T]`` once and writing the three CSR arrays of the result: the
memory traffic any assembler must do) and to each baseline that is installed:
``igl.cotmatrix`` / ``igl.massmatrix`` (pip ``libigl``), scikit-fem's P1 ``laplace`` form,
and a plain vectorised NumPy primal (below, SciPy's COO -> CSR included).
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from typing import Callable

import numpy as np
import scipy.sparse as sp

from . import assembly, meshes
from .mesh import Mesh

# Kuhn grids: 6 k^3 tets.
SIZES = {"10k": 12, "100k": 26, "1M": 55, "4M": 87}


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
    """Gather V[T] once and write CSR arrays of nnz entries: the memory traffic floor."""
    X = V[T]
    data = np.empty(nnz)
    data[:] = X[0, 0, 0]
    indices = np.empty(nnz, dtype=np.int32)
    indices[:] = 1
    indptr = np.arange(len(V) + 1, dtype=np.int32)
    return X, data, indices, indptr


def _cases(V, T, threads, quick) -> dict[str, Callable[[], object]]:
    nnz = assembly.laplacian(V, T).nnz
    cases: dict[str, Callable[[], object]] = {
        "floor": lambda: floor(V, T, nnz),
        "tetlap primal": lambda: assembly.laplacian(V, T, "primal", threads=threads),
        "tetlap dual": lambda: assembly.laplacian(V, T, "dual", threads=threads),
        "tetlap L+M primal+barycentric": lambda: assembly.operators(
            V, T, "primal", "barycentric", threads=threads),
        "tetlap L+M dual+circumcentric": lambda: assembly.operators(
            V, T, "dual", "circumcentric", threads=threads),
    }
    # Two cached meshes, each toggling between two geometries: every vertex moves, or 20.
    rng = np.random.default_rng(0)
    few = V.copy()
    few[rng.choice(len(V), 20, replace=False)] += 1e-4
    toggles = {"all": (Mesh(V, T, threads=threads), [V * (1 + 1e-6), V * (1 + 2e-6)]),
               "few": (Mesh(V, T, threads=threads), [few, V])}
    for mesh, _ in toggles.values():
        mesh.operators("dual", "circumcentric")
    state = {"all": 0, "few": 0}

    def toggle(which):
        mesh, geometries = toggles[which]
        state[which] ^= 1
        return mesh, mesh.update(geometries[state[which]])

    def all_moved():
        mesh, _ = toggle("all")
        return mesh.operators("dual", "circumcentric")

    def twenty_moved():
        return toggle("few")

    cases["Mesh: update all + L+M dual"] = all_moved
    cases["Mesh: update 20 vertices"] = twenty_moved
    if not quick:
        cases["numpy primal"] = lambda: numpy_primal(V, T)
    try:
        import igl

        cases["igl.cotmatrix"] = lambda: igl.cotmatrix(V, T)
        cases["igl.massmatrix barycentric"] = lambda: igl.massmatrix(
            V, T, igl.MASSMATRIX_TYPE_BARYCENTRIC)
        if not quick:
            cases["igl.massmatrix voronoi"] = lambda: igl.massmatrix(
                V, T, igl.MASSMATRIX_TYPE_VORONOI)
    except ImportError:
        pass
    if not quick:
        try:
            import skfem
            from skfem.models.poisson import laplace

            tets = meshes.orient(V, T)
            basis = skfem.Basis(skfem.MeshTet(V.T.copy(), tets.T.copy()), skfem.ElementTetP1())
            cases["scikit-fem P1 stiffness"] = lambda: skfem.asm(laplace, basis)
        except ImportError:
            pass
    return cases


def run(sizes=("100k",), threads=None, repeat=5, quick=False, progress=True,
        only=None) -> list[dict]:
    """Time every case (or those whose name contains a word of ``only``; the floor and
    ``igl.cotmatrix`` always run, for the ratios) on every size; one record per
    (size, case)."""
    records = []
    for size in sizes:
        V, T = meshes.cube(SIZES[size], jitter=0.2, seed=0)
        cases = _cases(V, T, threads, quick)
        if only:
            keep = ("floor", "igl.cotmatrix")
            cases = {k: f for k, f in cases.items()
                     if k in keep or any(word in k for word in only)}
        times: dict[str, list[float]] = {name: [] for name in cases}
        for r in range(repeat):
            if progress:
                print(f"\r{size}: repetition {r + 1}/{repeat}", end="", file=sys.stderr, flush=True)
            for name, f in cases.items():
                start = time.perf_counter()
                f()
                times[name].append(time.perf_counter() - start)
        if progress:
            print(file=sys.stderr)
        medians = {name: statistics.median(t) for name, t in times.items()}
        for name, t in medians.items():
            records.append({
                "size": size, "n_tets": int(len(T)), "n_vertices": int(len(V)), "case": name,
                "threads": threads, "median_s": t, "mtets_per_s": len(T) / t / 1e6,
                "vs_floor": t / medians["floor"],
                "igl_cotmatrix_over_this": medians.get("igl.cotmatrix", float("nan")) / t,
            })
    return records


def table(records) -> str:
    lines = [f"{'size':>5} {'case':<32} {'median':>10} {'Mtets/s':>8} {'x floor':>8} "
             f"{'igl.cot / this':>14}"]
    for r in records:
        lines.append(f"{r['size']:>5} {r['case']:<32} {1e3 * r['median_s']:>8.2f}ms "
                     f"{r['mtets_per_s']:>8.2f} {r['vs_floor']:>8.2f} "
                     f"{r['igl_cotmatrix_over_this']:>14.2f}")
    return "\n".join(lines)


def main(args) -> int:
    sizes = args.sizes or (["10k", "100k"] if args.quick else ["10k", "100k", "1M"])
    records = run(sizes, threads=args.threads, repeat=args.repeat or (3 if args.quick else 7),
                  quick=args.quick, only=args.operators)
    print(json.dumps(records, indent=1) if args.json else table(records))
    return 0
