"""What ``tetlap info`` prints about regularity (moving to :mod:`tetlap.info`)."""

from __future__ import annotations

from .. import _arrays, assembly
from .conditions import _validated
from .result import RegularWeights

__all__ = ["summary"]


def summary(V, T, result: RegularWeights | None = None, *, nsd: bool = False,
            time_limit: float | None = None, reports: dict | None = None) -> dict:
    """Regularity and what the weighted dual gains, as a JSON-ready dict for ``tetlap info``.

    Parameters
    ----------
    V : (n, 3) array-like.  T : (m, 4) integer array-like.
    result : a :class:`RegularWeights` of this mesh (computed when None, with
        ``time_limit``).
    nsd : also check negative semidefiniteness of the three Laplacians (slow on big meshes).
    time_limit : an optional wall-clock limit for :func:`regular_weights` when ``result``
        is None (None, the default: its deterministic work budget alone).
    reports : optional ``{"dual": ..., "primal": ...}``, :meth:`tetlap.Report.to_dict`
        of the plain dual and the primal on this mesh (``tetlap info`` has them): their
        counts are used instead of checking those two Laplacians again.

    Returns
    -------
    dict with ``regular`` (bool), ``status`` (one of :data:`STATUSES`), ``margin``,
    ``margin_plain``, ``n_non_delaunay_faces``, ``n_weighted_vertices``,
    ``negative_interior_weights`` ({"dual", "weighted_dual", "primal"}: counts on edges
    not both on the boundary), ``nsd`` (same keys, or None), ``linear_precision_weighted_dual``
    (bool, None without interior vertices), ``masses_lost`` (count of positive plain
    circumcentric masses that the weights make non-positive), ``mass_min`` ({"dual",
    "weighted_dual"}), ``violated_faces`` (count), ``certificate_faces`` (count),
    ``iterations``, ``notes``, ``seconds`` (of :func:`regular_weights`).

    Example
    -------
    >>> import tetlap
    >>> from tetlap.regular import summary
    >>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    >>> s = summary(V, T)
    >>> s["status"], s["negative_interior_weights"]["weighted_dual"]
    ('regular', 0)
    """
    from ..properties import check
    from . import regular_weights

    V, T = _validated(V, T)
    r = regular_weights(V, T, time_limit=time_limit) if result is None else result
    if len(r.weights) != len(V):
        raise _arrays.ShapeError(f"the result has {len(r.weights)} weights, the mesh "
                                 f"{len(V)} vertices")
    reports = dict(reports or {})
    weights = r.weights if r.weights.any() else None
    kinds = {"dual": ("dual", None), "weighted_dual": ("dual", weights),
             "primal": ("primal", None)}
    for key, (kind, w) in kinds.items():
        if key == "weighted_dual" and w is None and not nsd and "dual" in reports:
            reports[key] = reports["dual"]
        if key not in reports or (nsd and reports[key].get("nsd") is None):
            L = assembly.laplacian(V, T, kind, weights=w, degenerate="skip")
            reports[key] = check(L, V, T, nsd=nsd).to_dict()
    return {
        "regular": bool(r.regular),
        "status": r.status,
        "margin": r.margin,
        "margin_plain": r.margin_plain,
        "n_non_delaunay_faces": r.n_violated_plain,
        "n_weighted_vertices": r.n_weighted_vertices,
        "negative_interior_weights": {k: int(reports[k]["n_negative_interior"])
                                      for k in kinds},
        "nsd": {k: reports[k]["nsd"] for k in kinds} if nsd else None,
        "linear_precision_weighted_dual": reports["weighted_dual"]["linear_precision_ok"],
        "masses_lost": int(len(r.masses_lost)),
        "mass_min": {"dual": r.mass_min_plain, "weighted_dual": r.mass_min_weighted},
        "violated_faces": int(len(r.violated_faces)),
        "certificate_faces": int(len(r.certificate_faces)),
        "certificate_kind": r.certificate_kind,
        "verification": r.verification,
        "iterations": r.iterations,
        "notes": list(r.notes),
        "seconds": r.seconds,
    }
