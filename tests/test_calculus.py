"""tetlap.gradient / tetlap.divergence: exact rationals, linear precision, the identity
``D G = L_primal``, immersed meshes, triangles, mesh objects, degenerate elements."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import tetlap
from exact_reference import cross, det3, sub, vec
from tetlap import calculus

INTEGER_MESHES = {
    "corner": ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]]),
    "mixed orientation": (
        [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [2, 2, 2], [-1, -1, 3]],
        [[0, 1, 2, 3], [4, 2, 1, 3], [0, 3, 2, 5], [1, 0, 3, 5]],
    ),
    "sliver-ish": ([[0, 0, 0], [7, 1, 0], [3, 9, 1], [4, 4, 1], [5, -3, 8]],
                   [[0, 1, 2, 3], [1, 0, 3, 4]]),
}


def exact_gradients(V, T):
    """(m, 4, 3) Fractions: grad(lambda_a) = n_a / det, n_a the face normal opposite a
    (an independent route: Cramer's rule on the edge matrix)."""
    out = []
    for tet in T:
        x = [vec(V[v]) for v in tet]
        e = [sub(x[k], x[0]) for k in (1, 2, 3)]
        det = det3(*e)
        g1, g2, g3 = (cross(e[1], e[2]), cross(e[2], e[0]), cross(e[0], e[1]))
        g = [[c / det for c in n] for n in (g1, g2, g3)]
        g0 = [-(g[0][c] + g[1][c] + g[2][c]) for c in range(3)]
        out.append([g0] + g)
    return out, [abs(det3(*[sub(vec(V[t[k]]), vec(V[t[0]])) for k in (1, 2, 3)])) / 6
                 for t in T]


@pytest.mark.parametrize("name", list(INTEGER_MESHES))
def test_gradients_and_divergence_equal_exact_rationals(name):
    V, T = INTEGER_MESHES[name]
    g, vol = exact_gradients(V, T)
    n, m = len(V), len(T)
    G = tetlap.gradient(V, T).toarray()
    D = tetlap.divergence(V, T).toarray()
    G_exact = [[Fraction(0)] * n for _ in range(3 * m)]
    for t, tet in enumerate(T):
        for a, v in enumerate(tet):
            for c in range(3):
                G_exact[3 * t + c][v] = g[t][a][c]
    for r in range(3 * m):
        for j in range(n):
            assert abs(G[r, j] - float(G_exact[r][j])) <= 4e-16 * max(1, abs(float(G_exact[r][j])))
            D_exact = -G_exact[r][j] * vol[r // 3]
            assert abs(D[j, r] - float(D_exact)) <= 4e-16 * max(1, abs(float(D_exact)))
    # D G is the exact primal Laplacian: -sum_t vol_t g_a . g_b
    L = tetlap.laplacian(V, T).toarray()
    for i in range(n):
        for j in range(n):
            exact = -sum(vol[r // 3] * G_exact[r][i] * G_exact[r][j] for r in range(3 * m))
            assert abs(L[i, j] - float(exact)) <= 1e-15 * max(1, abs(float(exact)))
            assert abs((D @ G)[i, j] - float(exact)) <= 1e-14 * max(1, abs(float(exact)))


def test_gradient_is_exact_on_linear_functions(rng):
    V, T = tetlap.meshes.ball(300, seed=3)
    G = tetlap.gradient(V, T)
    a, b = rng.normal(size=3), 0.7
    grad = (G @ (V @ a + b)).reshape(-1, 3)
    assert np.abs(grad - a).max() < 1e-11 * np.abs(a).max()
    assert np.abs(G @ np.ones(len(V))).max() < 1e-11 * abs(G).max()  # constants


def test_shapes_pattern_and_canonical_format():
    V, T = tetlap.meshes.cube(3, jitter=0.2)
    G, D = tetlap.gradient(V, T), tetlap.divergence(V, T)
    assert G.shape == (3 * len(T), len(V)) and D.shape == (len(V), 3 * len(T))
    assert G.format == D.format == "csr" and G.dtype == D.dtype == np.float64
    assert np.all(np.diff(G.indptr) == 4) and G.has_sorted_indices
    assert np.all(np.diff(G.indices.reshape(-1, 4), axis=1) > 0)
    # D is exactly -G^T diag(vol (x) 1_3)
    _, vol = calculus.element_gradients(V, T)
    assert abs(D - (-(G.T @ np.diag(np.repeat(vol, 3))))).max() == 0


def test_divergence_of_gradient_is_the_primal_laplacian():
    V, T = tetlap.meshes.ball(500, seed=1)
    L = tetlap.laplacian(V, T)
    E = tetlap.divergence(V, T) @ tetlap.gradient(V, T)
    assert abs(E - L).max() <= 1e-13 * abs(L).max()


@pytest.mark.slow
def test_identity_on_every_real_mesh(real_mesh):
    """-G^T diag(vol) G equals the primal Laplacian to 1e-13 of each row's size."""
    name, V, T = real_mesh
    L = tetlap.laplacian(V, T, degenerate="skip")
    E = tetlap.divergence(V, T, degenerate="skip") @ tetlap.gradient(V, T, degenerate="skip")
    diff = abs(E - L).tocsr()
    size = np.asarray(abs(L).sum(axis=1)).ravel()
    worst = (np.asarray(diff.max(axis=1).todense()).ravel() / np.maximum(size, 1e-300)).max()
    assert worst <= 1e-13, f"{name}: {worst:.2e}"


def test_immersed_tets_match_the_rotated_mesh():
    V, T = tetlap.meshes.ball(200, seed=2)
    Q, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(5, 5)))
    V5 = np.hstack([V, np.zeros((len(V), 2))]) @ Q.T + 3.0
    G3 = tetlap.gradient(V, T)
    G5 = tetlap.gradient(V5, T)
    assert G5.shape == (5 * len(T), len(V))
    # the ambient gradient is the R^3 one rotated by Q (columns 0..2 of Q)
    g3 = (G3 @ V[:, 0]).reshape(-1, 3)
    g5 = (G5 @ V[:, 0]).reshape(-1, 5)
    assert np.abs(g5 - g3 @ Q[:, :3].T).max() < 1e-12
    L = tetlap.laplacian(V5, T)
    assert abs(tetlap.divergence(V5, T) @ G5 - L).max() <= 1e-13 * abs(L).max()


def test_triangles_in_the_plane_and_in_space():
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    F = tetlap.diagnostics.boundary_faces(T)
    G = tetlap.gradient(V, F)
    assert G.shape == (3 * len(F), len(V))
    L = tetlap.laplacian(V, F)
    assert abs(tetlap.divergence(V, F) @ G - L).max() <= 1e-13 * abs(L).max()
    # gradients are tangent: orthogonal to each face's normal
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    g = (G @ np.sin(V @ [1.0, 2.0, 3.0])).reshape(-1, 3)
    assert np.abs((g * n).sum(1)).max() < 1e-12
    P = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    G2 = tetlap.gradient(P, [[0, 1, 2], [1, 3, 2]])
    assert G2.shape == (4, 4)
    assert np.allclose((G2 @ (3 * P[:, 0] - P[:, 1])).reshape(-1, 2), [3, -1])


def test_mesh_objects_are_accepted():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(2)
    mesh = meshio.Mesh(V, [("tetra", T)])
    assert abs(tetlap.gradient(mesh) - tetlap.gradient(V, T)).max() == 0
    assert abs(tetlap.divergence(mesh) - tetlap.divergence(V, T)).max() == 0
    with pytest.raises(TypeError):
        tetlap.gradient(mesh, T)


def test_degenerate_elements_raise_or_get_zero_rows():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]]
    T = [[0, 1, 2, 3], [0, 1, 2, 4]]          # the second tet is flat
    with pytest.raises(tetlap.DegenerateElementError, match="element 1"):
        tetlap.gradient(V, T)
    G = tetlap.gradient(V, T, degenerate="skip")
    assert G.shape == (6, 5) and G.nnz == 24
    assert abs(G[[3, 4, 5], :]).max() == 0
    assert abs(G[[0, 1, 2], :] - tetlap.gradient(V, T[:1])[:, :]).max() == 0
    _, vol = calculus.element_gradients(V, T, degenerate="skip")
    assert vol.tolist() == [1 / 6, 0.0]


def test_bad_input_gets_clear_errors():
    V, T = tetlap.meshes.cube(2)
    with pytest.raises(tetlap.IndexRangeError):
        tetlap.gradient(V, T + 100)
    with pytest.raises(tetlap.OptionError):
        tetlap.gradient(V, T, degenerate="maybe")
    with pytest.raises(tetlap.OptionError):
        tetlap.divergence(V, T, threads=0)
    bad = V.copy()
    bad[0, 0] = np.nan
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.gradient(bad, T)
    V0, T0 = V.copy(), T.copy()
    tetlap.divergence(V, T)
    assert np.array_equal(V, V0) and np.array_equal(T, T0)


def test_huge_and_tiny_coordinates_scale_the_gradients():
    V, T = tetlap.meshes.ball(100, seed=4)
    G = tetlap.gradient(V, T)
    for s in (2.0 ** 300, 2.0 ** -300):
        Gs = tetlap.gradient(V * s, T)
        assert abs(Gs * s - G).max() <= 1e-12 * abs(G).max()
    # volumes beyond float64 (2^1500) are refused like the operators' masses, where they
    # are returned; the gradient needs none (issue 37: it refused them too)
    with pytest.raises(tetlap.DegenerateElementError, match="float64 range"):
        tetlap.calculus.element_gradients(V * 2.0 ** 500, T)
    assert abs(tetlap.gradient(V * 2.0 ** 500, T) * 2.0 ** 500 - G).max() <= 1e-12 * abs(G).max()


def triangles():
    """A jittered triangulated square in the plane."""
    rng = np.random.default_rng(1)
    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 5), indexing="ij")
    V = np.column_stack([x.ravel(), y.ravel()])
    inside = ((V > 0) & (V < 1)).all(axis=1)
    V[inside] += rng.uniform(-0.05, 0.05, (inside.sum(), 2))
    i = np.arange(25).reshape(5, 5)
    a, b, c, d = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, 1:].ravel()
    return V, np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])])


@pytest.mark.parametrize("exponent", [-150, -130, -110, -100, -60, 60, 100, 110, 130, 150])
def test_gradient_and_divergence_at_any_scale_are_the_scaled_unit_ones(exponent):
    """Issue 37.22: at 1e-110 a well-shaped mesh's gradient said "degenerate (zero volume)"
    (its volumes underflow), at 1e105 "beyond the float64 range" (they overflow), and at
    1e-105 the divergence came out 1e-7 off (subnormal volumes). The operators' rule: the
    mesh is computed scaled by a power of two (exact) and scaled back, and only a value
    that itself leaves the float64 range is refused. G scales as 1/length, D as length^2
    (tets) or length (triangles)."""
    s = 10.0 ** exponent
    for V, T in (tetlap.meshes.cube(2, jitter=0.2), triangles()):
        p = T.shape[1] - 2                                  # D scales as length^p
        G, D = tetlap.gradient(V, T), tetlap.divergence(V, T)
        Gs, Ds = tetlap.gradient(V * s, T), tetlap.divergence(V * s, T)
        assert abs(Gs * s - G).max() <= 1e-13 * abs(G).max()
        assert abs(Ds / s**p - D).max() <= 1e-13 * abs(D).max()
        assert (Gs.indices == G.indices).all() and (Ds.indices == D.indices).all()
    # what cannot be represented is refused, naming the range, never "degenerate"
    V, T = tetlap.meshes.cube(2, jitter=0.2)
    if abs(exponent) > 100:                                 # volumes of 1e-330 / 1e330
        with pytest.raises(tetlap.DegenerateElementError, match="float64 range"):
            tetlap.calculus.element_gradients(V * s, T)
        g, vol = tetlap.calculus.element_gradients(V * s, T, degenerate="skip")
        assert not vol.any() and not g.any()
    else:
        g, vol = tetlap.calculus.element_gradients(V * s, T)
        g0, vol0 = tetlap.calculus.element_gradients(V, T)
        assert np.allclose(g * s, g0, rtol=1e-13) and np.allclose(vol / s**3, vol0, rtol=1e-13)


def test_a_divergence_beyond_the_float_range_is_refused_not_rounded_away():
    V, T = tetlap.meshes.cube(2, jitter=0.2)
    with pytest.raises(tetlap.DegenerateElementError, match="float64 range"):
        tetlap.divergence(V * 1e-160, T)                     # entries of 1e-320
    D = tetlap.divergence(V * 1e-160, T, degenerate="skip")
    assert D.shape == tetlap.divergence(V, T).shape and not D.data.any()


def test_bitwise_identical_for_any_thread_count():
    V, T = tetlap.meshes.ball(2000, seed=5)
    G1 = tetlap.gradient(V, T, threads=1)
    for threads in (2, 4):
        G = tetlap.gradient(V, T, threads=threads)
        assert np.array_equal(G.data, G1.data) and np.array_equal(G.indices, G1.indices)
