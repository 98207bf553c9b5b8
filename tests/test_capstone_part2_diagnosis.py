"""Part II's capstone checker tells apart the mistakes that make a bearing filter's means vary over seeds: one
random-walk step shared by the whole cloud, atan2's arguments swapped, no resampling (student_p2 review, item 2).
Each gets its own sentence; the reference and a correct filter that averages after resampling pass."""
import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import bearing_bootstrap, check_bearing_filter
from pfcourse.book.exercises.capstones import BearingModel, _bearing_spread_cause


def wrap(a):
    return a - 2 * np.pi * np.ceil((a - np.pi) / (2 * np.pi))


def filter_with(mistake=None):
    """A bootstrap filter for bearing-only tracking as a student writes it, one mistake switched on."""

    def fn(z, observer, n, rng, model):
        p = np.asarray(model.m0) + model.s0 * rng.standard_normal((n, 2))
        means, log_lik = np.empty((len(z), 2)), 0.0
        for k, zk in enumerate(z):
            step = rng.standard_normal((1 if mistake == "shared" else n, 2))
            p = p + model.q * step
            d = p - observer[k]
            h = np.arctan2(d[:, 0], d[:, 1]) if mistake == "swapped" else np.arctan2(d[:, 1], d[:, 0])
            log_w = -0.5 * (wrap(zk - h) / model.sigma) ** 2 - np.log(np.sqrt(2 * np.pi) * model.sigma)
            log_lik += logsumexp(log_w) - np.log(n)
            w = np.exp(log_w - logsumexp(log_w))
            if mistake == "no_resampling":
                means[k] = w @ p
                p = p[rng.choice(n, size=n, p=w)] if k == 0 else p  # resamples once, then never
                continue
            a = rng.choice(n, size=n, p=w)
            # "after": the plain mean of the resampled copies, the same estimate with a little more noise
            means[k] = p[a].mean(axis=0) if mistake == "mean_after" else w @ p
            p = p[a]
        return means, log_lik

    return fn


def test_the_reference_and_a_mean_taken_after_resampling_pass():
    assert check_bearing_filter(bearing_bootstrap).ok
    report = check_bearing_filter(filter_with("mean_after"))
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says, not_says", [
    ("shared", "all move by the same random-walk step", "atan2"),
    ("swapped", "atan2's arguments swapped", "resample"),
])
def test_each_cause_of_a_wide_spread_gets_its_own_sentence(mistake, says, not_says):
    report = check_bearing_filter(filter_with(mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0] and not_says not in report.problems[0], report.problems[0]


def test_the_probes_pass_a_correct_filter_to_the_resampling_sentence():
    """A correct filter passes both probes (its cloud goes east, its mean hardly moves on blind bearings), so
    what is left for a wide spread is the missing resampling; the probes run at the checker's N and seed."""
    for fn in (bearing_bootstrap, filter_with("no_resampling")):
        assert "resample after each weighting" in _bearing_spread_cause(fn, 2000, 0, 10.0)


def test_an_answer_the_probes_cannot_run_gets_the_symptom():
    def fails_on_one_step(z, observer, n, rng, model):
        if len(z) < 40:
            raise ValueError("expects 40 bearings")
        return bearing_bootstrap(z, observer, n, rng, model)

    assert "resample after each weighting" in _bearing_spread_cause(fails_on_one_step, 2000, 0, 10.0)


def test_the_probes_draw_no_global_random_numbers():
    np.random.seed(3)
    expected = np.random.random()
    np.random.seed(3)
    _bearing_spread_cause(filter_with("shared"), 2000, 0, 10.0)
    assert np.random.random() == expected
    assert BearingModel().sigma == 0.05  # the blind probe's model does not change the capstone's
