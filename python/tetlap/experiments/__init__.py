"""The paper's experiments (Sec. 8 and 9) as commands: ``tetlap experiment NAME``.

Each experiment writes into ``--out`` (default ``tetlap-experiments/NAME``) a CSV of the
raw numbers, at least one PNG figure and ``summary.txt``, and shows a progress bar.
``--quick`` sizes finish in under two minutes on two cores; the full sizes approach the
paper's. Figures need matplotlib (``pip install ".[experiments]"``).

:data:`EXPERIMENTS` lists them, once: each name with its module (its ``run(out)``, or
``run(out, meshes=None)`` for those that read a corpus folder) and what it shows.

>>> from tetlap import experiments
>>> experiments.NAMES[:2], experiments.CORPUS_NAMES
(('dirichlet-shell', 'eigen-ball'), ('negative-weights', 'improve', 'regular-weights', 'harmonic', 'anisotropic'))
"""

from __future__ import annotations

import importlib
import pathlib
from typing import NamedTuple

from .. import _options
from ..errors import OptionError
from ._output import Output, folder
from .._names import public_dir

__all__ = ["EXPERIMENTS", "NAMES", "CORPUS_NAMES", "Experiment", "Output", "folder", "run"]
__dir__ = public_dir(globals())


class Experiment(NamedTuple):
    """One experiment of ``tetlap experiment``."""

    name: str
    """The command's name for it."""
    module: str
    """Its module in this package, imported when it runs."""
    about: str
    """What it shows."""
    quick: int
    """Seconds ``tetlap experiment NAME --quick`` took, measured once on the repository's
    shared 2-core machine (the built-in meshes; process start-up included)."""
    corpus: bool = False
    """It reads a folder of mesh files (``--meshes``)."""


#: Every experiment, in the order of ``tetlap experiment --help``.
EXPERIMENTS = (
    Experiment("dirichlet-shell", "shell",
               "Eq. 28 on a spherical shell: variance on r = 0.75 (Fig. 8/9)", 16),
    Experiment("eigen-ball", "eigen_ball", "Dirichlet eigenvalues of the unit ball (Fig. 10/11)",
               10),
    Experiment("negative-weights", "negative_weights",
               "NaN/Inf and negative weights over a mesh corpus (Fig. 12)", 4, corpus=True),
    Experiment("sphere3", "sphere3", "normals and mean curvature on S^3 in R^4 (Fig. 13/14)",
               4),
    Experiment("flips", "flips", "sign of the Dirichlet-energy change of 2-3 / 3-2 flips (Sec. 9)",
               8),
    Experiment("improve", "improve",
               "vertex moves that remove negative dual weights (tetlap.improve)", 8,
               corpus=True),
    Experiment("regular-weights", "regular_weights",
               "weights that make a mesh regular; the Sec. 9 conjecture", 33, corpus=True),
    Experiment("heat-distance", "heat_distance",
               "heat-method distance against the Euclidean one on balls and boxes", 8),
    Experiment("harmonic", "harmonic",
               "the maximum principle of harmonic fields over a mesh corpus, against libigl",
               9, corpus=True),
    Experiment("finite-volumes", "finite_volumes",
               "Poisson on the ball: cell-centred and vertex-centred duals against the exact "
               "solution", 7),
    Experiment("anisotropic", "anisotropic",
               "div(K grad u) on the FVCA6 tets: primal, dual and regular dual in the metric, "
               "cells", 24, corpus=True),
)
#: Their names, the choices of ``tetlap experiment NAME``.
NAMES = tuple(e.name for e in EXPERIMENTS)
#: The experiments that read a folder of mesh files (``--meshes``).
CORPUS_NAMES = tuple(e.name for e in EXPERIMENTS if e.corpus)


def run(name: str, *, quick: bool = False, out=None, seed: int = 0, meshes=None) -> pathlib.Path:
    """Run experiment ``name``; return the folder with its CSV, PNG and summary. ``meshes``
    (a folder of mesh files) only for :data:`CORPUS_NAMES`; ``seed`` a non-negative integer."""
    _options.count(seed, "seed", 0)
    experiment = next((e for e in EXPERIMENTS if e.name == name), None)
    if experiment is None:
        raise OptionError(f"unknown experiment {name!r}; choose one of {', '.join(NAMES)}")
    if meshes is not None and not experiment.corpus:
        raise OptionError(f"experiment {name} reads no mesh folder (--meshes is for "
                          f"{', '.join(CORPUS_NAMES)})")
    module = importlib.import_module(f".{experiment.module}", __name__)
    output = Output(name, out, quick, seed)
    if experiment.corpus:
        module.run(output, meshes=meshes)
    else:
        module.run(output)
    return output.finish()
