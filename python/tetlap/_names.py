"""What ``dir()`` of a public module lists: its ``__all__`` and its dunders, not the names
it imports for its own use (``np``, ``functools``, ``annotations``), so that tab
completion offers only the public API. Every public module ends its ``__all__`` with

    __dir__ = public_dir(globals())

(``from ._names import public_dir``); ``__all__`` is read on each call, so a name added to
it later is listed too. The package ``tetlap`` has its own ``__dir__`` (its lazy names)."""

from __future__ import annotations


def public_dir(namespace: dict):
    """The module-level ``__dir__`` of the module whose ``globals()`` are ``namespace``."""

    def __dir__() -> list[str]:
        dunders = {name for name in namespace if name.startswith("__") and name.endswith("__")}
        return sorted(set(namespace["__all__"]) | dunders)

    return __dir__
