"""The cure's new parts (pfcourse.scenarios.maprobot.global_mcl): hysteresis, the belief's evidence with its admitted
strata, and the deterministic-mixture start; the defaults keep the cure before them (HAZARD) unchanged."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.errors import ParameterError
from pfcourse.studies import maprobot as study
from pfcourse.scenarios.maprobot import global_mcl as gm


def _strata(rng, bf):
    """A cloud of 300 moved particles and a stratum of 200 whose mean weight is ``bf`` times the cloud's."""
    moved, lw_m = rng.normal(size=(300, 3)), rng.normal(size=300)
    inj, lw_r = rng.normal(size=(200, 3)), rng.normal(size=200)
    lw_r += np.log(bf) + logsumexp(lw_m) - np.log(300) - (logsumexp(lw_r) - np.log(200))
    return moved, lw_m, inj, lw_r


def test_the_defaults_are_the_cure_before_hysteresis():
    assert gm.HAZARD.confirm == 0 and not gm.HAZARD.mixture_evidence and not gm.HAZARD.start_mixture
    assert gm.CURE == replace(gm.HAZARD, confirm=gm.CONFIRM, mixture_evidence=True)
    moved, lw_m, inj, lw_r = _strata(np.random.default_rng(0), 1e-3)
    x, lw, share, streak, log_z = gm.admit(moved, lw_m, inj, lw_r, 4e-3, 0, -1.5, gm.HAZARD)
    want_x, want_lw = gm._stratified([(1 - 4e-3, moved, lw_m), (4e-3, inj, lw_r)])
    assert np.array_equal(x, want_x) and np.array_equal(lw, want_lw) and log_z == -1.5 and 0 < share < 1e-4


@pytest.mark.parametrize("confirm", [1, 2, 3])
def test_a_stratum_takes_the_weight_only_at_its_confirm_th_win_in_a_row(confirm):
    rng = np.random.default_rng(1)
    s = replace(gm.HAZARD, confirm=confirm)
    eps = 4e-3
    streak, shares = 0, []
    # odds eps * BF / (1 - eps): BF = 1e4 wins (odds about 40), BF = 10 loses
    for bf in [1e4] * (confirm - 1) + [10.0] + [1e4] * confirm:
        moved, lw_m, inj, lw_r = _strata(rng, bf)
        x, lw, share, streak, _ = gm.admit(moved, lw_m, inj, lw_r, eps, streak, 0.0, s)
        shares.append(share)
        if share == 0.0:
            assert x is moved and lw is lw_m
    # the loss resets the streak: only the last of the final run of wins is admitted
    assert [sh > 0 for sh in shares] == [False] * (2 * confirm - 1) + [True]
    assert shares[-1] == pytest.approx(eps * 1e4 / (eps * 1e4 + 1 - eps), rel=1e-9)


def test_the_belief_s_evidence_counts_the_admitted_stratum():
    """log((1 - eps) Z + eps B Z) = log Z + log(1 - eps + eps B): the evidence the kidnap model gives the scan."""
    moved, lw_m, inj, lw_r = _strata(np.random.default_rng(2), 50.0)
    log_z = float(logsumexp(lw_m) - np.log(300))
    eps = 4e-3
    *_, plain = gm.admit(moved, lw_m, inj, lw_r, eps, 0, log_z, gm.HAZARD)
    *_, counted = gm.admit(moved, lw_m, inj, lw_r, eps, 0, log_z, replace(gm.HAZARD, mixture_evidence=True))
    assert plain == log_z
    assert counted == pytest.approx(log_z + np.log(1 - eps + eps * 50.0), abs=1e-9)


def test_the_mixture_start_weights_every_pose_by_the_mixture_density():
    grid, field = study.book_map(), study.field()
    run = study.simulate(0, 2)
    s = replace(gm.HAZARD, n_start=3000, n_start_scan=300, start_mixture=True)
    x, lw = gm.start_cloud(grid, field, run.scans[0], np.random.default_rng(3), s)
    assert x.shape == (3300, 3) and lw.shape == (3300,)
    # replay: the uniform poses, then the proposal's centres and draws, from the same generator
    rng = np.random.default_rng(3)
    x_u = grid.sample_free(3000, rng)
    c, log_v = gm.scan_centres(grid, field, run.scans[0], rng, s)
    assert np.array_equal(x[:3000], x_u)
    log_q = gm.kernel_log_density(x, c, log_v, gm.kernel_widths(s))
    log_u = gm.uniform_log_density(grid, x)
    a = 3000 / 3300
    want = log_u + field.log_likelihood(x, run.scans[0]) - np.log(a * np.exp(log_u) + (1 - a) * np.exp(log_q)) - np.log(3300)
    ok = np.isfinite(want)
    assert np.array_equal(ok, np.isfinite(lw)) and np.allclose(lw[ok], want[ok], rtol=0, atol=1e-9)


def test_the_mixture_start_has_a_larger_ess_than_two_strata():
    """Fox's bins need an ESS: two strata of half the mass put it on one or two uniform poses (review nav_global 3)."""
    grid, field = study.book_map(), study.field()
    ess = {}
    for mixture in (False, True):
        vals = []
        for seed in range(3):
            run = study.simulate(seed, 1)
            _, lw = gm.start_cloud(grid, field, run.scans[0], np.random.default_rng(seed),
                                   replace(gm.HAZARD, start_mixture=mixture))
            w = np.exp(lw - logsumexp(lw))
            vals.append(1 / np.sum(w ** 2))
        ess[mixture] = np.median(vals)
    assert ess[True] > 3 * ess[False]


def test_confirm_is_checked():
    with pytest.raises(ParameterError):
        gm.GlobalSettings(confirm=-1)


def test_the_cure_keeps_a_kidnapped_robot_it_has_found_again():
    """Kidnap drive 5 (the cascade that chose the cure): the cure finds the robot again and keeps it; hysteresis alone,
    comparing later strata with the wrong cloud's stale evidence, hands it to the half-turn twin."""
    grid, field = study.book_map(), study.field()
    run = study.simulate(5, 100, kidnap_at=study.KIDNAP_STEP)
    err = {}
    for name, s in (("cure", gm.CURE), ("hysteresis only", replace(gm.HAZARD, confirm=gm.CONFIRM))):
        res = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng([41, 5, 2]),
                            s, start=run.truth[0])
        err[name] = np.hypot(*(res.mean[:, :2] - run.truth[:, :2]).T)
    assert np.all(err["cure"][70:] < 0.5)
    assert np.any(err["hysteresis only"][70:] > 5.0)
