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

The names below and the submodules are imported on first use (PEP 562), so that
``import tetlap`` and ``tetlap --version`` do not load NumPy and SciPy.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: Where each public name lives, in the order of ``__all__``: {module: names}; a name that
#: is its module's own (``".io": ("io",)``) is a public submodule.
_EXPORTS = {
    ".assembly": ("laplacian", "mass", "operators", "triplets", "edge_weights",
                  "element_contributions", "tet_contributions", "Triplets"),
    ".derivatives": ("vjp", "dirichlet_energy", "mass_energy", "coefficient_vjp", "VJP"),
    ".regular": ("regular_weights", "RegularWeights"),
    ".mesh": ("Mesh", "UpdateInfo"),
    ".calculus": ("gradient", "divergence"),
    ".dual": ("dual_geometry", "DualGeometry"),
    ".cells": ("cell_laplacian",),
    ".dec": ("dec",),
    ".heat": ("HeatDistance", "heat_distance"),
    ".fields": ("harmonic", "Harmonic"),
    ".analysis": ("check", "Report"),
    ".meshes": ("meshes",),
    ".coefficient": ("coefficient",),
    ".diagnostics": ("diagnostics",),
    ".solve": ("solve",),
    ".io": ("io",),
    ".info": ("info",),
    "._core": ("MAX_THREADS",),
    ".errors": ("TetlapError", "ShapeError", "DtypeError", "EmptyMeshError",
                "IndexRangeError", "NonFiniteError", "RepeatedVertexError",
                "DegenerateElementError", "OptionError", "MeshFileError",
                "CompatibilityError", "SolveError", "CoefficientError", "InternalError"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}
__all__ = list(_WHERE)


def __getattr__(name: str):
    """Import a public name's module, or the submodule ``name``, on first use (every
    submodule was an attribute of ``tetlap`` when the package imported them eagerly)."""
    if name in _WHERE:
        module = importlib.import_module(_WHERE[name], __name__)
        value = module if module.__name__ == f"{__name__}.{name}" else getattr(module, name)
    elif not name.startswith("__") and importlib.util.find_spec(f"{__name__}.{name}"):
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names, the public submodules imported so far and the module's dunders:
    not the helpers of this file (``importlib``, ``TYPE_CHECKING``, ``annotations``)."""
    submodules = {name for name, value in globals().items() if not name.startswith("_")
                  and getattr(value, "__name__", None) == f"{__name__}.{name}"}
    dunders = {name for name in globals() if name.startswith("__") and name.endswith("__")}
    return sorted(set(__all__) | submodules | dunders)


if TYPE_CHECKING:  # what type checkers and IDEs see: the same names, imported eagerly
    from . import coefficient, dec, diagnostics, info, io, meshes, solve
    from ._core import MAX_THREADS
    from .analysis import Report, check
    from .assembly import (Triplets, edge_weights, element_contributions, laplacian, mass,
                           operators, tet_contributions, triplets)
    from .derivatives import VJP, coefficient_vjp, dirichlet_energy, mass_energy, vjp
    from .errors import (CoefficientError, CompatibilityError, DegenerateElementError, DtypeError,
                         EmptyMeshError, IndexRangeError, InternalError, MeshFileError,
                         NonFiniteError, OptionError, RepeatedVertexError, ShapeError,
                         SolveError, TetlapError)
    from .calculus import divergence, gradient
    from .cells import cell_laplacian
    from .dual import DualGeometry, dual_geometry
    from .fields import Harmonic, harmonic
    from .heat import HeatDistance, heat_distance
    from .mesh import Mesh, UpdateInfo
    from .regular import RegularWeights, regular_weights
