"""tetlap.regular.conditions: the face margins, affine in the vertex weights (the core's
regular_conditions)."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.diagnostics import interior_faces, non_delaunay_faces
from tetlap.regular import face_margins
from tetlap.regular.conditions import Conditions, _validated


def power_center(X, w):
    """Point with equal power |c - x|^2 - w to the 4 corners X (4, 3)."""
    A = 2 * (X[1:] - X[0])
    rhs = ((X[1:] - X[0]) ** 2).sum(axis=1) + w[0] - w[1:]
    return X[0] + np.linalg.solve(A, rhs)


def test_margin_is_the_signed_power_edge_over_the_face_size(rng):
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=3)
    w = rng.uniform(-0.01, 0.01, size=len(V))
    g = face_margins(V, T, w)
    tets, opposite = interior_faces(T)
    for f in rng.choice(len(g), size=20, replace=False):
        c1 = power_center(V[T[tets[f, 0]]], w[T[tets[f, 0]]])
        c2 = power_center(V[T[tets[f, 1]]], w[T[tets[f, 1]]])
        F = V[[k for k in T[tets[f, 0]] if k != opposite[f, 0]]]
        n = np.cross(F[1] - F[0], F[2] - F[0])
        n *= np.sign(n @ (V[opposite[f, 1]] - F[0])) / np.linalg.norm(n)
        rms = np.sqrt(((F - np.roll(F, 1, axis=0)) ** 2).sum(axis=1).mean())
        assert g[f] == pytest.approx((c2 - c1) @ n / rms, rel=1e-9, abs=1e-12)
        assert np.linalg.norm(np.cross(c2 - c1, n)) < 1e-9   # the dual edge is orthogonal


def test_margins_are_affine_vanish_for_a_flat_lifting_and_signal_delaunay(rng):
    V, T = tetlap.meshes.weighted_ball(500, 1.0, seed=1)
    g0 = face_margins(V, T)
    np.testing.assert_array_equal(g0 < 0, non_delaunay_faces(V, T))
    assert (g0 < 0).sum() > 20
    a, b = rng.normal(size=(2, len(V))) * 1e-3
    np.testing.assert_allclose(face_margins(V, T, a + b) - g0,
                               (face_margins(V, T, a) - g0) + (face_margins(V, T, b) - g0),
                               atol=1e-12)
    # w = |x|^2 lifts every point onto a hyperplane; affine weights change nothing
    np.testing.assert_allclose(face_margins(V, T, (V * V).sum(axis=1)), 0, atol=1e-12)
    np.testing.assert_allclose(face_margins(V, T, 1.0 + V @ [0.3, -0.2, 0.5]), g0, atol=1e-12)


def test_a_folded_face_has_two_rows_of_opposite_sign():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.1, 0.1, 0.2]], dtype=float)
    T = np.array([[0, 1, 2, 3], [4, 1, 2, 3]])
    cond = Conditions.of(*_validated(V, T))
    assert cond.n_faces == 1 and cond.folded.tolist() == [True] and cond.face.tolist() == [0, 0]
    for w in np.random.default_rng(0).normal(size=(5, 5)):
        rows = cond.margins(w)
        assert rows[0] * rows[1] < 0 and cond.per_face(rows)[0] == rows.min()


def test_tiny_and_huge_meshes_give_the_same_margins():
    V, T = tetlap.meshes.weighted_ball(200, 1.0, seed=2)
    g = face_margins(V, T)
    for s in (2.0 ** -500, 2.0 ** 500):
        np.testing.assert_array_equal(face_margins(s * V, T), g)


def test_bad_input():
    V, T = tetlap.meshes.ball(100, seed=0)
    with pytest.raises(tetlap.ShapeError):
        face_margins(V, T, np.zeros(3))
    with pytest.raises(tetlap.NonFiniteError):
        face_margins(V, T, np.full(len(V), np.nan))
    with pytest.raises(tetlap.ShapeError):
        face_margins(np.hstack([V, V[:, :1]]), T)
    flat = np.vstack([V, V[T[0, 0]]])         # exactly flat (a corner's copy)
    with pytest.raises(tetlap.DegenerateElementError, match=f"tet {len(T)} is flat") as e:
        face_margins(flat, np.vstack([T, [[T[0, 0], T[0, 1], T[0, 2], len(V)]]]))
    assert e.value.element == len(T)
