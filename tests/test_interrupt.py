"""Ctrl-C: every long call answers SIGINT within half a second with KeyboardInterrupt."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import pytest

PROBE = textwrap.dedent("""
    import sys, time, tetlap
    V, T = tetlap.meshes.cube(50, jitter=0.2)  # 750k tets
    L = tetlap.laplacian(V, T, "dual")
    mesh = tetlap.Mesh(V, T)
    calls = {
        "laplacian": lambda: tetlap.laplacian(V, T, "dual", threads=1),
        "operators": lambda: tetlap.operators(V, T, "dual", "circumcentric", threads=1),
        "Mesh": lambda: tetlap.Mesh(V, T, threads=1),
        "Mesh.update": lambda: (mesh.laplacian("dual"), mesh.update(V * 1.0001),
                                mesh.update(V)),
        "check": lambda: tetlap.check(L, V, T, kind="dual"),
        "diagnostics": lambda: tetlap.diagnostics.summary(V, T),
        "info": lambda: tetlap.info.report(V, T, progress=False),
    }
    print("ready", flush=True)
    try:
        for _ in range(100):
            calls[sys.argv[1]]()
    except KeyboardInterrupt:
        print("interrupted", time.time(), flush=True)
        sys.exit(3)
""")

CALLS = ["laplacian", "operators", "Mesh", "Mesh.update", "check", "diagnostics", "info"]


def interrupt(call: str) -> float:
    """Seconds from SIGINT to the KeyboardInterrupt of ``call`` running in a subprocess."""
    p = subprocess.Popen([sys.executable, "-c", PROBE, call], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(0.8)  # well inside the calls
    sent = time.time()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 3, (call, p.returncode, out)
    return float(out.split()[1]) - sent


def test_assembly_answers_ctrl_c():
    assert interrupt("laplacian") < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("call", CALLS[1:])
def test_every_long_call_answers_ctrl_c(call):
    assert interrupt(call) < 0.5


@pytest.mark.slow
def test_an_interrupted_update_leaves_the_mesh_as_it_was():
    code = textwrap.dedent("""
        import signal, threading, time, os, numpy as np, tetlap
        V, T = tetlap.meshes.cube(50, jitter=0.2)
        mesh = tetlap.Mesh(V, T, threads=1)
        before = mesh.laplacian("dual").data.copy()
        threading.Timer(0.05, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        try:
            for _ in range(50):
                mesh.update(V * 1.5)
                mesh.update(V)
        except KeyboardInterrupt:
            pass
        after = mesh.laplacian("dual").data
        V_now = mesh.V
        assert np.array_equal(V_now, V) or np.array_equal(V_now, V * 1.5)
        fresh = tetlap.laplacian(V_now, T, "dual").data
        assert after.tobytes() == fresh.tobytes()
        print("consistent")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "consistent" in out.stdout, out.stderr
