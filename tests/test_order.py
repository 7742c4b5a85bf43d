"""The order of V and T: any numbering of the vertices and any order of the elements gives
the same operators, permuted (the internal locality order decides where things are in
memory, never what is computed)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import benchmark


def shuffled(V, T, seed):
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(V))  # new vertex k is old vertex perm[k]
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(V))
    order = rng.permutation(len(T))
    return V[perm], inverse[T][order], perm, order


MESHES = {
    "kuhn": lambda: tetlap.meshes.cube(7, jitter=0.2, seed=1),
    "qhull order": lambda: benchmark.delaunay(6000, seed=2),
    "real-mesh like (ball)": lambda: tetlap.meshes.ball(1500, seed=3),
}


@pytest.mark.parametrize("mesh", list(MESHES))
@pytest.mark.parametrize("seed", [0, 1])
def test_shuffled_input_gives_the_permuted_operators(mesh, seed):
    V, T = MESHES[mesh]()
    V2, T2, perm, order = shuffled(V, T, seed)
    for kind, mass in (("primal", "barycentric"), ("dual", "circumcentric"), (0.4, "fem")):
        L, M = tetlap.operators(V, T, kind, mass)
        L2, M2 = tetlap.operators(V2, T2, kind, mass)
        # new vertex k is old vertex perm[k]; indexing keeps explicit zeros (a product of
        # permutation matrices would drop them)
        expected_L, expected_M = L[perm][:, perm], M[perm][:, perm]
        # the same pattern, exactly
        for A, B in ((L2, expected_L), (M2, expected_M)):
            B = sp.csr_array(B)
            B.sort_indices()
            np.testing.assert_array_equal(A.indptr, B.indptr)
            np.testing.assert_array_equal(A.indices, B.indices)
            # the same values up to the order of the sums (a few units in the last place)
            scale = np.abs(B.data).max()
            assert np.abs(A.data - B.data).max() <= 4e-16 * scale * 16
    # per-element values follow the elements exactly (each is computed from its own corners)
    W, W2 = tetlap.element_contributions(V, T, "dual"), tetlap.element_contributions(V2, T2, "dual")
    np.testing.assert_array_equal(W2, W[order])


def test_renumbering_only_the_vertices_changes_no_off_diagonal_bit():
    """With the elements in the same order, every edge's sum runs in the same order (the
    diagonal sums a row in column order, so it may differ in the last place)."""
    V, T = tetlap.meshes.ball(1500, seed=4)
    rng = np.random.default_rng(0)
    perm = rng.permutation(len(V))
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(V))
    L = tetlap.laplacian(V, T, "dual")
    L2 = tetlap.laplacian(V[perm], inverse[T], "dual")
    # row inverse[i] of L2 is row i of L, with its columns renumbered and re-sorted
    for i in range(0, len(V), 37):
        a = L[[i], :].tocoo()
        b = L2[[inverse[i]], :].tocoo()
        by_old = dict(zip(inverse[a.col], a.data))
        by_new = dict(zip(b.col, b.data))
        diagonal = inverse[i]
        assert by_new.pop(diagonal) == pytest.approx(by_old.pop(diagonal), rel=1e-14)
        assert by_new == by_old


def test_the_benchmark_meshes_are_what_they_say():
    V, T = benchmark.mesh("delaunay", "10k")
    assert 9000 < len(T) < 11000
    V2, T2 = benchmark.mesh("shuffled", "10k")
    assert len(T2) == len(T) and np.allclose(np.sort(V2, axis=0), np.sort(V, axis=0))
    assert not np.array_equal(V2, V)
    # a qhull mesh's first tets are spread over the whole cube (no memory locality)
    centroids = V[T[:100]].mean(axis=1)
    assert np.ptp(centroids, axis=0).min() > 0.3
