"""The cell-centred two-point-flux Laplacian of a tet mesh (finite volumes on the tets,
with the circumcentres or power centres as cell centres), and its Table 1 report.

>>> import tetlap
>>> V, T = tetlap.meshes.ball(300, seed=3)
>>> Lc = tetlap.cell_laplacian(V, T)
>>> Lc.shape == (len(T), len(T)), bool(abs(Lc.sum(axis=1)).max() < 1e-12 * abs(Lc).max())
(True, True)
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, analysis, diagnostics
from ._docs import shared_docs
from .dual import OUTSIDE_TOL, DualGeometry, dual_geometry
from .errors import DegenerateElementError
from ._names import public_dir

__all__ = ["cell_laplacian", "CellReport", "ZERO_TOL"]
__dir__ = public_dir(globals())

#: A dual edge counts as zero-length when ``|dual_length| <= ZERO_TOL * r``, ``r`` the
#: larger distance from its two centres to the face's first corner (2^-40, the core's
#: documented accuracy, as :data:`tetlap.dual.OUTSIDE_TOL`): the two centres coincide to
#: the accuracy they are known with.
ZERO_TOL = OUTSIDE_TOL


def _interior_weights(g: DualGeometry, degenerate: str, V: np.ndarray):
    """``(s, t, w)`` over the interior faces: the two tets and ``face_area / dual_length``
    (0 for a zero-length dual edge under ``degenerate="skip"``)."""
    interior = np.flatnonzero(g.face_tets[:, 1] >= 0)
    s, t = g.face_tets[interior, 0], g.face_tets[interior, 1]
    length = g.dual_length[interior]
    corner = V[g.faces[interior, 0]]
    reach = np.maximum(np.linalg.norm(g.centres[s] - corner, axis=1),
                       np.linalg.norm(g.centres[t] - corner, axis=1))
    zero = np.abs(length) <= ZERO_TOL * reach
    if zero.any() and degenerate == "raise":
        k = int(np.flatnonzero(zero)[0])
        face = tuple(g.faces[interior[k]].tolist())
        raise DegenerateElementError(
            f"face {face} between tets {s[k]} and {t[k]} has a dual edge of length 0 (their "
            f"centres coincide: the tets' vertices lie on one sphere), so its two-point flux "
            f"is infinite; {int(zero.sum())} faces are like it. Perturb the mesh, pass vertex "
            "weights that separate the centres, or degenerate=\"skip\" to give those faces no "
            "flux", element=int(s[k]))
    w = np.zeros(len(interior))
    w[~zero] = g.face_area[interior][~zero] / length[~zero]
    return s, t, w


@_arrays.takes_mesh_object
@shared_docs
def cell_laplacian(V, T=None, *, weights=None, degenerate="raise", threads=None) -> sp.csr_array:
    """The (m, m) cell-centred two-point-flux Laplacian of a tet mesh: the DEC Laplacian on
    dual 0-forms (one value per tet, at its circumcentre or power centre).

    Parameters
    ----------
    {dual_mesh}
    degenerate : {{"raise", "skip"}}, default "raise"
        A face whose dual edge has zero length (its two tets share their centre: their
        vertices are cospherical, as in a Kuhn grid; to the accuracy ``ZERO_TOL``) has an
        infinite flux coefficient: ``"raise"`` a :class:`tetlap.DegenerateElementError`
        naming it, ``"skip"`` gives it weight 0 (an explicit 0 stays in the pattern). A
        zero-volume tet is refused either way.

    Returns
    -------
    Lc : (m, m) scipy.sparse.csr_array, float64
        ``Lc[s, t] = A_f / l_f`` for tets ``s != t`` sharing the interior face ``f``
        (area ``A_f``, signed dual-edge length ``l_f``, see
        :class:`tetlap.DualGeometry`), ``Lc[t, t] = -sum_s Lc[t, s]``: the paper's sign
        convention (off-diagonals are the weights, rows sum to zero), symmetric, and
        negative semidefinite when every weight is non-negative (a Delaunay mesh; a
        regular one with its weights). The pattern is the face-adjacent pairs plus the
        diagonal. Boundary faces carry no flux (homogeneous Neumann); for Dirichlet data
        ``g`` on a boundary face ``f`` of tet ``t`` add ``-A_f / l_f`` to ``Lc[t, t]`` and
        move ``A_f / l_f * g(face_centres[f])`` to the right-hand side.

    Notes
    -----
    With the exterior derivative ``d2`` and the Hodge star ``*2`` of :mod:`tetlap.dec`
    and ``I`` the interior faces, ``Lc = -d2[:, I] @ inv(*2[I, I]) @ d2[:, I].T``: the
    DEC Laplacian on dual 0-forms (``*3^-1 = diag(volume)`` is its mass matrix: ``Lc u``
    approximates ``volume * laplacian(u)``). It is exact for linear functions sampled at
    the centres on every cell without a boundary face: ``sum_f A_f n_f = 0`` over a
    closed cell, and every dual edge is parallel to its face's normal. Both hold where the
    two tets of every interior face lie on opposite sides of it; at a folded face (tets
    that overlap, both on one side) ``d2`` gives the pair the weight ``-A_f / l_f`` and
    no zero row sum, while ``Lc`` keeps ``+A_f / l_f`` (symmetric, zero row sums) and
    loses linear precision at those cells (:func:`tetlap.check` counts such faces).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.ball(400, seed=1)
    >>> g = tetlap.dual_geometry(V, T)
    >>> Lc = tetlap.cell_laplacian(V, T)
    >>> inner = np.setdiff1d(np.arange(len(T)), g.face_tets[g.boundary_faces, 0])
    >>> bool(np.abs(Lc @ g.centres)[inner].max() < 1e-10 * abs(Lc).max())
    True
    """
    _core.check_options({"degenerate": degenerate})
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    g = dual_geometry(V, T, weights=weights, threads=threads)
    s, t, w = _interior_weights(g, degenerate, V)
    m = len(g.volume)
    diagonal = -(np.bincount(s, weights=w, minlength=m) + np.bincount(t, weights=w, minlength=m))
    cells = np.arange(m)
    Lc = sp.coo_array((np.concatenate([w, w, diagonal]),
                       (np.concatenate([s, t, cells]), np.concatenate([t, s, cells]))),
                      shape=(m, m)).tocsr()
    Lc.sort_indices()
    return Lc


@dataclasses.dataclass
class CellReport(analysis.Report):
    """:class:`tetlap.analysis.Report` of a cell-centred Laplacian (``check(Lc, V, T,
    kind="cell")``). The fields keep their names, read on the dual graph: ``n_edges``
    counts the interior faces (pairs of face-adjacent tets), ``n_edges_interior`` those
    not between two tets that both have a boundary face; ``local`` means every stored
    entry lies on a face-adjacent pair or the diagonal; linear precision is checked at
    the centres, on the ``n_cells_off_boundary`` tets without a boundary face.
    ``n_vertices`` and ``n_tets`` describe the mesh. ``n_folded_faces`` counts the
    interior faces whose two tets lie on the same side of them (the tets overlap): no
    two-point flux is linearly precise at their cells."""

    n_cells_off_boundary: int = 0
    n_folded_faces: int = 0

    _LABELS = {
        "local (edges + diagonal)": "local (face neighbours + diagonal)",
        "linear precision (interior)": "linear precision (cells off the boundary)",
        "  ... edges not both on the boundary": "  ... faces not between boundary cells",
    }

    def rows(self) -> list[tuple[str, bool | None, str]]:
        return [(self._LABELS.get(name, name), ok, detail) for name, ok, detail in super().rows()]

    def __str__(self) -> str:
        lines = super().__str__().splitlines()
        lines[0] = (f"{self.n_tets} cells (the tets of a mesh with {self.n_vertices} "
                    f"vertices), {self.n_edges} interior faces")
        return "\n".join(lines)


def _sample(A: sp.csr_array, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``A[rows, cols]`` as a float64 array (0 where nothing is stored); SciPy gives a sparse
    array for empty indices."""
    return np.asarray(A[rows, cols], dtype=np.float64).ravel() if len(rows) else np.zeros(0)


def _report(L, V: np.ndarray, T: np.ndarray, M, *, weights, negative_tol: float, nsd: bool):
    """``check(L, V, T, M, kind="cell", weights=weights)`` on validated ``V`` (float64) and
    ``T`` (int64)."""
    m = T.shape[0]
    L = _arrays.laplacian(L, m, finite=False)           # the stiffness sign refused
    # the geometry in a frame centred on the box of the vertices in tets (an unused vertex
    # changes no answer), as the vertex check measures: the centres of a mesh far from
    # the origin are then as accurate as near it (their rounding is relative to the
    # mesh's size, not to its offset), and linear precision does not depend on where the
    # mesh lies
    used = np.zeros(len(V), dtype=bool)
    used[T.ravel()] = True
    low, high = V[used].min(axis=0), V[used].max(axis=0)
    diameter = float(np.linalg.norm(high - low))
    g = dual_geometry(np.where(used[:, None], V - (low / 2 + high / 2), 0.0), T,
                      weights=weights)
    interior = (g.face_tets >= 0).all(axis=1)
    s, t = g.face_tets[interior, 0], g.face_tets[interior, 1]
    on_boundary = np.zeros(m, dtype=bool)
    on_boundary[g.face_tets[g.boundary_faces, 0]] = True
    finite = bool(np.isfinite(L.data).all())
    decided = (lambda ok: ok) if finite else (lambda ok: None)
    scale = float(np.abs(L.data).max()) if L.nnz and finite else 0.0
    scale = scale if scale > 0 else 1.0
    symmetry_error = float(abs(L - L.T).max()) if L.nnz and finite else 0.0
    max_row_sum = float(np.abs(L.sum(axis=1)).max()) if finite else float("nan")
    # locality: every stored entry on the diagonal or a face-adjacent pair
    rows = np.repeat(np.arange(m), np.diff(L.indptr))
    pairs = sp.csr_array((np.ones(2 * len(s)), (np.concatenate([s, t]), np.concatenate([t, s]))),
                         shape=(m, m))
    pairs.sum_duplicates()
    local = bool(((rows == L.indices) | (_sample(pairs, rows, L.indices) > 0)).all())
    w = _sample(L, s, t)
    notes: list[str] = []
    residual = None
    off = ~on_boundary
    if V.shape[1] != 3:
        notes.append("linear precision: not applicable to an immersed (d > 3) mesh")
    elif not off.any():
        notes.append("linear precision: every cell has a boundary face")
    elif finite:
        residual = float(np.abs(L @ g.centres)[off].max()) / (scale * diameter)
    if not finite:
        notes.append("L has NaN or Inf entries: only finiteness and locality are decided")
    folded = int(diagnostics.folded_faces(V, T).sum())   # the two tets on one side
    if folded:
        notes.append(f"{folded} interior faces are folded (their two tets on one side: the "
                     "mesh overlaps itself): linear precision fails at their cells")
    inner = ~(on_boundary[s] & on_boundary[t])
    negative = w < -negative_tol * (np.abs(w).max() if len(w) else 0.0)
    nsd_ok, min_eig, method = None, None, "skipped (nsd=False)"
    if nsd and not finite:
        method = "skipped (not finite)"
    elif nsd:
        nsd_ok, min_eig, method = analysis._nsd(L, V, T, scale, "cell", False)
    fraction = lambda k, total: k / total if total else 0.0
    report = CellReport(
        n_vertices=V.shape[0], n_tets=m, finite=finite,
        symmetric=decided(symmetry_error <= analysis.TOL * scale), symmetry_error=symmetry_error,
        max_row_sum=max_row_sum, row_sums_ok=decided(max_row_sum <= analysis.TOL * scale),
        local=local, linear_precision_residual=residual,
        linear_precision_ok=None if residual is None else decided(residual < analysis.TOL),
        nsd=nsd_ok, nsd_min_eigenvalue_upper_bound=min_eig, nsd_method=method,
        min_weight=float(w.min()) if len(w) else 0.0,
        n_edges=len(w), n_negative=int(negative.sum()),
        negative_fraction=fraction(int(negative.sum()), len(w)),
        n_edges_interior=int(inner.sum()), n_negative_interior=int((negative & inner).sum()),
        negative_fraction_interior=fraction(int((negative & inner).sum()), int(inner.sum())),
        negative_tol=negative_tol, notes=notes, n_cells_off_boundary=int(off.sum()),
        n_folded_faces=folded)
    if M is not None:
        M = _arrays.matrix(M, m, "M")
        lumped = np.asarray(M.sum(axis=1)).ravel()
        report.mass_min = float(lumped.min())
        report.mass_nonpositive = int((lumped <= 0).sum())
        report.mass_total = float(M.sum())
        report.mesh_volume = float(g.volume.sum())
    return report
