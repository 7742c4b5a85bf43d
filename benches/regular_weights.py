"""Time tetlap.regular.regular_weights on ~200k-tet meshes next to the operator assembly.

    python benches/regular_weights.py [--meshes DIR] [--time-limit S] [--json]

Cases: the Kuhn block of the corpus (Delaunay: the check alone), the pipe lumen of the
corpus (2.4% non-Delaunay faces), and generated regular triangulations of about 215k tets
(weighted balls, ~1% and ~10% non-Delaunay tets) and random Delaunay balls of the same
size with their interior vertices jittered by 0.1 and 0.3 mean spacings. Each line: tets, non-Delaunay faces,
assembly time of ``tetlap.operators(V, T, "dual", "circumcentric")`` in the same run,
``regular_weights`` time, verdict, LPs and the largest LP. Run it alone: the machine has
two cores.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time
import warnings

import tetlap
import tetlap.io
from tetlap.experiments.regular_weights import jittered_ball
from tetlap.regular import regular_weights


def cases(folder):
    if folder:
        for name in ("svfsi_block_kuhn_197k.vtu", "svfsi_pipe_lumen_205k.vtu"):
            path = pathlib.Path(folder) / name
            if path.is_file():
                yield name, lambda path=path: tetlap.io.read(path)
    for scale in (0.01, 0.1):
        yield (f"weighted ball 34000 scale {scale}",
               lambda scale=scale: tetlap.meshes.weighted_ball(34000, scale, seed=0))
    for amount in (0.1, 0.3):
        yield (f"jittered ball 34000 amount {amount}",
               lambda amount=amount: jittered_ball(34000, amount, seed=0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default=str(pathlib.Path(__file__).resolve().parents[2]
                                                / "shared" / "data" / "meshes"))
    parser.add_argument("--time-limit", type=float, default=300.0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    for name, load in cases(args.meshes):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = load()
        t0 = time.perf_counter()
        tetlap.operators(V, T, "dual", "circumcentric")
        assembly = time.perf_counter() - t0
        r = regular_weights(V, T, time_limit=args.time_limit)
        record = {"mesh": name, "n_tets": len(T), "non_delaunay_faces": r.n_violated_plain,
                  "assembly_s": round(assembly, 3), "regular_weights_s": round(r.seconds, 2),
                  "ratio": round(r.seconds / assembly, 1), "regular": r.regular,
                  "margin": r.margin, "status": r.status, "iterations": r.iterations, "lp_count": r.lp_count,
                  "notes": r.notes}
        if args.json:
            print(json.dumps(record), flush=True)
        else:
            print(f"{name:<36} {len(T):>7} tets {r.n_violated_plain:>6} non-Del faces  "
                  f"assembly {assembly:6.3f} s  regular_weights {r.seconds:7.2f} s "
                  f"({r.seconds / assembly:.0f}x)  regular {r.regular}  margin "
                  f"{r.margin:+.2e}  {r.status}, {r.iterations} iterations, {r.lp_count} LPs  {'; '.join(r.notes)}",
                  flush=True)


if __name__ == "__main__":
    main()
