"""``tetlap experiment NAME``: one of the paper's experiments (:mod:`tetlap.experiments`)."""

from __future__ import annotations

import argparse
import os
import textwrap

from .. import _options, experiments
from . import _output, _paths
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "EPILOG", "arguments", "check", "run"]
__dir__ = public_dir(globals())

NAME = "experiment"
HELP = "reproduce the paper's experiments"
DESCRIPTION = "One of the paper's Sec. 8 and 9 experiments: CSV, PNG, summary."
#: The experiments, one line each with its --quick time (shown after the arguments).
EPILOG = "experiments (--quick: seconds measured on 2 cores):\n" + "\n".join(
    textwrap.fill(f"{e.about} (--quick: {e.quick} s)", 79, initial_indent=f"  {e.name:<18}",
                  subsequent_indent=" " * 20) for e in experiments.EXPERIMENTS)


def _folder(text: str) -> str:
    if not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"no such folder: {_paths.shown(text)}")
    return text


def arguments(p) -> None:
    p.add_argument("name", choices=experiments.NAMES, metavar="NAME",
                   help="the experiment, one of those listed below")
    p.add_argument("--quick", action="store_true",
                   help="small sizes (the seconds listed below; under a minute each)")
    p.add_argument("--out", help="output folder (default: tetlap-experiments/NAME)")
    p.add_argument("--seed", type=int, default=0, help="random seed, >= 0 (default: 0)")
    p.add_argument("--meshes", type=_folder,
                   help=f"{', '.join(experiments.CORPUS_NAMES)}: a folder of mesh files")


def check(args) -> None:
    """``--seed``, then the output folder (``--out`` or its default)."""
    _options.count(args.seed, "--seed", least=0)
    _paths.output_folder(experiments.folder(args.name, args.out), "--out")


def run(args) -> int:
    folder = experiments.run(args.name, quick=args.quick, out=args.out, seed=args.seed,
                             meshes=args.meshes)
    print(_output.experiment_summary(folder))
    return 0
