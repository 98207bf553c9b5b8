"""The exercise checkers accept correct code and name what is wrong in typical mistakes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.exercises import (check_ancestors, check_kalman, check_log_likelihood, check_optimal_proposal,
                                check_resampler, check_sis, check_weight_update)
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
    from pfcourse.exercises import KALMAN_CASE, ScalarModel, scalar_kalman
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
    from pfcourse.exercises import KALMAN_MISTAKES, scalar_kalman

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
    from pfcourse.exercises import PROPOSAL_MODEL, PROPOSAL_PARENTS, PROPOSAL_Z, scalar_optimal_proposal
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
    from pfcourse.exercises import check_landmark_update

    report = check_landmark_update(_landmark)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ({"no_robot": True}, "forgets the robot"),
    ({"s_without_r": True}, "misses the measurement noise"),
    ({"no_cov_update": True}, "covariance is not updated"),
    ({"loglik_with_r": True}, "uses R where it needs S"),
])
def test_landmark_update_mistakes_are_named(mistake, says):
    from pfcourse.exercises import check_landmark_update

    report = check_landmark_update(lambda *args, **kw: _landmark(*args, **kw, **mistake))
    assert not report.ok and says in str(report), str(report)


def test_landmark_update_bad_returns_are_reported():
    from pfcourse.exercises import check_landmark_update

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
    from pfcourse.exercises import check_apf_second_stage

    assert check_apf_second_stage(_second_stage).ok, str(check_apf_second_stage(_second_stage))


@pytest.mark.parametrize("mistake, says", [
    ("no_division", "first stage is not divided out"),
    ("own_index", "own first-stage value"),
    ("multiplied", "multiplied in again"),
    ("unnormalised", "not normalised"),
])
def test_second_stage_mistakes_are_named(mistake, says):
    from pfcourse.exercises import check_apf_second_stage

    report = check_apf_second_stage(lambda a, b, c: _second_stage(a, b, c, mistake))
    assert not report.ok and says in str(report), str(report)


def test_second_stage_bad_returns_are_reported():
    from pfcourse.exercises import check_apf_second_stage

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
    from pfcourse.exercises import LIKELIHOOD_CASES, LIKELIHOOD_H, LIKELIHOOD_R
    from pfcourse.landmarks.scenario import quadrant_scenario

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
    from pfcourse.exercises import LIKELIHOOD_MISTAKES, landmark_log_likelihood

    for mistake, why in LIKELIHOOD_MISTAKES.items():
        report = check_log_likelihood(lambda x, z, H, R, m=mistake: landmark_log_likelihood(x, z, H, R, m))
        assert report.problems == [f"your function computes a known mistake: {why}"], (mistake, str(report))
    half = check_log_likelihood(lambda x, z, H, R: 2 * cloud_log_likelihood(x, z, H, R))
    assert "the values differ from log N(z_s; H_s x, R_ss)" in half.problems[0], str(half)
    assert "shape (50, 1)" in check_log_likelihood(lambda x, z, H, R: np.zeros((len(x), 1))).problems[0]
    assert check_log_likelihood(lambda x, z, H, R: None).problems == [
        "the function returned None: compute and return one log-likelihood per particle"]
    assert "raised ZeroDivisionError" in str(check_log_likelihood(lambda x, z, H, R: 1 / 0))


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
    from pfcourse.exercises import BACKWARD_K, _backward_case, backward_weights, check_backward_weights
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
    from pfcourse.exercises import check_backward_weights

    report = check_backward_weights(lambda *a: student_backward_weights(*a, **mistake))
    assert not report.ok and len(report.problems) == 1
    assert says in report.problems[0], report.problems[0]


def test_odd_backward_weights_are_named():
    from pfcourse.exercises import check_backward_weights

    assert "shape (29,)" in check_backward_weights(lambda k, p, w, s, f: np.ones(29) / 29).problems[0]
    assert "not " in check_backward_weights(lambda k, p, w, s, f: w[k]).problems[0]
    assert "raised ZeroDivisionError" in str(check_backward_weights(lambda *a: 1 / 0))
    assert "normalise them" in check_backward_weights(lambda *a: 2 * student_backward_weights(*a)).problems[0]
