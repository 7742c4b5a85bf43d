"""The orthogonal dual on every mesh of the corpus, with and without vertex weights: the
DEC identities, one code path with the dual Laplacian and the circumcentric mass, the cell
Laplacian and its report."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap

pytestmark = pytest.mark.slow  # the whole corpus: about a minute


def weights_of(V, T, weighted):
    """Random vertex weights of 1% of the squared median edge length, or None."""
    if not weighted:
        return None
    edges, _ = tetlap.edge_weights(V, T)
    h = np.median(np.linalg.norm(V[edges[:, 1]] - V[edges[:, 0]], axis=1))
    return 0.01 * h * h * np.random.default_rng(len(T)).uniform(-1, 1, len(V))


@pytest.mark.parametrize("weighted", [False, True], ids=["plain", "weighted"])
def test_identities_on_every_real_mesh(real_mesh, weighted):
    name, V, T = real_mesh
    w = weights_of(V, T, weighted)
    g = tetlap.dual_geometry(V, T, weights=w)
    L, M = tetlap.laplacian(V, T, "dual", weights=w), tetlap.mass(V, T, "circumcentric", weights=w)
    edges, weight = tetlap.edge_weights(V, T, "dual", weights=w)
    np.testing.assert_array_equal(g.edges, edges)
    np.testing.assert_array_equal(g.transmissibility, weight)
    np.testing.assert_array_equal(g.control_volume, M.diagonal())
    assert (np.abs(g.dual_area / g.edge_length - weight) <= 1e-14 * np.abs(weight)).all(), name
    d, s = tetlap.dec.exterior_derivatives(V, T), tetlap.dec.hodge_stars(V, T, weights=w)
    assert abs(d.d1 @ d.d0).max() == 0 and abs(d.d2 @ d.d1).max() == 0, name
    assert abs(L + d.d0.T @ s.star1 @ d.d0).max() <= 1e-13 * abs(L).max(), name
    Lc = tetlap.cell_laplacian(V, T, weights=w, degenerate="skip")
    inner = np.flatnonzero(~g.boundary_faces)
    star2 = s.star2.diagonal()[inner]
    D = d.d2[:, inner]
    s_, t_ = g.face_tets[inner].T
    kept = np.abs(g.dual_length[inner]) > 0  # skipped faces: zero dual edges (Kuhn blocks)
    if len(inner):
        kept = np.asarray(Lc[s_, t_]) != 0
    dec = -(D[:, kept] @ sp.diags_array(1 / star2[kept]) @ D[:, kept].T)
    # the identity needs the two tets of a face on opposite sides of it; where tets overlap
    # (a folded face: equal signs in d2) the two-point flux still pairs them with +A/l
    folded = np.zeros(len(inner), dtype=bool)
    if len(inner):  # (an empty fancy index of a SciPy array is a sparse array)
        folded = D[s_, np.arange(len(inner))] == D[t_, np.arange(len(inner))]
    at_folded = np.concatenate([s_[folded], t_[folded]])
    rows = np.setdiff1d(np.arange(len(T)), at_folded)
    assert abs((Lc - dec)[rows]).max() <= 1e-13 * abs(Lc).max(), (name, int(folded.sum()))
    report = tetlap.check(Lc, V, T, sp.diags_array(g.volume), kind="cell", weights=w)
    assert report.finite and report.symmetric and report.row_sums_ok and report.local, name
    assert report.n_edges == len(inner) and report.mass_nonpositive == 0, name
    assert report.n_folded_faces == int(folded.sum()), name
    assert isinstance(str(report), str) and report.nsd_method, name
    # linear precision at the centres of every cell off the boundary, away from folded
    # and skipped faces
    if report.linear_precision_residual is not None:
        off = np.ones(len(T), dtype=bool)
        off[g.face_tets[g.boundary_faces, 0]] = False
        off[np.concatenate([at_folded, s_[~kept], t_[~kept]])] = False
        residual = np.abs(Lc @ g.centres).max(axis=1)[off]
        diameter = np.linalg.norm(np.ptp(V, axis=0))
        assert (residual <= 1e-10 * abs(Lc).max() * diameter).all(), name
        if not folded.any() and kept.all():
            assert report.linear_precision_ok, (name, report.linear_precision_residual)
