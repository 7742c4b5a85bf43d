"""Thick-restart block Lanczos on a shift-inverted pencil: the search of :func:`tetlap.solve.eigs`.

For ``A v = lambda B v`` (``A``, ``B`` symmetric, ``B`` positive definite) and a shift
``s``, the operator ``T = (A - s B)^-1 B`` is self-adjoint in the ``B`` inner product, with
eigenvalues ``theta = 1 / (lambda - s)``: the eigenvalues nearest ``s`` are its largest in
magnitude, which Krylov methods find first. The search builds a ``B``-orthonormal basis
``V`` of a block Krylov space of ``T``, one block of ``b`` vectors per step (one solve
with ``b`` right-hand sides: the factorization's multi-right-hand-side solve costs a
fraction per vector of a single solve), keeping the Krylov decomposition

    T V_m = V_m H_m + Q R E^T        (H_m = V_m^T B T V_m, symmetric)

where ``Q`` is the next block and ``E^T`` selects the last block's columns. The Ritz pairs
``(theta, V_m u)`` of ``H_m`` (LAPACK's symmetric eigensolver) have the residual ``|T y -
theta y|_B = |R u_last|``, known without a further solve. When the basis is full it is
restarted from the wanted Ritz vectors (the Krylov-Schur restart, which for a symmetric
``T`` is the thick restart of Wu and Simon); converged ones are locked (their coupling to
the rest, below the tolerance, set to zero) and stay in the basis, so no vector is found
twice. Every new block is ``B``-orthogonalized against the whole basis twice (classical
Gram-Schmidt, BLAS-3) and orthonormalized by SVQB (the eigenvectors of its Gram matrix),
which also detects a block the basis already spans (an invariant subspace found) and
replaces it with (seeded) random directions.

``B V`` is kept beside ``V`` for a non-diagonal ``B`` (one sparse product per block instead
of five); for a diagonal ``B`` it is formed on the fly. Everything that decides the output
runs in a fixed order on one BLAS thread (the caller holds the limit): the same bits for
any number of threads. The tall products run in row chunks of fixed size, and the dense
eigensolver on a helper thread, so Ctrl-C is answered between them.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
import scipy.linalg
import scipy.linalg.blas as blas
import scipy.sparse as sp

from .._interrupt import interruptible

#: Rows per chunk of the tall products (a fixed size: the sums do not depend on threads).
CHUNK = 8192
#: A column of a new block whose ``B``-norm after orthogonalization is at most this
#: fraction of its norm before is taken as spanned by the basis (two passes of classical
#: Gram-Schmidt leave an error of a few units in the last place of the column).
SPANNED = 1e-14
#: Keys at or above this mark Ritz values the caller does not want at all (outside an
#: interval): they are ordered among themselves but never count as found.
FAR = 1e300
#: An SVQB sweep whose Gram matrix (scaled to unit diagonal) has a condition number above
#: ``1 / ILL`` is followed by one more orthogonalization against the basis.
ILL = 1e-8


@dataclasses.dataclass
class Stats:
    """What one search did."""
    solves: int = 0          # right-hand sides solved
    blocks: int = 0          # block solves
    restarts: int = 0
    converged: int = 0       # wanted pairs converged
    want: int = 0


def tdot(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``X^T Y`` for F-ordered tall ``X`` (n, p), ``Y`` (n, q) (one BLAS call)."""
    return blas.dgemm(1.0, X, Y, trans_a=1)


def subtract(W: np.ndarray, V: np.ndarray, C: np.ndarray) -> None:
    """``W -= V C`` in place, for F-ordered ``W`` and ``V`` (one BLAS call)."""
    out = blas.dgemm(-1.0, V, C, 1.0, W, overwrite_c=1)
    if out is not W:                              # BLAS could not write in place
        W[:] = out


def times(V: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``V U`` (n, q), F-ordered, by row chunks of fixed size (each row is its own
    product: the bits do not depend on the chunks; Ctrl-C is answered between them)."""
    out = np.empty((V.shape[0], U.shape[1]), order="F")
    for r in range(0, V.shape[0], CHUNK):
        out[r:r + CHUNK] = V[r:r + CHUNK] @ U
    return out


def rotate(X: np.ndarray, cols: slice, U: np.ndarray, at: int) -> None:
    """``X[:, at:at + q] = X[:, cols] U`` in place, row chunk by row chunk (the same bits
    as :func:`times`, without an (n, q) temporary)."""
    for r in range(0, X.shape[0], CHUNK):
        X[r:r + CHUNK, at:at + U.shape[1]] = X[r:r + CHUNK, cols] @ U


class Mass:
    """``B X`` for tall blocks: a diagonal ``B`` as a vector, else the sparse matrix."""

    def __init__(self, B: sp.csr_array) -> None:
        d = B.diagonal()
        self.diagonal = d if not sp.coo_array(B - sp.diags_array(d)).count_nonzero() else None
        self.B = B

    def __call__(self, X: np.ndarray) -> np.ndarray:
        if self.diagonal is not None:
            return np.asfortranarray(self.diagonal[:, None] * X)
        return np.asfortranarray(self.B @ X)


class Basis:
    """A ``B``-orthonormal basis ``V`` of at most ``cap`` columns (F-ordered), ``B V`` for
    a non-diagonal ``B``, and fixed ``B``-orthonormal vectors ``X0`` the basis stays
    ``B``-orthogonal to."""

    def __init__(self, n: int, cap: int, mass: Mass, X0: np.ndarray | None, rng) -> None:
        self.mass, self.rng = mass, rng
        self.V = np.zeros((n, cap), order="F")
        self.BV = None if mass.diagonal is not None else np.zeros((n, cap), order="F")
        self.X0 = np.asfortranarray(X0) if X0 is not None and X0.shape[1] else None
        self.BX0 = mass(self.X0) if self.X0 is not None else None

    def store(self, at: int, Q: np.ndarray, BQ: np.ndarray | None) -> None:
        self.V[:, at:at + Q.shape[1]] = Q
        if self.BV is not None:
            self.BV[:, at:at + Q.shape[1]] = BQ if BQ is not None else self.mass(Q)

    def bv(self, lo: int, hi: int) -> np.ndarray:
        """``B V[:, lo:hi]``."""
        if self.BV is not None:
            return self.BV[:, lo:hi]
        return self.mass(self.V[:, lo:hi])

    def project(self, W: np.ndarray, lo: int, hi: int, C: np.ndarray,
                BW: np.ndarray | None = None) -> np.ndarray:
        """One pass of classical Gram-Schmidt of ``W`` against ``X0`` and ``V[:, lo:hi]``
        in place (``C[lo:hi]`` accumulates the coefficients, ``BW`` follows ``W`` when
        given); returns the squared ``B``-norms of what it took from each column."""
        taken = np.zeros(W.shape[1])
        if self.X0 is not None:
            c0 = tdot(self.BX0, W)
            subtract(W, self.X0, c0)
            if BW is not None:
                subtract(BW, self.BX0, c0)
            taken += np.einsum("ij,ij->j", c0, c0)
        if hi > lo:
            if self.BV is not None:
                c = tdot(self.BV[:, lo:hi], W)
            else:
                c = tdot(self.V[:, lo:hi], self.mass(W))
            subtract(W, self.V[:, lo:hi], c)
            if BW is not None:
                if self.BV is not None:
                    subtract(BW, self.BV[:, lo:hi], c)
                else:
                    BW[:] = self.mass(W)
            C[lo:hi] += c
            taken += np.einsum("ij,ij->j", c, c)
        return taken

    def extend(self, W: np.ndarray, upto: int, local: int):
        """``(Q, BQ, R, C)`` with ``W = Q R + V[:, :upto] C`` (+ an ``X0`` part): ``Q``
        (n, b) ``B``-orthonormal and ``B``-orthogonal to the basis, ``W`` (n, b, F-ordered)
        overwritten. ``W`` is projected against ``V[:, local:upto]`` (the blocks its
        recurrence couples it to), then against the whole basis; once more for a column
        that this second pass shortened by more than ``1/sqrt(2)`` (Daniel, Gragg, Kaufman
        and Stewart's criterion). Then two SVQB sweeps (the eigenvectors of the Gram
        matrix scaled to unit diagonal); a column at most :data:`SPANNED` of its norm
        before is replaced by a random direction with zero coupling, and an
        ill-conditioned sweep is followed by one more pass against the basis."""
        b = W.shape[1]
        C = np.zeros((upto, b))
        R = np.eye(b)
        removed = self.project(W, local, upto, C) if local < upto else np.zeros(b)
        last = self.project(W, 0, upto, C)
        removed += last
        BW = self.mass(W)
        d2 = np.maximum(np.einsum("ij,ij->j", W, BW), 0.0)
        if (d2 < (d2 + last) / 2).any():                 # the pass cancelled: once more
            removed += self.project(W, 0, upto, C, BW)
            d2 = np.maximum(np.einsum("ij,ij->j", W, BW), 0.0)
        spanned = ~(np.sqrt(d2) > SPANNED * np.sqrt(d2 + removed))
        if spanned.any():
            X = np.asfortranarray(self.rng.standard_normal((W.shape[0], int(spanned.sum()))))
            for _ in range(2):
                self.project(X, 0, upto, np.zeros((upto, X.shape[1])))
            W[:, spanned] = X
            BW[:, spanned] = self.mass(X)
            R[spanned] = 0.0
        good = 0
        for _ in range(6):
            G = tdot(W, BW)
            G = (G + G.T) / 2
            d = np.sqrt(np.diag(G))
            s, U = scipy.linalg.eigh(G / d[:, None] / d[None, :])
            s = np.maximum(s, np.finfo(float).tiny)
            F = U / d[:, None] / np.sqrt(s)[None, :]              # W F is B-orthonormal
            W, BW = blas.dgemm(1.0, W, F), blas.dgemm(1.0, BW, F)
            R = (np.sqrt(s)[:, None] * U.T * d[None, :]) @ R     # F^-1 R
            if s[0] < ILL * s[-1]:
                good = 0
                extra = np.zeros((upto, b))
                self.project(W, 0, upto, extra, BW)
                C += extra @ R
                continue
            good += 1
            if good == 2:
                return W, BW, R, C
        raise ArithmeticError("the block could not be orthonormalized (is B positive definite?)")


def search(solve: Callable, mass: Mass, n: int, *, want: int, key: Callable, block: int,
           basis: int, tol: Callable, X0: np.ndarray | None, rng,
           progress: Callable | None = None, max_restarts: int = 100,
           patience: int | None = None):
    """The ``want`` Ritz pairs of ``T = solve(B .)`` first in the order of ``key`` (a
    function of an array of Ritz values ``theta`` giving sort keys, smaller first; keys
    of at least :data:`FAR` are never wanted), converged to ``|T y - theta y|_B <=
    tol(theta)``.

    ``solve(Z)`` returns ``(A - s B)^-1 Z`` for an (n, b) block; ``mass`` multiplies by
    ``B``; ``X0`` (n, c) are ``B``-orthonormal vectors to stay orthogonal to; ``basis`` is
    the most columns of the basis (at least ``want + 3 block``), ``rng`` a NumPy Generator
    for the starting block; ``progress(stats)`` is called after each Rayleigh-Ritz step.
    Returns ``(theta (want,), Y (n, want) B-orthonormal, residuals (want,), Stats)``; after
    ``max_restarts`` restarts the pairs are returned as they are (the caller checks them).
    With ``patience``, a search still short of ``want`` after that many restarts returns
    the converged pairs that come first by ``key`` (at least one block of them), for a
    caller that moves its shift to them (spectrum slicing).
    """
    b = block
    stats = Stats(want=want)
    space = Basis(n, basis + b, mass, X0, rng)
    V = space.V
    H = np.zeros((basis + b, basis + b))
    nlock = 0
    Q, BQ, _, _ = space.extend(np.asfortranarray(rng.standard_normal((n, b))), 0, 0)
    space.store(0, Q, BQ)
    m = 0                          # columns whose image is in H; V[:, m:m+b] is next
    local = 0                      # the columns the next block's image is coupled to
    cycle = max(1, basis // b)           # blocks per restart cycle
    check = max(1, cycle // 4)           # blocks between Rayleigh-Ritz steps
    since = 0
    while True:
        # -- expand the next block: W = T V_j, orthogonalized against the basis
        W = np.asfortranarray(solve(space.bv(m, m + b)))
        stats.solves += b
        stats.blocks += 1
        Q, BQ, R, C = space.extend(W, m + b, local)
        local = m
        C[:nlock] = 0.0                                        # locked: decoupled
        H[:m + b, m:m + b] = C
        H[m:m + b, :m] = C[:m].T
        H[m:m + b, m:m + b] = (C[m:m + b] + C[m:m + b].T) / 2
        m += b
        space.store(m, Q, BQ)
        since += 1
        full = m + b > basis
        if not full and since < check:
            continue
        since = 0
        # -- Rayleigh-Ritz on the unlocked part
        act = slice(nlock, m)
        theta, U = interruptible(scipy.linalg.eigh, H[act, act])
        res = np.linalg.norm(R @ U[-b:], axis=0)
        all_theta = np.concatenate([np.diag(H)[:nlock], theta])
        done = np.concatenate([np.ones(nlock, dtype=bool), res <= tol(theta)])
        keys = key(all_theta)
        order = np.argsort(keys, kind="stable")
        wanted = order[:want]
        # a wanted pair counts when converged and wanted indeed (a key below FAR)
        stats.converged = int((done[wanted] & (keys[wanted] < FAR)).sum())
        # Rayleigh-Ritz more often as the wanted pairs converge (convergence is seen
        # sooner, at a cost of one dense eigensolver per step)
        share = stats.converged / max(want, 1)
        check = max(1, cycle // (16 if share > 0.8 else 8 if share > 0.4 else 4))
        if progress is not None:
            progress(stats)
        if stats.converged == want or (full and stats.restarts >= max_restarts):
            break
        if full and patience is not None and stats.restarts >= patience:
            run = np.cumsum(~(done[wanted] & (keys[wanted] < FAR)))
            prefix = int((run == 0).sum())
            if prefix >= min(b, want):
                wanted = wanted[:prefix]
                stats.converged = prefix
                break
        if not full:
            continue
        # -- restart: lock the converged among the first (want + b), keep the wanted and
        #    half of the room left, drop the rest
        stats.restarts += 1
        lock = [int(i) for i in order[:want + b] if i >= nlock and done[i]]
        room = basis - 2 * b - nlock - len(lock)
        missing = max(want - nlock - len(lock), 0)
        taken = set(lock)
        rest = [int(i) for i in order if i >= nlock and int(i) not in taken]
        rest = rest[:max(min(room, missing + (room - missing) // 2), 0)]
        sel = np.array(lock + rest, dtype=np.int64) - nlock
        l = nlock + len(sel)
        for X in (V,) if space.BV is None else (V, space.BV):
            rotate(X, act, U[:, sel], nlock)            # X[:, nlock:l] = X[:, act] U
        space.store(l, Q, BQ)
        d = np.concatenate([np.diag(H)[:nlock], theta[sel]])
        S = R @ U[-b:, sel]                                    # T Y = Y Theta + Q S
        S[:, :len(lock)] = 0.0
        H[:] = 0.0
        H[np.arange(l), np.arange(l)] = d
        H[l:l + b, nlock:l] = S
        H[nlock:l, l:l + b] = S.T
        local = nlock
        nlock += len(lock)
        m = l
    # -- the wanted pairs
    locked = wanted[wanted < nlock]
    free = wanted[wanted >= nlock] - nlock
    Y = np.empty((n, len(wanted)), order="F")
    Y[:, :len(locked)] = V[:, locked]
    if len(free):
        Y[:, len(locked):] = times(V[:, act], U[:, free])
    th = np.concatenate([all_theta[locked], theta[free]])
    rs = np.concatenate([np.zeros(len(locked)), res[free]])
    return th, Y, rs, stats
