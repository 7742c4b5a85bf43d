"""
Eigenmodes of a real mesh
=========================

The vibration modes of a solid, the first terms of a spectral shape descriptor and the
slow modes of diffusion are the smallest eigenpairs of ``-L x = lambda M x``.
:func:`tetlap.solve.eigs` finds them with a sparse factorization and proves that none
below them was missed. Here: the first modes of a tetrahedral armadillo from the
real-mesh corpus with a free (Neumann) boundary, the first eigenvalue 0 (the constant),
and the next modes drawn on the surface.
"""

import os
import pathlib

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

import tetlap

# %%
# The mesh: ``pbd_armadillo_4k`` from the real-mesh corpus in ``$TETLAP_MESHES`` (by
# default ``../shared/data/meshes`` from the repository's root), or a built-in ball when
# the corpus is not there.
folder = pathlib.Path(os.environ.get("TETLAP_MESHES", "../shared/data/meshes"))
path = folder / "pbd_armadillo_4k.ele"
if path.is_file():
    V, T = tetlap.io.read(path)
    name = path.stem
else:
    print(f"note: {path} is missing (set TETLAP_MESHES); using tetlap.meshes.ball(2000)")
    V, T = tetlap.meshes.ball(2000, seed=0)
    name = "ball(2000)"
print(f"{name}: {len(V)} vertices, {len(T)} tets")

# %%
# The primal Laplacian (semidefinite on every mesh) and the lumped barycentric mass;
# no ``fixed`` vertices: the free boundary, whose first eigenvalue is 0.
L, M = tetlap.operators(V, T, laplacian="primal", mass="barycentric")
lam, vecs = tetlap.solve.eigs(L, M, k=4)
print("eigenvalues:", np.array2string(lam, precision=4))

# %%
# Modes 1 to 3 on the boundary surface, each face coloured by its vertices' mean and
# shaded by its normal.
faces = tetlap.diagnostics.boundary_faces(V, T)
normals = tetlap.diagnostics.face_normals(V, faces)           # area vectors
normals /= np.linalg.norm(normals, axis=1, keepdims=True)
shade = 0.55 + 0.45 * np.abs(normals @ [0.3, 0.4, 0.87])[:, None]
fig = plt.figure(figsize=(10, 4.2), layout="constrained")
for i in range(1, 4):
    ax = fig.add_subplot(1, 3, i, projection="3d")
    mode = vecs[faces, i].mean(axis=1)
    colours = plt.cm.RdBu_r(0.5 + 0.5 * mode / np.abs(mode).max())
    colours[:, :3] *= shade
    ax.add_collection3d(Poly3DCollection(V[faces], facecolors=colours, linewidths=0))
    ax.auto_scale_xyz(*[(V[:, j].min(), V[:, j].max()) for j in range(3)])
    ax.set_box_aspect(np.ptp(V, axis=0)[[0, 2, 1]], zoom=1.3)
    ax.view_init(elev=10, azim=-70, vertical_axis="y")
    ax.set_axis_off()
    ax.set_title(f"mode {i}: lambda = {lam[i]:.4g}")
fig.suptitle(f"{name}: free-boundary eigenmodes of the primal Laplacian")
plt.show()
