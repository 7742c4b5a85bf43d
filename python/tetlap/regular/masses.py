"""Keeping the weighted circumcentric masses positive where the plain ones are.

Weights that make the faces regular move the power centres of boundary tets, and the
signed pieces they cut can make a boundary vertex's cell volume (its circumcentric mass)
non-positive where the plain one was positive. The core's mass step
(``tetlap._core.regular_masses``, ``tetlap::analysis::regular::keep_masses``) runs rounds
of: the masses below ``mass_floor`` times their plain value, linearised at the current
weights (exact derivatives: every tet's reverse derivative), join the faces' squared
shortfall as hinge rows, minimised by the search's L-BFGS (the faces may give up half of
their floors); the step is then taken by a line search on the true masses, which are
cubic polynomials of the weights along it (power centres are affine in them), for the
fewest masses lost, then the smallest deficit below the floor; a round that does not
improve confines the next to a tenth of its step. Up to 30 rounds (the core's
``ROUNDS``) within :data:`MASS_ITERATIONS` iterations. A soft goal: where masses stay lost, the result says
which (no proof that no weights keep them).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import _core, assembly
from .search import Budget, Outcome, Problem
from .._names import public_dir

__all__ = ["MASS_ITERATIONS", "MassStep", "keep_masses", "circumcentric_masses"]
__dir__ = public_dir(globals())

#: L-BFGS iterations of the mass step at most (over all rounds).
MASS_ITERATIONS = 2000


@dataclasses.dataclass(frozen=True)
class MassStep:
    """What the mass step did: ``rounds`` run, ``iterations`` spent, rounds ``kept`` (that
    improved the masses), and at its end the positive plain masses ``lost`` (now
    ``<= 0``) and their relative ``deficit`` below the floor."""

    rounds: int
    iterations: int
    kept: int
    lost: int
    deficit: float


def circumcentric_masses(V, T, w: np.ndarray | None, threads: int | None = None) -> np.ndarray:
    """(n,) the circumcentric masses of the (weighted) dual, as the operators assemble
    them. With weights, tets the core's accuracy rule refuses are skipped (zero mass)."""
    M = assembly.mass(V, T, "circumcentric", weights=w,
                      degenerate="raise" if w is None else "skip", threads=threads)
    return M.diagonal()


def keep_masses(V, T, problem: Problem, outcome: Outcome, lo: np.ndarray, hi: np.ndarray,
                plain: np.ndarray, mass_floor: float, budget: Budget,
                threads: int | None = None) -> tuple[np.ndarray, MassStep]:
    """The mass step (module docstring) from the search's ``outcome`` (status
    ``"reached"``): returns ``u`` (problem units) and what it did. The faces keep half the
    floors the search reached."""
    iterations = min(budget.iterations, MASS_ITERATIONS)
    targets = (outcome.floors, outcome.aims, lo, hi)
    u, info = _core.regular_masses(
        V, T, (problem.core_rows, targets, (plain, float(mass_floor), problem.scale)),
        outcome.u, (iterations, budget.seconds()), options={"threads": threads})
    budget.iterations -= info["iterations"]
    return u, MassStep(rounds=info["rounds"], iterations=info["iterations"],
                       kept=info["kept"], lost=info["lost"], deficit=info["deficit"])
