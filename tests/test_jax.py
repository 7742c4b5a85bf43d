"""The JAX adapter, and tetlap's gradients against jax.grad of an independent pure-JAX
implementation of both operators (1e-10 relative).

The pure-JAX reference follows the paper's definitions literally, not tetlap's formulas:
primal weights ``w_ab = -Vol grad(lambda_a) . grad(lambda_b)`` from the adjugate of the
edge matrix (P1 stiffness), and the dual from explicit (weighted) circumcenters of every
edge, face and tet (Gram systems solved by Cramer's rule), summing the signed volumes of the 24 flag pieces
``det[c_ab - x_a, c_abk - x_a, c_abkl - x_a] / 6`` times the tet's orientation sign
(SPEC section 2), ``w_ab = 3 (pieces at a and b around ab) / |ab|^2``. JAX differentiates
those with its own reverse mode.
"""

from __future__ import annotations

import numpy as np
import pytest

jax = pytest.importorskip("jax")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import tetlap  # noqa: E402
import tetlap.jax as tj  # noqa: E402

from test_derivatives import random_mesh  # noqa: E402

PAIRS = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
OPPOSITE = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)]


def dot(a, b):
    return jnp.sum(a * b, axis=-1)


def det3(a, b, c):
    """det[a, b, c] of rows (batched), by the rule of Sarrus."""
    return (a[..., 0] * (b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1])
            - a[..., 1] * (b[..., 0] * c[..., 2] - b[..., 2] * c[..., 0])
            + a[..., 2] * (b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0]))


def primal_weights(X):
    """(m, 6) primal weights of tets X (m, 4, 3): ``-Vol grad(lambda_a).grad(lambda_b)``,
    the gradients from the adjugate of the edge matrix (rows e_k = x_k - x_0)."""
    e1, e2, e3 = (X[:, k] - X[:, 0] for k in (1, 2, 3))
    det = det3(e1, e2, e3)
    g = [jnp.cross(e2, e3) / det[:, None], jnp.cross(e3, e1) / det[:, None],
         jnp.cross(e1, e2) / det[:, None]]
    grads = [-(g[0] + g[1] + g[2])] + g
    vol = jnp.abs(det) / 6
    return jnp.stack([-vol * dot(grads[a], grads[b]) for a, b in PAIRS], axis=1)


def power_center(P, w):
    """The point of the affine hull of the k = 2, 3 or 4 points P (..., k, 3) with equal
    power |c - p_i|^2 - w_i (w: (..., k)) to all: ``c = o + sum_i a_i e_i`` with the Gram
    system ``G a = r`` solved by Cramer's rule."""
    o = P[..., 0, :]
    E = [P[..., i, :] - o for i in range(1, P.shape[-2])]
    r = [(dot(e, e) + w[..., 0] - w[..., i + 1]) / 2 for i, e in enumerate(E)]
    G = [[dot(a, b) for b in E] for a in E]
    if len(E) == 1:
        coef = [r[0] / G[0][0]]
    elif len(E) == 2:
        d = G[0][0] * G[1][1] - G[0][1] * G[1][0]
        coef = [(r[0] * G[1][1] - G[0][1] * r[1]) / d, (G[0][0] * r[1] - r[0] * G[1][0]) / d]
    else:
        cols = [jnp.stack([G[i][j] for i in range(3)], axis=-1) for j in range(3)]
        rv = jnp.stack(r, axis=-1)
        d = det3(*cols)
        coef = [det3(*[rv if j == i else cols[j] for j in range(3)]) / d for i in range(3)]
    return o + sum(c[..., None] * e for c, e in zip(coef, E))


FACES = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]  # opposite corner l
A, B = np.array(PAIRS).T
K, L = np.array(OPPOSITE).T
# the flag (a, b, k; l) is oriented like the tet times the parity of (a, b, k, l)
PARITY = np.array([np.linalg.det(np.eye(4)[[a, b, k, l]]) for (a, b), (k, l) in zip(PAIRS, OPPOSITE)])
ONE_HOT_A, ONE_HOT_B = np.eye(4)[A], np.eye(4)[B]  # (6, 4)


def dual(X, W):
    """(m, 6) dual weights and (m, 4) cell volumes of tets X (m, 4, 3) with vertex
    weights W (m, 4), from explicit power centers of the 6 edges, 4 faces and the tet."""
    c = power_center(X, W)[:, None, :]  # (m, 1, 3)
    faces = power_center(X[:, FACES], W[:, FACES])  # (m, 4, 3)
    edges = power_center(X[:, PAIRS], W[:, PAIRS])  # (m, 6, 3)
    sign = jnp.sign(det3(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]))
    s = (sign[:, None] * PARITY / 6)  # (m, 6)
    xa, xb = X[:, A], X[:, B]

    def piece(x, face):  # det[c_ab - x, c_face - x, c - x]
        return det3(edges - x, faces[:, face] - x, c - x)

    pk_a, pk_b = s * piece(xa, L), -s * piece(xb, L)  # face abk: opposite l
    pl_a, pl_b = -s * piece(xa, K), s * piece(xb, K)
    weights = 3 * (pk_a + pk_b + pl_a + pl_b) / dot(xa - xb, xa - xb)
    cells = (pk_a + pl_a) @ ONE_HOT_A + (pk_b + pl_b) @ ONE_HOT_B
    return weights, cells


def reference_energy(V, omega, T, f, kind, mass):
    """-sum_c f_c^T L f_c + sum_c f_c^T M f_c with the pure-JAX kernels."""
    X = V[T]
    F = f[T]  # (m, 4, k)
    d2 = jnp.stack([jnp.sum((F[:, a] - F[:, b]) ** 2, axis=-1) for a, b in PAIRS], axis=1)
    s = {"primal": 0.0, "dual": 1.0}.get(kind, kind)
    w = 0.0
    if s != 1:
        w = w + (1 - s) * primal_weights(X)
    if s != 0 or mass == "circumcentric":
        wd, cells = dual(X, omega[T])
        w = w + s * wd
    e = jnp.sum(w * d2)
    if mass == "circumcentric":
        e = e + jnp.sum(cells * jnp.sum(F**2, axis=-1))
    elif mass == "barycentric":
        vol = jnp.abs(det3(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0])) / 6
        e = e + jnp.sum(vol[:, None] / 4 * jnp.sum(F**2, axis=-1))
    return e


def reference_grad(V, omega, T, f, kind, mass):
    """jax.grad of :func:`reference_energy` with respect to V and omega."""
    return jax.grad(reference_energy, argnums=(0, 1))(
        jnp.asarray(V), jnp.asarray(omega), T, jnp.asarray(f), kind, mass)


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


@pytest.mark.slow
def test_reference_matches_tetlap_forward():
    V, T = random_mesh(1, n=16)
    X = jnp.asarray(V[T])
    w = np.asarray(primal_weights(X))
    assert rel(tetlap.element_contributions(V, T, "primal"), w) < 1e-12
    wd, cells = dual(X, jnp.zeros((len(T), 4)))
    assert rel(tetlap.element_contributions(V, T, "dual"), wd) < 1e-12
    omega = np.random.default_rng(0).uniform(0, 0.02, size=len(V))
    wd, cells = dual(X, jnp.asarray(omega[T]))
    assert rel(tetlap.element_contributions(V, T, "dual", weights=omega), wd) < 1e-11
    m = np.zeros(len(V))
    np.add.at(m, T, np.asarray(cells))
    assert rel(tetlap.mass(V, T, "circumcentric", weights=omega).diagonal(), m) < 1e-11


@pytest.mark.slow
@pytest.mark.parametrize("kind,mass", [("primal", None), ("dual", None), (0.3, None),
                                       ("dual", "circumcentric"), ("primal", "barycentric")])
@pytest.mark.parametrize("seed", [1, 2])
def test_gradients_match_jax_grad_of_the_reference(kind, mass, seed):
    V, T = random_mesh(1, n=16)  # one mesh: JAX compiles its primitives once per shape
    f = np.random.default_rng(seed).normal(size=(len(V), 2))
    g_ref, _ = reference_grad(V, np.zeros(len(V)), T, f, kind, mass)
    _, g = tetlap.dirichlet_energy(V, T, f, kind)
    if mass is not None:
        g = g + tetlap.mass_energy(V, T, f, mass)[1]
    assert rel(g, g_ref) < 1e-10


@pytest.mark.slow
def test_weighted_gradients_match_jax_grad_of_the_reference():
    V, T = random_mesh(1, n=16)
    rng = np.random.default_rng(4)
    omega = rng.uniform(0, 0.03, size=len(V))
    f = rng.normal(size=(len(V), 2))
    gV, gw = reference_grad(V, omega, T, f, "dual", "circumcentric")
    _, dV, dw = tetlap.dirichlet_energy(V, T, f, "dual", weights=omega, return_weights_gradient=True)
    _, mV, mw = tetlap.mass_energy(V, T, f, "circumcentric", weights=omega,
                                   return_weights_gradient=True)
    assert rel(dV + mV, gV) < 1e-10
    assert rel(dw + mw, gw) < 1e-10


@pytest.mark.slow
def test_adapter_grad_jit_and_bcoo():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=5)
    E = tj.edges(T)
    assert np.array_equal(E, tetlap.edge_weights(V, T)[0])
    f = jnp.asarray(np.cos(V).sum(axis=1))

    def energy(V):
        w, m = tj.operators(V, T, "dual", "circumcentric")
        return jnp.sum(w * (f[E[:, 0]] - f[E[:, 1]]) ** 2) + jnp.sum(m * f**2)

    g = jax.grad(energy)(jnp.asarray(V))
    expected = (tetlap.dirichlet_energy(V, T, np.asarray(f), "dual")[1]
                + tetlap.mass_energy(V, T, np.asarray(f), "circumcentric")[1])
    assert rel(g, expected) < 1e-13
    assert rel(jax.jit(jax.grad(energy))(jnp.asarray(V)), expected) < 1e-13
    # the BCOO Laplacian, and a gradient through a sparse product
    L = tj.laplacian(V, T, "primal")
    assert np.allclose(L.todense(), tetlap.laplacian(V, T).toarray(), atol=1e-15)
    g = jax.grad(lambda V: -f @ (tj.laplacian(V, T, "primal") @ f))(jnp.asarray(V))
    assert rel(g, tetlap.dirichlet_energy(V, T, np.asarray(f))[1]) < 1e-12
    # masses alone, and the vertex weights
    omega = jnp.full(len(V), 1e-3)
    gw = jax.grad(lambda w: jnp.sum(tj.mass(V, T, "circumcentric", weights=w) * f**2))(omega)
    expected = tetlap.vjp(V, T, mass="circumcentric", dM=np.asarray(f**2), weights=np.asarray(omega))
    assert rel(gw, expected.dweights) < 1e-13
    with pytest.raises(tetlap.OptionError):
        tj.mass(V, T, "fem")
    with pytest.raises(tetlap.ShapeError, match=r"shape \(n, d\)"):
        tj.operators(V[0], T)
