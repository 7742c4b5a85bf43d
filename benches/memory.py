"""Peak memory of one-shot assembly, each case in a fresh process.

    python benches/memory.py [--size 1M]

Reports, per case, the peak resident set size (VmHWM, reset through
/proc/self/clear_refs once the inputs are loaded) above the resident size at that point, against the size of the inputs (V float64, T int64) plus the outputs
(CSR arrays of L, diagonal or CSR M): the issue's target is a peak of at most twice
(inputs + outputs), i.e. ``(inputs + extra peak) / (inputs + outputs) <= 2``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile

CASE = r"""
import json, sys
import numpy as np
import tetlap

def status(key):  # kB, from /proc/self/status
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1])

data = np.load(sys.argv[1])
V, T = data["V"].copy(), data["T"].copy()
del data
tetlap.laplacian(tetlap.meshes.cube(1)[0], tetlap.meshes.cube(1)[1])  # load everything once
open("/proc/self/clear_refs", "w").write("5")  # reset the peak (VmHWM) to the current RSS
before = status("VmRSS")
case = sys.argv[2]
if case == "primal":
    out = [tetlap.laplacian(V, T, "primal")]
elif case == "dual+circumcentric":
    out = list(tetlap.operators(V, T, "dual", "circumcentric"))
elif case == "Mesh dual+circumcentric":
    mesh = tetlap.Mesh(V, T)
    out = list(mesh.operators("dual", "circumcentric"))
    mesh.update(V * 1.001)
after = status("VmHWM")
nbytes = lambda A: A.data.nbytes + A.indices.nbytes + A.indptr.nbytes
print(json.dumps({"case": case, "n_tets": len(T), "peak_mb": (after - before) / 1024,
                  "inputs_mb": (V.nbytes + T.nbytes) / 2**20,
                  "outputs_mb": sum(nbytes(A) for A in out) / 2**20}))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", default="1M", choices=["10k", "100k", "1M", "4M"])
    args = parser.parse_args()
    import numpy as np

    import tetlap
    from tetlap.benchmark import SIZES

    V, T = tetlap.meshes.cube(SIZES[args.size], jitter=0.2, seed=0)
    path = tempfile.NamedTemporaryFile(suffix=".npz", delete=False).name
    np.savez(path, V=V, T=T)
    print(f"{'case':<26} {'tets':>9} {'inputs MB':>10} {'outputs MB':>11} "
          f"{'extra peak MB':>14} {'(in+extra)/(in+out)':>20}")
    for case in ("primal", "dual+circumcentric", "Mesh dual+circumcentric"):
        res = subprocess.run([sys.executable, "-c", CASE, path, case], capture_output=True,
                             text=True, check=True)
        r = json.loads(res.stdout)
        io = r["inputs_mb"] + r["outputs_mb"]
        print(f"{r['case']:<26} {r['n_tets']:>9} {r['inputs_mb']:>10.1f} {r['outputs_mb']:>11.1f} "
              f"{r['peak_mb']:>14.1f} {(r['inputs_mb'] + r['peak_mb']) / io:>20.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
