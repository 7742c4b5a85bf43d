"""``mpirun -n P tetlap distributed-info POINTS TETS``: counts and checks with PETSc from
``.npy`` files (:func:`tetlap.distributed.info`)."""

from __future__ import annotations

from . import _output

NAME = "distributed-info"
HELP = "under mpirun: counts and checks with PETSc from .npy files"
DESCRIPTION = None


def arguments(p) -> None:
    p.add_argument("points", help="(n, d) float .npy file")
    p.add_argument("tets", help="(m, 4) integer .npy file")


def check(args) -> None:
    """No numeric flags."""


def run(args) -> int:
    from .. import distributed

    result = distributed.info(args.points, args.tets)
    from mpi4py import MPI

    if MPI.COMM_WORLD.Get_rank() == 0:
        print(_output.json_document(result))
    return 0
