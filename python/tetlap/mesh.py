"""``tetlap.Mesh``: a mesh that keeps its topology, for fast re-assembly and local updates."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, _sparse
from ._options import centres_used, renamed, weights_used
from . import coefficient as _coefficient
from .assembly import _options
from .errors import ShapeError
from ._names import public_dir

__all__ = ["Mesh", "UpdateInfo"]
__dir__ = public_dir(globals())


class UpdateInfo(NamedTuple):
    """What :meth:`Mesh.update` recomputed: the vertices that moved, the elements
    recomputed (around them, and those whose coefficient or density changed) and the rows
    re-summed."""

    moved_vertices: int
    recomputed_tets: int
    recomputed_rows: int


class Mesh:
    """A tetrahedral (or triangle) mesh whose edge topology is computed once.

    ``Mesh(V, T)`` validates the mesh and builds its CSR pattern and slot map; every
    operator asked for afterwards is assembled without the symbolic step, and cached.
    :meth:`update` moves vertices and refreshes the cached operators by recomputing only
    the elements around moved vertices and re-summing only their rows (strong locality,
    paper Sec. 7.1). Rows always sum their elements in a fixed order, so the result is
    **bitwise equal** to a fresh :func:`tetlap.laplacian` / :func:`tetlap.mass` of the new
    geometry.

    Parameters
    ----------
    V : (n, d) array-like of real numbers
        Vertex positions (see :func:`tetlap.laplacian`).
    T : (m, 4) or (m, 3) array-like of integers, optional
        Tets or triangles, any orientation; leave it out to pass a mesh object as ``V``.
    boundary_centres, weights, degenerate, threads
        As for :func:`tetlap.laplacian`; they apply to every operator of this mesh
        (``boundary_centres`` was ``boundary`` until 0.1; that name still works,
        deprecated). With ``weights``, a request that does not depend on them (the primal
        Laplacian, a mass other than the circumcentric, alone) is refused with
        :class:`tetlap.OptionError`, as :func:`tetlap.laplacian` refuses ``weights=`` with
        the primal.
    coefficient, density
        As for :func:`tetlap.operators`: the coefficient of every Laplacian and the density
        of every mass of this mesh; :meth:`update` changes them.

    Notes
    -----
    The returned matrices own their values; their index arrays are shared by all matrices
    of this Mesh and read-only (copy a matrix before changing its structure in place,
    e.g. ``L.copy().eliminate_zeros()``). A Mesh may be used from several threads: reads
    of cached operators run concurrently; a first request or an :meth:`update` runs alone,
    and every reader sees the mesh before or after it, never in between.

    Examples
    --------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(4, jitter=0.2)
    >>> mesh = tetlap.Mesh(V, T)
    >>> L = mesh.laplacian("dual")
    >>> V2 = V.copy(); V2[62] += 0.01  # an interior vertex: 24 tets around it
    >>> mesh.update(V2).recomputed_tets
    24
    >>> (mesh.laplacian("dual") != tetlap.laplacian(V2, T, "dual")).nnz
    0
    >>> c = np.ones(len(T)); c[:10] = 5.0  # ten tets conduct five times better
    >>> mesh.update(coefficient=c).recomputed_tets
    10
    >>> (mesh.laplacian("dual") != tetlap.laplacian(V2, T, "dual", coefficient=c)).nnz
    0
    """

    @renamed(boundary="boundary_centres")
    @_arrays.takes_mesh_object
    def __init__(self, V, T=None, *, boundary_centres="circumcentric", weights=None,
                 coefficient=None, density=None, degenerate="raise", threads=None) -> None:
        V, T = _arrays.mesh(V, T)
        V, T = _arrays.points(V), _arrays.elements(T)
        w = _arrays.vertex_weights(weights, V.shape[0])
        self._shapes = (V.shape, T.shape)
        K = _coefficient._argument(coefficient, self._shapes)
        rho = _coefficient._argument(density, self._shapes, density=True)
        self._core = _core.Mesh(V, T, weights=w, medium=(K, rho),
                                options=_options(boundary_centres, degenerate, threads))
        self._weighted = w is not None
        self._centres = boundary_centres
        self._n, self._dim = V.shape
        indices, indptr = self._core.pattern()
        pattern = _sparse.csr((np.empty(len(indices)), indices, indptr), self._n)
        self._indices, self._indptr = pattern.indices, pattern.indptr
        self._indices.flags.writeable = False
        self._indptr.flags.writeable = False

    @property
    def n_vertices(self) -> int:
        """The number of vertices n."""
        return self._n

    @property
    def V(self) -> np.ndarray:
        """The current coordinates, (n, d) float64 (a copy)."""
        return self._core.points()

    @property
    def T(self) -> np.ndarray:
        """The elements, (m, 4) or (m, 3) int64 (a copy)."""
        return self._core.cells()

    def _matrix(self, data) -> sp.csr_array:
        return _sparse.csr((data, self._indices, self._indptr), self._n)

    def laplacian(self, kind="primal") -> sp.csr_array:
        """The (n, n) Laplacian of ``kind`` (cached; see :func:`tetlap.laplacian`). A Mesh
        with vertex weights refuses the primal (:class:`tetlap.OptionError`): the weights
        belong to the dual, and the primal would ignore them."""
        weights_used(self._weighted, (kind,), "weights (of this Mesh)")
        centres_used(self._centres, (kind,), " (of this Mesh)")
        return self._laplacian(kind)

    def _laplacian(self, kind) -> sp.csr_array:
        return self._matrix(self._core.laplacian(kind))

    def mass(self, kind="barycentric") -> sp.csr_array:
        """The (n, n) mass matrix of ``kind`` (cached; see :func:`tetlap.mass`). A Mesh
        with vertex weights refuses the kinds that do not use them (all but
        ``"circumcentric"``), as :meth:`laplacian` refuses the primal."""
        weights_used(self._weighted, (kind,), "weights (of this Mesh)")
        centres_used(self._centres, (kind,), " (of this Mesh)")
        return self._mass(kind)

    def _mass(self, kind) -> sp.csr_array:
        values = self._core.mass(kind)
        if kind == "fem":
            return self._matrix(values)
        return sp.diags_array(values, format="csr")

    def operators(self, laplacian="primal", mass="barycentric"):
        """``(L, M)``, both cached. With vertex weights, one of them must use them (the
        dual Laplacian or the circumcentric mass), as for :func:`tetlap.operators`."""
        weights_used(self._weighted, (laplacian, mass), "weights (of this Mesh)")
        centres_used(self._centres, (laplacian, mass), " (of this Mesh)")
        return self._laplacian(laplacian), self._mass(mass)

    def update(self, V=None, *, coefficient=None, density=None) -> UpdateInfo:
        """Move the vertices to ``V`` ((n, d), same shape) and/or set a new ``coefficient``
        (any form :func:`tetlap.laplacian` takes) and ``density``, at once, and refresh the
        cached operators. ``None`` keeps what the Mesh has (a coefficient of ones gives
        the plain Laplacians, bitwise).

        Only the elements around vertices whose coordinates changed, and those whose
        coefficient or density changed, are recomputed, and only the rows of their corners
        re-summed: no topology, no pattern. The result is bitwise equal to a one-shot
        assembly of the new mesh. On error (an element became degenerate, non-finite
        coordinates, a bad coefficient, wrong shape, Ctrl-C) the Mesh is unchanged.
        """
        if V is not None:
            V = _arrays.points(V)
            if V.shape[0] != self._n:
                raise ShapeError(f"V must have {self._n} rows, got {V.shape[0]}")
        K = _coefficient._argument(coefficient, self._shapes)
        rho = _coefficient._argument(density, self._shapes, density=True)
        return UpdateInfo(*self._core.update(V, medium=(K, rho)))
