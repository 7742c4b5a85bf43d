"""``eigen-ball``: Dirichlet eigenvalues of the unit ball (paper Sec. 8.2, Fig. 10/11).

The exact eigenvalues of -Laplace on the unit ball with f = 0 on the sphere are the
squares of the zeros of the spherical Bessel functions j_l, each with multiplicity
2 l + 1. Compared: the 32 smallest of -L_II f = lambda M_II f (Eq. 30) for the primal and
dual Laplacian with barycentric and circumcentric masses.
"""

from __future__ import annotations

import numpy as np

from .. import assembly, diagnostics, meshes, solve
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
    spectra = {}
    for family, size in progress(jobs, desc="eigen-ball"):
        if family.startswith("optimized"):
            V, T = meshes.optimized_ball(size, seed=seed)
        elif family.startswith("weighted"):
            V, T = meshes.weighted_ball(size, 1.0, seed=seed)
        else:
            V, T = meshes.ball(size, seed=seed)
        fixed = diagnostics.boundary_vertices(V, T)
        for lap, mass in PAIRS:
            L, M = assembly.operators(V, T, lap, mass)
            row = {"family": family, "size": size, "n_vertices": len(V), "laplacian": lap,
                   "mass": mass,
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
            out.say(f"  {lap:>6} + {mass:<13} mean relative deviation at those sizes: {devs}")

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
