"""One run of one filter, recorded: what was run, its scores, and how it ended.

Every experiment of the book records a run the same way, as a :class:`RunRecord`:

* ``setting``: what identifies the run (the filter, its ``N``, ...), ``{}`` if nothing;
* ``scores``: the run's numbers and per-step arrays, named (``position_rmse``, ``position_error``, ...);
* ``status``: ``"ok"``; ``"lost"`` (the filter finished without an estimate from some step on:
  a Kalman estimate off the map, :attr:`pfcourse.results.KalmanResult.lost_at`); or
  ``"failed"`` (the filter raised a :class:`~pfcourse.errors.StepError`: every particle
  impossible, a NaN);
* ``error``: what happened (``""`` when ``ok``), ``seconds``: the filter's wall time.

**One failure policy**, :func:`record_run`: a :class:`~pfcourse.errors.StepError` raised by the
filter is data (the run is recorded ``"failed"`` with ``"ErrorType: message"``); any other
exception is a bug or a bad setting and propagates.  It is the rule of the study runner
(:func:`pfcourse.studies.study.run_study`), whose rows carry the same ``status`` and
``error`` (:func:`failure_message`) beside their setting, metrics and ``seconds``.

**One way of recording a loss**: a lost filter has no estimate from the step ``k`` it was lost
(NaN rows, as a Kalman result's rows from ``lost_at`` on), and a filter that failed has none
from the start (``k = 0``): given the run's shape, :func:`record_run` scores a failed run on a
result whose every row is NaN (:func:`no_estimate`), so the scorer that scores a lost filter
scores a failed one.  Summaries over runs count a run that is not ``ok`` as an infinite error
(:func:`scores` with ``failed=np.inf``) or as no lock-on.

A record's scores and setting also read as attributes (``record.position_rmse``,
``record.n_particles``) and by name (``record["position_rmse"]``); none may take a field's name
(``error`` is the record's message, a position error is ``position_error``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, TypeVar

import numpy as np

from pfcourse.checks import Array
from pfcourse.errors import ParameterError, StepError, is_collapse
from pfcourse.results import KalmanResult

Status = Literal["ok", "lost", "failed"]
R = TypeVar("R")


@dataclass(frozen=True)
class RunRecord:
    """One filter on one run (see the module docstring)."""

    scores: Mapping[str, Any]
    status: Status = "ok"
    error: str = ""
    seconds: float = 0.0
    setting: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        hidden = (set(self.scores) | set(self.setting)) & _FIELDS
        if hidden:
            raise ParameterError(f"a run record's scores and setting cannot be named {sorted(hidden)}: "
                                 f"those are its fields ({sorted(_FIELDS)})")

    @property
    def ok(self) -> bool:
        """The filter finished with an estimate at every step."""
        return self.status == "ok"

    @property
    def failed(self) -> bool:
        """The filter raised a :class:`~pfcourse.errors.StepError`."""
        return self.status == "failed"

    def __getitem__(self, name: str) -> Any:
        return self.scores[name]

    def __getattr__(self, name: str) -> Any:
        # Called only for names that are not fields: a score, else a setting.
        if name.startswith("__"):
            raise AttributeError(name)
        for part in ("scores", "setting"):
            values = self.__dict__.get(part, {})
            if name in values:
                return values[name]
        raise AttributeError(f"this run record has no score or setting {name!r} "
                             f"(scores: {sorted(self.__dict__.get('scores', {}))})")


_FIELDS = {"scores", "status", "error", "seconds", "setting", "ok", "failed"}


def no_estimate(n_steps: int, dim_x: int, dim_z: int = 1) -> KalmanResult:
    """The result of a filter that failed: no estimate at any step (every row NaN, lost at step 0)."""
    result = KalmanResult.empty(n_steps, dim_x, dim_z, "failed")
    result.lost_at = 0
    return result


def failure_message(exc: StepError) -> str:
    """How a failed run's error is written, here and in a study table: ``"ErrorType: message"``."""
    return f"{type(exc).__name__}: {exc}"


def record_run(run: Callable[[], R], score: Callable[[R], Mapping[str, Any]], *,
               setting: Mapping[str, Any] | None = None,
               shape: tuple[int, int, int] | None = None) -> RunRecord:
    """Run a filter (``run()``) and record it, scored by ``score(result)``.

    ``seconds`` is the wall time of ``run()``. A result with a ``lost_at`` step (a Kalman
    estimate off the map) is recorded ``"lost"``. A :class:`~pfcourse.errors.StepError` is
    recorded ``"failed"`` with its message; with ``shape = (K, d, m)`` its scores are
    ``score(no_estimate(K, d, m))``, without it (a run whose scores are not those of a result)
    it has none (NaN in a table).
    """
    setting = {} if setting is None else dict(setting)
    start = time.perf_counter()
    try:
        result = run()
    except StepError as exc:
        if not is_collapse(exc):
            raise
        seconds = time.perf_counter() - start
        scores = {} if shape is None else dict(score(no_estimate(*shape)))
        return RunRecord(scores, "failed", failure_message(exc), seconds, setting)
    seconds = time.perf_counter() - start
    lost_at = getattr(result, "lost_at", None)
    status, error = ("ok", "") if lost_at is None else ("lost", f"no estimate from step {lost_at}")
    return RunRecord(dict(score(result)), status, error, seconds, setting)


def scores(records: Sequence[RunRecord], name: str, failed: Any = None) -> Array:
    """``records``' score ``name`` stacked into an array, one row per record.

    With ``failed`` given, a run that is not ``ok`` gets ``failed`` instead (broadcast to the
    score's shape): ``failed=np.inf`` counts a lost or failed run as an infinite error.
    """
    values = [np.asarray(r.scores[name]) if failed is None or r.ok else None for r in records]
    shape = next((np.shape(r.scores[name]) for r in records if name in r.scores), ())
    return np.array([np.broadcast_to(failed, shape) if v is None else v for v in values])
