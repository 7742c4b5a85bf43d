"""Laplacians and mass matrices of tetrahedral meshes as SciPy sparse arrays.

Conventions (all functions)
---------------------------
V : (n, d) array-like of real numbers, d >= 3 for tets, d >= 2 for triangles (larger d:
    an immersed mesh; every element is computed in its own 3- or 2-space). Any real dtype;
    converted to float64.
T : (m, 4) tets or (m, 3) triangles: integer vertex indices, 0-based, any integer dtype,
    any orientation: results do not depend on the orientation or vertex order of an
    element. For triangles the primal (cotan, Eq. 6) and the dual (Eq. 16) coincide; the
    local edge order is (0,1), (0,2), (1,2); ``boundary`` and ``weights`` are for tets.
L : (n, n) ``scipy.sparse.csr_array``, float64, sorted indices, no duplicates, pattern
    exactly the mesh edges plus the diagonal. Sign as in the paper (Eq. 1):
    ``L[i, j] = w_ij`` on edges, ``L[i, i] = -sum_j w_ij``; rows sum to zero; the primal L
    is negative semidefinite, and ``-L`` is the P1 stiffness matrix.
kind : ``"primal"`` (P1 FEM / cotan, Eq. 7), ``"dual"`` (circumcentric DEC, Eq. 17-20),
    or a float ``t`` in [0, 1] for ``(1 - t) L_primal + t L_dual`` (Sec. 9).
boundary : ``"circumcentric"`` (default) or ``"barycentric"``: in tets with a boundary
    face, dual vertices (tet and face circumcenters) outside their simplex are replaced by
    centroids (paper Sec. 6). Positive circumcentric masses and dual weights in those tets;
    linear precision is lost at their vertices. Affects the dual and circumcentric mass.
weights : optional (n,) vertex weights (squared length units) for the dual and the
    circumcentric mass: weighted circumcenters, i.e. the orthogonal dual of a regular
    (weighted Delaunay) triangulation, a power diagram. ``None`` or zeros: the plain dual.
degenerate : ``"raise"`` (default: a zero-volume tet raises
    :class:`~tetlap.DegenerateElementError` naming it) or ``"skip"`` (such tets contribute
    nothing; their edges stay in the pattern).
threads : worker threads, ``None`` for all cores. Output is bitwise identical for any value.

Inputs are never modified. The GIL is released during the computation.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core

__all__ = [
    "laplacian",
    "mass",
    "operators",
    "triplets",
    "edge_weights",
    "tet_contributions",
    "Triplets",
]


def _inputs(V, T, weights=None, boundary="circumcentric"):
    V = _arrays.points(V)
    T = _arrays.elements(T)
    if T.shape[1] == 3 and (weights is not None or boundary != "circumcentric"):
        raise _arrays.OptionError("`weights` and `boundary` apply to tet meshes only")
    return V, T, _arrays.vertex_weights(weights, V.shape[0])


def _csr(arrays, n: int) -> sp.csr_array:
    """A canonical csr_array from the core's ``(data, uint32 indices, indptr)``, no copy."""
    data, indices, indptr = arrays
    indices = indices.view(np.int32) if indptr.dtype == np.int32 else indices.astype(np.int64)
    A = sp.csr_array((data, indices, indptr), shape=(n, n), copy=False)
    A.has_sorted_indices = True
    A.has_canonical_format = True
    return A


def _mass(result, n: int) -> sp.csr_array:
    form, arrays = result
    if form == "lumped":
        return sp.diags_array(arrays, format="csr")
    return _csr(arrays, n)


def laplacian(V, T, kind="primal", *, boundary="circumcentric", weights=None,
              degenerate="raise", threads=None) -> sp.csr_array:
    """The (n, n) Laplacian of a tetrahedral mesh.

    Parameters
    ----------
    V : (n, d) array-like, d >= 3.  T : (m, 4) integer array-like.
    kind : "primal" | "dual" | float t in [0, 1].  See the module docstring for all.

    Returns
    -------
    L : (n, n) csr_array, float64. ``L[i, j] = w_ij``, ``L[i, i] = -sum_j w_ij``.

    Example
    -------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> L = tetlap.laplacian(V, [[0, 1, 2, 3]], kind="dual")
    >>> L[[0], :].toarray().round(4)
    array([[-0.75,  0.25,  0.25,  0.25]])
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    name, t = _arrays.laplacian_kind(kind)
    arrays = _core.laplacian(V, T, w, name, t, opts)
    return _csr(arrays, V.shape[0])


def mass(V, T, kind="barycentric", *, boundary="circumcentric", weights=None,
         degenerate="raise", threads=None) -> sp.csr_array:
    """The (n, n) mass matrix of a tetrahedral mesh.

    kind : ``"barycentric"`` (Eq. 3, ``Vol/4`` per tet corner, diagonal),
        ``"circumcentric"`` (Eq. 4/21, signed dual-cell volumes ``Vol(*i)``, diagonal;
        negative entries are possible on non-Delaunay meshes), or ``"fem"`` (consistent
        P1 mass ``Vol (1 + delta_ab) / 20``, on the pattern of L).
    Unreferenced vertices get 0. The entries sum to the mesh volume for every kind.

    Example
    -------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> tetlap.mass(V, [[0, 1, 2, 3]], kind="circumcentric").diagonal() * 72
    array([9., 1., 1., 1.])
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    result = _core.mass(V, T, w, _arrays.mass_kind(kind), opts)
    return _mass(result, V.shape[0])


def operators(V, T, laplacian="primal", mass="barycentric", *, boundary="circumcentric",
              weights=None, degenerate="raise",
              threads=None) -> tuple[sp.csr_array, sp.csr_array]:
    """``(L, M)`` from one pass over the tets; same conventions as :func:`laplacian`
    and :func:`mass`.

    Example
    -------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> L, M = tetlap.operators(V, T, laplacian="dual", mass="circumcentric")
    >>> round(M.sum(), 12)
    1.0
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    name, t = _arrays.laplacian_kind(laplacian)
    L, M = _core.operators(V, T, w, name, t, _arrays.mass_kind(mass), opts)
    n = V.shape[0]
    return _csr(L, n), _mass(M, n)


class Triplets(NamedTuple):
    """Unsummed COO triplets: ``coo_array((vals, (rows, cols)), shape)`` sums them."""

    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    shape: tuple[int, int]


def triplets(V, T, kind="primal", *, boundary="circumcentric", weights=None,
             degenerate="raise", threads=None) -> Triplets:
    """The Laplacian as unsummed triplets: 16 per tet (9 per triangle), its local Laplacian.

    Returns rows, cols (int64, shape (16 m,)), vals (float64) and shape (n, n); entry
    ``16 t + 4 a + b`` belongs to corners ``a, b`` of tet ``t`` (``9 t + 3 a + b`` for
    triangles). Summing duplicates gives
    :func:`laplacian` up to rounding. Useful to assemble into another sparse format.

    Example
    -------
    >>> import tetlap, scipy.sparse as sp
    >>> V, T = tetlap.meshes.cube(2)
    >>> r, c, v, shape = tetlap.triplets(V, T)
    >>> L = sp.coo_array((v, (r, c)), shape=shape).tocsr()
    >>> bool(abs(L - tetlap.laplacian(V, T)).max() < 1e-12)
    True
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    name, t = _arrays.laplacian_kind(kind)
    rows, cols, vals = _core.triplets(V, T, w, name, t, opts)
    n = V.shape[0]
    return Triplets(rows, cols, vals, (n, n))


def edge_weights(V, T, kind="primal", *, boundary="circumcentric", weights=None,
                 degenerate="raise", threads=None):
    """Unique edges and their weights.

    Returns
    -------
    edges : (E, 2) int64, ``i < j``, sorted lexicographically.
    w : (E,) float64, ``w[e] = L[i, j]`` summed over the tets around edge e.

    Example
    -------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> edges, w = tetlap.edge_weights(V, [[0, 1, 2, 3]], kind="dual")
    >>> edges[0].tolist(), float(w[0])
    ([0, 1], 0.25)
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    name, t = _arrays.laplacian_kind(kind)
    return _core.edge_weights(V, T, w, name, t, opts)


def tet_contributions(V, T, kind="primal", *, boundary="circumcentric", weights=None,
                      degenerate="raise", threads=None) -> np.ndarray:
    """Per-element edge weights: (m, 6) float64 for tets, local edge order
    ``(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`` of each row of T; (m, 3) for triangles,
    order ``(0,1), (0,2), (1,2)``.

    Example
    -------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> (tetlap.tet_contributions(V, [[0, 1, 2, 3]], kind="primal") * 6).round(12)
    array([[1., 1., 1., 0., 0., 0.]])
    """
    V, T, w = _inputs(V, T, weights, boundary)
    opts = _arrays.options(threads, degenerate, boundary)
    name, t = _arrays.laplacian_kind(kind)
    return _core.tet_contributions(V, T, w, name, t, opts)
