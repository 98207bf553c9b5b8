"""Part V's chapter exercises added by the first-text pass: the fully adapted likelihood estimator
(likelihood) and the fixed-lag smoother (smoothing). The reference passes, each typical mistake gets its
own sentence, the generator is checked."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import adapted_log_likelihood, check_adapted_likelihood
from pfcourse.book.exercises.part5 import ADAPTED_A, ADAPTED_Q, ADAPTED_R, adapted_data, scalar_kalman_log_likelihood


def adapted_student(z, n, rng, a, q, r, mistake=None):
    """The fully adapted filter as a student writes it (systematic resampling), one mistake switched on."""
    draw = np.random if mistake == "global" else rng
    x = draw.standard_normal(n)
    s2 = 1 / (1 / q**2 + 1 / r**2)
    total = 0.0
    for zk in z:
        if mistake == "bootstrap":
            x = a * x + q * draw.standard_normal(n)
            log_w = -0.5 * (np.log(2 * np.pi * r**2) + (zk - x) ** 2 / r**2)
        else:
            var = q**2 if mistake == "q_only" else q**2 + r**2
            log_w = -0.5 * (np.log(2 * np.pi * var) + (zk - a * x) ** 2 / var)
        if mistake == "mean_log":
            total += log_w.mean()
        elif mistake == "log_sum":
            total += logsumexp(log_w)
        else:
            total += logsumexp(log_w) - np.log(n)
        w = np.exp(log_w - logsumexp(log_w))
        u = (np.arange(n) + draw.random()) / n
        x = x[np.minimum(np.searchsorted(np.cumsum(w), u), n - 1)]
        if mistake == "prior_move":
            x = a * x + q * draw.standard_normal(n)
        elif mistake != "bootstrap":
            x = s2 * (a * x / q**2 + zk / r**2) + np.sqrt(s2) * draw.standard_normal(n)
    return total


def test_the_references_pass():
    assert check_adapted_likelihood(adapted_log_likelihood).ok
    report = check_adapted_likelihood(adapted_student, seed=7)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ("bootstrap", "as noisy as a bootstrap"),
    ("log_sum", "K log N too large"),
    ("mean_log", "Jensen"),
    ("q_only", "q^2 + r^2 given x_(k-1)"),
    ("prior_move", "p(x_k | x_(k-1), z_k)"),
    ("global", "NumPy's global generator"),
])
def test_each_typical_mistake_of_the_adapted_filter_gets_its_own_sentence(mistake, says):
    report = check_adapted_likelihood(lambda *args: adapted_student(*args, mistake=mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


@pytest.mark.parametrize("feed, says", [
    (lambda rng: np.random.default_rng(), "same seed gave different"),
    (lambda rng: np.random.default_rng(7), "whatever the generator's seed"),
])
def test_a_generator_of_its_own_is_named_in_the_adapted_filter(feed, says):
    report = check_adapted_likelihood(lambda z, n, rng, a, q, r: adapted_student(z, n, feed(rng), a, q, r))
    assert not report.ok and says in report.problems[0], str(report)


def test_the_adapted_estimate_is_unbiased_and_far_less_noisy_than_the_bootstrap():
    """E[p^] = p on the log scale (mean + var/2 near log p) and the spread is a fraction of the bootstrap's."""
    z = adapted_data()
    exact = scalar_kalman_log_likelihood(z, ADAPTED_A, ADAPTED_Q, ADAPTED_R)
    args = (ADAPTED_A, ADAPTED_Q, ADAPTED_R)
    ad = np.array([adapted_log_likelihood(z, 100, np.random.default_rng(s), *args) for s in range(200)])
    bs = np.array([adapted_log_likelihood(z, 100, np.random.default_rng(s), *args, "bootstrap") for s in range(200)])
    assert abs(ad.mean() + ad.var(ddof=1) / 2 - exact) < 5 * ad.std(ddof=1) / np.sqrt(200) + 0.02
    # with r = 1.5 > q the bootstrap's spread is about 1.7 times the adapted one's; the checker flags 1.3
    assert ad.std(ddof=1) < 0.75 * bs.std(ddof=1)


def test_the_checker_leaves_numpys_global_state_alone():
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    check_adapted_likelihood(lambda *args: adapted_student(*args, mistake="global"))
    assert np.random.random() == expected


def lag_student(particles, weights, ancestors, lag, mistake=None):
    """The fixed-lag smoother as a student writes it, one mistake switched on."""
    T = len(weights) - 1
    means = []
    for k in range(T + 1):
        t = min(k + lag, T)
        if mistake == "end_not_clipped" and k + lag > T:
            means.append(weights[k] @ particles[k])
            continue
        idx = np.arange(weights.shape[1])
        last = k + 1 if mistake == "one_step_short" else k
        for j in range(t, last, -1):
            idx = ancestors[j - 1][idx] if mistake == "shifted_ancestors" else ancestors[j][idx]
        if mistake == "no_ancestry":
            means.append(weights[t] @ particles[t])
        elif mistake == "filter_weights":
            means.append(weights[k] @ particles[k][idx])
        else:
            means.append(weights[t] @ particles[k][idx])
    return np.array(means)


def test_the_fixed_lag_reference_passes_and_agrees_with_the_package():
    from pfcourse.book.exercises import check_fixed_lag, fixed_lag_reference
    from pfcourse.book.exercises.part5 import _fixed_lag_case
    from pfcourse.smoothing import fixed_lag_means
    assert check_fixed_lag(lag_student).ok, str(check_fixed_lag(lag_student))
    particles, weights, ancestors = _fixed_lag_case()
    for lag in (0, 2, 3, 20):
        assert np.allclose(fixed_lag_reference(particles, weights, ancestors, lag),
                           fixed_lag_means(particles, weights, ancestors, lag))


@pytest.mark.parametrize("mistake, says", [
    ("filter_weights", "carry THEIR weights"),
    ("no_ancestry", "follow each one's ancestor indices"),
    ("one_step_short", "one step too few"),
    ("shifted_ancestors", "ancestors[j - 1] where ancestors[j] belongs"),
    ("end_not_clipped", "min(k + L, T)"),
])
def test_each_typical_mistake_of_the_fixed_lag_smoother_gets_its_own_sentence(mistake, says):
    from pfcourse.book.exercises import check_fixed_lag
    report = check_fixed_lag(lambda *args: lag_student(*args, mistake=mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_the_fixed_lag_checker_names_a_wrong_shape_and_none():
    from pfcourse.book.exercises import check_fixed_lag
    assert "not (8, 2)" in check_fixed_lag(lambda p, w, a, lag: np.zeros((8, 3))).problems[0]
    assert "returned None" in check_fixed_lag(lambda p, w, a, lag: None).problems[0]
