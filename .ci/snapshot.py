"""Bitwise snapshot of tetlap's outputs, to prove a refactor changes no bit.

    python .ci/snapshot.py save before.json       # on the old tree (installed)
    python .ci/snapshot.py compare before.json    # on the new tree: lists every case that moved

Every public operator, option and route (one-shot, cached, updated, per element, triplets,
edge weights, derivatives, checks, diagnostics) on every corpus mesh
(``$TETLAP_MESHES``, default ``../shared/data/meshes``) and on generated tets and
triangles; each result is a SHA-256 of its arrays' bytes, dtypes and shapes. Cases whose
outputs an issue changes on purpose are listed with ``--except PREFIX`` at comparison.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

import tetlap


def digest(*values) -> str:
    h = hashlib.sha256()

    def add(v):
        if v is None:
            h.update(b"None")
        elif hasattr(v, "tocsr"):
            v = v.tocsr()
            for a in (v.data, v.indices, v.indptr):
                add(np.asarray(a))
        elif isinstance(v, np.ndarray):
            h.update(str((v.dtype.str, v.shape)).encode())
            h.update(np.ascontiguousarray(v).tobytes())
        elif isinstance(v, dict):
            for k in sorted(v):
                h.update(str(k).encode())
                add(v[k])
        elif isinstance(v, (list, tuple)):
            for x in v:
                add(x)
        elif isinstance(v, float):
            h.update(np.float64(v).tobytes())
        else:
            h.update(repr(v).encode())

    for v in values:
        add(v)
    return h.hexdigest()[:16]


def tet_cases(V, T):
    """(name, thunk) pairs for a tet mesh."""
    rng = np.random.default_rng(0)
    n = len(V)
    h2 = float(np.median(np.sum((V[T[:, 0]] - V[T[:, 1]]) ** 2, axis=1)))
    w = rng.uniform(0.0, 0.01 * h2, size=n)
    f = V[:, 0] ** 2 - V[:, 1] * V[:, 2]
    moved = V.copy()
    moved[rng.choice(n, size=min(20, n), replace=False)] += 1e-3 * np.sqrt(h2)
    skip = {"degenerate": "skip"}

    def cached():
        mesh = tetlap.Mesh(V, T, **skip)
        first = (mesh.laplacian("dual"), mesh.mass("circumcentric"), mesh.laplacian("primal"))
        info = mesh.update(moved)
        return first + (tuple(info), mesh.laplacian("dual"), mesh.mass("circumcentric"),
                        mesh.laplacian("primal"))

    yield "laplacian.primal", lambda: tetlap.laplacian(V, T, "primal", **skip)
    yield "laplacian.dual", lambda: tetlap.laplacian(V, T, "dual", **skip)
    yield "laplacian.affine", lambda: tetlap.laplacian(V, T, 0.3, **skip)
    for kind in ("barycentric", "circumcentric", "fem"):
        yield f"mass.{kind}", lambda kind=kind: tetlap.mass(V, T, kind, **skip)
    yield "operators", lambda: tetlap.operators(V, T, "dual", "circumcentric", **skip)
    yield "weighted.operators", lambda: tetlap.operators(V, T, "dual", "circumcentric",
                                                         weights=w, **skip)
    yield "barycentric.operators", lambda: tetlap.operators(V, T, "dual", "circumcentric",
                                                            boundary="barycentric", **skip)
    yield "contributions", lambda: tetlap.tet_contributions(V, T, "dual", **skip)
    yield "triplets", lambda: tuple(tetlap.triplets(V, T, "primal", **skip))
    yield "edge_weights", lambda: tetlap.edge_weights(V, T, 0.7, **skip)
    yield "cached", cached
    yield "derivatives.dual", lambda: tuple(tetlap.dirichlet_energy(V, T, f, "dual", **skip))
    yield "derivatives.weighted", lambda: tuple(tetlap.dirichlet_energy(
        V, T, f, "dual", weights=w, return_weights_gradient=True, **skip))
    yield "derivatives.mass", lambda: tuple(tetlap.mass_energy(V, T, f, "circumcentric", **skip))
    yield "check", lambda: tetlap.check(tetlap.laplacian(V, T, "dual", **skip), V, T,
                                        nsd=len(V) <= 3000).to_dict()
    yield "diagnostics", lambda: tetlap.diagnostics.summary(V, T)


def tri_cases(V, T):
    yield "tri.laplacian", lambda: tetlap.laplacian(V, T, "dual")
    yield "tri.operators", lambda: tetlap.operators(V, T, "primal", "circumcentric")
    yield "tri.mass.fem", lambda: tetlap.mass(V, T, "fem")


def meshes():
    folder = Path(os.environ.get("TETLAP_MESHES", "../shared/data/meshes"))
    for path in sorted(folder.iterdir()):
        if path.suffix in (".md", ".json", ".node"):
            continue
        V, T = tetlap.io.read(path)
        yield path.name, V, T, tet_cases
    yield "ball", *tetlap.meshes.ball(3000, seed=1), tet_cases
    yield "cube", *tetlap.meshes.cube(6, jitter=0.2), tet_cases
    V, T = tetlap.meshes.cube(5)
    F = np.unique(np.sort(T[:, :3], axis=1), axis=0)          # some triangles in R^3
    yield "triangles", V, F, tri_cases


def snapshot() -> dict:
    out = {}
    for name, V, T, cases in meshes():
        for case, thunk in cases(V, T):
            try:
                out[f"{name}/{case}"] = digest(thunk())
            except tetlap.TetlapError as e:
                out[f"{name}/{case}"] = f"error {type(e).__name__}: {e}"
        print(name, file=sys.stderr)
    return out


def main(argv: list[str]) -> int:
    if len(argv) < 2 or argv[0] not in ("save", "compare"):
        print(__doc__, file=sys.stderr)
        return 2
    if argv[0] == "save":
        Path(argv[1]).write_text(json.dumps(snapshot(), indent=1, sort_keys=True))
        return 0
    before = json.loads(Path(argv[1]).read_text())
    ignored = tuple(argv[argv.index("--except") + 1:]) if "--except" in argv else ()
    now = snapshot()
    moved = [k for k in sorted(set(before) | set(now))
             if before.get(k) != now.get(k) and not k.split("/", 1)[1].startswith(ignored or ("\0",))]
    for k in moved:
        print(f"{k}: {before.get(k)} -> {now.get(k)}")
    print(f"{len(now)} cases, {len(moved)} moved")
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
