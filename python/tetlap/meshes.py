"""Built-in, seeded, deterministic tetrahedral meshes.

>>> import tetlap

Every generator returns ``(V, T)``: ``V`` (n, 3) float64, ``T`` (m, 4) int64, positively
oriented (``det[x1-x0, x2-x0, x3-x0] > 0``).

The generators built on Qhull or gmsh report their steps on stderr when ``progress`` is
True (default: when stderr is a terminal): the points, the tetrahedralisation (about 95% of
the time: 13 s for ``ball(100000)``), the clean-up.

Sizes, seeds and the other options are checked before any work (:class:`tetlap.OptionError`:
a size must be an integer, ``cube(2.5)`` is refused); sizes are bounded by
:data:`MAX_CUBE`, :data:`MAX_POINTS` and :data:`MIN_H`, and a size that does not fit in
memory all the same is an ``OptionError`` too, never a bare ``MemoryError``.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

from . import _arrays, _extras, _options
from ._progress import Stages
from .diagnostics import orientation, signed_volumes
from .errors import NonFiniteError, OptionError, ShapeError
from ._names import public_dir

__all__ = ["compact", "cube", "ball", "shell", "sphere3", "optimized_ball", "optimized_shell",
           "weighted_ball", "regular_triangulation", "single_tet", "orient", "MAX_CUBE",
           "MAX_POINTS", "MIN_H", "MAX_WEIGHT_SCALE"]
__dir__ = public_dir(globals())

#: The largest ``k`` of :func:`cube`: its ``6 k^3`` tets are within the core's limit
#: (``2^30 - 1`` tets, 32-bit element-corner ids).
MAX_CUBE = 563
#: The most points of the generators built on Qhull (:func:`ball`, :func:`shell`,
#: :func:`weighted_ball`, :func:`sphere3`): Qhull's tetrahedralisation takes about 3 KB a
#: point (0.6 GB and 19 s for 200,000 points), 30 GB at this bound.
MAX_POINTS = 10**7
#: The smallest mesh size of :func:`optimized_ball` and :func:`optimized_shell`: about 4
#: million tets on the unit ball.
MIN_H = 0.02
#: The largest ``weight_scale`` of :func:`weighted_ball` and :func:`shell`: weights of
#: 1000 ``h^2`` hide every interior point that can be hidden (Qhull's lifting loses its
#: precision far beyond).
MAX_WEIGHT_SCALE = 1e3


def _fits_in_memory(f):
    """``f`` with a ``MemoryError`` (of NumPy or Qhull) turned into an ``OptionError``
    naming the call."""
    @functools.wraps(f)
    def generator(*args, **kwargs):
        try:
            return f(*args, **kwargs)
        except MemoryError as e:
            given = ", ".join([*map(repr, args), *(f"{k}={v!r}" for k, v in kwargs.items())])
            raise OptionError(f"{f.__name__}({given}): the mesh does not fit in memory ({e}); "
                              "ask for a smaller one") from None
    return generator


def _size(n, least: int, most: int, name: str = "n") -> int:
    return _options.at_most(_options.count(n, name, least), most, name)


def _seed(seed) -> int:
    return _options.count(seed, "seed", least=0)


def _stages(name: str, progress) -> Stages:
    """The steps of the generator ``name`` on stderr (``progress``: True, False, or None
    for "when stderr is a terminal")."""
    return Stages(f"tetlap.meshes.{name}",
                  None if progress is None else _options.flag(progress, "progress"))


def _qhull(build, points: np.ndarray):
    """``build(points)`` (a scipy.spatial Delaunay or ConvexHull), Qhull's errors as a
    ShapeError: the points span no volume, or are too few."""
    from scipy.spatial import QhullError

    try:
        return build(points)
    except QhullError as e:
        first = str(e).strip().splitlines()[0]
        raise ShapeError(f"{len(points)} points span no tetrahedralisation (too few, or all "
                         f"in a plane; Qhull: {first})") from None


def orient(V, T) -> np.ndarray:
    """A copy of ``T`` with every negatively oriented tet made positive (corners 2, 3 swapped)."""
    T = np.array(T, dtype=np.int64)
    flip = orientation(V, T) < 0
    T[flip, 2], T[flip, 3] = T[flip, 3].copy(), T[flip, 2].copy()
    return T


def compact(V, T, *per_vertex):
    """Drop unreferenced vertices: ``(V[used], T renumbered, *(a[used] for a in
    per_vertex))``, order preserved."""
    V, T = np.asarray(V), np.asarray(T, dtype=np.int64)
    used = np.zeros(len(V), dtype=bool)
    used[T.ravel()] = True
    remap = np.cumsum(used) - 1
    return (V[used], remap[T], *(np.asarray(a)[used] for a in per_vertex))


def single_tet(kind: str = "corner"):
    """One positively oriented tet: ``"corner"`` (0,0,0),(1,0,0),(0,1,0),(0,0,1) or
    ``"regular"`` (edge 1, centred at the origin)."""
    if kind == "corner":
        V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    elif kind == "regular":
        s = 1 / np.sqrt(8)
        V = s * np.array([[1, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1]], dtype=np.float64)
    else:
        raise OptionError(f'kind must be "corner" or "regular", got {kind!r}')
    return V, np.array([[0, 1, 2, 3]], dtype=np.int64)


@_fits_in_memory
def cube(k: int = 4, *, jitter: float = 0.0, seed: int = 0):
    """The unit cube split into ``k^3`` cells of 6 Kuhn (Freudenthal) tets each, ``k`` an
    integer from 1 to :data:`MAX_CUBE`.

    ``jitter`` (0 to 0.25) moves interior vertices by up to ``jitter / k`` per coordinate
    (uniform, seeded by ``seed``, an integer >= 0), which breaks the grid's right angles
    while keeping the tets valid (a tet can be flat only at exactly 0.25).

    Example
    -------
    >>> V, T = cube(2)
    >>> V.shape, T.shape
    ((27, 3), (48, 4))
    """
    k = _size(k, 1, MAX_CUBE, "k")
    _options.at_most(_options.non_negative(jitter, "jitter"), 0.25, "jitter")
    _seed(seed)
    g = np.arange(k + 1)
    V = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3).astype(np.float64)
    index = lambda p: (p[..., 0] * (k + 1) + p[..., 1]) * (k + 1) + p[..., 2]
    corners = np.stack(np.meshgrid(*(np.arange(k),) * 3, indexing="ij"), -1).reshape(-1, 1, 3)
    tets = []
    for perm in itertools.permutations(range(3)):
        path = [np.zeros(3, dtype=np.int64)]
        for axis in perm:
            step = path[-1].copy()
            step[axis] += 1
            path.append(step)
        tets.append(index(corners + np.array(path)))
    T = np.concatenate(tets, axis=0)
    if jitter:
        interior = np.all((V > 0) & (V < k), axis=1)
        rng = np.random.default_rng(seed)
        V[interior] += rng.uniform(-jitter, jitter, size=(interior.sum(), 3))
    V /= k
    return V, orient(V, T)


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    r = np.sqrt(1 - z * z)
    phi = np.pi * (1 + 5**0.5) * i
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def _ball_points(n: int, rng) -> np.ndarray:
    n_boundary = min(n - 1, int(4 * n ** (2 / 3)))
    n_interior = n - n_boundary
    direction = rng.normal(size=(n_interior, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    radius = 0.97 * rng.uniform(size=(n_interior, 1)) ** (1 / 3)
    return np.vstack([_fibonacci_sphere(n_boundary), radius * direction]), n_boundary


def _drop_flat(V, T):
    vol = np.abs(signed_volumes(V, T))
    return T[vol > 1e-12 * vol.mean()]


@_fits_in_memory
def ball(n: int = 2000, *, seed: int = 0, progress=None):
    """Random Delaunay tetrahedralisation of the unit ball (slivers included), ``n`` points
    (4 to :data:`MAX_POINTS`).

    About ``4 n^(2/3)`` vertices lie exactly on the unit sphere (a Fibonacci lattice), the
    rest are uniform random in the ball; the tets are the Delaunay tetrahedralisation
    (``scipy.spatial.Delaunay``) with zero-volume hull slivers removed. ``progress``: the
    steps on stderr (module docs).

    Example
    -------
    >>> V, T = ball(500, seed=1)
    >>> bool(np.allclose(np.linalg.norm(V, axis=1).max(), 1.0))
    True
    """
    from scipy.spatial import Delaunay

    n = _size(n, 4, MAX_POINTS)
    step = _stages("ball", progress)
    step("points")
    V, _ = _ball_points(n, np.random.default_rng(_seed(seed)))
    step("Delaunay tetrahedralisation (Qhull)")
    T = _qhull(Delaunay, V).simplices.astype(np.int64)
    step("orient, drop flat tets")
    T = orient(V, _drop_flat(V, T))
    step.done()
    return V, T


def _shell_points(n: int, rng, radii=(0.5, 0.75, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Points on the three spheres (Fibonacci lattices, density matched to the interior)
    and uniform random points strictly between them; returns (V, sphere index or -1)."""
    r0, r1 = radii[0], radii[-1]
    volume = 4 / 3 * np.pi * (r1**3 - r0**3)
    h = (volume / n) ** (1 / 3)  # mean spacing
    counts = [max(12, int(4 * np.pi * r * r / (h * h) * 1.1)) for r in radii]
    n_inside = max(n - sum(counts), 1)
    direction = rng.normal(size=(n_inside, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    # uniform in volume, kept at least 0.3 h away from every sphere
    radius = (rng.uniform(r0**3, r1**3, size=(4 * n_inside, 1))) ** (1 / 3)
    far = np.min(np.abs(radius - np.array(radii)), axis=1) > 0.3 * h
    radius = radius[far][:n_inside]
    V = np.vstack([r * _fibonacci_sphere(c) for r, c in zip(radii, counts)] +
                  [radius * direction[: len(radius)]])
    label = np.concatenate([np.full(c, k) for k, c in enumerate(counts)] +
                           [np.full(len(radius), -1)])
    return V, label


@_fits_in_memory
def shell(n: int = 4000, *, seed: int = 0, weight_scale: float = 0.0, progress=None):
    """Random (weighted) Delaunay mesh of the spherical shell ``0.5 <= r <= 1`` with an
    interior sphere at ``r = 0.75`` (paper Sec. 8.1, Eq. 28).

    Vertices lie exactly (to rounding) on the three spheres; the rest are uniform in the
    shell, at least 0.3 mean spacings from the spheres (``n`` from 1 to :data:`MAX_POINTS`;
    at least 12 points lie on each sphere). The tets are the Delaunay (or, for
    ``weight_scale > 0``, up to :data:`MAX_WEIGHT_SCALE`, a regular triangulation with
    random interior weights as in :func:`weighted_ball`) of all points, minus those inside
    the inner sphere.

    Returns ``V, T, spheres`` with ``spheres`` (n,) int8: 0, 1, 2 for the vertices on the
    spheres of radius 0.5, 0.75, 1, and -1 for the others. ``progress``: the steps on
    stderr (module docs).

    Example
    -------
    >>> V, T, spheres = shell(2000, seed=1)
    >>> r = np.linalg.norm(V[spheres == 1], axis=1)
    >>> bool(np.allclose(r, 0.75, rtol=1e-14))
    True
    """
    n = _size(n, 1, MAX_POINTS)
    _weight_scale(weight_scale)
    rng = np.random.default_rng(_seed(seed))
    step = _stages("shell", progress)
    step("points")
    V, label = _shell_points(n, rng)
    h = (4 / 3 * np.pi * (1 - 0.125) / n) ** (1 / 3)
    w = rng.uniform(0, weight_scale * h * h, size=len(V))
    w[label >= 0] = 0
    T = _regular_triangulation(V, w, step)
    T = T[~(label[T] == 0).all(axis=1)]
    step.done()
    return compact(V, T, label.astype(np.int8))


def _weight_scale(value) -> float:
    return _options.at_most(_options.non_negative(value, "weight_scale"), MAX_WEIGHT_SCALE,
                            "weight_scale")


def regular_triangulation(V, weights) -> np.ndarray:
    """The regular (weighted Delaunay) tetrahedralisation of points ``V`` (n, 3) with
    ``weights`` (n,): the lower convex hull of the lifted points ``(x, |x|^2 - w)``
    (``scipy.spatial.ConvexHull``), zero-volume tets removed, positively oriented.
    Points whose weight is too small to appear are left unreferenced (see
    :func:`compact`). Zero weights give the Delaunay tetrahedralisation.

    Raises ShapeError for points that are not (n, 3) or span no volume (coplanar, fewer
    than 5), NonFiniteError for a coordinate or weight that is not finite."""
    return _regular_triangulation(V, weights, _stages("regular_triangulation", False))


def _regular_triangulation(V, weights, step: Stages) -> np.ndarray:
    from scipy.spatial import ConvexHull

    V = _arrays.points(V)
    if V.shape[1] != 3:
        raise ShapeError(f"V must have shape (n, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise NonFiniteError(f"V holds a coordinate that is not finite (vertex "
                             f"{int(np.argmax(~np.isfinite(V).all(axis=1)))})")
    w = _arrays.vector(weights, len(V), "weights")
    lifted = np.column_stack([V, (V**2).sum(axis=1) - w])
    step("regular tetrahedralisation (Qhull)")
    hull = _qhull(ConvexHull, lifted)
    T = hull.simplices[hull.equations[:, 3] < 0].astype(np.int64)
    step("orient, drop flat tets")
    return orient(V, _drop_flat(V, T))


@_fits_in_memory
def weighted_ball(n: int = 2000, weight_scale: float = 0.0, *, seed: int = 0, progress=None):
    """A ball meshed by a regular triangulation with random weights: non-Delaunay tets.

    The points of :func:`ball` (``n`` from 5 to :data:`MAX_POINTS`, ``weight_scale`` from
    0 to :data:`MAX_WEIGHT_SCALE`); interior points get weights uniform in
    ``[0, weight_scale * h^2]`` (``h`` the mean spacing ``(4/3 pi / n)^(1/3)``), boundary
    points weight 0, so the boundary stays the same (interior points that the weights hide
    are dropped). ``weight_scale = 0`` is the Delaunay
    ball; the fraction of non-Delaunay tets grows with ``weight_scale`` (n = 800: about
    5%, 10%, 17%, 33%, 48% for 0.05, 0.1, 0.2, 0.5, 1; see
    :func:`tetlap.diagnostics.non_delaunay_tets`). ``progress``: the steps on stderr
    (module docs).

    Example
    -------
    >>> import tetlap
    >>> V, T = weighted_ball(500, 1.0, seed=0)
    >>> bool(tetlap.diagnostics.non_delaunay_tets(V, T).mean() > 0.05)
    True
    """
    n = _size(n, 5, MAX_POINTS)
    _weight_scale(weight_scale)
    rng = np.random.default_rng(_seed(seed))
    step = _stages("weighted_ball", progress)
    step("points")
    V, n_boundary = _ball_points(n, rng)
    h = (4 / 3 * np.pi / n) ** (1 / 3)
    w = rng.uniform(0, weight_scale * h * h, size=n)
    w[:n_boundary] = 0
    T = _regular_triangulation(V, w, step)
    step.done()
    return compact(V, T)


@_fits_in_memory
def sphere3(n: int = 2000, *, seed: int = 0, progress=None):
    """Convex hull of ``n`` uniform random points on the unit 3-sphere in R^4 (paper
    Sec. 8.4): a closed tetrahedral 3-manifold immersed in R^4, extrinsically Delaunay
    (``n`` from 5 to :data:`MAX_POINTS`).

    Returns ``V`` (n, 4) float64 with ``|x| = 1`` and ``T`` (m, 4) int64. ``progress``: the
    steps on stderr (module docs).

    Example
    -------
    >>> V, T = sphere3(200, seed=0)
    >>> V.shape[1], bool(np.allclose(np.linalg.norm(V, axis=1), 1))
    (4, True)
    """
    from scipy.spatial import ConvexHull

    n = _size(n, 5, MAX_POINTS)
    rng = np.random.default_rng(_seed(seed))
    step = _stages("sphere3", progress)
    step("points")
    V = rng.normal(size=(n, 4))
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    step("convex hull (Qhull)")
    T = _qhull(ConvexHull, V).simplices.astype(np.int64)
    step.done()
    return V, T


def _gmsh():
    try:
        import gmsh
    except ImportError:
        raise ImportError(
            f"optimized (quality) Delaunay meshes need gmsh: {_extras.hint('meshing')}"
        ) from None
    return gmsh


def _gmsh_mesh(build, h: float, seed: int, step: Stages):
    """Run ``build(gmsh)`` (OCC geometry) and mesh it with HXT at size ``h``."""
    _options.at_least(_options.positive(h, "h"), MIN_H, "h")
    _options.at_most(_seed(seed), 2**31 - 1, "seed")   # gmsh's seed is a C int
    step("geometry (gmsh OCC)")
    gmsh = _gmsh()
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)  # deterministic
        gmsh.option.setNumber("Mesh.RandomSeed", seed)
        gmsh.model.add("tetlap")
        build(gmsh)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT
        step("tetrahedralisation (gmsh HXT)")
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        V = coords.reshape(-1, 3)
        index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        types, _, nodes = gmsh.model.mesh.getElements(3)
        T = np.concatenate([index[np.asarray(nd, dtype=np.int64).reshape(-1, 4)]
                            for t, nd in zip(types, nodes) if t == 4])
    finally:
        gmsh.finalize()
    step("orient")
    V, T = compact(V, T)
    T = orient(V, T)
    step.done()
    return V, T


@_fits_in_memory
def optimized_ball(h: float = 0.1, *, seed: int = 0, progress=None):
    """A quality Delaunay mesh of the unit ball from gmsh (OCC sphere, HXT), mesh size
    ``h`` (at least :data:`MIN_H`); needs the optional ``gmsh`` (``pip install
    ".[meshing]"``). ``progress``: the steps on stderr (module docs)."""
    return _gmsh_mesh(lambda g: g.model.occ.addSphere(0, 0, 0, 1), h, seed,
                      _stages("optimized_ball", progress))


@_fits_in_memory
def optimized_shell(h: float = 0.1, *, seed: int = 0, progress=None):
    """A quality Delaunay mesh of the shell ``0.5 <= r <= 1`` with a conforming sphere at
    0.75, from gmsh (OCC spheres + fragment, HXT). Returns ``V, T, spheres`` like
    :func:`shell` (vertices on a sphere to ~1e-12 are labelled). ``progress``: the steps
    on stderr (module docs)."""
    def build(g):
        outer = g.model.occ.addSphere(0, 0, 0, 1)
        middle = g.model.occ.addSphere(0, 0, 0, 0.75)
        inner = g.model.occ.addSphere(0, 0, 0, 0.5)
        shell_, _ = g.model.occ.cut([(3, outer)], [(3, inner)])
        g.model.occ.fragment(shell_, [(3, middle)])
        g.model.occ.synchronize()
        # the fragment also returns the part of the r = 0.75 ball inside r = 0.5 (volume
        # 0.52; the two shell layers have 1.24 and 2.42): drop it
        for dim, tag in g.model.getEntities(3):
            if g.model.occ.getMass(dim, tag) < 0.6:
                g.model.occ.remove([(dim, tag)], recursive=True)

    V, T = _gmsh_mesh(build, h, seed, _stages("optimized_shell", progress))
    r = np.linalg.norm(V, axis=1)
    spheres = np.full(len(V), -1, dtype=np.int8)
    for k, radius in enumerate((0.5, 0.75, 1.0)):
        spheres[np.abs(r - radius) < 1e-9] = k
    return V, T, spheres
