"""The result of :func:`tetlap.regular.regular_weights` and its statuses."""

from __future__ import annotations

import dataclasses

import numpy as np
from .._names import public_dir

__all__ = ["RegularWeights", "STATUSES", "ANSWERS"]
__dir__ = public_dir(globals())

#: The values of :attr:`RegularWeights.status`: ``"regular"`` (the weights returned make
#: every interior face strictly locally regular: checked), ``"not regular"`` (proved: a
#: checked certificate, :attr:`RegularWeights.certificate_kind`) and ``"undecided"``
#: (neither within the budget; the notes say why).
STATUSES = ("regular", "not regular", "undecided")
#: The values of the three guarantees of :class:`RegularWeights`
#: (:attr:`~RegularWeights.nonnegative_interior`, :attr:`~RegularWeights.positive_masses`,
#: :attr:`~RegularWeights.semidefinite`): checked true, checked false, or not decided.
ANSWERS = ("yes", "no", "not checked")


def _empty_faces() -> np.ndarray:
    return np.zeros((0, 3), dtype=np.int64)


@dataclasses.dataclass
class RegularWeights:
    """Result of :func:`tetlap.regular.regular_weights`.

    Attributes
    ----------
    weights : (n,) float64, squared-length units, sign convention of ``weights=`` (larger =
        bigger power cell). Zero on unreferenced vertices, and everywhere when the mesh is
        strictly Delaunay. Pass them on: ``tetlap.laplacian(V, T, "dual", weights=r.weights)``.
    status : str, one of :data:`STATUSES`.
    regular : bool, ``status == "regular"``: every interior face is strictly locally regular
        for ``weights`` (checked as ``verification`` says), every face is shared by at most
        two tets, and none is folded; then every interior weighted-dual weight is ``>= 0``.
    margin : float, the smallest face margin for ``weights`` (scale-free; module
        :mod:`~tetlap.regular.conditions`), in float64; 0.0 without interior faces.
    violated_faces : (k, 3) int64, the interior faces that are not strictly locally regular
        for ``weights`` (margin ``<= 0`` exactly; folded faces included).
    face_margins : (f,) float64, every interior face's margin for ``weights``, order of
        :func:`tetlap.diagnostics.interior_faces`.
    margin_plain : float, the smallest margin at ``w = 0``.
    n_violated_plain : int, interior faces that are not locally Delaunay (margin ``< 0``
        at ``w = 0``, beyond rounding).
    n_cospherical_plain : int, interior faces whose margin at ``w = 0`` is 0 to rounding
        (cospherical, as in a Kuhn grid): not strictly regular, so repaired like the
        violated ones.
    n_folded : int, folded interior faces (both tets on one side: no weights repair them).
    n_nonmanifold : int, faces shared by more than two tets.
    target_margin : float, the margin aimed for on repaired faces.
    margin_floor : float or None, the margin the search guaranteed on the repaired faces
        before the mass step (which keeps at least half of it); None when nothing was
        repaired or the mesh is not regular.
    n_weighted_vertices : int, vertices with a non-zero weight.
    n_negative_interior_plain, n_negative_interior_weighted : int, negative weights (as
        :func:`tetlap.check` counts them, :func:`tetlap.properties.negative_weights`) on
        edges whose endpoints are not both on the boundary, plain dual vs weighted dual.
    mass_min_plain, mass_min_weighted : float, smallest circumcentric mass (cell volume)
        over the vertices in tets, in the caller's units (inf or 0 when the cube of the
        mesh's size leaves the float64 range).
    masses_lost : (k,) int64, vertices whose plain circumcentric mass is positive but whose
        weighted one is not (the mass step's target: none).
    masses_below_floor : (k,) int64, vertices whose weighted mass fell below ``mass_floor``
        times their positive plain mass (``masses_lost`` included).
    seconds : float, wall time (the only field that depends on the machine).
    notes : list of str, what happened (phases, relaxations, why undecided).
    certificate_kind : str or None, the proof of ``"not regular"``: ``"gordan"``
        (multipliers on face margins that cancel for every weight), ``"folded"`` or
        ``"non-manifold"``; None otherwise.
    certificate_faces : (k, 3) int64, the faces of that proof; empty otherwise.
    certificate_multipliers : (k,) float64 > 0: for ``"gordan"``, multipliers ``y`` with
        ``sum_f y_f margin_f(w)`` = 0 for every ``w`` (exact multipliers, rounded), so some
        face of the certificate has margin ``<= 0`` whatever the weights; ones otherwise.
    verification : str, how the status was checked, independently of the search.
    nonnegative_interior : str, one of :data:`ANSWERS`: whether every weight of the
        weighted dual on an edge not both on the boundary is non-negative
        (``n_negative_interior_weighted == 0``, the rule of :func:`tetlap.check`).
        ``"regular"`` implies it (up to that rule's rounding tolerance); the field is
        checked on the weighted dual itself, whatever the status.
    positive_masses : str, one of :data:`ANSWERS`: whether every weighted circumcentric
        mass (control volume) is positive where the plain dual's is (``masses_lost``
        empty); ``n_masses_nonpositive_plain`` says how many are not positive in the
        plain dual already. A "no" is about these weights only: there is no proof that no
        regular weights keep them (the mass step is a search, :mod:`~tetlap.regular.masses`).
    semidefinite : str, one of :data:`ANSWERS`: whether the weighted dual is negative
        semidefinite, decided by :func:`tetlap.check`'s certificates (``semidefinite_method``
        names the one that decided, or why none did: then ``"not checked"``).
    semidefinite_method : str.
    n_masses_nonpositive_plain : int, vertices in tets whose plain circumcentric mass is
        ``<= 0``.
    iterations : int, L-BFGS iterations (search and mass step).
    lp_count : int, certificate LPs solved.
    mass_rounds : int, rounds of the mass step.
    """

    weights: np.ndarray
    status: str
    margin: float
    violated_faces: np.ndarray
    face_margins: np.ndarray
    margin_plain: float
    n_violated_plain: int
    n_cospherical_plain: int
    n_folded: int
    n_nonmanifold: int
    target_margin: float
    margin_floor: float | None
    n_weighted_vertices: int
    n_negative_interior_plain: int
    n_negative_interior_weighted: int
    mass_min_plain: float
    mass_min_weighted: float
    masses_lost: np.ndarray
    masses_below_floor: np.ndarray
    seconds: float
    notes: list[str] = dataclasses.field(default_factory=list)
    certificate_kind: str | None = None
    certificate_faces: np.ndarray = dataclasses.field(default_factory=_empty_faces)
    certificate_multipliers: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    verification: str = ""
    iterations: int = 0
    lp_count: int = 0
    mass_rounds: int = 0
    nonnegative_interior: str = "not checked"
    positive_masses: str = "not checked"
    semidefinite: str = "not checked"
    semidefinite_method: str = ""
    n_masses_nonpositive_plain: int = 0

    @property
    def regular(self) -> bool:
        return self.status == "regular"

    @property
    def guarantees(self) -> dict[str, str]:
        """What the weights give a finite-volume code, each one of :data:`ANSWERS`:
        ``{"nonnegative_interior", "positive_masses", "semidefinite"}``. Being regular is
        not all of it: a regular mesh's weights can still lose control volumes at the
        boundary and leave the weighted dual indefinite."""
        return {"nonnegative_interior": self.nonnegative_interior,
                "positive_masses": self.positive_masses, "semidefinite": self.semidefinite}

    def to_dict(self) -> dict:
        """A JSON-ready dict of the scalar fields and counts (arrays summarised as
        ``n_<name>``; ``weights``, ``face_margins`` and ``certificate_multipliers`` left
        out)."""
        out = {"regular": self.regular, "guarantees": self.guarantees}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if f.name in ("weights", "face_margins", "certificate_multipliers"):
                continue
            if isinstance(v, np.ndarray):
                out[f"n_{f.name}"] = int(len(v))
            elif isinstance(v, list):
                out[f.name] = list(v)
            else:
                out[f.name] = v
        return out

    def __str__(self) -> str:
        verdict = {"regular": "yes", "not regular": "NO (proved)",
                   "undecided": "undecided"}[self.status]
        shout = {"yes": "yes", "no": "NO", "not checked": "not checked"}
        # no certificate that no weights keep them exists yet: say so
        lost = (f" ({len(self.masses_lost)} lost; no proof either way that other weights "
                "keep them)" if len(self.masses_lost) else "")
        lines = [
            f"regular: {verdict}; interior weights >= 0: {shout[self.nonnegative_interior]}; "
            f"control volumes > 0 where the plain dual's are: "
            f"{shout[self.positive_masses]}{lost}; semidefinite: {shout[self.semidefinite]}",
            f"margin {self.margin:.3e} (plain dual {self.margin_plain:.3e}, "
            f"{self.n_violated_plain} non-Delaunay and {self.n_cospherical_plain} cospherical "
            "faces)",
            f"weights: {self.n_weighted_vertices} non-zero; negative interior weights "
            f"{self.n_negative_interior_plain} (plain dual) -> "
            f"{self.n_negative_interior_weighted} (weighted dual)",
            f"masses: min {self.mass_min_plain:.3e} -> {self.mass_min_weighted:.3e}; "
            f"{len(self.masses_lost)} turned non-positive, {len(self.masses_below_floor)} "
            f"below the floor ({self.n_masses_nonpositive_plain} non-positive in the plain "
            "dual)",
        ]
        if self.semidefinite_method:
            lines.append(f"semidefinite: {self.semidefinite_method}")
        if len(self.violated_faces):
            lines.append(f"violated faces: {len(self.violated_faces)} ({self.n_folded} folded)")
        if self.certificate_kind is not None:
            lines.append(f"certificate ({self.certificate_kind}): "
                         f"{len(self.certificate_faces)} faces that no weights make all "
                         "strictly locally regular")
        if self.verification:
            lines.append(f"verified: {self.verification}")
        return "\n".join(lines + [f"note: {n}" for n in self.notes])
