"""Figures of Monte Carlo studies: a median and the 10-90 % band of the runs.

A study (:func:`pfcourse.studies.study.run_study`) gives many runs per setting; a figure
of it should show where the typical run lies *and* how far the runs spread.
These helpers draw, for each setting (or each time step), the median of the
metric and the band between its 10 % and 90 % quantiles over the runs: 80 % of
the runs fall inside it.  They take the table of
:func:`pfcourse.studies.study.summarize` or a ``(runs, steps)`` array and return the
axes.
"""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pfcourse.errors import ShapeError


def summary_band(
    summary: pd.DataFrame,
    ax=None,
    *,
    x: Sequence[float] | None = None,
    color: str = "tab:red",
    label: str | None = None,
    categorical: bool = False,
    show_failed: bool = True,
):
    """Median (dots joined by a line) and 10-90 % band of each row of a :func:`summarize` table.

    ``x`` defaults to the table's index (the parameter values).  With
    ``categorical=True`` the settings are placed at 0, 1, 2, ... with their
    names as tick labels and drawn as a dot with a 10-90 % bar.  Settings with
    failed runs are marked with their count when ``show_failed``.
    """
    for column in ("q10", "q50", "q90"):
        if column not in summary:
            raise ShapeError(f"summary_band needs the columns q10, q50 and q90 of summarize(); missing {column}")
    if ax is None:
        _, ax = plt.subplots()
    lo, mid, hi = (summary[c].to_numpy(dtype=float) for c in ("q10", "q50", "q90"))
    if categorical:
        pos = np.arange(len(summary))
        ax.errorbar(pos, mid, yerr=[mid - lo, hi - mid], fmt="o", color=color, capsize=5, lw=2, label=label)
        ax.set_xticks(pos, [str(v) for v in summary.index])
    else:
        pos = np.asarray(summary.index if x is None else x, dtype=float)
        ax.fill_between(pos, lo, hi, color=color, alpha=0.2, lw=0)
        ax.plot(pos, mid, "o-", color=color, ms=4, label=label)
    if show_failed and "n_failed" in summary:
        for p, top, failed in zip(pos, hi, summary["n_failed"].to_numpy()):
            if failed:
                ax.annotate(f"{failed} failed", (p, top), xytext=(0, 4), textcoords="offset points",
                            ha="center", color=color)
    return ax


def time_band(
    t: Sequence[float],
    values: np.ndarray,
    ax=None,
    *,
    color: str = "tab:red",
    label: str | None = None,
):
    """Median over runs and 10-90 % band of a ``(runs, steps)`` array against time ``t``."""
    values = np.asarray(values, dtype=float)
    t = np.asarray(t, dtype=float)
    if values.ndim != 2 or values.shape[1] != t.size:
        raise ShapeError(f"time_band needs values of shape (runs, {t.size}), got {values.shape}")
    if ax is None:
        _, ax = plt.subplots()
    lo, mid, hi = np.quantile(values, [0.1, 0.5, 0.9], axis=0)
    ax.fill_between(t, lo, hi, color=color, alpha=0.2, lw=0)
    ax.plot(t, mid, "-", color=color, lw=1.5, label=label)
    return ax
