"""NIS and predictive moments, the terrain UKF, and the innovations the Kalman family records."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate
from pfcourse.scenarios.terrain.kalman import state_mean, unscented_kalman_filter
from pfcourse.collectors import Clouds
from pfcourse.angles import wrap_angle
from pfcourse.studies.comparison import (
    particle_innovations,
    robot_tracks,
    summarize_tracks,
)
from pfcourse.diagnostics import chi2_band, fraction_in_band, nis, predictive_moments
from pfcourse.errors import ShapeError
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario
from pfcourse.scenarios.landmarks.scenario import simulate as simulate_landmarks
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot
from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf
from pfcourse.scenarios.terrain.map import load_jacksboro

TIGHT = dict(P0=np.diag([30.0, 30.0, 5.0, 0.01]) ** 2, Qf=np.diag([1.0, 1.0, 0.1, 0.001]) ** 2)


@pytest.fixture(scope="module")
def jacksboro():
    return load_jacksboro()


# --- NIS and the predictive distribution ---------------------------------------------------


def test_nis_of_gaussian_innovations_is_chi_square():
    rng = np.random.default_rng(2)
    m, k = 2, 4000
    a = rng.normal(size=(m, m))
    S = a @ a.T + np.eye(m)
    y = rng.multivariate_normal(np.zeros(m), S, size=k)
    values = nis(y, np.broadcast_to(S, (k, m, m)))
    lo, hi = chi2_band(m, n_runs=k, probability=0.999)
    assert lo < values.mean() < hi
    assert stats.kstest(values, stats.chi2(m).cdf).pvalue > 1e-3
    # Fraction inside the single-step 95 % band: binomial(k, 0.95), 4 standard deviations.
    inside = fraction_in_band(values, chi2_band(m, 1))
    assert abs(inside - 0.95) < 4 * np.sqrt(0.95 * 0.05 / k)


def test_nis_missing_steps_and_shapes():
    y = np.array([[1.0], [np.nan], [2.0]])
    S = np.array([[[4.0]], [[1.0]], [[1.0]]])
    out = nis(y, S)
    assert out[0] == pytest.approx(0.25) and np.isnan(out[1]) and out[2] == pytest.approx(4.0)
    assert np.allclose(nis(y[:, 0], S[:, 0, 0]), out, equal_nan=True)
    with pytest.raises(ShapeError, match="nis needs"):
        nis(np.zeros((3, 2)), np.zeros((3, 1, 1)))
    # inf (a lost filter) is outside every band, NaN (no measurement) is left out.
    assert fraction_in_band(np.array([1.0, np.inf, np.nan]), (0.5, 2.0)) == 0.5


def test_predictive_moments_of_a_weighted_mixture():
    h = np.array([[0.0, np.pi - 0.1], [2.0, -np.pi + 0.1]])
    w = np.array([0.25, 0.75])
    R = np.diag([1.0, 0.01])
    mean, S = predictive_moments(h, w, R, angle_indices=(1,))
    # The bearings straddle the +/-pi cut: circular mean and wrapped deviations.
    assert mean[0] == pytest.approx(1.5)
    b = h[:, 1]
    circ = np.arctan2(w @ np.sin(b), w @ np.cos(b))
    assert abs(wrap_angle(mean[1] - circ)) < 1e-12 and abs(wrap_angle(circ - (-np.pi + 0.05))) < 1e-3
    dev = wrap_angle(b - circ)
    assert S[0, 0] == pytest.approx(0.25 * 1.5**2 + 0.75 * 0.5**2 + 1.0)
    assert S[1, 1] == pytest.approx(w @ dev**2 + 0.01)
    assert S[1, 1] < 0.02  # not the (2 pi)^2-sized spread of unwrapped bearings
    with pytest.raises(ShapeError, match="predictive_moments needs"):
        predictive_moments(h, w[:1], R)


def test_particle_innovations_converge_to_the_kalman_ones():
    """On a scalar linear-Gaussian model the PF's predictive mean and S match the Kalman
    filter's ``H m^-`` and ``H P^- H^T + R`` up to Monte Carlo error ~ 1/sqrt(ESS)."""
    F, Q, R = 0.9, 0.09, 0.25
    model = LinearGaussianModel(F=[[F]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[Q]], R=[[R]])
    rng = np.random.default_rng(5)
    x, z = 0.0, np.empty((20, 1))
    for k in range(20):
        x = F * x + rng.normal(0, np.sqrt(Q)) if k else rng.normal(0, 1)
        z[k] = x + rng.normal(0, np.sqrt(R))
    kf = kalman_filter(model, z)
    pf = ParticleFilter(model, 20000, threshold=0.5).run(z, 1, collect=[Clouds()])
    y, S = particle_innovations(pf, z, lambda p, zk, k: p, np.array([[R]]))
    m_pred = F * kf.mean[:-1, 0]
    P_pred = F**2 * kf.cov[:-1, 0, 0] + Q
    ess = pf.ess[:-1]
    # Predicted mean: sd sqrt(P^- / ESS); predicted variance: relative sd sqrt(2 / ESS).
    assert np.all(np.abs((z[1:, 0] - y[1:, 0]) - m_pred) < 5 * np.sqrt(P_pred / ess))
    assert np.all(np.abs(S[1:, 0, 0] - (P_pred + R)) < 5 * np.sqrt(2 / ess) * P_pred)


# --- the Kalman family records its own innovations, and they give its posterior --------------


def _recorded_posterior(run):
    ok = ~np.isnan(run.innovation[:, 0])
    return ok, run.predicted[ok] + np.einsum("kij,kj->ki", run.gain[ok], run.innovation[ok])


@pytest.mark.parametrize("runner", [run_ekf, run_ukf])
def test_robot_innovations_give_the_filters_posterior(runner):
    sim = simulate_robot(None, 4, n_steps=60)
    model = RobotModel.for_simulation(sim, q_scale=1.0, r_scale=1.0)
    run = runner(model, sim.measurements)
    ok, post = _recorded_posterior(run)
    post[:, 2] = wrap_angle(post[:, 2])
    assert ok.sum() == sim.has_measurement.sum()
    assert np.allclose(post, run.mean[ok], atol=1e-9)
    assert np.all(np.linalg.eigvalsh(run.innovation_cov[ok])[:, 0] > 0)


def test_terrain_ekf_innovations_give_the_filters_posterior(jacksboro):
    scenario = AircraftScenario().with_(**TIGHT)
    flight = simulate(scenario, jacksboro, 3)
    ekf = extended_kalman_filter(scenario, jacksboro, flight.measurements)
    ok, post = _recorded_posterior(ekf)
    post[:, 3] = wrap_angle(post[:, 3])
    assert ok.sum() == 80
    assert np.allclose(post, ekf.mean[ok], atol=1e-6)


def test_linear_kalman_innovations_give_the_exact_posterior_and_likelihood():
    """For the linear filter: m_k = m^-_k + G_k y_k, and log p(z) = sum_k log N(y_k; 0, S_k)."""
    from scipy.stats import multivariate_normal

    scenario = quadrant_scenario()
    sim = simulate_landmarks(scenario, 2)
    kf = kalman_filter(scenario.model(), sim.measurements)
    measured = ~np.all(np.isnan(kf.innovation), axis=1)
    post = kf.predicted + np.einsum("kij,kj->ki", np.nan_to_num(kf.gain), np.nan_to_num(kf.innovation))
    assert np.allclose(post[measured], kf.mean[measured], atol=1e-12)
    total = 0.0
    for y, S in zip(kf.innovation[measured], kf.innovation_cov[measured]):
        o = ~np.isnan(y)
        total += multivariate_normal(np.zeros(o.sum()), S[np.ix_(o, o)]).logpdf(y[o])
    assert total == pytest.approx(kf.log_likelihood, rel=1e-10)


# --- the terrain UKF -------------------------------------------------------------------------


def test_ukf_state_mean_is_circular_in_the_heading():
    sigmas = np.array([[0.0, 0, 0, np.pi - 0.1], [2.0, 0, 0, -np.pi + 0.1]])
    m = state_mean(sigmas, np.array([0.5, 0.5]))
    assert m[0] == 1.0 and abs(wrap_angle(m[3] - np.pi)) < 1e-12


def test_terrain_ukf_tracks_from_a_small_prior_and_is_consistent(jacksboro):
    """From a small prior the linearisation-free UKF tracks within about a DEM cell, like the
    EKF; its NIS averaged over the 80 readings is no larger than the 99.9 % upper bound of an
    average of 80 chi2_1 values (the filter allows for process noise the true flight does not
    have, so it may be smaller, but not collapsed: above 0.2)."""
    scenario = AircraftScenario().with_(**TIGHT)
    cell = np.hypot(jacksboro.dx, jacksboro.dy)
    for seed in range(3):
        flight = simulate(scenario, jacksboro, seed, initial_state=scenario.x0)
        ukf = unscented_kalman_filter(scenario, jacksboro, flight.measurements)
        assert ukf.lost_at is None
        err = np.hypot(*(ukf.mean[:, :2] - flight.truth[:, :2]).T)
        assert np.max(err) < cell
        q = nis(ukf.innovation, ukf.innovation_cov)
        assert np.isnan(q[0]) and np.all(np.isfinite(q[1:]))
        assert 0.2 < np.mean(q[1:]) < chi2_band(1, 80, probability=0.999)[1]


def test_terrain_ukf_handles_a_heading_across_the_cut(jacksboro):
    """Flying west (heading near +/-pi) the sigma points straddle the cut; the heading estimate
    must stay near pi, not collapse to the arithmetic mean 0."""
    scenario = AircraftScenario().with_(**TIGHT, x0=np.array([21000.0, 15000.0, 1500.0, np.pi - 0.005]))
    flight = simulate(scenario, jacksboro, 0, initial_state=scenario.x0)
    ukf = unscented_kalman_filter(scenario, jacksboro, flight.measurements)
    assert ukf.lost_at is None
    assert np.max(np.abs(wrap_angle(ukf.mean[:, 3] - flight.truth[:, 3]))) < 0.05


def test_terrain_ukf_stops_when_it_leaves_the_map(jacksboro):
    scenario = AircraftScenario().with_(**TIGHT, x0=np.array([500.0, 15000.0, 1500.0, np.pi]))
    z = np.full(81, np.nan)  # dead reckoning: the mean leaves the map between 5 and 6 s
    ukf = unscented_kalman_filter(scenario, jacksboro, z)
    assert ukf.lost_at == 6
    assert np.all(np.isnan(ukf.mean[ukf.lost_at:])) and np.all(np.isfinite(ukf.mean[: ukf.lost_at]))


# --- the per-run comparison ------------------------------------------------------------------


def test_robot_tracks_and_summary_are_seeded_and_complete():
    runs = [robot_tracks(seed, (50,), n_steps=30) for seed in range(2)]
    again = robot_tracks(0, (50,), n_steps=30)
    assert [t.filter for t in runs[0]] == ["pf", "ekf", "ukf"]
    assert np.array_equal(runs[0][0].nees, again[0].nees) and np.array_equal(runs[0][0].nis, again[0].nis, equal_nan=True)
    table = summarize_tracks(runs, dim_x=3, dim_z=2, burn_in=5)
    assert list(table.index) == ["PF N=50", "EKF", "UKF"]
    assert table.loc["UKF", "evaluations"] == 7 and table.loc["PF N=50", "evaluations"] == 50
    assert table[["nees_in_band", "nis_in_band"]].apply(lambda c: c.between(0, 1)).all().all()


def test_a_particle_filter_that_dies_is_lost_from_the_start(jacksboro, monkeypatch):
    """terrain_tracks: a particle filter that loses every particle is recorded "failed", with inf error
    and NEES at every step and inf NIS at every measured step (NaN where there is no reading), as a
    Kalman filter lost at step 0 would be; summarize_tracks counts it as diverged."""
    from pfcourse.errors import DegenerateWeightsError
    from pfcourse.studies.comparison import terrain_tracks
    from pfcourse.seeding import data_rng

    def dies(self, *args, **kwargs):
        raise DegenerateWeightsError("every particle is off the map", step=2)

    monkeypatch.setattr(ParticleFilter, "run", dies)
    scenario = AircraftScenario().with_(duration=10.0)
    runs = [terrain_tracks(0, r, scenario, jacksboro, (50,), kalman=("ekf",)) for r in range(2)]
    pf = runs[0][0]
    z = simulate(scenario, jacksboro, data_rng(0, 0)).measurements
    assert pf.failed and pf.error.startswith("DegenerateWeightsError") and pf.n_particles == 50
    assert np.all(np.isinf(pf.position_error)) and np.all(np.isinf(pf.nees))
    assert np.array_equal(np.isnan(pf.nis), np.isnan(z[:, 0])) and np.all(np.isinf(pf.nis[~np.isnan(z[:, 0])]))
    table = summarize_tracks(runs, dim_x=4, dim_z=1, diverged_error=500.0)
    assert table.loc["PF N=50", "diverged"] == 1.0 and table.loc["PF N=50", "nees_in_band"] == 0.0
