"""Derivatives of the operators with respect to the mesh: vector-Jacobian products.

Every operator of tetlap is a sum of per-tet terms, so the gradient of a scalar function
of ``L`` and ``M`` with respect to the vertex positions ``V`` (and the vertex weights of a
weighted dual) is a sum of small per-tet products, computed exactly (hand-derived reverse
mode, not finite differences) in the same parallel, deterministic pass as the assembly.

* :func:`vjp`: the general product. Given cotangents ``dL = dphi/dL`` and ``dM =
  dphi/dM`` it returns ``dphi/dV`` for ``phi = <dL, L(V)> + <dM, M(V)>`` (``<A, B> =
  sum_ij A_ij B_ij``): the backward step of any computation that uses ``L`` or ``M``.
* :func:`dirichlet_energy`: ``E = -f^T L f`` and ``dE/dV``.
* :func:`mass_energy`: ``E = f^T M f`` and ``dE/dV``.
* :func:`coefficient_vjp`: ``dphi/dK`` for ``phi = <dL, L(K)>``, the coefficient's
  gradient (scalars for both constructions, tensors for the primal): the backward step of
  a conductivity-estimation (inverse) problem.

Automatic-differentiation adapters built on :func:`vjp`: :mod:`tetlap.jax`
(``jax.custom_vjp``) and :mod:`tetlap.torch` (``torch.autograd.Function``).

Tets only (in R^3 or immersed in R^d); ``boundary_centres="barycentric"`` is not differentiated
(its switch of dual vertices to centroids is piecewise) and raises
:class:`tetlap.OptionError` when the dual or the circumcentric mass is involved.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, _sparse
from ._options import centres_used, weights_used
from .assembly import _LOCAL_EDGES, _options, element_contributions
from .coefficient import _argument
from .coefficient import check as check_coefficient
from ._docs import shared_docs
from ._options import renamed
from .errors import DegenerateElementError, DtypeError, OptionError, ShapeError
from ._names import public_dir

__all__ = ["vjp", "dirichlet_energy", "mass_energy", "coefficient_vjp", "VJP"]
__dir__ = public_dir(globals())


class VJP(NamedTuple):
    """The result of :func:`vjp`."""

    dV: np.ndarray
    """(n, d) float64: ``dphi/dV``, zero rows for unreferenced vertices."""
    dweights: np.ndarray | None
    """(n,) float64: ``dphi/dweights`` when ``weights`` were given, else None."""
    value: float
    """``phi = <dL, L> + <dM, M>`` (for the quadratic cotangents of
    :func:`dirichlet_energy` and :func:`mass_energy`, the energy)."""


def _real(x, name: str) -> np.ndarray:
    arr = _arrays._as_array(x, name)
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _csr(A, n: int, name: str):
    """``("matrix", (data, indices, indptr))`` of a SciPy sparse (n, n) matrix, canonical
    (duplicates summed, sorted), without touching ``A``."""
    if A.shape != (n, n):
        raise ShapeError(f"{name} must have shape ({n}, {n}), got {A.shape}")
    if A.dtype.kind not in "fiub":
        raise DtypeError(f"{name} must hold real numbers, got dtype {A.dtype}")
    A = sp.csr_array(A)
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    return ("matrix", _sparse.arrays(A))


def _edge_csr(edges, dw, n: int):
    """An upper-triangular cotangent from per-edge cotangents ``dw`` on ``edges``."""
    edges = _arrays.edges(edges, n, "the edges of dL")
    dw = _real(dw, "the edge cotangent dw")
    if dw.shape != (len(edges),):
        raise ShapeError(f"dw must have shape ({len(edges)},), one per edge, got {dw.shape}")
    i, j = edges.min(axis=1), edges.max(axis=1)
    if np.any(i == j):
        raise ShapeError("the edges of dL must join two distinct vertices")
    A = sp.coo_array((dw, (i, j)), shape=(n, n)).tocsr()
    return _csr(A, n, "dL")


def _laplacian_cotangent(dL, n: int, m: int):
    if dL is None:
        return None
    if sp.issparse(dL):
        return _csr(dL, n, "dL")
    if isinstance(dL, tuple) and len(dL) == 2:
        return _edge_csr(dL[0], dL[1], n)
    W = _real(dL, "dL")
    if W.shape != (m, 6):
        raise ShapeError(
            f"dL must be a sparse ({n}, {n}) matrix, a pair (edges, dw) or an ({m}, 6) array "
            f"of per-tet cotangents, got an array of shape {W.shape}")
    return ("elements", W)


def _mass_cotangent(dM, n: int):
    if dM is None:
        return None
    if sp.issparse(dM):
        return _csr(dM, n, "dM")
    d = _real(dM, "dM")
    if d.shape != (n,):
        raise ShapeError(f"dM must be a sparse ({n}, {n}) matrix or an ({n},) diagonal, "
                         f"got an array of shape {d.shape}")
    return ("diagonal", d)


def _mesh(V, T, weights, kinds, boundary_centres=None):
    """Validated ``(V, T, weights)``; weights refused where none of the differentiated
    ``kinds`` (None: not differentiated) depends on them, and so is
    ``boundary_centres="barycentric"``."""
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    w = _arrays.vertex_weights(weights, V.shape[0])
    weights_used(w is not None, kinds)
    centres_used(boundary_centres, kinds)
    return V, T, w


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def vjp(V, T, kind="primal", mass="barycentric", *, dL=None, dM=None,
        boundary_centres="circumcentric", weights=None, coefficient=None, degenerate="raise",
        threads=None) -> VJP:
    """The vector-Jacobian product of the Laplacian and the mass matrix.

    For cotangents ``dL`` (on ``L`` of ``kind``) and ``dM`` (on ``M`` of ``mass``), the
    gradient of ``phi(V) = <dL, L(V)> + <dM, M(V)>``, ``<A, B> = sum_ij A_ij B_ij``: the
    backward step of any function of the operators (``dL = dphi/dL``).

    Parameters
    ----------
    {tet_mesh}
    {kind}
    mass : {{"barycentric", "circumcentric", "fem"}}, default "barycentric"
        (the ``"mixed"`` mass is not differentiable: its centres move piecewise)
        The mass matrix's kind, as ``kind`` of :func:`tetlap.mass`.
    dL : optional
        The cotangent on ``L``, one of

        * a SciPy sparse (n, n) matrix or array: on the entries of ``L`` (any pattern;
          entries off the mesh's edges and diagonal meet structural zeros). With
          ``L[i, j] = L[j, i] = w_ij`` and ``L[i, i] = -sum_j w_ij``, edge ``ij`` receives
          ``dL[i, j] + dL[j, i] - dL[i, i] - dL[j, j]``;
        * a pair ``(edges, dw)``, ``edges`` (E, 2) integers and ``dw`` (E,) reals: on the
          summed edge weights ``w_ij`` as :func:`tetlap.edge_weights` returns them (any
          subset of edges, in any order; repeated edges add up);
        * an (m, 6) array: on each tet's own weights, as
          :func:`tetlap.element_contributions` returns them.
    dM : optional
        The cotangent on ``M``: a SciPy sparse (n, n) matrix (on its entries; only the
        diagonal counts for the lumped kinds) or an (n,) array (on its diagonal).
    coefficient : (m,) array-like of positive reals, optional
        ``L`` built with ``coefficient=c``, one scalar per tet (as :func:`tetlap.laplacian`
        takes it): ``L = sum_t c_t L_t(V)``, so the product is the plain one with each
        tet's cotangent times ``c_t``; or tensors ``(m, 3, 3)`` / ``(3, 3)`` for the primal
        (``w_ab = -Vol g_a . K g_b`` differentiated in closed form, NumPy, per tet).
        Tensors with the dual and ``weights=`` with a coefficient (centres that move with
        the metric) are not differentiated with respect to the vertices
        (:class:`tetlap.OptionError`); with respect to the coefficient itself:
        :func:`coefficient_vjp`.
    {options}

    Returns
    -------
    VJP
        ``dV`` (n, d) float64, ``dphi/dV`` (for an immersed mesh, within the tets' own
        3-spaces); ``dweights`` (n,) float64 ``dphi/dweights`` if ``weights`` were given
        (weights that neither the differentiated Laplacian nor the differentiated mass
        depends on, such as the primal's, are refused: :class:`tetlap.OptionError`), else None;
        ``value`` the float ``phi``. Bitwise identical for any ``threads``.

    {raises}
    tetlap.OptionError
        ``boundary_centres="barycentric"`` with the dual or the circumcentric mass (not
        differentiated).

    Notes
    -----
    A degenerate tet raises, or with ``degenerate="skip"`` contributes a zero gradient,
    consistently with its zero contribution to the operators. Inputs are never modified;
    the GIL is released. With a scalar ``coefficient`` the operator differentiated is
    ``L`` built with it (the masses do not depend on it); the gradient with respect to the
    coefficient itself is :func:`coefficient_vjp`.

    Examples
    --------
    The gradient of the sum of all primal edge weights of one tet:

    >>> import numpy as np, scipy.sparse as sp, tetlap
    >>> V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    >>> T = [[0, 1, 2, 3]]
    >>> edges, w = tetlap.edge_weights(V, T)
    >>> g = tetlap.vjp(V, T, "primal", dL=(edges, np.ones(len(edges))))
    >>> bool(np.isclose(g.value, w.sum())), g.dV.shape
    (True, (4, 3))
    >>> bool(np.allclose(g.dV.sum(axis=0), 0))  # moving the tet rigidly changes nothing
    True
    """
    V, T, w = _mesh(V, T, weights, (None if dL is None else kind, None if dM is None else mass),
                    boundary_centres)
    n, m = V.shape[0], T.shape[0]
    dl = _laplacian_cotangent(dL, n, m)
    tensors = None
    if coefficient is not None:
        dl = _scaled_by(coefficient, V, T, w, dL, dl)
        if dl is not None and dl[0] == "tensors":
            if kind != "primal":
                raise OptionError(f"vjp differentiates a tensor coefficient with respect to the "
                                  f"vertices for kind=\"primal\" only, got kind={kind!r} (the "
                                  f"dual's centres move with the metric); scalars per tet are "
                                  f"differentiated for every kind")
            tensors, dl = dl[1:], None
    dm = _mass_cotangent(dM, n)
    dV, dweights, value = _core.vjp(V, T, {"laplacian": (kind, dl), "mass": (mass, dm)},
                                    weights=w, options=_options(boundary_centres, degenerate,
                                                                 threads))
    if tensors is not None:
        dV_K, value_K = _tensor_primal_vjp(V, T, *tensors, degenerate)
        dV, value = dV + dV_K, float(value) + value_K
    return VJP(dV, dweights, float(value))


def _scaled_by(coefficient, V, T, w, dL, dl):
    """The Laplacian's cotangent ``dl`` for ``L = sum_t c_t L_t``: per tet, times ``c_t``
    (``coefficient`` validated as every function validates it; scalars), or for tensors
    ``("tensors", (m, 3, 3) K, (m, 6) cotangent)``, which :func:`_tensor_primal_vjp`
    differentiates."""
    c = check_coefficient(coefficient, V, T)
    if w is not None:
        raise OptionError("vjp: weights= with a coefficient are not differentiated (their power "
                          "centres move with the coefficient's metric)")
    if dl is None:
        return None
    W = _element_cotangent(dL, T, V.shape[0])
    if c.ndim == 1:
        return ("elements", W * c[:, None])
    return ("tensors", np.broadcast_to(c, (T.shape[0], 3, 3)), W)


def _tensor_primal_vjp(V, T, K, W, degenerate: str) -> tuple[np.ndarray, float]:
    """``(dphi/dV (n, 3), phi)`` for ``phi = sum_t sum_e W[t, e] w_e^t``, ``w^t`` the
    primal weights of tet ``t`` with the tensor ``K_t``: ``w_ab = -Vol g_a . K g_b``.

    With ``J`` the tet's edge matrix (columns ``x_k - x_0``), ``G = J^-T D`` its gradients
    and ``A = D S D^T`` (``S`` the symmetric 4 x 4 of the cotangents, zero diagonal),
    ``phi_t = -Vol / 2 tr(B A)``, ``B = J^-1 K J^-T``, and
    ``dphi_t = tr(J^-1 dJ C)``, ``C = -Vol / 2 (tr(B A) I - 2 B A)``: row ``k`` of
    ``C J^-1`` is ``dphi / dx_k`` (``k = 1..3``), ``x_0`` gets minus their sum. ``phi`` is
    homogeneous of degree 1 in the coordinates, so its gradient is that of each tet scaled
    by a power of two (exact), and ``K`` is divided by one (the gradient is linear in it)."""
    G, vol, e = _gradients(V, T)
    if degenerate == "raise" and not (vol > 0).all():
        t = int(np.flatnonzero(~(vol > 0))[0])
        raise DegenerateElementError(f"tet {t} has zero volume: its derivative is undefined",
                                     element=t)
    p = np.frexp(np.abs(K).max(axis=(1, 2)))[1]
    Ks = np.ldexp(K, -p[:, None, None])
    S = np.zeros((len(T), 4, 4))
    a, b = _LOCAL_EDGES.T
    S[:, a, b] = W
    S[:, b, a] = W
    D = np.array([[-1.0, 1, 0, 0], [-1, 0, 1, 0], [-1, 0, 0, 1]])
    A = np.einsum("ia,tab,jb->tij", D, S, D)
    Jinv = G[:, 1:]                                             # rows: gradients of lambda_k
    B = np.einsum("tij,tjk,tlk->til", Jinv, Ks, Jinv)
    BA = B @ A
    trace = np.trace(BA, axis1=1, axis2=2)
    C = -0.5 * vol[:, None, None] * (trace[:, None, None] * np.eye(3) - 2 * BA)
    rows = np.ldexp(C @ Jinv, p[:, None, None])                 # (m, 3, 3): dphi/dx_1..3
    rows[~(vol > 0)] = 0.0
    dV = np.zeros((V.shape[0], 3))
    for k in range(3):
        np.add.at(dV, T[:, k + 1], rows[:, k])
        np.add.at(dV, T[:, 0], -rows[:, k])
    w = element_contributions(V, T, "primal", coefficient=np.ascontiguousarray(K),
                              degenerate=degenerate)
    return dV, float(np.sum(W * w))


def _columns(f, n: int) -> np.ndarray:
    f = _real(f, "f")
    if f.ndim == 1:
        f = f[:, None]
    if f.ndim != 2 or f.shape[0] != n:
        raise ShapeError(f"f must have shape ({n},) or ({n}, k), one row per vertex, "
                         f"got {f.shape}")
    return np.ascontiguousarray(f)


def _energy(V, T, f, lap, mass, weights, boundary, degenerate, threads, return_weights_gradient):
    V, T, w = _mesh(V, T, weights, (lap, mass), boundary)
    F = _columns(f, V.shape[0])
    terms = {"laplacian": lap, "mass": mass}
    dV, dweights, value = _core.vjp(
        V, T, {name: (kind, ("quadratic", F)) for name, kind in terms.items() if kind is not None},
        weights=w, options=_options(boundary, degenerate, threads))
    if return_weights_gradient:
        if dweights is None:
            dweights = np.zeros(V.shape[0])
        return float(value), dV, dweights
    return float(value), dV


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def dirichlet_energy(V, T, f, kind="primal", *, boundary_centres="circumcentric", weights=None,
                     degenerate="raise", threads=None, return_weights_gradient=False):
    """The Dirichlet energy ``E = -f^T L f`` and its gradient with respect to ``V``.

    ``E = sum over edges ij of w_ij |f_i - f_j|^2``: non-negative for the primal ``L``
    (negative semidefinite), possibly negative for the dual on non-Delaunay meshes.

    Parameters
    ----------
    {tet_mesh}
    f : (n,) or (n, k) array-like of real numbers
        A function per vertex; for k columns the energies add up
        (``E = -trace(f^T L f)``).
    {kind}
    {options}
    return_weights_gradient : bool, default False
        Also return ``dE/dweights`` (zeros without ``weights``; the primal refuses
        ``weights``, which it does not depend on).

    Returns
    -------
    E : float
        ``-f^T L f``, summed in a fixed order (equal to the value from
        :func:`tetlap.laplacian` up to rounding).
    dE_dV : (n, d) float64 array
        ``dE/dV``; zero rows for unreferenced vertices. Bitwise identical for any
        ``threads``.
    dE_dweights : (n,) float64 array
        Only with ``return_weights_gradient=True``.

    {raises}
    tetlap.OptionError
        ``boundary_centres="barycentric"`` with the dual (not differentiated).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(3, jitter=0.2)
    >>> f = V[:, 0] ** 2
    >>> E, dE = tetlap.dirichlet_energy(V, T, f, "dual")
    >>> L = tetlap.laplacian(V, T, "dual")
    >>> bool(np.isclose(E, -f @ (L @ f))), dE.shape
    (True, (64, 3))

    A central difference in one coordinate of an interior vertex agrees:

    >>> i, h = 21, 1e-6
    >>> Vp, Vm = V.copy(), V.copy()
    >>> Vp[i, 2] += h; Vm[i, 2] -= h
    >>> fd = (tetlap.dirichlet_energy(Vp, T, f, "dual")[0]
    ...       - tetlap.dirichlet_energy(Vm, T, f, "dual")[0]) / (2 * h)
    >>> bool(abs(fd - dE[i, 2]) < 1e-7 * abs(dE).max())
    True
    """
    return _energy(V, T, f, kind, None, weights, boundary_centres, degenerate, threads,
                   return_weights_gradient)


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def mass_energy(V, T, f, kind="barycentric", *, boundary_centres="circumcentric",
                weights=None, degenerate="raise", threads=None,
                return_weights_gradient=False):
    """The quadratic form ``E = f^T M f`` of a mass matrix and its gradient with respect
    to ``V``.

    Parameters
    ----------
    {tet_mesh}
    f : (n,) or (n, k) array-like of real numbers
        A function per vertex; for k columns the forms add up.
    {mass_kind}
    {options}
    return_weights_gradient : bool, default False
        Also return ``dE/dweights`` (zeros without ``weights``; a mass other than the
        circumcentric refuses ``weights``, which it does not depend on).

    Returns
    -------
    E : float
        ``f^T M f`` (``sum_i M_ii |f_i|^2`` for the lumped kinds).
    dE_dV : (n, d) float64 array
        ``dE/dV``.
    dE_dweights : (n,) float64 array
        Only with ``return_weights_gradient=True``.

    {raises}

    Examples
    --------
    With ``f = 1`` the form is the mesh volume, whose gradient is the area-weighted
    normal of the boundary (zero inside):

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(2)
    >>> E, dE = tetlap.mass_energy(V, T, np.ones(len(V)), "circumcentric")
    >>> round(E, 12), bool(np.allclose(dE[13], 0))  # vertex 13: the cube's center
    (1.0, True)
    """
    return _energy(V, T, f, None, kind, weights, boundary_centres, degenerate, threads,
                   return_weights_gradient)


def _element_cotangent(dL, T: np.ndarray, n: int) -> np.ndarray:
    """(m, 6): the cotangent ``dL`` on each tet's own edge weights (local edge order of
    :func:`tetlap.element_contributions`): ``dL[i, j] + dL[j, i] - dL[i, i] - dL[j, j]``
    for a matrix, ``dw`` of the edge (repeats summed) for ``(edges, dw)``, or the (m, 6)
    array itself."""
    if dL is None:
        raise TypeError("coefficient_vjp needs the cotangent dL")
    kind, arrays = _laplacian_cotangent(dL, n, T.shape[0])
    if kind == "elements":
        return arrays
    A = sp.csr_array(arrays, shape=(n, n))  # canonical, upper-triangular for (edges, dw)
    i, j = T[:, _LOCAL_EDGES[:, 0]].ravel(), T[:, _LOCAL_EDGES[:, 1]].ravel()
    if isinstance(dL, tuple):
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        C = A[lo, hi]
    else:
        diagonal = A.diagonal()
        C = A[i, j] + A[j, i] - diagonal[i] - diagonal[j]
    return np.asarray(C, dtype=np.float64).reshape(T.shape[0], 6)


def _gradients(V: np.ndarray, T: np.ndarray):
    """``(G, vol)``: (m, 4, 3) the gradients of the tets' barycentric coordinates and (m,)
    their volumes, each tet's edges scaled by a power of two to order one first (exact)
    and ``G`` and ``vol`` returned for the scaled tet, with ``(m,)`` exponents ``e``: the
    true ``G`` is ``G * 2^-e``, the true volume ``vol * 2^(3e)``."""
    E = V[T[:, 1:]] - V[T[:, :1]]  # (m, 3, 3): rows x_k - x_0
    e = np.frexp(np.abs(E).max(axis=(1, 2)))[1]
    E = np.ldexp(E, -e[:, None, None])
    vol = np.abs(np.linalg.det(E)) / 6
    G = np.zeros((len(T), 4, 3))
    ok = vol > 0
    G[ok, 1:] = np.linalg.inv(E[ok]).swapaxes(1, 2)  # rows: gradients of lambda_1..3
    G[:, 0] = -G[:, 1:].sum(axis=1)
    return G, vol, e


@renamed(boundary="boundary_centres")
@_arrays.takes_mesh_object
@shared_docs
def coefficient_vjp(V, T, coefficient, kind="primal", *, dL, boundary_centres="circumcentric",
                    weights=None, degenerate="raise", threads=None) -> np.ndarray:
    """The vector-Jacobian product of the Laplacian with respect to its coefficient.

    For a cotangent ``dL`` on ``L = laplacian(V, T, kind, coefficient=K)``, the gradient
    of ``phi(K) = <dL, L(K)>`` (``<A, B> = sum_ij A_ij B_ij``) with respect to ``K``: the
    backward step of a conductivity-estimation (inverse) problem. ``L`` is linear in ``K``
    (for scalars, both constructions; for tensors, the primal), so the gradient does not
    depend on the value of ``K``, only on its form:

    * scalars ``c`` (m,): ``dphi/dc_t = <dL, L_t>``, ``L_t`` tet ``t``'s plain
      contribution (either ``kind``);
    * tensors (m, 3, 3), primal: ``L_t = -Vol_t G_t^T K_t G_t`` (``G_t`` the 3 x 4
      gradients of the barycentric coordinates), so ``dphi/dK_t = -Vol_t G_t dL_t
      G_t^T``, symmetrised (the gradient within symmetric matrices: for a symmetric
      direction ``H``, ``dphi = sum_t <dphi/dK_t, H_t>``), ``dL_t`` the 4 x 4 cotangent
      on the tet's entries;
    * one tensor (3, 3): the sum of the per-tet gradients.

    Parameters
    ----------
    {tet_mesh}
    coefficient : array-like of real numbers
        ``K``, as ``coefficient=`` of :func:`tetlap.laplacian` (validated the same way):
        ``(m,)`` positive scalars, ``(m, 3, 3)`` or ``(3, 3)`` symmetric positive definite
        tensors (the primal only: the dual's dependence on a tensor moves its centres).
    {kind}
    dL : required
        The cotangent on ``L``, in any form :func:`vjp` takes: a SciPy sparse (n, n)
        matrix (edge ``ij`` of tet ``t`` receives ``dL[i, j] + dL[j, i] - dL[i, i] -
        dL[j, j]``), a pair ``(edges, dw)`` on the summed edge weights, or an (m, 6) array
        on each tet's own weights.
    {options}
        ``weights`` are refused (:class:`tetlap.OptionError`): the weighted dual's powers
        are measured in the metric of ``K``, so it is not linear in ``K``.

    Returns
    -------
    numpy.ndarray, float64
        The shape of ``coefficient``: ``(m,)``, ``(m, 3, 3)`` (symmetric) or ``(3, 3)``.
        Zero for a tet skipped under ``degenerate="skip"``.

    {raises}
    tetlap.CoefficientError
        A coefficient that is not positive (as everywhere).
    tetlap.OptionError
        A tensor with the dual; ``weights``.

    Notes
    -----
    The gradient with respect to the vertices with a coefficient is not provided:
    :func:`vjp`, :func:`dirichlet_energy` and the adapters differentiate the plain
    operators.

    Examples
    --------
    The Dirichlet energy ``E = -f^T L f`` of a conductivity ``c``: its gradient is each
    tet's own plain energy, and ``E`` is linear in ``c``:

    >>> import numpy as np, scipy.sparse as sp, tetlap
    >>> V, T = tetlap.meshes.ball(200, seed=1)
    >>> c = np.linspace(1.0, 2.0, len(T))
    >>> f = V[:, 0] ** 2
    >>> dE = tetlap.coefficient_vjp(V, T, c, "dual", dL=-sp.csr_array(np.outer(f, f)))
    >>> E = -f @ (tetlap.laplacian(V, T, "dual", coefficient=c) @ f)
    >>> bool(np.isclose(dE @ c, E))
    True
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    K = _argument(coefficient, (V.shape, T.shape))
    if K is None:
        raise TypeError("coefficient_vjp needs the coefficient")
    _core.check_coefficient(K, T.shape[0], 4, V.shape[1])
    if weights is not None:
        raise OptionError("coefficient_vjp refuses weights=: the weighted dual's powers are "
                          "measured in the metric of the coefficient, so it is not linear in it")
    C = _element_cotangent(dL, T, V.shape[0])
    W = element_contributions(V, T, kind, boundary_centres=boundary_centres,
                              degenerate=degenerate, threads=threads)
    if K.ndim > 1 and kind != "primal":
        raise OptionError(f"coefficient_vjp differentiates tensors for kind=\"primal\" only, got "
                          f"kind={kind!r}: the dual's dependence on a tensor moves its centres; "
                          "scalars are differentiated for both")
    if K.ndim == 1:
        return np.einsum("te,te->t", W, C)
    G, vol, e = _gradients(V, T)
    Cm = np.zeros((len(T), 4, 4))
    a, b = _LOCAL_EDGES.T
    Cm[:, a, b] = C
    Cm[:, b, a] = C
    # sym(-Vol sum_e C_e g_a g_b^T) = -Vol / 2 G^T Cm G, scaled back by 2^(3e - 2e)
    dK = np.ldexp(-0.5 * vol[:, None, None] * np.einsum("tai,tab,tbj->tij", G, Cm, G),
                  e[:, None, None])
    dK = (dK + dK.swapaxes(1, 2)) / 2  # symmetric to the last bit
    dK[~W.any(axis=1)] = 0.0  # skipped
    return dK if K.ndim == 3 else dK.sum(axis=0)
