"""``tetlap assemble MESH -o OUTPUT``: L and M as ``scipy.sparse.save_npz`` files."""

from __future__ import annotations

import contextlib

from . import _mesh, _paths

NAME = "assemble"
HELP = "save L and M as scipy .npz files"
DESCRIPTION = "Assemble L and M and save them for scipy.sparse.load_npz."


def arguments(p) -> None:
    p.add_argument("mesh", help="mesh file (any format meshio reads)")
    p.add_argument("-o", "--output", required=True,
                   help="L goes to OUTPUT (.npz appended if missing), M to OUTPUT.mass.npz; "
                        "the folder is created if needed")
    p.add_argument("--laplacian", default="dual",
                   help='"primal", "dual" or a float t in [0, 1] (default: dual)')
    p.add_argument("--mass", default="circumcentric",
                   choices=["barycentric", "circumcentric", "mixed", "fem"],
                   help="mass matrix (default: circumcentric)")
    p.add_argument("--degenerate", default="raise", choices=["raise", "skip"],
                   help="zero-volume tets: an error, or no contribution (default: raise)")


def output_names(output: str) -> tuple[str, str]:
    """The files ``tetlap assemble -o OUTPUT`` writes: L and M (``.npz`` appended when
    missing, as ``scipy.sparse.save_npz`` does)."""
    base = output[:-4] if output.endswith(".npz") else output
    return base + ".npz", base + ".mass.npz"


def kind(text: str):
    """``--laplacian``: a name, or the float ``t`` of the affine family."""
    with contextlib.suppress(ValueError):
        return float(text)
    return text


def check(args) -> None:
    """``--laplacian`` (a name, or t in [0, 1]) before the mesh is read: by the core's own
    check, on one reference tet; then the two output files."""
    check_laplacian(args)
    for name in output_names(args.output):
        _paths.output_file(name, "-o")


def check_laplacian(args) -> None:
    """``--laplacian``: a name, or t in [0, 1] (also ``tetlap geodesic``'s)."""
    from .. import assembly
    from ..errors import OptionError

    try:
        assembly.laplacian([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]],
                           kind(args.laplacian))
    except OptionError as e:
        raise OptionError(f"--laplacian: {e}") from None


def run(args) -> int:
    import scipy.sparse as sp

    from .. import assembly

    V, T, _ = _mesh.load(args.mesh)
    L, M = assembly.operators(V, T, laplacian=kind(args.laplacian), mass=args.mass,
                              degenerate=args.degenerate)
    l_file, m_file = output_names(args.output)
    _paths.make_folder(l_file)
    sp.save_npz(l_file, L)
    sp.save_npz(m_file, M)
    print(f"L ({args.laplacian}, {L.shape[0]} x {L.shape[1]}, {L.nnz} entries) -> "
          f"{_paths.shown(l_file)}")
    print(f"M ({args.mass}) -> {_paths.shown(m_file)}")
    return 0
