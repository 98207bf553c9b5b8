"""The Rao-Blackwellised and auxiliary particle filters against exact answers."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.collectors import Clouds
from pfcourse import LinearGaussianModel, ParticleFilter, kalman_filter
from pfcourse.proposals import FullyAdaptedAuxiliary, LinearGaussianOptimal
from pfcourse.errors import ParameterError
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.scenarios.landmarks.rao_blackwell import RaoBlackwellError, RaoBlackwellModel, RaoBlackwellProposal

def short_scenario(n_samples=12):
    return quadrant_scenario().with_(n_samples=n_samples)


def test_coupled_model_is_refused():
    m = quadrant_scenario().model()
    F = m.F.copy()
    F[0, 2] = 0.1
    coupled = LinearGaussianModel(F=F, H=m.H, m0=m.m0, P0=m.P0, Q=m.Q, R=m.R, B=m.B)
    with pytest.raises(ParameterError, match="F couples the robot"):
        RaoBlackwellModel(coupled)
    with pytest.raises(ParameterError, match="n_robot"):
        RaoBlackwellModel(m, n_robot=6)


def test_likelihood_without_proposal_is_a_named_error():
    rb = RaoBlackwellModel(quadrant_scenario().model())
    z = np.array([1.0, 1.0, np.nan, np.nan])
    with pytest.raises(RaoBlackwellError, match="step 0"):
        ParticleFilter(rb, 10).run([z], rng=0)


def test_known_robot_gives_the_kalman_filter():
    """With the robot (almost) known, every particle's map filter is the exact Kalman filter."""
    sc = short_scenario(20)
    tiny = np.diag([1e-14, 1e-14] + [1e-20] * 4)
    P0 = sc.PX0.copy()
    P0[:2, :2] = 1e-14 * np.eye(2)
    sc = sc.with_(Qw=tiny, PX0=P0)
    model = sc.model()
    sim = simulate(sc, rng=3)
    kf = kalman_filter(model, sim.measurements)
    rb = RaoBlackwellModel(model)
    for optimal in (False, True):
        res = rb.marginal(ParticleFilter(rb, 50, proposal=RaoBlackwellProposal(optimal)).run(sim.measurements, rng=4))
        np.testing.assert_allclose(res.mean, kf.mean, atol=1e-5)
        np.testing.assert_allclose(res.cov[:, 2:, 2:], kf.cov[:, 2:, 2:], rtol=1e-6, atol=1e-12)
        assert res.log_likelihood == pytest.approx(kf.log_likelihood, abs=1e-3)


def test_marginal_is_the_law_of_total_covariance():
    sc = short_scenario()
    rb = RaoBlackwellModel(sc.model())
    sim = simulate(sc, rng=1)
    raw = ParticleFilter(rb, 40, proposal=RaoBlackwellProposal(True)).run(sim.measurements, rng=2, collect=[Clouds()])
    res = rb.marginal(raw)
    k = sc.n_samples - 1
    robot, mean, cov = rb.unpack(raw.particles[k])
    w = raw.weights[k]
    x = np.hstack([robot, mean])
    mu = w @ x
    between = (x - mu).T @ ((x - mu) * w[:, None])
    within = np.zeros((6, 6))
    within[2:, 2:] = np.einsum("n,nij->ij", w, cov)
    np.testing.assert_allclose(res.mean[k], mu, atol=1e-12)
    np.testing.assert_allclose(res.cov[k], between + within, atol=1e-10)


def test_optimal_weight_does_not_depend_on_the_draw_and_shared_path_is_exact():
    sc = short_scenario()
    rb = RaoBlackwellModel(sc.model())
    rng = np.random.default_rng(0)
    particles = rb.sample_transition(rb.sample_initial(30, rng), 1, rng)
    z = np.array([0.5, 3.0, np.nan, np.nan])
    prop = RaoBlackwellProposal(True)
    new1, w1 = prop.propose(rb, particles, z, 2, np.random.default_rng(1))
    new2, w2 = prop.propose(rb, particles, z, 2, np.random.default_rng(2))
    np.testing.assert_array_equal(w1, w2)
    assert not np.allclose(new1[:, :2], new2[:, :2])
    np.testing.assert_allclose(prop.log_predictive(rb, particles, z, 2), w1, rtol=1e-12)
    # break the shared covariance on one particle: the per-particle path gives the others the same numbers
    perturbed = particles.copy()
    perturbed[0, 6:] += 1e-3 * np.eye(4).ravel()
    new3, w3 = prop.propose(rb, perturbed, z, 2, np.random.default_rng(1))
    np.testing.assert_allclose(new3[1:], new1[1:], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(w3[1:], w1[1:], rtol=1e-10)


@pytest.mark.parametrize("method", ["rbpf_prior", "apf", "rb_apf"])
def test_likelihood_estimate_is_unbiased(method):
    """E[p^(z)] = p(z): the mean of exp(log p^ - log p) over runs is 1 within 4 standard errors."""
    sc = short_scenario(10)
    model = sc.model()
    sim = simulate(sc, rng=7)
    exact = kalman_filter(model, sim.measurements).log_likelihood
    rb = RaoBlackwellModel(model)
    ratios = []
    for seed in range(300):
        if method == "apf":
            pf = ParticleFilter(model, 20, threshold=1.0, proposal=FullyAdaptedAuxiliary(LinearGaussianOptimal()))
        elif method == "rb_apf":
            pf = ParticleFilter(rb, 20, threshold=1.0, proposal=FullyAdaptedAuxiliary(RaoBlackwellProposal(True)))
        else:
            pf = ParticleFilter(rb, 20, threshold=1 / 3, proposal=RaoBlackwellProposal(False))
        ratios.append(np.exp(pf.run(sim.measurements, rng=seed).log_likelihood - exact))
    ratios = np.array(ratios)
    assert abs(ratios.mean() - 1.0) < 4 * ratios.std(ddof=1) / np.sqrt(len(ratios))
    assert ratios.std() > 0  # a real estimate, not the exact value


def test_error_against_kalman_falls_like_inverse_root_n():
    """Paired over 40 simulations, log(error) falls by 1/2 per unit of log N (N = 100 -> 1600).

    The slope estimate is the mean over runs of (log e_1600 - log e_100) / log 16; it must be
    within 3 standard errors of -1/2, and below -3/8 (SIR's impoverished rate is about -1/4).
    A simulation with no measurement has zero error at every N and is left out.
    """
    sc = short_scenario(20)
    model = sc.model()
    rb = RaoBlackwellModel(model)
    slopes = []
    for seed in range(40):
        sim = simulate(sc, rng=seed)
        kf = kalman_filter(model, sim.measurements)
        errors = []
        for n in (100, 1600):
            pf = ParticleFilter(rb, n, threshold=1 / 3, proposal=RaoBlackwellProposal(True))
            res = rb.marginal(pf.run(sim.measurements, rng=seed + 10**6))
            errors.append(np.sqrt(np.mean((res.mean[-1, 2:] - kf.mean[-1, 2:]) ** 2)))
        if min(errors) > 0:
            slopes.append(np.log(errors[1] / errors[0]) / np.log(16))
    slopes = np.array(slopes)
    se = slopes.std(ddof=1) / np.sqrt(len(slopes))
    assert abs(slopes.mean() + 0.5) < 3 * se
    assert slopes.mean() < -0.375
