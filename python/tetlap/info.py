"""``tetlap info``: one report of a mesh and of both Laplacians on it.

The mesh part is :func:`tetlap.diagnostics.summary`; each operator part is a
:class:`tetlap.Report` of :func:`tetlap.check` (the primal with the barycentric mass, the
dual with the circumcentric mass); the regular part is :func:`regular_summary`. Every step
costs ``O(size of the mesh)`` and answers Ctrl-C. The fields of the report (the JSON of
``tetlap info --json``) are documented in the API reference, "The tetlap info JSON",
versioned by :data:`SCHEMA_VERSION`.

A mesh whose tet volumes leave the float64 range (coordinates beyond about ``1e100`` or
below ``1e-100`` for a tet of unit shape) is refused with
:class:`tetlap.DegenerateElementError` before any work, as the assembly refuses it: its
volumes, masses and "degenerate" counts would be wrong. The operators are assembled with
``degenerate="skip"``: the tets they leave out (flat ones, and those whose values leave
the float64 range, such as a needle whose dual weights overflow) are counted and named
in each operator's section (``n_skipped_tets``, ``skipped_tets``), since the properties
reported are then those of the operator without them.

Example
-------
>>> import tetlap
>>> r = tetlap.info.report(*tetlap.meshes.cube(3))
>>> r["schema_version"], r["mesh"]["n_tets"], r["primal"]["nsd"], r["dual"]["n_negative_interior"]
(5, 162, True, 0)
"""

from __future__ import annotations


import numpy as np

from . import _arrays, _extras, _options, assembly, diagnostics
from . import coefficient as _coefficient
from ._float_range import check_float_range
from ._progress import Stages
from .errors import ShapeError, TetlapError
from .analysis import NEGATIVE_TOL, _check, _constant, check, lumped_masses, negative_weights
from .regular import RegularWeights, regular_weights
from ._names import public_dir

__all__ = ["report", "regular_summary", "plot", "plot_names", "PAIRS", "SCHEMA_VERSION",
           "REGULAR_MAX_TETS"]
__dir__ = public_dir(globals())

#: The version of the report's layout (its keys and their meaning), the first key of
#: ``tetlap info --json``; raised with every change, each noted in the :doc:`/project/changelog`.
#: 1: the counts at the top level, ``negative_weight_fraction_interior``; 2: the counts
#: under ``"mesh"``, ``negative_fraction_interior``, ``schema_version`` itself; 3:
#: ``nsd_min_eigenvalue`` renamed ``nsd_min_eigenvalue_upper_bound`` (a witness's
#: Rayleigh quotient is an upper bound, not the eigenvalue), ``regular.guarantees``; 4:
#: the folds under ``"mesh"`` (``n_folded_faces``, ``n_folded_tets``, ``folded_tets``,
#: ``n_folded_vertices``, ``folded_vertices``), ``linear_precision_residual`` measured in
#: a frame centred on the mesh; 5: ``coefficient`` at the top level, and in each operator
#: ``coefficient``, ``n_obtuse_tets_metric``, ``obtuse_tets_metric``,
#: ``n_non_delaunay_faces_metric``, ``non_delaunay_faces_metric`` (Table 1 in the metric).
SCHEMA_VERSION = 5

#: The operators of the report: (Laplacian kind, mass kind).
PAIRS = (("primal", "barycentric"), ("dual", "circumcentric"))


#: The ``regular`` section runs :func:`tetlap.regular.regular_weights` on its deterministic
#: work budget (:data:`tetlap.regular.MAX_ITERATIONS`), so two runs print the same answer
#: on any machine and under any load. Above this many tets the default report leaves the
#: search out (``status`` "n/a"); an explicit ``regular_time_limit`` (a wall-clock opt-in)
#: runs it at any size.
REGULAR_MAX_TETS = 300_000


def report(V, T=None, *, nsd: bool = True, progress: bool | None = None,
           regular: bool = True, regular_time_limit: float | None = None,
           coefficient=None) -> dict:
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
        weighted dual with the weights found gains (:func:`regular_summary`).
    regular_time_limit : float > 0, optional
        An explicit wall-clock limit in seconds for that search, on top of its work
        budget; past it its ``status`` is ``"undecided"`` and the report depends on the
        machine's speed and load. Default None: the work budget alone (the same report
        on every run), and no search above :data:`REGULAR_MAX_TETS` tets.
    coefficient : array-like of real numbers, optional
        A coefficient of ``div(K grad u)`` (``(m,)``, ``(m, 3, 3)`` or ``(3, 3)``, as
        :func:`tetlap.laplacian` takes it and validated by the same rule): both operators
        are built with it and checked in its metric (:func:`tetlap.check` with
        ``coefficient=``); the ``regular`` section, a search for weights of the plain
        dual, is then "n/a".

    Returns
    -------
    dict
        ``{"schema_version": SCHEMA_VERSION, "mesh": diagnostics summary, "primal": Report
        dict, "dual": Report dict, "regular": dict or None}``; each Report dict includes
        its mass checks (``mass_min``, ``mass_nonpositive``, ``mass_total``,
        ``mesh_volume``). ``regular`` is :func:`regular_summary` (``status`` "regular",
        "not regular" or "undecided", ``margin``, ``negative_interior_weights`` of the
        dual, the weighted dual and the primal, ...), ``{"status": "n/a", "reason": ...}``
        when it does not apply (points not in R^3, flat tets, a big mesh without a time
        limit), None with ``regular=False``. ``coefficient``: None, or ``{"kind": "scalar"
        | "tensor", "constant": bool}``. Every float is finite.

    Raises
    ------
    OptionError
        ``regular_time_limit`` not a positive number (before any work).
    DegenerateElementError
        A tet volume beyond the float64 range (see the module docs), before any work.
    """
    if regular_time_limit is not None:
        _options.positive(regular_time_limit, "regular_time_limit")
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    K = None if coefficient is None else _coefficient.check(coefficient, V, T)
    check_float_range(V, T)
    step = Stages("tetlap info", progress)
    step("mesh diagnostics")
    summary, boundary = diagnostics._summary(V, T)
    result = {"schema_version": SCHEMA_VERSION, "mesh": summary}
    for lap, mass in PAIRS:
        step(f"{lap} Laplacian and {mass} mass")
        L, M, skipped = assembly._operators_skipping(V, T, lap, mass, K)
        step(f"checks of the {lap} Laplacian")
        # L is laplacian(V, T, lap, degenerate="skip") bitwise: the certificates need no gap
        result[lap] = _check(L, V, T, M, kind=lap, negative_tol=NEGATIVE_TOL, nsd=nsd,
                             boundary=boundary, mesh_volume=result["mesh"]["mesh_volume"],
                             assembled=True, coefficient=K).to_dict()
        result[lap].update(_skipped(skipped, result[lap]["notes"]))
    result["regular"] = None
    if regular:
        step("regular weights")
        if K is not None:
            result["regular"] = {"status": "n/a", "reason": (
                "regular weights are searched for the plain dual; the operators here are "
                "built with a coefficient")}
        elif regular_time_limit is None and len(T) > REGULAR_MAX_TETS:
            result["regular"] = {"status": "n/a", "reason": (
                f"{len(T)} tets > {REGULAR_MAX_TETS}: not searched by default, pass a time "
                "limit (--regular-time S) to search")}
        else:
            result["regular"] = _regular_section(V, T, result, regular_time_limit)
    result["coefficient"] = None if K is None else {
        "kind": "scalar" if K.ndim == 1 else "tensor", "constant": _constant(K)}
    step.done()
    return result


#: How many skipped tets the report names.
SKIPPED_LISTED = 10


def _skipped(skipped: np.ndarray, notes: list) -> dict:
    """The report's fields on the tets an operator left out (``degenerate="skip"``; the
    (k, 2) array of :func:`tetlap.assembly._operators_skipping`), with a note when there
    are any: its other fields are those of the operator without them."""
    tets = [int(t) for t in skipped[:SKIPPED_LISTED, 0]]
    out_of_range = int((skipped[:, 1] == 1).sum())
    if len(skipped):
        named = ", ".join(map(str, tets)) + (", ..." if len(skipped) > len(tets) else "")
        notes.append(f"{len(skipped)} tets skipped ({len(skipped) - out_of_range} flat, "
                     f"{out_of_range} with values beyond the float64 range): {named}; the "
                     "properties are those of the operator without them")
    return {"n_skipped_tets": len(skipped), "n_skipped_out_of_range": out_of_range,
            "skipped_tets": tets}


def _regular_section(V, T, result, time_limit) -> dict:
    """:func:`regular_summary` with the plain dual's and the primal's reports reused;
    ``{"status": "n/a", "reason": ...}`` where regularity is not defined."""
    if V.shape[1] != 3:
        return {"status": "n/a", "reason": f"points in R^{V.shape[1]}, not R^3"}
    try:
        return regular_summary(V, T, time_limit=time_limit,
                               reports={"dual": result["dual"], "primal": result["primal"]})
    except TetlapError as error:       # flat tets: no power centers
        return {"status": "n/a", "reason": " ".join(str(error).split())}


def regular_summary(V, T, result: RegularWeights | None = None, *, nsd: bool = False,
                    time_limit: float | None = None, reports: dict | None = None) -> dict:
    """Regularity and what the weighted dual gains: the ``regular`` section of the report.

    Parameters
    ----------
    V : (n, 3) array-like of real numbers
    T : (m, 4) array-like of integers
    result : RegularWeights, optional
        :func:`tetlap.regular_weights` of this mesh (computed when None, with
        ``time_limit``).
    nsd : bool, default False
        Also check negative semidefiniteness of the three Laplacians (slow on big meshes).
    time_limit : float, optional
        An explicit wall-clock limit for :func:`tetlap.regular_weights` when ``result``
        is None (None, the default: its deterministic work budget alone); past it the
        verdict is ``"undecided"``.
    reports : dict, optional
        ``{"dual": ..., "primal": ...}``, :meth:`tetlap.Report.to_dict` of the plain dual
        and the primal on this mesh (``tetlap info`` has them): their counts are used
        instead of checking those two Laplacians again.

    Returns
    -------
    dict
        ``regular`` (bool), ``status`` (``"regular"``, ``"not regular"`` or
        ``"undecided"``), ``guarantees`` (:attr:`tetlap.RegularWeights.guarantees`:
        "yes", "no" or "not checked" for non-negative interior weights, positive control
        volumes and semidefiniteness of the weighted dual), ``margin``, ``margin_plain``, ``n_non_delaunay_faces``,
        ``n_weighted_vertices``, ``negative_interior_weights`` ({"dual",
        "weighted_dual", "primal"}: counts on edges not both on the boundary), ``nsd``
        (same keys, or None), ``linear_precision_weighted_dual`` (bool, None without
        interior vertices), ``masses_lost`` (count of positive plain circumcentric masses
        that the weights make non-positive), ``mass_min`` ({"dual", "weighted_dual"}),
        ``violated_faces`` (count), ``certificate_faces`` (count), ``iterations``,
        ``notes``, ``seconds`` (of :func:`tetlap.regular_weights`).

    Example
    -------
    >>> import tetlap
    >>> V, T = tetlap.meshes.weighted_ball(400, 1.0, seed=0)
    >>> s = tetlap.info.regular_summary(V, T)
    >>> s["status"], s["negative_interior_weights"]["weighted_dual"]
    ('regular', 0)
    """
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    if V.shape[1] != 3:
        raise ShapeError(f"regular weights need points in R^3, got V of shape {V.shape}")
    if result is None:
        result = regular_weights(V, T, time_limit=time_limit)
    if len(result.weights) != len(V):
        raise ShapeError(f"the result has {len(result.weights)} weights, the mesh "
                         f"{len(V)} vertices")
    reports = dict(reports or {})
    weights = result.weights if result.weights.any() else None
    kinds = {"dual": ("dual", None), "weighted_dual": ("dual", weights),
             "primal": ("primal", None)}
    for key, (kind, w) in kinds.items():
        if key == "weighted_dual" and w is None and not nsd and "dual" in reports:
            reports[key] = reports["dual"]
        if key not in reports or (nsd and reports[key].get("nsd") is None):
            L = assembly.laplacian(V, T, kind, weights=w, degenerate="skip")
            reports[key] = check(L, V, T, nsd=nsd).to_dict()
    return {
        "regular": bool(result.regular),
        "status": result.status,
        "guarantees": result.guarantees,
        "margin": result.margin,
        "margin_plain": result.margin_plain,
        "n_non_delaunay_faces": result.n_violated_plain,
        "n_weighted_vertices": result.n_weighted_vertices,
        "negative_interior_weights": {k: int(reports[k]["n_negative_interior"])
                                      for k in kinds},
        "nsd": {k: reports[k]["nsd"] for k in kinds} if nsd else None,
        "linear_precision_weighted_dual": reports["weighted_dual"]["linear_precision_ok"],
        "masses_lost": int(len(result.masses_lost)),
        "mass_min": {"dual": result.mass_min_plain,
                     "weighted_dual": result.mass_min_weighted},
        "violated_faces": int(len(result.violated_faces)),
        "certificate_faces": int(len(result.certificate_faces)),
        "iterations": result.iterations,
        "notes": list(result.notes),
        "seconds": result.seconds,
    }


# ---- plots ----------------------------------------------------------------------------


def pyplot():
    """matplotlib's ``pyplot`` on the Agg backend, or an ImportError saying how to install
    it (``tetlap info --plot`` calls it before any analysis)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ImportError(f"info plots need matplotlib: {_extras.hint('experiments')}") from None
    return plt


def spread_bins(values, per_decade: int = 8):
    """Histogram bins and a linear threshold for values that may span many orders of
    magnitude and both signs (the weights and masses of a mesh with slivers): log-spaced
    bins for ``|x|`` from ``threshold`` (a thousandth of the median non-zero ``|x|``) up to
    ``max|x|``, ``per_decade`` per decade (at most 400), mirrored for negative values, and
    one bin ``[-threshold, threshold]``; draw them on ``symlog`` axes with that threshold.

    >>> bins, threshold = spread_bins([-1.0, 0.5, 2.0, 1e3])
    >>> threshold, float(bins[0]) < -1 < 1e3 <= float(bins[-1])
    (0.0015, True)
    """
    size = np.abs(np.asarray(values, dtype=np.float64))
    nonzero = size[size > 0]
    threshold = 1e-3 * float(np.median(nonzero)) if nonzero.size else 1.0
    top = max(float(size.max()) if size.size else 0.0, 10 * threshold)
    count = min(400, int(np.ceil(np.log10(top / threshold) * per_decade)))
    outer = np.geomspace(threshold, top, count + 1)
    outer[-1] = np.nextafter(top, np.inf)
    return np.concatenate([-outer[::-1], outer]), threshold


def spread_ticks(values, bins, threshold: float) -> tuple[list[float], list[str]]:
    """The ticks and labels of a :func:`spread_bins` axis: at most three decades a side
    (none within a decade of the linear part), a side without values left out, and always
    ``-threshold``, ``0`` and ``threshold`` (labelled ``-t``, ``0``, ``t``), the bounds of
    the one linear bin around 0; :func:`plot` gives ``t`` in the axis label.

    >>> values = [-1.0, 0.5, 2.0, 1e3]
    >>> ticks, labels = spread_ticks(values, *spread_bins(values))
    >>> ticks[2:7], labels[2:7]
    ([-0.1, -0.0015, 0.0, 0.0015, 0.1], ['$-10^{-1}$', '$-t$', '$0$', '$t$', '$10^{-1}$'])
    """
    values = np.asarray(values, dtype=np.float64)
    low, high = np.log10(threshold), np.floor(np.log10(bins[-1]))
    step = max(1, int(np.ceil((high - low - 1) / 3)))
    decades = np.arange(high, low + 1, -step)
    below, above = (values < -threshold).any(), (values > threshold).any()
    left = [-float(10.0**k) for k in decades] if below else []
    right = [float(10.0**k) for k in decades[::-1]] if above else []
    ticks = left + [-float(threshold), 0.0, float(threshold)] + right
    labels = ([f"$-10^{{{np.log10(-x):.0f}}}$" for x in left] + ["$-t$", "$0$", "$t$"]
              + [f"$10^{{{np.log10(x):.0f}}}$" for x in right])
    return ticks, labels


def plot_names(name: str) -> list[str]:
    """The file names :func:`plot` writes for a mesh named ``name``.

    >>> plot_names("cube")
    ['cube_dihedral_angles.png', 'cube_weights.png', 'cube_masses.png']
    """
    return [f"{name}_{what}.png" for what in ("dihedral_angles", "weights", "masses")]


def plot(V, T=None, folder=".", name: str = "mesh") -> list:
    """Histograms of a mesh's dihedral angles, of the edge weights of both Laplacians and of
    the barycentric and circumcentric masses, as PNG files ``NAME_dihedral_angles.png``,
    ``NAME_weights.png`` and ``NAME_masses.png`` (:func:`plot_names`) in ``folder``
    (created if needed); returns their paths. Titles name the mesh (a lone surrogate of
    ``name``, from a file name that is not UTF-8, escaped). Weights and masses are binned
    on symmetric log scales (:func:`spread_bins`), so that slivers' huge values do not
    collapse the rest into one bar; the linear bin around 0 is shaded, with 0 and its
    bounds ``-t``, ``t`` labelled (:func:`spread_ticks`; ``t`` in the axis label). The
    titles count as the report does: weights negative by :data:`NEGATIVE_TOL`
    (:func:`tetlap.analysis.negative_weights`), masses over the vertices in tets
    (:func:`tetlap.analysis.lumped_masses`, also what the mass histograms show). Needs
    matplotlib (``pip install ".[experiments]"``), checked first.

    Example
    -------
    >>> import tempfile, tetlap
    >>> files = tetlap.info.plot(*tetlap.meshes.cube(3, jitter=0.2), tempfile.mkdtemp(), "cube")
    >>> sorted(p.name for p in files)
    ['cube_dihedral_angles.png', 'cube_masses.png', 'cube_weights.png']
    """
    import pathlib

    plt = pyplot()
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    check_float_range(V, T)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    files = dict(zip(("dihedral_angles", "weights", "masses"), plot_names(name)))
    title = name.encode("utf-8", "backslashreplace").decode("utf-8")  # no lone surrogates

    def save(fig, what):
        path = folder / files[what]
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        paths.append(path)

    def spread(ax, values, color, what):
        from matplotlib.ticker import NullLocator

        bins, threshold = spread_bins(values)
        ax.hist(values, bins=bins, color=color)
        ax.set_xscale("symlog", linthresh=threshold, linscale=1.5)
        ax.set_yscale("log")
        # the one linear bin [-threshold, threshold] shaded, 0 (the black line) and its
        # bounds labelled; a side without values shown only to -threshold
        ax.axvspan(-threshold, threshold, color="0.9", zorder=0)
        ax.axvline(0, color="k", lw=0.8)
        below, above = (values < -threshold).any(), (values > threshold).any()
        ax.set_xlim(bins[0] if below else -threshold, bins[-1] if above else threshold)
        ax.set_xticks(*spread_ticks(values, bins, threshold))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xlabel(f"{what} (symmetric log scale)\nshaded: one bin [-t, t], "
                      f"t = {threshold:.1e}")

    angles = diagnostics.dihedral_angles(V, T).ravel()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.hist(angles[np.isfinite(angles)], bins=90, range=(0, 180))
    ax.set_yscale("log")
    ax.set_xlabel("dihedral angle (degrees)")
    ax.set_ylabel("tet edges")
    ax.set_title(f"{title}: dihedral angles of its {len(T)} tets")
    save(fig, "dihedral_angles")

    # the counts of the titles are those of the table, by its rules: a weight is negative
    # by NEGATIVE_TOL, a mass is counted over the vertices in tets
    edges = diagnostics.mesh_edges(T)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, kind in zip(axes, ("primal", "dual")):
        L = assembly.laplacian(V, T, kind, degenerate="skip")
        w = np.asarray(L[edges[:, 0], edges[:, 1]], dtype=np.float64).ravel()
        negative = negative_weights(L, V, T)[0] / len(w) if len(w) else 0.0
        spread(ax, w, "tab:blue" if kind == "primal" else "tab:orange", "edge weight w_ij")
        ax.set_ylabel("edges")
        ax.set_title(f"{kind} Laplacian: {100 * negative:.2f}% of the weights negative")
    fig.suptitle(f"{title}: edge weights of the two Laplacians")
    save(fig, "weights")

    fig, axes = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    for ax, kind in zip(axes, ("barycentric", "circumcentric")):
        m = lumped_masses(assembly.mass(V, T, kind, degenerate="skip"), T, len(V))
        spread(ax, m, None, "vertex mass")
        ax.set_ylabel("vertices in tets")
        ax.set_title(f"{kind} mass: {int((m <= 0).sum())} of {len(m)} vertices with mass <= 0")
    fig.suptitle(f"{title}: lumped masses")
    save(fig, "masses")
    return paths
