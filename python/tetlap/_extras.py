"""The one wording of the install hint of an optional dependency, the guide's: tetlap is
installed from its repository (``pip install .``), its optional dependencies as extras
of it (``pip install ".[io]"``).

>>> from tetlap._extras import hint
>>> hint("io")
'pip install ".[io]"'
"""

from __future__ import annotations


def hint(extra: str) -> str:
    """The command that installs the extra ``extra`` (``io``, ``experiments``, ...)."""
    return f'pip install ".[{extra}]"'
