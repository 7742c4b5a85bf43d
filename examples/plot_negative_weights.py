"""
Negative weights, primal against dual
=====================================

The paper's Fig. 12: over many meshes, the fraction of negative edge weights (on edges
not both on the boundary) of each Laplacian. A negative weight breaks the discrete
maximum principle; the primal has them on almost every mesh, the dual of a Delaunay
mesh has none inside. Here on generated meshes: random Delaunay balls and shells (dual
without negative interior weights), jittered grids and weighted (regular, not Delaunay)
balls. The dual of a mesh that is not Delaunay can have more negative weights than
the primal: that is when the primal, or regular weights, serve better.
"""

import matplotlib.pyplot as plt
import numpy as np

import tetlap

meshes = {
    "ball": tetlap.meshes.ball(1500, seed=0),
    "shell": tetlap.meshes.shell(1500, seed=0)[:2],
    "grid, jitter 0.2": tetlap.meshes.cube(7, jitter=0.2, seed=0),
    "grid, jitter 0.24": tetlap.meshes.cube(7, jitter=0.24, seed=1),
    "weighted ball 0.5": tetlap.meshes.weighted_ball(1500, 0.5, seed=0),
    "weighted ball 1.0": tetlap.meshes.weighted_ball(1500, 1.0, seed=0),
}
fraction = {"primal": [], "dual": []}
for name, (V, T) in meshes.items():
    for kind in fraction:
        r = tetlap.check(tetlap.laplacian(V, T, kind), V, T, nsd=False)
        fraction[kind].append(r.negative_fraction_interior)
    print(f"{name:<18} primal {fraction['primal'][-1]:6.2%}  dual {fraction['dual'][-1]:6.2%}")

# %%
# One bar per mesh and operator.
x = np.arange(len(meshes))
fig, ax = plt.subplots(figsize=(8, 4), layout="constrained")
ax.bar(x - 0.2, fraction["primal"], 0.4, label="primal")
ax.bar(x + 0.2, fraction["dual"], 0.4, label="dual")
ax.set_xticks(x, list(meshes), rotation=20)
ax.yaxis.set_major_formatter(plt.matplotlib.ticker.PercentFormatter(1.0))
ax.set_ylabel("negative weights (edges not both on the boundary)")
ax.legend()
plt.show()
