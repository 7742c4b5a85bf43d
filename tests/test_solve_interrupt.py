"""Ctrl-C in tetlap.solve: the solves of a 750k-tet grid answer SIGINT within a second
(each call runs in a child process; see tests/test_interrupt.py)."""

from __future__ import annotations

import os
import signal
import sys
import textwrap
import time

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
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


# --- Ctrl-C frees the process: every factorization path ---------------------------------
#
# The probes announce the start of every factorization (SuperLU through scipy's splu and
# spsolve, the core's through tetlap._core.Factor and Factor.refactor), wherever it runs;
# the test sends SIGINT 0.5 s after the announcement it waits for. The probe then reports
# (a) when the KeyboardInterrupt came, (b) the CPU time it spent in the next second (a
# factorization abandoned on a thread goes on spending it) and (c) when it began to exit;
# the test checks that no child process is left and that the exit took under a second.

#: Prints "factorizing <what>" when a factorization starts.
ANNOUNCE = textwrap.dedent("""
    import numpy as _np, scipy.sparse.linalg as _sla, tetlap._core as _core

    def _announced(what, f):
        def call(*args, **kwargs):
            print("factorizing", what, flush=True)
            return f(*args, **kwargs)
        return call

    _sla.splu = _announced("splu", _sla.splu)
    _sla.spsolve = _announced("spsolve", _sla.spsolve)
    _core.Factor = _announced("Factor", _core.Factor)
    _np.linalg.eigvalsh = _announced("eigvalsh", _np.linalg.eigvalsh)

    class Refactor:
        def __init__(self, inner):
            self.inner = inner

        def refactor(self, *args, **kwargs):
            print("factorizing refactor", flush=True)
            return self.inner.refactor(*args, **kwargs)

        def __getattr__(self, name):
            return getattr(self.inner, name)
""")

FREE = RESTORE_SIGINT + ANNOUNCE + textwrap.dedent("""
    import sys, time, numpy as np, scipy.sparse as sp, tetlap
    from tetlap import solve
    from tetlap.solve.factor import Factor

    case = sys.argv[1]
    size = {"LL^T": 40, "LDL^T": 40, "refactor": 36, "lu": 24, "factor lu": 21, "kkt": 14,
            "replace": 28, "eigs": 44, "eigs lu": 24, "nsd": 28, "heat": 44,
            "harmonic": 44, "dense": 13}[case]
    V, T = tetlap.meshes.cube(size, jitter=0.2)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = tetlap.diagnostics.boundary_vertices(T, len(V))
    A = M - 1e-3 * L
    if case == "refactor":
        F = solve.factorize(A, ordering="amd")
        F._core = Refactor(F._core)
    calls = {
        "LL^T": lambda: solve.factorize(A, ordering="amd"),
        "LDL^T": lambda: Factor(A, "cholesky", "amd", False, method="ldlt"),
        "refactor": lambda: F.refactor(M - 2e-3 * L),
        "lu": lambda: solve.dirichlet(L, fixed, V[:, 0], solver="lu"),
        "factor lu": lambda: solve.factorize(A + 1e-3 * sp.triu(A, 1)),
        "kkt": lambda: solve.neumann_primal_kkt(L, V, T, lambda c, n: n[:, 0]),
        "replace": lambda: solve.dirichlet(L, fixed, V[:, 0], method="replace"),
        "eigs": lambda: solve.eigs(L, M, 10, fixed),
        "eigs lu": lambda: solve.eigs(L, M, 10, fixed, solver="lu"),
        "nsd": lambda: tetlap.analysis._ldl_inertia(sp.csr_array(-L), np.full(len(V), 1e-3)),
        "heat": lambda: tetlap.HeatDistance(V, T),
        "harmonic": lambda: tetlap.fields.harmonic(V, T, fixed, V[fixed, 0],
                                                   laplacian="primal"),
        "dense": lambda: tetlap.analysis._dense(L, np.abs(L.diagonal())),
    }
    print("ready", flush=True)
    start = time.time()
    try:
        calls[case]()
        print("finished", time.time() - start, flush=True)
    except KeyboardInterrupt:
        now = time.time()
        print("interrupted", now, flush=True)
        if case == "refactor":  # the factor was half overwritten: refused, not used
            try:
                F.solve(np.ones(len(V)))
                print("after: solved", flush=True)
            except tetlap.SolveError as e:
                print("after: refused", e, flush=True)
        cpu = time.process_time()
        time.sleep(1.0)
        print("cpu", time.process_time() - cpu, flush=True)
        print("exiting", time.time(), flush=True)
        sys.exit(3)
""")

#: The factorization each case is interrupted in (its first).
TARGET = {"LL^T": "Factor", "LDL^T": "Factor", "refactor": "refactor", "lu": "spsolve",
          "factor lu": "splu", "kkt": "splu", "replace": "spsolve", "eigs": "Factor",
          "eigs lu": "splu", "nsd": "splu", "heat": "Factor", "harmonic": "Factor",
          "dense": "eigvalsh"}


def until(p, prefix: str, timeout: float) -> str:
    """The child's first line starting with ``prefix`` (skipping others)."""
    end = time.time() + timeout
    while True:
        text = line(p, max(end - time.time(), 0.1))
        if text.startswith(prefix):
            return text
        assert not text.startswith("finished"), f"the call ended first: {text}"


@pytest.mark.slow
@pytest.mark.parametrize("case", list(TARGET))
def test_ctrl_c_during_a_factorization_frees_the_process(case):
    psutil = pytest.importorskip("psutil")
    with child(FREE, case) as p:
        until(p, "ready", 600)
        until(p, f"factorizing {TARGET[case]}", 300)
        time.sleep(0.5)
        sent = time.time()
        p.send_signal(signal.SIGINT)
        words = until(p, "interrupted", 120).split()
        assert float(words[1]) - sent < 1.0, (case, float(words[1]) - sent)
        assert psutil.Process(p.pid).children(recursive=True) == [], case
        if case == "refactor":
            assert until(p, "after", 60).startswith("after: refused")
        cpu = float(until(p, "cpu", 60).split()[1])
        assert cpu < 0.2, f"{case}: {cpu:.2f} s of CPU in the second after the interrupt"
        exiting = float(until(p, "exiting", 60).split()[1])
        p.wait(timeout=120)
        assert time.time() - exiting < 1.0, (case, time.time() - exiting)
        assert p.returncode == 3


def session_processes(sid: int) -> list:
    """The live (not zombie) processes of the session ``sid``."""
    psutil = pytest.importorskip("psutil")
    alive = []
    for proc in psutil.process_iter(["pid", "status"]):
        try:
            if os.getsid(proc.pid) == sid and proc.info["status"] != psutil.STATUS_ZOMBIE:
                alive.append(proc.pid)
        except (ProcessLookupError, PermissionError):
            pass
    return alive


@pytest.mark.slow
def test_the_geodesic_command_exits_at_once_on_ctrl_c(tmp_path):
    """``python -m tetlap geodesic`` (run through runpy, after the announcements) on a
    300k-tet mesh, interrupted in its first factorization: it exits with 130 within a
    second and leaves no process."""
    V, T = tetlap.meshes.cube(40, jitter=0.2)
    tetlap.io.write(tmp_path / "cube.vtu", V, T)
    code = RESTORE_SIGINT + ANNOUNCE + textwrap.dedent(f"""
        import runpy, sys
        sys.argv = ["tetlap", "geodesic", {str(tmp_path / "cube.vtu")!r}, "--source", "0",
                    "--out", {str(tmp_path / "d.vtu")!r}]
        runpy.run_module("tetlap", run_name="__main__")
    """)
    with child(code) as p:
        until(p, "factorizing Factor", 600)
        time.sleep(0.5)
        sent = time.time()
        p.send_signal(signal.SIGINT)
        p.wait(timeout=120)
        assert time.time() - sent < 1.0, time.time() - sent
        assert p.returncode == 130
        assert session_processes(p.pid) == []


# --- the same answers, wherever the factorization runs -----------------------------------

def _heat_matrix(k: int):
    from tetlap.solve.factor import canonical

    V, T = tetlap.meshes.cube(k, jitter=0.2)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    return canonical(M - 1e-3 * L), canonical(M - 2e-3 * L)


@pytest.mark.parametrize("method", ["cholesky", "ldlt"])
def test_a_factorization_in_a_child_process_is_bitwise_the_same(method):
    from tetlap import _core, _sparse

    A, A2 = _heat_matrix(8)
    n = A.shape[0]
    b = np.random.default_rng(0).standard_normal((2, n))
    here = _core.Factor(n, _sparse.arrays(A), method, None, child=False)
    there = _core.Factor(n, _sparse.arrays(A), method, None, child=True)
    assert not here.in_child and there.in_child == sys.platform.startswith("linux")
    assert here.solve(b).tobytes() == there.solve(b).tobytes()
    assert here.inertia() == there.inertia() and here.smallest_pivot() == there.smallest_pivot()
    here.refactor(n, _sparse.arrays(A2), child=False)
    there.refactor(n, _sparse.arrays(A2), child=True)
    assert here.solve(b).tobytes() == there.solve(b).tobytes()
    there.refactor(n, _sparse.arrays(A2), child=False)  # back into this process
    assert not there.in_child and here.solve(b).tobytes() == there.solve(b).tobytes()
    # by default, by the size of the factor
    assert not _core.Factor(n, _sparse.arrays(A), method, None).in_child
    assert here.factor_entries < _core.FACTOR_CHILD_MIN


@pytest.mark.parametrize("child", [None, True])
def test_a_refactor_that_fails_leaves_no_factor_to_solve_with(child):
    """An LDL^T refactor that meets a zero pivot (or is interrupted) has overwritten the
    factor: solving with what is left would be wrong, so it is refused until a refactor
    succeeds."""
    from tetlap import _core, _sparse

    A, _ = _heat_matrix(5)
    n = A.shape[0]
    b = np.ones((1, n))
    kw = {} if child is None else {"child": child}
    F = _core.Factor(n, _sparse.arrays(A), "ldlt", None, **kw)
    x = F.solve(b)
    zero = sp.csr_array((np.zeros(A.nnz), A.indices, A.indptr), shape=A.shape)
    with pytest.raises(tetlap.SolveError, match="zero pivot"):
        F.refactor(n, _sparse.arrays(zero), **kw)
    for call in (lambda: F.solve(b), F.inertia, F.smallest_pivot):
        with pytest.raises(tetlap.SolveError, match="refactor"):
            call()
    F.refactor(n, _sparse.arrays(A), **kw)
    assert F.solve(b).tobytes() == x.tobytes()


def test_superlu_in_a_child_process_gives_the_same_factors(monkeypatch):
    from scipy.sparse.linalg import splu, spsolve

    from tetlap import _interrupt

    A, _ = _heat_matrix(6)
    A = sp.csc_array(A + 1e-3 * sp.triu(A, 1))  # not symmetric
    b = np.random.default_rng(1).standard_normal(A.shape[0])
    monkeypatch.setattr(_interrupt, "CHILD_MIN_ROWS", 10**9)
    here = _interrupt.splu(A)
    monkeypatch.setattr(_interrupt, "CHILD_MIN_ROWS", 0)
    there = _interrupt.splu(A)
    scipy_lu = splu(A)
    for lu in (here, there):
        for name in ("L", "U"):
            mine, theirs = getattr(lu, name), getattr(scipy_lu, name)
            theirs.sort_indices()
            for part in ("data", "indices", "indptr"):
                assert np.array_equal(getattr(mine, part), getattr(theirs, part)), (name, part)
        assert np.array_equal(lu.perm_r, scipy_lu.perm_r)
        assert np.array_equal(lu.perm_c, scipy_lu.perm_c)
    x = here.solve(b)
    assert x.tobytes() == there.solve(b).tobytes()
    np.testing.assert_allclose(x, scipy_lu.solve(b), rtol=1e-12)
    X = here.solve(np.column_stack([b, 2 * b]))
    assert X.shape == (len(b), 2) and X[:, 0].tobytes() == x.tobytes()
    assert _interrupt.spsolve(A, b).tobytes() == spsolve(A, b).tobytes()
    with pytest.raises(RuntimeError, match="singular"):
        _interrupt.splu(sp.csc_array(A.shape))


# --- SIGTERM: the child processes die with their parent and leave no file -------------------

TERM = RESTORE_SIGINT + textwrap.dedent("""
    import sys, tetlap
    from tetlap.solve.factor import canonical, nested_dissection

    k = {"metis": 50, "factorization": 40}[sys.argv[1]]
    V, T = tetlap.meshes.cube(k, jitter=0.2)  # 132k vertices: METIS in a child
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    A = canonical(M - 1e-3 * L)
    print("ready", flush=True)
    if sys.argv[1] == "metis":
        nested_dissection(A)
    else:
        tetlap.solve.factorize(A, ordering="amd")
""")


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["metis", "factorization"])
def test_sigterm_leaves_no_process_and_no_file(tmp_path, phase):
    import subprocess

    folder = tmp_path / "tmp"
    folder.mkdir()
    p = subprocess.Popen([sys.executable, "-c", TERM, phase], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True, start_new_session=True,
                         env=dict(os.environ, TMPDIR=str(folder)))
    try:
        assert line(p, 300) == "ready"
        assert wait_for_a_child(p.pid, 60)
        time.sleep(0.3)
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=60)
        end = time.time() + 2.0
        while session_processes(p.pid) and time.time() < end:
            time.sleep(0.05)
        assert session_processes(p.pid) == [], "a child outlived its parent"
        assert list(folder.iterdir()) == []
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
        for pid in session_processes(p.pid):
            os.kill(pid, signal.SIGKILL)
        p.wait()


def wait_for_a_child(pid: int, limit: float) -> bool:
    """Whether the process ``pid`` has a child process within ``limit`` seconds."""
    psutil = pytest.importorskip("psutil")
    end = time.time() + limit
    while time.time() < end:
        if psutil.Process(pid).children():
            return True
        time.sleep(0.02)
    return False
