"""The cost of tetlap.HeatDistance on a large ball against a one-shot assembly and one
factorization, measured in the same run (issue 29's targets: each further source at most
3 one-shot assemblies' time, the set-up at most 2 factorizations).

    python benches/heat_distance.py [N_VERTICES] [--boundary neumann|average]

Prints a table of median wall-clock times (seconds) and the ratios. The factorization is
``tetlap.solve.factorize`` of the heat matrix ``M - t L`` itself (the one the set-up makes
first).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import scipy.sparse as sp

import tetlap
from tetlap.solve import factorize


def timed(f, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("n", type=int, nargs="?", default=150000)
    p.add_argument("--boundary", default="neumann")
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    V, T = tetlap.meshes.ball(a.n, seed=0)
    print(f"ball({a.n}): {len(V)} vertices, {len(T)} tets, boundary={a.boundary}")
    assembly = timed(lambda: tetlap.laplacian(V, T), a.repeat)
    L, M = tetlap.operators(V, T)
    A = sp.csc_array(M - 1e-4 * L)
    factor = timed(lambda: factorize(A), 1)
    t0 = time.perf_counter()
    heat = tetlap.HeatDistance(V, T, boundary=a.boundary)
    setup = time.perf_counter() - t0
    centre = int(np.argmin((V ** 2).sum(1)))
    sources = [centre, int(np.argmax(V[:, 0])), int(np.argmin(V[:, 2]))]
    per_source = statistics.median([timed(lambda s=s: heat.distance(s), 1) for s in sources])
    d = heat.distance(centre)
    err = np.abs(d - np.linalg.norm(V - V[centre], axis=1)).mean() / d.max()
    print("| what | seconds | ratio | target |")
    print("| --- | --- | --- | --- |")
    print(f"| one-shot assembly (primal L) | {assembly:.3f} | 1 | |")
    print(f"| one factorization (M - t L) | {factor:.2f} | 1 | |")
    print(f"| HeatDistance set-up ({heat.n_factorizations} factorizations) | {setup:.2f} | "
          f"{setup / factor:.2f} factorizations | <= 2 |")
    print(f"| each further source | {per_source:.3f} | {per_source / assembly:.1f} "
          f"assemblies | <= 3 |")
    print(f"mean error from the centre: {err:.4f} of the largest distance")


if __name__ == "__main__":
    main()
