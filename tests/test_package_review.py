"""The package review of issue 44 (pkg44): a configuration error stops a study, a Study refuses bad
input by name when it is built, the one RMSE sums an error's components, and augmented MCL's
injection probability is collected as the filter runs."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import DegenerateWeightsError, ModelError, ParameterError, is_collapse
from pfcourse.filter_config import FilterSettings
from pfcourse.studies.executor import SerialExecutor
from pfcourse.studies.record import record_run
from pfcourse.studies.registry import Study
from pfcourse.studies.study import run_study


def _bad_settings_row(seed: int, jitter: float) -> dict:
    FilterSettings(100, jitter=jitter)  # a number is not a jitter function: refused when built
    return {"x": 1.0}


def _collapsing_row(seed: int, a: int = 1) -> dict:
    raise DegenerateWeightsError("every particle has zero likelihood", step=3)


def test_a_row_that_builds_bad_settings_stops_the_study_instead_of_storing_failed_runs():
    with pytest.raises(ModelError, match="jitter must be a function"):
        run_study(_bad_settings_row, {"jitter": [0.2]}, 3, progress=False, executor=SerialExecutor())
    with pytest.raises(ModelError, match="jitter must be a function"):
        record_run(lambda: _bad_settings_row(0, 0.2), lambda r: r)


def test_a_collapse_is_still_recorded_as_a_failed_run():
    table = run_study(_collapsing_row, {"a": [1]}, 2, progress=False, executor=SerialExecutor(),
                      failed_scores={"final": np.inf})
    assert list(table["status"]) == ["failed", "failed"] and np.isinf(table["final"]).all()
    assert table["error_message"].str.startswith("DegenerateWeightsError").all()
    assert is_collapse(DegenerateWeightsError("x")) and not is_collapse(ModelError("x", step=2))


GOOD = dict(name="demo", row=_collapsing_row, grid={"a": [1, 2]}, n_runs=3, table="demo/t.csv",
            provenance="demo/t.json")


@pytest.mark.parametrize("change, match", [
    ({"n_runs": 0}, "n_runs"),
    ({"n_runs": "3"}, "n_runs must be an integer"),
    ({"n_runs": True}, "n_runs must be an integer"),
    ({"grid": {"a": []}}, "non-empty list"),
    ({"grid": [1, 2]}, "grid must be a dict"),
    ({"grid": ()}, "grid must be a dict"),
    ({"row": 3}, "row must be the function"),
    ({"arrays": "theta"}, "arrays must be a tuple"),
    ({"columns": ["a"]}, "columns must be a tuple"),
    ({"table": "/etc/x.csv"}, "inside book/data"),
    ({"table": "../x.csv"}, "inside book/data"),
    ({"table": "x.txt"}, "table must be a .csv"),
    ({"provenance": "x.csv"}, "provenance must be a .json"),
    ({"name": ""}, "needs a name"),
])
def test_a_study_refuses_bad_input_by_name_when_built(change, match):
    Study(**GOOD)  # the reference is accepted
    with pytest.raises(ParameterError, match=match):
        Study(**{**GOOD, **change})


def test_the_one_rmse_sums_an_error_s_components_first():
    from pfcourse.metrics import rmse

    e = np.array([[3.0, 4.0], [0.0, 0.0]])
    assert rmse(e, components=-1) == pytest.approx(np.sqrt(25.0 / 2))
    assert rmse(e[:, 0]) == pytest.approx(np.sqrt(9.0 / 2))
    m = np.ones((4, 2, 2))
    assert rmse(m, components=(1, 2)) == pytest.approx(2.0)
    rng = np.random.default_rng(0)
    err = rng.standard_normal((50, 2))
    # bit for bit the sums the studies stored
    assert rmse(err, components=-1) == np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))


def test_augmented_mcl_s_injection_probability_is_collected_per_resampling():
    from pfcourse.filter import ParticleFilter
    from pfcourse.scenarios.robot.mcl import AugmentedMCL, InjectionProbability
    from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot

    sim = simulate_robot(None, 1, n_steps=20)
    base = RobotModel.for_simulation(sim, initial="uniform")
    aug = AugmentedMCL(base, alpha_slow=0.01, alpha_fast=0.3)
    res = ParticleFilter(base, 300, threshold=1.0, proposal=aug, jitter=aug).run(
        sim.measurements, 2, collect=[InjectionProbability()])
    assert np.array_equal(res.collected["injected"], np.array(aug.injected)) and res.collected["injected"].max() > 0
    with pytest.raises(ParameterError, match="needs augmented MCL"):
        ParticleFilter(base, 300).run(sim.measurements, 2, collect=[InjectionProbability()])


def test_a_result_s_settings_tell_a_roughened_filter_from_a_plain_one():
    from pfcourse import ParticleFilter, StateSpaceModel
    from pfcourse.jitter import RegularisedJitter

    model = StateSpaceModel(dim_x=1, sample_initial=lambda n, rng: rng.standard_normal((n, 1)),
                            sample_transition=lambda x, k, rng: x + rng.standard_normal(x.shape),
                            log_likelihood=lambda x, z, k: -0.5 * (z[0] - x[:, 0]) ** 2)
    z = np.zeros((5, 1))
    plain = ParticleFilter(model, 50).run(z, 1).settings
    rough = ParticleFilter(model, 80, jitter=RegularisedJitter(0.2)).run(z, 1).settings
    assert plain["n_particles"] == 50 and rough["n_particles"] == 80
    assert plain["jitter"] is None and rough["jitter"]["type"] == "RegularisedJitter"
