"""Time tetlap.regular.regular_weights on the corpus and on ~200k-tet meshes, as a ratio to
the operator assembly timed in the same process, and optionally next to another checkout
of tetlap in the same run.

    python benches/regular_weights.py [--meshes DIR] [--big] [--only NAME] [--before PATH] [--json]

Cases: every corpus mesh of ``--meshes`` (default ``../shared/data/meshes``), and with
``--big`` generated meshes of about 215k tets (weighted balls, ~1% and ~10% non-Delaunay
tets, and random Delaunay balls with their interior vertices jittered by 0.1 and 0.3 mean
spacings); ``--only`` keeps the cases whose name contains it. Each line: tets,
non-Delaunay faces, the assembly time of ``tetlap.operators(V, T, "dual",
"circumcentric")`` (the best of three, in the same process), ``regular_weights`` time
(wall and CPU), their ratio, status, the three guarantees, iterations, LPs, masses lost.
With ``--before PATH`` (the ``python`` folder of another checkout, its extension built),
each case is also run by that version, in a child process right after this one (its own
assembly timed there): the ratios compare across versions on a shared machine. Run it
alone: the machine has two cores.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import time
import warnings

SUFFIXES = {".mesh", ".msh", ".vtu", ".vtk", ".ele"}


def cases(folder, big):
    import tetlap
    import tetlap.io
    from tetlap.experiments.regular_weights import jittered_ball

    if folder:
        for path in sorted(p for p in pathlib.Path(folder).iterdir() if p.suffix in SUFFIXES):
            yield path.name, lambda path=path: tetlap.io.read(path)
    if big:
        for scale in (0.01, 0.1):
            yield (f"weighted ball 34000 scale {scale}",
                   lambda scale=scale: tetlap.meshes.weighted_ball(34000, scale, seed=0))
        for amount in (0.1, 0.3):
            yield (f"jittered ball 34000 amount {amount}",
                   lambda amount=amount: jittered_ball(34000, amount, seed=0))


def timed(function, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def measure(name, read) -> dict:
    """One case: the assembly (best of three) and regular_weights, in this process."""
    import tetlap
    from tetlap.regular import regular_weights

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        V, T = read()
    assembly = min(timed(tetlap.operators, V, T, "dual", "circumcentric")[1] for _ in range(3))
    r, wall, cpu = timed(regular_weights, V, T)
    return {"mesh": name, "n_tets": len(T), "non_delaunay_faces": r.n_violated_plain,
            "assembly_s": round(assembly, 4), "seconds": round(wall, 3),
            "cpu_seconds": round(cpu, 2), "ratio": round(wall / assembly, 1),
            "status": r.status, "guarantees": getattr(r, "guarantees", None),
            "certificate": r.certificate_kind, "iterations": r.iterations,
            "lp_count": r.lp_count, "masses_lost": int(len(r.masses_lost))}


def before(path, args, name) -> dict:
    """The case ``name`` measured by the checkout whose ``python`` folder is ``path``."""
    command = [sys.executable, __file__, "--meshes", args.meshes or "", "--only", name,
               "--exact", "--json"] + (["--big"] if args.big else [])
    env = dict(os.environ, PYTHONPATH=str(path))
    out = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default=str(pathlib.Path(__file__).resolve().parents[2]
                                                / "shared" / "data" / "meshes"))
    parser.add_argument("--big", action="store_true", help="add the generated 215k-tet meshes")
    parser.add_argument("--only", help="only the cases whose name contains this")
    parser.add_argument("--exact", action="store_true", help="--only matches the whole name")
    parser.add_argument("--before", metavar="PATH",
                        help="the python folder of another checkout, to time too")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    for name, read in cases(args.meshes, args.big):
        if args.only and not (name == args.only if args.exact else args.only in name):
            continue
        record = measure(name, read)
        if args.before:
            old = before(args.before, args, name)
            record["before"] = {k: old[k] for k in ("assembly_s", "seconds", "ratio", "status",
                                                     "iterations", "masses_lost")}
        if args.json:
            print(json.dumps(record), flush=True)
            continue
        g = record["guarantees"] or {}
        line = (f"{name:<36} {record['n_tets']:>7} tets {record['non_delaunay_faces']:>6} "
                f"non-Del.  assembly {record['assembly_s']:6.3f} s  regular_weights "
                f"{record['seconds']:6.2f} s ({record['cpu_seconds']:6.2f} CPU) = "
                f"{record['ratio']:6.1f}x  {record['status']}, {record['iterations']} "
                f"iterations, {record['lp_count']} LPs, {record['masses_lost']} masses lost, "
                f"guarantees {'/'.join(g.values())}")
        if args.before:
            b = record["before"]
            line += (f"  | before: {b['seconds']:6.2f} s = {b['ratio']:6.1f}x, {b['status']}, "
                     f"{b['masses_lost']} lost")
        print(line, flush=True)


if __name__ == "__main__":
    main()
