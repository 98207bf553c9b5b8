"""The chapter "Why it works": its exercise checker, its stored studies' row functions and the exact
asymptotic variance of the CLT (the chapter's own cell checks its generic algorithm against the engine)."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises import FK_MISTAKES, check_guided_fk, fk_exact_log_likelihood, fk_guided_exact, fk_simulate
from pfcourse.book.exercises.why_it_works import FK_MODEL, fk_run


def _with_move(move):
    """A reader's pair whose M at k >= 1 is ``move(Z, k, x_prev, rng)``, G the reference."""
    def make(Z):
        M, G = fk_guided_exact(Z)
        return (lambda k, x_prev, N, rng: M(0, None, N, rng) if k == 0 else move(Z, k, x_prev, rng)), G
    return make


def test_reference_answer_passes_and_quotes_the_mean_ratio():
    report = check_guided_fk(fk_guided_exact)
    assert report.ok, str(report)
    assert "every check passed" in str(report) and "mean p^/p over 200 data sets" in str(report)


@pytest.mark.parametrize("mistake", list(FK_MISTAKES))
def test_each_potential_mistake_is_named(mistake):
    report = check_guided_fk(lambda Z: fk_guided_exact(Z, mistake))
    assert report.problems == [f"your G computes a known mistake: {FK_MISTAKES[mistake]}"]


@pytest.mark.parametrize("move, words", [
    (lambda Z, k, xp, rng: FK_MODEL["a"] * xp + np.sqrt(FK_MODEL["q"]) * rng.standard_normal(len(xp)),
     "draws from the transition"),
    (lambda Z, k, xp, rng: Z[k] + 2.0 * rng.standard_normal(len(xp)), "variance 2 used as a standard deviation"),
    (lambda Z, k, xp, rng: Z[k] + np.sqrt(2.0) * np.random.standard_normal(len(xp)), "global np.random"),
    (lambda Z, k, xp, rng: Z[k] + np.sqrt(2.0) * np.random.default_rng(5).standard_normal(len(xp)),
     "another seed gave the same particles"),
])
def test_each_move_mistake_is_named(move, words):
    state = np.random.get_state()
    report = check_guided_fk(_with_move(move))
    np.random.set_state(state)
    assert len(report.problems) == 1 and words in report.problems[0], str(report)


def test_checker_restores_numpy_global_state():
    state = np.random.get_state()
    check_guided_fk(_with_move(lambda Z, k, xp, rng: Z[k] + np.sqrt(2.0) * np.random.standard_normal(len(xp))))
    after = np.random.get_state()
    assert np.array_equal(state[1], after[1]) and state[2] == after[2]


def test_a_constant_in_g_and_a_wrong_step_0_are_named():
    def constant(Z):
        M, G = fk_guided_exact(Z)
        return M, (lambda k, xp, x: G(k, xp, x) + (0.3 if k > 0 else 0.0))
    assert "off by the constant 0.3000" in check_guided_fk(constant).problems[0]

    def nan_at_zero(Z):
        M, G = fk_guided_exact(Z)
        return M, (lambda k, xp, x: np.full(len(x), np.nan) if k == 0 else G(k, xp, x))
    assert "G at step 0 is not 0" in check_guided_fk(nan_at_zero).problems[0]


def test_a_potential_wrong_at_other_steps_fails_the_unbiasedness_check():
    # right at the step the checker inspects (k = 3), the bootstrap potential elsewhere: only the
    # likelihood estimate over many data sets can see it
    def sneaky(Z):
        M, G = fk_guided_exact(Z)
        B = fk_guided_exact(Z, "bootstrap")[1]
        return M, (lambda k, xp, x: G(k, xp, x) if k == 3 else B(k, xp, x))
    problems = check_guided_fk(sneaky).problems
    assert len(problems) == 1 and "the likelihood estimate is biased" in problems[0]


def test_the_checkers_kalman_likelihood_is_exact_by_enumeration():
    # a two-step model: z_1 ~ N(0, a^2 p0 + q + r) exactly
    Z = np.array([np.nan, 0.7])
    a, q, r, p0 = (FK_MODEL[k] for k in ("a", "q", "r", "p0"))
    s = a * a * p0 + q + r
    assert fk_exact_log_likelihood(Z) == pytest.approx(-0.5 * (0.49 / s + np.log(2 * np.pi * s)), abs=1e-12)


def test_the_reference_estimate_is_unbiased_with_many_particles():
    # with N large, log p^ concentrates on log p (var ~ 1/N): a tolerance from the CLT for log p^
    Z = fk_simulate(np.random.default_rng(11))
    M, G = fk_guided_exact(Z)
    logs = np.array([fk_run(M, G, len(Z), 2000, np.random.default_rng(s)) for s in range(20)])
    gap = logs - fk_exact_log_likelihood(Z)
    assert abs(gap.mean()) < 4 * gap.std(ddof=1) / np.sqrt(len(gap)) + 0.5 * gap.var(ddof=1)


def test_the_studys_checkpoints_are_those_of_shorter_runs():
    # row() reads log p^(z_1:t) at t = 25 from a run over more steps: the filter is causal, so it must equal
    # the same seed's run that stops at t = 25 (same random numbers up to there)
    from pfcourse.studies.why_it_works import row
    short, longer = row(seed=3, T=25, N=100, tau=1.0), row(seed=3, T=50, N=100, tau=1.0)
    assert short["log_ratio_25"] == longer["log_ratio_25"]
    assert np.isnan(short["log_ratio_50"]) and np.isfinite(longer["log_ratio_50"])


def test_the_particles_crosscheck_density_is_the_gaussian_log_density():
    from scipy.stats import multivariate_normal

    from pfcourse.studies.why_it_works_particles import _log_gauss
    cov = np.array([[0.3, 0.1], [0.1, 0.5]])
    residual = np.random.default_rng(0).normal(size=(5, 2))
    assert np.allclose(_log_gauss(residual, cov), multivariate_normal(cov=cov).logpdf(residual), atol=1e-12)


def test_the_clt_variance_at_step_0_is_the_closed_form():
    # one importance-sampling step: V_0 = eta_0(G^2 (x - mu)^2) / eta_0(G)^2 with eta_0 = N(0, 1) and
    # G = N(z; x, r); G^2 is a Gaussian in x of variance r/2 times 1 / (2 sqrt(pi r)), so it is in closed form
    from scipy.stats import norm

    from pfcourse.studies.why_it_works import clt_variance
    z, r = 0.7, 0.5
    mu = z / (1 + r)
    s2, m2 = (r / 2) / (1 + r / 2), z / (1 + r / 2)
    top = norm.pdf(z, 0, np.sqrt(1 + r / 2)) / (2 * np.sqrt(np.pi * r)) * (s2 + (m2 - mu) ** 2)
    exact = top / norm.pdf(z, 0, np.sqrt(1 + r)) ** 2
    assert clt_variance(np.array([[z]]), 0) == pytest.approx(exact, rel=1e-9)
    # nothing measured at step 0: V_0 is the prior's variance, 1
    assert clt_variance(np.array([[np.nan]]), 0) == pytest.approx(1.0, rel=1e-9)


def test_the_clt_variance_does_not_depend_on_the_grid():
    from pfcourse.studies.why_it_works import clt_variance
    assert clt_variance(n_grid=401) == pytest.approx(clt_variance(n_grid=1201, half_width=12.0), rel=1e-6)


def test_the_stored_multinomial_runs_agree_with_the_clt_variance():
    # N var of the filter mean over 2000 multinomial runs at N = 1000: its standard error is about
    # V sqrt(2 / R); the stored value must lie within 4 of them of V (plus a 1/N finite-N allowance)
    import pandas as pd

    from pfcourse.studies.store import DATA
    from pfcourse.studies.why_it_works import RESAMPLING_N, clt_variance
    table = pd.read_csv(DATA / "why_it_works_resampling.csv")
    errors = table[table.resampling == "multinomial"].error_last.to_numpy()
    v, n_var = clt_variance(), RESAMPLING_N * np.var(errors, ddof=1)
    assert abs(n_var - v) < 4 * v * np.sqrt(2 / (len(errors) - 1)) + 10 * v / RESAMPLING_N


def test_the_resampling_row_converges_to_the_kalman_mean():
    # N = 20000: the error is about sqrt(V / N) = 0.006; 5 standard deviations
    from pfcourse.studies.why_it_works import clt_variance, resampling_row
    for scheme in ("multinomial", "systematic"):
        out = resampling_row(seed=1, resampling=scheme, N=20000)
        assert abs(out["error_last"]) < 5 * np.sqrt(clt_variance() / 20000)
        assert abs(out["log_ratio"]) < 0.5
