"""The remedies of pfcourse.scenarios.robot.mcl: correct densities and weights, Fox's bound, the injection rule."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from pfcourse.errors import ParameterError
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.robot.scenario import RobotModel, range_bearing, simulate_robot
from pfcourse.sample_size import kld_bound
from pfcourse.scenarios.robot.mcl import (
    AugmentedMCL,
    KidnapRobotModel,
    SensorPoseSampler,
    kidnap,
    kld_filter,
    run_method,
    sensor_mixture_proposal,
)


def _models(seed=0, n_steps=4, teleport=1e-3, global_start=True):
    sim = simulate_robot(None, seed, n_steps=n_steps)
    base = RobotModel.for_simulation(sim, initial="uniform" if global_start else "tracking")
    return sim, base, KidnapRobotModel(base, teleport, global_start=global_start)


def _wide_model(teleport, global_start, dt=2.0, seed=0):
    """A robot whose odometry noise (3 m/s, 0.5 rad/s, dt = 2 s) overlaps the ring of a reading."""
    sim = simulate_robot(None, seed, n_steps=5)
    base = RobotModel(sim.landmarks, sim.odometry, np.diag([3.0, 3.0, 0.5]) ** 2, 2 * sim.scenario.r_true,
                      dt=dt, initial="uniform" if global_start else "tracking", start=sim.truth[0],
                      initial_std=(4.0, 4.0, 0.5))
    return sim, base, KidnapRobotModel(base, teleport, global_start=global_start)


def _near_reading(sim, base, old, rng):
    """A reading of landmark 0 as seen from a pose one odometry step after ``old``."""
    x = base.sample_transition(old[None], 1, rng)[0]
    h = range_bearing(x, sim.landmarks[0])
    return np.array([0.0, h[0], h[1]])


def test_mixture_density_is_normalised_over_its_own_draws():
    # E_q[p_odo / q] = 1 for q = 0.5 p_odo + 0.5 q_z when both are normalised densities:
    # checks p_odo (inverse motion, Jacobian dt^3) and q_z (Jacobian 1 / r) where they overlap.
    # The ratio lies in [0, 2]: its sd is at most 1.
    sim, base, model = _wide_model(0.0, False)
    prop = sensor_mixture_proposal(model, share=0.5)
    rng = np.random.default_rng(3)
    n = 400_000
    old = np.tile(sim.truth[0], (n, 1))
    z = _near_reading(sim, base, sim.truth[0], rng)
    new = prop.sample(old, z, 1, rng)
    log_p = model.odometry_log_density(new, old, 1)
    log_q = prop.log_density(new, old, z, 1)
    ratio = np.exp(log_p - log_q)
    assert np.all(ratio <= 2.0 + 1e-9)
    assert 0.05 < np.mean(np.exp(log_p[: n // 2] - log_q[: n // 2]) > 0.1)  # the components overlap
    assert abs(ratio.mean() - 1.0) < 4 * ratio.std() / np.sqrt(n)


def test_first_step_posterior_matches_a_grid():
    # Uniform prior at the first reading, every particle drawn from q_z, weights through the
    # engine. A reading 2 m from a landmark, so the 1/r Jacobian matters: the posterior of the
    # position is proportional to N(|l - p|; 2, s_r^2) on the map (the heading integrates out).
    # Compare E|l - p|, E p_x and P(p_x > l_x) with a 0.01 m grid.
    sim, base, model = _models(seed=4, n_steps=2)
    z = np.array([[np.nan] * 3, [0.0, 2.0, 0.3]])
    n = 40_000
    res = ParticleFilter(model, n, proposal=sensor_mixture_proposal(model)).run(z, 5, collect=[Clouds()])
    lm = sim.landmarks[0]
    s_r = np.sqrt(base.r_est[0, 0])
    g = np.arange(-6 + 0.005, 6, 0.01)
    gx, gy = np.meshgrid(g + lm[0], g + lm[1], indexing="ij")
    r = np.hypot(lm[0] - gx, lm[1] - gy)
    dens = stats.norm.pdf(r, 2.0, s_r) * (np.abs(gx) <= 60) * (np.abs(gy) <= 60)
    dens /= dens.sum()
    stats_of = lambda w, px, rr: np.array([w @ rr, w @ px, w @ (px > lm[0])])
    exact = stats_of(dens.ravel(), gx.ravel(), r.ravel())
    second = stats_of(dens.ravel(), gx.ravel() ** 2, r.ravel() ** 2)
    sd = np.sqrt([second[0] - exact[0] ** 2, second[1] - exact[1] ** 2, exact[2] * (1 - exact[2])])
    w, x = res.weights[1], res.particles[1]
    estimate = stats_of(w, x[:, 0], np.hypot(lm[0] - x[:, 0], lm[1] - x[:, 1]))
    ess = 1 / np.sum(w**2)
    assert np.all(np.abs(estimate - exact) < 4 * sd / np.sqrt(ess))
    # without the 1/r Jacobian the weights would be uniform and E|l - p| would be off by far more
    unweighted = np.mean(np.hypot(lm[0] - x[:, 0], lm[1] - x[:, 1]))
    assert abs(unweighted - exact[0]) > 10 * sd[0] / np.sqrt(ess)


def test_mixture_and_bootstrap_agree_on_the_kidnap_model():
    # Same target (wide odometry noise, teleport 0.05, so every term of the weight counts):
    # posterior mean and log-likelihood estimate of the mixture proposal (share 0.5) agree with
    # a 10^6-particle bootstrap filter on the kidnap model.
    sim, base, model = _wide_model(0.05, False)
    rng = np.random.default_rng(9)
    z = np.full((3, 3), np.nan)
    z[1] = _near_reading(sim, base, sim.truth[0], rng)
    z[2] = z[1]
    ref = ParticleFilter(model, 1_000_000).run(z, 0)
    runs = [ParticleFilter(model, 20_000, proposal=sensor_mixture_proposal(model, share=0.5)).run(z, s)
            for s in range(10)]
    means = np.array([r.mean[-1, :2] for r in runs])
    logl = np.array([r.log_likelihood for r in runs])
    se_mean = means.std(axis=0, ddof=1) / np.sqrt(len(runs))
    se_logl = logl.std(ddof=1) / np.sqrt(len(runs))
    ref_se = np.sqrt(np.diag(ref.cov[-1])[:2] / ref.ess[-1])
    ref_se_logl = 1 / np.sqrt(ref.ess[1]) + 1 / np.sqrt(ref.ess[2])  # delta method, relative error of each increment
    assert np.all(np.abs(means.mean(axis=0) - ref.mean[-1, :2]) < 4 * np.hypot(se_mean, ref_se))
    assert abs(logl.mean() - ref.log_likelihood) < 4 * np.hypot(se_logl, ref_se_logl)


def test_sensor_sampler_puts_poses_on_the_reading():
    sim, base, _ = _models()
    sampler = SensorPoseSampler(base.landmarks, base.r_est)
    z = sim.measurements[1]
    x = sampler.sample(z, 50_000, np.random.default_rng(1))
    h = range_bearing(x, base.landmarks[int(z[0])])
    nu = (h - z[1:]) / np.sqrt(np.diag(base.r_est))
    nu[:, 1] = np.angle(np.exp(1j * (h[:, 1] - z[2]))) / np.sqrt(base.r_est[1, 1])
    # The drawn reading is N(z, REst): standardized innovations are standard normal.
    assert stats.kstest(nu[:, 0], "norm").pvalue > 1e-3
    assert stats.kstest(nu[:, 1], "norm").pvalue > 1e-3


def test_kld_bound_is_fox_wilson_hilferty_of_the_chi2_quantile():
    k = np.arange(10, 2000, 37)
    exact = stats.chi2.ppf(0.99, k - 1) / (2 * 0.05)
    assert np.all(np.abs(kld_bound(k, 0.05, 0.01) - exact) <= 0.005 * exact + 1)
    assert kld_bound(1) == 1
    assert np.all(np.diff(kld_bound(k)) > 0)


def test_kld_bound_keeps_the_kl_divergence_below_epsilon():
    # n = bound(k) draws from k equally likely bins: KL(empirical || true) > eps in about delta of the cases.
    rng = np.random.default_rng(0)
    k, eps, delta, reps = 30, 0.05, 0.05, 4000
    n = int(kld_bound(k, eps, delta))
    counts = rng.multinomial(n, np.full(k, 1 / k), size=reps)
    p = counts / n
    with np.errstate(divide="ignore", invalid="ignore"):
        kl = np.sum(np.where(p > 0, p * np.log(p * k), 0.0), axis=1)
    exceed = int(np.sum(kl > eps))
    # the chi2 approximation of 2 n KL is close at this n: the rate lies in a binomial band around delta
    assert stats.binomtest(exceed, reps, delta).pvalue > 1e-3


def test_kld_filter_uses_few_particles_once_the_cloud_is_tight():
    sim, base, _ = _models(seed=1, n_steps=30, global_start=False)
    res = kld_filter(base, sim.measurements, 0, n_max=5000, n_min=50)
    assert res.sizes[0] == 5000 and res.n_particles == 5000
    assert np.all(res.sizes[10:] < 1000)
    assert np.all(res.sizes >= 50)


def test_injection_rule_and_averages():
    _, base, _ = _models()
    aug = AugmentedMCL(base, alpha_slow=0.1, alpha_fast=0.5)
    values = [0.5, 0.2, 0.01]
    slow = fast = values[0]
    for v in values:
        aug.update_averages(np.log(v))
    for v in values[1:]:
        slow += 0.1 * (v - slow)
        fast += 0.5 * (v - fast)
    np.testing.assert_allclose(np.exp([aug.w_slow, aug.w_fast]), [slow, fast], rtol=1e-12)
    p = max(0.0, 1 - fast / slow)
    assert aug.injection_probability() == pytest.approx(p, rel=1e-12)
    aug.z = simulate_robot(None, 0, n_steps=4).measurements[1]
    cloud = np.zeros((20_000, 3))
    out = aug(cloud, np.random.default_rng(2))
    replaced = int(np.sum(np.any(out != 0, axis=1)))
    assert stats.binomtest(replaced, len(cloud), p).pvalue > 1e-3


def test_kidnap_keeps_noise_and_odometry():
    sim = simulate_robot(None, 3, n_steps=40)
    k = kidnap(sim, 20, (10.0, 10.0, 1.0))
    np.testing.assert_array_equal(k.truth[:20], sim.truth[:20])
    np.testing.assert_array_equal(k.odometry, sim.odometry)
    np.testing.assert_allclose(k.truth[20], [10.0, 10.0, 1.0])
    for step in np.flatnonzero(sim.has_measurement):
        lm = sim.landmarks[int(sim.measurements[step, 0])]
        old = sim.measurements[step, 1:] - range_bearing(sim.truth[step], lm)
        new = k.measurements[step, 1:] - range_bearing(k.truth[step], lm)
        assert abs(old[0] - new[0]) < 1e-9
        assert abs(np.angle(np.exp(1j * (old[1] - new[1])))) < 1e-9


def test_bad_settings_raise_named_errors():
    sim, base, model = _models()
    with pytest.raises(ParameterError, match="share"):
        sensor_mixture_proposal(model, share=1.5)
    with pytest.raises(ParameterError, match="diagonal"):
        SensorPoseSampler(base.landmarks, np.array([[1.0, 0.1], [0.1, 1.0]]))
    with pytest.raises(ParameterError, match="alpha"):
        AugmentedMCL(base, alpha_slow=0.5, alpha_fast=0.1)
    with pytest.raises(ParameterError, match="unknown method"):
        run_method(sim, "magic", 100, 0)
    with pytest.raises(ParameterError, match="kidnap step"):
        kidnap(sim, 0, (0.0, 0.0, 0.0))


def test_tempered_method_counts_every_stage_of_progressive_correction():
    sim = simulate_robot(None, 3, n_steps=30)
    out = run_method(sim, "tempered", 500, 3)
    measured = np.flatnonzero(sim.has_measurement)
    measured = measured[measured > 0]
    assert np.all(out["n_used"] == 500)
    # the first tempered readings need several stages (a uniform prior against a sharp likelihood) ...
    assert out["likelihood_evaluations"][measured[0]] >= 2 * 500
    # ... every evaluation is a multiple of N, and after the tempered readings it is the bootstrap filter
    assert np.all(out["likelihood_evaluations"] % 500 == 0)
    assert np.all(out["likelihood_evaluations"][measured[10:]] == 500)


def test_kld_bin_size_reaches_the_filter():
    # Half-size bins in position: the same cloud occupies more bins, so KLD-sampling keeps more particles.
    from pfcourse.scenarios.robot.mcl import kld_policy, run_settings, settings_of

    sim = simulate_robot(None, 0, n_steps=15)
    coarse = run_method(sim, "kld_mixture", 2000, 0)["n_used"]
    finer = settings_of("kld_mixture", 2000).with_(sample_size=kld_policy((0.5, 0.5, float(np.deg2rad(10.0)))))
    fine = run_settings(sim, finer, 0)["n_used"]
    assert fine[5:].mean() > coarse[5:].mean()


def _hand_written(method, base, n):
    """The filters of the registry as they were written before they became settings records."""
    if method == "mixture":
        model = KidnapRobotModel(base, 1e-3, global_start=base.initial == "uniform")
        return ParticleFilter(model, n, proposal=sensor_mixture_proposal(model, 0.1, 1.0))
    if method == "augmented":
        aug = AugmentedMCL(base, alpha_slow=0.01, alpha_fast=0.1)
        return ParticleFilter(base, n, threshold=1.0, proposal=aug, jitter=aug)
    if method == "tempered":
        from pfcourse.jitter import RegularisedJitter
        from pfcourse.proposals import ProgressiveCorrection
        from pfcourse.scenarios.robot.scenario import ANGLE_INDICES

        pc = ProgressiveCorrection(n_tempered=10, ess_fraction=0.5, kernel=RegularisedJitter(0.5, ANGLE_INDICES))
        return ParticleFilter(base, n, threshold=1.0, proposal=pc)
    raise AssertionError(method)


@pytest.mark.parametrize("method", ["mixture", "augmented", "tempered"])
@pytest.mark.parametrize("initial", ["uniform", "tracking"])
def test_a_settings_record_builds_the_filter_written_by_hand(method, initial):
    """Each record of FILTERS builds the filter its components describe, float for float (the kidnap model's
    global start follows the robot's initial cloud); a second build starts from fresh components."""
    from pfcourse.scenarios.robot.mcl import settings_of

    sim = simulate_robot(None, 2, n_steps=12)
    base = RobotModel.for_simulation(sim, initial=initial)
    by_hand = _hand_written(method, base, 400).run(sim.measurements, 5)
    settings = settings_of(method, 400)
    for _ in range(2):
        built = settings.build(base).run(sim.measurements, 5)
        assert built.mean.tobytes() == by_hand.mean.tobytes() and built.ess.tobytes() == by_hand.ess.tobytes()


@pytest.mark.parametrize("seed", [0, 1])
def test_the_mixture_spends_its_share_drawn_from_the_reading_while_tracking(seed):
    # A tenth of the particles drawn from the reading carry weights of order eps = 1e-3 while the robot is
    # tracked, so the mixture's ESS is about 0.9 of the bootstrap filter's on the same run, never above it.
    from pfcourse.studies.global_localization import tracking_row

    ratio = tracking_row(seed, "mixture", 2000)["ess_fraction"] / tracking_row(seed, "bootstrap", 2000)["ess_fraction"]
    assert 0.8 < ratio < 0.97


def test_augmented_mcl_made_without_a_model_injects_on_the_filter_s():
    sim = simulate_robot(None, 1, n_steps=20)
    base = RobotModel.for_simulation(sim, initial="uniform")
    given = AugmentedMCL(base, alpha_slow=0.01, alpha_fast=0.3)
    later = AugmentedMCL(alpha_slow=0.01, alpha_fast=0.3)
    a = ParticleFilter(base, 300, threshold=1.0, proposal=given, jitter=given).run(sim.measurements, 2)
    b = ParticleFilter(base, 300, threshold=1.0, proposal=later, jitter=later).run(sim.measurements, 2)
    assert a.mean.tobytes() == b.mean.tobytes() and later.injected == given.injected and max(given.injected) > 0
