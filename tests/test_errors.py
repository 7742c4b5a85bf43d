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
        tetlap.laplacian([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], boundary="barycentric")


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
