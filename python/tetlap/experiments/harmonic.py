"""``harmonic``: the maximum principle of harmonic fields over a mesh corpus.

For every mesh (compacted: vertices in no tet dropped): the boundary vertices fixed to a
step (1 where x is above the boundary's median x, else 0), the harmonic field solved with
``tetlap.harmonic(laplacian="auto")`` (which operator, whether the principle is proved,
the values outside [0, 1]), with the primal, and with ``igl.harmonic`` (the primal too,
when libigl is installed), each count with the tolerance :data:`tetlap.fields.RANGE_RTOL`.
``--meshes DIR`` reads every mesh file there; without it, the generated meshes of
``negative-weights``.
"""

from __future__ import annotations

import importlib.util
import warnings

import numpy as np

from .. import _extras as extras
from .. import diagnostics
from .. import meshes as meshes_module
from .._progress import bar as progress
from ..fields import RANGE_RTOL, harmonic
from .negative_weights import built_in, from_folder
from .._names import public_dir

__all__ = ["igl_outside", "run"]
__dir__ = public_dir(globals())


def igl_outside(V, T, b, values):
    """Values of ``igl.harmonic(V, T, b, values, 1)`` outside [0, 1] at free vertices, or
    None without libigl."""
    try:
        import igl
    except ImportError:
        return None
    T = meshes_module.orient(V, T).astype(np.int64)   # libigl assumes positive orientation
    W = igl.harmonic(V, T, b.astype(np.int64), values[:, None], 1)[:, 0]
    free = np.setdiff1d(np.arange(len(V)), b)
    return int(((W[free] < -RANGE_RTOL) | (W[free] > 1 + RANGE_RTOL)).sum())


def run(out, meshes=None) -> None:
    sources = list(from_folder(meshes) if meshes else built_in(out.quick, out.seed))
    if meshes and out.quick:
        sources = sources[:12]
    out.say(f"corpus: {meshes or 'built-in generated meshes'} ({len(sources)} meshes); "
            "boundary fixed to a step in x")
    if importlib.util.find_spec("igl") is None:
        out.say(f"(libigl is not installed, its column is n/a: {extras.hint('baselines')})")
    for name, load in progress(sources, desc="harmonic"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = meshes_module.compact(*load())
        b = np.flatnonzero(diagnostics.boundary_vertices(V, T))
        values = (V[b, 0] > np.median(V[b, 0])).astype(float)
        row = {"mesh": name, "n_vertices": len(V), "n_tets": len(T), "n_fixed": len(b)}
        try:
            auto = harmonic(V, T, b, values, degenerate="skip")
            primal = harmonic(V, T, b, values, laplacian="primal", degenerate="skip")
            row.update(operator=auto.laplacian, proved=auto.proved,
                       auto_outside=auto.out_of_range, primal_outside=primal.out_of_range,
                       reason=auto.reason)
            row["igl_outside"] = igl_outside(V, T, b, values)
        except Exception as e:  # a singular system, a mesh libigl cannot take, ...
            row["note"] = " ".join(str(e).split())[:200]
        out.row(**row)

    done = [r for r in out.rows if "note" not in r]
    proved = [r for r in done if r["proved"]]
    out.say(f"proved: {len(proved)} of {len(done)} meshes; values outside [0, 1] where "
            f"proved: {sum(r['auto_outside'] for r in proved)}")
    out.say(f"{'mesh':<40} {'operator':<14} {'proved':<6} {'auto':>6} {'primal':>7} {'igl':>6}")
    for r in out.rows:
        if "note" in r:
            out.say(f"{r['mesh']:<40} n/a: {r['note']}")
            continue
        igl = "n/a" if r["igl_outside"] is None else r["igl_outside"]
        out.say(f"{r['mesh']:<40} {r['operator']:<14} {'yes' if r['proved'] else 'no':<6} "
                f"{r['auto_outside']:>6} {r['primal_outside']:>7} {igl:>6}")

    def counts(plt):
        fig, ax = plt.subplots(figsize=(10, 4.2), layout="constrained")
        names = [r["mesh"] for r in done]
        x = np.arange(len(done))
        ax.bar(x - 0.2, [r["auto_outside"] for r in done], 0.4, label='harmonic(..., "auto")')
        ax.bar(x + 0.2, [r["igl_outside"] or 0 for r in done], 0.4, label="igl.harmonic")
        ax.set_yscale("symlog")
        ax.set_xticks(x, names, rotation=90, fontsize=6)
        ax.set_ylabel("free values outside [0, 1]")
        ax.set_title("harmonic: values outside the range of the boundary data")
        ax.legend()
        return fig

    out.figure("out_of_range.png", counts)
