"""``finite-volumes``: a Poisson problem on the unit ball solved by the two finite-volume
schemes of the orthogonal dual, against the exact solution.

The exact solution ``u = x^4 + y^2 z^2 - x y z + z`` (``Laplace(u) = 12 x^2 + 2 y^2 + 2
z^2``; every scheme here reproduces linear functions, and the vertex dual even
``|x|^2``, so a quartic is the first test that shows a rate) on the polyhedral ball, in
three schemes:

* **vertex dual, Dirichlet**: ``L u = M Laplace(u)`` on the interior vertices
  (``L = laplacian(V, T, "dual")``, ``M`` the control volumes), ``u`` exact on the
  boundary vertices; error at the interior vertices.
* **cell, Neumann**: ``Lc u = int_t Laplace(u) - g_t`` on the tets
  (``Lc = cell_laplacian(V, T)``, ``g_t`` the exact outward flux of ``u`` through the
  boundary faces of tet ``t``; both integrals exact by quadrature), a pure Neumann problem
  (zero mean); error at the centres after removing the volume-weighted mean difference.
* **cell, Dirichlet faces**: the same with ``u`` given at the boundary faces' centres,
  coupled through ``A_f / l_f`` (the boundary dual edge from the tet's centre to the
  face's centre), as :func:`tetlap.cell_laplacian` describes.
* **cell, Neumann, regular weights**: the Neumann scheme on the power dual of
  ``tetlap.regular_weights(V, T).weights`` (power centres; zero weights on a Delaunay
  mesh), whose interior weights are all positive on a regular mesh.

Errors: the maximum and the volume-weighted L2 norm (barycentric masses at vertices, tet
volumes at cells), against the mean edge length ``h``; rates between consecutive sizes.
Families: random Delaunay balls (:func:`tetlap.meshes.ball`) and, when gmsh is
installed, optimized Delaunay balls (:func:`tetlap.meshes.optimized_ball`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import assembly, diagnostics, meshes, solve
from .._progress import bar as progress
from ..cells import cell_laplacian
from ..dual import dual_geometry
from ..regular import regular_weights
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["SCHEMES", "exact", "gradient", "laplacian", "vertex_dual", "cell_neumann",
           "cell_dirichlet", "cell_neumann_regular", "run"]
__dir__ = public_dir(globals())

SCHEMES = ("vertex dual, Dirichlet", "cell, Neumann", "cell, Dirichlet faces",
           "cell, Neumann, regular weights")

# quadrature: a degree-2 rule on tets (exact for Laplace(u)), a degree-3 rule on triangles
# (exact for grad(u) . n)
_A, _B = 0.5854101966249685, 0.1381966011250105
_TET = np.array([[_A, _B, _B, _B], [_B, _A, _B, _B], [_B, _B, _A, _B], [_B, _B, _B, _A]])
_TRI = np.array([[1 / 3] * 3, [0.6, 0.2, 0.2], [0.2, 0.6, 0.2], [0.2, 0.2, 0.6]])
_TRI_WEIGHTS = np.array([-27 / 48, 25 / 48, 25 / 48, 25 / 48])


def exact(x: np.ndarray) -> np.ndarray:
    """The exact solution ``u`` at the points ``x`` (..., 3)."""
    X, Y, Z = x[..., 0], x[..., 1], x[..., 2]
    return X**4 + Y**2 * Z**2 - X * Y * Z + Z


def gradient(x: np.ndarray) -> np.ndarray:
    X, Y, Z = x[..., 0], x[..., 1], x[..., 2]
    return np.stack([4 * X**3 - Y * Z, 2 * Y * Z**2 - X * Z, 2 * Y**2 * Z - X * Y + 1], axis=-1)


def laplacian(x: np.ndarray) -> np.ndarray:
    return 12 * x[..., 0] ** 2 + 2 * x[..., 1] ** 2 + 2 * x[..., 2] ** 2


def vertex_dual(V, T, u=exact, lap=laplacian):
    """(max error, L2 error, unknowns) of the vertex dual with Dirichlet data."""
    L, M = assembly.operators(V, T, "dual", "circumcentric")
    fixed = diagnostics.boundary_vertices(T, len(V))
    f = solve.dirichlet(L, fixed, u(V), rhs=M.diagonal() * lap(V))
    free = ~fixed & diagnostics.referenced_vertices(T, len(V))
    e = np.abs(f - u(V))[free]
    weight = assembly.mass(V, T).diagonal()[free]
    return float(e.max()), float(np.sqrt(np.sum(weight * e**2))), int(free.sum())


def _cells(V, T, weights=None):
    """The dual geometry, the cell Laplacian, the exact source per tet and the boundary
    faces' tets and outward fluxes."""
    g = dual_geometry(V, T, weights=weights)
    Lc = cell_laplacian(V, T, weights=weights)
    source = g.volume * laplacian(np.einsum("qk,tkc->tqc", _TET, V[T])).mean(axis=1)
    b = g.boundary_faces
    tet, F = g.face_tets[b, 0], V[g.faces[b]]
    n = np.cross(F[:, 1] - F[:, 0], F[:, 2] - F[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[np.einsum("ij,ij->i", V[T[tet]].mean(axis=1) - F[:, 0], n) > 0] *= -1  # outward
    points = np.einsum("qk,fkc->fqc", _TRI, F)
    flux = g.face_area[b] * (np.einsum("fqc,fc->fq", gradient(points), n) @ _TRI_WEIGHTS)
    return g, Lc, source, tet, flux


def _cell_errors(g, c):
    e = np.abs(c - exact(g.centres))
    return float(e.max()), float(np.sqrt(np.sum(g.volume * e**2))), len(c)


def cell_neumann(V, T, weights=None):
    """(max error, L2 error, unknowns) of the cell scheme with the exact boundary fluxes
    (on the power dual of ``weights``)."""
    g, Lc, source, tet, flux = _cells(V, T, weights)
    c = solve.neumann(Lc, np.bincount(tet, flux, len(T)), rhs=source)
    d = c - exact(g.centres)
    return _cell_errors(g, c - np.sum(g.volume * d) / g.volume.sum())


def cell_dirichlet(V, T):
    """(max error, L2 error, unknowns) of the cell scheme with ``u`` at the boundary faces'
    centres."""
    g, Lc, source, tet, _ = _cells(V, T)
    b = g.boundary_faces
    w = g.face_area[b] / g.dual_length[b]
    A = Lc - sp.diags_array(np.bincount(tet, w, len(T)))
    rhs = source - np.bincount(tet, w * exact(g.face_centres[b]), len(T))
    return _cell_errors(g, solve.factorize(-A).solve(-rhs))


def cell_neumann_regular(V, T):
    """:func:`cell_neumann` on the power dual of the mesh's regular weights."""
    r = regular_weights(V, T)
    if not r.regular:
        raise ValueError(f"regular_weights: {r.status}")
    return cell_neumann(V, T, r.weights)


def run(out) -> None:
    quick, seed = out.quick, out.seed
    jobs = [("random Delaunay", n) for n in ([500, 1000, 2000] if quick else [1000, 4000, 16000, 64000])]
    try:
        meshes._gmsh()
        jobs += [("optimized (gmsh)", h) for h in ([0.3, 0.2, 0.15] if quick else [0.2, 0.1, 0.05])]
    except ImportError as e:
        out.say(f"optimized meshes skipped: {e}")
    solvers = dict(zip(SCHEMES, (vertex_dual, cell_neumann, cell_dirichlet, cell_neumann_regular)))
    for family, size in progress(jobs, desc="finite-volumes"):
        V, T = meshes.optimized_ball(size, seed=seed) if family.startswith("optimized") else (
            meshes.ball(size, seed=seed))
        g = dual_geometry(V, T)
        inner = ~g.boundary_faces
        stats = {"family": family, "size": size, "n_vertices": len(V), "n_tets": len(T),
                 "h": float(g.edge_length.mean()),
                 "centres_outside": float(g.outside.mean()),
                 "negative_interior_dual_edges": int((g.dual_length[inner] < 0).sum()),
                 "negative_boundary_dual_edges": int((g.dual_length[~inner] < 0).sum())}
        for scheme, solver in solvers.items():
            row = dict(stats, scheme=scheme)
            try:
                row["max_error"], row["l2_error"], row["unknowns"] = solver(V, T)
            except Exception as e:  # a singular or indefinite system, for instance
                row["max_error"] = row["l2_error"] = float("nan")
                row["note"] = " ".join(str(e).split())[:200]
            out.row(**row)

    out.say("u = x^4 + y^2 z^2 - x y z + z on the unit ball; errors against the mean edge "
            "length h, rates log(e1/e2)/log(h1/h2)")
    for family in dict.fromkeys(r["family"] for r in out.rows):
        out.say(f"{family}:")
        out.say(f"  {'scheme':<30} {'n':>7} {'tets':>8} {'h':>8} {'max error':>10} {'rate':>5} "
                f"{'L2 error':>10} {'rate':>5}")
        for scheme in SCHEMES:
            mine = [r for r in out.rows if r["family"] == family and r["scheme"] == scheme]
            for k, r in enumerate(mine):
                if "note" in r:
                    out.say(f"  {scheme:<30} {r['n_vertices']:>7} n/a: {r['note']}")
                    continue
                rates = ["", ""]
                if k and "note" not in mine[k - 1]:
                    p = mine[k - 1]
                    step = np.log(p["h"] / r["h"])
                    rates = [f"{np.log(p[e] / r[e]) / step:.2f}" for e in ("max_error", "l2_error")]
                out.say(f"  {scheme:<30} {r['n_vertices']:>7} {r['n_tets']:>8} {r['h']:>8.4f} "
                        f"{r['max_error']:>10.3e} {rates[0]:>5} {r['l2_error']:>10.3e} "
                        f"{rates[1]:>5}")
        first = next(r for r in out.rows if r["family"] == family)
        last = [r for r in out.rows if r["family"] == family][-1]
        span = lambda key: f"{first[key]} - {last[key]}"
        out.say(f"  centres outside their tets: {100 * first['centres_outside']:.0f}% - "
                f"{100 * last['centres_outside']:.0f}%; negative dual edges, interior: "
                f"{span('negative_interior_dual_edges')}, boundary: "
                f"{span('negative_boundary_dual_edges')}")

    def errors(plt):
        families = list(dict.fromkeys(r["family"] for r in out.rows))
        fig, axes = plt.subplots(1, len(families), figsize=(5.5 * len(families), 4.2),
                                 layout="constrained", squeeze=False)
        for ax, family in zip(axes[0], families):
            for scheme, marker in zip(SCHEMES, "os^v"):
                mine = [r for r in out.rows if r["family"] == family and r["scheme"] == scheme
                        and "note" not in r]
                ax.loglog([r["h"] for r in mine], [r["l2_error"] for r in mine], marker=marker,
                          label=scheme)
            h = np.array([r["h"] for r in out.rows if r["family"] == family])
            ax.loglog(h, 0.5 * (h / h.max()) ** 2 * max(r["l2_error"] for r in out.rows
                                                         if r["family"] == family
                                                         and "note" not in r),
                      "k:", label="h^2")
            log_ticks(ax)
            ax.set_xlabel("mean edge length h")
            ax.set_ylabel("L2 error")
            ax.set_title(family)
            ax.legend(fontsize=8)
        return fig

    out.figure("errors.png", errors)
