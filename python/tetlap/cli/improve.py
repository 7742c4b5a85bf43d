"""``tetlap improve MESH -o OUT``: interior vertex moves that remove negative dual weights
(:func:`tetlap.improve.improve`)."""

from __future__ import annotations

from .. import _options
from . import _output, _paths, _threads
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "check", "run"]
__dir__ = public_dir(globals())

NAME = "improve"
HELP = "move interior vertices to remove negative dual weights"
DESCRIPTION = ("Optimise interior vertex positions (L-BFGS-B) so that fewer interior dual "
               "weights are negative; the boundary stays fixed. See tetlap.improve.")


def arguments(p) -> None:
    p.add_argument("mesh", help="mesh file (any format meshio reads)")
    p.add_argument("-o", "--output", required=True,
                   help="the improved mesh (format from the extension, e.g. .vtu)")
    p.add_argument("--margin", type=float, default=0.02,
                   help="penalise dual weights below MARGIN times the mean edge length, a "
                        "number from 0 to 1e6 (default: 0.02)")
    p.add_argument("--iterations", type=int, default=200,
                   help="L-BFGS-B iterations, >= 1 (default: 200)")
    p.add_argument("--step", type=float, default=0.3,
                   help="largest move per coordinate, in shortest incident edges, a positive "
                        "number (default: 0.3)")
    _threads.argument(p)


def check(args) -> None:
    from ..improve import MAX_MARGIN

    _options.at_most(_options.non_negative(args.margin, "--margin"), MAX_MARGIN, "--margin")
    _options.count(args.iterations, "--iterations")
    _options.positive(args.step, "--step")
    _options.threads(args.threads, "--threads")
    _paths.mesh_file(args.output, "-o")


def run(args) -> int:
    from .. import io
    from ..improve import improve
    from . import _mesh

    V, T, source = _mesh.load(args.mesh)
    result = improve(V, T, margin=args.margin, max_iterations=args.iterations, step=args.step,
                     threads=args.threads)
    _paths.make_folder(args.output)
    io.write(args.output, result.V, T)
    print(f"mesh: {source} ({len(V)} vertices, {len(T)} tets) -> "
          f"{_paths.shown(args.output)}")
    print(_output.improve_table(result))
    return 0
