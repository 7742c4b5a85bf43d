"""The paper's experiments (Sec. 8 and 9) as commands: ``tetlap experiment NAME``.

Each experiment writes into ``--out`` (default ``tetlap-experiments/NAME``) a CSV of the
raw numbers, at least one PNG figure and ``summary.txt``, and shows a progress bar.
``--quick`` sizes finish in under two minutes on two cores; the full sizes approach the
paper's. Figures need matplotlib (``pip install 'tetlap[experiments]'``).

========================  ==========================================================
``dirichlet-shell``       Eq. 28 on a spherical shell: variance on r = 0.75 (Fig. 8/9)
``eigen-ball``            Dirichlet eigenvalues of the unit ball (Fig. 10/11)
``negative-weights``      NaN/Inf and negative weights over a mesh corpus (Fig. 12)
``sphere3``               normals and mean curvature on S^3 in R^4 (Fig. 13/14)
``flips``                 sign of the Dirichlet-energy change of 2-3 / 3-2 flips (Sec. 9)
========================  ==========================================================
"""

from __future__ import annotations

import csv
import os
import pathlib
import sys
import time
from typing import Callable, Iterable

import numpy as np

NAMES = ("dirichlet-shell", "eigen-ball", "negative-weights", "sphere3", "flips")


class Output:
    """The files of one experiment run: CSV rows, figures and the summary."""

    def __init__(self, name: str, out: str | os.PathLike | None, quick: bool, seed: int):
        self.name, self.quick, self.seed = name, quick, seed
        self.dir = pathlib.Path(out or pathlib.Path("tetlap-experiments") / name)
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
            self.say(f"(figure {filename} skipped: matplotlib is not installed)")
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


def log_ticks(ax, which: str = "both") -> None:
    """Readable tick labels on the log axes of ``ax`` (plotting only; call after drawing).

    matplotlib labels minor ticks ("1.2x10^-1", ...) when a log axis spans less than about
    a decade, and they collide. Here a short range gets 3-6 plain ticks, a range of a few
    decades 1-2-5 ticks, a long one the decades; minor ticks stay unlabelled."""
    from matplotlib import ticker

    def label(v, _pos=None):
        if v <= 0:
            return ""
        if 1e-3 <= v < 1e5:
            return f"{v:g}"
        exponent = int(np.floor(np.log10(v) + 1e-9))
        mantissa = v / 10.0**exponent
        head = "" if abs(mantissa - 1) < 1e-9 else f"{mantissa:g}\\times"
        return f"${head}10^{{{exponent}}}$"

    for axis, lim in (("x", ax.get_xlim()), ("y", ax.get_ylim())):
        if which not in ("both", axis):
            continue
        target = ax.xaxis if axis == "x" else ax.yaxis
        if target.get_scale() != "log":
            continue
        lo, hi = sorted(lim)
        decades = np.log10(hi / lo) if lo > 0 else np.inf
        if decades < 1.2:
            target.set_major_locator(ticker.MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))
        elif decades < 3.5:
            target.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        else:
            target.set_major_locator(ticker.LogLocator(base=10, subs=(1.0,)))
        target.set_major_formatter(ticker.FuncFormatter(label))
        target.set_minor_formatter(ticker.NullFormatter())


def progress(items: Iterable, total: int | None = None, desc: str = ""):
    """tqdm if installed (on stderr), else a plain counter on stderr."""
    items = list(items)
    try:
        from tqdm import tqdm

        yield from tqdm(items, total=total or len(items), desc=desc, file=sys.stderr,
                        leave=False)
        return
    except ImportError:
        pass
    for k, item in enumerate(items):
        print(f"\r{desc} {k + 1}/{len(items)}", end="", file=sys.stderr, flush=True)
        yield item
    print(file=sys.stderr)


def run(name: str, *, quick: bool = False, out=None, seed: int = 0, meshes=None) -> pathlib.Path:
    """Run experiment ``name``; return the folder with its CSV, PNG and summary."""
    from . import eigen_ball, flips, negative_weights, shell, sphere3

    runners = {
        "dirichlet-shell": shell.run,
        "eigen-ball": eigen_ball.run,
        "negative-weights": negative_weights.run,
        "sphere3": sphere3.run,
        "flips": flips.run,
    }
    if name not in runners:
        raise ValueError(f"unknown experiment {name!r}; choose one of {', '.join(NAMES)}")
    output = Output(name, out, quick, seed)
    if name == "negative-weights":
        runners[name](output, meshes=meshes)
    else:
        runners[name](output)
    return output.finish()
