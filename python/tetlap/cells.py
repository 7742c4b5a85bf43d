"""The cell-centred two-point-flux Laplacian of a tet mesh (finite volumes on the tets,
with the circumcentres or power centres as cell centres), and its Table 1 report.

>>> import tetlap
>>> V, T = tetlap.meshes.ball(300, seed=3)
>>> Lc = tetlap.cell_laplacian(V, T)
>>> Lc.shape == (len(T), len(T)), bool(abs(Lc.sum(axis=1)).max() < 1e-12 * abs(Lc).max())
(True, True)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from typing import NamedTuple

from . import _arrays, _core
from ._docs import shared_docs
from .analysis import CellReport
from .coefficient import _argument
from .dual import OUTSIDE_TOL, DualGeometry, dual_geometry
from .errors import DegenerateElementError, DtypeError, NonFiniteError, ShapeError
from ._names import public_dir

__all__ = ["cell_laplacian", "k_orthogonality", "KOrthogonality", "CellReport", "ZERO_TOL",
           "ANGLE_TOL"]
__dir__ = public_dir(globals())

#: A dual edge counts as zero-length when ``|dual_length| <= ZERO_TOL * r``, ``r`` the
#: larger distance from its two centres to the face's first corner (2^-40, the core's
#: documented accuracy, as :data:`tetlap.dual.OUTSIDE_TOL`): the two centres coincide to
#: the accuracy they are known with.
ZERO_TOL = OUTSIDE_TOL

#: A face counts as K-orthogonal on one side when the angle between ``K n`` and the
#: centre-to-centre line is at most ``ANGLE_TOL`` radians (2^-30, about 1e-9: rounding of
#: centres computed to the core's accuracy stays far below it).
ANGLE_TOL = 2.0 ** -30


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


def _degenerate_face(g: DualGeometry, interior, s, t, k: int, count: int, what: str):
    face = tuple(g.faces[interior[k]].tolist())
    return DegenerateElementError(
        f"face {face} between tets {s[k]} and {t[k]} {what}, so its two-point flux is "
        f"infinite; {count} faces are like it. Perturb the mesh, pass vertex weights or "
        "centres that separate the centres, or degenerate=\"skip\" to give those faces no "
        "flux", element=int(s[k]))


def _centres(centres, m: int) -> np.ndarray:
    """``centres`` as a new finite (m, 3) float64 array."""
    arr = _arrays._as_array(centres, "centres")
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"centres must hold real numbers, got dtype {arr.dtype}")
    if arr.shape != (m, 3):
        raise ShapeError(f"centres must have shape ({m}, 3), one point per tet, got {arr.shape}")
    arr = np.array(arr, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        raise NonFiniteError(f"centres[{bad[0]}] (tet {bad[0]}) is not finite: {arr[bad[0]]}",
                             element=int(bad[0]))
    return arr


def _coefficient_and_centres(V, T, coefficient, centres):
    """The validated ``coefficient`` and ``centres`` (each None if not given) of a tet mesh
    in R^3."""
    if coefficient is None and centres is None:
        return None, None
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        what = "a coefficient" if coefficient is not None else "centres"
        raise ShapeError(f"cell_laplacian with {what} takes tets in R^3; V has {V.shape[1]} "
                         "columns")
    K = _argument(coefficient, (V.shape, T.shape))
    if K is not None:
        _core.check_coefficient(K, T.shape[0], 4, 3)
    X = None if centres is None else _centres(centres, T.shape[0])
    return K, X


class _Faces(NamedTuple):
    """The interior faces seen from their two cells ``s < t``, for the tensor scheme."""

    interior: np.ndarray  # (F,) indices into g.faces
    s: np.ndarray
    t: np.ndarray
    area: np.ndarray  # |f|
    n: np.ndarray  # (F, 3) unit normal, pointing out of tet s
    d: np.ndarray  # (F, 3) x_t - x_s
    tau: np.ndarray  # x_f = x_s + tau d: where the centre line crosses the face's plane
    Kn: tuple[np.ndarray, np.ndarray]  # K_s n, K_t n
    zero: np.ndarray  # the centre line does not cross the plane (to ZERO_TOL)


def _faces(V, T, g: DualGeometry, coefficient, centres) -> _Faces:
    interior = np.flatnonzero(g.face_tets[:, 1] >= 0)
    s, t = g.face_tets[interior, 0], g.face_tets[interior, 1]
    F = g.faces[interior]
    a = V[F[:, 0]]
    N = np.cross(V[F[:, 1]] - a, V[F[:, 2]] - a)
    opposite = V[T[s].sum(axis=1) - F.sum(axis=1)]
    N *= np.sign(np.einsum("fi,fi->f", N, a - opposite))[:, None] / np.linalg.norm(N, axis=1)[:, None]
    X = g.centres if centres is None else centres
    d = X[t] - X[s]
    nd = np.einsum("fi,fi->f", N, d)
    reach = np.maximum(np.linalg.norm(X[s] - a, axis=1), np.linalg.norm(X[t] - a, axis=1))
    zero = np.abs(nd) <= ZERO_TOL * reach
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.einsum("fi,fi->f", N, a - X[s]) / nd
    K = coefficient
    if K.ndim == 1:
        Kn = (K[s, None] * N, K[t, None] * N)
    elif K.ndim == 2:
        Kn = (N @ K, N @ K)  # K symmetric
    else:
        Kn = (np.einsum("fij,fj->fi", K[s], N), np.einsum("fij,fj->fi", K[t], N))
    return _Faces(interior, s, t, g.face_area[interior], N, d, tau, Kn, zero)


def _tensor_weights(f: _Faces, g: DualGeometry, degenerate: str):
    """``(s, t, w)`` as :func:`_interior_weights`, ``w`` the harmonic combination of the
    half-transmissibilities ``a = |f| (K n) . (x_f - x) / |x_f - x|^2`` of the two cells."""
    d2 = np.einsum("fi,fi->f", f.d, f.d)
    with np.errstate(divide="ignore", invalid="ignore"):
        # 1 / a_s = tau |d|^2 / (|f| (K_s n) . d), 1 / a_t = (1 - tau) |d|^2 / (|f| (K_t n) . d)
        r_s = np.where(f.tau == 0, 0.0, f.tau / np.einsum("fi,fi->f", f.Kn[0], f.d))
        r_t = np.where(f.tau == 1, 0.0, (1 - f.tau) / np.einsum("fi,fi->f", f.Kn[1], f.d))
        r = r_s + r_t
        infinite = f.zero | (np.isfinite(r) & (np.abs(r) <= ZERO_TOL * (np.abs(r_s) + np.abs(r_t))))
        w = f.area / (d2 * r)
    w[np.isnan(w)] = 0.0  # K_s n and K_t n both orthogonal to the line: no flux
    if infinite.any() and degenerate == "raise":
        k = int(np.flatnonzero(infinite)[0])
        what = ("has centres whose line does not cross its plane (they coincide, or the "
                "line runs parallel to the face)" if f.zero[k] else
                "has half-transmissibilities of opposite signs that cancel")
        raise _degenerate_face(g, f.interior, f.s, f.t, k, int(infinite.sum()), what)
    w[infinite] = 0.0
    return f.s, f.t, w


@_arrays.takes_mesh_object
@shared_docs
def cell_laplacian(V, T=None, *, weights=None, coefficient=None, centres=None, degenerate="raise",
                   threads=None) -> sp.csr_array:
    """The (m, m) cell-centred two-point-flux Laplacian of a tet mesh: the DEC Laplacian on
    dual 0-forms (one value per tet, at its circumcentre or power centre).

    Parameters
    ----------
    {dual_mesh}
    coefficient : array-like of real numbers, optional
        ``K`` of ``div(K grad u)`` per tet, as ``coefficient=`` of :func:`tetlap.laplacian`:
        ``(m,)`` positive scalars, ``(m, 3, 3)`` symmetric positive definite tensors or one
        ``(3, 3)`` tensor; tets in R^3 only. The transmissibility of the face ``f`` between
        the cells ``s`` and ``t`` is then the harmonic combination
        ``a_s a_t / (a_s + a_t)`` of the half-transmissibilities
        ``a_s = |f| (K_s n) . (x_f - x_s) / |x_f - x_s|^2`` (``a_t`` alike with ``x_t -
        x_f``), ``n`` the unit normal of ``f`` pointing out of ``s``, ``x_s``, ``x_t`` the
        cell centres and ``x_f`` the point where the line ``x_s x_t`` crosses the plane of
        ``f`` (the two-point flux of PorePy or DuMux with that face point). With tetlap's
        centres ``x_f`` is the face's circumcentre (power centre), so a coefficient of ones
        gives the plain weights ``A_f / l_f`` up to rounding, and a scalar ``c`` gives
        ``A_f / (h_s / c_s + h_t / c_t)`` (``h`` the signed distances of the centres from
        the face). The scheme is exact for linear solutions of a constant ``K`` where
        every face is K-orthogonal (``K n`` parallel to ``x_t - x_s``, see
        :func:`k_orthogonality`); a non-scalar ``K`` is K-orthogonal on the circumcentric
        cells only where ``n`` is its eigenvector, hence ``centres``. ``None``: the plain
        weights, bitwise.
    centres : (m, 3) array-like of real numbers, optional
        Cell centres to use instead of the circumcentres (power centres), for instance the
        circumcentres in the metric ``K^-1``, which are K-orthogonal on a mesh Delaunay in
        that metric. The weights are then the harmonic combination above (with ``K = I``
        when ``coefficient`` is None). Tets in R^3 only.
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
        move ``A_f / l_f * g(face_centres[f])`` to the right-hand side. With a
        ``coefficient`` or ``centres``, ``Lc[s, t]`` is the harmonic transmissibility
        described there, with the same signs, symmetry and zero row sums (it is negative
        where the half-transmissibilities are: a centre on the wrong side of the face, or
        ``K n`` at more than a right angle to the centre line); a face whose centre line
        does not cross its plane, or whose two half-transmissibilities cancel, is
        degenerate as above.

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
    K, X = _coefficient_and_centres(V, T, coefficient, centres)
    g = dual_geometry(V, T, weights=weights, threads=threads)
    if K is None and X is None:
        s, t, w = _interior_weights(g, degenerate, V)
    else:
        T = _arrays.elements(T, 4)
        s, t, w = _tensor_weights(_faces(V, T, g, np.ones(len(T)) if K is None else K, X),
                                  g, degenerate)
    m = len(g.volume)
    diagonal = -(np.bincount(s, weights=w, minlength=m) + np.bincount(t, weights=w, minlength=m))
    cells = np.arange(m)
    Lc = sp.coo_array((np.concatenate([w, w, diagonal]),
                       (np.concatenate([s, t, cells]), np.concatenate([t, s, cells]))),
                      shape=(m, m)).tocsr()
    Lc.sort_indices()
    return Lc


class KOrthogonality(NamedTuple):
    """The result of :func:`k_orthogonality`: per interior face, how far the two-point
    flux is from consistent."""

    faces: np.ndarray
    """(F, 3) int64: the interior faces (rows of :attr:`tetlap.DualGeometry.faces`)."""
    tets: np.ndarray
    """(F, 2) int64: the two cells ``s < t`` of each face."""
    angle: np.ndarray
    """(F, 2) float64, radians in ``[0, pi]``: the angle between ``K_s n`` and the centre
    line ``x_t - x_s`` (column 0), and between ``K_t n`` and it (column 1), ``n`` the
    face's unit normal out of ``s``. 0 where the face is K-orthogonal on that side; above
    ``pi / 2`` the half-transmissibility is negative. NaN where the two centres coincide."""
    max_angle: float
    """The largest angle (NaN only if every face has coinciding centres; 0 without
    interior faces)."""
    orthogonal: int
    """Faces K-orthogonal on both sides (both angles at most :data:`ANGLE_TOL`)."""
    obtuse: int
    """Faces with an angle above ``pi / 2`` on at least one side."""


@_arrays.takes_mesh_object
@shared_docs
def k_orthogonality(V, T=None, coefficient=None, *, weights=None, centres=None,
                    threads=None) -> KOrthogonality:
    """The K-orthogonality of the cells of :func:`cell_laplacian`: per interior face, the
    angle between ``K n`` and the centre-to-centre line on each side.

    The two-point flux ``Lc[s, t] (u_t - u_s)`` of the face is exact for linear ``u`` and a
    constant ``K`` when both angles are 0, and the scheme is then exact for linear
    solutions on every cell without a boundary face; the angles measure how far a mesh is
    from that (with ``K = I`` and tetlap's own centres, every angle is 0 or ``pi``: the
    dual edge is orthogonal to its face).

    Parameters
    ----------
    {dual_mesh}
    coefficient : array-like of real numbers, optional
        As ``coefficient=`` of :func:`cell_laplacian` (None: ``K = I``). Tets in R^3.
    centres : (m, 3) array-like of real numbers, optional
        As ``centres=`` of :func:`cell_laplacian` (None: circumcentres or power centres).

    Returns
    -------
    KOrthogonality
        ``faces``, ``tets``, ``angle`` (F, 2), ``max_angle``, and the counts
        ``orthogonal`` and ``obtuse``.

    Examples
    --------
    The circumcentric cells of a Delaunay mesh are orthogonal (``K = I``), but not
    K-orthogonal for a tensor whose eigenvectors are not the faces' normals:

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.ball(300, seed=3)
    >>> plain = tetlap.cells.k_orthogonality(V, T)
    >>> plain.orthogonal == len(plain.faces), plain.obtuse
    (True, 0)
    >>> K = np.diag([1.0, 1.0, 10.0])
    >>> tetlap.cells.k_orthogonality(V, T, K).orthogonal
    0
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    K, X = _coefficient_and_centres(V, T, np.ones(len(T)) if coefficient is None else coefficient,
                                    centres)
    g = dual_geometry(V, T, weights=weights, threads=threads)
    f = _faces(V, T, g, K, X)
    angle = np.empty((len(f.s), 2))
    for side, Kn in enumerate(f.Kn):
        cross = np.linalg.norm(np.cross(Kn, f.d), axis=1)
        angle[:, side] = np.arctan2(cross, np.einsum("fi,fi->f", Kn, f.d))
    angle[np.all(f.d == 0, axis=1)] = np.nan
    worst = angle.max(axis=1)
    return KOrthogonality(
        faces=g.faces[f.interior], tets=np.stack([f.s, f.t], axis=1), angle=angle,
        max_angle=float(np.nanmax(worst)) if np.isfinite(worst).any() else
        (float("nan") if len(worst) else 0.0),
        orthogonal=int(np.sum(worst <= ANGLE_TOL)), obtuse=int(np.sum(worst > np.pi / 2)))
