"""Deprecated alias of :mod:`tetlap.analysis` (the module's name until 0.1), kept for one
release: it re-exports the same objects. Import from :mod:`tetlap.analysis` instead."""

from .analysis import *  # noqa: F401,F403
from .analysis import __all__, _check  # noqa: F401
from ._names import public_dir

__dir__ = public_dir(globals())
