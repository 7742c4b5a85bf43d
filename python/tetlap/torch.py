"""PyTorch adapter: tetlap's operators as a differentiable ``torch.autograd.Function``.

``loss.backward()`` flows through :func:`operators` into the vertex positions ``V`` (and
the vertex weights of a weighted dual). Forward and backward run in tetlap's Rust core on
the CPU (tensors on another device are copied to the host and back); the backward pass is
:func:`tetlap.vjp`. ``T`` and the options are static. Use float64 tensors for tetlap's
precision (float32 inputs give float32 results).

Needs ``torch`` (``pip install ".[torch]"``).

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

from . import _extras

try:
    import torch
except ImportError as e:  # pragma: no cover - exercised only without the extra
    raise ImportError(f"tetlap.torch needs torch: {_extras.hint('torch')}") from e

from . import _adapters
from ._options import renamed
from ._names import public_dir

__all__ = ["edges", "operators", "edge_weights", "mass", "laplacian"]
__dir__ = public_dir(globals())


def edges(T) -> np.ndarray:
    """The unique edges ``(E, 2)`` int64, ``i < j``, sorted: the order of the weights of
    :func:`operators` (that of :func:`tetlap.edge_weights`)."""
    return _adapters.edges(T)


def _numpy(x: torch.Tensor) -> np.ndarray:
    return x.detach().cpu().numpy().astype(np.float64)


class _Operators(torch.autograd.Function):
    """``(V, omega) -> (w, m)`` for a fixed mesh and options (an :class:`_adapters.Spec`)."""

    @staticmethod
    def forward(ctx, V, omega, spec):
        we, m = _adapters.forward(spec, _numpy(V), _numpy(omega) if spec.weighted else None)
        ctx.save_for_backward(V, omega)
        ctx.spec = spec
        as_out = {"dtype": V.dtype, "device": V.device}
        return torch.as_tensor(we, **as_out), torch.as_tensor(m, **as_out)

    @staticmethod
    def backward(ctx, dw, dm):
        V, omega = ctx.saved_tensors
        spec = ctx.spec
        dV, dom = _adapters.backward(spec, _numpy(V), _numpy(omega) if spec.weighted else None,
                                     _numpy(dw), _numpy(dm))
        dV = torch.as_tensor(dV, dtype=V.dtype, device=V.device)
        domega = torch.as_tensor(dom, dtype=omega.dtype, device=omega.device)
        return dV, (domega if spec.weighted else None), None


def _call(V, T, kind, mass_kind, weights, boundary, degenerate, threads):
    V = torch.as_tensor(V)
    _adapters.check_points(V.shape)
    spec = _adapters.spec(T, kind, mass_kind, weights is not None, boundary, degenerate,
                          threads)
    omega = (torch.as_tensor(weights, dtype=V.dtype, device=V.device) if spec.weighted
             else torch.zeros(V.shape[0], dtype=V.dtype, device=V.device))
    return _Operators.apply(V, omega, spec)


@renamed(boundary="boundary_centres")
def operators(V, T, kind="primal", mass="barycentric", *, weights=None,
              boundary_centres="circumcentric", degenerate="raise", threads=None):
    """Edge weights ``w`` (E,) on the edges of :func:`edges` and the lumped mass
    diagonal ``m`` (n,), differentiable with respect to ``V`` (n, d) and ``weights``
    (n,); see :func:`tetlap.jax.operators` for the parameters."""
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
    """The Laplacian as a sparse COO ``torch`` tensor (n, n), differentiable in its values:
    ``L[i, j] = w_ij``, ``L[i, i] = -sum_j w_ij`` (paper Eq. 1)."""
    V = torch.as_tensor(V)
    n = V.shape[0]
    E_host = edges(T)
    E = torch.as_tensor(E_host)
    w = edge_weights(V, T, kind, weights=weights, boundary_centres=boundary_centres,
                     degenerate=degenerate, threads=threads)
    diag = -(torch.zeros(n, dtype=w.dtype).index_add(0, E[:, 0], w).index_add(0, E[:, 1], w))
    entries = torch.as_tensor(np.ascontiguousarray(_adapters.laplacian_entries(E_host, n).T))
    # the indices come from validated tets: in range by construction
    return torch.sparse_coo_tensor(entries, torch.cat([w, w, diag]), (n, n),
                                   check_invariants=False)
