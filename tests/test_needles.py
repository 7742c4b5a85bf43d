"""Needles (issue 30): tets far longer than wide, in every orientation and vertex order,
up to the ends of the float64 range. Every value whose exact magnitude fits is computed
to the documented accuracy against exact rationals (plain, weighted, barycentric-boundary
and affine duals, primal weights and diagonal entries, circumcentric, mixed and
barycentric masses, derivatives); what does not fit is refused as beyond the range,
never called degenerate; the primal's diagonal is exact to its own digits, so its
semidefiniteness is seen; and ``tetlap info`` names the tets it skips.
"""

from __future__ import annotations

import json
from fractions import Fraction

import numpy as np
import pytest

import tetlap
import exact_reference as ex
from tetlap import info

ACCURACY = 1e-12
T1 = np.array([[0, 1, 2, 3]])
LARGEST = Fraction(np.finfo(np.float64).max)
BASE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
TILTED = np.array([[0, 0, 0], [1, 0, 0.5], [0, 1, 0.25]], float)


def needle(family: str, z: float) -> np.ndarray:
    """A needle of aspect about ``z``: its apex far above the base (``perp``), in the
    base's plane extended (``inplane``: weights and masses grow like ``z^4``), above a
    base tilted against it (``tilt``: the primal's weights at the apex cancel), with all
    four corners along one axis (``spread``), or a base ``1/z`` wide under an apex at 1."""
    if family == "perp":
        return np.vstack([BASE, [0.3, 0.2, z]])
    if family == "inplane":
        return np.vstack([BASE, [z, 0.2, 0.3]])
    if family == "tilt":
        return np.vstack([TILTED, [0.3, 0.2, z]])
    if family == "spread":
        return np.array([[0, 0, 0], [1, 0.5, 0], [0.3, 1, 0.1], [0.7, 0.2, 0.4]]) * [1, 1, z]
    return np.vstack([TILTED / z, [0.3 / z, 0.2 / z, 1.0]])


#: Vertex orders: as built, the apex first, and a cycle.
ORDERS = [[0, 1, 2, 3], [3, 0, 1, 2], [2, 3, 1, 0]]


def exact(X, kind):
    """The exact per-tet values of ``kind`` (a list of Fractions) for the corners ``X``."""
    if kind == "primal":
        return ex.primal_tet(X)
    if kind == "diagonal":
        d = [Fraction(0)] * 4
        for (a, b), w in zip(ex.EDGES, ex.primal_tet(X)):
            d[a] -= w
            d[b] -= w
        return d
    if kind in ("weighted", "weighted mass"):
        h2 = min(ex.dot(ex.sub(X[a], X[b]), ex.sub(X[a], X[b])) for a, b in ex.EDGES)
        W = [0.0, float(h2) * 1e-3, 0.0, float(h2) * 2e-3]
        return ex.dual_tet(X, W)[kind == "weighted mass"], np.array(W)
    placement = {"barycentric": "centroids", "barycentric mass": "centroids",
                 "mixed": "snapped"}.get(kind, "centres")
    w, m = ex.dual_tet(X, None, placement)
    return m if kind in ("circumcentric", "barycentric mass", "mixed") else w


def computed(P, kind, weights=None):
    """tetlap's per-tet values of ``kind`` for the corners ``P``."""
    if kind == "primal":
        return tetlap.element_contributions(P, T1, "primal")[0]
    if kind == "diagonal":
        return tetlap.laplacian(P, T1, "primal").diagonal()
    if kind == "dual":
        return tetlap.element_contributions(P, T1, "dual")[0]
    if kind == "weighted":
        return tetlap.element_contributions(P, T1, "dual", weights=weights)[0]
    if kind == "weighted mass":
        return tetlap.mass(P, T1, "circumcentric", weights=weights).diagonal()
    if kind == "barycentric":
        return tetlap.element_contributions(P, T1, "dual", boundary_centres="barycentric")[0]
    if kind == "barycentric mass":
        return tetlap.mass(P, T1, "circumcentric", boundary_centres="barycentric").diagonal()
    return tetlap.mass(P, T1, kind).diagonal()


KINDS = ["primal", "diagonal", "dual", "weighted", "weighted mass", "barycentric",
         "barycentric mass", "circumcentric", "mixed"]


def check_kind(P, kind):
    X = [ex.vec(p) for p in P]
    reference = exact(X, kind)
    weights = None
    if isinstance(reference, tuple):
        reference, weights = reference
    largest = max(abs(x) for x in reference)
    if largest > LARGEST:
        # beyond the range: refused as such, never as degenerate
        with pytest.raises(tetlap.DegenerateElementError, match="float64 range") as e:
            computed(P, kind, weights)
        assert "zero volume" not in str(e.value)
        return
    values = computed(P, kind, weights)
    errors = [abs(Fraction(float(v)) - x) for v, x in zip(values, reference)]
    if kind == "diagonal":  # each entry against itself
        worst = max(e / abs(x) for e, x in zip(errors, reference))
    else:
        worst = max(errors) / largest
    assert worst <= ACCURACY, f"{kind}: error {float(worst):.1e}"


@pytest.mark.parametrize("order", range(len(ORDERS)))
@pytest.mark.parametrize("z", [1e20, 1e150] + [pytest.param(z, marks=pytest.mark.slow)
                                                for z in (1e100, 1e200, 1e300)])
@pytest.mark.parametrize("family", ["perp", "inplane", "tilt", "spread", "tiny"])
def test_needles_equal_exact_rationals_or_leave_the_range(family, z, order):
    """Issue 30.1: apex at 1e50 and the plain dual refused as beyond the range while its
    values fit, 1e200 called degenerate, and (found on the way) the dual 30 % wrong with
    the apex as the first corner. Every kind, three vertex orders."""
    if family == "tiny" and z > 1e150:
        z = 1e150                                     # the volume 1e-300 stays normal
    P = needle(family, z)[ORDERS[order]]
    for kind in KINDS:
        check_kind(P, kind)


@pytest.mark.parametrize("family", ["perp", "tilt", "tiny"])
def test_the_volume_of_a_needle_is_its_own_and_not_zero(family):
    """A needle whose frame's determinant underflows (apex at 1e200, volume 1.7e199) is
    no degenerate tet: its volume, its masses and the mesh report agree with exact
    arithmetic."""
    P = needle(family, 1e200 if family != "tiny" else 1e150)
    X = [ex.vec(p) for p in P]
    volume = ex.det3(*[ex.sub(X[k], X[0]) for k in (1, 2, 3)]) / 6
    assert tetlap.diagnostics.signed_volumes(P, T1)[0] == pytest.approx(float(volume), rel=1e-15)
    assert tetlap.mass(P, T1, "barycentric").sum() == pytest.approx(float(volume), rel=1e-15)
    summary = tetlap.diagnostics.summary(P, T1)
    assert summary["n_degenerate_tets"] == 0 and summary["mesh_volume"] > 0


def test_only_an_exactly_flat_tet_is_degenerate():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1e300, 1e300, 0.0]])
    for kind in ("primal", "dual"):
        with pytest.raises(tetlap.DegenerateElementError, match="zero volume"):
            tetlap.laplacian(flat, T1, kind)
    # a needle whose frame's determinant underflows: computed (its values fit) ...
    assert np.isfinite(tetlap.laplacian(needle("perp", 1e300), T1, "dual").data).all()
    # ... or refused as beyond the range (its dual weights are about 1e399)
    with pytest.raises(tetlap.DegenerateElementError, match="float64 range") as e:
        tetlap.laplacian(needle("inplane", 1e100), T1, "dual")
    assert "zero volume" not in str(e.value)
    L, M = tetlap.operators(needle("inplane", 1e100), T1, "primal", "barycentric")
    assert np.isfinite(L.data).all() and M.sum() > 0


def with_needle(V, T, z):
    """``(V, T)`` with a tilted needle glued on a boundary face (its apex ``z`` away)."""
    f = tetlap.diagnostics.boundary_faces(T)[0]
    c = V[f].mean(axis=0)
    n = np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])
    n = n / np.linalg.norm(n) * np.sign(np.dot(n, c - V.mean(axis=0)))
    u = (V[f[1]] - V[f[0]]) / np.linalg.norm(V[f[1]] - V[f[0]])
    return np.vstack([V, c + (n + 0.5 * u) * z]), np.vstack([T, np.r_[f, len(V)]])


@pytest.mark.parametrize("order", range(len(ORDERS)))
@pytest.mark.parametrize("z", [1e20, 1e60, 1e150])
def test_the_primal_diagonal_of_a_needle_is_exact_and_the_primal_nsd(z, order):
    """Issue 30.2: with the apex at 1e20, L[3, 3] came back 0 beside off-diagonals of
    0.1 (exact -1.7e-21), and check / info said the primal was not semidefinite."""
    P = needle("tilt", z)[ORDERS[order]]
    L = tetlap.laplacian(P, T1, "primal")
    exact_diagonal = exact([ex.vec(p) for p in P], "diagonal")
    for i, d in enumerate(exact_diagonal):
        assert abs(Fraction(L[i, i]) - d) <= ACCURACY * abs(d), (i, L[i, i], float(d))
    assert tetlap.check(L, P, T1).nsd
    V, T = with_needle(*tetlap.meshes.cube(3), z)
    assert tetlap.check(tetlap.laplacian(V, T), V, T).nsd
    assert info.report(V, T, progress=False, regular=False)["primal"]["nsd"]


@pytest.mark.slow
def test_the_element_certificate_uses_each_needles_own_diagonal():
    """Beyond the dense route (n > 2500): the per-tet matrices of the certificate carry
    the tets' own diagonal entries, not minus their weights' sums."""
    V, T = with_needle(*tetlap.meshes.cube(14), 1e20)
    r = tetlap.check(tetlap.laplacian(V, T), V, T)
    assert r.nsd and r.nsd_method.startswith("element certificate"), r.nsd_method


def energy(P, f, kind):
    X = [[Fraction(x) for x in p] for p in P]
    w = ex.primal_tet(X) if kind == "primal" else ex.dual_tet(X)[0]
    return sum(we * (Fraction(f[a]) - Fraction(f[b])) ** 2 for (a, b), we in zip(ex.EDGES, w))


def exact_gradient(P, f, kind):
    """The energy's gradient by central differences in exact arithmetic, the step far
    below the tet's thinnest dimension (error of order step^2)."""
    X = [[Fraction(x) for x in p] for p in P]
    volume = abs(ex.det3(*[ex.sub(X[k], X[0]) for k in (1, 2, 3)]))
    longest = max(max(abs(X[a][c] - X[b][c]) for c in range(3)) for a, b in ex.EDGES)
    h = volume / longest**2 / 10**30
    g = [[Fraction(0)] * 3 for _ in range(4)]
    for i in range(4):
        for c in range(3):
            up, down = [list(p) for p in X], [list(p) for p in X]
            up[i][c] += h
            down[i][c] -= h
            g[i][c] = (energy(up, f, kind) - energy(down, f, kind)) / (2 * h)
    return g


SLOW = pytest.mark.slow
DERIVATIVE_CASES = [("primal", ("perp", 1e200, 0)), ("dual", ("tilt", 1e50, 1)),
                    ("primal", ("inplane", 1e50, 0)), ("dual", ("inplane", 1e50, 0)),
                    ("dual", ("needle", 1e-12, 0)), ("primal", ("needle", 1e-12, 0)),
                    pytest.param("dual", ("perp", 1e200, 0), marks=SLOW),
                    pytest.param("primal", ("tilt", 1e50, 1), marks=SLOW),
                    pytest.param("dual", ("perp", 1e100, 1), marks=SLOW),
                    pytest.param("dual", ("tiny", 1e100, 2), marks=SLOW)]


@pytest.mark.parametrize("kind, case", DERIVATIVE_CASES)
def test_needle_derivatives_follow_the_same_rule(kind, case):
    """The derivatives of needles take the precise path too: within 1e-12 of the largest
    component of the exact gradient (they were refused as cotangent overflows, or wrong
    in their leading digits)."""
    family, z, order = case
    if family == "needle":
        from test_accuracy import thin
        P = thin("needle", z, np.random.default_rng(1))
    else:
        P = needle(family, z)[ORDERS[order]]
    f = np.array([0.3, -0.2, 0.5, 0.1])
    reference = exact_gradient(P, f, kind)
    largest = max(abs(x) for row in reference for x in row)
    if largest > LARGEST:                 # the gradient itself leaves the range: refused
        with pytest.raises(tetlap.NonFiniteError, match="float64 range"):
            tetlap.dirichlet_energy(P, T1, f, kind)
        return
    E, G = tetlap.dirichlet_energy(P, T1, f, kind)
    error = max(abs(Fraction(G[i, c]) - reference[i][c]) for i in range(4) for c in range(3))
    assert error <= ACCURACY * largest, float(error / largest)
    assert abs(Fraction(E) - energy(P, f, kind)) <= ACCURACY * abs(energy(P, f, kind))


def test_info_names_the_tets_the_operators_skip():
    """Issue 30.1: with degenerate="skip" a needle whose dual overflows was dropped
    silently, and info reported the dual of a different mesh. Now each operator says how
    many tets it left out, why, and which."""
    V, T = tetlap.meshes.cube(2)
    bottom = np.flatnonzero(V[:, 2] == 0)
    flat = bottom[[0, 1, 3, 4]]                                  # four corners on z = 0
    V = np.vstack([V, [1e100, 0.2, 0.3]])                         # a needle in a face's plane
    T = np.vstack([T, flat, [bottom[0], bottom[1], bottom[3], len(V) - 1]])
    result = info.report(V, T, progress=False, regular=False)
    assert result["primal"]["n_skipped_tets"] == 1                # the flat tet only
    assert result["primal"]["skipped_tets"] == [48]
    dual = result["dual"]
    assert (dual["n_skipped_tets"], dual["n_skipped_out_of_range"]) == (2, 1)
    assert dual["skipped_tets"] == [48, 49]
    assert any("2 tets skipped" in note for note in dual["notes"])
    json.dumps(result)
    from tetlap.cli import _output
    text = _output.info_report(result, "needle")
    assert "skipped (dual): 2 tets (1 flat, 1 with values beyond the float64 range): 48, 49" in text
