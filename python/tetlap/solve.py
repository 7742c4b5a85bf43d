"""Boundary-value and eigenvalue problems with tetlap's operators (paper Sec. 6, 8).

Sign convention as everywhere in tetlap: ``L`` is the paper's Laplacian (``L[i, i] =
-sum_j w_ij``), so ``-L`` is positive semidefinite for the primal; ``L f = b`` discretises
``Laplace(f) = b`` integrated over vertex cells.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.cube(4, jitter=0.2)
>>> L = tetlap.laplacian(V, T, "dual")
>>> fixed = tetlap.diagnostics.boundary_vertices(T, len(V))
>>> f = tetlap.solve.dirichlet(L, fixed, V[:, 0] + 2 * V[:, 1])   # a linear function
>>> bool(np.allclose(f, V[:, 0] + 2 * V[:, 1]))                   # is reproduced
True
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import eigsh, spsolve

from . import _arrays, diagnostics
from .errors import DtypeError, IndexRangeError, OptionError, ShapeError
from .errors import TetlapError

__all__ = [
    "dirichlet",
    "neumann",
    "neumann_primal_kkt",
    "eigs",
    "dual_boundary_areas",
    "fem_boundary_areas",
    "CompatibilityError",
]


class CompatibilityError(TetlapError):
    """A pure Neumann problem whose data do not integrate to zero (no solution exists)."""


def _mask(fixed, n: int) -> np.ndarray:
    fixed = np.asarray(fixed)
    if fixed.dtype == bool:
        if fixed.shape != (n,):
            raise ShapeError(f"a boolean `fixed` must have shape ({n},), got {fixed.shape}")
        return fixed.copy()
    if fixed.dtype.kind not in "iu":
        raise DtypeError("`fixed` must be a boolean mask or integer vertex indices")
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        raise IndexRangeError(f"`fixed` holds indices outside 0..{n}")
    mask = np.zeros(n, dtype=bool)
    mask[fixed.ravel()] = True
    return mask


def _values(values, fixed: np.ndarray) -> np.ndarray:
    n = len(fixed)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 0:
        out = np.zeros(n)
        out[fixed] = v
        return out
    if v.shape == (n,):
        return np.where(fixed, v, 0.0)
    if v.shape == (int(fixed.sum()),):
        out = np.zeros(n)
        out[fixed] = v
        return out
    raise ShapeError(
        f"values must be a scalar, one per vertex ({n}) or one per fixed vertex "
        f"({int(fixed.sum())}), got shape {v.shape}")


def dirichlet(L, fixed, values, rhs=None, *, method: str = "eliminate") -> np.ndarray:
    """Solve ``(L f)_i = rhs_i`` on free vertices with ``f = values`` on ``fixed`` ones.

    Parameters
    ----------
    L : (n, n) sparse Laplacian.
    fixed : (n,) bool mask or integer indices of the constrained vertices (at least one
        per connected component, or the problem is singular).
    values : scalar, (n,) (entries at free vertices ignored) or (n_fixed,) values.
    rhs : optional (n,) right-hand side (``0``: the Laplace equation, i.e. minimising the
        Dirichlet energy ``-f^T L f`` of Eq. 28 under the constraints).
    method : ``"eliminate"`` solves the reduced system ``L_FF f_F = rhs_F - L_FB f_B``;
        ``"replace"`` replaces the rows of fixed vertices by identity rows (paper Sec. 6)
        and solves the full system. Both give the same solution (to rounding).

    Returns
    -------
    f : (n,) float64, equal to ``values`` on fixed vertices.
    """
    L = sp.csr_array(L, dtype=np.float64)
    n = L.shape[0]
    fixed = _mask(fixed, n)
    f = _values(values, fixed)
    b = np.zeros(n) if rhs is None else np.asarray(rhs, dtype=np.float64).copy()
    if b.shape != (n,):
        raise ShapeError(f"rhs must have shape ({n},), got {b.shape}")
    free = ~fixed
    if not free.any():
        return f
    if method == "eliminate":
        A = L[free][:, free]
        f[free] = spsolve(sp.csc_array(A), b[free] - L[free][:, fixed] @ f[fixed])
    elif method == "replace":
        keep = sp.diags_array(free.astype(np.float64))
        A = keep @ L + sp.diags_array(fixed.astype(np.float64))
        b[fixed] = f[fixed]
        f = spsolve(sp.csc_array(A), b)
    else:
        raise OptionError(f'method must be "eliminate" or "replace", got {method!r}')
    if not np.isfinite(f).all():
        raise TetlapError("the Dirichlet system is singular: is every connected component "
                          "of the mesh constrained somewhere?")
    return f


def _components(L):
    referenced = np.asarray(abs(L).sum(axis=1)).ravel() > 0
    _, labels = csgraph.connected_components(sp.csr_array(L != 0), directed=False)
    return labels, referenced


def neumann(L, g, rhs=None, *, gauge="mean", rtol: float = 1e-6) -> np.ndarray:
    """Solve the pure Neumann problem ``L f = rhs - g`` (paper Sec. 6, ``L f = -g``).

    ``g`` (n,) is the integrated outward normal flux per vertex (zero at interior
    vertices): for the dual Laplacian use :func:`dual_boundary_areas` (exact for linear
    functions: dual cells at the boundary are closed by circumcentric pieces of the
    boundary faces); for the primal, the natural (weak) boundary condition is
    :func:`fem_boundary_areas` (the P1 boundary load). ``rhs`` (n,) is the integrated
    source (e.g. ``M @ s`` for ``Laplace(f) = s``).

    The constant functions of every connected component are in the null space: the data
    must integrate to zero over each component (else :class:`CompatibilityError`, with
    ``rtol`` relative to ``sum |data|``), and the solution is fixed by the gauge
    ``"mean"`` (zero mean per component) or an integer vertex (``f[gauge] = 0`` in its
    component, zero mean elsewhere). Unreferenced vertices get 0.
    """
    L = sp.csr_array(L, dtype=np.float64)
    n = L.shape[0]
    data = -np.asarray(g, dtype=np.float64)
    if rhs is not None:
        data = data + np.asarray(rhs, dtype=np.float64)
    if data.shape != (n,):
        raise ShapeError(f"g and rhs must have shape ({n},)")
    labels, referenced = _components(L)
    comps = np.unique(labels[referenced])
    rows, cols, vals = [], [], []
    for k, c in enumerate(comps):
        members = np.flatnonzero((labels == c) & referenced)
        total, scale = data[members].sum(), np.abs(data[members]).sum()
        if abs(total) > rtol * max(scale, 1e-300):
            raise CompatibilityError(
                f"the Neumann data do not integrate to zero on the component of vertex "
                f"{members[0]}: sum = {total:.3e} (relative {total / scale:.1e})")
        if isinstance(gauge, (int, np.integer)) and not isinstance(gauge, bool) and gauge in members:
            gauged = np.array([gauge])
        elif gauge == "mean" or isinstance(gauge, (int, np.integer)):
            gauged = members
        else:
            raise OptionError(f'gauge must be "mean" or a vertex index, got {gauge!r}')
        rows += [np.full(len(gauged), k)]
        cols += [gauged]
        vals += [np.ones(len(gauged))]
    C = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                     shape=(len(comps), n))
    lone = sp.diags_array((~referenced).astype(np.float64))
    K = sp.block_array([[L + lone, C.T], [C, None]], format="csc")
    sol = spsolve(K, np.concatenate([np.where(referenced, data, 0.0), np.zeros(len(comps))]))
    return sol[:n]


def neumann_primal_kkt(L, V, T=None, normal_derivative=None, rhs=None, *,
                       gauge="mean") -> np.ndarray:
    """Primal Neumann problem with the gradient constraints of Eq. 25, in a KKT system.

    For every boundary face (of a tet ``t``) the normal component of the gradient of the
    piecewise linear ``f`` on ``t`` is asked to equal ``normal_derivative`` (an (F,) array
    in the order of :func:`tetlap.diagnostics.boundary_faces`, or a callable taking the
    face centroids (F, 3) and outward unit normals (F, 3)). There are more faces than
    boundary vertices, so the constraints are met in the least-squares sense while the
    interior rows ``(L f)_I = rhs_I`` hold exactly (Lagrange multipliers):

        minimise |C f - g|^2  subject to  L_I f = rhs_I  (and the gauge).

    Linear functions are reproduced exactly. Returns f (n,).
    """
    L = sp.csr_array(L, dtype=np.float64)
    V, T = _geometry(V, T, normal_derivative)
    n = len(V)
    bf, tets, corners = diagnostics.boundary_faces(T, return_tets=True)
    centroid = V[bf].mean(axis=1)
    normal = diagnostics.face_normals(V, bf)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    # orient outward: away from the tet's opposite vertex
    opposite = V[T[tets, corners]]
    normal *= np.sign(np.einsum("ij,ij->i", normal, centroid - opposite))[:, None]
    g = normal_derivative(centroid, normal) if callable(normal_derivative) else np.asarray(
        normal_derivative, dtype=np.float64)
    # gradient of the P1 function on tet t: G_t f = sum_a f_a grad(lambda_a)
    X = V[T[tets]]
    E = X[:, 1:] - X[:, :1]
    inv = np.linalg.inv(E)  # rows of E^-T are grad(lambda_1..3)
    grads = np.concatenate([-inv.sum(axis=2, keepdims=True), inv], axis=2)  # (F, 3, 4)
    coef = np.einsum("fd,fda->fa", normal, grads)
    C = sp.csr_array((coef.ravel(), (np.repeat(np.arange(len(bf)), 4), T[tets].ravel())),
                     shape=(len(bf), n))
    inner = diagnostics.interior_vertices(T, n)
    LI = L[inner]
    b = np.zeros(int(inner.sum())) if rhs is None else np.asarray(rhs, dtype=np.float64)[inner]
    gauge_row = sp.csr_array(np.ones((1, n)) if gauge == "mean" else
                             sp.csr_array(([1.0], ([0], [int(gauge)])), shape=(1, n)))
    A = sp.vstack([LI, gauge_row])
    K = sp.block_array([[C.T @ C, A.T], [A, None]], format="csc")
    sol = spsolve(K, np.concatenate([C.T @ g, b, [0.0]]))
    if not np.isfinite(sol).all():
        raise TetlapError("the KKT system is singular (is the mesh connected?)")
    return sol[:n]


def _geometry(V, T, normal_derivative):
    """``(V, T)`` arrays (or those of one mesh object passed as ``V``), checked."""
    if normal_derivative is None:
        raise TypeError("normal_derivative is missing (pass it by keyword with a mesh object)")
    V, T = _arrays.mesh(V, T)
    return _arrays.points(V), _arrays.elements(T, 4)


def _boundary_pieces(V, T):
    """Boundary faces (F, 3), outward unit normals, and per corner the circumcentric
    (signed) and the barycentric areas of the face."""
    V = _arrays.points(V)
    bf = diagnostics.boundary_faces(T)
    P = V[bf]
    n = diagnostics.face_normals(V, bf)
    area = np.linalg.norm(n, axis=1)
    unit = n / area[:, None]
    # circumcentric piece of corner a: triangles (x_a, c_ab, c) and (x_a, c_ac, c), signed
    # area = (|ab|^2 cot(angle at c) + |ac|^2 cot(angle at b)) / 8
    cot = np.empty((len(bf), 3))
    for k in range(3):
        u, w = P[:, (k + 1) % 3] - P[:, k], P[:, (k + 2) % 3] - P[:, k]
        cot[:, k] = np.einsum("ij,ij->i", u, w) / np.linalg.norm(np.cross(u, w), axis=1)
    sq = lambda a, b: ((P[:, a] - P[:, b]) ** 2).sum(axis=1)
    circ = np.stack([(sq(0, 1) * cot[:, 2] + sq(0, 2) * cot[:, 1]) / 8,
                     (sq(1, 0) * cot[:, 2] + sq(1, 2) * cot[:, 0]) / 8,
                     (sq(2, 0) * cot[:, 1] + sq(2, 1) * cot[:, 0]) / 8], axis=1)
    return bf, unit, circ, np.repeat(area[:, None] / 3, 3, axis=1), P


def _flux(V, T, normal_derivative, which: int) -> np.ndarray:
    V, T = _geometry(V, T, normal_derivative)
    bf, unit, circ, bary, P = _boundary_pieces(V, T)
    area = (circ, bary)[which]
    n = len(_arrays.points(V))
    if callable(normal_derivative):
        # one quadrature point per corner piece: its own corner's sub-region centroid
        centroid = P.mean(axis=1)
        values = np.stack([normal_derivative((P[:, k] + centroid) / 2, unit) for k in range(3)],
                          axis=1)
    else:
        grad = np.asarray(normal_derivative, dtype=np.float64)
        values = np.repeat((unit @ grad)[:, None], 3, axis=1)
    return np.bincount(bf.ravel(), weights=(area * values).ravel(), minlength=n)


def dual_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """Integrated normal flux ``g`` per vertex for the dual Neumann problem ``L f = -g``.

    Each boundary face is split into the circumcentric pieces of its corners (signed, the
    faces that close the dual cells of boundary vertices); ``normal_derivative`` is a
    constant gradient (3,) (exact) or a callable ``(points (k, 3), normals (k, 3)) ->
    (k,)`` evaluated once per piece. Returns (n,), zero at interior vertices.
    """
    return _flux(V, T, normal_derivative, 0)


def fem_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """The P1 boundary load ``g_i = int_boundary (n . grad u) phi_i``: the natural Neumann
    condition of the primal (each face's flux shared equally by its corners)."""
    return _flux(V, T, normal_derivative, 1)


def eigs(L, M, k: int = 10, fixed=None, *, sigma: float | None = None):
    """The ``k`` smallest eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30).

    ``I`` are the vertices not in ``fixed`` (Dirichlet conditions, e.g. the boundary; None
    for no constraint). Shift-invert Lanczos (``scipy.sparse.linalg.eigsh``) around
    ``sigma`` (default slightly below 0), so it stays fast on 1e5+ vertices. ``M_II``
    must be positive definite: a lumped mass with a non-positive free entry (circumcentric
    masses on bad meshes) raises :class:`~tetlap.TetlapError`.

    Returns
    -------
    eigenvalues : (k,) ascending.
    eigenvectors : (n, k), zero on ``fixed`` vertices, M-orthonormal on the free ones.
    """
    L = sp.csr_array(L, dtype=np.float64)
    M = sp.csr_array(M, dtype=np.float64)
    n = L.shape[0]
    fixed = np.zeros(n, dtype=bool) if fixed is None else _mask(fixed, n)
    free = np.flatnonzero(~fixed)
    if not 0 < k < len(free):
        raise OptionError(f"k must be between 1 and {len(free) - 1}, got {k}")
    A = -L[free][:, free]
    B = M[free][:, free]
    is_diagonal = B.nnz == np.count_nonzero(B.diagonal())
    if is_diagonal:
        d = B.diagonal()
        if (d <= 0).any():
            bad = free[np.argmin(d)]
            raise TetlapError(
                f"the mass matrix is not positive on the free vertices: M[{bad}, {bad}] = "
                f"{d.min():.3e} ({int((d <= 0).sum())} entries <= 0); circumcentric masses "
                "can be negative on non-Delaunay meshes: use boundary='barycentric' or the "
                "barycentric mass")
    if sigma is None:
        scale = abs(A).max() / max(abs(B).max(), 1e-300)
        sigma = -1e-6 * scale
    lam, vec = eigsh(sp.csc_array(A), k=k, M=sp.csc_array(B), sigma=sigma, which="LM")
    order = np.argsort(lam)
    full = np.zeros((n, k))
    full[free] = vec[:, order]
    return lam[order], full
