"""Time tetlap.regular.regular_weights on the corpus and on ~200k-tet meshes, next to the
operator assembly, and optionally next to another version of it in the same run.

    python benches/regular_weights.py [--meshes DIR] [--big] [--compare OLD.py] [--json]

Cases: every corpus mesh of ``--meshes`` (default ``../shared/data/meshes``), and with
``--big`` generated regular triangulations of about 215k tets (weighted balls, ~1% and
~10% non-Delaunay tets) and random Delaunay balls of the same size with their interior
vertices jittered by 0.1 and 0.3 mean spacings. Each line: tets, non-Delaunay faces, the
assembly time of ``tetlap.operators(V, T, "dual", "circumcentric")`` in the same run,
``regular_weights`` time (wall and CPU), status, iterations, LPs, masses lost. With
``--compare OLD.py`` (a copy of an earlier ``tetlap/regular.py``, loaded as
``tetlap.regular_old``), that version runs on every case too, with ``--time-limit`` (its
budget was wall-clock; default 60 s). Run it alone: the machine has two cores.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import pathlib
import sys
import time
import warnings

import tetlap
import tetlap.io
from tetlap.experiments.regular_weights import jittered_ball
from tetlap.regular import regular_weights

SUFFIXES = {".mesh", ".msh", ".vtu", ".vtk", ".ele"}


def cases(folder, big):
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


def load(path):
    """An earlier regular.py as the module ``tetlap.regular_old``."""
    spec = importlib.util.spec_from_file_location("tetlap.regular_old", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["tetlap.regular_old"] = module
    spec.loader.exec_module(module)
    return module


def timed(function, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default=str(pathlib.Path(__file__).resolve().parents[2]
                                                / "shared" / "data" / "meshes"))
    parser.add_argument("--big", action="store_true", help="add the generated 215k-tet meshes")
    parser.add_argument("--compare", metavar="OLD.py", help="an earlier regular.py to time too")
    parser.add_argument("--time-limit", type=float, default=60.0,
                        help="the earlier version's wall-clock budget (s)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    old = load(args.compare) if args.compare else None
    for name, read in cases(args.meshes, args.big):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = read()
        _, assembly, _ = timed(tetlap.operators, V, T, "dual", "circumcentric")
        r, wall, cpu = timed(regular_weights, V, T)
        record = {"mesh": name, "n_tets": len(T), "non_delaunay_faces": r.n_violated_plain,
                  "assembly_s": round(assembly, 3), "seconds": round(wall, 2),
                  "cpu_seconds": round(cpu, 2), "status": r.status,
                  "certificate": r.certificate_kind, "iterations": r.iterations,
                  "lp_count": r.lp_count, "masses_lost": int(len(r.masses_lost)),
                  "verification": r.verification}
        if old is not None:
            o, wall_old, cpu_old = timed(old.regular_weights, V, T, time_limit=args.time_limit)
            record.update(old_seconds=round(wall_old, 2), old_cpu_seconds=round(cpu_old, 2),
                          old_status=o.status, old_masses_lost=int(len(o.masses_lost)))
        if args.json:
            print(json.dumps(record), flush=True)
        else:
            line = (f"{name:<36} {len(T):>7} tets {r.n_violated_plain:>6} non-Del.  assembly "
                    f"{assembly:6.3f} s  regular_weights {wall:6.2f} s ({cpu:6.2f} CPU)  "
                    f"{r.status}, {r.iterations} iterations, {r.lp_count} LPs, "
                    f"{len(r.masses_lost)} masses lost")
            if old is not None:
                line += f"  | before: {wall_old:6.2f} s, {o.status}, {len(o.masses_lost)} lost"
            print(line, flush=True)


if __name__ == "__main__":
    main()
