"""Discrete exterior calculus of a tet mesh: exterior derivatives and diagonal Hodge stars
of every degree, on the circumcentric (or, with vertex weights, power) dual.

Conventions (PyDEC's, except where noted):

* **Simplices.** Vertices ``0..n-1``; edges ``(i, j)``, ``i < j``, sorted
  lexicographically (the order of :func:`tetlap.edge_weights`), oriented ``i -> j``;
  faces ``(a, b, c)``, ``a < b < c``, sorted lexicographically, oriented by that order
  (normal ``(x_b - x_a) x (x_c - x_a)``); tets in the order of ``T``, **oriented by the
  sign of their volume** (PyDEC orients a top simplex by the order its vertices are
  given, so that its ``d2`` and its signed ``*3`` change with a tet's vertex order;
  tetlap's results never depend on it). Unused vertices keep their index (zero columns).
* **Exterior derivatives** (coboundaries, PyDEC's ``sc[k].d``): ``d0`` (E, n), ``d1``
  (F, E), ``d2`` (m, F) signed incidence matrices, float64 ``scipy.sparse.csr_array``
  (not int8: products such as ``d0.T @ d0`` would overflow). ``d0[e, j] = +1``,
  ``d0[e, i] = -1``; ``d1[f, (b,c)] = d1[f, (a,b)] = +1``, ``d1[f, (a,c)] = -1``;
  ``d2[t, f] = +1`` when the face's orientation gives the outward normal of tet ``t``,
  ``-1`` when it gives the inward one. ``d1 @ d0 = 0`` and ``d2 @ d1 = 0`` exactly.
* **Hodge stars** (PyDEC's ``sc[k].star``): diagonal, ``*k = |dual cell| / |primal
  simplex|`` with signed circumcentric dual measures: ``*0`` the control volumes (the
  circumcentric mass), ``*1`` dual face area / edge length (the dual Laplacian's
  weights), ``*2`` dual edge length / face area, ``*3 = 1 / volume`` (PyDEC: 1 / signed
  volume). Boundary dual cells are closed by the boundary faces' centres, as in PyDEC.
  With vertex weights every centre is a power centre (PyDEC has no weights). In 3D
  PyDEC's sign ``(-1)^(k (3 - k))`` of the inverse stars is always +1: ``*k^-1`` is the
  plain reciprocal.

Then the dual Laplacian is ``L = -d0.T @ *1 @ d0`` (paper sign convention: off-diagonals
are the weights) and the cell-centred Laplacian of :func:`tetlap.cell_laplacian` is
``-d2_I @ inv(*2_I) @ d2_I.T`` over the interior faces ``I`` (on a mesh whose tets do not
overlap: no folded face).

>>> import tetlap
>>> V, T = tetlap.meshes.ball(300, seed=2)
>>> d = tetlap.dec.exterior_derivatives(V, T)
>>> float(abs(d.d1 @ d.d0).max()), float(abs(d.d2 @ d.d1).max())
(0.0, 0.0)
>>> s = tetlap.dec.hodge_stars(V, T)
>>> L = tetlap.laplacian(V, T, "dual")
>>> bool(abs(L + d.d0.T @ s.star1 @ d.d0).max() < 1e-13 * abs(L).max())
True
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from . import _arrays, _core, diagnostics
from ._docs import shared_docs
from .dual import _Faces, _outward, dual_geometry
from .errors import DegenerateElementError
from ._names import public_dir

__all__ = ["exterior_derivatives", "Derivatives", "hodge_stars", "Stars"]
__dir__ = public_dir(globals())


class Derivatives(NamedTuple):
    """The exterior derivatives of a tet mesh and the simplices they act on (see the module
    docstring for the orientations)."""

    d0: sp.csr_array
    """(E, n) float64: vertices to edges."""
    d1: sp.csr_array
    """(F, E) float64: edges to faces."""
    d2: sp.csr_array
    """(m, F) float64: faces to tets."""
    edges: np.ndarray
    """(E, 2) int64, ``i < j``, sorted."""
    faces: np.ndarray
    """(F, 3) int64, ``a < b < c``, sorted."""


class Stars(NamedTuple):
    """The diagonal Hodge stars, each a float64 ``scipy.sparse.csr_array`` on the simplices
    of :class:`Derivatives` (same order)."""

    star0: sp.csr_array
    """(n, n): control volumes (signed; 0 at unused vertices)."""
    star1: sp.csr_array
    """(E, E): dual face area / edge length."""
    star2: sp.csr_array
    """(F, F): dual edge length / face area (signed; boundary faces: centre to face)."""
    star3: sp.csr_array
    """(m, m): 1 / tet volume."""


def _incidence(rows: np.ndarray, cols: np.ndarray, signs: np.ndarray, shape) -> sp.csr_array:
    A = sp.csr_array((signs.astype(np.float64).ravel(), (rows.ravel(), cols.ravel())),
                     shape=shape)
    A.sort_indices()
    return A


@_arrays.takes_mesh_object
def exterior_derivatives(V, T=None) -> Derivatives:
    """The exterior derivatives ``d0``, ``d1``, ``d2`` of a tet mesh as signed incidence
    matrices.

    Parameters
    ----------
    V : (n, d) array-like of real numbers
        Vertex positions: only the tets' orientations (the signs of their volumes) are
        read. For ``d > 3`` no orientation of R^d is at hand and every tet keeps the order
        of its vertices (as in PyDEC).
    T : (m, 4) array-like of integers, optional
        Tets, any orientation; leave it out to pass a mesh object as ``V``.

    Returns
    -------
    Derivatives
        ``d0`` (E, n), ``d1`` (F, E), ``d2`` (m, F) float64 ``csr_array`` with sorted
        indices, and the ``edges`` (E, 2) and ``faces`` (F, 3) they index, oriented and
        ordered as the module docstring says. Non-manifold faces are allowed here (a
        column of ``d2`` with more than two entries).

    Raises
    ------
    tetlap.DegenerateElementError
        A zero-volume tet (it has no orientation).

    Examples
    --------
    >>> import tetlap
    >>> d = tetlap.dec.exterior_derivatives([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
    ...                                     [[0, 2, 1, 3]])
    >>> d.d2.toarray()  # faces (0,1,2), (0,1,3), (0,2,3), (1,2,3): outward for the last
    array([[-1.,  1., -1.,  1.]])
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    n, m = V.shape[0], T.shape[0]
    orientation = np.sign(diagnostics.signed_volumes(V, T)).astype(np.int64)
    flat = np.flatnonzero(orientation == 0)
    if len(flat):
        raise DegenerateElementError(f"tet {flat[0]} has zero volume: it has no orientation",
                                     element=int(flat[0]))
    edges = _core.edges(T, n)
    topology = _Faces(T, n)
    faces = topology.faces
    E, F = len(edges), len(faces)
    d0 = _incidence(np.repeat(np.arange(E), 2), edges, np.tile([-1, 1], E), (E, n))
    key = edges[:, 0] * n + edges[:, 1]
    edge_of = lambda a, b: np.searchsorted(key, faces[:, a] * n + faces[:, b])
    d1 = _incidence(np.repeat(np.arange(F), 3),
                    np.column_stack([edge_of(1, 2), edge_of(0, 2), edge_of(0, 1)]),
                    np.tile([1, -1, 1], F), (F, E))
    d2 = _incidence(np.repeat(np.arange(m), 4), topology.tet_faces, _outward(T, orientation),
                    (m, F))
    return Derivatives(d0, d1, d2, edges, faces)


@_arrays.takes_mesh_object
@shared_docs
def hodge_stars(V, T=None, *, weights=None, threads=None) -> Stars:
    """The diagonal Hodge stars ``*0`` to ``*3`` of the circumcentric (power) dual.

    Parameters
    ----------
    {dual_mesh}

    Returns
    -------
    Stars
        ``star0`` (n, n) control volumes, ``star1`` (E, E) dual face area / edge length,
        ``star2`` (F, F) dual edge length / face area, ``star3`` (m, m) 1 / volume:
        diagonal float64 ``csr_array``, on the simplices and in the order of
        :func:`exterior_derivatives`, signed as :class:`tetlap.DualGeometry` signs the
        dual measures. ``star0`` and ``star1`` are the diagonal of
        ``tetlap.mass(V, T, "circumcentric")`` and the weights of ``tetlap.laplacian(V, T,
        "dual")`` bit for bit.

    Raises
    ------
    tetlap.DegenerateElementError
        A zero-volume tet, or a face shared by more than two tets.

    Examples
    --------
    >>> import tetlap
    >>> s = tetlap.dec.hodge_stars([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]])
    >>> s.star0.diagonal() * 72, s.star3.diagonal()
    (array([9., 1., 1., 1.]), array([6.]))
    """
    g = dual_geometry(V, T, weights=weights, threads=threads)
    diagonal = lambda values: sp.diags_array(values, format="csr")
    return Stars(diagonal(g.control_volume), diagonal(g.transmissibility),
                 diagonal(g.dual_length / g.face_area), diagonal(1.0 / g.volume))
