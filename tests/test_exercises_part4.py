"""Part IV's variant exercises: the NIS check with missing readings (chapter 23) and the likelihood of
an anonymous range-only reading (chapter 24). Each checker passes a reference written as a student
would, names each typical mistake in its own sentence, and explains shapes and other errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises import (
    MISSING_NIS_MISTAKES,
    RANGE_ONLY_MISTAKES,
    _missing_nis_case,
    check_missing_nis,
    check_range_only_anonymous,
    missing_nis_consistency,
    range_only_log_likelihood,
)


def student_nis(innovations, covariances):
    """A reference as a student writes it: loops over the steps, nanmean over the runs with a reading."""
    R, K, m = innovations.shape
    average, low, high = np.full(K, np.nan), np.full(K, np.nan), np.full(K, np.nan)
    inside = []
    for k in range(K):
        runs = [r for r in range(R) if not np.isnan(innovations[r, k]).any()]
        if not runs:
            continue
        values = [innovations[r, k] @ np.linalg.solve(covariances[r, k], innovations[r, k]) for r in runs]
        n = len(runs)
        average[k] = np.mean(values)
        low[k], high[k] = stats.chi2.ppf([0.025, 0.975], n * m) / n
        inside.append(low[k] <= average[k] <= high[k])
    return average, low, high, float(np.mean(inside))


def test_missing_nis_reference_passes_and_matches_the_package():
    report = check_missing_nis(student_nis)
    assert report.ok, str(report)
    y, S = _missing_nis_case()
    ref = missing_nis_consistency(y, S)
    mine = student_nis(y, S)
    for a, b in zip(mine[:3], ref[:3]):
        np.testing.assert_allclose(a, b, rtol=1e-12, equal_nan=True)
    assert np.isnan(ref[0][10:15]).all() and not np.isnan(ref[0][:10]).any()
    # the over-confident spell (steps 40-49) is above its band at most steps, the rest mostly inside
    assert np.mean(ref[0][40:50] > ref[2][40:50]) >= 0.8 and 0.75 <= ref[3] < 0.95


@pytest.mark.parametrize("mistake", list(MISSING_NIS_MISTAKES))
def test_missing_nis_mistakes_are_named(mistake):
    report = check_missing_nis(lambda y, S: missing_nis_consistency(y, S, mistake=mistake))
    assert not report.ok
    assert report.problems == [f"your function computes a known mistake: {MISSING_NIS_MISTAKES[mistake]}"]
    # each mistake differs from the reference and from every other mistake on the checker's case
    y, S = _missing_nis_case()
    got = missing_nis_consistency(y, S, mistake=mistake)
    for other in [None, *MISSING_NIS_MISTAKES]:
        if other != mistake:
            ref = missing_nis_consistency(y, S, mistake=other)
            same = all(np.allclose(a, b, equal_nan=True) for a, b in zip(got[:3], ref[:3])) and got[3] == ref[3]
            assert not same, (mistake, other)


def test_missing_nis_shapes_and_other_errors_are_explained():
    def per_run(y, S):
        average, low, high, f = missing_nis_consistency(y, S)
        return np.tile(average, (2, 1)), low, high, f

    assert "one value per step" in check_missing_nis(per_run).problems[0]
    assert "not (average_nis" in check_missing_nis(lambda y, S: 3.0).problems[0]
    assert "returned None" in check_missing_nis(lambda y, S: None).problems[0]
    assert "raised ZeroDivisionError" in check_missing_nis(lambda y, S: 1 / 0).problems[0]

    def zeros_not_nan(y, S):
        average, low, high, f = missing_nis_consistency(y, S)
        return np.nan_to_num(average), low, high, f

    assert "NaN exactly at the steps" in check_missing_nis(zeros_not_nan).problems[0]

    def bounds_excluded(y, S):
        average, low, high, _ = missing_nis_consistency(y, S)
        seen = ~np.isnan(average)
        return average, low, high, float(np.mean(((average > low) & (average < high))[seen]) - 0.01)

    assert "bounds included" in check_missing_nis(bounds_excluded).problems[0]


def student_range_only(x, r, landmarks, var, p_detect, clutter_rate, max_range):
    dist = np.linalg.norm(landmarks[None, :, :] - x[:, None, :2], axis=2)
    log_gauss = -0.5 * (r - dist) ** 2 / var - 0.5 * np.log(2 * np.pi * var)
    with np.errstate(divide="ignore"):
        clutter = np.log((1 - p_detect) * clutter_rate / max_range)
    terms = np.column_stack([np.full(len(x), clutter), np.log(p_detect / len(landmarks)) + log_gauss])
    return logsumexp(terms, axis=1) - clutter_rate


def test_range_only_reference_passes():
    report = check_range_only_anonymous(student_range_only)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(RANGE_ONLY_MISTAKES))
def test_range_only_mistakes_are_named(mistake):
    def wrong(x, r, landmarks, var, p_detect, clutter_rate, max_range):
        return range_only_log_likelihood(x, r, landmarks, var, p_detect, clutter_rate, max_range, mistake=mistake)

    report = check_range_only_anonymous(wrong)
    assert report.problems == [f"your function computes a known mistake: {RANGE_ONLY_MISTAKES[mistake]}"]


def test_range_only_reduces_to_a_gaussian_and_other_errors_are_explained():
    """One landmark, P_D = 1, no clutter: the log-density of N(r; distance, var)."""
    x = np.array([[3.0, 4.0, 0.2], [0.0, 0.0, 0.0]])
    got = range_only_log_likelihood(x, 4.0, np.zeros((1, 2)), 0.25, 1.0, 0.0, 30.0)
    np.testing.assert_allclose(got, stats.norm(np.array([5.0, 0.0]), 0.5).logpdf(4.0), rtol=1e-12)
    assert "shape" in check_range_only_anonymous(lambda *a: np.zeros(3)).problems[0]
    assert "raised" in check_range_only_anonymous(lambda *a: 1 / 0).problems[0]
    report = check_range_only_anonymous(lambda x, *a: student_range_only(x, *a) + 0.1)
    assert "check each term" in report.problems[0]


# --- the capstone (exercise 24.3): a whole particle filter of a target in clutter ----------------------------
from pfcourse.book.exercises import CLUTTER_PF_MISTAKES, check_clutter_pf, clutter_target_posterior  # noqa: E402
from pfcourse.book.exercises.part4 import CLUTTER_PF_DATA, clutter_pf_reference, clutter_target_readings  # noqa: E402


def student_clutter_pf(readings, n, rng, r=1.0, resample_every_step=False, mistake=None):
    """As a student writes it: systematic resampling when the ESS falls below n/2, weights carried over;
    ``mistake`` plants one of the mistakes a student makes (test_planted_clutter_pf_mistakes_are_named)."""
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    Q = 0.5 * np.array([[1 / 3, 1 / 2], [1 / 2, 1.0]])
    p_d, lam, length = 0.7, 3.0, 30.0
    miss = {"miss_without_rate": (1 - p_d) / length, "miss_without_one_minus_pd": lam / length,
            "density_not_divided": (1 - p_d) * lam}.get(mistake, (1 - p_d) * lam / length)
    x = rng.multivariate_normal([10.0, 0.5], np.diag([4.0, 1.0]), size=n)
    log_w = np.full(n, -np.log(n))
    means = []
    for k, z in enumerate(readings):
        if mistake != "no_first_prediction" or k > 0:
            x = x @ F.T + (0 if mistake == "no_process_noise" else rng.multivariate_normal(np.zeros(2), Q, size=n))
        predicted_mean = np.exp(log_w) @ x[:, 0]
        g = stats.norm.logpdf(z[None, :], loc=x[:, :1], scale=np.sqrt(r))
        detect = {"detect_without_pd": 1.0, "detect_over_n": p_d / max(len(z), 1)}.get(mistake, p_d)
        terms = np.column_stack([np.full(n, np.log(miss)), np.log(detect) + g])
        if mistake == "no_miss" and len(z):
            terms = terms[:, 1:]
        log_w = log_w + (g.sum(axis=1) if mistake == "all_readings_target" else logsumexp(terms, axis=1))
        log_w -= logsumexp(log_w)
        w = np.exp(log_w)
        means.append(predicted_mean if mistake == "prior_mean" else w @ x[:, 0])
        if resample_every_step or 1 / np.sum(w**2) < n / 2:
            idx = np.searchsorted(np.cumsum(w), (rng.random() + np.arange(n)) / n)
            x, log_w = x[np.minimum(idx, n - 1)], np.full(n, -np.log(n))
    return np.array(means)


def test_clutter_pf_reference_and_a_students_filter_pass():
    assert check_clutter_pf(student_clutter_pf).ok, str(check_clutter_pf(student_clutter_pf))
    assert check_clutter_pf(lambda r, n, rng: clutter_pf_reference(r, n, rng)).ok


def test_the_exact_posterior_is_the_kalman_filter_without_clutter_and_is_converged():
    """With one reading per step, every history but 'that reading is the target's' pruned, the mixture is
    a Kalman filter; and pruning at 1e-12 moves the answer by less than 1e-6 of a standard deviation."""
    from pfcourse.book.exercises import part4

    readings = clutter_target_readings(CLUTTER_PF_DATA[0])
    fine, sd = clutter_target_posterior(readings, prune=1e-16)
    coarse, _ = clutter_target_posterior(readings)
    assert np.max(np.abs(fine - coarse) / sd) < 1e-6
    saved = dict(part4.CLUTTER_TARGET)
    try:
        part4.CLUTTER_TARGET.update(p_detect=1.0 - 1e-12, clutter_rate=1e-12)
        z = [np.array([11.0 + k]) for k in range(5)]
        mean, sd = clutter_target_posterior(z)
        F, Q = part4._clutter_target_model()
        m, P = np.array([10.0, 0.5]), np.diag([4.0, 1.0])
        for k, zk in enumerate(z):
            m, P = F @ m, F @ P @ F.T + Q
            K = P[:, 0] / (P[0, 0] + 1.0)
            m, P = m + K * (zk[0] - m[0]), P - np.outer(K, P[0])
            assert abs(mean[k] - m[0]) < 1e-9 and abs(sd[k] - np.sqrt(P[0, 0])) < 1e-9
    finally:
        part4.CLUTTER_TARGET.clear()
        part4.CLUTTER_TARGET.update(saved)


@pytest.mark.parametrize("mistake", list(CLUTTER_PF_MISTAKES))
def test_clutter_pf_mistakes_are_named(mistake):
    report = check_clutter_pf(lambda r, n, rng: clutter_pf_reference(r, n, rng, mistake))
    assert report.problems == [f"your function computes a known mistake: {CLUTTER_PF_MISTAKES[mistake]}"]


@pytest.mark.parametrize("mistake", ["miss_without_rate", "detect_without_pd", "no_first_prediction",
                                     "miss_without_one_minus_pd", "detect_over_n", "prior_mean", "no_miss",
                                     "density_not_divided", "no_process_noise"])
def test_planted_clutter_pf_mistakes_are_named(mistake):
    """The mistakes a reviewer planted in the chapter's solution, planted in a student's filter (systematic
    resampling at ESS < n/2, not the checker's own filter): each fails, with its own sentence."""
    report = check_clutter_pf(lambda r, n, rng: student_clutter_pf(r, n, rng, mistake=mistake))
    assert report.problems == [f"your function computes a known mistake: {CLUTTER_PF_MISTAKES[mistake]}"]


def test_an_unlisted_clutter_pf_mistake_is_not_given_a_wrong_name():
    """A filter whose reading noise is wrong (variance 2 for 1) makes no listed mistake: the report says how far
    it is from the exact posterior, without naming one."""
    report = check_clutter_pf(lambda r, n, rng: student_clutter_pf(r, n, rng, r=2.0))
    assert len(report.problems) == 1 and "posterior standard deviations" in report.problems[0], report.problems


def test_clutter_pf_draws_from_its_generator_and_other_errors_are_explained():
    def global_draws(readings, n, rng):
        return clutter_pf_reference(readings, n, np.random.default_rng(np.random.randint(1 << 30)))

    state = np.random.get_state()
    assert "global np.random" in check_clutter_pf(global_draws).problems[0]
    assert all(a == b for a, b in zip(state[1], np.random.get_state()[1]))  # the checker restores it
    fixed = check_clutter_pf(lambda r, n, rng: clutter_pf_reference(r, n, np.random.default_rng(5)))
    assert "another seed gave the same estimates" in fixed.problems[0]
    fresh = iter(range(100))
    drifting = check_clutter_pf(lambda r, n, rng: clutter_pf_reference(r, n, np.random.default_rng([next(fresh),
                                                                                                  int(rng.integers(9))])))
    assert "same seed gave different estimates" in drifting.problems[0]
    assert "shape" in check_clutter_pf(lambda r, n, rng: np.zeros(3)).problems[0]
    assert "raised" in check_clutter_pf(lambda r, n, rng: 1 / 0).problems[0]
    assert "not finite" in check_clutter_pf(lambda r, n, rng: clutter_pf_reference(r, n, rng) * np.nan).problems[0]
    wrong_noise = check_clutter_pf(lambda r, n, rng: student_clutter_pf(r, n, rng, r=9.0))
    assert "posterior standard deviations" in wrong_noise.problems[0]
