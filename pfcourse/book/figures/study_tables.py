"""Tables and glue of a Monte Carlo study's verdicts, as the chapters of Part III print them.

A study table (:func:`pfcourse.studies.study.run_study`) has one row per run and setting,
each run ``r`` on the same seed in every setting (common random numbers).  For a metric ``m``
and a column ``by`` of settings:

* :func:`medians` tabulates the medians of several metrics per setting;
* :func:`show` prints, per setting, the median and the 10-90 % band of ``m`` over the runs
  and the number of failed runs;
* :func:`paired_vs` compares every setting with a reference setting *run by run*: the median
  of the per-run ratios ``m_r(setting) / m_r(reference)``, its 95 % interval and the Wilcoxon
  signed-rank p-value (:func:`pfcourse.evidence.paired`, ``ratio=True``);
* :func:`glue_summary` and :func:`glue_paired` glue those numbers under the keys the prose
  quotes (``{key}_{setting}``; ``{key}``, ``{key}_low``, ``{key}_high``, ``{key}_p``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from myst_nb import glue

from pfcourse import evidence
from pfcourse.studies.study import summarize


def show(table: pd.DataFrame, by, metrics: dict[str, str], digits: int = 3) -> None:
    """Print median [10 %, 90 %] of each metric per setting, and the number of failed runs."""
    parts = []
    for name, label in metrics.items():
        s = summarize(table, by, name)
        parts.append(s.apply(lambda r: f"{r.q50:.{digits}f} [{r.q10:.{digits}f}, {r.q90:.{digits}f}]", axis=1)
                     .rename(label))
    out = pd.concat(parts, axis=1)
    out["failed"] = summarize(table, by, name)["n_failed"]
    print(out.to_string())


def medians(table: pd.DataFrame, by, metrics: dict[str, str]) -> pd.DataFrame:
    """The median over the runs of each metric per setting, one row per setting, the columns named
    by ``metrics`` (metric -> label): the table an evidence block shows."""
    return pd.concat([summarize(table, by, m)["q50"].rename(label) for m, label in metrics.items()],
                     axis=1).reset_index()


def median(table: pd.DataFrame, by, metric: str) -> pd.Series:
    """Median of a metric per setting (a Series indexed by the setting)."""
    return summarize(table, by, metric)["q50"]


def paired_vs(table: pd.DataFrame, by: str, reference, metric: str = "position_rmse", printed: bool = True) -> dict:
    """Each setting against ``reference`` on the same seeds: median ratio of ``metric``, its 95 % interval, Wilcoxon p.

    Prints the table (unless ``printed`` is False: an evidence block shows it) and returns ``{setting: pfcourse.evidence.Paired}``; runs that failed in
    either setting are left out.
    """
    ref = table[table[by] == reference].set_index("seed")[metric]
    out, rows = {}, []
    for value, g in table.groupby(by, sort=False):
        if value == reference:
            continue
        x = g.set_index("seed")[metric]
        common = x.index.intersection(ref.index)
        ok = np.isfinite(x[common].to_numpy()) & np.isfinite(ref[common].to_numpy())
        cmp = evidence.paired(x[common].to_numpy()[ok], ref[common].to_numpy()[ok], ratio=True)
        out[value] = cmp
        rows.append({by: value, f"{metric} ratio to {by} = {reference:g}": cmp.median, "95% CI low": cmp.low,
                     "95% CI high": cmp.high, "Wilcoxon p": cmp.pvalue, "paired runs": cmp.n,
                     "verdict": cmp.verdict().replace("A ", "")})
    if printed:
        print(pd.DataFrame(rows).set_index(by).to_string(float_format=lambda v: f"{v:.3g}"))
    return out


def tag(value) -> str:
    """A setting as it appears in a glue key: 0.25, 2, 0.333, multinomial."""
    return f"{value:g}" if isinstance(value, (int, float, np.number)) else str(value)


def glue_summary(table: pd.DataFrame, by, metric: str, key: str, q: str = "q50", scale: float = 1.0) -> None:
    """Glue a quantile of ``metric`` for every setting as ``{key}_{setting}``: the numbers the prose quotes."""
    for value, row in summarize(table, by, metric).iterrows():
        glue(f"{key}_{tag(value)}", float(row[q]) * scale, display=False)


def glue_paired(key: str, cmp: evidence.Paired) -> None:
    """Glue a paired comparison under ``key``: median (ratio or difference), 95 % interval, Wilcoxon p."""
    glue(key, float(cmp.median), display=False)
    glue(f"{key}_low", float(cmp.low), display=False)
    glue(f"{key}_high", float(cmp.high), display=False)
    glue(f"{key}_p", float(cmp.pvalue), display=False)


def ratio_text(cmp: evidence.Paired) -> str:
    """A paired ratio as a summary table states it."""
    return f"paired ratio {cmp.median:.2f}, 95 % interval {cmp.low:.2f}-{cmp.high:.2f}"
