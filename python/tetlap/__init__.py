"""tetlap: primal and dual Laplace operators and mass matrices of tetrahedral meshes.

The primal Laplacian (P1 FEM / cotan, always negative semidefinite) and the circumcentric
dual Laplacian (DEC / finite volume, non-negative weights on Delaunay meshes) of Alexa et
al., "Properties of Laplace Operators for Tetrahedral Meshes" (SGP 2020), computed by a
parallel Rust core and returned as ``scipy.sparse.csr_array``.

Sign convention (paper Eq. 1): ``L[i, j] = w_ij`` on edges, ``L[i, i] = -sum_j w_ij``.

>>> import tetlap
>>> V, T = tetlap.meshes.cube(3)
>>> L = tetlap.laplacian(V, T, kind="dual")
>>> M = tetlap.mass(V, T, kind="circumcentric")
>>> L.shape, round(float(M.sum()), 12)
((64, 64), 1.0)
"""

from . import diagnostics, info, io, meshes, solve
from ._core import MAX_THREADS
from .mesh import Mesh, UpdateInfo
from .analysis import Report, check
from .errors import (
    CompatibilityError,
    DegenerateElementError,
    DtypeError,
    EmptyMeshError,
    IndexRangeError,
    InternalError,
    MeshFileError,
    NonFiniteError,
    OptionError,
    RepeatedVertexError,
    ShapeError,
    SolveError,
    TetlapError,
)
from .derivatives import VJP, dirichlet_energy, mass_energy, vjp
from .regular import RegularWeights, regular_weights
from .assembly import (
    Triplets,
    edge_weights,
    element_contributions,
    laplacian,
    mass,
    operators,
    tet_contributions,
    triplets,
)

__version__ = "0.1.0"

__all__ = [
    "laplacian",
    "mass",
    "operators",
    "triplets",
    "edge_weights",
    "element_contributions",
    "tet_contributions",
    "Triplets",
    "vjp",
    "dirichlet_energy",
    "mass_energy",
    "VJP",
    "regular_weights",
    "RegularWeights",
    "Mesh",
    "UpdateInfo",
    "check",
    "Report",
    "meshes",
    "diagnostics",
    "solve",
    "io",
    "info",
    "MAX_THREADS",
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
    "InternalError",
]
