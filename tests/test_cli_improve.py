"""``tetlap improve`` (tetlap.cli.improve): the mesh it writes and the table it prints.
The optimisation is tested in test_improve.py, its flags in test_cli.py."""

from __future__ import annotations

import numpy as np
import pytest

import tetlap
from tetlap import cli


def test_improve_writes_the_mesh_and_prints_the_table(tmp_path, capsys):
    pytest.importorskip("meshio")
    from tetlap import io

    V, T = tetlap.meshes.weighted_ball(500, 1.0, seed=3)
    src, out = tmp_path / "in.vtu", tmp_path / "out.vtu"
    io.write(src, V, T)
    assert cli.main(["improve", str(src), "-o", str(out), "--iterations", "5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"mesh: {src} ({len(V)} vertices, {len(T)} tets) -> {out}"
    assert lines[1].split() == ["before", "after"]
    assert [line[:30].strip() for line in lines[2:7]] == [
        "negative interior dual weights", "min interior dual weight",
        "non-Delaunay interior faces", "min dihedral angle (deg)", "min tet volume"]
    assert "5 iterations" in lines[7]
    V2, T2 = io.read(out)
    assert np.array_equal(T2, T) and V2.shape == V.shape
    before, after = (int(x) for x in lines[2].split()[-2:])
    assert after < before
    assert cli.main(["improve", str(tmp_path / "missing.vtu"), "-o", str(out)]) == 2
