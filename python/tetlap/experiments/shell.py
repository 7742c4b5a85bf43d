"""``dirichlet-shell``: Eq. 28 on the shell 0.5 <= r <= 1 (paper Sec. 8.1, Fig. 8/9).

f = 1 on r = 0.5, 0 on r = 1; the exact solution 1/r - 1 is constant on r = 0.75, so the
variance of f over the vertices on that sphere measures the error. Meshes: optimized
(gmsh, if installed), random Delaunay, and weighted Delaunay with a growing fraction of
non-Delaunay tets.
"""

from __future__ import annotations

import numpy as np

from .. import assembly, diagnostics, meshes, solve
from .._progress import bar as progress
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["KINDS", "measure", "run"]
__dir__ = public_dir(globals())

KINDS = ("primal", "dual")


def measure(V, T, spheres) -> dict:
    r = np.linalg.norm(V, axis=1)
    fixed = (spheres == 0) | (spheres == 2)
    values = np.where(spheres == 0, 1.0, 0.0)
    edges = diagnostics.mesh_edges(T)
    row = {
        "n_vertices": len(V), "n_tets": len(T),
        "mean_edge_length": float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean()),
        "non_delaunay_tets": float(diagnostics.non_delaunay_tets(V, T).mean()),
        "min_dihedral_deg": float(diagnostics.min_dihedral_angles(V, T).min()),
    }
    for kind in KINDS:
        f = solve.dirichlet(assembly.laplacian(V, T, kind), fixed, values)
        err = (f - (1 / r - 1))[~fixed]
        row[f"variance_{kind}"] = float(f[spheres == 1].var())
        row[f"rms_error_{kind}"] = float(np.sqrt((err**2).mean()))
    return row


def run(out) -> None:
    quick, seed = out.quick, out.seed
    sizes = [3000, 9000] if quick else [4000, 12000, 36000]
    seeds = [seed] if quick else [seed, seed + 1, seed + 2]
    heights = [0.12, 0.08] if quick else [0.12, 0.08, 0.055]
    weighted_n = 3000 if quick else 9000
    scales = [0.0, 0.1, 0.3, 1.0] if quick else [0.0, 0.05, 0.1, 0.3, 1.0, 2.0]
    weighted_seeds = range(seed, seed + (3 if quick else 8))

    jobs = [("random Delaunay", n, s, 0.0) for n in sizes for s in seeds]
    jobs += [("weighted Delaunay", weighted_n, s, w) for w in scales for s in weighted_seeds]
    try:
        meshes._gmsh()
        jobs = [("optimized (gmsh)", h, seed, 0.0) for h in heights] + jobs
    except ImportError as e:
        out.say(f"optimized meshes skipped: {e}")
    for family, size, s, w in progress(jobs, desc="dirichlet-shell"):
        if family.startswith("optimized"):
            V, T, spheres = meshes.optimized_shell(size, seed=s)
        else:
            V, T, spheres = meshes.shell(size, seed=s, weight_scale=w)
        out.row(family=family, size=size, seed=s, weight_scale=w, **measure(V, T, spheres))

    rows = out.rows
    for family in dict.fromkeys(r["family"] for r in rows):
        mine = [r for r in rows if r["family"] == family]
        ratio = np.median([r["variance_primal"] / r["variance_dual"] for r in mine])
        out.say(f"{family}: median variance ratio primal / dual = {ratio:.2f} over "
                f"{len(mine)} meshes (non-Delaunay tets "
                f"{100 * min(r['non_delaunay_tets'] for r in mine):.1f}-"
                f"{100 * max(r['non_delaunay_tets'] for r in mine):.1f}%)")
        if family == "weighted Delaunay":
            continue
        for kind in KINDS:
            pairs = ", ".join(f"h {r['mean_edge_length']:.3f}: {r[f'variance_{kind}']:.2e}"
                              for r in mine)
            out.say(f"  {kind} variance by mesh: {pairs}")
            h = np.log([r["mean_edge_length"] for r in mine])
            if len(set(h)) > 2:
                v = np.log([r[f"variance_{kind}"] for r in mine])
                out.say(f"  {kind}: variance ~ h^{np.polyfit(h, v, 1)[0]:.2f} (least squares)")

    def fig8(plt):
        fams = [f for f in dict.fromkeys(r["family"] for r in rows) if f != "weighted Delaunay"]
        fig, axes = plt.subplots(1, len(fams), figsize=(5 * len(fams), 4.4), squeeze=False,
                                 layout="constrained")
        fig.suptitle("dirichlet-shell: variance of f on r = 0.75 vs mean edge length "
                     "(paper Fig. 8)")
        for ax, family in zip(axes[0], fams):
            mine = [r for r in rows if r["family"] == family]
            for kind, marker in zip(KINDS, "os"):
                ax.loglog([r["mean_edge_length"] for r in mine],
                          [r[f"variance_{kind}"] for r in mine], marker, label=kind)
            ax.set_xlabel("mean edge length")
            ax.set_ylabel("variance of f on r = 0.75")
            ax.set_title(family)
            ax.legend()
            log_ticks(ax)
        return fig

    def fig9(plt):
        mine = [r for r in rows if r["family"] == "weighted Delaunay"]
        fig, ax = plt.subplots(figsize=(7, 4.4), layout="constrained")
        fig.suptitle("dirichlet-shell: variance of f on r = 0.75 on weighted-Delaunay meshes "
                     "(paper Fig. 9)")
        for k, (kind, color) in enumerate(zip(KINDS, ("C0", "C1"))):
            data = [[r[f"variance_{kind}"] for r in mine if r["weight_scale"] == w] for w in scales]
            pos = np.arange(len(scales)) + (k - 0.5) * 0.35
            bp = ax.boxplot(data, positions=pos, widths=0.3, patch_artist=True,
                            medianprops={"color": "k"})
            for patch in bp["boxes"]:
                patch.set_facecolor(color)
            ax.plot([], [], color=color, lw=6, label=kind)
        labels = []
        for w in scales:
            frac = np.mean([r["non_delaunay_tets"] for r in mine if r["weight_scale"] == w])
            labels.append(f"{100 * frac:.0f}%")
        ax.set_xticks(np.arange(len(scales)), labels)
        ax.set_yscale("log")
        ax.set_xlabel("non-Delaunay tets")
        ax.set_ylabel("variance of f on r = 0.75")
        ax.legend()
        log_ticks(ax, "y")
        return fig

    out.figure("fig8_variance_vs_edge_length.png", fig8)
    out.figure("fig9_variance_vs_non_delaunay.png", fig9)
