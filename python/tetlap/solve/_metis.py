"""METIS's nested dissection (pymetis), in a child process for large graphs: pymetis holds
the GIL for its whole call (2.4 s at 1M tets), so in this process Ctrl-C could not be
answered during it. The child is ``python -m tetlap.solve._metis`` (not multiprocessing,
which would re-import the user's main script), given the graph in a temporary file and
killed on Ctrl-C."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import numpy as np


def order(xadj: np.ndarray, adjncy: np.ndarray) -> np.ndarray:
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
    """:func:`order` in a child process, waiting in slices of 0.1 s (Ctrl-C kills the
    child and raises KeyboardInterrupt here); None if the child fails."""
    with tempfile.TemporaryDirectory() as folder:
        graph, result = os.path.join(folder, "graph.npz"), os.path.join(folder, "order.npy")
        np.savez(graph, xadj=xadj, adjncy=adjncy)
        p = subprocess.Popen([sys.executable, "-m", "tetlap.solve._metis", graph, result],
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        try:
            while True:
                try:
                    p.wait(timeout=0.1)
                    break
                except subprocess.TimeoutExpired:
                    continue
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        return np.load(result) if p.returncode == 0 else None


if __name__ == "__main__":
    data = np.load(sys.argv[1])
    perm = order(data["xadj"], data["adjncy"])
    if perm is None:
        sys.exit(1)
    np.save(sys.argv[2], perm)
