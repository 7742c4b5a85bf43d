"""How `tetlap.check` and `tetlap info` grow with the mesh, and the peak memory of `info`.

    python benches/check_scaling.py [--kinds kuhn delaunay] [--sizes 10k 100k 1M 4M]

For each mesh kind (the meshes of `tetlap bench`) and size: the median of 3 timings of
`tetlap.check(L_dual, V, T, kind="dual")` (L assembled beforehand), and of `tetlap info`
on the mesh written as a `.vtu` file, run as a fresh process (`python -m tetlap info
FILE`: what a user runs, reading the file included), with that process's peak resident
memory (`ru_maxrss`). Then the exponent `p` of `time ~ size^p` fitted by least squares
over the sizes (1 means linear). `igl.cotmatrix` on the same mesh is timed too when libigl
is installed, for the target "info in less than 5 calls of igl.cotmatrix".
"""

from __future__ import annotations

import argparse
import os
import resource
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


def info_process(path: str) -> tuple[float, float]:
    """Wall time (s) and peak resident memory (MB) of `tetlap info path` in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "tetlap", "info", path], check=True, stdout=subprocess.DEVNULL)
    elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return elapsed, max(peak, before) / 1024


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

    print(f"{'kind':9} {'size':>5} {'tets':>9} {'check dual':>11} {'info (process)':>15} "
          f"{'info peak':>10} {'igl.cotmatrix':>14} {'info/igl':>9}")
    with tempfile.TemporaryDirectory() as folder:
        for kind in args.kinds:
            sizes, checks, infos = [], [], []
            for size in args.sizes:
                V, T = benchmark.mesh(kind, size)
                L = tetlap.laplacian(V, T, "dual", degenerate="skip")
                t_check = median_time(lambda: tetlap.check(L, V, T, kind="dual"))
                path = os.path.join(folder, f"{kind}{size}.vtu")
                meshio.write(path, meshio.Mesh(V, [("tetra", T)]))
                t_info, peak = info_process(path)
                t_igl = median_time(lambda: igl.cotmatrix(V, T)) if igl else float("nan")
                sizes.append(len(T))
                checks.append(t_check)
                infos.append(t_info)
                print(f"{kind:9} {size:>5} {len(T):9d} {t_check:10.2f}s {t_info:14.2f}s "
                      f"{peak:8.0f}MB {t_igl:13.2f}s {t_info / t_igl:9.2f}", flush=True)
                os.remove(path)
            if len(sizes) > 1:
                fit = lambda t: np.polyfit(np.log(sizes), np.log(t), 1)[0]  # noqa: E731
                print(f"{kind:9} fitted exponent of time ~ tets^p: check p = {fit(checks):.2f}, "
                      f"info p = {fit(infos):.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
