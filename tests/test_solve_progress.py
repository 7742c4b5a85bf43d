"""The CG bar of tetlap.solve tells the truth: it measures the digits gained on the
relative residual towards the tolerance (full when CG converges), not iterations out of
the iteration cap (it stopped at a tenth of its length and looked dead)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import solve
from tetlap.solve import _amg


class Recorder:
    """A stand-in for tqdm that keeps what the bar was told."""

    made: list = []

    def __init__(self, total=None, **kwargs):
        self.total, self.n, self.postfix, self.closed = total, 0.0, "", False
        self.history: list[float] = []
        Recorder.made.append(self)

    def update(self, delta):
        self.n += delta
        self.history.append(self.n)

    def set_postfix_str(self, text, refresh=True):
        self.postfix = text

    def close(self):
        self.closed = True


def test_the_cg_bar_fills_up_as_the_residual_reaches_the_tolerance(monkeypatch):
    tqdm = pytest.importorskip("tqdm")
    monkeypatch.setattr(tqdm, "tqdm", Recorder)
    Recorder.made.clear()
    V, T = tetlap.meshes.ball(2000, seed=2)
    L = tetlap.laplacian(V, T)
    fixed = tetlap.diagnostics.boundary_vertices(V, T)
    _, info = solve.dirichlet(L, fixed, np.sin(3 * V[:, 0]), solver="amg", progress=True,
                              return_info=True)
    bar, = Recorder.made
    assert bar.total == pytest.approx(-np.log10(_amg.CG_RTOL))
    assert bar.n == pytest.approx(bar.total)             # converged: full
    assert (np.diff(bar.history) >= 0).all() and bar.history[0] < bar.total / 2
    assert bar.postfix == f"{info.iterations} iterations" and bar.closed
    assert 0 < info.iterations < _amg.CG_MAXITER / 4      # the cap would have shown < 25%
