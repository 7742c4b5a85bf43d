"""The Dirichlet problem ``(L f)_i = rhs_i`` on free vertices, ``f = values`` on fixed ones."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _arrays
from ..errors import OptionError, SolveError
from . import _checks, _linear
from .info import SolveInfo


def dirichlet(L, fixed, values, rhs=None, *, method: str = "eliminate", solver: str = "auto",
              progress=None, return_info: bool = False):
    """Solve ``(L f)_i = rhs_i`` on free vertices with ``f = values`` on ``fixed`` ones.

    Parameters
    ----------
    L : (n, n) SciPy sparse array or matrix
        A tetlap Laplacian, ``L[i, i] = -sum_j w_ij`` (any format; not modified). The
        stiffness sign ``-L`` (LaPy, scikit-fem) is refused: a non-negative diagonal is
        an :class:`tetlap.OptionError`.
    fixed : (n,) bool mask or 1-D integer array of distinct vertex indices
        The constrained vertices: at least one in every connected component of the mesh
        that has free vertices (else :class:`tetlap.SolveError` names the component).
    values : float, (n,) or (n_fixed,) array-like
        The values on the fixed vertices: one per fixed vertex, ``f[fixed[i]] =
        values[i]`` in the order of ``fixed`` (ascending vertex order for a mask); or one
        per vertex (entries at free vertices are ignored). When every vertex is fixed by
        indices in another order, the two readings differ and such values are refused.
    rhs : (n,) array-like, optional
        The right-hand side (default 0: the Laplace equation, i.e. minimising the
        Dirichlet energy ``-f^T L f`` of Eq. 28 under the constraints).
    method : {"eliminate", "replace"}, default "eliminate"
        ``"eliminate"`` solves the reduced system ``L_FF f_F = rhs_F - L_FB f_B``;
        ``"replace"`` replaces the rows of fixed vertices by identity rows (paper Sec. 6;
        each multiplied by the power of two of its diagonal entry, exactly, so that the
        rows are of one size at any scale of ``L``) and solves the full, non-symmetric
        system (``solver`` "auto" or "lu"). Both give the same solution (to rounding).
    solver : {"auto", "amg", "cholesky", "lu"}, default "auto"
        ``"amg"``: CG preconditioned by smoothed aggregation (pyamg), for one solve of a
        large system (the fastest from about 10k unknowns); ``"cholesky"``: the core's
        sparse ``LL^T`` (``LDL^T`` for an indefinite ``-L_FF``), refined in extended
        precision, fastest below 10k unknowns; ``"lu"``: SciPy's SuperLU, the old path
        (minutes at 1M tets). ``"auto"``: amg from 10k unknowns, else cholesky, falling
        back to cholesky then lu when CG finds the system indefinite or its answer fails
        the residual check (``info.fallbacks`` says why). What each costs, measured as
        multiples of one assembly with the command to rerun: :doc:`/guide/solving`.
    progress : bool, optional
        Phases and CG iterations on stderr (default: when stderr is a terminal).
    return_info : bool, default False
        Also return a :class:`tetlap.solve.SolveInfo` (solver, ordering, iterations,
        residual, phase times).

    Returns
    -------
    f : (n,) float64 array
        Equal to ``values`` on fixed vertices; free vertices in no element (no edge in
        ``L``) get 0.
    info : SolveInfo, with ``return_info=True``.

    Raises
    ------
    tetlap.SolveError
        A component without a fixed vertex, or a system without an accurate solution.
    tetlap.NonFiniteError
        A solution beyond the float64 range (values and ``rhs`` up to its largest number
        are solved scaled by a power of two, exactly).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(4, jitter=0.2)
    >>> L = tetlap.laplacian(V, T, "dual")
    >>> fixed = tetlap.diagnostics.boundary_vertices(V, T)
    >>> f, info = tetlap.solve.dirichlet(L, fixed, V[:, 0], solver="cholesky", return_info=True)
    >>> bool(np.allclose(f, V[:, 0])), info.solver, info.residual < 1e-12
    (True, 'cholesky', True)
    """
    L = _arrays.laplacian(L)
    n = L.shape[0]
    order = _checks.fixed(fixed, n)
    f = _checks.values(values, order, n)
    fixed = np.zeros(n, dtype=bool)
    fixed[order] = True
    b = np.zeros(n) if rhs is None else _arrays.vector(rhs, n, "rhs")
    if method not in ("eliminate", "replace"):
        raise OptionError(f'method must be "eliminate" or "replace", got {method!r}')
    _checks.solver(solver)
    _checks.flag(progress, "progress")
    _checks.flag(return_info, "return_info", unset=False)
    if method == "replace" and solver not in ("auto", "lu"):
        raise OptionError('method="replace" builds a non-symmetric system: use solver="auto" '
                          'or "lu" (or method="eliminate")')
    info = SolveInfo()
    with info.phase("components"):
        labels, referenced = _checks.components(L)
    free = ~fixed & referenced
    has_fixed = np.zeros(labels.max() + 1 if n else 0, dtype=bool)
    has_fixed[labels[fixed & referenced]] = True
    orphan = free & ~has_fixed[labels]
    if orphan.any():
        v = int(np.argmax(orphan))
        raise SolveError(f"the component of vertex {v} has no fixed vertex: the Dirichlet "
                         "problem is singular there (fix a vertex of it, or use neumann)")
    _checks.off_the_mesh(np.where(fixed, 0.0, b), referenced, "rhs")
    e = _checks.exponent(f, b)  # 1e308 values: solved scaled by 2^-e (exact), then back
    f, b = np.ldexp(f, -e), np.ldexp(b, -e)
    if free.any():
        if method == "eliminate":
            with info.phase("reduce"):
                rows = L[free]
                A = -rows[:, free]
                used = fixed & referenced
                rhs_f = b[free] - rows[:, used] @ f[used]
            f[free] = _linear.solve(A, -rhs_f, "Dirichlet system", solver=solver, info=info,
                                    progress=progress)
        else:
            # on the referenced vertices: an unused vertex takes part in no system. A fixed
            # vertex's row is 2^p f_i = 2^p values_i, 2^p the power of two of its diagonal
            # (exact): rows of one size at any scale of L (identity rows beside rows of
            # 2^100 made the system look singular)
            sub = L[referenced][:, referenced]
            keep = sp.diags_array(free[referenced].astype(np.float64))
            size = np.ldexp(1.0, np.frexp(np.abs(L.diagonal()))[1])[referenced]
            pinned = np.where(free[referenced], 0.0, size)
            A = keep @ sub + sp.diags_array(pinned)
            full = np.where(free, b, np.ldexp(f, np.frexp(np.abs(L.diagonal()))[1]))[referenced]
            f[referenced] = _linear.solve(sp.csr_array(A), full, "Dirichlet system", solver="lu",
                                          info=info, symmetric=False)
    f = _checks.unscaled(f, e, "Dirichlet system")
    return (f, info) if return_info else f
