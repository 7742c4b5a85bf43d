"""The float64 range that the mesh reports (``tetlap info``, ``tetlap improve``) need: every
tet's volume a normal float64, and their sum finite.

The core computes each tet in a frame rescaled by a power of two, so weights and angles
hold at any scale; volumes and masses are in the caller's units. A tet whose volume is
``inf``, or is below ``2.2e-308`` although the tet is not flat (its dihedral angles are
defined), is beyond the range: the assembly refuses it (``degenerate="raise"``) or drops
its masses (``"skip"``), and a report would count it as flat. For a tet of unit shape that
is coordinates from about ``1e-100`` to ``1e100``. Flat tets are reported, not refused.

>>> import tetlap
>>> from tetlap._float_range import check_float_range
>>> V, T = tetlap.meshes.cube(2)
>>> check_float_range(V * 1e100, T)
>>> check_float_range(V * 1e200, T)
Traceback (most recent call last):
...
tetlap.errors.DegenerateElementError: tet 0 has volume inf, beyond the float64 range ...
"""

from __future__ import annotations

import numpy as np

from . import _core
from .errors import DegenerateElementError

__all__ = ["check_float_range", "SMALLEST", "LARGEST"]

#: The normal float64 magnitudes a volume must lie between.
SMALLEST = float(np.finfo(np.float64).tiny)
LARGEST = float(np.finfo(np.float64).max)
_ADVICE = ("a tet of unit shape allows coordinates from about 1e-100 to 1e100: rescale "
           "the mesh")


def check_float_range(V, T) -> None:
    """Raise :class:`tetlap.DegenerateElementError` (``.element``: the first such tet)
    unless every tet's volume is a normal float64 or the tet is flat, and the mesh volume
    is finite. ``V`` (n, d) float64 and ``T`` (m, 4) int64, validated."""
    volume, dihedral, _, _ = _core.quality(V, T)
    size = np.abs(volume)
    shaped = ~np.isnan(dihedral).any(axis=1)
    outside = ~(size <= LARGEST) | (shaped & (size < SMALLEST))
    if outside.any():
        k = int(np.argmax(outside))
        raise DegenerateElementError(
            f"tet {k} has volume {volume[k]:.3g}, beyond the float64 range (normal "
            f"magnitudes {SMALLEST:.3g} to {LARGEST:.3g}); {_ADVICE}", element=k)
    with np.errstate(over="ignore"):
        total = size.sum()
    if not np.isfinite(total):
        raise DegenerateElementError(
            f"the mesh volume (the sum of {len(T)} tet volumes) exceeds the float64 range "
            f"({LARGEST:.3g}); {_ADVICE}")


#: Meshes whose bounding box is between these sizes are computed in their own units.
UNIT_BAND = (2.0**-64, 2.0**64)


def unit_scale(V, T) -> float:
    """A power of two ``s`` such that ``V / s`` has edges of about unit length, for the
    scale-free computations that take powers of lengths in NumPy (the quality barrier of
    :func:`tetlap.improve.improve`, :func:`tetlap.regular_weights`); ``V`` (n, 3) the
    vertices in tets only (so that a vertex in none changes nothing), ``T`` (m, 4) or
    (m, 3) on them. 1.0 for the meshes of any real-world unit (box between ``2^-64`` and
    ``2^64``), which are computed as given; beyond, ``2^frame_exponent(V, T)``. Dividing by
    ``s`` and multiplying back are exact.

    >>> import numpy as np
    >>> T = np.array([[0, 1, 2, 3]])
    >>> unit_scale(np.eye(4)[:, :3], T), unit_scale(3e100 * np.eye(4)[:, :3], T) == 2.0**334
    (1.0, True)
    """
    V = np.asarray(V, dtype=np.float64)
    extent = float(np.ptp(V, axis=0).max()) if len(V) else 0.0
    if UNIT_BAND[0] <= extent <= UNIT_BAND[1] or not np.isfinite(extent) or extent == 0:
        return 1.0
    return float(2.0 ** frame_exponent(V, T))


def frame_exponent(V, T) -> int:
    """The exponent ``k`` of the power of two ``2^k`` that brings the mesh to unit size, for
    every mesh (also those in :data:`UNIT_BAND`): the mean of the binary exponents of the
    shortest and the longest edge (each measured by its largest coordinate difference,
    within ``sqrt(3)`` of its length), so that a mesh spanning many orders of magnitude
    (a needle of 1e150 on a unit base) keeps both ends' volumes in the float64 range.
    ``frame_exponent(2^j V, T) == frame_exponent(V, T) + j`` exactly, so that a computation
    in the frame ``V / 2^k`` is bitwise the same for every power-of-two scaling of a mesh
    (:class:`tetlap.HeatDistance`). ``V`` (n, d) float64 finite, ``T`` (m, k) int64 on it; 0
    for a mesh with no edge of non-zero length.

    >>> import numpy as np
    >>> T = np.array([[0, 1, 2, 3]])
    >>> frame_exponent(np.eye(4)[:, :3], T), frame_exponent(0.1 * np.eye(4)[:, :3], T)
    (1, -3)
    """
    X = np.asarray(V, dtype=np.float64)[T]
    k = T.shape[1]
    edges = np.concatenate([X[:, b] - X[:, a] for a in range(k) for b in range(a + 1, k)])
    longest = np.abs(edges).max(axis=1)                   # within sqrt(3) of the length
    longest = longest[longest > 0]
    if not len(longest):
        return 0
    exponents = np.frexp(np.array([longest.min(), longest.max()]))[1]
    return (int(exponents[0]) + int(exponents[1])) // 2
