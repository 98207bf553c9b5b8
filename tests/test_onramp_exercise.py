"""The on-ramp's exercise checker (pfcourse.book.exercises.onramp): the reader's particle filter for two
beacons, checked against the exact grid. It accepts the reference on every seed tried, names each
typical mistake in its own sentence, and requires the filter to draw from the generator it is given."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises import (INFLATION, TWO_BEACONS, check_two_beacon_filter, two_beacon_case,
                                two_beacon_grid)


def two_beacons(z, n, rng, model, *, one_beacon=False, no_noise=False, sd_as_variance=False, unweighted=False,
                use_nan=False, mean_after=False, global_rng=False, own_rng=False, fixed_seed=False,
                wrong_shape=False, nan_as_zero=False, carried=False, tenth=False):
    """The reference solution; each flag changes one line, as a reader's typical mistake would."""
    if global_rng:
        rng = np.random  # the legacy global generator has the same methods
    elif own_rng:
        rng = np.random.default_rng()
    elif fixed_seed:
        rng = np.random.default_rng(1)
    beacons = np.asarray(model["beacons"])
    sd = model["range_sd"] ** 2 if sd_as_variance else model["range_sd"]
    if tenth:  # a filter silently using a tenth of its particles
        n = n // 10
    x = rng.uniform(*model["rail"], n)
    means = []
    log_w = np.zeros(n)
    for zk in z:
        x = x + model["speed"] + (0.0 if no_noise else model["motion_sd"]) * rng.standard_normal(n)
        if not carried:
            log_w = np.zeros(n)
        if nan_as_zero:
            zk = np.nan_to_num(zk)
        for j in range(1 if one_beacon else len(beacons)):
            if use_nan or not np.isnan(zk[j]):
                log_w += -0.5 * ((zk[j] - np.hypot(x - beacons[j], model["offset"])) / sd) ** 2
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        if not mean_after:
            means.append(x.mean() if unweighted else w @ x)
        picked = rng.choice(n, size=n, p=w)
        x, log_w = x[picked], log_w[picked]
        if mean_after:
            means.append(x.mean())
    return np.array(means[:-1] if wrong_shape else means)


def report_of(**mistake):
    return check_two_beacon_filter(lambda z, n, rng, model: two_beacons(z, n, rng, model, **mistake))


@pytest.mark.parametrize("seed", range(8))
def test_the_reference_passes_on_every_seed_tried(seed):
    for mean_after in (False, True):  # the mean of the resampled cloud is right too
        report = check_two_beacon_filter(
            lambda z, n, rng, model: two_beacons(z, n, rng, model, mean_after=mean_after), seed=seed)
        assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ({"one_beacon": True}, "reads beacon A only"),
    ({"no_noise": True}, "without motion noise"),
    ({"sd_as_variance": True}, "range_sd**2 where range_sd goes"),
    ({"unweighted": True}, "plain average of the moved particles"),
    ({"use_nan": True}, "missing reading (NaN) of beacon B"),
    ({"nan_as_zero": True}, "reads a lost reading (NaN) as a range of 0 m"),
    ({"carried": True}, "carries the log-weights over after resampling"),
    ({"tenth": True}, "does every step use all n_particles particles"),
    ({"global_rng": True}, "NumPy's global generator"),
    ({"own_rng": True}, "same seed gave different means"),
    ({"fixed_seed": True}, "different seeds gave the same means"),
    ({"wrong_shape": True}, "one mean per step"),
])
def test_each_typical_mistake_gets_its_own_sentence(mistake, says):
    report = report_of(**mistake)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


@pytest.mark.parametrize("seed", range(3))
def test_the_mistakes_are_named_on_other_seeds_too(seed):
    for mistake, says in [("one_beacon", "beacon A only"), ("no_noise", "without motion noise"),
                          ("sd_as_variance", "range_sd**2"), ("unweighted", "plain average")]:
        report = check_two_beacon_filter(
            lambda z, n, rng, model: two_beacons(z, n, rng, model, **{mistake: True}), seed=seed + 10)
        assert len(report.problems) == 1 and says in report.problems[0], str(report)


def test_the_checker_leaves_the_global_generator_as_it_found_it():
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    report_of(global_rng=True)
    assert np.random.random() == expected


def test_the_grid_is_exact_to_far_below_the_tolerance():
    """Halving the cells moves the grid's means by far less than the smallest tolerance of the check."""
    z = two_beacon_case()
    fine, var = two_beacon_grid(z, cell=0.005)
    coarse, _ = two_beacon_grid(z)
    smallest_tolerance = np.sqrt(INFLATION * var / 5000).min()
    assert np.abs(fine - coarse).max() < 0.01 * smallest_tolerance


def test_the_stored_error_variance_is_what_the_reference_shows_on_other_seeds():
    """Over 100 other seeds, the reference's error variance per step (mean after resampling, the larger),
    in units of var_k / N, agrees with the stored ERROR_VARIANCE within the chi-square bounds of a
    100-run estimate (two-sided 0.999 at each step, Bonferroni over the steps), and exceeds 1: resampling
    adds variance, so a bound from a plain sample would be too tight."""
    from scipy.stats import chi2

    from pfcourse.book.exercises.onramp import ERROR_VARIANCE

    z = two_beacon_case()
    mean, var = two_beacon_grid(z)
    n, runs = 5000, 100
    errors = np.array([(two_beacons(z, n, np.random.default_rng(30_000 + s), TWO_BEACONS, mean_after=True) - mean)
                       / np.sqrt(var / n) for s in range(runs)])
    ratio = errors.var(axis=0, ddof=1) / np.asarray(ERROR_VARIANCE)
    alpha = 0.001 / len(ERROR_VARIANCE)
    assert np.all(ratio < chi2.isf(alpha / 2, runs - 1) / (runs - 1)), ratio
    assert np.all(ratio > chi2.ppf(alpha / 2, runs - 1) / (runs - 1)), ratio
    assert min(ERROR_VARIANCE) > 1.0
    assert INFLATION < 12.0  # tighter than the earlier bound, set by measurement alone


def test_a_filter_using_a_tenth_of_its_particles_fails_on_every_seed_tried():
    for seed in range(5):
        report = check_two_beacon_filter(lambda z, n, rng, model: two_beacons(z, n, rng, model, tenth=True),
                                         seed=seed)
        assert len(report.problems) == 1 and "scatter" in report.problems[0], str(report)


def test_the_bonferroni_z_is_the_family_wise_rate_over_the_steps():
    from scipy.stats import norm

    from pfcourse.book.exercises.onramp import ALPHA, tolerance_z

    z16 = tolerance_z(16)
    assert 2 * norm.sf(z16) * 16 == pytest.approx(ALPHA)
    assert tolerance_z(32) > z16


def test_an_exception_and_an_empty_answer_are_reported_not_raised():
    def broken(z, n, rng, model):
        raise KeyError("beacon")

    assert "raised KeyError" in check_two_beacon_filter(broken).problems[0]
    empty = check_two_beacon_filter(lambda z, n, rng, model: None)
    assert empty.problems == ["the function returned None: write the filter and return its means, one per step"]


def test_underflowing_weights_are_named():
    def linear(z, n, rng, model):
        x = rng.uniform(*model["rail"], n)
        means = []
        for zk in z:
            x = x + model["speed"] + model["motion_sd"] * rng.standard_normal(n)
            w = np.ones(n)
            for j in range(2):
                if not np.isnan(zk[j]):
                    w *= np.exp(-0.5 * ((zk[j] - np.hypot(x - model["beacons"][j], model["offset"]))
                                        / model["range_sd"]) ** 2)
            w /= w.sum()
            means.append(w @ x)
            x = x[rng.choice(n, size=n, p=w)]
        return np.array(means)

    far = two_beacon_case()
    far[5, 0] = 80.0  # a reading no particle explains: every linear weight underflows
    report = check_two_beacon_filter(linear, z=far)
    assert len(report.problems) == 1 and "underflow" in report.problems[0], str(report)
