"""The mesh files of a corpus folder, for the experiments that read one (``--meshes``)."""

from __future__ import annotations

import pathlib

#: The file extensions read as meshes.
SUFFIXES = (".mesh", ".msh", ".vtu", ".vtk", ".ele")


def mesh_files(folder, only=None) -> list[pathlib.Path]:
    """The files of ``folder`` with a mesh extension, sorted by name; with ``only`` (a
    collection of file names), just those."""
    return sorted(p for p in pathlib.Path(folder).iterdir()
                  if p.suffix in SUFFIXES and (only is None or p.name in only))
