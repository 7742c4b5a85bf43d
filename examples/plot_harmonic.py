"""
A harmonic field and its maximum principle
==========================================

A harmonic field (``L f = 0`` inside, values given on the boundary) interpolates
boundary data smoothly: harmonic coordinates, deformation, temperature at equilibrium.
The continuous field stays between the smallest and largest boundary values; the
discrete one does so when every weight on an edge with a free endpoint is non-negative.
:func:`tetlap.harmonic` with ``laplacian="auto"`` picks an operator for which this is
proved on your mesh. Here a step (0 on one half of the sphere, 1 on the other) on a
random Delaunay ball: the dual keeps every value in [0, 1]; the primal, with negative
weights, overshoots.
"""

import matplotlib.pyplot as plt
import numpy as np

import tetlap

V, T = tetlap.meshes.ball(3000, seed=0)
fixed = tetlap.diagnostics.boundary_vertices(V, T)
step = (V[fixed, 0] > 0).astype(float)

auto = tetlap.harmonic(V, T, fixed, step)
primal = tetlap.harmonic(V, T, fixed, step, laplacian="primal")
for r in (auto, primal):
    print(f"{r.laplacian}: proved {r.proved}, {r.out_of_range} values outside [0, 1]")
print("primal:", primal.reason)

# %%
# The values of the free vertices, and how far each operator leaves [0, 1].
free = ~fixed
fig, (left, right) = plt.subplots(1, 2, figsize=(9, 4), layout="constrained")
near = free & (np.abs(V[:, 1]) < 0.1)
points = left.scatter(V[near, 0], V[near, 2], c=auto.field[near], s=12, cmap="coolwarm",
                      vmin=0, vmax=1)
left.set_aspect("equal")
left.set_title(f"{auto.laplacian} Laplacian, near y = 0")
fig.colorbar(points, ax=left)
bins = np.linspace(-0.05, 1.05, 45)
right.hist(primal.field[free], bins=bins, alpha=0.6, label="primal")
right.hist(auto.field[free], bins=bins, alpha=0.6, label=auto.laplacian)
for edge in (0, 1):
    right.axvline(edge, color="k", linewidth=1)
right.set_yscale("log")
right.set_xlabel("value at a free vertex")
right.set_ylabel("vertices")
right.legend()
plt.show()
