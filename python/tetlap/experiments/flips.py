"""``flips``: the Dirichlet energy under bistellar 2-3 / 3-2 flips (paper Sec. 9).

Five points a, b, c, p, q with the segment pq through the triangle abc can be split into
the two tets {abcp, abcq} or the three tets {pqab, pqbc, pqca}. By strong locality the
flip changes L only on these five vertices; by linear precision of both splits the change
annihilates the four-dimensional space of linear functions, so it has rank one:
``L_2 - L_3 = lambda u u^T``, and the 3-2 flip changes the energy ``-f^T L f`` by
``-lambda (u . f)^2`` for every f: its sign does not depend on f. The paper conjectures
that for the dual a 3-2 flip always decreases the energy (lambda >= 0).
"""

from __future__ import annotations

import numpy as np

from .. import assembly
from .._progress import bar as progress
from .._names import public_dir

__all__ = ["TWO", "THREE", "configuration", "rank_one", "two_tets_are_delaunay", "run"]
__dir__ = public_dir(globals())

TWO = np.array([[0, 1, 2, 3], [0, 1, 2, 4]])
THREE = np.array([[3, 4, 0, 1], [3, 4, 1, 2], [3, 4, 2, 0]])


def configuration(rng) -> np.ndarray:
    """Random a, b, c, p, q with pq crossing the triangle abc, randomly placed."""
    abc = np.column_stack([rng.normal(size=(3, 2)), np.zeros(3)])
    o = rng.dirichlet([1, 1, 1]) @ abc
    direction = rng.normal(size=3)
    direction[2] = abs(direction[2]) + 0.05
    direction /= np.linalg.norm(direction)
    p = o + rng.uniform(0.05, 2) * direction
    q = o - rng.uniform(0.05, 2) * direction
    X = np.vstack([abc, p, q])
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return X @ Q.T + rng.normal(size=3)


def rank_one(D) -> tuple[float, float]:
    """(the eigenvalue of largest magnitude, |second| / |largest|) of symmetric D."""
    lam = np.linalg.eigvalsh(D)
    order = np.argsort(-np.abs(lam))
    return float(lam[order[0]]), float(abs(lam[order[1]]) / abs(lam[order[0]]))


def two_tets_are_delaunay(X) -> bool:
    """Is q outside the circumsphere of abcp (the 2-tet split is the Delaunay one)?"""
    a, b, c, p, q = X
    A = 2 * np.array([b - a, c - a, p - a])
    rhs = np.array([b @ b - a @ a, c @ c - a @ a, p @ p - a @ a])
    center = np.linalg.solve(A, rhs)
    return np.linalg.norm(q - center) > np.linalg.norm(a - center)


def run(out) -> None:
    rng = np.random.default_rng(out.seed)
    count = 2000 if out.quick else 20000
    for k in progress(range(count), desc="flips"):
        X = configuration(rng)
        row = {"config": k, "two_tet_split_delaunay": two_tets_are_delaunay(X)}
        for kind in ("primal", "dual"):
            D = (assembly.laplacian(X, TWO, kind) - assembly.laplacian(X, THREE, kind)).toarray()
            lam, rank_gap = rank_one(D)
            row[f"lambda_{kind}"] = lam
            row[f"rank_gap_{kind}"] = rank_gap
        out.row(**row)
    rows = out.rows
    delaunay = np.array([r["two_tet_split_delaunay"] for r in rows])
    for kind in ("primal", "dual"):
        lam = np.array([r[f"lambda_{kind}"] for r in rows])
        gap = max(r[f"rank_gap_{kind}"] for r in rows)
        out.say(f"{kind}: the 3-2 flip decreases the energy (lambda >= 0) in "
                f"{(lam >= 0).sum()} of {len(lam)} configurations "
                f"({(lam[delaunay] >= 0).mean() * 100:.1f}% when the 2-tet split is Delaunay, "
                f"{(lam[~delaunay] >= 0).mean() * 100:.1f}% when not); max rank gap {gap:.1e}")

    def fig(plt):
        from matplotlib.ticker import FixedLocator, NullLocator

        def symlog_ticks(values, most=9):
            """0 and +-10^k on the sides the values reach, every few decades so that at
            most ``most`` labels share the axis (none next to 0, where they would collide)."""
            top = int(np.ceil(np.log10(max(np.abs(values).max(), 1e-2))))
            sides = [s for s in (-1, 1) if (s * values > 1e-3).any()]
            stride = 1
            while 1 + len(sides) * len(range(-2, top + 1, stride)) > most:
                stride += 1
            exps = [k for k in range(-2, top + 1) if k % stride == 0]
            return sorted([0.0] + [s * 10.0**k for s in sides for k in exps])

        fig, ax = plt.subplots(figsize=(7, 5.5), layout="constrained")
        fig.suptitle(r"flips: a 3-2 flip changes $-f^T L f$ by $-\lambda\,(u \cdot f)^2$, "
                     r"where $L_2 - L_3 = \lambda\, u u^T$"
                     "\n(paper Sec. 9, which has no figure for it)")
        lp = np.array([r["lambda_primal"] for r in rows])
        ld = np.array([r["lambda_dual"] for r in rows])
        for mask, label in ((delaunay, "2-tet split Delaunay"), (~delaunay, "3-tet split Delaunay")):
            ax.scatter(lp[mask], ld[mask], s=4, label=label)
        ax.set_xscale("symlog", linthresh=1e-3)
        ax.set_yscale("symlog", linthresh=1e-3)
        for axis, values in ((ax.xaxis, lp), (ax.yaxis, ld)):
            axis.set_major_locator(FixedLocator(symlog_ticks(values)))
            axis.set_minor_locator(NullLocator())
        ax.axhline(0, color="k", lw=0.5)
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel("lambda, primal (> 0: 3-2 flip lowers the energy)")
        ax.set_ylabel("lambda, dual")
        ax.legend()
        return fig

    out.figure("flips_energy_change.png", fig)
