"""Coefficients of the Laplacian in heterogeneous and anisotropic media: ``div(K grad u)``.

Every Laplacian of tetlap takes ``coefficient=K`` (and every mass ``density=rho``), ``K``
given per element:

* ``(m,)``: a positive scalar per element (a conductivity ``c_t``);
* ``(m, 3, 3)``: a symmetric positive definite tensor per tet (``(m, 2, 2)`` per triangle
  of a mesh in the plane);
* ``(3, 3)``: one such tensor for every tet (``(2, 2)`` for triangles in the plane).

Tensors need the mesh in its own space (tets in R^3, triangles in R^2); a mesh immersed
in a larger space takes scalars only. The library never guesses what an array means
from its length (a mesh can have as many vertices as elements): a field given per vertex
goes through :func:`from_vertices` first.

The definitions (sign convention of :func:`tetlap.laplacian`: ``L[i, j] = w_ij``,
``L[i, i] = -sum_j w_ij``):

* primal: ``L_ij = -sum_t Vol_t grad(phi_i) . K_t grad(phi_j)``;
* dual: each tet's circumcentric contribution in the metric ``K_t^-1`` (of the tet mapped
  by ``K_t^-1/2``) times ``sqrt(det K_t)``; for a scalar ``c``, ``c`` times the plain
  contribution;
* both equal, for a constant ``K``, ``sqrt(det K)`` times the plain operators of the mesh
  mapped by ``K^-1/2``;
* masses do not depend on ``K``; ``density=rho`` multiplies each element's contributions
  to every mass kind by ``rho_t``.

:func:`check` is the validation every entry point applies (shapes here, values in the
core): use it to validate a coefficient once for code of your own.
"""

from __future__ import annotations

import numpy as np

from . import _arrays, _core
from ._names import public_dir
from .errors import DtypeError, OptionError, ShapeError

__all__ = ["check", "from_vertices"]
__dir__ = public_dir(globals())


def _argument(values, shapes: tuple[tuple[int, int], tuple[int, int]], *,
              density: bool = False) -> np.ndarray | None:
    """``values`` as the core takes a coefficient (``density=False``) or a density for a
    mesh whose ``V`` and ``T`` have the ``shapes`` ``((n, d), (m, k))``: ``None``, or a
    C-contiguous float64 array of one of the accepted shapes (the input itself when it
    already is one: never modified). Shapes and dtypes are checked here, the values by the
    core, as :func:`check` does."""
    if values is None:
        return None
    name = "density" if density else "coefficient"
    arr = _arrays._as_array(values, name)
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    (n, d), (m, k) = shapes
    e = 3 if k == 4 else 2
    noun = "tet" if k == 4 else "triangle"
    scalars = (m,)
    tensors = () if density else ((m, e, e), (e, e))
    if arr.shape == scalars or arr.shape in tensors:
        if arr.ndim > 1 and d != e:
            raise ShapeError(
                f"a tensor {name} needs the mesh in its own space ({noun}s in R^{e}); this "
                f"mesh is immersed in R^{d} (V has {d} columns): give one positive scalar per "
                f"{noun}, shape ({m},)")
        return np.ascontiguousarray(arr, dtype=np.float64)
    per_vertex = n != m and arr.shape in ((n,), (n, e, e))
    if per_vertex:
        raise ShapeError(
            f"{name} has shape {arr.shape}: one value per vertex (n = {n}), but it is taken per "
            f"{noun} (m = {m}); average a per-vertex field onto the {noun}s first with "
            f"tetlap.coefficient.from_vertices(values, T)")
    accepted = f"({m},): a positive scalar per {noun}"
    if not density:
        accepted += (f"; ({m}, {e}, {e}): a symmetric positive definite tensor per {noun}; "
                     f"or ({e}, {e}): one such tensor for every {noun}")
    raise ShapeError(f"{name} must have shape {accepted}; got {arr.shape}")


def check(values, V, T, *, density: bool = False) -> np.ndarray:
    """A coefficient of the Laplacian (or with ``density=True`` a density of the masses),
    validated for the mesh ``(V, T)`` exactly as every function of tetlap validates it.

    Parameters
    ----------
    values : array-like of real numbers
        A coefficient: ``(m,)`` positive scalars, ``(m, 3, 3)`` symmetric positive definite
        tensors per tet (``(m, 2, 2)`` per triangle in the plane) or one ``(3, 3)``
        (``(2, 2)``) tensor for every element. A density: ``(m,)`` positive scalars.
    V : (n, d) array-like of real numbers
        Vertex positions (only the shape is used: tensors need ``d`` equal to the
        element's dimension).
    T : (m, 4) or (m, 3) array-like of integers
        Tets or triangles.
    density : bool, default False
        Check a density (scalars only) instead of a coefficient.

    Returns
    -------
    numpy.ndarray
        A new C-contiguous float64 array of the accepted shape.

    Raises
    ------
    tetlap.ShapeError
        A shape that is none of the accepted ones (they are named); one value per vertex
        where one per element is expected (``n != m``); a tensor for an immersed mesh.
    tetlap.DtypeError
        Not real numbers.
    tetlap.NonFiniteError
        NaN or an infinity, naming the element (``element``) and the entry.
    tetlap.CoefficientError
        A scalar <= 0; a tensor not symmetric beyond rounding (its relative asymmetry
        above ``2^-40``; the message gives it), or not positive definite to float64
        precision (the message gives its smallest eigenvalue). ``element`` names the
        element.

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> V, T = tetlap.meshes.cube(1)
    >>> K = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> tetlap.coefficient.check(K, V, T).shape
    (3, 3)
    >>> c = np.ones(len(T)); c[2] = -1.0
    >>> tetlap.coefficient.check(c, V, T)
    Traceback (most recent call last):
    ...
    tetlap.errors.CoefficientError: coefficient[2] (tet 2) is -1.0: a scalar coefficient must be positive
    """
    V, T = _arrays.points(V), _arrays.elements(T)
    arr = _argument(values, (V.shape, T.shape), density=density)
    if arr is None:
        raise TypeError("values must be an array-like of numbers, got NoneType")
    _core.check_coefficient(arr, T.shape[0], T.shape[1], V.shape[1], density=density)
    return arr.copy()


def from_vertices(values, T, method: str = "mean") -> np.ndarray:
    """A per-vertex field averaged onto the elements: the coefficient of each element from
    the values at its corners.

    Parameters
    ----------
    values : (n,) or (n, 3, 3) / (n, 2, 2) array-like of real numbers
        Positive scalars, or symmetric positive definite tensors, one per vertex (checked
        as a coefficient is, naming the vertex).
    T : (m, 4) or (m, 3) array-like of integers
        Tets or triangles.
    method : {"mean", "harmonic", "geometric"}, default "mean"
        ``"mean"``: the arithmetic mean of the corners' values, the average over the
        element of the field's linear interpolant (what neuromodes does with its
        heterogeneity maps). ``"harmonic"``: ``k / sum(1 / v)`` (for tensors the inverse
        of the mean of the inverses), the effective conductivity of layers in series:
        at most the mean, and dominated by the smallest value, so a thin insulating layer
        is not averaged away (finite-volume codes average interface conductivities this
        way). ``"geometric"``: ``exp(mean(log v))``, for fields whose logarithm varies
        smoothly (log-normal permeabilities); scalars only.

    Returns
    -------
    (m,) or (m, d, d) float64 numpy.ndarray
        One coefficient per element, positive (SPD) as the values are; pass it as
        ``coefficient=``.

    Examples
    --------
    >>> import numpy as np, tetlap
    >>> T = np.array([[0, 1, 2, 3]])
    >>> tetlap.coefficient.from_vertices([1.0, 1.0, 1.0, 4.0], T)
    array([1.75])
    >>> tetlap.coefficient.from_vertices([1.0, 1.0, 1.0, 4.0], T, "harmonic").round(4)
    array([1.2308])
    """
    T = _arrays.elements(T)
    arr = _arrays._as_array(values, "values")
    if arr.dtype.kind not in "fiu":
        raise DtypeError(f"values must hold real numbers, got dtype {arr.dtype}")
    if method not in ("mean", "harmonic", "geometric"):
        raise OptionError(f'method must be "mean", "harmonic" or "geometric", got {method!r}')
    e = 3 if T.shape[1] == 4 else 2
    if arr.ndim == 0 or arr.shape[1:] not in ((), (e, e)):
        raise ShapeError(f"values must have shape (n,) (a scalar per vertex) or (n, {e}, {e}) "
                         f"(a tensor per vertex), got {arr.shape}")
    n = arr.shape[0]
    _arrays.in_range(T, n, "element")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    _core.check_coefficient(arr, n, T.shape[1], e, vertices=True)
    corners = arr[T]  # (m, k) or (m, k, e, e)
    if method == "mean":
        return corners.mean(axis=1)
    if method == "geometric":
        if arr.ndim > 1:
            raise OptionError('method="geometric" takes scalars only (the geometric mean of '
                              'tensors would need matrix logarithms); use "mean" or "harmonic"')
        return np.exp(np.log(corners).mean(axis=1))
    if arr.ndim == 1:
        return T.shape[1] / (1.0 / corners).sum(axis=1)
    mean_inverse = np.linalg.inv(corners).mean(axis=1)
    out = np.linalg.inv(mean_inverse)
    return (out + out.swapaxes(-1, -2)) / 2
