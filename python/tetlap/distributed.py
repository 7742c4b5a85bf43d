"""Distributed assembly and solves with PETSc / SLEPc over MPI (optional).

Each MPI rank reads only its share of a mesh stored as memory-mappable ``.npy`` files — a
contiguous slice of the tets and the coordinates of the vertices that slice uses —,
computes that share's operators with the same Rust core, and adds them into a distributed
PETSc matrix (``MPIAIJ``, contiguous row ownership) with ``ADD_VALUES``. No rank holds the
whole mesh or the whole matrix. Needs ``petsc4py`` (with MUMPS), ``slepc4py`` and
``mpi4py``; see :doc:`/guide/scale`. Debian's petsc4py and slepc4py are found
without ``PETSC_DIR`` / ``SLEPC_DIR`` (the newest ``/usr/lib/petscdir/petsc*/*-real``);
every function that needs them raises a one-line ``ImportError`` saying whether a package
is missing or installed but failing to import (and why).

Conventions are tetlap's: ``L[i, j] = w_ij``, ``L[i, i] = -sum_j w_ij``.

    mpirun -n 2 python -m tetlap distributed-info points.npy tets.npy

>>> from tetlap import distributed                                  # doctest: +SKIP
>>> L, M = distributed.assemble("points.npy", "tets.npy")           # doctest: +SKIP
"""

from __future__ import annotations

import glob
import importlib
import importlib.util
import os
import re
import sys

import numpy as np

from . import _arrays, _options, assembly
from .errors import ShapeError
from ._names import public_dir

__all__ = ["assemble", "load_share", "dirichlet", "eigs", "boundary_rows", "info", "to_scipy"]
__dir__ = public_dir(globals())


# Debian installs petsc4py / slepc4py under PETSc's and SLEPc's own prefixes; its .pth
# files put them on sys.path only if PETSC_DIR / SLEPC_DIR is set when Python starts (or
# petsc-dev's /usr/lib/petsc link exists). Real scalars: tetlap's matrices are real.
_DEBIAN_PREFIXES = {
    "petsc4py": ("PETSC_DIR", "/usr/lib/petscdir/petsc*/*-linux-gnu-real"),
    "slepc4py": ("SLEPC_DIR", "/usr/lib/slepcdir/slepc*/*-linux-gnu-real"),
}
_INSTALL = ("Debian: apt-get install python3-petsc4py python3-slepc4py python3-mpi4py "
            "openmpi-bin, and use /usr/bin/python3 or a venv made from it with "
            "--system-site-packages; see the guide's page docs/guide/scale.md")


def _version_key(path: str) -> tuple[int, ...]:
    return tuple(int(x) for x in re.findall(r"\d+", path))


def _find_debian(module: str) -> str:
    """Make Debian's ``module`` (petsc4py or slepc4py) importable when Python started
    without PETSC_DIR / SLEPC_DIR: set the variable to the newest real-scalar prefix (if
    unset) and add the prefix's ``lib/python3/dist-packages`` to ``sys.path``. Only for
    Debian's own Python (``sys.base_prefix == "/usr"``), for which those modules are built.
    Returns a note for the error message when that did not happen."""
    if importlib.util.find_spec(module) is not None:
        return ""
    var, pattern = _DEBIAN_PREFIXES[module]
    prefixes = [os.environ[var]] if os.environ.get(var) else sorted(
        glob.glob(pattern), key=_version_key)
    if not prefixes:
        return ""
    site = os.path.join(prefixes[-1], "lib", "python3", "dist-packages")
    if not os.path.isdir(os.path.join(site, module)):
        return f"; {var}={prefixes[-1]} has no {module}" if os.environ.get(var) else ""
    if sys.base_prefix != "/usr":
        return (f"; Debian's {module} in {site} is built for /usr/bin/python3, not for "
                f"{sys.executable}")
    os.environ.setdefault(var, prefixes[-1])
    if site not in sys.path:
        sys.path.append(site)
    importlib.invalidate_caches()
    return ""


def _import(module: str, what: str = ""):
    """Import ``module`` (or ``module.what``) with a one-line ImportError that says
    whether it is missing or installed but broken."""
    note = _find_debian(module) if module in _DEBIAN_PREFIXES else ""
    spec = importlib.util.find_spec(module)
    if spec is None:
        raise ImportError(f"tetlap.distributed needs {module}, which is not installed{note}"
                          f" ({_INSTALL})")
    try:
        top = importlib.import_module(module)
        return importlib.import_module(f"{module}.{what}") if what else top
    except Exception as e:  # ImportError, or a RuntimeError from a broken MPI / PETSc
        reason = " ".join(f"{type(e).__name__}: {e}".split())
        raise ImportError(f"{module} is installed ({os.path.dirname(spec.origin or '')}) but "
                          f"failed to import: {reason}") from e


def _petsc():
    """petsc4py's ``PETSc`` module, after mpi4py's ``MPI`` (which initialises MPI)."""
    _import("mpi4py", "MPI")
    return _import("petsc4py", "PETSc")


def _slepc():
    _petsc()
    return _import("slepc4py", "SLEPc")


def _share(m: int, rank: int, size: int) -> tuple[int, int]:
    return m * rank // size, m * (rank + 1) // size


def load_share(points_path, tets_path, comm=None):
    """This rank's tets and the coordinates they use, read through memory maps.

    Returns ``(V, T, vertices, n, m)``: ``V`` (k, d) the coordinates of the ``vertices``
    (global ids, ascending) that this rank's tets use, ``T`` those tets in local numbering,
    ``n`` and ``m`` the global counts.
    """
    comm = comm or _petsc().COMM_WORLD
    points = np.load(points_path, mmap_mode="r")
    tets = np.load(tets_path, mmap_mode="r")
    lo, hi = _share(len(tets), comm.getRank(), comm.getSize())
    T = np.asarray(tets[lo:hi], dtype=np.int64)
    vertices = np.unique(T)
    V = np.asarray(points[vertices], dtype=np.float64)
    return V, np.searchsorted(vertices, T), vertices, int(points.shape[0]), int(tets.shape[0])


def _rows(values, lo: int, hi: int, m: int, name: str):
    """This rank's rows ``lo:hi`` of a per-tet array (or a ``.npy`` path to one, read
    through a memory map), or one ``(3, 3)`` tensor as it is; None stays None."""
    if values is None:
        return None
    if isinstance(values, (str, os.PathLike)):
        values = np.load(values, mmap_mode="r")
    values = _arrays._as_array(values, name)
    if values.shape == (3, 3):
        return np.asarray(values)
    if values.ndim == 0 or values.shape[0] != m:
        raise ShapeError(f"{name} must have one row per tet ({m}) or be one (3, 3) tensor, "
                         f"got shape {values.shape}")
    share = np.asarray(values[lo:hi])
    return share.reshape(-1, 3, 3) if share.ndim == 2 and share.shape[1] == 9 else share


def _matrix(PETSc, comm, n: int):
    A = PETSc.Mat().create(comm=comm)
    A.setSizes(((None, n), (None, n)))
    A.setType(PETSc.Mat.Type.AIJ)
    A.setPreallocationNNZ((32, 32))
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    A.setUp()
    return A


def _add_csr(A, local, vertices) -> None:
    """Add a local CSR matrix over ``vertices`` (global ids) into ``A``."""
    if local is not None and local.nnz:
        I = local.indptr.astype(np.int32)
        J = vertices[local.indices].astype(np.int32)
        A.setValuesIJV(I, J, local.data, addv=True, rowmap=vertices.astype(np.int32))


def assemble(points_path, tets_path, laplacian="dual", mass="circumcentric", comm=None,
             degenerate="raise", *, coefficient=None, density=None):
    """Assemble ``L`` (a PETSc ``Mat``) and ``M`` (a ``Vec`` of lumped masses, a ``Mat``
    for ``mass="fem"``, or None) from ``.npy`` files, every rank its share of the tets.

    ``points_path``: (n, d) float array; ``tets_path``: (m, 4) integer array. ``laplacian``
    and ``mass`` as in :func:`tetlap.operators`. (The barycentric boundary option and vertex
    weights are not available here: a rank does not see the global boundary.)
    ``coefficient`` and ``density``: as in :func:`tetlap.operators` (one row per tet, in
    the order of ``tets_path``, or one ``(3, 3)`` tensor; ``(m, 9)`` rows are tensors), an
    array or the path of a ``.npy`` file, which every rank reads its share of through a
    memory map.
    """
    PETSc = _petsc()
    comm = comm or PETSc.COMM_WORLD
    V, T, vertices, n, m = load_share(points_path, tets_path, comm)
    lo, hi = _share(m, comm.getRank(), comm.getSize())
    K = _rows(coefficient, lo, hi, m, "coefficient")
    rho = _rows(density, lo, hi, m, "density")
    Lloc = Mloc = None
    if len(T):
        Lloc, Mloc = assembly.operators(V, T, laplacian, mass or "barycentric",
                                        coefficient=K, density=rho, degenerate=degenerate)
    L = _matrix(PETSc, comm, n)
    _add_csr(L, Lloc, vertices)
    L.assemblyBegin()
    L.assemblyEnd()
    if mass is None:
        return L, None
    if mass == "fem":
        M = _matrix(PETSc, comm, n)
        _add_csr(M, Mloc, vertices)
        M.assemblyBegin()
        M.assemblyEnd()
        return L, M
    M = L.createVecLeft()
    M.set(0.0)
    if Mloc is not None:
        M.setValues(vertices.astype(np.int32), Mloc.diagonal(), addv=True)
    M.assemblyBegin()
    M.assemblyEnd()
    return L, M


def to_scipy(A, root: int = 0):
    """Gather a PETSc ``Mat`` (or ``Vec``) on rank ``root`` as a scipy ``csr_array`` (or
    NumPy array); None on the other ranks. For tests and small problems."""
    import scipy.sparse as sp

    _options.count(root, "root", 0)
    comm = A.getComm().tompi4py()
    if hasattr(A, "getValuesCSR"):
        lo, _ = A.getOwnershipRange()
        indptr, indices, data = A.getValuesCSR()
        parts = comm.gather((lo, indptr, indices, data), root=root)
        if comm.rank != root:
            return None
        n = A.getSize()[0]
        rows = np.concatenate([lo + np.repeat(np.arange(len(ip) - 1), np.diff(ip))
                               for lo, ip, _, _ in parts])
        cols = np.concatenate([ix for _, _, ix, _ in parts])
        vals = np.concatenate([d for _, _, _, d in parts])
        return sp.csr_array((vals, (rows, cols)), shape=(n, n))
    parts = comm.gather(A.getArray().copy(), root=root)
    return None if comm.rank != root else np.concatenate(parts)


def boundary_rows(tets_path, comm, n: int) -> np.ndarray:
    """Owned rows (global ids) of vertices on boundary faces, found by sending every face
    of this rank's tets to an owner rank (by hash) that counts it: a face seen once is on
    the boundary. No rank sees more than its share of the faces."""
    tets = np.load(tets_path, mmap_mode="r")
    rank, size = comm.Get_rank(), comm.Get_size()
    lo, hi = _share(len(tets), rank, size)
    T = np.asarray(tets[lo:hi], dtype=np.int64)
    F = np.sort(T[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    owner = (F[:, 0] * 73856093 ^ F[:, 1] * 19349663 ^ F[:, 2] * 83492791) % size
    received = comm.alltoall([F[owner == r] for r in range(size)])
    faces = np.concatenate(received) if received else np.zeros((0, 3), dtype=np.int64)
    keys, counts = np.unique(faces, axis=0, return_counts=True)
    on_boundary = np.unique(keys[counts == 1].ravel())
    # send every boundary vertex to the rank owning its row (contiguous shares of n)
    starts = np.array([_share(n, r, size)[0] for r in range(size)] + [n])
    dest = np.searchsorted(starts, on_boundary, side="right") - 1
    received = comm.alltoall([on_boundary[dest == r] for r in range(size)])
    return np.unique(np.concatenate(received)).astype(np.int64)


def dirichlet(L, fixed, values, rhs=None, *, rtol: float = 1e-10):
    """Solve ``(L f)_i = rhs_i`` on free vertices, ``f = values`` on ``fixed`` ones, with
    KSP (CG on ``-L`` with the constraints eliminated symmetrically, GAMG preconditioner).

    ``fixed``: global vertex ids (any rank may pass any of them; each uses those it owns);
    ``values``: a scalar or one value per entry of ``fixed``; ``rhs``: None or the full
    (n,) right-hand side on every rank; ``rtol`` KSP's relative tolerance in [0, 1).
    Returns the solution ``Vec``.
    """
    _options.tolerance(rtol, "rtol")
    PETSc = _petsc()
    lo, hi = L.getOwnershipRange()
    fixed = np.asarray(fixed, dtype=np.int64)
    values = np.broadcast_to(np.asarray(values, dtype=np.float64), fixed.shape)
    mine = (fixed >= lo) & (fixed < hi)
    A = L.copy()
    A.scale(-1.0)  # -L is positive (semi)definite for the primal
    x, b = A.createVecs()
    x.set(0.0)
    x.setValues(fixed[mine].astype(np.int32), values[mine])
    x.assemble()
    b.set(0.0)
    if rhs is not None:  # the full (n,) right-hand side on every rank; each takes its rows
        b.setValues(np.arange(lo, hi, dtype=np.int32), -np.asarray(rhs, dtype=np.float64)[lo:hi])
        b.assemble()
    A.zeroRowsColumns(fixed[mine].astype(np.int32), diag=1.0, x=x, b=b)
    ksp = PETSc.KSP().create(comm=A.getComm())
    ksp.setOperators(A)
    ksp.setType(PETSc.KSP.Type.CG)
    ksp.getPC().setType(PETSc.PC.Type.GAMG)
    ksp.setTolerances(rtol=rtol, atol=0.0, max_it=10000)
    ksp.solve(b, x)
    if ksp.getConvergedReason() <= 0:
        raise RuntimeError(f"KSP did not converge (reason {ksp.getConvergedReason()})")
    return x


def eigs(L, M, k: int = 10, fixed=(), *, sigma: float = -1e-3):
    """The ``k`` smallest eigenvalues of ``-L_II f = lambda M_II f`` (Eq. 30) with SLEPc:
    generalised Hermitian problem, shift-and-invert around ``sigma`` with a MUMPS LU.
    ``M`` a ``Vec`` (lumped) or ``Mat``; ``fixed`` global ids. Returns eigenvalues (k,)."""
    _options.count(k, "k")
    _options.finite(sigma, "sigma")
    PETSc = _petsc()
    SLEPc = _slepc()

    lo, hi = L.getOwnershipRange()
    fixed = np.asarray(fixed, dtype=np.int64)
    free = np.setdiff1d(np.arange(lo, hi), fixed).astype(np.int32)
    iset = PETSc.IS().createGeneral(free, comm=L.getComm())
    A = L.copy()
    A.scale(-1.0)
    if isinstance(M, PETSc.Vec):
        B = L.duplicate()
        B.zeroEntries()
        B.setDiagonal(M)
    else:
        B = M
    A_II, B_II = A.createSubMatrix(iset, iset), B.createSubMatrix(iset, iset)
    eps = SLEPc.EPS().create(comm=L.getComm())
    eps.setOperators(A_II, B_II)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(k)
    eps.setTarget(sigma)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorSolverType("mumps")
    eps.setTolerances(tol=1e-10)
    eps.solve()
    values = np.sort([eps.getEigenvalue(i).real for i in range(eps.getConverged())])
    if len(values) < k:
        raise RuntimeError(f"SLEPc converged {len(values)} of {k} eigenpairs")
    return values[:k]


def info(points_path, tets_path, comm=None) -> dict:
    """Global counts and the Table-1 checks that work distributed, for both operators."""
    PETSc = _petsc()
    MPI = _import("mpi4py", "MPI")

    comm = comm or PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    points = np.load(points_path, mmap_mode="r")
    n, d = points.shape
    m = int(np.load(tets_path, mmap_mode="r").shape[0])
    boundary = boundary_rows(tets_path, mpi, n)
    result = {"n_vertices": int(n), "n_tets": m, "ranks": mpi.Get_size(),
              "n_boundary_vertices": int(mpi.allreduce(len(boundary)))}
    for kind in ("primal", "dual"):
        L, _ = assemble(points_path, tets_path, kind, None, comm=comm)
        lo, hi = L.getOwnershipRange()
        T = L.copy()
        T.transpose()
        T.axpy(-1.0, L)
        ones, rowsum = L.createVecs()
        ones.set(1.0)
        L.mult(ones, rowsum)
        indptr, indices, data = L.getValuesCSR()
        rows = lo + np.repeat(np.arange(hi - lo), np.diff(indptr))
        off = indices != rows
        scale = mpi.allreduce(np.abs(data).max() if len(data) else 0.0, op=MPI.MAX)
        negative = off & (data < -1e-12 * scale)
        residual = 0.0
        interior = np.setdiff1d(np.arange(lo, hi), boundary) - lo
        coords = np.asarray(points[lo:hi], dtype=np.float64)
        # measured in a frame centred on the mesh (its bounding box), as tetlap.check does:
        # from the origin, a mesh far away adds its offset times each row's rounding
        low = np.array([mpi.allreduce(float(coords[:, c].min()) if len(coords) else np.inf,
                                      op=MPI.MIN) for c in range(d)])
        high = np.array([mpi.allreduce(float(coords[:, c].max()) if len(coords) else -np.inf,
                                       op=MPI.MAX) for c in range(d)])
        coords = coords - (low + (high - low) / 2)
        for c in range(d):
            x, y = L.createVecs()
            x.setArray(coords[:, c].copy())
            L.mult(x, y)
            r = np.abs(y.getArray()[interior])
            residual = max(residual, float(r.max()) if len(r) else 0.0)
        residual = mpi.allreduce(residual, op=MPI.MAX)
        extent = mpi.allreduce(float(np.abs(coords).max()) if len(coords) else 0.0, op=MPI.MAX)
        n_off = mpi.allreduce(int(off.sum()))
        result[kind] = {
            "symmetry_error": T.norm(PETSc.NormType.INFINITY),
            "max_row_sum": rowsum.norm(PETSc.NormType.INFINITY),
            "negative_weight_fraction": mpi.allreduce(int(negative.sum())) / max(n_off, 1),
            "linear_precision_residual": residual / max(scale * 2 * extent, 1e-300),
            "finite": bool(mpi.allreduce(int(np.isfinite(data).all()), op=MPI.MIN)),
        }
    return result

