"""The solver layer of tetlap.solve: every solver= on every function, the "auto" choice and
its fallbacks, what SolveInfo reports, indefinite operators (never an unchecked CG answer),
option checks, and vertices in no element (they change no answer)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

import tetlap
from tetlap import diagnostics as d
from tetlap import solve
from tetlap.solve import _linear

from conftest import corpus_mesh

GRAD = np.array([1.0, 2.0, -1.0])
FLUX = lambda centroids, normals: normals @ GRAD  # noqa: E731 (the normal derivative of V @ GRAD)


@pytest.fixture(scope="module")
def ball():
    return tetlap.meshes.ball(3000, seed=2)


@pytest.fixture(scope="module")
def bunny():
    pytest.importorskip("meshio")
    return corpus_mesh("libigl_bunny.mesh")


@pytest.mark.parametrize("solver", ["amg", "cholesky", "lu", "auto"])
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_every_solver_solves_the_dirichlet_problem(ball, solver, kind):
    V, T = ball
    L, M = tetlap.operators(V, T, kind, "barycentric")
    fixed = d.boundary_vertices(T, len(V))
    u = V @ GRAD + 3
    f, info = solve.dirichlet(L, fixed, u, M @ np.sin(V[:, 0]), solver=solver, return_info=True)
    free = ~fixed
    reference = u.copy()
    reference[free] = spsolve(sp.csc_array(L[free][:, free]),
                              (M @ np.sin(V[:, 0]))[free] - L[free][:, fixed] @ u[fixed])
    assert np.abs(f - reference).max() <= 1e-8 * np.abs(reference).max()
    assert info.solver == (solver if solver != "auto" else "cholesky")
    assert info.residual <= solve.RESIDUAL_TOL
    assert set(info.phases) >= {"components", "check"}
    if solver == "amg":
        assert info.iterations > 0 and info.ordering == "reverse Cuthill-McKee"
    if solver == "cholesky":
        assert info.method == "LL^T" and "METIS" in info.ordering


def test_auto_takes_amg_from_its_size_and_reports_it(ball, monkeypatch):
    V, T = ball
    L = tetlap.laplacian(V, T, "dual")
    fixed = d.boundary_vertices(T, len(V))
    monkeypatch.setattr(_linear, "AUTO_AMG_MIN", 100)
    f, info = solve.dirichlet(L, fixed, V[:, 0], return_info=True)
    assert info.solver == "amg" and not info.fallbacks
    assert info.certified is _linear.certified(-L[~fixed][:, ~fixed])
    assert np.abs(f - V[:, 0]).max() < 1e-8
    # bitwise the same on a second run (pyamg's set-up and CG are serial)
    assert np.array_equal(f, solve.dirichlet(L, fixed, V[:, 0]))


def test_the_diagonal_dominance_certificate():
    A = sp.csr_array(np.array([[2.0, -1.0, -1.0], [-1.0, 2.0, -1.0], [-1.0, -1.0, 2.0]]))
    assert _linear.certified(A)
    assert not _linear.certified(A - 0.01 * sp.eye_array(3))
    assert _linear.certified(sp.csr_array(np.array([[1.0, 1.0], [1.0, 1.0]])))  # PSD, signs free


@pytest.mark.slow
def test_an_indefinite_dual_gets_a_checked_direct_solution_or_an_error(bunny, monkeypatch):
    V, T = bunny
    L = tetlap.laplacian(V, T, "dual")
    assert tetlap.check(L, V, T, kind="dual").nsd is False
    fixed = d.boundary_vertices(T, len(V))
    free = ~fixed
    A = -L[free][:, free]
    lam = np.linalg.eigvalsh(A.toarray())
    assert lam[0] < 0  # the Dirichlet block itself is indefinite
    assert not _linear.certified(A)
    monkeypatch.setattr(_linear, "AUTO_AMG_MIN", 0)  # auto tries CG first
    u = np.sin(V[:, 0]) + V[:, 1]
    reference = u.copy()
    reference[free] = spsolve(sp.csc_array(L[free][:, free]), -L[free][:, fixed] @ u[fixed])
    f, info = solve.dirichlet(L, fixed, u, return_info=True)
    assert info.solver in ("cholesky", "lu"), info
    assert info.fallbacks and info.fallbacks[0].startswith("amg:")
    assert np.abs(f - reference).max() <= 1e-8 * np.abs(reference).max()
    # CG asked for by name: an answer only if it passes the residual check, else an error
    try:
        g, info = solve.dirichlet(L, fixed, u, solver="amg", return_info=True)
    except tetlap.SolveError as e:
        assert "curvature" in str(e) or "residual" in str(e) or "converge" in str(e)
    else:
        assert info.residual <= solve.RESIDUAL_TOL
        assert np.abs(g - reference).max() <= 1e-6 * np.abs(reference).max()


def test_factorize_solves_vectors_and_blocks_and_refactors(ball):
    V, T = ball
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    A = M - 0.01 * L
    F = solve.factorize(A)
    assert (F.info.solver, F.info.method) == ("cholesky", "LL^T")
    b = np.cos(V @ GRAD)
    np.testing.assert_allclose(F.solve(b), spsolve(sp.csc_array(A), b), rtol=1e-10)
    B = np.column_stack([b, V[:, 0], np.ones(len(V))])
    X = F.solve(B)
    assert X.shape == B.shape
    np.testing.assert_allclose(X[:, 0], F.solve(b), rtol=1e-12)  # block kernels: not bitwise
    # a new time step: same pattern, the symbolic analysis reused
    A2 = M - 0.05 * L
    F.refactor(A2)
    np.testing.assert_allclose(F.solve(b), spsolve(sp.csc_array(A2), b), rtol=1e-10)
    assert F.inertia() == (0, 0, len(V))
    # entries may be missing (a diagonal), none may be added
    F.refactor(M)
    np.testing.assert_allclose(F.solve(b), b / M.diagonal(), rtol=1e-12)
    with pytest.raises(tetlap.ShapeError):
        F.refactor(A2 + sp.csr_array(([1.0], ([0], [len(V) - 1])), shape=A.shape))
    with pytest.raises(tetlap.ShapeError):
        F.solve(np.ones(len(V) + 1))
    with pytest.raises(tetlap.NonFiniteError):
        F.solve(np.full(len(V), np.nan))
    lu = solve.factorize(A, solver="lu")
    np.testing.assert_allclose(lu.solve(b), spsolve(sp.csc_array(A), b), rtol=1e-10)


def test_a_given_ordering_is_used_and_changes_the_answer_by_rounding_only(ball):
    V, T = ball
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    A = M - 0.01 * L
    F = solve.factorize(A)
    perm = F.permutation
    assert sorted(perm) == list(range(len(V)))
    b = np.cos(V @ GRAD)
    for ordering in (perm, perm[::-1].copy(), np.arange(len(V))):
        G = solve.factorize(A, ordering=ordering)
        assert G.info.ordering == "given"
        np.testing.assert_array_equal(G.permutation, ordering)
        np.testing.assert_allclose(G.solve(b), F.solve(b), rtol=1e-12)
    assert solve.factorize(A, ordering="amd").permutation is None


def test_heat_distance_orders_the_mesh_once(ball, monkeypatch):
    from tetlap.solve import factor

    calls = []
    real = factor.nested_dissection
    monkeypatch.setattr(factor, "nested_dissection", lambda A: calls.append(A.shape) or real(A))
    for boundary, factorizations in (("neumann", 2), ("average", 3)):
        calls.clear()
        heat = tetlap.HeatDistance(*ball, boundary_condition=boundary)
        assert heat.n_factorizations == factorizations
        assert calls == [(len(ball[0]),) * 2]


def test_the_inertia_counts_eigenvalues_below_a_shift(ball):
    V, T = tetlap.meshes.ball(600, seed=3)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    fixed = d.boundary_vertices(T, len(V))
    A, B = -L[~fixed][:, ~fixed], M[~fixed][:, ~fixed]
    from scipy.linalg import eigh

    lam = eigh(A.toarray(), B.toarray(), eigvals_only=True)
    for j in (1, 4, 20, 100):
        s = (lam[j - 1] + lam[j]) / 2
        F = solve.factorize(A - s * B)
        assert F.info.method == "LDL^T"
        assert F.inertia() == (j, 0, len(lam) - j)
    with pytest.raises(tetlap.OptionError):
        solve.factorize(A, solver="lu").inertia()


def test_a_non_symmetric_matrix_is_factorized_by_lu():
    A = sp.csr_array(np.array([[4.0, 1.0], [0.0, 3.0]]))
    F = solve.factorize(A)
    assert F.info.solver == "lu"
    np.testing.assert_allclose(F.solve(np.array([5.0, 3.0])), [1.0, 1.0])
    with pytest.raises(tetlap.OptionError):
        solve.factorize(A, solver="cholesky")
    with pytest.raises(tetlap.SolveError):
        solve.factorize(sp.csr_array(np.array([[1.0, 2.0], [2.0, 4.0]])), solver="lu")


@pytest.mark.parametrize("call", [
    lambda L, g, f: solve.neumann(L, g, rtol=np.nan),
    lambda L, g, f: solve.neumann(L, g, rtol=np.inf),
    lambda L, g, f: solve.neumann(L, g, rtol=-1e-3),
    lambda L, g, f: solve.neumann(L, g, rtol="1e-6"),
    lambda L, g, f: solve.neumann(L, g, solver="cg"),
    lambda L, g, f: solve.dirichlet(L, f, 0.0, solver=None),
    lambda L, g, f: solve.dirichlet(L, f, 0.0, progress="yes"),
    lambda L, g, f: solve.dirichlet(L, f, 0.0, method="replace", solver="amg"),
    lambda L, g, f: solve.eigs(L, L, 3, f, sigma=np.nan),
    lambda L, g, f: solve.eigs(L, L, 3, f, sigma=True),
    lambda L, g, f: solve.eigs(L, L, 0, f),
    lambda L, g, f: solve.eigs(L, L, 3, f, solver="fast"),
    lambda L, g, f: solve.factorize(L, ordering="metis"),
    lambda L, g, f: solve.factorize(L, solver="amg"),
    lambda L, g, f: solve.factorize(-L + sp.eye_array(L.shape[0]), ordering=np.zeros(L.shape[0], int)),
    lambda L, g, f: solve.factorize(-L + sp.eye_array(L.shape[0]), ordering=np.arange(L.shape[0] - 1)),
    lambda L, g, f: solve.factorize(-L + sp.eye_array(L.shape[0]), ordering=np.arange(L.shape[0]) + 0.0),
    lambda L, g, f: solve.factorize(-L + sp.eye_array(L.shape[0]), solver="lu",
                                    ordering=np.arange(L.shape[0])),
])
def test_every_option_is_checked(call):
    V, T = tetlap.meshes.cube(3)
    L = tetlap.laplacian(V, T)
    with pytest.raises(tetlap.OptionError):
        call(L, solve.fem_boundary_areas(V, T, GRAD), d.boundary_vertices(T, len(V)))


def _with_far_vertex(V, T, far=1e150):
    return np.vstack([V, [[far, -far, far]]]), T


def test_a_far_unused_vertex_changes_no_answer(ball):
    V, T = tetlap.meshes.ball(800, seed=4)
    V2, T2 = _with_far_vertex(V, T)
    n = len(V)
    for kind in ("primal", "dual"):
        L, M = tetlap.operators(V, T, kind, "barycentric")
        L2, M2 = tetlap.operators(V2, T2, kind, "barycentric")
        fixed = d.boundary_vertices(T, n)
        fixed2 = d.boundary_vertices(T2, n + 1)
        u = V @ GRAD
        for solver in ("amg", "cholesky", "lu"):
            a = solve.dirichlet(L, fixed, u, solver=solver)
            b = solve.dirichlet(L2, fixed2, np.r_[u, 1e300], solver=solver)
            assert np.array_equal(a, b[:n]) and b[n] == 0
        g, g2 = (solve.fem_boundary_areas(W, T, GRAD) for W in (V, V2))
        a, b = solve.neumann(L, g), solve.neumann(L2, g2)
        assert np.array_equal(a, b[:n]) and b[n] == 0
        lam, vec = solve.eigs(L, M, 4, fixed)
        lam2, vec2 = solve.eigs(L2, M2, 4, fixed2)
        assert np.array_equal(lam, lam2) and (vec2[n] == 0).all()
    L, L2 = tetlap.laplacian(V, T), tetlap.laplacian(V2, T2)
    a = solve.neumann_primal_kkt(L, V, T, FLUX)
    b = solve.neumann_primal_kkt(L2, V2, T2, FLUX)
    np.testing.assert_allclose(a, b[:n], atol=1e-12)
    assert b[n] == 0


def test_kkt_gauges_every_component_and_leaves_unused_vertices_at_zero():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    n = len(V)
    V2 = np.vstack([V, V + 4, [[50.0, 0.0, 0.0]]])
    T2 = np.vstack([T, T + n])
    L2 = tetlap.laplacian(V2, T2)
    f = solve.neumann_primal_kkt(L2, V2, T2, FLUX)
    u = V2 @ GRAD
    for part in (slice(0, n), slice(n, 2 * n)):
        np.testing.assert_allclose(f[part], u[part] - u[part].mean(), atol=1e-10)
    assert f[-1] == 0
    g = solve.neumann_primal_kkt(L2, V2, T2, FLUX, gauge=n + 2)
    assert abs(g[n + 2]) < 1e-12
    np.testing.assert_allclose(g[:n], u[:n] - u[:n].mean(), atol=1e-10)
    np.testing.assert_allclose(g[n:2 * n], u[n:2 * n] - u[n + 2], atol=1e-10)
    with pytest.raises(tetlap.OptionError):
        solve.neumann_primal_kkt(L2, V2, T2, FLUX, gauge=2 * n)
    with pytest.raises(tetlap.OptionError):
        solve.neumann_primal_kkt(L2, V2, T2, FLUX, solver="amg")
    h, info = solve.neumann_primal_kkt(L2, V2, T2, FLUX, solver="lu", return_info=True)
    assert info.solver == "lu" and np.array_equal(h, f)


@pytest.mark.parametrize("solver", ["auto", "amg", "cholesky", "lu"])
def test_neumann_with_every_solver(ball, solver):
    V, T = ball
    L = tetlap.laplacian(V, T, "dual")
    u = V @ GRAD
    f, info = solve.neumann(L, solve.dual_boundary_areas(V, T, GRAD), solver=solver,
                            return_info=True)
    assert np.abs(f - (u - u.mean())).max() < 1e-8
    assert info.residual <= solve.RESIDUAL_TOL


def test_metis_in_a_child_process_gives_the_same_order(monkeypatch, tmp_path):
    from tetlap.solve import factor

    V, T = tetlap.meshes.cube(6)
    A = factor.canonical(-tetlap.laplacian(V, T) + sp.eye_array(len(V)))
    here = factor.nested_dissection(A)
    monkeypatch.setattr(factor, "METIS_CHILD_MIN", 0)
    assert np.array_equal(factor.nested_dissection(A), here)
    # a user's script without a main guard is not run again by the child
    script = tmp_path / "user.py"
    script.write_text("import numpy as np, scipy.sparse as sp, tetlap\n"
                      "from tetlap.solve import factor\n"
                      "factor.METIS_CHILD_MIN = 0\n"
                      "V, T = tetlap.meshes.cube(4)\n"
                      "print('run', flush=True)\n"
                      "F = tetlap.solve.factorize(sp.eye_array(len(V)) - tetlap.laplacian(V, T))\n"
                      "print(F.info.ordering)\n")
    import subprocess
    import sys

    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[:2] == ["run", "nested dissection (METIS)"]


def test_metis_gets_a_symmetric_graph_from_any_pattern():
    """METIS hangs, crashes or raises on a graph that is not symmetric (the fuzz test met a
    segfault through dirichlet on a matrix with an explicit zero on one side): the graph
    of any pattern is symmetrized first. Run in a child, so that a hang is a failure."""
    import subprocess
    import sys

    code = ("import numpy as np, scipy.sparse as sp\n"
            "from tetlap.solve.factor import nested_dissection\n"
            "for seed in range(40):\n"
            "    A = sp.random_array((27, 27), density=0.15, rng=seed, format='csr')\n"
            "    p = nested_dissection(A + sp.eye_array(27))\n"
            "    assert np.array_equal(np.sort(p), np.arange(27)), seed\n"
            "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0 and out.stdout == "ok\n", out.stderr[-2000:]


@pytest.mark.parametrize("solver", ["auto", "cholesky", "lu"])
def test_a_singular_matrix_is_refused_not_solved(solver):
    # issue 30 item 4: factorize(-L) of a pure Neumann Laplacian (singular: constants in
    # its null space) gave answers of 1e17 that passed the residual check
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    L = tetlap.laplacian(V, T)
    V2, T2 = np.vstack([V, V + 3]), np.vstack([T, T + len(V)])   # two components
    for A in (-L, -tetlap.laplacian(V2, T2, "dual")):
        F = solve.factorize(A, solver=solver)
        b = np.sin(np.arange(A.shape[0]))
        for rhs in (b, b - b.mean(), np.ones(A.shape[0])):
            with pytest.raises(tetlap.SolveError, match="singular"):
                F.solve(rhs)
    # refactored onto a singular matrix, and back
    F = solve.factorize(-L + sp.eye_array(L.shape[0]), solver=solver)
    F.refactor(-L)
    with pytest.raises(tetlap.SolveError, match="singular"):
        F.solve(b[:L.shape[0]])
    F.refactor(-L + 1e-3 * sp.eye_array(L.shape[0]))
    assert np.isfinite(F.solve(b[:L.shape[0]])).all()


def test_lobpcg_on_an_indefinite_dual_says_so_in_public_terms_and_quietly():
    # the error's class was the private _Missed, after a dozen of LOBPCG's UserWarnings
    import warnings

    V, T = corpus_mesh("libigl_octopus_low.mesh")
    L, M = tetlap.operators(V, T, "dual", "mixed")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(tetlap.SolveError, match="could not be certified") as e:
            solve.eigs(L, M, k=5, solver="amg")
    assert type(e.value) is tetlap.SolveError


@pytest.mark.parametrize("solver", ["auto", "cholesky", "lu"])
def test_a_singular_matrix_whose_pivots_look_fine_is_refused_by_its_answer(solver):
    # the bunny's primal L (singular: constants) factorizes without a small pivot, and
    # F.solve(ones) returned 6.4e15-sized answers with a relative residual of 1e-16
    V, T = corpus_mesh("libigl_bunny.mesh")
    L = tetlap.laplacian(V, T, "primal")
    F = solve.factorize(L, solver=solver)
    with pytest.raises(tetlap.SolveError, match="singular to working precision"):
        F.solve(np.ones(len(V)))
    with pytest.raises(tetlap.SolveError, match="singular to working precision"):
        F.solve(np.column_stack([np.sin(np.arange(len(V))), np.ones(len(V))]))
    # the same system made regular is solved, and its bound is the condition number's
    A = -L + 1e-2 * tetlap.mass(V, T)
    b = np.sin(np.arange(len(V)))
    x = solve.factorize(A, solver=solver).solve(b)
    assert 1 <= solve._checks.condition_bound(A, x, b) < 1 / solve.PIVOT_RTOL


def test_the_condition_bound_is_a_lower_bound_of_the_scaled_condition_number():
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = 12
        B = rng.normal(size=(n, n))
        A = B @ B.T + 10.0 ** rng.uniform(-8, 0) * np.eye(n)
        s = 10.0 ** rng.uniform(-20, 20, n)
        A = s[:, None] * A * s[None, :]              # badly scaled: the bound is Jacobi-scaled
        S = np.diag(1 / np.sqrt(np.diag(A)))
        kappa = np.linalg.cond(S @ A @ S, np.inf)
        b = rng.normal(size=(n, 2))
        x = np.linalg.solve(A, b)
        bound = solve._checks.condition_bound(sp.csr_array(A), x, b)
        assert 0 < bound <= kappa * (1 + 1e-6), (bound, kappa)
    assert solve._checks.condition_bound(sp.csr_array(np.eye(3)), np.zeros(3), np.zeros(3)) == 0


@pytest.mark.parametrize("solver", ["auto", "cholesky", "lu"])
def test_badly_scaled_but_well_conditioned_matrices_are_solved(solver):
    # the singularity test is relative to each row: a diagonal scaling changes nothing
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    A = -tetlap.laplacian(V, T) + 0.5 * tetlap.mass(V, T)
    s = sp.diags_array(np.logspace(-30, 30, A.shape[0]))
    b = np.sin(np.arange(A.shape[0]))
    x = solve.factorize(sp.csr_array(s @ A @ s), solver=solver).solve(s @ b)
    np.testing.assert_allclose(s @ x, solve.factorize(A, solver=solver).solve(b), rtol=1e-5)
