# Private native module (Rust, PyO3). Public API: tetlap.assembly.
# Inputs: points (n, d) C-contiguous float64, tets (m, 4) C-contiguous int64 (validated in
# the core). kind: "primal" | "dual" | "affine" (then t in [0, 1]); mass kind:
# "barycentric" | "circumcentric" | "fem"; degenerate: "raise" | "skip".
# CSR triples are (data float64, indices int32|int64, indptr int32|int64).
from typing import Literal

import numpy as np
import numpy.typing as npt

_F64 = npt.NDArray[np.float64]
_Idx = npt.NDArray[np.int32] | npt.NDArray[np.int64]
_CsrArrays = tuple[_F64, _Idx, _Idx]
_MassArrays = tuple[Literal["lumped"], _F64] | tuple[Literal["csr"], _CsrArrays]

def laplacian(points: _F64, tets: npt.NDArray[np.int64], kind: str, t: float,
              threads: int | None, degenerate: str) -> _CsrArrays: ...
def mass(points: _F64, tets: npt.NDArray[np.int64], kind: str,
         threads: int | None, degenerate: str) -> _MassArrays: ...
def operators(points: _F64, tets: npt.NDArray[np.int64], kind: str, t: float,
              mass_kind: str, threads: int | None,
              degenerate: str) -> tuple[_CsrArrays, _MassArrays]: ...
def tet_contributions(points: _F64, tets: npt.NDArray[np.int64], kind: str, t: float,
                      threads: int | None, degenerate: str) -> _F64: ...
def triplets(points: _F64, tets: npt.NDArray[np.int64], kind: str, t: float,
             threads: int | None, degenerate: str
             ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], _F64]: ...
def edge_weights(points: _F64, tets: npt.NDArray[np.int64], kind: str, t: float,
                 threads: int | None, degenerate: str
                 ) -> tuple[npt.NDArray[np.int64], _F64]: ...
