"""The ``tetlap`` command (also ``python -m tetlap``): it parses arguments and prints; the
work is done by :mod:`tetlap.info`, :mod:`tetlap.assembly`, :mod:`tetlap.benchmark` and
:mod:`tetlap.experiments`.

    tetlap info [MESH] [--json]      the mesh, both Laplacians' Table 1 properties, regularity
    tetlap assemble MESH -o L.npz    L and M as scipy .npz files
    tetlap bench                     timings against the floor and the baselines
    tetlap experiment NAME           the paper's experiments (CSV + PNG + summary)
    tetlap improve MESH -o OUT       move interior vertices to remove negative dual weights
    tetlap distributed-info P T      (under mpirun) global checks with PETSc, from .npy files
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys

from . import __version__, experiments
from .errors import TetlapError
from .info import REGULAR_TIME_LIMIT

#: The built-in mesh of ``tetlap info`` without a file.
BUILT_IN = "a random Delaunay ball, tetlap.meshes.ball(2000, seed=0)"


def _load(path: str | None):
    """``(V, T, description)`` of a mesh file, or of the built-in ball; nothing that the
    readers print reaches stdout."""
    from . import meshes

    if path is None:
        return (*meshes.ball(2000, seed=0), BUILT_IN)
    from . import io

    with contextlib.redirect_stdout(sys.stderr):
        V, T = io.read(path)
    return V, T, path


def _cell(value) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return f"{value:.3e}"
    return str(value)


def _share(count: int, total: int) -> str:
    return f"{count}/{total} ({100 * count / total:.2f}%)" if total else "0/0"


def _print_info(result: dict, source: str) -> None:
    m = result["mesh"]
    print(f"mesh: {source}")
    print(f"{m['n_vertices']} vertices ({m['n_boundary_vertices']} on the boundary, "
          f"{m['n_unreferenced_vertices']} unreferenced), {m['n_tets']} tets "
          f"({_cell(m['n_positive_tets'])} positive, {_cell(m['n_negative_tets'])} negative, "
          f"{m['n_degenerate_tets']} degenerate, {m['n_duplicate_tets']} duplicate)")
    faces = (f"faces: {m['n_boundary_faces']} on the boundary, {m['n_interior_faces']} interior, "
             f"{m['n_nonmanifold_faces']} non-manifold")
    if m["non_delaunay_face_fraction"] is not None:
        faces += (f"; non-Delaunay: {_share(m['n_non_delaunay_faces'], m['n_interior_faces'])} "
                  f"of the interior faces, {100 * m['non_delaunay_tet_fraction']:.2f}% of the tets")
    print(faces)
    angles = ("n/a" if m["min_dihedral_deg"] is None else
              f"{m['min_dihedral_deg']:.2f} .. {m['max_dihedral_deg']:.2f} deg")
    print(f"dihedral angles {angles}; "
          f"well-centered tets {100 * m['well_centered_tet_fraction']:.2f}%; "
          f"volume {m['mesh_volume']:.10g}")
    p, d = result["primal"], result["dual"]
    rows = [
        ("finite", _cell(p["finite"]), _cell(d["finite"])),
        ("symmetric", _cell(p["symmetric"]), _cell(d["symmetric"])),
        ("max |row sum|", _cell(p["max_row_sum"]), _cell(d["max_row_sum"])),
        ("linear precision residual", _cell(p["linear_precision_residual"]),
         _cell(d["linear_precision_residual"])),
        ("negative semidefinite", _cell(p["nsd"]), _cell(d["nsd"])),
        ("min weight", _cell(p["min_weight"]), _cell(d["min_weight"])),
        ("negative weights", _share(p["n_negative"], p["n_edges"]),
         _share(d["n_negative"], d["n_edges"])),
        ("  edges not both on the boundary", _share(p["n_negative_interior"], p["n_edges_interior"]),
         _share(d["n_negative_interior"], d["n_edges_interior"])),
        ("mass total (vs volume)", f"{p['mass_total']:.10g}", f"{d['mass_total']:.10g}"),
        ("mass min", _cell(p["mass_min"]), _cell(d["mass_min"])),
        ("vertices with mass <= 0", str(p["mass_nonpositive"]), str(d["mass_nonpositive"])),
    ]
    widths = [max(len(r[k]) for r in rows + [("property", "primal", "dual")]) for k in range(3)]
    print()
    print(f"{'property':<{widths[0]}}  {'primal':>{widths[1]}}  {'dual':>{widths[2]}}")
    for label, a, b in rows:
        print(f"{label:<{widths[0]}}  {a:>{widths[1]}}  {b:>{widths[2]}}")
    print("(mass: barycentric with the primal, circumcentric with the dual)")
    print()
    for kind, r in (("primal", p), ("dual", d)):
        print(f"semidefinite ({kind}): {r['nsd_method']}")
    if result.get("regular") is not None:
        print()
        _print_regular(result["regular"])


def _print_regular(r: dict) -> None:
    """The ``regular`` section of ``tetlap info``: the verdict and what the weights buy."""
    if r["status"] == "n/a":
        print(f"regular (weighted Delaunay): n/a ({r['reason']})")
        return
    verdict = {"regular": "yes", "not regular": "no (proved)",
               "undecided": "undecided"}[r["status"]]
    print(f"regular (weighted Delaunay): {verdict}; margin {r['margin']:+.3e} with the "
          f"weights found ({r['n_weighted_vertices']} non-zero), {r['margin_plain']:+.3e} "
          f"without; {r['seconds']:.2f} s")
    n = r["negative_interior_weights"]
    print(f"negative interior weights: dual {n['dual']}, weighted dual {n['weighted_dual']}, "
          f"primal {n['primal']}")
    if r["status"] == "not regular":
        print(f"certificate: {r['certificate_faces']} faces that no weights make all "
              "locally regular")
    elif r["status"] == "undecided":
        print(f"undecided: {r['notes'][0] if r['notes'] else 'budget exhausted'} "
              "(raise --regular-time)")


def _info(args) -> int:
    from . import info

    V, T, source = _load(args.mesh)
    result = info.report(V, T, nsd=not args.no_nsd, progress=None if not args.json else False,
                         regular=not args.no_regular, regular_time_limit=args.regular_time)
    if args.json:
        print(json.dumps({"source": source, **result}, indent=2))
    else:
        _print_info(result, source)
    if args.plot:
        files = info.plot(V, T, args.plot)
        print(f"plots: {', '.join(str(p) for p in files)}", file=sys.stderr if args.json else sys.stdout)
    return 0


def output_names(output: str) -> tuple[str, str]:
    """The files ``tetlap assemble -o OUTPUT`` writes: L and M (``.npz`` appended when
    missing, as ``scipy.sparse.save_npz`` does)."""
    base = output[:-4] if output.endswith(".npz") else output
    return base + ".npz", base + ".mass.npz"


def _assemble(args) -> int:
    import scipy.sparse as sp

    from . import assembly

    kind = args.laplacian
    with contextlib.suppress(ValueError):
        kind = float(kind)
    V, T, _ = _load(args.mesh)
    L, M = assembly.operators(V, T, laplacian=kind, mass=args.mass, degenerate=args.degenerate)
    l_file, m_file = output_names(args.output)
    sp.save_npz(l_file, L)
    sp.save_npz(m_file, M)
    print(f"L ({args.laplacian}, {L.shape[0]} x {L.shape[1]}, {L.nnz} entries) -> {l_file}")
    print(f"M ({args.mass}) -> {m_file}")
    return 0


def _experiment(args) -> int:
    from . import experiments

    folder = experiments.run(args.name, quick=args.quick, out=args.out, seed=args.seed,
                             meshes=args.meshes)
    print((folder / "summary.txt").read_text(), end="")
    print(f"files: {', '.join(sorted(p.name for p in folder.iterdir()))} in {folder}")
    return 0


def _improve(args) -> int:
    from . import io
    from .improve import format_table, improve

    V, T = io.read(args.mesh)
    result = improve(V, T, margin=args.margin, max_iterations=args.iterations, step=args.step,
                     threads=args.threads)
    io.write(args.output, result.V, T)
    print(f"mesh: {args.mesh} ({len(V)} vertices, {len(T)} tets) -> {args.output}")
    print(format_table(result))
    return 0


def _distributed_info(args) -> int:
    from . import distributed

    result = distributed.info(args.points, args.tets)
    from mpi4py import MPI

    if MPI.COMM_WORLD.Get_rank() == 0:
        print(json.dumps(result, indent=2))
    return 0


def _threads(text: str) -> int:
    from . import _core

    value = int(text)
    if not 1 <= value <= _core.MAX_THREADS:
        raise argparse.ArgumentTypeError(f"must be between 1 and {_core.MAX_THREADS}")
    return value


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError("must be at least 1")
    return value


def _folder(text: str) -> str:
    if not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"no such folder: {text}")
    return text


def parser() -> argparse.ArgumentParser:
    """The argument parser of the ``tetlap`` command."""
    p = argparse.ArgumentParser(
        prog="tetlap", description="Laplace operators of tetrahedral meshes (also: python -m tetlap).")
    p.add_argument("--version", action="version", version=f"tetlap {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = sub.add_parser("info", help="the mesh and the Table 1 properties of both Laplacians",
                          description="Counts, mesh quality and the paper's Table 1 for the "
                                      "primal and the dual Laplacian, with numbers.")
    info.add_argument("mesh", nargs="?",
                      help=f"mesh file (any format meshio reads); without it, {BUILT_IN}")
    info.add_argument("--json", action="store_true", help="print one JSON object (default: tables)")
    info.add_argument("--no-nsd", action="store_true",
                      help="skip the semidefiniteness certificates (default: computed)")
    info.add_argument("--no-regular", action="store_true",
                      help="skip the search for regular (weighted Delaunay) weights")
    info.add_argument("--regular-time", type=float, default=None, metavar="S",
                      help="seconds for that search; past it the verdict is 'undecided' "
                           "(default: half the time of the other checks, 1 to "
                           f"{REGULAR_TIME_LIMIT:g} s)")
    info.add_argument("--plot", metavar="DIR",
                      help="also write histograms of dihedral angles, weights and masses "
                           "(PNG) into DIR")
    asm = sub.add_parser("assemble", help="save L and M as scipy .npz files",
                         description="Assemble L and M and save them for scipy.sparse.load_npz.")
    asm.add_argument("mesh", help="mesh file (any format meshio reads)")
    asm.add_argument("-o", "--output", required=True,
                     help="L goes to OUTPUT (.npz appended if missing), M to OUTPUT.mass.npz")
    asm.add_argument("--laplacian", default="dual",
                     help='"primal", "dual" or a float t in [0, 1] (default: dual)')
    asm.add_argument("--mass", default="circumcentric", choices=["barycentric", "circumcentric", "fem"],
                     help="mass matrix (default: circumcentric)")
    asm.add_argument("--degenerate", default="raise", choices=["raise", "skip"],
                     help="zero-volume tets: an error, or no contribution (default: raise)")
    bench = sub.add_parser("bench", help="timings against the floor and the baselines",
                           description="Median timings of tetlap and the baselines installed, "
                                       "side by side, on several kinds of mesh.")
    bench.add_argument("--kinds", nargs="+", choices=["kuhn", "delaunay", "shuffled", "ordered"],
                       help="mesh kinds (default: all four; --quick: kuhn delaunay)")
    bench.add_argument("--sizes", nargs="+", choices=["10k", "100k", "1M", "4M"],
                       help="sizes in tets (default: 100k 1M; --quick: 10k 100k)")
    bench.add_argument("--mesh", nargs="+", metavar="FILE", help="also time these mesh files")
    bench.add_argument("--threads", type=_threads, default=None,
                       help="worker threads (default: all cores)")
    bench.add_argument("--repeat", type=_positive, default=None,
                       help="repetitions, the median is reported (default: 5; --quick: 3)")
    bench.add_argument("--operators", nargs="+", metavar="WORD",
                       help="only cases whose name contains a word, e.g. primal dual Mesh check "
                            "info numpy voronoi scikit (the floor and igl.cotmatrix always run)")
    bench.add_argument("--quick", action="store_true", help="small sizes, fewer repetitions")
    bench.add_argument("--json", action="store_true", help="print JSON records (default: a table)")
    exp = sub.add_parser("experiment", help="reproduce the paper's experiments",
                         description="One of the paper's Sec. 8 and 9 experiments: CSV, PNG, summary.")
    exp.add_argument("name", choices=list(experiments.NAMES))
    exp.add_argument("--quick", action="store_true", help="small sizes (< 2 minutes)")
    exp.add_argument("--out", help="output folder (default: tetlap-experiments/NAME)")
    exp.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    exp.add_argument("--meshes", type=_folder, help="negative-weights, improve: a folder of mesh files")
    imp = sub.add_parser("improve", help="move interior vertices to remove negative dual weights",
                         description="Optimise interior vertex positions (L-BFGS-B) so that "
                                     "fewer interior dual weights are negative; the boundary "
                                     "stays fixed. See tetlap.improve.")
    imp.add_argument("mesh", help="mesh file (any format meshio reads)")
    imp.add_argument("-o", "--output", required=True,
                     help="the improved mesh (format from the extension, e.g. .vtu)")
    imp.add_argument("--margin", type=float, default=0.02,
                     help="penalise dual weights below MARGIN times the mean edge length "
                          "(default: 0.02)")
    imp.add_argument("--iterations", type=_positive, default=200,
                     help="L-BFGS-B iterations (default: 200)")
    imp.add_argument("--step", type=float, default=0.3,
                     help="largest move per coordinate, in shortest incident edges (default: 0.3)")
    imp.add_argument("--threads", type=_threads, default=None,
                     help="worker threads (default: all cores)")
    dist = sub.add_parser("distributed-info",
                          help="under mpirun: counts and checks with PETSc from .npy files")
    dist.add_argument("points", help="(n, d) float .npy file")
    dist.add_argument("tets", help="(m, 4) integer .npy file")
    return p


COMMANDS = {"info": _info, "assemble": _assemble, "experiment": _experiment,
            "improve": _improve, "distributed-info": _distributed_info}


def main(argv: list[str] | None = None) -> int:
    """Run the command; 2 with one line ``tetlap: error: ...`` on stderr for bad input."""
    args = parser().parse_args(argv)
    try:
        if args.command == "bench":
            from . import benchmark

            return benchmark.main(args)
        return COMMANDS[args.command](args)
    except KeyboardInterrupt:
        print("tetlap: interrupted", file=sys.stderr)
        return 130
    except (TetlapError, OSError, ImportError, ValueError) as e:
        print(f"tetlap: error: {e}", file=sys.stderr)
        return 2
