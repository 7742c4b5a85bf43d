"""The whole tetlap.solve API with empty and odd shapes: an empty problem has an empty
answer of the right shape, everything else a tetlap error naming the argument (never a
bare NumPy/SciPy error: factorize of a 0-d or 3-d array, Factor.solve with (n, 0) or with
n = 0, boundary areas in the plane raised them)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import tetlap
from tetlap import solve

Z = sp.csr_array((0, 0))
A = sp.csr_array(np.array([[2.0, -1.0], [-1.0, 2.0]]))
L = -A
V, T = tetlap.meshes.cube(2)
LM = tetlap.laplacian(V, T)
F = len(tetlap.diagnostics.boundary_faces(T))
FLUX = lambda c, n: n[:, 0]  # noqa: E731

# (call, the answer's shape or the error)
CASES = {
    # empty problems: empty answers
    "factorize 0x0 solve (0,)": (lambda: solve.factorize(Z).solve(np.zeros(0)), (0,)),
    "factorize 0x0 solve (0, 3)": (lambda: solve.factorize(Z).solve(np.zeros((0, 3))), (0, 3)),
    "factorize 0x0 lu solve": (lambda: solve.factorize(Z, solver="lu").solve(np.zeros(0)), (0,)),
    "factorize 0x0 refactor": (lambda: solve.factorize(Z).refactor(Z), None),
    "factorize 0x0 inertia": (lambda: solve.factorize(Z).inertia(), (3,)),
    "Factor.solve (n, 0)": (lambda: solve.factorize(A).solve(np.zeros((2, 0))), (2, 0)),
    "Factor.solve (n, 0) lu": (lambda: solve.factorize(A, solver="lu").solve(np.zeros((2, 0))), (2, 0)),
    "Factor.solve (n, 0) non-symmetric": (
        lambda: solve.factorize(sp.csr_array(np.array([[2.0, 1.0], [0.0, 2.0]]))).solve(np.zeros((2, 0))),
        (2, 0)),
    "dirichlet 0x0": (lambda: solve.dirichlet(Z, [], 0.0), (0,)),
    "dirichlet 0x0 mask": (lambda: solve.dirichlet(Z, np.zeros(0, dtype=bool), np.zeros(0)), (0,)),
    "dirichlet 0x0 replace": (lambda: solve.dirichlet(Z, [], 0.0, method="replace"), (0,)),
    "neumann 0x0": (lambda: solve.neumann(Z, np.zeros(0)), (0,)),
    # odd shapes: named errors
    "factorize 0-d": (lambda: solve.factorize(np.array(1.0)), tetlap.ShapeError),
    "factorize 1-d": (lambda: solve.factorize(np.ones(2)), tetlap.ShapeError),
    "factorize 3-d": (lambda: solve.factorize(np.ones((2, 2, 2))), tetlap.ShapeError),
    "factorize 3-d sparse": (lambda: solve.factorize(sp.coo_array(np.ones((2, 2, 2)))), tetlap.ShapeError),
    "factorize 2x3": (lambda: solve.factorize(np.ones((2, 3))), tetlap.ShapeError),
    "refactor 3x3": (lambda: solve.factorize(A).refactor(sp.eye_array(3)), tetlap.ShapeError),
    "refactor 3-d": (lambda: solve.factorize(A).refactor(np.ones((2, 2, 2))), tetlap.ShapeError),
    "Factor.solve 0-d": (lambda: solve.factorize(A).solve(np.array(1.0)), tetlap.ShapeError),
    "Factor.solve (0,)": (lambda: solve.factorize(A).solve(np.zeros(0)), tetlap.ShapeError),
    "Factor.solve 3-d": (lambda: solve.factorize(A).solve(np.ones((2, 1, 1))), tetlap.ShapeError),
    "Factor.solve (n, 0) complex": (lambda: solve.factorize(A).solve(np.zeros((2, 0), complex)),
                                    tetlap.DtypeError),
    "Factor.solve 0x0 with (1,)": (lambda: solve.factorize(Z).solve(np.zeros(1)), tetlap.ShapeError),
    "dirichlet 0-d L": (lambda: solve.dirichlet(np.array(1.0), [0], 0.0), tetlap.ShapeError),
    "dirichlet 3-d L": (lambda: solve.dirichlet(np.ones((2, 2, 2)), [0], 0.0), tetlap.ShapeError),
    "dirichlet values (1, 0)": (lambda: solve.dirichlet(L, [0], np.zeros((1, 0))), tetlap.ShapeError),
    "dirichlet values (0,)": (lambda: solve.dirichlet(L, [0], np.zeros(0)), tetlap.ShapeError),
    "dirichlet fixed 0-d": (lambda: solve.dirichlet(L, np.array(0), 1.0), tetlap.ShapeError),
    "dirichlet fixed 2-d": (lambda: solve.dirichlet(L, np.array([[0]]), 1.0), tetlap.ShapeError),
    "dirichlet rhs (n, 0)": (lambda: solve.dirichlet(L, [0], 1.0, np.zeros((2, 0))), tetlap.ShapeError),
    "neumann 3-d L": (lambda: solve.neumann(np.ones((2, 2, 2)), np.zeros(2)), tetlap.ShapeError),
    "neumann g (n, 1)": (lambda: solve.neumann(L, np.zeros((2, 1))), tetlap.ShapeError),
    "neumann g (0,)": (lambda: solve.neumann(L, np.zeros(0)), tetlap.ShapeError),
    "neumann rhs (n, 0)": (lambda: solve.neumann(L, np.zeros(2), np.zeros((2, 0))), tetlap.ShapeError),
    "kkt V (0, 3)": (lambda: solve.neumann_primal_kkt(LM, np.zeros((0, 3)), T, FLUX), tetlap.EmptyMeshError),
    "kkt T (0, 4)": (lambda: solve.neumann_primal_kkt(LM, V, np.zeros((0, 4), int), FLUX),
                     tetlap.EmptyMeshError),
    "kkt V (n, 2)": (lambda: solve.neumann_primal_kkt(LM, V[:, :2], T, FLUX), tetlap.ShapeError),
    "kkt data (F, 0)": (lambda: solve.neumann_primal_kkt(LM, V, T, np.zeros((F, 0))), tetlap.ShapeError),
    "kkt callable (F, 3)": (lambda: solve.neumann_primal_kkt(LM, V, T, lambda c, n: n), tetlap.ShapeError),
    "kkt rhs (n, 0)": (lambda: solve.neumann_primal_kkt(LM, V, T, FLUX, np.zeros((len(V), 0))),
                       tetlap.ShapeError),
    "kkt 3-d L": (lambda: solve.neumann_primal_kkt(np.ones((2, 2, 2)), V, T, FLUX), tetlap.ShapeError),
    "dual areas V (n, 2)": (lambda: solve.dual_boundary_areas(V[:, :2], T, [1, 0, 0]), tetlap.ShapeError),
    "fem areas V (n, 4)": (lambda: solve.fem_boundary_areas(np.c_[V, V[:, 0]], T, [1, 0, 0]),
                           tetlap.ShapeError),
    "fem areas T (0, 4)": (lambda: solve.fem_boundary_areas(V, np.zeros((0, 4), int), [1, 0, 0]),
                           tetlap.EmptyMeshError),
    "fem areas gradient (3, 1)": (lambda: solve.fem_boundary_areas(V, T, np.zeros((3, 1))),
                                  tetlap.ShapeError),
    "dual areas callable (F, 0)": (lambda: solve.dual_boundary_areas(V, T, lambda p, n: np.zeros((len(p), 0))),
                                   tetlap.ShapeError),
    "eigs 3-d L": (lambda: solve.eigs(np.ones((2, 2, 2)), A, 1), tetlap.ShapeError),
}


@pytest.mark.parametrize("case", CASES)
def test_empty_and_odd_shapes(case):
    call, expected = CASES[case]
    if isinstance(expected, type):
        with pytest.raises(expected):
            call()
        return
    out = call()
    if expected is None:
        assert out is None
    else:
        assert np.shape(out) == expected
        if isinstance(out, np.ndarray):
            assert out.dtype == np.float64 or out.size == 0
