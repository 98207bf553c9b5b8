"""Islands (pfcourse.scenarios.maprobot.global_mcl, ``islands``): independent small filters from the uniform start,
adopted when their evidence beats the cloud's; none from a known start; and the protocol's rules
(pfcourse.studies.map_global_islands)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.special import logsumexp

from pfcourse.errors import ParameterError
from pfcourse.studies import maprobot as study
from pfcourse.studies import map_global_islands as mgi
from pfcourse.scenarios.maprobot import global_mcl as gm


@pytest.fixture(scope="module")
def drive():
    return study.book_map(), study.field(), study.simulate(3, 24)


def test_a_tracked_robot_runs_no_islands(drive):
    """From a known start the islands' settings give the cure's run, draw for draw."""
    grid, field, run = drive
    a = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), gm.CURE,
                      start=run.truth[0])
    b = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(1), gm.ISLANDS,
                      start=run.truth[0])
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.sizes, b.sizes)


def test_no_islands_is_the_cure(drive):
    grid, field, run = drive
    a = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(2), gm.CURE)
    b = gm.global_mcl(grid, field, study.MOTION, run.scans, run.drive.odometry, np.random.default_rng(2),
                      replace(gm.ISLANDS, islands=0))
    assert np.array_equal(a.mean, b.mean)


def test_an_island_starts_from_the_scan_proposal_weighted_u_over_q(drive):
    grid, field, run = drive
    s = replace(gm.ISLANDS, islands=2, island_size=50)
    isl = gm.start_islands(grid, field, run.scans[0], np.random.default_rng(4), s)
    again = np.random.default_rng(4)
    assert len(isl) == 2
    for x, lw, record in isl:
        y, log_q = gm.scan_proposal(grid, field, run.scans[0], 50, again, s)
        want = gm.uniform_log_density(grid, y) - log_q + field.log_likelihood(y, run.scans[0])
        assert np.array_equal(x, y) and np.allclose(lw, want, rtol=0, atol=1e-12)
        assert record.shape == (1,) and record[0] == pytest.approx(logsumexp(want) - np.log(50), abs=1e-12)


def test_an_island_step_resamples_moves_and_weighs(drive):
    grid, field, run = drive
    rng = np.random.default_rng(5)
    x = run.truth[0] + rng.standard_normal((60, 3)) * [0.2, 0.2, 0.05]
    lw = field.log_likelihood(x, run.scans[0])
    y, lv, record = gm.island_step(field, study.MOTION, run.scans[1], run.drive.odometry[1], (x, lw, np.array([-1.0])),
                                   np.random.default_rng(6))
    again = np.random.default_rng(6)
    want = study.MOTION.sample(x[gm.systematic(np.exp(lw - logsumexp(lw)), again, 60)], run.drive.odometry[1], again)
    assert np.array_equal(y, want) and np.array_equal(lv, field.log_likelihood(want, run.scans[1]))
    assert record[0] == -1.0 and record[1] == pytest.approx(logsumexp(lv) - np.log(60), abs=1e-12)


def test_the_cloud_adopts_an_island_whose_evidence_beats_its_own(drive, monkeypatch):
    grid, field, run = drive
    s = replace(gm.ISLANDS, islands=1, island_size=40, island_margin=3.0)
    x0 = run.truth[0] + np.random.default_rng(7).standard_normal((40, 3)) * 0.05

    def island(lead):
        return lambda *a, **k: [(x0.copy(), np.zeros(40), np.array([lead]))]

    # an island far ahead in evidence is adopted at step 0: 40 poses, marked as adopted
    monkeypatch.setattr(gm, "start_islands", island(1e6))
    res = gm.global_mcl(grid, field, study.MOTION, run.scans[:3], run.drive.odometry[:3], np.random.default_rng(8), s)
    assert res.sizes[0] == 40 and res.injected_mass[0] == 1.0
    assert np.hypot(*(res.mean[0, :2] - run.truth[0, :2])) < 0.1
    # one far behind is not
    monkeypatch.setattr(gm, "start_islands", island(-1e6))
    res = gm.global_mcl(grid, field, study.MOTION, run.scans[:3], run.drive.odometry[:3], np.random.default_rng(8), s)
    assert res.sizes[0] == s.n_start + s.n_start_scan and res.injected_mass[0] == 0.0


def test_the_islands_settings_are_checked():
    for name, value in (("islands", -1), ("island_size", 0), ("island_margin", -1.0)):
        with pytest.raises(ParameterError, match=name):
            replace(gm.ISLANDS, **{name: value})


def test_decided_from_is_the_step_from_which_the_margin_stays_above_99_to_1():
    lo, hi = 0.0, np.log(99.0) + 0.1
    assert mgi.decided_from(np.array([lo, hi, hi, lo, hi, hi])) == 4
    assert mgi.decided_from(np.array([hi, hi])) == 0
    assert mgi.decided_from(np.array([hi, lo])) == 2


def test_the_protocol_keeps_the_margin_with_most_lock_ons_within_the_budget():
    def arm(name, locked, lost):
        return pd.DataFrame({"arm": name, "locked_on": locked, "n_lost_decided": lost})
    cure = arm("cure", [True, False, False], [1, 0, 0])
    dev = pd.concat([cure, arm("islands_0", [True, True, True], [1, 1, 0]),
                     arm("islands_99", [True, True, False], [1, 0, 0])])
    assert mgi.choose_margin(dev) == "islands_99"  # islands_0 locks on more but exceeds the budget
    assert mgi.choose_margin(pd.concat([cure, arm("islands_99", [True, False, False], [0, 0, 0])])) is None


def test_the_screen_s_choice_follows_from_the_stored_table():
    from pfcourse.studies.registry import STUDIES
    dev = STUDIES["map_global/global_dev_islands"].load()
    assert sorted(dev["arm"].unique()) == sorted(mgi.DEV_ARMS)
    assert dev.groupby("arm")["seed"].apply(lambda s: sorted(s) == list(range(mgi.DEV_RUNS))).all()
    assert mgi.choose_margin(dev) == mgi.CHOSEN_ARM and mgi.ARMS[mgi.CHOSEN_ARM] == gm.ISLANDS
    assert mgi.CHOSEN_ARM in mgi.HELDOUT_ARMS
    # the docstring's counts
    count = dev.groupby("arm")[["locked_on", "n_lost_decided", "n_lost"]].sum()
    assert count.loc["islands_99"].tolist() == [150, 0, 10] and count.loc["cure"].tolist() == [138, 2, 2]
    # the cure's arm is the cure recomputed: equal to map_global/global_dev_cure, drive by drive
    cure = dev[dev["arm"] == "cure"].sort_values("seed").reset_index(drop=True)
    old = STUDIES["map_global/global_dev_cure"].load().sort_values("seed").reset_index(drop=True)
    for column in ("locked_on", "locked_from_s", "final_position_error", "n_lost"):
        assert np.array_equal(cure[column].to_numpy(), old[column].to_numpy())
