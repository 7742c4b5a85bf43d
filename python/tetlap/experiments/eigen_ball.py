"""``eigen-ball``: Dirichlet eigenvalues of the unit ball (paper Sec. 8.2, Fig. 10/11).

The exact eigenvalues of -Laplace on the unit ball with f = 0 on the sphere are the
squares of the zeros of the spherical Bessel functions j_l, each with multiplicity
2 l + 1. Compared: the 32 smallest of -L_II f = lambda M_II f (Eq. 30) for the primal and
dual Laplacian with barycentric and circumcentric masses, on random Delaunay balls,
optimized balls from gmsh (HXT: not Delaunay), optimized *Delaunay* balls from TetGen
(quality constrained Delaunay refinement, up to about 1M tets; the optional ``tetgen``
package), and a non-Delaunay weighted ball. The paper's claim "for optimized Delaunay
meshes the dual converges faster" is decided on the TetGen family by the slopes of the
mean deviation against the number of vertices.
"""
from __future__ import annotations

import numpy as np

from .. import _extras, assembly, diagnostics, meshes, solve
from .._progress import bar as progress
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["K", "PAIRS", "ball_eigenvalues", "run"]
__dir__ = public_dir(globals())

K = 32
PAIRS = (("primal", "barycentric"), ("primal", "circumcentric"),
         ("dual", "barycentric"), ("dual", "circumcentric"))


def ball_eigenvalues(k: int = K) -> np.ndarray:
    """The k smallest Dirichlet eigenvalues of the unit ball, with multiplicity."""
    from scipy.optimize import brentq
    from scipy.special import spherical_jn

    values = []
    for l in range(12):
        x = np.linspace(0.5, 40, 8000)
        y = spherical_jn(l, x)
        for a, b, ya, yb in zip(x[:-1], x[1:], y[:-1], y[1:]):
            if ya * yb < 0:
                values += [brentq(lambda t: spherical_jn(l, t), a, b) ** 2] * (2 * l + 1)
    return np.sort(values)[:k]


def tetgen_ball(h: float):
    """An optimized Delaunay mesh of the unit ball from TetGen: an icosphere (vertices on
    the sphere, edges about ``h``) refined inside to tets of edge about ``h`` with
    radius-edge ratio at most 1.4 and dihedral angles of at least 10 degrees (TetGen's
    quality Delaunay refinement)."""
    try:
        import pyvista as pv
        import tetgen
    except ImportError:
        raise ImportError("optimized Delaunay meshes need tetgen: "
                          f"{_extras.hint('experiments')}") from None
    import warnings

    nsub = max(1, int(round(np.log2(1.1 / h))))   # icosphere edges about 1.1 / 2^nsub
    sphere = pv.Icosphere(radius=1.0, nsub=nsub)
    P = np.asarray(sphere.points, dtype=np.float64)
    sphere.points = P / np.linalg.norm(P, axis=1)[:, None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        V, T = tetgen.TetGen(sphere).tetrahedralize(
            quality=True, minratio=1.4, mindihedral=10.0, fixedvolume=True, steinerleft=-1,
            maxvolume=h**3 / (6 * np.sqrt(2)))[:2]
    V, T = meshes.compact(np.asarray(V, dtype=np.float64), np.asarray(T, dtype=np.int64))
    return V, meshes.orient(V, T)


def slope(rows) -> float:
    """The exponent ``p`` of ``deviation ~ n_vertices^p`` fitted over ``rows``."""
    good = [r for r in rows if np.isfinite(r["mean_relative_deviation"])]
    if len(good) < 2:
        return float("nan")
    x = np.log([r["n_vertices"] for r in good])
    y = np.log([r["mean_relative_deviation"] for r in good])
    return float(np.polyfit(x, y, 1)[0])


def run(out) -> None:
    quick, seed = out.quick, out.seed
    exact = ball_eigenvalues()
    sizes = [1000, 3000] if quick else [2000, 8000, 32000, 64000]
    heights = [0.25, 0.15] if quick else [0.2, 0.12, 0.08, 0.06]
    jobs = [("random Delaunay", n) for n in sizes]
    jobs += [("weighted Delaunay (non-Delaunay)", n) for n in sizes[-1:]]
    try:
        meshes._gmsh()
        jobs = [("optimized (gmsh)", h) for h in heights] + jobs
    except ImportError as e:
        out.say(f"optimized meshes skipped: {e}")
    try:
        import tetgen  # noqa: F401

        # icosphere edges 1.1 / 2^j: the surface and the inside refined together (the
        # finest, 0.041 inside a surface of 0.034: about 1M tets)
        steps = [0.275, 0.1375] if quick else [0.275, 0.1375, 0.06875, 0.041]
        jobs = [("optimized Delaunay (TetGen)", h) for h in steps] + jobs
    except ImportError:
        out.say(f"optimized Delaunay meshes skipped: tetgen is not installed: "
                f"{_extras.hint('experiments')}")
    spectra = {}
    for family, size in progress(jobs, desc="eigen-ball"):
        if family.startswith("optimized Delaunay"):
            V, T = tetgen_ball(size)
        elif family.startswith("optimized"):
            V, T = meshes.optimized_ball(size, seed=seed)
        elif family.startswith("weighted"):
            V, T = meshes.weighted_ball(size, 1.0, seed=seed)
        else:
            V, T = meshes.ball(size, seed=seed)
        fixed = diagnostics.boundary_vertices(V, T)
        for lap, mass in PAIRS:
            L, M = assembly.operators(V, T, lap, mass)
            row = {"family": family, "size": size, "n_vertices": len(V), "n_tets": len(T),
                   "laplacian": lap, "mass": mass,
                   "non_delaunay_tets": float(diagnostics.non_delaunay_tets(V, T).mean())}
            try:
                lam, _ = solve.eigs(L, M, K, fixed)
                row["mean_relative_deviation"] = float(np.mean(np.abs(lam / exact - 1)))
                row["n_negative"] = int((lam < 0).sum())
                spectra[(family, size, lap, mass)] = lam
            except Exception as e:  # a non-positive circumcentric mass, for instance
                row["mean_relative_deviation"] = float("nan")
                row["note"] = " ".join(str(e).split())
            out.row(**row)

    for family in dict.fromkeys(r["family"] for r in out.rows):
        counts = dict.fromkeys(r["n_vertices"] for r in out.rows if r["family"] == family)
        out.say(f"{family}, meshes of {', '.join(map(str, counts))} vertices:")
        for lap, mass in PAIRS:
            mine = [r for r in out.rows if r["family"] == family and r["laplacian"] == lap
                    and r["mass"] == mass]
            devs = ", ".join(f"n/a ({r['note']})" if "note" in r
                             else f"{r['mean_relative_deviation']:.4f}" for r in mine)
            out.say(f"  {lap:>6} + {mass:<13} mean relative deviation at those sizes: {devs}"
                    + (f" (slope {slope(mine):.2f})" if len(mine) > 1 else ""))
    delaunay = [r for r in out.rows if r["family"].startswith("optimized Delaunay")]
    if len(dict.fromkeys(r["size"] for r in delaunay)) > 1:
        mine = lambda lap, mass: [r for r in delaunay if r["laplacian"] == lap  # noqa: E731
                                  and r["mass"] == mass]
        p, q = slope(mine("primal", "barycentric")), slope(mine("dual", "circumcentric"))
        finest = max(r["n_vertices"] for r in delaunay)
        last = {(r["laplacian"], r["mass"]): r["mean_relative_deviation"] for r in delaunay
                if r["n_vertices"] == finest}
        faster = q < p - 0.05
        out.say(f"optimized Delaunay (TetGen): the dual with the circumcentric mass converges "
                f"as n^{q:.2f}, the primal with the barycentric mass as n^{p:.2f}: the dual "
                f"{'converges faster' if faster else 'does not converge faster'}; at "
                f"{finest} vertices {last.get(('dual', 'circumcentric'), float('nan')):.4f} "
                f"against {last.get(('primal', 'barycentric'), float('nan')):.4f}")

    def fig10(plt):
        keys = [k for k in spectra if k[1] in (sizes[-1],) and k[2:] in
                (("primal", "barycentric"), ("dual", "circumcentric"))]
        fams = list(dict.fromkeys(k[0] for k in keys))
        fig, axes = plt.subplots(1, len(fams), figsize=(5 * len(fams), 4.4), squeeze=False,
                                 layout="constrained")
        fig.suptitle(f"eigen-ball: the {K} smallest Dirichlet eigenvalues of the unit ball "
                     "(paper Fig. 10)")
        for ax, family in zip(axes[0], fams):
            ax.plot(np.arange(1, K + 1), exact, "k-", label="exact")
            for k in keys:
                if k[0] == family:
                    ax.plot(np.arange(1, K + 1), spectra[k], ".", label=f"{k[2]} + {k[3]}")
            ax.set_xlabel("index")
            ax.set_ylabel("eigenvalue")
            ax.set_title(f"{family}, {sizes[-1]} vertices")
            ax.legend()
        return fig

    def fig11(plt):
        fams = [f for f in dict.fromkeys(r["family"] for r in out.rows) if "weighted" not in f]
        fig, axes = plt.subplots(1, len(fams), figsize=(5 * len(fams), 4.4), squeeze=False,
                                 layout="constrained")
        fig.suptitle(f"eigen-ball: mean deviation of the {K} smallest eigenvalues from the "
                     "exact ones (paper Fig. 11)")
        for ax, family in zip(axes[0], fams):
            for lap, mass in PAIRS:
                mine = [r for r in out.rows if r["family"] == family and r["laplacian"] == lap
                        and r["mass"] == mass]
                ax.loglog([r["n_vertices"] for r in mine],
                          [r["mean_relative_deviation"] for r in mine], "o-",
                          label=f"{lap} + {mass}")
            ax.set_xlabel("vertices")
            ax.set_ylabel(f"mean relative deviation ({K} eigenvalues)")
            ax.set_title(family)
            ax.legend(fontsize=8)
            log_ticks(ax)
        return fig

    out.figure("fig10_spectrum.png", fig10)
    out.figure("fig11_convergence.png", fig11)
