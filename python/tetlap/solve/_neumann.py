"""Pure Neumann problems: :func:`neumann` (``L f = rhs - g``, any Laplacian) and
:func:`neumann_primal_kkt` (the primal with the gradient constraints of Eq. 25)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _arrays, diagnostics
from ..errors import CompatibilityError, OptionError, ShapeError
from . import _checks, _linear
from ._boundary import _geometry, _unit_normals
from .info import SolveInfo


def neumann(L, g, rhs=None, *, gauge="mean", rtol: float = 1e-6, solver: str = "auto",
            progress=None, return_info: bool = False):
    """Solve the pure Neumann problem ``L f = rhs - g`` (paper Sec. 6, ``L f = -g``).

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian (symmetric, rows summing to zero; not modified).
    g : (n,) array-like
        The integrated outward normal flux per vertex (zero at interior vertices): for the
        dual Laplacian use :func:`dual_boundary_areas` (exact for linear functions: dual
        cells at the boundary are closed by circumcentric pieces of the boundary faces);
        for the primal, the natural (weak) boundary condition is :func:`fem_boundary_areas`
        (the P1 boundary load).
    rhs : (n,) array-like, optional
        The integrated source (e.g. ``M @ s`` for ``Laplace(f) = s``).
    gauge : "mean" or int, default "mean"
        The constant functions of every connected component are in the null space; the
        solution is fixed by zero mean per component, or ``f[gauge] = 0`` in the component
        of that vertex (zero mean elsewhere).
    rtol : float, default 1e-6
        The data must integrate to zero over each component: ``|sum| <= rtol sum |data|``
        (a relative tolerance in [0, 1)). The defect within it is removed as a Lagrange multiplier
        of the gauge removes it: spread evenly (``"mean"``) or at the gauge vertex.
    solver, progress, return_info
        As for :func:`dirichlet`: one vertex per component is pinned to 0 (the other
        equations then imply its own), the system on the rest is solved by ``solver``,
        and the gauge is applied after; the residual is checked on the whole system.

    Returns
    -------
    f : (n,) float64 array
        Unreferenced vertices get 0.
    info : SolveInfo, with ``return_info=True``.

    Raises
    ------
    tetlap.CompatibilityError
        Data that do not integrate to zero (no solution exists).
    tetlap.SolveError
        A system without an accurate solution.
    """
    L = _arrays.matrix(L)
    n = L.shape[0]
    data = -_arrays.vector(g, n, "g")
    if rhs is not None:
        data = data + _arrays.vector(rhs, n, "rhs")
    gauge = _checks.gauge(gauge, n)
    rtol = _checks.rtol(rtol)
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    info = SolveInfo()
    with info.phase("components"):
        labels, referenced = _checks.components(L)
    f = np.zeros(n)
    if not referenced.any():
        return (f, info) if return_info else f
    idx = np.flatnonzero(referenced)
    lab = labels[idx]
    order = np.argsort(lab, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(lab[order]) != 0])
    groups = np.split(idx[order], starts[1:])
    d = np.where(referenced, data, 0.0)
    pinned = np.zeros(n, dtype=bool)
    for members in groups:
        total, scale = d[members].sum(), np.abs(d[members]).sum()
        if abs(total) > rtol * max(scale, 1e-300):
            raise CompatibilityError(
                f"the Neumann data do not integrate to zero on the component of vertex "
                f"{members[0]}: sum = {total:.3e} (relative {total / scale:.1e})")
        at_gauge = gauge != "mean" and labels[gauge] == labels[members[0]] and referenced[gauge]
        if at_gauge:
            d[gauge] -= total
        else:
            d[members] -= total / len(members)
        pinned[gauge if at_gauge else members[0]] = True
    rest = referenced & ~pinned
    if rest.any():
        f[rest] = _linear.solve(-L[rest][:, rest], -d[rest], "Neumann system", solver=solver,
                                info=info, progress=progress)
    for members in groups:
        at_gauge = gauge != "mean" and labels[gauge] == labels[members[0]] and referenced[gauge]
        f[members] -= f[gauge] if at_gauge else f[members].mean()
    Lr = L[idx][:, idx]
    _checks.accept(Lr, f[idx], d[idx], "Neumann system", info)
    return (f, info) if return_info else f


def _mesh_components(T, n: int) -> np.ndarray:
    """Component label per vertex of the graph of the tets' edges."""
    from scipy.sparse import csgraph

    a = T[:, [0, 0, 0, 1, 1, 2]].ravel()
    b = T[:, [1, 2, 3, 2, 3, 3]].ravel()
    G = sp.csr_array((np.ones(len(a)), (a, b)), shape=(n, n))
    return csgraph.connected_components(G, directed=False)[1]


def neumann_primal_kkt(L, V, T=None, normal_derivative=None, rhs=None, *, gauge="mean",
                       solver: str = "auto", progress=None, return_info: bool = False):
    """Primal Neumann problem with the gradient constraints of Eq. 25, in a KKT system.

    For every boundary face (of a tet ``t``) the normal component of the gradient of the
    piecewise linear ``f`` on ``t`` is asked to equal ``normal_derivative`` (an (F,) array
    in the order of :func:`tetlap.diagnostics.boundary_faces`, or a callable taking the
    face centroids (F, 3) and outward unit normals (F, 3)). There are more faces than
    boundary vertices, so the constraints are met in the least-squares sense while the
    interior rows ``(L f)_I = rhs_I`` hold exactly (Lagrange multipliers)::

        minimise |C f - g|^2  subject to  L_I f = rhs_I  (and the gauge).

    ``gauge`` is ``"mean"`` (zero mean on every connected component of the mesh) or a
    vertex index (``f[gauge] = 0`` in its component, zero mean on the others); vertices in
    no tet take no part and get 0. Linear functions are reproduced exactly. ``solver``:
    the KKT matrix is a symmetric saddle point, so ``"auto"`` is SuperLU (``"lu"``);
    ``"cholesky"`` tries the core's ``LDL^T`` (no pivoting: it may meet a zero pivot,
    then :class:`tetlap.SolveError`); ``"amg"`` does not apply. Returns f (n,) float64
    (and a :class:`SolveInfo` with ``return_info=True``).
    """
    L = _arrays.matrix(L)
    V, T = _geometry(V, T, normal_derivative)
    n = len(V)
    if L.shape[0] != n:
        raise ShapeError(f"L has shape {L.shape}, the mesh has {n} vertices")
    gauge = _checks.gauge(gauge, n)
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    if solver == "amg":
        raise OptionError('the KKT system is an indefinite saddle point: solver="amg" does not '
                          'apply (use "auto", "cholesky" or "lu")')
    used = diagnostics.referenced_vertices(T, n)
    if gauge != "mean" and not used[gauge]:
        raise OptionError(f"gauge = {gauge} is a vertex of no tet")
    bf, tets, corners = diagnostics.boundary_faces(T, return_tets=True)
    centroid = V[bf].mean(axis=1)
    normal = _unit_normals(V, bf, tets)
    # orient outward: away from the tet's opposite vertex
    opposite = V[T[tets, corners]]
    normal *= np.sign(np.einsum("ij,ij->i", normal, centroid - opposite))[:, None]
    g = normal_derivative(centroid, normal) if callable(normal_derivative) else normal_derivative
    g = _arrays.vector(g, len(bf), "normal_derivative")
    # gradient of the P1 function on tet t: G_t f = sum_a f_a grad(lambda_a)
    X = V[T[tets]]
    E = X[:, 1:] - X[:, :1]
    inv = np.linalg.inv(E)  # rows of E^-T are grad(lambda_1..3)
    grads = np.concatenate([-inv.sum(axis=2, keepdims=True), inv], axis=2)  # (F, 3, 4)
    coef = np.einsum("fd,fda->fa", normal, grads)
    # the system on the vertices in tets only (renumbered)
    idx = np.flatnonzero(used)
    new = np.full(n, -1)
    new[idx] = np.arange(len(idx))
    m = len(idx)
    C = sp.csr_array((coef.ravel(), (np.repeat(np.arange(len(bf)), 4), new[T[tets]].ravel())),
                     shape=(len(bf), m))
    inner = diagnostics.interior_vertices(T, n)
    LI = L[inner][:, idx]
    b = np.zeros(int(inner.sum())) if rhs is None else _arrays.vector(rhs, n, "rhs")[inner]
    labels = _mesh_components(T, n)[idx]
    comps = np.unique(labels)
    rows, cols = [], []
    for k, c in enumerate(comps):
        members = np.flatnonzero(labels == c)
        if gauge != "mean" and labels[new[gauge]] == c:
            members = np.array([new[gauge]])
        rows.append(np.full(len(members), k))
        cols.append(members)
    cols_all = np.concatenate(cols)
    G = sp.csr_array((np.ones(len(cols_all)), (np.concatenate(rows), cols_all)), shape=(len(comps), m))
    A = sp.vstack([LI, G])
    K = sp.csr_array(sp.block_array([[C.T @ C, A.T], [A, None]], format="csr"))
    info = SolveInfo()
    sol = _linear.solve(K, np.concatenate([C.T @ g, b, np.zeros(len(comps))]),
                        "KKT system", solver="lu" if solver == "auto" else solver, info=info,
                        progress=progress, symmetric=solver == "cholesky")
    f = np.zeros(n)
    f[idx] = sol[:m]
    return (f, info) if return_info else f
