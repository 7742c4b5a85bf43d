# Private native module (Rust, PyO3). Public API: tetlap.assembly.
# Inputs: points (n, d) C-contiguous float64, tets (m, 4) C-contiguous int64 (validated in
# the core). kind: "primal" | "dual" | "affine" (then t in [0, 1]); mass kind:
# "barycentric" | "circumcentric" | "fem"; weights: (n,) float64 or None; options:
# (threads: int | None, degenerate: "raise" | "skip", boundary: "circumcentric" |
# "barycentric").
# CSR triples are (data float64, indices uint32 (< 2^31), indptr int32|int64).
from typing import Literal, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = ["laplacian", "mass", "operators", "tet_contributions", "triplets", "edge_weights",
           "_panic_inside_guard", "Mesh"]

_F64 = npt.NDArray[np.float64]
_Idx = npt.NDArray[np.int32] | npt.NDArray[np.int64]
_CsrArrays = tuple[_F64, npt.NDArray[np.uint32], _Idx]
_MassArrays = tuple[Literal["lumped"], _F64] | tuple[Literal["csr"], _CsrArrays]

_Tets = npt.NDArray[np.int64]
_Weights = _F64 | None
_Options = tuple[int | None, str, str]

def laplacian(points: _F64, tets: _Tets, weights: _Weights, kind: str, t: float,
              options: _Options) -> _CsrArrays: ...
def mass(points: _F64, tets: _Tets, weights: _Weights, kind: str,
         options: _Options) -> _MassArrays: ...
def operators(points: _F64, tets: _Tets, weights: _Weights, kind: str, t: float,
              mass_kind: str, options: _Options) -> tuple[_CsrArrays, _MassArrays]: ...
def tet_contributions(points: _F64, tets: _Tets, weights: _Weights, kind: str, t: float,
                      options: _Options) -> _F64: ...
def triplets(points: _F64, tets: _Tets, weights: _Weights, kind: str, t: float,
             options: _Options) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], _F64]: ...
def edge_weights(points: _F64, tets: _Tets, weights: _Weights, kind: str, t: float,
                 options: _Options) -> tuple[npt.NDArray[np.int64], _F64]: ...

def _panic_inside_guard(message: str) -> None: ...  # test hook: raises InternalError

@final
class Mesh:
    def __new__(cls, points: _F64, tets: _Tets, weights: _Weights,
                options: _Options) -> Self: ...
    def pattern(self) -> tuple[npt.NDArray[np.uint32], _Idx]: ...
    def laplacian(self, kind: str, t: float) -> _F64: ...
    def mass(self, kind: str) -> _F64: ...
    def update(self, points: _F64) -> tuple[int, int, int]: ...
    def points(self) -> _F64: ...
    def tets(self) -> npt.NDArray[np.int64]: ...
