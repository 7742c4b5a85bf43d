"""The host side of the JAX and PyTorch adapters (:mod:`tetlap.jax`, :mod:`tetlap.torch`):
edge weights and lumped masses forward, their vector-Jacobian product backward, in NumPy
float64. Each adapter only wraps these two functions in its framework's autodiff.

A Laplacian and a mass are asked for with ``kind`` and ``mass_kind``; either may be None.
The outputs always have both parts (zeros for the one not asked), so that the frameworks
see fixed shapes: ``w`` (E,) on the edges of :func:`tetlap.edge_weights` and ``m`` (n,).
"""

from __future__ import annotations

import numpy as np

from . import assembly
from .derivatives import vjp
from .errors import OptionError

#: The masses the adapters give: lumped (a diagonal, one value per vertex).
LUMPED = ("barycentric", "circumcentric")


def check_mass(mass_kind) -> None:
    """OptionError unless ``mass_kind`` is None or a lumped mass."""
    if mass_kind is not None and mass_kind not in LUMPED:
        raise OptionError(f"the adapters give lumped masses: mass must be \"barycentric\" or "
                          f"\"circumcentric\", got {mass_kind!r}")


def upper(L) -> np.ndarray:
    """The strictly upper entries of a canonical CSR array, in CSR order: the weights of
    its edges ``i < j`` in sorted order."""
    rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
    return L.data[L.indices > rows]


def forward(V, T, kind, mass_kind, weights, n_edges: int, opts: dict):
    """``(w (E,), m (n,))`` float64 for float64 ``V`` (n, d) and validated ``T``."""
    n = V.shape[0]
    if kind is not None and mass_kind is not None:
        L, M = assembly.operators(V, T, kind, mass_kind, weights=weights, **opts)
    elif kind is not None:
        L, M = assembly.laplacian(V, T, kind, weights=weights, **opts), None
    else:
        L, M = None, assembly.mass(V, T, mass_kind, weights=weights, **opts)
    w = upper(L) if L is not None else np.zeros(n_edges)
    m = M.diagonal() if M is not None else np.zeros(n)
    return w, m


def backward(V, T, edges, kind, mass_kind, weights, dw, dm, opts: dict):
    """``(dV (n, d), dweights (n,))`` float64: the cotangents ``dw`` (E,) on the edge
    weights and ``dm`` (n,) on the masses pulled back by :func:`tetlap.vjp`."""
    g = vjp(V, T, kind if kind is not None else "primal",
            mass_kind if mass_kind is not None else "barycentric",
            dL=(edges, dw) if kind is not None else None,
            dM=dm if mass_kind is not None else None,
            weights=weights, **opts)
    dweights = g.dweights if g.dweights is not None else np.zeros(V.shape[0])
    return g.dV, dweights
