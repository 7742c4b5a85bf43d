"""``tetlap bench --solve`` and ``benches/solve.py``: the solves of :mod:`tetlap.solve` on
1M-tet meshes next to one assembly, the old SuperLU path and other libraries, in one run.

Every case runs in its own child process (``python -m tetlap.benchmark_solve CASE MESH``)
started with the mesh saved once to a temporary ``.npz``: its wall-clock time and its peak
resident memory (the whole process: Python, the mesh and the solve) are its own, and a
case that outlives ``cap`` seconds (the old SuperLU path at 1M tets) is killed with its
process group and reported as "timeout". Each child also times one primal one-shot
assembly (the median of 3) before its case, so every record carries the ratio to an
assembly measured in the same process.

Cases (each on the Dirichlet problem with the boundary fixed, values ``x^2 - y``):
``dirichlet primal`` / ``dirichlet dual`` (the default solver, the whole call),
``dirichlet primal lu`` (the old path), ``dirichlet primal cholesky``, ``pyamg by hand``
(the reduced system, ``smoothed_aggregation_solver`` with its defaults and CG to 1e-10,
as a user would write it), ``igl.harmonic`` and ``igl.min_quad_with_fixed`` (libigl, when
installed), ``eigs k=10`` (primal, barycentric mass, boundary fixed), ``factorize`` (of
``M - 1e-3 L``) and ``factor solve`` (one further solve).
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

from . import _options
from ._names import public_dir

__all__ = ["MESHES", "CASES", "make_mesh", "run_case", "run", "table", "isolated"]
__dir__ = public_dir(globals())

#: The meshes of the bench: name -> how to make it.
MESHES = {
    "ball 189k": ("ball", 30000),
    "ball 974k": ("ball", 150000),
    "shuffled Delaunay 1M": ("shuffled", "1M"),
    "svfsi_pipe_lumen_205k.vtu": ("file", "svfsi_pipe_lumen_205k.vtu"),
    "svfsi_block_kuhn_197k.vtu": ("file", "svfsi_block_kuhn_197k.vtu"),
}
CASES = ("dirichlet primal", "dirichlet dual", "dirichlet primal cholesky", "pyamg by hand",
         "eigs k=10", "factorize", "dirichlet primal lu", "igl.harmonic",
         "igl.min_quad_with_fixed")


def make_mesh(name: str, meshes_dir=None):
    from . import benchmark, io, meshes

    how, arg = MESHES[name]
    if how == "ball":
        return meshes.ball(arg, seed=0)
    if how == "shuffled":
        return benchmark.mesh("shuffled", arg)
    folder = pathlib.Path(meshes_dir or os.environ.get("TETLAP_MESHES", "../shared/data/meshes"))
    return io.read(folder / arg)


def _timed(f):
    start = time.perf_counter()
    result = f()
    return result, time.perf_counter() - start


def run_case(case: str, path: str) -> dict:
    """One case on the mesh saved at ``path`` (in this process): seconds, the same-process
    assembly seconds, and what the solver reports."""
    import scipy.sparse as sp

    import tetlap

    data = np.load(path)
    V, T = data["V"], data["T"]
    assembly = sorted(_timed(lambda: tetlap.laplacian(V, T, "primal"))[1] for _ in range(3))[1]
    fixed = tetlap.diagnostics.boundary_vertices(V, T)
    values = V[:, 0] ** 2 - V[:, 1]
    out: dict = {"assembly_s": assembly}
    kind = "dual" if case == "dirichlet dual" else "primal"
    L = tetlap.laplacian(V, T, kind)
    if case.startswith("dirichlet"):
        solver = case.split()[2] if len(case.split()) > 2 else "auto"
        (f, info), out["seconds"] = _timed(lambda: tetlap.solve.dirichlet(
            L, fixed, values, solver=solver, return_info=True))
        out["info"] = info.to_dict()
    elif case == "pyamg by hand":
        import pyamg

        def by_hand():
            free = ~fixed
            A = (-L[free][:, free]).tocsr()
            b = L[free][:, fixed] @ values[fixed]
            ml = pyamg.smoothed_aggregation_solver(A, symmetry="symmetric")
            return ml.solve(b, tol=1e-10, accel="cg")

        _, out["seconds"] = _timed(by_hand)
    elif case.startswith("igl."):
        import igl

        b = np.flatnonzero(fixed)
        if case == "igl.harmonic":
            _, out["seconds"] = _timed(lambda: igl.harmonic(V, T, b, values[b][:, None], 1))
        else:
            Q = sp.csc_matrix(-L)
            _, out["seconds"] = _timed(lambda: igl.min_quad_with_fixed(
                Q, np.zeros((len(V), 1)), b.astype(np.int64), values[b][:, None],
                sp.csc_matrix((0, len(V))), np.zeros((0, 1)), True))
    elif case == "eigs k=10":
        L, M = tetlap.operators(V, T, "primal", "barycentric")
        (lam, _, info), out["seconds"] = _timed(lambda: tetlap.solve.eigs(
            L, M, 10, fixed, return_info=True))
        out["info"] = info.to_dict()
        out["eigenvalues"] = lam.tolist()
    elif case == "factorize":
        L, M = tetlap.operators(V, T, "primal", "barycentric")
        F, out["seconds"] = _timed(lambda: tetlap.solve.factorize(M - 1e-3 * L))
        _, out["solve_s"] = _timed(lambda: F.solve(M @ values))
        out["info"] = F.info.to_dict()
    else:
        raise ValueError(f"unknown case {case!r}")
    import resource

    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _child(case: str, path: str, cap: float) -> dict:
    return isolated([sys.executable, "-m", "tetlap.benchmark_solve", case, path], cap)


def isolated(argv: list[str], cap: float) -> dict:
    """Run ``argv`` (a case printing one JSON object on its last line) in its own process
    group, killed with its children after ``cap`` seconds: ``{"status": "ok", **the
    object}``, or ``{"status": "timeout (...)" | "failed: <its last error line>"}``."""
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    try:
        stdout, stderr = p.communicate(timeout=cap)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        return {"status": f"timeout (> {cap:g} s)"}
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
    if p.returncode:
        return {"status": f"failed: {stderr.strip().splitlines()[-1] if stderr.strip() else p.returncode}"}
    return {"status": "ok", **json.loads(stdout.strip().splitlines()[-1])}


def run(meshes=tuple(MESHES), cases=CASES, cap: float = 300.0, meshes_dir=None,
        progress: bool = True) -> list[dict]:
    """One record per (mesh, case): ``mesh, n_tets, case, status, seconds, assembly_s,
    over_assembly, peak_rss_mb`` and, where the case has them, ``info`` and ``solve_s``.
    ``cap``: seconds (> 0) each case may run."""
    _options.positive(cap, "cap")
    records = []
    with tempfile.TemporaryDirectory() as folder:
        for name in meshes:
            V, T = make_mesh(name, meshes_dir)
            path = str(pathlib.Path(folder) / "mesh.npz")
            np.savez(path, V=V, T=T)
            for case in cases:
                if case.startswith("igl."):
                    try:
                        import igl  # noqa: F401
                    except ImportError:
                        continue
                r = {"mesh": name, "n_tets": int(len(T)), "case": case, **_child(case, path, cap)}
                if "seconds" in r:
                    r["over_assembly"] = r["seconds"] / r["assembly_s"]
                if progress:
                    print(f"{name}: {case}: {r['status']} "
                          + (f"{r['seconds']:.2f} s = {r['over_assembly']:.1f} assemblies"
                             if "seconds" in r else ""), file=sys.stderr, flush=True)
                records.append(r)
    return records


def table(records) -> str:
    """The records as an aligned text table."""
    head = (f"{'mesh':<26} {'tets':>8} {'case':<26} {'seconds':>8} {'x asm':>7} {'peak MB':>8} "
            f"{'solver':<9} {'iters':>5} {'residual':>9}  phases")
    lines = [head]
    for r in records:
        if r["status"] != "ok":
            lines.append(f"{r['mesh']:<26} {r['n_tets']:>8} {r['case']:<26} {r['status']}")
            continue
        info = r.get("info") or {}
        phases = " ".join(f"{k} {v:.2f}" for k, v in info.get("phases", {}).items())
        if "solve_s" in r:
            phases += f" | further solve {r['solve_s']:.3f} s = {r['solve_s'] / r['assembly_s']:.2f} asm"
        lines.append(
            f"{r['mesh']:<26} {r['n_tets']:>8} {r['case']:<26} {r['seconds']:>8.2f} "
            f"{r['over_assembly']:>7.1f} {r['peak_rss_mb']:>8.0f} {info.get('solver', ''):<9} "
            f"{info.get('iterations') if info.get('iterations') is not None else '':>5} "
            f"{info.get('residual', float('nan')):>9.1e}  {phases}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(json.dumps(run_case(sys.argv[1], sys.argv[2])))
