"""Vector-Jacobian products against one-shot assembly of the same operator, in one run.

    python benches/derivatives.py            # two ~1M-tet meshes (a few minutes)
    python benches/derivatives.py --quick    # ~50k tets
    python benches/derivatives.py --json     # machine-readable records

Meshes: a jittered Kuhn grid (``tetlap.meshes.cube(55, jitter=0.2)``, 998,250 tets) and
the Delaunay tetrahedralisation of 153,846 uniform random points in the unit cube
(``scipy.spatial.Delaunay``, qhull's order, ~1.03M tets). For each operator the full VJP
(a general cotangent: a sparse ``dL`` on every entry of ``L``, a diagonal ``dM``, through
the public Python call, conversions included) and the quadratic-form gradients
(``dirichlet_energy``, ``mass_energy``) are timed against the one-shot assembly of the
same operator (``tetlap.laplacian``, ``tetlap.mass``, ``tetlap.operators``). Median of
interleaved repetitions; ratios VJP / assembly. The target (issue 17): at most 3x.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np
import scipy.sparse as sp

import tetlap


def meshes(quick: bool):
    k, n = (20, 8000) if quick else (55, 153_846)
    yield f"Kuhn grid {k}^3 jitter 0.2", tetlap.meshes.cube(k, jitter=0.2)
    from scipy.spatial import Delaunay

    V = np.random.default_rng(0).uniform(size=(n, 3))
    yield f"random Delaunay n={n}", (V, Delaunay(V).simplices.astype(np.int64))


def cases(V, T):
    """(operator, assembly call, [(vjp name, vjp call)])."""
    n = len(V)
    rng = np.random.default_rng(1)
    f = np.sin(3 * V[:, 0]) * V[:, 1] + V[:, 2]
    pattern = tetlap.laplacian(V, T, "primal")
    dL = sp.csr_array((rng.normal(size=pattern.nnz), pattern.indices, pattern.indptr), shape=(n, n))
    dm = rng.normal(size=n)
    out = []
    for kind in ("primal", "dual"):
        out.append((f"L {kind}", lambda kind=kind: tetlap.laplacian(V, T, kind), [
            ("vjp(dL sparse)", lambda kind=kind: tetlap.vjp(V, T, kind, dL=dL)),
            ("dirichlet_energy", lambda kind=kind: tetlap.dirichlet_energy(V, T, f, kind)),
        ]))
    out.append(("M circumcentric", lambda: tetlap.mass(V, T, "circumcentric"), [
        ("vjp(dM diagonal)", lambda: tetlap.vjp(V, T, mass="circumcentric", dM=dm)),
        ("mass_energy", lambda: tetlap.mass_energy(V, T, f, "circumcentric")),
    ]))
    out.append(("L dual + M circumcentric",
                lambda: tetlap.operators(V, T, "dual", "circumcentric"), [
                    ("vjp(dL sparse, dM diagonal)",
                     lambda: tetlap.vjp(V, T, "dual", "circumcentric", dL=dL, dM=dm)),
                ]))
    return out


def timed(f) -> float:
    start = time.perf_counter()
    f()
    return time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    records = []
    load = open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else []
    for mesh, (V, T) in meshes(args.quick):
        if not args.json:
            print(f"\n{mesh}: {len(V)} vertices, {len(T)} tets "
                  f"(load average before: {' '.join(load)})")
            print(f"{'operator':<26} {'assembly':>9}  {'VJP':<28} {'time':>8} {'ratio':>6}")
        for name, assemble, vjps in cases(V, T):
            times = {"assembly": []} | {v: [] for v, _ in vjps}
            for _ in range(args.repeat):  # interleaved
                times["assembly"].append(timed(assemble))
                for v, call in vjps:
                    times[v].append(timed(call))
            base = statistics.median(times["assembly"])
            for v, _ in vjps:
                t = statistics.median(times[v])
                records.append({"mesh": mesh, "n_tets": len(T), "operator": name,
                                "assembly_s": base, "vjp": v, "vjp_s": t, "ratio": t / base})
                if not args.json:
                    print(f"{name:<26} {base:>8.3f}s  {v:<28} {t:>7.3f}s {t / base:>5.2f}x")
        load = open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else []
    if args.json:
        print(json.dumps(records, indent=2))
    else:
        print(f"\nworst ratio: {max(r['ratio'] for r in records):.2f}x "
              f"(load average after: {' '.join(load)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
