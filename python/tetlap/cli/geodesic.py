"""``tetlap geodesic MESH --source I [--out FIELD.vtu]``: the heat method's distance from
one or more source vertices (:class:`tetlap.HeatDistance`), written as point data."""

from __future__ import annotations

from .. import _options
from . import _paths, _threads, assemble
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "check", "run"]
__dir__ = public_dir(globals())

NAME = "geodesic"
HELP = "heat-method geodesic distance from source vertices"
DESCRIPTION = ("The distance from the --source vertices by the heat method (Crane et al. "
               "2013; see tetlap.HeatDistance), written as point data 'distance' to --out "
               "(ParaView and PyVista open .vtu). Vertices unreachable from every source "
               "get inf.")


def arguments(p) -> None:
    p.add_argument("mesh", help="mesh file (any format meshio reads)")
    p.add_argument("--source", type=int, action="append", required=True, metavar="I",
                   help="a source vertex (0-based); repeat for a set")
    p.add_argument("--out", default=None, metavar="FIELD",
                   help="write the mesh with the point data 'distance' (format from the "
                        "extension, e.g. .vtu)")
    p.add_argument("--laplacian", default="primal",
                   help="primal, dual, or t in [0, 1] (default: primal)")
    p.add_argument("--boundary", default="neumann", choices=["neumann", "dirichlet", "average"],
                   help="the heat step's boundary condition (default: neumann)")
    p.add_argument("--time", type=float, default=None, metavar="T",
                   help="the heat step's time, a positive number (default: the mean edge "
                        "length squared)")
    p.add_argument("--degenerate", default="raise", choices=["raise", "skip"],
                   help="zero-volume tets: an error, or no part (default: raise)")
    _threads.argument(p)


def check(args) -> None:
    for s in args.source:
        _options.count(s, "--source", least=0)
    if args.time is not None:
        _options.positive(args.time, "--time")
    _options.threads(args.threads, "--threads")
    assemble.check_laplacian(args)
    if args.out is not None:
        _paths.mesh_file(args.out, "--out", ("distance",))


def run(args) -> int:
    import numpy as np

    from .. import io
    from .._progress import Stages
    from ..errors import TetlapError
    from ..heat import HeatDistance, _sources
    from . import _mesh

    step = Stages("tetlap geodesic", True)   # stderr; a line per step when not a terminal
    step("read")
    V, T, source = _mesh.load(args.mesh)
    used = np.zeros(len(V), dtype=bool)
    used[np.asarray(T).ravel()] = True
    try:   # before the set-up's factorizations
        _sources(np.array(args.source), len(V), used)
    except TetlapError as e:
        raise type(e)(f"--source: {e}") from None
    step("set-up: assemble, factorize")
    heat = HeatDistance(V, T, t=args.time, laplacian=assemble.kind(args.laplacian),
                        boundary=args.boundary, degenerate=args.degenerate,
                        threads=args.threads)
    step("distance")
    d = heat.distance(args.source)
    if args.out is not None:
        step("write")
        _paths.make_folder(args.out)
        io.write(args.out, V, T, point_data={"distance": d})
    step.done()
    finite = d[np.isfinite(d)]
    print(f"mesh: {source} ({len(V)} vertices, {len(T)} elements)")
    print(f"sources: {', '.join(map(str, sorted(set(args.source))))}; h = {heat.h:.4g}, "
          f"t = {heat.t:.4g}, boundary: {args.boundary}, laplacian: {args.laplacian}")
    print(f"distance: max {finite.max():.6g}, mean {finite.mean():.6g}; "
          f"{len(d) - len(finite)} vertices unreachable (inf)")
    if args.out is not None:
        print(f"written: {_paths.shown(args.out)} (point data 'distance')")
    return 0
