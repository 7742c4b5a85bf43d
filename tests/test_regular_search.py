"""tetlap.regular.search: the search (the core's regular_search), quadratic liftings and
certificate LPs."""

from __future__ import annotations

import numpy as np

import tetlap
from tetlap import _core
from tetlap.regular import search, verify
from tetlap.regular.conditions import Conditions, _validated
from tetlap.regular import _vertex_scale

from test_regular_examples import mother


def problem_of(V, T):
    V, T = _validated(V, T)
    cond = Conditions.of(V, T)
    plain = verify.check_margins(V, T, cond.interior, np.zeros(len(V)), exact=False)
    problem = search.Problem.of(cond, _vertex_scale(V, T))
    sign = plain.sign[cond.face[problem.rows]]
    return V, T, cond, problem, sign


def test_the_core_search_reaches_its_floors_the_same_on_any_thread_count():
    V, T, cond, problem, sign = problem_of(*tetlap.meshes.weighted_ball(2000, 1.0, seed=1))
    floors, aims = search._aims(problem, sign, 1e-3)
    bound = np.full(problem.n, 10.0)
    runs = [_core.regular_search(problem.core_rows, (floors, aims, -bound, bound),
                                 np.zeros(problem.n), (5000, None), options={"threads": k})
            for k in (1, 2, 3)]
    u, stop, iterations, short, y = runs[0]
    assert stop == "done" and (problem.margins(u) >= floors).all() and len(short) == 0
    for other in runs[1:]:
        np.testing.assert_array_equal(other[0], u)
        assert other[1:3] == (stop, iterations)
    # an iteration budget is a budget
    u, stop, iterations, short, y = _core.regular_search(
        problem.core_rows, (floors, aims, -bound, bound), np.zeros(problem.n), (3, None))
    assert (stop, iterations) == ("iterations", 3) and len(short) > 0 and (y > 0).all()


def test_a_kuhn_grid_is_delaunay_in_a_sheared_metric():
    V, T, cond, problem, sign = problem_of(*tetlap.meshes.cube(5))
    assert (sign == 0).sum() > 0          # cospherical faces
    floors, aims = search._aims(problem, sign, 1e-3)
    bound = np.full(problem.n, 10.0)
    u = search.quadratic(V, problem, floors, aims, -bound, bound)
    assert u is not None and (problem.margins(u) >= floors).all()
    # the mother of all examples is Delaunay in no metric
    V, T, cond, problem, sign = problem_of(*mother(0.0))
    floors, aims = search._aims(problem, sign, 1e-3)
    bound = np.full(problem.n, 10.0)
    assert search.quadratic(V, problem, floors, aims, -bound, bound) is None


def test_a_stuck_search_finds_a_checked_certificate_within_its_lp_budget():
    V, T, cond, problem, sign = problem_of(*mother(0.1, apexes=2))
    bound = np.full(problem.n, 10.0)
    notes: list[str] = []
    out = search.search(V, T, cond, problem, sign, 1e-3, -bound, bound,
                        search.Budget(iterations=5000), notes)
    assert out.status == "not regular" and out.certificate.kind == "gordan"
    assert 0 < out.lps <= search.STALL_LPS
    # without LPs it is undecided, however long it searches
    out = search.search(V, T, cond, problem, sign, 1e-3, -bound, bound,
                        search.Budget(iterations=5000, lps=0), notes)
    assert out.status == "undecided" and out.lps == 0
