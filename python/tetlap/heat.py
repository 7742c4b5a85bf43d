"""Geodesic distance by the heat method (Crane, Weischedel and Wardetzky, "Geodesics in
Heat", ACM TOG 2013) on tetrahedral and triangle meshes.

Three steps, for the sources ``s``:

1. the heat step ``(M - t L) u = delta_s`` (``M`` a lumped mass, ``L`` tetlap's Laplacian,
   negative semidefinite, so ``M - t L`` is positive definite for the primal), one implicit
   Euler step of the heat flow for the time ``t`` (default ``h^2``, ``h`` the mean edge
   length);
2. the normalised field ``X = -grad u / |grad u|`` per element (:func:`tetlap.gradient`);
3. the Poisson step ``L phi = div X`` (:func:`tetlap.divergence`), ``phi`` shifted so that
   the sources are 0.

:class:`HeatDistance` builds and factorizes the matrices once; each further call of
:meth:`HeatDistance.distance` costs two solves with those factors (three with
``boundary="average"``), one product with ``G`` and one with ``D``.

>>> import numpy as np, tetlap
>>> V, T = tetlap.meshes.ball(2000, seed=0)
>>> centre = int(np.argmin((V ** 2).sum(1)))
>>> d = tetlap.heat_distance(V, T, centre)
>>> exact = np.linalg.norm(V - V[centre], axis=1)
>>> bool(np.abs(d - exact).mean() < 0.05 * exact.max())
True
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from . import _arrays, _core, _options, assembly, calculus
from ._float_range import unit_scale
from .solve import factorize
from .errors import DegenerateElementError, IndexRangeError, OptionError, ShapeError
from ._names import public_dir

__all__ = ["HeatDistance", "heat_distance", "BOUNDARY_CONDITIONS"]
__dir__ = public_dir(globals())

#: The boundary conditions of the heat step (Crane et al. 2013, Sec. 3.3).
BOUNDARY_CONDITIONS = ("neumann", "dirichlet", "average")


def _sources(sources, n: int, used: np.ndarray) -> np.ndarray:
    """``sources`` (a vertex index or a 1-D array-like of them) as sorted unique int64
    indices of vertices of the mesh."""
    if isinstance(sources, bool) or (np.isscalar(sources)
                                     and not isinstance(sources, numbers.Integral)):
        raise OptionError(f"sources must be a vertex index or integer vertex indices, got "
                          f"{sources!r}")
    if isinstance(sources, numbers.Integral):
        if not 0 <= sources < n:        # before int64: 2**70 is not a vertex either
            raise _arrays.not_a_vertex("sources holds", int(sources), n)
        s = np.array([int(sources)], dtype=np.int64)
    else:
        arr = _arrays._as_array(sources, "sources")
        if arr.size == 0:
            raise ShapeError("sources is empty: give at least one source vertex")
        if arr.dtype.kind not in "iu":
            raise OptionError(f"sources must be a vertex index or integer vertex indices, "
                              f"got dtype {arr.dtype}")
        if arr.ndim != 1:
            raise ShapeError(f"sources must be one index or a 1-D array, got shape {arr.shape}")
        if arr.dtype == np.uint64 and arr.max() >= n:
            raise _arrays.not_a_vertex("sources holds", int(arr.max()), n)
        s = np.unique(arr.astype(np.int64))
    bad = s[(s < 0) | (s >= n)]
    if bad.size:
        raise _arrays.not_a_vertex("sources holds", int(bad[0]), n)
    unused = s[~used[s]]
    if unused.size:
        raise IndexRangeError(f"source {int(unused[0])} is in no element of the mesh",
                              index=int(unused[0]))
    return s


def _boundary_vertices(T: np.ndarray, n: int) -> np.ndarray:
    """Mask (n,) of the vertices on a facet (triangle of a tet, edge of a triangle) that
    belongs to one element only."""
    k = T.shape[1]
    facets = np.sort(np.concatenate([np.delete(T, a, axis=1) for a in range(k)]), axis=1)
    unique, counts = np.unique(facets, axis=0, return_counts=True)
    mask = np.zeros(n, dtype=bool)
    mask[unique[counts == 1].ravel()] = True
    return mask


class HeatDistance:
    """The heat method's distance from any set of source vertices, factorized once.

    Parameters
    ----------
    V : (n, d) array-like, T : (m, 4) or (m, 3) array-like, optional
        The mesh, as :func:`tetlap.laplacian` takes it (or one mesh object as ``V``).
    t : float > 0, optional
        The heat step's time, in squared length units; default ``h^2`` with ``h`` the mean
        edge length (the paper's choice: the error then converges with ``h``). One so large
        that ``t L`` overflows is an OptionError.
    laplacian : {"primal", "dual"} or float in [0, 1], default "primal"
        The Laplacian of the heat and Poisson steps (any kind :func:`tetlap.laplacian`
        takes; ``weights=`` gives the weighted dual). The divergence is always the P1 one,
        so that for the primal ``div grad`` is exactly ``L``.
    boundary : {"neumann", "dirichlet", "average"}, default "neumann"
        The heat step's boundary condition. ``"neumann"`` (no flux; the paper's default
        and LaPy's): two factorizations and two solves per call. ``"dirichlet"``: ``u = 0``
        on boundary vertices that are not sources (a boundary source keeps ``u = 1 /
        A_ss``, the value its delta gives at its own vertex to first order).
        ``"average"``: the mean of both, which the paper recommends against the bending of
        isolines that each condition causes alone; one more factorization and one more
        solve per call. The default is ``"neumann"`` for its cost: on balls it meets the
        accuracy targets with two factorizations, and ``"average"`` is slightly more
        accurate (mean error 0.80% against 0.97% of the largest distance from a boundary
        vertex of ``ball(30000)``, the same from the centre: :doc:`/project/experiments`). Pure
        ``"dirichlet"`` is poor from boundary sources (about 20%).
    mass : {"barycentric", "circumcentric", "mixed"}, default "barycentric"
        The lumped mass of the heat step.
    weights, dual_boundary, degenerate, threads
        As ``weights``, ``boundary``, ``degenerate`` and ``threads`` of
        :func:`tetlap.laplacian` (``dual_boundary`` is that function's ``boundary``).
        Skipped degenerate elements have no gradient and no volume.

    Attributes
    ----------
    t : float
        The heat step's time.
    h : float
        The mean edge length (of the elements that are not skipped).
    n_factorizations : int
        The factorizations of the set-up (2, or 3 with ``boundary="average"``).

    Notes
    -----
    Distances are ``inf`` on the components of the mesh without a source and on vertices
    in no element (neither is ever NaN); vertices only in skipped degenerate elements count
    as in no element. An element where ``grad u`` is exactly zero (``u``
    constant on it, or skipped as degenerate) gets ``X = 0``. A mesh whose bounding box
    is beyond ``2^-64 .. 2^64`` is computed in a copy scaled by a power of two (exact), so
    that the distance is the same at any scale (it was 0 everywhere from about 1e40).

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(6)
    >>> heat = tetlap.HeatDistance(V, T)
    >>> d0, d1 = heat.distance(0), heat.distance([0, len(V) - 1])   # one factorization
    >>> round(float(d0[-1]), 2)        # the far corner, at sqrt(3) = 1.73
    1.77
    >>> bool(abs(d1[0]) < 1e-12), bool(abs(d1[-1]) < 1e-12)   # two sources, both at 0
    (True, True)
    """

    @_arrays.takes_mesh_object
    def __init__(self, V, T=None, *, t=None, laplacian="primal", boundary="neumann",
                 mass="barycentric", weights=None, dual_boundary="circumcentric",
                 degenerate="raise", threads=None) -> None:
        if boundary not in BOUNDARY_CONDITIONS:
            raise OptionError(f"boundary must be one of {', '.join(BOUNDARY_CONDITIONS)}, "
                              f"got {boundary!r}")
        if mass not in ("barycentric", "circumcentric", "mixed"):
            raise OptionError(f'mass must be a lumped kind ("barycentric", "circumcentric", '
                              f'"mixed"), got {mass!r}')
        if t is not None:
            _options.positive(t, "t")
        V, T = _arrays.mesh(V, T)
        V, T = _arrays.points(V), _arrays.elements(T)
        n = len(V)
        used, T_used = _arrays.used_vertices(V, T)
        # a mesh far from unit size is computed in a copy scaled by a power of two (exact;
        # the heat step's powers of lengths left float64 from about 1e40): distances,
        # h and t are given back in the caller's units
        self._scale = unit_scale(V[used], T_used)
        if self._scale != 1.0:
            V = V / self._scale
            if weights is not None:
                weights = _arrays.vertex_weights(weights, n) / self._scale**2
        L, M = assembly.operators(V, T, laplacian, mass, boundary=dual_boundary,
                                  weights=weights, degenerate=degenerate, threads=threads)
        g, vol = calculus.element_gradients(V, T, degenerate=degenerate, threads=threads)
        self._G = calculus._operator(g, T, n)
        # the divergence D = -G^T diag(vol (x) 1_d), applied through G's transpose (a CSC
        # view, no copy) rather than built
        self._vol = np.repeat(vol, V.shape[1])
        self._d = V.shape[1]
        # what takes part: the vertices and edges of elements that are not skipped
        live = T[vol > 0]
        if not len(live):
            raise DegenerateElementError("every element is degenerate: nothing to solve on")
        self._used = np.zeros(n, dtype=bool)
        self._used[live.ravel()] = True
        edges = _core.edges(live, n, options={"threads": threads})
        h = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
        t_work = float(t) / self._scale**2 if t is not None else h ** 2
        self.h = h * self._scale
        self.t = float(t) if t is not None else self.h ** 2
        self.boundary = boundary
        self.n = n
        _, self._labels = csgraph.connected_components(
            sp.coo_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n)),
            directed=False)
        L, M = sp.csr_array(L), sp.csr_array(M)
        if not math.isfinite(t_work * float(np.abs(L.data).max(initial=0.0))):
            raise OptionError(f"t = {self.t:g} is too large for this mesh: t L leaves the "
                              "float64 range")
        A = sp.csr_array(M - t_work * L)
        used = np.flatnonzero(self._used)
        self._factors = 0
        self._order = None    # vertices in the elimination order of the first factorization
        if boundary != "dirichlet":
            self._heat_neumann = (used, self._factor(A, used))
        if boundary != "neumann":
            on_boundary = _boundary_vertices(live, n)
            inner = np.flatnonzero(self._used & ~on_boundary)
            self._diagonal = A.diagonal()
            self._A_inner = A[inner]          # the rows of the inner vertices, for the rhs
            self._on_boundary = on_boundary
            self._heat_dirichlet = (inner, self._factor(A, inner) if len(inner) else None)
        # the Poisson step: one vertex pinned per component (L's null space is constants)
        pinned = np.zeros(n, dtype=bool)
        pinned[used[np.unique(self._labels[used], return_index=True)[1]]] = True
        free = np.flatnonzero(self._used & ~pinned)
        self._poisson = (free, self._factor(-L, free) if len(free) else None)
        self.n_factorizations = self._factors

    def _factor(self, A, rows: np.ndarray):
        """The factorization of ``A[rows][:, rows]``. The first one's nested dissection is
        kept as an order of vertices and restricted to the later ones' rows (the same
        graph less a few vertices), so that the set-up orders the mesh once."""
        self._factors += 1
        ordering = "auto"
        if self._order is not None:
            rank = np.full(self.n, -1, dtype=np.int64)
            rank[self._order] = np.arange(len(self._order))
            if (rank[rows] >= 0).all():
                ordering = np.argsort(rank[rows], kind="stable")
        F = factorize(A[rows][:, rows], ordering=ordering)
        if self._order is None and F.permutation is not None:
            self._order = rows[F.permutation]
        return F

    def _heat(self, s: np.ndarray) -> np.ndarray:
        """``u`` of the heat step from the sources ``s``."""
        delta = np.zeros(self.n)
        delta[s] = 1.0
        parts = []
        if self.boundary != "dirichlet":
            used, factor = self._heat_neumann
            u = np.zeros(self.n)
            u[used] = factor.solve(delta[used])
            parts.append(u)
        if self.boundary != "neumann":
            inner, factor = self._heat_dirichlet
            u = np.zeros(self.n)
            at_boundary = s[self._on_boundary[s]]
            u[at_boundary] = 1.0 / self._diagonal[at_boundary]
            if factor is not None:
                rhs = delta[inner] - self._A_inner @ u
                u[inner] = factor.solve(rhs)
            parts.append(u)
        return sum(parts) / len(parts)

    def distance(self, sources) -> np.ndarray:
        """The distance of every vertex from the nearest of ``sources``.

        Parameters
        ----------
        sources : int or 1-D array-like of int
            One source vertex or a set (repeats are ignored); every one a vertex of some
            element.

        Returns
        -------
        d : (n,) float64 array
            0 at the source with the smallest value (every source for one), ``inf`` on
            components without a source and on vertices in no element.

        Raises
        ------
        tetlap.IndexRangeError
            A source outside ``0..n-1`` or in no element.
        tetlap.ShapeError, tetlap.OptionError
            An empty set, or not integers.
        tetlap.SolveError
            A singular heat or Poisson matrix (an indefinite dual on a bad mesh).
        """
        s = _sources(sources, self.n, self._used)
        u = self._heat(s)
        grad = (self._G @ u).reshape(-1, self._d)
        norm = np.linalg.norm(grad, axis=1)
        X = np.divide(-grad, norm[:, None], out=np.zeros_like(grad), where=norm[:, None] > 0)
        b = -(self._G.T @ (self._vol * X.reshape(-1)))
        free, factor = self._poisson
        phi = np.zeros(self.n)
        if factor is not None:
            phi[free] = factor.solve(-b[free])   # the factor is of -L_FF
        d = np.full(self.n, np.inf)
        for label in np.unique(self._labels[s]):
            component = (self._labels == label) & self._used
            d[component] = phi[component] - phi[s[self._labels[s] == label]].min()
        return d * self._scale if self._scale != 1.0 else d


@_arrays.takes_mesh_object
def heat_distance(V, T=None, sources=None, **options) -> np.ndarray:
    """The heat method's distance from ``sources``: ``HeatDistance(V, T, **options)
    .distance(sources)`` (build a :class:`HeatDistance` to reuse its factorizations for
    several source sets).

    Parameters
    ----------
    V, T
        The mesh (or one mesh object as ``V``).
    sources : int or 1-D array-like of int
        As :meth:`HeatDistance.distance`.
    **options
        The keywords of :class:`HeatDistance` (``t``, ``laplacian``, ``boundary``, ...).

    Returns
    -------
    d : (n,) float64 array
        As :meth:`HeatDistance.distance`.

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(5)
    >>> d = tetlap.heat_distance(V, T, 0)
    >>> float(d[0]), bool(abs(d.max() - 3 ** 0.5) < 0.1)
    (0.0, True)
    """
    if sources is None:
        raise TypeError("heat_distance() needs sources: a vertex index or a set of them")
    return HeatDistance(V, T, **options).distance(sources)
