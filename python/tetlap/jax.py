"""JAX adapter: tetlap's operators as differentiable JAX functions (``jax.custom_vjp``).

``jax.grad`` (and ``jax.jit``, ``jax.value_and_grad``, ...) work through these functions
with respect to the vertex positions ``V`` and, for a weighted dual, the vertex weights.
The forward pass and the backward pass run in tetlap's Rust core through
``jax.pure_callback`` (on the host CPU); the backward pass is :func:`tetlap.vjp`.

The topology ``T`` and the options are static (plain NumPy values, not traced). Enable
float64 (``jax.config.update("jax_enable_x64", True)``) for tetlap's precision; with
float32 inputs the results are rounded to float32.

Needs ``jax`` (``pip install ".[jax]"``).

>>> import jax, jax.numpy as jnp, tetlap, tetlap.jax  # doctest: +SKIP
>>> jax.config.update("jax_enable_x64", True)  # doctest: +SKIP
>>> V, T = tetlap.meshes.cube(3, jitter=0.2)  # doctest: +SKIP
>>> E = tetlap.jax.edges(T)  # the order of the edge weights  # doctest: +SKIP
>>> f = jnp.asarray(V[:, 0] ** 2)  # doctest: +SKIP
>>> def energy(V):  # -f^T L f = sum_ij w_ij (f_i - f_j)^2  # doctest: +SKIP
...     w, m = tetlap.jax.operators(V, T, "dual", "circumcentric")
...     return jnp.sum(w * (f[E[:, 0]] - f[E[:, 1]]) ** 2) + jnp.sum(m)
>>> g = jax.grad(energy)(jnp.asarray(V))  # (n, 3), equal to tetlap's own gradient  # doctest: +SKIP
"""

from __future__ import annotations

import numpy as np

from . import _extras

try:
    import jax
    import jax.numpy as jnp
    from jax.experimental import sparse as jsparse
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(f"tetlap.jax needs jax: {_extras.hint('jax')}") from e

from . import _adapters
from ._options import renamed
from ._names import public_dir

__all__ = ["edges", "operators", "edge_weights", "mass", "laplacian"]
__dir__ = public_dir(globals())


def edges(T) -> np.ndarray:
    """The unique edges ``(E, 2)`` int64, ``i < j``, sorted: the order of the weights of
    :func:`operators` and :func:`edge_weights` (that of :func:`tetlap.edge_weights`)."""
    return _adapters.edges(T)


def _f64(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


def _function(spec: _adapters.Spec):
    """The custom_vjp function ``(V, omega) -> (w, m)`` of one mesh and option set."""

    def host_forward(V, omega):
        we, m = _adapters.forward(spec, _f64(V), _f64(omega) if spec.weighted else None)
        return we.astype(V.dtype), m.astype(V.dtype)

    def host_backward(V, omega, dw, dm):
        dV, dom = _adapters.backward(spec, _f64(V), _f64(omega) if spec.weighted else None,
                                     _f64(dw), _f64(dm))
        return dV.astype(np.asarray(V).dtype), dom.astype(np.asarray(omega).dtype)

    def shapes(V):
        return (jax.ShapeDtypeStruct((len(spec.edges),), V.dtype),
                jax.ShapeDtypeStruct((V.shape[0],), V.dtype))

    @jax.custom_vjp
    def f(V, omega):
        return jax.pure_callback(host_forward, shapes(V), V, omega)

    def f_fwd(V, omega):
        return f(V, omega), (V, omega)

    def f_bwd(residuals, cotangents):
        V, omega = residuals
        dw, dm = cotangents
        out = (jax.ShapeDtypeStruct(V.shape, V.dtype),
               jax.ShapeDtypeStruct(omega.shape, omega.dtype))
        return jax.pure_callback(host_backward, out, V, omega, dw, dm)

    f.defvjp(f_fwd, f_bwd)
    return f


def _call(V, T, kind, mass_kind, weights, boundary, degenerate, threads):
    V = jnp.asarray(V)
    _adapters.check_points(V.shape)
    spec = _adapters.spec(T, kind, mass_kind, weights is not None, boundary, degenerate,
                          threads)
    omega = (jnp.asarray(weights, dtype=V.dtype) if spec.weighted
             else jnp.zeros(V.shape[0], V.dtype))
    return _function(spec)(V, omega)


@renamed(boundary="boundary_centres")
def operators(V, T, kind="primal", mass="barycentric", *, weights=None,
              boundary_centres="circumcentric", degenerate="raise", threads=None):
    """Edge weights and lumped masses, differentiable with respect to ``V`` and
    ``weights``.

    Parameters
    ----------
    V : (n, d) JAX or NumPy array (traced or not)
    T : (m, 4) integer NumPy array (static)
    kind : {"primal", "dual"} or float t in [0, 1]
        The Laplacian, as for :func:`tetlap.laplacian`.
    mass : {"barycentric", "circumcentric"}
        A lumped mass, as for :func:`tetlap.mass`.
    weights : (n,) array, optional
        Vertex weights of a weighted dual (differentiable).
    boundary_centres, degenerate, threads
        As for :func:`tetlap.laplacian` (``boundary_centres`` was ``boundary`` until 0.1;
        that name still works, deprecated).

    Returns
    -------
    w : (E,) array
        ``w[e] = L[i, j]`` for the edges ``(i, j)`` of :func:`edges` (the same order).
    m : (n,) array
        The diagonal of ``M``.
    """
    return _call(V, T, kind, mass, weights, boundary_centres, degenerate, threads)


@renamed(boundary="boundary_centres")
def edge_weights(V, T, kind="primal", *, weights=None, boundary_centres="circumcentric",
                 degenerate="raise", threads=None):
    """The summed edge weights ``(E,)`` on the edges of :func:`edges` (differentiable)."""
    return _call(V, T, kind, None, weights, boundary_centres, degenerate, threads)[0]


@renamed(boundary="boundary_centres")
def mass(V, T, kind="barycentric", *, weights=None, boundary_centres="circumcentric",
         degenerate="raise", threads=None):
    """The lumped mass diagonal ``(n,)`` (differentiable)."""
    return _call(V, T, None, kind, weights, boundary_centres, degenerate, threads)[1]


@renamed(boundary="boundary_centres")
def laplacian(V, T, kind="primal", *, weights=None, boundary_centres="circumcentric",
              degenerate="raise", threads=None):
    """The Laplacian as a ``jax.experimental.sparse.BCOO`` (n, n) matrix (differentiable
    in its values): ``L[i, j] = w_ij``, ``L[i, i] = -sum_j w_ij``, paper Eq. 1.

    Entries: the edges ``(i, j)`` of :func:`edges`, then ``(j, i)``, then the diagonal.
    """
    V = jnp.asarray(V)
    n = V.shape[0]
    E = edges(T)
    w = edge_weights(V, T, kind, weights=weights, boundary_centres=boundary_centres,
                     degenerate=degenerate, threads=threads)
    diag = -(jax.ops.segment_sum(w, E[:, 0], n) + jax.ops.segment_sum(w, E[:, 1], n))
    entries = _adapters.laplacian_entries(E, n)
    return jsparse.BCOO((jnp.concatenate([w, w, diag]), jnp.asarray(entries)), shape=(n, n))
