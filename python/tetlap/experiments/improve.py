"""``improve``: moving interior vertices to remove negative dual weights.

Two parts, both with :func:`tetlap.improve.improve` (L-BFGS-B on a penalty of the
interior dual weights below a margin, a volume barrier and a small displacement term; the
gradient from :func:`tetlap.vjp`):

1. **Corpus.** Every mesh of ``--meshes DIR`` (default ``$TETLAP_MESHES``) up to
   ``MAX_TETS`` tets (the quick run: three small ones): negative
   interior dual weights (edges not both on the boundary) and non-Delaunay interior
   faces before and after, the change of the minimum dihedral angle, the time.
2. **Dirichlet shells** (experiment 1, Eq. 28). Non-Delaunay random shells
   (:func:`tetlap.meshes.shell` with ``weight_scale > 0``) improved with the vertices of
   the three spheres fixed (so the boundary data and the measuring sphere r = 0.75 stay
   exact); the variance of f on r = 0.75 and the RMS error against ``1/r - 1`` before and
   after, for both Laplacians (:func:`tetlap.experiments.shell.measure`).

Run it with ``tetlap experiment improve [--quick] [--out DIR] [--meshes DIR]``.
"""

from __future__ import annotations

import os
import pathlib
import warnings

import numpy as np

from .. import io, meshes as builtin
from .._progress import bar as progress
from ..improve import improve
from . import shell as shell_experiment
from ._corpus import mesh_files
from .._names import public_dir

__all__ = ["MAX_TETS", "QUICK", "corpus", "run"]
__dir__ = public_dir(globals())
#: The full run skips corpus meshes with more tets than this (on a 2-core machine an
#: L-BFGS-B iteration costs about two dual assemblies).
MAX_TETS = 100_000
#: Meshes of the quick run (small ones of the corpus).
QUICK = ("sofa_liver_v1.vtu", "libigl_octopus_low.mesh", "pbd_armadillo_4k.ele")


def corpus(folder, quick: bool):
    """(name, path) of the corpus meshes (the quick subset with ``quick``)."""
    if folder is None:
        folder = os.environ.get("TETLAP_MESHES")
    if folder is None or not pathlib.Path(folder).is_dir():
        return []
    return [(p.name, p) for p in mesh_files(folder, QUICK if quick else None)]


def _corpus_row(name, V, T, iterations):
    r = improve(V, T, max_iterations=iterations)
    b, a = r.before, r.after
    return {
        "part": "corpus", "mesh": name, "n_vertices": len(V), "n_tets": len(T),
        "moved_vertices": r.moved, "interior_edges": b["interior_edges"],
        "negative_before": b["negative_interior"], "negative_after": a["negative_interior"],
        "interior_faces": b["interior_faces"],
        "non_delaunay_before": b["non_delaunay_faces"],
        "non_delaunay_after": a["non_delaunay_faces"],
        "min_dihedral_before": b["min_dihedral_deg"], "min_dihedral_after": a["min_dihedral_deg"],
        "iterations": r.iterations, "evaluations": r.evaluations, "seconds": r.seconds,
        "objective_before": r.objective[0], "objective_after": r.objective[1],
        "message": r.message,
    }


def _shell_rows(n, weight_scale, seed, iterations):
    V, T, spheres = builtin.shell(n, seed=seed, weight_scale=weight_scale)
    before = shell_experiment.measure(V, T, spheres)
    r = improve(V, T, fixed=spheres >= 0, max_iterations=iterations)
    after = shell_experiment.measure(r.V, T, spheres)
    row = {"part": "shell", "mesh": f"shell n={n} w={weight_scale} seed={seed}",
           "n_vertices": len(V), "n_tets": len(T), "moved_vertices": r.moved,
           "interior_edges": r.before["interior_edges"],
           "negative_before": r.before["negative_interior"],
           "negative_after": r.after["negative_interior"],
           "interior_faces": r.before["interior_faces"],
           "non_delaunay_before": r.before["non_delaunay_faces"],
           "non_delaunay_after": r.after["non_delaunay_faces"],
           "min_dihedral_before": r.before["min_dihedral_deg"],
           "min_dihedral_after": r.after["min_dihedral_deg"],
           "iterations": r.iterations, "evaluations": r.evaluations, "seconds": r.seconds}
    for kind in shell_experiment.KINDS:
        for stat in ("variance", "rms_error"):
            row[f"{stat}_{kind}_before"] = before[f"{stat}_{kind}"]
            row[f"{stat}_{kind}_after"] = after[f"{stat}_{kind}"]
    return row


def run(out, meshes=None) -> None:
    quick, seed = out.quick, out.seed
    iterations = 25 if quick else 60
    sources = corpus(meshes, quick)
    out.say(f"corpus: {meshes or os.environ.get('TETLAP_MESHES') or '(none found)'} "
            f"({len(sources)} meshes); {iterations} L-BFGS-B iterations at most")
    for name, path in progress(sources, desc="improve: corpus"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = io.read(path)
        if V.shape[1] != 3 or len(T) < 2:
            continue
        if len(T) > MAX_TETS:
            out.say(f"skipped {name}: {len(T)} tets (more than {MAX_TETS})")
            continue
        out.row(**_corpus_row(name, V, T, iterations))
    shells = [(1500, 1.0, seed)] if quick else [
        (n, w, s) for n in (4000, 8000) for w in (0.3, 1.0) for s in (seed, seed + 1)]
    for n, w, s in progress(shells, desc="improve: shells"):
        out.row(**_shell_rows(n, w, s, iterations))
    _summarise(out)


def _summarise(out) -> None:
    rows = [r for r in out.rows if r["part"] == "corpus"]
    if rows:
        nb = sum(r["negative_before"] for r in rows)
        na = sum(r["negative_after"] for r in rows)
        out.say(f"corpus: negative interior dual weights {nb} -> {na} "
                f"({100 * (1 - na / max(nb, 1)):.1f}% fewer) over {len(rows)} meshes; "
                f"fewer on {sum(r['negative_after'] < r['negative_before'] for r in rows)}, "
                f"more on {sum(r['negative_after'] > r['negative_before'] for r in rows)}")
        db = sum(r["non_delaunay_before"] for r in rows)
        da = sum(r["non_delaunay_after"] for r in rows)
        out.say(f"corpus: non-Delaunay interior faces {db} -> {da}")
        out.say("")
        out.say(f"{'mesh':<34} {'tets':>7} {'neg. before':>11} {'after':>7} "
                f"{'non-Del. before':>15} {'after':>7} {'min dih. before':>15} {'after':>7} "
                f"{'s':>7}")
        for r in rows:
            out.say(f"{r['mesh']:<34} {r['n_tets']:>7} {r['negative_before']:>11} "
                    f"{r['negative_after']:>7} {r['non_delaunay_before']:>15} "
                    f"{r['non_delaunay_after']:>7} {r['min_dihedral_before']:>15.2f} "
                    f"{r['min_dihedral_after']:>7.2f} {r['seconds']:>7.1f}")
    shells = [r for r in out.rows if r["part"] == "shell"]
    if shells:
        out.say("")
        out.say(f"{'Dirichlet shell':<30} {'neg.':>11} {'non-Del.':>13} "
                f"{'var. dual':>21} {'var. primal':>21}")
        for r in shells:
            out.say(f"{r['mesh']:<30} {r['negative_before']:>5}->{r['negative_after']:<5} "
                    f"{r['non_delaunay_before']:>6}->{r['non_delaunay_after']:<6} "
                    f"{r['variance_dual_before']:>10.2e}->{r['variance_dual_after']:<9.2e} "
                    f"{r['variance_primal_before']:>10.2e}->{r['variance_primal_after']:<9.2e}")
        ratio = np.median([r["variance_dual_before"] / r["variance_dual_after"] for r in shells])
        out.say(f"shells: median variance ratio dual before / after = {ratio:.2f}")

    def figure(plt):
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        if rows:
            b = np.array([r["negative_before"] / max(r["interior_edges"], 1) for r in rows])
            a = np.array([r["negative_after"] / max(r["interior_edges"], 1) for r in rows])
            top = 100 * max(b.max(), a.max(), 1e-4) * 1.05
            axes[0].plot([0, top], [0, top], "k:", lw=1)
            axes[0].plot(100 * b, 100 * a, "o")
            axes[0].set_xlabel("negative interior dual weights before (%)")
            axes[0].set_ylabel("after (%)")
            axes[0].set_title("corpus meshes")
        if shells:
            for kind, marker in zip(shell_experiment.KINDS, "os"):
                axes[1].loglog([r[f"variance_{kind}_before"] for r in shells],
                               [r[f"variance_{kind}_after"] for r in shells], marker, label=kind)
            lo = min(min(r[f"variance_{k}_{w}"] for k in shell_experiment.KINDS
                         for w in ("before", "after")) for r in shells)
            hi = max(max(r[f"variance_{k}_{w}"] for k in shell_experiment.KINDS
                         for w in ("before", "after")) for r in shells)
            axes[1].plot([lo, hi], [lo, hi], "k:", lw=1)
            axes[1].set_xlabel("variance of f on r = 0.75, before")
            axes[1].set_ylabel("after")
            axes[1].set_title("non-Delaunay Dirichlet shells")
            axes[1].legend()
        return fig

    out.figure("improve.png", figure)
