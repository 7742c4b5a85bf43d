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

from . import _arrays, _core
from ._docs import shared_docs
from .analysis import CellReport
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
