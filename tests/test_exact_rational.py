"""tetlap (float64) against exact rational arithmetic on small integer meshes."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import tetlap
from exact_reference import EDGES, assemble, det3, dot, sub, vec

MESHES = {
    "corner": ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]]),
    "mixed orientation": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [2, 2, 2], [-1, -1, 3]],
        [[0, 1, 2, 3], [4, 2, 1, 3], [0, 3, 2, 5], [1, 0, 3, 5]],
    ),
}


def non_delaunay_mesh():
    """A regular triangulation with large random weights (most tets non-Delaunay),
    coordinates rounded to integers: 40 vertices, 74 tets, one interior vertex."""
    V, T = tetlap.meshes.weighted_ball(40, 2.0, seed=9)
    return np.round(V * 20).astype(int).tolist(), T.tolist()


MESHES["non-Delaunay"] = non_delaunay_mesh()


def as_float(M):
    return np.array([[float(x) for x in row] for row in M])


@pytest.mark.parametrize("name", list(MESHES))
@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_laplacian_equals_exact(name, kind):
    V, T = MESHES[name]
    L, _ = assemble(V, T, kind)
    got = tetlap.laplacian(V, T, kind).toarray()
    np.testing.assert_allclose(got, as_float(L), rtol=1e-13, atol=1e-14 * np.abs(got).max())


@pytest.mark.parametrize("name", list(MESHES))
def test_circumcentric_mass_equals_exact_and_identities_hold_exactly(name):
    V, T = MESHES[name]
    L, mass = assemble(V, T, "dual")
    got = tetlap.mass(V, T, "circumcentric").diagonal()
    np.testing.assert_allclose(got, [float(m) for m in mass], rtol=1e-13, atol=1e-15)
    P = [vec(p) for p in V]
    # the 24 pieces of every tet sum to its volume: sum of masses = mesh volume, exactly
    volume = sum(abs(det3(sub(P[t[1]], P[t[0]]), sub(P[t[2]], P[t[0]]), sub(P[t[3]], P[t[0]]))) / 6
                 for t in T)
    assert sum(mass) == volume
    # pyramid identity Vol(*i) = sum_j |x_i - x_j|^2 w_ij / 6, exactly
    for i in range(len(V)):
        pyramid = sum(dot(sub(P[i], P[j]), sub(P[i], P[j])) * L[i][j]
                      for j in range(len(V)) if j != i) / 6
        assert pyramid == mass[i]


def test_non_delaunay_example_has_negative_weights_and_masses():
    V, T = MESHES["non-Delaunay"]
    L, mass = assemble(V, T, "dual")
    n = len(V)
    interior = int(np.flatnonzero(tetlap.diagnostics.interior_vertices(T, n))[0])
    assert min(L[interior][j] for j in range(n) if j != interior) < 0  # exact, interior edge
    assert min(mass) < 0
    got = tetlap.laplacian(V, T, "dual").toarray()
    assert (got[interior][np.arange(n) != interior] < 0).any()
    assert tetlap.mass(V, T, "circumcentric").diagonal().min() < 0


def test_golden_values_of_the_spec():
    """SPEC §10, exactly for the corner tet."""
    V, T = MESHES["corner"]
    L, mass = assemble(V, T, "dual")
    assert L[0] == [Fraction(-3, 4), Fraction(1, 4), Fraction(1, 4), Fraction(1, 4)]
    assert mass == [Fraction(1, 8), Fraction(1, 72), Fraction(1, 72), Fraction(1, 72)]
    P, _ = assemble(V, T, "primal")
    assert P[0] == [Fraction(-1, 2), Fraction(1, 6), Fraction(1, 6), Fraction(1, 6)]
    s = 1 / np.sqrt(8)
    R = s * np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    for kind in ("primal", "dual"):
        row = tetlap.laplacian(R, T, kind).toarray()[0]
        np.testing.assert_allclose(row, [-0.176777, 0.058926, 0.058926, 0.058926], atol=1e-6)
    np.testing.assert_allclose(tetlap.mass(R, T, "circumcentric").diagonal(), 0.029463, atol=1e-6)
    np.testing.assert_allclose(tetlap.mass(R, T, "barycentric").diagonal(), 0.029463, atol=1e-6)


def test_intrinsic_eq22_matches_the_signed_volume_dual(rng):
    """Eq. 22 in its 1/sin form, per tet, on random tets (well-shaped and flat ones,
    including right dihedral angles where the printed 1/cos form is NaN)."""
    tets = [rng.normal(size=(4, 3)) for _ in range(200)]
    tets.append(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]))  # right angles
    for X in tets:
        W = tetlap.element_contributions(X, [[0, 1, 2, 3]], "dual")[0]
        expected = []
        for a, b in EDGES:
            k, l = [c for c in range(4) if c not in (a, b)]
            e = X[b] - X[a]

            def angle(p, q, r):
                u, v = q - p, r - p
                return np.arctan2(np.linalg.norm(np.cross(u, v)), u @ v)

            alpha, beta = angle(X[k], X[a], X[b]), angle(X[l], X[a], X[b])
            n1, n2 = np.cross(e, X[k] - X[a]), np.cross(e, X[l] - X[a])
            theta = np.arctan2(np.linalg.norm(np.cross(n1, n2)), n1 @ n2)
            cot = lambda x: np.cos(x) / np.sin(x)
            expected.append(np.linalg.norm(e) / (8 * np.sin(theta)) * (
                2 * cot(alpha) * cot(beta) - (cot(alpha) ** 2 + cot(beta) ** 2) * np.cos(theta)))
        np.testing.assert_allclose(W, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
