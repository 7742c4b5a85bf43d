"""Derivatives of the operators (tetlap.vjp, dirichlet_energy, mass_energy).

**Finite differences.** Every gradient is compared with fourth-order central differences
``(8 (f(x + h) - f(x - h)) - (f(x + 2h) - f(x - 2h))) / 12 h`` of the assembled operators
(:func:`tetlap.laplacian`, :func:`tetlap.mass`), in every coordinate, with ``h = 1e-4``
times the mesh's mean edge length (truncation ~ h^4, rounding ~ eps / h: both below 1e-9
relative on the meshes used). The error is ``max |g - fd| / max |g|`` over all
coordinates; the target is 1e-6.

**Slivers excluded.** Random meshes are Delaunay tetrahedralisations of random points
(scipy) from which every tet of quality ``6 sqrt(2) Vol / l_max^3 < 0.1`` is removed (1 for
the regular tet, 0 for a flat one; a sliver's derivatives are huge and its differences
need a much smaller step, so it tests the differences, not the gradient). The kept meshes
still have obtuse tets, negative dual weights and non-Delaunay configurations.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tetlap

MIN_QUALITY = 0.1
TOL = 1e-6


def quality(V, T):
    E = V[T[:, 1:]] - V[T[:, :1]]
    vol = np.abs(np.einsum("ij,ij->i", E[:, 0], np.cross(E[:, 1], E[:, 2]))) / 6
    pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    lmax = np.max([np.linalg.norm(V[T[:, a]] - V[T[:, b]], axis=1) for a, b in pairs], axis=0)
    return 6 * np.sqrt(2) * vol / lmax**3


def random_mesh(seed: int, n: int = 14):
    """A random Delaunay mesh without slivers (see the module docs), unreferenced vertices
    dropped, mixed orientations."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    V = rng.uniform(-1, 1, size=(n, 3))
    T = Delaunay(V).simplices.astype(np.int64)
    T = T[quality(V, T) >= MIN_QUALITY]
    V, T = tetlap.meshes.compact(V, T)
    flip = rng.uniform(size=len(T)) < 0.5
    T[flip, 1], T[flip, 2] = T[flip, 2].copy(), T[flip, 1].copy()
    return V, T


def mean_edge(V, T):
    E = tetlap.diagnostics.mesh_edges(T)
    return np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean()


def differences(phi, x, h):
    """Fourth-order central differences of ``phi`` at every entry of ``x``."""
    g = np.zeros_like(x)
    for k in np.ndindex(x.shape):
        def at(t):
            y = x.copy()
            y[k] += t
            return phi(y)
        g[k] = (8 * (at(h) - at(-h)) - (at(2 * h) - at(-2 * h))) / (12 * h)
    return g


def rel_err(g, fd):
    return np.abs(g - fd).max() / max(np.abs(g).max(), 1e-300)


def pairing_L(V, T, kind, dL, **kw):
    """<dL, L> with dL dense (n, n)."""
    return float((tetlap.laplacian(V, T, kind, **kw).toarray() * dL).sum())


def pairing_M(V, T, kind, dM, **kw):
    return float((tetlap.mass(V, T, kind, **kw).toarray() * dM).sum())


# ---------------------------------------------------------------- central differences

KINDS = ["primal", "dual", 0.3]
MASSES = ["barycentric", "circumcentric", "fem"]


@pytest.mark.parametrize("kind", KINDS)
def test_dirichlet_energy_matches_differences(kind):
    V, T = random_mesh(1)
    f = np.random.default_rng(2).normal(size=(len(V), 2))
    E, dE = tetlap.dirichlet_energy(V, T, f, kind)
    L = tetlap.laplacian(V, T, kind)
    assert np.isclose(E, -np.trace(f.T @ (L @ f)), rtol=1e-12)
    fd = differences(lambda X: tetlap.dirichlet_energy(X, T, f, kind)[0], V, 1e-4 * mean_edge(V, T))
    assert rel_err(dE, fd) < TOL


@pytest.mark.parametrize("kind", MASSES)
def test_mass_energy_matches_differences(kind):
    V, T = random_mesh(3)
    f = np.random.default_rng(4).normal(size=len(V))
    E, dE = tetlap.mass_energy(V, T, f, kind)
    assert np.isclose(E, f @ (tetlap.mass(V, T, kind) @ f), rtol=1e-12)
    fd = differences(lambda X: tetlap.mass_energy(X, T, f, kind)[0], V, 1e-4 * mean_edge(V, T))
    assert rel_err(dE, fd) < TOL


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), kind=st.sampled_from(KINDS),
       mass=st.sampled_from(MASSES), form=st.sampled_from(["sparse", "edges", "elements"]))
def test_random_cotangents_match_differences(seed, kind, mass, form):
    """Hypothesis: random meshes, random cotangents on L (in each form) and on M."""
    V, T = random_mesh(seed, n=12)
    n, m = len(V), len(T)
    rng = np.random.default_rng(seed + 1)
    dense = rng.normal(size=(n, n)) * (rng.uniform(size=(n, n)) < 0.6)
    dMd = rng.normal(size=(n, n)) * (rng.uniform(size=(n, n)) < 0.6)
    if form == "sparse":
        dL, phiL = sp.csr_array(dense), lambda X: pairing_L(X, T, kind, dense)
    elif form == "edges":
        edges, _ = tetlap.edge_weights(V, T)
        dw = rng.normal(size=len(edges))
        dL = (edges, dw)
        phiL = lambda X: float(tetlap.edge_weights(X, T, kind)[1] @ dw)  # noqa: E731
    else:
        dW = rng.normal(size=(m, 6))
        dL = dW
        phiL = lambda X: float((tetlap.element_contributions(X, T, kind) * dW).sum())  # noqa: E731
    g = tetlap.vjp(V, T, kind, mass, dL=dL, dM=sp.coo_array(dMd))

    def phi(X):
        return phiL(X) + pairing_M(X, T, mass, dMd)

    assert np.isclose(g.value, phi(V), rtol=1e-10, atol=1e-12)
    fd = differences(phi, V, 1e-4 * mean_edge(V, T))
    assert rel_err(g.dV, fd) < TOL
    assert g.dweights is None


def test_weighted_dual_gradients_match_differences():
    V, T = random_mesh(5)
    rng = np.random.default_rng(6)
    h = mean_edge(V, T)
    w = rng.uniform(0, 0.05 * h * h, size=len(V))
    f = rng.normal(size=len(V))
    E, dE, dw = tetlap.dirichlet_energy(V, T, f, "dual", weights=w, return_weights_gradient=True)
    fdV = differences(lambda X: tetlap.dirichlet_energy(X, T, f, "dual", weights=w)[0], V, 1e-4 * h)
    fdw = differences(lambda x: tetlap.dirichlet_energy(V, T, f, "dual", weights=x)[0], w, 1e-4 * h * h)
    assert rel_err(dE, fdV) < TOL
    assert rel_err(dw, fdw) < TOL
    assert abs(dw.sum()) < 1e-10 * np.abs(dw).max()  # a constant shift changes nothing
    # the mass too, through the general product
    g = tetlap.vjp(V, T, mass="circumcentric", dM=f, weights=w)
    fdw = differences(lambda x: float(tetlap.mass(V, T, "circumcentric", weights=x).diagonal() @ f),
                      w, 1e-4 * h * h)
    assert rel_err(g.dweights, fdw) < TOL
    # the primal does not depend on the weights: it refuses them (issue 37: ignored)
    with pytest.raises(tetlap.OptionError, match="weights"):
        tetlap.dirichlet_energy(V, T, f, "primal", weights=w, return_weights_gradient=True)
    _, _, zero = tetlap.dirichlet_energy(V, T, f, "primal", return_weights_gradient=True)
    assert not zero.any()


def test_immersed_meshes_match_differences():
    """A mesh rotated into R^4: the gradient is the rotated R^3 gradient, and matches
    differences in all four coordinates."""
    V, T = random_mesh(7)
    rng = np.random.default_rng(8)
    Q, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    V4 = np.column_stack([V, np.zeros(len(V))]) @ Q.T + rng.normal(size=4)
    f = rng.normal(size=len(V))
    for kind in ("primal", "dual"):
        _, g3 = tetlap.dirichlet_energy(V, T, f, kind)
        _, g4 = tetlap.dirichlet_energy(V4, T, f, kind)
        assert np.allclose(g4, np.column_stack([g3, np.zeros(len(V))]) @ Q.T, atol=1e-12 * np.abs(g3).max())
        fd = differences(lambda X: tetlap.dirichlet_energy(X, T, f, kind)[0], V4, 1e-4 * mean_edge(V, T))
        assert rel_err(g4, fd) < TOL
    _, gm = tetlap.mass_energy(V4, T, f, "circumcentric")
    fd = differences(lambda X: tetlap.mass_energy(X, T, f, "circumcentric")[0], V4, 1e-4 * mean_edge(V, T))
    assert rel_err(gm, fd) < TOL


# ---------------------------------------------------------------- forms agree

def test_cotangent_forms_agree():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    f = V[:, 0] * V[:, 1] - V[:, 2]
    _, dE = tetlap.dirichlet_energy(V, T, f, "dual")
    edges, _ = tetlap.edge_weights(V, T)
    diff2 = (f[edges[:, 0]] - f[edges[:, 1]]) ** 2
    pairs = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    per_tet = np.stack([(f[T[:, a]] - f[T[:, b]]) ** 2 for a, b in pairs], axis=1)
    scale = np.abs(dE).max()
    for dL in [(edges, diff2), (edges[::-1, ::-1], diff2[::-1]), -sp.csr_array(np.outer(f, f)),
               per_tet]:
        g = tetlap.vjp(V, T, "dual", dL=dL)
        assert np.abs(g.dV - dE).max() < 1e-13 * scale
    # masses: diagonal, sparse diagonal and quadratic form agree
    _, dm = tetlap.mass_energy(V, T, f, "barycentric")
    for dM in [f * f, sp.diags_array(f * f)]:
        assert np.abs(tetlap.vjp(V, T, mass="barycentric", dM=dM).dV - dm).max() < 1e-13 * np.abs(dm).max()
    _, dfem = tetlap.mass_energy(V, T, f, "fem")
    g = tetlap.vjp(V, T, mass="fem", dM=sp.csr_array(np.outer(f, f)))
    assert np.abs(g.dV - dfem).max() < 1e-13 * np.abs(dfem).max()


def test_vector_valued_f_sums_the_columns():
    V, T = tetlap.meshes.cube(2, jitter=0.2)
    F = np.random.default_rng(0).normal(size=(len(V), 3))
    E, dE = tetlap.dirichlet_energy(V, T, F, 0.5)
    parts = [tetlap.dirichlet_energy(V, T, F[:, k], 0.5) for k in range(3)]
    assert np.isclose(E, sum(p[0] for p in parts))
    assert np.allclose(dE, sum(p[1] for p in parts), atol=1e-14)
    # the coordinates themselves: -tr(V^T L V) for the primal
    E, _ = tetlap.dirichlet_energy(V, T, V, "primal")
    L = tetlap.laplacian(V, T)
    assert np.isclose(E, -np.trace(V.T @ (L @ V)))


def test_dirichlet_energy_of_the_coordinates_is_three_volumes():
    """For the primal, -tr(V^T L(V) V) = sum_t Vol_t (|grad x|^2 + |grad y|^2 + |grad z|^2)
    = 3 Vol(V) for every V. Differentiating both sides, with the partial derivative of
    E(V) = -tr(f^T L(V) f) at f = V: dE/dV - 2 L V = 3 dVol/dV."""
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=2)
    E, dE = tetlap.dirichlet_energy(V, T, V, "primal")
    vol = np.abs(tetlap.diagnostics.signed_volumes(V, T)).sum()
    assert np.isclose(E, 3 * vol)  # |grad x|^2 + |grad y|^2 + |grad z|^2 = 3
    _, dvol = tetlap.mass_energy(V, T, np.ones(len(V)), "barycentric")
    L = tetlap.laplacian(V, T)
    assert np.allclose(dE, 3 * dvol + 2 * (L @ V), atol=1e-13)
    assert not np.allclose(dE, 3 * dvol, atol=1e-3)  # the boundary rows differ


# ---------------------------------------------------------------- determinism, inputs

def test_bitwise_identical_for_any_thread_count():
    V, T = tetlap.meshes.ball(3000, seed=3)
    f = np.sin(3 * V)
    w = np.random.default_rng(1).uniform(0, 1e-3, size=len(V))
    runs = [tetlap.dirichlet_energy(V, T, f, "dual", weights=w, threads=k,
                                    return_weights_gradient=True) for k in (1, 2, 3, None)]
    for E, dE, dw in runs[1:]:
        assert E == runs[0][0]
        assert dE.tobytes() == runs[0][1].tobytes()
        assert dw.tobytes() == runs[0][2].tobytes()
    g = [tetlap.vjp(V, T, 0.4, "fem", dL=(T[:, :2], np.ones(len(T))), dM=f[:, 0], threads=k)
         for k in (1, 4)]
    assert g[0].dV.tobytes() == g[1].dV.tobytes() and g[0].value == g[1].value


def test_inputs_are_never_modified():
    V, T = tetlap.meshes.cube(2, jitter=0.2)
    V = np.asfortranarray(V)
    T = T.astype(np.int32)
    f = np.random.default_rng(0).normal(size=len(V))
    # a non-canonical sparse cotangent: row 0 unsorted, with a duplicate
    indptr = np.zeros(len(V) + 1, dtype=np.int32)
    indptr[1:] = 3
    dL = sp.csr_array((np.array([1.0, 2.0, 3.0]), np.array([5, 0, 5], dtype=np.int32), indptr),
                      shape=(len(V), len(V)))
    saved = [a.copy() for a in (V, T, f, dL.data, dL.indices, dL.indptr)]
    tetlap.vjp(V, T, "dual", "fem", dL=dL, dM=f)
    tetlap.dirichlet_energy(V, T, f, "dual")
    tetlap.mass_energy(V, T, f, "circumcentric")
    for a, b in zip(saved, (V, T, f, dL.data, dL.indices, dL.indptr)):
        assert np.array_equal(a, b)


def test_accepts_array_likes():
    V, T = tetlap.meshes.single_tet("corner")
    E1, g1 = tetlap.dirichlet_energy(V.tolist(), T.tolist(), [0, 1, 2, 3])
    E2, g2 = tetlap.dirichlet_energy(V.astype(np.float32), T.astype(np.uint32), np.arange(4.0))
    assert E1 == E2 and np.array_equal(g1, g2)
    assert g1.dtype == np.float64 and g1.shape == (4, 3)


def test_degenerate_policy():
    V, T = tetlap.meshes.cube(2)
    V = V.copy()
    T = np.vstack([T, [[0, 1, 2, 3]]])  # add a flat tet: 0, 1, 2 are collinear (z axis)
    f = V[:, 0]
    with pytest.raises(tetlap.DegenerateElementError) as e:
        tetlap.dirichlet_energy(V, T, f, "dual")
    assert e.value.element == len(T) - 1
    E, dE = tetlap.dirichlet_energy(V, T, f, "dual", degenerate="skip")
    E0, dE0 = tetlap.dirichlet_energy(V, T[:-1], f, "dual")
    assert E == E0 and np.array_equal(dE, dE0)


# ---------------------------------------------------------------- errors

@pytest.mark.parametrize("degenerate", ["raise", "skip"])
def test_products_that_overflow_are_an_error_never_dropped(degenerate):
    """A large f makes the energy overflow, not the tet: never skipped, always named."""
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=4)
    for f in (V[:, 0] * 1e155, np.where(np.arange(len(V)) == 13, 1e155, V[:, 0])):
        for energy, kind in ((tetlap.dirichlet_energy, "dual"), (tetlap.dirichlet_energy, "primal"),
                             (tetlap.mass_energy, "circumcentric")):
            with pytest.raises(tetlap.NonFiniteError, match="cotangents") as error:
                energy(V, T, f, kind, degenerate=degenerate)
            assert error.value.element >= 0
    # in range: the same f scaled down is computed, and skip drops nothing
    f = V[:, 0] * 1e150
    E, _ = tetlap.dirichlet_energy(V, T, f, "dual", degenerate=degenerate)
    L = tetlap.laplacian(V, T, "dual")
    assert E == pytest.approx(-f @ (L @ f), rel=1e-12)


def test_errors():
    V, T = tetlap.meshes.cube(2)
    n, m = len(V), len(T)
    f = np.ones(n)
    with pytest.raises(tetlap.ShapeError):
        tetlap.dirichlet_energy(V, T, f[1:])
    with pytest.raises(tetlap.ShapeError):
        tetlap.dirichlet_energy(V, T, np.ones((n, 2, 2)))
    with pytest.raises(tetlap.ShapeError):
        tetlap.vjp(V, T, dL=np.ones((m, 5)))
    with pytest.raises(tetlap.ShapeError):
        tetlap.vjp(V, T, dL=sp.eye_array(n + 1))
    with pytest.raises(tetlap.ShapeError):
        tetlap.vjp(V, T, dL=(np.array([[0, 1]]), np.ones(2)))
    with pytest.raises(tetlap.IndexRangeError, match=f"edge 0 refers to vertex {n}"):
        tetlap.vjp(V, T, dL=(np.array([[0, n]]), np.ones(1)))
    with pytest.raises(tetlap.DtypeError, match="integer vertex indices"):
        tetlap.vjp(V, T, dL=(np.array([[0.0, 1.0]]), np.ones(1)))
    with pytest.raises(tetlap.ShapeError):
        tetlap.vjp(V, T, mass="fem", dM=np.ones(n + 1))
    with pytest.raises(tetlap.DtypeError):
        tetlap.dirichlet_energy(V, T, np.array(["a"] * n))
    bad = f.copy()
    bad[2] = np.nan
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.dirichlet_energy(V, T, bad)
    with pytest.raises(tetlap.NonFiniteError):
        tetlap.vjp(V, T, mass="fem", dM=sp.diags_array(bad))
    with pytest.raises(tetlap.OptionError, match="barycentric"):
        tetlap.dirichlet_energy(V, T, f, "dual", boundary_centres="barycentric")
    with pytest.raises(tetlap.OptionError, match="barycentric"):
        tetlap.mass_energy(V, T, f, "circumcentric", boundary_centres="barycentric")
    # the primal and the barycentric mass do not use the boundary treatment: refused, as
    # the operators refuse it
    with pytest.raises(tetlap.OptionError, match="would ignore it"):
        tetlap.dirichlet_energy(V, T, f, "primal", boundary_centres="barycentric")
    with pytest.raises(tetlap.OptionError, match="would ignore it"):
        tetlap.mass_energy(V, T, f, "barycentric", boundary_centres="barycentric")
    with pytest.raises(tetlap.OptionError):
        tetlap.dirichlet_energy(V, T, f, "cotan")
    with pytest.raises(tetlap.OptionError):
        tetlap.dirichlet_energy(V, T, f, 1.5)
    with pytest.raises(tetlap.OptionError):
        tetlap.mass_energy(V, T, f, "lumped")
    with pytest.raises(tetlap.OptionError):
        tetlap.dirichlet_energy(V, T, f, threads=0)
    with pytest.raises(tetlap.ShapeError):
        tetlap.dirichlet_energy(V, [[0, 1, 2]], f)
    # the kinds are checked even without a cotangent
    with pytest.raises(tetlap.OptionError):
        tetlap.vjp(V, T, "cotan")
    with pytest.raises(tetlap.OptionError):
        tetlap.vjp(V, T, mass="lumped")
    # no cotangent at all: a zero gradient
    g = tetlap.vjp(V, T)
    assert g.value == 0 and not g.dV.any()


def test_docstring_examples_run():
    import doctest

    import tetlap.derivatives

    result = doctest.testmod(tetlap.derivatives, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 10 and result.failed == 0
