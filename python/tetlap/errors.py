"""Exceptions of tetlap: one hierarchy under :class:`TetlapError` (a ``ValueError``).

Every exception names the offending element in its message and, where it applies, as
attributes (``element``: tet index, ``vertex``: vertex index, ``index``: the bad value).
Objects that are not arrays at all raise a plain ``TypeError``.

Example
-------
>>> import tetlap
>>> try:
...     tetlap.laplacian([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 7]])
... except tetlap.IndexRangeError as e:
...     print(e.element, e.index)
0 7
"""

from __future__ import annotations

from ._names import public_dir

__all__ = [
    "TetlapError",
    "ShapeError",
    "DtypeError",
    "EmptyMeshError",
    "IndexRangeError",
    "NonFiniteError",
    "RepeatedVertexError",
    "DegenerateElementError",
    "OptionError",
    "MeshFileError",
    "CompatibilityError",
    "SolveError",
    "CoefficientError",
    "InternalError",
]
__dir__ = public_dir(globals())


class TetlapError(ValueError):
    """Base class of every tetlap error (a ``ValueError``)."""

    def __init__(self, message: str, *, element: int | None = None,
                 vertex: int | None = None, index: int | None = None) -> None:
        super().__init__(message)
        self.element = element
        self.vertex = vertex
        self.index = index


class ShapeError(TetlapError):
    """An array has the wrong number of dimensions or columns (e.g. ``V`` with d < 3)."""


class DtypeError(TetlapError):
    """An array has the wrong kind of values (e.g. float or bool vertex indices)."""


class EmptyMeshError(TetlapError):
    """The mesh has no vertices or no elements."""


class IndexRangeError(TetlapError):
    """An element refers to a vertex index that is negative or ``>= n``."""


class NonFiniteError(TetlapError):
    """A coordinate is NaN or infinite."""


class RepeatedVertexError(TetlapError):
    """An element uses the same vertex more than once."""


class DegenerateElementError(TetlapError):
    """An element has zero volume (or is too flat for a finite result in float64)."""


class OptionError(TetlapError):
    """An option has a value outside its domain (kind, threads, t, policy)."""


class MeshFileError(TetlapError):
    """A mesh file could not be read (unknown format, malformed content)."""


class CompatibilityError(TetlapError):
    """A pure Neumann problem whose data do not integrate to zero (no solution exists)."""


class SolveError(TetlapError):
    """A linear system or eigenproblem of :mod:`tetlap.solve` has no accurate solution
    (singular, or too ill-conditioned): the message gives the relative residual."""


class CoefficientError(TetlapError):
    """A coefficient of the Laplacian (``coefficient=``) or a density of the masses
    (``density=``) that is not positive: a scalar <= 0, or a tensor that is not symmetric
    (beyond rounding) or not positive definite. The message gives the value (the
    asymmetry, the smallest eigenvalue); ``element`` is the element it belongs to."""


class InternalError(TetlapError):
    """A bug inside tetlap (a Rust panic caught at the boundary). Please report it."""
