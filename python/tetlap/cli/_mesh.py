"""The mesh a command reads: a file, or for ``tetlap info`` without one, the built-in ball."""

from __future__ import annotations

import contextlib
import pathlib
import sys

#: The built-in mesh of ``tetlap info`` without a file.
BUILT_IN = "a random Delaunay ball, tetlap.meshes.ball(2000, seed=0)"
#: The name of the built-in mesh in plot files and titles.
BUILT_IN_NAME = "ball"


def load(path: str | None):
    """``(V, T, description)`` of a mesh file (its path as printable text), or of the
    built-in ball; nothing that the readers print reaches stdout."""
    from .. import meshes

    if path is None:
        return (*meshes.ball(2000, seed=0), BUILT_IN)
    from .. import io

    from ._paths import shown

    with contextlib.redirect_stdout(sys.stderr):
        V, T = io.read(path)
    return V, T, shown(path)


def name(path: str | None) -> str:
    """The mesh's name for file names and titles: the file name without its extension."""
    return BUILT_IN_NAME if path is None else pathlib.Path(path).stem
