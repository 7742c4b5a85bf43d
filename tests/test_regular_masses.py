"""tetlap.regular.masses: the mass step (the core's regular_masses)."""

from __future__ import annotations

import numpy as np

import tetlap
from tetlap.regular import face_margins, masses, regular_weights


def test_masses_are_cubic_along_a_segment_of_weights(rng):
    # what the mass step's line search relies on: power centres are affine in w
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=5)
    w0, w1 = (rng.uniform(-0.005, 0.005, size=len(V)) for _ in range(2))
    ts = np.array([0, 1 / 3, 2 / 3, 1])
    M = np.stack([masses.circumcentric_masses(V, T, w0 + t * (w1 - w0)) for t in ts])
    C = np.linalg.solve(np.vander(ts, 4, increasing=True), M)
    for t in (0.1, 0.5, 0.9):
        np.testing.assert_allclose(np.vander([t], 4, increasing=True)[0] @ C,
                                   masses.circumcentric_masses(V, T, w0 + t * (w1 - w0)),
                                   rtol=0, atol=1e-12 * np.abs(M).max())


def test_the_mass_step_keeps_more_masses_and_the_faces_regular():
    for n, scale, seed in ((400, 1.0, 0), (1000, 0.3, 1), (600, 1.0, 3)):
        V, T = tetlap.meshes.weighted_ball(n, scale, seed=seed)
        bare, r = regular_weights(V, T, mass_floor=None), regular_weights(V, T)
        assert r.regular and bare.regular
        assert len(r.masses_lost) < len(bare.masses_lost)
        assert face_margins(V, T, r.weights).min() > 0
        # the faces keep at least half the floor the search reached (repaired faces)
        repaired = face_margins(V, T) < 0
        assert face_margins(V, T, r.weights)[repaired].min() >= r.margin_floor / 2 * (1 - 1e-9)
        assert r.mass_rounds > 0 and r.iterations > bare.iterations


def test_circumcentric_masses_are_the_operators():
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=5)
    w = np.linspace(0, 1e-3, len(V))
    np.testing.assert_array_equal(masses.circumcentric_masses(V, T, w),
                                  tetlap.mass(V, T, "circumcentric", weights=w).diagonal())
