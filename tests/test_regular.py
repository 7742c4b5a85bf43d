"""Regular weights (issue 16): tetlap.regular.regular_weights, face_margins (the `info`
summary of them is tested in test_info.py)."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import tetlap
import tetlap.regular as regular
from tetlap.diagnostics import interior_faces, non_delaunay_faces
from tetlap.regular import face_margins, regular_weights

from conftest import corpus_mesh


def power_center(X, w):
    """Point with equal power |c - x|^2 - w to the 4 corners X (4, 3)."""
    A = 2 * (X[1:] - X[0])
    rhs = ((X[1:] - X[0]) ** 2).sum(axis=1) + w[0] - w[1:]
    return X[0] + np.linalg.solve(A, rhs)


def weighted_points(seed, n=250, scale=0.05):
    rng = np.random.default_rng(seed)
    P = rng.uniform(-1, 1, size=(n, 3))
    w = rng.uniform(0, scale, size=n)
    T = tetlap.meshes.regular_triangulation(P, w)
    return tetlap.meshes.compact(P, T, w)


def interior_dual_weights(V, T, w):
    edges, weights = tetlap.edge_weights(V, T, "dual", weights=w)
    b = tetlap.diagnostics.boundary_vertices(T, len(V))
    return weights[~(b[edges[:, 0]] & b[edges[:, 1]])], np.abs(weights).max()


def test_margin_is_the_signed_dual_edge_length_over_the_face_size(rng):
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=3)
    w = rng.uniform(-0.01, 0.01, size=len(V))
    g = face_margins(V, T, w)
    tets, opposite = interior_faces(T)
    for f in rng.choice(len(g), size=20, replace=False):
        c1 = power_center(V[T[tets[f, 0]]], w[T[tets[f, 0]]])
        c2 = power_center(V[T[tets[f, 1]]], w[T[tets[f, 1]]])
        face = [k for k in T[tets[f, 0]] if k != opposite[f, 0]]
        F = V[face]
        n = np.cross(F[1] - F[0], F[2] - F[0])
        n *= np.sign(n @ (V[opposite[f, 1]] - F[0])) / np.linalg.norm(n)
        rms = np.sqrt(((F - np.roll(F, 1, axis=0)) ** 2).sum(axis=1).mean())
        assert g[f] == pytest.approx((c2 - c1) @ n / rms, rel=1e-9, abs=1e-12)
        assert np.linalg.norm(np.cross(c2 - c1, n)) < 1e-9  # the dual edge is orthogonal


def test_zero_weights_margin_sign_is_the_delaunay_test():
    V, T = tetlap.meshes.weighted_ball(500, 1.0, seed=1)
    g = face_margins(V, T)
    np.testing.assert_array_equal(g < 0, non_delaunay_faces(V, T))
    assert (g < 0).sum() > 20


@pytest.mark.parametrize("seed", [0, 1])
def test_regular_triangulations_are_recognised(seed):
    V, T, w_true = weighted_points(seed)
    assert face_margins(V, T, w_true).min() > 0  # the generating weights certify it
    r = regular_weights(V, T)
    assert r.regular and r.margin > 0 and len(r.violated_faces) == 0
    assert r.n_violated_plain > 0 and r.n_negative_interior_plain > 0
    inner, scale = interior_dual_weights(V, T, r.weights)
    assert inner.min() >= -1e-12 * scale
    assert r.n_negative_interior_weighted == 0
    L, M = tetlap.operators(V, T, "dual", "circumcentric", weights=r.weights)
    rep = tetlap.check(L, V, T, M, nsd=False)
    assert rep.linear_precision_ok and rep.symmetric
    # (not NSD in general: the convex hull's slivers give negative boundary weights)
    # masses: reported exactly; a few boundary cells may be lost (the generating weights
    # themselves lose one of seed 1's), never many
    m0 = tetlap.mass(V, T, "circumcentric").diagonal()
    np.testing.assert_array_equal(r.masses_lost, np.flatnonzero((m0 > 0) & (M.diagonal() <= 0)))
    assert len(r.masses_lost) <= 0.01 * len(V)


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10**6), scale=st.sampled_from([0.01, 0.05, 0.2]))
def test_random_regular_triangulations(seed, scale):
    V, T, w_true = weighted_points(seed, n=80, scale=scale)
    try:  # the hull of random points has slivers the core refuses even with w_true
        tetlap.edge_weights(V, T, "dual", weights=w_true)
    except tetlap.DegenerateElementError:
        assume(False)
    r = regular_weights(V, T)
    assert r.regular and r.status == "regular"
    inner, s = interior_dual_weights(V, T, r.weights)
    assert inner.min() >= -1e-12 * s
    np.testing.assert_allclose(r.face_margins, face_margins(V, T, r.weights))


def test_delaunay_meshes_are_regular_at_zero_weights():
    V, T = tetlap.meshes.ball(600, seed=2)
    r = regular_weights(V, T)
    assert r.status == "regular" and r.margin > 0 and r.lp_count == 0
    assert not r.weights.any()
    # a Kuhn grid: cospherical faces, margin 0 to rounding, still regular
    V, T = tetlap.meshes.cube(4)
    r = regular_weights(V, T)
    assert r.regular and abs(r.margin) < 1e-9 and not r.weights.any()


def mother_of_all_examples(twist_deg):
    """The classic non-regular planar triangulation (an inner triangle inside an outer
    one, the three quads between split cyclically), coned to an apex above and below:
    8 vertices, 14 tets. A twist of -10 degrees makes it Delaunay; +10 degrees makes it
    non-regular (checked independently by a full LP in the test)."""
    a = np.radians([90.0, 210.0, 330.0])
    outer = np.column_stack([np.cos(a), np.sin(a)])
    b = a + np.radians(twist_deg)
    inner = 0.35 * np.column_stack([np.cos(b), np.sin(b)])
    tris = [[3, 4, 5]]
    for k in range(3):
        tris += [[k, (k + 1) % 3, 3 + (k + 1) % 3], [k, 3 + (k + 1) % 3, 3 + k]]
    V = np.vstack([np.column_stack([np.vstack([outer, inner]), np.zeros(6)]),
                   [[0, 0, 1.0], [0, 0, -1.0]]])
    T = np.array([t + [6] for t in tris] + [t + [7] for t in tris])
    return V, tetlap.meshes.orient(V, T)


def best_margin_by_full_lp(V, T, box=10.0):
    """Independent check: the largest smallest margin over all faces, by one dense LP
    whose rows come from face_margins (linear in w) evaluated at unit weights."""
    from scipy.optimize import linprog

    n = len(V)
    g0 = face_margins(V, T)
    G = np.column_stack([face_margins(V, T, np.eye(n)[i]) - g0 for i in range(n)])
    c = np.zeros(n + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=np.hstack([-G, np.ones((len(g0), 1))]), b_ub=g0,
                  bounds=[(-box, box)] * n + [(None, 1.0)])
    return res.x[-1]


def certificate_holds(V, T, faces, y, rng):
    """Independent check of a Gordan certificate: the faces are interior faces of the mesh
    and the combination ``sum_f y_f margin_f(w)`` of their margins (from face_margins,
    which is linear in w) is the same, 0, at random weights: then some face of the set
    has margin <= 0 whatever w."""
    all_faces = {tuple(sorted(f)): k for k, f in enumerate(interior_face_vertices(T))}
    ids = [all_faces[tuple(sorted(f))] for f in faces.tolist()]
    assert len(set(ids)) == len(ids) and (y > 0).all()
    h = tetlap.diagnostics.mesh_edges(T)
    scale = np.mean(np.sum((V[h[:, 0]] - V[h[:, 1]]) ** 2, axis=1))
    for w in [np.zeros(len(V))] + [rng.normal(size=len(V)) * scale for _ in range(3)]:
        g = face_margins(V, T, w)[ids]
        assert abs(y @ g) <= 1e-8 * (y @ np.abs(g))
    return True


def interior_face_vertices(T):
    """(f, 3) vertices of every interior face, order of interior_faces."""
    tets, opposite = interior_faces(T)
    T = np.asarray(T)
    return np.array([[k for k in T[t] if k != o] for t, o in zip(tets[:, 0], opposite[:, 0])])


def test_a_hand_built_non_regular_mesh_is_reported(rng):
    V, T = mother_of_all_examples(-10.0)
    r = regular_weights(V, T)
    assert r.regular and r.margin_plain > 0          # this twist is Delaunay
    V, T = mother_of_all_examples(10.0)
    assert best_margin_by_full_lp(V, T) < 1e-9       # no weights give a positive margin
    r = regular_weights(V, T)
    assert not r.regular and r.status == "not regular"
    assert r.margin < 0 and len(r.violated_faces) >= 1
    assert len(r.violated_faces) <= r.n_violated_plain
    assert r.certificate_residual < 1e-8
    assert certificate_holds(V, T, r.certificate_faces, r.certificate_multipliers, rng)


def test_a_corpus_mesh_named_in_the_issue_is_proved_non_regular(rng):
    V, T = corpus_mesh("libigl_octopus_low.mesh")
    r = regular_weights(V, T, time_limit=60)
    assert r.status == "not regular" and r.n_folded == 0
    assert 0 < len(r.certificate_faces) < r.n_violated_plain
    assert certificate_holds(V, T, r.certificate_faces, r.certificate_multipliers, rng)


def test_budget_exhausted_is_undecided():
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)   # regular, needs iterations
    r = regular_weights(V, T, max_iterations=1)
    assert r.status == "undecided" and not r.regular
    assert len(r.certificate_faces) == 0 and len(r.violated_faces) > 0
    assert any("max_iterations" in note for note in r.notes)
    # never worse than w = 0
    assert len(r.violated_faces) <= r.n_violated_plain
    r = regular_weights(V, T, time_limit=1e-9)
    assert r.status == "undecided" and any("time limit" in note for note in r.notes)


@pytest.mark.parametrize("s", [1e-3, 1e3])
def test_status_and_margin_are_scale_invariant(s):
    """The margin and its round-off tolerance are scale-free: V -> s V, w -> s^2 w
    changes neither the verdict nor the margin (nor the weights beyond s^2)."""
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=7)
    r = regular_weights(V, T, mass_floor=None)
    r2 = regular_weights(s * V, T, mass_floor=None)
    assert (r2.status, r2.n_violated_plain) == (r.status, r.n_violated_plain) == (
        "regular", r.n_violated_plain)
    assert r2.margin == pytest.approx(r.margin, rel=1e-6)
    np.testing.assert_allclose(r2.face_margins, r.face_margins, atol=1e-9)
    np.testing.assert_allclose(face_margins(s * V, T, s**2 * r.weights), r.face_margins,
                               atol=1e-9)
    np.testing.assert_allclose(r2.weights, s**2 * r.weights,
                               atol=1e-6 * s**2 * np.abs(r.weights).max())
    # the mass step is an infeasible hinge problem whose path changes with the last bit of
    # V (so with s = 1e3): the verdict holds; powers of two give the same bits
    r, r2 = regular_weights(V, T), regular_weights(s * V, T)
    assert r2.status == r.status == "regular" and r2.margin > 0
    b = 2.0 ** np.round(np.log2(s))
    rb = regular_weights(b * V, T)
    assert rb.margin == r.margin
    np.testing.assert_array_equal(rb.weights, b**2 * r.weights)
    # the Kuhn grid's cospherical faces (margin 0 to rounding) stay regular at any scale
    V, T = tetlap.meshes.cube(3)
    assert regular_weights(s * V, T).status == "regular"


def test_folded_faces_are_never_regular():
    V, T = tetlap.meshes.ball(300, seed=4)
    # move one interior vertex far through a face: its tets overlap others (folded)
    inner = np.flatnonzero(tetlap.diagnostics.interior_vertices(T, len(V)))
    tets, opposite = interior_faces(T)
    V2 = V.copy()
    i = inner[0]
    nb = T[(T == i).any(axis=1)]
    far = nb[nb != i][0]
    V2[i] = V[i] + 1.6 * (V[far] - V[i])
    r = regular_weights(V2, T)
    assert r.n_folded > 0 and not r.regular and r.margin <= 0


@pytest.mark.slow
def test_invariance_under_rigid_motions_and_scaling(rng):
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=7)
    r = regular_weights(V, T)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    s = 37.5
    V2 = s * V @ Q.T + rng.normal(size=3) * 10
    r2 = regular_weights(V2, T)
    assert r2.regular == r.regular
    assert (r2.status, r2.n_violated_plain) == (r.status, r.n_violated_plain)
    assert r2.margin_plain == pytest.approx(r.margin_plain, rel=1e-8)
    # the search's path may differ by rounding (a rotation changes every coordinate);
    # whatever weights it finds, the moved weights certify the moved mesh and back
    np.testing.assert_allclose(face_margins(V2, T, s**2 * r.weights), r.face_margins,
                               atol=1e-8)
    np.testing.assert_allclose(face_margins(V, T, r2.weights / s**2), r2.face_margins,
                               atol=1e-8)
    assert r2.margin > 0


def test_deterministic_and_inputs_untouched():
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=9)
    V0, T0 = V.copy(), T.copy()
    a, b = regular_weights(V, T), regular_weights(V, T)
    np.testing.assert_array_equal(a.weights, b.weights)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(T, T0)


def test_bad_input_raises_tetlap_errors():
    V, T = tetlap.meshes.ball(100, seed=0)
    with pytest.raises(tetlap.ShapeError):
        regular_weights(V[:, :2], T)
    V2 = V.copy()
    V2[3] = np.nan
    with pytest.raises(tetlap.NonFiniteError):
        regular_weights(V2, T)
    with pytest.raises(tetlap.IndexRangeError):
        regular_weights(V, np.vstack([T, [[0, 1, 2, len(V)]]]))
    with pytest.raises(tetlap.OptionError):
        regular_weights(V, T, target_margin=-1)
    with pytest.raises(tetlap.OptionError):
        regular_weights(V, T, boundary="fixed")
    with pytest.raises(tetlap.OptionError):
        regular_weights(V, T, time_limit=0)
    with pytest.raises(tetlap.OptionError):
        regular_weights(V, T, max_iterations=0)
    with pytest.raises(tetlap.ShapeError):
        face_margins(V, T, np.zeros(3))


def test_boundary_zero_keeps_boundary_weights_at_zero():
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    b = tetlap.diagnostics.boundary_vertices(T, len(V))
    r = regular_weights(V, T, boundary="zero")
    assert not r.weights[b].any()
    if r.regular:
        assert r.n_negative_interior_weighted == 0


@pytest.mark.slow
def test_masses_stay_positive_where_the_plain_ones_are():
    V, T = tetlap.meshes.weighted_ball(500, 1.0, seed=4)
    r = regular_weights(V, T)
    m0 = tetlap.mass(V, T, "circumcentric").diagonal()
    m = tetlap.mass(V, T, "circumcentric", weights=r.weights).diagonal()
    np.testing.assert_array_equal(np.flatnonzero((m0 > 0) & (m <= 0)), r.masses_lost)
    assert len(r.masses_lost) == 0
    # interior cells of a regular mesh are convex polytopes: positive
    inner = tetlap.diagnostics.interior_vertices(T, len(V))
    assert (m[inner] > 0).all()


def test_mass_step_line_search_keeps_the_masses():
    # the mass step used to take its linearised steps whole and rejected every round here
    # (7 masses lost); the line search on the true masses keeps them all
    V, T = tetlap.meshes.weighted_ball(1000, 1.0, seed=1)
    r = regular_weights(V, T)
    assert r.regular and r.margin > 0 and r.n_negative_interior_weighted == 0
    m0 = tetlap.mass(V, T, "circumcentric").diagonal()
    m = tetlap.mass(V, T, "circumcentric", weights=r.weights).diagonal()
    np.testing.assert_array_equal(np.flatnonzero((m0 > 0) & (m <= 0)), r.masses_lost)
    assert len(r.masses_lost) == 0 and len(r.masses_lost_tets) == 0


def test_masses_are_cubic_along_a_segment_of_weights(rng):
    # what the line search of the mass step relies on: power centres are affine in w
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=5)
    w0, w1 = (rng.uniform(-0.005, 0.005, size=len(V)) for _ in range(2))
    ts = np.array([0, 1 / 3, 2 / 3, 1])
    M = np.stack([regular._masses(V, T, w0 + t * (w1 - w0)) for t in ts])
    C = np.linalg.solve(np.vander(ts, 4, increasing=True), M)
    for t in (0.1, 0.5, 0.9):
        np.testing.assert_allclose(np.vander([t], 4, increasing=True)[0] @ C,
                                   regular._masses(V, T, w0 + t * (w1 - w0)),
                                   rtol=0, atol=1e-12 * np.abs(M).max())


def test_lost_masses_are_explained(rng):
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=5)
    on_b = tetlap.diagnostics.boundary_vertices(T, len(V))
    w = rng.uniform(-0.05, 0.05, size=len(V))
    m0 = tetlap.mass(V, T, "circumcentric").diagonal()
    m = regular._masses(V, T, w)
    lost = np.flatnonzero((m0 > 0) & (m <= 0))
    assert len(lost)
    tets, note = regular._why_masses_lost(V, T, w, lost, np.zeros(len(T), dtype=bool), on_b)
    assert len(tets) == len(lost) and f"{len(lost)} positive plain masses" in note
    for v, t in zip(lost, tets):
        assert v in T[t]


def test_mass_jacobian_matches_finite_differences(rng):
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=5)
    w = rng.uniform(-0.005, 0.005, size=len(V))
    rows = np.array([3, 10, 50])
    J = regular._mass_jacobian(V, T, w, rows).toarray()
    h = 1e-6
    for j in np.flatnonzero(np.abs(J).sum(axis=0) > 0)[:10]:
        e = np.zeros(len(V))
        e[j] = h
        d = (tetlap.mass(V, T, "circumcentric", weights=w + e).diagonal()
             - tetlap.mass(V, T, "circumcentric", weights=w - e).diagonal()) / (2 * h)
        np.testing.assert_allclose(J[:, j], d[rows], rtol=1e-5, atol=1e-9)


@pytest.mark.slow
def test_doctests():
    result = doctest.testmod(regular, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 5 and result.failed == 0


CORPUS = {"flipfree_fish_blub.mesh": True, "sofa_raptor_8418.vtu": True,
          "libigl_octopus_low.mesh": False, "polyfem_microstructure_p1.msh": False}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CORPUS))
def test_corpus_meshes_named_in_the_issue(name):
    V, T = corpus_mesh(name)
    r = regular_weights(V, T, time_limit=300)
    assert r.regular == CORPUS[name]
    if r.regular:
        assert r.margin > 0 and r.n_negative_interior_weighted == 0
        L = tetlap.laplacian(V, T, "dual", weights=r.weights)
        assert tetlap.check(L, V, T, nsd=False).linear_precision_ok
        m0 = tetlap.mass(V, T, "circumcentric").diagonal()
        m = tetlap.mass(V, T, "circumcentric", weights=r.weights).diagonal()
        np.testing.assert_array_equal(r.masses_lost, np.flatnonzero((m0 > 0) & (m <= 0)))
        assert len(r.masses_lost) == 0
    else:
        assert len(r.violated_faces) > 0
        assert len(r.violated_faces) <= r.n_violated_plain


@pytest.mark.slow
@pytest.mark.parametrize("name", ["libigl_decimated_knight.mesh", "simnibs_sphere3.msh"])
def test_corpus_masses_kept_by_the_line_search(name):
    # 6 and 27 masses lost before the mass step's line search, 0 with it
    V, T = corpus_mesh(name)
    r = regular_weights(V, T, time_limit=300)
    assert r.regular and len(r.masses_lost) == 0
