"""Needles in tetlap.regular (issue 30 item 1): a tet is refused only when exactly flat, so a
needle next to an interior face gets its true margin row (computed exactly where float64
cannot prove it accurate) and a proved answer, without NumPy warnings."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

import tetlap
from tetlap.regular import face_margins, regular_weights

BASE = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])


def needle(apex: float, below: bool = False):
    """Two tets on the face (0, 1, 2): apexes at height -1 and ``apex`` above the point
    (0.3, 0.3), or mirrored (``below``). The face's margin is the distance of the power
    centres, ``(h - 0.42 / h) / 2 + 0.29``, over the RMS edge ``2 / sqrt(3)``."""
    z = np.array([-1.0, apex]) * (-1 if below else 1)
    V = np.vstack([BASE, [[0.3, 0.3, z[0]], [0.3, 0.3, z[1]]]])
    return V, np.array([[0, 1, 2, 3], [0, 1, 2, 4]])


def relabelled(V, T, order, corners):
    """The same mesh with vertex ``i`` renamed ``order[i]`` and every tet's corners in the
    order ``corners``."""
    W = np.empty_like(V)
    W[list(order)] = V
    return W, np.asarray(order)[T][:, list(corners)]


APEXES = [1e14, 1e16, 1e20, 1e50]
ORDERS = [((0, 1, 2, 3, 4), (0, 1, 2, 3)), ((4, 2, 0, 3, 1), (3, 1, 0, 2)),
          ((1, 3, 4, 0, 2), (2, 3, 1, 0))]


@pytest.mark.parametrize("apex", APEXES + [1e150, 1e300])
@pytest.mark.parametrize("below", [False, True])
def test_the_margin_of_a_needle_is_its_exact_power_edge(apex, below):
    expected = ((apex - 0.42 / apex) / 2 + 0.29) * np.sqrt(3) / 2
    for order, corners in ORDERS:
        V, T = relabelled(*needle(apex, below), order, corners)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            g = face_margins(V, T)
        np.testing.assert_allclose(g, [expected], rtol=1e-13)


@pytest.mark.parametrize("apex", APEXES + [1e150])
@pytest.mark.parametrize("below", [False, True])
def test_a_delaunay_needle_is_proved_regular(apex, below):
    for order, corners in ORDERS:
        V, T = relabelled(*needle(apex, below), order, corners)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            # locally Delaunay (the other apex far outside each circumsphere): w = 0 is
            # the answer; the plain dual's dual-face weight is the exact value
            assert face_margins(V, T).min() > 0
            L = tetlap.laplacian(V, T, "dual")
            assert L[order[0], order[1]] == pytest.approx(0.2125 * apex, rel=1e-12)
            r = regular_weights(V, T)
            assert (r.status, r.weights.any(), r.margin > 0) == ("regular", False, True), r.notes
            assert "decided exactly" in r.verification
            report = tetlap.info.report(V, T)["regular"]
        assert report["status"] == "regular", report


def test_a_mesh_spanning_600_orders_of_squared_length_is_named_not_warned():
    # at 1e150 the search's unit put the unit base's volume below float64 (1e-452); at
    # 1e300 the weights' units (squared lengths 1e-300 .. 1e300) overflow
    V, T = needle(1e300)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(tetlap.NonFiniteError, match="too many orders of magnitude"):
            regular_weights(V, T)
        assert tetlap.info.report(V, T)["regular"]["status"] == "n/a"


def test_only_an_exactly_flat_tet_is_refused():
    V, T = needle(1.0)
    V[4] = [0.25, 0.5, 0.0]              # in the plane of the face: exactly flat
    with pytest.raises(tetlap.DegenerateElementError, match="tet 1 is flat") as e:
        regular_weights(V, T)
    assert e.value.element == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # flat to 1e-7, not exactly: a row, and weights that repair the face
        V[4, 2] = 1e-7
        assert regular_weights(V, T).status == "regular"
        # flat to 1e-301: its power centre 1e300 away, beyond the weights the search may
        # use (max_weight), so undecided, but a true row, not a refusal
        V[4, 2] = 2.0 ** -1000
        assert face_margins(V, T)[0] < -1e299
        assert regular_weights(V, T).status == "undecided"
