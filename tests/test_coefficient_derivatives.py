"""tetlap.coefficient_vjp: the gradient of <dL, L(K)> with respect to the coefficient K,
against central finite differences and the linearity of L in K."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap


def random_spd(m, seed):
    rng = np.random.default_rng(seed)
    R = np.linalg.qr(rng.normal(size=(m, 3, 3)))[0]
    return np.einsum("mij,mj,mkj->mik", R, rng.uniform(0.3, 3.0, size=(m, 3)), R)


def small_mesh(seed):
    """A small random mesh with mixed orientations."""
    V, T = tetlap.meshes.ball(60, seed=seed)
    T = T.copy()
    flip = np.random.default_rng(seed).random(len(T)) < 0.5
    T[flip, :2] = T[flip, 1::-1]
    return V, T


def cotangent(n, seed):
    return sp.random_array((n, n), density=0.3, format="csr", rng=seed)


def phi(V, T, kind, K, dL):
    return float((dL * tetlap.laplacian(V, T, kind, coefficient=K)).sum())


@pytest.mark.parametrize("kind", ["primal", "dual"])
@pytest.mark.parametrize("seed", [1, 2])
def test_scalar_gradients_match_central_differences(kind, seed):
    V, T = small_mesh(seed)
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.5, 2.0, len(T))
    dL = cotangent(len(V), seed)
    g = tetlap.coefficient_vjp(V, T, c, kind, dL=dL)
    assert g.shape == c.shape
    h = 1e-5
    for _ in range(3):
        dc = rng.normal(size=len(T))
        fd = (phi(V, T, kind, c + h * dc, dL) - phi(V, T, kind, c - h * dc, dL)) / (2 * h)
        assert g @ dc == pytest.approx(fd, rel=1e-7, abs=1e-9 * np.abs(g).sum())
    t = int(rng.integers(len(T)))  # one tet's own coordinate
    e = np.zeros(len(T))
    e[t] = 1.0
    fd = (phi(V, T, kind, c + h * e, dL) - phi(V, T, kind, c - h * e, dL)) / (2 * h)
    assert g[t] == pytest.approx(fd, rel=1e-6, abs=1e-9 * np.abs(g).max())


@pytest.mark.parametrize("seed", [1, 2])
def test_tensor_gradients_match_central_differences(seed):
    V, T = small_mesh(seed)
    rng = np.random.default_rng(seed)
    K = random_spd(len(T), seed)
    dL = cotangent(len(V), seed + 10)
    g = tetlap.coefficient_vjp(V, T, K, dL=dL)
    assert g.shape == K.shape
    assert np.array_equal(g, g.swapaxes(1, 2))
    h = 1e-5
    for _ in range(3):
        H = rng.normal(size=K.shape)
        H = H + H.swapaxes(1, 2)  # a symmetric direction
        fd = (phi(V, T, "primal", K + h * H, dL) - phi(V, T, "primal", K - h * H, dL)) / (2 * h)
        assert np.sum(g * H) == pytest.approx(fd, rel=1e-7, abs=1e-9 * np.abs(g).sum())
    K0 = np.diag([1.0, 2.0, 5.0])  # one tensor: the sum over the tets
    g0 = tetlap.coefficient_vjp(V, T, K0, dL=dL)
    assert g0.shape == (3, 3) and np.allclose(g0, tetlap.coefficient_vjp(
        V, T, np.broadcast_to(K0, K.shape), dL=dL).sum(axis=0), rtol=1e-14, atol=0)
    H = np.ones((3, 3)) + np.eye(3)
    fd = (phi(V, T, "primal", K0 + h * H, dL) - phi(V, T, "primal", K0 - h * H, dL)) / (2 * h)
    assert np.sum(g0 * H) == pytest.approx(fd, rel=1e-7)


@pytest.mark.parametrize("kind,tensor", [("primal", False), ("dual", False), ("primal", True)])
def test_linearity_gives_phi_exactly_for_every_cotangent_form(kind, tensor):
    """L is linear in K: <dphi/dK, K> = phi(K) (Euler), for each form of dL."""
    V, T = small_mesh(3)
    rng = np.random.default_rng(3)
    K = random_spd(len(T), 4) if tensor else rng.uniform(0.5, 2.0, len(T))
    edges, _ = tetlap.edge_weights(V, T)
    pick = rng.choice(len(edges), 40)  # repeated edges add up, any order
    dw = rng.normal(size=len(pick))
    Wt = rng.normal(size=(len(T), 6))
    L = tetlap.laplacian(V, T, kind, coefficient=K)
    E, w = tetlap.edge_weights(V, T, kind, coefficient=K)
    W = tetlap.element_contributions(V, T, kind, coefficient=K)
    lookup = {tuple(e): k for k, e in enumerate(E.tolist())}
    dL = cotangent(len(V), 5)
    for cot, value in ((dL, float((dL * L).sum())),
                       ((edges[pick][:, ::-1], dw), float(dw @ w[[lookup[tuple(e)] for e in edges[pick].tolist()]])),
                       (Wt, float(np.sum(Wt * W)))):
        before = cot[1].copy() if isinstance(cot, tuple) else cot.copy()
        g = tetlap.coefficient_vjp(V, T, K, kind, dL=cot)
        got = np.sum(g * K)
        assert got == pytest.approx(value, rel=1e-12, abs=1e-13 * np.abs(g * K).sum())
        after = cot[1] if isinstance(cot, tuple) else cot
        assert (abs(after - before).max() if sp.issparse(after) else np.abs(after - before).max()) == 0


def test_scale_and_offset():
    """dphi/dK_t scales as the mesh (Vol |G|^2 ~ s) for s = 2^k down to 1e-150 and up to
    1e150, and does not see a translation."""
    V, T = small_mesh(4)
    K = random_spd(len(T), 5)
    c = np.linspace(1, 2, len(T))
    Wt = np.random.default_rng(0).normal(size=(len(T), 6))
    gK = tetlap.coefficient_vjp(V, T, K, dL=Wt)
    gc = tetlap.coefficient_vjp(V, T, c, "dual", dL=Wt)
    for k in (-498, 498):
        assert np.allclose(tetlap.coefficient_vjp(np.ldexp(V, k), T, K, dL=Wt),
                           np.ldexp(gK, k), rtol=1e-12, atol=0)
        assert np.allclose(tetlap.coefficient_vjp(np.ldexp(V, k), T, c, "dual", dL=Wt),
                           np.ldexp(gc, k), rtol=1e-12, atol=1e-12 * np.ldexp(abs(gc).max(), k))
    shifted = tetlap.coefficient_vjp(V + 1e6, T, K, dL=Wt)
    assert abs(shifted - gK).max() <= 1e-6 * abs(gK).max()


def test_a_skipped_tet_gets_a_zero_gradient():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=float)
    T = np.array([[0, 1, 2, 3], [0, 1, 2, 4]])  # the second is flat
    Wt = np.ones((2, 6))
    K = random_spd(2, 1)
    with pytest.raises(tetlap.DegenerateElementError):
        tetlap.coefficient_vjp(V, T, K, dL=Wt)
    for coefficient in (K, np.ones(2)):
        g = tetlap.coefficient_vjp(V, T, coefficient, dL=Wt, degenerate="skip")
        assert np.all(g[1] == 0) and np.any(g[0] != 0) and np.isfinite(g).all()


def test_bad_input():
    V, T = small_mesh(1)
    m, n = len(T), len(V)
    dL = cotangent(n, 0)
    with pytest.raises(tetlap.OptionError, match="primal"):
        tetlap.coefficient_vjp(V, T, random_spd(m, 0), "dual", dL=dL)
    with pytest.raises(tetlap.OptionError, match="weights"):
        tetlap.coefficient_vjp(V, T, np.ones(m), "dual", dL=dL, weights=np.zeros(n))
    c = np.ones(m)
    c[4] = 0.0
    with pytest.raises(tetlap.CoefficientError, match="tet 4"):
        tetlap.coefficient_vjp(V, T, c, dL=dL)
    with pytest.raises(tetlap.ShapeError, match="per vertex"):
        tetlap.coefficient_vjp(V, T, np.ones(n), dL=dL)
    with pytest.raises(tetlap.ShapeError, match="dL"):
        tetlap.coefficient_vjp(V, T, np.ones(m), dL=np.ones((m, 5)))
    with pytest.raises(tetlap.ShapeError, match="dL"):
        tetlap.coefficient_vjp(V, T, np.ones(m), dL=sp.eye_array(n + 1))
    with pytest.raises(TypeError):
        tetlap.coefficient_vjp(V, T, np.ones(m))
    with pytest.raises(tetlap.OptionError):
        tetlap.coefficient_vjp(V, T, np.ones(m), "nope", dL=dL)


def test_a_mesh_object_in_place_of_v_and_t():
    meshio = pytest.importorskip("meshio")
    V, T = small_mesh(2)
    c = np.linspace(1, 2, len(T))
    Wt = np.ones((len(T), 6))
    mesh = meshio.Mesh(V, [("tetra", T)])
    assert np.array_equal(tetlap.coefficient_vjp(mesh, c, "dual", dL=Wt),
                          tetlap.coefficient_vjp(V, T, c, "dual", dL=Wt))


# ---- with respect to the vertices, with a scalar coefficient ----------------------------


@pytest.mark.parametrize("kind", ["primal", "dual", 0.3])
@pytest.mark.parametrize("form", ["edges", "matrix"])
def test_vertex_vjp_with_a_scalar_coefficient_matches_central_differences(kind, form):
    """L = sum_t c_t L_t(V): the vertex gradient of <dL, L> with L built with c, against
    central differences along a random direction; the value is <dL, L>."""
    V, T = tetlap.meshes.ball(250, seed=21)
    rng = np.random.default_rng(21)
    c = rng.uniform(0.5, 2.0, len(T))
    edges, _ = tetlap.edge_weights(V, T)
    dw = rng.normal(size=len(edges))
    dL = (edges, dw) if form == "edges" else sp.csr_array(
        (np.r_[dw, dw], (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]])),
        shape=(len(V), len(V)))

    def phi(X):
        L = tetlap.laplacian(X, T, kind, coefficient=c)
        return float((L.multiply(dL)).sum()) if form == "matrix" else \
            float(sum(L[i, j] * w for (i, j), w in zip(edges, dw)))

    V0 = V.copy()
    g = tetlap.vjp(V, T, kind, dL=dL, coefficient=c)
    assert np.array_equal(V, V0)
    assert abs(g.value - phi(V)) <= 1e-12 * abs(phi(V)) + 1e-12
    D = rng.normal(size=V.shape)
    h = 1e-6
    fd = (phi(V + h * D) - phi(V - h * D)) / (2 * h)
    assert abs(np.sum(g.dV * D) - fd) <= 1e-6 * abs(fd) + 1e-8
    # ones: the plain product (to rounding: the cotangent is taken per tet)
    plain = tetlap.vjp(V, T, kind, dL=dL)
    ones = tetlap.vjp(V, T, kind, dL=dL, coefficient=np.ones(len(T)))
    np.testing.assert_allclose(ones.dV, plain.dV, rtol=0, atol=1e-12 * np.abs(plain.dV).max())


@pytest.mark.parametrize("form", ["per tet", "one tensor"])
def test_vertex_vjp_with_a_tensor_matches_central_differences(form):
    """The primal with an SPD tensor per tet (or one tensor): the closed-form vertex
    gradient against central differences, with a mass cotangent beside it; the value; a
    mesh and tensor far from unit size give the same gradient (degree 0 in the
    coordinates, degree 1 in K)."""
    V, T = tetlap.meshes.ball(250, seed=23)
    rng = np.random.default_rng(23)
    A = rng.normal(size=(len(T), 3, 3))
    K = np.einsum("mij,mkj->mik", A, A) + np.eye(3)
    K = K if form == "per tet" else K[0]
    edges, _ = tetlap.edge_weights(V, T)
    dw = rng.normal(size=len(edges))
    dm = rng.normal(size=len(V))

    def phi(X):
        e, w = tetlap.edge_weights(X, T, "primal", coefficient=K)
        assert np.array_equal(e, edges)
        return float(w @ dw + tetlap.mass(X, T, "barycentric").diagonal() @ dm)

    K0 = K.copy()
    g = tetlap.vjp(V, T, "primal", "barycentric", dL=(edges, dw), dM=dm, coefficient=K)
    assert np.array_equal(K, K0)
    assert abs(g.value - phi(V)) <= 1e-12 * abs(phi(V))
    D = rng.normal(size=V.shape)
    h = 1e-6
    fd = (phi(V + h * D) - phi(V - h * D)) / (2 * h)
    assert abs(np.sum(g.dV * D) - fd) <= 1e-6 * abs(fd)
    far = tetlap.vjp(V * 2.0**300, T, "primal", dL=(edges, dw), coefficient=K * 2.0**-600)
    near = tetlap.vjp(V, T, "primal", dL=(edges, dw), coefficient=K)
    np.testing.assert_allclose(np.ldexp(far.dV, 600), near.dV, rtol=1e-13,
                               atol=1e-13 * np.abs(near.dV).max())


def test_vertex_vjp_refuses_dual_tensors_and_weights_with_a_coefficient():
    V, T = tetlap.meshes.ball(200, seed=22)
    edges, _ = tetlap.edge_weights(V, T)
    dL = (edges, np.ones(len(edges)))
    with pytest.raises(tetlap.OptionError, match="primal\" only"):
        tetlap.vjp(V, T, "dual", dL=dL, coefficient=np.eye(3))
    with pytest.raises(tetlap.OptionError, match="weights= with a coefficient"):
        tetlap.vjp(V, T, "dual", dL=dL, coefficient=np.ones(len(T)), weights=np.zeros(len(V)))
    with pytest.raises(tetlap.CoefficientError):
        tetlap.vjp(V, T, "primal", dL=dL, coefficient=-np.ones(len(T)))
