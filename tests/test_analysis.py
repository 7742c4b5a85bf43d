"""tetlap.analysis (tetlap.check): every line of the report can fail, and says why; the
semidefiniteness answer against dense eigenvalues."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import tetlap
import tetlap.analysis as analysis
from tetlap import _core


@pytest.fixture
def cube():
    return tetlap.meshes.cube(3, jitter=0.15, seed=4)


def test_good_operator_passes_everything(cube):
    V, T = cube
    L, M = tetlap.operators(V, T, "primal", "barycentric")
    r = tetlap.check(L, V, T, M)
    assert (r.finite, r.symmetric, r.row_sums_ok, r.local, r.linear_precision_ok, r.nsd) == (
        True, True, True, True, True, True)
    assert r.nsd_method == "dense eigenvalues"
    assert r.mass_nonpositive == 0
    assert r.mass_total == pytest.approx(r.mesh_volume, rel=1e-12)
    assert json.loads(json.dumps(r.to_dict()))["n_tets"] == len(T)
    text = str(r)
    assert "linear precision" in text and "negative semidefinite" in text


def test_kuhn_grid_zero_weights_are_not_negative():
    V, T = tetlap.meshes.cube(3)
    L = tetlap.laplacian(V, T, "primal")
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert (w == 0).sum() + (np.abs(w) < 1e-15).sum() > 0  # right dihedral angles
    r = tetlap.check(L, V, T)
    assert r.n_negative == 0 and r.min_weight > -1e-12 * np.abs(w).max()
    # a zero weight that rounding made -1e-17: below the tolerance, it does not count;
    # with negative_tol=0 every w < 0 counts
    i, j = edges[np.flatnonzero(w == 0)[0]]
    noisy = L.tolil()
    noisy[i, j] = noisy[j, i] = -1e-17
    noisy[i, i] += 1e-17
    noisy[j, j] += 1e-17
    noisy = noisy.tocsr()
    assert tetlap.check(noisy, V, T).n_negative == 0
    strict = tetlap.check(noisy, V, T, negative_tol=0.0)
    assert strict.n_negative == 1 and strict.min_weight == -1e-17
    assert tetlap.check(L, V, T, negative_tol=0.0).n_negative == (w < 0).sum() == 0


def test_each_failure_is_detected(cube):
    V, T = cube
    L = tetlap.laplacian(V, T, "dual").tolil()
    asym = L.copy()
    asym[0, 1] += 0.5
    r = tetlap.check(asym.tocsr(), V, T)
    assert not r.symmetric and not r.row_sums_ok
    far = L.copy()
    i, j = 0, len(V) - 1
    assert j not in L.rows[i]
    far[i, j] = far[j, i] = 1e-3
    far[i, i] -= 1e-3
    far[j, j] -= 1e-3
    r = tetlap.check(far.tocsr(), V, T)
    assert r.symmetric and r.row_sums_ok and not r.local
    graph = tetlap.laplacian(V, T, "dual").copy()
    off = graph.indices != np.repeat(np.arange(len(V)), np.diff(graph.indptr))
    graph.data[off] = 1.0
    graph = sp.csr_array(graph - sp.diags_array(np.asarray(graph.sum(axis=1)).ravel()))
    r = tetlap.check(graph, V, T)
    assert r.row_sums_ok and not r.linear_precision_ok  # the uniform Laplacian
    nan = tetlap.laplacian(V, T, "dual").copy()
    nan.data[3] = np.nan
    r = tetlap.check(nan, V, T)
    assert not r.finite and r.nsd is None
    assert r.symmetric is None and r.row_sums_ok is None and r.linear_precision_ok is None
    assert "NO" in str(r) and "NaN or Inf" in str(r)


def test_non_delaunay_dual_is_reported_indefinite_with_negative_weights():
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    L, M = tetlap.operators(V, T, "dual", "circumcentric")
    r = tetlap.check(L, V, T, M)
    assert r.nsd is False and r.nsd_min_eigenvalue < 0
    assert r.n_negative_interior > 0 and r.linear_precision_ok
    assert "NO" in str(r)
    p = tetlap.check(tetlap.laplacian(V, T, "primal"), V, T)
    assert p.nsd is True


CERTIFICATE_CASES = {
    "Delaunay ball, primal": (lambda: tetlap.meshes.ball(700, seed=2), "primal"),
    "Delaunay ball, dual": (lambda: tetlap.meshes.ball(700, seed=2), "dual"),
    "Delaunay ball, t = 0.5": (lambda: tetlap.meshes.ball(700, seed=2), 0.5),
    "non-Delaunay ball, dual": (lambda: tetlap.meshes.weighted_ball(600, 0.5, seed=1), "dual"),
    "slightly non-Delaunay ball, dual": (lambda: tetlap.meshes.weighted_ball(600, 0.05, seed=4), "dual"),
    "jittered cube, dual": (lambda: tetlap.meshes.cube(6, jitter=0.24, seed=5), "dual"),
}


@pytest.mark.parametrize("case", list(CERTIFICATE_CASES))
def test_certificates_never_contradict_dense_eigenvalues(monkeypatch, case):
    mesh, kind = CERTIFICATE_CASES[case]
    V, T = mesh()
    L = tetlap.laplacian(V, T, kind)
    dense = tetlap.check(L, V, T)
    assert dense.nsd_method == "dense eigenvalues"
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)
    for hint in (None, kind):
        r = tetlap.check(L, V, T, kind=hint)
        assert r.nsd in (dense.nsd, None), (case, hint, r.nsd_method, dense.nsd_min_eigenvalue)
        if r.nsd is False:  # the witness's Rayleigh quotient bounds the smallest eigenvalue
            assert dense.nsd_min_eigenvalue <= r.nsd_min_eigenvalue < 0
    # the certificates answer every one of these cases
    assert tetlap.check(L, V, T, kind=kind).nsd == dense.nsd, case


def test_the_primal_is_semidefinite_by_construction_only_when_it_is_the_primal(monkeypatch):
    monkeypatch.setattr(analysis, "DENSE_NSD_MAX", 10)
    V, T = tetlap.meshes.ball(700, seed=2)
    P = tetlap.laplacian(V, T, "primal")
    assert "by construction" in tetlap.check(P, V, T).nsd_method
    V2 = V.copy()
    V2[np.abs(V2).max(axis=1) < 0.5] *= 1.001  # another geometry: not this mesh's primal
    assert "by construction" not in tetlap.check(P, V2, T).nsd_method


def test_mass_lines(cube):
    V, T = tetlap.meshes.weighted_ball(600, 1.0, seed=3)
    M = tetlap.mass(V, T, "circumcentric")
    r = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T, M)
    assert r.mass_nonpositive > 0 and r.mass_min < 0
    assert r.mass_total == pytest.approx(r.mesh_volume, rel=1e-10)


def test_immersed_mesh_skips_linear_precision(cube):
    V, T = cube
    V4 = np.column_stack([V, V[:, 0] ** 2])
    r = tetlap.check(tetlap.laplacian(V4, T, "primal"), V4, T)
    assert r.linear_precision_residual is None and r.nsd
    assert any("immersed" in n for n in r.notes)


def test_tetlap_properties_is_an_alias_of_tetlap_analysis():
    import tetlap.properties as old

    for name in analysis.__all__:
        assert getattr(old, name) is getattr(analysis, name), name
    assert old.__all__ == analysis.__all__
    assert tetlap.check is analysis.check


def test_shape_mismatch(cube):
    V, T = cube
    with pytest.raises(tetlap.ShapeError):
        tetlap.check(sp.eye_array(3, format="csr"), V, T)


def _dense_minus_laplacian(n, T, W):
    """``-L = sum_t K_t`` from per-tet edge weights (local edges 01 02 03 12 13 23)."""
    A = np.zeros((n, n))
    for (a, b), w in zip([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)], W.T):
        i, j = T[:, a], T[:, b]
        np.add.at(A, (i, i), w)
        np.add.at(A, (j, j), w)
        np.add.at(A, (i, j), -w)
        np.add.at(A, (j, i), -w)
    return A


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mean=st.floats(-0.5, 2.0), spread=st.floats(0.0, 3.0))
def test_the_element_certificate_never_certifies_an_indefinite_sum(seed, mean, spread):
    rng = np.random.default_rng(seed)
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=seed % 997)
    W = rng.normal(mean, spread, size=(len(T), 6))
    lam = np.linalg.eigvalsh(_dense_minus_laplacian(len(V), T, W))[0]
    tol = 1e-9 * np.abs(W).max()
    verdict, name, details = _core.element_certificate(T, len(V), W, tol)
    assert verdict in (True, None)
    if verdict:
        assert name == "element certificate" and lam >= -tol, (lam, details)
    else:
        assert name == "undetermined" and details["uncovered"] > 0


def test_the_element_certificate_answers_when_neighbours_cover_the_negative_weights():
    V, T = tetlap.meshes.cube(8, jitter=0.24, seed=5)
    W = tetlap.element_contributions(V, T, "dual")
    assert (W < 0).any()
    verdict, _, details = _core.element_certificate(T, len(V), W, 1e-9 * np.abs(W).max())
    assert verdict is True and details["groups"] > 0
    assert np.linalg.eigvalsh(_dense_minus_laplacian(len(V), T, W))[0] >= -1e-9 * np.abs(W).max()
    # the primal needs no group: every K_t is a Gram matrix
    P = tetlap.element_contributions(V, T, "primal")
    assert _core.element_certificate(T, len(V), P, 1e-9 * np.abs(P).max())[2]["groups"] == 0


def test_the_element_certificate_refuses_weights_of_the_wrong_shape():
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(tetlap.ShapeError):
        _core.element_certificate(T, len(V), np.zeros((len(T), 3)), 1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_the_element_certificate_never_contradicts_dense_eigenvalues_on_the_corpus(real_mesh, kind):
    name, V, T = real_mesh
    W = tetlap.element_contributions(V, T, kind, degenerate="skip")
    L = tetlap.laplacian(V, T, kind, degenerate="skip")
    tol = analysis.NSD_RTOL * abs(L).max()
    verdict, _, _ = _core.element_certificate(T, len(V), W, tol)
    if kind == "primal":
        assert verdict is True, name  # a sum of Gram matrices
    if verdict and len(V) <= 3000:
        assert np.linalg.eigvalsh((-(L + L.T) / 2).toarray())[0] >= -tol, name
