"""The fully adapted auxiliary filter at any resampling threshold (issue 40, item 1).

The auxiliary filter is SIR on the extended target of the ancestor and the new state
(Pitt and Shephard 1999; Johansen and Doucet 2008): its first-stage weights are
``W_{k-1}^i p(z_k | x_{k-1}^i)``, and its likelihood increment ``sum_i W_{k-1}^i p(z_k | x_{k-1}^i)``.
At ``threshold=1`` the weights it receives are equal, and ``W_{k-1}`` can be dropped; at
``threshold=0.5`` a measurement at step 0 that leaves the ESS above ``N/2`` hands it unequal
weights, which it must read.  A filter that drops them loses ``z_0`` altogether.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

from pfcourse import ParticleFilter, kalman_filter
from pfcourse.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.proposals import FullyAdaptedAuxiliary, LinearGaussianOptimal

# x_0 ~ N(0, 1), x_k = x_{k-1} + N(0, Q), z_k = x_k + N(0, R): the step-0 weights have an ESS of
# about 0.73 N for z_0 = 1, above the threshold 0.5, so the engine does not resample them.
Q, R = 0.5, 1.0
MODEL = LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[Q]], R=[[R]])
Z = np.array([[1.0], [0.8], [0.6]])
N, RUNS = 200, 300


class DropsWeights(FullyAdaptedAuxiliary):
    """The filter before the fix: first-stage weights p(z_k | x_{k-1}^i) whatever W_{k-1} holds."""

    draws_ancestors = False


class Recorder:
    """A systematic resampler that keeps the first-stage weights it is given."""

    def __init__(self) -> None:
        self.weights: list[np.ndarray] = []

    def __call__(self, weights, rng):
        self.weights.append(np.array(weights))
        n = len(weights)
        cum = np.cumsum(weights)
        cum[-1] = 1.0
        return np.searchsorted(cum, (np.arange(n) + rng.random()) / n, side="right")


def general_apf_step(x, log_w, z):
    """An independent general APF step's first stage and increment on the scalar model, by hand.

    First stage ``log W^i + log N(z; x^i, Q + R)``, normalised; the likelihood increment
    ``log sum_i W^i N(z; x^i, Q + R)``.
    """
    log_lam = log_w + norm.logpdf(z, x, np.sqrt(Q + R))
    return np.exp(log_lam - logsumexp(log_lam)), logsumexp(log_lam)


def test_first_stage_reads_the_weights():
    """Unequal W_{k-1}: the first stage and the increment are those of the general APF, the new weights equal."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((50, 1))
    log_w = rng.normal(0.0, 1.0, 50)
    log_w -= logsumexp(log_w)
    recorder = Recorder()
    apf = FullyAdaptedAuxiliary(LinearGaussianOptimal(), resampler=recorder)
    new, log_inc = apf.propose(MODEL, x, np.array([0.7]), 1, np.random.default_rng(0), log_weights=log_w)
    lam, log_evidence = general_apf_step(x[:, 0], log_w, 0.7)
    np.testing.assert_allclose(recorder.weights[0], lam, rtol=1e-12)
    # the engine adds the increments to log W_{k-1}: the sum is log p^(z_k | z_{0:k-1}) - log N for every slot
    np.testing.assert_allclose(log_w + log_inc, log_evidence - np.log(50), rtol=0, atol=1e-12)
    assert new.shape == x.shape
    # with equal weights the weights are dropped, and the increment is log (1/N) sum_i p(z_k | x_{k-1}^i)
    equal = np.full(50, -np.log(50))
    _, log_inc_equal = apf.propose(MODEL, x, np.array([0.7]), 1, np.random.default_rng(0), log_weights=equal)
    np.testing.assert_allclose(recorder.weights[1], general_apf_step(x[:, 0], equal, 0.7)[0], rtol=1e-12)
    assert np.ptp(log_inc_equal) == 0


def test_equal_weights_give_the_same_floats_as_no_weights():
    """Threshold 1 hands equal weights: particles and increments are those of the weight-blind filter, bit for bit."""
    x = np.random.default_rng(4).standard_normal((30, 1))
    a = FullyAdaptedAuxiliary(LinearGaussianOptimal()).propose(MODEL, x, np.array([0.2]), 1, np.random.default_rng(1))
    b = FullyAdaptedAuxiliary(LinearGaussianOptimal()).propose(
        MODEL, x, np.array([0.2]), 1, np.random.default_rng(1), log_weights=np.full(30, -np.log(30)))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def test_zero_weights_carry_no_child():
    """Slots of weight zero get a zero increment weight; the live slots hold children, equally weighted."""
    rng = np.random.default_rng(5)
    x = rng.standard_normal((40, 1))
    log_w = np.where(np.arange(40) % 4 == 0, -np.inf, 0.0)
    log_w -= logsumexp(log_w)
    new, log_inc = FullyAdaptedAuxiliary(LinearGaussianOptimal()).propose(
        MODEL, x, np.array([0.5]), 1, np.random.default_rng(2), log_weights=log_w)
    live = np.isfinite(log_w)
    assert np.all(log_inc[~live] == -np.inf)
    _, log_evidence = general_apf_step(x[:, 0], log_w, 0.5)
    np.testing.assert_allclose(log_w[live] + log_inc[live], log_evidence - np.log(live.sum()), atol=1e-12)
    assert np.all(np.isfinite(new))


def _runs(proposal_class):
    """Filtered means at every step and log-likelihoods of RUNS seeded runs at threshold 0.5."""
    means, log_liks, resampled_at_0 = [], [], []
    for seed in range(RUNS):
        pf = ParticleFilter(MODEL, N, threshold=0.5, proposal=proposal_class(LinearGaussianOptimal()))
        result = pf.run(Z, rng=seed)
        means.append(result.mean[:, 0])
        log_liks.append(result.log_likelihood)
        resampled_at_0.append(result.resampled[0])
    return np.array(means), np.array(log_liks), np.array(resampled_at_0)


def _bias_scores(proposal_class):
    """Standardised bias of the last filtered mean and of the likelihood against Kalman (z-scores)."""
    kf = kalman_filter(MODEL, Z)
    means, log_liks, resampled_at_0 = _runs(proposal_class)
    assert not resampled_at_0.any()  # the step-0 weights reach the auxiliary filter unequal
    error = means[:, -1] - kf.mean[-1, 0]
    ratio = np.exp(log_liks - kf.log_likelihood)  # E[p^] = p: the estimate is unbiased
    return (error.mean() / (error.std(ddof=1) / np.sqrt(RUNS)),
            (ratio.mean() - 1.0) / (ratio.std(ddof=1) / np.sqrt(RUNS)))


def test_threshold_half_matches_kalman():
    """At threshold 0.5 the filtered mean (bias O(1/N)) and the unbiased likelihood agree with Kalman.

    Over 300 seeded runs each mean is within 4 standard errors of the exact value; the bias of
    the filtered mean, of order 1/N = 0.005, is far below a standard error of the run mean.
    """
    z_mean, z_lik = _bias_scores(FullyAdaptedAuxiliary)
    assert abs(z_mean) < 4 and abs(z_lik) < 4


def test_dropping_the_weights_is_detected():
    """The same check fails the weight-blind filter: it forgets z_0 (posterior mean 0.5 instead of 0)."""
    z_mean, z_lik = _bias_scores(DropsWeights)
    assert abs(z_mean) > 8 or abs(z_lik) > 8


@pytest.mark.parametrize("threshold", [1.0, 0.5])
def test_rao_blackwellised_robot_any_threshold(threshold):
    """The robot's auxiliary filter is unbiased in the likelihood at both thresholds (no step-0 reading)."""
    sc = quadrant_scenario().with_(n_samples=10)
    model = sc.model()
    sim = simulate(sc, rng=7)
    exact = kalman_filter(model, sim.measurements).log_likelihood
    rb = RaoBlackwellModel(model)
    ratios = np.array([
        np.exp(ParticleFilter(rb, 20, threshold=threshold, proposal=FullyAdaptedAuxiliary(RaoBlackwellProposal(True)))
               .run(sim.measurements, rng=seed).log_likelihood - exact)
        for seed in range(150)])
    assert abs(ratios.mean() - 1.0) < 4 * ratios.std(ddof=1) / np.sqrt(len(ratios))
