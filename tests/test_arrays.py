"""tetlap._arrays: array-likes in, clear errors for bad input, inputs never modified; a
mesh object in place of (V, T), followed by the other arguments as users write them."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap

V0, T0 = tetlap.meshes.cube(2, jitter=0.1, seed=1)
FUNCTIONS = [
    lambda V, T, **kw: tetlap.laplacian(V, T, "primal", **kw),
    lambda V, T, **kw: tetlap.laplacian(V, T, "dual", **kw),
    lambda V, T, **kw: tetlap.mass(V, T, "circumcentric", **kw),
    lambda V, T, **kw: tetlap.mass(V, T, "fem", **kw),
    lambda V, T, **kw: tetlap.operators(V, T, "dual", "barycentric", **kw)[0],
    lambda V, T, **kw: tetlap.triplets(V, T, **kw).vals,
    lambda V, T, **kw: tetlap.edge_weights(V, T, **kw)[1],
    lambda V, T, **kw: tetlap.element_contributions(V, T, **kw),
]


def dense(x):
    return x.toarray() if hasattr(x, "toarray") else np.asarray(x)


@pytest.mark.parametrize("f", FUNCTIONS)
@pytest.mark.parametrize("convert", [
    lambda V, T: (V.tolist(), T.tolist()),
    lambda V, T: (np.asfortranarray(V), np.asfortranarray(T)),
    lambda V, T: (V, T.astype(np.int32)),
    lambda V, T: (V, T.astype(np.uint32)),
    lambda V, T: (V, T.astype(np.uint64)),
    lambda V, T: (V, T.astype(np.int16)),
    lambda V, T: (np.ma.masked_array(V), np.ma.masked_array(T)),  # nothing masked
], ids=["lists", "fortran", "int32", "uint32", "uint64", "int16", "unmasked"])
def test_array_likes_give_identical_results(f, convert):
    V, T = convert(V0.copy(), T0.copy())
    np.testing.assert_array_equal(dense(f(V, T)), dense(f(V0, T0)))


def test_float32_coordinates_are_accepted():
    L32 = tetlap.laplacian(V0.astype(np.float32), T0)
    L64 = tetlap.laplacian(V0.astype(np.float32).astype(np.float64), T0)
    assert (L32 != L64).nnz == 0


@pytest.mark.parametrize("f", FUNCTIONS)
def test_inputs_are_never_modified_and_read_only_views_work(f):
    V = np.asfortranarray(V0.copy())
    T = T0.copy()
    V.flags.writeable = False
    T.flags.writeable = False
    v_before, t_before = V.copy(), T.copy()
    f(V, T)
    np.testing.assert_array_equal(V, v_before)
    np.testing.assert_array_equal(T, t_before)
    # non-contiguous views
    Vbig = np.zeros((len(V0), 6))
    Vbig[:, ::2] = V0
    Tbig = np.zeros((len(T0), 8), dtype=np.int64)
    Tbig[:, 1::2] = T0
    np.testing.assert_array_equal(dense(f(Vbig[:, ::2], Tbig[:, 1::2])), dense(f(V0, T0)))


CORNER_V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]


@pytest.mark.parametrize("V, T, error, match", [
    (np.zeros(12), [[0, 1, 2, 3]], tetlap.ShapeError, r"shape \(n, d\)"),
    (np.zeros((4, 2)), [[0, 1, 2, 3]], tetlap.ShapeError, "at least 3 coordinates"),
    (CORNER_V, [[0, 1]], tetlap.ShapeError, r"\(m, 3\) or \(m, 4\)"),
    (CORNER_V, [[0, 1, 2, 3, 4]], tetlap.ShapeError, r"\(m, 4\)"),
    (CORNER_V, [0, 1, 2, 3], tetlap.ShapeError, r"\(m, 4\)"),
    (CORNER_V, [[0.0, 1.0, 2.0, 3.0]], tetlap.DtypeError, "integer"),
    (CORNER_V, [[True, False, True, False]], tetlap.DtypeError, "integer"),
    ([["a", "b", "c"]] * 4, [[0, 1, 2, 3]], tetlap.DtypeError, "real numbers"),
    ([[0, 0, 0], [1, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]], tetlap.ShapeError, "rectangular"),
    (np.array(CORNER_V, dtype=complex), [[0, 1, 2, 3]], tetlap.DtypeError, "real numbers"),
    (np.ma.masked_array(np.array(CORNER_V, float), mask=np.eye(4, 3, dtype=bool)), [[0, 1, 2, 3]],
     tetlap.DtypeError, "masked"),
    (CORNER_V, np.ma.masked_array([[0, 1, 2, 3]], mask=[[0, 0, 0, 1]]), tetlap.DtypeError,
     "masked"),
    (CORNER_V, [[0, 1, 2, -1]], tetlap.IndexRangeError, "element 0 refers to vertex -1"),
    (CORNER_V, [[0, 1, 2, 3], [0, 1, 2, 4]], tetlap.IndexRangeError,
     "element 1 refers to vertex 4"),
    (CORNER_V, np.array([[0, 1, 2, 2**64 - 1]], dtype=np.uint64), tetlap.IndexRangeError,
     "element 0"),
    (CORNER_V, [[0, 1, 2, 2**40]], tetlap.IndexRangeError, "element 0"),
    ([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]], [[0, 1, 2, 3]],
     tetlap.NonFiniteError, "vertex 2"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.inf]], [[0, 1, 2, 3]],
     tetlap.NonFiniteError, "vertex 3"),
    (CORNER_V, np.zeros((0, 4), dtype=int), tetlap.EmptyMeshError, "no elements"),
    (np.zeros((0, 3)), [[0, 1, 2, 3]], tetlap.EmptyMeshError, "no vertices"),
    (CORNER_V, [[0, 1, 1, 3]], tetlap.RepeatedVertexError, "element 0 uses vertex 1"),
    ([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 1, 2, 3]],
     tetlap.DegenerateElementError, "element 0 is degenerate"),
    ([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], [[0, 1, 2, 3]],
     tetlap.DegenerateElementError, "element 0"),
    ([[5, 5, 5]] * 4, [[0, 1, 2, 3]], tetlap.DegenerateElementError, "element 0"),
])
def test_bad_input_raises_a_named_value_error(V, T, error, match):
    for f in FUNCTIONS:
        with pytest.raises(error, match=match) as info:
            f(V, T)
        assert isinstance(info.value, ValueError)


@pytest.mark.parametrize("bad", [None, 3.5, "mesh", {"V": 1}, object()])
def test_non_arrays_raise_type_error(bad):
    with pytest.raises(TypeError):
        tetlap.laplacian(bad, [[0, 1, 2, 3]])
    with pytest.raises(TypeError):
        tetlap.laplacian(CORNER_V, bad)


@pytest.mark.parametrize("s", [1e-150, 1e-100, 1e100, 1e150])
def test_tiny_and_huge_coordinates(s):
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=2)
    for kind in ("primal", "dual"):
        A, B = tetlap.laplacian(V, T, kind), tetlap.laplacian(s * V, T, kind)
        assert abs(B / s - A).max() <= 1e-13 * abs(A).max()
    if 1e-100 <= s <= 1e100:  # s^3 is a normal float64
        m, ms = (tetlap.mass(x, T, "circumcentric").diagonal() for x in (V, s * V))
        np.testing.assert_allclose(ms / s**3, m, rtol=1e-13)
    elif s > 1e100:  # the volume itself overflows float64: a clear error, never inf
        with pytest.raises(tetlap.DegenerateElementError, match="float64 range"):
            tetlap.mass(s * V, T, "circumcentric")


def test_translation_invariance_far_from_the_origin():
    V, T = tetlap.meshes.cube(2, jitter=0.2, seed=2)
    A = tetlap.laplacian(V, T, "dual")
    B = tetlap.laplacian(V + 1e6, T, "dual")
    assert abs(A - B).max() <= 1e-8 * abs(A).max()  # 1e6 offset costs ~6 digits


# ---- a mesh object in place of V and T --------------------------------------------------

V1, T1 = tetlap.meshes.cube(2, jitter=0.2, seed=3)
L1 = tetlap.laplacian(V1, T1, "dual")
M1 = tetlap.mass(V1, T1, "circumcentric")
F1 = V1[:, 0] ** 2

#: Every function that takes a mesh: (the call with arrays, the natural call with an object).
NATURAL_CALLS = {
    "laplacian": (lambda V, T: tetlap.laplacian(V, T, "dual"), lambda m: tetlap.laplacian(m, "dual")),
    "mass": (lambda V, T: tetlap.mass(V, T, "fem"), lambda m: tetlap.mass(m, "fem")),
    "operators": (lambda V, T: tetlap.operators(V, T, "dual", "circumcentric"),
                  lambda m: tetlap.operators(m, "dual", "circumcentric")),
    "triplets": (lambda V, T: tetlap.triplets(V, T, 0.5), lambda m: tetlap.triplets(m, 0.5)),
    "edge_weights": (lambda V, T: tetlap.edge_weights(V, T, "dual"),
                     lambda m: tetlap.edge_weights(m, "dual")),
    "element_contributions": (lambda V, T: tetlap.element_contributions(V, T, "dual"),
                              lambda m: tetlap.element_contributions(m, "dual")),
    "check": (lambda V, T: tetlap.check(L1, V, T, M1).to_dict(),
              lambda m: tetlap.check(L1, m, M1).to_dict()),
    "vjp": (lambda V, T: tuple(tetlap.vjp(V, T, "dual", dL=L1)),
            lambda m: tuple(tetlap.vjp(m, "dual", dL=L1))),
    "dirichlet_energy": (lambda V, T: tetlap.dirichlet_energy(V, T, F1, "dual"),
                         lambda m: tetlap.dirichlet_energy(m, F1, "dual")),
    "mass_energy": (lambda V, T: tetlap.mass_energy(V, T, F1, "circumcentric"),
                    lambda m: tetlap.mass_energy(m, F1, "circumcentric")),
    "Mesh": (lambda V, T: tetlap.Mesh(V, T).laplacian("dual"),
             lambda m: tetlap.Mesh(m).laplacian("dual")),
    "non_delaunay_faces": (lambda V, T: tetlap.diagnostics.non_delaunay_faces(V, T, 1e-6),
                           lambda m: tetlap.diagnostics.non_delaunay_faces(m, 1e-6)),
    "degenerate_tets": (lambda V, T: tetlap.diagnostics.degenerate_tets(V, T, 0.5),
                        lambda m: tetlap.diagnostics.degenerate_tets(m, 0.5)),
    "summary": (lambda V, T: tetlap.diagnostics.summary(V, T, 1e-6),
                lambda m: tetlap.diagnostics.summary(m, 1e-6)),
    "dual_boundary_areas": (lambda V, T: tetlap.solve.dual_boundary_areas(V, T, [1.0, 2.0, 0.0]),
                            lambda m: tetlap.solve.dual_boundary_areas(m, [1.0, 2.0, 0.0])),
}


def same(a, b) -> bool:
    """Bitwise equality of results: sparse arrays, arrays, numbers, tuples, dicts."""
    if hasattr(a, "tocsr"):
        a, b = a.tocsr(), b.tocsr()
        return all(np.array_equal(x, y) for x, y in
                   ((a.data, b.data), (a.indices, b.indices), (a.indptr, b.indptr)))
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return np.array_equal(a, b, equal_nan=isinstance(a, float) or np.asarray(a).dtype.kind == "f")


def mesh_objects():
    import meshio  # a test extra

    objects = {"meshio": meshio.Mesh(V1, [("tetra", T1)])}
    try:
        import pyvista
    except ImportError:
        return objects
    objects["pyvista"] = pyvista.UnstructuredGrid({pyvista.CellType.TETRA: T1}, V1)
    return objects


@pytest.mark.parametrize("library", ["meshio", "pyvista"])
@pytest.mark.parametrize("name", list(NATURAL_CALLS))
def test_a_mesh_object_takes_the_arguments_after_t_in_their_places(library, name):
    pytest.importorskip(library)
    obj = mesh_objects()[library]
    with_arrays, natural = NATURAL_CALLS[name]
    assert same(natural(obj), with_arrays(V1, T1)), name


def test_a_mesh_object_with_t_is_a_type_error_naming_the_function():
    obj = mesh_objects()["meshio"]
    for call in (lambda: tetlap.laplacian(obj, T1), lambda: tetlap.laplacian(obj, T1.tolist()),
                 lambda: tetlap.laplacian(obj, T=T1), lambda: tetlap.vjp(obj, T1)):
        with pytest.raises(TypeError, match="a mesh object carries its cells"):
            call()
    with pytest.raises(TypeError, match="^Mesh: a mesh object carries its cells"):
        tetlap.Mesh(obj, T1)
    # keywords and an explicit T=None still work
    assert same(tetlap.laplacian(obj, kind="dual"), L1)
    assert same(tetlap.laplacian(obj, None, "dual"), L1)
    assert same(tetlap.laplacian(V=obj, kind="dual"), L1)
    assert same(tetlap.check(L1, obj, None, M1).to_dict(), tetlap.check(L1, V1, T1, M1).to_dict())


def test_the_decorator_keeps_names_signatures_and_docs():
    import inspect

    for f in (tetlap.laplacian, tetlap.check, tetlap.dirichlet_energy, tetlap.Mesh.__init__):
        assert list(inspect.signature(f).parameters).count("V") == 1
    assert tetlap.laplacian.__name__ == "laplacian" and tetlap.check.__doc__.startswith("Check")
    assert "laplacian(mesh, \"dual\")" in tetlap.laplacian.__doc__
