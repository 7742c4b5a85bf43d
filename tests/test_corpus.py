"""Every real mesh of the corpus: finite operators satisfying the invariants.

The tolerances are relative to the size of each row (``sum_j |L_ij|``): the corpus has
slivers with weights 1e6 times the typical ones, whose rounding errors are relative to
them, not to the mesh's typical weight.
"""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap.diagnostics import (interior_faces, interior_vertices, mesh_edges,
                                referenced_vertices, signed_volumes)
from tetlap.meshes import orient


def folded_vertices(V, T):
    """Vertices of tets that lie on the same side of a shared face as their neighbour."""
    tets, opposite = interior_faces(T)
    mask = np.zeros(len(V), dtype=bool)
    if len(tets) == 0:
        return mask
    # the shared face's vertices, from the first tet's corners other than its opposite one
    # (in corner order: the mask keeps three entries per row)
    first = T[tets[:, 0]]
    shared = first[first != opposite[:, :1]].reshape(-1, 3)
    e1, e2 = V[shared[:, 1]] - V[shared[:, 0]], V[shared[:, 2]] - V[shared[:, 0]]
    n = np.cross(e1, e2)
    side = lambda p: np.sign(np.einsum("ij,ij->i", n, V[p] - V[shared[:, 0]]))
    bad = side(opposite[:, 0]) == side(opposite[:, 1])
    mask[T[tets[bad].ravel()].ravel()] = True
    return mask


def test_fold_detection():
    V, T = tetlap.meshes.cube(2)
    assert not folded_vertices(V, T).any()
    V2 = V.copy()
    V2[13] = [0.9, 0.5, 0.5] + np.array([0.6, 0, 0])  # the centre pushed through a face
    assert folded_vertices(V2, T).any()


@pytest.mark.parametrize("kind", ["primal", "dual"])
def test_operators_of_every_real_mesh(real_mesh, kind):
    name, V, T = real_mesh
    V0, T0 = V.copy(), T.copy()
    L, M = tetlap.operators(V, T, kind, "circumcentric")
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(T, T0)
    assert np.isfinite(L.data).all() and np.isfinite(M.data).all()
    absrow = np.asarray(abs(L).sum(axis=1)).ravel()
    assert abs(L - L.T).max() <= 1e-14 * abs(L).max()
    assert (np.abs(np.asarray(L.sum(axis=1)).ravel()) <= 1e-13 * absrow + 1e-300).all()
    # linear precision (Eq. 26) at interior vertices, relative to the row and the extent;
    # not where the mesh folds over itself (inverted tets among positive ones: the star
    # of such a vertex is not embedded, and no orientation-free operator can be exact)
    inner = interior_vertices(T, len(V)) & ~folded_vertices(V, T)
    if inner.any():
        extent = np.abs(V).max() + np.ptp(V, axis=0).max()
        residual = np.abs(L @ V).max(axis=1)[inner]
        assert (residual <= 1e-11 * absrow[inner] * extent).all(), name
    # pattern: exactly the edges plus the diagonal
    edges = mesh_edges(T)
    assert L.nnz == len(V) + 2 * len(edges)
    # masses: total volume, zero at unreferenced vertices
    volume = np.abs(signed_volumes(V, T)).sum()
    assert M.sum() == pytest.approx(volume, rel=1e-10)
    unref = ~referenced_vertices(T, len(V))
    assert (M.diagonal()[unref] == 0).all()
    assert tetlap.mass(V, T).sum() == pytest.approx(volume, rel=1e-12)


def test_orientation_of_real_meshes_does_not_matter(real_mesh):
    name, V, T = real_mesh
    T2 = orient(V, T)
    for kind in ("primal", "dual"):
        A, B = tetlap.laplacian(V, T, kind), tetlap.laplacian(V, T2, kind)
        assert abs(A - B).max() <= 1e-13 * abs(A).max(), name


def test_scale_and_translation_invariance_on_real_meshes(real_mesh):
    name, V, T = real_mesh
    A = tetlap.laplacian(V, T, "dual")
    s = 2.0**-20 * 3  # not a power of two: rounding happens
    B = tetlap.laplacian(V * s, T, "dual")
    assert abs(B / s - A).max() <= 1e-9 * abs(A).max(), name
    m, ms = tetlap.mass(V, T, "circumcentric").diagonal(), tetlap.mass(V * s, T, "circumcentric").diagonal()
    np.testing.assert_allclose(ms / s**3, m, rtol=1e-8, atol=1e-12 * np.abs(m).max())
    shift = np.abs(V).max()
    C = tetlap.laplacian(V + shift, T, "dual")
    assert abs(C - A).max() <= 1e-6 * abs(A).max(), name


def test_barycentric_boundary_guarantees_on_real_meshes(real_mesh):
    """Sec. 6 on real files: every tet with a boundary face contributes non-negative dual
    weights and non-negative dual-cell volumes, however bad the mesh."""
    name, V, T = real_mesh
    F = np.sort(tetlap.diagnostics.faces(T), axis=1)
    key = (F[:, 0] * len(V) + F[:, 1]) * len(V) + F[:, 2]  # one integer per sorted face
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    fixed = (counts[inverse.ravel()] == 1).reshape(-1, 4).any(axis=1)
    W = tetlap.element_contributions(V, T[fixed], "dual", boundary_centres="barycentric")
    assert W.min() >= -1e-12 * np.abs(W).max(), name
    M = tetlap.mass(V, T[fixed], "circumcentric", boundary_centres="barycentric").diagonal()
    assert M.min() >= 0, name
    plain = tetlap.element_contributions(V, T[fixed], "dual")
    assert plain.min() < 0 or name in {"svfsi_block_kuhn_197k.vtu", "sofa_6_tetra_bad.msh"}, name
