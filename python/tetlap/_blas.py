"""The BLAS held to one thread around dense and sparse linear algebra: tetlap's own
threads, and other processes on the machine, would make more BLAS threads spin against
each other, and on vectors of a mesh's size they cost more than they give.

>>> from tetlap._blas import one_blas_thread
>>> with one_blas_thread():
...     pass
"""

from __future__ import annotations

import contextlib


@contextlib.contextmanager
def one_blas_thread():
    """A context in which the BLAS (and OpenMP) libraries run on one thread; a no-op
    without threadpoolctl."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield
        return
    with threadpool_limits(1):
        yield
