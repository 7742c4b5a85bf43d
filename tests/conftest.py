"""Shared fixtures: the real-mesh corpus and small meshes.

Real meshes are read from ``$TETLAP_MESHES`` (default: ``../shared/data/meshes`` beside
the repository). Tests that need them skip with a reason when the folder is missing; CI
checks that it exists before running the suite.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

# Dense eigenvalues (the NSD checks) on one BLAS thread: tetlap's own threads and a
# shared machine make OpenBLAS's threads spin against each other (2000 x 2000 eigvalsh:
# 1.5 s on one thread, 5-7 s on two under load). Set before NumPy is imported; the
# `tetlap` subprocesses of test_cli / test_benchmark inherit it. Override from outside.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import tetlap  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
MESH_DIR = pathlib.Path(os.environ.get("TETLAP_MESHES", ROOT.parent / "shared" / "data" / "meshes"))
MESH_SUFFIXES = {".mesh", ".msh", ".vtu", ".vtk", ".ele"}


def real_mesh_paths() -> list[pathlib.Path]:
    """Every mesh file of the corpus (TetGen pairs by their .ele), sorted; [] if absent."""
    if not MESH_DIR.is_dir():
        return []
    return sorted(p for p in MESH_DIR.iterdir() if p.suffix in MESH_SUFFIXES)


def real_mesh_params():
    paths = real_mesh_paths()
    if not paths:
        return [pytest.param(None, marks=pytest.mark.skip(
            reason=f"real-mesh corpus not found at {MESH_DIR} (set TETLAP_MESHES)"))]
    return [pytest.param(p, id=p.name) for p in paths]


_cache: dict = {}


def read_mesh(path: pathlib.Path):
    """(V, T) of a corpus file, cached for the session (read with meshio)."""
    if path not in _cache:
        import warnings

        import tetlap.io

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _cache[path] = tetlap.io.read(path)
    V, T = _cache[path]
    return V.copy(), T.copy()


# Small generated meshes shared by the assembly and invariant tests.


def jittered_cube():
    return tetlap.meshes.cube(4, jitter=0.2, seed=3)


def random_ball():
    return tetlap.meshes.ball(600, seed=7)


def non_delaunay():
    """A jittered cube with some interior vertices pushed hard: many non-Delaunay tets."""
    return tetlap.meshes.cube(4, jitter=0.24, seed=11)


def corpus_mesh(name: str):
    """(V, T) of the corpus file ``name``; skips when the corpus folder is missing (a
    user's clone), fails when the folder is there without the file (CI has it)."""
    if not MESH_DIR.is_dir():
        pytest.skip(f"real-mesh corpus not found at {MESH_DIR} (set TETLAP_MESHES)")
    return read_mesh(MESH_DIR / name)


@pytest.fixture(params=real_mesh_params())
def real_mesh(request):
    """(name, V, T) for every mesh of the corpus."""
    path = request.param
    V, T = read_mesh(path)
    return path.name, V, T


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def run_tetlap(*args, **kwargs) -> subprocess.CompletedProcess:
    """``python -m tetlap ARGS`` in a child process, text output captured (the CLI tests)."""
    return subprocess.run([sys.executable, "-m", "tetlap", *args], capture_output=True,
                          text=True, timeout=600, **kwargs)


def strict_json(text: str):
    """Parse JSON as the standard says: NaN and Infinity are not JSON."""
    return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} is not valid JSON"))


@pytest.fixture
def cube_file(tmp_path):
    """``(path, V, T)``: a jittered ``cube(3)`` written as ``cube.vtu`` (needs meshio)."""
    pytest.importorskip("meshio")
    V, T = tetlap.meshes.cube(3, jitter=0.1)
    path = tmp_path / "cube.vtu"
    tetlap.io.write(path, V, T)
    return path, V, T

