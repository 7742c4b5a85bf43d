"""The ``tetlap`` command (also ``python -m tetlap``).

    tetlap info [MESH] [--json]    properties of both Laplacians on a mesh file
                                   (a built-in random Delaunay ball when MESH is omitted)
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


def info(V, T) -> dict:
    """Counts, boundary and the Table-1 checks of both Laplacians and both lumped masses."""
    n = V.shape[0]
    boundary = diagnostics.boundary_vertices(T, n)
    result = {
        "n_vertices": int(n),
        "n_tets": int(T.shape[0]),
        "n_boundary_vertices": int(boundary.sum()),
        "n_unreferenced_vertices": int((~diagnostics.referenced_vertices(T, n)).sum()),
    }
    for kind in _KINDS:
        L = assembly.laplacian(V, T, kind)
        r = check(L, V, T)
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
          f"{result['n_unreferenced_vertices']} unreferenced), {result['n_tets']} tets")
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="tetlap", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p_info = sub.add_parser("info", help="properties of both Laplacians on a mesh")
    p_info.add_argument("mesh", nargs="?", help="mesh file (any format meshio reads)")
    p_info.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)

    if args.command == "info":
        try:
            V, T, source = _load(args.mesh)
            result = info(V, T)
        except (ValueError, OSError, ImportError) as e:
            print(f"tetlap: error: {e}", file=sys.stderr)
            return 2
        if args.json:
            print(json.dumps({"source": source, **result}, indent=2))
        else:
            _print_info(result, source)
    return 0
