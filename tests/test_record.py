"""The run record: one failure policy (a StepError is a recorded run, anything else propagates) and
one way of recording a loss (no estimate from the step the filter was lost)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.studies.record import RunRecord, no_estimate, record_run, scores
from pfcourse.results import KalmanResult


def _score(result) -> dict:
    return {"final": float(result.mean[-1, 0]), "path": result.mean[:, 0]}


def _finished(lost_at=None) -> KalmanResult:
    mean = np.arange(8.0).reshape(4, 2)
    if lost_at is not None:
        mean[lost_at:] = np.nan
    return KalmanResult(mean=mean, cov=np.tile(np.eye(2), (4, 1, 1)), lost_at=lost_at)


def test_a_finished_run_is_ok_and_scored():
    record = record_run(_finished, _score, setting={"filter": "ekf"})
    assert record.ok and record.status == "ok" and record.error == "" and record.seconds >= 0
    assert record.final == 6.0 and record["final"] == 6.0 and record.filter == "ekf"
    with pytest.raises(AttributeError, match="no score or setting 'rmse'"):
        record.rmse


def test_a_lost_run_keeps_its_scores_up_to_the_step_it_was_lost():
    record = record_run(lambda: _finished(lost_at=2), _score)
    assert record.status == "lost" and record.error == "no estimate from step 2" and not record.ok
    np.testing.assert_array_equal(record.path, [0.0, 2.0, np.nan, np.nan])


def test_a_failed_run_is_scored_as_no_estimate_from_the_start():
    def dies():
        raise DegenerateWeightsError("every particle has zero likelihood", step=3)

    record = record_run(dies, _score, shape=(4, 2, 1))
    assert record.failed and record.error == "DegenerateWeightsError: every particle has zero likelihood"
    assert np.isnan(record.final) and np.all(np.isnan(record.path))
    assert record_run(dies, _score).scores == {}  # without the run's shape: no scores (NaN in a table)
    nothing = no_estimate(4, 2, 1)
    assert nothing.lost_at == 0 and np.all(np.isnan(nothing.mean)) and nothing.cov.shape == (4, 2, 2)


def test_other_errors_are_bugs_and_propagate():
    def bad():
        raise ParameterError("n_particles must be positive")

    with pytest.raises(ParameterError):
        record_run(bad, _score)


def test_scores_stack_and_count_a_run_that_is_not_ok_as_given():
    records = [RunRecord({"e": np.array([1.0, 2.0])}), RunRecord({"e": np.array([3.0, np.nan])}, "lost"),
               RunRecord({}, "failed", "DegenerateWeightsError: lost")]
    np.testing.assert_array_equal(scores(records, "e", failed=np.inf), [[1.0, 2.0], [np.inf, np.inf], [np.inf, np.inf]])
    np.testing.assert_array_equal(scores(records[:2], "e"), [[1.0, 2.0], [3.0, np.nan]])
    np.testing.assert_array_equal(scores(records[1:], "e", failed=np.inf), np.full((2, 2), np.inf))  # shape kept
    with pytest.raises(KeyError):
        scores(records, "e")  # a failed run without scores has none to stack


def test_a_record_pickles():
    record = RunRecord({"e": 1.0}, "lost", "no estimate from step 3", 0.5, {"filter": "pf", "n_particles": 30})
    again = pickle.loads(pickle.dumps(record))
    assert again == record and again.n_particles == 30


def test_a_score_cannot_hide_a_field():
    with pytest.raises(ParameterError, match="cannot be named \\['error'\\]"):
        RunRecord({"error": np.zeros(3)})
