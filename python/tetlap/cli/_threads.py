"""The ``--threads N`` flag of the commands: checked with the other flags before any work,
then the thread count of every computation of the command (through ``RAYON_NUM_THREADS``,
which ``threads=None`` follows), those without a ``threads`` keyword included."""

from __future__ import annotations

import contextlib
import os

#: The variable that ``threads=None`` follows (``tetlap::THREADS_VARIABLE``).
VARIABLE = "RAYON_NUM_THREADS"


def argument(p) -> None:
    """Adds ``--threads N`` to a command's parser."""
    p.add_argument("--threads", type=int, default=None, metavar="N",
                   help="worker threads, 1 to tetlap.MAX_THREADS (default: "
                        f"{VARIABLE} if set, else all cores)")


@contextlib.contextmanager
def used(count: int | None):
    """``count`` threads (checked before) for everything inside, then the environment as
    it was."""
    if count is None:
        yield
        return
    before = os.environ.get(VARIABLE)
    os.environ[VARIABLE] = str(count)
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(VARIABLE, None)
        else:
            os.environ[VARIABLE] = before
