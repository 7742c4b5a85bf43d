"""``heat-distance``: the heat method's distance against the Euclidean distance on balls
and boxes (convex: the geodesic distance is the Euclidean one), at several refinements,
from the vertex nearest the centre and from a boundary vertex, for the Neumann and the
averaged boundary conditions, and LaPy's heat geodesics on the same meshes (when
installed). The error is the mean absolute error over the vertices relative to the
largest exact distance."""

from __future__ import annotations

import numpy as np

from .. import _extras as extras
from .. import meshes
from .._progress import bar as progress
from ..heat import HeatDistance
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["BOUNDARIES", "lapy_distance", "sources", "run"]
__dir__ = public_dir(globals())

BOUNDARIES = ("neumann", "average")


def lapy_distance(V, T, s):
    """LaPy's heat geodesics (``heat.diffusion`` then ``diffgeo.compute_geodesic_f``), or
    None when LaPy is not installed, or the text of the error it raised.

    LaPy's last step is a pure-Neumann Poisson solve on the singular stiffness matrix;
    SuperLU factors it only when rounding hides the singularity, and on small Kuhn-like
    boxes (``cube(5)``) it raises "Factor is exactly singular". A baseline that fails is
    a row of the table, not the end of the experiment."""
    try:
        from lapy import TetMesh
        from lapy.diffgeo import compute_geodesic_f
        from lapy.heat import diffusion
    except ImportError:
        return None
    mesh = TetMesh(V, T)
    try:
        return compute_geodesic_f(mesh, diffusion(mesh, s))
    except (RuntimeError, ValueError, np.linalg.LinAlgError) as error:
        return f"{type(error).__name__}: {error}"


def sources(V, family):
    """The vertex nearest the centre and one on the boundary (largest x)."""
    centre = 0.0 if family == "ball" else 0.5
    return {"centre": int(np.argmin(((V - centre) ** 2).sum(1))),
            "boundary": int(np.argmax(V[:, 0]))}


def run(out) -> None:
    balls = [1000, 4000] if out.quick else [2000, 8000, 30000]
    boxes = [5, 8] if out.quick else [6, 10, 16]
    jobs = [("ball", n) for n in balls] + [("box", k) for k in boxes]
    fields = {}
    for family, size in progress(jobs, desc="heat-distance"):
        if family == "ball":
            V, T = meshes.ball(size, seed=out.seed)
        else:
            V, T = meshes.cube(size, jitter=0.2, seed=out.seed)
        for boundary in BOUNDARIES:
            heat = HeatDistance(V, T, boundary_condition=boundary)
            for where, s in sources(V, family).items():
                exact = np.linalg.norm(V - V[s], axis=1)
                d = heat.distance(s)
                row = {"family": family, "size": size, "n_vertices": len(V), "n_tets": len(T),
                       "h": heat.h, "source": where, "boundary": boundary,
                       "error": float(np.abs(d - exact).mean() / exact.max()),
                       "max_error": float(np.abs(d - exact).max() / exact.max())}
                if boundary == "neumann":
                    theirs = lapy_distance(V, T, s)
                    if isinstance(theirs, str):
                        row["lapy_failed"] = theirs
                    elif theirs is not None:
                        row["lapy_error"] = float(np.abs(theirs - exact).mean() / exact.max())
                    fields[(family, where)] = (V, d, exact)
                out.row(**row)

    out.say("mean |d - |x - x_s|| / max |x - x_s| (LaPy: its heat geodesics, Neumann)")
    if not any("lapy_error" in r or "lapy_failed" in r for r in out.rows):
        out.say(f"  (LaPy is not installed: {extras.hint('baselines')})")
    for family in ("ball", "box"):
        counts = dict.fromkeys(r["n_vertices"] for r in out.rows if r["family"] == family)
        out.say(f"  {family}, meshes of {', '.join(map(str, counts))} vertices:")
        for where in ("centre", "boundary"):
            mine = [r for r in out.rows if r["family"] == family and r["source"] == where]
            for boundary in BOUNDARIES:
                errs = ", ".join(f"{r['error']:.4f}" for r in mine if r["boundary"] == boundary)
                out.say(f"    from the {where}, {boundary}: {errs}")
            lapy = [r for r in mine if r["boundary"] == "neumann"
                    and ("lapy_error" in r or "lapy_failed" in r)]
            if lapy:
                out.say(f"    from the {where}, LaPy: " + ", ".join(
                    f"{r['lapy_error']:.4f}" if "lapy_error" in r
                    else f"failed ({r['lapy_failed']})" for r in lapy))

    def convergence(plt):
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
        fig.suptitle("heat-distance: mean error against the mean edge length h")
        for ax, family in zip(axes, ("ball", "box")):
            for where in ("centre", "boundary"):
                for boundary, style in zip(BOUNDARIES, ("o-", "s--")):
                    mine = [r for r in out.rows if r["family"] == family
                            and r["source"] == where and r["boundary"] == boundary]
                    ax.loglog([r["h"] for r in mine], [r["error"] for r in mine], style,
                              label=f"{where}, {boundary}")
                lapy = [r for r in out.rows if r["family"] == family and r["source"] == where
                        and r["boundary"] == "neumann" and "lapy_error" in r]
                if lapy:
                    ax.loglog([r["h"] for r in lapy], [r["lapy_error"] for r in lapy], "kx",
                              label=f"{where}, LaPy")
            ax.set_xlabel("h (mean edge length)")
            ax.set_ylabel("mean |error| / largest distance")
            ax.set_title(f"{family}es" if family == "box" else "balls")
            ax.legend(fontsize=7)
            log_ticks(ax)
        return fig

    def slice_(plt):
        V, d, exact = fields[("ball", "boundary")]
        near = np.abs(V[:, 2]) < 0.06
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), layout="constrained")
        fig.suptitle(f"heat-distance: ball({balls[-1]}), source on the boundary, the "
                     "vertices with |z| < 0.06")
        a = axes[0].scatter(V[near, 0], V[near, 1], c=d[near], s=6, cmap="viridis")
        axes[0].tricontour(V[near, 0], V[near, 1], d[near], levels=10, colors="w",
                           linewidths=0.6)
        fig.colorbar(a, ax=axes[0], label="heat distance")
        b = axes[1].scatter(V[near, 0], V[near, 1], c=d[near] - exact[near], s=6,
                            cmap="coolwarm")
        fig.colorbar(b, ax=axes[1], label="heat distance - Euclidean")
        for ax in axes:
            ax.set_aspect("equal")
            ax.set_xlabel("x")
            ax.set_ylabel("y")
        return fig

    out.figure("error_against_h.png", convergence)
    out.figure("distance_slice.png", slice_)
