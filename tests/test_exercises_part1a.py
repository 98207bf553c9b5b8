"""The checkers of the opening of Part I (SIS and SIR) check the generator, and name each mistake.

Issue 39: a function that draws random numbers is checked to draw them from the generator it is
given (same seed, same answer; another seed, another answer; NumPy's global state untouched), and
the multinomial resampler of the SIR chapter is told apart from the systematic and stratified ones.
Each typical mistake gets its own sentence, tested here with the sentence it must contain.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises import check_multinomial_resampler, check_sis
from pfcourse.resampling import multinomial, residual, stratified, systematic
from test_exercises import sis


def inverse_cdf(w, rng):
    """The reference answer of the SIR chapter's exercise."""
    cumulative = np.cumsum(w)
    cumulative[-1] = 1.0
    return np.searchsorted(cumulative, rng.random(len(w)), side="right")


def global_numpy(w, rng):
    return np.searchsorted(np.cumsum(w), np.random.random(len(w)), side="right")


def own_generator(w, rng):
    return np.searchsorted(np.cumsum(w), np.random.default_rng().random(len(w)), side="right")


def fixed_generator(w, rng):
    return np.searchsorted(np.cumsum(w), np.random.default_rng(0).random(len(w)), side="right")


def shared_uniform(w, rng):
    return np.searchsorted(np.cumsum(w), np.full(len(w), rng.random()), side="right")


def uniform_indices(w, rng):
    return rng.integers(0, len(w), len(w))


def off_by_one(w, rng):
    return np.searchsorted(np.cumsum(w), rng.random(len(w)), side="right") + 1


def float_indices(w, rng):
    return inverse_cdf(w, rng).astype(float)


def left_side_biased(w, rng):
    """Picks the particle before the right one: biased, and it chooses the zero-weight particle."""
    return np.maximum(np.searchsorted(np.cumsum(w), rng.random(len(w)), side="right") - 1, 0)


@pytest.mark.parametrize("seed", range(3))
def test_the_reference_and_the_package_multinomial_pass(seed):
    assert check_multinomial_resampler(inverse_cdf, seed=seed).ok
    assert check_multinomial_resampler(multinomial, seed=seed, n_draws=2000).ok
    # rng.choice inverts the cumulative weights with N uniforms: the text allows it, the checker passes it
    assert check_multinomial_resampler(lambda w, rng: rng.choice(len(w), len(w), p=w), seed=seed, n_draws=2000).ok


@pytest.mark.parametrize("mistake, says", [
    (global_numpy, "NumPy's global generator"),
    (own_generator, "same seed gave different"),
    (fixed_generator, "whatever the generator's seed"),
    (systematic, "stratified or systematic"),
    (stratified, "stratified or systematic"),
    (residual, "this is residual resampling"),
    (shared_uniform, "one uniform shared"),
    (uniform_indices, "weight 0 was chosen"),
    (left_side_biased, "weight 0 was chosen"),
    (off_by_one, "out of range"),
    (float_indices, "must be integers"),
    (lambda w, rng: None, "returned None"),
    (lambda w, rng: inverse_cdf(w, rng)[:-1], "one ancestor index per particle"),
])
def test_each_typical_resampler_mistake_gets_its_own_sentence(mistake, says):
    report = check_multinomial_resampler(mistake, n_draws=2000)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_a_biased_resampler_is_named_biased():
    def heavy_first(w, rng):  # moves 10 % of the mass of every particle onto the first
        v = 0.9 * w
        v[0] += 0.1
        return inverse_cdf(v, rng)

    report = check_multinomial_resampler(heavy_first, n_draws=2000)
    assert not report.ok and "biased" in report.problems[0], str(report)


def test_the_checkers_leave_numpys_global_state_as_they_found_it():
    np.random.seed(123)
    expected = np.random.random()
    np.random.seed(123)
    check_multinomial_resampler(global_numpy, n_draws=200)
    check_sis(lambda z, n, rng, model: sis(z, n, np.random.default_rng(np.random.randint(1 << 30)), model))
    assert np.random.random() == expected


def sis_from(generator):
    """The reference SIS of tests/test_exercises.py, fed another generator than the one it is given."""
    return lambda z, n, rng, model: sis(z, n, generator(rng), model)


class GlobalNumpy:
    """A generator-like object whose draws come from NumPy's global state (np.random)."""

    def standard_normal(self, size=None):
        return np.random.standard_normal(size)


@pytest.mark.parametrize("feed, says", [
    (lambda rng: GlobalNumpy(), "NumPy's global generator"),
    (lambda rng: np.random.default_rng(), "same seed gave different"),
    (lambda rng: np.random.default_rng(7), "whatever the generator's seed"),
    (lambda rng: rng, None),
])
def test_the_sis_checker_checks_the_generator(feed, says):
    report = check_sis(sis_from(feed))
    if says is None:
        assert report.ok, str(report)
    else:
        assert not report.ok and len(report.problems) == 1, str(report)
        assert says in report.problems[0], report.problems[0]


# The importance-sampling exercise: the reference answer and its typical mistakes, each a flag that
# changes one line, as a student would write them.
def toy_sampler(z, sd_v, n, rng, *, mistake=None, draw=None):
    from scipy import stats
    from scipy.special import logsumexp

    x = z / 2 + (draw(rng) if draw else rng).standard_normal(n)
    scale = sd_v**2 if mistake == "sd_as_variance" else sd_v
    log_lik = stats.norm.logpdf(z, loc=x, scale=scale)
    log_prior, log_q = stats.norm.logpdf(x), stats.norm.logpdf(x, z / 2, 1.0)
    log_w = {"likelihood_only": log_lik, "no_proposal": log_lik + log_prior,
             "no_prior": log_lik - log_q}.get(mistake, log_lik + log_prior - log_q)
    W = np.exp(log_w - logsumexp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


@pytest.mark.parametrize("seed", range(4))
def test_the_reference_importance_sampler_passes(seed):
    from pfcourse.book.exercises import check_importance_sampler

    assert check_importance_sampler(toy_sampler, seed=seed).ok


@pytest.mark.parametrize("mistake, draw, says", [
    ("likelihood_only", None, "the likelihood alone"),
    ("no_proposal", None, "leaves out - log q(x)"),
    ("no_prior", None, "leaves out the prior"),
    ("sd_as_variance", None, "sd_v^2 as its standard deviation"),
    (None, lambda rng: np.random.default_rng(), "same seed gave different"),
    (None, lambda rng: np.random.default_rng(5), "whatever the generator's seed"),
    (None, lambda rng: GlobalNumpy(), "NumPy's global generator"),
])
def test_each_typical_importance_sampling_mistake_gets_its_own_sentence(mistake, draw, says):
    from pfcourse.book.exercises import check_importance_sampler

    report = check_importance_sampler(lambda z, s, n, rng: toy_sampler(z, s, n, rng, mistake=mistake, draw=draw))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_the_importance_sampler_checker_names_a_missing_answer_and_a_bad_ess():
    from pfcourse.book.exercises import check_importance_sampler

    assert "returned None" in check_importance_sampler(lambda z, s, n, rng: None).problems[0]
    assert "outside [1, n]" in check_importance_sampler(
        lambda z, s, n, rng: (toy_sampler(z, s, n, rng)[0], 2.0 * n)).problems[0]


def test_the_limits_of_the_mistakes_are_apart_from_the_exact_mean():
    """Each mistake's limit is at least 0.1 from the exact mean and from the others (the checker's six
    standard errors are about 0.03 at n = 20 000), so it can name it."""
    from pfcourse.book.exercises import IS_TOY_CASE, IS_TOY_MISTAKES, toy_is_limit

    means = [toy_is_limit(*IS_TOY_CASE)[0]] + [toy_is_limit(*IS_TOY_CASE, m)[0] for m in IS_TOY_MISTAKES]
    gaps = np.abs(np.subtract.outer(means, means))[np.triu_indices(len(means), 1)]
    assert gaps.min() > 0.1
    assert toy_is_limit(*IS_TOY_CASE)[0] == pytest.approx(IS_TOY_CASE[0] / (1 + IS_TOY_CASE[1] ** 2))


# Samplers that estimate the right mean from the wrong proposal, or return a wrong ESS (review fixp1a,
# item 3): the checker compares ESS / n with its closed-form limit 1 / E_q[w^2] and takes its
# tolerance from the exact asymptotic variance, not from the student's ESS.
def gaussian_proposal_sampler(z, sd_v, n, rng, q_mean, q_sd):
    from scipy import stats
    from scipy.special import logsumexp

    x = q_mean + q_sd * rng.standard_normal(n)
    log_w = stats.norm.logpdf(z, x, sd_v) + stats.norm.logpdf(x) - stats.norm.logpdf(x, q_mean, q_sd)
    W = np.exp(log_w - logsumexp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


def exact_posterior_sampler(z, sd_v, n, rng):
    x = z / (1 + sd_v**2) + np.sqrt(sd_v**2 / (1 + sd_v**2)) * rng.standard_normal(n)
    return x.mean(), float(n)


@pytest.mark.parametrize("sampler, says", [
    (lambda z, s, n, rng: gaussian_proposal_sampler(z, s, n, rng, 0.0, 1.0), "draws from the prior N(0, 1)"),
    (exact_posterior_sampler, "every weight is the same"),
    (lambda z, s, n, rng: gaussian_proposal_sampler(z, s, n, rng, z / 2, 3.0), "the estimate is right but"),
    (lambda z, s, n, rng: (toy_sampler(z, s, n, rng)[0], n / 2), "the estimate is right but"),
    (lambda z, s, n, rng: (toy_sampler(z, s, n, rng, mistake="no_prior")[0], 1.0), "leaves out the prior"),
])
def test_the_importance_sampler_checker_checks_the_proposal_and_the_ess(sampler, says):
    from pfcourse.book.exercises import check_importance_sampler

    report = check_importance_sampler(sampler)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_the_toy_ess_ratio_and_kong_ratio_are_the_closed_forms():
    """1 / E_q[w^2] = 0.383 for q = N(z/2, 1), and sigma^2 / (Var_pi E_q[w^2]) = 0.61, against quadrature."""
    from scipy import integrate, stats

    from pfcourse.book.exercises import IS_TOY_CASE, toy_is_ess_ratio, toy_is_limit
    from pfcourse.book.exercises.part1 import _gauss_chi2

    z, sd_v = IS_TOY_CASE
    m, v = toy_is_limit(z, sd_v)
    ratio = lambda x: stats.norm.pdf(x, m, np.sqrt(v)) ** 2 / stats.norm.pdf(x, z / 2, 1.0)  # noqa: E731
    e_w2 = integrate.quad(ratio, -10, 15)[0]
    sigma2 = integrate.quad(lambda x: ratio(x) * (x - m) ** 2, -10, 15)[0]
    assert toy_is_ess_ratio(z, sd_v) == pytest.approx(1 / e_w2, rel=1e-8)
    assert _gauss_chi2(m, v, z / 2, 1.0)[1] == pytest.approx(sigma2, rel=1e-8)
    assert toy_is_ess_ratio(z, sd_v) == pytest.approx(0.383, abs=5e-4)
    assert sigma2 / (v * e_w2) == pytest.approx(0.61, abs=5e-3)


# SIS answers whose ESS is wrong (review fixp1a, item 4): the checker compares the ESS with its
# closed form N / E[W_k^2] and takes the tolerance of the means from it, not from the student's ESS.
def sis_variant(z, n, rng, model, *, weigh=True, forget=False, resample=False, ess_one=False):
    from scipy.special import logsumexp

    x = model.m0 + np.sqrt(model.p0) * rng.standard_normal(n)
    log_w = np.full(n, -np.log(n))
    means, ess = [], []
    for k, zk in enumerate(z):
        if k > 0:
            x = model.a * x + np.sqrt(model.q) * rng.standard_normal(n)
        if weigh and not np.isnan(zk):
            if resample:
                x = x[rng.choice(n, n, p=np.exp(log_w))]
                log_w = np.full(n, -np.log(n))
            log_lik = -0.5 * (zk - x) ** 2 / model.r
            log_w = log_lik if forget else log_w + log_lik
            log_w = log_w - logsumexp(log_w)
        W = np.exp(log_w)
        means.append(W @ x)
        ess.append(1.0 if ess_one and k > 0 else 1.0 / np.sum(W**2))
    return np.array(means), np.array(ess)


@pytest.mark.parametrize("flags, says", [
    ({"weigh": False, "ess_one": True}, "never weighted"),
    ({"forget": True, "ess_one": True}, "forget the previous steps"),
    ({"resample": True}, "resamples at every step"),
    ({"ess_one": True}, "the means are right but the ESS"),
])
def test_the_sis_checker_compares_the_ess_with_its_closed_form(flags, says):
    report = check_sis(lambda z, n, rng, model: sis_variant(z, n, rng, model, **flags))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_the_closed_form_sis_ess_matches_the_reference_filter():
    """N / E[W_k^2] against the mean ESS of 40 seeded runs of the reference SIS (sd of ESS/N about 0.003)."""
    from pfcourse.book.exercises import SIS_CASE
    from pfcourse.book.exercises.part1 import ScalarModel, _sis_ess_ratio

    runs = np.array([sis(SIS_CASE, 20_000, np.random.default_rng(s), ScalarModel())[1] for s in range(40)])
    assert np.allclose(runs.mean(0) / 20_000, _sis_ess_ratio(SIS_CASE, ScalarModel()), atol=0.003)


# The genealogy checker (review fixp1a, item 14): the indexing turned round and the first step left out
# get their own sentences.
def origins_variant(ancestors, mistake=None):
    a = np.arange(ancestors.shape[1])
    stop = 1 if mistake == "skip_first" else 0
    for k in range(len(ancestors) - 1, stop, -1):
        a = a[ancestors[k]] if mistake == "turned_round" else ancestors[k][a]
    return a


@pytest.mark.parametrize("mistake, says", [
    (None, None),
    ("turned_round", "a[ancestors[k]] instead of ancestors[k][a]"),
    ("skip_first", "the first step is left out"),
])
def test_the_genealogy_checker_names_the_indexing_and_the_first_step(mistake, says):
    from pfcourse.book.exercises import check_ancestors

    for seed in range(5):
        report = check_ancestors(lambda a: origins_variant(a, mistake), seed=seed)
        if says is None:
            assert report.ok, str(report)
        else:
            assert not report.ok and len(report.problems) == 1, str(report)
            assert says in report.problems[0], report.problems[0]
