"""The output paths of the ``tetlap`` commands, checked in each command's ``check(args)``,
before any work: a bad ``-o``, ``--out`` or ``--plot`` is a one-line error at once, not
after minutes of computation.

A check writes what it can into a temporary folder beside the output (for a mesh, one tet
in the output's own format, with the point data the command adds) and removes it, and any
folder it had to create, again: it proves that the folder exists or can be created, that
files can be created in it, that the path is not a folder (for a file) or a file (for a
folder), that an existing output can be replaced, and that the format can hold the data,
and it leaves the file system as it was.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import shutil
import tempfile

from ..errors import OptionError, TetlapError
from ._output import printable

__all__ = ["shown", "output_file", "output_folder", "mesh_file", "make_folder", "input_file"]


def shown(path) -> str:
    """``path`` as printable text (:func:`tetlap.cli._output.printable`)."""
    return printable(os.fsdecode(path))


@contextlib.contextmanager
def _scratch(folder: pathlib.Path, flag: str, path):
    """A temporary folder inside ``folder`` (created for the check with its missing
    parents), removed with them afterwards; OptionError naming ``flag`` and ``path`` when
    any of it cannot be made."""
    created = []
    scratch = None
    try:
        for parent in reversed([folder, *folder.parents]):
            if not parent.exists():
                parent.mkdir()
                created.append(parent)
        scratch = pathlib.Path(tempfile.mkdtemp(prefix=".tetlap-check-", dir=folder))
        yield scratch
    except OSError as e:
        raise OptionError(f"{flag} {shown(path)}: cannot be written "
                          f"({e.strerror or type(e).__name__})") from None
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
        for parent in reversed(created):
            with contextlib.suppress(OSError):
                parent.rmdir()


def output_folder(path, flag: str, files=()) -> None:
    """OptionError unless ``path`` is a folder (or can be made one) in which ``files``
    (names) can be written."""
    folder = pathlib.Path(path)
    if folder.exists() and not folder.is_dir():
        raise OptionError(f"{flag} {shown(path)}: is a file, not a folder")
    with _scratch(folder, flag, path) as scratch:
        for name in files:
            _replaceable(folder / name, flag)
            (scratch / name).touch()


def output_file(path, flag: str, write=None) -> None:
    """OptionError unless ``path`` can be written as a file: ``write(probe)`` (default: an
    empty file) is called on a path of the same name in a scratch folder beside it, and a
    :class:`tetlap.TetlapError` it raises (a format that cannot hold the data) becomes the
    OptionError."""
    target = pathlib.Path(path)
    if target.is_dir():
        raise OptionError(f"{flag} {shown(path)}: is a folder, not a file")
    if target.name in ("", ".", ".."):
        raise OptionError(f"{flag} {shown(path)}: names no file")
    with _scratch(target.parent, flag, path) as scratch:
        _replaceable(target, flag)
        probe = scratch / target.name
        try:
            (write or pathlib.Path.touch)(probe)
        except TetlapError as e:
            message = " ".join(str(e).replace(os.fspath(probe), "it").split())
            raise OptionError(f"{flag} {shown(path)}: {message}") from None


def _replaceable(target: pathlib.Path, flag: str) -> None:
    """OSError (reported by ``_scratch``) if an existing ``target`` cannot be replaced;
    it is opened for appending, which changes nothing in it."""
    if target.is_dir():
        raise OptionError(f"{flag} {shown(target)}: is a folder, not a file")
    if target.exists():
        with open(target, "a"):
            pass


def mesh_file(path, flag: str, point_data: tuple[str, ...] = ()) -> None:
    """:func:`output_file` for a tet mesh written by :func:`tetlap.io.write` in the format
    of its extension, with the ``point_data`` arrays (names) the command adds: one tet is
    written and, where meshio reads the format back, read back. A format that meshio
    cannot write or that :func:`tetlap.io.write` refuses (a surface format such as .stl,
    .off or .ply would drop the tets), or that reads back without the tet, is refused."""
    import io as text

    import numpy as np

    from .. import io, meshes
    from ..errors import MeshFileError

    V, T = meshes.single_tet("regular")
    data = {name: np.zeros(len(V)) for name in point_data} or None

    def write(probe):
        quiet = text.StringIO()
        with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
            try:
                io.write(probe, V, T, point_data=data)
            except MeshFileError as e:
                reason = str(e).removeprefix(f"{os.fspath(probe)}: ")
                reason = reason.split(" could not write it ", 1)[-1]
                if not reason.startswith("not a mesh format"):
                    reason = "not a mesh format meshio writes tets in " + reason
                raise MeshFileError(reason.replace(os.fspath(probe), pathlib.Path(path).name)
                                    ) from None
            try:
                _, back = io.read(probe)
            except TetlapError:
                back = None  # not read back (no reader, or nothing written)
        if back is not None and back.shape != T.shape:
            raise MeshFileError("not a mesh format that holds tets (the tets were not written)")

    output_file(path, flag, write)


def make_folder(path) -> None:
    """Create the folder of the output file ``path``, with its parents, where missing (the
    checks above made sure that they can be)."""
    pathlib.Path(path).parent.mkdir(parents=True, exist_ok=True)


def input_file(path, flag: str) -> None:
    """OptionError unless ``path`` is a file that can be opened for reading (for inputs
    that a command reads only after other work)."""
    try:
        with open(path, "rb"):
            pass
    except OSError as e:
        raise OptionError(f"{flag} {shown(path)}: cannot be read "
                          f"({e.strerror or type(e).__name__})") from None
