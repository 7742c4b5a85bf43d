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


#: The help of ``--coefficient`` (``tetlap info``, ``tetlap assemble``).
COEFFICIENT_HELP = ("a coefficient K of div(K grad u), one per tet: a .npy file holding (m,) "
                    "positive scalars, (m, 3, 3) or (m, 9) SPD tensors (rows row-major) or "
                    "one (3, 3) tensor, or the name of a cell-data field of the mesh file "
                    "(SimNIBS-style files carry tensors as (m, 9) fields)")


def coefficient(text: str | None, path: str | None, V, T):
    """``--coefficient``: None, or the array it names for the mesh ``(V, T)`` read from
    ``path``: a ``.npy`` file, else a cell-data field of the mesh file; ``(m, 9)`` rows
    become ``(m, 3, 3)`` tensors. Validated as every function validates a coefficient
    (:func:`tetlap.coefficient.check`), with ``--coefficient`` in the message."""
    if text is None:
        return None
    import numpy as np

    from .. import coefficient as _coefficient, io
    from ..errors import OptionError, TetlapError

    if text.endswith(".npy"):
        try:
            values = np.load(text, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise OptionError(f"--coefficient: cannot read {text!r}: {e}") from None
    else:
        if path is None:
            raise OptionError(f"--coefficient: {text!r} is not a .npy file, and the built-in "
                              "mesh has no cell data")
        with contextlib.redirect_stdout(sys.stderr):
            data = io.read(path, cell_data=True)[2]
        if text not in data:
            fields = ", ".join(sorted(data)) or "none"
            raise OptionError(f"--coefficient: {text!r} is neither a .npy file nor a cell-data "
                              f"field of the mesh (its fields: {fields})")
        values = data[text]
    values = np.asarray(values)
    if values.ndim == 2 and values.shape == (len(T), 9):
        values = values.reshape(-1, 3, 3)
    try:
        return _coefficient.check(values, V, T)
    except TetlapError as e:
        raise type(e)(f"--coefficient {text}: {e}", element=e.element, vertex=e.vertex,
                      index=e.index) from None


def name(path: str | None) -> str:
    """The mesh's name for file names and titles: the file name without its extension."""
    return BUILT_IN_NAME if path is None else pathlib.Path(path).stem
