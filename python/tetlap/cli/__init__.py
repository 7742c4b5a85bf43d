"""The ``tetlap`` command (also ``python -m tetlap``).

One module per command, each with its ``NAME``, ``HELP`` and ``DESCRIPTION`` (and an
optional ``EPILOG``, a list laid out as written), its
``arguments(parser)``, the ``check(args)`` of its numeric flags (run before any work) and
its ``run(args)``; every table, report and JSON document is formatted in
:mod:`tetlap.cli._output`. The work is done by :mod:`tetlap.info`, :mod:`tetlap.assembly`,
:mod:`tetlap.benchmark`, :mod:`tetlap.experiments`, :mod:`tetlap.improve` and
:mod:`tetlap.distributed`.

    tetlap info [MESH] [--json]      the mesh, both Laplacians' Table 1 properties, regularity
    tetlap assemble MESH -o L.npz    L and M as scipy .npz files
    tetlap bench                     timings against the floor and the baselines
    tetlap experiment NAME           the paper's experiments (CSV + PNG + summary)
    tetlap improve MESH -o OUT       move interior vertices to remove negative dual weights
    tetlap distributed-info P T      (under mpirun) global checks with PETSc, from .npy files
    tetlap geodesic MESH --source I  heat-method distance from source vertices (--out F.vtu)

A command's arguments are added to its parser on first use, so that ``tetlap --version``
and ``tetlap --help`` import neither NumPy nor SciPy.
"""

from __future__ import annotations

import argparse
import sys

from .. import __version__
from ..errors import TetlapError
from . import _output, _threads, assemble, bench, distributed_info, experiment, improve, info
from . import geodesic
from .._names import public_dir

__all__ = ["main", "parser", "COMMANDS"]
__dir__ = public_dir(globals())

#: The commands, in the order of ``tetlap --help``.
COMMANDS = (info, assemble, bench, experiment, improve, distributed_info,
            geodesic)


class _CommandParser(argparse.ArgumentParser):
    """The parser of one command; ``arguments(parser)`` adds its arguments when it is first
    used (to parse, or to print its help)."""

    def __init__(self, *args, arguments=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._arguments = arguments

    def _add_arguments(self) -> None:
        if self._arguments is not None:
            arguments, self._arguments = self._arguments, None
            arguments(self)

    def parse_known_args(self, args=None, namespace=None):
        self._add_arguments()
        return super().parse_known_args(args, namespace)

    def format_usage(self) -> str:
        self._add_arguments()
        return super().format_usage()

    def format_help(self) -> str:
        self._add_arguments()
        return super().format_help()


def parser() -> argparse.ArgumentParser:
    """The argument parser of the ``tetlap`` command."""
    p = argparse.ArgumentParser(
        prog="tetlap", description="Laplace operators of tetrahedral meshes (also: python -m tetlap).")
    p.add_argument("--version", action="version", version=f"tetlap {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND",
                           parser_class=_CommandParser)
    for command in COMMANDS:
        epilog = getattr(command, "EPILOG", None)  # a list, laid out as written
        sub.add_parser(command.NAME, help=command.HELP, description=command.DESCRIPTION,
                       arguments=command.arguments, epilog=epilog,
                       formatter_class=argparse.RawDescriptionHelpFormatter if epilog
                       else argparse.HelpFormatter)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command; 2 with one line ``tetlap: error: ...`` on stderr for bad input
    (a bad flag value among them, found before any work) or for running out of memory,
    130 on Ctrl-C."""
    args = parser().parse_args(argv)
    command = next(c for c in COMMANDS if c.NAME == args.command)
    try:
        command.check(args)
        with _threads.used(getattr(args, "threads", None)):
            return command.run(args)
    except KeyboardInterrupt:
        print("tetlap: interrupted", file=sys.stderr)
        return 130
    except (TetlapError, OSError, ImportError, ValueError) as e:
        print(_output.error_line(e), file=sys.stderr)
        return 2
    except MemoryError as e:
        print(_output.error_line(MemoryError(f"out of memory: {e}")), file=sys.stderr)
        return 2
