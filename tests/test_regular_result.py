"""tetlap.regular.result (RegularWeights) and tetlap.info.regular_summary (what tetlap
info prints of it)."""

from __future__ import annotations

import json

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
