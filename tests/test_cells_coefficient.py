"""tetlap.cell_laplacian with coefficient= (two-point transmissibilities with a tensor,
combined harmonically) and centres=, and tetlap.cells.k_orthogonality."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.cells import ANGLE_TOL


def off_boundary(g):
    """(m,) bool: tets without a boundary face."""
    mask = np.ones(len(g.volume), dtype=bool)
    mask[g.face_tets[g.boundary_faces, 0]] = False
    return mask


def rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q


def random_spd(m, seed):
    rng = np.random.default_rng(seed)
    R = np.linalg.qr(rng.normal(size=(m, 3, 3)))[0]
    lam = rng.uniform(0.2, 5.0, size=(m, 3))
    return np.einsum("mij,mj,mkj->mik", R, lam, R)


def test_none_takes_the_plain_path_bitwise():
    V, T = tetlap.meshes.ball(300, seed=4)
    a = tetlap.cell_laplacian(V, T)
    b = tetlap.cell_laplacian(V, T, coefficient=None, centres=None)
    for x, y in ((a.data, b.data), (a.indices, b.indices), (a.indptr, b.indptr)):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("weighted", [False, True])
def test_a_coefficient_of_ones_or_the_identity_gives_the_plain_weights(weighted):
    V, T = tetlap.meshes.ball(400, seed=1)
    w = np.random.default_rng(0).uniform(0, 1e-3, len(V)) if weighted else None
    plain = tetlap.cell_laplacian(V, T, weights=w)
    for K in (np.ones(len(T)), np.eye(3), np.broadcast_to(np.eye(3), (len(T), 3, 3))):
        Lc = tetlap.cell_laplacian(V, T, weights=w, coefficient=K)
        assert np.array_equal(Lc.indices, plain.indices)
        # plain: A_f / l_f; here the half-transmissibilities through the face centre
        assert abs(Lc - plain).max() <= 1e-11 * abs(plain).max()


def test_scalars_combine_harmonically_through_the_signed_distances():
    """A second formula: A_f / (h_s / c_s + h_t / c_t), the signed distances h from the
    centres' barycentric coordinates (h = lambda_opposite * 3 Vol / A_f)."""
    V, T = tetlap.meshes.weighted_ball(300, 0.5, seed=3)  # non-Delaunay: negative h too
    c = np.random.default_rng(5).uniform(0.1, 10.0, len(T))
    Lc = tetlap.cell_laplacian(V, T, coefficient=c)
    g = tetlap.dual_geometry(V, T)
    inner = np.flatnonzero(~g.boundary_faces)
    s, t = g.face_tets[inner].T
    ls = np.argmax(g.tet_faces[s] == inner[:, None], axis=1)
    lt = np.argmax(g.tet_faces[t] == inner[:, None], axis=1)
    area = g.face_area[inner]
    hs = g.barycentric[s, ls] * 3 * g.volume[s] / area
    ht = g.barycentric[t, lt] * 3 * g.volume[t] / area
    expected = area / (hs / c[s] + ht / c[t])
    assert (expected < 0).any()
    got = np.asarray(Lc[s, t]).ravel()
    assert np.allclose(got, expected, rtol=1e-9, atol=1e-12 * abs(expected).max())
    assert abs(Lc.sum(axis=1)).max() <= 1e-12 * abs(Lc).max()


def test_one_face_by_the_literal_formula():
    """Two tets, random tensors and centres: a_s = |f| (K_s n).(x_f - x_s) / |x_f - x_s|^2,
    x_f where the centre line crosses the face plane, T = a_s a_t / (a_s + a_t)."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0.2, 1.1, 0], [0.3, 0.2, 1.0], [0.4, 0.3, -0.9]])
    T = np.array([[0, 1, 2, 3], [0, 1, 2, 4]])
    K = random_spd(2, 7)
    X = np.array([[0.35, 0.3, 0.3], [0.3, 0.4, -0.25]])
    Lc = tetlap.cell_laplacian(V, T, coefficient=K, centres=X).toarray()
    a, b, c = V[0], V[1], V[2]
    N = np.cross(b - a, c - a)
    area = np.linalg.norm(N) / 2
    n = N / np.linalg.norm(N)
    n = n if n @ (a - V[3]) > 0 else -n  # out of tet 0
    tau = n @ (a - X[0]) / (n @ (X[1] - X[0]))
    xf = X[0] + tau * (X[1] - X[0])
    assert abs(n @ (xf - a)) < 1e-15
    a_s = area * (K[0] @ n) @ (xf - X[0]) / np.sum((xf - X[0]) ** 2)
    a_t = area * (K[1] @ n) @ (X[1] - xf) / np.sum((X[1] - xf) ** 2)
    expected = a_s * a_t / (a_s + a_t)
    assert Lc[0, 1] == pytest.approx(expected, rel=1e-13)
    assert Lc[1, 0] == Lc[0, 1] and Lc[0, 0] == -Lc[0, 1]


def metric_mesh(K, seed=2):
    """The mapped-mesh construction: a Delaunay mesh W mapped by K^1/2, with the images of
    its circumcentres as cell centres (the circumcentres in the metric K^-1)."""
    W, T = tetlap.meshes.ball(400, seed=seed)
    lam, R = np.linalg.eigh(K)
    A = R @ np.diag(np.sqrt(lam)) @ R.T
    return W @ A, T, tetlap.dual_geometry(W, T).centres @ A


@pytest.mark.parametrize("K", [np.diag([1.0, 4.0, 25.0]),
                               rotation(3) @ np.diag([1.0, 0.1, 30.0]) @ rotation(3).T])
def test_k_orthogonal_cells_are_exact_for_linear_solutions(K):
    V, T, X = metric_mesh(K)
    report = tetlap.cells.k_orthogonality(V, T, K, centres=X)
    # verify the construction before relying on it
    assert report.orthogonal == len(report.faces) and report.max_angle <= ANGLE_TOL
    g = tetlap.dual_geometry(V, T)
    inner = off_boundary(g)
    u = X @ np.array([1.0, -2.0, 3.0]) + 5.0
    for Kc in (K, np.broadcast_to(K, (len(T), 3, 3))):
        Lc = tetlap.cell_laplacian(V, T, coefficient=Kc, centres=X)
        assert abs(Lc @ u)[inner].max() <= 1e-12 * abs(Lc).max() * abs(u).max()
    # the circumcentric cells of the same mesh are not K-orthogonal, nor exact
    Lc = tetlap.cell_laplacian(V, T, coefficient=K)
    assert tetlap.cells.k_orthogonality(V, T, K).orthogonal < len(report.faces) // 2
    u = g.centres @ np.array([1.0, -2.0, 3.0])
    assert abs(Lc @ u)[inner].max() > 1e-4 * abs(Lc).max() * abs(u).max()


def test_k_orthogonality_angles_against_a_direct_computation():
    V, T = tetlap.meshes.ball(200, seed=8)
    K = random_spd(len(T), 1)
    r = tetlap.cells.k_orthogonality(V, T, K)
    g = tetlap.dual_geometry(V, T)
    assert len(r.faces) == int((~g.boundary_faces).sum())
    for k in np.random.default_rng(0).choice(len(r.faces), 20, replace=False):
        s, t = r.tets[k]
        a, b, c = V[r.faces[k]]
        n = np.cross(b - a, c - a)
        opposite = V[np.setdiff1d(T[s], r.faces[k])[0]]
        n *= np.sign(n @ (a - opposite)) / np.linalg.norm(n)
        d = g.centres[t] - g.centres[s]
        for side, tet in enumerate((s, t)):
            v = K[tet] @ n
            cos = v @ d / np.linalg.norm(v) / np.linalg.norm(d)
            assert r.angle[k, side] == pytest.approx(np.arccos(np.clip(cos, -1, 1)), abs=1e-7)
    assert r.max_angle == r.angle.max()
    assert r.obtuse == int((r.angle.max(axis=1) > np.pi / 2).sum())


def test_a_power_of_two_coefficient_scales_the_operator_exactly():
    V, T = tetlap.meshes.ball(200, seed=2)
    K = random_spd(len(T), 3)
    Lc = tetlap.cell_laplacian(V, T, coefficient=K)
    for k in (-490, 490):
        scaled = tetlap.cell_laplacian(V, T, coefficient=np.ldexp(K, k))
        assert np.array_equal(scaled.data, np.ldexp(Lc.data, k))


def test_cospherical_centres_are_degenerate_with_a_coefficient_too():
    V, T = tetlap.meshes.cube(2)
    c = np.ones(len(T))
    with pytest.raises(tetlap.DegenerateElementError, match="face"):
        tetlap.cell_laplacian(V, T, coefficient=c)
    Lc = tetlap.cell_laplacian(V, T, coefficient=c, degenerate="skip")
    assert np.isfinite(Lc.data).all()
    assert np.array_equal(Lc.indices, tetlap.cell_laplacian(V, T, degenerate="skip").indices)


def test_bad_coefficients_and_centres_are_named_and_nothing_is_modified():
    V, T = tetlap.meshes.ball(100, seed=1)
    m = len(T)
    K = random_spd(m, 2)
    bad = K.copy()
    bad[3] = -np.eye(3)
    before = bad.copy()
    with pytest.raises(tetlap.CoefficientError, match="tet 3") as e:
        tetlap.cell_laplacian(V, T, coefficient=bad)
    assert e.value.element == 3 and np.array_equal(bad, before)
    asym = K.copy()
    asym[5, 0, 1] += 1.0
    with pytest.raises(tetlap.CoefficientError, match="tet 5"):
        tetlap.cell_laplacian(V, T, coefficient=asym)
    c = np.ones(m)
    c[7] = np.nan
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.cell_laplacian(V, T, coefficient=c)
    with pytest.raises(tetlap.CoefficientError, match="positive"):
        tetlap.cell_laplacian(V, T, coefficient=np.zeros(m))
    with pytest.raises(tetlap.ShapeError, match="per vertex"):
        tetlap.cell_laplacian(V, T, coefficient=np.ones(len(V)))
    with pytest.raises(tetlap.ShapeError, match=r"\(3, 3\)"):
        tetlap.cell_laplacian(V, T, coefficient=np.ones((m, 2)))
    with pytest.raises(tetlap.DtypeError):
        tetlap.cell_laplacian(V, T, coefficient=np.array(["a"] * m))
    X = tetlap.dual_geometry(V, T).centres
    with pytest.raises(tetlap.ShapeError, match="centres"):
        tetlap.cell_laplacian(V, T, centres=X[:-1])
    X[4, 1] = np.inf
    with pytest.raises(tetlap.NonFiniteError, match="tet 4") as e:
        tetlap.cell_laplacian(V, T, centres=X)
    assert e.value.element == 4
    with pytest.raises(tetlap.ShapeError, match="R\\^3"):
        tetlap.cell_laplacian(np.hstack([V, np.zeros((len(V), 1))]), T, coefficient=np.ones(m))
    with pytest.raises(tetlap.CoefficientError, match="tet 3"):
        tetlap.cells.k_orthogonality(V, T, bad)


def test_a_mesh_object_in_place_of_v_and_t():
    meshio = pytest.importorskip("meshio")
    V, T = tetlap.meshes.ball(100, seed=2)
    K = random_spd(len(T), 0)
    mesh = meshio.Mesh(V, [("tetra", T)])
    assert np.array_equal(tetlap.cells.k_orthogonality(mesh, K).angle,
                          tetlap.cells.k_orthogonality(V, T, K).angle)
    a, b = tetlap.cell_laplacian(mesh, coefficient=K), tetlap.cell_laplacian(V, T, coefficient=K)
    assert np.array_equal(a.data, b.data)
