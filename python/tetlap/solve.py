"""Boundary-value and eigenvalue problems with tetlap's operators (paper Sec. 6, 8).

Sign convention as everywhere in tetlap: ``L`` is the paper's Laplacian (``L[i, i] =
-sum_j w_ij``), so ``-L`` is positive semidefinite for the primal; ``L f = b`` discretises
``Laplace(f) = b`` integrated over vertex cells.

Every solver checks its input like the operators do (shapes, finiteness, index ranges:
the :mod:`tetlap.errors` classes) and checks what it returns: a solution is finite and its
relative residual ``|A x - b| / (|A| |x| + |b|)`` (infinity norms) is at most
``RESIDUAL_TOL`` (1e-8), else :class:`tetlap.SolveError` says why; a component of the mesh
without a constraint where one is needed is named before anything is solved.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.cube(4, jitter=0.2)
>>> L = tetlap.laplacian(V, T, "dual")
>>> fixed = tetlap.diagnostics.boundary_vertices(T, len(V))
>>> f = tetlap.solve.dirichlet(L, fixed, V[:, 0] + 2 * V[:, 1])   # a linear function
>>> bool(np.allclose(f, V[:, 0] + 2 * V[:, 1]))                   # is reproduced
True
"""

from __future__ import annotations

import numbers
import warnings

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import eigsh, spsolve

from . import _arrays, diagnostics
from .errors import (CompatibilityError, DegenerateElementError, DtypeError, IndexRangeError,
                     OptionError, ShapeError, SolveError)

__all__ = [
    "dirichlet",
    "neumann",
    "neumann_primal_kkt",
    "eigs",
    "dual_boundary_areas",
    "fem_boundary_areas",
    "CompatibilityError",
    "SolveError",
    "RESIDUAL_TOL",
]

#: Largest relative residual ``|A x - b|_inf / (|A|_inf |x|_inf + |b|_inf)`` accepted.
RESIDUAL_TOL = 1e-8


def _mask(fixed, n: int) -> np.ndarray:
    fixed = _arrays._as_array(fixed, "fixed")
    if fixed.dtype == bool:
        if fixed.shape != (n,):
            raise ShapeError(f"a boolean `fixed` must have shape ({n},), got {fixed.shape}")
        return fixed.copy()
    if fixed.dtype.kind not in "iu":
        raise DtypeError("`fixed` must be a boolean mask or integer vertex indices")
    if fixed.size and (fixed.min() < 0 or fixed.max() >= n):
        bad = int(fixed.ravel()[np.argmax((fixed.ravel() < 0) | (fixed.ravel() >= n))])
        raise IndexRangeError(f"`fixed` holds the index {bad}, outside 0..{n}", index=bad)
    mask = np.zeros(n, dtype=bool)
    mask[fixed.ravel()] = True
    return mask


def _values(values, fixed: np.ndarray) -> np.ndarray:
    n = len(fixed)
    v = np.asarray(values) if np.isscalar(values) else _arrays._as_array(values, "values")
    if v.dtype.kind not in "fiub":
        raise DtypeError(f"values must hold real numbers, got dtype {v.dtype}")
    v = v.astype(np.float64)
    if v.ndim == 0:
        out = np.zeros(n)
        out[fixed] = v
    elif v.shape == (n,):
        out = np.where(fixed, v, 0.0)
    elif v.shape == (int(fixed.sum()),):
        out = np.zeros(n)
        out[fixed] = v
    else:
        raise ShapeError(
            f"values must be a scalar, one per vertex ({n}) or one per fixed vertex "
            f"({int(fixed.sum())}), got shape {v.shape}")
    return _arrays.vector(out, n, "values")


def _solve(A, b, what: str) -> np.ndarray:
    """``spsolve(A, b)`` and the check of its residual (see :data:`RESIDUAL_TOL`)."""
    A = sp.csc_array(A)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a singular matrix is reported below, once
        x = spsolve(A, b)
    x = np.atleast_1d(x)
    if not np.isfinite(x).all():
        raise SolveError(f"the {what} is singular (the solution is not finite)")
    residual = np.abs(A @ x - b).max() if len(b) else 0.0
    scale = abs(A).sum(axis=1).max() * np.abs(x).max() + np.abs(b).max() if len(b) else 1.0
    if residual > RESIDUAL_TOL * max(scale, 1e-300):
        raise SolveError(f"the {what} is singular or too ill-conditioned: relative residual "
                         f"{residual / max(scale, 1e-300):.1e} (tolerance {RESIDUAL_TOL:g})")
    return x


def _gauge(gauge, n: int):
    """``"mean"`` or a checked vertex index."""
    if isinstance(gauge, str):
        if gauge != "mean":
            raise OptionError(f'gauge must be "mean" or a vertex index, got {gauge!r}')
        return gauge
    return _arrays.vertex_index(gauge, n, "gauge")


def _components(L):
    """Connected components of the graph of ``L`` and the referenced vertices (non-zero
    rows)."""
    referenced = np.asarray(abs(L).sum(axis=1)).ravel() > 0
    _, labels = csgraph.connected_components(sp.csr_array(L != 0), directed=False)
    return labels, referenced


def dirichlet(L, fixed, values, rhs=None, *, method: str = "eliminate") -> np.ndarray:
    """Solve ``(L f)_i = rhs_i`` on free vertices with ``f = values`` on ``fixed`` ones.

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian (any format; not modified).
    fixed : (n,) bool mask or integer array of vertex indices
        The constrained vertices: at least one in every connected component of the mesh
        that has free vertices (else :class:`tetlap.SolveError` names the component).
    values : float, (n,) or (n_fixed,) array-like
        The values on the fixed vertices (entries of an (n,) array at free vertices are
        ignored).
    rhs : (n,) array-like, optional
        The right-hand side (default 0: the Laplace equation, i.e. minimising the
        Dirichlet energy ``-f^T L f`` of Eq. 28 under the constraints).
    method : {"eliminate", "replace"}, default "eliminate"
        ``"eliminate"`` solves the reduced system ``L_FF f_F = rhs_F - L_FB f_B``;
        ``"replace"`` replaces the rows of fixed vertices by identity rows (paper Sec. 6)
        and solves the full system. Both give the same solution (to rounding).

    Returns
    -------
    f : (n,) float64 array
        Equal to ``values`` on fixed vertices; unreferenced free vertices get 0.

    Raises
    ------
    tetlap.SolveError
        A component without a fixed vertex, or a system without an accurate solution.
    """
    L = _arrays.matrix(L)
    n = L.shape[0]
    fixed = _mask(fixed, n)
    f = _values(values, fixed)
    b = np.zeros(n) if rhs is None else _arrays.vector(rhs, n, "rhs")
    if method not in ("eliminate", "replace"):
        raise OptionError(f'method must be "eliminate" or "replace", got {method!r}')
    labels, referenced = _components(L)
    free = ~fixed & referenced
    for c in np.unique(labels[free]):
        if not (fixed & (labels == c)).any():
            v = int(np.flatnonzero(free & (labels == c))[0])
            raise SolveError(f"the component of vertex {v} has no fixed vertex: the Dirichlet "
                             "problem is singular there (fix a vertex of it, or use neumann)")
    lone = ~fixed & ~referenced
    if (b[lone] != 0).any():
        v = int(np.flatnonzero(lone & (b != 0))[0])
        raise SolveError(f"vertex {v} belongs to no element but has rhs {b[v]:g} != 0")
    if not free.any():
        return f
    if method == "eliminate":
        f[free] = _solve(L[free][:, free], b[free] - L[free][:, fixed] @ f[fixed],
                         "Dirichlet system")
    else:
        keep = sp.diags_array((~fixed).astype(np.float64))
        A = keep @ L + sp.diags_array((fixed | lone).astype(np.float64))
        b = b.copy()
        b[fixed] = f[fixed]
        f = _solve(A, b, "Dirichlet system")
    return f


def neumann(L, g, rhs=None, *, gauge="mean", rtol: float = 1e-6) -> np.ndarray:
    """Solve the pure Neumann problem ``L f = rhs - g`` (paper Sec. 6, ``L f = -g``).

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian (not modified).
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
        The data must integrate to zero over each component: ``|sum| <= rtol sum |data|``.

    Returns
    -------
    f : (n,) float64 array
        Unreferenced vertices get 0.

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
    gauge = _gauge(gauge, n)
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
        gauged = np.array([gauge]) if gauge != "mean" and gauge in members else members
        rows += [np.full(len(gauged), k)]
        cols += [gauged]
        vals += [np.ones(len(gauged))]
    if not len(comps):
        return np.zeros(n)
    C = sp.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                     shape=(len(comps), n))
    lone = sp.diags_array((~referenced).astype(np.float64))
    K = sp.block_array([[L + lone, C.T], [C, None]], format="csc")
    sol = _solve(K, np.concatenate([np.where(referenced, data, 0.0), np.zeros(len(comps))]),
                 "Neumann system")
    return sol[:n]


def neumann_primal_kkt(L, V, T=None, normal_derivative=None, rhs=None, *,
                       gauge="mean") -> np.ndarray:
    """Primal Neumann problem with the gradient constraints of Eq. 25, in a KKT system.

    For every boundary face (of a tet ``t``) the normal component of the gradient of the
    piecewise linear ``f`` on ``t`` is asked to equal ``normal_derivative`` (an (F,) array
    in the order of :func:`tetlap.diagnostics.boundary_faces`, or a callable taking the
    face centroids (F, 3) and outward unit normals (F, 3)). There are more faces than
    boundary vertices, so the constraints are met in the least-squares sense while the
    interior rows ``(L f)_I = rhs_I`` hold exactly (Lagrange multipliers)::

        minimise |C f - g|^2  subject to  L_I f = rhs_I  (and the gauge).

    ``gauge`` is ``"mean"`` (zero mean) or a vertex index (``f[gauge] = 0``); the mesh must
    be connected. Linear functions are reproduced exactly. Returns f (n,) float64.
    """
    L = _arrays.matrix(L)
    V, T = _geometry(V, T, normal_derivative)
    n = len(V)
    if L.shape[0] != n:
        raise ShapeError(f"L has shape {L.shape}, the mesh has {n} vertices")
    gauge = _gauge(gauge, n)
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
    C = sp.csr_array((coef.ravel(), (np.repeat(np.arange(len(bf)), 4), T[tets].ravel())),
                     shape=(len(bf), n))
    inner = diagnostics.interior_vertices(T, n)
    LI = L[inner]
    b = np.zeros(int(inner.sum())) if rhs is None else _arrays.vector(rhs, n, "rhs")[inner]
    gauge_row = sp.csr_array(np.ones((1, n)) if gauge == "mean" else
                             sp.csr_array(([1.0], ([0], [gauge])), shape=(1, n)))
    A = sp.vstack([LI, gauge_row])
    K = sp.block_array([[C.T @ C, A.T], [A, None]], format="csc")
    sol = _solve(K, np.concatenate([C.T @ g, b, [0.0]]), "KKT system (is the mesh connected?)")
    return sol[:n]


def _unit_normals(V, F, tets) -> np.ndarray:
    """Unit normals of the faces ``F``; a degenerate face (zero area) raises
    :class:`tetlap.DegenerateElementError` naming its tet."""
    n = diagnostics.face_normals(V, F)
    area = np.linalg.norm(n, axis=1)
    if not (area > 0).all():
        t = int(tets[np.argmin(area > 0)])
        raise DegenerateElementError(f"element {t} has a boundary face of zero area",
                                     element=t)
    return n / area[:, None]


def _geometry(V, T, normal_derivative):
    """``(V, T)`` arrays (or those of one mesh object passed as ``V``), checked."""
    if normal_derivative is None:
        raise TypeError("normal_derivative is missing: a constant gradient (3,) or a callable")
    V, T = _arrays.mesh(V, T)
    return _arrays.points(V), _arrays.elements(T, 4)


def _boundary_pieces(V, T):
    """Boundary faces (F, 3), outward unit normals, and per corner the circumcentric
    (signed) and the barycentric areas of the face."""
    bf, tets, _ = diagnostics.boundary_faces(T, return_tets=True)
    P = V[bf]
    unit = _unit_normals(V, bf, tets)
    area = np.linalg.norm(diagnostics.face_normals(V, bf), axis=1)
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
    n = len(V)
    if callable(normal_derivative):
        # one quadrature point per corner piece: its own corner's sub-region centroid
        centroid = P.mean(axis=1)
        values = np.stack([_arrays.vector(normal_derivative((P[:, k] + centroid) / 2, unit),
                                          len(bf), "normal_derivative(...)") for k in range(3)],
                          axis=1)
    else:
        grad = _arrays.vector(normal_derivative, 3, "normal_derivative (a constant gradient)")
        values = np.repeat((unit @ grad)[:, None], 3, axis=1)
    return np.bincount(bf.ravel(), weights=(area * values).ravel(), minlength=n)


@_arrays.takes_mesh_object
def dual_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """Integrated normal flux ``g`` per vertex for the dual Neumann problem ``L f = -g``.

    Each boundary face is split into the circumcentric pieces of its corners (signed, the
    faces that close the dual cells of boundary vertices); ``normal_derivative`` is a
    constant gradient (3,) (exact) or a callable ``(points (k, 3), normals (k, 3)) ->
    (k,)`` evaluated once per piece. Returns (n,), zero at interior vertices.
    """
    return _flux(V, T, normal_derivative, 0)


@_arrays.takes_mesh_object
def fem_boundary_areas(V, T=None, normal_derivative=None) -> np.ndarray:
    """The P1 boundary load ``g_i = int_boundary (n . grad u) phi_i``: the natural Neumann
    condition of the primal (each face's flux shared equally by its corners)."""
    return _flux(V, T, normal_derivative, 1)


def eigs(L, M, k: int = 10, fixed=None, *, sigma: float | None = None):
    """The ``k`` smallest eigenpairs of ``-L_II f = lambda M_II f`` (Eq. 30).

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A Laplacian (not modified).
    M : (n, n) SciPy sparse array or matrix
        A mass matrix; ``M_II`` must be positive definite: a lumped mass with a
        non-positive free entry (circumcentric masses on bad meshes) raises
        :class:`tetlap.SolveError` naming the vertex.
    k : int, default 10
        Number of eigenpairs, ``1 <= k < n_free``.
    fixed : (n,) bool mask or integer array, optional
        Dirichlet vertices (e.g. the boundary; ``None``: no constraint). ``I`` are the
        others.
    sigma : float, optional
        The shift of the shift-invert Lanczos iteration (``scipy.sparse.linalg.eigsh``;
        default slightly below 0), so it stays fast on 1e5+ vertices.

    Returns
    -------
    eigenvalues : (k,) float64, ascending.
    eigenvectors : (n, k) float64, zero on ``fixed`` vertices, M-orthonormal on the free
        ones. Every pair is checked: ``|A v - lambda B v| <= 1e-8 (|A| + |lambda| |B|)
        |v|`` (infinity norms), else :class:`tetlap.SolveError`.
    """
    L = _arrays.matrix(L)
    n = L.shape[0]
    M = _arrays.matrix(M, n, "M")
    fixed = np.zeros(n, dtype=bool) if fixed is None else _mask(fixed, n)
    free = np.flatnonzero(~fixed)
    if not isinstance(k, numbers.Integral) or isinstance(k, bool) or not 0 < k < len(free):
        raise OptionError(f"k must be an integer between 1 and {len(free) - 1}, got {k!r}")
    k = int(k)
    if sigma is not None and not (isinstance(sigma, numbers.Real) and np.isfinite(sigma)):
        raise OptionError(f"sigma must be a finite real number or None, got {sigma!r}")
    A = -L[free][:, free]
    B = M[free][:, free]
    is_diagonal = B.nnz == np.count_nonzero(B.diagonal())
    if is_diagonal:
        d = B.diagonal()
        if (d <= 0).any():
            bad = int(free[np.argmin(d)])
            raise SolveError(
                f"the mass matrix is not positive on the free vertices: M[{bad}, {bad}] = "
                f"{d.min():.3e} ({int((d <= 0).sum())} entries <= 0); circumcentric masses "
                "can be negative on non-Delaunay meshes: use boundary='barycentric' or the "
                "barycentric mass")
    if sigma is None:
        scale = abs(A).max() / max(abs(B).max(), 1e-300)
        sigma = -1e-6 * scale
    try:
        lam, vec = eigsh(sp.csc_array(A), k=k, M=sp.csc_array(B), sigma=float(sigma), which="LM")
    except Exception as e:  # ARPACK and SuperLU failures: no eigenpairs to return
        raise SolveError(f"the eigenproblem could not be solved ({type(e).__name__}: {e})") from e
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    norm_a, norm_b = abs(A).sum(axis=1).max(), abs(B).sum(axis=1).max()
    for j in range(k):
        v = vec[:, j]
        residual = np.abs(A @ v - lam[j] * (B @ v)).max()
        if not np.isfinite(lam[j]) or residual > RESIDUAL_TOL * (norm_a + abs(lam[j]) * norm_b) * np.abs(v).max():
            raise SolveError(f"eigenpair {j} (lambda = {lam[j]:.6g}) has relative residual "
                             f"{residual / ((norm_a + abs(lam[j]) * norm_b) * np.abs(v).max()):.1e}")
    full = np.zeros((n, k))
    full[free] = vec
    return lam, full
