"""tetlap.errors: one hierarchy under TetlapError (a ValueError), and every exception
names the offending element, vertex or value, in its message and as attributes."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
import tetlap.errors as errors
from tetlap import solve

CORNER_V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]


#: The classes of every input check (the hierarchy may grow; these stay).
INPUT_ERRORS = ["ShapeError", "DtypeError", "EmptyMeshError", "IndexRangeError",
                "NonFiniteError", "RepeatedVertexError", "DegenerateElementError",
                "OptionError", "MeshFileError", "InternalError"]


def test_every_exception_is_a_tetlap_error_and_a_value_error():
    assert {"TetlapError", *INPUT_ERRORS} <= set(errors.__all__) <= set(tetlap.__all__)
    for name in errors.__all__:
        cls = getattr(errors, name)
        assert issubclass(cls, errors.TetlapError) and issubclass(cls, ValueError), cls
        assert getattr(tetlap, name) is cls  # the same class at the top level
    assert issubclass(solve.CompatibilityError, errors.TetlapError)
    # the input errors are distinct: catching one does not catch another
    classes = [getattr(errors, name) for name in INPUT_ERRORS]
    for a in classes:
        for b in classes:
            assert issubclass(a, b) == (a is b), (a, b)


def test_attributes_default_to_none_and_are_keyword_only():
    e = errors.ShapeError("bad shape")
    assert str(e) == "bad shape"
    assert (e.element, e.vertex, e.index) == (None, None, None)
    e = errors.IndexRangeError("element 3 refers to vertex 9", element=3, index=9)
    assert (e.element, e.vertex, e.index) == (3, None, 9)
    with pytest.raises(TypeError):
        errors.IndexRangeError("message", 3)  # attributes only by keyword


def test_errors_carry_the_offending_element():
    with pytest.raises(tetlap.IndexRangeError) as e:
        tetlap.laplacian(CORNER_V, [[0, 1, 2, 3], [3, 2, 9, 0]])
    assert (e.value.element, e.value.index) == (1, 9)
    V = np.array(CORNER_V + [[0.5, 0.5, 0]], dtype=float)
    with pytest.raises(tetlap.DegenerateElementError) as e:
        tetlap.laplacian(V, [[0, 1, 2, 3], [0, 1, 2, 4]])
    assert e.value.element == 1
    with pytest.raises(tetlap.NonFiniteError) as e:
        tetlap.mass([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, np.nan]], [[0, 1, 2, 3]])
    assert e.value.vertex == 3


def test_each_core_error_arrives_as_its_class_with_its_attributes():
    V5 = CORNER_V + [[1, 1, 1]]
    with pytest.raises(tetlap.RepeatedVertexError, match="element 1 uses vertex 2") as e:
        tetlap.laplacian(V5, [[0, 1, 2, 3], [4, 2, 2, 1]])
    assert (e.value.element, e.value.vertex) == (1, 2)
    with pytest.raises(tetlap.NonFiniteError, match="vertex 4") as e:
        tetlap.laplacian(V5, [[0, 1, 2, 3]], "dual", weights=[0, 0, 0, 0, np.inf])
    assert e.value.vertex == 4
    with pytest.raises(tetlap.DegenerateElementError, match='degenerate="skip"') as e:
        tetlap.mass(np.array(CORNER_V) * 1e150, [[0, 1, 2, 3]], "circumcentric")
    assert e.value.element == 0  # a volume that overflows: not finite, named
    with pytest.raises(tetlap.EmptyMeshError, match="no elements|empty"):
        tetlap.laplacian(CORNER_V, np.zeros((0, 4), dtype=int))
    with pytest.raises(tetlap.ShapeError):
        tetlap.laplacian(CORNER_V, [[0, 1, 2, 3]], "dual", weights=[0, 0])
    with pytest.raises(tetlap.OptionError, match=r"\[0, 1\]"):
        tetlap.laplacian(CORNER_V, [[0, 1, 2, 3]], 2.0)
    with pytest.raises(tetlap.OptionError, match="tet meshes only"):
        tetlap.laplacian([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], boundary_centres="barycentric")


def test_a_cached_mesh_names_the_element_that_an_update_makes_degenerate():
    V, T = tetlap.meshes.cube(2)
    mesh = tetlap.Mesh(V, T)
    mesh.laplacian("dual")
    bad = V.copy()
    bad[13] = bad[0]  # the centre onto a corner: the tets around that edge go flat
    with pytest.raises(tetlap.DegenerateElementError) as e:
        mesh.update(bad)
    flat = np.abs(tetlap.diagnostics.signed_volumes(bad, T)) == 0
    assert flat[e.value.element]


def test_mesh_file_errors_name_the_file(tmp_path):
    pytest.importorskip("meshio")
    path = tmp_path / "noise.msh"
    path.write_text("this is not a mesh\n")
    with pytest.raises(tetlap.MeshFileError, match=r"noise\.msh") as e:
        tetlap.io.read(path)
    assert isinstance(e.value, ValueError)


# ---- texts that say no more than is known (issue 30 item 13) ----------------------------


def test_index_ranges_are_said_as_people_read_them():
    """'valid indices are 0..64' for 64 vertices read as 65 indices: every index error says
    how many vertices there are and the last index."""
    V, T = tetlap.meshes.cube(3)                       # 64 vertices
    L = tetlap.laplacian(V, T)
    fixed = tetlap.diagnostics.boundary_vertices(V, T)
    calls = [lambda: tetlap.laplacian(V, np.array([[0, 1, 2, 64]])),
             lambda: tetlap.Mesh(V, np.array([[0, 1, 2, 64]])),
             lambda: solve.dirichlet(L, [0, 64], 0.0),
             lambda: solve.neumann(L, np.zeros(64), gauge=64),
             lambda: tetlap.heat_distance(V, T, 64),
             lambda: tetlap.harmonic(V, T, [0, 64], [0.0, 1.0])]
    for call in calls:
        with pytest.raises(tetlap.IndexRangeError) as e:
            call()
        message = str(e.value)
        assert "there are 64 vertices, 0 to 63" in message and "0..64" not in message, message
        assert e.value.index == 64


def test_a_collinear_triangle_is_not_said_to_have_zero_volume():
    V = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]
    with pytest.raises(tetlap.DegenerateElementError, match="zero area for a triangle") as e:
        tetlap.laplacian(V, [[0, 1, 2]])
    assert e.value.element == 0


def test_kind_errors_name_no_argument_the_call_did_not_use():
    """operators(laplacian="cotan") answered "kind must be ...": each message names the
    value's role (operators, Mesh, HeatDistance, vjp and the energies call it kind=,
    laplacian= or mass=)."""
    V, T = tetlap.meshes.cube(2)
    f = V[:, 0]
    for call, role in [
        (lambda: tetlap.operators(V, T, laplacian="cotan"), "Laplacian kind"),
        (lambda: tetlap.operators(V, T, mass="cotan"), "mass kind"),
        (lambda: tetlap.laplacian(V, T, kind="cotan"), "Laplacian kind"),
        (lambda: tetlap.Mesh(V, T).laplacian("cotan"), "Laplacian kind"),
        (lambda: tetlap.HeatDistance(V, T, laplacian="cotan"), "Laplacian kind"),
        (lambda: tetlap.vjp(V, T, "cotan"), "Laplacian kind"),
        (lambda: tetlap.mass_energy(V, T, f, "cotan"), "mass kind"),
        (lambda: tetlap.laplacian(V, T, boundary_centres="cotan"), "boundary_centres"),
        (lambda: tetlap.HeatDistance(V, T, boundary_centres="cotan"), "boundary_centres"),
    ]:
        with pytest.raises(tetlap.OptionError) as e:
            call()
        assert str(e.value).startswith(f"{role} must be "), str(e.value)
        assert "got 'cotan'" in str(e.value)


def test_tet_only_functions_say_that_triangles_are_not_tets():
    V, T = [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]
    L = tetlap.laplacian(V, T)
    for call in (lambda: tetlap.check(L, V, T), lambda: tetlap.info.report(V, T),
                 lambda: tetlap.diagnostics.signed_volumes(V, T)):
        with pytest.raises(tetlap.ShapeError, match=r"got \(1, 3\): triangles, and this "
                                                    "function needs tets"):
            call()


@pytest.mark.parametrize("solver", ["auto", "cholesky", "lu"])
def test_dirichlet_values_near_the_float64_limit_are_solved_not_called_singular(solver):
    V, T = tetlap.meshes.cube(3)
    L = tetlap.laplacian(V, T)
    fixed = tetlap.diagnostics.boundary_vertices(V, T)
    for value in (1e308, -1.7e308):
        f = solve.dirichlet(L, fixed, value, solver=solver)  # was "singular"
        np.testing.assert_allclose(f, value, rtol=1e-12)
    step = np.where(V[:, 0] > 0.5, 1e308, -1e308)
    f = solve.dirichlet(L, fixed, step, solver=solver)
    assert np.isfinite(f).all() and np.abs(f).max() <= 1e308 * (1 + 1e-12)
    f1 = solve.dirichlet(L, fixed, step / 2**1000, solver=solver)
    np.testing.assert_array_equal(f, f1 * 2**1000)  # scaled exactly by a power of two
    with pytest.raises(tetlap.NonFiniteError, match="float64 range"):
        solve.dirichlet(L, fixed, 1e308, rhs=np.full(len(V), -1e308), solver=solver)


def test_fixed_is_a_mask_or_indices_everywhere_and_empty_means_none():
    """``fixed=[]`` is a float array to NumPy: it was a DtypeError (solve) or a ShapeError
    (improve, which read indices as a mask)."""
    V, T = tetlap.meshes.cube(3, jitter=0.2, seed=1)
    n = len(V)
    L, M = tetlap.operators(V, T)
    lam, _ = solve.eigs(L, M, 3, fixed=[])
    np.testing.assert_array_equal(lam, solve.eigs(L, M, 3)[0])
    with pytest.raises(tetlap.SolveError, match="no fixed vertex"):
        solve.dirichlet(L, [], 0.0)           # the real problem, not the dtype of []
    plain = tetlap.improve.improve(V, T, max_iterations=3)
    same = tetlap.improve.improve(V, T, fixed=[], max_iterations=3)
    np.testing.assert_array_equal(plain.V, same.V)
    inner = np.flatnonzero(tetlap.diagnostics.interior_vertices(V, T))[:2]
    by_index = tetlap.improve.improve(V, T, fixed=inner, max_iterations=3)
    mask = np.zeros(n, dtype=bool)
    mask[inner] = True
    np.testing.assert_array_equal(by_index.V, tetlap.improve.improve(V, T, fixed=mask,
                                                                     max_iterations=3).V)
    np.testing.assert_array_equal(by_index.V[inner], V[inner])
    for bad, error in (([0.5], tetlap.DtypeError), ([n], tetlap.IndexRangeError),
                       (np.ones(3, bool), tetlap.ShapeError)):
        for call in (lambda: tetlap.improve.improve(V, T, fixed=bad),
                     lambda: solve.dirichlet(L, bad, 0.0)):
            with pytest.raises(error, match="fixed"):
                call()
