"""The fully adapted auxiliary filter at any resampling threshold (issue 40, item 1).

The auxiliary filter is SIR on the extended target of the ancestor and the new state
(Pitt and Shephard 1999; Johansen and Doucet 2008): its first-stage weights are
``W_{k-1}^i p(z_k | x_{k-1}^i)``, and its likelihood increment ``sum_i W_{k-1}^i p(z_k | x_{k-1}^i)``.
At ``threshold=1`` the weights it receives are equal, and ``W_{k-1}`` can be dropped; at
``threshold=0.5`` a measurement at step 0 that leaves the ESS above ``N/2`` hands it unequal
weights, which it must read.  A filter that drops them loses ``z_0`` altogether.  The checks rest
on the likelihood estimate, which is exactly unbiased at any ``N`` (the filtered mean has a bias
of order ``1/N``), and each is shown to fail the filter that drops the weights (``DropsWeights``).

In the engine the filter reports the ancestors it draws (``Step.parents``): the genealogy
(``Ancestors()``) and the ``resampled`` record follow them, and all ``N`` children are kept.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

from pfcourse import ParticleFilter, StateSpaceModel, kalman_filter
from pfcourse.collectors import Ancestors, Clouds
from pfcourse.errors import ModelError, ShapeError
from pfcourse.scenarios.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
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
    """Used alone (``propose``), slots of weight zero get a zero increment weight; the live slots hold
    children, equally weighted (in the engine all N children are kept: see below)."""
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


def _likelihood_score(proposal_class):
    """The z-score of the mean likelihood ratio p^ / p over RUNS seeded runs at threshold 0.5.

    ``E[p^] = p`` exactly, at any ``N`` (Del Moral 2004): the mean of the ratios is 1 up to its
    standard error (measured sd of a ratio about 0.06, standard error about 0.003).
    """
    kf = kalman_filter(MODEL, Z)
    ratios, resampled_at_0 = [], []
    for seed in range(RUNS):
        pf = ParticleFilter(MODEL, N, threshold=0.5, proposal=proposal_class(LinearGaussianOptimal()))
        first = next(pf.steps(Z, rng=seed))
        resampled_at_0.append(first.resampled)
        ratios.append(np.exp(pf.run(Z, rng=seed).log_likelihood - kf.log_likelihood))
    assert not any(resampled_at_0)  # the step-0 weights reach the auxiliary filter unequal
    ratios = np.array(ratios)
    return (ratios.mean() - 1.0) / (ratios.std(ddof=1) / np.sqrt(RUNS))


def test_threshold_half_gives_an_unbiased_likelihood():
    """At threshold 0.5 the mean likelihood ratio against Kalman is 1 within 4 standard errors."""
    assert abs(_likelihood_score(FullyAdaptedAuxiliary)) < 4


def test_dropping_the_weights_is_detected():
    """The same check fails the weight-blind filter: it forgets z_0 (measured: ratio 0.79, 60 standard errors)."""
    assert abs(_likelihood_score(DropsWeights)) > 8


class FastSLAM2ThenAuxiliary:
    """FastSLAM 2.0 at the first reading, the auxiliary filter ``auxiliary`` afterwards.

    The robot's filter has no reading at step 0 and the auxiliary filter always leaves equal
    weights: FastSLAM 2.0's weights ``p(z_k | r_{k-1}^i)`` at the first reading are what makes
    ``W_{k-1}`` unequal before an auxiliary step (when the threshold does not resample them).
    """

    draws_ancestors = True

    def __init__(self, auxiliary, first: int) -> None:
        self.auxiliary, self.first, self.optimal = auxiliary, first, RaoBlackwellProposal(True)

    def propose(self, model, particles, z, k, rng):
        return self.propose_with_ancestors(model, particles, z, k, rng)[:2]

    def propose_with_ancestors(self, model, particles, z, k, rng, log_weights=None):
        if k == self.first:
            return (*self.optimal.propose(model, particles, z, k, rng), None)
        if self.auxiliary.draws_ancestors:
            return self.auxiliary.propose_with_ancestors(model, particles, z, k, rng, log_weights=log_weights)
        return (*self.auxiliary.propose(model, particles, z, k, rng), None)


def _robot_likelihood_score(threshold, auxiliary_class, runs=200, n=20):
    """The z-score of the mean likelihood ratio of the robot's filter (FastSLAM 2.0, then auxiliary)."""
    sc = quadrant_scenario().with_(n_samples=10)
    model = sc.model()
    sim = simulate(sc, rng=7)
    first = int(np.argmax(sim.seen.any(axis=1)))
    exact = kalman_filter(model, sim.measurements).log_likelihood
    rb = RaoBlackwellModel(model)

    def build():
        proposal = FastSLAM2ThenAuxiliary(auxiliary_class(RaoBlackwellProposal(True)), first)
        return ParticleFilter(rb, n, threshold=threshold, proposal=proposal)

    step = list(build().steps(sim.measurements, rng=0))[first]
    assert np.ptp(step.weights) > 0 and step.resampled == (step.ess < threshold * n)
    ratios = np.array([np.exp(build().run(sim.measurements, rng=seed).log_likelihood - exact)
                       for seed in range(runs)])
    return (ratios.mean() - 1.0) / (ratios.std(ddof=1) / np.sqrt(runs)), step.resampled


@pytest.mark.parametrize("threshold", [1.0, 0.5])
def test_rao_blackwellised_robot_any_threshold(threshold):
    """The robot's auxiliary filter is unbiased in the likelihood at both thresholds (4 standard errors);
    at 0.5 the weights FastSLAM 2.0 leaves (ESS 17.6 of 20) reach it unequal."""
    score, resampled = _robot_likelihood_score(threshold, FullyAdaptedAuxiliary)
    assert resampled == (threshold == 1.0)
    assert abs(score) < 4


def test_robot_dropping_the_weights_is_detected():
    """At threshold 0.5 the weight-blind robot filter fails the same check (measured: 7.9 standard errors)."""
    score, resampled = _robot_likelihood_score(0.5, DropsWeights)
    assert not resampled and abs(score) > 4


class IdentityMove:
    """An inner proposal whose move keeps the parent: a child equals its ancestor, so the genealogy can be read."""

    def log_predictive(self, model, particles, z, k):
        return norm.logpdf(z[0], particles[:, 0], 1.0)

    def propose(self, model, particles, z, k, rng):
        return particles.copy(), np.zeros(len(particles))


WALK = StateSpaceModel(
    dim_x=1,
    sample_initial=lambda n, rng: rng.normal(0.0, 1.0, (n, 1)),
    sample_transition=lambda x, k, rng: x + rng.normal(0.0, 0.5, x.shape),
    log_likelihood=lambda x, z, k: norm.logpdf(z[0], x[:, 0], 1.0),
)
Z_GAP = [np.array([1.0]), np.array([0.5]), None, np.array([0.2]), np.array([-0.3])]


@pytest.mark.parametrize("threshold", [1.0, 0.5])
def test_the_genealogy_follows_the_first_stage(threshold):
    """Ancestors() and resampled record the auxiliary filter's first stage: child i equals its ancestor."""
    pf = ParticleFilter(WALK, 50, threshold=threshold, proposal=FullyAdaptedAuxiliary(IdentityMove()))
    run = pf.run(Z_GAP, rng=4, collect=[Ancestors(), Clouds()])
    lines, clouds = run.collected["ancestors"], run.particles
    # at threshold 1 step 0 resamples itself (ESS below N), so the first stage composes with that resampling
    assert next(pf.steps(Z_GAP, rng=4)).resampled == (threshold == 1.0)
    for k in (1, 3, 4):  # the auxiliary steps
        np.testing.assert_array_equal(clouds[k], clouds[k - 1][lines[k]])
        assert not np.array_equal(lines[k], np.arange(50))
        assert run.resampled[k - 1]
    # the step without a reading moves through the transition, with no resampling
    np.testing.assert_array_equal(lines[2], np.arange(50))
    assert not run.resampled[1]


def test_a_variable_n_composes_the_first_stage_with_its_batches():
    """With a sample_size policy each batch's ancestors are composed with the first stage's: child i
    equals particle ancestors[i] of the step before."""
    from pfcourse.sample_size import KLDSampling

    pf = ParticleFilter(WALK, 300, proposal=FullyAdaptedAuxiliary(IdentityMove()),
                        sample_size=KLDSampling([0.2], n_min=50, batch=50))
    steps = list(pf.steps(Z_GAP, rng=1))
    for k in (1, 3, 4):
        np.testing.assert_array_equal(steps[k].particles, steps[k - 1].particles[steps[k].ancestors])


def test_every_child_is_kept_when_some_weights_are_zero():
    """A zero weight at step 0 (never resampled, threshold 0): the auxiliary step keeps all N children,
    each from a live parent, with equal weights (the filter before the fix kept only the M live slots)."""
    model = StateSpaceModel(
        dim_x=1,
        sample_initial=lambda n, rng: rng.normal(0.0, 1.0, (n, 1)),
        sample_transition=WALK.sample_transition,
        log_likelihood=lambda x, z, k: np.where(x[:, 0] > 0.5, -np.inf, norm.logpdf(z[0], x[:, 0], 1.0)),
    )
    pf = ParticleFilter(model, 40, threshold=0.0, proposal=FullyAdaptedAuxiliary(IdentityMove()))
    run = pf.run([np.array([0.0]), np.array([0.3])], rng=6, collect=[Ancestors(), Clouds()])
    live = np.flatnonzero(run.weights[0] > 0)
    assert 0 < len(live) < 40
    assert np.isin(run.collected["ancestors"][1], live).all()
    np.testing.assert_allclose(run.weights[1], 1 / 40, rtol=1e-12)
    assert run.ess[1] == pytest.approx(40, rel=1e-12)


def test_a_proposal_that_draws_ancestors_is_checked():
    """Without propose_with_ancestors it is refused when the filter is built; bad ancestors at the step."""

    class NoHook:
        draws_ancestors = True

        def propose(self, model, particles, z, k, rng):
            return particles, np.zeros(len(particles))

    with pytest.raises(ModelError, match="propose_with_ancestors"):
        ParticleFilter(WALK, 10, proposal=NoHook())

    class BadAncestors(NoHook):
        def propose_with_ancestors(self, model, particles, z, k, rng, log_weights=None):
            return particles, np.zeros(len(particles)), np.arange(len(particles)) + 1

    with pytest.raises(ShapeError, match="step 1"):
        ParticleFilter(WALK, 10, proposal=BadAncestors()).run(Z_GAP, rng=0)
