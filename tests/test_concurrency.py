"""Threads: the GIL released during assembly, concurrent calls equal to serial ones, a Mesh
shared between Python threads, bounded worker threads, one pool per count, determinism
for any count."""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import tetlap


def test_concurrent_readers_of_a_mesh_see_the_cached_operator():
    V, T = tetlap.meshes.cube(8, jitter=0.2, seed=1)
    mesh = tetlap.Mesh(V, T)
    reference = mesh.laplacian("dual")
    with ThreadPoolExecutor(max_workers=8) as pool:
        results = list(pool.map(lambda _: mesh.laplacian("dual"), range(64)))
    assert all((L != reference).nnz == 0 for L in results)


def test_first_requests_from_many_threads_compute_once_and_agree():
    V, T = tetlap.meshes.cube(8, jitter=0.2, seed=2)
    mesh = tetlap.Mesh(V, T)
    kinds = ["primal", "dual", 0.25, 0.75] * 8
    with ThreadPoolExecutor(max_workers=8) as pool:
        results = list(pool.map(mesh.laplacian, kinds))
    for kind, L in zip(kinds, results):
        assert (L != tetlap.laplacian(V, T, kind)).nnz == 0


def test_updates_concurrent_with_reads_are_serialised():
    """Every read sees the mesh before or after an update, never in between."""
    V, T = tetlap.meshes.cube(6, jitter=0.2, seed=3)
    geometries = [V, V * 1.5, V * 2.0]
    fresh = [tetlap.laplacian(G, T, "dual").data.tobytes() for G in geometries]
    mesh = tetlap.Mesh(V, T)
    mesh.laplacian("dual")
    seen: list[bytes] = []
    stop = threading.Event()

    def read():
        while not stop.is_set():
            seen.append(mesh.laplacian("dual").data.tobytes())

    readers = [threading.Thread(target=read) for _ in range(4)]
    for r in readers:
        r.start()
    for k in (1, 2, 0, 1, 2):
        mesh.update(geometries[k])
        time.sleep(0.01)
    stop.set()
    for r in readers:
        r.join()
    assert seen and set(seen) <= set(fresh)


@pytest.mark.parametrize("threads", [0, -1, 10**9, 2**64, 1.5, True, "2"])
def test_thread_counts_are_bounded(threads):
    V, T = tetlap.meshes.cube(2)
    start = time.perf_counter()
    with pytest.raises(tetlap.OptionError, match="threads"):
        tetlap.laplacian(V, T, threads=threads)
    with pytest.raises(tetlap.OptionError, match="threads"):
        tetlap.Mesh(V, T, threads=threads)
    assert time.perf_counter() - start < 1.0  # refused, not started
    assert tetlap.MAX_THREADS >= 8


def test_the_largest_thread_count_works_and_gives_the_same_bits():
    V, T = tetlap.meshes.cube(5, jitter=0.2, seed=4)
    reference = tetlap.operators(V, T, "dual", "circumcentric", threads=1)
    for threads in (2, 3, tetlap.MAX_THREADS, None):
        L, M = tetlap.operators(V, T, "dual", "circumcentric", threads=threads)
        assert L.data.tobytes() == reference[0].data.tobytes()
        assert M.data.tobytes() == reference[1].data.tobytes()


def test_repeated_calls_with_a_thread_count_reuse_its_pool():
    V, T = tetlap.meshes.cube(2)
    tetlap.laplacian(V, T, threads=3)
    before = threading.active_count()
    for _ in range(50):
        tetlap.laplacian(V, T, threads=3)
    assert threading.active_count() == before  # no Python threads left behind
    with open("/proc/self/status") as f:
        native = int(next(line for line in f if line.startswith("Threads:")).split()[1])
    assert native < 200, native  # pools are kept per count, not per call


def test_mesh_of_triangles_is_thread_safe_too():
    g = np.linspace(0, 1, 9)
    V = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    idx = np.arange(81).reshape(9, 9)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    T = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    mesh = tetlap.Mesh(V, T)
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(lambda k: mesh.mass(k), ["barycentric", "circumcentric"] * 8))
    assert all(abs(M.sum() - 1) < 1e-12 for M in results)


def test_the_gil_is_released_during_assembly():
    V, T = tetlap.meshes.cube(36, jitter=0.1)  # 280k tets: ~0.1-0.3 s
    start = time.perf_counter()
    tetlap.operators(V, T, "dual", "circumcentric", threads=1)
    serial = time.perf_counter() - start
    ticks = 0
    done = threading.Event()

    def work():
        tetlap.operators(V, T, "dual", "circumcentric", threads=1)
        done.set()

    thread = threading.Thread(target=work)
    thread.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    thread.join()
    # with the GIL held the loop could tick at most once or twice before the call returned
    assert serial > 0.02, "the call is too short to tell"
    assert ticks >= 5, (ticks, serial)


def test_concurrent_calls_equal_serial_calls():
    meshes = [tetlap.meshes.cube(k, jitter=0.2, seed=k) for k in (3, 5, 7, 9)]
    jobs = [(V, T, kind) for V, T in meshes for kind in ("primal", "dual", 0.5)] * 2

    def run(job):
        V, T, kind = job
        L, M = tetlap.operators(V, T, kind, "circumcentric")
        return L.data.tobytes(), M.data.tobytes()

    serial = [run(j) for j in jobs]
    with ThreadPoolExecutor(max_workers=6) as pool:
        parallel = list(pool.map(run, jobs))
    assert parallel == serial


# A child with RAYON_NUM_THREADS set: threads=None obeys the bound of threads= (an
# OptionError naming the variable, before any thread starts), an explicit count ignores
# the variable, and the native threads stay few. The timeout ends a child that starts
# threads without bound (what rayon's global pool did with 100000).
_ENVIRONMENT_CHILD = r"""
import json, sys
import numpy as np
import tetlap
V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1.]])
T = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])
out = {"explicit": tetlap.laplacian(V, T, threads=2).nnz,
       "mesh": tetlap.Mesh(V, T, threads=1).laplacian().nnz}
try:
    out["default"] = tetlap.laplacian(V, T).nnz
except tetlap.OptionError as e:
    out["error"] = str(e)
with open("/proc/self/status") as f:
    out["native"] = int(next(l for l in f if l.startswith("Threads:")).split()[1])
print(json.dumps(out))
"""


@pytest.mark.parametrize("value, accepted", [  # every case: the core's threads tests
    ("100000", False), ("-3", False), ("abc", False), ("0", True), ("MAX", True)])
def test_rayon_num_threads_obeys_the_bound_of_threads(value, accepted):
    import json
    import os
    import subprocess
    import sys

    value = str(tetlap.MAX_THREADS) if value == "MAX" else value
    env = {**os.environ, "RAYON_NUM_THREADS": value}
    out = subprocess.run([sys.executable, "-c", _ENVIRONMENT_CHILD], env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout)
    assert result["explicit"] == result["mesh"] == 23
    if accepted:
        assert result["default"] == 23 and "error" not in result
    else:
        assert "default" not in result
        assert f'RAYON_NUM_THREADS is "{value}"' in result["error"]
        assert str(tetlap.MAX_THREADS) in result["error"]
    assert result["native"] <= 3 * tetlap.MAX_THREADS + 8, result


def test_options_check_the_environment_before_any_work(monkeypatch):
    from tetlap import _options

    monkeypatch.setenv("RAYON_NUM_THREADS", "100000")
    with pytest.raises(tetlap.OptionError, match="RAYON_NUM_THREADS"):
        _options.threads(None, "--threads")
    assert _options.threads(2) == 2
    monkeypatch.setenv("RAYON_NUM_THREADS", "1")
    assert _options.threads(None) is None
