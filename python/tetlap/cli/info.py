"""``tetlap info [MESH]``: the mesh and the Table 1 properties of both Laplacians, with
numbers (:func:`tetlap.info.report`), as text or JSON, and optionally histograms."""

from __future__ import annotations

import sys

from .. import _options
from . import _mesh, _output, _paths, _threads
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "check", "run"]
__dir__ = public_dir(globals())

NAME = "info"
HELP = "the mesh and the Table 1 properties of both Laplacians"
DESCRIPTION = ("Counts, mesh quality and the paper's Table 1 for the primal and the dual "
               "Laplacian, with numbers.")


def arguments(p) -> None:
    p.add_argument("mesh", nargs="?",
                   help=f"mesh file (any format meshio reads); without it, {_mesh.BUILT_IN}")
    p.add_argument("--json", action="store_true", help="print one JSON object (default: tables)")
    p.add_argument("--no-nsd", action="store_true",
                   help="skip the semidefiniteness certificates (default: computed)")
    p.add_argument("--no-regular", action="store_true",
                   help="skip the search for regular (weighted Delaunay) weights")
    p.add_argument("--regular-time", type=float, default=None, metavar="S",
                   help="an optional wall-clock limit in seconds for that search, a positive "
                        "number; past it the verdict is 'undecided' and depends on the "
                        "machine's load (default: none, a work budget that gives the same "
                        "answer on every run)")
    p.add_argument("--coefficient", metavar="X", help=_mesh.COEFFICIENT_HELP + "; both "
                   "Laplacians are built with it and checked in its metric")
    _threads.argument(p)
    p.add_argument("--plot", metavar="DIR",
                   help="also write histograms of dihedral angles, weights and masses "
                        "(PNG, named after the mesh) into DIR (created if needed; needs "
                        "matplotlib)")


def check(args) -> None:
    """The flags, and matplotlib and the folder for ``--plot``, before the mesh is read."""
    from .. import info

    if args.regular_time is not None:
        _options.positive(args.regular_time, "--regular-time")
    _options.threads(args.threads, "--threads")
    if args.plot is not None:
        info.pyplot()
        _paths.output_folder(args.plot, "--plot", info.plot_names(_mesh.name(args.mesh)))


def run(args) -> int:
    from .. import info
    from .._progress import Stages

    step = Stages("tetlap info", not args.json)   # stderr; a line per step when not a terminal
    step("read the mesh" if args.mesh else "make the built-in mesh")
    V, T, source = _mesh.load(args.mesh)
    K = _mesh.coefficient(args.coefficient, args.mesh, V, T)
    step.done()
    result = info.report(V, T, nsd=not args.no_nsd, progress=not args.json,
                         regular=not args.no_regular, regular_time_limit=args.regular_time,
                         coefficient=K)
    if args.json:
        print(_output.json_document({"schema_version": result["schema_version"],
                                     "source": source, **result}))
    else:
        print(_output.info_report(result, source))
    if args.plot is not None:
        files = info.plot(V, T, args.plot, name=_mesh.name(args.mesh))
        print(f"plots: {', '.join(_paths.shown(p) for p in files)}",
              file=sys.stderr if args.json else sys.stdout)
    return 0
