"""Laplacians and mass matrices of tetrahedral (and triangle) meshes as SciPy arrays.

Every function takes the mesh ``(V, T)``, the operator kind and the same keyword options,
documented in full in each function. Inputs are never modified; the GIL is released
during the computation, which answers Ctrl-C.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, _sparse
from . import coefficient as _coefficient
from ._docs import shared_docs
from ._options import centres_used, renamed, weights_used
from ._names import public_dir

#: The local edges ``(a, b)`` of a tet, in the order of the columns of
#: :func:`element_contributions` (and of every per-tet edge array).
_LOCAL_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])

__all__ = [
    "laplacian",
    "mass",
    "operators",
    "triplets",
    "edge_weights",
    "element_contributions",
    "tet_contributions",
    "Triplets",
]
__dir__ = public_dir(globals())


def _options(boundary, degenerate, threads) -> dict:
    """The keyword options as the core takes them (it parses and checks them, once)."""
    return {"boundary": boundary, "degenerate": degenerate, "threads": threads}


def _assemble(what: tuple, V, T, weights, boundary, degenerate, threads, coefficient=None,
              density=None):
    """``(the core's result for what, n)``: the one path of every function here from the
    user's arguments to :func:`tetlap._core.assemble`."""
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T)
    w = _arrays.vertex_weights(weights, V.shape[0])
    if T.shape[1] == 4:  # triangles: the core refuses both
        weights_used(w is not None, what[1:])
        centres_used(boundary, what[1:])
    K = _coefficient._argument(coefficient, (V.shape, T.shape))
    rho = _coefficient._argument(density, (V.shape, T.shape), density=True)
    options = _options(boundary, degenerate, threads)
    return (_core.assemble(V, T, what, weights=w, medium=(K, rho), options=options),
            V.shape[0])


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def laplacian(V, T=None, kind="primal", *, boundary_centres="circumcentric", weights=None,
              coefficient=None, degenerate="raise", threads=None) -> sp.csr_array:
    """The (n, n) Laplacian of a tetrahedral or triangle mesh.

    Parameters
    ----------
    {mesh}
    {kind}
    {coefficient}
    {options}

    Returns
    -------
    L : (n, n) scipy.sparse.csr_array, float64
        ``L[i, j] = w_ij`` on edges, ``L[i, i] = -sum_j w_ij`` (paper Eq. 1): rows sum to
        zero, the primal ``L`` is negative semidefinite and ``-L`` is the P1 stiffness
        matrix. Sorted indices, no duplicates; the pattern is exactly the mesh edges plus
        the diagonal (an edge whose weights cancel keeps an explicit 0). Multiply with
        ``L @ x`` (``L * x`` is elementwise for SciPy sparse arrays).

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> L = tetlap.laplacian(V, [[0, 1, 2, 3]], kind="dual")
    >>> L[[0], :].toarray().round(4)
    array([[-0.75,  0.25,  0.25,  0.25]])
    >>> K = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # conducts 4x along x
    >>> tetlap.laplacian(V, [[0, 1, 2, 3]], coefficient=K)[[0], :].toarray().round(4)
    array([[-1.    ,  0.6667,  0.1667,  0.1667]])
    """
    arrays, n = _assemble(("laplacian", kind), V, T, weights, boundary_centres, degenerate, threads,
                          coefficient)
    return _sparse.csr(arrays, n)


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def mass(V, T=None, kind="barycentric", *, boundary_centres="circumcentric", weights=None,
         density=None, degenerate="raise", threads=None) -> sp.csr_array:
    """The (n, n) mass matrix of a tetrahedral or triangle mesh.

    Parameters
    ----------
    {mesh}
    {mass_kind}
    {density}
    {options}

    Returns
    -------
    M : (n, n) scipy.sparse.csr_array, float64
        Diagonal for the lumped kinds (unreferenced vertices get 0), on the pattern of
        :func:`laplacian` for ``"fem"``. The entries sum to the mesh volume (area) for
        every kind (to the sum of ``density`` times the element measures with a density).

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> tetlap.mass(V, [[0, 1, 2, 3]], kind="circumcentric").diagonal() * 72
    array([9., 1., 1., 1.])
    """
    result, n = _assemble(("mass", kind), V, T, weights, boundary_centres, degenerate, threads,
                          density=density)
    return _sparse.mass(result, n)


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def operators(V, T=None, laplacian="primal", mass="barycentric", *, boundary_centres="circumcentric",
              weights=None, coefficient=None, density=None, degenerate="raise",
              threads=None) -> tuple[sp.csr_array, sp.csr_array]:
    """The Laplacian and a mass matrix from one pass over the elements.

    Parameters
    ----------
    {mesh}
    laplacian : {{"primal", "dual"}} or float, default "primal"
        The Laplacian's kind, as ``kind`` of :func:`laplacian`.
    mass : {{"barycentric", "circumcentric", "mixed", "fem"}}, default "barycentric"
        The mass matrix's kind, as ``kind`` of :func:`mass`.
    {coefficient}
    {density}
    {options}

    Returns
    -------
    L : (n, n) scipy.sparse.csr_array
        As :func:`laplacian` returns it.
    M : (n, n) scipy.sparse.csr_array
        As :func:`mass` returns it.

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> L, M = tetlap.operators(V, T, laplacian="dual", mass="circumcentric")
    >>> round(float(M.sum()), 12)
    1.0
    """
    (L, M), n = _assemble(("operators", laplacian, mass), V, T, weights, boundary_centres, degenerate,
                          threads, coefficient, density)
    return _sparse.csr(L, n), _sparse.mass(M, n)


class Triplets(NamedTuple):
    """Unsummed COO triplets: ``scipy.sparse.coo_array((vals, (rows, cols)), shape)``
    sums them."""

    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    shape: tuple[int, int]


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def triplets(V, T=None, kind="primal", *, boundary_centres="circumcentric", weights=None,
             coefficient=None, degenerate="raise", threads=None) -> Triplets:
    """The Laplacian as unsummed triplets: each element's local Laplacian.

    Parameters
    ----------
    {mesh}
    {kind}
    {coefficient}
    {options}

    Returns
    -------
    Triplets
        ``rows``, ``cols`` (int64, shape (16 m,) for tets, (9 m,) for triangles), ``vals``
        (float64) and ``shape`` (n, n). Entry ``16 t + 4 a + b`` belongs to corners
        ``a, b`` of tet ``t`` (``9 t + 3 a + b`` for triangles). Summing duplicates gives
        :func:`laplacian` up to rounding; useful to assemble into another sparse format.

    {raises}

    Examples
    --------
    >>> import tetlap, scipy.sparse as sp
    >>> V, T = tetlap.meshes.cube(2)
    >>> r, c, v, shape = tetlap.triplets(V, T)
    >>> L = sp.coo_array((v, (r, c)), shape=shape).tocsr()
    >>> bool(abs(L - tetlap.laplacian(V, T)).max() < 1e-12)
    True
    """
    (rows, cols, vals), n = _assemble(("triplets", kind), V, T, weights, boundary_centres, degenerate,
                                      threads, coefficient)
    return Triplets(rows, cols, vals, (n, n))


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def edge_weights(V, T=None, kind="primal", *, boundary_centres="circumcentric", weights=None,
                 coefficient=None, degenerate="raise",
                 threads=None) -> tuple[np.ndarray, np.ndarray]:
    """The unique edges of the mesh and their summed weights.

    Parameters
    ----------
    {mesh}
    {kind}
    {coefficient}
    {options}

    Returns
    -------
    edges : (E, 2) int64 array
        Every edge once, ``i < j``, sorted lexicographically.
    w : (E,) float64 array
        ``w[e] = L[i, j]``, the weight summed over the elements around edge e.

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> edges, w = tetlap.edge_weights(V, [[0, 1, 2, 3]], kind="dual")
    >>> edges[0].tolist(), float(w[0])
    ([0, 1], 0.25)
    """
    return _assemble(("edge_weights", kind), V, T, weights, boundary_centres, degenerate, threads,
                     coefficient)[0]


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def element_contributions(V, T=None, kind="primal", *, boundary_centres="circumcentric", weights=None,
                          coefficient=None, degenerate="raise", threads=None) -> np.ndarray:
    """Per-element edge weights (each element's contribution to ``L``), for tets and
    triangles. ``tet_contributions`` is this function under its name until 0.1, kept for
    one release.

    Parameters
    ----------
    {mesh}
    {kind}
    {coefficient}
    {options}

    Returns
    -------
    W : (m, 6) float64 array for tets, (m, 3) for triangles
        Row ``t`` holds the weights of element ``t`` in the local edge order
        ``(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`` of ``T[t]`` (triangles: ``(0,1),
        (0,2), (1,2)``). Summed over the elements around an edge they give ``L[i, j]``.

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> (tetlap.element_contributions(V, [[0, 1, 2, 3]], kind="primal") * 6).round(12) + 0.0  # no -0.
    array([[1., 1., 1., 0., 0., 0.]])
    """
    return _assemble(("contributions", kind), V, T, weights, boundary_centres, degenerate, threads,
                     coefficient)[0]


def _operators_skipping(V, T, laplacian, mass, coefficient=None):
    """``(L, M, skipped)``: :func:`operators` with ``degenerate="skip"`` and the (k, 2)
    int64 array of the tets it left out, ascending: ``[t, 0]`` for a flat tet, ``[t, 1]``
    for one whose values leave the float64 range. ``V``, ``T`` validated, ``coefficient``
    as the core takes it (:func:`tetlap.coefficient._argument`) or None."""
    L, M, skipped = _core.assemble(V, T, ("operators_skipping", laplacian, mass),
                                   medium=(coefficient, None),
                                   options=_options("circumcentric", "skip", None))
    n = V.shape[0]
    return _sparse.csr(L, n), _sparse.mass(M, n), skipped


def _element_laplacians(V, T, kind, weights=None, coefficient=None) -> np.ndarray:
    """(m, 10) for tets, (m, 6) for triangles: each element's edge weights (as
    :func:`element_contributions`) then its diagonal entries ``L_aa`` at its corners, with
    ``degenerate="skip"`` (zeros for a dropped element). The primal's entries are
    ``-Vol |grad lambda_a|^2`` computed on their own, accurate where minus the sum of the
    corner's weights cancels (a needle); the dual's are minus that sum, of the weighted
    dual with vertex ``weights`` (n,) if given; with the ``coefficient`` (as the core takes
    it) if given. ``V``, ``T``, ``weights`` validated."""
    return _core.assemble(V, T, ("element_laplacians", kind), weights=weights,
                          medium=(coefficient, None),
                          options=_options("circumcentric", "skip", None))


#: The name of :func:`element_contributions` until 0.1 (it returns triangles' weights too),
#: kept for one release.
tet_contributions = element_contributions
