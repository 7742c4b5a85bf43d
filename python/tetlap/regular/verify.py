"""The checks of the answers of :func:`tetlap.regular.regular_weights`, independent of the
search that found them.

*Regular* is accepted only when every interior face is strictly locally regular for the
weights found, seen from both of its tets: the lifted orientation determinant

``D = -sign(sum_i C_i) * sum_i C_i (|e_i|^2 - (w_i - w_q))``, ``e_i = x_i - x_q``,

(``C_i`` the cofactors of the lifted column, rows ``i`` the corners of the tet, ``q`` the
other tet's opposite vertex; ``D / norm`` is the margin, ``norm > 0``) is positive. It is
evaluated in float64 (by the core, ``tetlap._core.regular_signs``: every face view on its
own, in parallel, by code that shares nothing with the search's rows) together with its
*permanent* ``P`` (the same sum
with every product of absolute values, ``|e_i|^2 + |w_i - w_q|`` for the lifted entries).
The rounding error of that evaluation is at most a few dozen units in the last place of
``P``, so ``|D| > VERIFY_RTOL * P`` (:data:`VERIFY_RTOL` = 1e-12, more than 4000 units)
decides the sign; the faces within it are decided by exact rational arithmetic
(:class:`fractions.Fraction` of the float64 inputs). So is the orientation sign.

*Not regular* is accepted only with one of:

* a *Gordan certificate*: interior faces with multipliers ``y > 0`` such that
  ``sum_f y_f D_f(w)`` has zero coefficients for every weight. Then that sum is the same
  for every ``w``, and since it vanishes for the flat lifting ``w = |x|^2`` it is 0, so
  some ``D_f(w) <= 0`` whatever the weights. The coefficients are computed exactly
  (integers after a power-of-two scaling of every row), the positive null vector of the
  certificate's rows by exact elimination (the float multipliers of the search choose it
  when the null space has more than one dimension), and the identity is then checked in
  exact arithmetic;
* a *folded* face: its opposite vertices lie strictly on the same side of it (exact
  orientation signs), so its two views have opposite signs for every ``w``;
* a face of more than two tets (counted on ``T`` itself): no triangulation has one.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction
from math import gcd

import numpy as np

from .. import _core
from .._names import public_dir

__all__ = ["VERIFY_RTOL", "MarginCheck", "check_margins", "check_certificate", "check_folded",
           "check_nonmanifold", "exact_orientation"]
__dir__ = public_dir(globals())

#: Relative tolerance of the float64 test of a lifted determinant against its permanent;
#: within it, exact arithmetic decides (module docstring; the core's
#: ``tetlap::analysis::regular::VERIFY_RTOL``).
VERIFY_RTOL = 1e-12


def _exact_vector(x) -> list[Fraction]:
    return [Fraction(float(v)) for v in x]


def _exact_lifted(V, w, tet, q):
    """``(sigma, C, lengths)`` of the lifted determinant of rows ``tet`` (4 vertex indices)
    against ``q``, exactly: ``D = sigma * sum_i C_i (lengths_i - (w_i - w_q))``,
    ``sigma = -sign(sum C)`` (0 for a flat tet)."""
    xq = _exact_vector(V[q])
    E = [[a - b for a, b in zip(_exact_vector(V[i]), xq)] for i in tet]

    def det3(a, b, c):
        return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]))

    C = [-det3(E[1], E[2], E[3]), det3(E[0], E[2], E[3]), -det3(E[0], E[1], E[3]),
         det3(E[0], E[1], E[2])]
    total = sum(C)
    sigma = -1 if total > 0 else (1 if total < 0 else 0)
    lengths = [sum(x * x for x in e) for e in E]
    return sigma, C, lengths


def _exact_sign(V, w, tet, q) -> int:
    sigma, C, lengths = _exact_lifted(V, w, tet, q)
    wq = Fraction(float(w[q]))
    D = sum(c * (s - (Fraction(float(w[i])) - wq)) for c, s, i in zip(C, lengths, tet))
    return sigma * (D > 0) - sigma * (D < 0)


@dataclasses.dataclass(frozen=True)
class MarginCheck:
    """The result of :func:`check_margins`.

    Attributes
    ----------
    proved : bool, every interior face strictly locally regular, seen from both tets.
    sign : (f,) int8, per interior face the smaller sign of its two views' lifted
        determinants: 1 (strictly locally regular), 0 (cospherical: the lifted points on
        one hyperplane; without the exact test, within rounding of it), -1 (not locally
        regular, or folded).
    exact : int, face views whose sign needed exact arithmetic (within rounding of 0).
    """

    proved: bool
    sign: np.ndarray
    exact: int

    @property
    def failed(self) -> np.ndarray:
        """(k,) int64, the interior faces that are not strictly locally regular."""
        return np.flatnonzero(self.sign <= 0)


def check_margins(V, T, interior, w, exact: bool = True, threads: int | None = None
                  ) -> MarginCheck:
    """Whether the weights ``w`` (n,) make every interior face of ``(V, T)`` strictly
    locally regular, from both of its tets (module docstring). ``interior`` (f, 4) is the
    face table ``[tet, corner, tet, corner]`` (:func:`tetlap.diagnostics.interior_faces`
    order); ``V`` (n, 3) float64, ``T`` (m, 4) int64. With ``exact=False`` the face views
    within rounding of 0 are left undecided (sign 0) instead of being decided exactly (a
    cospherical mesh has many). ``threads``: the core's worker threads (the answer does not
    depend on them)."""
    f = len(interior)
    sign = _core.regular_signs(V, T, interior, w if w.any() else None,
                               options={"threads": threads})
    unsure = np.flatnonzero(sign == 0) if exact else np.zeros(0, dtype=np.int64)
    for k in unsure:
        t1, c1, t2, c2 = (int(x) for x in interior[k % f])
        tet, q = (T[t1], T[t2, c2]) if k < f else (T[t2], T[t1, c1])
        sign[k] = _exact_sign(V, w, [int(v) for v in tet], int(q))
    per_face = np.minimum(sign[:f], sign[f:])
    return MarginCheck(proved=bool((per_face > 0).all()), sign=per_face, exact=int(len(unsure)))


def _integer_row(V, T, face) -> tuple[dict[int, int], int]:
    """The coefficients of ``D_f(w)`` (view of the first tet) of the interior face
    ``face = [t1, c1, t2, c2]``, scaled by a positive power of two to integers:
    ``({vertex: coefficient}, scaled constant term)``."""
    t1, c1, t2, c2 = (int(x) for x in face)
    tet, q = [int(v) for v in T[t1]], int(T[t2, c2])
    sigma, C, lengths = _exact_lifted(V, None, tet, q)
    row: dict[int, Fraction] = {}
    for i, c in zip(tet, C):
        row[i] = row.get(i, Fraction(0)) - sigma * c
    row[q] = row.get(q, Fraction(0)) + sigma * sum(C)
    constant = sigma * sum(c * s for c, s in zip(C, lengths))
    scale = 1
    for value in list(row.values()) + [constant]:
        scale = max(scale, value.denominator)       # powers of two: the largest divides all
    return ({v: int(c * scale) for v, c in row.items() if c != 0}, int(constant * scale))


def _positive_null_vector(rows: list[dict[int, int]], hint: list[Fraction]) -> list[Fraction] | None:
    """``z > 0`` (exact) with ``sum_f z_f rows[f] = 0``, or None. The null space is found
    by fraction-free elimination over the integers; with more than one free unknown, the
    free ones are set to the rationals of ``hint`` (the search's multipliers)."""
    k = len(rows)
    # one equation per vertex: {face: coefficient}
    equations: dict[int, dict[int, int]] = {}
    for f, row in enumerate(rows):
        for v, a in row.items():
            equations.setdefault(v, {})[f] = a
    pending = [eq for _, eq in sorted(equations.items())]
    pivots: list[tuple[int, dict[int, int]]] = []
    while pending:
        pending.sort(key=len)
        eq = pending.pop(0)
        if not eq:
            continue
        # the unknown of this (shortest) equation with the smallest coefficient
        f = min(eq, key=lambda g: (abs(eq[g]).bit_length(), g))
        a = eq[f]
        pivots.append((f, eq))
        for other in pending:
            b = other.get(f)
            if b is None:
                continue
            for g, c in eq.items():
                other[g] = other.get(g, 0) * a - c * b if g in other else -c * b
            for g in other:
                if g not in eq:
                    other[g] *= a
            other.pop(f)
            for g in [g for g, c in other.items() if c == 0]:
                del other[g]
            divisor = 0
            for c in other.values():
                divisor = gcd(divisor, c)
            if divisor > 1:
                for g in other:
                    other[g] //= divisor
    pivot_of = {f for f, _ in pivots}
    free = [f for f in range(k) if f not in pivot_of]
    if not free:
        return None
    z: list[Fraction | None] = [None] * k
    if len(free) == 1:
        z[free[0]] = Fraction(1)
    else:
        for f in free:
            z[f] = hint[f]
    for f, eq in reversed(pivots):
        z[f] = -sum(c * z[g] for g, c in eq.items() if g != f) / eq[f]
    if all(v < 0 for v in z):
        z = [-v for v in z]
    if not all(v > 0 for v in z):
        return None
    # the identity itself, checked on its own: every vertex's coefficient vanishes
    for eq in equations.values():
        if sum(c * z[f] for f, c in eq.items()) != 0:
            return None
    return z


@dataclasses.dataclass(frozen=True)
class CertificateCheck:
    """A Gordan certificate checked in exact arithmetic.

    Attributes
    ----------
    multipliers : (k,) float64 > 0, the exact multipliers ``y`` of the faces' margins
        (rounded, normalised to sum 1): ``sum_f y_f margin_f(w)`` is 0 for every ``w``.
    """

    multipliers: np.ndarray


def check_certificate(V, T, interior, faces, hint, vertices, coefficients
                      ) -> CertificateCheck | None:
    """Checks that no weights make the interior faces ``faces`` (k,) (indices into
    ``interior``) all strictly locally regular, by an exact Gordan certificate on their
    lifted determinants (module docstring). ``hint`` (k,) > 0 are the search's multipliers
    on the faces' margins, whose rows (first tet's view) are ``vertices`` (k, 5) and
    ``coefficients`` (k, 5) (:class:`~tetlap.regular.conditions.Conditions`): they only
    choose among null vectors when there is more than one. Returns None when no positive
    exact null vector exists on these faces."""
    rows, ratios = [], []
    for f, verts, coefs in zip(faces, vertices, coefficients):
        row, _ = _integer_row(V, T, interior[f])
        rows.append(row)
        # margin_f = D_f / norm_f and row_f = scale_f D_f: row_f = ratio_f * margin row, > 0
        k = int(np.argmax(np.abs(coefs)))
        ratios.append(Fraction(row.get(int(verts[k]), 0)) / Fraction(float(coefs[k])))
    if not all(r > 0 for r in ratios):
        return None
    z = _positive_null_vector(rows, [Fraction(float(y)) / r for y, r in zip(hint, ratios)])
    if z is None:
        return None
    # the same identity on the margins: sum_f (z_f ratio_f) margin_f = 0
    y = np.array([float(v * r) for v, r in zip(z, ratios)])
    return CertificateCheck(multipliers=y / y.sum())


def exact_orientation(V, tet) -> int:
    """The exact sign (-1, 0, 1) of ``det[x1 - x0, x2 - x0, x3 - x0]`` of the four vertices
    ``tet`` of ``V`` (n, 3) float64: 0 only for an exactly flat tet."""
    X = [_exact_vector(V[int(v)]) for v in tet]
    e = [[a - b for a, b in zip(X[k], X[0])] for k in (1, 2, 3)]
    d = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
         - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
         + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
    return (d > 0) - (d < 0)


def check_folded(V, T, interior, faces) -> bool:
    """Whether every face of ``faces`` (indices into ``interior``) has both opposite
    vertices strictly on the same side of its plane (exact orientation signs)."""
    for f in faces:
        t1, c1, t2, c2 = (int(x) for x in interior[f])
        tri = [int(v) for k, v in enumerate(T[t1]) if k != c1]
        sides = [exact_orientation(V, tri + [apex]) for apex in (int(T[t1, c1]), int(T[t2, c2]))]
        if not (sides[0] == sides[1] != 0):
            return False
    return True


def check_nonmanifold(T, triangles) -> bool:
    """Whether every vertex triple of ``triangles`` (k, 3) is a face of more than two tets
    of ``T`` (counted directly)."""
    for a, b, c in np.asarray(triangles).tolist():
        holds = (T == a).any(axis=1) & (T == b).any(axis=1) & (T == c).any(axis=1)
        if holds.sum() <= 2:
            return False
    return True
