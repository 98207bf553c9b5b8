"""The exercise checkers accept correct code and name what is wrong in typical mistakes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import (check_ancestors, check_kalman, check_log_likelihood, check_optimal_proposal,
                                check_range_bearing_jacobian, check_range_bearing_log_weights,
                                check_resampler, check_sis, check_weight_update)
from pfcourse.collectors import Clouds
from pfcourse.resampling import multinomial, residual, stratified, systematic


def test_every_package_resampler_passes():
    for scheme in (multinomial, stratified, systematic, residual):
        report = check_resampler(scheme, n_draws=2000)
        assert report.ok, str(report)


def test_biased_resampler_is_caught():
    def rounding(w, rng):  # deterministic copies round(N w): biased and never random
        copies = np.round(len(w) * w).astype(int)
        idx = np.repeat(np.arange(len(w)), copies)
        return np.resize(idx, len(w))

    report = check_resampler(rounding, n_draws=500)
    assert not report.ok
    assert any("biased" in p for p in report.problems)


def test_wrong_side_and_out_of_range_are_caught():
    def left_side(w, rng):  # picks a zero-weight particle when u hits its cumulative value
        u = (np.arange(len(w)) + rng.random()) / len(w)
        return np.searchsorted(np.cumsum(w), u, side="left").clip(max=len(w) - 1)

    def off_by_one(w, rng):
        return np.searchsorted(np.cumsum(w), rng.random(len(w)), side="right") + 1

    assert any("out of range" in p for p in check_resampler(off_by_one, n_draws=200).problems)
    wrong = check_resampler(lambda w, rng: rng.integers(0, len(w), len(w)), n_draws=500)
    assert any("weight 0" in p for p in wrong.problems) and any("biased" in p for p in wrong.problems)
    assert check_resampler(left_side, n_draws=500).ok  # P(u exactly on a boundary) = 0: correct


def test_weight_update_checks():
    def good(logw, loglik):
        a = logw + loglik
        return a - logsumexp(a)

    def linear(logw, loglik):
        w = np.exp(logw) * np.exp(loglik)
        return np.log(w / w.sum())

    def unnormalised(logw, loglik):
        return logw + loglik

    assert check_weight_update(good).ok
    bad = check_weight_update(linear)
    assert len(bad.problems) == 1 and "NaN" in bad.problems[0] and "e^-1000" in bad.problems[0]
    assert any("normalise" in p for p in check_weight_update(unnormalised).problems)
    assert "raised" in str(check_weight_update(lambda a, b: 1 / 0))


# The SIS checker: the chapter's reference solution, and typical mistakes, each written as a
# student would (a flag changes one line of the reference).
def sis(z, n_particles, rng, model, *, forget=False, no_noise=False, r_as_sd=False, q_as_sd=False,
        linear=False, weight_nan=False, unnormalised=False, wrong_shape=False):
    x = model.m0 + np.sqrt(model.p0) * rng.standard_normal(n_particles)
    log_w = np.full(n_particles, -np.log(n_particles))
    means, ess = [], []
    for k, zk in enumerate(z):
        if k > 0:
            noise = 0.0 if no_noise else (model.q if q_as_sd else np.sqrt(model.q)) * rng.standard_normal(n_particles)
            x = model.a * x + noise
        if not np.isnan(zk) or weight_nan:
            sd = model.r if r_as_sd else np.sqrt(model.r)
            log_lik = -0.5 * ((zk - x) / sd) ** 2
            if linear:
                w = (np.exp(log_w) if not forget else 1.0) * np.exp(log_lik)
                log_w = np.log(w / w.sum())
            else:
                log_w = (log_lik if forget else log_w + log_lik)
                if not unnormalised:
                    log_w = log_w - logsumexp(log_w)
        w = np.exp(log_w)
        means.append(w @ x)
        ess.append(1.0 / np.sum(w**2))
    return (np.array(means), np.array(ess)[:-1]) if wrong_shape else (np.array(means), np.array(ess))


def sis_report(**mistake):
    return check_sis(lambda z, n, rng, model: sis(z, n, rng, model, **mistake))


def test_the_reference_sis_passes_on_every_seed_tried():
    for seed in range(5):
        report = check_sis(sis, seed=seed)
        assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ({"forget": True}, "forget the previous steps"),
    ({"no_noise": True}, "without process noise"),
    ({"r_as_sd": True}, "uses r as a standard deviation"),
    ({"q_as_sd": True}, "uses q as a standard deviation"),
    ({"weight_nan": True}, "skip the weight update when z_k is NaN"),
    ({"unnormalised": True}, "outside [1, N]"),
    ({"wrong_shape": True}, "one mean and one ESS per step"),
])
def test_each_typical_sis_mistake_gets_its_own_sentence(mistake, says):
    report = sis_report(**mistake)
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_linear_weights_that_underflow_are_named():
    """With a measurement far out in the tail, every linear-domain weight underflows to 0."""
    report = check_sis(lambda z, n, rng, model: sis(z, n, rng, model, linear=True), z=np.array([np.nan, 60.0]))
    assert not report.ok and "logsumexp" in report.problems[0], str(report)
    logged = check_sis(sis, z=np.array([np.nan, 60.0]))  # the log-domain filter keeps finite weights there
    assert not any("NaN" in p for p in logged.problems), str(logged)


def test_a_student_exception_is_reported_not_raised():
    def broken(z, n, rng, model):
        raise IndexError("index 5 is out of bounds")

    report = check_sis(broken)
    assert not report.ok and "raised IndexError: index 5" in report.problems[0]


def test_the_empty_answer_cell_gets_a_plain_sentence():
    report = check_sis(lambda z, n, rng, model: None)
    assert report.problems == ["the function returned None: write the filter and return (means, ess)"]


def test_an_empty_weight_update_or_resampler_gets_a_plain_sentence():
    """The answer cells of the importance-sampling chapter start as stubs that return None."""
    empty_update = check_weight_update(lambda log_w, log_lik: None)
    assert empty_update.problems == ["the function returned None: write the update and return the new log-weights"]
    empty_resampler = check_resampler(lambda w, rng: None)
    assert empty_resampler.problems == [
        "the function returned None: write the resampler and return the N ancestor indices"]


def origins(ancestors, mistake=None):
    """The genealogy of the SIR chapter's exercise, and its typical mistakes."""
    a = np.arange(ancestors.shape[1])
    steps = {None: range(len(ancestors) - 1, 0, -1), "forwards": range(1, len(ancestors)),
             "skip_last": range(len(ancestors) - 2, 0, -1)}.get(mistake, range(len(ancestors) - 1, 0, -1))
    if mistake == "one_generation":
        return ancestors[-1]
    if mistake == "counts":
        return np.unique(ancestors[-1])
    for k in steps:
        a = ancestors[k][a]
    return a


def test_the_reference_genealogy_passes_on_every_case():
    for seed in range(5):
        report = check_ancestors(origins, seed=seed)
        assert report.ok, str(report)
    assert str(check_ancestors(origins)) == "genealogy: every check passed"


@pytest.mark.parametrize("mistake, says", [
    ("forwards", "followed forwards"),
    ("one_generation", "only one generation"),
    ("skip_last", "the last step is left out"),
    ("counts", "one step-0 origin per particle"),
])
def test_each_typical_genealogy_mistake_gets_its_own_sentence(mistake, says):
    for seed in range(5):
        report = check_ancestors(lambda a: origins(a, mistake), seed=seed)
        assert not report.ok and len(report.problems) == 1
        assert says in report.problems[0], report.problems[0]


def test_a_wrong_genealogy_without_a_known_mistake_is_told_where():
    report = check_ancestors(lambda a: np.zeros(a.shape[1], dtype=int))
    assert not report.ok and "follow a = ancestors[k][a]" in report.problems[0]
    assert check_ancestors(lambda a: None).problems[0].startswith("the function returned None")
    assert "raised KeyError" in check_ancestors(lambda a: {}[0]).problems[0]


# The Kalman checker: the chapter's reference solution, and typical mistakes written as a student
# would (a flag changes one line of the reference).
def kalman(z, model, *, gain_with_p=False, no_q=False, r_as_sd=False, nan_kept=False, nan_as_zero=False,
           loglik_with_p=False, loglik_no_constant=False, loglik_at_missing=False, wrong_shape=False):
    m, p, log_lik = model.m0, model.p0, 0.0
    means, variances = [], []
    for k, zk in enumerate(z):
        if k > 0:
            m, p = model.a * m, model.a**2 * p + (0.0 if no_q else model.q)
        if nan_as_zero and np.isnan(zk):
            zk = 0.0
        if not np.isnan(zk) or nan_kept or loglik_at_missing:
            s = p + (model.r**2 if r_as_sd else model.r)
            nu = zk - m
            s_lik = p if loglik_with_p else s
            log_lik += -0.5 * nu**2 / s_lik - (0.0 if loglik_no_constant else 0.5 * np.log(2 * np.pi * s_lik))
            if not np.isnan(zk) or nan_kept:
                gain = 1.0 if gain_with_p else p / s
                m, p = m + gain * nu, (1 - gain) * p
        means.append(m)
        variances.append(p)
    return (np.array(means)[:-1] if wrong_shape else np.array(means)), np.array(variances), log_lik


def kalman_report(**mistake):
    return check_kalman(lambda z, model: kalman(z, model, **mistake))


def test_the_reference_kalman_passes_and_matches_the_package_filter():
    from pfcourse.book.exercises import KALMAN_CASE, ScalarModel, scalar_kalman
    from pfcourse.kalman import kalman_filter
    from pfcourse.linear_gaussian import LinearGaussianModel

    assert check_kalman(kalman).ok, str(check_kalman(kalman))
    model = ScalarModel()
    lg = LinearGaussianModel(F=[[model.a]], H=[[1.0]], m0=[model.m0], P0=[[model.p0]], Q=[[model.q]], R=[[model.r]])
    ref = kalman_filter(lg, KALMAN_CASE[:, None])
    means, variances, log_lik = scalar_kalman(KALMAN_CASE, model)
    np.testing.assert_allclose(means, ref.mean[:, 0], rtol=1e-12)
    np.testing.assert_allclose(variances, ref.cov[:, 0, 0], rtol=1e-12)
    np.testing.assert_allclose(log_lik, ref.log_likelihood, rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"gain_with_p": True}, "instead of the innovation variance"),
    ({"no_q": True}, "forgets the process noise"),
    ({"r_as_sd": True}, "uses r as a standard deviation"),
    ({"nan_kept": True}, "skip the update at such a step"),
    ({"nan_as_zero": True}, "is used as z_k = 0"),
    ({"loglik_with_p": True}, "uses P_k^- where it needs S_k"),
    ({"loglik_no_constant": True}, "misses the normalising term"),
    ({"loglik_at_missing": True}, "only at the steps where something is measured"),
    ({"wrong_shape": True}, "one mean and one variance per step"),
])
def test_each_typical_kalman_mistake_gets_its_own_sentence(mistake, says):
    report = kalman_report(**mistake)
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_every_named_kalman_mistake_is_recognised_from_its_own_numbers():
    from pfcourse.book.exercises import KALMAN_MISTAKES, scalar_kalman

    for mistake, why in KALMAN_MISTAKES.items():
        report = check_kalman(lambda z, model, m=mistake: scalar_kalman(z, model, m))
        assert report.problems == [f"your filter computes a known mistake: {why}"], (mistake, str(report))


def test_an_unnamed_kalman_mistake_points_at_its_step_and_a_student_exception_is_reported():
    def innovation_sign(z, model):
        means, variances, log_lik = kalman(z, model)
        return means * np.where(np.arange(len(z)) >= 2, 1.1, 1.0), variances, log_lik

    report = check_kalman(innovation_sign)
    assert not report.ok and "at step 2" in report.problems[0], str(report)
    assert "raised ZeroDivisionError" in str(check_kalman(lambda z, model: 1 / 0))
    assert check_kalman(lambda z, model: None).problems == [
        "the function returned None: write the filter and return (means, variances, log_likelihood)"]


def test_a_kalman_answer_of_the_wrong_form_is_named():
    def two_values(z, model):
        return kalman(z, model)[:2]

    def increments(z, model):
        means, variances, _ = kalman(z, model)
        return means, variances, np.zeros(len(z))

    assert check_kalman(two_values).problems == [
        "the function returned 2 values; return 3: (means, variances, log_likelihood)"]
    assert "not one number: return the sum of the increments" in check_kalman(increments).problems[0]


# The optimal-proposal checker: the chapter's reference solution, and typical mistakes, each written
# as a student would (a flag changes one line of the reference).
def optimal_proposal(x_prev, z, model, *, var_added=False, mean_blind=False, weight_q=False, weight_r=False,
                     weight_at_new=False, no_constant=False):
    var = model.q + model.r if var_added else 1.0 / (1.0 / model.q + 1.0 / model.r)
    mean = model.a * x_prev if mean_blind else var * (model.a * x_prev / model.q + z / model.r)
    centre = mean if weight_at_new else model.a * x_prev
    s = model.q if weight_q else model.r if weight_r or weight_at_new else model.q + model.r
    log_w = -0.5 * (z - centre) ** 2 / s - (0.0 if no_constant else 0.5 * np.log(2 * np.pi * s))
    return mean, np.full(x_prev.shape, var), log_w


def test_the_reference_optimal_proposal_passes_and_matches_the_package_proposal():
    from pfcourse.book.exercises import PROPOSAL_MODEL, PROPOSAL_PARENTS, PROPOSAL_Z, scalar_optimal_proposal
    from pfcourse.linear_gaussian import LinearGaussianModel
    from pfcourse.proposals import LinearGaussianOptimal

    assert check_optimal_proposal(optimal_proposal).ok, str(check_optimal_proposal(optimal_proposal))
    assert check_optimal_proposal(lambda x, z, m: optimal_proposal(x, z, m, no_constant=True)).ok
    m = PROPOSAL_MODEL
    lg = LinearGaussianModel(F=np.array([[m.a]]), Q=np.array([[m.q]]), H=np.array([[1.0]]), R=np.array([[m.r]]),
                             m0=np.array([m.m0]), P0=np.array([[m.p0]]))
    x = PROPOSAL_PARENTS[:, None]
    logw = LinearGaussianOptimal().log_predictive(lg, x, np.array([PROPOSAL_Z]), 1)
    np.testing.assert_allclose(logw, scalar_optimal_proposal(PROPOSAL_PARENTS, PROPOSAL_Z, m)[2], rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"var_added": True}, "the variances are added (q + r) where the precisions add"),
    ({"mean_blind": True}, "the mean is the prediction a x_(k-1), blind to z_k"),
    ({"weight_q": True}, "the log-weight uses the variance q alone"),
    ({"weight_r": True}, "the log-weight uses the variance r alone"),
    ({"weight_at_new": True}, "evaluated at the new particle (the proposal's mean) instead of the parent"),
])
def test_each_typical_optimal_proposal_mistake_gets_its_own_sentence(mistake, says):
    report = check_optimal_proposal(lambda x, z, model: optimal_proposal(x, z, model, **mistake))
    assert not report.ok
    assert any(says in p for p in report.problems), str(report)


def test_added_variances_are_named_in_the_mean_too_and_an_unnamed_mistake_is_told_where():
    report = check_optimal_proposal(lambda x, z, model: optimal_proposal(x, z, model, var_added=True))
    assert len(report.problems) == 2 and "the mean uses q + r as its variance" in report.problems[0]

    def sign_flipped(x, z, model):
        mean, var, log_w = optimal_proposal(x, z, model)
        return mean, var, -log_w

    report = check_optimal_proposal(sign_flipped)
    assert report.problems[0].startswith("for the parent x_(k-1) = -1.5 your log-weight is"), str(report)


def test_an_optimal_proposal_answer_of_the_wrong_form_is_named():
    assert check_optimal_proposal(lambda x, z, model: None).problems == [
        "the function returned None: write the proposal and return (means, variances, log_weights)"]
    assert "raised ZeroDivisionError" in str(check_optimal_proposal(lambda x, z, model: 1 / 0))
    assert "returned 2 values; return 3" in str(check_optimal_proposal(lambda x, z, model: (x, x)))
    assert "one mean and one variance and one log-weight per parent" in str(
        check_optimal_proposal(lambda x, z, model: (x, x, x[:2])))


def test_an_unbiased_but_too_variable_resampler_is_named():
    """Copy counts right on average but more variable than multinomial resampling's: one uniform for all."""
    def stratified_reference(w, rng):  # the chapter's solution (exercise 6.3)
        n = len(w)
        return np.minimum(np.searchsorted(np.cumsum(w), (np.arange(n) + rng.random(n)) / n, side="right"), n - 1)

    def one_uniform_for_all(w, rng):  # u = rng.random() broadcast: every particle copies the same ancestor
        return np.minimum(np.searchsorted(np.cumsum(w), np.full(len(w), rng.random()), side="right"), len(w) - 1)

    def half_share_one_uniform(w, rng):  # the first half of the particles share one uniform: still unbiased
        n = len(w)
        u = np.where(np.arange(n) < n // 2, rng.random(), rng.random(n))
        return np.minimum(np.searchsorted(np.cumsum(w), np.sort(u), side="right"), n - 1)

    assert check_resampler(stratified_reference, n_draws=2000).ok
    for mistake in (one_uniform_for_all, half_share_one_uniform):
        report = check_resampler(mistake, n_draws=2000)
        assert len(report.problems) == 1, str(report)
        assert report.problems[0].startswith("the copy counts are right on average but too variable"), str(report)
        assert "one uniform shared by all" in report.problems[0]


def _landmark(robot, m, P, z, A, C, R, **mistake):
    """A student's map update, right unless a mistake is named."""
    nu = z - C @ m if mistake.get("no_robot") else z - A @ robot - C @ m
    S = C @ P @ C.T + (0 if mistake.get("s_without_r") else R)
    K = P @ C.T @ np.linalg.inv(S)
    S_lik = R if mistake.get("loglik_with_r") else S
    log_lik = -0.5 * (nu @ np.linalg.inv(S_lik) @ nu + np.log(np.linalg.det(2 * np.pi * S_lik)))
    P_new = P if mistake.get("no_cov_update") else P - K @ C @ P
    return m + K @ nu, P_new, log_lik


def test_the_reference_landmark_update_passes():
    from pfcourse.book.exercises import check_landmark_update

    report = check_landmark_update(_landmark)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ({"no_robot": True}, "forgets the robot"),
    ({"s_without_r": True}, "misses the measurement noise"),
    ({"no_cov_update": True}, "covariance is not updated"),
    ({"loglik_with_r": True}, "uses R where it needs S"),
])
def test_landmark_update_mistakes_are_named(mistake, says):
    from pfcourse.book.exercises import check_landmark_update

    report = check_landmark_update(lambda *args, **kw: _landmark(*args, **kw, **mistake))
    assert not report.ok and says in str(report), str(report)


def test_landmark_update_bad_returns_are_reported():
    from pfcourse.book.exercises import check_landmark_update

    assert "returned None" in str(check_landmark_update(lambda **kw: None))
    assert "raised" in str(check_landmark_update(lambda **kw: 1 / 0))
    assert "three things" in str(check_landmark_update(lambda **kw: (1, 2)))


def _second_stage(log_lik, log_pred, ancestors, mistake=None):
    """A student's second-stage weights, right unless a mistake is named."""
    if mistake == "no_division":
        log_w = log_lik.copy()
    elif mistake == "own_index":
        log_w = log_lik - log_pred
    elif mistake == "multiplied":
        log_w = log_lik + log_pred[ancestors]
    else:
        log_w = log_lik - log_pred[ancestors]
    return log_w if mistake == "unnormalised" else log_w - logsumexp(log_w)


def test_the_reference_second_stage_passes():
    from pfcourse.book.exercises import check_apf_second_stage

    assert check_apf_second_stage(_second_stage).ok, str(check_apf_second_stage(_second_stage))


@pytest.mark.parametrize("mistake, says", [
    ("no_division", "first stage is not divided out"),
    ("own_index", "own first-stage value"),
    ("multiplied", "multiplied in again"),
    ("unnormalised", "not normalised"),
])
def test_second_stage_mistakes_are_named(mistake, says):
    from pfcourse.book.exercises import check_apf_second_stage

    report = check_apf_second_stage(lambda a, b, c: _second_stage(a, b, c, mistake))
    assert not report.ok and says in str(report), str(report)


def test_second_stage_bad_returns_are_reported():
    from pfcourse.book.exercises import check_apf_second_stage

    assert "returned None" in str(check_apf_second_stage(lambda a, b, c: None))
    assert "shape" in str(check_apf_second_stage(lambda a, b, c: a[:3]))


# The log-likelihood checker (chapter 1): the reference solution, and typical mistakes written
# as a student would.
def cloud_log_likelihood(x, z, H, R, *, nan_kept=False, reversed_offset=False, r_as_sd=False,
                         whole_r=False, leading_block=False, no_constant=False, some_zero=False):
    seen = np.ones(len(z), dtype=bool) if (nan_kept or whole_r) else ~np.isnan(z)
    if not seen.any():
        return np.full(len(x), 1e-3 if some_zero else 0.0)
    d = (z[seen] + x @ H[seen].T) if reversed_offset else (z[seen] - x @ H[seen].T)
    if whole_r:
        d = np.nan_to_num(d)
    S = R[: seen.sum(), : seen.sum()] if leading_block else R[np.ix_(seen, seen)]
    if r_as_sd:
        S = S @ S
    quad = np.sum(d * np.linalg.solve(S, d.T).T, axis=1)
    const = 0.0 if no_constant else seen.sum() * np.log(2 * np.pi) + np.log(np.linalg.det(S))
    return -0.5 * (quad + const)


def test_the_reference_log_likelihood_passes_and_matches_the_package_model():
    from pfcourse.book.exercises import LIKELIHOOD_CASES, LIKELIHOOD_H, LIKELIHOOD_R
    from pfcourse.scenarios.landmarks.scenario import quadrant_scenario

    assert check_log_likelihood(cloud_log_likelihood).ok, str(check_log_likelihood(cloud_log_likelihood))
    model = quadrant_scenario().with_(Rv=LIKELIHOOD_R).model()
    np.testing.assert_array_equal(model.H, LIKELIHOOD_H)
    x = np.random.default_rng(1).normal(size=(7, 6))
    for z in LIKELIHOOD_CASES:
        np.testing.assert_allclose(cloud_log_likelihood(x, z, LIKELIHOOD_H, LIKELIHOOD_R),
                                   model.log_likelihood(x, z, 1), rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"nan_kept": True}, "NaN when a landmark is out of view"),
    ({"reversed_offset": True}, "the offset reversed"),
    ({"r_as_sd": True}, "R as a matrix of standard deviations"),
    ({"whole_r": True}, "keeps the whole R"),
    ({"leading_block": True}, "leading block R[:n, :n]"),
    ({"no_constant": True}, "misses the normalising term"),
    ({"some_zero": True}, "return zeros, one per particle"),
])
def test_each_typical_log_likelihood_mistake_gets_its_own_sentence(mistake, says):
    report = check_log_likelihood(lambda x, z, H, R: cloud_log_likelihood(x, z, H, R, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_every_named_log_likelihood_mistake_is_recognised_and_odd_answers_are_named():
    from pfcourse.book.exercises import LIKELIHOOD_MISTAKES, landmark_log_likelihood

    for mistake, why in LIKELIHOOD_MISTAKES.items():
        report = check_log_likelihood(lambda x, z, H, R, m=mistake: landmark_log_likelihood(x, z, H, R, m))
        assert report.problems == [f"your function computes a known mistake: {why}"], (mistake, str(report))
    half = check_log_likelihood(lambda x, z, H, R: 2 * cloud_log_likelihood(x, z, H, R))
    assert "the values differ from log N(z_k; H_k x^i, R_k)" in half.problems[0], str(half)
    assert half.problems[0].endswith("with m the number of coordinates measured"), str(half)
    assert "shape (50, 1)" in check_log_likelihood(lambda x, z, H, R: np.zeros((len(x), 1))).problems[0]
    assert check_log_likelihood(lambda x, z, H, R: None).problems == [
        "the function returned None: compute and return one log-likelihood per particle"]
    assert "raised ZeroDivisionError" in str(check_log_likelihood(lambda x, z, H, R: 1 / 0))


# --- check_consistency (chapter 20): the reference passes, each mistake is named
from pfcourse.book.exercises import CONSISTENCY_MISTAKES, _consistency_case, check_consistency, nees_consistency


def test_consistency_reference_passes_and_matches_the_package():
    from pfcourse.diagnostics import chi2_band, fraction_in_band

    def mine(errors, covariances):
        return nees_consistency(errors, covariances)

    assert check_consistency(mine).ok, str(check_consistency(mine))
    errors, covs = _consistency_case()
    average, band, fraction = nees_consistency(errors, covs)
    assert band == pytest.approx(chi2_band(3, len(errors)), rel=1e-12)
    assert fraction == fraction_in_band(average, band)
    assert 0.6 < fraction < 0.95  # consistent outside the over-confident spell, outside the band within it
    assert np.all(average[40:50] > band[1])


@pytest.mark.parametrize("mistake", list(CONSISTENCY_MISTAKES))
def test_consistency_mistakes_are_named(mistake):
    report = check_consistency(lambda e, c: nees_consistency(e, c, mistake=mistake))
    assert not report.ok and CONSISTENCY_MISTAKES[mistake] in report.problems[0]


def test_consistency_shapes_and_other_errors_are_explained():
    def per_run(e, c):  # averaged over the steps instead of the runs
        average, band, fraction = nees_consistency(e, c)
        return np.einsum("rki,rkij,rkj->rk", e, np.linalg.inv(c), e).mean(axis=1), band, fraction

    assert "one value per step" in check_consistency(per_run).problems[0]
    assert "not (average_nees" in check_consistency(lambda e, c: 3.0).problems[0]

    def bounds_excluded(e, c):
        average, (lo, hi), _ = nees_consistency(e, c)
        return average, (lo, hi), float(np.mean((average > lo) & (average < hi))) - 0.5

    assert "bounds included" in check_consistency(bounds_excluded).problems[0]


# --- check_ess (chapter 18)
from pfcourse.book.exercises import ESS_MISTAKES, check_ess, effective_sample_size_from_logs  # noqa: E402


def test_ess_reference_passes_and_agrees_with_the_package():
    from pfcourse.diagnostics import effective_sample_size, normalize_log_weights

    assert check_ess(effective_sample_size_from_logs).ok
    for case in (np.log([0.5, 0.25, 0.125, 0.125]), np.array([-1000.0, -1001.0, -1000.5])):
        weights, _ = normalize_log_weights(case)
        assert effective_sample_size_from_logs(case) == pytest.approx(effective_sample_size(weights), rel=1e-12)
    assert effective_sample_size_from_logs(np.zeros(7)) == pytest.approx(7.0)


@pytest.mark.parametrize("mistake", list(ESS_MISTAKES))
def test_ess_mistakes_are_named(mistake):
    report = check_ess(lambda lw: effective_sample_size_from_logs(lw, mistake))
    assert not report.ok and ESS_MISTAKES[mistake] in report.problems[0]


def test_ess_other_answers_are_explained():
    assert "not a number" in check_ess(lambda lw: "ten").problems[0]
    assert "returned None" in check_ess(lambda lw: None).problems[0]
    assert "differ from 1 / sum_i W_i^2" in check_ess(lambda lw: 2.0).problems[0]


# The pose-density checker (chapter 11): the reference solution, and typical mistakes written as a
# student would.
def pose_log_density(x, z, landmark, sd, *, bearing_added=False, no_jacobian=False, no_direction=False,
                     no_truncation=False, unwrapped=False, variance_for_sd=False, halved=False):
    from scipy.stats import norm

    r, b = z
    s_r, s_b = (sd**2 if variance_for_sd else sd)
    d = landmark - x[:, :2]
    h_r = np.linalg.norm(d, axis=1)
    h_b = np.arctan2(d[:, 1], d[:, 0]) + (x[:, 2] if bearing_added else -x[:, 2])
    nu_b = b - h_b if unwrapped else np.angle(np.exp(1j * (b - h_b)))
    out = norm.logpdf(h_r, r, s_r) + norm.logpdf(nu_b, 0.0, s_b)
    out -= 0.0 if no_truncation else norm.logcdf(r / s_r)
    out -= 0.0 if no_direction else np.log(2 * np.pi)
    out -= 0.0 if no_jacobian else np.log(h_r)
    return out / 2 if halved else out


def test_the_reference_pose_density_passes_and_is_the_package_proposal():
    from pfcourse.book.exercises import POSE_DENSITY_CASES, check_pose_density
    from pfcourse.scenarios.robot.mcl import SensorPoseSampler

    assert check_pose_density(pose_log_density).ok, str(check_pose_density(pose_log_density))
    rng = np.random.default_rng(3)
    for z, landmark, sd in POSE_DENSITY_CASES:
        sampler = SensorPoseSampler(landmark[None, :], np.diag(sd**2))
        x = sampler.sample(np.array([0.0, *z]), 25, rng)
        np.testing.assert_allclose(pose_log_density(x, z, landmark, sd), sampler.log_density(x, np.array([0.0, *z])),
                                   rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"bearing_added": True}, "predicts the bearing as atan2(l - p) + theta"),
    ({"no_jacobian": True}, "misses the Jacobian term"),
    ({"no_direction": True}, "misses the direction's density 1 / (2 pi)"),
    ({"no_truncation": True}, "misses the truncation term"),
    ({"unwrapped": True}, "does not wrap the bearing residual"),
    ({"variance_for_sd": True}, "uses s_r and s_b as variances"),
    ({"halved": True}, "the values differ from log q_z(x)"),
])
def test_each_typical_pose_density_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_pose_density

    report = check_pose_density(lambda x, z, landmark, sd: pose_log_density(x, z, landmark, sd, **mistake))
    assert report is not None and not report.ok and len(report.problems) == 1, report
    assert says in report.problems[0], report.problems[0]


# --- chapter 21: check_anonymous_likelihood ----------------------------------------------------------

def anonymous_reading(x, z, landmarks, R, p_detect, clutter_rate, max_range, **mistake):
    """A student's answer, written independently of the reference (a loop over the landmarks)."""
    terms = [] if mistake.get("no_clutter") else [np.full(len(x), np.log((1 - p_detect) * clutter_rate
                                                                         / (2 * np.pi * max_range))
                                                          if clutter_rate > 0 else -np.inf)]
    M = 1 if mistake.get("no_division") else len(landmarks)
    for lx, ly in landmarks:
        dx, dy = lx - x[:, 0], ly - x[:, 1]
        nu = np.column_stack([z[0] - np.sqrt(dx**2 + dy**2), z[1] - np.arctan2(dy, dx) + x[:, 2]])
        nu[:, 1] = (nu[:, 1] + np.pi) % (2 * np.pi) - np.pi
        quad = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(R), nu)
        terms.append(np.log(p_detect / M) - 0.5 * quad - 0.5 * np.log(np.linalg.det(2 * np.pi * R)))
    terms = np.array(terms)
    if mistake.get("sum_logs"):
        return -clutter_rate + np.sum(np.where(np.isinf(terms), 0.0, terms), axis=0)
    return logsumexp(terms, axis=0) - clutter_rate


def test_anonymous_reference_passes_and_is_the_package_mixture():
    from pfcourse.book.exercises import ANONYMOUS_LANDMARKS, ANONYMOUS_R, check_anonymous_likelihood
    from pfcourse.scenarios.robot import RobotModel
    from pfcourse.scenarios.robot.association import ClutterSensor, mixture_log_likelihood

    report = check_anonymous_likelihood(anonymous_reading)
    assert report.ok, str(report)
    base = RobotModel(ANONYMOUS_LANDMARKS, np.zeros((2, 3)), np.eye(3), ANONYMOUS_R)
    x = np.random.default_rng(2).normal(0.0, 2.0, size=(9, 3))
    z = np.array([9.0, 0.4])
    np.testing.assert_allclose(anonymous_reading(x, z, ANONYMOUS_LANDMARKS, ANONYMOUS_R, 0.8, 1.5, 30.0),
                               mixture_log_likelihood(base, ClutterSensor(0.8, 1.5, 30.0), x, z[None]), rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"no_clutter": True}, "forgets the clutter term"),
    ({"no_division": True}, "does not divide P_D by the number of landmarks"),
    ({"sum_logs": True}, "sums the log-likelihoods"),
])
def test_each_typical_anonymous_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_anonymous_likelihood

    report = check_anonymous_likelihood(lambda *args: anonymous_reading(*args, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_odd_pose_density_answers_are_named():
    from pfcourse.book.exercises import check_pose_density

    assert "shape (40, 1)" in check_pose_density(lambda x, z, l, sd: np.zeros((len(x), 1))).problems[0]
    assert check_pose_density(lambda x, z, l, sd: None).problems == [
        "the function returned None: compute and return log q_z(x), one value per pose"]
    assert "NaN or infinite" in check_pose_density(lambda x, z, l, sd: np.full(len(x), np.nan)).problems[0]
    assert "raised ZeroDivisionError" in str(check_pose_density(lambda x, z, l, sd: 1 / 0))
def test_every_named_anonymous_mistake_is_recognised_and_odd_answers_are_named():
    from pfcourse.book.exercises import ANONYMOUS_MISTAKES, anonymous_log_likelihood, check_anonymous_likelihood

    for mistake, why in ANONYMOUS_MISTAKES.items():
        report = check_anonymous_likelihood(lambda *a, m=mistake: anonymous_log_likelihood(*a, mistake=m))
        assert report.problems == [f"your function computes a known mistake: {why}"]
    assert "differ from -lambda" in check_anonymous_likelihood(lambda *a: anonymous_log_likelihood(*a) + 0.1).problems[0]
    assert "shape" in check_anonymous_likelihood(lambda x, *a: np.zeros(3)).problems[0]
    assert "raised ZeroDivisionError" in check_anonymous_likelihood(lambda *a: 1 / 0).problems[0]
    assert "returned None" in check_anonymous_likelihood(lambda *a: None).problems[0]


# ---------------------------------------------------------------- chapter 22: the likelihood estimator
def student_estimate(log_w, resampled, forgot_previous=False, mean_of_logs=False, no_reset=False,
                     linear=False, unnormalised=False):
    """A student's ``log p^(z_1:K)``, correct by default, with each typical mistake as an option."""
    n = log_w.shape[1]
    log_W, total = np.full(n, -np.log(n)), 0.0
    for row, was_resampled in zip(log_w, resampled):
        if forgot_previous:
            log_W = np.full(n, -np.log(n))
        a = log_W + row
        if mean_of_logs:
            step = np.mean(row)
        elif linear:
            step = np.log(np.sum(np.exp(a)))
        else:
            step = logsumexp(a)
        total += step
        log_W = a if unnormalised else a - logsumexp(a)
        if was_resampled and not no_reset:
            log_W = np.full(n, -np.log(n))
    return total


def test_the_reference_estimator_is_the_engines_log_likelihood():
    from pfcourse.book.exercises import likelihood_estimate
    from pfcourse.filter import ParticleFilter
    from pfcourse.scenarios.landmarks import quadrant_scenario, simulate

    scenario = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
    model = scenario.model()
    Z = simulate(scenario, 7).measurements
    run = ParticleFilter(model, 200, threshold=0.5).run(Z, 3, collect=[Clouds()])
    assert 0 < run.resampled.sum() < (~np.isnan(Z).all(axis=1)).sum()  # some measured steps resample, some do not
    log_w = np.array([np.zeros(200) if np.isnan(z).all() else model.log_likelihood(x, z, k)
                      for k, (z, x) in enumerate(zip(Z, run.particles))])
    assert likelihood_estimate(log_w, run.resampled) == pytest.approx(run.log_likelihood, rel=1e-10)


def test_a_correct_likelihood_estimator_passes():
    from pfcourse.book.exercises import check_likelihood_estimate

    report = check_likelihood_estimate(student_estimate)
    assert report.ok and str(report).endswith("every check passed"), str(report)


@pytest.mark.parametrize("mistake, says", [
    ({"forgot_previous": True}, "instead of the previous weights W_(k-1)"),
    ({"no_reset": True}, "keeps the weights W_k after a resampling"),
    ({"unnormalised": True}, "unnormalised weights"),
    ({"linear": True}, "underflows to 0"),
])
def test_each_typical_estimator_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_likelihood_estimate

    report = check_likelihood_estimate(lambda log_w, resampled: student_estimate(log_w, resampled, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_averaging_log_weights_is_named_with_or_without_the_previous_weights():
    from pfcourse.book.exercises import ESTIMATOR_MISTAKES, check_likelihood_estimate, likelihood_estimate

    weighted = check_likelihood_estimate(lambda log_w, r: likelihood_estimate(log_w, r, "mean_of_logs"))
    assert "averages the log-weights" in weighted.problems[0], str(weighted)
    plain = check_likelihood_estimate(lambda log_w, r: student_estimate(log_w, r, mean_of_logs=True))
    assert "averages the log-weights" in plain.problems[0] and "without the previous" in plain.problems[0], str(plain)
    case = np.random.default_rng(0).normal(-2.0, 1.5, size=(10, 8))
    from pfcourse.book.exercises import ESTIMATOR_RESAMPLED
    values = [likelihood_estimate(case, ESTIMATOR_RESAMPLED, m) for m in [None, *ESTIMATOR_MISTAKES]]
    assert len(np.unique(np.round(values, 6))) == len(values)  # every mistake gives its own number


def test_odd_estimator_answers_are_named():
    from pfcourse.book.exercises import check_likelihood_estimate

    assert check_likelihood_estimate(lambda log_w, r: None).problems == [
        "the function returned None: compute and return log p^(z_1:K), one float"]
    assert "not one float" in check_likelihood_estimate(lambda log_w, r: np.zeros(3)).problems[0]
    assert "raised ZeroDivisionError" in str(check_likelihood_estimate(lambda log_w, r: 1 / 0))


# --- chapter 13: the likelihood-field log-weight (check_likelihood_field) -------------------------------
def student_field(poses, z, field, keep_max=False, no_heading=False, no_rand=False, no_constant=False,
                  product=False):
    """A student's table 6.3, written independently of field_log_weights; each flag one typical mistake."""
    out = np.zeros(len(poses))
    dens_all = []
    for b, (zb, ab) in enumerate(zip(z, field.angles)):
        if zb >= field.max_range and not keep_max:
            continue
        direction = ab + (0.0 if no_heading else poses[:, 2])
        ends = np.column_stack([poses[:, 0] + zb * np.cos(direction), poses[:, 1] + zb * np.sin(direction)])
        d = field.grid.distance_at(ends)
        gauss = np.exp(-d**2 / (2 * field.sigma**2)) / (1.0 if no_constant else np.sqrt(2 * np.pi) * field.sigma)
        dens = field.z_hit * gauss + (0.0 if no_rand else field.z_rand / field.max_range)
        dens_all.append(dens)
        with np.errstate(divide="ignore"):
            out += np.log(dens)
    if product:
        with np.errstate(divide="ignore"):
            return np.log(np.prod(dens_all, axis=0))
    return out


def test_likelihood_field_checker_passes_the_reference():
    from pfcourse.book.exercises import check_likelihood_field
    report = check_likelihood_field(student_field)
    assert report.ok, str(report)
    assert str(report) == "likelihood field: every check passed"


@pytest.mark.parametrize("mistake, says", [
    ({"keep_max": True}, "beams at the maximum range"),
    ({"no_heading": True}, "the robot's heading plus the beam's angle"),
    ({"no_rand": True}, "the term z_rand / z_max is missing"),
    ({"no_constant": True}, "factor 1 / (sqrt(2 pi) sigma)"),
    ({"product": True}, "underflows to 0"),
])
def test_each_typical_likelihood_field_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_likelihood_field
    report = check_likelihood_field(lambda p, z, f: student_field(p, z, f, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_likelihood_field_checker_names_odd_answers():
    from pfcourse.book.exercises import check_likelihood_field
    assert "differ from table 6.3's" in check_likelihood_field(lambda p, z, f: 2 * student_field(p, z, f)).problems[0]
    assert "shape (40, 1)" in check_likelihood_field(lambda p, z, f: np.zeros((len(p), 1))).problems[0]
    assert check_likelihood_field(lambda p, z, f: None).problems == [
        "the function returned None: compute and return one log-weight per pose"]


def _altitude(mean, var, ground, reading, rf, mistake=None):
    """A student's altitude update of every particle, right unless a mistake is named."""
    nu = reading - (mean + ground if mistake == "sign" else mean - ground)
    s = var + rf
    gain = var / s
    new_var = var if mistake == "no_var" else (1 - gain) * var
    s_lik = rf if mistake == "r" else s
    return mean + gain * nu, new_var, -0.5 * nu**2 / s_lik - 0.5 * np.log(2 * np.pi * s_lik)


def test_the_reference_altitude_update_passes():
    from pfcourse.book.exercises import check_altitude_update

    assert check_altitude_update(_altitude).ok, str(check_altitude_update(_altitude))


@pytest.mark.parametrize("mistake, says", [
    ("sign", "wrong sign"),
    ("r", "uses Rf where it needs S"),
    ("no_var", "variance is not updated"),
])
def test_altitude_update_mistakes_are_named(mistake, says):
    from pfcourse.book.exercises import check_altitude_update

    report = check_altitude_update(lambda *a, **kw: _altitude(*a, **kw, mistake=mistake))
    assert not report.ok and says in str(report), str(report)


def test_altitude_update_gain_and_bad_returns_are_reported():
    from pfcourse.book.exercises import check_altitude_update

    def gain_over_r(mean, var, ground, reading, rf):
        k = var / rf
        nu = reading - mean + ground
        return mean + k * nu, (1 - k) * var, -0.5 * nu**2 / (var + rf) - 0.5 * np.log(2 * np.pi * (var + rf))

    assert "gain is P / Rf" in str(check_altitude_update(gain_over_r))
    assert "returned None" in str(check_altitude_update(lambda **kw: None))
    assert "raised" in str(check_altitude_update(lambda **kw: 1 / 0))
    assert "three arrays" in str(check_altitude_update(lambda **kw: (1, 2)))
    assert "mean differs" in str(check_altitude_update(lambda mean, var, ground, reading, rf:
                                                       (mean, *_altitude(mean, var, ground, reading, rf)[1:])))


# --- check_range_bearing_log_weights and check_range_bearing_jacobian (chapters 10 and 12) -----------

def robot_log_weights(x, landmark, z, R, wrap_innovation=True, heading=True, r_as_sd=False, constant=True):
    """A student's answer, written independently of the reference; the flags make the typical mistakes."""
    dx, dy = landmark[0] - x[:, 0], landmark[1] - x[:, 1]
    bearing = np.arctan2(dy, dx) - (x[:, 2] if heading else 0.0)
    bearing = np.angle(np.exp(1j * bearing))
    nu_b = z[1] - bearing
    if wrap_innovation:
        nu_b = np.angle(np.exp(1j * nu_b))
    nu = np.stack([z[0] - np.sqrt(dx**2 + dy**2), nu_b], axis=1)
    cov = R @ R if r_as_sd else R
    out = -0.5 * np.sum(nu @ np.linalg.inv(cov) * nu, axis=1)
    return out - np.log(2 * np.pi) - 0.5 * np.log(np.linalg.det(cov)) if constant else out


def test_range_bearing_log_weights_reference_passes_and_matches_the_engine():
    from pfcourse.book.exercises import RANGE_BEARING_LANDMARK, RANGE_BEARING_R, RANGE_BEARING_Z, range_bearing_log_weights
    from pfcourse.scenarios.robot.scenario import RobotModel

    assert check_range_bearing_log_weights(robot_log_weights).ok, str(check_range_bearing_log_weights(robot_log_weights))
    x = np.random.default_rng(3).normal([1.0, -50.0, 0.0], [0.5, 0.5, 0.05], size=(30, 3))
    model = RobotModel(RANGE_BEARING_LANDMARK[None], np.zeros((2, 3)), np.eye(3), RANGE_BEARING_R)
    np.testing.assert_allclose(range_bearing_log_weights(x, RANGE_BEARING_LANDMARK, RANGE_BEARING_Z, RANGE_BEARING_R),
                               model.log_likelihood(x, np.r_[0.0, RANGE_BEARING_Z], 1), rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"wrap_innovation": False}, "not wrapped to (-pi, pi]"),
    ({"heading": False}, "without subtracting the particle's heading"),
    ({"r_as_sd": True}, "read as a matrix of standard deviations"),
    ({"constant": False}, "normalising term"),
])
def test_each_typical_range_bearing_mistake_gets_its_own_sentence(mistake, says):
    report = check_range_bearing_log_weights(lambda x, l, z, R: robot_log_weights(x, l, z, R, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_odd_range_bearing_answers_are_named():
    assert "differ from log N(nu; 0, R)" in check_range_bearing_log_weights(
        lambda x, l, z, R: 2 * robot_log_weights(x, l, z, R)).problems[0]
    assert "shape" in check_range_bearing_log_weights(lambda x, l, z, R: np.zeros(3)).problems[0]
    assert "returned None" in check_range_bearing_log_weights(lambda x, l, z, R: None).problems[0]


def robot_jacobian(state, landmark, offset_sign=1.0, heading=-1.0, range_power=0.5, swapped=False):
    """A student's H, written independently; the keywords make the typical mistakes."""
    dx, dy = offset_sign * (landmark[0] - state[0]), offset_sign * (landmark[1] - state[1])
    q = dx**2 + dy**2
    b = [-dx / q, dy / q] if swapped else [dy / q, -dx / q]
    return np.array([[-dx / q**range_power, -dy / q**range_power, 0.0], [b[0], b[1], heading]])


def test_range_bearing_jacobian_reference_and_finite_differences_pass():
    from pfcourse.scenarios.robot.kalman import measurement_jacobian
    from pfcourse.scenarios.robot.scenario import range_bearing

    def central_difference(state, landmark, h=1e-6):
        cols = []
        for i in range(3):
            e = np.zeros(3)
            e[i] = h
            d = range_bearing(state + e, landmark) - range_bearing(state - e, landmark)
            d[1] = np.angle(np.exp(1j * d[1]))
            cols.append(d / (2 * h))
        return np.array(cols).T

    for fn in (robot_jacobian, measurement_jacobian, central_difference):
        assert check_range_bearing_jacobian(fn).ok, str(check_range_bearing_jacobian(fn))


@pytest.mark.parametrize("mistake, says", [
    ({"offset_sign": -1.0}, "signs of the position columns are reversed"),
    ({"heading": 1.0}, "d bearing / d theta is +1"),
    ({"range_power": 1.0}, "divides by q"),
    ({"swapped": True}, "swaps dx and dy"),
])
def test_each_typical_jacobian_mistake_gets_its_own_sentence(mistake, says):
    report = check_range_bearing_jacobian(lambda s, l: robot_jacobian(s, l, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_odd_jacobians_are_named():
    assert "differs from dh/dx" in check_range_bearing_jacobian(lambda s, l: 2 * robot_jacobian(s, l)).problems[0]
    assert "shape" in check_range_bearing_jacobian(lambda s, l: robot_jacobian(s, l).T).problems[0]


# --- the smoothing chapter: check_backward_weights ---------------------------------------------

def student_backward_weights(k, particles, weights, smoothed_next, log_transition, *, forget_filter_weight=False,
                             wrong_axis=False, wrong_time=False):
    """A student's FFBSm backward step written in the linear domain, with the typical mistakes as switches."""
    step = k - 1 if wrong_time else k
    f = np.exp(log_transition(particles[step + 1], particles[step]))  # f[j, i] = f(x_{k+1}^j | x_k^i)
    w = weights[step]
    predictive = (f * w[None, :]).sum(axis=0 if wrong_axis else 1)  # p(x_{k+1}^j | z_{0:k})
    if wrong_axis:
        s = (smoothed_next[:, None] * f / predictive[None, :]).sum(axis=0)
    else:
        s = (smoothed_next[:, None] * f / predictive[:, None]).sum(axis=0)
    if not forget_filter_weight:
        s = weights[k] * s
    return s / s.sum()


def test_the_reference_backward_weights_pass_and_match_ffbsm():
    from pfcourse.book.exercises import BACKWARD_K, _backward_case, backward_weights, check_backward_weights
    from pfcourse.smoothing import ffbsm

    report = check_backward_weights(student_backward_weights)
    assert report.ok, str(report)
    particles, weights, smoothed_next, log_transition = _backward_case()
    k = BACKWARD_K
    # the package's FFBSm, started at k + 1 from the same smoothed weights, gives the same step
    last = weights.copy()
    last[k + 1] = smoothed_next
    s = ffbsm(particles[k:k + 2], last[k:k + 2], lambda new, old, _: log_transition(new, old))
    np.testing.assert_allclose(s.weights[0], backward_weights(k, particles, weights, smoothed_next, log_transition),
                               rtol=1e-12)


@pytest.mark.parametrize("mistake, says", [
    ({"forget_filter_weight": True}, "the filter weight W_k^i is missing"),
    ({"wrong_axis": True}, "summed over the wrong axis"),
    ({"wrong_time": True}, "taken at the wrong time"),
])
def test_each_typical_backward_weights_mistake_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_backward_weights

    report = check_backward_weights(lambda *a: student_backward_weights(*a, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_odd_backward_weights_are_named():
    from pfcourse.book.exercises import check_backward_weights

    assert "shape (29,)" in check_backward_weights(lambda k, p, w, s, f: np.ones(29) / 29).problems[0]
    assert "not " in check_backward_weights(lambda k, p, w, s, f: w[k]).problems[0]
    assert "raised ZeroDivisionError" in str(check_backward_weights(lambda *a: 1 / 0))
    assert "normalise them" in check_backward_weights(lambda *a: 2 * student_backward_weights(*a)).problems[0]
