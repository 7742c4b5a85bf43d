"""``anisotropic``: ``-div(K grad u) = f`` on the FVCA6 3D benchmark's tetrahedral family,
by every operator that takes the coefficient, against the exact solution.

The meshes: ``tet_0.msh`` .. ``tet_5.msh`` of the FVCA6 3D benchmark (tetgen meshes of the
unit cube, 215 to 30,480 tets) from ``--meshes DIR``, else ``$TETLAP_FVCA6``, else
``fvca6`` beside ``$TETLAP_MESHES``, else ``../shared/data/fvca6``; ``--quick`` takes
``tet_0`` .. ``tet_2``. Two cases:

* **test 1** of the benchmark: ``K = [[1, .5, 0], [.5, 1, .5], [0, .5, 1]]``,
  ``u = 1 + sin(pi x) sin(pi (y + 1/2)) sin(pi (z + 1/3))``;
* **strong**: ``K = diag(1, 1, 1000)``, ``u = sin(2 pi x) sin(2 pi y) sin(2 pi z)``.

``f = -div(K grad u)`` is computed analytically (the Hessian of ``u`` contracted with
``K``) and ``u`` is given at the boundary vertices. The operators, each with its
constant ``K``:

* **primal**: ``laplacian(V, T, "primal", coefficient=K)`` (P1 finite elements);
* **dual**: ``laplacian(V, T, "dual", coefficient=K)``, the circumcentric dual in the
  metric ``K^-1``;
* **dual, regular weights**: the same with ``weights=regular_weights(V, T,
  coefficient=K).weights`` (power centres in the metric; the search's budget is
  :data:`REGULAR_ITERATIONS`, its status is reported);
* **cell**: ``cell_laplacian(V, T, coefficient=K)`` (two-point fluxes, harmonic
  half-transmissibilities, cell centres at the circumcentres), with ``u`` at the boundary
  faces' circumcentres through the half transmissibility of the face's tet; where
  ``cell_laplacian`` takes no coefficient, reported as not run;
* **cell, metric centres**: the same with ``centres=`` the circumcentres in the metric
  ``K^-1`` (those of the mesh mapped by ``K^-1/2``, mapped back), which make a face
  K-orthogonal wherever the mesh is Delaunay in the metric; boundary data at the faces'
  circumcentres in the metric.

Every vertex scheme takes the same load, the barycentric (lumped) mass times ``f`` at the
vertices: ``L u = -M f`` on the interior vertices. The cell schemes take ``f`` at the tet's
centroid times its volume and are compared with ``u`` at their centres.

Columns: ``l2_error``, relative and mass-weighted (``sqrt(sum M_i e_i^2 / sum M_i u_i^2)``,
barycentric masses; tet volumes for the cell scheme); ``gradient_error``, relative L2 of
the per-tet gradients of the P1 field against the exact gradient at the centroid (vertex
schemes only; first order at best); rates between consecutive meshes
(``log(e1/e2)/log(h1/h2)``, ``h`` the mean edge length); ``negative_fraction``, the
negative weights (the rule of :func:`tetlap.check`) over the edges not both on the
boundary (interior faces for the cell scheme); ``outside``, the maximum-principle count:
for the harmonic problem (``f = 0``, boundary data 1 where ``x > 1/2``, else 0) the
values out of ``[0, 1]`` beyond ``1e-12``.
"""

from __future__ import annotations

import inspect
import os
import pathlib
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg  # noqa: F401  (sp.linalg)

from .. import assembly, cells, diagnostics, io, solve
from .._progress import bar as progress
from ..analysis import negative_weights
from ..dual import dual_geometry
from ..regular import regular_weights
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["CASES", "OPERATORS", "REGULAR_ITERATIONS", "Case", "fvca6_folder", "run"]
__dir__ = public_dir(globals())

OPERATORS = ("primal", "dual", "dual, regular weights", "cell", "cell, metric centres")
#: The work budget of the regular-weights search on each mesh (``max_iterations``).
REGULAR_ITERATIONS = 300
#: The tolerance of the maximum-principle count.
OUTSIDE_TOL = 1e-12


class Case:
    """``u = c + prod_i sin(k (x_i + o_i))`` with a constant ``K``: ``u``, its gradient
    and ``f = -div(K grad u) = -sum_ij K_ij d_i d_j u``."""

    def __init__(self, name: str, label: str, K, k: float, offset, constant: float):
        self.name, self.label, self.K, self.k = name, label, np.asarray(K, dtype=float), k
        self.offset, self.constant = np.asarray(offset, dtype=float), constant

    def _parts(self, x):
        a = self.k * (x + self.offset)
        return np.sin(a), np.cos(a)

    def u(self, x):
        s, _ = self._parts(x)
        return self.constant + s.prod(axis=-1)

    def gradient(self, x):
        s, c = self._parts(x)
        return self.k * np.stack([c[..., 0] * s[..., 1] * s[..., 2],
                                  s[..., 0] * c[..., 1] * s[..., 2],
                                  s[..., 0] * s[..., 1] * c[..., 2]], axis=-1)

    def f(self, x):
        s, c = self._parts(x)
        H = np.empty(x.shape[:-1] + (3, 3))
        for i in range(3):
            for j in range(3):
                if i == j:
                    H[..., i, i] = -s.prod(axis=-1)
                else:
                    other = 3 - i - j
                    H[..., i, j] = c[..., i] * c[..., j] * s[..., other]
        return -self.k**2 * np.einsum("ij,...ij->...", self.K, H)


CASES = (
    Case("test 1", "[[1, .5, 0], [.5, 1, .5], [0, .5, 1]]",
         [[1.0, 0.5, 0.0], [0.5, 1.0, 0.5], [0.0, 0.5, 1.0]], np.pi, [0.0, 0.5, 1.0 / 3.0], 1.0),
    Case("strong", "diag(1, 1, 1000)", np.diag([1.0, 1.0, 1000.0]), 2 * np.pi, [0.0, 0.0, 0.0],
         0.0),
)


def fvca6_folder(meshes=None) -> pathlib.Path:
    """The folder of ``tet_0.msh`` .. ``tet_5.msh``: ``meshes``, else ``$TETLAP_FVCA6``,
    else ``fvca6`` beside ``$TETLAP_MESHES`` (the corpus), else ``../shared/data/fvca6``."""
    if meshes:
        return pathlib.Path(meshes)
    if os.environ.get("TETLAP_FVCA6"):
        return pathlib.Path(os.environ["TETLAP_FVCA6"])
    if os.environ.get("TETLAP_MESHES"):
        return pathlib.Path(os.environ["TETLAP_MESHES"]).parent / "fvca6"
    return pathlib.Path("../shared/data/fvca6")


def _read(path):
    with warnings.catch_warnings():     # the files' boundary triangles and lines
        warnings.simplefilter("ignore")
        V, T = io.read(path, "tetra")[:2]
    return np.ascontiguousarray(V, dtype=float), np.ascontiguousarray(T, dtype=np.int64)


def _tet_gradients(V, T, values):
    """(m, 3) gradients of the P1 interpolant of vertex ``values``."""
    D = V[T[:, 1:]] - V[T[:, :1]]
    return np.linalg.solve(D, (values[T[:, 1:]] - values[T[:, :1]])[..., None])[..., 0]


def _has_cells() -> bool:
    return "coefficient" in inspect.signature(cells.cell_laplacian).parameters


class _Vertex:
    """A vertex scheme on one mesh: its Laplacian and what the rows need."""

    def __init__(self, V, T, L):
        self.V, self.T, self.L = V, T, L
        self.fixed = diagnostics.boundary_vertices(T, len(V))
        self.M = assembly.mass(V, T, "barycentric").diagonal()
        self.volume = np.abs(np.linalg.det(V[T[:, 1:]] - V[T[:, :1]])) / 6

    def solve(self, case: Case):
        V, T = self.V, self.T
        u = case.u(V)
        x = solve.dirichlet(self.L, self.fixed, u, rhs=-self.M * case.f(V))
        l2 = np.sqrt(np.sum(self.M * (x - u) ** 2) / np.sum(self.M * u**2))
        exact = case.gradient(V[T].mean(axis=1))
        e = _tet_gradients(V, T, x) - exact
        gradient = np.sqrt(np.sum(self.volume * (e**2).sum(axis=1))
                           / np.sum(self.volume * (exact**2).sum(axis=1)))
        return float(l2), float(gradient)

    def outside(self) -> int:
        step = (self.V[:, 0] > 0.5).astype(float)
        x = solve.dirichlet(self.L, self.fixed, step)
        free = ~self.fixed
        return int(((x[free] < -OUTSIDE_TOL) | (x[free] > 1 + OUTSIDE_TOL)).sum())

    def negative_fraction(self) -> float:
        _, negative = negative_weights(self.L, self.V, self.T, self.fixed)
        E = diagnostics.mesh_edges(self.T)
        interior = int((~(self.fixed[E[:, 0]] & self.fixed[E[:, 1]])).sum())
        return negative / interior


class _Cell:
    """The two-point flux scheme with ``K`` on one mesh (cell centres: the circumcentres,
    or with ``metric`` those in the metric ``K^-1``), ``u`` given at the boundary faces'
    centres through the half transmissibility ``|f| (K n) . (x_f - x_t) / |x_f - x_t|^2``
    of the face's tet (``n`` pointing out of it: negative for a centre beyond the face)."""

    def __init__(self, V, T, K, metric: bool):
        self.V, self.T, self.K = V, T, K
        lam, Q = np.linalg.eigh(K)
        root, inverse_root = (Q * np.sqrt(lam)) @ Q.T, (Q / np.sqrt(lam)) @ Q.T
        g = dual_geometry(V, T)
        mapped = dual_geometry(V @ inverse_root, T) if metric else g
        self.centres = mapped.centres @ root if metric else g.centres
        face_centres = mapped.face_centres @ root if metric else g.face_centres
        self.Lc = sp.csr_array(cells.cell_laplacian(
            V, T, coefficient=K, centres=self.centres if metric else None))
        b = np.flatnonzero(g.boundary_faces)
        self.tet = g.face_tets[b, 0]
        F = V[g.faces[b]]
        n = np.cross(F[:, 1] - F[:, 0], F[:, 2] - F[:, 0])
        n /= np.linalg.norm(n, axis=1)[:, None]
        n[np.einsum("fi,fi->f", V[T[self.tet]].mean(axis=1) - F[:, 0], n) > 0] *= -1
        self.face_centres = face_centres[b]
        d = self.face_centres - self.centres[self.tet]
        self.half = g.face_area[b] * np.einsum("fi,ij,fj->f", n, K, d) / (d * d).sum(1)
        self.A = self.Lc - sp.diags_array(np.bincount(self.tet, self.half, len(T)))
        self.lu = None
        self.volume = g.volume
        self.load_points = V[T].mean(axis=1)

    def _solve(self, source, face_values):
        if self.lu is None:     # one LU for both problems (A can be indefinite)
            self.lu = sp.linalg.splu(sp.csc_array(-self.A))
        rhs = source - np.bincount(self.tet, self.half * face_values, len(self.T))
        return self.lu.solve(-rhs)

    def solve(self, case: Case):
        c = self._solve(-self.volume * case.f(self.load_points), case.u(self.face_centres))
        u = case.u(self.centres)
        l2 = np.sqrt(np.sum(self.volume * (c - u) ** 2) / np.sum(self.volume * u**2))
        return float(l2), float("nan")

    def outside(self) -> int:
        step = (self.face_centres[:, 0] > 0.5).astype(float)
        c = self._solve(np.zeros(len(self.T)), step)
        return int(((c < -OUTSIDE_TOL) | (c > 1 + OUTSIDE_TOL)).sum())

    def negative_fraction(self) -> float:
        off = sp.triu(self.Lc, k=1, format="coo")
        scale = np.abs(off.data).max()
        return float((off.data < -1e-12 * scale).sum() / max(len(off.data), 1))


def _schemes(V, T, K):
    """name -> scheme (or a note why not run), and the regular weights' status."""
    out = {"primal": _Vertex(V, T, assembly.laplacian(V, T, "primal", coefficient=K)),
           "dual": _Vertex(V, T, assembly.laplacian(V, T, "dual", coefficient=K))}
    r = regular_weights(V, T, coefficient=K, max_iterations=REGULAR_ITERATIONS)
    out["dual, regular weights"] = _Vertex(
        V, T, assembly.laplacian(V, T, "dual", coefficient=K, weights=r.weights))
    for name, metric in (("cell", False), ("cell, metric centres", True)):
        try:
            out[name] = (_Cell(V, T, K, metric) if _has_cells() else
                         "not run: cell_laplacian takes no coefficient in this version")
        except ValueError as e:     # a degenerate face, for instance
            out[name] = "not run: " + " ".join(str(e).split())[:160]
    return out, r.status


def run(out, meshes=None) -> None:
    folder = fvca6_folder(meshes)
    files = [folder / f"tet_{i}.msh" for i in range(3 if out.quick else 6)]
    missing = [p.name for p in files if not p.is_file()]
    if missing:
        out.say(f"FVCA6 meshes not found in {folder} ({', '.join(missing)}): give --meshes "
                "DIR or set TETLAP_FVCA6")
        return
    out.say(f"meshes: {folder} (tet_0 .. tet_{len(files) - 1}); load: barycentric mass "
            "times f at the vertices (cells: volume times f at the centroid)")
    jobs = [(case, path) for case in CASES for path in files]
    for case, path in progress(jobs, desc="anisotropic"):
        V, T = _read(path)
        E = diagnostics.mesh_edges(T)
        h = float(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean())
        schemes, status = _schemes(V, T, case.K)
        for name in OPERATORS:
            row = {"case": case.name, "mesh": path.stem, "n_vertices": len(V), "n_tets": len(T),
                   "h": h, "operator": name}
            scheme = schemes[name]
            if isinstance(scheme, str):
                out.row(**row, l2_error=float("nan"), gradient_error=float("nan"),
                        negative_fraction=float("nan"), outside=-1, note=scheme)
                continue
            row["l2_error"], row["gradient_error"] = scheme.solve(case)
            row["negative_fraction"] = scheme.negative_fraction()
            row["outside"] = scheme.outside()
            row["note"] = status if "regular" in name else ""
            out.row(**row)
    _rates(out.rows)
    _summary(out)
    out.figure("errors.png", lambda plt: _figure(plt, out.rows))


def _rates(rows) -> None:
    """``l2_rate`` and ``gradient_rate`` against the previous mesh of the same case and
    operator (empty on the first)."""
    for r in rows:
        previous = [p for p in rows[:rows.index(r)]
                    if p["case"] == r["case"] and p["operator"] == r["operator"]]
        for key in ("l2", "gradient"):
            rate = ""
            if previous:
                p = previous[-1]
                with np.errstate(all="ignore"):
                    value = np.log(p[f"{key}_error"] / r[f"{key}_error"]) / np.log(p["h"] / r["h"])
                rate = "" if not np.isfinite(value) else round(float(value), 3)
            r[f"{key}_rate"] = rate


def _summary(out) -> None:
    out.say("-div(K grad u) = f, u exact on the boundary; relative L2 (mass-weighted) and "
            "gradient errors, rates log(e1/e2)/log(h1/h2); neg: negative interior weights; "
            "outside: harmonic values out of [0, 1]")
    for case in CASES:
        out.say(f"{case.name}: K = {case.label}")
        out.say(f"  {'operator':<22} {'mesh':<6} {'tets':>6} {'h':>7} {'L2 error':>9} "
                f"{'rate':>5} {'grad err':>9} {'rate':>5} {'neg':>6} {'outside':>7}  weights")
        for r in (r for r in out.rows if r["case"] == case.name):
            if r["outside"] < 0:
                out.say(f"  {r['operator']:<22} {r['mesh']:<6} {r['note']}")
                continue
            out.say(f"  {r['operator']:<22} {r['mesh']:<6} {r['n_tets']:>6} {r['h']:>7.4f} "
                    f"{r['l2_error']:>9.2e} {r['l2_rate']!s:>5.5} "
                    f"{_number(r['gradient_error']):>9} "
                    f"{r['gradient_rate']!s:>5.5} {100 * r['negative_fraction']:>5.1f}% "
                    f"{r['outside']:>7}  {r['note']}")


def _number(value: float) -> str:
    return "-" if np.isnan(value) else f"{value:.2e}"


def _figure(plt, rows):
    fig, axes = plt.subplots(1, len(CASES), figsize=(5.5 * len(CASES), 4.2),
                             layout="constrained", squeeze=False)
    for ax, case in zip(axes[0], CASES):
        mine = [r for r in rows if r["case"] == case.name and r["outside"] >= 0]
        for name, marker in zip(OPERATORS, "os^vD"):
            points = [(r["h"], r["l2_error"]) for r in mine if r["operator"] == name]
            if points:
                ax.loglog(*zip(*points), marker=marker, label=name)
        h = np.array(sorted({r["h"] for r in mine}))
        primal = [r["l2_error"] for r in mine if r["operator"] == "primal"]
        ax.loglog(h, primal[0] * (h / h.max()) ** 2, "k:", label="h^2")
        log_ticks(ax)
        ax.set_xlabel("mean edge length h")
        ax.set_ylabel("relative L2 error")
        ax.set_title(f"{case.name}: K = {case.label}", fontsize=9)
        ax.legend(fontsize=8)
    return fig
