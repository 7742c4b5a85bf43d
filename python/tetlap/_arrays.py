"""Conversion of user array-likes into the exact arrays the core takes, never in place."""

from __future__ import annotations

import numbers

import numpy as np

from .errors import DtypeError, EmptyMeshError, IndexRangeError, OptionError, ShapeError

_I64_MAX = np.iinfo(np.int64).max


def _as_array(x, name: str) -> np.ndarray:
    if x is None or isinstance(x, (str, bytes, dict, set, frozenset)) or not (
        hasattr(x, "__array__") or hasattr(x, "__len__")
    ):
        raise TypeError(f"{name} must be an array-like of numbers, got {type(x).__name__}")
    try:
        arr = np.asarray(x)
    except (ValueError, TypeError) as e:  # ragged nested lists and the like
        raise ShapeError(f"{name} is not a rectangular array: {e}") from None
    if arr.dtype == object:
        raise DtypeError(f"{name} must hold numbers, got Python objects (dtype=object)")
    return arr


def points(V) -> np.ndarray:
    """``V`` as a C-contiguous ``(n, d)`` float64 array (a copy unless it already is one)."""
    arr = _as_array(V, "V")
    if arr.size == 0:
        raise EmptyMeshError("V is empty: the mesh has no vertices")
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"V must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ShapeError(f"V must have shape (n, d), got an array of shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def elements(T, n_columns=(3, 4)) -> np.ndarray:
    """``T`` as a C-contiguous ``(m, k)`` int64 array of any integer input dtype, ``k`` in
    ``n_columns`` (tets: 4, triangles: 3)."""
    n_columns = (n_columns,) if isinstance(n_columns, int) else tuple(n_columns)
    arr = _as_array(T, "T")
    if arr.size == 0:
        raise EmptyMeshError("T is empty: the mesh has no elements")
    if arr.dtype.kind not in "iu":
        raise DtypeError(
            f"T must hold integer vertex indices, got dtype {arr.dtype} "
            "(cast it yourself if the values are whole numbers)"
        )
    if arr.ndim != 2 or arr.shape[1] not in n_columns:
        shapes = " or ".join(f"(m, {k})" for k in n_columns)
        raise ShapeError(f"T must have shape {shapes}, got {arr.shape}")
    if arr.dtype == np.uint64 and arr.max() > _I64_MAX:
        flat = int(np.argmax(arr.ravel() > _I64_MAX))
        bad = int(arr.ravel()[flat])
        element = flat // arr.shape[1]
        raise IndexRangeError(
            f"element {element} refers to vertex {bad}, beyond any valid index",
            element=element, index=bad,
        )
    return np.ascontiguousarray(arr, dtype=np.int64)


def laplacian_kind(kind) -> tuple[str, float]:
    """``"primal"``, ``"dual"`` or a float ``t`` in [0, 1] as the core's ``(name, t)``."""
    if isinstance(kind, str):
        if kind in ("primal", "dual"):
            return kind, 0.0
        raise OptionError(f'kind must be "primal", "dual" or a float t in [0, 1], got {kind!r}')
    if isinstance(kind, numbers.Real) and not isinstance(kind, bool):
        t = float(kind)
        if 0.0 <= t <= 1.0:
            return "affine", t
        raise OptionError(f"the affine parameter t must lie in [0, 1], got {kind!r}")
    raise OptionError(f'kind must be "primal", "dual" or a float t in [0, 1], got {kind!r}')


def mass_kind(kind) -> str:
    if kind in ("barycentric", "circumcentric", "fem"):
        return kind
    raise OptionError(f'mass kind must be "barycentric", "circumcentric" or "fem", got {kind!r}')


def threads(value) -> int | None:
    if value is None:
        return None
    if isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= 1:
        return int(value)
    raise OptionError(f"threads must be None or an integer >= 1, got {value!r}")


def degenerate(policy) -> str:
    if policy in ("raise", "skip"):
        return policy
    raise OptionError(f'degenerate must be "raise" or "skip", got {policy!r}')


def boundary(treatment) -> str:
    if treatment in ("circumcentric", "barycentric"):
        return treatment
    raise OptionError(
        f'boundary must be "circumcentric" or "barycentric", got {treatment!r}')


def options(threads_, degenerate_, boundary_) -> tuple:
    """The core's options tuple ``(threads, degenerate, boundary)``."""
    return threads(threads_), degenerate(degenerate_), boundary(boundary_)


def vertex_weights(w, n: int) -> np.ndarray | None:
    """Per-vertex weights as a contiguous (n,) float64 array, or None."""
    if w is None:
        return None
    arr = _as_array(w, "weights")
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"weights must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ShapeError(f"weights must have shape ({n},), one per vertex, got {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)
