"""Heterogeneous and anisotropic Laplacians, ``coefficient=`` (and the masses' ``density=``):
the definitions against independent routes (exact rationals, scikit-fem, the mapped mesh),
the plain path bit for bit, scaling, every bad input, and ``Mesh.update``."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import coefficient as coef

import exact_reference as ref

KINDS = ["primal", "dual", 0.3]
MASSES = ["barycentric", "circumcentric", "mixed", "fem"]


def mixed_cube(k=4, seed=0):
    """A jittered cube with half of its tets reversed (mixed orientations)."""
    V, T = tetlap.meshes.cube(k, jitter=0.2, seed=seed)
    T = T.copy()
    flip = np.random.default_rng(seed).random(len(T)) < 0.5
    T[flip] = T[flip][:, [1, 0, 2, 3]]
    return V, T


def random_spd(rng, m, decades=2.0, d=3):
    """``m`` SPD tensors ``R diag(l) R^T``, eigenvalues from 1 to ``10^decades``,
    symmetric to the last bit."""
    Q, _ = np.linalg.qr(rng.normal(size=(m, d, d)))
    lam = 10.0 ** (decades * rng.random((m, d)))
    K = np.einsum("mij,mj,mkj->mik", Q, lam, Q)
    return (K + K.swapaxes(-1, -2)) / 2


def inv_sqrt(K):
    lam, Q = np.linalg.eigh(K)
    return Q @ np.diag(lam ** -0.5) @ Q.T


def dense(A):
    return A.toarray() if sp.issparse(A) else np.asarray(A)


def rel(A, B):
    A, B = dense(A), dense(B)
    return abs(A - B).max() / abs(B).max()


def bits_equal(A, B):
    A, B = (A.tocsr(), B.tocsr()) if sp.issparse(A) else (A, B)
    if sp.issparse(A):
        return (np.array_equal(A.indptr, B.indptr) and np.array_equal(A.indices, B.indices)
                and A.data.tobytes() == B.data.tobytes())
    return np.asarray(A).tobytes() == np.asarray(B).tobytes()


# -- the plain path, bit for bit ---------------------------------------------------------

def every_output(V, T, **kw):
    """Every operator of the one-shot API, and the Mesh's, for comparison bit by bit."""
    lap_kw = {k: v for k, v in kw.items() if k != "density"}
    mass_kw = {k: v for k, v in kw.items() if k != "coefficient"}
    out = {}
    for kind in KINDS:
        out[f"laplacian {kind}"] = tetlap.laplacian(V, T, kind, **lap_kw)
        out[f"contributions {kind}"] = tetlap.element_contributions(V, T, kind, **lap_kw)
        out[f"triplets {kind}"] = tetlap.triplets(V, T, kind, **lap_kw).vals
        out[f"edge_weights {kind}"] = tetlap.edge_weights(V, T, kind, **lap_kw)[1]
    for mass in MASSES:
        out[f"mass {mass}"] = tetlap.mass(V, T, mass, **mass_kw)
        L, M = tetlap.operators(V, T, "dual", mass, **kw)
        out[f"operators {mass}"] = (L, M)
    mesh = tetlap.Mesh(V, T, **kw)
    out["Mesh"] = (mesh.laplacian("dual"), mesh.laplacian("primal"), mesh.mass("fem"))
    return out


def same_bits(a, b):
    if isinstance(a, tuple):
        return all(same_bits(x, y) for x, y in zip(a, b))
    return bits_equal(a, b)


@pytest.mark.parametrize("seed", [0, 1])
def test_ones_and_none_give_the_plain_operators_bit_for_bit(seed):
    V, T = mixed_cube(4, seed)
    plain = every_output(V, T)
    m = len(T)
    for kw in [dict(coefficient=None, density=None), dict(coefficient=np.ones(m)),
               dict(density=np.ones(m)), dict(coefficient=np.ones(m), density=np.ones(m))]:
        got = every_output(V, T, **kw)
        moved = [k for k in plain if not same_bits(plain[k], got[k])]
        assert not moved, (kw, moved)
    # vertex weights and the barycentric boundary take the scalar path bit for bit too
    w = 1e-3 * np.random.default_rng(seed).random(len(V))
    for options in [dict(weights=w), dict(boundary_centres="barycentric")]:
        a = tetlap.operators(V, T, "dual", "circumcentric", **options)
        b = tetlap.operators(V, T, "dual", "circumcentric", coefficient=np.ones(m), **options)
        assert same_bits(a, b), options


def test_identity_tensors_give_the_plain_operators_to_rounding():
    V, T = mixed_cube(4, 2)
    for K in [np.eye(3), np.broadcast_to(np.eye(3), (len(T), 3, 3)), 4.0 * np.eye(3)]:
        scale = 4.0 if K.ndim == 2 and K[0, 0] == 4 else 1.0
        for kind in KINDS:
            got = tetlap.laplacian(V, T, kind, coefficient=K)
            assert rel(got, scale * tetlap.laplacian(V, T, kind)) < 1e-14, kind


def test_a_scalar_coefficient_scales_each_element():
    V, T = mixed_cube(4, 3)
    c = np.random.default_rng(3).uniform(0.1, 10.0, len(T))
    for kind in KINDS:
        W = tetlap.element_contributions(V, T, kind, coefficient=c)
        assert bits_equal(W, tetlap.element_contributions(V, T, kind) * c[:, None]), kind
        # the assembled operator is the sum of the scaled elements
        E = np.sort(T[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]], axis=2).reshape(-1, 2)
        n = len(V)
        A = sp.coo_array((W.ravel(), (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
        A = A + A.T
        A = A - sp.diags_array(np.asarray(A.sum(axis=1)).ravel())
        assert rel(tetlap.laplacian(V, T, kind, coefficient=c), A) < 1e-14, kind


def test_density_scales_every_mass_kind_per_element():
    V, T = mixed_cube(4, 4)
    rho = np.random.default_rng(4).uniform(0.5, 3.0, len(T))
    for kind in MASSES:
        got = tetlap.mass(V, T, kind, density=rho).toarray()
        # each tet's contribution scaled: the mass of the mesh of one tet at a time
        want = np.zeros_like(got)
        for t in range(len(T)):
            want += rho[t] * tetlap.mass(V, T[t:t + 1], kind).toarray()
        assert rel(got, want) < 1e-13, kind
    total = tetlap.mass(V, T, "fem", density=rho).sum()
    vol = np.abs(np.linalg.det(V[T[:, 1:]] - V[T[:, :1]])) / 6
    assert abs(total - (rho * vol).sum()) < 1e-13


# -- the definitions against independent routes ------------------------------------------

def exact_primal(X, K):
    """Six primal weights ``-Vol grad(l_a) . K grad(l_b)`` in exact rationals (``K``
    rational 3 x 3)."""
    e = [ref.sub(X[k], X[0]) for k in (1, 2, 3)]
    vol = abs(ref.det3(*e)) / 6
    grads = [ref.solve3(e, [Fraction(int(j == k)) for j in range(3)]) for k in range(3)]
    grads = [ref.scale(ref.add(ref.add(grads[0], grads[1]), grads[2]), -1)] + grads
    Kg = lambda g: [sum(K[i][j] * g[j] for j in range(3)) for i in range(3)]  # noqa: E731
    return [-vol * ref.dot(grads[a], Kg(grads[b])) for a, b in ref.EDGES]


def integer_tets(rng, m):
    """``m`` tets with small integer coordinates, non-degenerate, mixed orientations."""
    out = []
    while len(out) < m:
        X = rng.integers(-4, 5, size=(4, 3))
        if round(np.linalg.det(X[1:] - X[0])) != 0:
            out.append(X)
    return np.array(out)


def dyadic_factor(rng):
    """A lower triangular ``C`` with power-of-two diagonal and dyadic entries below: ``K =
    C C^T`` and its inverse square-root map ``C^-1`` are exact rationals, and ``K`` is
    exact in float64."""
    C = np.tril(rng.integers(-4, 5, size=(3, 3)) / 4.0, -1)
    C[np.diag_indices(3)] = 2.0 ** rng.integers(-1, 2, size=3)
    return C


def test_the_primal_with_a_tensor_is_the_exact_bilinear_form():
    rng = np.random.default_rng(5)
    worst = 0.0
    for X in integer_tets(rng, 40):
        C = dyadic_factor(rng)
        K = C @ C.T
        V = X.astype(float)
        got = tetlap.element_contributions(V, [[0, 1, 2, 3]], "primal", coefficient=[K])[0]
        Kq = [[Fraction(x) for x in row] for row in K]
        want = [float(w) for w in exact_primal([ref.vec(p) for p in X], Kq)]
        worst = max(worst, abs(got - want).max() / abs(np.array(want)).max())
    assert worst < 1e-13, worst


def mapped_exact(X, C):
    """The tet ``X`` (integers) mapped by ``C^-1`` exactly: rational corners."""
    Cq = [[Fraction(x) for x in row] for row in C]
    out = []
    for p in X:  # forward substitution C y = p
        y = []
        for i in range(3):
            y.append((Fraction(int(p[i])) - sum(Cq[i][j] * y[j] for j in range(i))) / Cq[i][i])
        out.append(y)
    return out


@pytest.mark.parametrize("case", ["plain", "weights", "centroids"])
def test_the_dual_in_the_metric_is_the_exact_dual_of_the_mapped_tet(case):
    """The dual with ``K = C C^T``: ``det C`` times the exact circumcentric (power, with
    centroids) dual of the tet mapped by ``C^-1``, by explicit centres (Cramer's rule) and
    signed pieces, a route that shares nothing with the kernels."""
    rng = np.random.default_rng(6)
    worst = 0.0
    for X in integer_tets(rng, 30):
        C = dyadic_factor(rng)
        K = C @ C.T
        V = X.astype(float)
        W = [Fraction(int(x), 8) for x in rng.integers(-3, 4, size=4)] if case == "weights" else None
        weights = None if W is None else np.array([float(x) for x in W])
        if case == "centroids":
            # the barycentric boundary fix applies to a tet with a boundary face: every
            # face of a single tet is one
            got = tetlap.element_contributions(V, [[0, 1, 2, 3]], "dual", coefficient=[K],
                                               boundary_centres="barycentric")[0]
        else:
            got = tetlap.element_contributions(V, [[0, 1, 2, 3]], "dual", coefficient=[K],
                                               weights=weights)[0]
        placement = "centroids" if case == "centroids" else "centres"
        w, _ = ref.dual_tet(mapped_exact(X, C), W, placement)
        det_c = Fraction(float(np.prod(np.diag(C))))
        want = np.array([float(x * det_c) for x in w])
        worst = max(worst, abs(got - want).max() / abs(want).max())
    assert worst < 1e-13, worst


def test_the_primal_with_a_tensor_agrees_with_scikit_fem():
    skfem = pytest.importorskip("skfem")
    from skfem.helpers import dot, grad

    V, T = mixed_cube(4, 7)
    K = random_spd(np.random.default_rng(7), len(T), decades=3)
    # scikit-fem wants positively oriented tets; the stiffness does not depend on it
    Tp = T.copy()
    neg = np.linalg.det(V[T[:, 1:]] - V[T[:, :1]]) < 0
    Tp[neg] = Tp[neg][:, [1, 0, 2, 3]]
    basis = skfem.Basis(skfem.MeshTet(V.T, Tp.T), skfem.ElementTetP1())

    @skfem.BilinearForm
    def tensor_form(u, v, w):
        return dot(np.einsum("ij...,j...->i...", w.K, grad(u)), grad(v))

    nq = basis.X.shape[-1]
    Kq = np.broadcast_to(K.transpose(1, 2, 0)[..., None], (3, 3, len(T), nq))
    stiffness = tensor_form.assemble(basis, K=Kq)
    L = tetlap.laplacian(V, T, "primal", coefficient=K)
    assert rel(L, -stiffness) < 1e-12


@pytest.mark.parametrize("options", [{}, {"boundary_centres": "barycentric"}, {"weights": "random"}])
def test_a_constant_tensor_is_the_plain_operator_of_the_mapped_mesh(options):
    V, T = mixed_cube(4, 8)
    rng = np.random.default_rng(8)
    K = random_spd(rng, 1, decades=1.5)[0]
    if options.get("weights") == "random":
        options = {"weights": 1e-3 * rng.random(len(V))}
    mapped = V @ inv_sqrt(K)  # rows are points: x -> K^-1/2 x (symmetric)
    factor = np.sqrt(np.linalg.det(K))
    for kind in KINDS:
        if "weights" in options and kind != "dual":
            continue
        got = tetlap.laplacian(V, T, kind, coefficient=K, **options)
        want = factor * tetlap.laplacian(mapped, T, kind, **options)
        assert rel(got, want) < 1e-13, kind
        # the same tensor given per tet
        per_tet = tetlap.laplacian(V, T, kind, coefficient=np.broadcast_to(K, (len(T), 3, 3)),
                                   **options)
        assert bits_equal(per_tet, got), kind


def test_triangles_take_scalars_and_tensors_in_the_plane():
    V3, T = tetlap.meshes.cube(3)  # a surface to take triangles from
    rng = np.random.default_rng(9)
    V = rng.random((30, 2))
    from scipy.spatial import Delaunay

    T = Delaunay(V).simplices
    K = random_spd(rng, 1, decades=1.0, d=2)[0]
    got = tetlap.laplacian(V, T, coefficient=K)
    want = np.sqrt(np.linalg.det(K)) * tetlap.laplacian(V @ inv_sqrt(K), T)
    assert rel(got, want) < 1e-13
    Ks = random_spd(rng, len(T), d=2)
    for t in [0, 5]:  # per triangle: each one its own mapped triangle
        one = tetlap.element_contributions(V, T[t:t + 1], coefficient=Ks[t:t + 1])
        mapped = tetlap.element_contributions(V @ inv_sqrt(Ks[t]), T[t:t + 1])
        assert rel(one, np.sqrt(np.linalg.det(Ks[t])) * mapped) < 1e-13
    c = rng.uniform(0.5, 2.0, len(T))
    assert bits_equal(tetlap.element_contributions(V, T, coefficient=c),
                      tetlap.element_contributions(V, T) * c[:, None])
    # immersed meshes take scalars only
    V3 = np.c_[V, V[:, 0] ** 2]
    tetlap.laplacian(V3, T, coefficient=c)
    with pytest.raises(tetlap.ShapeError, match="own space"):
        tetlap.laplacian(V3, T, coefficient=np.eye(2))
    with pytest.raises(tetlap.ShapeError, match=r"\(2, 2\)"):
        tetlap.laplacian(V, T, coefficient=np.eye(3))


def test_immersed_tets_take_scalars_only():
    V, T = mixed_cube(2, 10)
    V4 = np.c_[V, np.zeros(len(V))]
    c = np.full(len(T), 2.0)
    assert rel(tetlap.laplacian(V4, T, coefficient=c), 2 * tetlap.laplacian(V4, T)) < 1e-15
    with pytest.raises(tetlap.ShapeError, match="immersed in R\\^4"):
        tetlap.laplacian(V4, T, coefficient=np.eye(3))


# -- scaling -----------------------------------------------------------------------------

def test_a_tensor_scaled_by_a_power_of_two_scales_the_operator_exactly():
    V, T = mixed_cube(3, 11)
    K = random_spd(np.random.default_rng(11), len(T), decades=2)
    c = np.random.default_rng(12).uniform(0.5, 2.0, len(T))
    for kind in KINDS:
        base = tetlap.laplacian(V, T, kind, coefficient=K)
        base_c = tetlap.laplacian(V, T, kind, coefficient=c)
        for k in [-498, -200, -1, 1, 77, 498]:  # 2^-498 ~ 1e-150, 2^498 ~ 1e150
            s = np.ldexp(1.0, k)
            assert bits_equal(tetlap.laplacian(V, T, kind, coefficient=K * s), base * s), (kind, k)
            assert bits_equal(tetlap.laplacian(V, T, kind, coefficient=c * s), base_c * s), (kind, k)


@pytest.mark.parametrize("scale", [1e-150, 1e150])
def test_extreme_coordinates_and_offsets_with_a_tensor(scale):
    V, T = mixed_cube(3, 13)
    K = random_spd(np.random.default_rng(13), len(T), decades=2)
    s = np.ldexp(1.0, int(np.round(np.log2(scale))))
    for kind in KINDS:
        base = tetlap.laplacian(V, T, kind, coefficient=K)
        # lengths scaled by a power of two: every weight scaled by it, exactly
        assert bits_equal(tetlap.laplacian(V * s, T, kind, coefficient=K), base * s), kind
        # the coefficient against the coordinates: no overflow or underflow on the way
        got = tetlap.laplacian(V * s, T, kind, coefficient=K / s)
        assert rel(got, base) < 1e-15, kind
        # an offset of 1e6: the coordinates' rounding only
        assert rel(tetlap.laplacian(V + 1e6, T, kind, coefficient=K), base) < 1e-8, kind


# -- bad input -----------------------------------------------------------------------------

def bad_cases(m):
    """(name, coefficient, density, error class, message pieces, element)."""
    ones = np.ones(m)

    def at(t, x, arr=None):
        a = ones.copy() if arr is None else arr.copy()
        a[t] = x
        return a

    K = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
    skew, indefinite, nan_tensor = K.copy(), K.copy(), K.copy()
    skew[4, 0, 1] = 0.1
    indefinite[6] = [[1, 2, 0], [2, 1, 0], [0, 0, 5]]
    nan_tensor[2, 1, 2] = np.nan
    return [
        ("nan", at(3, np.nan), None, tetlap.NonFiniteError, ["coefficient[3]", "tet 3", "nan"], 3),
        ("inf", at(1, np.inf), None, tetlap.NonFiniteError, ["coefficient[1]", "inf"], 1),
        ("zero", at(5, 0.0), None, tetlap.CoefficientError, ["coefficient[5]", "positive"], 5),
        ("negative", at(2, -3.0), None, tetlap.CoefficientError, ["-3.0", "positive"], 2),
        ("nan tensor", nan_tensor, None, tetlap.NonFiniteError, ["coefficient[2, 1, 2]"], 2),
        ("skew", skew, None, tetlap.CoefficientError, ["tet 4", "not symmetric", "1.00000e-01"], 4),
        ("indefinite", indefinite, None, tetlap.CoefficientError,
         ["tet 6", "smallest eigenvalue is -1.00000e+00"], 6),
        ("constant indefinite", np.array([[1.0, 2, 0], [2, 1, 0], [0, 0, 1]]), None,
         tetlap.CoefficientError, ["one tensor for every tet", "-1.00000e+00"], None),
        ("density nan", None, at(7, np.nan), tetlap.NonFiniteError, ["density[7]"], 7),
        ("density zero", None, at(0, 0.0), tetlap.CoefficientError, ["density[0]", "positive"], 0),
    ]


@pytest.mark.parametrize("case", range(10))
def test_bad_values_raise_naming_the_element_and_change_nothing(case):
    V, T = mixed_cube(2, 14)
    name, c, rho, error, pieces, element = bad_cases(len(T))[case]
    copies = [None if a is None else a.copy() for a in (c, rho)]
    calls = [
        lambda: tetlap.laplacian(V, T, coefficient=c) if c is not None else tetlap.mass(V, T, density=rho),
        lambda: tetlap.operators(V, T, coefficient=c, density=rho),
        lambda: tetlap.Mesh(V, T, coefficient=c, density=rho),
        lambda: coef.check(c if c is not None else rho, V, T, density=c is None),
    ]
    for call in calls:
        with pytest.raises(error) as e:
            call()
        for piece in pieces:
            assert piece in str(e.value), (name, str(e.value))
        assert e.value.element == element, name
    for a, b in zip((c, rho), copies):
        assert a is None or np.array_equal(a, b, equal_nan=True)
    # Mesh.update refuses it too, and the mesh is unchanged
    mesh = tetlap.Mesh(V, T)
    L = mesh.laplacian("dual")
    with pytest.raises(error):
        mesh.update(coefficient=c, density=rho)
    assert bits_equal(mesh.laplacian("dual"), L)


def test_a_tensor_symmetric_up_to_rounding_is_accepted():
    V, T = mixed_cube(2, 15)
    K = random_spd(np.random.default_rng(15), len(T))
    K[:, 0, 1] *= 1 + 1e-15
    tetlap.laplacian(V, T, coefficient=K)


def test_bad_shapes_name_the_accepted_ones():
    V, T = mixed_cube(2, 16)
    m, n = len(T), len(V)
    with pytest.raises(tetlap.ShapeError, match=rf"\({m},\).*\({m}, 3, 3\).*\(3, 3\).*got \(4, 2\)"):
        tetlap.laplacian(V, T, coefficient=np.ones((4, 2)))
    with pytest.raises(tetlap.ShapeError, match="one value per vertex.*from_vertices"):
        tetlap.laplacian(V, T, coefficient=np.ones(n))
    with pytest.raises(tetlap.ShapeError, match="one value per vertex.*from_vertices"):
        tetlap.laplacian(V, T, coefficient=np.broadcast_to(np.eye(3), (n, 3, 3)))
    with pytest.raises(tetlap.ShapeError, match=rf"density must have shape \({m},\)"):
        tetlap.mass(V, T, density=np.ones((m, 3, 3)))
    with pytest.raises(tetlap.ShapeError, match=r"got \(\)"):
        tetlap.laplacian(V, T, coefficient=np.float64(2.0))
    with pytest.raises(TypeError):
        tetlap.laplacian(V, T, coefficient=2.0)
    with pytest.raises(tetlap.DtypeError):
        tetlap.laplacian(V, T, coefficient=np.ones(m, dtype=bool))
    with pytest.raises(tetlap.DtypeError):
        tetlap.laplacian(V, T, coefficient=np.ones(m, dtype=complex))
    with pytest.raises(TypeError):
        tetlap.laplacian(V, T, coefficient="ones")


def test_per_element_values_are_taken_as_such_when_n_equals_m():
    # one tet, four vertices: n != m; a mesh with as many vertices as tets takes (m,) as is
    V, T = tetlap.meshes.cube(2)
    V = np.r_[V, np.random.default_rng(17).random((len(T) - len(V), 3)) + 5]  # unused vertices
    assert len(V) == len(T)
    c = np.arange(1.0, len(T) + 1)
    assert bits_equal(tetlap.element_contributions(V, T, coefficient=c),
                      tetlap.element_contributions(V, T) * c[:, None])


# -- Mesh.update ---------------------------------------------------------------------------

def test_mesh_update_with_a_coefficient_is_a_one_shot_assembly():
    V, T = mixed_cube(5, 18)
    rng = np.random.default_rng(18)
    m = len(T)
    mesh = tetlap.Mesh(V, T)
    mesh.operators("dual", "circumcentric")
    mesh.laplacian(0.3)
    mesh.mass("fem")

    def agree(**kw):
        lap_kw = {k: v for k, v in kw.items() if k != "density"}
        for kind in ["dual", 0.3]:
            assert bits_equal(mesh.laplacian(kind), tetlap.laplacian(mesh.V, T, kind, **lap_kw)), kind
        for kind in ["circumcentric", "fem"]:
            want = tetlap.mass(mesh.V, T, kind, density=kw.get("density"))
            assert bits_equal(mesh.mass(kind), want), kind

    c = np.ones(m)
    c[:7] = 3.0
    info = mesh.update(coefficient=c)  # from none: only the tets whose scalar is not 1
    assert info == tetlap.UpdateInfo(0, 7, info.recomputed_rows) and info.recomputed_rows > 0
    agree(coefficient=c)
    c2 = c.copy()
    c2[[3, 100]] = [0.5, 2.0]
    assert mesh.update(coefficient=c2).recomputed_tets == 2
    agree(coefficient=c2)
    K = random_spd(rng, m)
    assert mesh.update(coefficient=K).recomputed_tets == m  # a new form: every tet
    agree(coefficient=K)
    K2 = K.copy()
    K2[10] *= 2
    assert mesh.update(coefficient=K2).recomputed_tets == 1
    agree(coefficient=K2)
    Kc = np.diag([1.0, 2.0, 3.0])
    mesh.update(coefficient=Kc)
    agree(coefficient=Kc)
    assert mesh.update(coefficient=Kc).recomputed_tets == 0
    rho = np.ones(m)
    rho[5] = 2.0
    assert mesh.update(density=rho).recomputed_tets == m  # from none: a new form
    agree(coefficient=Kc, density=rho)
    V2 = V.copy()
    V2[40] += 0.01
    rho2 = rho.copy()
    rho2[0] = 4.0
    info = mesh.update(V2, coefficient=K2, density=rho2)  # everything at once
    agree(coefficient=K2, density=rho2)
    assert info.moved_vertices == 1


def test_mesh_update_that_fails_changes_nothing():
    V, T = mixed_cube(3, 19)
    c = np.full(len(T), 2.0)
    mesh = tetlap.Mesh(V, T, coefficient=c)
    L = mesh.laplacian("primal")
    V2 = V.copy()
    V2[0] = np.nan
    with pytest.raises(tetlap.NonFiniteError):
        mesh.update(V2, coefficient=np.full(len(T), 3.0))
    assert bits_equal(mesh.laplacian("primal"), L)
    assert bits_equal(L, tetlap.laplacian(V, T, coefficient=c))


def test_threads_do_not_change_a_bit():
    V, T = mixed_cube(6, 20)
    K = random_spd(np.random.default_rng(20), len(T), decades=3)
    c = np.random.default_rng(21).uniform(0.1, 10, len(T))
    for kw in [dict(coefficient=K), dict(coefficient=c, density=c)]:
        first = None
        for threads in [1, 2, 3]:
            out = tetlap.operators(V, T, 0.4, "fem", threads=threads, **kw)
            if first is None:
                first = out
            assert same_bits(out, first), threads


# -- properties on random tensors (Hypothesis) -----------------------------------------

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@st.composite
def spd_tensors(draw, d=3):
    """A random SPD tensor: a rotation from a random unit quaternion (or angle) and
    eigenvalues over up to eight decades, at a random power-of-ten scale."""
    lam = np.array([10.0 ** draw(st.floats(-4, 4)) for _ in range(d)])
    scale = 10.0 ** draw(st.integers(-100, 100))
    if d == 3:
        q = np.array([draw(st.floats(-1, 1)) for _ in range(4)])
        q = q / np.linalg.norm(q) if np.linalg.norm(q) > 1e-3 else np.array([1.0, 0, 0, 0])
        a, b, c, e = q
        R = np.array([[a*a + b*b - c*c - e*e, 2*(b*c - a*e), 2*(b*e + a*c)],
                      [2*(b*c + a*e), a*a - b*b + c*c - e*e, 2*(c*e - a*b)],
                      [2*(b*e - a*c), 2*(c*e + a*b), a*a - b*b - c*c + e*e]])
    else:
        th = draw(st.floats(0, np.pi))
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    K = R @ np.diag(lam) @ R.T * scale
    return (K + K.T) / 2


@settings(max_examples=60, deadline=None)
@given(K=spd_tensors(), seed=st.integers(0, 2**31))
def test_the_primal_with_a_tensor_is_symmetric_semidefinite_and_rotation_invariant(K, seed):
    rng = np.random.default_rng(seed)
    V = rng.random((12, 3))
    from scipy.spatial import Delaunay

    T = Delaunay(V).simplices
    L = tetlap.laplacian(V, T, "primal", coefficient=K).toarray()
    size = abs(L).max()
    assert abs(L - L.T).max() <= 1e-14 * size
    assert abs(L.sum(axis=1)).max() <= 1e-12 * size
    assert np.linalg.eigvalsh(L).max() <= 1e-12 * size
    # rotate the mesh and the tensor together: the same operator
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    L_rot = tetlap.laplacian(V @ Q.T, T, "primal", coefficient=Q @ K @ Q.T).toarray()
    assert abs(L_rot - L).max() <= 1e-11 * size


@settings(max_examples=60, deadline=None)
@given(K=spd_tensors(), seed=st.integers(0, 2**31), kind=st.sampled_from(["primal", "dual"]))
def test_a_random_tensor_is_the_plain_operator_of_the_mapped_tet(K, seed, kind):
    X = np.random.default_rng(seed).random((4, 3))
    if abs(np.linalg.det(X[1:] - X[0])) < 1e-3:
        return
    got = tetlap.element_contributions(X, [[0, 1, 2, 3]], kind, coefficient=[K])[0]
    want = np.sqrt(np.linalg.det(K)) * tetlap.element_contributions(X @ inv_sqrt(K), [[0, 1, 2, 3]], kind)[0]
    # the mapped tet is computed in float64 from eigenvectors here: its rounding grows with
    # the tensor's condition number
    cond = np.linalg.cond(K)
    assert abs(got - want).max() <= 1e-13 * max(1.0, cond) * abs(want).max()


# -- per-vertex fields -------------------------------------------------------------------

def test_from_vertices_averages_each_element():
    V, T = mixed_cube(3, 22)
    rng = np.random.default_rng(22)
    v = rng.uniform(0.5, 4.0, len(V))
    assert np.allclose(coef.from_vertices(v, T), v[T].mean(axis=1), rtol=1e-15)
    assert np.allclose(coef.from_vertices(v, T, "harmonic"), 4 / (1 / v[T]).sum(axis=1))
    assert np.allclose(coef.from_vertices(v, T, "geometric"), np.exp(np.log(v[T]).mean(axis=1)))
    # harmonic <= geometric <= mean, and the output is a valid coefficient
    h, g, a = (coef.from_vertices(v, T, m) for m in ("harmonic", "geometric", "mean"))
    assert (h <= g * (1 + 1e-14)).all() and (g <= a * (1 + 1e-14)).all()
    Kv = random_spd(rng, len(V))
    for method in ("mean", "harmonic"):
        Kt = coef.from_vertices(Kv, T, method)
        assert Kt.shape == (len(T), 3, 3)
        tetlap.laplacian(V, T, coefficient=Kt)
    t = 5
    assert np.allclose(coef.from_vertices(Kv, T, "harmonic")[t],
                       np.linalg.inv(np.linalg.inv(Kv[T[t]]).mean(axis=0)))
    with pytest.raises(tetlap.OptionError, match="scalars only"):
        coef.from_vertices(Kv, T, "geometric")
    with pytest.raises(tetlap.OptionError):
        coef.from_vertices(v, T, "median")
    bad = v.copy()
    bad[9] = -1.0
    with pytest.raises(tetlap.CoefficientError, match=r"values\[9\] \(vertex 9\)") as e:
        coef.from_vertices(bad, T)
    assert e.value.vertex == 9
    with pytest.raises(tetlap.ShapeError):
        coef.from_vertices(np.ones((len(V), 2)), T)


def test_check_returns_a_validated_copy():
    V, T = mixed_cube(2, 23)
    c = [1.0] * len(T)
    out = coef.check(c, V, T)
    assert out.dtype == np.float64 and out.shape == (len(T),) and out.flags.c_contiguous
    K = np.eye(3)
    out = coef.check(K, V, T)
    out[0, 0] = 5.0
    assert K[0, 0] == 1.0
    assert coef.check(np.ones(len(T), dtype=np.int32), V, T, density=True).dtype == np.float64
