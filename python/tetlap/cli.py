"""The ``tetlap`` command (also ``python -m tetlap``).

    tetlap info [MESH] [--json]    properties of both Laplacians on a mesh file
                                   (a built-in random Delaunay ball when MESH is omitted)
    tetlap assemble MESH -o L.npz  save L (and M to L.mass.npz) for scipy.sparse.load_npz
    tetlap bench [--sizes ...] [--operators ...]  timings against the floor and baselines
    tetlap experiment NAME         the paper's experiments (CSV + PNG + summary)
    tetlap improve MESH -o OUT     move interior vertices to remove negative dual weights
    tetlap distributed-info P T    (under mpirun) global checks with PETSc, from .npy files
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from . import assembly, diagnostics, meshes
from .properties import check

_KINDS = ("primal", "dual")


def _load(path: str | None):
    if path is None:
        V, T = meshes.ball(2000, seed=0)
        return V, T, "built-in random Delaunay ball (n=2000, seed=0)"
    from . import io

    V, T = io.read(path)
    return V, T, path


def info(V, T, *, nsd: bool = True) -> dict:
    """Counts, boundary, mesh quality and the Table-1 checks of both Laplacians and both
    lumped masses, as one JSON-ready dict."""
    n = V.shape[0]
    boundary = diagnostics.boundary_vertices(T, n)
    orientation = diagnostics.orientation(V, T) if V.shape[1] == 3 else None
    result = {
        "n_vertices": int(n),
        "n_tets": int(T.shape[0]),
        "n_boundary_vertices": int(boundary.sum()),
        "n_boundary_faces": int(len(diagnostics.boundary_faces(T))),
        "n_unreferenced_vertices": int((~diagnostics.referenced_vertices(T, n)).sum()),
        "n_positive_tets": None if orientation is None else int((orientation > 0).sum()),
        "n_negative_tets": None if orientation is None else int((orientation < 0).sum()),
        "n_degenerate_tets": int(diagnostics.degenerate_tets(V, T).sum()),
        "n_duplicate_tets": int(diagnostics.duplicate_tets(T).sum()),
        "n_nonmanifold_faces": int(len(diagnostics.nonmanifold_faces(T))),
    }
    if V.shape[1] == 3:
        flags = diagnostics.non_delaunay_faces(V, T)
        dihedral = diagnostics.dihedral_angles(V, T)
        result.update({
            "n_interior_faces": int(len(flags)),
            "non_delaunay_face_fraction": float(flags.mean()) if len(flags) else 0.0,
            "non_delaunay_tet_fraction": float(diagnostics.non_delaunay_tets(V, T).mean()),
            "min_dihedral_deg": float(np.nanmin(dihedral)),
            "max_dihedral_deg": float(np.nanmax(dihedral)),
            "well_centered_tet_fraction": float(diagnostics.well_centered(V, T).mean()),
        })
    else:
        result.update({"n_interior_faces": None, "non_delaunay_face_fraction": None,
                       "non_delaunay_tet_fraction": None, "min_dihedral_deg": None,
                       "max_dihedral_deg": None, "well_centered_tet_fraction": None})
    for kind in _KINDS:
        L = assembly.laplacian(V, T, kind)
        r = check(L, V, T, nsd=nsd)
        result[kind] = {
            "symmetric": r.symmetric,
            "max_row_sum": r.max_row_sum,
            "linear_precision_residual": r.linear_precision_residual,
            "nsd": r.nsd,
            "nsd_method": r.nsd_method,
            "min_weight": r.min_weight,
            "negative_weight_fraction": r.negative_fraction,
            "negative_weight_fraction_interior": r.negative_fraction_interior,
            "finite": r.finite,
        }
    masses = {}
    for kind in ("barycentric", "circumcentric"):
        m = assembly.mass(V, T, kind).diagonal()
        masses[kind] = {"total": float(m.sum()), "min": float(m.min())}
    masses["mesh_volume"] = float(np.abs(diagnostics.signed_volumes(V, T)).sum())
    result["mass"] = masses
    return result


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, bool):
        return "yes" if v else "NO"
    if isinstance(v, float):
        return f"{v:.3e}"
    return str(v)


def _print_info(result: dict, source: str) -> None:
    print(f"mesh: {source}")
    print(f"{result['n_vertices']} vertices ({result['n_boundary_vertices']} on the boundary, "
          f"{result['n_unreferenced_vertices']} unreferenced), {result['n_tets']} tets "
          f"({result['n_positive_tets']} positive, {result['n_negative_tets']} negative, "
          f"{result['n_degenerate_tets']} degenerate, {result['n_duplicate_tets']} duplicate; "
          f"{result['n_nonmanifold_faces']} non-manifold faces)")
    if result["non_delaunay_face_fraction"] is not None:
        print(f"non-Delaunay interior faces: {100 * result['non_delaunay_face_fraction']:.2f}% "
              f"of {result['n_interior_faces']} (tets: "
              f"{100 * result['non_delaunay_tet_fraction']:.2f}%); dihedral angles "
              f"{result['min_dihedral_deg']:.2f}..{result['max_dihedral_deg']:.2f} deg; "
              f"well-centered tets: {100 * result['well_centered_tet_fraction']:.2f}%")
    rows = [
        ("finite", "finite"),
        ("symmetric", "symmetric"),
        ("max |row sum|", "max_row_sum"),
        ("linear precision residual", "linear_precision_residual"),
        ("negative semidefinite", "nsd"),
        ("min weight", "min_weight"),
        ("negative weights", "negative_weight_fraction"),
        ("  not both on boundary", "negative_weight_fraction_interior"),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"\n{'property':<{width}}  {'primal':>12}  {'dual':>12}")
    for label, key in rows:
        cells = []
        for kind in _KINDS:
            v = result[kind][key]
            cells.append(f"{100 * v:.2f}%" if "fraction" in key else _fmt(v))
        print(f"{label:<{width}}  {cells[0]:>12}  {cells[1]:>12}")
    m = result["mass"]
    print(f"\nmass         {'total':>14}  {'min':>12}   (mesh volume {m['mesh_volume']:.10g})")
    for kind in ("barycentric", "circumcentric"):
        print(f"{kind:<12} {m[kind]['total']:>14.10g}  {m[kind]['min']:>12.3e}")


def mass_output(output: str) -> str:
    """Where ``tetlap assemble -o OUTPUT`` writes the mass matrix."""
    return output[:-4] + ".mass.npz" if output.endswith(".npz") else output + ".mass.npz"


def _assemble(args) -> int:
    import scipy.sparse as sp

    from . import io

    kind = args.laplacian
    try:
        kind = float(kind)
    except ValueError:
        pass
    try:
        V, T = io.read(args.mesh)
        L, M = assembly.operators(V, T, laplacian=kind, mass=args.mass,
                                  degenerate=args.degenerate)
        sp.save_npz(args.output, L)
        sp.save_npz(mass_output(args.output), M)
    except (ValueError, OSError, ImportError) as e:
        print(f"tetlap: error: {e}", file=sys.stderr)
        return 2
    print(f"L ({args.laplacian}, {L.shape[0]} x {L.shape[1]}, {L.nnz} entries) -> {args.output}")
    print(f"M ({args.mass}) -> {mass_output(args.output)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="tetlap", description="Laplace operators of tetrahedral meshes (also: python -m tetlap).")
    sub = parser.add_subparsers(dest="command", required=True)
    p_info = sub.add_parser("info", help="properties of both Laplacians on a mesh")
    p_info.add_argument("mesh", nargs="?", help="mesh file (any format meshio reads)")
    p_info.add_argument("--json", action="store_true", help="print one JSON object")
    p_info.add_argument("--no-nsd", action="store_true",
                        help="skip the semidefiniteness check (the slowest one)")
    p_asm = sub.add_parser("assemble", help="save L and M as scipy .npz files")
    p_asm.add_argument("mesh", help="mesh file (any format meshio reads)")
    p_asm.add_argument("-o", "--output", required=True,
                       help="L goes to OUTPUT, M to OUTPUT with .npz replaced by .mass.npz")
    p_asm.add_argument("--laplacian", default="dual",
                       help='"primal", "dual" (default) or t in [0, 1]')
    p_asm.add_argument("--mass", default="circumcentric",
                       choices=["barycentric", "circumcentric", "fem"])
    p_asm.add_argument("--degenerate", default="raise", choices=["raise", "skip"])
    p_bench = sub.add_parser("bench", help="timings against the floor and the baselines")
    p_bench.add_argument("--sizes", nargs="+", choices=["10k", "100k", "1M", "4M"],
                         help="Kuhn-grid sizes in tets (default 10k 100k 1M; --quick: 10k 100k)")
    p_bench.add_argument("--threads", type=int, default=None, help="worker threads (default: all)")
    p_bench.add_argument("--repeat", type=int, default=None, help="repetitions (median reported)")
    p_bench.add_argument("--operators", nargs="+", metavar="WORD",
                         help="only cases whose name contains a word, e.g. primal dual "
                              "mass Mesh igl (the floor and igl.cotmatrix always run)")
    p_bench.add_argument("--quick", action="store_true", help="small sizes, fast baselines only")
    p_bench.add_argument("--json", action="store_true", help="print JSON records")
    p_exp = sub.add_parser("experiment", help="reproduce the paper's experiments")
    p_exp.add_argument("name", choices=["dirichlet-shell", "eigen-ball", "negative-weights",
                                        "sphere3", "flips"])
    p_exp.add_argument("--quick", action="store_true", help="small sizes (< 2 minutes)")
    p_exp.add_argument("--out", help="output folder (default tetlap-experiments/NAME)")
    p_exp.add_argument("--seed", type=int, default=0)
    p_exp.add_argument("--meshes", help="negative-weights: a folder of mesh files")
    from . import improve as _improve

    _improve.add_arguments(sub.add_parser(
        "improve", help="move interior vertices to remove negative dual weights"))
    p_dist = sub.add_parser("distributed-info",
                            help="under mpirun: counts and checks with PETSc from .npy files")
    p_dist.add_argument("points", help="(n, d) float .npy file")
    p_dist.add_argument("tets", help="(m, 4) integer .npy file")
    args = parser.parse_args(argv)

    if args.command == "distributed-info":
        from . import distributed

        result = distributed.info(args.points, args.tets)
        from mpi4py import MPI

        if MPI.COMM_WORLD.Get_rank() == 0:
            print(json.dumps(result, indent=2))
        return 0

    if args.command == "experiment":
        from . import experiments

        folder = experiments.run(args.name, quick=args.quick, out=args.out, seed=args.seed,
                                 meshes=args.meshes)
        print((folder / "summary.txt").read_text(), end="")
        print(f"files: {', '.join(sorted(p.name for p in folder.iterdir()))} in {folder}")
        return 0

    if args.command == "improve":
        return _improve.main(args)

    if args.command == "bench":
        from . import benchmark

        return benchmark.main(args)

    if args.command == "assemble":
        return _assemble(args)
    if args.command == "info":
        try:
            V, T, source = _load(args.mesh)
            result = info(V, T, nsd=not args.no_nsd)
        except (ValueError, OSError, ImportError) as e:
            print(f"tetlap: error: {e}", file=sys.stderr)
            return 2
        if args.json:
            print(json.dumps({"source": source, **result}, indent=2))
        else:
            _print_info(result, source)
    return 0
