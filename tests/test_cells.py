"""tetlap.cell_laplacian: the cell-centred two-point-flux Laplacian, the DEC Laplacian on
dual 0-forms; its Table 1 report through tetlap.check(..., kind="cell")."""

from __future__ import annotations

import warnings
from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from exact_reference import cross, dot, sub, tet_circumcenter, vec
from test_dual import INTEGER_MESHES, with_weights


def meshes():
    yield "ball", tetlap.meshes.ball(400, seed=6)
    yield "shell", tetlap.meshes.shell(500, seed=1)[:2]  # a hole: boundary cells inside too
    yield "non-Delaunay", tetlap.meshes.weighted_ball(300, 0.5, seed=3)


def off_boundary(g):
    """(m,) bool: tets without a boundary face."""
    mask = np.ones(len(g.volume), dtype=bool)
    mask[g.face_tets[g.boundary_faces, 0]] = False
    return mask


@pytest.mark.parametrize("V,T,w", with_weights(meshes()))
def test_the_cell_laplacian_is_the_dec_laplacian_on_dual_0_forms(V, T, w):
    Lc = tetlap.cell_laplacian(V, T, weights=w)
    g = tetlap.dual_geometry(V, T, weights=w)
    d, s = tetlap.dec.exterior_derivatives(V, T), tetlap.dec.hodge_stars(V, T, weights=w)
    inner = np.flatnonzero(~g.boundary_faces)
    D = d.d2[:, inner]
    dec = -(D @ sp.diags_array(1 / s.star2.diagonal()[inner]) @ D.T)
    assert abs(Lc - dec).max() <= 1e-13 * abs(Lc).max()
    # the paper's sign convention: off-diagonals are face area / dual length, rows sum to 0
    m = len(T)
    assert Lc.shape == (m, m) and isinstance(Lc, sp.csr_array) and Lc.has_sorted_indices
    s_, t_ = g.face_tets[inner].T
    np.testing.assert_array_equal(Lc[s_, t_], g.face_area[inner] / g.dual_length[inner])
    assert Lc.nnz == m + 2 * len(inner)
    assert abs(Lc - Lc.T).max() == 0
    rows = np.asarray(abs(Lc).sum(axis=1)).ravel()
    assert (np.abs(np.asarray(Lc.sum(axis=1)).ravel()) <= 1e-14 * rows).all()
    # exact for linear functions at the centres, on every cell without a boundary face
    off = off_boundary(g)
    residual = np.abs(Lc @ g.centres).max(axis=1)[off]
    assert (residual <= 1e-12 * rows[off] * np.abs(g.centres).max()).all()


def test_negative_semidefinite_on_a_delaunay_mesh_and_not_beyond():
    V, T = tetlap.meshes.ball(300, seed=2)
    Lc = tetlap.cell_laplacian(V, T)
    assert Lc.data[Lc.indices != np.repeat(np.arange(len(T)), np.diff(Lc.indptr))].min() > 0
    assert np.linalg.eigvalsh(-Lc.toarray()).min() > -1e-12 * abs(Lc).max()
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=3)
    assert np.linalg.eigvalsh(-tetlap.cell_laplacian(V, T).toarray()).min() < 0
    # the weights of a regular triangulation put its power centres in order again
    r = tetlap.regular_weights(V, T)
    assert r.regular
    Lc = tetlap.cell_laplacian(V, T, weights=r.weights)
    report = tetlap.check(Lc, V, T, kind="cell", weights=r.weights)
    assert report.n_negative == 0 and report.nsd and report.linear_precision_ok


@pytest.mark.parametrize("name", list(INTEGER_MESHES))
def test_exact_rationals(name):
    """``Lc[s, t] = A / l = |n|^2 / (2 (h_s + h_t) |n|)``: rational, against Fractions; the
    fan has two cospherical tets (an exactly zero dual edge, skipped to an exact 0)."""
    V, T = INTEGER_MESHES[name]
    X = [vec(p) for p in V]
    expected: dict = {}
    for t, tet in enumerate(T):
        c = tet_circumcenter(*[X[i] for i in tet])
        for l in range(4):
            face = tuple(sorted(tet[:l] + tet[l + 1:]))
            Q = [X[i] for i in face]
            n = cross(sub(Q[1], Q[0]), sub(Q[2], Q[0]))
            towards = 1 if dot(n, sub(X[tet[l]], Q[0])) > 0 else -1
            tets, length = expected.get(face, ([], Fraction(0)))
            expected[face] = (tets + [t], length + towards * dot(n, sub(c, Q[0])))
    Lc = tetlap.cell_laplacian(V, T, degenerate="skip").toarray()
    exact = np.zeros_like(Lc)
    zero = [face for face, (tets, length) in expected.items() if len(tets) == 2 and length == 0]
    assert bool(zero) == (name == "fan")
    if zero:
        with pytest.raises(tetlap.DegenerateElementError, match=str(zero[0])):
            tetlap.cell_laplacian(V, T)
    for face, (tets, length) in expected.items():
        if len(tets) == 2 and length != 0:
            Q = [X[i] for i in face]
            n = cross(sub(Q[1], Q[0]), sub(Q[2], Q[0]))
            exact[tets[0], tets[1]] = exact[tets[1], tets[0]] = float(dot(n, n) / (2 * length))
    np.fill_diagonal(exact, -exact.sum(axis=1))
    np.testing.assert_allclose(Lc, exact, rtol=1e-13, atol=1e-13 * np.abs(exact).max())


def test_zero_length_dual_edges_are_named_or_skipped():
    V, T = tetlap.meshes.cube(2)  # Kuhn cubes: six tets share each cube's circumsphere
    with pytest.raises(tetlap.DegenerateElementError, match="dual edge of length 0") as e:
        tetlap.cell_laplacian(V, T)
    assert e.value.element is not None
    Lc = tetlap.cell_laplacian(V, T, degenerate="skip")
    g = tetlap.dual_geometry(V, T)
    inner = np.flatnonzero(~g.boundary_faces)
    assert Lc.nnz == len(T) + 2 * len(inner)  # explicit zeros keep the pattern
    s, t = g.face_tets[inner].T
    w = Lc[s, t]
    zero = np.abs(g.dual_length[inner]) < 1e-12
    assert zero.any() and (w[zero] == 0).all() and (w[~zero] > 0).all()
    with pytest.raises(tetlap.OptionError):
        tetlap.cell_laplacian(V, T, degenerate="merge")
    # the remedy the message names: regular weights separate the centres
    r = tetlap.regular_weights(V, T)
    Lc = tetlap.cell_laplacian(V, T, weights=r.weights)
    assert tetlap.check(Lc, V, T, kind="cell", weights=r.weights).n_negative == 0


def test_bad_input_gets_clear_errors():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]]
    with pytest.raises(tetlap.DegenerateElementError) as e:
        tetlap.cell_laplacian(V, [[0, 1, 2, 3], [0, 1, 2, 4]], degenerate="skip")
    assert e.value.element == 1
    with pytest.raises(tetlap.ShapeError):
        tetlap.cell_laplacian([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.cell_laplacian([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]], [[0, 1, 2, 3]])


@pytest.mark.parametrize("name,mesh", list(meshes()))
def test_check_reports_the_table_1_properties_of_cells(name, mesh):
    V, T = mesh
    Lc = tetlap.cell_laplacian(V, T)
    g = tetlap.dual_geometry(V, T)
    r = tetlap.check(Lc, V, T, sp.diags_array(g.volume), kind="cell")
    assert isinstance(r, tetlap.analysis.Report) and isinstance(r, tetlap.cells.CellReport)
    assert r.finite and r.symmetric and r.row_sums_ok and r.local and r.linear_precision_ok
    assert r.n_edges == int((~g.boundary_faces).sum()) and r.n_tets == len(T)
    assert r.n_cells_off_boundary == int(off_boundary(g).sum())
    negative = int((g.dual_length[~g.boundary_faces] < 0).sum())
    assert r.n_negative == negative
    assert r.nsd is (negative == 0)
    assert r.mass_nonpositive == 0 and r.mass_total == pytest.approx(r.mesh_volume)
    text = str(r)
    assert text.startswith(f"{len(T)} cells") and "face neighbours" in text
    assert r.to_dict()["n_cells_off_boundary"] == r.n_cells_off_boundary


def test_check_of_a_wrong_cell_operator_says_what_is_wrong():
    V, T = tetlap.meshes.ball(300, seed=1)
    Lc = tetlap.cell_laplacian(V, T).tolil()
    Lc[0, len(T) - 1] = 1.0  # not face-adjacent, not symmetric, row 0 no longer sums to 0
    r = tetlap.check(Lc.tocsr(), V, T, kind="cell", nsd=False)
    assert not r.local and not r.symmetric and not r.row_sums_ok
    Lc = tetlap.cell_laplacian(V, T)
    Lc.data[0] = np.nan
    r = tetlap.check(Lc, V, T, kind="cell")
    assert not r.finite and r.symmetric is None and r.nsd is None
    with pytest.raises(tetlap.ShapeError):
        tetlap.check(tetlap.laplacian(V, T, "dual"), V, T, kind="cell")
    with pytest.raises(tetlap.OptionError):
        tetlap.check(tetlap.laplacian(V, T, "dual"), V, T, kind="dual", weights=np.zeros(len(V)))
    with pytest.raises(tetlap.OptionError):
        tetlap.check(Lc, V, T, kind="cells")


@pytest.mark.parametrize("far", [1e8, 1e300])
def test_an_unused_vertex_changes_no_cell_report(far):
    # linear precision was relative to the diameter of every vertex: one unused vertex at
    # 1e8 turned a failing operator into a passing one, at 1e300 the residual became 0
    V, T = tetlap.meshes.ball(300, seed=1)
    Lc = tetlap.cell_laplacian(V, T).tolil()
    Lc[0, 0] -= 1e-3
    Lc[0, 1] += 1e-3            # a wrong weight, symmetric, rows still summing to zero
    Lc[1, 0] += 1e-3
    Lc[1, 1] -= 1e-3
    Lc = Lc.tocsr()
    plain = tetlap.check(Lc, V, T, kind="cell").to_dict()
    assert plain["linear_precision_ok"] is False
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        far_vertex = tetlap.check(Lc, np.vstack([V, [far, far, far]]), T, kind="cell").to_dict()
    assert {k: v for k, v in far_vertex.items() if k != "n_vertices"} == \
        {k: v for k, v in plain.items() if k != "n_vertices"}


def test_check_counts_folded_faces():
    """Two tets on the same side of their shared face (they overlap): the flux pairs them
    with +A/l, but a linear function is not reproduced there, and check says why."""
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 1], [0.3, 0.25, 2]]
    T = [[0, 1, 2, 3], [0, 1, 2, 4]]
    Lc = tetlap.cell_laplacian(V, T)
    assert abs(Lc - Lc.T).max() == 0 and abs(Lc.sum(axis=1)).max() < 1e-12
    r = tetlap.check(Lc, V, T, kind="cell")
    assert r.n_folded_faces == 1 and any("folded" in note for note in r.notes)
    r = tetlap.check(tetlap.cell_laplacian(*tetlap.meshes.ball(200, seed=1)),
                     *tetlap.meshes.ball(200, seed=1), kind="cell")
    assert r.n_folded_faces == 0 and not any("folded" in note for note in r.notes)


def test_the_cell_checks_semidefiniteness_speaks_of_cells(monkeypatch):
    """Issue 37.22: the cell check's witness spoke of "a vector on N vertices around
    vertex K" where its rows are cells; every route's reason names cells. The last
    routes, forced, run on a mesh with more vertices than cells (the vertex mask of the
    dense route was built over the cells' indices)."""
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=3)
    r = tetlap.check(tetlap.cell_laplacian(V, T), V, T, kind="cell")
    assert r.nsd is False and r.nsd_method.startswith("witness: a vector on ")
    assert " cells around cell " in r.nsd_method and "vert" not in r.nsd_method
    V, T = tetlap.meshes.ball(60, seed=1)
    V = np.vstack([V, np.random.default_rng(0).uniform(5, 6, (len(T), 3))])  # n > m
    Lc = tetlap.cell_laplacian(V, T)
    monkeypatch.setattr(tetlap.analysis._core, "negative_semidefinite",
                        lambda n, S, tol: (None, "undetermined", {"uncovered": 2}))
    monkeypatch.setattr(tetlap.analysis, "_ldl_inertia", lambda A, shift: None)
    r = tetlap.check(Lc, V, T, kind="cell")
    assert r.nsd is True and r.nsd_method.startswith("dense eigenvalues")
    assert "<= 600 cells" in r.nsd_method and "vert" not in r.nsd_method


def test_check_refuses_the_stiffness_sign():
    """Issue 37.22: check(-L) (LaPy's and scikit-fem's stiffness sign) reported an
    indefinite operator with 69% negative weights: every sign-dependent row answered for
    the negated Laplacian. It is refused, naming the convention, for every kind."""
    V, T = tetlap.meshes.cube(3, jitter=0.2)
    for kind in ("primal", "dual", None):
        L = tetlap.laplacian(V, T, kind or "primal")
        assert tetlap.check(L, V, T, kind=kind, nsd=False).symmetric
        with pytest.raises(tetlap.OptionError, match=r"non-negative diagonal.*-K"):
            tetlap.check(-L, V, T, kind=kind)
    with pytest.raises(tetlap.OptionError, match="non-negative diagonal"):
        tetlap.analysis.negative_weights(-L, V, T)
    with pytest.raises(tetlap.OptionError, match="non-negative diagonal"):
        W, C = tetlap.meshes.ball(300, seed=2)                 # Delaunay: a negative diagonal
        tetlap.check(-tetlap.cell_laplacian(W, C), W, C, kind="cell")
    # a broken Laplacian of the right sign is reported, not refused
    bad = L.tolil()
    bad[0, 1] = -5.0
    assert tetlap.check(bad.tocsr(), V, T, nsd=False).symmetric is False
