"""tetlap.info.report, the numbers behind ``tetlap info``, against independent routes.

Every number of the report is recomputed here another way: the mesh counts, volumes,
dihedral angles, Delaunay and well-centredness tests with NumPy from (V, T); the weights
from :func:`tetlap.edge_weights`; row sums, linear precision and the masses with NumPy
from the assembled matrices (the circumcentric mass by the pyramid identity); the
semidefiniteness from dense eigenvalues where the report used them. Rounding-sensitive
decisions (a point on a circumsphere, a right angle) are allowed either way inside a
tolerance band.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

import tetlap
from tetlap import info
from tetlap.meshes import orient

from conftest import read_mesh, real_mesh_paths

PAIRS = {"primal": "barycentric", "dual": "circumcentric"}
FACES = [list(f) for f in itertools.combinations(range(4), 3)]
EDGES = list(itertools.combinations(range(4), 2))
NEGATIVE_TOL = 1e-12


# ---- independent computations ---------------------------------------------------------


def volumes(V, T):
    X = V[T]
    return np.linalg.det(X[:, 1:] - X[:, :1]) / 6


def exact_volume6(X):
    """``det[x1-x0, x2-x0, x3-x0]`` of a tet's (4, 3) corners, in exact rationals."""
    from fractions import Fraction

    (a, b, c), (d, e, f), (g, h, i) = [[Fraction(float(x)) - Fraction(float(y))
                                        for x, y in zip(X[k], X[0])] for k in (1, 2, 3)]
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def dihedral_angles(V, T):
    """(m, 6) degrees at the local edges (0,1), (0,2), ... from the normals of the two
    faces at each edge (both taken with the edge's direction)."""
    X = V[T]
    out = np.empty((len(T), 6))
    for k, (a, b) in enumerate(EDGES):
        c, d = [i for i in range(4) if i not in (a, b)]
        e = X[:, b] - X[:, a]
        n1, n2 = np.cross(e, X[:, c] - X[:, a]), np.cross(e, X[:, d] - X[:, a])
        out[:, k] = np.degrees(np.arctan2(np.linalg.norm(np.cross(n1, n2), axis=1),
                                          np.einsum("ij,ij->i", n1, n2)))
    return out


def circumspheres(X):
    """Circumcenters (m, 3) and squared radii (m,) of tets X (m, 4, 3); NaN when flat."""
    A = 2 * (X[:, 1:] - X[:, :1])
    b = (X[:, 1:] ** 2).sum(axis=2) - (X[:, :1] ** 2).sum(axis=2)
    ok = np.abs(np.linalg.det(A)) > 1e-300
    c = np.full((len(X), 3), np.nan)
    c[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    return c, ((c - X[:, 0]) ** 2).sum(axis=1)


def face_table(T):
    """Sorted faces, their counts, and for each face occurrence: (tet, opposite corner)."""
    F = np.sort(np.concatenate([T[:, f] for f in FACES]), axis=1)
    tet = np.tile(np.arange(len(T)), 4)
    corner = np.repeat([3, 2, 1, 0], len(T))  # FACES[k] leaves out corner 3 - k
    keys, inverse, counts = np.unique(F, axis=0, return_inverse=True, return_counts=True)
    return keys, inverse.ravel(), counts, tet, corner


def delaunay_bounds(V, T, keys, inverse, counts, tet, corner):
    """(definitely non-Delaunay interior faces, undecidable ones) of a manifold mesh: the
    second tet's opposite vertex inside / within 1e-8 of the first tet's circumsphere."""
    order = np.argsort(inverse, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])[:-1]
    pairs = counts == 2
    first, second = order[starts[pairs]], order[starts[pairs] + 1]
    # the tet with the lower index is "the first" (as in tetlap.diagnostics.interior_faces)
    swap = tet[first] > tet[second]
    first, second = np.where(swap, second, first), np.where(swap, first, second)
    t1, t2, o2 = tet[first], tet[second], corner[second]
    c, r2 = circumspheres(V[T[t1]])
    d2 = ((V[T[t2, o2]] - c) ** 2).sum(axis=1)
    margin = (r2 - d2) / r2
    unsure = ~np.isfinite(margin) | (np.abs(margin) <= 1e-8)
    return int((margin > 1e-8).sum()), int(unsure.sum())


def well_centered_bounds(V, T):
    """(definitely well-centred tets, undecidable ones): circumcenter strictly inside the
    tet and every face angle acute, with a band of 1e-9 for rounding."""
    X = V[T]
    c, _ = circumspheres(X)
    M = np.concatenate([np.transpose(X, (0, 2, 1)), np.ones((len(X), 1, 4))], axis=1)
    ok = np.isfinite(c).all(axis=1)
    bary = np.full((len(X), 4), np.nan)
    bary[ok] = np.linalg.solve(M[ok], np.concatenate([c[ok], np.ones((ok.sum(), 1))], axis=1)[..., None])[..., 0]
    cosines = []
    for f in FACES:
        P = X[:, f]
        for i in range(3):
            u, v = P[:, (i + 1) % 3] - P[:, i], P[:, (i + 2) % 3] - P[:, i]
            cosines.append(np.einsum("ij,ij->i", u, v)
                           / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)))
    cosines = np.column_stack(cosines)
    sure = ok & (bary.min(axis=1) > 1e-9) & (cosines.min(axis=1) > 1e-9)
    maybe = ~ok | (np.abs(bary).min(axis=1) <= 1e-9) | (np.abs(cosines).min(axis=1) <= 1e-9)
    return int(sure.sum()), int((maybe & ~sure).sum())


def assert_mesh_summary(V, T, m):
    n = len(V)
    vol = volumes(V, T)
    mean = np.abs(vol).mean()
    assert (m["n_vertices"], m["n_tets"]) == (n, len(T))
    near_zero = (np.abs(vol) <= 1e-10 * mean).sum()
    assert abs(m["n_positive_tets"] - (vol > 0).sum()) <= near_zero
    assert abs(m["n_negative_tets"] - (vol < 0).sum()) <= near_zero
    assert m["n_positive_tets"] + m["n_negative_tets"] == len(T) - (vol == 0).sum()
    # degenerate: exactly flat (exact determinants of the candidates near zero)
    candidates = np.flatnonzero(np.abs(vol) <= 1e-10 * mean)
    assert m["n_degenerate_tets"] == sum(exact_volume6(V[T[k]]) == 0 for k in candidates)
    assert m["mesh_volume"] == pytest.approx(np.abs(vol).sum(), rel=1e-9)
    used = np.unique(T)
    assert m["n_unreferenced_vertices"] == n - len(used)
    assert m["n_duplicate_tets"] == len(T) - len(np.unique(np.sort(T, axis=1), axis=0))
    keys, inverse, counts, tet, corner = face_table(T)
    assert m["n_boundary_faces"] == (counts == 1).sum()
    assert m["n_interior_faces"] == (counts[counts >= 2] - 1).sum()
    assert m["n_nonmanifold_faces"] == (counts > 2).sum()
    assert m["n_boundary_vertices"] == len(np.unique(keys[counts == 1]))
    fine = np.abs(vol) > 1e-10 * mean
    if fine.all():  # (flat tets: NaN in the core, 0 or 180 here)
        angles = dihedral_angles(V, T)
        assert m["min_dihedral_deg"] == pytest.approx(angles.min(), abs=1e-6)
        assert m["max_dihedral_deg"] == pytest.approx(angles.max(), abs=1e-6)
        sure, unsure = well_centered_bounds(V, T)
        assert sure <= m["well_centered_tet_fraction"] * len(T) + 1e-9 <= sure + unsure + 1e-6
        if (counts <= 2).all():
            bad, unsure = delaunay_bounds(V, T, keys, inverse, counts, tet, corner)
            assert bad <= m["n_non_delaunay_faces"] <= bad + unsure
            assert m["non_delaunay_face_fraction"] == pytest.approx(
                m["n_non_delaunay_faces"] / max(m["n_interior_faces"], 1))


def assert_operator_report(V, T, kind, r, boundary):
    """The Report dict of ``kind`` with the mass of PAIRS[kind] against NumPy."""
    n = len(V)
    L = tetlap.laplacian(V, T, kind, degenerate="skip")
    scale = abs(L).max()
    assert r["n_vertices"] == n and r["n_tets"] == len(T)
    assert r["finite"] == bool(np.isfinite(L.data).all())
    assert r["symmetry_error"] == abs(L - L.T).max()
    assert r["max_row_sum"] == pytest.approx(np.abs(L.sum(axis=1)).max(), abs=1e-14 * scale)
    assert r["local"] is True
    edges, w = tetlap.edge_weights(V, T, kind, degenerate="skip")
    inner = ~(boundary[edges[:, 0]] & boundary[edges[:, 1]])
    negative = w < -NEGATIVE_TOL * np.abs(w).max()
    assert r["n_edges"] == len(edges) and r["n_edges_interior"] == inner.sum()
    assert r["min_weight"] == w.min()
    assert r["n_negative"] == negative.sum() and r["n_negative_interior"] == (negative & inner).sum()
    assert r["negative_fraction"] == pytest.approx(negative.mean())
    # linear precision: max |(L (V - c))_i| at interior vertices / (max|L| * bbox diagonal
    # of the vertices in tets), c the box's centre (issue 37: the frame of the origin
    # failed a perfect operator 1e6 away); the masses over those vertices too (issue 30:
    # an unused vertex takes no part)
    used = np.isin(np.arange(n), T)
    interior = ~boundary & used
    if interior.any():
        low, high = V[used].min(axis=0), V[used].max(axis=0)
        diagonal = np.linalg.norm(high - low)
        residual = np.abs((L @ (V - (low + high) / 2))[interior]).max() / (scale * diagonal)
        assert r["linear_precision_residual"] == pytest.approx(residual, rel=1e-6, abs=1e-13)
    else:
        assert r["linear_precision_residual"] is None
    if kind == "primal" and r["nsd"] is not None:
        assert r["nsd"], "the primal is always negative semidefinite"
    if r["nsd_method"] == "dense eigenvalues":
        lam = np.linalg.eigvalsh(-(L + L.T).toarray() / 2)[0]
        assert r["nsd_min_eigenvalue_upper_bound"] == pytest.approx(lam, abs=1e-10 * scale)
        if abs(lam) > 1e-8 * scale:
            assert r["nsd"] == (lam > 0 or lam >= -1e-9 * scale)
    # the mass: barycentric = |Vol| / 4 per corner; circumcentric by the pyramid identity
    vol = np.abs(volumes(V, T))
    if PAIRS[kind] == "barycentric":
        m = np.bincount(T.ravel(), weights=np.repeat(vol / 4, 4), minlength=n)
    else:
        coo = L.tocoo()
        off = coo.row != coo.col
        sq = ((V[coo.row[off]] - V[coo.col[off]]) ** 2).sum(axis=1)
        m = np.bincount(coo.row[off], weights=sq * coo.data[off], minlength=n) / 6
    big = np.abs(m).max()
    assert r["mass_total"] == pytest.approx(vol.sum(), rel=1e-9)
    assert r["mesh_volume"] == pytest.approx(vol.sum(), rel=1e-9)
    assert r["mass_min"] == pytest.approx(m[used].min(), rel=1e-6, abs=1e-9 * big)
    eps = 1e-9 * big
    assert (m[used] < -eps).sum() <= r["mass_nonpositive"] <= (m[used] <= eps).sum()


def assert_report(V, T, result):
    assert list(result) == ["schema_version", "mesh", "primal", "dual", "regular", "coefficient"]
    assert result["schema_version"] == info.SCHEMA_VERSION
    json.dumps(result, allow_nan=False)  # JSON-ready, every float finite
    reg = result["regular"]
    if reg is not None and reg["status"] != "n/a":
        # the section reuses the plain dual's and the primal's counts
        for kind in ("dual", "primal"):
            assert reg["negative_interior_weights"][kind] == result[kind]["n_negative_interior"]
        if reg["status"] == "regular":
            assert reg["negative_interior_weights"]["weighted_dual"] == 0
    assert_mesh_summary(V, T, result["mesh"])
    keys, _, counts, _, _ = face_table(T)
    boundary = np.zeros(len(V), dtype=bool)
    boundary[keys[counts == 1].ravel()] = True
    for kind in PAIRS:
        assert_operator_report(V, T, kind, result[kind], boundary)


# ---- built-in meshes ------------------------------------------------------------------


def mixed_cube():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=2)
    T = T.copy()
    T[::3, [0, 1]] = T[::3, [1, 0]]
    return V, T


def flawed_cube():
    """Unused vertex, a duplicate tet, a flat tet on the bottom face."""
    V, T = tetlap.meshes.cube(2, jitter=0.1, seed=1)
    V = np.vstack([V, [[7.0, 7.0, 7.0]]])
    return V, np.vstack([T, T[5:6, ::-1], [[0, 3, 9, 27]]])


BUILT_IN = {
    "Delaunay ball": lambda: tetlap.meshes.ball(800, seed=0),
    "non-Delaunay ball": lambda: tetlap.meshes.weighted_ball(600, 0.5, seed=1),
    "mixed orientation": mixed_cube,
    "flaws": flawed_cube,
}


@pytest.mark.parametrize("name", list(BUILT_IN))
def test_report_against_independent_routes(name):
    V, T = BUILT_IN[name]()
    assert_report(V, T, info.report(V, T, progress=False))


def check_report_of_a_delaunay_ball(result, V, T):
    """The facts of Table 1 on the Delaunay mesh ``(V, T)``, as the report ``result``
    states them (also what ``tetlap info --json`` prints: test_cli_info)."""
    assert result["mesh"]["n_tets"] == len(T)
    assert result["mesh"]["non_delaunay_face_fraction"] == 0.0  # a Delaunay mesh
    assert result["primal"]["nsd"] is True
    assert result["dual"]["negative_fraction_interior"] == 0.0
    edges, w = tetlap.edge_weights(V, T, "primal")
    assert result["primal"]["min_weight"] == pytest.approx(w.min(), rel=1e-12)
    for kind in ("primal", "dual"):
        assert result[kind]["mass_total"] == pytest.approx(result[kind]["mesh_volume"])


def test_report_of_a_delaunay_ball():
    V, T = tetlap.meshes.ball(800, seed=0)
    check_report_of_a_delaunay_ball(info.report(V, T, progress=False), V, T)


def test_report_of_a_non_delaunay_ball_says_indefinite():
    V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    result = info.report(V, T, progress=False)
    assert result["mesh"]["non_delaunay_face_fraction"] > 0
    assert result["dual"]["nsd"] is False and result["primal"]["nsd"] is True
    assert result["dual"]["n_negative_interior"] > 0


def test_nsd_false_skips_the_certificates_only():
    V, T = tetlap.meshes.ball(300, seed=3)
    a, b = info.report(V, T, progress=False), info.report(V, T, nsd=False, progress=False)
    for kind in PAIRS:
        assert b[kind]["nsd"] is None and "skipped" in b[kind]["nsd_method"]
        for key in set(a[kind]) - {"nsd", "nsd_min_eigenvalue_upper_bound", "nsd_method"}:
            assert a[kind][key] == b[kind][key], key
    assert a["mesh"] == b["mesh"]


def test_regular_section_compares_the_three_laplacians():
    """A regular non-Delaunay ball: the weights found remove every negative interior
    weight of the dual; the section's counts are those of tetlap.check."""
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    r = info.report(V, T, nsd=False, progress=False)["regular"]
    assert r["status"] == "regular" and r["regular"] is True and r["margin"] > 0
    n = r["negative_interior_weights"]
    assert n["dual"] > 0 and n["weighted_dual"] == 0
    assert n["primal"] == info.report(V, T, nsd=False, progress=False,
                                      regular=False)["primal"]["n_negative_interior"]
    w = tetlap.regular_weights(V, T).weights
    L = tetlap.laplacian(V, T, "dual", weights=w)
    assert tetlap.check(L, V, T, nsd=False).n_negative_interior == 0


def test_regular_section_statuses_and_budget():
    V, T = tetlap.meshes.ball(300, seed=3)                       # Delaunay
    r = info.report(V, T, nsd=False, progress=False)["regular"]
    assert r["status"] == "regular" and r["n_weighted_vertices"] == 0
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    r = info.report(V, T, nsd=False, progress=False, regular_time_limit=1e-9)["regular"]
    assert r["status"] == "undecided" and r["regular"] is False
    assert info.report(V, T, nsd=False, progress=False, regular=False)["regular"] is None
    V4 = np.hstack([V, np.zeros((len(V), 1))])                  # immersed in R^4: n/a
    assert info.report(V4, T, nsd=False, progress=False)["regular"]["status"] == "n/a"


def test_big_meshes_are_searched_only_when_asked(monkeypatch):
    V, T = tetlap.meshes.ball(300, seed=3)
    monkeypatch.setattr(info, "REGULAR_MAX_TETS", len(T) - 1)
    r = info.report(V, T, nsd=False, progress=False)["regular"]
    assert r["status"] == "n/a" and "--regular-time" in r["reason"]
    r = info.report(V, T, nsd=False, progress=False, regular_time_limit=30.0)["regular"]
    assert r["status"] == "regular"


def test_progress_goes_to_stderr_only(capsys):
    V, T = tetlap.meshes.cube(2)
    info.report(V, T, nsd=False, progress=True)
    out, err = capsys.readouterr()
    assert out == "" and "mesh diagnostics" in err


def test_report_rejects_triangles():
    with pytest.raises(tetlap.ShapeError):
        info.report([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], progress=False)


def test_regular_summary_counts_and_nsd():
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    s = info.regular_summary(V, T, nsd=True)
    assert s["regular"] is True and s["status"] == "regular"
    neg = s["negative_interior_weights"]
    assert neg["weighted_dual"] == 0 < neg["dual"]
    assert s["nsd"]["primal"]        # the weighted dual's NSD is not guaranteed (boundary)
    assert s["linear_precision_weighted_dual"]
    r = tetlap.regular_weights(V, T)
    again = info.regular_summary(V, T, r)            # a given result is used as it is
    assert again["margin"] == r.margin and again["iterations"] == r.iterations
    with pytest.raises(tetlap.ShapeError):
        info.regular_summary(V[:10], T, r)


@pytest.mark.parametrize("limit", [0, -1, float("nan"), float("inf"), "1", True])
def test_a_bad_regular_time_limit_is_an_option_error_before_any_work(limit, monkeypatch):
    """Issue 24.3: -1, 0 and NaN came back as a "n/a" row of the regular section."""
    def work(*args, **kwargs):
        raise AssertionError("work started before the option was checked")

    monkeypatch.setattr(tetlap.diagnostics, "_summary", work)
    with pytest.raises(tetlap.OptionError, match="^regular_time_limit must be a positive number"):
        info.report(*tetlap.meshes.cube(2), regular_time_limit=limit)


@pytest.mark.parametrize("scale", [1e200, 1e-200])
def test_a_mesh_beyond_the_float_range_is_refused(scale):
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(tetlap.DegenerateElementError, match="beyond the float64 range") as e:
        info.report(V * scale, T, progress=False)
    assert e.value.element == 0


def test_a_flat_tet_is_reported_not_refused():
    V, T = tetlap.meshes.cube(2)
    bottom = np.flatnonzero(V[:, 2] == 0)
    T = np.vstack([T, [bottom[[0, 1, 3, 4]]]])                   # four corners on z = 0
    result = info.report(V, T, progress=False)
    assert result["mesh"]["n_degenerate_tets"] == 1
    assert result["regular"]["status"] == "n/a"
    assert "tet 48 is flat (zero volume, exactly)" in result["regular"]["reason"]


# ---- plots ----------------------------------------------------------------------------


def sliver_ball():
    """A Delaunay ball with one vertex pushed almost onto a face: a few slivers whose
    weights are orders of magnitude beyond the others."""
    V, T = tetlap.meshes.ball(600, seed=2)
    V = V.copy()
    inner = np.flatnonzero(tetlap.diagnostics.interior_vertices(T, len(V)))
    t = T[np.flatnonzero((T == inner[0]).any(axis=1))[0]]
    a, b, c = V[t[t != inner[0]]]
    V[inner[0]] = (a + b + c) / 3 + 1e-7 * np.cross(b - a, c - a)
    return V, T


def test_spread_bins_show_the_distribution_where_linear_bins_show_one_spike():
    V, T = sliver_ball()
    for kind in ("primal", "dual"):
        _, w = tetlap.edge_weights(V, T, kind, degenerate="skip")
        linear, _ = np.histogram(w, bins=100)
        assert (linear > 0).sum() <= 5                          # the spike of the issue
        bins, threshold = info.spread_bins(w)
        spread, _ = np.histogram(w, bins=bins)
        assert spread.sum() == len(w)                           # every value in a bin
        assert spread.max() < 0.5 * len(w) and (spread > 0).sum() >= 10
        assert threshold == pytest.approx(1e-3 * np.median(np.abs(w[w != 0])))
    m = tetlap.mass(V, T, "circumcentric", degenerate="skip").diagonal()
    assert np.histogram(m, bins=info.spread_bins(m)[0])[0].sum() == len(m)


@pytest.mark.slow
def test_plot_names_files_and_titles_after_the_mesh(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    titles = []
    save = Figure.savefig

    def savefig(fig, path, **kwargs):
        titles.append((fig._suptitle.get_text() if fig._suptitle else "")
                      + " | " + " | ".join(ax.get_title() for ax in fig.axes))
        return save(fig, path, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    paths = info.plot(*sliver_ball(), tmp_path / "plots", name="sliver")
    assert [p.name for p in paths] == ["sliver_dihedral_angles.png", "sliver_weights.png",
                                       "sliver_masses.png"]
    assert all(p.stat().st_size > 5000 for p in paths)
    assert all(t.startswith("sliver: ") or " | sliver: " in t for t in titles), titles
    masses = titles[2]
    assert "barycentric mass: 0 of " in masses and "vertices with mass <= 0" in masses
    assert "% of the weights negative" in titles[1]


def test_the_plot_titles_count_what_the_table_counts(tmp_path, monkeypatch):
    """Issue 37.27: the titles of ``--plot`` counted masses <= 0 over every vertex (3 where
    the table said 0: the vertices in no tet) and weights < 0 without the table's
    tolerance (48 rounding zeros of the dual of a Kuhn grid). Both now come from the
    table's own rules (analysis.lumped_masses, analysis.negative_weights)."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    V, T = tetlap.meshes.cube(3)                       # Kuhn: dual weights of -2e-17
    V = np.vstack([V, [[5.0, 5.0, 5.0], [6.0, 5.0, 5.0], [5.0, 6.0, 5.0]]])  # in no tet
    titles = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, path, **kwargs: titles.extend(
        ax.get_title() for ax in fig.axes))
    info.plot(V, T, tmp_path, name="kuhn")
    r = info.report(V, T, nsd=False, regular=False, progress=False)
    used = len(V) - 3
    for kind, mass in PAIRS.items():
        share = 100 * r[kind]["n_negative"] / r[kind]["n_edges"]
        assert f"{kind} Laplacian: {share:.2f}% of the weights negative" in titles
        assert (f"{mass} mass: {r[kind]['mass_nonpositive']} of {used} vertices with "
                "mass <= 0") in titles
    assert r["dual"]["n_negative"] == 0 and r["primal"]["mass_nonpositive"] == 0


def test_the_linear_bin_around_zero_is_labelled(tmp_path, monkeypatch):
    """Issue 30: the symlog histograms drew [-threshold, threshold] as one unlabelled
    block; 0 and the threshold are ticks now, on every weight and mass axis."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    V, T = sliver_ball()
    _, w = tetlap.edge_weights(V, T, "dual", degenerate="skip")
    bins, threshold = info.spread_bins(w)
    ticks, labels = info.spread_ticks(w, bins, threshold)
    zero = ticks.index(0.0)
    assert ticks[zero - 1:zero + 2] == [-threshold, 0.0, threshold]
    assert labels[zero - 1:zero + 2] == ["$-t$", "$0$", "$t$"]
    assert ticks == sorted(ticks) and len(set(labels)) == len(labels)
    m = tetlap.mass(V, T, "barycentric", degenerate="skip").diagonal()   # all positive
    ticks, _ = info.spread_ticks(m, *info.spread_bins(m))
    assert min(ticks) == -info.spread_bins(m)[1]                       # no empty side

    axes = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, path, **kwargs: axes.extend(fig.axes))
    info.plot(*tetlap.meshes.weighted_ball(300, 0.5, seed=1), tmp_path, name="ball")
    spread = [ax for ax in axes if ax.get_xscale() == "symlog"]
    assert len(spread) == 4                                    # weights x 2, masses x 2
    for ax in spread:
        assert 0.0 in list(ax.get_xticks())
        assert "$0$" in [t.get_text() for t in ax.get_xticklabels()]
        assert "t = " in ax.get_xlabel() and "[-t, t]" in ax.get_xlabel()


def documented_keys():
    """{section: [keys]} of the tables of docs/api/info-json.md."""
    import pathlib
    import re

    text = (pathlib.Path(__file__).parent.parent / "docs/api/info-json.md").read_text()
    sections, current = {}, None
    for line in text.splitlines():
        if line.startswith("## "):
            current = line[3:].strip().strip("`").split("`")[0]
            sections[current] = []
        elif line.startswith("| `") and current is not None:
            sections[current] += re.findall(r"`(\w+)`", line.split("|")[1])
    return sections


def test_the_json_fields_are_documented_as_they_are():
    """Issue 24.9: the JSON changed shape silently; its fields are now documented in the
    API reference, every one of them, and nothing else."""
    docs = documented_keys()
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
    result = info.report(V, T, nsd=False, progress=False)
    assert set(docs["Top level"]) == set(result) | {"source", "non_finite"}
    assert docs["mesh"] == list(result["mesh"])
    assert set(docs["primal"]) == set(result["primal"]) == set(result["dual"])
    assert set(docs["regular"]) == set(result["regular"]) | {"reason"}
    V4 = np.hstack([V, np.zeros((len(V), 1))])            # the same keys when immersed
    assert list(info.report(V4, T, nsd=False, progress=False)["mesh"]) == docs["mesh"]


# ---- the corpus -----------------------------------------------------------------------


def corpus(predicate=lambda path: True):
    paths = [p for p in real_mesh_paths() if predicate(p)]
    if not paths:
        return [pytest.param(None, marks=pytest.mark.skip(
            reason="real-mesh corpus not found (set TETLAP_MESHES)"))]
    return [pytest.param(p, id=p.name) for p in paths]


@pytest.mark.slow
@pytest.mark.parametrize("path", corpus())
def test_report_agrees_with_independent_routes_on_every_real_mesh(path):
    V, T = read_mesh(path)
    assert_report(V, T, info.report(V, T, nsd=len(V) <= 3000, progress=False))


@pytest.mark.parametrize("path", corpus(lambda p: "mixed_orient" in p.name or "sphshells" in p.name))
def test_mixed_orientation_file_gives_the_numbers_of_a_reoriented_copy(path):
    V, T = read_mesh(path)
    a = info.report(V, T, nsd=False, progress=False)
    b = info.report(V, orient(V, T), nsd=False, progress=False)
    assert a["mesh"]["n_negative_tets"] > 0 and b["mesh"]["n_negative_tets"] == 0
    for kind in ("primal", "dual"):
        for key, value in a[kind].items():
            if key in ("max_row_sum", "linear_precision_residual"):
                continue  # rounding noise, checked relative to max|L| elsewhere
            elif isinstance(value, float):
                assert b[kind][key] == pytest.approx(value, rel=1e-9, abs=1e-15), key
            else:
                assert b[kind][key] == value, key
    assert a["mesh"]["non_delaunay_face_fraction"] == b["mesh"]["non_delaunay_face_fraction"]
