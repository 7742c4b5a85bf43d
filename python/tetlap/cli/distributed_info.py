"""``mpirun -n P tetlap distributed-info POINTS TETS``: counts and checks with PETSc from
``.npy`` files (:func:`tetlap.distributed.info`)."""

from __future__ import annotations

from . import _output
from .._names import public_dir

__all__ = ["NAME", "HELP", "DESCRIPTION", "arguments", "check", "run"]
__dir__ = public_dir(globals())

NAME = "distributed-info"
HELP = "under mpirun: counts and checks with PETSc from .npy files"
DESCRIPTION = ("Under mpirun (mpirun -n P tetlap distributed-info points.npy tets.npy): each "
               "rank reads its share of a mesh stored as .npy files, the primal and the "
               "dual Laplacian are assembled into distributed PETSc matrices, and rank 0 "
               "prints one JSON object: the global counts, and per operator the symmetry "
               "error, the largest row sum, the fraction of negative weights, the linear "
               "precision residual and whether every entry is finite (Table 1's checks "
               "that work distributed). Needs petsc4py, slepc4py and mpi4py "
               "(tetlap.distributed).")


def arguments(p) -> None:
    p.add_argument("points", help="the vertices, an (n, d) float .npy file")
    p.add_argument("tets", help="the tets, an (m, 4) integer .npy file")


def check(args) -> None:
    """No numeric flags."""


def run(args) -> int:
    from .. import distributed

    result = distributed.info(args.points, args.tets)
    from mpi4py import MPI

    if MPI.COMM_WORLD.Get_rank() == 0:
        print(_output.json_document(result))
    return 0
