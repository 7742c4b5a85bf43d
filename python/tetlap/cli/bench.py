"""``tetlap bench``: median timings of tetlap and the baselines installed, side by side
(:mod:`tetlap.benchmark`)."""

from __future__ import annotations

from .. import _options
from . import _output, _paths, _threads
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "MAX_REPEAT", "check", "run"]
__dir__ = public_dir(globals())

NAME = "bench"
HELP = "timings against the floor and the baselines"
DESCRIPTION = ("Median timings of tetlap and the baselines installed, side by side, on "
               "several kinds of mesh.")


def arguments(p) -> None:
    from ..benchmark import KINDS, SIZES

    p.add_argument("--kinds", nargs="+", choices=KINDS,
                   help="mesh kinds (default: all four; --quick: kuhn delaunay)")
    p.add_argument("--sizes", nargs="+", choices=list(SIZES),
                   help="sizes in tets (default: 100k 1M; --quick: 10k 100k)")
    p.add_argument("--mesh", nargs="+", metavar="FILE", help="also time these mesh files")
    _threads.argument(p)
    p.add_argument("--repeat", type=int, default=None,
                   help="repetitions, the median is reported, 1 to 10000 (default: 5; "
                        "--quick: 3)")
    p.add_argument("--operators", nargs="+", metavar="WORD",
                   help="only cases whose name contains a word, e.g. primal dual Mesh check "
                        "info numpy voronoi scikit coefficient (the floor always runs, and "
                        "igl.cotmatrix when libigl is installed: the last column is relative "
                        "to it)")
    p.add_argument("--solve", action="store_true",
                   help="time tetlap.solve instead (Dirichlet, eigs, factorize on 189k-1M tets, "
                        "each case in its own process, against one assembly, SuperLU, pyamg "
                        "and libigl: tetlap.benchmark_solve); --quick: the 189k-tet ball only")
    p.add_argument("--cap", type=float, default=300.0,
                   help="--solve: seconds after which a case is killed, at most 1e6 "
                        "(default: 300)")
    p.add_argument("--quick", action="store_true", help="small sizes, fewer repetitions")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object, {schema_version, benchmark, records} "
                        "(default: a table)")


#: The most repetitions ``--repeat`` takes.
MAX_REPEAT = 10_000


def check(args) -> None:
    """The numeric flags, and that every ``--mesh`` file can be read (the generated meshes
    are timed first)."""
    _options.threads(args.threads, "--threads")
    if args.repeat is not None:
        _options.at_most(_options.count(args.repeat, "--repeat"), MAX_REPEAT, "--repeat")
    _options.at_most(_options.positive(args.cap, "--cap"), _options.MAX_SECONDS, "--cap")
    for path in args.mesh or ():
        _paths.input_file(path, "--mesh")


def run(args) -> int:
    from .. import benchmark

    if args.solve:
        from .. import benchmark_solve

        names = ["ball 189k"] if args.quick else list(benchmark_solve.MESHES)
        records = benchmark_solve.run(names, cap=args.cap, progress=not args.json)
        print(_output.json_document(benchmark.document("solve", records), indent=1)
              if args.json else benchmark_solve.table(records))
        return 0

    sizes = args.sizes or (["10k", "100k"] if args.quick else ["100k", "1M"])
    kinds = args.kinds or (["kuhn", "delaunay"] if args.quick else list(benchmark.KINDS))
    if args.mesh and not args.kinds:
        kinds = []
    records = benchmark.run(kinds, sizes, args.mesh or (), threads=args.threads,
                            repeat=args.repeat or (3 if args.quick else 5), only=args.operators,
                            progress=not args.json)
    print(_output.json_document(benchmark.document("assembly", records), indent=1)
          if args.json else _output.bench_table(records))
    return 0
