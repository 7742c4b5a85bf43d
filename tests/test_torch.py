"""The PyTorch adapter: autograd through tetlap's operators equals tetlap's own gradients,
and torch.autograd.gradcheck (central differences) passes on a small mesh."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import tetlap  # noqa: E402
import tetlap.torch as tt  # noqa: E402


def test_backward_equals_tetlap_gradients():
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    E = torch.as_tensor(tt.edges(T))
    f = torch.as_tensor(np.sin(V).sum(axis=1))
    Vt = torch.tensor(V, requires_grad=True)
    w, m = tt.operators(Vt, T, "dual", "circumcentric")
    loss = (w * (f[E[:, 0]] - f[E[:, 1]]) ** 2).sum() + (m * f**2).sum()
    loss.backward()
    fn = f.numpy()
    expected = (tetlap.dirichlet_energy(V, T, fn, "dual")[1]
                + tetlap.mass_energy(V, T, fn, "circumcentric")[1])
    assert np.abs(Vt.grad.numpy() - expected).max() < 1e-13 * np.abs(expected).max()
    # the sparse Laplacian: -f^T L f
    Vt.grad = None
    L = tt.laplacian(Vt, T, "primal")
    assert np.allclose(L.to_dense().detach().numpy(), tetlap.laplacian(V, T).toarray(), atol=1e-15)
    (-(f @ torch.sparse.mm(L, f[:, None]))).sum().backward()
    expected = tetlap.dirichlet_energy(V, T, fn, "primal")[1]
    assert np.abs(Vt.grad.numpy() - expected).max() < 1e-12 * np.abs(expected).max()


def test_gradcheck_with_weights():
    V, T = tetlap.meshes.cube(1, jitter=0.0)
    V = V + np.random.default_rng(0).uniform(-0.1, 0.1, size=V.shape)
    Vt = torch.tensor(V, requires_grad=True)
    omega = torch.full((len(V),), 1e-3, dtype=torch.float64, requires_grad=True)

    def f(V, omega):
        return tt.operators(V, T, 0.5, "circumcentric", weights=omega)

    assert torch.autograd.gradcheck(f, (Vt, omega), eps=1e-6, atol=1e-8, rtol=1e-6)
    with pytest.raises(tetlap.OptionError):
        tt.mass(Vt, T, "fem")
    with pytest.raises(tetlap.ShapeError, match=r"shape \(n, d\)"):
        tt.operators(Vt[0], T)
