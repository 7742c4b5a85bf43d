"""Strong and weak scaling of tetlap.distributed.assemble, and memory per rank.

    mpirun -n R python benches/distributed_scaling.py FOLDER

FOLDER holds points.npy / tets.npy (made by --make K: a jittered Kuhn grid, 6 K^3 tets).
Prints, on rank 0, the median wall time of assemble (L dual + circumcentric M) over 3 runs
and the peak resident memory of every rank (VmHWM) per million of its tets.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np


def make(folder, k):
    import tetlap

    V, T = tetlap.meshes.cube(k, jitter=0.2, seed=0)
    os.makedirs(folder, exist_ok=True)
    np.save(os.path.join(folder, "points.npy"), V)
    np.save(os.path.join(folder, "tets.npy"), T.astype(np.int32))
    print(f"{len(T)} tets, {len(V)} vertices in {folder}")


def main():
    if sys.argv[1] == "--make":
        return make(sys.argv[3], int(sys.argv[2]))
    from mpi4py import MPI

    from tetlap import distributed

    comm = MPI.COMM_WORLD
    folder = sys.argv[1]
    points, tets = os.path.join(folder, "points.npy"), os.path.join(folder, "tets.npy")
    times = []
    for _ in range(3):
        comm.Barrier()
        start = time.perf_counter()
        L, M = distributed.assemble(points, tets, "dual", "circumcentric")
        comm.Barrier()
        times.append(time.perf_counter() - start)
        L.destroy()
        M.destroy()
    m = np.load(tets, mmap_mode="r").shape[0]
    hwm = int(next(line.split()[1] for line in open("/proc/self/status") if line.startswith("VmHWM")))
    peaks = comm.gather(hwm / 1024)
    if comm.rank == 0:
        share = m / comm.size / 1e6
        print(f"ranks {comm.size}  tets {m}  assemble median {np.median(times):.3f} s  "
              f"peak MB per rank {', '.join(f'{p:.0f}' for p in peaks)}  "
              f"(= {max(peaks) / share:.0f} MB per million tets of a rank's share, "
              f"interpreter and libraries included)")


if __name__ == "__main__":
    main()
