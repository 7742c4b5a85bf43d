"""Derivatives of eigenvalues with respect to the mesh.

For ``-L v = lambda M v`` with ``v^T M v = 1`` (the pairs :func:`tetlap.solve.eigs`
returns) and a simple eigenvalue,

    d lambda = -v^T dL v - lambda v^T dM v,

so ``d lambda / dV`` is the gradient of the Dirichlet energy ``-v^T L v`` minus ``lambda``
times that of the mass form ``v^T M v``, both at the fixed ``v``: two passes of the
operators' exact vector-Jacobian products (:func:`tetlap.dirichlet_energy`,
:func:`tetlap.mass_energy`). Fixed (Dirichlet) vertices are zero in ``v``: the same
formula differentiates the free block, and the gradient includes the fixed vertices'
positions, which move the free block's entries.

The eigenvalues of a cluster (near-equal: closer than ``1e-6`` relative, the clusters of
:func:`tetlap.solve.eigs`) have no individual derivatives; the mean of a cluster has,
``sum_j (-v_j^T dL v_j - lambda_j v_j^T dM v_j) / c`` over any ``M``-orthonormal basis of
its eigenvectors, and it is what every member of the cluster gets.

* :func:`eigenvalue_gradients`: ``d lambda_i / dV`` for every returned pair, (k, n, d).
* :func:`eigenvalue_vjp`: ``sum_i g_i d lambda_i / dV`` for given ``g`` in at most four
  passes, whatever ``k`` (the backward step of a loss of the spectrum).
* :func:`coefficient_gradients`: ``d lambda_i / dc_t`` with respect to the coefficient of
  ``div(c grad u)`` per tet (scalars, both constructions; tensors, the primal): the
  Laplacian is linear in it, so ``d lambda = -v^T dL v`` needs no derivative of the
  geometry (what conductivity estimation needs).
"""

from __future__ import annotations

import numpy as np

from . import _arrays, assembly, calculus
from .assembly import _LOCAL_EDGES
from ._docs import shared_docs
from ._names import public_dir
from .derivatives import dirichlet_energy, mass_energy, vjp
from .errors import NonFiniteError, OptionError, ShapeError
from .solve._checks import flag
from .solve._eigs import CLUSTER_RTOL

__all__ = ["eigenvalue_gradients", "eigenvalue_vjp", "coefficient_gradients", "clusters"]
__dir__ = public_dir(globals())


def clusters(eigenvalues) -> np.ndarray:
    """(k,) int64: the cluster of each eigenvalue (ascending input), numbered from 0:
    consecutive values closer than ``1e-6`` of the largest magnitude among them share
    one."""
    lam = _arrays._as_array(eigenvalues, "eigenvalues").astype(np.float64)
    if lam.ndim != 1:
        raise ShapeError(f"eigenvalues must have shape (k,), got {lam.shape}")
    if len(lam) < 2:
        return np.zeros(len(lam), dtype=np.int64)
    width = CLUSTER_RTOL * np.maximum(np.abs(lam[1:]), np.abs(lam[:-1]))
    return np.concatenate([[0], np.cumsum(np.diff(lam) > width)]).astype(np.int64)


def _pairs(V, T, eigenvalues, eigenvectors):
    V, T = _arrays.mesh(V, T)
    n = len(_arrays._as_array(V, "V"))
    lam = _arrays._as_array(eigenvalues, "eigenvalues").astype(np.float64)
    vec = _arrays._as_array(eigenvectors, "eigenvectors").astype(np.float64)
    if lam.ndim != 1 or vec.shape != (n, len(lam)):
        raise ShapeError(f"eigenvalues (k,) and eigenvectors (n, k) = ({n}, k) expected, got "
                         f"{lam.shape} and {vec.shape}")
    if len(lam) > 1 and (np.diff(lam) < 0).any():
        raise ShapeError("eigenvalues must be ascending, as tetlap.solve.eigs returns them")
    for name, x in (("eigenvalues", lam), ("eigenvectors", vec)):
        if not np.isfinite(x).all():
            raise NonFiniteError(f"{name} holds a non-finite value")
    return V, T, lam, vec


def _split(columns: np.ndarray, coefficients: np.ndarray):
    """``columns`` scaled by ``sqrt(|c|)``, split by the sign of ``c``: ``(positive,
    negative)``, so that ``sum_j c_j q(v_j) = q(P) - q(N)`` for a quadratic form ``q``
    summed over columns."""
    root = np.sqrt(np.abs(coefficients))[None, :]
    return columns[:, coefficients > 0] * root[:, coefficients > 0], \
        columns[:, coefficients < 0] * root[:, coefficients < 0]


def _edge_squares(vec: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(m, 6, k): ``(v[a] - v[b])^2`` over each tet's local edges ``(a, b)`` for each
    column ``v`` of ``vec``: the derivative of ``-v^T L v`` with respect to the tet's own
    edge weights."""
    diff = vec[T[:, _LOCAL_EDGES[:, 0]]] - vec[T[:, _LOCAL_EDGES[:, 1]]]
    return diff * diff


def _gradient(V, T, vec, dirichlet_weights, mass_weights, kind, mass, options,
              coefficient=None):
    """``sum_j a_j d(-v_j^T L v_j)/dV + b_j d(v_j^T M v_j)/dV`` in at most four passes;
    with a ``coefficient``, the Dirichlet part in one pass of :func:`tetlap.vjp` with the
    per-tet cotangent
    ``sum_j a_j (v_j[a] - v_j[b])^2`` on each tet's edge weights."""
    out = np.zeros(np.asarray(V, dtype=float).shape)
    terms = [(mass_weights, mass_energy, mass)]
    if coefficient is None:
        terms.insert(0, (dirichlet_weights, dirichlet_energy, kind))
    else:
        W = _edge_squares(vec, _arrays.elements(T, 4)) @ dirichlet_weights
        out += vjp(V, T, kind, dL=W, coefficient=coefficient, **options).dV
    for weights, energy, k in terms:
        for sign, F in zip((1.0, -1.0), _split(vec, weights)):
            if F.shape[1]:
                out += sign * energy(V, T, F, k, **options)[1]
    return out


@shared_docs
def eigenvalue_vjp(V, T, eigenvalues, eigenvectors, deigenvalues, kind="primal",
                   mass="barycentric", *, boundary_centres="circumcentric", weights=None,
                   coefficient=None, degenerate="raise", threads=None) -> np.ndarray:
    """``sum_i g_i d lambda_i / dV`` for the pairs of ``-L v = lambda M v`` and cotangents
    ``g = deigenvalues``: the gradient of a loss of the spectrum.

    Parameters
    ----------
    {tet_mesh}
    eigenvalues : (k,) array-like, ascending
        From :func:`tetlap.solve.eigs` on the operators of this mesh, ``kind`` and
        ``mass``.
    eigenvectors : (n, k) array-like
        Their ``M``-orthonormal eigenvectors (zero on fixed vertices), as ``eigs``
        returns them.
    deigenvalues : (k,) array-like
        ``g_i = d loss / d lambda_i``; within a cluster only their sum counts (a cluster
        has the derivative of its mean only).
    {kind}
    mass : {{"barycentric", "circumcentric", "fem"}}, default "barycentric"
        The mass matrix's kind (the ``"mixed"`` mass is not differentiable).
    {options}
    coefficient : array-like, optional
        The coefficient ``L`` was built with, as :func:`tetlap.vjp` takes it: scalars per
        tet for every kind, tensors for the primal.

    Returns
    -------
    (n, d) float64
        ``sum_i g_i d lambda_i / dV`` (with ``g`` averaged over each cluster). Sign
        convention: ``-L v = lambda M v``, ``lambda >= 0`` for the primal.

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.ball(600, seed=1)
    >>> L, M = tetlap.operators(V, T, "primal", "barycentric")
    >>> lam, vec = tetlap.solve.eigs(L, M, 5, tetlap.diagnostics.boundary_vertices(V, T))
    >>> g = tetlap.spectral.eigenvalue_vjp(V, T, lam, vec, np.ones(5))
    >>> g.shape                                        # d (sum of the 5 values) / dV
    (600, 3)
    >>> bool(abs(np.sum(g * V)) > 0)                    # scaling the ball moves them
    True
    """
    V, T, lam, vec = _pairs(V, T, eigenvalues, eigenvectors)
    g = _arrays._as_array(deigenvalues, "deigenvalues").astype(np.float64)
    if g.shape != lam.shape:
        raise ShapeError(f"deigenvalues must have shape {lam.shape}, one per eigenvalue, "
                         f"got {g.shape}")
    if not np.isfinite(g).all():
        raise NonFiniteError("deigenvalues holds a non-finite value")
    groups = clusters(lam)
    g = (np.bincount(groups, weights=g) / np.bincount(groups))[groups]
    options = {"boundary_centres": boundary_centres, "weights": weights, "degenerate": degenerate,
               "threads": threads}
    return _gradient(V, T, vec, g, -g * lam, kind, mass, options, coefficient)


@shared_docs
def eigenvalue_gradients(V, T, eigenvalues, eigenvectors, kind="primal",
                         mass="barycentric", *, boundary_centres="circumcentric", weights=None,
                         coefficient=None, degenerate="raise", threads=None) -> np.ndarray:
    """``d lambda_i / dV`` of every pair of ``-L v = lambda M v``: ``-v_i^T dL v_i -
    lambda_i v_i^T dM v_i``; the members of a cluster get the derivative of its mean.

    Parameters
    ----------
    {tet_mesh}
    eigenvalues : (k,) array-like, ascending
        From :func:`tetlap.solve.eigs` on the operators of this mesh, ``kind`` and
        ``mass``.
    eigenvectors : (n, k) array-like
        Their ``M``-orthonormal eigenvectors (zero on fixed vertices).
    {kind}
    mass : {{"barycentric", "circumcentric", "fem"}}, default "barycentric"
        The mass matrix's kind (the ``"mixed"`` mass is not differentiable).
    {options}
    coefficient : array-like, optional
        The coefficient ``L`` was built with, as :func:`tetlap.vjp` takes it: scalars per
        tet for every kind, tensors for the primal.

    Returns
    -------
    (k, n, d) float64
        ``[i] = d lambda_i / dV``; two passes of the operators' products per cluster (use
        :func:`eigenvalue_vjp` for a weighted sum in at most four).

    Examples
    --------
    The derivative of an eigenvalue of the unit ball under a uniform scaling ``V (1 +
    t)`` is ``-2 lambda`` (``lambda`` scales as ``1 / r^2``):

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.ball(600, seed=1)
    >>> L, M = tetlap.operators(V, T, "primal", "fem")
    >>> lam, vec = tetlap.solve.eigs(L, M, 3, tetlap.diagnostics.boundary_vertices(V, T))
    >>> G = tetlap.spectral.eigenvalue_gradients(V, T, lam, vec, mass="fem")
    >>> bool(np.allclose(np.einsum("knd,nd->k", G, V), -2 * lam))
    True
    """
    V, T, lam, vec = _pairs(V, T, eigenvalues, eigenvectors)
    groups = clusters(lam)
    options = {"boundary_centres": boundary_centres, "weights": weights, "degenerate": degenerate,
               "threads": threads}
    out = np.empty((len(lam),) + np.asarray(V, dtype=float).shape)
    for c in range(int(groups.max()) + 1 if len(lam) else 0):
        members = np.flatnonzero(groups == c)
        share = np.full(len(members), 1.0 / len(members))
        out[members] = _gradient(V, T, vec[:, members], share, -share * lam[members],
                                 kind, mass, options, coefficient)
    return out



@shared_docs
def coefficient_gradients(V, T, eigenvalues, eigenvectors, kind="primal", *,
                          tensor: bool = False, boundary_centres="circumcentric",
                          degenerate="raise", threads=None) -> np.ndarray:
    """``d lambda_i / dc_t``: the derivatives of the eigenvalues of ``-L v = lambda M v``,
    ``L`` built with ``coefficient=c``, with respect to the coefficient of each tet; the
    members of a cluster get the derivative of its mean.

    ``L`` is linear in a scalar coefficient, ``L = sum_t c_t L_t`` (``L_t`` the tet's plain
    contribution), and the primal in a tensor, ``L_t = -vol_t G_t^T K_t G_t``; the mass does
    not depend on it. So for an ``M``-orthonormal ``v``, ``d lambda = -v^T dL v``:

    * scalars: ``d lambda / dc_t = sum_(a, b) w^t_ab (v_a - v_b)^2 >= 0`` over the tet's
      edges, ``w^t`` its plain weights of ``kind`` (primal, dual, or an affine ``t``);
    * tensors (primal): ``d lambda / dK_t = vol_t grad(v)_t grad(v)_t^T`` (3, 3), symmetric
      positive semidefinite (read it as the gradient over symmetric tensors).

    Parameters
    ----------
    {tet_mesh}
    eigenvalues : (k,) array-like, ascending
        From :func:`tetlap.solve.eigs` on ``L`` built with ``coefficient=`` (any value:
        the derivative is taken at it through the eigenvectors).
    eigenvectors : (n, k) array-like
        Their ``M``-orthonormal eigenvectors (zero on fixed vertices).
    {kind}
    tensor : bool, default False
        ``False``: per-tet scalars, (k, m). ``True``: per-tet tensors of the primal,
        (k, m, 3, 3) (the dual in a tensor metric is not linear in the tensor: an
        :class:`tetlap.OptionError`).
    boundary_centres, degenerate, threads
        As for :func:`tetlap.laplacian`. Vertex weights are not taken: a weighted dual's
        power centres move with the metric, so it is not linear in the coefficient.

    Returns
    -------
    (k, m) or (k, m, 3, 3) float64
        ``[i, t] = d lambda_i / dc_t`` (non-negative: a better conductor raises every
        eigenvalue of the primal; the dual's can be negative where its weights are).

    Examples
    --------
    Scaling every coefficient by ``1 + s`` scales every eigenvalue by it, so the sum of
    ``c_t d lambda / dc_t`` over the tets is ``lambda`` (Euler's theorem):

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.ball(600, seed=1)
    >>> c = tetlap.coefficient.from_vertices(1 + V[:, 0] ** 2, T)
    >>> L, M = tetlap.operators(V, T, "primal", "fem", coefficient=c)
    >>> lam, vec = tetlap.solve.eigs(L, M, 4, tetlap.diagnostics.boundary_vertices(V, T))
    >>> G = tetlap.spectral.coefficient_gradients(V, T, lam, vec)
    >>> G.shape, bool(np.allclose(G @ c, lam))
    ((4, 2894), True)
    """
    V, T, lam, vec = _pairs(V, T, eigenvalues, eigenvectors)
    tensor = flag(tensor, "tensor", unset=False)
    T = _arrays.elements(T, 4)
    if tensor:
        if kind != "primal":
            raise OptionError(f"tensor=True differentiates the primal only (the dual in a "
                              f"tensor metric is not linear in the tensor), got kind={kind!r}")
        G, vol = calculus.element_gradients(V, T, degenerate=degenerate)
        grad = np.einsum("mad,mak->kmd", G, vec[T])           # grad(v_i) on each tet
        per_pair = vol[None, :, None, None] * grad[..., :, None] * grad[..., None, :]
    else:
        W = assembly.element_contributions(V, T, kind, boundary_centres=boundary_centres,
                                           degenerate=degenerate, threads=threads)
        per_pair = np.einsum("me,mek->km", W, _edge_squares(vec, T))
    groups = clusters(lam)
    sizes = np.bincount(groups)
    means = np.zeros((len(sizes),) + per_pair.shape[1:])
    np.add.at(means, groups, per_pair)
    return (means / sizes.reshape((-1,) + (1,) * (per_pair.ndim - 1)))[groups]

