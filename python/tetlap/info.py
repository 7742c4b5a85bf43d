"""``tetlap info``: one report of a mesh and of both Laplacians on it.

The mesh part is :func:`tetlap.diagnostics.summary`; each operator part is a
:class:`tetlap.Report` of :func:`tetlap.check` (the primal with the barycentric mass, the
dual with the circumcentric mass). Every step costs ``O(size of the mesh)`` and answers
Ctrl-C.

Example
-------
>>> import tetlap
>>> r = tetlap.info.report(*tetlap.meshes.cube(3))
>>> r["mesh"]["n_tets"], r["primal"]["nsd"], r["dual"]["n_negative_interior"]
(162, True, 0)
"""

from __future__ import annotations

import time

from . import _arrays, assembly, diagnostics
from ._progress import Stages
from .properties import NEGATIVE_TOL, _check

__all__ = ["report", "plot", "PAIRS", "REGULAR_TIME_LIMIT", "REGULAR_TIME_SHARE",
           "REGULAR_MAX_TETS"]

#: The operators of the report: (Laplacian kind, mass kind).
PAIRS = (("primal", "barycentric"), ("dual", "circumcentric"))


#: The default budget of the ``regular`` section (:func:`tetlap.regular.regular_weights`)
#: is ``REGULAR_TIME_SHARE`` times the time the rest of the report took, at least 1 s and
#: at most ``REGULAR_TIME_LIMIT`` seconds: past it the verdict is "undecided", so that
#: ``tetlap info`` costs at most 1.5x its other checks on big meshes (which are ``O(m)``).
REGULAR_TIME_LIMIT = 10.0
REGULAR_TIME_SHARE = 0.5
#: Above this many tets the default report leaves the search out (``status`` "n/a"): its
#: set-up alone (NumPy, about 2.5 s per 1M tets here) exceeds the budget. An explicit
#: ``regular_time_limit`` runs it at any size.
REGULAR_MAX_TETS = 300_000


def report(V, T=None, *, nsd: bool = True, progress: bool | None = None,
           regular: bool = True, regular_time_limit: float | None = None) -> dict:
    """The report of ``tetlap info`` as a JSON-ready dict.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers
        Vertex positions (an immersed mesh, d > 3, gets the checks that apply).
    T : (m, 4) array-like of integers
        Tets, any orientation; degenerate tets are counted and skipped by the operators.
    nsd : bool, default True
        False skips the semidefiniteness certificates.
    progress : bool, optional
        Report each step on stderr (default: when stderr is a terminal).
    regular : bool, default True
        Add the ``regular`` section: is the mesh regular (weighted Delaunay), and what the
        weighted dual with the weights found gains (:func:`tetlap.regular.summary`).
    regular_time_limit : float, optional
        Seconds for that search; past it its ``status`` is ``"undecided"``. Default:
        half the time the rest of the report took, clamped to [1, 10] seconds
        (:data:`REGULAR_TIME_SHARE`, :data:`REGULAR_TIME_LIMIT`), and no search above
        :data:`REGULAR_MAX_TETS` tets.

    Returns
    -------
    dict
        ``{"mesh": diagnostics summary, "primal": Report dict, "dual": Report dict,
        "regular": dict or None}``; each Report dict includes its mass checks
        (``mass_min``, ``mass_nonpositive``, ``mass_total``, ``mesh_volume``). ``regular``
        is :func:`tetlap.regular.summary` (``status`` "regular", "not regular" or
        "undecided", ``margin``, ``negative_interior_weights`` of the dual, the weighted
        dual and the primal, ...), ``{"status": "n/a", "reason": ...}`` when it does not
        apply (points not in R^3, flat tets), None with ``regular=False``.
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    start = time.perf_counter()
    step = Stages("tetlap info", progress)
    step("mesh diagnostics")
    summary, boundary = diagnostics._summary(V, T)
    result = {"mesh": summary}
    for lap, mass in PAIRS:
        step(f"{lap} Laplacian and {mass} mass")
        L, M = assembly.operators(V, T, lap, mass, degenerate="skip")
        step(f"checks of the {lap} Laplacian")
        # L is laplacian(V, T, lap, degenerate="skip") bitwise: the certificates need no gap
        result[lap] = _check(L, V, T, M, kind=lap, negative_tol=NEGATIVE_TOL, nsd=nsd,
                             boundary=boundary, mesh_volume=result["mesh"]["mesh_volume"],
                             assembled=True).to_dict()
    result["regular"] = None
    if regular:
        step("regular weights")
        if regular_time_limit is None and len(T) > REGULAR_MAX_TETS:
            result["regular"] = {"status": "n/a", "reason": (
                f"{len(T)} tets > {REGULAR_MAX_TETS}: not searched by default, pass a time "
                "limit (--regular-time S) to search")}
        else:
            if regular_time_limit is None:
                spent = time.perf_counter() - start
                regular_time_limit = min(REGULAR_TIME_LIMIT, max(1.0, REGULAR_TIME_SHARE * spent))
            result["regular"] = _regular_section(V, T, result, regular_time_limit)
    step.done()
    return result


def _regular_section(V, T, result, time_limit) -> dict:
    """:func:`tetlap.regular.summary` with the plain dual's and the primal's reports
    reused; ``{"status": "n/a", "reason": ...}`` where regularity is not defined."""
    from .errors import TetlapError
    from .regular import summary

    if V.shape[1] != 3:
        return {"status": "n/a", "reason": f"points in R^{V.shape[1]}, not R^3"}
    try:
        return summary(V, T, time_limit=time_limit,
                       reports={"dual": result["dual"], "primal": result["primal"]})
    except TetlapError as error:       # flat tets: no power centers
        return {"status": "n/a", "reason": str(error).splitlines()[0]}


def plot(V, T=None, folder=".") -> list:
    """Histograms of a mesh's dihedral angles, of the edge weights of both Laplacians and of
    the barycentric and circumcentric masses, as PNG files in ``folder`` (created if
    needed); returns their paths. Needs matplotlib (``pip install 'tetlap[experiments]'``).

    Example
    -------
    >>> import tempfile, tetlap
    >>> files = tetlap.info.plot(*tetlap.meshes.cube(3, jitter=0.2), tempfile.mkdtemp())
    >>> sorted(p.name for p in files)
    ['dihedral_angles.png', 'masses.png', 'weights.png']
    """
    import pathlib

    import numpy as np

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError("info plots need matplotlib: pip install 'tetlap[experiments]'") from None
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []

    def save(fig, name):
        path = folder / name
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)

    angles = diagnostics.dihedral_angles(V, T).ravel()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.hist(angles[np.isfinite(angles)], bins=90, range=(0, 180))
    ax.set_xlabel("dihedral angle (degrees)")
    ax.set_ylabel("tet edges")
    ax.set_title(f"dihedral angles of {len(T)} tets")
    save(fig, "dihedral_angles.png")

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, kind in zip(axes, ("primal", "dual")):
        _, w = assembly.edge_weights(V, T, kind, degenerate="skip")
        negative = (w < 0).mean() if len(w) else 0.0
        ax.hist(w, bins=100, color="tab:blue" if kind == "primal" else "tab:orange")
        ax.axvline(0, color="k", lw=0.8)
        ax.set_yscale("log")
        ax.set_xlabel("edge weight w_ij")
        ax.set_title(f"{kind}: {100 * negative:.2f}% negative")
    fig.suptitle("edge weights of the two Laplacians")
    save(fig, "weights.png")

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, kind in zip(axes, ("barycentric", "circumcentric")):
        m = assembly.mass(V, T, kind, degenerate="skip").diagonal()
        ax.hist(m, bins=100)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_yscale("log")
        ax.set_xlabel("vertex mass")
        ax.set_title(f"{kind}: {int((m <= 0).sum())} <= 0")
    fig.suptitle("lumped masses")
    save(fig, "masses.png")
    return paths
