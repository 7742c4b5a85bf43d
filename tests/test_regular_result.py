"""tetlap.regular.result (RegularWeights) and tetlap.info.regular_summary (what tetlap
info prints of it)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tetlap
from tetlap.info import regular_summary
from tetlap.regular import STATUSES, regular_weights

from test_regular_examples import mother


def test_the_result_reads_as_json_and_as_text():
    for V, T in (tetlap.meshes.weighted_ball(300, 1.0, seed=0), mother(0.0)):
        r = regular_weights(V, T)
        d = json.loads(json.dumps(r.to_dict()))
        assert d["status"] == r.status in STATUSES and d["regular"] == r.regular
        assert d["n_certificate_faces"] == len(r.certificate_faces)
        assert "weights" not in d and d["verification"] == r.verification != ""
        text = str(r)
        assert text.startswith("regular: " + {"regular": "yes", "not regular": "NO (proved)"}[
            r.status])
        assert ("certificate (gordan)" in text) == (r.certificate_kind == "gordan")


@pytest.mark.slow
def test_summary_counts():
    V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    s = regular_summary(V, T, nsd=True)
    assert s["regular"] is True and s["status"] == "regular"
    neg = s["negative_interior_weights"]
    assert neg["weighted_dual"] == 0 < neg["dual"]
    assert s["nsd"]["primal"] and s["linear_precision_weighted_dual"]


def dense_semidefinite(L) -> bool:
    """Whether ``-L`` is positive semidefinite under check's tolerance (1e-9 of each row's
    diagonal), by dense eigenvalues of the Jacobi-scaled matrix: independent of the
    certificates."""
    S = -(L + L.T).toarray() / 2
    d = np.abs(np.diag(S))
    live = d > 0
    s = 1 / np.sqrt(d[live])
    return bool(np.linalg.eigvalsh(S[np.ix_(live, live)] * s[:, None] * s[None, :])[0] >= -1e-9)


@pytest.mark.parametrize("case", ["bare", "masses", "not regular"])
def test_the_three_guarantees_are_checked_and_lead_the_summary(case):
    # issue 31: "regular: yes" read as safe while 189 control volumes were lost and the
    # weighted dual was indefinite; each guarantee is now stated, and compared here with a
    # check of its own
    if case == "not regular":
        V, T = mother(0.0)
        r = regular_weights(V, T)
    else:
        V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
        r = regular_weights(V, T, mass_floor=None if case == "bare" else 0.1)
    answer = {True: "yes", False: "no"}
    L, M = tetlap.operators(V, T, "dual", "circumcentric", weights=r.weights)
    m0 = tetlap.mass(V, T, "circumcentric").diagonal()
    assert r.nonnegative_interior == answer[tetlap.check(L, V, T, nsd=False)
                                           .n_negative_interior == 0]
    assert r.positive_masses == answer[bool(((M.diagonal() > 0) | (m0 <= 0)).all())]
    assert r.semidefinite == answer[dense_semidefinite(L)]
    assert r.guarantees == {"nonnegative_interior": r.nonnegative_interior,
                            "positive_masses": r.positive_masses,
                            "semidefinite": r.semidefinite}
    first = str(r).splitlines()[0]
    shout = {"yes": "yes", "no": "NO"}
    for label, value in (("interior weights >= 0", r.nonnegative_interior),
                         ("control volumes > 0 where the plain dual's are", r.positive_masses),
                         ("semidefinite", r.semidefinite)):
        assert f"{label}: {shout[value]}" in first
    expected = {"bare": ("regular", "no"), "masses": ("regular", "yes"),
                "not regular": ("not regular", None)}[case]
    assert r.status == expected[0]
    if expected[1] is not None:
        assert r.positive_masses == expected[1] and r.nonnegative_interior == "yes"
    assert json.loads(json.dumps(r.to_dict()))["guarantees"] == r.guarantees


def test_an_undecided_semidefiniteness_reads_not_checked(monkeypatch):
    from tetlap import analysis

    monkeypatch.setattr(analysis, "_nsd", lambda *a, **k: (None, None, "undetermined: test"))
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
    r = regular_weights(V, T)
    assert r.semidefinite == "not checked" and r.semidefinite_method == "undetermined: test"
    assert "semidefinite: not checked" in str(r).splitlines()[0]


def test_past_the_time_limit_semidefiniteness_is_not_checked():
    V, T = tetlap.meshes.weighted_ball(300, 1.0, seed=0)
    r = regular_weights(V, T, time_limit=1e-9)
    assert r.status == "undecided" and r.semidefinite == "not checked"
    assert "time limit" in r.semidefinite_method
    assert r.positive_masses in ("yes", "no") and r.nonnegative_interior in ("yes", "no")
