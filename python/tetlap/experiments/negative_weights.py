"""``negative-weights``: robustness and negative weights over a corpus (Sec. 8.3, Fig. 12).

For every mesh: NaN/Inf counts of both Laplacians (the paper found none) and the fraction
of negative weights over edges whose endpoints are not both on the boundary, primal vs
dual; a histogram over the corpus. ``--meshes DIR`` reads every mesh file there
(e.g. ``../shared/data/meshes``); without it, a built-in set of generated meshes.
"""

from __future__ import annotations

import warnings

import numpy as np

from .. import assembly, io, meshes
from ..analysis import check
from .._progress import bar as progress
from ._corpus import mesh_files
from .._names import public_dir

__all__ = ["built_in", "from_folder", "run"]
__dir__ = public_dir(globals())


def built_in(quick: bool, seed: int):
    """(name, loader) pairs of generated meshes: Delaunay, jittered grids, non-Delaunay."""
    n = 2000 if quick else 20000
    yield "ball (random Delaunay)", lambda: meshes.ball(n, seed=seed)
    yield "shell (random Delaunay)", lambda: meshes.shell(n, seed=seed)[:2]
    yield "cube 8^3 jittered 0.2", lambda: meshes.cube(8, jitter=0.2, seed=seed)
    yield "cube 8^3 jittered 0.24", lambda: meshes.cube(8, jitter=0.24, seed=seed + 1)
    for w in (0.1, 0.5, 1.0):
        yield f"weighted ball {w}", lambda w=w: meshes.weighted_ball(n, w, seed=seed)


def from_folder(folder):
    """(name, loader) pairs of the mesh files of ``folder``."""
    for path in mesh_files(folder):
        yield path.name, lambda path=path: io.read(path)


def run(out, meshes=None) -> None:
    sources = list(from_folder(meshes) if meshes else built_in(out.quick, out.seed))
    if meshes and out.quick:
        sources = sources[:12]
    out.say(f"corpus: {meshes or 'built-in generated meshes'} ({len(sources)} meshes)")
    for name, load in progress(sources, desc="negative-weights"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = load()
        row = {"mesh": name, "n_vertices": len(V), "n_tets": len(T)}
        for kind in ("primal", "dual"):
            L = assembly.laplacian(V, T, kind, degenerate="skip")
            r = check(L, V, T, nsd=False)
            row[f"nan_inf_{kind}"] = int((~np.isfinite(L.data)).sum())
            row[f"negative_fraction_{kind}"] = r.negative_fraction_interior
        out.row(**row)
    rows = out.rows
    p = np.array([r["negative_fraction_primal"] for r in rows])
    d = np.array([r["negative_fraction_dual"] for r in rows])
    out.say(f"NaN/Inf values: primal {sum(r['nan_inf_primal'] for r in rows)}, "
            f"dual {sum(r['nan_inf_dual'] for r in rows)}")
    out.say(f"negative weights (edges not both on the boundary): median primal "
            f"{100 * np.median(p):.2f}%, dual {100 * np.median(d):.2f}%")
    out.say(f"dual has fewer negative weights than primal on {(d < p).sum()} of {len(rows)} "
            f"meshes, more on {(d > p).sum()}")
    for r in rows:
        out.say(f"  {r['mesh']:<40} primal {100 * r['negative_fraction_primal']:6.2f}%  "
                f"dual {100 * r['negative_fraction_dual']:6.2f}%")

    def fig12(plt):
        from matplotlib.ticker import MaxNLocator

        fig, ax = plt.subplots(figsize=(6.5, 4.4), layout="constrained")
        fig.suptitle(f"negative-weights: negative weights on {len(rows)} meshes "
                     "(paper Fig. 12)")
        bins = np.linspace(0, max(p.max(), d.max(), 1e-3) * 1.05, 20)
        ax.hist(p, bins=bins, alpha=0.6, label="primal")
        ax.hist(d, bins=bins, alpha=0.6, label="dual")
        ax.set_xlabel("fraction of negative weights (edges not both on the boundary)")
        ax.set_ylabel("meshes")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.legend()
        return fig

    out.figure("fig12_negative_weights.png", fig12)
