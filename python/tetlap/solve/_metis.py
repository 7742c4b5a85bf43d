"""METIS's nested dissection (pymetis), in a child process for large graphs: pymetis holds
the GIL for its whole call (2.4 s at 1M tets), so in this process Ctrl-C could not be
answered during it. The child is forked (:func:`tetlap._interrupt.forked`): it reads the
graph from the memory it shares with this process and sends the order back through an
anonymous shared-memory file, so no file is left behind; Ctrl-C kills it, and it dies with
this process (a SIGTERM or SIGKILL of this process leaves no orphan). Where fork is not
available (Windows, macOS) METIS runs in this process, and Ctrl-C waits for it."""

from __future__ import annotations

import numpy as np

from .._interrupt import FORK, forked


def order(xadj: np.ndarray, adjncy: np.ndarray) -> np.ndarray | None:
    """The nested-dissection order (int64) of the graph ``(xadj, adjncy)`` (int32 CSR of a
    symmetric pattern without self-loops: METIS hangs or crashes on any other), or None
    when METIS fails."""
    import pymetis

    try:
        perm, _ = pymetis.nested_dissection(adjacency=pymetis.CSRAdjacency(xadj, adjncy))
    except RuntimeError:  # pybind11's "unknown exception" from METIS
        return None
    return np.asarray(perm, dtype=np.int64)


def order_in_child(xadj: np.ndarray, adjncy: np.ndarray) -> np.ndarray | None:
    """:func:`order` in a child process (Ctrl-C kills it and raises KeyboardInterrupt
    here); None if METIS or the child fails."""
    if not FORK:
        return order(xadj, adjncy)
    try:
        return forked(order, xadj, adjncy)
    except (ChildProcessError, MemoryError):
        return None
