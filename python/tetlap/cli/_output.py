"""Everything the ``tetlap`` command prints: the JSON documents, the text report of
``info`` (its regular-weights section included), the tables of ``improve`` and ``bench``,
the summary of ``experiment`` and the one-line errors. Each function returns the text;
the commands print it."""

from __future__ import annotations

import json
import math

# ---- JSON ------------------------------------------------------------------------------


def json_document(value, indent: int = 2) -> str:
    """``value`` as indented JSON that any parser reads: a NaN or infinite float becomes
    ``null`` and its path is listed under ``"non_finite"`` (added to a top-level dict), so
    that no value is out of range silently.

    >>> print(json_document({"a": 1.5, "b": [float("inf")]}))
    {
      "a": 1.5,
      "b": [
        null
      ],
      "non_finite": [
        "b.0"
      ]
    }
    """
    paths: list[str] = []

    def finite(v, path):
        if isinstance(v, float) and not math.isfinite(v):
            paths.append(".".join(path))
            return None
        if isinstance(v, dict):
            return {k: finite(x, path + [str(k)]) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [finite(x, path + [str(i)]) for i, x in enumerate(v)]
        return v

    clean = finite(value, [])
    if paths and isinstance(clean, dict):
        clean["non_finite"] = paths
    return json.dumps(clean, indent=indent, allow_nan=False)


# ---- cells -----------------------------------------------------------------------------


def _cell(value) -> str:
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return f"{value:.3e}"
    return str(value)


def _share(count: int, total: int) -> str:
    return f"{count}/{total} ({100 * count / total:.2f}%)" if total else "0/0"


def error_line(error: BaseException) -> str:
    """``tetlap: error: MESSAGE`` on one line, printable (:func:`printable`)."""
    return "tetlap: error: " + printable(" ".join(str(error).split()))


def printable(text: str) -> str:
    """``text`` that any stream can print: the bytes of a file name that are not UTF-8
    (which Python passes on as lone surrogates) become ``\\xNN`` escapes.

    >>> import os
    >>> printable(os.fsdecode(b"mesh-\\xff.vtu"))
    'mesh-\\\\xff.vtu'
    """
    try:
        return text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that no file name decodes to
        return text.encode("utf-8", "backslashreplace").decode("utf-8")


# ---- tetlap info -----------------------------------------------------------------------


def info_report(result: dict, source: str) -> str:
    """The text report of ``tetlap info``: the mesh, the property table of both
    Laplacians, how semidefiniteness was decided (in full), and the regular section."""
    m = result["mesh"]
    lines = [f"mesh: {source}",
             f"{m['n_vertices']} vertices ({m['n_boundary_vertices']} on the boundary, "
             f"{m['n_unreferenced_vertices']} unreferenced), {m['n_tets']} tets "
             f"({_cell(m['n_positive_tets'])} positive, {_cell(m['n_negative_tets'])} negative, "
             f"{m['n_degenerate_tets']} degenerate, {m['n_duplicate_tets']} duplicate)"]
    faces = (f"faces: {m['n_boundary_faces']} on the boundary, {m['n_interior_faces']} interior, "
             f"{m['n_nonmanifold_faces']} non-manifold")
    if m["non_delaunay_face_fraction"] is not None:
        faces += (f"; non-Delaunay: {_share(m['n_non_delaunay_faces'], m['n_interior_faces'])} "
                  f"of the interior faces, {100 * m['non_delaunay_tet_fraction']:.2f}% of the tets")
    lines.append(faces)
    angles = ("n/a" if m["min_dihedral_deg"] is None else
              f"{m['min_dihedral_deg']:.2f} .. {m['max_dihedral_deg']:.2f} deg")
    lines.append(f"dihedral angles {angles}; "
                 f"well-centered tets {100 * m['well_centered_tet_fraction']:.2f}%; "
                 f"volume {m['mesh_volume']:.10g}")
    if m["n_folded_tets"]:
        lines.append(_folded_line(m))
    p, d = result["primal"], result["dual"]
    rows = [
        ("finite", _cell(p["finite"]), _cell(d["finite"])),
        ("symmetric", _cell(p["symmetric"]), _cell(d["symmetric"])),
        ("zero row sums (max |row sum|)", _verdict(p["row_sums_ok"], p["max_row_sum"]),
         _verdict(d["row_sums_ok"], d["max_row_sum"])),
        ("linear precision (residual)", _verdict(p["linear_precision_ok"],
                                                 p["linear_precision_residual"]),
         _verdict(d["linear_precision_ok"], d["linear_precision_residual"])),
        ("negative semidefinite", _cell(p["nsd"]), _cell(d["nsd"])),
        ("min weight", _cell(p["min_weight"]), _cell(d["min_weight"])),
        ("negative weights", _share(p["n_negative"], p["n_edges"]),
         _share(d["n_negative"], d["n_edges"])),
        ("  edges not both on the boundary", _share(p["n_negative_interior"], p["n_edges_interior"]),
         _share(d["n_negative_interior"], d["n_edges_interior"])),
        ("mass total (vs volume)", f"{p['mass_total']:.10g}", f"{d['mass_total']:.10g}"),
        ("mass min", _cell(p["mass_min"]), _cell(d["mass_min"])),
        ("vertices with mass <= 0", str(p["mass_nonpositive"]), str(d["mass_nonpositive"])),
        ("tets skipped", str(p["n_skipped_tets"]), str(d["n_skipped_tets"])),
    ]
    if result.get("coefficient") is not None:   # each construction's own row in the metric
        rows[4:4] = [
            ("tets obtuse in the metric", _share(p["n_obtuse_tets_metric"], p["n_tets"]), "-"),
            ("faces not Delaunay in the metric", "-",
             _share(d["n_non_delaunay_faces_metric"], m["n_interior_faces"])),
        ]
    widths = [max(len(r[k]) for r in rows + [("property", "primal", "dual")]) for k in range(3)]
    lines += ["", f"{'property':<{widths[0]}}  {'primal':>{widths[1]}}  {'dual':>{widths[2]}}"]
    lines += [f"{label:<{widths[0]}}  {a:>{widths[1]}}  {b:>{widths[2]}}" for label, a, b in rows]
    lines += ["(mass: barycentric with the primal, circumcentric with the dual)", ""]
    c = result.get("coefficient")
    if c is not None:
        lines[-1:-1] = [f"(both built with a {'constant' if c['constant'] else 'varying'} "
                        f"{c['kind']} coefficient K; in the metric: each tet mapped by K^-1/2)"]
        lines += [f"{kind}: {note}" for kind, r in (("primal", p), ("dual", d))
                  for note in r["notes"] if note.startswith("linear precision: not applicable")]
    lines += [f"semidefinite ({kind}): {r['nsd_method']}" for kind, r in (("primal", p), ("dual", d))]
    lines += [_skipped_line(kind, r) for kind, r in (("primal", p), ("dual", d)) if r["n_skipped_tets"]]
    if result.get("regular") is not None:
        lines += ["", regular_section(result["regular"])]
    advice = next_steps(result)
    if advice:
        lines += ["", "what to do:"] + [f"- {line}" for line in advice]
    return "\n".join(lines)


def _verdict(ok, value) -> str:
    """A row's verdict and its number (``NO 3.081e-05``), or ``n/a``."""
    return "n/a" if ok is None else f"{_cell(ok)} {_cell(value)}"


def _listed(indices: list, count: int) -> str:
    return ", ".join(map(str, indices)) + (", ..." if count > len(indices) else "")


def _folded_line(m: dict) -> str:
    """The folded tets of ``tetlap info`` and the vertices they spoil."""
    return (f"folded: {m['n_folded_tets']} tets overlap a neighbour (both on one side of "
            f"their shared face; a reversed vertex order alone is no fold): "
            f"{_listed(m['folded_tets'], m['n_folded_tets'])}; every Laplacian loses linear "
            f"precision, by the folded tets' share, at the {m['n_folded_vertices']} "
            f"vertices of the {m['n_folded_faces']} folded faces: "
            f"{_listed(m['folded_vertices'], m['n_folded_vertices'])}")


def next_steps(result: dict) -> list[str]:
    """What ``tetlap info`` advises for what it found, each line only where the step fixes
    it: untangle folded tets; the primal where the dual is indefinite; the mixed mass where
    circumcentric masses are not positive; the weights of
    :func:`tetlap.regular_weights` where they make the dual's interior weights
    non-negative; the dual where the primal's are negative and the dual's are not."""
    m, p, d, r = result["mesh"], result["primal"], result["dual"], result.get("regular")
    advice = []
    if m["n_folded_tets"]:
        advice.append(f"untangle the {m['n_folded_tets']} folded tets (move their vertices "
                      "until each lies on its own side of its faces): no operator or option "
                      "restores linear precision at their vertices")
    if d["nsd"] is False and p["nsd"]:
        advice.append('the dual is indefinite here: for solves, eigenvalues, energies or heat, '
                      'use the primal, negative semidefinite on every mesh '
                      '(tetlap.laplacian(V, T, "primal"))')
    if d["mass_nonpositive"]:
        k = d["mass_nonpositive"]
        advice.append(f"{k} circumcentric {'mass is' if k == 1 else 'masses are'} <= 0 (no "
                      'lumped mass, no inverse there): mass="mixed" moves the centres that '
                      "fall outside their tets inside and is positive on every mesh "
                      '(tetlap.mass(V, T, "mixed"); "barycentric" is positive too)')
    negative = d["n_negative_interior"]
    if negative and r is None:
        if result.get("coefficient") is None:    # the search is for the plain dual
            advice.append(f"the dual has {negative} negative interior weights: run without "
                          "--no-regular to search for vertex weights that remove them")
    elif negative and r["status"] == "regular" and (
            (r.get("guarantees") or {}).get("nonnegative_interior") == "yes"):
        g = r["guarantees"]
        also = " and ".join(what for what, key in (
            ("is negative semidefinite", "semidefinite"),
            ("has positive control volumes", "positive_masses")) if g.get(key) == "yes")
        advice.append(f"vertex weights remove the dual's {negative} negative interior weights "
                      "(a maximum principle)" + (f", and the weighted dual {also}" if also
                                                 else "") + ": w = tetlap.regular_weights(V, "
                      'T).weights, then tetlap.laplacian(V, T, "dual", weights=w)')
    if p["n_negative_interior"] and not negative and d["nsd"] is not False:
        advice.append("for non-negative interior weights (a maximum principle) use the dual, "
                      'which has them here (tetlap.laplacian(V, T, "dual"))')
    return advice


def _skipped_line(kind: str, r: dict) -> str:
    """Which tets an operator of ``tetlap info`` left out, and why."""
    n, far = r["n_skipped_tets"], r["n_skipped_out_of_range"]
    named = _listed(r["skipped_tets"], n)
    return (f"skipped ({kind}): {n} tets ({n - far} flat, {far} with values beyond the float64 "
            f"range): {named}; the properties above are those of the operator without them")


def regular_section(r: dict) -> str:
    """The ``regular`` section of ``tetlap info``: the verdict and what the weights buy
    (:func:`tetlap.info.regular_summary`)."""
    if r["status"] == "n/a":
        return f"regular (weighted Delaunay): n/a ({r['reason']})"
    verdict = {"regular": "yes", "not regular": "no (proved)",
               "undecided": "undecided"}[r["status"]]
    n = r["negative_interior_weights"]
    g = r.get("guarantees") or {}
    safe = ("; the weighted dual: interior weights >= 0 {nonnegative_interior}, control "
            "volumes > 0 {positive_masses}, semidefinite {semidefinite}").format(**g) if g else ""
    weighted = r["n_weighted_vertices"]
    found = (f"with the weights found (on {weighted} vertices) {r['margin']:+.3e}" if weighted
             else "no weights needed" if r["margin_plain"] > 0
             else "the search found no better weights (all zero)")
    lines = [f"regular (weighted Delaunay): {verdict}{safe}",
             f"worst interior face (its dual edge's length over the face's size, > 0 at every "
             f"face: regular): {r['margin_plain']:+.3e} without weights; {found}",
             f"negative interior weights: dual {n['dual']}, weighted dual {n['weighted_dual']}, "
             f"primal {n['primal']}"]
    if r["status"] == "not regular":
        lines.append(f"proof: {r['certificate_faces']} interior faces whose conditions no "
                     "vertex weights meet together")
    elif r["status"] == "undecided":
        lines.append(f"undecided: {r['notes'][0] if r['notes'] else 'budget exhausted'} "
                     "(raise --regular-time)")
    lines.append(f"the search took {r['seconds']:.2f} s (--no-regular skips it)")
    return "\n".join(lines)


# ---- tetlap improve --------------------------------------------------------------------

_IMPROVE_ROWS = [
    ("negative interior dual weights", "negative_interior", "{:d}"),
    ("min interior dual weight", "min_interior_weight", "{:.3e}"),
    ("non-Delaunay interior faces", "non_delaunay_faces", "{:d}"),
    ("min dihedral angle (deg)", "min_dihedral_deg", "{:.2f}"),
    ("min tet volume", "min_volume", "{:.3e}"),
]


def improve_table(result) -> str:
    """The before/after numbers of a :class:`tetlap.improve.Improvement` as a small table."""
    width = max(len(r[0]) for r in _IMPROVE_ROWS)
    lines = [f"{'':<{width}}  {'before':>12}  {'after':>12}"]
    for label, key, fmt in _IMPROVE_ROWS:
        lines.append(f"{label:<{width}}  {fmt.format(result.before[key]):>12}  "
                     f"{fmt.format(result.after[key]):>12}")
    lines.append(f"{result.moved} vertices free to move, {result.iterations} iterations, "
                 f"{result.evaluations} evaluations, {result.seconds:.2f} s "
                 f"(objective {result.objective[0]:.4g} -> {result.objective[1]:.4g}); "
                 f"{result.message}")
    return "\n".join(lines)


# ---- tetlap bench ----------------------------------------------------------------------


def bench_table(records) -> str:
    """The records of :func:`tetlap.benchmark.run` as an aligned table; the last column
    (igl.cotmatrix's time over the case's) only when libigl was timed."""
    width = max([len(r["mesh"]) for r in records] + [4])
    igl = any(r["igl_cotmatrix_over_this"] is not None for r in records)
    head = (f"{'mesh':<{width}} {'tets':>9} {'case':<32} {'median':>10} {'Mtets/s':>8} "
            f"{'x floor':>8}")
    lines = [head + (f" {'igl.cot / this':>14}" if igl else "")]
    for r in records:
        line = (f"{r['mesh']:<{width}} {r['n_tets']:>9} {r['case']:<32} "
                f"{1e3 * r['median_s']:>8.2f}ms {r['mtets_per_s']:>8.2f} {r['vs_floor']:>8.2f}")
        if igl:
            ratio = r["igl_cotmatrix_over_this"]
            line += f" {ratio:>14.2f}" if ratio is not None else f" {'n/a':>14}"
        lines.append(line)
    return "\n".join(lines)


# ---- tetlap experiment -----------------------------------------------------------------


def experiment_summary(folder) -> str:
    """An experiment's ``summary.txt`` and the list of the files it wrote."""
    summary = (folder / "summary.txt").read_text().rstrip("\n")
    return f"{summary}\nfiles: {', '.join(sorted(p.name for p in folder.iterdir()))} in {folder}"
