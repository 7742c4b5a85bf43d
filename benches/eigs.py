"""Eigenpairs with tetlap.solve.eigs next to one assembly and LaPy 1.7, in one run.

    python benches/eigs.py [--cases NAME ...] [--cap SECONDS] [--json FILE]

Every case runs in its own child process, started with its mesh saved once to a temporary
``.npz``: its time, its peak resident memory and the machine's load average around it are
its own. Each child first times one primal one-shot assembly (the median of 3), so every
record carries the ratio to an assembly measured in the same process. ``tetlap`` cases
time ``solve.eigs(L, M, k, fixed)`` on the primal Laplacian (the operators are assembled
before the clock starts: about one assembly); ``lapy`` cases time
``lapy.Solver(lapy.TetMesh(V, T)).eigs(k)`` as its users call it (its own assembly of the
stiffness and the consistent mass included; Neumann). A case that outlives ``--cap``
seconds is killed with its process group ("timeout"). The machine has 2 cores shared with
other work: read the ratios, and the load average printed with each case.

Meshes: ``ball 189k`` and ``ball 974k`` (``tetlap.meshes.ball(30000)``, ``ball(150000)``),
``shuffled Delaunay 1M`` (``tetlap.benchmark.mesh("shuffled", "1M")``) and the corpus's
``svfsi_beam_tet4_129k.vtu`` (``$TETLAP_MESHES``).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time

import numpy as np

from tetlap.benchmark_solve import isolated

#: name -> (mesh, engine, k, boundary, mass)
CASES = {}
for k in (10, 50, 200, 500):
    CASES[f"ball189k tetlap k={k} neumann fem"] = ("ball 189k", "tetlap", k, "neumann", "fem")
for k in (10, 50, 200):
    CASES[f"ball189k lapy k={k}"] = ("ball 189k", "lapy", k, "neumann", "fem")
CASES.update({
    "ball189k tetlap k=200 neumann lumped": ("ball 189k", "tetlap", 200, "neumann", "barycentric"),
    "ball189k tetlap k=10 fixed lumped": ("ball 189k", "tetlap", 10, "fixed", "barycentric"),
    "ball189k tetlap k=200 fixed fem": ("ball 189k", "tetlap", 200, "fixed", "fem"),
    "beam129k tetlap k=200 neumann fem": ("svfsi_beam_tet4_129k.vtu", "tetlap", 200, "neumann", "fem"),
    "beam129k lapy k=200": ("svfsi_beam_tet4_129k.vtu", "lapy", 200, "neumann", "fem"),
    "beam129k tetlap k=10 fixed lumped": ("svfsi_beam_tet4_129k.vtu", "tetlap", 10, "fixed", "barycentric"),
    "ball974k tetlap k=10 fixed lumped": ("ball 974k", "tetlap", 10, "fixed", "barycentric"),
    "ball974k tetlap k=200 neumann fem": ("ball 974k", "tetlap", 200, "neumann", "fem"),
    "ball974k tetlap k=200 neumann lumped": ("ball 974k", "tetlap", 200, "neumann", "barycentric"),
    "delaunay1M tetlap k=10 fixed lumped": ("shuffled Delaunay 1M", "tetlap", 10, "fixed", "barycentric"),
})


def make_mesh(name: str):
    import tetlap
    from tetlap import benchmark

    if name == "ball 189k":
        return tetlap.meshes.ball(30000, seed=0)
    if name == "ball 974k":
        return tetlap.meshes.ball(150000, seed=0)
    if name == "shuffled Delaunay 1M":
        return benchmark.mesh("shuffled", "1M")
    folder = pathlib.Path(os.environ.get("TETLAP_MESHES", "../shared/data/meshes"))
    return tetlap.io.read(folder / name)


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def run_case(case: str, path: str) -> dict:
    """One case on the mesh at ``path``, in this process."""
    import resource

    import tetlap

    _, engine, k, boundary, mass = CASES[case]
    data = np.load(path)
    V, T = data["V"], data["T"]
    times = []
    for _ in range(3):
        start = time.perf_counter()
        tetlap.laplacian(V, T, "primal")
        times.append(time.perf_counter() - start)
    out = {"assembly_s": sorted(times)[1], "load_before": os.getloadavg()[0],
           "n_vertices": len(V)}
    if engine == "lapy":
        import lapy

        start = time.perf_counter()
        lam, _ = lapy.Solver(lapy.TetMesh(V, T)).eigs(k)
        out["seconds"] = time.perf_counter() - start
        out["lapy"] = getattr(lapy, "__version__", "?")
    else:
        L, M = tetlap.operators(V, T, "primal", mass)
        fixed = tetlap.diagnostics.boundary_vertices(V, T) if boundary == "fixed" else None
        out["base_rss_mb"] = _rss_mb()
        start = time.perf_counter()
        lam, vec, info = tetlap.solve.eigs(L, M, k, fixed, return_info=True)
        out["seconds"] = time.perf_counter() - start
        out["info"] = info.to_dict()
        out["block_mb"] = len(V) * k * 8 / 2**20      # one n x k block of doubles
    out["eigenvalues"] = np.asarray(lam, dtype=float).tolist()
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out["load_after"] = os.getloadavg()[0]
    return out


def _child(case: str, path: str, cap: float) -> dict:
    return isolated([sys.executable, __file__, "--child", case, path], cap)


def run(cases, cap: float) -> list[dict]:
    records = []
    with tempfile.TemporaryDirectory() as folder:
        for mesh in dict.fromkeys(CASES[c][0] for c in cases):
            V, T = make_mesh(mesh)
            path = str(pathlib.Path(folder) / "mesh.npz")
            np.savez(path, V=V, T=T)
            for case in [c for c in cases if CASES[c][0] == mesh]:
                r = {"case": case, "mesh": mesh, "n_tets": int(len(T)), **_child(case, path, cap)}
                if "seconds" in r:
                    r["over_assembly"] = r["seconds"] / r["assembly_s"]
                print(f"{case}: {r['status']} " + (
                    f"{r['seconds']:.1f} s = {r['over_assembly']:.0f} assemblies "
                    f"(assembly {r['assembly_s']:.3f} s, load {r['load_before']:.1f}-"
                    f"{r['load_after']:.1f}, peak {r['peak_rss_mb']:.0f} MB)"
                    if "seconds" in r else ""), file=sys.stderr, flush=True)
                records.append(r)
    # the same eigenvalues as LaPy (where both ran)
    for r in records:
        mesh, engine, k, boundary, mass = CASES[r["case"]]
        if engine != "lapy" or r["status"] != "ok":
            continue
        for other in records:
            o = CASES[other["case"]]
            if o[:1] == (mesh,) and o[1:] == ("tetlap", k, "neumann", "fem") and other["status"] == "ok":
                a, b = np.array(r["eigenvalues"]), np.array(other["eigenvalues"])
                other["speedup_over_lapy"] = r["seconds"] / other["seconds"]
                other["lapy_agreement"] = float(np.abs(a - b).max() / np.abs(b).max())
    return records


def table(records) -> str:
    lines = [f"{'case':<40} {'tets':>8} {'seconds':>8} {'x asm':>6} {'asm s':>6} {'load':>9} "
             f"{'peak MB':>8} {'solves':>6} {'vs LaPy':>8}  phases"]
    for r in records:
        if r["status"] != "ok":
            lines.append(f"{r['case']:<40} {r['n_tets']:>8} {r['status']}")
            continue
        info = r.get("info") or {}
        phases = " ".join(f"{k} {v:.1f}" for k, v in info.get("phases", {}).items())
        vs = f"{r['speedup_over_lapy']:.1f}x" if "speedup_over_lapy" in r else ""
        lines.append(
            f"{r['case']:<40} {r['n_tets']:>8} {r['seconds']:>8.1f} {r['over_assembly']:>6.0f} "
            f"{r['assembly_s']:>6.3f} {r['load_before']:>4.1f}-{r['load_after']:<4.1f} "
            f"{r['peak_rss_mb']:>8.0f} {info.get('iterations') or '':>6} {vs:>8}  {phases}")
    return "\n".join(lines)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        print(json.dumps(run_case(sys.argv[2], sys.argv[3])))
        sys.exit(0)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    p.add_argument("--cap", type=float, default=1800.0)
    p.add_argument("--json", help="also write the records to this file")
    args = p.parse_args()
    records = run(args.cases, args.cap)
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(records, indent=1))
    print(table(records))
