"""
Convergence in an anisotropic medium
====================================

``-div(K grad u) = f`` with a constant tensor ``K``: every Laplacian of tetlap takes it as
``coefficient=K``. The primal (P1 finite elements) converges at second order in L2 on
any mesh. The dual "in the metric ``K^-1``" (circumcentres of each tet mapped by
``K^-1/2``) is an orthogonal finite-volume scheme only where the mesh is Delaunay in that
metric; on a mesh made for ``K = I`` many of its interior weights are negative and it
does not converge. :func:`tetlap.regular_weights` with ``coefficient=K`` looks for vertex
weights that repair it (or proves that none exist).

Here the FVCA6 benchmark's test 1 (``K = [[1, .5, 0], [.5, 1, .5], [0, .5, 1]]``,
``u = 1 + sin(pi x) sin(pi (y + 1/2)) sin(pi (z + 1/3))``) on random Delaunay balls
(Delaunay for ``K = I``, not in the metric), ``u`` given on the boundary; the command
``tetlap experiment anisotropic`` runs it on the benchmark's own meshes, with a
strongly anisotropic case and the cell-centred scheme too.
"""

import matplotlib.pyplot as plt
import numpy as np

import tetlap
from tetlap.experiments.anisotropic import CASES

case = CASES[0]                 # K, u, its gradient and f = -div(K grad u)
K = case.K

rows = []
for n in (1000, 2000, 4000, 8000):
    V, T = tetlap.meshes.ball(n, seed=0)
    fixed = tetlap.diagnostics.boundary_vertices(T, len(V))
    M = tetlap.mass(V, T).diagonal()            # the barycentric (lumped) load
    u = case.u(V)
    edges = tetlap.diagnostics.mesh_edges(T)
    row = {"h": np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean()}
    for kind in ("primal", "dual"):
        L = tetlap.laplacian(V, T, kind, coefficient=K)
        x = tetlap.solve.dirichlet(L, fixed, u, rhs=-M * case.f(V))
        row[kind] = np.sqrt(np.sum(M * (x - u) ** 2) / np.sum(M * u**2))
        negative = tetlap.analysis.negative_weights(L, V, T)[1]
        row[f"{kind} negative"] = negative
    rows.append(row)
    print(f"{len(T):6d} tets: relative L2 error primal {row['primal']:.2e}, dual in the metric "
          f"{row['dual']:.2e} ({row['dual negative']} negative interior weights)")

# %%
# The errors against the mean edge length: the primal follows ``h^2``, the dual in the
# metric does not converge. (On structured grids, jittered Kuhn cubes for instance, it
# does converge, negative weights and all: a comparison needs unstructured meshes.)
h = np.array([r["h"] for r in rows])
fig, ax = plt.subplots(figsize=(5.5, 4.2), layout="constrained")
for kind, marker in (("primal", "o"), ("dual", "s")):
    ax.loglog(h, [r[kind] for r in rows], marker=marker,
              label="primal with K" if kind == "primal" else "dual in the metric K^-1")
ax.loglog(h, rows[0]["primal"] * (h / h[0]) ** 2, "k:", label="h^2")
ax.set_xlabel("mean edge length h")
ax.set_ylabel("relative L2 error")
ax.set_title("-div(K grad u) = f, FVCA6 test 1")
ax.legend()
plt.show()
