"""Particle MCMC: conditional SMC with ancestor sampling, correlated likelihood estimates, R-hat and ESS.

Each piece against an exact property: PG-AS leaves the exact smoothing distribution of a two-step
model with two states invariant (enumerated); the correlation of the correlated estimator at one
step equals the closed form of rho; the Hilbert order visits neighbouring cells; R-hat and ESS of
AR(1) chains match their theory; the stored chains start as the short chains the registry re-computes.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import signal, stats
from scipy.special import logsumexp

from pfcourse import StateSpaceModel
from pfcourse.correlated import (NormalStream, correlated_log_likelihood, crank_nicolson, hilbert_keys,
                                 hilbert_order, normals_needed)
from pfcourse.csmc import AncestorSamplingProposal, conditional_smc, noise_scale_draw
from pfcourse.diagnostics import chain_ess, split_rhat
from pfcourse.errors import ParameterError, ShapeError
from pfcourse.pmmh import correlated_pmmh, integrated_autocorrelation_time

# ---------------------------------------------------------------- a two-state, two-step model
P1, STAY, SD, Z2 = 0.3, 0.85, 0.7, np.array([[1.0], [0.0]])


def _two_state_model():
    def sample_initial(n, rng):
        return (rng.random((n, 1)) < P1).astype(float)

    def sample_transition(x, k, rng):
        flip = rng.random(x.shape) >= STAY
        return np.where(flip, 1.0 - x, x)

    def transition_log_density(new, old, k):
        return np.where(new[:, 0] == old[:, 0], np.log(STAY), np.log(1 - STAY))

    def log_likelihood(x, z, k):
        return stats.norm.logpdf(z[0], x[:, 0], SD)

    return StateSpaceModel(1, sample_initial, sample_transition, log_likelihood, transition_log_density)


def _exact_posterior():
    """p(x_0, x_1 | z_0, z_1) over the four paths, enumerated."""
    paths = list(itertools.product((0.0, 1.0), repeat=2))
    p = np.array([(P1 if a else 1 - P1) * (STAY if a == b else 1 - STAY)
                  * stats.norm.pdf(Z2[0, 0], a, SD) * stats.norm.pdf(Z2[1, 0], b, SD) for a, b in paths])
    return paths, p / p.sum()


def _kernel_output(n_draws, proposal_class=AncestorSamplingProposal, n_particles=2, seed=0, ancestor_sampling=True):
    """Start each sweep from a path drawn from the exact posterior; count the paths CSMC(-AS) returns."""
    import pfcourse.csmc as csmc

    paths, post = _exact_posterior()
    model, rng = _two_state_model(), np.random.default_rng(seed)
    counts = np.zeros(len(paths))
    original = csmc.AncestorSamplingProposal
    csmc.AncestorSamplingProposal = proposal_class
    try:
        for start in rng.choice(len(paths), n_draws, p=post):
            ref = np.array(paths[start])[:, None]
            new = conditional_smc(model, Z2, n_particles, ref, rng, ancestor_sampling).path[:, 0]
            counts[paths.index(tuple(new))] += 1
    finally:
        csmc.AncestorSamplingProposal = original
    return counts, post


def test_pgas_leaves_the_exact_posterior_invariant():
    # If x* ~ p(x | z), one CSMC-AS sweep returns x' ~ p(x | z): a chi-square test of the counts
    counts, post = _kernel_output(4000)
    assert stats.chisquare(counts, counts.sum() * post).pvalue > 1e-3


def test_plain_csmc_leaves_the_exact_posterior_invariant():
    # the same enumerated test for conditional SMC without ancestor sampling (the stored no-AS chains)
    counts, post = _kernel_output(4000, ancestor_sampling=False, seed=1)
    assert stats.chisquare(counts, counts.sum() * post).pvalue > 1e-3


class _ReferenceDroppedAtResampling(AncestorSamplingProposal):
    """A typical mistake of plain CSMC: the reference's ancestor drawn like the others' (not kept at 0)."""

    def propose_with_ancestors(self, model, particles, z, k, rng, log_weights=None):
        n = len(particles)
        log_weights = np.full(n, -np.log(n)) if log_weights is None else np.asarray(log_weights, dtype=float)
        ancestors = rng.choice(n, n, p=np.exp(log_weights - logsumexp(log_weights)))
        new = model.sample_transition(particles[ancestors], k, rng)
        return new, model.log_likelihood(new, z, k), ancestors


def test_the_plain_csmc_test_detects_a_reference_that_loses_its_past():
    counts, post = _kernel_output(4000, _ReferenceDroppedAtResampling, ancestor_sampling=False, seed=1)
    assert stats.chisquare(counts, counts.sum() * post).pvalue < 1e-6


class _AncestorsByWeightOnly(AncestorSamplingProposal):
    """A typical mistake: the reference's ancestor drawn by the weights alone, without p(x*_k | x_(k-1)^j)."""

    def ancestor_log_weights(self, model, particles, log_weights, k):
        return np.asarray(log_weights, dtype=float)


def test_the_invariance_test_detects_ancestor_weights_without_the_transition():
    counts, post = _kernel_output(4000, _AncestorsByWeightOnly)
    assert stats.chisquare(counts, counts.sum() * post).pvalue < 1e-6


def test_csmc_keeps_the_reference_and_refuses_bad_input():
    model = _two_state_model()
    ref = np.array([[1.0], [0.0]])
    # without ancestor sampling and with one other particle the reference survives when drawn
    assert conditional_smc(model, Z2, 2, ref, 1).path.shape == (2, 1)
    with pytest.raises(ShapeError):
        conditional_smc(model, Z2, 2, np.zeros((3, 1)), 1)
    with pytest.raises(ParameterError):
        conditional_smc(model, Z2, 1, ref, 1)


def test_noise_scale_draw_follows_its_inverse_gamma():
    rng = np.random.default_rng(3)
    H, R0 = np.eye(2), np.eye(2)
    path = np.zeros((30, 2))
    Z = rng.normal(0.0, np.sqrt(0.8), (30, 2))
    draws = np.array([noise_scale_draw(H, R0, Z, path, (0.1, 10.0), rng) for _ in range(2000)])
    law = stats.invgamma(30.0, scale=float((Z**2).sum()) / 2)  # m = 60 coordinates
    assert stats.kstest(draws, law.cdf).pvalue > 1e-3


# ---------------------------------------------------------------- correlated random numbers
def _exact_one_step_correlation(rho, z=0.5, r=1.0):
    """corr(g(U), g(U')) for g(x) = N(z; x, r), (U, U') standard normals of correlation rho."""
    a = 1.0 / (2.0 * r)

    def moment(c):  # E[exp(-a (U - z)^2 - a (U' - z)^2)], corr(U, U') = c
        S, A, m = np.array([[1.0, c], [c, 1.0]]), 2 * a * np.eye(2), np.full(2, z)
        return np.linalg.det(np.eye(2) + A @ S) ** -0.5 * np.exp(-0.5 * m @ np.linalg.solve(np.linalg.inv(A) + S, m))

    mean = (1 + 2 * a) ** -0.5 * np.exp(-a * z**2 / (1 + 2 * a))
    return (moment(rho) - mean**2) / (moment(1.0) - mean**2)


def _scalar_model(q=1.0):
    return StateSpaceModel(1, lambda n, rng: rng.standard_normal((n, 1)),
                           lambda x, k, rng: x + q * rng.standard_normal(x.shape),
                           lambda x, z, k: stats.norm.logpdf(z[0], x[:, 0], 1.0))


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.9, 0.99])
def test_one_step_correlation_equals_its_closed_form(rho):
    # one measured step: p^ = mean_i g(U_i), so corr(p^(U), p^(U')) = corr(g(U), g(U')) for every N
    model, n, pairs = _scalar_model(), 5, 800
    rng = np.random.default_rng(int(rho * 100))
    a, b = np.empty(pairs), np.empty(pairs)
    for i in range(pairs):
        u = rng.standard_normal(normals_needed(1, n, 1))
        v = crank_nicolson(u, rho, rng)
        a[i] = np.exp(correlated_log_likelihood(model, [[0.5]], n, u))
        b[i] = np.exp(correlated_log_likelihood(model, [[0.5]], n, v))
    exact = _exact_one_step_correlation(rho)
    # Fisher's z: sd 1 / sqrt(pairs - 3); 4 sd
    assert abs(np.arctanh(np.corrcoef(a, b)[0, 1]) - np.arctanh(min(exact, 0.9999))) < 4 / np.sqrt(pairs - 3)


def test_sorting_keeps_the_estimates_together_over_many_steps():
    # 1-D, 20 steps: with sorted resampling the log-likelihoods at rho = 0.99 stay correlated; unsorted
    # they lose much of it (one ancestor that jumps sends a particle down another path)
    model, n, k, reps = _scalar_model(0.5), 50, 20, 80
    Z = np.random.default_rng(0).normal(size=(k, 1))
    rng = np.random.default_rng(1)
    out = {True: [], False: []}
    for _ in range(reps):
        u = rng.standard_normal(normals_needed(1, n, k))
        v = crank_nicolson(u, 0.99, rng)
        for sort in (True, False):
            out[sort].append((correlated_log_likelihood(model, Z, n, u, sort), correlated_log_likelihood(model, Z, n, v, sort)))
    corr = {s: np.corrcoef(np.array(o).T)[0, 1] for s, o in out.items()}
    assert corr[True] > 0.9 and corr[True] > corr[False] + 0.1


def test_normal_stream_reads_in_order_and_refuses_other_draws():
    s = NormalStream(np.arange(6.0) / 10)
    assert np.array_equal(s.standard_normal((2, 2)), np.arange(4.0).reshape(2, 2) / 10)
    assert s.random() == pytest.approx(stats.norm.cdf(0.4))
    with pytest.raises(ParameterError, match="more than"):
        s.standard_normal(2)
    with pytest.raises(ParameterError, match="serves"):
        NormalStream(np.zeros(3)).integers(0, 5)


def test_crank_nicolson_keeps_the_standard_normal():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(200_000)
    v = crank_nicolson(u, 0.9, rng)
    assert abs(v.var() - 1) < 0.02 and abs(np.corrcoef(u, v)[0, 1] - 0.9) < 0.005
    with pytest.raises(ParameterError):
        crank_nicolson(u, 1.5, rng)


@pytest.mark.parametrize("d, bits", [(2, 4), (3, 3), (6, 2)])
def test_hilbert_order_visits_neighbouring_cells(d, bits):
    cells = np.array(np.meshgrid(*[np.arange(2**bits)] * d, indexing="ij")).reshape(d, -1).T
    keys = hilbert_keys(cells, bits)
    steps = np.abs(np.diff(cells[np.argsort(keys)], axis=0)).sum(axis=1)
    assert len(np.unique(keys)) == len(keys) and np.all(steps == 1)
    x = np.random.default_rng(0).normal(size=(50, 1))
    assert np.array_equal(hilbert_order(x), np.argsort(x[:, 0]))


def test_correlated_pmmh_with_rho_one_and_a_deterministic_estimate_is_a_plain_mh_chain():
    # an estimate that ignores the normals is the exact likelihood: the chain targets the prior x likelihood
    prior = stats.uniform(-3, 6)
    chain = correlated_pmmh(lambda t, u: stats.norm.logpdf(np.log(t), 0.0, 0.5), prior, 1.0, 3, 20_000, 0.8, 1.0, 0)
    u = np.log(chain.theta[1000:])
    assert abs(u.mean()) < 0.05 and abs(u.std() - 0.5) < 0.03


# ---------------------------------------------------------------- R-hat and ESS
def _ar1(phi, m, n, seed=0):
    e = np.random.default_rng(seed).standard_normal((m, n))
    x = signal.lfilter([1.0], [1.0, -phi], e, axis=1)
    return x[:, 200:] * np.sqrt(1 - phi**2)  # stationary, unit variance


def test_chain_ess_of_ar1_chains_matches_theory():
    phi = 0.8
    x = _ar1(phi, 4, 20_200)
    theory = x.size * (1 - phi) / (1 + phi)
    assert abs(chain_ess(x) / theory - 1) < 0.15
    one = x[:1]
    assert abs(chain_ess(one) / (one.size / integrated_autocorrelation_time(one[0])) - 1) < 0.15


def test_split_rhat_is_one_for_mixed_chains_and_large_for_separated_ones():
    x = _ar1(0.8, 4, 5200)
    assert abs(split_rhat(x) - 1) < 0.01
    shifted = x + np.array([[0.0], [0.0], [0.0], [1.0]])
    assert split_rhat(shifted) > 1.05
    assert chain_ess(shifted) < 0.5 * chain_ess(x)
    drifting = x + np.linspace(0, 2, x.shape[1])  # every chain moves: the split halves disagree
    assert split_rhat(drifting) > 1.05
    with pytest.raises(ShapeError):
        split_rhat(np.ones((2, 10)))


# ---------------------------------------------------------------- stored chains
@pytest.mark.parametrize("name", ["pmcmc/tuning", "pmcmc/correlated", "pmcmc/pgas"])
def test_stored_chains_start_as_their_short_check_chains(name):
    from pfcourse.studies.pmcmc_studies import CHECK_ITERATIONS
    from pfcourse.studies.registry import STUDIES

    study, check = STUDIES[name], STUDIES[name + "_check"]
    long, short = study.load(), check.load()
    key = [k for k in check.grid if k != "iterations"][0]
    assert len(short) == check.n_runs and (short["iterations"] == CHECK_ITERATIONS).all()
    assert len(long) == study.n_runs * len(study.grid[key])
    for _, row in short.iterrows():
        match = long[(long["seed"] == row["seed"]) & (long[key] == row[key])]
        assert len(match) == 1
        assert np.array_equal(match.iloc[0]["theta"][:CHECK_ITERATIONS], row["theta"])
