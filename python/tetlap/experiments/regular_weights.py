"""``regular-weights``: which meshes can be made regular, and what the weighted dual gains,
plus the Sec. 9 conjecture.

Part 1, per mesh (the corpus with ``--meshes DIR``, and generated meshes): is it regular
(:func:`tetlap.regular.regular_weights`), its margin, the negative interior weights and NSD
of the plain dual, the weighted dual and the primal, the masses, the solver's time next to
the assembly time. Generated: random Delaunay balls with interior vertices jittered to a
growing fraction of non-Delaunay faces (regular or not is what is measured), and regular
triangulations of random weighted points (regular by construction).

Part 2, Dirichlet shell (Eq. 28, as in ``dirichlet-shell``) on non-Delaunay shells
(regular triangulations with random weights): the error of the weighted dual with the
weights found, against the plain dual and the primal.

Part 3, the conjecture of Sec. 9 ("the primal Laplacian can have non-negative weights only
for weighted Delaunay tetrahedralisations, and then they are the dual weights for some
weights"): on meshes whose primal has no negative interior weight (the body-centred cubic
lattice, whose tets have dihedral angles of 60 and 90 degrees, the Kuhn grid, and random
perturbations of both, kept when the primal stays non-negative), (a) is the mesh regular,
(b) the least-squares fit of vertex weights making the weighted-dual weights equal the
primal ones on every interior edge, and its residual relative to the weights.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from .. import assembly, diagnostics, io, solve
from .. import meshes as generate
from ..properties import check
from ..regular import regular_weights
from .._progress import bar as progress
from ._corpus import mesh_files
from .._names import public_dir

__all__ = ["QUICK_CORPUS", "NSD_MAX_VERTICES", "MAX_TETS", "jittered_ball", "bcc",
           "fit_primal", "shell_errors", "run"]
__dir__ = public_dir(globals())

#: The corpus meshes of the quick run: small ones, regular and not (the full run has all
#: 41, with the fish and the microstructure).
QUICK_CORPUS = ("sofa_raptor_8418.vtu", "libigl_octopus_low.mesh", "sofa_liver_v1.vtu",
                "vtkdata_tetramesh_mixed_orient.vtk")
NSD_MAX_VERTICES = 3000
#: Corpus meshes larger than this are skipped (listed in the summary). The whole corpus
#: (up to 205k tets) fits: the first-order search decides 200k tets in seconds.
MAX_TETS = 250000


def jittered_ball(n: int, amount: float, seed: int):
    """A random Delaunay ball whose interior vertices moved by up to ``amount`` mean
    spacings (same connectivity): non-Delaunay, regular or not. Inverted tets are avoided
    by halving the move of the vertices of any tet that flips, a few times."""
    V, T = generate.ball(n, seed=seed)
    rng = np.random.default_rng(seed + 1000)
    h = (4 / 3 * np.pi / n) ** (1 / 3)
    inner = diagnostics.interior_vertices(V, T)
    move = np.zeros_like(V)
    move[inner] = rng.uniform(-1, 1, size=(int(inner.sum()), 3)) * amount * h
    sign0 = diagnostics.orientation(V, T)
    for _ in range(20):
        flipped = diagnostics.orientation(V + move, T) != sign0
        if not flipped.any():
            break
        move[np.unique(T[flipped])] /= 2
    else:
        move[np.unique(T[flipped])] = 0
    return V + move, T


def bcc(k: int):
    """The body-centred cubic lattice in the unit cube: ``(k+1)^3`` corners and ``k^3``
    centres, tetrahedralised by Delaunay (its tets are congruent, dihedral angles 60 and
    90 degrees; flat hull slivers dropped)."""
    from scipy.spatial import Delaunay

    g = np.arange(k + 1) / k
    corners = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    c = (np.arange(k) + 0.5) / k
    centres = np.stack(np.meshgrid(c, c, c, indexing="ij"), -1).reshape(-1, 3)
    V = np.vstack([corners, centres])
    T = Delaunay(V, qhull_options="Qbb Qc Qz Q12").simplices.astype(np.int64)
    vol = np.abs(diagnostics.signed_volumes(V, T))
    T = T[vol > 1e-9 * vol.max()]
    return V, generate.orient(V, T)


def _interior_edges(V, T):
    edges = diagnostics.mesh_edges(T)
    b = diagnostics.boundary_vertices(V, T)
    return edges, ~(b[edges[:, 0]] & b[edges[:, 1]])


def _negative_interior(V, T, kind, w=None):
    return check(assembly.laplacian(V, T, kind, weights=w), V, T, nsd=False).n_negative_interior


def fit_primal(V, T, w0=None):
    """Least squares: vertex weights w making the weighted-dual weights equal the primal
    ones on every interior edge. Returns (w, relative residual |r| / |w_primal|, the same
    at w = 0). The dual weights are quadratic in w: scipy's ``least_squares`` with a
    finite-difference Jacobian on the edge-vertex sparsity pattern."""
    import scipy.sparse as sp
    from scipy.optimize import least_squares

    edges, inner = _interior_edges(V, T)
    _, wp = assembly.edge_weights(V, T, "primal")
    target = wp[inner]
    scale = np.linalg.norm(target)
    n = len(V)
    h2 = float(np.mean(np.sum((V[edges[:, 0]] - V[edges[:, 1]]) ** 2, axis=1)))

    def residual(x):
        _, wd = assembly.edge_weights(V, T, "dual", weights=x * h2)
        return (wd[inner] - target) / scale

    # an edge's weight depends on the weights of the vertices of its tets
    key = edges[:, 0] * n + edges[:, 1]
    rows, cols = [], []
    for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)):
        e = np.searchsorted(key, np.minimum(T[:, a], T[:, b]) * n + np.maximum(T[:, a], T[:, b]))
        for c in range(4):
            rows.append(e)
            cols.append(T[:, c])
    pattern = sp.csr_array((np.ones(len(np.concatenate(rows))),
                            (np.concatenate(rows), np.concatenate(cols))), shape=(len(edges), n))
    pattern = pattern[np.flatnonzero(inner)]
    x0 = np.zeros(n) if w0 is None else w0 / h2
    r0 = float(np.linalg.norm(residual(np.zeros(n))))
    sol = least_squares(residual, x0, jac_sparsity=pattern, method="trf", x_scale=1.0,
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    return sol.x * h2, float(np.linalg.norm(sol.fun)), r0


def _mesh_row(name, family, V, T, *, nsd):
    t0 = time.perf_counter()
    L, M = assembly.operators(V, T, "dual", "circumcentric")
    assembly_s = time.perf_counter() - t0
    r = regular_weights(V, T)
    row = {"family": family, "mesh": name, "n_vertices": len(V), "n_tets": len(T),
           "non_delaunay_faces": r.n_violated_plain, "regular": r.regular,
           "status": r.status, "certificate_faces": len(r.certificate_faces),
           "iterations": r.iterations, "lps": r.lp_count,
           "margin": r.margin, "margin_plain": r.margin_plain,
           "weighted_vertices": r.n_weighted_vertices, "violated_faces": len(r.violated_faces),
           "folded_faces": r.n_folded, "seconds": r.seconds, "assembly_seconds": assembly_s}
    do_nsd = nsd and len(V) <= NSD_MAX_VERTICES
    weights = r.weights if r.weights.any() else None
    for label, kind, w in (("dual", "dual", None), ("weighted", "dual", weights),
                           ("primal", "primal", None)):
        L = assembly.laplacian(V, T, kind, weights=w)
        rep = check(L, V, T, nsd=do_nsd)
        row[f"negative_interior_{label}"] = rep.n_negative_interior
        row[f"nsd_{label}"] = rep.nsd
        if label == "weighted":
            row["linear_precision_weighted"] = rep.linear_precision_ok
    row["mass_nonpositive_dual"] = int((M.diagonal() <= 0).sum())
    m_w = (M if weights is None else
           assembly.mass(V, T, "circumcentric", weights=weights)).diagonal()
    used = diagnostics.referenced_vertices(V, T)
    row["mass_nonpositive_weighted"] = int((m_w[used] <= 0).sum())
    row["masses_lost"] = len(r.masses_lost)
    row["note"] = "; ".join(r.notes)
    return row


def shell_errors(V, T, spheres, weights) -> dict:
    """Dirichlet shell (Eq. 28) errors of the primal, the plain dual and the weighted dual."""
    r = np.linalg.norm(V, axis=1)
    fixed = (spheres == 0) | (spheres == 2)
    values = np.where(spheres == 0, 1.0, 0.0)
    out = {}
    for label, kind, w in (("primal", "primal", None), ("dual", "dual", None),
                           ("weighted", "dual", weights)):
        f = solve.dirichlet(assembly.laplacian(V, T, kind, weights=w), fixed, values)
        err = (f - (1 / r - 1))[~fixed]
        out[f"variance_{label}"] = float(f[spheres == 1].var())
        out[f"rms_error_{label}"] = float(np.sqrt((err**2).mean()))
    return out


def run(out, meshes=None) -> None:
    """Run the experiment into ``out`` (an :class:`~tetlap.experiments.Output`);
    ``meshes``: a folder of mesh files (the corpus), or None for generated meshes only."""
    folder = meshes
    quick, seed = out.quick, out.seed

    # -- part 1: corpus and generated meshes ----------------------------------------------
    jobs = []
    if folder:
        jobs += [("corpus", p.name, lambda p=p: io.read(p))
                 for p in mesh_files(folder, QUICK_CORPUS if quick else None)]
    n = 1000 if quick else 4000
    for a in ((0.03,) if quick else (0.03, 0.1, 0.2, 0.3)):
        jobs.append(("jittered Delaunay", f"ball {n} jitter {a}",
                     lambda a=a: jittered_ball(n, a, seed)))
    for s in ((0.3,) if quick else (0.1, 0.3, 1.0)):
        jobs.append(("regular triangulation", f"weighted ball {n} scale {s}",
                     lambda s=s: generate.weighted_ball(n, s, seed=seed)))
    for family, name, load in progress(jobs, desc="regular-weights"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            V, T = load()
        if family == "corpus" and len(T) > MAX_TETS:
            out.row(part="meshes", family=family, mesh=name, n_vertices=len(V),
                    n_tets=len(T), note=f"skipped: more than {MAX_TETS} tets")
            continue
        try:
            row = _mesh_row(name, family, V, T, nsd=True)
        except Exception as e:  # a mesh the solver rejects (flat tets): say so
            row = {"family": family, "mesh": name, "n_vertices": len(V), "n_tets": len(T),
                   "note": f"{type(e).__name__}: {e}"}
        out.row(part="meshes", **row)

    # -- part 2: Dirichlet shell on non-Delaunay (regular) shells ----------------------------
    shell_n = 2000 if quick else 4000
    for w in progress((0.3,) if quick else (0.1, 0.3, 1.0), desc="shells"):
        for s in range(seed, seed + (1 if quick else 2)):
            V, T, spheres = generate.shell(shell_n, seed=s, weight_scale=w)
            r = regular_weights(V, T)
            out.row(part="shell", family="weighted shell", mesh=f"shell {shell_n} w {w} seed {s}",
                    n_vertices=len(V), n_tets=len(T), weight_scale=w, regular=r.regular,
                    margin=r.margin, non_delaunay_faces=r.n_violated_plain,
                    seconds=r.seconds, **shell_errors(V, T, spheres, r.weights))

    # -- part 3: the Sec. 9 conjecture ------------------------------------------------------
    rng = np.random.default_rng(seed)
    bases = [("BCC", bcc(3)), ("Kuhn", generate.cube(3))]
    trials = 4 if quick else 16
    for base, (V0, T) in bases:
        h = float(np.mean(np.linalg.norm(V0[T[:, 0]] - V0[T[:, 1]], axis=1)))
        inner = diagnostics.interior_vertices(T, len(V0))
        cases = [(0.0, V0)]
        for k in range(trials):
            a = (0.02, 0.05, 0.1, 0.15)[k % 4]
            V = V0.copy()
            V[inner] += rng.uniform(-a, a, size=(int(inner.sum()), 3)) * h
            cases.append((a, V))
        for a, V in progress(cases, desc=f"conjecture {base}"):
            if (diagnostics.orientation(V, T) <= 0).any():
                continue
            if _negative_interior(V, T, "primal") > 0:
                out.row(part="conjecture", family=base, jitter=a, primal_non_negative=False)
                continue
            r = regular_weights(V, T)
            w, res, res0 = fit_primal(V, T, r.weights if r.regular else None)
            out.row(part="conjecture", family=base, jitter=a, primal_non_negative=True,
                    n_vertices=len(V), n_tets=len(T), non_delaunay_faces=r.n_violated_plain,
                    regular=r.regular, status=r.status, margin=r.margin, fit_residual=res,
                    fit_residual_plain=res0,
                    fit_negative_interior=_negative_interior(V, T, "dual", w))

    _summarise(out)


def _summarise(out) -> None:
    rows = out.rows
    mesh_rows = [r for r in rows if r["part"] == "meshes"]
    out.say("per mesh: status, margin, negative interior weights dual / weighted / primal, "
            "NSD dual / weighted / primal, masses <= 0 dual / weighted, seconds (assembly)")
    for r in mesh_rows:
        if "regular" not in r:
            out.say(f"  {r['mesh']}: {r['note']}")
            continue
        out.say(f"  {r['mesh']:<36} {r['status']:>11} {r['margin']:+.2e}  "
                f"{r['negative_interior_dual']}/{r['negative_interior_weighted']}/"
                f"{r['negative_interior_primal']}  {r['nsd_dual']}/{r['nsd_weighted']}/"
                f"{r['nsd_primal']}  {r['mass_nonpositive_dual']}/{r['mass_nonpositive_weighted']}"
                f"  {r['seconds']:.2f} s ({r['assembly_seconds']:.3f} s)")
    regular = [r for r in mesh_rows if r.get("regular")]
    if regular:
        negative = sum(r["negative_interior_weighted"] for r in regular)
        lost = [r["mesh"] for r in regular if r["linear_precision_weighted"] is False]
        statuses = [r["status"] for r in mesh_rows if "status" in r]
        out.say("statuses: " + ", ".join(f"{k} {statuses.count(k)}" for k in
                                           ("regular", "not regular", "undecided")))
        out.say(f"regular meshes: {len(regular)} of {len(mesh_rows)}; negative interior "
                f"weighted-dual weights on them: {negative}; linear precision lost on: "
                f"{lost or 'none'} (n/a without interior vertices)")
    shells = [r for r in rows if r["part"] == "shell"]
    if shells:
        for label in ("primal", "dual", "weighted"):
            out.say(f"shell ({len(shells)} non-Delaunay shells): median variance {label} "
                    f"{np.median([r[f'variance_{label}'] for r in shells]):.3e}, median rms "
                    f"error {np.median([r[f'rms_error_{label}'] for r in shells]):.3e}")
        wins = sum(r["variance_weighted"] < r["variance_dual"] for r in shells)
        out.say(f"  weighted dual beats the plain dual on {wins} of {len(shells)} shells, the "
                f"primal on {sum(r['variance_weighted'] < r['variance_primal'] for r in shells)}")
    conj = [r for r in rows if r["part"] == "conjecture" and r.get("primal_non_negative")]
    if conj:
        out.say(f"Sec. 9 conjecture: {len(conj)} meshes with non-negative primal interior weights "
                f"({sum(r['non_delaunay_faces'] > 0 for r in conj)} of them non-Delaunay)")
        out.say(f"  (a) regular: {sum(r['regular'] for r in conj)} of {len(conj)} (status: "
                + ", ".join(f"{k} {sum(r['status'] == k for r in conj)}"
                            for k in ("regular", "not regular", "undecided")) + ")")
        res = np.array([r["fit_residual"] for r in conj])
        res0 = np.array([r["fit_residual_plain"] for r in conj])
        out.say(f"  (b) least-squares fit of weighted-dual to primal weights: relative residual "
                f"median {np.median(res):.2e}, max {res.max():.2e} (plain dual, w = 0: median "
                f"{np.median(res0):.2e})")
        for base in dict.fromkeys(r["family"] for r in conj):
            mine = [r for r in conj if r["family"] == base]
            out.say(f"  {base}: residual by jitter " + ", ".join(
                f"{r['jitter']}: {r['fit_residual']:.1e}" for r in mine[:8]))

    def fig(plt):
        fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
        ax = axes[0]
        names = [r["mesh"] for r in mesh_rows if "regular" in r]
        x = np.arange(len(names))
        for k, (label, color) in enumerate((("dual", "C1"), ("weighted", "C2"),
                                            ("primal", "C0"))):
            vals = [r[f"negative_interior_{label}"] for r in mesh_rows if "regular" in r]
            ax.bar(x + (k - 1) * 0.27, np.maximum(vals, 0.5), 0.27, color=color, label=label)
        ax.set_yscale("log")
        ax.set_xticks(x, names, rotation=75, fontsize=7)
        ax.set_ylabel("negative interior weights (0 shown as 0.5)")
        ax.legend(fontsize=8)
        ax.set_title("negative interior weights per mesh")
        ax = axes[1]
        if shells:
            scales = sorted({r["weight_scale"] for r in shells})
            for label, marker in (("primal", "o"), ("dual", "s"), ("weighted", "^")):
                ax.semilogy([r["weight_scale"] for r in shells],
                             [r[f"variance_{label}"] for r in shells], marker, label=label,
                             alpha=0.7)
            ax.set_xticks(scales)
            ax.set_xlabel("weight scale of the shell (non-Delaunay fraction grows)")
            ax.set_ylabel("variance of f on r = 0.75")
            ax.legend(fontsize=8)
            ax.set_title("Dirichlet shell")
        ax = axes[2]
        if conj:
            for base, marker in zip(dict.fromkeys(r["family"] for r in conj), "os"):
                mine = [r for r in conj if r["family"] == base]
                ax.semilogy([r["jitter"] for r in mine],
                            [max(r["fit_residual"], 1e-16) for r in mine], marker, label=base)
            ax.set_xlabel("jitter (mean edge lengths)")
            ax.set_ylabel("relative residual of the fit")
            ax.legend(fontsize=8)
            ax.set_title("Sec. 9: weighted dual = primal?")
        return fig

    out.figure("regular_weights.png", fig)
