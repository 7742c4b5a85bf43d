"""The solves of tetlap.solve at 1M tets, next to one assembly and the baselines, in one run
(tetlap.benchmark_solve; also ``tetlap bench --solve``).

    python benches/solve.py [--meshes NAME ...] [--cases CASE ...] [--cap SECONDS] [--json]

Default: every mesh and case of tetlap.benchmark_solve, the old SuperLU path and libigl
killed after --cap seconds (default 300). Run it alone: the machine has two cores.
"""

from __future__ import annotations

import argparse
import json

from tetlap import benchmark_solve

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("--meshes", nargs="+", choices=list(benchmark_solve.MESHES),
               default=list(benchmark_solve.MESHES))
p.add_argument("--cases", nargs="+", choices=benchmark_solve.CASES, default=list(benchmark_solve.CASES))
p.add_argument("--cap", type=float, default=300.0)
p.add_argument("--json", action="store_true")
args = p.parse_args()
records = benchmark_solve.run(args.meshes, args.cases, args.cap)
print(json.dumps(records, indent=1) if args.json else benchmark_solve.table(records))
