"""The exercise checkers accept correct code and name what is wrong in typical mistakes."""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from pfcourse.exercises import check_resampler, check_weight_update
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
