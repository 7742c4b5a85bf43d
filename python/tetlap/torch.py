"""PyTorch adapter: tetlap's operators as a differentiable ``torch.autograd.Function``.

``loss.backward()`` flows through :func:`operators` into the vertex positions ``V`` (and
the vertex weights of a weighted dual). Forward and backward run in tetlap's Rust core on
the CPU (tensors on another device are copied to the host and back); the backward pass is
:func:`tetlap.vjp`. ``T`` and the options are static. Use float64 tensors for tetlap's
precision (float32 inputs give float32 results).

Needs ``torch`` (``pip install 'tetlap[torch]'``).

>>> import torch, tetlap, tetlap.torch  # doctest: +SKIP
>>> V, T = tetlap.meshes.cube(3, jitter=0.2)  # doctest: +SKIP
>>> E = torch.as_tensor(tetlap.torch.edges(T))  # doctest: +SKIP
>>> Vt = torch.tensor(V, requires_grad=True)  # doctest: +SKIP
>>> w, m = tetlap.torch.operators(Vt, T, "dual", "circumcentric")  # doctest: +SKIP
>>> f = Vt[:, 0].detach() ** 2  # doctest: +SKIP
>>> (w * (f[E[:, 0]] - f[E[:, 1]]) ** 2).sum().backward()  # doctest: +SKIP
>>> Vt.grad.shape  # doctest: +SKIP
torch.Size([64, 3])
"""

from __future__ import annotations

import numpy as np

try:
    import torch
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError("tetlap.torch needs torch: pip install 'tetlap[torch]'") from e

from . import _arrays, assembly, diagnostics
from .derivatives import vjp
from .errors import OptionError

__all__ = ["edges", "operators", "edge_weights", "mass", "laplacian"]

_LUMPED = ("barycentric", "circumcentric")


def edges(T) -> np.ndarray:
    """The unique edges ``(E, 2)`` int64, ``i < j``, sorted: the order of the weights of
    :func:`operators` (that of :func:`tetlap.edge_weights`)."""
    return diagnostics.mesh_edges(_arrays.elements(T, 4))


def _numpy(x: torch.Tensor) -> np.ndarray:
    return x.detach().cpu().numpy().astype(np.float64)


class _Operators(torch.autograd.Function):
    """``(V, omega) -> (w, m)`` for a fixed mesh and options (in ``spec``)."""

    @staticmethod
    def forward(ctx, V, omega, spec):
        T, kind, mass_kind, weighted, opts = spec
        V64 = _numpy(V)
        w = _numpy(omega) if weighted else None
        n = V64.shape[0]
        if kind is not None and mass_kind is not None:
            L, M = assembly.operators(V64, T, kind, mass_kind, weights=w, **opts)
        elif kind is not None:
            L, M = assembly.laplacian(V64, T, kind, weights=w, **opts), None
        else:
            L, M = None, assembly.mass(V64, T, mass_kind, weights=w, **opts)
        if L is not None:
            rows = np.repeat(np.arange(n), np.diff(L.indptr))
            we = L.data[L.indices > rows]
        else:
            we = np.zeros(len(diagnostics.mesh_edges(T)))
        m = M.diagonal() if M is not None else np.zeros(n)
        ctx.save_for_backward(V, omega)
        ctx.spec = spec
        as_out = {"dtype": V.dtype, "device": V.device}
        return torch.as_tensor(we, **as_out), torch.as_tensor(m, **as_out)

    @staticmethod
    def backward(ctx, dw, dm):
        V, omega = ctx.saved_tensors
        T, kind, mass_kind, weighted, opts = ctx.spec
        E = diagnostics.mesh_edges(T)
        g = vjp(_numpy(V), T, kind if kind is not None else "primal",
                mass_kind if mass_kind is not None else "barycentric",
                dL=(E, _numpy(dw)) if kind is not None else None,
                dM=_numpy(dm) if mass_kind is not None else None,
                weights=_numpy(omega) if weighted else None, **opts)
        dV = torch.as_tensor(g.dV, dtype=V.dtype, device=V.device)
        dom = g.dweights if g.dweights is not None else np.zeros(V.shape[0])
        domega = torch.as_tensor(dom, dtype=omega.dtype, device=omega.device)
        return dV, (domega if weighted else None), None


def _call(V, T, kind, mass_kind, weights, boundary, degenerate, threads):
    if mass_kind is not None and mass_kind not in _LUMPED:
        raise OptionError(f"the adapters give lumped masses: mass must be \"barycentric\" or "
                          f"\"circumcentric\", got {mass_kind!r}")
    V = torch.as_tensor(V)
    if V.ndim != 2:
        raise OptionError(f"V must have shape (n, d), got {tuple(V.shape)}")
    weighted = weights is not None
    omega = (torch.as_tensor(weights, dtype=V.dtype, device=V.device) if weighted
             else torch.zeros(V.shape[0], dtype=V.dtype, device=V.device))
    opts = {"boundary": boundary, "degenerate": degenerate, "threads": threads}
    spec = (_arrays.elements(T, 4), kind, mass_kind, weighted, opts)
    return _Operators.apply(V, omega, spec)


def operators(V, T, kind="primal", mass="barycentric", *, weights=None,
              boundary="circumcentric", degenerate="raise", threads=None):
    """Edge weights ``w`` (E,) on the edges of :func:`edges` and the lumped mass
    diagonal ``m`` (n,), differentiable with respect to ``V`` (n, d) and ``weights``
    (n,); see :func:`tetlap.jax.operators` for the parameters."""
    return _call(V, T, kind, mass, weights, boundary, degenerate, threads)


def edge_weights(V, T, kind="primal", *, weights=None, boundary="circumcentric",
                 degenerate="raise", threads=None):
    """The summed edge weights ``(E,)`` on the edges of :func:`edges` (differentiable)."""
    return _call(V, T, kind, None, weights, boundary, degenerate, threads)[0]


def mass(V, T, kind="barycentric", *, weights=None, boundary="circumcentric",
         degenerate="raise", threads=None):
    """The lumped mass diagonal ``(n,)`` (differentiable)."""
    return _call(V, T, None, kind, weights, boundary, degenerate, threads)[1]


def laplacian(V, T, kind="primal", *, weights=None, boundary="circumcentric",
              degenerate="raise", threads=None):
    """The Laplacian as a sparse COO ``torch`` tensor (n, n), differentiable in its values:
    ``L[i, j] = w_ij``, ``L[i, i] = -sum_j w_ij`` (paper Eq. 1)."""
    V = torch.as_tensor(V)
    n = V.shape[0]
    E = torch.as_tensor(edges(T))
    w = edge_weights(V, T, kind, weights=weights, boundary=boundary, degenerate=degenerate,
                     threads=threads)
    diag = -(torch.zeros(n, dtype=w.dtype).index_add(0, E[:, 0], w).index_add(0, E[:, 1], w))
    ii = torch.arange(n)
    idx = torch.cat([E.T, E.flip(1).T, torch.stack([ii, ii])], dim=1)
    # the indices come from validated tets: in range by construction
    return torch.sparse_coo_tensor(idx, torch.cat([w, w, diag]), (n, n), check_invariants=False)
