"""The host side of the JAX and PyTorch adapters (:mod:`tetlap.jax`, :mod:`tetlap.torch`):
what they fix per mesh (:class:`Spec`), edge weights and lumped masses forward, their
vector-Jacobian product backward, in NumPy float64, and the entries of their sparse
Laplacians. Each adapter only wraps these in its framework's arrays and autodiff.

A Laplacian and a mass are asked for with ``kind`` and ``mass_kind``; either may be None.
The outputs always have both parts (zeros for the one not asked), so that the frameworks
see fixed shapes: ``w`` (E,) on the edges of :func:`tetlap.edge_weights` and ``m`` (n,).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import _arrays, assembly, diagnostics
from .assembly import _options
from .derivatives import vjp
from .errors import OptionError, ShapeError

#: The masses the adapters give: lumped (a diagonal, one value per vertex).
LUMPED = ("barycentric", "circumcentric")


class Spec(NamedTuple):
    """What an adapter keeps fixed (static) for one call: the validated tets ``T`` (m, 4)
    int64, their ``edges`` (E, 2) (:func:`edges`), the Laplacian ``kind`` and the
    ``mass_kind`` (either None), whether vertex weights are given (``weighted``) and the
    assembly ``options``."""

    T: np.ndarray
    edges: np.ndarray
    kind: object
    mass_kind: str | None
    weighted: bool
    options: dict


def spec(T, kind, mass_kind, weighted: bool, boundary, degenerate, threads) -> Spec:
    """The :class:`Spec` of a call; OptionError unless ``mass_kind`` is None or lumped."""
    if mass_kind is not None and mass_kind not in LUMPED:
        raise OptionError(f"the adapters give lumped masses: mass must be \"barycentric\" or "
                          f"\"circumcentric\", got {mass_kind!r}")
    T = _arrays.elements(T, 4)
    return Spec(T, diagnostics.mesh_edges(T), kind, mass_kind, weighted,
                _options(boundary, degenerate, threads))


def edges(T) -> np.ndarray:
    """The unique edges ``(E, 2)`` int64, ``i < j``, sorted, of the tets ``T``."""
    return diagnostics.mesh_edges(_arrays.elements(T, 4))


def check_points(shape) -> None:
    """ShapeError unless a framework array of ``shape`` can hold vertex positions."""
    if len(shape) != 2:
        raise ShapeError(f"V must have shape (n, d), got {tuple(shape)}")


def upper(L) -> np.ndarray:
    """The strictly upper entries of a canonical CSR array, in CSR order: the weights of
    its edges ``i < j`` in sorted order."""
    rows = np.repeat(np.arange(L.shape[0]), np.diff(L.indptr))
    return L.data[L.indices > rows]


def forward(s: Spec, V: np.ndarray, weights: np.ndarray | None):
    """``(w (E,), m (n,))`` float64 for float64 positions ``V`` (n, d)."""
    n = V.shape[0]
    opts = {"boundary_centres": s.options["boundary"], "degenerate": s.options["degenerate"],
            "threads": s.options["threads"]}      # the core's options, as keywords
    if s.kind is not None and s.mass_kind is not None:
        L, M = assembly.operators(V, s.T, s.kind, s.mass_kind, weights=weights, **opts)
    elif s.kind is not None:
        L, M = assembly.laplacian(V, s.T, s.kind, weights=weights, **opts), None
    else:
        L, M = None, assembly.mass(V, s.T, s.mass_kind, weights=weights, **opts)
    w = upper(L) if L is not None else np.zeros(len(s.edges))
    m = M.diagonal() if M is not None else np.zeros(n)
    return w, m


def backward(s: Spec, V: np.ndarray, weights: np.ndarray | None, dw: np.ndarray,
             dm: np.ndarray):
    """``(dV (n, d), dweights (n,))`` float64: the cotangents ``dw`` (E,) on the edge
    weights and ``dm`` (n,) on the masses pulled back by :func:`tetlap.vjp`."""
    g = vjp(V, s.T, s.kind if s.kind is not None else "primal",
            s.mass_kind if s.mass_kind is not None else "barycentric",
            dL=(s.edges, dw) if s.kind is not None else None,
            dM=dm if s.mass_kind is not None else None,
            weights=weights, **s.options)
    dweights = g.dweights if g.dweights is not None else np.zeros(V.shape[0])
    return g.dV, dweights


def laplacian_entries(edges: np.ndarray, n: int) -> np.ndarray:
    """The ``(2 E + n, 2)`` int64 (row, column) pairs of an adapter's sparse Laplacian:
    the edges ``(i, j)``, then ``(j, i)``, then the diagonal; its values are ``w``, ``w``
    and ``-sum_j w_ij`` (paper Eq. 1)."""
    diagonal = np.arange(n)
    return np.concatenate([edges, edges[:, ::-1], np.column_stack([diagonal, diagonal])])
