"""Exact rational reference implementation (``fractions.Fraction``) of both Laplacians and
the circumcentric mass of small tet meshes with rational coordinates.

Deliberately a different route from tetlap's kernels: the primal from the inverse of the
edge matrix (gradients of the barycentric coordinates), the dual from explicit
circumcenters and the signed piece determinants of SPEC §2 / paper Eq. 17-21, without
cotangents or barycentric coordinates of the circumcenter.
"""

from __future__ import annotations

from fractions import Fraction
from itertools import combinations

EDGES = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def vec(p):
    return [Fraction(x) for x in p]


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def scale(a, s):
    return [x * s for x in a]


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def det3(a, b, c):
    return dot(a, cross(b, c))


def sign(x):
    return (x > 0) - (x < 0)


def solve3(rows, rhs):
    """Cramer's rule for a 3 x 3 system with rows ``rows``."""
    d = det3(*rows)
    cols = list(zip(*rows))
    out = []
    for k in range(3):
        m = [list(c) for c in cols]
        m[k] = rhs
        out.append(det3(*[list(r) for r in zip(*m)]) / d)
    return out


def triangle_circumcenter(a, b, c):
    """The circumcenter of triangle abc in 3D: in its plane, equidistant from a, b, c."""
    u, v = sub(b, a), sub(c, a)
    n = cross(u, v)
    x = solve3([u, v, n], [dot(u, u) / 2, dot(v, v) / 2, Fraction(0)])
    return add(a, x)


def tet_circumcenter(a, b, c, d):
    u, v, w = sub(b, a), sub(c, a), sub(d, a)
    return add(a, solve3([u, v, w], [dot(u, u) / 2, dot(v, v) / 2, dot(w, w) / 2]))


def piece(xa, xb, xc, xd):
    """v(a, b, c): the signed volume of (x_a, c_ab, c_abc, c_abcd) (SPEC §2)."""
    cab = scale(add(xa, xb), Fraction(1, 2))
    cabc = triangle_circumcenter(xa, xb, xc)
    cabcd = tet_circumcenter(xa, xb, xc, xd)
    v = det3(sub(cab, xa), sub(cabc, xa), sub(cabcd, xa)) / 6
    return v * sign(det3(sub(xb, xa), sub(xc, xa), sub(xd, xa)))


def dual_tet(X):
    """(six weights, four cell volumes) of one tet ``X`` (4 rational points)."""
    w = []
    cells = [Fraction(0)] * 4
    for a, b in EDGES:
        k, l = [c for c in range(4) if c not in (a, b)]
        v = piece(X[a], X[b], X[k], X[l]) + piece(X[a], X[b], X[l], X[k])
        d = sub(X[a], X[b])
        w.append(6 * v / dot(d, d))
    for a in range(4):
        for b in range(4):
            for c in range(4):
                if len({a, b, c}) == 3:
                    dd = ({0, 1, 2, 3} - {a, b, c}).pop()
                    cells[a] += piece(X[a], X[b], X[c], X[dd])
    return w, cells


def primal_tet(X):
    """Six primal weights: minus Vol * grad(lambda_a) . grad(lambda_b)."""
    e = [sub(X[k], X[0]) for k in (1, 2, 3)]
    vol = abs(det3(*e)) / 6
    # grad(lambda_k), k = 1..3: rows of E^-T, i.e. g_k . e_j = delta_kj
    grads = [solve3(e, [Fraction(int(j == k)) for j in range(3)]) for k in range(3)]
    grads = [scale(add(add(grads[0], grads[1]), grads[2]), -1)] + grads
    return [-vol * dot(grads[a], grads[b]) for a, b in EDGES]


def assemble(V, T, kind):
    """Dense exact L (list of lists) and, for the dual, the circumcentric masses."""
    n = len(V)
    P = [vec(p) for p in V]
    L = [[Fraction(0)] * n for _ in range(n)]
    mass = [Fraction(0)] * n
    for tet in T:
        X = [P[i] for i in tet]
        if kind == "dual":
            w, cells = dual_tet(X)
            for a in range(4):
                mass[tet[a]] += cells[a]
        else:
            w = primal_tet(X)
        for (a, b), we in zip(EDGES, w):
            i, j = tet[a], tet[b]
            L[i][j] += we
            L[j][i] += we
            L[i][i] -= we
            L[j][j] -= we
    return L, mass
