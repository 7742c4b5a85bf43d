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

from . import _arrays, assembly, diagnostics
from ._progress import Stages
from .properties import check

__all__ = ["report", "PAIRS"]

#: The operators of the report: (Laplacian kind, mass kind).
PAIRS = (("primal", "barycentric"), ("dual", "circumcentric"))


def report(V, T=None, *, nsd: bool = True, progress: bool | None = None) -> dict:
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

    Returns
    -------
    dict
        ``{"mesh": diagnostics summary, "primal": Report dict, "dual": Report dict}``; each
        Report dict includes its mass checks (``mass_min``, ``mass_nonpositive``,
        ``mass_total``, ``mesh_volume``).
    """
    V, T = _arrays.mesh(V, T)
    V = _arrays.points(V)
    T = _arrays.elements(T, 4)
    step = Stages("tetlap info", progress)
    step("mesh diagnostics")
    result = {"mesh": diagnostics.summary(V, T)}
    for lap, mass in PAIRS:
        step(f"{lap} Laplacian and {mass} mass")
        L, M = assembly.operators(V, T, lap, mass, degenerate="skip")
        step(f"checks of the {lap} Laplacian")
        result[lap] = check(L, V, T, M, kind=lap, nsd=nsd).to_dict()
    step.done()
    return result
