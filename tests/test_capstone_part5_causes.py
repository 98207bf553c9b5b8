"""Part V's capstone checker names a cause only when the evidence shows it (review smc_p5, item 1): the
transition variance written as sigma and the normaliser summed over the wrong axis get their own sentences, the
ancestral lines are named by their spread, a valid FFBSm that stores each cloud after resampling with equal
weights passes, and a mistake whose particle version does not reach its own limit gets the symptom alone."""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import SVModel, check_sv_smoother, sv_ffbsm, sv_grid_smoother
from pfcourse.book.exercises.capstones import SV_SMOOTHER_DATA_SEED, SV_STEPS, _worst_z


def smoother(y, n, rng, model, mistake=None):
    """A bootstrap filter and FFBSm, with one variant switched on."""
    x = model.sigma / np.sqrt(1 - model.phi ** 2) * rng.standard_normal(n)
    xs, log_ws, ancestors = [], [], []
    for yk in y:
        x = model.phi * x + model.sigma * rng.standard_normal(n)
        var = model.beta ** 2 * np.exp(x)
        log_w = -0.5 * (np.log(var) + yk ** 2 / var)
        log_w -= logsumexp(log_w)
        a = rng.choice(n, size=n, p=np.exp(log_w))
        if mistake == "after_resampling":  # valid: the resampled cloud, equal weights
            xs.append(x[a])
            log_ws.append(np.full(n, -np.log(n)))
        else:
            xs.append(x)
            log_ws.append(log_w)
        ancestors.append(a)
        x = x[a]
    if mistake == "naive":  # the ancestral lines of the last cloud
        idx, out = np.arange(n), np.empty(len(y))
        w = np.exp(log_ws[-1])
        for k in range(len(y) - 1, -1, -1):
            out[k] = w @ xs[k][idx]
            if k > 0:
                idx = ancestors[k - 1][idx]
        return out
    var = model.sigma if mistake == "sigma_variance" else model.sigma ** 2
    log_s = log_ws[-1]
    means = [np.exp(log_s) @ xs[-1]]
    for k in range(len(y) - 2, -1, -1):
        ell = -0.5 * (xs[k + 1][:, None] - model.phi * xs[k][None, :]) ** 2 / var
        if mistake == "wrong_axis":
            log_c = logsumexp(log_ws[k][None, :] + ell, axis=0)[None, :]
        else:
            log_c = logsumexp(log_ws[k][None, :] + ell, axis=1)[:, None]
        log_s = log_ws[k] + logsumexp(log_s[:, None] + ell - log_c, axis=0)
        log_s -= logsumexp(log_s)
        means.insert(0, np.exp(log_s) @ xs[k])
    return np.array(means)


def answer(mistake):
    return lambda y, n, rng, model: smoother(y, n, rng, model, mistake)


@pytest.mark.parametrize("mistake, says, n_runs", [
    ("sigma_variance", "variance sigma where", 20),
    ("wrong_axis", "summed over the wrong axis", 40),
    ("naive", "ancestral lines", 40),
])
def test_each_new_mistake_gets_its_own_sentence(mistake, says, n_runs):
    """Measured on seeds 0..n_runs - 1: ``sigma_variance`` (20 runs) its own worst z 3.8 against 5, the exact
    smoother's 31; ``wrong_axis`` (40) own z 3.3, exact 162; ``naive`` (40) not biased (worst z 3.3) but its
    means vary 4.3 times as much as FFBSm's over the steps, 6.0 times over the first ten, 1.5 over the last five
    (threshold 2.5, and 2.5 times the last five's)."""
    report = check_sv_smoother(answer(mistake), n_runs=n_runs)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


def test_clouds_stored_after_resampling_with_equal_weights_pass():
    """A valid FFBSm: its worst z on seeds 0-39 is 3.3 (3.5 at most over five blocks of 40), its spread 1.3 times
    the reference's (against 2.5)."""
    report = check_sv_smoother(answer("after_resampling"))
    assert report.ok, str(report)


def test_a_mistake_is_named_only_when_its_own_limit_matches():
    """The filter weights left out: its particle version at N = 300 lies far from its own large-N limit too
    (worst z 8.8 at 8 runs), so no mistake is named, only the symptom."""
    from test_capstones_part5 import student
    report = check_sv_smoother(lambda y, n, rng, model: student(y, n, rng, model, "no_filter_weights"), n_runs=8)
    assert not report.ok and "further than chance allows" in report.problems[0], str(report)


def test_the_reference_passes_with_margin_on_five_blocks_of_seeds():
    """The worst |z| of the reference over five blocks of 40 seeds (0-199) stays below 5 with margin (measured
    3.4); a seeded sample: the last block, recomputed (the first is the checker's own default run,
    tests/test_capstones_part5.py)."""
    model = SVModel()
    y = model.simulate(SV_STEPS, np.random.default_rng(SV_SMOOTHER_DATA_SEED))[1]
    exact = sv_grid_smoother(y, model)
    for block in (4,):
        m = np.array([sv_ffbsm(y, 300, np.random.default_rng(40 * block + r), model) for r in range(40)])
        se = m.std(axis=0, ddof=1) / np.sqrt(len(m))
        assert _worst_z(m, se, exact) < 4.0
