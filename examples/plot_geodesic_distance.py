"""
Geodesic distance by the heat method
====================================

The distance from a point measured inside a solid, around its holes and corners, is what
path planning, offset surfaces and shape descriptors need. :class:`tetlap.HeatDistance`
computes it by the heat method (a heat step, the normalised gradient, a Poisson solve):
it factorizes once, and each further source costs two solves. On a ball the geodesic
distance is the Euclidean one, so the error shows.
"""

import matplotlib.pyplot as plt
import numpy as np

import tetlap

V, T = tetlap.meshes.ball(4000, seed=0)
heat = tetlap.HeatDistance(V, T)
source = int(np.argmin(np.linalg.norm(V - [0.0, 0.0, -1.0], axis=1)))  # a boundary vertex
d = heat.distance(source)
exact = np.linalg.norm(V - V[source], axis=1)
print(f"mean error: {np.abs(d - exact).mean() / exact.max():.2%} of the largest distance")

# %%
# The field on the vertices near the plane ``y = 0``, and the distance against the
# Euclidean one at every vertex.
near = np.abs(V[:, 1]) < 0.1
fig, (left, right) = plt.subplots(1, 2, figsize=(9, 4), layout="constrained")
points = left.scatter(V[near, 0], V[near, 2], c=d[near], s=12, cmap="viridis")
left.plot(*V[source, [0, 2]], "r*", markersize=14, label="source")
left.set_aspect("equal")
left.set_title("heat-method distance near y = 0")
left.legend(loc="upper right")
fig.colorbar(points, ax=left)
right.plot(exact, d, ".", markersize=2)
right.plot([0, 2], [0, 2], "k--", linewidth=1, label="exact")
right.set_xlabel("Euclidean distance")
right.set_ylabel("heat-method distance")
right.legend()
plt.show()
