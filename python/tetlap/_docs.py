"""The parameter descriptions that every operator function shares, written once.

``@shared_docs`` replaces a line holding only ``{name}`` in a docstring by the fragment
``name`` below, indented like the placeholder, so that ``help(tetlap.laplacian)`` shows
every option in full. Literal braces in a docstring that uses it are doubled.
"""

from __future__ import annotations

import re
import textwrap

FRAGMENTS = {
    "mesh": """\
V : (n, d) array-like of real numbers
    Vertex positions, any real dtype (converted to float64). ``d >= 3`` for tets,
    ``d >= 2`` for triangles; a larger ``d`` means an immersed mesh (e.g. a
    tetrahedralised 3-sphere in R^4), every element computed in its own 3-space (2-space).
T : (m, 4) or (m, 3) array-like of integers, optional
    Tets or triangles: 0-based vertex indices, any integer dtype, any orientation (results
    do not depend on the orientation or vertex order of an element). Leave it out to pass
    one mesh object as ``V`` instead: a ``meshio.Mesh``, a ``pyvista.UnstructuredGrid`` or
    anything with ``points`` and tetra or triangle cells (see
    :func:`tetlap.io.from_mesh`), followed by the arguments after ``T``
    (``laplacian(mesh, "dual")``).""",
    "tet_mesh": """\
V : (n, d) array-like of real numbers
    Vertex positions, any real dtype (converted to float64), ``d >= 3``; a larger ``d``
    means an immersed mesh (e.g. a tetrahedralised 3-sphere in R^4), every tet computed in
    its own 3-space.
T : (m, 4) array-like of integers
    Tets: 0-based vertex indices, any integer dtype, any orientation (results do not depend
    on the orientation or vertex order of a tet). Triangles ``(m, 3)`` are refused
    (:class:`tetlap.ShapeError`): the derivatives are those of tets. A mesh object may be
    passed as ``V`` with ``T=None``, as for :func:`tetlap.laplacian`.""",
    "kind": """\
kind : {"primal", "dual"} or float, default "primal"
    ``"primal"``: P1 FEM / cotan weights (paper Eq. 7), always negative semidefinite.
    ``"dual"``: circumcentric DEC / finite-volume weights (Eq. 17-20), non-negative on
    the interior of Delaunay meshes. A float ``t`` in [0, 1]: the affine family
    ``(1 - t) L_primal + t L_dual`` (Sec. 9). For triangles primal and dual coincide (the
    cotan Laplacian, Eq. 6 and Eq. 16 as two routes).""",
    "mass_kind": """\
kind : {"barycentric", "circumcentric", "mixed", "fem"}, default "barycentric"
    ``"barycentric"``: ``Vol / 4`` per tet corner (``Area / 3`` per triangle corner),
    diagonal (Eq. 3). ``"circumcentric"``: the signed dual-cell volumes ``Vol(*i)``
    (Eq. 4, 21), diagonal; negative entries are possible on non-Delaunay meshes.
    ``"mixed"``: the circumcentric cells with every centre that falls outside its face or
    tet moved inside it (libigl's "hybrid Voronoi" rule: to the midpoint of the edge, or
    the centre of the face, opposite its most negative barycentric coordinate), diagonal
    and positive on every mesh; of the plain circumcentres (no vertex weights). ``"fem"``: the consistent P1 mass
    ``Vol (1 + delta_ab) / 20`` (triangles: ``/ 12``), not diagonal.""",
    "options": """\
boundary_centres : {"circumcentric", "barycentric"}, default "circumcentric"
    The dual's centres in tets with a boundary face (paper Sec. 6). ``"barycentric"``: in
    such tets a tet or face circumcenter outside its simplex is replaced by the centroid,
    which makes their contributions to dual weights and circumcentric masses non-negative,
    at the cost of linear precision at their vertices. Affects the dual and the
    circumcentric mass; tets only. (Called ``boundary`` until 0.1; that name still works,
    deprecated.)
weights : (n,) array-like of real numbers, optional
    Vertex weights in squared-length units for the dual and the circumcentric mass:
    weighted circumcenters (equal power ``|c - x_i|^2 - w_i``), i.e. the orthogonal dual
    of a regular triangulation (a power diagram). ``None`` or zeros: the plain dual.
    Tets only. A request that does not depend on them (the primal, the barycentric,
    mixed or FEM mass, alone) refuses them with :class:`tetlap.OptionError`.
degenerate : {"raise", "skip"}, default "raise"
    A zero-volume element (exactly flat), or one whose values leave the float64 range
    (a needle or a flat tet whose exact weights or masses overflow; see
    :doc:`/guide/accuracy`), raises :class:`tetlap.DegenerateElementError` naming it, or with
    ``"skip"`` contributes nothing to what it fails (its edges stay in the pattern).
threads : int, optional
    Worker threads, from 1 to ``tetlap.MAX_THREADS`` (four per core); ``None`` uses
    ``RAYON_NUM_THREADS`` if it is set (0 means all cores; a value outside 0 to
    ``MAX_THREADS`` is an :class:`tetlap.OptionError`, as for ``threads``), else all
    cores. The output is bitwise identical for any value.""",
    "coefficient": """\
coefficient : array-like of real numbers, optional
    ``K`` of ``div(K grad u)`` (a conductivity, a diffusivity), per element: ``(m,)``
    positive scalars, ``(m, 3, 3)`` symmetric positive definite tensors per tet (``(m, 2,
    2)`` per triangle of a mesh in the plane), or one ``(3, 3)`` (``(2, 2)``) tensor for
    every element; tensors need the mesh in its own space (not immersed). Primal:
    ``L_ij = -sum_t Vol_t grad(phi_i) . K_t grad(phi_j)``. Dual: each tet's circumcentric
    contribution in the metric ``K_t^-1`` (of the tet mapped by ``K_t^-1/2``) times
    ``sqrt(det K_t)``, with ``weights`` as powers in that metric; a scalar ``c`` gives ``c``
    times the plain contribution (with ``weights``: ``c`` times that of the weights ``c w``,
    powers measured in the metric). ``None``: the plain operator, bitwise. A per-vertex field
    goes through :func:`tetlap.coefficient.from_vertices` first; bad values raise
    :class:`tetlap.CoefficientError` or :class:`tetlap.NonFiniteError` naming the element
    (:doc:`/guide/media`).""",
    "density": """\
density : (m,) array-like of real numbers, optional
    A positive factor per element for the masses (``rho c_p`` of a heat problem): every
    mass kind's contributions of element ``t`` times ``density[t]``. ``None``: the plain
    masses, bitwise.""",
    "dual_mesh": """\
V : (n, d) array-like of real numbers
    Vertex positions, ``d >= 3`` (``d > 3``: an immersed mesh; centres lie in each tet's
    own 3-space).
T : (m, 4) array-like of integers, optional
    Tets, any orientation; leave it out to pass one mesh object as ``V``. Triangles are
    refused (:class:`tetlap.ShapeError`).
weights : (n,) array-like of real numbers, optional
    Vertex weights in squared-length units, as ``weights=`` of :func:`tetlap.laplacian`:
    power centres (equal power ``|c - x_i|^2 - w_i`` to the corners) instead of
    circumcentres, the orthogonal dual of a regular triangulation (e.g.
    ``tetlap.regular_weights(V, T).weights``).
threads : int, optional
    Worker threads (``None``: all cores); the output is bitwise identical for any.""",
    "raises": """\
Raises
------
TypeError
    ``V`` or ``T`` is not an array-like at all.
tetlap.TetlapError
    A subclass naming the offending element, vertex or value for any bad input
    (``ShapeError``, ``DtypeError``, ``EmptyMeshError``, ``IndexRangeError``,
    ``NonFiniteError``, ``RepeatedVertexError``, ``DegenerateElementError``,
    ``OptionError``); every one is a ``ValueError``.
KeyboardInterrupt
    On Ctrl-C; nothing is left half-built.""",
}

_PLACEHOLDER = re.compile(r"^([ \t]*)\{(\w+)\}[ \t]*$", re.MULTILINE)


def expand(doc: str) -> str:
    """``doc`` with every placeholder line replaced by its fragment."""

    def fragment(match: re.Match) -> str:
        indent, name = match.groups()
        return textwrap.indent(FRAGMENTS[name], indent)

    return _PLACEHOLDER.sub(fragment, doc).replace("{{", "{").replace("}}", "}")


def shared_docs(f):
    """Decorator: expand the placeholders of ``f.__doc__``."""
    f.__doc__ = expand(f.__doc__)
    return f
