"""METIS's nested dissection (pymetis) in a child process: pymetis holds the GIL for its
whole call (2.4 s at 1M tets), so in this process Ctrl-C could not be answered during it.
The child is started with ``spawn`` (no fork of a process with threads) and killed on
Ctrl-C."""

from __future__ import annotations

import multiprocessing

import numpy as np


def order(xadj: np.ndarray, adjncy: np.ndarray) -> np.ndarray:
    """The nested-dissection order (int64) of the graph ``(xadj, adjncy)`` (int32 CSR)."""
    import pymetis

    perm, _ = pymetis.nested_dissection(adjacency=pymetis.CSRAdjacency(xadj, adjncy))
    return np.asarray(perm, dtype=np.int64)


def order_in_child(xadj: np.ndarray, adjncy: np.ndarray) -> np.ndarray:
    """:func:`order` in a child process, waiting in slices of 0.1 s (Ctrl-C ends the
    child and raises KeyboardInterrupt here)."""
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        job = pool.apply_async(order, (xadj, adjncy))
        while True:
            try:
                return job.get(timeout=0.1)
            except multiprocessing.TimeoutError:
                continue
