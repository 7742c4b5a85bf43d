# Private native module (Rust, PyO3). Public API: tetlap.assembly and tetlap.mesh.
# Inputs: points (n, d) C-contiguous float64, cells (m, 4) tets or (m, 3) triangles,
# C-contiguous int64 (validated in the core). Options are parsed here into the core's
# types: kind "primal" | "dual" | a real t in [0, 1]; mass kind "barycentric" |
# "circumcentric" | "fem"; boundary "circumcentric" | "barycentric"; degenerate "raise" |
# "skip"; threads None or 1..MAX_THREADS; anything else raises tetlap.OptionError.
# CSR triples are (data float64, indices uint32 (< 2^31), indptr int32|int64).
from typing import Literal, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = ["laplacian", "mass", "operators", "contributions", "triplets", "edge_weights",
           "vjp", "Mesh", "MAX_THREADS"]

MAX_THREADS: int

_F64 = npt.NDArray[np.float64]
_Idx = npt.NDArray[np.int32] | npt.NDArray[np.int64]
_CsrArrays = tuple[_F64, npt.NDArray[np.uint32], _Idx]
_MassArrays = tuple[Literal["lumped"], _F64] | tuple[Literal["csr"], _CsrArrays]
_Cells = npt.NDArray[np.int64]
_Kind = str | float

def laplacian(points: _F64, cells: _Cells, kind: _Kind, *, weights: _F64 | None = None,
              boundary: str = ..., degenerate: str = ...,
              threads: int | None = ...) -> _CsrArrays: ...
def mass(points: _F64, cells: _Cells, kind: str, *, weights: _F64 | None = None,
         boundary: str = ..., degenerate: str = ..., threads: int | None = ...) -> _MassArrays: ...
def operators(points: _F64, cells: _Cells, laplacian: _Kind, mass: str, *,
              weights: _F64 | None = None, boundary: str = ..., degenerate: str = ...,
              threads: int | None = ...) -> tuple[_CsrArrays, _MassArrays]: ...
def contributions(points: _F64, cells: _Cells, kind: _Kind, *, weights: _F64 | None = None,
                  boundary: str = ..., degenerate: str = ...,
                  threads: int | None = ...) -> _F64: ...
def triplets(points: _F64, cells: _Cells, kind: _Kind, *, weights: _F64 | None = None,
             boundary: str = ..., degenerate: str = ..., threads: int | None = ...
             ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], _F64]: ...
def edge_weights(points: _F64, cells: _Cells, kind: _Kind, *, weights: _F64 | None = None,
                 boundary: str = ..., degenerate: str = ..., threads: int | None = ...
                 ) -> tuple[npt.NDArray[np.int64], _F64]: ...

# Cotangents of vjp: on L ("elements", (m, 6)) | ("matrix", (indptr int64, indices int64,
# data)) | ("quadratic", (n, k)); on M ("diagonal", (n,)) | ("matrix", ...) | ("quadratic", ...).
_SparseCot = tuple[Literal["matrix"], tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], _F64]]
_LapCot = tuple[Literal["elements", "quadratic"], _F64] | _SparseCot
_MassCot = tuple[Literal["diagonal", "quadratic"], _F64] | _SparseCot

def vjp(points: _F64, cells: _Cells, laplacian: _Kind | None, mass: str | None, *,
        dl: _LapCot | None = None, dm: _MassCot | None = None, weights: _F64 | None = None,
        boundary: str = ..., degenerate: str = ..., threads: int | None = ...
        ) -> tuple[_F64, _F64 | None, float]: ...

@final
class Mesh:
    def __new__(cls, points: _F64, cells: _Cells, *, weights: _F64 | None = None,
                boundary: str = ..., degenerate: str = ..., threads: int | None = ...) -> Self: ...
    def pattern(self) -> tuple[npt.NDArray[np.uint32], _Idx]: ...
    def laplacian(self, kind: _Kind) -> _F64: ...
    def mass(self, kind: str) -> _F64: ...
    def update(self, points: _F64) -> tuple[int, int, int]: ...
    def points(self) -> _F64: ...
    def cells(self) -> npt.NDArray[np.int64]: ...
