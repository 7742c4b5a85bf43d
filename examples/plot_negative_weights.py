"""
Negative weights, primal against dual
=====================================

The paper's Fig. 12: over a corpus of meshes, the fraction of negative edge weights (on
edges not both on the boundary) of each Laplacian. A negative weight breaks the discrete
maximum principle. The primal has them on almost every mesh; the dual of a Delaunay mesh
has none inside, while on a mesh that is far from Delaunay it can have more than the
primal, which is when the primal, or the dual with regular weights, serves better.
Here on the small meshes of the real-mesh corpus, or on generated meshes when the corpus
is not there.
"""

import os
import pathlib
import warnings

import matplotlib.pyplot as plt
import numpy as np

import tetlap

# %%
# The meshes: every file under 300 kB in ``$TETLAP_MESHES`` (by default
# ``../shared/data/meshes`` from the repository's root), else generated ones.
folder = pathlib.Path(os.environ.get("TETLAP_MESHES", "../shared/data/meshes"))
files = sorted(p for p in folder.glob("*") if p.suffix in {".msh", ".mesh", ".vtu", ".vtk",
                                                           ".ele"} and p.stat().st_size < 3e5)
if files:
    meshes = {}
    for path in files:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")         # meshio's notes on the files
                meshes[path.stem] = tetlap.io.read(path)
        except tetlap.TetlapError as e:                 # a file the corpus holds as bad input
            print(f"{path.name}: {e}")
else:
    print(f"note: no meshes in {folder} (set TETLAP_MESHES); using generated meshes")
    meshes = {f"ball {seed}": tetlap.meshes.ball(1000, seed=seed) for seed in range(4)}
    meshes |= {f"grid {j}": tetlap.meshes.cube(6, jitter=j, seed=0) for j in (0.1, 0.2, 0.24)}
    meshes |= {f"weighted {w}": tetlap.meshes.weighted_ball(1000, w) for w in (0.3, 0.6, 1.0)}

fraction = {"primal": [], "dual": []}
for name, (V, T) in meshes.items():
    for kind in fraction:
        L = tetlap.laplacian(V, T, kind, degenerate="skip")
        fraction[kind].append(tetlap.check(L, V, T, nsd=False).negative_fraction_interior)
    print(f"{name:<32} primal {fraction['primal'][-1]:6.1%}  dual {fraction['dual'][-1]:6.1%}")

# %%
# The histogram over the meshes.
fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
bins = np.linspace(0, max(max(fraction["primal"]), max(fraction["dual"])) * 1.05, 20)
for kind, values in fraction.items():
    ax.hist(values, bins=bins, alpha=0.6, label=kind)
ax.xaxis.set_major_formatter(plt.matplotlib.ticker.PercentFormatter(1.0))
ax.set_xlabel("negative weights (edges not both on the boundary)")
ax.set_ylabel("meshes")
ax.set_title(f"negative weights on {len(meshes)} meshes")
ax.legend()
plt.show()
