"""Keeping the weighted circumcentric masses positive where the plain ones are.

Weights that make the faces regular move the power centres of boundary tets, and the
signed pieces they cut can make a boundary vertex's cell volume (its circumcentric mass)
non-positive where the plain one was positive. Every mass is a cubic polynomial of the
weights (power centres are affine in them). The core's mass step
(``tetlap._core.regular_masses``) minimises, by projected L-BFGS from the weights the
search found, the relative deficits of the masses below ``mass_floor`` times their plain
value, together with the faces' squared shortfall below their floors (measured in units
of the floor), with exact derivatives of the masses (the tets' reverse derivatives). Every
point it evaluates is a candidate: the best one whose faces keep half their floors (fewest
masses lost, then the smallest deficit) is kept when it improves; up to
:data:`ROUNDS` rounds, each on the tets of the vertices still below the floor.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import _core, assembly
from .search import Budget, Outcome, Problem

__all__ = ["ROUNDS", "MASS_ITERATIONS", "MassStep", "keep_masses", "circumcentric_masses"]

#: Rounds of the mass step at most (the core's ``ROUNDS``).
ROUNDS = 8
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
    u, info = _core.regular_masses(V, T, problem.core_rows,
                                   (outcome.floors, outcome.aims, lo, hi),
                                   (plain, float(mass_floor), problem.scale), outcome.u,
                                   iterations, seconds=budget.seconds(),
                                   options={"threads": threads})
    budget.iterations -= info["iterations"]
    return u, MassStep(rounds=info["rounds"], iterations=info["iterations"],
                       kept=info["kept"], lost=info["lost"], deficit=info["deficit"])
