"""What tetlap.solve.eigs takes: vertices in no element, the stiffness sign, matrices far
from unit size, non-symmetric matrices, non-positive masses beside explicit zeros, AMG's
random stream, and the progress of the search."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import eigh

import tetlap
from tetlap import diagnostics as d
from tetlap import solve
from tetlap.solve import _eigs


def _problem(n, seed=5):
    V, T = tetlap.meshes.ball(n, seed=seed)
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    return V, T, L, M, d.boundary_vertices(T, len(V))


@pytest.fixture(scope="module")
def small():
    """Dense path: fewer free vertices than DENSE_MAX."""
    V, T, L, M, fixed = _problem(300)
    assert (~fixed).sum() <= _eigs.DENSE_MAX
    return V, T, L, M, fixed


@pytest.fixture(scope="module")
def large():
    """Sparse path."""
    V, T, L, M, fixed = _problem(900)
    assert (~fixed).sum() > _eigs.DENSE_MAX
    return V, T, L, M, fixed


def _reference(L, M, fixed, k):
    free = ~fixed
    return eigh((-L[free][:, free]).toarray(), M[free][:, free].toarray(), eigvals_only=True)[:k]


@pytest.mark.parametrize("path", ["small", "large"])
def test_a_vertex_in_no_element_is_not_an_eigenvalue_of_the_identity_mass(path, request):
    """With M = I, a vertex in no tet has a zero row of L and a unit row of M: it was an
    eigenvalue 0 (the smallest), shifting the others by one."""
    V, T, L, _, fixed = request.getfixturevalue(path)
    n = len(V)
    V2 = np.vstack([V, [[5.0, 5.0, 5.0]]])                    # in no tet
    L2 = tetlap.laplacian(V2, T, "primal")
    assert L2.indptr[n + 1] > L2.indptr[n]                    # its stored (zero) diagonal
    fixed2 = np.append(fixed, False)
    lam, vec = solve.eigs(L2, sp.eye_array(n + 1, format="csr"), 4, fixed2)
    np.testing.assert_allclose(lam, _reference(L, sp.eye_array(n, format="csr"), fixed, 4),
                               rtol=1e-9)
    assert (vec[n] == 0).all()


@pytest.mark.parametrize("mass", ["barycentric", "fem"])
def test_the_stiffness_sign_is_refused_naming_the_convention(large, mass):
    """LaPy and scikit-fem hold K = -L: eigs(K, M) returned the negated top of the spectrum
    as 'certified' (lumped mass) or advised a lumped mass (the consistent one)."""
    V, T, L, _, fixed = large
    M = tetlap.mass(V, T, mass)
    with pytest.raises(tetlap.OptionError, match=r"stiffness.*-K"):
        solve.eigs(-L, M, 3, fixed)


#: (e_L, e_M): L scaled by 2^e_L, M by 2^e_M, independently and together.
SCALES = ([(e, 0) for e in (-1000, -601, -1, 1, 600, 1000)]
          + [(0, e) for e in (-1000, -601, -1, 1, 600, 1000)]
          + [(500, -400), (-400, 500), (300, -300), (-300, 300), (-1000, -1000), (1000, 1000)])


@pytest.mark.parametrize("path", ["small", "large"])
def test_eigs_is_invariant_under_powers_of_two(path, request):
    """L and M scaled by powers of two give the same pairs up to the exact factors (the
    sparse path refused eigenvalues in range, or found no starting vector)."""
    _, _, L, M, fixed = request.getfixturevalue(path)
    lam0, vec0 = solve.eigs(L, M, 4, fixed)
    for eL, eM in SCALES:
        Ls, Ms = L * 2.0**eL, M * 2.0**eM
        lam, vec = solve.eigs(Ls, Ms, 4, fixed)
        np.testing.assert_allclose(lam, lam0 * 2.0**(eL - eM), rtol=1e-12, err_msg=f"{eL, eM}")
        np.testing.assert_allclose(vec.T @ (Ms @ vec), np.eye(4), atol=1e-12)
        # the same modes, up to sign: |v_i . M v0_i| = 2^(eM / 2)
        np.testing.assert_allclose(np.abs(np.sum(vec * (Ms @ vec0), axis=0)),
                                   np.full(4, 2.0**(eM / 2)), rtol=1e-9)


def test_eigenvalues_beyond_the_float_range_are_named(small):
    _, _, L, M, fixed = small
    with pytest.raises(tetlap.NonFiniteError, match="float64 range"):
        solve.eigs(L * 2.0**1000, M * 2.0**-1000, 3, fixed)
    lam, _ = solve.eigs(L * 2.0**900, M * 2.0**-100, 3, fixed)        # 2^1000 * 9.9: fine
    assert np.isfinite(lam).all()


def test_amg_gives_the_same_bits_and_leaves_numpy_random_alone(large):
    """pyamg's default smoother estimated a spectral radius from np.random: other bits on
    every call, and the caller's stream advanced."""
    pytest.importorskip("pyamg")
    _, _, L, M, fixed = large
    state = np.random.get_state()
    a = solve.eigs(L, M, 3, fixed, solver="amg")
    after = np.random.get_state()
    b = solve.eigs(L, M, 3, fixed, solver="amg")
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert np.array_equal(state[1], after[1]) and state[2:] == after[2:]


@pytest.mark.parametrize("name", ["L", "M"])
def test_a_non_symmetric_matrix_is_named(large, name):
    _, _, L, M, fixed = large
    free = np.flatnonzero(~fixed)
    i = free[0]
    j = int(next(c for c in L[[i]].indices if c != i and not fixed[c]))
    X = (L if name == "L" else M).tolil()
    X[i, j] = X[i, j] * 1.5 + 0.1
    L2, M2 = (X.tocsr(), M) if name == "L" else (L, X.tocsr())
    with pytest.raises(tetlap.SolveError, match=rf"{name} is not symmetric.*\[{i}, {j}\]"):
        solve.eigs(L2, M2, 3, fixed)


def test_a_non_symmetric_matrix_outside_the_free_block_is_accepted(large):
    """Dirichlet rows replaced by identity rows (as some codes store them) do not enter."""
    _, _, L, M, fixed = large
    X = L.tolil()
    for i in np.flatnonzero(fixed)[:5]:
        X[i, :] = 0
        X[i, i] = -1.0
    lam, _ = solve.eigs(X.tocsr(), M, 3, fixed)
    np.testing.assert_allclose(lam, solve.eigs(L, M, 3, fixed)[0], rtol=1e-12)


@pytest.mark.parametrize("layout", ["explicit zeros", "setdiag on a pattern", "consistent"])
def test_a_non_positive_mass_is_named_whatever_its_stored_pattern(large, layout):
    """A diagonal mass stored with explicit zero off-diagonals, or written with setdiag
    onto a sparsity pattern, is diagonal: its negative entry is named as for a plain
    diagonal (it was "could not be certified"); so is one of a consistent mass (no
    positive definite matrix has one)."""
    V, T, L, M, fixed = large
    free = np.flatnonzero(~fixed)
    lumped = np.asarray(M.sum(axis=1)).ravel()
    lumped[free[7]] = -1e-3
    if layout == "explicit zeros":
        rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
        X = sp.csr_array((np.where(rows == L.indices, lumped[rows], 0.0), L.indices, L.indptr),
                         shape=L.shape)
        assert X.nnz == L.nnz and (X.diagonal() == lumped).all()
    elif layout == "setdiag on a pattern":
        X = sp.csr_array(L, copy=True)
        X.data[:] = 0.0
        X.setdiag(lumped)
    else:
        F = tetlap.mass(V, T, "fem")
        X = sp.csr_array(F, copy=True)
        X.setdiag(np.where(np.arange(len(lumped)) == free[7], -1e-3, F.diagonal()))
    with pytest.raises(tetlap.SolveError,
                       match=rf"M\[{free[7]}, {free[7]}\] = -1\.000e-03.*mixed mass"):
        solve.eigs(L, X, 3, fixed)


def test_progress_reports_the_solves_of_the_search(large, capsys):
    _, _, L, M, fixed = large
    _, _, info = solve.eigs(L, M, 3, fixed, progress=True, return_info=True)
    err = capsys.readouterr().err
    assert f"{info.iterations} solves" in err


@pytest.mark.parametrize("n_fixed", [0, 1])
def test_too_few_free_vertices_are_named(small, n_fixed):
    """An empty problem, or one whose vertices are all fixed but one: a message that
    counts the free vertices (it said "k between 1 and -1")."""
    V, T, L, M, _ = small
    if n_fixed == 0:
        L, M, fixed = sp.csr_array((0, 0)), sp.csr_array((0, 0)), None
    else:
        fixed = np.ones(len(V), dtype=bool)
        fixed[np.unique(T)[0]] = False
    with pytest.raises(tetlap.OptionError, match=f"at least 2 free vertices.*got {1 - (n_fixed == 0)}"):
        solve.eigs(L, M, 1, fixed)


@pytest.mark.parametrize("value", [1, "yes", None])
def test_return_info_is_a_flag(small, value):
    V, T, L, M, fixed = small
    with pytest.raises(tetlap.OptionError, match="return_info must be True or False"):
        solve.eigs(L, M, 3, fixed, return_info=value)
