"""The robot study row (`pf_run`) is the engine's run: the same numbers as `compare_filters`, seed by seed.

Part III runs its studies through :func:`pfcourse.studies.robot.pf_run` (one
:class:`~pfcourse.filter.ParticleFilter` run per seed, the runs spread over the cores by the
study runner); there is no second filter to keep in step.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import DegenerateWeightsError, ParameterError
from pfcourse.studies.robot import RobotRunOptions, compare_filters, global_localization_run, pf_run
from pfcourse.studies.study import run_study, summarize

SEEDS = [3, 11, 2024]


@pytest.mark.parametrize(
    "settings",
    [
        {},
        {"n_particles": 50, "threshold": 1.0, "scheme": "multinomial", "q_scale": 0.5},
        {"n_particles": 80, "threshold": 0.3, "scheme": "residual", "r_scale": 8.0, "dt_meas": 4.0},
        {"n_particles": 2000, "scheme": "stratified", "initial": "uniform", "n_landmarks": 3, "burn_in": 40},
    ],
)
def test_each_run_equals_compare_filters(settings):
    settings = {"burn_in": 5, **settings}
    for seed in SEEDS:
        row = pf_run(seed, n_steps=60, **settings)
        single = compare_filters(seed, filters=("pf",), n_steps=60, **settings)["pf"]
        assert row["position_rmse"] == pytest.approx(single.position_rmse, rel=1e-9)
        assert row["heading_rmse"] == pytest.approx(single.heading_rmse, rel=1e-9)
        assert row["mean_nees"] == pytest.approx(single.mean_nees, rel=1e-7)


def test_metrics_are_consistent():
    row = pf_run(5, n_steps=50, threshold=1.0, keep_errors=True)
    err = row["position_error"]
    assert err.shape == (50,) and row["position_sd"].shape == (50,)
    assert row["position_rmse"] == pytest.approx(np.sqrt(np.mean(err**2)))
    assert row["final_position_error"] == err[-1]
    # threshold 1 resamples at every measurement step (49 of them: weights are never exactly uniform)
    assert row["resamples"] == 49
    assert 0 < row["mean_ess_fraction"] <= 1


def test_no_resampling_at_threshold_zero():
    rows = [pf_run(seed, n_steps=30, threshold=0.0) for seed in SEEDS]
    assert all(r["resamples"] == 0 for r in rows)


def test_bad_arguments():
    with pytest.raises(ParameterError, match="q_scale must be positive"):
        pf_run(SEEDS[0], q_scale=0.0, n_steps=10)
    with pytest.raises(ParameterError, match="initial must be"):
        pf_run(SEEDS[0], initial="everywhere", n_steps=10)
    with pytest.raises(ParameterError, match="burn_in"):
        pf_run(SEEDS[0], n_steps=10, burn_in=10)


def test_filter_settings_are_written_once():
    """The run functions take RobotRunOptions fields and scenario fields as keywords, told apart by split."""
    settings, scenario = RobotRunOptions.split({"n_particles": 50, "n_steps": 20, "burn_in": 3, "gap": None})
    assert settings == RobotRunOptions(n_particles=50, burn_in=3)
    assert scenario == {"n_steps": 20, "gap": None}
    assert RobotRunOptions().n_particles == 300 and RobotRunOptions().initial == "tracking"
    with pytest.raises(ParameterError, match="uniform cloud"):
        global_localization_run(SEEDS[0], 100, n_steps=10, initial="tracking")
    with pytest.raises(ParameterError, match="position_tolerance"):
        global_localization_run(SEEDS[0], 100, n_steps=10, position_tolerance=0.0)
    with pytest.raises(TypeError, match="n_particle"):  # a misspelt setting is no scenario field either
        pf_run(SEEDS[0], n_particle=100, n_steps=10)


def test_study_with_batches_records_failures_per_replicate():
    def batch(seeds, level):
        return [DegenerateWeightsError("lost", step=3) if s % 2 else {"m": level} for s in seeds]

    table = run_study(None, {"level": [1.0]}, 10, run_batch=batch, batch_size=10, progress=False)
    odd = table["seed"] % 2 == 1
    assert (table.loc[odd, "status"] == "failed").all() and (table.loc[~odd, "status"] == "ok").all()
    assert table.loc[odd, "error_message"].str.contains("lost").all()
    assert summarize(table, "level", "m").loc[1.0, "n_failed"] == odd.sum()


def test_global_localization_run_uses_the_books_lock_on_definition():
    """Locked on is pfcourse.metrics.locked_on (every step of the last 20 s), not the last step alone."""
    from pfcourse.studies.robot import RobotRunOptions as Settings
    from pfcourse.metrics import heading_error, locked_on, position_error

    for seed, n in ((2, 3000), (4, 3000), (7, 1000)):
        out = global_localization_run(seed, n, n_steps=40)
        settings, changes = Settings.split({"n_particles": n, "initial": "uniform"})
        sim = settings.simulate(seed, None, {"n_steps": 40, **changes})
        res = settings.run_particle_filter(settings.model(sim), sim, seed)
        expected = locked_on(position_error(sim.truth, res.mean), heading_error(sim.truth, res.mean), sim.scenario.dt)
        assert out.locked_on == expected
        assert out.position_error == float(position_error(sim.truth[-1], res.mean[-1]))
    # a tolerance of half the book's is stricter: never locked on where the book's is not
    assert not global_localization_run(7, 1000, n_steps=40, position_tolerance=0.5).locked_on or \
        global_localization_run(7, 1000, n_steps=40).locked_on


def test_a_filter_that_fails_is_recorded_failed_with_no_estimate(monkeypatch):
    """Every particle impossible: the record says "failed" and why, the other filters of the run are
    kept, and the failed one is scored as having no estimate (NaN RMSE and NEES, not locked on)."""
    def dies(self, model, sim, seed):
        raise DegenerateWeightsError("every particle has zero likelihood", step=4)

    monkeypatch.setattr(RobotRunOptions, "run_particle_filter", dies)
    out = compare_filters(SEEDS[0], filters=("pf", "ekf"), n_steps=30, burn_in=5)
    assert out["pf"].failed and out["pf"].error == "DegenerateWeightsError: every particle has zero likelihood"
    assert np.isnan(out["pf"].position_rmse) and np.isnan(out["pf"].mean_nees) and out["pf"].nees.shape == (25,)
    assert out["ekf"].ok and np.isfinite(out["ekf"].position_rmse)
    lost = global_localization_run(SEEDS[0], 100, n_steps=10)
    assert lost.failed and not lost.locked_on and np.isnan(lost.position_error)
