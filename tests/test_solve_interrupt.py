"""Ctrl-C in tetlap.solve: the solves of a 750k-tet grid answer SIGINT within a second
(each call runs in a child process; see tests/test_interrupt.py)."""

from __future__ import annotations

import signal
import textwrap
import time

import pytest

from test_interrupt import LOOP, RESTORE_SIGINT, child, line

PROBE = RESTORE_SIGINT + textwrap.dedent("""
    import sys, time, numpy as np, tetlap
    V, T = tetlap.meshes.cube(50, jitter=0.2)  # 750k tets, 132k vertices
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = tetlap.diagnostics.boundary_vertices(T, len(V))
    calls = {
        "dirichlet amg": lambda: tetlap.solve.dirichlet(L, fixed, V[:, 0] ** 2, solver="amg"),
        "dirichlet cholesky": lambda: tetlap.solve.dirichlet(L, fixed, V[:, 0] ** 2,
                                                             solver="cholesky"),
        "factorize": lambda: tetlap.solve.factorize(M - 1e-3 * L),
        "eigs": lambda: tetlap.solve.eigs(L, M, 10, fixed),
    }
""") + LOOP


@pytest.mark.slow
@pytest.mark.parametrize("call", ["dirichlet amg", "dirichlet cholesky", "factorize", "eigs"])
def test_solves_answer_ctrl_c_within_a_second(call):
    best = float("inf")
    for delay in (0.8, 2.5):  # inside the ordering, then inside the factorization or CG
        with child(PROBE, call) as p:
            assert line(p, 600) == "ready"
            time.sleep(delay)
            sent = time.time()
            p.send_signal(signal.SIGINT)
            words = line(p, 120).split()
            assert words[:1] == ["interrupted"], (call, words)
            assert p.wait(timeout=120) == 3
            best = min(best, float(words[1]) - sent)
            assert float(words[1]) - sent < 1.0, (call, delay, float(words[1]) - sent)
