"""tetlap.regular.verify: the checks of regular_weights' answers, independent of its search
(float64 lifted determinants against their permanents, exact rationals near 0, exact
Gordan certificates, folded and non-manifold faces)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

import tetlap
from tetlap.regular import face_margins, regular_weights, verify
from tetlap.regular.conditions import Conditions, _validated

from test_regular_examples import mother, three_on_a_face, twisted_prism


def mesh(V, T):
    V, T = _validated(V, T)
    return V, T, Conditions.of(V, T)


def test_the_float_test_agrees_with_exact_signs_and_defers_near_zero(rng):
    V, T, cond = mesh(*tetlap.meshes.weighted_ball(300, 1.0, seed=3))
    for w in (np.zeros(len(V)), rng.uniform(-0.01, 0.01, size=len(V))):
        check = verify.check_margins(V, T, cond.interior, w)
        g = cond.per_face(cond.margins(w))
        sure = np.abs(g) > 1e-9
        np.testing.assert_array_equal(check.sign[sure], np.sign(g[sure]))
        # a sample against the exact sign, from both tets
        for f in rng.choice(cond.n_faces, size=10, replace=False):
            t1, c1, t2, c2 = cond.interior[f]
            exact = min(verify._exact_sign(V, w, T[t1], T[t2, c2]),
                        verify._exact_sign(V, w, T[t2], T[t1, c1]))
            assert exact == check.sign[f]


def test_cospherical_faces_are_zero_exactly_and_not_a_proof():
    V, T, cond = mesh(*mother(0.0))
    zero = np.zeros(len(V))
    loose = verify.check_margins(V, T, cond.interior, zero, exact=False)
    exact = verify.check_margins(V, T, cond.interior, zero)
    assert (loose.sign == 0).sum() == 3 and exact.exact == 6      # 3 faces, 2 views each
    assert (exact.sign == 0).sum() == 3 and not exact.proved


def test_gordan_certificates_are_checked_exactly():
    for V, T in (mother(0.0), mother(0.1), twisted_prism(0.3)):
        V, T, cond = mesh(V, T)
        r = regular_weights(V, T)
        assert r.certificate_kind == "gordan"
        key = {tuple(sorted(t)): f for f, t in enumerate(cond.triangles.tolist())}
        faces = np.array([key[tuple(sorted(t))] for t in r.certificate_faces.tolist()])
        rows = faces           # non-folded: row f is face f
        check = verify.check_certificate(V, T, cond.interior, faces, r.certificate_multipliers,
                                         cond.vertices[rows], cond.coefficients[rows])
        assert check is not None and (check.multipliers > 0).all()
        # the identity in exact arithmetic, through the integer rows
        integer = [verify._integer_row(V, T, cond.interior[f])[0] for f in faces]
        z = verify._positive_null_vector(integer, [Fraction(1)] * len(faces))
        total: dict[int, Fraction] = {}
        for zf, row in zip(z, integer):
            for v, a in row.items():
                total[v] = total.get(v, Fraction(0)) + zf * a
        assert all(value == 0 for value in total.values())
        # a face fewer is no certificate
        assert verify.check_certificate(V, T, cond.interior, faces[1:],
                                        r.certificate_multipliers[1:], cond.vertices[rows[1:]],
                                        cond.coefficients[rows[1:]]) is None


def test_faces_of_a_regular_mesh_carry_no_certificate():
    V, T, cond = mesh(*twisted_prism(-0.3))
    faces = np.arange(cond.n_faces)
    assert verify.check_certificate(V, T, cond.interior, faces, np.ones(len(faces)),
                                    cond.vertices[faces], cond.coefficients[faces]) is None


def test_folded_and_nonmanifold_faces_are_checked_on_the_mesh():
    V, T = three_on_a_face()
    overlapping = T[[0, 2]]
    _, _, cond = mesh(V, overlapping)
    assert cond.folded.all() and verify.check_folded(V, overlapping, cond.interior, [0])
    _, _, cond = mesh(V, T[[0, 1]])
    assert not cond.folded.any() and not verify.check_folded(V, T[[0, 1]], cond.interior, [0])
    assert verify.check_nonmanifold(T, [[0, 1, 2]])
    assert not verify.check_nonmanifold(T, [[0, 1, 3]])


def test_weights_that_repair_a_mesh_pass_and_small_errors_fail():
    V, T, cond = mesh(*tetlap.meshes.weighted_ball(400, 1.0, seed=0))
    r = regular_weights(V, T, mass_floor=None)
    assert verify.check_margins(V, T, cond.interior, r.weights).proved
    assert face_margins(V, T, r.weights).min() > 0
    # pull one repaired face below 0: the check fails on it
    worst = int(np.argmin(face_margins(V, T, r.weights)))
    f = cond.triangles[worst]
    w = r.weights.copy()
    w[f] -= 10 * np.abs(r.weights).max()
    check = verify.check_margins(V, T, cond.interior, w)
    assert not check.proved and worst in check.failed
