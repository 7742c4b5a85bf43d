"""``tetlap.Mesh``: a mesh that keeps its topology, for fast re-assembly and local updates."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core
from .assembly import _csr

__all__ = ["Mesh", "UpdateInfo"]


class UpdateInfo(NamedTuple):
    """What :meth:`Mesh.update` recomputed."""

    moved_vertices: int
    recomputed_tets: int
    recomputed_rows: int


class Mesh:
    """A tetrahedral mesh whose edge topology is computed once.

    ``Mesh(V, T)`` validates the mesh and builds its CSR pattern and slot map; every
    operator asked for afterwards is assembled without the symbolic step, and cached.
    :meth:`update` moves vertices and refreshes the cached operators by recomputing only
    the tets around moved vertices and re-summing only their rows (strong locality, paper
    Sec. 7.1). Rows always sum their tets in ascending order, so the result is **bitwise
    equal** to a fresh :func:`tetlap.laplacian` / :func:`tetlap.mass` of the new geometry.

    Conventions, ``kind`` values, ``boundary``, ``weights``, ``degenerate`` and ``threads``
    are those of
    :func:`tetlap.laplacian`. The returned matrices own their values; their index arrays
    are shared by all matrices of this Mesh and read-only (copy a matrix before changing
    its structure in place, e.g. ``L.copy().eliminate_zeros()``). A Mesh is not meant to be
    used from several threads at once.

    Example
    -------
    >>> import tetlap
    >>> V, T = tetlap.meshes.cube(4, jitter=0.2)
    >>> mesh = tetlap.Mesh(V, T)
    >>> L = mesh.laplacian("dual")
    >>> V2 = V.copy(); V2[62] += 0.01  # an interior vertex: 24 tets around it
    >>> mesh.update(V2).recomputed_tets
    24
    >>> (mesh.laplacian("dual") != tetlap.laplacian(V2, T, "dual")).nnz
    0
    """

    def __init__(self, V, T, *, boundary="circumcentric", weights=None, degenerate="raise",
                 threads=None) -> None:
        V, T = _arrays.points(V), _arrays.elements(T, 4)
        w = _arrays.vertex_weights(weights, V.shape[0])
        self._core = _core.Mesh(V, T, w, _arrays.options(threads, degenerate, boundary))
        self._n = V.shape[0]
        indices, indptr = self._core.pattern()
        self._indices = indices.view(np.int32) if indptr.dtype == np.int32 else indices.astype(np.int64)
        self._indptr = indptr
        self._indices.flags.writeable = False
        self._indptr.flags.writeable = False

    @property
    def n_vertices(self) -> int:
        return self._n

    @property
    def V(self) -> np.ndarray:
        """The current coordinates, (n, d) float64 (a copy)."""
        return self._core.points()

    @property
    def T(self) -> np.ndarray:
        """The tets, (m, 4) int64 (a copy)."""
        return self._core.tets()

    def _matrix(self, data) -> sp.csr_array:
        return _csr((data, self._indices, self._indptr), self._n)

    def laplacian(self, kind="primal") -> sp.csr_array:
        """The (n, n) Laplacian of ``kind`` (cached; see :func:`tetlap.laplacian`)."""
        name, t = _arrays.laplacian_kind(kind)
        return self._matrix(self._core.laplacian(name, t))

    def mass(self, kind="barycentric") -> sp.csr_array:
        """The (n, n) mass matrix of ``kind`` (cached; see :func:`tetlap.mass`)."""
        kind = _arrays.mass_kind(kind)
        values = self._core.mass(kind)
        if kind == "fem":
            return self._matrix(values)
        return sp.diags_array(values, format="csr")

    def operators(self, laplacian="primal", mass="barycentric"):
        """``(L, M)``, both cached."""
        return self.laplacian(laplacian), self.mass(mass)

    def update(self, V) -> UpdateInfo:
        """Move the vertices to ``V`` ((n, d), same shape) and refresh the cached operators.

        Only tets around vertices whose coordinates changed are recomputed. On error (a
        tet became degenerate, non-finite coordinates, wrong shape) the Mesh is unchanged.
        """
        V = _arrays.points(V)
        if V.shape[0] != self._n:
            raise _arrays.ShapeError(f"V must have {self._n} rows, got {V.shape[0]}")
        return UpdateInfo(*self._core.update(V))
