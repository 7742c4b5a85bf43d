"""Long calls that answer Ctrl-C within a second and leave the process free.

A thread cannot be stopped: a computation abandoned on one runs on, spends CPU and, on a
non-daemon thread, delays the interpreter's exit until it ends. So:

* :func:`forked` runs a call in a forked child process (Linux) whose result comes back
  through shared memory; Ctrl-C kills the child (SIGKILL) and reaps it before the
  KeyboardInterrupt is raised, and the child dies with this process (``PR_SET_PDEATHSIG``:
  a SIGTERM or SIGKILL of this process leaves no orphan and no file).
* :func:`splu` and :func:`spsolve`: SciPy's SuperLU that way (from :data:`CHILD_MIN_ROWS`
  rows); :func:`splu` brings the factors back for solves in this process
  (:class:`tetlap._core.LU`). :func:`eigvalsh`: NumPy's dense eigenvalues that way (from
  :data:`DENSE_CHILD_MIN` rows).
* :func:`interruptible` waits for a call on a daemon thread: for calls that release the GIL
  and end soon (dense LAPACK, linprog), and where fork is not available (Windows, macOS),
  where an interrupted call finishes in the background and its result is dropped.

The core's own factorization (``tetlap._core.Factor``) forks from Rust in the same way.
"""

from __future__ import annotations

import ctypes
import functools
import os
import pickle
import signal
import struct
import sys
import threading
import time
from typing import Callable, TypeVar

import numpy as np

from . import _core

R = TypeVar("R")

#: Whether :func:`forked` runs its call in a child process (Linux: fork and memfd).
FORK = sys.platform.startswith("linux") and hasattr(os, "fork") and hasattr(os, "memfd_create")

#: From this many rows on, :func:`splu` and :func:`spsolve` run SuperLU in a child process:
#: below it SuperLU ends within about 0.2 s (a KKT system of 1000 rows, the densest the
#: solvers build; 0.01 s for a Laplacian's), soon enough for Ctrl-C, and the fork would
#: cost as much (BENCHMARKS.md, "Ctrl-C during a factorization").
CHILD_MIN_ROWS = 1000

#: From this order on, :func:`eigvalsh` runs in a child process (LAPACK on one thread: 0.2 s
#: at 1000, 2 s at 2500).
DENSE_CHILD_MIN = 1000

_PR_SET_PDEATHSIG = 1


def interruptible(f: Callable[..., R], *args, **kwargs) -> R:
    """``f(*args, **kwargs)`` on a daemon thread while this thread waits in slices of
    0.05 s, so that a KeyboardInterrupt reaches the caller at once if ``f`` releases the GIL
    (LAPACK and HiGHS do). An interrupted call finishes in the background and its result is
    dropped; being a daemon thread, it never delays the interpreter's exit."""
    done = threading.Event()
    outcome: list = []

    def run() -> None:
        try:
            outcome.append((True, f(*args, **kwargs)))
        except BaseException as e:  # handed to the caller
            outcome.append((False, e))
        finally:
            done.set()

    threading.Thread(target=run, name="tetlap-interruptible", daemon=True).start()
    while not done.wait(0.05):
        pass
    ok, value = outcome[0]
    if not ok:
        raise value
    return value


def forked(f: Callable[..., R], *args, **kwargs) -> R:
    """``f(*args, **kwargs)`` in a forked child process (where :data:`FORK`; elsewhere, or
    if the fork fails, :func:`interruptible`). The result (any picklable value; NumPy
    arrays travel as their bytes, out of the pickle) or the exception ``f`` raised comes back
    through an anonymous memory file (``memfd_create``), read once the child has ended.
    This thread waits in slices of at most 0.05 s; on Ctrl-C (any exception while waiting)
    the child is killed (SIGKILL) and reaped before the exception goes on. The child
    ignores SIGINT and dies with this process.

    ``f`` must not need threads of this process (the child has only the calling one): NumPy,
    SciPy's SuperLU and METIS are fine. A child killed from outside (such as by the system's
    out-of-memory killer) raises MemoryError for SIGKILL, else ChildProcessError.
    """
    if not FORK:
        return interruptible(f, *args, **kwargs)
    libc = _libc()
    fd = os.memfd_create("tetlap-child", os.MFD_CLOEXEC)
    pid, parent = 0, os.getpid()
    # SIGINT blocked in this thread across the fork: the child starts with it blocked and
    # ignores it before anything else; here it is unblocked inside the try
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        try:
            pid = os.fork()
            if pid == 0:  # pragma: no cover (the child: it never leaves this block)
                try:
                    _child(fd, libc, parent, f, args, kwargs)
                finally:
                    os._exit(1)
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
            status = _wait(pid)
        except BaseException as e:
            if pid:
                _kill(pid)
            elif isinstance(e, OSError):  # fork: no memory for the page tables, no pid left
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)
                return interruptible(f, *args, **kwargs)
            raise
        return _result(fd, status, getattr(f, "__name__", "the call"))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        os.close(fd)


@functools.cache
def _libc():
    """The C library (for ``prctl``), loaded before any fork."""
    return ctypes.CDLL(None, use_errno=True)


def _child(fd: int, libc, parent: int, f, args, kwargs) -> None:  # pragma: no cover
    """The child's whole life: die with the parent, ignore SIGINT, run ``f``, write
    ``(ok, value)`` to ``fd``, ``_exit``."""
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:   # the parent died before prctl
        os._exit(1)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    try:
        outcome = (True, f(*args, **kwargs))
    except BaseException as e:
        outcome = (False, e)
    buffers: list = []
    try:
        head = pickle.dumps(outcome, protocol=5, buffer_callback=buffers.append)
    except Exception:   # an exception that does not pickle: its text
        buffers = []
        head = pickle.dumps((False, RuntimeError(f"{type(outcome[1]).__name__}: {outcome[1]}")),
                            protocol=5)
    raws = [b.raw() for b in buffers]
    with open(fd, "wb", closefd=False) as out:
        out.write(struct.pack("<QQ", len(head), len(raws)))
        out.write(struct.pack(f"<{len(raws)}Q", *(r.nbytes for r in raws)))
        out.write(head)
        for r in raws:
            out.write(r)
    os._exit(0)


def _wait(pid: int) -> int:
    """The wait status of the child ``pid``, polled in slices from 1 ms to 0.05 s."""
    pause = 0.001
    while True:
        try:
            done, status = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:  # reaped elsewhere (SIGCHLD ignored): its output tells
            return 0
        if done:
            return status
        time.sleep(pause)
        pause = min(2 * pause, 0.05)


def _kill(pid: int) -> None:
    """Kills the child ``pid`` and reaps it (a second Ctrl-C does not stop the reaping)."""
    os.kill(pid, signal.SIGKILL)
    while True:
        try:
            os.waitpid(pid, 0)
            return
        except KeyboardInterrupt:
            continue
        except ChildProcessError:
            return


def _result(fd: int, status: int, what: str):
    """The child's value (or its exception, raised here) read from ``fd``."""
    size = os.fstat(fd).st_size
    if not (os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0 and size >= 16):
        if os.WIFSIGNALED(status):
            sig = signal.Signals(os.WTERMSIG(status))
            if sig == signal.SIGKILL:
                raise MemoryError(f"{what} was killed in its child process (SIGKILL: out of "
                                  "memory?)")
            raise ChildProcessError(f"{what} ended its child process by {sig.name}")
        raise ChildProcessError(f"{what} failed in its child process")
    n_head, n_raw = struct.unpack("<QQ", _read(fd, 16, 0))
    sizes = struct.unpack(f"<{n_raw}Q", _read(fd, 8 * n_raw, 16))
    at = 16 + 8 * n_raw
    if at + n_head + sum(sizes) != size:
        raise ChildProcessError(f"{what} left an incomplete result in its child process")
    head = _read(fd, n_head, at)
    at += n_head
    buffers = []
    for nbytes in sizes:
        buffers.append(_read(fd, nbytes, at))
        at += nbytes
    ok, value = pickle.loads(head, buffers=buffers)
    if not ok:
        raise value
    return value


def _read(fd: int, nbytes: int, offset: int) -> bytearray:
    """``nbytes`` of ``fd`` from ``offset``, in a new (writable) buffer."""
    out = bytearray(nbytes)
    view, done = memoryview(out), 0
    while done < nbytes:
        got = os.preadv(fd, [view[done:]], offset + done)
        if got <= 0:
            raise ChildProcessError("the result of a child process ended early")
        done += got
    return out


def eigvalsh(A: np.ndarray) -> np.ndarray:
    """NumPy's ``eigvalsh(A)`` of a dense symmetric ``A``, in a child process from
    :data:`DENSE_CHILD_MIN` rows (below, on a daemon thread: :func:`interruptible`)."""
    run = forked if len(A) >= DENSE_CHILD_MIN else interruptible
    return run(np.linalg.eigvalsh, A)


def spsolve(A, b) -> np.ndarray:
    """SciPy's ``spsolve(A, b)`` (SuperLU), in a child process from :data:`CHILD_MIN_ROWS`
    rows: the same answer, bitwise."""
    from scipy.sparse.linalg import spsolve as superlu

    if A.shape[0] < CHILD_MIN_ROWS:
        return superlu(A, b)
    return forked(superlu, A, b)


class SuperLU:
    """The factors ``Pr A Pc = L U`` of SciPy's SuperLU, solved with in this process by
    :class:`tetlap._core.LU`: ``solve(b)`` for ``b`` of shape ``(n,)`` or ``(n, k)``,
    ``perm_r``, ``perm_c``, ``L``, ``U`` and ``shape`` as in ``scipy.sparse.linalg.SuperLU``
    (made by :func:`splu`)."""

    def __init__(self, factors, perm_r: np.ndarray, perm_c: np.ndarray) -> None:
        self.shape = (len(perm_r), len(perm_r))
        self.perm_r, self.perm_c = perm_r, perm_c
        self._core = _core.LU(len(perm_r), *factors, perm_r.astype(np.int64),
                              perm_c.astype(np.int64))

    def solve(self, b) -> np.ndarray:
        b = np.asarray(b, dtype=np.float64)
        x = self._core.solve(np.ascontiguousarray(b.reshape(self.shape[0], -1).T))
        return x.T.reshape(b.shape)

    def _factor(self, upper: bool):
        import scipy.sparse as sp

        return sp.csc_array(self._core.factor(upper), shape=self.shape)

    @property
    def L(self):
        return self._factor(False)

    @property
    def U(self):
        return self._factor(True)


def _superlu_factors(A, options: dict):
    """SuperLU's factors of ``A``: ``((L arrays), (U arrays), perm_r, perm_c)``, each factor
    as sorted CSC arrays ``(data, indices, indptr)``."""
    from scipy.sparse.linalg import splu as superlu

    lu = superlu(A, **options)
    factors = []
    for M in (lu.L, lu.U):
        M.sort_indices()
        factors.append((M.data, M.indices.astype(np.int64), M.indptr.astype(np.int64)))
    return tuple(factors), lu.perm_r, lu.perm_c


def splu(A, **options) -> SuperLU:
    """SciPy's ``splu(A, **options)`` (SuperLU), in a child process from
    :data:`CHILD_MIN_ROWS` rows, its factors brought back: a :class:`SuperLU`. SuperLU's
    errors (``RuntimeError("Factor is exactly singular")``) are raised as they are."""
    run = forked if A.shape[0] >= CHILD_MIN_ROWS else (lambda g, *a: g(*a))
    factors, perm_r, perm_c = run(_superlu_factors, A, options)
    return SuperLU(factors, perm_r, perm_c)
