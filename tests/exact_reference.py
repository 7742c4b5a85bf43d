"""Exact rational reference implementation (``fractions.Fraction``) of both Laplacians and
the circumcentric mass of small tet meshes with rational coordinates (and rational vertex
weights: the power-diagram dual).

Deliberately a different route from tetlap's kernels: the primal from the inverse of the
edge matrix (gradients of the barycentric coordinates), the dual from explicit
circumcenters (power centres) solved by Cramer's rule and the signed piece determinants of
SPEC §2 / paper Eq. 17-21, without cotangents or barycentric coordinates of the centres.
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


def edge_center(a, b, wa=0, wb=0):
    """The power point of edge ab: on its line, equal power ``|p - x|^2 - w`` to a and b."""
    u = sub(b, a)
    return add(a, scale(u, (dot(u, u) + wa - wb) / (2 * dot(u, u))))


def triangle_circumcenter(a, b, c, wa=0, wb=0, wc=0):
    """The power centre of triangle abc in 3D: in its plane, equal power to a, b, c (the
    circumcenter for zero weights)."""
    u, v = sub(b, a), sub(c, a)
    n = cross(u, v)
    x = solve3([u, v, n], [(dot(u, u) + wa - wb) / 2, (dot(v, v) + wa - wc) / 2, Fraction(0)])
    return add(a, x)


def tet_circumcenter(a, b, c, d, wa=0, wb=0, wc=0, wd=0):
    """The power centre of tet abcd: equal power to its corners."""
    u, v, w = sub(b, a), sub(c, a), sub(d, a)
    return add(a, solve3([u, v, w], [(dot(u, u) + wa - wb) / 2, (dot(v, v) + wa - wc) / 2,
                                     (dot(w, w) + wa - wd) / 2]))


def triangle_barycentric(P, q):
    """The barycentric coordinates of ``q`` (in the plane of the triangle ``P``): the
    signed areas of the sub-triangles over the triangle's."""
    n = cross(sub(P[1], P[0]), sub(P[2], P[0]))
    return [dot(cross(sub(P[(i + 1) % 3], q), sub(P[(i + 2) % 3], q)), n) / dot(n, n)
            for i in range(3)]


def tet_barycentric(P, q):
    """The barycentric coordinates of ``q`` in the tet ``P`` (Cramer's rule)."""
    M = [[P[k][c] - P[0][c] for k in (1, 2, 3)] for c in range(3)]
    rest = solve3(M, sub(q, P[0]))
    return [1 - sum(rest)] + rest


def centres(X, W, placement):
    """The dual vertices of the tet ``X``: edge points, face points (by the face's three
    corners, sorted) and the tet's point, placed by ``placement``: ``"centres"`` (power
    centres), ``"centroids"`` (SPEC §2's barycentric boundary fix: a face or tet centre
    not strictly inside its simplex becomes its centroid) or ``"snapped"`` (the mixed
    mass: a face centre outside its triangle becomes the midpoint of the edge opposite its
    most negative coordinate, a tet centre outside the tet the (snapped) point of the
    face opposite its most negative coordinate)."""
    edges = {(a, b): edge_center(X[a], X[b], W[a], W[b]) for a, b in EDGES}
    faces = {}
    for f in [(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)]:
        c = triangle_circumcenter(*[X[i] for i in f], *[W[i] for i in f])
        beta = triangle_barycentric([X[i] for i in f], c)
        if placement == "centroids" and min(beta) <= 0:
            c = scale(add(add(X[f[0]], X[f[1]]), X[f[2]]), Fraction(1, 3))
        elif placement == "snapped" and min(beta) < 0:
            j = beta.index(min(beta))
            p, q = [f[i] for i in range(3) if i != j]
            c = scale(add(X[p], X[q]), Fraction(1, 2))
        faces[f] = c
    t = tet_circumcenter(*X, *W)
    lam = tet_barycentric(X, t)
    if placement == "centroids" and min(lam) <= 0:
        t = scale(add(add(X[0], X[1]), add(X[2], X[3])), Fraction(1, 4))
    elif placement == "snapped" and min(lam) < 0:
        j = lam.index(min(lam))
        t = faces[tuple(i for i in range(4) if i != j)]
    return edges, faces, t


def piece(X, C, a, b, c, d):
    """v(a, b, c): the signed volume of (x_a, c_ab, c_abc, c_abcd) (SPEC §2) for the dual
    vertices ``C`` of :func:`centres`."""
    edges, faces, t = C
    xa = X[a]
    cab = edges[tuple(sorted((a, b)))]
    cabc = faces[tuple(sorted((a, b, c)))]
    v = det3(sub(cab, xa), sub(cabc, xa), sub(t, xa)) / 6
    return v * sign(det3(sub(X[b], xa), sub(X[c], xa), sub(X[d], xa)))


def dual_tet(X, W=None, placement="centres"):
    """(six weights, four cell volumes) of one tet ``X`` (4 rational points), with rational
    vertex weights ``W`` (None: the circumcentric dual) and dual vertices placed by
    ``placement`` (see :func:`centres`). The weight of edge ab is the dual face's area over
    ``|ab|``: ``3 (v(a,b,k) + v(b,a,k) + v(a,b,l) + v(b,a,l)) / |ab|^2`` (for zero weights
    both apex pyramids are equal and this is Eq. 20)."""
    W = [Fraction(0)] * 4 if W is None else [Fraction(x) for x in W]
    C = centres(X, W, placement)
    w = []
    cells = [Fraction(0)] * 4
    for a, b in EDGES:
        k, l = [c for c in range(4) if c not in (a, b)]
        v = (piece(X, C, a, b, k, l) + piece(X, C, b, a, k, l) + piece(X, C, a, b, l, k)
             + piece(X, C, b, a, l, k))
        d = sub(X[a], X[b])
        w.append(3 * v / dot(d, d))
    for a in range(4):
        for b in range(4):
            for c in range(4):
                if len({a, b, c}) == 3:
                    dd = ({0, 1, 2, 3} - {a, b, c}).pop()
                    cells[a] += piece(X, C, a, b, c, dd)
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
