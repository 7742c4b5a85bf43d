"""Which of the paper's Table 1 properties an operator has on a given mesh, with numbers.

Every check costs ``O(size of the mesh)``: the pattern, sign and precision checks are one
parallel pass of the Rust core, and semidefiniteness is answered by a certificate (see
:func:`check`), not by a sparse factorisation.

>>> import tetlap
>>> V, T = tetlap.meshes.cube(3)
>>> report = tetlap.check(tetlap.laplacian(V, T, "primal"), V, T)
>>> report.symmetric, report.nsd, report.linear_precision_ok
(True, True, True)
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import warnings

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, _options, _sparse, assembly, diagnostics
from . import coefficient as _coefficient
from ._blas import one_blas_thread
from .dual import dual_geometry
from ._interrupt import eigvalsh, splu
from .errors import OptionError, ShapeError
from ._names import public_dir

__all__ = ["check", "Report", "negative_weights", "lumped_masses", "NEGATIVE_TOL", "TOL", "NSD_RTOL", "DENSE_NSD_MAX", "SPARSE_NSD_MAX"]
__dir__ = public_dir(globals())

#: A weight counts as negative when ``w < -NEGATIVE_TOL * max|w|``: weights that are zero
#: up to rounding (right dihedral angles of a Kuhn grid) do not count.
NEGATIVE_TOL = 1e-12
#: Relative tolerance of the symmetry, row-sum and linear-precision checks.
TOL = 1e-10
#: ``L`` counts as negative semidefinite when ``-L + NSD_RTOL * diag(|L_ii|)`` is positive
#: semidefinite: each vertex's tolerance is relative to its own row, so that no part of the
#: mesh (a component far larger, a region far finer) sets the tolerance of another.
NSD_RTOL = 1e-9
#: Largest n for which the NSD check computes all eigenvalues (dense, on one BLAS thread),
#: its last resort when neither a certificate nor the LDL^T decides.
DENSE_NSD_MAX = 2500


@dataclasses.dataclass
class Report:
    """Property checks of one Laplacian (and optionally one mass matrix) on one mesh.

    Every quantity is a plain Python number (or None when it does not apply, with the
    reason in ``notes``); the ``*_ok`` flags compare them with the documented tolerances.
    ``nsd_min_eigenvalue_upper_bound`` is an upper bound on the smallest eigenvalue of
    ``-L``: that eigenvalue itself (to rounding) when dense eigenvalues decided, the
    Rayleigh quotient of the witness (negative: ``L`` is not NSD) when a witness did, else
    None. (Called ``nsd_min_eigenvalue`` until 0.1; that name reads it, deprecated.)
    Vertices in no tet take no part: the eigenvalue is that of ``-L`` without their empty
    rows, ``mass_min`` and ``mass_nonpositive`` are over the vertices in tets, and the
    linear-precision residual is relative to the diameter of those.

    With ``check(..., coefficient=K)``: ``coefficient`` is ``"constant"`` (one value on
    every tet: linear precision is checked, linear functions solve ``div(K grad u) = 0``)
    or ``"varying"`` (linear precision is None, with the reason in ``notes``), and the
    mesh's properties in the metric ``K^-1`` are counted: ``n_obtuse_tets_metric``, the
    tets with a dihedral angle above 90 degrees in their metric (the primal's maximum
    principle needs none; ``obtuse_tets_metric`` names the worst ten), and
    ``n_non_delaunay_faces_metric``, the interior faces not locally Delaunay in the metric
    of their two tets (the dual's; ``non_delaunay_faces_metric`` the worst ten as their
    two tets ``[s, t]``); see :func:`check`. Without a coefficient those are None (and
    ``[]``). Points not in R^3 give None as well.
    """

    n_vertices: int
    n_tets: int
    finite: bool
    symmetric: bool | None
    symmetry_error: float
    max_row_sum: float
    row_sums_ok: bool | None
    local: bool
    linear_precision_residual: float | None
    linear_precision_ok: bool | None
    nsd: bool | None
    nsd_min_eigenvalue_upper_bound: float | None
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
    coefficient: str | None = None
    n_obtuse_tets_metric: int | None = None
    obtuse_tets_metric: list[int] = dataclasses.field(default_factory=list)
    n_non_delaunay_faces_metric: int | None = None
    non_delaunay_faces_metric: list[list[int]] = dataclasses.field(default_factory=list)
    notes: list[str] = dataclasses.field(default_factory=list)

    def to_dict(self) -> dict:
        """A JSON-serialisable dict of every field."""
        return dataclasses.asdict(self)

    @property
    def nsd_min_eigenvalue(self) -> float | None:
        """Deprecated: :attr:`nsd_min_eigenvalue_upper_bound`, its name until 0.1 (a
        witness's Rayleigh quotient is only an upper bound on the eigenvalue)."""
        warnings.warn("Report.nsd_min_eigenvalue is nsd_min_eigenvalue_upper_bound (an upper "
                      "bound, not the eigenvalue, when a witness decided)", DeprecationWarning,
                      stacklevel=2)
        return self.nsd_min_eigenvalue_upper_bound

    def rows(self) -> list[tuple[str, bool | None, str]]:
        """The table's rows: ``(property, passed, numbers)``; with a NaN or Inf in ``L``
        only finiteness and locality are decided (the other rows are ``None``)."""
        numeric = (lambda ok: ok) if self.finite else (lambda ok: None)
        rows = [
            ("finite (no NaN/Inf)", self.finite, ""),
            ("symmetric", self.symmetric, f"max |L - L^T| = {self.symmetry_error:.2e}"),
            ("zero row sums", self.row_sums_ok, f"max |row sum| = {self.max_row_sum:.2e}"),
            ("local (edges + diagonal)", self.local, ""),
            ("linear precision (interior)", self.linear_precision_ok,
             _fmt(self.linear_precision_residual, "relative residual {:.2e}")),
            ("negative semidefinite", self.nsd,
             _fmt(self.nsd_min_eigenvalue_upper_bound, "min eig(-L) <= {:.3e} ")
             + f"[{self.nsd_method}]"),
            ("non-negative weights", numeric(self.n_negative == 0),
             f"{self.n_negative}/{self.n_edges} negative ({100 * self.negative_fraction:.2f}%), "
             f"min w = {self.min_weight:.3e}"),
            ("  ... edges not both on the boundary", numeric(self.n_negative_interior == 0),
             f"{self.n_negative_interior}/{self.n_edges_interior} negative "
             f"({100 * self.negative_fraction_interior:.2f}%)"),
        ]
        if self.n_obtuse_tets_metric is not None:
            rows.append(("non-obtuse in the metric (tets)", self.n_obtuse_tets_metric == 0,
                         f"{self.n_obtuse_tets_metric}/{self.n_tets} obtuse"
                         + _worst(self.obtuse_tets_metric, self.n_obtuse_tets_metric)))
        if self.n_non_delaunay_faces_metric is not None:
            rows.append(("Delaunay in the metric (interior faces)",
                         self.n_non_delaunay_faces_metric == 0,
                         f"{self.n_non_delaunay_faces_metric} not locally Delaunay"
                         + _worst([f"{s}|{t}" for s, t in self.non_delaunay_faces_metric],
                                  self.n_non_delaunay_faces_metric)))
        if self.mass_total is not None:
            rows.append(("positive mass", self.mass_nonpositive == 0,
                         f"min {self.mass_min:.3e}, {self.mass_nonpositive} <= 0"))
            rows.append(("mass total = volume",
                         math.isclose(self.mass_total, self.mesh_volume, rel_tol=1e-9),
                         f"{self.mass_total:.12g} vs {self.mesh_volume:.12g}"))
        return rows

    def __str__(self) -> str:
        rows = self.rows()
        width = max(len(r[0]) for r in rows)
        mark = {True: "yes", False: "NO", None: "n/a"}
        lines = [f"{self.n_vertices} vertices, {self.n_tets} tets"]
        lines += [f"{name:<{width}}  {mark[ok]:>3}  {detail}" for name, ok, detail in rows]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


def _fmt(value, template: str) -> str:
    return "" if value is None else template.format(value)


def _worst(listed: list, count: int) -> str:
    """``, worst: a, b, ...`` of a row of listed elements (nothing when there are none)."""
    if not count:
        return ""
    return ", worst: " + ", ".join(map(str, listed)) + (", ..." if count > len(listed) else "")


@_arrays.takes_mesh_object
def check(L, V, T=None, M=None, *, kind=None, negative_tol: float = NEGATIVE_TOL,
          nsd: bool = True, weights=None, coefficient=None) -> Report:
    """Check a Laplacian ``L`` (and mass ``M``) of the mesh ``(V, T)`` against Table 1.

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix (any format)
        In the paper's sign convention (``L[i, i] = -sum_j L[i, j]``, negative where the
        weights sum to more than zero). A matrix in the stiffness sign (``K = -L``, as
        LaPy and scikit-fem hold it: no negative diagonal entry and a positive one) is
        refused with :class:`tetlap.OptionError` (pass ``-K``): every sign-dependent row
        would answer for the negated operator. Not modified.
    V : (n, d) array-like of real numbers
        Vertex positions.
    T : (m, 4) array-like of integers, optional
        Tets, any orientation; leave it out to pass a mesh object as ``V``.
    M : (n, n) SciPy sparse array or matrix, optional
        A mass matrix (lumped or consistent): positivity and total volume are checked.
    kind : {"primal", "dual", "cell"} or float, optional
        What ``L`` is meant to be, if known; it only helps the semidefiniteness check
        (see Notes). Without it, ``L`` is compared with the primal of the mesh.
        ``"cell"``: ``L`` is an (m, m) cell-centred operator on the tets, such as
        :func:`tetlap.cell_laplacian`; the report (a
        :class:`tetlap.cells.CellReport`) reads every row on the dual graph: locality
        within face-adjacent tets, linear precision for linear functions sampled at the
        centres on tets without a boundary face, weights over interior faces; ``M`` is
        then (m, m), e.g. ``diag(volume)``.
    negative_tol : float, default 1e-12
        A weight is negative when ``w < -negative_tol * max|w|`` (a relative tolerance in
        [0, 1)).
    nsd : bool, default True
        False skips the semidefiniteness check.
    weights : (n,) array-like of real numbers, optional
        With ``kind="cell"``: the vertex weights ``L`` was built with (its centres are
        then power centres). Not used by the other kinds.
    coefficient : array-like of real numbers, optional
        The coefficient ``L`` was built with (``laplacian(V, T, kind, coefficient=K)``):
        ``(m,)`` positive scalars, ``(m, 3, 3)`` SPD tensors or one ``(3, 3)`` tensor,
        validated as every function validates it (:func:`tetlap.coefficient.check`).
        Table 1 in the metric ``K^-1``: see Notes. Not with ``kind="cell"``.

    Returns
    -------
    Report
        A dataclass (``to_dict()``; ``str()`` is a table). An ``L`` with NaN or Inf
        entries is reported (``finite=False``), not refused; its other checks are then
        ``None``.

    Notes
    -----
    Linear precision (Eq. 26) is ``max_i |(L (V - c))_i|`` over interior vertices relative
    to ``max|L| * diameter``, with ``c`` the centre and ``diameter`` the diagonal of the
    bounding box of the vertices in tets; it applies to meshes in R^3 (an immersed mesh is
    curved). Measured in that frame, the number does not depend on where the mesh lies
    (a mesh offset by ``1e12`` gets the numbers of the mesh translated back): in the frame
    of the origin it would add ``c`` times each row's sum, whose rounding is the row-sum
    check's business (``|row sum| <= 1e-10 max|L|``, which adds at most half the tolerance
    here, since ``|x_i - c| <= diameter / 2``), and a perfect operator 1e6 away from the
    origin would fail. One tolerance (``TOL``, relative to ``max|L|`` times a length of
    the mesh) thus serves both checks, at every offset and scale. ``kind="cell"`` measures
    the cell centres in the same frame.

    ``L`` counts as negative semidefinite when ``-L + 1e-9 diag(|L_ii|)`` is positive
    semidefinite (``NSD_RTOL``): the tolerance of each vertex is relative to its own row
    (equivalently, the Jacobi-scaled ``D^-1/2 (-L) D^-1/2``, ``D = diag(|L_ii|)``, has no
    eigenvalue below -1e-9). A mesh part of another scale (a far larger component, a far
    finer region) therefore changes nothing about the answer for the rest: "yes" holds of
    every part, and scaling any part leaves the answer as it is. The answer is the first
    of these, cheapest first, that decides; ``nsd_method`` names it. The **element
    certificate**, if ``L`` is the mesh's operator of ``kind`` (without ``kind``: the
    primal, then the dual) to 1e-12 relative: ``-L`` is the sum of per-tet matrices
    ``K_t``; each is checked positive semidefinite (for the primal, ``Vol_t G_t G_t^T``: by
    construction), and tets that fail are grouped with face neighbours until each group's
    sum is (a sum of positive semidefinite matrices is one); at every vertex the shifts of
    the pieces and the gap to ``L`` add up to at most its tolerance. Then the certificate of
    :func:`tetlap._core.negative_semidefinite` on the edge weights: non-negative weights (a
    weighted graph Laplacian), or every negative weight covered by the positive weights of
    its neighbourhood, or a witness vector ``x`` on a small neighbourhood with
    ``x^T (-L) x < -1e-9 x^T D x`` (indefinite, by interlacing). Those steps cost ``O(size
    of the mesh)``. When none of them answers and ``n <= 30000`` (``SPARSE_NSD_MAX``), the
    inertia of a sparse LDL^T of ``-L + 1e-9 D`` (seconds at that size); when that
    factorisation has to pivot off the diagonal and ``n <= 2500`` (``DENSE_NSD_MAX``),
    dense eigenvalues (of ``-L``, whose smallest is reported, and of the scaled matrix,
    which decide). Otherwise ``nsd`` is None and ``nsd_method`` says why.

    With ``coefficient=K`` every row reads ``L`` as an operator of ``div(K grad u)``:
    symmetry, zero row sums, locality and the sign of the weights as above; the element
    certificate compares ``L`` with the operators built with ``K`` (each tet's
    contribution in its metric is ``sqrt(det K_t)`` times the contribution of the tet
    mapped by ``K_t^-1/2``, positive semidefinite as that one is); linear precision only
    where ``K`` is one value on every tet (a ``(3, 3)`` tensor, or equal rows): then
    linear functions are ``K``-harmonic and the residual test holds; where ``K`` varies
    between tets the row is "n/a", with that reason in ``notes``. Per tet and face
    (points in R^3): a tet is obtuse in the metric when its primal contribution with
    ``K`` has a weight below ``-negative_tol`` times its largest ``|weight|`` (the
    cotangent of a dihedral angle above 90 degrees of the mapped tet, as
    :func:`tetlap.diagnostics.dihedral_angles` gives them with ``coefficient=K``); an
    interior face is not locally Delaunay in the metric by
    :func:`tetlap.diagnostics.non_delaunay_faces` with ``coefficient=K``, each tet
    contributing in its own metric. A scalar coefficient changes neither count.

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.weighted_ball(600, 0.5, seed=1)
    >>> r = tetlap.check(tetlap.laplacian(V, T, "dual"), V, T)
    >>> r.nsd, r.n_negative_interior > 0
    (False, True)
    >>> import numpy as np
    >>> V, T = tetlap.meshes.cube(3)
    >>> K = np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.5], [0.0, 0.5, 1.0]])
    >>> r = tetlap.check(tetlap.laplacian(V, T, coefficient=K), V, T, coefficient=K)
    >>> r.nsd, r.linear_precision_ok, r.n_obtuse_tets_metric > 0
    (True, True, True)
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if kind is not None and not (kind in ("primal", "dual", "cell") or (
            isinstance(kind, numbers.Real) and not isinstance(kind, bool) and 0 <= kind <= 1)):
        raise OptionError(f'kind must be None, "primal", "dual", "cell" or a float t in [0, 1], '
                          f'got {kind!r}')
    _options.tolerance(negative_tol, "negative_tol")
    nsd = _options.flag(nsd, "nsd")
    K = None if coefficient is None else _coefficient.check(coefficient, V, T)
    if kind == "cell":
        if K is not None:
            raise OptionError('coefficient= applies to the vertex Laplacians; with kind="cell" '
                              "L is read as given")
        return _cell_report(L, V, T, M, weights=weights, negative_tol=negative_tol, nsd=nsd)
    if weights is not None:
        raise OptionError('weights= applies to kind="cell" only: the vertex weights of the '
                          "dual whose power centres L's cells were built with; the other "
                          "kinds read L as given")
    return _check(L, V, T, M, kind=kind, negative_tol=negative_tol, nsd=nsd, coefficient=K)


def negative_weights(L, V, T, on_boundary=None) -> tuple[int, int]:
    """``(negative, negative_interior)``: the weights of ``L`` that count as negative, over
    all mesh edges and over the edges not both on the boundary, by the one rule of
    :func:`check` (``w < -NEGATIVE_TOL * max|w|``, counted by the core in one pass).

    ``V``, ``T`` validated (float64 points, int64 tets); ``on_boundary`` the (n,) boundary
    vertex mask when the caller has it. ``L`` in the stiffness sign (``-L``) is refused, as
    by :func:`check`.
    """
    L = _arrays.laplacian(L, V.shape[0])
    if on_boundary is None:
        on_boundary = diagnostics.boundary_vertices(T, V.shape[0])
    c = _core.check_operator(V, T, _sparse.arrays(L), on_boundary, NEGATIVE_TOL)
    return int(c["n_negative"]), int(c["n_negative_inner"])


def _fold_note(V, T) -> list[str]:
    """The note of a failed linear precision on a folded mesh: its folded tets and the
    vertices they spoil (:mod:`tetlap.diagnostics`), where every operator loses linear
    precision; none if the mesh has no fold."""
    vertices = np.flatnonzero(diagnostics.folded_vertices(V, T))
    if not len(vertices):
        return []
    tets = np.flatnonzero(diagnostics.folded_tets(V, T))
    listed = lambda x: ", ".join(map(str, x[:diagnostics.LISTED])) + (
        ", ..." if len(x) > diagnostics.LISTED else "")
    return [f"linear precision: the mesh folds over itself ({len(tets)} tets overlap a "
            f"neighbour: {listed(tets)}); every Laplacian loses linear precision at the "
            f"{len(vertices)} vertices of the folded faces: {listed(vertices)}"]


def lumped_masses(M, T, n: int) -> np.ndarray:
    """The lumped masses (row sums of ``M``, (n, n)) of the vertices in tets ``T``, in
    vertex order: the masses :func:`check` reports (``mass_min``, ``mass_nonpositive``)
    and ``tetlap info --plot`` draws and counts. A vertex in no tet has no mass to check
    (its 0 is no fault of the mass)."""
    M = _arrays.matrix(M, n, "M")
    return np.asarray(M.sum(axis=1)).ravel()[diagnostics.referenced_vertices(T, n)]


def _check(L, V, T, M, *, kind, negative_tol, nsd, boundary=None, mesh_volume=None,
           assembled=False, weights=None, coefficient=None) -> Report:
    """:func:`check` on validated ``V`` (float64) and ``T`` (int64), reusing what the
    caller already has: the ``boundary`` vertex mask, the ``mesh_volume``, and
    ``assembled=True`` when ``L`` is ``laplacian(V, T, kind, degenerate="skip",
    weights=weights, coefficient=coefficient)`` itself (``weights``: the vertex weights of a
    weighted dual, for its element certificate); ``coefficient`` validated
    (:func:`tetlap.coefficient.check`) or None."""
    n = V.shape[0]
    # a NaN or Inf is reported, not refused; the stiffness sign (-L) is refused: its every
    # sign-dependent row would answer for the negated operator
    L = _arrays.laplacian(L, n, finite=False)
    if boundary is None:
        boundary = diagnostics.boundary_vertices(T, n)
    c = _core.check_operator(V, T, _sparse.arrays(L), boundary, float(negative_tol))
    notes: list[str] = []
    scale = c["scale"] if c["scale"] > 0 else 1.0
    lp = c["linear_precision"]
    varying = coefficient is not None and not _constant(coefficient)
    if varying:
        lp = None
        notes.append("linear precision: not applicable: the coefficient varies between "
                     "elements: linear functions are not solutions")
    elif V.shape[1] != 3:
        notes.append("linear precision: not applicable to an immersed (d > 3) mesh")
    elif lp is None:
        notes.append("linear precision: the mesh has no interior vertices")
    elif not lp < TOL:
        notes += _fold_note(V, T)

    finite = c["finite"]
    if not finite:
        notes.append("L has NaN or Inf entries: only finiteness and locality are decided")
    decided = (lambda ok: ok) if finite else (lambda ok: None)

    nsd_ok, min_eig, method = None, None, "skipped (nsd=False)"
    if nsd and not c["finite"]:
        method = "skipped (not finite)"
    elif nsd:
        nsd_ok, min_eig, method = _nsd(L, V, T, scale, kind, assembled, weights, coefficient)

    edges, inner = c["n_edges"], c["n_edges_inner"]
    report = Report(
        n_vertices=n,
        n_tets=int(T.shape[0]),
        finite=finite,
        symmetric=decided(c["symmetry_error"] <= TOL * scale),
        symmetry_error=c["symmetry_error"],
        max_row_sum=c["max_row_sum"],
        row_sums_ok=decided(c["max_row_sum"] <= TOL * scale),
        local=c["local"],
        linear_precision_residual=lp,
        linear_precision_ok=None if lp is None else decided(lp < TOL),
        nsd=nsd_ok,
        nsd_min_eigenvalue_upper_bound=min_eig,
        nsd_method=method,
        min_weight=c["min_weight"],
        n_edges=edges,
        n_negative=c["n_negative"],
        negative_fraction=c["n_negative"] / edges if edges else 0.0,
        n_edges_interior=inner,
        n_negative_interior=c["n_negative_inner"],
        negative_fraction_interior=c["n_negative_inner"] / inner if inner else 0.0,
        negative_tol=negative_tol,
        notes=notes,
    )
    if coefficient is not None:
        report.coefficient = "varying" if varying else "constant"
        if V.shape[1] == 3:
            _in_metric(report, V, T, coefficient, negative_tol)
    if M is not None:
        M = _arrays.matrix(M, n, "M")
        lumped = lumped_masses(M, T, n)
        report.mass_min = float(lumped.min())
        report.mass_nonpositive = int((lumped <= 0).sum())
        report.mass_total = float(M.sum())
        report.mesh_volume = (float(np.abs(diagnostics.signed_volumes(V, T)).sum())
                              if mesh_volume is None else mesh_volume)
    return report


def _constant(K: np.ndarray) -> bool:
    """A validated coefficient is one value on every element: one ``(3, 3)`` tensor, or all
    rows equal (exactly)."""
    return K.ndim == 2 or bool((K == K[:1]).all())


def _in_metric(report: Report, V, T, K: np.ndarray, negative_tol: float) -> None:
    """The per-tet and per-face rows in the metric of the validated coefficient ``K``
    (points in R^3): the tets obtuse in their metric (a primal contribution with ``K``
    below ``-negative_tol`` times the tet's largest ``|weight|``, the worst first: the most
    negative relative weight) and the interior faces not locally Delaunay in the metric
    (:func:`tetlap.diagnostics.non_delaunay_faces`, the worst first: the most negative
    relative face weight)."""
    W = assembly._element_laplacians(V, T, "primal", coefficient=K)[:, :6]
    size = np.abs(W).max(axis=1)
    relative = np.divide(W.min(axis=1), size, out=np.zeros(len(W)), where=size > 0)
    obtuse = np.flatnonzero(relative < -negative_tol)
    obtuse = obtuse[np.argsort(relative[obtuse], kind="stable")]
    report.n_obtuse_tets_metric = len(obtuse)
    report.obtuse_tets_metric = [int(t) for t in obtuse[:diagnostics.LISTED]]
    interior = _core.faces(T, len(V))[1]
    tensors = K if K.ndim > 1 else np.eye(3)          # a scalar changes no face's answer
    flags, margin = diagnostics._delaunay_in_metric(
        V, T, np.broadcast_to(tensors, (len(T), 3, 3)), interior)
    bad = np.flatnonzero(flags)
    bad = bad[np.argsort(margin[bad], kind="stable")]
    report.n_non_delaunay_faces_metric = len(bad)
    report.non_delaunay_faces_metric = interior[bad[:diagnostics.LISTED]][:, [0, 2]].tolist()


#: Largest n for the last NSD step, the inertia of a sparse LDL^T factorisation.
SPARSE_NSD_MAX = 30_000


def _ldl_inertia(A: sp.csr_array, shift: np.ndarray) -> int | None:
    """Negative pivots of a symmetric-mode LU (an LDL^T with diagonal pivoting and a
    fill-reducing ordering) of ``A + diag(shift)``: by Sylvester's law, the number of its
    negative eigenvalues. None if the factorisation had to pivot off the diagonal. Runs in
    a child process (:func:`tetlap._interrupt.splu`), so Ctrl-C is answered at once and
    stops it."""
    shifted = sp.csc_array(A + sp.diags_array(shift))
    lu = splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
              options={"SymmetricMode": True})
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    return int((lu.U.diagonal() < 0).sum())


def _row_gaps(A: sp.csr_array, B: sp.csr_array) -> np.ndarray:
    """``sum_j |A_ij - B_ij|`` per row (n,): for symmetric ``A`` and ``B``,
    ``|x^T (A - B) x| <= sum_i gap_i x_i^2`` (Gershgorin)."""
    return np.asarray(abs(A - B).sum(axis=1)).ravel()


def _live_rows(S: sp.csr_array, diagonal: np.ndarray) -> tuple[np.ndarray, int | None]:
    """The rows of ``S`` with a non-zero entry, and the first of them whose diagonal is
    zero (None if none is). An all-zero row is an eigenvalue 0 on its own, semidefinite
    under any tolerance; a row with entries but a zero diagonal makes ``-L + diag(tol)``
    indefinite whatever the tolerances (its 2 x 2 principal minor with an off-diagonal
    entry has a negative determinant)."""
    live = np.asarray(abs(S).sum(axis=1)).ravel() > 0
    zero = np.flatnonzero(live & (diagonal == 0))
    return np.flatnonzero(live), (int(zero[0]) if len(zero) else None)


def _dense(S: sp.csr_array, diagonal: np.ndarray):
    """(is NSD, smallest eigenvalue of -L) from dense eigenvalues, on one BLAS thread (the
    core's threads and other processes would make more spin against each other): those of
    ``-L`` (the smallest is reported) and, unless that one already says no, those of the
    Jacobi-scaled ``D^-1/2 (-L) D^-1/2`` on the rows with entries, which decide."""
    A = (-S).toarray()
    with one_blas_thread():
        lam = float(eigvalsh(A)[0])
        verdict = False  # lambda_min(-L + diag(tol)) <= lam + max(tol) < 0
        if lam >= -NSD_RTOL * diagonal.max():
            live, zero_diagonal = _live_rows(S, diagonal)
            verdict = zero_diagonal is None
            if verdict and len(live):
                s = 1 / np.sqrt(diagonal[live])
                B = A[np.ix_(live, live)] * s[:, None] * s[None, :]
                verdict = float(eigvalsh(B)[0]) >= -NSD_RTOL
    return verdict, lam


def _nsd(L: sp.csr_array, V, T, scale: float, kind, assembled: bool, weights=None,
         coefficient=None):
    """(is NSD, smallest eigenvalue of -L or a witness' Rayleigh quotient, method): the
    cheapest answer first (see :func:`check`, Notes); ``weights`` those of a weighted dual
    (``kind="dual"``, ``assembled=True``). A matrix whose largest entry is beyond
    ``2^-900 .. 2^900`` is decided scaled by a power of two (exact for it, and the
    answer of a positive multiple): its tolerances and pivots would leave the normal
    float64 range (SuperLU called ``L * 1e-320`` exactly singular)."""
    S = (L + L.T) / 2
    S.sort_indices()
    largest = float(abs(S).max()) if S.nnz else 0.0
    if largest == 0 or 2.0**-900 <= largest <= 2.0**900 or not np.isfinite(largest):
        return _nsd_of(S, V, T, scale, kind, assembled, weights, coefficient)
    shift = -int(np.frexp(largest)[1])
    S = sp.csr_array((np.ldexp(S.data, shift), S.indices, S.indptr), shape=S.shape)
    verdict, lam, method = _nsd_of(S, V, T, scale, kind, assembled, weights, coefficient)
    return (verdict, None if lam is None else float(np.ldexp(lam, -shift)),
            f"{method} (on L x 2^{shift}, exact)")


def _nsd_of(S: sp.csr_array, V, T, scale: float, kind, assembled: bool, weights,
            coefficient=None):
    """:func:`_nsd` of the symmetric part ``S`` (sorted indices)."""
    n = S.shape[0]
    diagonal = np.abs(S.diagonal())
    tol = NSD_RTOL * diagonal
    answer = _element_certificate(S, V, T, scale, tol, kind, assembled, weights, coefficient)
    if answer is not None:
        return answer
    verdict, name, details = _core.negative_semidefinite(n, _sparse.arrays(S), tol)
    # the rows of L: the mesh's vertices, or the cells of a cell-centred operator
    one, many = ("cell", "cells") if kind == "cell" else ("vertex", "vertices")
    if name == "local certificate":
        return verdict, None, (f"local certificate: {details['groups']} neighbourhoods of <= "
                               f"{details['largest']} {many} cover every negative weight")
    if name == "indefinite":
        return False, details["rayleigh"], (
            f"witness: a vector on {details['support']} {many} around {one} "
            f"{details['vertex']} with Rayleigh quotient {details['rayleigh']:.3e}")
    if name != "undetermined":
        return verdict, None, name
    reason = (f"{details['uncovered']} negative weights not covered by neighbourhoods of "
              f"<= {_core.MAX_GROUP} {many}")
    live, zero_diagonal = _live_rows(S, diagonal)
    if zero_diagonal is not None:
        return False, None, (f"row {zero_diagonal} of L has entries but a zero diagonal "
                             "(an indefinite 2 x 2 principal minor)")
    if n <= SPARSE_NSD_MAX:
        negatives = _ldl_inertia((-S)[live][:, live], tol[live])
        if negatives is not None:
            return negatives == 0, None, (f"inertia of a sparse LDL^T of -L + {NSD_RTOL:.0e} "
                                          f"diag(|L_ii|): {negatives} negative pivots ({reason})")
        reason += "; the LDL^T pivoted off the diagonal"
    # a vertex in no tet whose row is empty takes no part (its eigenvalue 0 is no answer);
    # every cell of a cell operator does
    mesh = np.ones(n, dtype=bool) if kind == "cell" else diagnostics.referenced_vertices(T, n)
    part = mesh | (np.asarray(abs(S).sum(axis=1)).ravel() > 0)
    if part.sum() <= DENSE_NSD_MAX:
        verdict, lam = (_dense(S, diagonal) if part.all()
                        else _dense(S[part][:, part], diagonal[part]))
        return verdict, lam, f"dense eigenvalues ({reason})"
    limit = DENSE_NSD_MAX if n <= SPARSE_NSD_MAX else SPARSE_NSD_MAX
    return None, None, f"undetermined: {reason} (n > {limit})"


def _element_certificate(S, V, T, scale: float, tol: np.ndarray, kind, assembled: bool,
                         weights=None, coefficient=None):
    """The NSD answer from the per-tet matrices, if ``S`` (the symmetric part of ``L``) is
    the mesh's operator ``kind`` (the primal, then the dual, when ``kind`` is None):
    ``-S = sum_t K_t + E`` with ``|x^T E x| <= sum_i gap_i x_i^2``; every ``K_t`` is
    checked, failing ones in small groups of neighbours, with the shifts ``tol - gap``
    (:func:`tetlap._core.element_certificate`). None when ``S`` is none of them, a gap
    exceeds its vertex's tolerance or a group could not be certified. ``assembled``: ``L``
    is that operator (gaps zero), with the vertex ``weights`` of a weighted dual if
    given; every candidate is built with the validated ``coefficient`` if given (each
    tet's matrix in its metric is positive semidefinite as the plain one is)."""
    n = V.shape[0]
    if kind == "cell":  # a cell operator is no sum of per-tet matrices on the vertices
        return None
    for candidate in ("primal", "dual") if kind is None else (kind,):
        gaps = (np.zeros(n) if assembled
                else _row_gaps(S, assembly.laplacian(V, T, candidate, degenerate="skip",
                                                     coefficient=coefficient)))
        gap = float(gaps.max())
        if gap > 1e-12 * scale:
            continue
        if (gaps > tol).any():
            return None
        W = assembly._element_laplacians(V, T, candidate, weights if assembled else None,
                                         coefficient)
        verdict, _, details = _core.element_certificate(T, n, W, tol - gaps)
        if not verdict:
            return None
        name = candidate if isinstance(candidate, str) else f"t = {candidate:g} affine"
        name = f"weighted {name}" if weights is not None and assembled else name
        name += " (with the coefficient)" if coefficient is not None else ""
        groups = details["groups"]
        covered = (f", except in {groups} groups of <= {details['largest']} neighbouring tets "
                   "whose sums are positive semidefinite" if groups else "")
        construction = " (Gram matrices: by construction)" if candidate == "primal" else ""
        return True, None, (f"element certificate: L is the {name} Laplacian (to {gap:.1e}), a sum "
                            f"of per-tet matrices{construction}, each positive semidefinite{covered}")
    return None


# The report of a cell-centred operator (check(Lc, V, T, kind="cell")), public as
# tetlap.cells.CellReport: here, beside the checks it shares, so that tetlap.cells (the
# operator) imports the analysis and not the other way round.
@dataclasses.dataclass
class CellReport(Report):
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


def _cell_report(L, V: np.ndarray, T: np.ndarray, M, *, weights, negative_tol: float, nsd: bool):
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
        nsd_ok, min_eig, method = _nsd(L, V, T, scale, "cell", False)
    fraction = lambda k, total: k / total if total else 0.0
    report = CellReport(
        n_vertices=V.shape[0], n_tets=m, finite=finite,
        symmetric=decided(symmetry_error <= TOL * scale), symmetry_error=symmetry_error,
        max_row_sum=max_row_sum, row_sums_ok=decided(max_row_sum <= TOL * scale),
        local=local, linear_precision_residual=residual,
        linear_precision_ok=None if residual is None else decided(residual < TOL),
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
