"""The block Lanczos engine of tetlap.solve.eigs, tested like the core: against dense
eigenvalues on random meshes, against ARPACK (the previous engine) to 1e-9, against the
analytic spectra of the ball and the cube, on exact and near multiplicities, on
indefinite duals, and for what it promises of its modes (M-orthonormal, signs, exact
constant modes, the same bits for any thread count)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import eigh

import tetlap
from tetlap import diagnostics as d
from tetlap import solve
from tetlap.solve import _eigs, _lanczos


def _dense(L, M, fixed=None):
    """All eigenvalues of the free block of the pencil (vertices in elements only)."""
    free = _eigs._in_elements(L)
    if fixed is not None:
        free &= ~fixed
    A = (-L[free][:, free]).toarray()
    B = M[free][:, free].toarray()
    return eigh(A, B, eigvals_only=True)


def _sym_cube(k: int):
    """The unit cube in k^3 cells, each split into 24 tets about its centre and its face
    centres: the mesh has every symmetry of the cube (exact multiplicities)."""
    g = np.arange(k + 1) / k
    corner = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    index = {tuple(np.round(p * 2 * k).astype(int)): i for i, p in enumerate(corner)}
    points = list(corner)

    def at(p):
        key = tuple(np.round(np.asarray(p) * 2 * k).astype(int))
        if key not in index:
            index[key] = len(points)
            points.append(np.asarray(p, dtype=float))
        return index[key]

    tets = []
    h = 1.0 / k
    for i in range(k):
        for j in range(k):
            for l in range(k):
                o = np.array([i, j, l]) * h
                c = at(o + h / 2)
                for axis in range(3):
                    for side in (0, 1):
                        f = o + h / 2
                        f[axis] = o[axis] + side * h
                        fc = at(f)
                        a, b = [x for x in range(3) if x != axis]
                        quad = []
                        for da, db in ((0, 0), (1, 0), (1, 1), (0, 1)):
                            p = o.copy()
                            p[axis] += side * h
                            p[a] += da * h
                            p[b] += db * h
                            quad.append(at(p))
                        for e in range(4):
                            tets.append([quad[e], quad[(e + 1) % 4], fc, c])
    return np.array(points), np.array(tets)


def _mesh(kind, seed):
    if kind == "ball":
        return tetlap.meshes.ball(1200, seed=seed)
    if kind == "jittered cube":
        return tetlap.meshes.cube(9, jitter=0.25, seed=seed)
    if kind == "shell":
        V, T, _ = tetlap.meshes.shell(2000, seed=seed)
        return V, T
    raise ValueError(kind)


CASES = [
    (kind, lap, mass, boundary, seed)
    for kind, seed in (("ball", 1), ("jittered cube", 2), ("shell", 3))
    for lap, mass in (("primal", "barycentric"), ("primal", "fem"), ("dual", "mixed"))
    for boundary in ("fixed", "free")
]


@pytest.mark.parametrize("kind, lap, mass, boundary, seed", CASES)
def test_the_k_smallest_agree_with_dense_eigenvalues(kind, lap, mass, boundary, seed):
    V, T = _mesh(kind, seed)
    L, M = tetlap.operators(V, T, lap, mass)
    fixed = d.boundary_vertices(T, len(V)) if boundary == "fixed" else np.zeros(len(V), bool)
    assert (~fixed).sum() > _eigs.DENSE_MAX
    reference = _dense(L, M, fixed)
    k = 24
    lam, vec, info = solve.eigs(L, M, k, fixed if boundary == "fixed" else None,
                                return_info=True)
    top = np.abs(reference[:k]).max()
    np.testing.assert_allclose(lam, reference[:k], rtol=1e-9, atol=1e-11 * top)
    assert info.verification.startswith("Sylvester") and "block" in info.method
    free = ~fixed
    np.testing.assert_allclose(vec[free].T @ (M[free][:, free] @ vec[free]), np.eye(k),
                               atol=1e-10)
    assert (vec[fixed] == 0).all()


def test_agreement_with_arpack_to_1e_9():
    """The previous engine: SciPy's ARPACK in shift-invert mode on the same pencil."""
    from scipy.sparse.linalg import eigsh

    V, T = tetlap.meshes.ball(4000, seed=4)
    L, M = tetlap.operators(V, T, "primal", "fem")
    for fixed in (d.boundary_vertices(T, len(V)), np.zeros(len(V), bool)):
        free = ~fixed
        A, B = -L[free][:, free], M[free][:, free]
        ref = np.sort(eigsh(sp.csc_array(A), k=40, M=sp.csc_array(B), sigma=-1e-3,
                            which="LM", v0=np.ones(A.shape[0]), tol=1e-12)[0])
        lam, vec = solve.eigs(L, M, 40, fixed if fixed.any() else None)
        np.testing.assert_allclose(lam, ref, rtol=1e-9, atol=1e-9 * ref[-1])


def _neumann_cube(k):
    """pi^2 (a^2 + b^2 + c^2), a, b, c >= 0 integers: the Neumann spectrum of the unit cube."""
    v = sorted(np.pi**2 * (a * a + b * b + c * c) for a in range(6) for b in range(6)
               for c in range(6))
    return np.array(v[:k])


def test_the_cube_spectrum_within_discretization_error():
    V, T = tetlap.meshes.cube(16)
    L, M = tetlap.operators(V, T, "primal", "fem")
    lam, _ = solve.eigs(L, M, 20)
    exact = _neumann_cube(20)
    assert lam[0] == 0.0
    np.testing.assert_allclose(lam[1:], exact[1:], rtol=0.05)
    # the Kuhn cube splits the first triple by 3e-7: all three found and certified
    assert lam[3] - lam[1] < 1e-5 * lam[1]
    # the error falls with h (P1: O(h^2))
    V2, T2 = tetlap.meshes.cube(8)
    L2, M2 = tetlap.operators(V2, T2, "primal", "fem")
    coarse, _ = solve.eigs(L2, M2, 20)
    assert (np.abs(lam[1:] / exact[1:] - 1).mean()
            < 0.4 * np.abs(coarse[1:] / exact[1:] - 1).mean())


def test_the_ball_spectrum_within_discretization_error():
    from tetlap.experiments.eigen_ball import ball_eigenvalues

    V, T = tetlap.meshes.ball(6000, seed=2)
    L, M = tetlap.operators(V, T, "primal", "fem")
    fixed = d.boundary_vertices(T, len(V))
    lam, _ = solve.eigs(L, M, 32, fixed)
    exact = ball_eigenvalues(32)
    # conforming P1 on an inscribed polyhedron: upper bounds (Courant-Fischer), 1-13% here
    assert (lam >= exact).all() and (lam <= 1.15 * exact).all()
    lumped, _ = solve.eigs(L, tetlap.mass(V, T, "barycentric"), 32, fixed)
    assert (np.abs(lumped / exact - 1) < 0.06).all()


@pytest.mark.parametrize("k", [1, 2, 3, 4, 7, 10])
def test_exact_multiplicities_of_a_symmetric_mesh_are_complete_and_certified(k):
    """Every symmetry of the cube: Dirichlet values 3 pi^2 x1, 6 pi^2 x3, 9 pi^2 x3, ...
    exactly multiple; k cuts the clusters anywhere."""
    V, T = _sym_cube(6)
    L, M = tetlap.operators(V, T, "primal", "fem")
    fixed = d.boundary_vertices(T, len(V))
    reference = _dense(L, M, fixed)
    assert abs(reference[1] - reference[3]) < 1e-9 * reference[3]      # an exact triple
    lam, vec, info = solve.eigs(L, M, k, fixed, return_info=True)
    np.testing.assert_allclose(lam, reference[:k], rtol=1e-9)
    assert info.verification.startswith("Sylvester")
    free = ~fixed
    np.testing.assert_allclose(vec[free].T @ (M[free][:, free] @ vec[free]), np.eye(k),
                               atol=1e-10)


@pytest.mark.parametrize("k", [2, 3, 4])
def test_a_near_triple_is_complete_and_certified(k):
    """The Kuhn cube splits the first excited Neumann triple by 3e-6 (a double and a
    single); k cuts it."""
    V, T = tetlap.meshes.cube(10)
    L, M = tetlap.operators(V, T, "primal", "fem")
    reference = _dense(L, M)
    spread = (reference[3] - reference[1]) / reference[1]
    assert 0 < spread < 1e-5, spread
    lam, _, info = solve.eigs(L, M, k, return_info=True)
    np.testing.assert_allclose(lam, reference[:k], rtol=1e-9, atol=1e-11)
    assert info.verification.startswith("Sylvester")


def test_an_indefinite_dual_without_fixed_vertices_gets_its_negative_eigenvalues():
    V, T = tetlap.meshes.weighted_ball(900, 1.0, seed=1)
    L, M = tetlap.operators(V, T, "dual", "mixed")
    reference = _dense(L, M)
    assert (reference < -1e-9).sum() >= 2
    lam, vec, info = solve.eigs(L, M, 8, return_info=True)
    np.testing.assert_allclose(lam, reference[:8], rtol=1e-9, atol=1e-11 * abs(reference[0]))
    assert (lam == 0.0).sum() == 1


def test_the_constant_mode_of_every_component_is_exact():
    V, T = tetlap.meshes.ball(700, seed=1)
    V2 = np.vstack([V, V + 5.0, [[9.0, 9.0, 9.0]]])        # two balls and a lone vertex
    T2 = np.vstack([T, T + len(V)])
    for mass in ("barycentric", "fem"):
        L, M = tetlap.operators(V2, T2, "primal", mass)
        lam, vec = solve.eigs(L, M, 4)
        assert (lam[:2] == 0.0).all() and lam[2] > 0
        for j, part in enumerate((slice(0, len(V)), slice(len(V), 2 * len(V)))):
            column = vec[:, j]
            on = column[part]
            assert (on == on[0]).all() and (np.delete(column, np.r_[part]) == 0).all()
            mass_c = M[part][:, part].sum()
            np.testing.assert_allclose(on[0], 1 / np.sqrt(mass_c), rtol=1e-15)


def test_modes_are_signed_by_their_largest_entry():
    V, T = tetlap.meshes.ball(1500, seed=7)
    L, M = tetlap.operators(V, T, "primal", "fem")
    _, vec = solve.eigs(L, M, 12, d.boundary_vertices(T, len(V)))
    top = np.argmax(np.abs(vec), axis=0)
    assert (vec[top, np.arange(12)] > 0).all()
    # ties: the first of equal magnitudes decides
    X = np.array([[0.5, -0.5], [-0.5, 0.5], [0.1, 0.1]])
    np.testing.assert_array_equal(_eigs._signs(X.copy()), [[0.5, 0.5], [-0.5, -0.5], [0.1, -0.1]])


@pytest.mark.parametrize("boundary", ["fixed", "free"])
def test_sigma_gives_the_k_nearest(boundary):
    V, T = tetlap.meshes.ball(1500, seed=8)
    L, M = tetlap.operators(V, T, "primal", "fem")
    fixed = d.boundary_vertices(T, len(V)) if boundary == "fixed" else np.zeros(len(V), bool)
    reference = _dense(L, M, fixed)
    for sigma in (0.0, 60.0, 123.4):
        lam, vec, info = solve.eigs(L, M, 9, fixed if fixed.any() else None, sigma=sigma,
                                    return_info=True)
        nearest = np.sort(reference[np.argsort(np.abs(reference - sigma), kind="stable")[:9]])
        np.testing.assert_allclose(lam, nearest, rtol=1e-9, atol=1e-11 * reference[-1])
        assert "Sylvester" in info.verification


@pytest.mark.parametrize("boundary", ["fixed", "free"])
def test_interval_gives_every_pair_in_it(boundary):
    V, T = tetlap.meshes.ball(1500, seed=8)
    L, M = tetlap.operators(V, T, "primal", "fem")
    fixed = d.boundary_vertices(T, len(V)) if boundary == "fixed" else np.zeros(len(V), bool)
    reference = _dense(L, M, fixed)
    for a, b in ((0.0, 50.0), (40.0, 90.0), (1e3, 1e3 + 1e-9), (-5.0, 30.0)):
        lam, vec, info = solve.eigs(L, M, fixed=fixed if fixed.any() else None,
                                    interval=(a, b), return_info=True)
        expected = reference[(reference >= a - 1e-9) & (reference <= b)]
        np.testing.assert_allclose(lam, expected, rtol=1e-9, atol=1e-9)
        assert vec.shape == (len(V), len(expected))
        assert info.verification.startswith("Sylvester inertia")
    if boundary == "free":      # the constant mode at 0, included by a = 0
        lam, _ = solve.eigs(L, M, interval=(0.0, 10.0))
        assert lam[0] == 0.0


def test_interval_and_sigma_options_are_checked():
    V, T = tetlap.meshes.ball(600, seed=1)
    L, M = tetlap.operators(V, T, "primal", "fem")
    for bad in ((1.0,), (2.0, 1.0), (0.0, np.nan), "ab", 3.0):
        with pytest.raises(tetlap.OptionError, match="interval"):
            solve.eigs(L, M, interval=bad)
    with pytest.raises(tetlap.OptionError, match="interval"):
        solve.eigs(L, M, 3, interval=(0.0, 1.0))
    with pytest.raises(tetlap.OptionError, match="amg"):
        solve.eigs(L, M, 3, sigma=1.0, solver="amg")


def test_a_missed_pair_in_an_interval_is_caught(monkeypatch):
    V, T = tetlap.meshes.ball(1500, seed=8)
    L, M = tetlap.operators(V, T, "primal", "fem")
    real = _lanczos.search

    def missing(*args, want, **kwargs):
        theta, Y, res, stats = real(*args, want=want, **kwargs)
        return theta[1:], Y[:, 1:], res[1:], stats

    monkeypatch.setattr(_lanczos, "search", missing)
    with pytest.raises(tetlap.SolveError, match="could not be certified.*missed"):
        solve.eigs(L, M, interval=(10.0, 80.0))
    with pytest.raises(tetlap.SolveError, match="could not be certified.*missed"):
        solve.eigs(L, M, 6, sigma=50.0)


def test_progress_counts_converged_pairs_and_solves(capsys):
    V, T = tetlap.meshes.ball(1500, seed=8)
    L, M = tetlap.operators(V, T, "primal", "fem")
    _, _, info = solve.eigs(L, M, 30, progress=True, return_info=True)
    err = capsys.readouterr().err
    assert "pairs converged" in err and f"{info.iterations} solves" in err


PROBE = """
import hashlib, sys, numpy as np, tetlap
V, T = tetlap.meshes.ball(3000, seed=3)
out = []
for mass in ("barycentric", "fem"):
    L, M = tetlap.operators(V, T, "primal", mass, threads=1)
    for fixed in (tetlap.diagnostics.boundary_vertices(T, len(V)), None):
        lam, vec = tetlap.solve.eigs(L, M, 30, fixed)
        out.append(hashlib.sha256(lam.tobytes() + vec.tobytes()).hexdigest())
print(" ".join(out))
"""


@pytest.mark.slow
def test_the_same_bits_for_any_thread_count():
    def run(threads):
        env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
                   MKL_NUM_THREADS=str(threads), RAYON_NUM_THREADS=str(threads))
        return subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True,
                              text=True, check=True, timeout=600).stdout
    one = run(1)
    assert one == run(2) == run(4)
    assert len(one.split()) == 4


def test_the_same_bits_on_every_call():
    V, T = tetlap.meshes.ball(2000, seed=3)
    L, M = tetlap.operators(V, T, "primal", "fem")
    a = solve.eigs(L, M, 20)
    b = solve.eigs(L, M, 20)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


@pytest.mark.slow
def test_many_pairs_on_a_larger_mesh_agree_with_arpack():
    from scipy.sparse.linalg import eigsh

    V, T = tetlap.meshes.ball(12000, seed=6)
    L, M = tetlap.operators(V, T, "primal", "fem")
    lam, vec, info = solve.eigs(L, M, 300, return_info=True)
    A, B = sp.csc_array(-L), sp.csc_array(M)
    ref = np.sort(eigsh(A, k=300, M=B, sigma=-1e-2, which="LM", v0=np.ones(len(V)),
                        tol=1e-12)[0])
    np.testing.assert_allclose(lam, ref, rtol=1e-9, atol=1e-9 * ref[-1])
    np.testing.assert_allclose(vec.T @ (M @ vec), np.eye(300), atol=1e-10)
    assert info.verification.startswith("Sylvester")


SEARCH_PROBE = """
import signal; signal.signal(signal.SIGINT, signal.default_int_handler)
import sys, time, numpy as np, tetlap
V, T = tetlap.meshes.ball(30000)
L, M = tetlap.operators(V, T, "primal", "fem")
print("ready", flush=True)
try:
    for _ in range(100):
        tetlap.solve.eigs(L, M, 200)
except KeyboardInterrupt:
    print("interrupted", time.time(), flush=True)
    sys.exit(3)
"""


@pytest.mark.slow
@pytest.mark.parametrize("delay", [6.0, 12.0])
def test_the_search_answers_ctrl_c_within_a_second(delay):
    """Inside the block Lanczos phase (block solves, tall products, the dense eigensolver),
    not only in the factorization (tests/test_solve_interrupt.py)."""
    import signal
    import time
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_interrupt import child, line

    with child(SEARCH_PROBE) as p:
        assert line(p, 600) == "ready"
        time.sleep(delay)
        sent = time.time()
        p.send_signal(signal.SIGINT)
        words = line(p, 120).split()
        assert words[:1] == ["interrupted"], words
        assert p.wait(timeout=120) == 3
        assert float(words[1]) - sent < 1.0, float(words[1]) - sent
