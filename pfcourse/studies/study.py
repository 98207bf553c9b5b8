"""Monte Carlo studies: many seeded, independent runs of a filter over a parameter grid.

A study answers "how does the error depend on this parameter?" with a
distribution instead of one run.  For every setting ``s`` of the grid (the
Cartesian product of the values given) and every replicate ``r = 0 .. R-1`` it
calls ``run_one(seed=seed_r, **s)``, which simulates a scenario and filters it,
and returns a dictionary of metrics.  The result is a tidy table, one row per
(setting, run).

* **Reproducible runs.** Replicate ``r`` uses the seed
  :func:`pfcourse.seeding.replicate_seed` ``(base_seed, r)``, drawn from
  ``SeedSequence([base_seed, r])``: any single row can be re-run alone.
* **Common random numbers.** Replicate ``r`` uses the same seed in every setting,
  so the settings are compared on the same simulated truths and measurements and
  their differences are not blurred by different data.
* **Failures are data.** A run that collapses (a :class:`~pfcourse.errors.StepError`:
  every particle impossible, a NaN) is recorded with ``status = "failed"`` and its
  message, and scored as the study says a collapsed run scores (``failed_scores``: a terrain
  flight whose particles all died is lost, with an infinite error); the study goes on.  A row
  function never catches a collapse itself.  Configuration errors and bugs (a
  :class:`~pfcourse.errors.ModelError`, e.g. a bad ``FilterSettings``) still stop it.  This is the
  failure policy of every recorded run (:mod:`pfcourse.studies.record`): a row holds what
  a run record holds, its setting, ``status``, ``error_message``, metrics and ``seconds`` (the message's
  column is not named ``error``, so that no metric can take its place).
* **Batches.** ``run_batch(seeds=[...], **s)`` may replace ``run_one`` when a
  model can run several replicates at once; it returns one dictionary per seed,
  or, for a replicate that collapsed, the :class:`~pfcourse.errors.StepError`
  instance it would have raised (recorded as a failed run, the others kept).
* **Any executor.** The runs are independent, so they are shared out as tasks (a chunk of
  runs of one setting each) to a :class:`concurrent.futures.Executor`: by default a process
  pool over the machine's cores; :class:`~pfcourse.studies.executor.SerialExecutor` runs them in this process; a
  cluster's executor (``dask.distributed.Client(...).get_executor()``) spreads them over
  machines.  Each row depends only on its setting and seed, and the rows are put back in
  grid order, so the table is the same whatever the executor and its number of workers
  (only the ``seconds`` column, a wall time, differs).
* **A stuck pool is replaced.** If no task finishes for ``stall_timeout`` seconds, or a
  worker dies (the pool is broken), the pool's workers are stopped and the unfinished tasks
  run in this process, with a :class:`~pfcourse.studies.executor.StudyWarning`; since a row depends only on its
  setting and seed, the table is the one the pool would have made.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Executor
from typing import Any

import numpy as np
import pandas as pd

from pfcourse.checks import check_count
from pfcourse.errors import ModelError, ParameterError, StepError, is_collapse
from pfcourse.studies.executor import STALL_TIMEOUT, run_tasks
from pfcourse.studies.record import failure_message
from pfcourse.seeding import replicate_seed

Metrics = Mapping[str, float]


def grid_settings(grid: Mapping[str, Sequence]) -> list[dict]:
    """All combinations of the grid's values, in the order given (last key varies fastest)."""
    if not isinstance(grid, Mapping) or not all(isinstance(name, str) for name in grid):
        raise ParameterError(f"grid must map parameter names to lists of values, e.g. {{'n_particles': [100, 1000]}}, "
                             f"got {grid!r:.80}")
    for name, values in grid.items():
        if isinstance(values, (str, bytes)) or not isinstance(values, Iterable) or len(values) == 0:
            raise ParameterError(f"grid[{name!r}] must be a non-empty list of values, got {values!r}")
    keys = list(grid)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(grid[k] for k in keys))]


def run_study(
    run_one: Callable[..., Metrics] | None,
    grid: Mapping[str, Sequence],
    n_runs: int,
    *,
    base_seed: int = 0,
    seeds: Sequence[int] | None = None,
    run_batch: Callable[..., list[Metrics]] | None = None,
    batch_size: int = 10,
    progress: bool = True,
    executor: Executor | None = None,
    stall_timeout: float | None = STALL_TIMEOUT,
    failed_scores: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """Run every setting of ``grid`` ``n_runs`` times and return one row per run.

    Columns: the grid's parameters, ``run`` (replicate index), ``seed``,
    ``status`` (``"ok"`` or ``"failed"``), ``error_message`` (message of a failed run, ``""`` otherwise),
    the metrics returned by the run, and ``seconds`` (wall time of the run, or of
    its share of a batch).  A failed run's metrics are ``failed_scores`` (how the study scores a run
    that collapsed, e.g. an infinite error; default: none, NaN in the table).

    Replicate ``r`` has seed ``replicate_seed(base_seed, r)``, or ``seeds[r]`` when ``seeds``
    (``n_runs`` integers) is given: a study whose runs are seeded by their index passes
    ``seeds=range(n_runs)``.

    ``executor`` runs the tasks (``batch_size`` runs of one setting each); ``None`` uses
    :func:`~pfcourse.studies.executor.default_executor`.  The rows, their order and every column but ``seconds`` do
    not depend on it.  If no task finishes for ``stall_timeout`` seconds (``None``: wait for
    ever) or the executor breaks, the unfinished tasks run in this process
    (:class:`~pfcourse.studies.executor.StudyWarning`); a pool made here has its workers stopped first.
    """
    if (run_one is None) == (run_batch is None):
        raise ParameterError("give exactly one of run_one and run_batch")
    n_runs = check_count(n_runs, "n_runs")
    batch_size = check_count(batch_size, "batch_size")
    settings = grid_settings(grid)
    if seeds is None:
        seeds = [replicate_seed(base_seed, r) for r in range(n_runs)]
    elif len(seeds) != n_runs:
        raise ParameterError(f"seeds must give one seed per run ({n_runs}), got {len(seeds)}")
    seeds = [int(seed) for seed in seeds]
    task = _batch_task if run_batch is not None else _runs_task
    fn = run_batch if run_batch is not None else run_one
    tasks = [(setting, list(range(start, min(start + batch_size, n_runs))))
             for setting in settings for start in range(0, n_runs, batch_size)]
    bar = _Progress(len(settings) * n_runs) if progress else None

    def advance(chunk_rows: list[dict]) -> None:
        if bar:
            for row in chunk_rows:
                bar.advance(1, row["status"])

    failed = dict(failed_scores or {})
    chunks = run_tasks(task, [(fn, setting, chunk, [seeds[r] for r in chunk], failed) for setting, chunk in tasks],
                       executor=executor, stall_timeout=stall_timeout, on_result=advance)
    rows = [row for chunk_rows in chunks for row in chunk_rows]
    if bar:
        bar.finish(len(settings), n_runs)
    return pd.DataFrame(rows)


def _runs_task(run_one, setting: dict, runs: list[int], seeds: list[int], failed: dict) -> list[dict]:
    """One task of a study: runs ``runs`` of ``setting``, one at a time (module level, so it pickles)."""
    return [_one_row(run_one, setting, r, seed, failed) for r, seed in zip(runs, seeds)]


def _batch_task(run_batch, setting: dict, runs: list[int], seeds: list[int], failed: dict) -> list[dict]:
    """One task of a study: runs ``runs`` of ``setting`` in one call of ``run_batch``."""
    return _batch_rows(run_batch, setting, runs, seeds, failed)


def _metrics(result, setting: dict, seed: int) -> dict:
    """A run's metrics as a dict; anything else is refused with the setting and seed that gave it."""
    if not isinstance(result, Mapping):
        raise ParameterError(f"the run function must return a mapping of metric names to values; with {setting} "
                             f"and seed {seed} it returned {type(result).__name__} {result!r:.60}")
    return dict(result)


def _one_row(run_one, setting: dict, r: int, seed: int, failed: dict) -> dict:
    start = time.perf_counter()
    try:
        metrics, status, error = _metrics(run_one(seed=seed, **setting), setting, seed), "ok", ""
    except StepError as exc:
        if not is_collapse(exc):
            raise
        metrics, status, error = failed, "failed", failure_message(exc)
    return {**setting, "run": r, "seed": seed, "status": status, "error_message": error, **metrics,
            "seconds": time.perf_counter() - start}


def _batch_rows(run_batch, setting: dict, runs: list[int], seeds: list[int], failed: dict) -> list[dict]:
    start = time.perf_counter()
    try:
        outcomes = run_batch(seeds=seeds, **setting)
        bug = next((m for m in outcomes if isinstance(m, ModelError)), None)
        if bug is not None:
            raise bug
        results = [(failed, "failed", failure_message(m)) if isinstance(m, StepError)
                   else (_metrics(m, setting, seed), "ok", "") for m, seed in zip(outcomes, seeds)]
        if len(results) != len(seeds):
            raise ParameterError(f"run_batch returned {len(results)} results for {len(seeds)} seeds")
    except StepError as exc:
        if not is_collapse(exc):
            raise
        # One collapse spoils the batch: redo its runs one at a time to find which.
        return [_one_row(lambda seed, **s: run_batch(seeds=[seed], **s)[0], setting, r, seed, failed)
                for r, seed in zip(runs, seeds)]
    share = (time.perf_counter() - start) / len(seeds)
    return [{**setting, "run": r, "seed": seed, "status": status, "error_message": error, **m, "seconds": share}
            for r, seed, (m, status, error) in zip(runs, seeds, results)]


def summarize(
    table: pd.DataFrame, by: str | Sequence[str], metric: str, quantiles: Sequence[float] = (0.1, 0.5, 0.9)
) -> pd.DataFrame:
    """Quantiles of ``metric`` over the successful runs of each setting, with run counts.

    Columns ``q10``, ``q50``, ... (percent), ``n_ok`` and ``n_failed``; failed runs
    are counted, not averaged in.
    """
    by = [by] if isinstance(by, str) else list(by)
    ok = table[table["status"] == "ok"]
    grouped = ok.groupby(by, sort=False)[metric]
    out = pd.DataFrame({f"q{round(100 * q)}": grouped.quantile(q) for q in quantiles})
    out["n_ok"] = grouped.size()
    failed = table[table["status"] != "ok"].groupby(by, sort=False).size()
    out["n_failed"] = failed.reindex(out.index, fill_value=0)
    return out


class _Progress:
    """A progress bar in notebooks (nothing elsewhere), closed at the end and replaced by a one-line summary.

    The summary (``12 settings x 100 runs: 1200 ok, 0 failed``) is printed and the bar's
    view closed, so no finished bar stays above a table in a live notebook. Chapters run
    their studies with ``progress=False``: an executed notebook would store the bar as a
    widget view (which the HTML book, having no widget manager, cannot show) and nbval
    would compare its text form.
    """

    def __init__(self, total: int) -> None:
        from IPython import get_ipython

        self.bar = None
        self.failed = 0
        if get_ipython() is not None:
            import ipywidgets as widgets
            from IPython.display import display

            self.bar = widgets.IntProgress(value=0, min=0, max=total, description="runs")
            display(self.bar)

    def advance(self, n: int, status: str) -> None:
        self.failed += status != "ok"
        if self.bar is not None:
            self.bar.value += n

    def finish(self, n_settings: int, n_runs: int) -> None:
        if self.bar is not None:
            total = n_settings * n_runs
            self.bar.close()
            print(f"{n_settings} settings x {n_runs} runs: {total - self.failed} ok, {self.failed} failed")
