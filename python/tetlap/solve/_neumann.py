"""Pure Neumann problems: :func:`neumann` (``L f = rhs - g``, any Laplacian) and
:func:`neumann_primal_kkt` (the primal with the gradient constraints of Eq. 25)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _arrays, diagnostics
from ..errors import CompatibilityError, OptionError, ShapeError, SolveError
from . import _checks, _linear
from ._boundary import _geometry, boundary, frame_exponents
from .info import SolveInfo


def neumann(L, g, rhs=None, *, gauge="mean", rtol: float = 1e-6, solver: str = "auto",
            progress=None, return_info: bool = False):
    """Solve the pure Neumann problem ``L f = rhs - g`` (paper Sec. 6, ``L f = -g``).

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A tetlap Laplacian (symmetric, rows summing to zero, ``L[i, i] = -sum_j w_ij``;
        not modified). The stiffness sign ``-L`` is refused (:class:`tetlap.OptionError`).
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
        Vertices in no element (no edge in ``L``) get 0.
    info : SolveInfo, with ``return_info=True``.

    Raises
    ------
    tetlap.CompatibilityError
        Data that do not integrate to zero (no solution exists).
    tetlap.SolveError
        A system without an accurate solution, or data (``g`` or ``rhs``) that are not 0
        at a vertex in no element (no equation holds them).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(4, jitter=0.2)
    >>> L = tetlap.laplacian(V, T, "dual")
    >>> f = tetlap.solve.neumann(L, tetlap.solve.dual_boundary_areas(V, T, [1.0, 0.0, 0.0]))
    >>> bool(np.allclose(f, V[:, 0] - V[:, 0].mean()))
    True
    """
    L = _arrays.laplacian(L)
    n = L.shape[0]
    g = _arrays.vector(g, n, "g")
    r = None if rhs is None else _arrays.vector(rhs, n, "rhs")
    gauge = _checks.gauge(gauge, n)
    rtol = _checks.rtol(rtol)
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    _checks.flag(return_info, "return_info", unset=False)
    info = SolveInfo()
    with info.phase("components"):
        labels, referenced = _checks.components(L)
    _checks.off_the_mesh(g, referenced, "flux g")
    if r is not None:
        _checks.off_the_mesh(r, referenced, "rhs")
    e = _checks.exponent(g, *(() if r is None else (r,)))   # 1e308 data: solved scaled
    with np.errstate(over="ignore"):
        data = -np.ldexp(g, -e) if r is None else np.ldexp(r, -e) - np.ldexp(g, -e)
    f = _pure(L, data, labels, referenced, gauge, rtol, solver, info, progress)
    f = _checks.unscaled(f, e, "Neumann system")
    return (f, info) if return_info else f


def _pure(L, data, labels, referenced, gauge, rtol, solver, info, progress) -> np.ndarray:
    """The solution of ``L f = data`` on every component of ``labels`` (checked
    arguments), gauged; ``rtol`` None removes any defect of the data (else a larger one
    than ``rtol`` is a CompatibilityError)."""
    n = L.shape[0]
    f = np.zeros(n)
    if not referenced.any():
        return f
    idx = np.flatnonzero(referenced)
    lab = labels[idx]
    order = np.argsort(lab, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(lab[order]) != 0])
    groups = np.split(idx[order], starts[1:])
    d = np.where(referenced, data, 0.0)
    pinned = np.zeros(n, dtype=bool)
    for members in groups:
        total, scale = d[members].sum(), np.abs(d[members]).sum()
        if rtol is not None and abs(total) > rtol * scale:
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
    return f


def _mesh_components(T, n: int) -> np.ndarray:
    """Component label per vertex of the graph of the tets' edges."""
    from scipy.sparse import csgraph

    a = T[:, [0, 0, 0, 1, 1, 2]].ravel()
    b = T[:, [1, 2, 3, 2, 3, 3]].ravel()
    G = sp.csr_array((np.ones(len(a)), (a, b)), shape=(n, n))
    return csgraph.connected_components(G, directed=False)[1]


#: The proximal step of :func:`neumann_primal_kkt`: ``|C f - g|^2`` is minimised with
#: ``KKT_STEP max_i (C^T C)_ii |f - f_k|^2`` added, from the weak solution ``f_0`` on, until
#: the steps stop shrinking (at most ``KKT_STEPS``). Below :data:`RESIDUAL_TOL`, so that a
#: direction the steps leave unconverged cannot fail the residual check; larger steps
#: converge faster, smaller ones amplify rounding in the free directions less (2^-27:
#: about 1e-10 of the answer on the Kuhn grids).
KKT_STEP = 2.0**-27
KKT_STEPS = 30


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

    ``L`` is the primal Laplacian of ``(V, T)`` (``L[i, i] = -sum_j w_ij``; the stiffness
    sign ``-L`` is refused); ``rhs`` (n,) the integrated source, of which the entries at
    interior vertices enter (the boundary rows are replaced by the gradient constraints),
    0 at vertices in no tet.

    The minimiser need not be unique: on the Kuhn grids of :func:`tetlap.meshes.cube` the
    faces leave some boundary values free. The one returned is the minimiser closest
    (Euclidean norm) to the weak solution ``f_0`` of the same data (:func:`neumann` with
    the P1 load of ``normal_derivative``, as :func:`fem_boundary_areas` forms it), found by
    proximal steps: each solves the KKT system with ``KKT_STEP max_i (C^T C)_ii |f -
    f_k|^2`` added to the objective (one factorization), until the steps stop shrinking;
    directions that the faces determine more weakly than that keep ``f_0``'s values.
    Where the minimiser is unique (balls, jittered grids) that is it; linear functions
    are reproduced exactly on every mesh (they are both ``f_0`` and a minimiser). The
    system is solved in a frame scaled by a power of two to the size of a typical tet
    (exact), so the answer does not depend on the mesh's unit (coordinates from 1e-150 to
    1e150). ``info.iterations`` counts the proximal steps.

    ``gauge`` is ``"mean"`` (zero mean on every connected component of the mesh) or a
    vertex index (``f[gauge] = 0`` in its component, zero mean on the others); vertices in
    no tet take no part and get 0. ``solver``: the KKT matrix is a symmetric saddle point,
    so ``"auto"`` is SuperLU (``"lu"``); ``"cholesky"`` tries the core's ``LDL^T`` (no
    pivoting: it may meet a zero pivot, then :class:`tetlap.SolveError`); ``"amg"`` does
    not apply; the weak solution is solved by ``"auto"``. Returns f (n,) float64 (and a :class:`SolveInfo` with ``return_info=True``).

    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(3)                    # a Kuhn grid
    >>> L = tetlap.laplacian(V, T, "primal")
    >>> f = tetlap.solve.neumann_primal_kkt(L, V, T, lambda c, n: n @ [1.0, 2.0, 0.0])
    >>> u = V @ [1.0, 2.0, 0.0]
    >>> bool(np.abs(f - (u - u.mean())).max() < 1e-12)
    True
    """
    L = _arrays.laplacian(L)
    V, T = _geometry(V, T, normal_derivative)
    n = len(V)
    if L.shape[0] != n:
        raise ShapeError(f"L has shape {L.shape}, the mesh has {n} vertices")
    gauge = _checks.gauge(gauge, n)
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    _checks.flag(return_info, "return_info", unset=False)
    if solver == "amg":
        raise OptionError('the KKT system is an indefinite saddle point: solver="amg" does not '
                          'apply (use "auto", "cholesky" or "lu")')
    used = diagnostics.referenced_vertices(T, n)
    if gauge != "mean" and not used[gauge]:
        raise OptionError(f"gauge = {gauge} is a vertex of no tet")
    r = np.zeros(n) if rhs is None else _arrays.vector(rhs, n, "rhs")
    _checks.off_the_mesh(r, used, "rhs")
    faces = boundary(V, T)
    g = normal_derivative
    if callable(g):
        g = g(V[faces.faces].mean(axis=1), faces.normals)
    g = _arrays.vector(g, len(faces.faces), "normal_derivative")
    info = SolveInfo()
    # the frame: lengths divided by 2^e (a typical tet's frame, exact), so that C^T C and
    # L_I are of one size at any unit; the data by a further 2^k when they are huge
    tet_exponents = frame_exponents(_edges(V, T))
    e = int(np.sort(tet_exponents)[len(T) // 2])
    k = _data_exponent(g, e, r, -e)
    g1, r1 = np.ldexp(g, e - k), np.ldexp(r, -e - k)
    L1 = sp.csr_array((np.ldexp(L.data, -e), L.indices, L.indptr), shape=L.shape)
    # gradient of the P1 function on tet t: G_t f = sum_a f_a grad(lambda_a), each tet in
    # its own frame, then in the frame of the system
    s = tet_exponents[faces.tets]
    E = np.ldexp(_edges(V, T[faces.tets]), -s[:, None, None])
    inv = np.linalg.inv(E)          # rows of E^-T are grad(lambda_1..3)
    grads = np.ldexp(np.concatenate([-inv.sum(axis=2, keepdims=True), inv], axis=2),
                     (e - s)[:, None, None])                                  # (F, 3, 4)
    coef = np.einsum("fd,fda->fa", faces.normals, grads)
    # the system on the vertices in tets only (renumbered)
    idx = np.flatnonzero(used)
    new = np.full(n, -1)
    new[idx] = np.arange(len(idx))
    m = len(idx)
    F = len(faces.faces)
    C = sp.csr_array((coef.ravel(), (np.repeat(np.arange(F), 4), new[T[faces.tets]].ravel())),
                     shape=(F, m))
    inner = diagnostics.interior_vertices(T, n)
    labels = _mesh_components(T, n)[idx]
    comps = np.unique(labels)
    rows, cols = [], []
    for j, c in enumerate(comps):
        members = np.flatnonzero(labels == c)
        if gauge != "mean" and labels[new[gauge]] == c:
            members = np.array([new[gauge]])
        rows.append(np.full(len(members), j))
        cols.append(members)
    cols_all = np.concatenate(cols)
    G = sp.csr_array((np.ones(len(cols_all)), (np.concatenate(rows), cols_all)),
                     shape=(len(comps), m))
    A = sp.csr_array(sp.vstack([L1[inner][:, idx], G]))
    b = np.concatenate([r1[inner], np.zeros(len(comps))])
    # the weak solution: L f = rhs - (the P1 load of g), its defect removed
    load = np.bincount(faces.faces.ravel(), minlength=n,
                       weights=np.repeat(np.ldexp(faces.area, -2 * e) / 3 * g1, 3))
    with info.phase("weak solution"):
        weak_labels, weak_used = _checks.components(L1)
        f0 = _pure(L1, r1 - load, weak_labels, weak_used, gauge, None, "auto", SolveInfo(),
                   progress)
    z = _closest_minimiser(C, g1, A, b, f0[idx], solver, info, progress)
    f = np.zeros(n)
    f[idx] = z[:m]
    f = _checks.unscaled(f, k, "KKT system")
    return (f, info) if return_info else f


def _edges(V, T) -> np.ndarray:
    """``x_k - x_0`` (k = 1, 2, 3) of every tet, (m, 3, 3)."""
    X = V[T]
    with np.errstate(over="ignore", invalid="ignore"):
        return X[:, 1:] - X[:, :1]


def _data_exponent(g, eg: int, r, er: int) -> int:
    """``k`` such that ``g 2^(eg - k)`` and ``r 2^(er - k)`` are below :data:`_checks.LARGE`
    (0 when they are already: ordinary data are solved unscaled)."""
    top = [int(np.frexp(float(np.abs(x).max()))[1]) + ex for x, ex in ((g, eg), (r, er))
           if x.size and np.abs(x).max() > 0]
    largest = max(top, default=0)
    return largest - 1 if largest - 1 >= int(np.log2(_checks.LARGE)) else 0


def _closest_minimiser(C, g, A, b, f0, solver, info, progress) -> np.ndarray:
    """``(f, lambda)`` of ``min |C f - g|^2 s.t. A f = b`` closest to ``f0``: proximal
    steps ``z += K_eps^-1 (r - K z)`` with ``K = [[C^T C, A^T], [A, 0]]`` and ``K_eps`` its
    ``(1, 1)`` block shifted by ``KKT_STEP max diag(C^T C)`` (each step minimises the
    objective plus that multiple of ``|f - f_k|^2``), the residual in the factored form
    ``C^T (g - C f) - A^T lambda`` (a rounding of ``C^T g`` in the free directions would
    otherwise drift them by ``eps / KKT_STEP`` per step), until the steps stop
    shrinking. The residual is checked on ``K``."""
    m = C.shape[1]
    H = sp.csr_array(C.T @ C)
    K = sp.csr_array(sp.block_array([[H, A.T], [A, None]], format="csr"))
    shift = KKT_STEP * float(H.diagonal().max(initial=0.0))
    K_eps = sp.csr_array(K + sp.diags_array(np.r_[np.full(m, shift), np.zeros(A.shape[0])]))
    factor = _linear.factor(K_eps, "lu" if solver == "auto" else solver, info, progress)
    if factor._tiny is not None:
        raise SolveError(f"the KKT system: {factor._tiny}")
    z = np.r_[f0, np.zeros(A.shape[0])]
    last = np.inf
    steps = 0
    with info.phase("solve"):
        while steps < KKT_STEPS:
            f, lam = z[:m], z[m:]
            residual = np.r_[C.T @ _checks.extended_residual(C, f, g) - A.T @ lam,
                             _checks.extended_residual(A, f, b)]
            step = factor._raw(residual[:, None])[:, 0]
            if not np.isfinite(step).all():
                break
            z = z + step
            steps += 1
            size = float(np.abs(step).max()) / max(float(np.abs(z).max()), np.finfo(float).tiny)
            if size <= np.finfo(float).eps or size > last / 2:
                break
            last = size
    info.iterations = steps
    info.residual = 0.0
    return _checks.accept(K, z, np.r_[C.T @ g, b], "KKT system", info, condition=False)
