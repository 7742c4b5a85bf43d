"""tetlap.dec: exterior derivatives and Hodge stars of every degree, their orientations
(PyDEC's conventions, tets by their volume's sign) and the identities of the duals."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

import tetlap
from tetlap import dec
from test_dual import with_weights


def meshes():
    yield "ball", tetlap.meshes.ball(400, seed=6)
    yield "jittered cube", tetlap.meshes.cube(3, jitter=0.2, seed=2)
    yield "non-Delaunay", tetlap.meshes.weighted_ball(300, 0.5, seed=3)


def flip_some(T, seed=0):
    """``T`` with a random half of its tets in the other orientation."""
    T = T.copy()
    flip = np.random.default_rng(seed).random(len(T)) < 0.5
    T[flip] = T[flip][:, [1, 0, 2, 3]]
    return T


def test_corner_tet_by_hand():
    """PyDEC's conventions, written out: edges i -> j, faces (a, b, c) by their order,
    d0 = boundary_1^T, d1 = boundary_2^T, the tet as (0, 1, 2, 3) (positive)."""
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    d = dec.exterior_derivatives(V, [[0, 1, 2, 3]])
    assert d.edges.tolist() == [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]
    assert d.faces.tolist() == [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
    assert d.d0.toarray().tolist() == [[-1, 1, 0, 0], [-1, 0, 1, 0], [-1, 0, 0, 1],
                                       [0, -1, 1, 0], [0, -1, 0, 1], [0, 0, -1, 1]]
    # boundary of (a, b, c) = (b, c) - (a, c) + (a, b)
    assert d.d1.toarray().tolist() == [[1, -1, 0, 1, 0, 0], [1, 0, -1, 0, 1, 0],
                                       [0, 1, -1, 0, 0, 1], [0, 0, 0, 1, -1, 1]]
    # boundary of (0, 1, 2, 3) = (1, 2, 3) - (0, 2, 3) + (0, 1, 3) - (0, 1, 2)
    assert d.d2.toarray().tolist() == [[-1, 1, -1, 1]]
    for A in (d.d0, d.d1, d.d2):
        assert isinstance(A, sp.csr_array) and A.dtype == np.float64 and A.has_sorted_indices
    s = dec.hodge_stars(V, [[0, 1, 2, 3]])
    assert s.star3.diagonal().tolist() == [6.0]
    np.testing.assert_allclose(s.star0.diagonal(), [1 / 8, 1 / 72, 1 / 72, 1 / 72], rtol=1e-15)
    # the dual face of edge (0, 1): 1/4 of |01| = 1; of (1, 2): -1/24 (the centre is outside)
    np.testing.assert_allclose(s.star1.diagonal(), [0.25] * 3 + [-1 / 24] * 3, rtol=1e-14)
    np.testing.assert_allclose(s.star2.diagonal(), [1.0] * 3 + [-1 / 3], rtol=1e-14)


@pytest.mark.parametrize("name,mesh", list(meshes()))
def test_d_of_d_is_zero_and_d2_points_outward(name, mesh):
    V, T = mesh
    T = flip_some(T)
    d = dec.exterior_derivatives(V, T)
    n, E, F, m = len(V), len(d.edges), len(d.faces), len(T)
    assert d.d0.shape == (E, n) and d.d1.shape == (F, E) and d.d2.shape == (m, F)
    assert abs(d.d1 @ d.d0).max() == 0 and abs(d.d2 @ d.d1).max() == 0
    np.testing.assert_array_equal(d.edges, tetlap.edge_weights(V, T)[0])
    # d2[t, f] = +1 exactly when the face's (a, b, c) normal points away from the tet
    t, f = d.d2.nonzero()
    a, b, c = (V[d.faces[f, k]] for k in range(3))
    outward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - V[T[t]].mean(axis=1)) > 0
    np.testing.assert_array_equal(d.d2[t, f] > 0, outward)
    # interior faces: one +1 and one -1; boundary faces: one entry
    column = np.asarray(abs(d.d2).sum(axis=0)).ravel()
    assert set(column.tolist()) <= {1.0, 2.0}
    np.testing.assert_array_equal(np.asarray(d.d2.sum(axis=0)).ravel()[column == 2], 0)
    # the derivative of a linear function is its change along each edge
    g = np.array([0.3, -1.2, 0.7])
    np.testing.assert_allclose(d.d0 @ (V @ g), (V[d.edges[:, 1]] - V[d.edges[:, 0]]) @ g,
                               atol=1e-14)
    # the tets' orientation does not matter
    d_plain = dec.exterior_derivatives(V, mesh[1])
    for A, B in zip(d[:3], d_plain[:3]):
        assert abs(A - B).max() == 0


@pytest.mark.parametrize("V,T,w", with_weights(meshes()))
def test_the_dual_laplacian_is_d0_star1_d0(V, T, w):
    d, s = dec.exterior_derivatives(V, T), dec.hodge_stars(V, T, weights=w)
    L = tetlap.laplacian(V, T, "dual", weights=w)
    assert abs(L + d.d0.T @ s.star1 @ d.d0).max() <= 1e-13 * abs(L).max()
    g = tetlap.dual_geometry(V, T, weights=w)
    np.testing.assert_array_equal(s.star0.diagonal(),
                                  tetlap.mass(V, T, "circumcentric", weights=w).diagonal())
    np.testing.assert_array_equal(s.star2.diagonal(), g.dual_length / g.face_area)
    np.testing.assert_array_equal(s.star3.diagonal(), 1 / g.volume)
    np.testing.assert_allclose(1 / s.star3.diagonal(), np.abs(tetlap.diagnostics.signed_volumes(V, T)),
                               rtol=1e-14)


def test_non_manifold_faces_have_derivatives_but_no_star2():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1]]
    T = [[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]]
    d = dec.exterior_derivatives(V, T)
    assert abs(d.d2 @ d.d1).max() == 0
    assert abs(d.d2[:, [0]]).sum() == 3  # the face (0, 1, 2) in three tets
    with pytest.raises(tetlap.DegenerateElementError, match="non-manifold"):
        dec.hodge_stars(V, T)


def test_unused_vertices_have_zero_columns_and_no_volume():
    V, T = tetlap.meshes.ball(100, seed=5)
    V = np.vstack([V, [[9.0, 9, 9]]])
    d, s = dec.exterior_derivatives(V, T), dec.hodge_stars(V, T)
    assert d.d0.shape[1] == len(V) and abs(d.d0[:, [len(V) - 1]]).sum() == 0
    assert s.star0.diagonal()[-1] == 0


def test_a_flat_tet_has_no_orientation():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    with pytest.raises(tetlap.DegenerateElementError) as e:
        dec.exterior_derivatives(V, [[0, 1, 2, 3]])
    assert e.value.element == 0


def test_immersed_tets_keep_their_vertex_order():
    """On a closed 3-manifold in R^4 oriented by its vertex order (the hull of S^3, every
    facet ordered by the side of the origin), the tets sum to a cycle: every face is +1 in
    one tet and -1 in the other; the same tets in mixed order do not."""
    V, T = tetlap.meshes.sphere3(60, seed=1)
    side = np.linalg.det(V[T] - 0.0)  # det of the corners: the origin's side of each facet
    T = np.where((side > 0)[:, None], T, T[:, [1, 0, 2, 3]])
    d = dec.exterior_derivatives(V, T)
    assert abs(d.d2 @ d.d1).max() == 0
    assert abs(np.ones(len(T)) @ d.d2).max() == 0
    mixed = dec.exterior_derivatives(V, flip_some(T))
    assert abs(np.ones(len(T)) @ mixed.d2).max() == 2


points = st.lists(st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3), min_size=8,
                  max_size=30, unique=True)


@settings(max_examples=25, deadline=None)
@given(points)
def test_identities_on_random_delaunay_meshes(pts):
    from scipy.spatial import Delaunay, QhullError

    V = np.array(pts)
    try:
        T = Delaunay(V).simplices.astype(np.int64)
    except (QhullError, ValueError):
        return
    vol = np.abs(tetlap.diagnostics.signed_volumes(V, T))
    T = T[vol > 1e-9]
    if len(T) == 0:
        return
    d = dec.exterior_derivatives(V, T)
    assert abs(d.d1 @ d.d0).max() == 0 and abs(d.d2 @ d.d1).max() == 0
    L = tetlap.laplacian(V, T, "dual")
    s = dec.hodge_stars(V, T)
    assert abs(L + d.d0.T @ s.star1 @ d.d0).max() <= 1e-13 * abs(L).max()
    # the cell Laplacian: symmetric, zero row sums, linear at the centres off the boundary
    g = tetlap.dual_geometry(V, T)
    Lc = tetlap.cell_laplacian(V, T, degenerate="skip")
    assert abs(Lc - Lc.T).max() == 0
    rows = np.asarray(abs(Lc).sum(axis=1)).ravel()
    assert (np.abs(np.asarray(Lc.sum(axis=1)).ravel()) <= 1e-13 * rows).all()
    inner = np.setdiff1d(np.arange(len(T)), g.face_tets[g.boundary_faces, 0])
    skipped = np.abs(g.dual_length) <= 1e-9 * np.abs(g.centres).max()
    inner = np.setdiff1d(inner, g.face_tets[skipped].ravel())
    residual = np.abs(Lc @ g.centres).max(axis=1)[inner]
    assert (residual <= 1e-9 * rows[inner] * (1 + np.abs(g.centres).max())).all()
