"""``tetlap geodesic MESH --source S [--out FIELD.vtu]``: the heat method's distance from
one or more sources (:class:`tetlap.HeatDistance`), written as point data. A source is a
vertex index, a point (its nearest vertex) or ``boundary`` (one boundary vertex, chosen
by its coordinates)."""

from __future__ import annotations

import argparse
import re
import sys

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

#: ``--source boundary``: this boundary vertex (the first in this order).
BOUNDARY_CHOICE = ("the vertex on a boundary face with the smallest x, then the smallest y, "
                   "then z, then index (an extreme point of the mesh: the same vertex "
                   "whatever the numbering)")

_INDEX = re.compile(r"^\+?[0-9]+$")


def arguments(p) -> None:
    p.add_argument("mesh", help="mesh file (any format meshio reads)")
    p.add_argument("--source", action="append", required=True, metavar="S",
                   help="a source: a vertex index (0-based), a point x,y,z (the nearest "
                        "vertex of an element is taken, and printed; write "
                        "--source=-1,0,0 when it starts with a minus), or 'boundary' ("
                        + BOUNDARY_CHOICE + "); repeat for a set")
    p.add_argument("--out", default=None, metavar="FIELD",
                   help="write the mesh with the point data 'distance' (format from the "
                        "extension, e.g. .vtu)")
    p.add_argument("--laplacian", default="primal",
                   help="primal, dual, or t in [0, 1] (default: primal)")
    p.add_argument("--boundary-condition", default=None,
                   choices=["neumann", "dirichlet", "average"],
                   help="the heat step's boundary condition (default: neumann)")
    p.add_argument("--boundary", default=None, choices=["neumann", "dirichlet", "average"],
                   help=argparse.SUPPRESS)     # the old name of --boundary-condition
    p.add_argument("--time", type=float, default=None, metavar="T",
                   help="the heat step's time, a positive number (default: the mean edge "
                        "length squared)")
    p.add_argument("--degenerate", default="raise", choices=["raise", "skip"],
                   help="zero-volume tets: an error, or no part (default: raise)")
    _threads.argument(p)


def source(text: str):
    """One ``--source``: an int index (any size), a tuple of floats, or ``"boundary"``;
    an OptionError naming the flag for anything else."""
    from ..errors import OptionError

    text = text.strip()
    if text == "boundary":
        return text
    if _INDEX.match(text):
        return int(text)
    if "," in text:
        try:
            point = tuple(float(x) for x in text.split(","))
        except ValueError:
            point = ()
        if point and all(x == x and abs(x) != float("inf") for x in point):
            return point
        raise OptionError(f"--source {text}: a point must be finite numbers separated by "
                          "commas, x,y,z")
    if text.startswith("-") and _INDEX.match(text[1:]):
        raise OptionError(f"--source must be a non-negative integer (a vertex index), a "
                          f"point x,y,z or 'boundary', got {text}")
    raise OptionError(f"--source must be a vertex index, a point x,y,z or 'boundary', "
                      f"got {text!r}")


def check(args) -> None:
    args.sources = [source(s) for s in args.source]
    if args.boundary is not None:
        if args.boundary_condition is not None:
            from ..errors import OptionError

            raise OptionError("--boundary is the old name of --boundary-condition: give "
                              "--boundary-condition only")
        print("tetlap: warning: --boundary is deprecated, use --boundary-condition (it takes "
              "the same values)", file=sys.stderr)
        args.boundary_condition = args.boundary
    if args.boundary_condition is None:
        args.boundary_condition = "neumann"
    if args.time is not None:
        _options.positive(args.time, "--time")
    _options.threads(args.threads, "--threads")
    assemble.check_laplacian(args)
    if args.out is not None:
        _paths.mesh_file(args.out, "--out", ("distance",))


def vertices(sources, V, T) -> tuple[list[int], list[str]]:
    """The vertex of each ``--source`` (in the order given) and what was chosen for the
    points and ``boundary``, as lines to print; an error naming the flag for an index or a
    point the mesh does not have."""
    import numpy as np

    from ..errors import IndexRangeError, ShapeError
    from ..heat import _boundary_vertices, _norms

    n = len(V)
    used = np.zeros(n, dtype=bool)
    used[T.ravel()] = True
    chosen, notes = [], []
    for s in sources:
        if isinstance(s, int):
            if not 0 <= s < n:
                known = f"there are {n} vertices, 0 to {n - 1}"
                raise IndexRangeError(f"--source {s}: not a vertex ({known})", index=s)
            if not used[s]:
                raise IndexRangeError(f"--source {s}: vertex {s} is in no element of the "
                                      "mesh", index=s)
            chosen.append(s)
        elif s == "boundary":
            candidates = np.flatnonzero(_boundary_vertices(T, n))
            order = np.lexsort((candidates, *V[candidates].T[::-1]))
            v = int(candidates[order[0]])
            chosen.append(v)
            notes.append(f"--source boundary: vertex {v} at "
                         f"({', '.join(f'{x:.6g}' for x in V[v])})")
        else:
            if len(s) != V.shape[1]:
                raise ShapeError(f"--source {','.join(map(str, s))}: a point of the mesh has "
                                 f"{V.shape[1]} coordinates, got {len(s)}")
            candidates = np.flatnonzero(used)
            gap = _norms(V[candidates] - np.array(s))
            v = int(candidates[np.argmin(gap)])    # the first of the nearest
            chosen.append(v)
            notes.append(f"--source {','.join(f'{x:g}' for x in s)}: the nearest vertex is "
                         f"{v}, at distance {gap.min():.4g}")
    return chosen, notes


def run(args) -> int:
    import numpy as np

    from .. import io
    from .._progress import Stages
    from ..heat import HeatDistance
    from . import _mesh

    step = Stages("tetlap geodesic", True)   # stderr; a line per step when not a terminal
    step("read")
    V, T, source_file = _mesh.load(args.mesh)
    chosen, notes = vertices(args.sources, V, np.asarray(T))   # before the set-up
    heat = HeatDistance(V, T, t=args.time, laplacian=assemble.kind(args.laplacian),
                        boundary_condition=args.boundary_condition,
                        degenerate=args.degenerate, threads=args.threads,
                        progress=step)        # its set-up's steps, on the same lines
    step("distance")
    d = heat.distance(chosen)
    if args.out is not None:
        step("write")
        _paths.make_folder(args.out)
        io.write(args.out, V, T, point_data={"distance": d})
    step.done()
    finite = d[np.isfinite(d)]
    print(f"mesh: {source_file} ({len(V)} vertices, {len(T)} elements)")
    for note in notes:
        print(note)
    print(f"sources: {', '.join(map(str, chosen))}; h = {heat.h:.4g}, {heat._t_text()}, "
          f"boundary condition: {args.boundary_condition}, laplacian: {args.laplacian}")
    print(f"distance: max {finite.max():.6g}, mean {finite.mean():.6g}; "
          f"{len(d) - len(finite)} vertices unreachable (inf)")
    if args.out is not None:
        print(f"written: {_paths.shown(args.out)} (point data 'distance')")
    return 0
