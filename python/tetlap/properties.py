"""Which of the paper's Table 1 properties an operator has on a given mesh, with numbers.

>>> import tetlap
>>> V, T = tetlap.meshes.cube(3)
>>> report = tetlap.check(tetlap.laplacian(V, T, "primal"), V, T)
>>> report.symmetric, report.nsd, report.linear_precision_ok
(True, True, True)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp

from . import _arrays
from .errors import DtypeError, IndexRangeError, OptionError, ShapeError
from .diagnostics import (
    boundary_vertices,
    interior_vertices,
    mesh_edges,
    referenced_vertices,
    signed_volumes,
)

__all__ = ["check", "Report", "NEGATIVE_TOL"]

#: A weight counts as negative when ``w < -NEGATIVE_TOL * max|w|``: weights that are zero
#: up to rounding (right dihedral angles of a Kuhn grid) do not count.
NEGATIVE_TOL = 1e-12
#: Relative tolerance of the symmetry, row-sum and linear-precision checks.
TOL = 1e-10
#: Largest n for the dense eigenvalue route of the NSD check.
DENSE_NSD_MAX = 2500
#: Largest n for the sparse LDL-inertia route of the NSD check (beyond: skipped).
SPARSE_NSD_MAX = 300_000


@dataclasses.dataclass
class Report:
    """Property checks of one Laplacian (and optionally one mass matrix) on one mesh.

    Every quantity is a plain Python number (or None when it does not apply, with the
    reason in ``notes``); the ``*_ok`` flags compare them with the documented tolerances.
    """

    n_vertices: int
    n_tets: int
    finite: bool
    symmetric: bool
    symmetry_error: float
    max_row_sum: float
    row_sums_ok: bool
    local: bool
    linear_precision_residual: float | None
    linear_precision_ok: bool | None
    nsd: bool | None
    nsd_min_eigenvalue: float | None
    nsd_method: str
    min_weight: float
    n_edges: int
    n_negative: int
    negative_fraction: float
    n_edges_interior: int
    n_negative_interior: int
    negative_fraction_interior: float
    negative_tol: float = NEGATIVE_TOL
    mass_min: float | None = None
    mass_nonpositive: int | None = None
    mass_total: float | None = None
    mesh_volume: float | None = None
    notes: list[str] = dataclasses.field(default_factory=list)

    def to_dict(self) -> dict:
        """A JSON-serialisable dict of every field."""
        return dataclasses.asdict(self)

    def __str__(self) -> str:
        rows = [
            ("finite (no NaN/Inf)", self.finite, ""),
            ("symmetric", self.symmetric, f"max |L - L^T| = {self.symmetry_error:.2e}"),
            ("zero row sums", self.row_sums_ok, f"max |row sum| = {self.max_row_sum:.2e}"),
            ("local (edges + diagonal)", self.local, ""),
            ("linear precision (interior)", self.linear_precision_ok,
             _fmt(self.linear_precision_residual, "relative residual {:.2e}")),
            ("negative semidefinite", self.nsd,
             _fmt(self.nsd_min_eigenvalue, "min eig(-L) {:.3e}") + f" [{self.nsd_method}]"),
            ("non-negative weights", self.n_negative == 0,
             f"{self.n_negative}/{self.n_edges} negative ({100 * self.negative_fraction:.2f}%), "
             f"min w = {self.min_weight:.3e}"),
            ("  ... not both on boundary", self.n_negative_interior == 0,
             f"{self.n_negative_interior}/{self.n_edges_interior} negative "
             f"({100 * self.negative_fraction_interior:.2f}%)"),
        ]
        if self.mass_total is not None:
            rows.append(("positive mass", self.mass_nonpositive == 0,
                         f"min {self.mass_min:.3e}, {self.mass_nonpositive} <= 0"))
            rows.append(("mass total = volume",
                         math.isclose(self.mass_total, self.mesh_volume, rel_tol=1e-9),
                         f"{self.mass_total:.12g} vs {self.mesh_volume:.12g}"))
        width = max(len(r[0]) for r in rows)
        mark = {True: "yes", False: "NO", None: "n/a"}
        lines = [f"{self.n_vertices} vertices, {self.n_tets} tets"]
        lines += [f"{name:<{width}}  {mark[ok]:>3}  {detail}" for name, ok, detail in rows]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


def _fmt(value, template: str) -> str:
    return "" if value is None else template.format(value)


def check(L, V, T, M=None, *, negative_tol: float = NEGATIVE_TOL, nsd: bool = True) -> Report:
    """Check a Laplacian ``L`` (and mass ``M``) of the mesh ``(V, T)`` against Table 1.

    Parameters
    ----------
    L : (n, n) sparse array or matrix (any format), the paper's sign convention.
    V : (n, d) array-like.  T : (m, 4) integer array-like.
    M : optional (n, n) mass matrix (lumped or consistent).
    negative_tol : a weight is negative when ``w < -negative_tol * max|w|``.
    nsd : set False to skip the (costliest) semidefiniteness check.

    Returns
    -------
    Report, a dataclass (``to_dict()``; ``str()`` is a table). Linear precision (Eq. 26)
    is ``max_i |(L V)_i|`` over interior vertices relative to ``max|L| * diameter``; it
    applies to meshes in R^3 only (an immersed mesh is curved). NSD is the smallest
    eigenvalue of ``-L`` (dense, n <= 2500) or the inertia of a sparse LDL^T factorisation
    of ``-L + eps I`` with ``eps = 1e-9 max|L|`` (n <= 300000); beyond that it is skipped.
    """
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    n = V.shape[0]
    L = sp.csr_array(L, dtype=np.float64)
    if L.shape != (n, n):
        raise ShapeError(f"L has shape {L.shape}, expected ({n}, {n})")
    notes: list[str] = []
    finite = bool(np.isfinite(L.data).all())
    scale = float(abs(L).max()) if L.nnz else 0.0
    scale = scale if scale > 0 else 1.0

    asym = float(abs(L - L.T).max()) if L.nnz else 0.0
    row_sum = float(np.abs(L.sum(axis=1)).max())

    edges = mesh_edges(T)
    coo = L.tocoo()
    off = coo.row != coo.col
    r, c = np.minimum(coo.row[off], coo.col[off]), np.maximum(coo.row[off], coo.col[off])
    edge_key = edges[:, 0] * n + edges[:, 1]
    local = bool(np.isin(r.astype(np.int64) * n + c, edge_key).all())

    # weights of the mesh edges (missing entries are 0)
    w = np.asarray(L[edges[:, 0], edges[:, 1]]).ravel()
    w_scale = float(np.abs(w).max()) if w.size else 1.0
    negative = w < -negative_tol * w_scale
    on_boundary = boundary_vertices(T, n)
    inner = ~(on_boundary[edges[:, 0]] & on_boundary[edges[:, 1]])

    interior = interior_vertices(T, n)
    if V.shape[1] != 3:
        lp, lp_ok = None, None
        notes.append("linear precision: not applicable to an immersed (d > 3) mesh")
    elif not interior.any():
        lp, lp_ok = None, None
        notes.append("linear precision: the mesh has no interior vertices")
    else:
        diam = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
        lp = float(np.abs((L @ V)[interior]).max() / (scale * diam))
        lp_ok = lp < TOL

    nsd_ok, min_eig, method = (None, None, "skipped (nsd=False)")
    if nsd and finite:
        nsd_ok, min_eig, method = _nsd(L, scale)

    report = Report(
        n_vertices=n,
        n_tets=int(T.shape[0]),
        finite=finite,
        symmetric=asym <= TOL * scale,
        symmetry_error=asym,
        max_row_sum=row_sum,
        row_sums_ok=row_sum <= TOL * scale,
        local=local,
        linear_precision_residual=lp,
        linear_precision_ok=lp_ok,
        nsd=nsd_ok,
        nsd_min_eigenvalue=min_eig,
        nsd_method=method,
        min_weight=float(w.min()) if w.size else 0.0,
        n_edges=int(w.size),
        n_negative=int(negative.sum()),
        negative_fraction=float(negative.mean()) if w.size else 0.0,
        n_edges_interior=int(inner.sum()),
        n_negative_interior=int((negative & inner).sum()),
        negative_fraction_interior=float((negative & inner).sum() / max(inner.sum(), 1)),
        negative_tol=negative_tol,
        notes=notes,
    )
    if M is not None:
        M = sp.csr_array(M, dtype=np.float64)
        lumped = M.sum(axis=1)
        report.mass_min = float(lumped.min())
        report.mass_nonpositive = int((lumped[referenced_vertices(T, n)] <= 0).sum())
        report.mass_total = float(M.sum())
        report.mesh_volume = float(np.abs(signed_volumes(V, T)).sum())
    return report


def _nsd(L, scale: float):
    """(is NSD, smallest eigenvalue of -L or None, method)."""
    n = L.shape[0]
    A = -(L + L.T) / 2
    if n <= DENSE_NSD_MAX:
        lam = float(np.linalg.eigvalsh(A.toarray())[0])
        return lam >= -1e-9 * scale, lam, "dense eigenvalues"
    if n > SPARSE_NSD_MAX:
        return None, None, f"skipped (n > {SPARSE_NSD_MAX})"
    from scipy.sparse.linalg import splu

    eps = 1e-9 * scale
    shifted = sp.csc_array(A + eps * sp.eye_array(n))
    lu = splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    if np.array_equal(lu.perm_r, lu.perm_c):
        negatives = int((lu.U.diagonal() < 0).sum())
        return negatives == 0, None, (
            f"inertia of LDL^T of -L + {eps:.1e} I: {negatives} negative pivots")
    return None, None, "skipped (the factorisation pivoted off the diagonal)"
