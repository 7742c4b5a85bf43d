"""Long calls into NumPy/SciPy that hold no GIL, run so that Ctrl-C still answers at once."""

from __future__ import annotations

import concurrent.futures
from typing import Callable, TypeVar

R = TypeVar("R")


def interruptible(f: Callable[..., R], *args, **kwargs) -> R:
    """``f(*args, **kwargs)`` on a helper thread while this thread waits in short slices,
    so that a KeyboardInterrupt reaches the caller within 0.1 s. ``f`` must release the GIL
    (LAPACK and SuperLU do); an interrupted call finishes in the background and its result
    is dropped."""
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=1)
    job = pool.submit(f, *args, **kwargs)
    pool.shutdown(wait=False)
    while True:
        try:
            return job.result(timeout=0.1)
        except concurrent.futures.TimeoutError:
            continue
