"""The files of one experiment run: CSV rows, figures and the summary."""

from __future__ import annotations

import csv
import os
import pathlib
import time
from typing import Callable

from .. import _extras as extras


def folder(name: str, out: str | os.PathLike | None = None) -> pathlib.Path:
    """The folder experiment ``name`` writes into: ``out``, by default
    ``tetlap-experiments/NAME`` in the working folder."""
    return pathlib.Path(out or pathlib.Path("tetlap-experiments") / name)


class Output:
    """The files of one experiment run: CSV rows, figures and the summary."""

    def __init__(self, name: str, out: str | os.PathLike | None, quick: bool, seed: int):
        self.name, self.quick, self.seed = name, quick, seed
        self.dir = folder(name, out)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.rows: list[dict] = []
        self.lines: list[str] = []
        self.start = time.perf_counter()

    def row(self, **values) -> None:
        self.rows.append(values)

    def say(self, line: str = "") -> None:
        self.lines.append(line)

    def figure(self, filename: str, draw: Callable) -> pathlib.Path | None:
        """Draw with matplotlib (Agg) into ``filename``; skipped with a note if missing."""
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            self.say(f"(figure {filename} skipped: matplotlib is not installed: "
                     f"{extras.hint('experiments')})")
            return None
        fig = draw(plt)
        path = self.dir / filename
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
        return path

    def finish(self) -> pathlib.Path:
        """Write ``results.csv`` and ``summary.txt``; return the folder."""
        keys: list[str] = []
        for r in self.rows:
            keys += [k for k in r if k not in keys]
        with open(self.dir / "results.csv", "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=keys)
            writer.writeheader()
            writer.writerows(self.rows)
        mode = "quick" if self.quick else "full"
        head = [f"tetlap experiment {self.name} ({mode}, seed {self.seed}), "
                f"{time.perf_counter() - self.start:.1f} s"]
        (self.dir / "summary.txt").write_text("\n".join(head + self.lines) + "\n")
        return self.dir
