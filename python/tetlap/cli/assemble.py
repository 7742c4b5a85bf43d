"""``tetlap assemble MESH -o OUTPUT``: L and M as ``scipy.sparse.save_npz`` files."""

from __future__ import annotations

import contextlib
import os
import sys

from . import _mesh, _paths, _threads
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "output_names", "kind", "check",
           "check_laplacian", "run"]
__dir__ = public_dir(globals())

NAME = "assemble"
HELP = "save L and M as scipy .npz files"
DESCRIPTION = "Assemble L and M and save them for scipy.sparse.load_npz."


def arguments(p) -> None:
    p.add_argument("mesh", help="mesh file (any format meshio reads)")
    p.add_argument("-o", "--output", required=True,
                   help="L goes to OUTPUT (.npz appended if missing), M to OUTPUT.mass.npz; "
                        "the folder is created if needed; a folder alone (DIR/) gets "
                        "DIR/MESHNAME.npz and DIR/MESHNAME.mass.npz")
    p.add_argument("--laplacian", default="primal",
                   help='"primal", "dual" or a float t in [0, 1] (default: primal, as '
                        'tetlap.operators)')
    p.add_argument("--mass", default="barycentric",
                   choices=["barycentric", "circumcentric", "mixed", "fem"],
                   help="mass matrix (default: barycentric, as tetlap.operators); "
                        "circumcentric masses can be negative on non-Delaunay meshes (a "
                        "warning says how many), mixed ones are the positive dual masses")
    p.add_argument("--degenerate", default="raise", choices=["raise", "skip"],
                   help="zero-volume tets: an error, or no contribution (default: raise)")
    p.add_argument("--coefficient", metavar="X", help=_mesh.COEFFICIENT_HELP)
    _threads.argument(p)


def output_names(output: str, mesh: str = "operators") -> tuple[str, str]:
    """The files ``tetlap assemble -o OUTPUT`` writes: L and M (``.npz`` appended when
    missing, as ``scipy.sparse.save_npz`` does); an OUTPUT that names a folder only
    (``out/``, ``.``) holds them under the mesh's name (``-o out/`` wrote the hidden files
    ``out/.npz`` and ``out/.mass.npz``)."""
    base = output[:-4] if output.endswith(".npz") else output
    if os.path.basename(base) in ("", ".", ".."):
        base = os.path.join(base, _mesh.name(mesh))
    return base + ".npz", base + ".mass.npz"


def kind(text: str):
    """``--laplacian``: a name, or the float ``t`` of the affine family."""
    with contextlib.suppress(ValueError):
        return float(text)
    return text


def check(args) -> None:
    """``--threads``, ``--laplacian`` (a name, or t in [0, 1]) before the mesh is read: by
    the core's own check, on one reference tet; then the two output files."""
    from .. import _options

    _options.threads(args.threads, "--threads")
    check_laplacian(args)
    for name in output_names(args.output, args.mesh):
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
    """Everything is computed before the first file is written: a command that fails
    leaves no file behind, and one that wrote its files succeeded."""
    import scipy.sparse as sp

    from .. import assembly, diagnostics

    V, T, _ = _mesh.load(args.mesh)
    L, M = assembly.operators(V, T, laplacian=kind(args.laplacian), mass=args.mass,
                              degenerate=args.degenerate,
                              coefficient=_mesh.coefficient(args.coefficient, args.mesh, V, T))
    bad = int((M.diagonal()[diagnostics.referenced_vertices(V, T)] <= 0).sum())
    l_file, m_file = output_names(args.output, args.mesh)
    _paths.make_folder(l_file)
    sp.save_npz(l_file, L)
    sp.save_npz(m_file, M)
    print(f"L ({args.laplacian}, {L.shape[0]} x {L.shape[1]}, {L.nnz} entries) -> "
          f"{_paths.shown(l_file)}")
    print(f"M ({args.mass}) -> {_paths.shown(m_file)}")
    if bad:
        print(f"tetlap: warning: M ({args.mass}) has {bad} non-positive diagonal entries at "
              "vertices of the mesh (circumcentres outside their elements: a mesh that is not "
              "Delaunay, or obtuse elements at its boundary); --mass mixed gives positive dual "
              "masses", file=sys.stderr)
    return 0
