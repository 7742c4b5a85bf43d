"""``sphere3``: mean-curvature normals on the unit 3-sphere in R^4 (Sec. 8.4, Fig. 13/14).

Convex hulls of uniform samples of S^3. ``(L X)_i = 3 m_i H_i n_i`` (Eq. 31): the normal
estimate is ``-(L X)_i / |(L X)_i|`` (tetlap's L points inward on a convex surface), to be
compared with ``x_i`` itself, and the mean curvature ``H_i = |(L X)_i| / (3 m_i)`` with
``m_i = Vol(*i)`` the circumcentric dual-cell volume (Eq. 33), exactly 1.
"""

from __future__ import annotations

import numpy as np

from .. import assembly, meshes
from .._progress import bar as progress
from ._plot import log_ticks
from .._names import public_dir

__all__ = ["run"]
__dir__ = public_dir(globals())


def run(out) -> None:
    sizes = [500, 1000, 2000, 4000] if out.quick else [500, 1000, 2000, 4000, 8000, 16000, 32000]
    for n in progress(sizes, desc="sphere3"):
        V, T = meshes.sphere3(n, seed=out.seed)
        m = assembly.mass(V, T, "circumcentric").diagonal()
        row = {"n_vertices": n, "n_tets": len(T)}
        for kind in ("primal", "dual"):
            L = assembly.laplacian(V, T, kind)
            LX = -(L @ V)
            norm = np.linalg.norm(LX, axis=1)
            angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", LX / norm[:, None], V), -1, 1)))
            H = norm / (3 * m)
            row[f"normal_angle_mean_deg_{kind}"] = float(angle.mean())
            row[f"curvature_error_mean_{kind}"] = float(np.abs(H - 1).mean())
            row[f"min_weight_{kind}"] = float(L.data[L.indices != np.repeat(
                np.arange(n), np.diff(L.indptr))].min())
        out.row(**row)
    rows = out.rows
    for kind in ("primal", "dual"):
        n = np.log([r["n_vertices"] for r in rows])
        a = np.log([r[f"normal_angle_mean_deg_{kind}"] for r in rows])
        h = np.log([r[f"curvature_error_mean_{kind}"] for r in rows])
        out.say(f"{kind}, {rows[0]['n_vertices']} -> {rows[-1]['n_vertices']} samples: mean "
                f"normal angle {rows[0][f'normal_angle_mean_deg_{kind}']:.3f} -> "
                f"{rows[-1][f'normal_angle_mean_deg_{kind}']:.3f} deg (slope in n "
                f"{np.polyfit(n, a, 1)[0]:.2f}); mean |H - 1| "
                f"{rows[0][f'curvature_error_mean_{kind}']:.4f} -> "
                f"{rows[-1][f'curvature_error_mean_{kind}']:.4f} (slope {np.polyfit(n, h, 1)[0]:.2f}); "
                f"min weight {min(r[f'min_weight_{kind}'] for r in rows):.3e}")

    def fig14(plt):
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), layout="constrained")
        fig.suptitle("sphere3: normals and mean curvature on the 3-sphere in R^4 "
                     "(paper Fig. 14)")
        for kind, marker in (("primal", "o-"), ("dual", "s-")):
            n = [r["n_vertices"] for r in rows]
            axes[0].loglog(n, [r[f"normal_angle_mean_deg_{kind}"] for r in rows], marker, label=kind)
            axes[1].loglog(n, [r[f"curvature_error_mean_{kind}"] for r in rows], marker, label=kind)
        axes[0].set_ylabel("mean normal deviation (degrees)")
        axes[1].set_ylabel("mean |H - 1|")
        for ax in axes:
            ax.set_xlabel("samples on S^3")
            ax.legend()
            log_ticks(ax)
        return fig

    out.figure("fig14_sphere3_convergence.png", fig14)
