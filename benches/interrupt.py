"""What it costs to run the factorizations in a child process (so that Ctrl-C stops them):
the fork of a process holding a 1M-tet mesh, and every factorization in this process and
in a child, alternated in one run (medians).

    python benches/interrupt.py [--k 55] [--repeat 3]

Rows: the fork itself (``os.fork`` + ``_exit`` + ``waitpid``; the core's ``Factor`` of a
tiny matrix with ``child=True`` less ``child=False``); the core's numeric ``LL^T`` of heat
matrices ``M - 1e-3 L`` of cubes (nested dissection computed once) and of the big mesh,
and its refactor, here and in a child; SciPy's SuperLU of the non-symmetric
``M - 1e-3 L + 1e-3 triu(M - 1e-3 L)`` here and through ``tetlap._interrupt.splu`` (a
child, the factors brought back), and one solve with each. Run it alone: the machine has
two cores.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
import scipy.sparse as sp

import tetlap
from tetlap import _core, _interrupt, _sparse
from tetlap.solve.factor import canonical, nested_dissection


def timed(f, repeat):
    out = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        out.append(time.perf_counter() - start)
    return statistics.median(out)


def rss_gb() -> float:
    with open(f"/proc/{os.getpid()}/status") as status:
        kb = next(int(x.split()[1]) for x in status if x.startswith("VmRSS"))
    return kb / 2**20


def heat(k):
    V, T = tetlap.meshes.cube(k, jitter=0.2)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    return canonical(M - 1e-3 * L), len(T)


def fork():
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    os.waitpid(pid, 0)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--k", type=int, default=55, help="the big cube: 6 k^3 tets")
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args()
    r = args.repeat
    core = lambda A, o, child: _core.Factor(A.shape[0], _sparse.arrays(A), "cholesky", o,  # noqa: E731
                                            child=child)

    def here_and_there(A, o):
        """Medians of the core's factorization of A here and in a child, alternated."""
        times = {False: [], True: []}
        for i in range(r):
            for child in (False, True) if i % 2 == 0 else (True, False):
                start = time.perf_counter()
                F = core(A, o, child)
                times[child].append(time.perf_counter() - start)
                entries = F.factor_entries
                del F
        return entries, statistics.median(times[False]), statistics.median(times[True])

    print("core LL^T (nested dissection given) | tets | factor entries | here s | child s | ratio")
    for k in (8, 12, 16, 20, 24, 30):
        A, m = heat(k)
        entries, th, tc = here_and_there(A, nested_dissection(A))
        print(f"cube({k}) | {m} | {entries} | {th:.3f} | {tc:.3f} | {tc / th:.2f}")
    big, tets = heat(args.k)
    order = nested_dissection(big)
    entries, th, tc = here_and_there(big, order)
    print(f"cube({args.k}) | {tets} | {entries} | {th:.3f} | {tc:.3f} | {tc / th:.2f}")
    b = np.ones((1, big.shape[0]))
    here, there = core(big, order, False), core(big, order, True)
    assert here.solve(b).tobytes() == there.solve(b).tobytes()
    n = big.shape[0]
    th = timed(lambda: here.refactor(n, _sparse.arrays(big), child=False), r)
    tc = timed(lambda: there.refactor(n, _sparse.arrays(big), child=True), r)
    print(f"refactor cube({args.k}) | {tets} | {entries} | {th:.3f} | {tc:.3f} | {tc / th:.2f}")
    sh, sc = timed(lambda: here.solve(b), r), timed(lambda: there.solve(b), r)
    print(f"one solve: heap {sh:.3f} s, shared memory {sc:.3f} s (bitwise the same answer)")

    # the fork in a process holding the 1M-tet mesh, its operators and two factors
    V, T = tetlap.meshes.cube(args.k, jitter=0.2)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    tiny, _ = heat(2)
    t_fork = timed(fork, 5)
    t_tiny = timed(lambda: core(tiny, None, True), 5) - timed(lambda: core(tiny, None, False), 5)
    print(f"\nin a process of {rss_gb():.2f} GB: fork + exit + wait {1e3 * t_fork:.0f} ms; "
          f"a tiny Factor in a child +{1e3 * t_tiny:.0f} ms")
    del here, there, V, T, L, M

    from scipy.sparse.linalg import splu

    print("\nSuperLU | rows | L+U entries | splu s | splu + L, U s | child s | solve s | core solve s")
    _interrupt.CHILD_MIN_ROWS = 0  # every size in a child
    for k in (8, 12, 16, 20):
        A, _ = heat(k)
        A = sp.csc_array(A + 1e-3 * sp.triu(A, 1))
        t_here = timed(lambda: splu(A), r)
        t_factors = timed(lambda: _interrupt._superlu_factors(A, {}), r)
        t_child = timed(lambda: _interrupt.splu(A), r)
        lu, ours = splu(A), _interrupt.splu(A)
        x = np.ones(A.shape[0])
        print(f"cube({k}) | {A.shape[0]} | {lu.L.nnz + lu.U.nnz} | {t_here:.3f} | {t_factors:.3f} | "
              f"{t_child:.3f} | {timed(lambda: lu.solve(x), 5):.4f} | "
              f"{timed(lambda: ours.solve(x), 5):.4f}")


if __name__ == "__main__":
    main()
