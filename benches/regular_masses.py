"""Masses lost by tetlap.regular.regular_weights on the corpus meshes of issue 16.

    OPENBLAS_NUM_THREADS=1 python benches/regular_masses.py [--meshes DIR] [--json]

Per mesh: status, margin, positive plain circumcentric masses that the weights make
non-positive (``masses_lost``), masses below the floor, the time of ``regular_weights``,
non-positive masses plain / weighted and the vertices with a non-zero weight (columns of
EXPERIMENTS.md section 7). The meshes are the regular ones whose masses the mass step used to
lose (EXPERIMENTS.md section 7) and the fish (0 lost). Run it alone: two cores.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time
import warnings

import tetlap
import tetlap.io
from tetlap.regular import regular_weights

MESHES = ("flipfree_octopus_vol.mesh", "flipfree_monkey_87k.mesh",
          "flipfree_armadillo_74k.mesh", "libigl_car.msh", "simnibs_sphere3.msh",
          "libigl_decimated_knight.mesh", "mmg_tinybox.mesh", "flipfree_fish_blub.mesh")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default="../shared/data/meshes")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--mass-floor", type=float, default=0.1)
    parser.add_argument("names", nargs="*", default=list(MESHES))
    args = parser.parse_args()
    rows = []
    for name in args.names:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = tetlap.io.read(pathlib.Path(args.meshes) / name)
        t = time.perf_counter()
        r = regular_weights(V, T, mass_floor=args.mass_floor)
        seconds = time.perf_counter() - t
        m0 = tetlap.mass(V, T, "circumcentric").diagonal()
        m = tetlap.mass(V, T, "circumcentric", weights=r.weights, degenerate="skip").diagonal()
        row = {"mesh": name, "tets": len(T), "status": r.status, "margin": r.margin,
               "masses_lost": int(len(r.masses_lost)),
               "masses_below_floor": int(len(r.masses_below_floor)),
               "seconds": round(seconds, 2), "non_positive_plain": int((m0 <= 0).sum()),
               "non_positive_weighted": int((m <= 0).sum()),
               "weighted_vertices": r.n_weighted_vertices}
        rows.append(row)
        if args.json:
            print(json.dumps(row), flush=True)
        else:
            print(f"| `{name}` | {len(T):,} | {r.status} | {r.margin:+.2e} | "
                  f"{row['masses_lost']} | {row['masses_below_floor']} | {seconds:.2f} | "
                  f"{row['non_positive_plain']} / {row['non_positive_weighted']} | "
                  f"{r.n_weighted_vertices} |",
                  flush=True)
            for note in r.notes:
                if "mass" in note:
                    print(f"    note: {note}", flush=True)


if __name__ == "__main__":
    main()
