# Private native module (Rust, PyO3). Public API: tetlap.assembly and tetlap.mesh.
# Inputs: points (n, d) C-contiguous float64, cells (m, 4) tets or (m, 3) triangles,
# C-contiguous int64 (validated in the core). Options are one dict (any of "boundary":
# "circumcentric" | "barycentric", "degenerate": "raise" | "skip", "threads": None or
# 1..MAX_THREADS), parsed here into the core's types and checked by the core; kinds are
# "primal" | "dual" | a real t in [0, 1], mass kinds "barycentric" | "circumcentric" |
# "fem"; anything else raises tetlap.OptionError.
# Sparse outputs are CSR triples (data float64, indices uint32 (< 2^31), indptr
# int32|int64); sparse inputs are (data float64, indices int64, indptr int64).
from typing import Literal, TypedDict, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = ["assemble", "check_options", "check_coefficient", "vjp", "Mesh", "MAX_THREADS",
           "DELAUNAY_RTOL",
           "MAX_GROUP", "faces", "duplicates", "edges", "quality", "non_delaunay",
           "check_operator", "negative_semidefinite", "element_certificate",
           "regular_conditions", "regular_signs", "regular_search", "regular_masses",
           "gradients", "Factor", "LU", "FACTOR_CHILD_MIN", "dual_centres"]

MAX_THREADS: int
DELAUNAY_RTOL: float
MAX_GROUP: int
FACTOR_CHILD_MIN: int

_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]
_Idx = npt.NDArray[np.int32] | npt.NDArray[np.int64]
_CsrArrays = tuple[_F64, npt.NDArray[np.uint32], _Idx]
_CsrInput = tuple[_F64, _I64, _I64]
_MassArrays = tuple[Literal["lumped"], _F64] | tuple[Literal["csr"], _CsrArrays]
_Cells = npt.NDArray[np.int64]
_Kind = str | float
_Options = dict[str, str | int | None] | None
_Request = (tuple[Literal["laplacian", "contributions", "triplets", "edge_weights"], _Kind]
            | tuple[Literal["mass"], str] | tuple[Literal["operators"], _Kind, str])

# ("laplacian", kind) -> _CsrArrays; ("mass", kind) -> _MassArrays; ("operators", kind,
# mass) -> (_CsrArrays, _MassArrays); ("contributions", kind) -> (m, 6) | (m, 3) float64;
# ("triplets", kind) -> (rows int64, cols int64, vals); ("edge_weights", kind) ->
# (edges (E, 2) int64, weights (E,)).
# medium: (coefficient, density), either None: the Laplacians' (m,) scalars, (m, d, d)
# tensors or one (d, d) tensor, and the masses' (m,) factors (C-contiguous float64, values
# checked by the core).
_Medium = tuple[_F64 | None, _F64 | None] | None
def assemble(points: _F64, cells: _Cells, request: _Request, *, weights: _F64 | None = None,
             medium: _Medium = None, options: _Options = None) -> object: ...
def check_options(options: _Options) -> None: ...
# Checks a coefficient (or density) for m elements of `corners` corners in dim-space:
# NonFiniteError / CoefficientError / ShapeError naming the element (vertices=True: the
# values are per vertex, named `values`, the error names the vertex).
def check_coefficient(values: _F64, m: int, corners: int, dim: int, *, density: bool = False,
                      vertices: bool = False) -> None: ...

# Cotangents of vjp: on L ("elements", (m, 6)) | ("matrix", _CsrInput) | ("quadratic",
# (n, k)); on M ("diagonal", (n,)) | ("matrix", ...) | ("quadratic", ...).
_SparseCot = tuple[Literal["matrix"], _CsrInput]
_LapCot = tuple[Literal["elements", "quadratic"], _F64] | _SparseCot
_MassCot = tuple[Literal["diagonal", "quadratic"], _F64] | _SparseCot

# cotangents: {"laplacian": (kind | None, _LapCot | None), "mass": (mass kind | None,
# _MassCot | None)}, either key optional; a None cotangent is no term.
class _Cotangents(TypedDict, total=False):
    laplacian: tuple[_Kind | None, _LapCot | None]
    mass: tuple[str | None, _MassCot | None]
def vjp(points: _F64, cells: _Cells, cotangents: _Cotangents, *, weights: _F64 | None = None,
        options: _Options = None) -> tuple[_F64, _F64 | None, float]: ...

# (g, vol): barycentric-coordinate gradients (m, 4 | 3, d) and element measures (m,).
def gradients(points: _F64, cells: _Cells, *, options: _Options = None
              ) -> tuple[_F64, _F64]: ...

# The orthogonal dual (tetlap.dual_geometry), tets only: (points (m, 5, d): per tet its
# centre then the centres of the faces opposite corners 0..3; barycentric (m, 4) of the
# centre; heights (m, 4): signed distances of the centre from the faces, positive on the
# tet's side; areas (m, 4) of the faces; volumes (m,) signed).
def dual_centres(points: _F64, cells: _Cells, *, weights: _F64 | None = None,
                 options: _Options = None) -> tuple[_F64, _F64, _F64, _F64, _F64]: ...

@final
class Mesh:
    def __new__(cls, points: _F64, cells: _Cells, *, weights: _F64 | None = None,
                medium: _Medium = None, options: _Options = None) -> Self: ...
    def pattern(self) -> tuple[npt.NDArray[np.uint32], _Idx]: ...
    def laplacian(self, kind: _Kind) -> _F64: ...
    def mass(self, kind: str) -> _F64: ...
    # points, the medium's coefficient and density: each None keeps the mesh's
    def update(self, points: _F64 | None = None, *,
               medium: _Medium = None) -> tuple[int, int, int]: ...
    def points(self) -> _F64: ...
    def cells(self) -> npt.NDArray[np.int64]: ...

# Sparse factorizations (tetlap.solve.factorize): matrix is (data, indices, indptr).
# child: the numeric factorization in a forked child process (Linux), killed on Ctrl-C;
# None: from FACTOR_CHILD_MIN stored values of the factor on.
@final
class Factor:
    def __new__(cls, n: int, matrix: _CsrInput, method_name: str,
                ordering: _I64 | None = None, *, options: _Options = None,
                child: bool | None = None) -> Self: ...
    def refactor(self, n: int, matrix: _CsrInput, *,
                 options: _Options = None, child: bool | None = None) -> None: ...
    def solve(self, rhs: _F64, *, options: _Options = None) -> _F64: ...
    def inertia(self) -> tuple[int, int, int]: ...
    def smallest_pivot(self) -> tuple[int, float]: ...
    @property
    def n(self) -> int: ...
    @property
    def factor_entries(self) -> int: ...
    @property
    def supernodal(self) -> bool: ...
    @property
    def in_child(self) -> bool: ...

# Solves with SuperLU's factors Pr A Pc = L U (tetlap._interrupt.splu): l and u are CSC
# (data, indices, indptr) with sorted indices; factor(upper) gives U or L back (a copy).
@final
class LU:
    def __new__(cls, n: int, l: _CsrInput, u: _CsrInput, perm_r: _I64,
                perm_c: _I64) -> Self: ...
    def solve(self, rhs: _F64, *, options: _Options = None) -> _F64: ...
    def factor(self, upper: bool) -> tuple[_F64, _I64, _I64]: ...
    @property
    def n(self) -> int: ...

# Diagnostics (topology: cells over n vertices; geometry: tets in R^3 or R^d).
def faces(cells: _Cells, n: int, *, options: _Options = None) -> tuple[_I64, _I64, _I64]: ...
def duplicates(cells: _Cells, n: int, *, options: _Options = None) -> npt.NDArray[np.bool_]: ...
def edges(cells: _Cells, n: int, *, options: _Options = None) -> _I64: ...
def quality(points: _F64, cells: _Cells, *, options: _Options = None
            ) -> tuple[_F64, _F64, npt.NDArray[np.bool_], npt.NDArray[np.int8]]: ...
def non_delaunay(points: _F64, cells: _Cells, interior: _I64, rtol: float, *,
                 options: _Options = None) -> npt.NDArray[np.bool_]: ...
def check_operator(points: _F64, cells: _Cells, l: _CsrInput, boundary: npt.NDArray[np.bool_],
                   negative_tol: float, *, options: _Options = None
                   ) -> dict[str, bool | int | float | None]: ...
def negative_semidefinite(n: int, l: _CsrInput, tol: _F64, *, options: _Options = None
                          ) -> tuple[bool | None, str, dict[str, int | float]]: ...
def element_certificate(cells: _Cells, n: int, weights: _F64, tol: _F64, *,
                        options: _Options = None
                        ) -> tuple[Literal[True] | None, str, dict[str, int | float]]: ...

# Regular weights (tetlap.regular): rows = (vertices (c, 5) int64, g0 (c,), coefficients
# (c, 5)); targets = (floor (c,), aim (c,), lo (n,), hi (n,)); a budget is (iterations,
# seconds or None), seconds an optional wall-clock limit. regular_conditions returns a dict: "interior" (f, 4),
# "boundary" (b, 2), "nonmanifold" (k, 3) int64 (see faces); "vertices" (c, 5) int64, "g0"
# (c,), "coefficients" (c, 5), "face" (c,) int64 (the margin rows); "folded" (f,) bool;
# "flat" (k,) int64 (faces with an exactly flat tet), "beyond_range" (k,) int64 (faces with
# a value beyond the float64 range).
_Rows = tuple[_I64, _F64, _F64]
_Targets = tuple[_F64, _F64, _F64, _F64]
_Stop = Literal["done", "stalled", "iterations", "deadline"]
_Budget = tuple[int, float | None]

def regular_conditions(points: _F64, cells: _Cells, *, options: _Options = None
                       ) -> dict[str, npt.NDArray[np.int64] | _F64 | npt.NDArray[np.bool_]]: ...
# interior: the (f, 4) face table of regular_conditions; weights (n,) or None (zeros); ->
# (2 f,) int8, the sign of every face view's lifted determinant (views from the first tets,
# then from the second): 1 strictly locally regular, -1 not, 0 float64 cannot tell
def regular_signs(points: _F64, cells: _Cells, interior: _I64, weights: _F64 | None = None,
                  *, options: _Options = None) -> npt.NDArray[np.int8]: ...
# -> (u (n,), stop, iterations, short rows (k,) int64 largest shortfall first, their
# multipliers (k,))
def regular_search(rows: _Rows, targets: _Targets, u: _F64, budget: _Budget, *,
                   options: _Options = None) -> tuple[_F64, _Stop, int, _I64, _F64]: ...
# problem = (rows, targets, masses), masses = (plain circumcentric masses (n,), floor in
# [0, 1), u -> w scale (n,)); -> (u (n,), {"rounds", "iterations", "kept", "lost", "deficit"})
def regular_masses(points: _F64, cells: _Cells,
                   problem: tuple[_Rows, _Targets, tuple[_F64, float, _F64]], u: _F64,
                   budget: _Budget, *, options: _Options = None
                   ) -> tuple[_F64, dict[str, int | float]]: ...
