"""Progress output on stderr: a bar over items (tqdm when installed) and named stages of a
long computation. Logs get no ``\\r`` updates: the bar is quiet when stderr is not a
terminal, and stages are whole lines there."""

from __future__ import annotations

import sys
import time
from typing import Iterable, Iterator, TypeVar

T = TypeVar("T")


def _interactive() -> bool:
    return hasattr(sys.stderr, "isatty") and sys.stderr.isatty()


def bar(items: Iterable[T], total: int | None = None, desc: str = "") -> Iterator[T]:
    """Yield ``items`` with a progress bar on stderr: tqdm if installed, else a counter;
    nothing when stderr is not a terminal."""
    items = list(items)
    if not _interactive():
        yield from items
        return
    try:
        from tqdm import tqdm
    except ImportError:
        for k, item in enumerate(items):
            print(f"\r{desc} {k + 1}/{len(items)}", end="", file=sys.stderr, flush=True)
            yield item
        print(file=sys.stderr)
        return
    yield from tqdm(items, total=total or len(items), desc=desc, file=sys.stderr, leave=False)


class Stages:
    """Named steps of one computation, reported on stderr when enabled (by default, when
    stderr is a terminal): on a terminal each step's line ends with its duration when it
    ends; elsewhere (a pipe, a log file) each step is one whole line when it starts, so
    that a log never holds a partial line."""

    def __init__(self, title: str, enabled: bool | None = None) -> None:
        self.title = title
        self.live = _interactive()
        self.enabled = self.live if enabled is None else enabled
        self.start = time.perf_counter()
        self.current: tuple[str, float] | None = None

    def __call__(self, name: str) -> None:
        """End the current step (if any) and start ``name``."""
        self.done()
        self.current = (name, time.perf_counter())
        if self.enabled and self.live:
            print(f"{self.title}: {name} ...", end="", file=sys.stderr, flush=True)
        elif self.enabled:
            print(f"{self.title}: {name} ...", file=sys.stderr, flush=True)

    def done(self) -> None:
        """End the current step."""
        if self.current is not None and self.enabled and self.live:
            print(f" {time.perf_counter() - self.current[1]:.1f} s", file=sys.stderr, flush=True)
        self.current = None
