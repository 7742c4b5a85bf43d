"""
Dual cells
==========

The dual Laplacian is a finite-volume scheme whose control volumes are the Voronoi cells
of the vertices, clipped by the mesh's boundary. :func:`tetlap.io.dual_cells` returns
them as polyhedra (to write as a ``.vtu`` file for ParaView, or to draw), and their
volumes are the circumcentric masses. Here the cells of a few vertices of a jittered
cube grid.
"""

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

import tetlap

V, T = tetlap.meshes.cube(4, jitter=0.15, seed=0)
cells = tetlap.io.dual_cells(V, T)
print(cells)
M = tetlap.mass(V, T, "circumcentric")
print("volumes equal the circumcentric masses:",
      np.allclose(cells.volumes(), M.diagonal()[cells.vertex]))

# %%
# Four cells: an interior one and three that meet the boundary.
fig = plt.figure(figsize=(6, 5.5), layout="constrained")
ax = fig.add_subplot(projection="3d")
chosen = [62, 0, 3, 15]
for colour, c in zip(plt.cm.tab10.colors, chosen):
    faces = cells.cell_faces[cells.cell_offsets[c]:cells.cell_offsets[c + 1]]
    polygons = [cells.points[cells.faces[cells.face_offsets[f]:cells.face_offsets[f + 1]]]
                for f in faces]
    ax.add_collection3d(Poly3DCollection(polygons, facecolors=colour, edgecolors="k",
                                         linewidths=0.3, alpha=0.55))
    ax.plot(*V[cells.vertex[c]], "ko", markersize=3)
ax.set_box_aspect((1, 1, 1))
ax.set_xlim(0, 1)
ax.set_ylim(0, 1)
ax.set_zlim(0, 1)
ax.set_title("dual cells of four vertices of a jittered grid")
plt.show()
