"""Conversion of user array-likes into the exact arrays the core takes, never in place.

Options (``kind``, ``boundary``, ``threads``, ...) are not checked here: the native module
parses them into its own types and raises :class:`tetlap.OptionError` itself.
"""

from __future__ import annotations

import functools
import inspect
import numbers

import numpy as np
import scipy.sparse as sp

from . import _meshobj
from .errors import (DtypeError, EmptyMeshError, IndexRangeError, NonFiniteError, OptionError,
                     ShapeError)

_I64_MAX = np.iinfo(np.int64).max


def _as_array(x, name: str) -> np.ndarray:
    if x is None or isinstance(x, (str, bytes, dict, set, frozenset)) or not (
        hasattr(x, "__array__") or hasattr(x, "__len__")
    ):
        raise TypeError(f"{name} must be an array-like of numbers, got {type(x).__name__}")
    if isinstance(x, np.ma.MaskedArray):
        if np.ma.is_masked(x):
            raise DtypeError(f"{name} is a masked array with masked entries: fill them first "
                             "(x.filled(...)) or drop them")
        x = x.data
    try:
        arr = np.asarray(x)
    except (ValueError, TypeError) as e:  # ragged nested lists and the like
        raise ShapeError(f"{name} is not a rectangular array: {e}") from None
    if arr.dtype == object:
        raise DtypeError(f"{name} must hold numbers, got Python objects (dtype=object)")
    return arr


def mesh(V, T):
    """``(V, T)`` as given, or the arrays of one mesh object passed as ``V`` (a
    ``meshio.Mesh``, a ``pyvista.UnstructuredGrid``, or anything with ``points`` and tetra
    or triangle cells) when ``T`` is None."""
    if T is None:
        if _meshobj.is_mesh_object(V):
            return _meshobj.to_arrays(V, stacklevel=4)
        raise TypeError(
            f"T is missing: pass V and T arrays, or one mesh object (meshio, PyVista, ...) "
            f"instead of V; got {type(V).__name__}")
    return V, T


def takes_mesh_object(f):
    """Decorator for a function of ``(..., V, T, after, ...)``: one mesh object in place of
    ``V`` is followed directly by the arguments after ``T``, as users write it
    (``laplacian(mesh, "dual")``, ``check(L, mesh, M)``, ``dirichlet_energy(mesh, f)``);
    :func:`mesh` then reads the object. With a mesh object, an array in the place of ``T``
    where an option (a name or a number) or nothing positional follows is a ``TypeError``:
    the object carries its own cells."""
    params = list(inspect.signature(f).parameters.values())
    at = [p.name for p in params].index("T")
    after = params[at + 1] if at + 1 < len(params) else None
    positional = after is not None and after.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
    option = positional and isinstance(after.default, (str, numbers.Number))
    name = f.__qualname__.removesuffix(".__init__")

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        V = args[at - 1] if len(args) >= at else kwargs.get("V")
        if _meshobj.is_mesh_object(V):
            if kwargs.get("T") is not None:
                raise TypeError(f"{name}: a mesh object carries its cells; pass T only "
                                "with a V array")
            if len(args) > at and args[at] is not None:
                if not positional or (option and isinstance(args[at], (np.ndarray, list, tuple))):
                    raise TypeError(f"{name}: a mesh object carries its cells; pass it "
                                    "alone, or V and T arrays")
                args = args[:at] + (None,) + args[at:]
            elif len(args) <= at:
                kwargs.setdefault("T", None)
        return f(*args, **kwargs)

    return wrapper


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
        why = (": triangles, and this function needs tets (laplacian, mass, operators, the "
               "other assembly functions, Mesh and gradient take triangles too)"
               if n_columns == (4,) and arr.ndim == 2 and arr.shape[1] == 3 else "")
        raise ShapeError(f"T must have shape {shapes}, got {arr.shape}{why}")
    if arr.dtype == np.uint64 and arr.max() > _I64_MAX:
        flat = int(np.argmax(arr.ravel() > _I64_MAX))
        bad = int(arr.ravel()[flat])
        element = flat // arr.shape[1]
        raise IndexRangeError(
            f"element {element} refers to vertex {bad}, beyond any valid index",
            element=element, index=bad,
        )
    return np.ascontiguousarray(arr, dtype=np.int64)


def in_range(A: np.ndarray, n: int, row: str) -> None:
    """IndexRangeError naming the first row of the integer array ``A`` (``row`` says what
    a row is: "element", "edge") with an entry outside ``0..n-1``."""
    bad = (A < 0) | (A >= n)
    if bad.any():
        first = int(np.flatnonzero(bad.any(axis=1))[0])
        index = int(A[first][bad[first]][0])
        raise IndexRangeError(f"{row} {first} refers to vertex {index}, but there are {n} "
                              "vertices", element=first, index=index)


def used_vertices(V: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(used, T_used)`` of a mesh ``V`` (n, d) float64, ``T`` (m, k) int64: the vertices
    in elements of ``T`` ((k,) int64, increasing) and ``T`` renumbered onto them, in the
    same order (so every order derived from vertex numbers is kept). Computations that
    vertices in no element must not influence run on ``(V[used], T_used)``; ``used`` is
    ``arange(n)`` and ``T_used`` is ``T`` when every vertex is used. Raises as the core
    does for an index outside ``0..n-1`` (IndexRangeError) and for a non-finite coordinate
    of any vertex (NonFiniteError)."""
    n = len(V)
    in_range(T, n, "element")
    bad = ~np.isfinite(V)
    if bad.any():
        v, c = (int(i) for i in np.argwhere(bad)[0])
        raise NonFiniteError(f"vertex {v} has a non-finite coordinate "
                             f"{'NaN' if np.isnan(V[v, c]) else V[v, c]} (column {c})", vertex=v)
    referenced = np.zeros(n, dtype=bool)
    referenced[T.ravel()] = True
    if referenced.all():
        return np.arange(n, dtype=np.int64), T
    return np.flatnonzero(referenced).astype(np.int64), (np.cumsum(referenced) - 1)[T]


def edges(E, n: int, name: str = "edges") -> np.ndarray:
    """``E`` as a new ``(E, 2)`` int64 array of vertex indices in ``0..n-1``."""
    arr = _as_array(E, name)
    if arr.dtype.kind not in "iu":
        raise DtypeError(f"{name} must hold integer vertex indices, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ShapeError(f"{name} must have shape (E, 2), got {arr.shape}")
    arr = arr.astype(np.int64)
    in_range(arr, n, "edge")
    return arr


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


def matrix(A, n: int | None = None, name: str = "L", finite: bool = True) -> sp.csr_array:
    """``A`` as a new float64 ``(n, n)`` csr_array with summed duplicates and sorted
    indices: a SciPy sparse array or matrix (or a dense 2-D array), square, and finite
    unless ``finite=False`` (a checker that reports non-finite entries)."""
    if not (sp.issparse(A) or isinstance(A, np.ndarray)):
        raise TypeError(f"{name} must be a SciPy sparse array or matrix, got {type(A).__name__}")
    if isinstance(A, np.ndarray) and A.dtype.kind not in "fiub":
        raise DtypeError(f"{name} must hold real numbers, got dtype {A.dtype}")
    if sp.issparse(A) and A.dtype.kind not in "fiub":
        raise DtypeError(f"{name} must hold real numbers, got dtype {A.dtype}")
    if A.ndim != 2:        # a 0-d or 3-d array: SciPy's own errors are a TypeError or bare
        expected = f"({n}, {n})" if n is not None else "square"
        raise ShapeError(f"{name} has shape {A.shape}, expected {expected}")
    A = sp.csr_array(A, dtype=np.float64, copy=True)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or (n is not None and A.shape[0] != n):
        expected = f"({n}, {n})" if n is not None else "square"
        raise ShapeError(f"{name} has shape {A.shape}, expected {expected}")
    A.sum_duplicates()
    A.sort_indices()
    bad = np.flatnonzero(~np.isfinite(A.data)) if finite else ()
    if len(bad):
        row = int(np.searchsorted(A.indptr, bad[0], side="right") - 1)
        raise NonFiniteError(f"{name} has a non-finite entry in row {row}", vertex=row)
    return A


def laplacian(L, n: int | None = None, name: str = "L", finite: bool = True) -> sp.csr_array:
    """``L`` checked as :func:`matrix` does, and refused with an :class:`OptionError` when
    its sign says it is the stiffness ``-L`` (LaPy's, scikit-fem's): a tetlap Laplacian has
    ``L[i, i] = -sum_j w_ij``, negative wherever the weights sum to more than zero, so a
    diagonal with no negative entry and a positive one is the other convention."""
    L = matrix(L, n, name, finite)
    d = L.diagonal()
    if d.size and (d >= 0).all() and (d > 0).any():
        raise OptionError(
            f"{name} has a non-negative diagonal ({name}[{int(np.argmax(d))}, "
            f"{int(np.argmax(d))}] = {d.max():.3g}): it is not a tetlap Laplacian, whose "
            f"diagonal is minus the sum of the edge weights ({name}[i, i] = -sum_j w_ij, "
            f"negative semidefinite on good meshes); a stiffness matrix K = -L (LaPy, "
            f"scikit-fem) is passed as -K")
    return L


def vector(x, n: int, name: str) -> np.ndarray:
    """``x`` as a new finite float64 ``(n,)`` array."""
    arr = _as_array(x, name)
    if arr.dtype.kind not in "fiub":
        raise DtypeError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if arr.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},), got {arr.shape}")
    arr = np.array(arr, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise NonFiniteError(f"{name}[{bad[0]}] is not finite ({arr[bad[0]]})", vertex=int(bad[0]))
    return arr


def not_a_vertex(what: str, index: int, n: int) -> IndexRangeError:
    """The error for ``index`` outside ``0..n-1`` (``what``: "sources holds"), the range
    said as people read it ("0..64" read as 65 indices for 64 vertices)."""
    known = f"there are {n} vertices, 0 to {n - 1}" if n else "there are no vertices"
    return IndexRangeError(f"{what} {index}, not a vertex: {known}", index=int(index))


def vertex_mask(given, n: int, name: str, once: bool = False) -> np.ndarray:
    """``given``, a boolean mask ``(n,)`` or integer vertex indices (``[]``: none), as a new
    ``(n,)`` bool mask; ``once``: an index given twice is an OptionError (where values
    follow the indices one by one)."""
    arr = _as_array(given, name)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise ShapeError(f"a boolean `{name}` must have shape ({n},), got {arr.shape}")
        return arr.copy()
    out = np.zeros(n, dtype=bool)
    if arr.size == 0:        # [] is a float array to NumPy: no vertex, not a DtypeError
        return out
    if arr.dtype.kind not in "iu":
        raise DtypeError(f"`{name}` must be a boolean mask or integer vertex indices, got "
                         f"dtype {arr.dtype}")
    if arr.ndim != 1:
        raise ShapeError(f"`{name}` must be a 1-D array of vertex indices, got shape "
                         f"{arr.shape}")
    flat = arr
    bad = (flat < 0) | (flat >= n)
    if bad.any():
        raise not_a_vertex(f"`{name}` holds", int(flat[np.argmax(bad)]), n)
    if once:
        unique, counts = np.unique(flat, return_counts=True)
        if (counts > 1).any():
            raise OptionError(f"`{name}` holds vertex {int(unique[np.argmax(counts > 1)])} "
                              "twice: give each vertex once")
    out[flat] = True
    return out


def vertex_index(v, n: int, name: str) -> int:
    """``v`` (an option naming a vertex) as a vertex index in ``0..n-1``."""
    if not isinstance(v, numbers.Integral) or isinstance(v, bool):
        raise OptionError(f"{name} must be an integer vertex index, got {v!r}")
    if not 0 <= v < n:
        raise not_a_vertex(f"{name} =", v, n)
    return int(v)
