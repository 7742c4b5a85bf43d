"""Plotting helpers shared by the experiments' figures."""

from __future__ import annotations

import numpy as np


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
