"""The paper's experiments (Sec. 8 and 9) as commands: ``tetlap experiment NAME``.

Each experiment writes into ``--out`` (default ``tetlap-experiments/NAME``) a CSV of the
raw numbers, at least one PNG figure and ``summary.txt``, and shows a progress bar.
``--quick`` sizes finish in under two minutes on two cores; the full sizes approach the
paper's. Figures need matplotlib (``pip install 'tetlap[experiments]'``).

========================  ==========================================================
``dirichlet-shell``       Eq. 28 on a spherical shell: variance on r = 0.75 (Fig. 8/9)
``eigen-ball``            Dirichlet eigenvalues of the unit ball (Fig. 10/11)
``negative-weights``      NaN/Inf and negative weights over a mesh corpus (Fig. 12)
``sphere3``               normals and mean curvature on S^3 in R^4 (Fig. 13/14)
``flips``                 sign of the Dirichlet-energy change of 2-3 / 3-2 flips (Sec. 9)
``improve``               vertex moves that remove negative dual weights (tetlap.improve)
``regular-weights``       weights that make a mesh regular; the Sec. 9 conjecture
========================  ==========================================================
"""

from __future__ import annotations

import pathlib

from ._output import Output

__all__ = ["NAMES", "Output", "run"]

NAMES = ("dirichlet-shell", "eigen-ball", "negative-weights", "sphere3", "flips", "improve",
         "regular-weights")


def run(name: str, *, quick: bool = False, out=None, seed: int = 0, meshes=None) -> pathlib.Path:
    """Run experiment ``name``; return the folder with its CSV, PNG and summary."""
    from . import eigen_ball, flips, improve, negative_weights, regular_weights, shell, sphere3

    runners = {
        "dirichlet-shell": shell.run,
        "eigen-ball": eigen_ball.run,
        "negative-weights": negative_weights.run,
        "sphere3": sphere3.run,
        "flips": flips.run,
        "improve": improve.run,
        "regular-weights": regular_weights.run,
    }
    if name not in runners:
        raise ValueError(f"unknown experiment {name!r}; choose one of {', '.join(NAMES)}")
    output = Output(name, out, quick, seed)
    if name in ("negative-weights", "improve", "regular-weights"):
        runners[name](output, meshes=meshes)
    else:
        runners[name](output)
    return output.finish()
