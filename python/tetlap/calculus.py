"""The P1 gradient and divergence operators of a tetrahedral (or triangle) mesh.

``G = gradient(V, T)`` maps a function per vertex to its constant gradient per element;
``D = divergence(V, T) = -G^T diag(vol (x) 1_d)`` maps a vector per element back to
vertices, so that ``D @ G`` is the primal Laplacian (paper Eq. 7, the sign convention of
:func:`tetlap.laplacian`):

    ``laplacian(V, T, "primal") == divergence(V, T) @ gradient(V, T)``.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.cube(3, jitter=0.2)
>>> G, D = tetlap.gradient(V, T), tetlap.divergence(V, T)
>>> L = tetlap.laplacian(V, T)
>>> bool(abs(D @ G - L).max() < 1e-12 * abs(L).max())
True
>>> g = (G @ (2 * V[:, 0] - V[:, 2])).reshape(-1, 3)   # a linear function's gradient
>>> bool(np.allclose(g, [2, 0, -1]))
True
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core
from ._docs import shared_docs
from ._float_range import LARGEST, SMALLEST, unit_scale
from .errors import DegenerateElementError
from ._names import public_dir

__all__ = ["gradient", "divergence", "element_gradients"]
__dir__ = public_dir(globals())


@_arrays.takes_mesh_object
@shared_docs
def element_gradients(V, T=None, *, degenerate="raise",
                      threads=None) -> tuple[np.ndarray, np.ndarray]:
    """The gradients of every element's barycentric coordinates, and the elements'
    measures: the values :func:`gradient` and :func:`divergence` are built from.

    Parameters
    ----------
    {mesh}
    degenerate : {{"raise", "skip"}}, default "raise"
        A zero-volume element (or one whose gradients or measure leave the float64 range)
        raises :class:`tetlap.DegenerateElementError` naming it, or with ``"skip"`` gets
        zero gradients and measure 0. A mesh far from unit size is computed scaled by a
        power of two (exact, :func:`tetlap._float_range.unit_scale`) and scaled back, so
        only a value beyond the range is refused: the volumes of a unit-shaped mesh of
        coordinates ``1e-110`` (``1e-330``) are, its gradients (:func:`gradient`) are
        not.
    threads : int, optional
        Worker threads (``None``: all cores); the output is bitwise identical for any.

    Returns
    -------
    g : (m, k, d) float64 array
        ``g[t, a]`` is the gradient of the barycentric coordinate of corner ``a`` of
        element ``t`` (``k = 4`` for tets, 3 for triangles), in the ambient space R^d
        (``d = V.shape[1]``; tangent to the element for an immersed one). ``g[t].sum(0)``
        is 0 to rounding, and ``g[t, a] . (x_b - x_c) = delta_ab - delta_ac``.
    vol : (m,) float64 array
        The unsigned volumes (areas of triangles).

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> g, vol = tetlap.calculus.element_gradients([[0, 0, 0], [2, 0, 0], [0, 1, 0], [0, 0, 1]],
    ...                                            [[0, 1, 2, 3]])
    >>> g[0].tolist(), vol.tolist()
    ([[-0.5, -1.0, -1.0], [0.5, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.3333333333333333])
    """
    V, T, g, vol, k = _scaled(*_arrays.mesh(V, T), degenerate, threads)
    e = (T.shape[1] - 1) * k                          # volume: length^3 (area: length^2)
    keep = _in_range(vol, e, degenerate)
    if not keep.all():
        g[~keep], vol[~keep] = 0.0, 0.0
    return (np.ldexp(g, -k), np.ldexp(vol, e)) if k else (g, vol)


def _scaled(V, T, degenerate, threads):
    """``(V, T, g, vol, k)``: ``V``, ``T`` validated and the core's gradients and measures of the mesh ``V / 2^k``, exact,
    ``2^k`` the scale of :func:`tetlap._float_range.unit_scale` (the operators' rule: 0,
    the plain path, for a mesh of any real-world unit). A mesh of coordinates ``1e-110``
    then has gradients of ``1e110`` (its volumes of ``1e-330`` no longer read as
    "degenerate"), one of ``1e150`` gradients of ``1e-150``; the callers scale back what
    they return by the power of two of its unit, and check its range."""
    V = _arrays.points(V)
    T = _arrays.elements(T)
    used, T_used = _arrays.used_vertices(V, T)
    k = int(np.frexp(unit_scale(V[used], T_used))[1]) - 1
    g, vol = _core.gradients(np.ldexp(V, -k) if k else V, T,
                             options={"degenerate": degenerate, "threads": threads})
    return V, T, g, vol, k


def _in_range(largest: np.ndarray, e: int, degenerate: str) -> np.ndarray:
    """(m,) bool: the elements whose ``largest`` value (in the scaled frame), times
    ``2^e``, is zero or a normal float64. An element beyond raises
    :class:`tetlap.DegenerateElementError` naming it, or with ``degenerate="skip"`` is
    dropped (False), as the operators drop theirs."""
    with np.errstate(over="ignore", under="ignore"):
        scaled = np.ldexp(largest, e)
    bad = (largest != 0) & ~((np.abs(scaled) >= SMALLEST) & (np.abs(scaled) <= LARGEST))
    if bad.any() and degenerate == "raise":
        t = int(np.argmax(bad))
        size = round(float(np.log10(abs(largest[t]))) + e * float(np.log10(2)))
        raise DegenerateElementError(
            f"element {t}: its values leave the float64 range (normal magnitudes "
            f"{SMALLEST:.2g} to {LARGEST:.2g}; here about 1e{size}); rescale the mesh, or "
            'pass degenerate="skip" to drop it', element=t)
    return ~bad


def _operator(g: np.ndarray, T, n: int) -> sp.csr_array:
    """The ``(d m, n)`` CSR operator of the per-element gradients ``g`` ``(m, k, d)`` of the
    elements ``T``: row ``d t + c`` holds component ``c`` on element ``t``, its ``k``
    columns sorted."""
    m, k, d = g.shape
    T = _arrays.elements(T)
    order = np.argsort(T, axis=1, kind="stable")
    cols = np.take_along_axis(T, order, axis=1)
    vals = np.take_along_axis(g, order[:, :, None], axis=1)     # (m, k, d), columns sorted
    data = vals.transpose(0, 2, 1).reshape(-1)                   # (m, d, k)
    indices = np.repeat(cols[:, None, :], d, axis=1).reshape(-1)
    index = np.int32 if max(n, k * d * m) < 2**31 else np.int64
    indptr = np.arange(0, k * d * m + 1, k, dtype=index)
    G = sp.csr_array((data, indices.astype(index), indptr), shape=(d * m, n), copy=False)
    G.has_sorted_indices = True
    G.has_canonical_format = True
    return G


@_arrays.takes_mesh_object
@shared_docs
def gradient(V, T=None, *, degenerate="raise", threads=None) -> sp.csr_array:
    """The ``(d m, n)`` P1 gradient operator: ``(G @ f)[d t : d t + d]`` is the gradient
    of the piecewise linear ``f`` on element ``t``.

    Parameters
    ----------
    {mesh}
    degenerate : {{"raise", "skip"}}, default "raise"
        As :func:`element_gradients`, for the gradients alone (a unit-shaped mesh has them
        from coordinates of ``1e-300`` to ``1e300``): a skipped element's rows are zero
        (their entries stay in the pattern as explicit zeros).
    threads : int, optional
        Worker threads (``None``: all cores); the output is bitwise identical for any.

    Returns
    -------
    G : (d m, n) scipy.sparse.csr_array, float64
        ``d = V.shape[1]`` (3 for tets in R^3, 2 for triangles in the plane; for an
        immersed mesh the gradients are ambient vectors tangent to each element). Row
        ``d t + c`` holds component ``c`` on element ``t``: ``G @ f`` reshaped to
        ``(m, d)`` is the gradient per element. Each row has one entry per corner of its
        element, columns sorted; the entries of a row block sum to zero (constants have
        no gradient) and ``G`` is exact on linear functions (to rounding).

    {raises}

    Examples
    --------
    >>> import tetlap
    >>> V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    >>> G = tetlap.gradient(V, [[0, 1, 2, 3]])
    >>> G.shape, (G @ [0.0, 1.0, 2.0, 3.0]).tolist()
    ((3, 4), [1.0, 2.0, 3.0])
    """
    V, T, g, _, k = _scaled(*_arrays.mesh(V, T), degenerate, threads)
    if k:
        keep = _in_range(np.abs(g).max(axis=(1, 2)), -k, degenerate)
        g = np.ldexp(g, -k)
        g[~keep] = 0.0
    return _operator(g, T, len(V))


@_arrays.takes_mesh_object
@shared_docs
def divergence(V, T=None, *, degenerate="raise", threads=None) -> sp.csr_array:
    """The ``(n, d m)`` divergence ``D = -G^T diag(vol (x) 1_d)``, the negative adjoint of
    :func:`gradient` in the volume-weighted inner product.

    ``(D @ X)[i] = -sum_t vol_t grad(lambda_i) . X_t`` is the weak divergence of the
    piecewise constant field ``X`` tested with the hat function of vertex ``i``
    (integrated over its support, like the rows of the Laplacian). Sign: ``D @ G`` is the
    primal :func:`tetlap.laplacian` (negative semidefinite), ``D @ G @ f`` discretises
    ``div grad f = Laplace(f)``.

    Parameters
    ----------
    {mesh}
    degenerate : {{"raise", "skip"}}, default "raise"
        As :func:`gradient`, for the entries ``vol grad(lambda)`` (``length^2``): a unit-
        shaped mesh has them from coordinates of about ``1e-150`` to ``1e150``.
    threads : int, optional
        Worker threads (``None``: all cores); the output is bitwise identical for any.

    Returns
    -------
    D : (n, d m) scipy.sparse.csr_array, float64
        Columns ``d t .. d t + d - 1`` belong to element ``t``; sorted indices. The
        columns sum to zero (``D`` maps into functions of zero total).

    {raises}

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> D = tetlap.divergence(V, T)
    >>> X = np.tile([1.0, 0.0, 0.0], len(T))     # a constant field: divergence 0 inside
    >>> bool(abs(D @ X)[tetlap.diagnostics.interior_vertices(V, T)].max() < 1e-15)
    True
    """
    V, T, g, vol, k = _scaled(*_arrays.mesh(V, T), degenerate, threads)
    e = (T.shape[1] - 2) * k                     # vol grad: length^2 (triangles: length)
    if not k:
        return _divergence(_operator(g, T, len(V)), vol)
    keep = _in_range(np.abs(g).max(axis=(1, 2)) * vol, e, degenerate)
    D = _divergence(_operator(g, T, len(V)), np.where(keep, vol, 0.0))
    D.data = np.ldexp(D.data, e)
    return D


def _divergence(G: sp.csr_array, vol: np.ndarray) -> sp.csr_array:
    """``-G^T diag(vol (x) 1_d)`` of a gradient operator ``G`` and the measures ``vol``."""
    scaled = G.copy()
    scaled.data = G.data * -np.repeat(vol, len(G.data) // max(len(vol), 1))  # d k per element
    D = sp.csr_array(scaled.T)
    D.sort_indices()
    return D
