"""How `tetlap.check` and `tetlap info` grow with the mesh, and the peak memory of `info`.

    python benches/check_scaling.py [--kinds kuhn delaunay] [--sizes 10k 100k 1M 4M]

For each mesh kind (the meshes of `tetlap bench`) and size: the medians of 3 timings of
`tetlap.check(L_dual, V, T, kind="dual")` (L assembled beforehand) and of
`tetlap.info.report(V, T, regular=False)` (the `O(m)` checks; the regular section has a
budget of its own: half of that time, 1 to 10 s, and none by default above 300k tets), in
this process; then `tetlap info` on the mesh written as a
`.vtu` file, run once as a fresh process (`python -m tetlap info FILE`: what a user runs,
interpreter start-up and reading the file included), with that process's peak resident
memory (its `VmHWM` at exit: `ru_maxrss` would count the parent's pages at the fork). Then the exponent `p` of
`time ~ size^p` fitted by least squares over the sizes of at least 100k tets (1 means
linear; below, fixed costs dominate: the interpreter start-up of the process). `igl.cotmatrix` on the same mesh is
timed too when libigl is installed, for the target "info in less than 5 calls of
igl.cotmatrix".
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import tetlap
from tetlap import benchmark


def median_time(f, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


# `tetlap info FILE`, then the process's peak resident memory (kB) on stderr
INFO = """
import sys
from tetlap.cli import main
code = main(sys.argv[1:])
print(next(l for l in open("/proc/self/status") if l.startswith("VmHWM")).split()[1], file=sys.stderr)
sys.exit(code)
"""


def info_process(path: str) -> tuple[float, float]:
    """Wall time (s) and peak resident memory (MB) of `tetlap info path` in a fresh process."""
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", INFO, "info", path], check=True,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    return elapsed, int(done.stderr.split()[-1]) / 1024


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", nargs="+", default=["kuhn", "delaunay"], choices=benchmark.KINDS)
    parser.add_argument("--sizes", nargs="+", default=["10k", "100k", "1M"], choices=list(benchmark.SIZES))
    args = parser.parse_args()
    try:
        import igl
    except ImportError:
        igl = None
    import meshio

    print(f"{'kind':9} {'size':>5} {'tets':>9} {'check dual':>11} {'info.report':>12} "
          f"{'info (process)':>15} {'its peak':>9} {'igl.cotmatrix':>14} {'process/igl':>12}")
    with tempfile.TemporaryDirectory() as folder:
        for kind in args.kinds:
            sizes, checks, reports = [], [], []
            for size in args.sizes:
                V, T = benchmark.mesh(kind, size)
                L = tetlap.laplacian(V, T, "dual", degenerate="skip")
                t_check = median_time(lambda: tetlap.check(L, V, T, kind="dual"))
                t_report = median_time(lambda: tetlap.info.report(V, T, progress=False, regular=False))
                path = os.path.join(folder, f"{kind}{size}.vtu")
                meshio.write(path, meshio.Mesh(V, [("tetra", T)]))
                t_info, peak = info_process(path)
                t_igl = median_time(lambda: igl.cotmatrix(V, T)) if igl else float("nan")
                if len(T) >= 100_000:
                    sizes.append(len(T))
                    checks.append(t_check)
                    reports.append(t_report)
                print(f"{kind:9} {size:>5} {len(T):9d} {t_check:10.2f}s {t_report:11.2f}s "
                      f"{t_info:14.2f}s {peak:7.0f}MB {t_igl:13.2f}s {t_info / t_igl:12.2f}",
                      flush=True)
                os.remove(path)
            if len(sizes) > 1:
                fit = lambda t: np.polyfit(np.log(sizes), np.log(t), 1)[0]  # noqa: E731
                print(f"{kind:9} time ~ tets^p from 100k tets on: check p = {fit(checks):.2f}, "
                      f"info.report p = {fit(reports):.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
