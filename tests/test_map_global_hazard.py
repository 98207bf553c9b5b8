"""The cure's prior of a kidnapping (pfcourse.scenarios.maprobot.global_mcl, ``kidnap_hazard``): the injected
stratum's prior mass is the kidnap model's hazard, not augmented MCL's ratio of averages."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import ParameterError
from pfcourse.scenarios.maprobot import global_mcl as gm
from pfcourse.studies import maprobot as study

#: Small settings, so that a run takes a second or two.
SMALL = dict(n_start=4000, n_start_scan=500, n_min=300, n_max=1000, history=10, inject_min=100)


def test_the_hazard_is_checked_when_the_settings_are_built():
    for bad in (0.0, -1e-3, 0.3, float("nan"), True):
        with pytest.raises(ParameterError):
            gm.GlobalSettings(kidnap_hazard=bad)  # 0.3 * inject_every (4) would be a prior mass above one
    assert gm.GlobalSettings(kidnap_hazard=0.25).kidnap_hazard == 0.25
    assert gm.SETTINGS.kidnap_hazard is None  # the default keeps augmented MCL's rule
    assert gm.HAZARD == gm.with_settings(kidnap_hazard=gm.KIDNAP_HAZARD)


def test_the_hazard_sets_the_prior_mass_and_the_augmented_ratio_is_still_recorded():
    grid, field = study.book_map(), study.field()
    run = study.simulate(5, 40)
    s = gm.with_settings(**SMALL)
    a = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), s,
                      start=run.truth[0])
    h = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1),
                      gm.replace(s, kidnap_hazard=1e-3), start=run.truth[0])
    # without a hazard, eps is augmented MCL's ratio
    assert np.array_equal(a.eps, a.eps_augmented)
    # with it, eps is the hazard times the scans an injection stands for, and the ratio is recorded beside it
    assert np.allclose(h.eps[1:], 1e-3 * s.inject_every, rtol=0, atol=1e-15)
    assert np.all((h.eps_augmented[1:] >= s.eps_min) & (h.eps_augmented[1:] <= 1))
    # the two runs draw the same numbers until the first injection (the prior changes weights, not draws)
    first = s.history
    assert np.array_equal(a.mean[:first], h.mean[:first]) and np.array_equal(a.eps_augmented[:first + 1],
                                                                             h.eps_augmented[:first + 1])


def test_a_right_cloud_keeps_its_place_and_a_kidnapped_robot_is_found():
    """Tracked from the known start: with the hazard the injected strata never take a right cloud's place,
    and after a kidnapping (carried away, odometry silent) they take the weight within a few seconds."""
    grid, field = study.book_map(), study.field()
    s = gm.with_settings(**SMALL, kidnap_hazard=gm.KIDNAP_HAZARD)
    run = study.simulate(6, 60)
    res = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(2), s,
                        start=run.truth[0])
    err = np.hypot(*(res.mean[:, :2] - run.truth[:, :2]).T)
    assert res.injected_mass.max() < 0.5 and np.all(err < 1.0)
    kid = study.simulate(6, 100, kidnap_at=30)
    res = gm.global_mcl(grid, field, study.MOTION, kid.scans, kid.drive.odometry, np.random.default_rng(2), s,
                        start=kid.truth[0])
    err = np.hypot(*(res.mean[:, :2] - kid.truth[:, :2]).T)
    assert err[29] < 1.0 and err[31] > 1.0  # tracked, then carried away
    taken = np.flatnonzero(res.injected_mass > 0.5)
    assert len(taken) and 30 < taken[0] <= 30 + s.history + 2 * s.inject_every
    assert np.all(err[-10:] < 1.0)
