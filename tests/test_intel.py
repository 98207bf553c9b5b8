"""The Intel log's experiments (pfcourse.studies.intel): the held-out split, the lock-on rule, the global runs'
settings record and drift correction, and a global run's determinism."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pfcourse.angles import wrap_angle
from pfcourse.errors import ParameterError
from pfcourse.studies import intel
from pfcourse.scenarios.maprobot.carmen import relative_pose


def test_the_map_is_built_from_the_other_half_and_holds_the_held_out_path():
    sp = intel.split()
    assert intel.MAP_PART.start == intel.HELD_OUT.stop == 455
    assert len(sp.poses) == len(sp.ranges) == len(sp.odometry) == 455
    assert np.all(sp.odometry[0] == 0.0)
    # the held-out poses lie on the map, off its walls, and most in cells the other half saw free (94 %:
    # the rest were never crossed by a beam of the second half, or are a wall cell there)
    assert sp.grid.is_free(sp.poses).mean() > 0.97
    assert sp.free.is_free(sp.poses).mean() > 0.9
    # the held-out poses are the log's corrected poses moved by the map's origin, nothing else
    np.testing.assert_allclose(sp.poses[:, :2] + sp.map.origin, sp.log.poses[intel.HELD_OUT, :2], atol=1e-12)


def test_the_heading_tolerance_is_three_times_the_odometrys_rms_heading_error_of_a_step():
    log = intel.split().log
    true = relative_pose(log.poses[:-1], log.poses[1:])[:, 2]
    rms = np.sqrt(np.mean(wrap_angle(log.relative_motion()[1:, 2] - true) ** 2))
    assert intel.heading_tolerance(log) == pytest.approx(3 * rms, rel=1e-12)
    assert np.deg2rad(5) < intel.heading_tolerance(log) < np.deg2rad(20)


def test_locked_on_means_most_of_the_last_window():
    tol = 0.2
    window = intel.LOCK_WINDOW
    good = int(np.ceil(intel.LOCK_SHARE * window))
    pos, head = np.zeros(50), np.zeros(50)
    pos[-window:][:window - good] = 5.0  # the first steps of the window off by 5 m
    assert intel.locked_on_share(pos, head, tol)
    pos[-good] = 5.0  # one more step off: below the share
    assert not intel.locked_on_share(pos, head, tol)
    assert not intel.locked_on_share(np.zeros(50), np.full(50, 0.3), tol)  # heading beyond the tolerance
    assert intel.locked_on_share(np.r_[np.full(35, 9.0), np.zeros(15)], np.zeros(50), tol)  # earlier steps do not count


def _stored_settings(name: str, settings) -> dict:
    """The settings record stored with ``name``, a field added to the record after the study ran counting at
    its default (its default keeps the old code path; the re-computation test of the study's rows proves it)."""
    from dataclasses import fields

    from pfcourse.studies.registry import STUDIES

    stored = STUDIES[name].load().attrs["provenance"]["settings"]
    defaults = {f.name: f.default for f in fields(settings) if f.name not in stored}
    return {**stored, **json.loads(json.dumps(defaults))}


@pytest.mark.parametrize("name, settings", [("intel/global", "GLOBAL_SETTINGS"), ("intel/map_control", "GLOBAL_SETTINGS"),
                                            ("intel/global_previous", "PREVIOUS_SETTINGS"),
                                            ("intel/guarded_maps", "GUARDED_SETTINGS")])
def test_the_global_runs_use_the_cure_of_one_record_and_the_stored_study_was_made_with_it(name, settings):
    from dataclasses import asdict

    from pfcourse.scenarios.maprobot import global_mcl

    assert intel.GLOBAL_SETTINGS is global_mcl.HAZARD and intel.PREVIOUS_SETTINGS is global_mcl.SETTINGS
    record = getattr(intel, settings)
    assert _stored_settings(name, record) == json.loads(json.dumps(asdict(record))), (
        f"intel.{settings} changed since the table of {name} was made: python3 tasks.py study {name}")
    # the uniform-only filter: as many particles at the start, none from the scan, no injection
    u = intel.uniform_only(intel.GLOBAL_SETTINGS)
    assert u.n_start == intel.GLOBAL_SETTINGS.n_start + intel.GLOBAL_SETTINGS.n_start_scan
    assert u.n_start_scan == 0 and u.inject_share == 0.0


def test_the_map_control_is_the_map_of_every_scan_but_the_runs_own():
    from pfcourse.scenarios.maprobot.mapping import build_map

    first = 200
    sp, log = intel.leave_out_split(first), intel.split().log
    left_out = np.arange(first - intel.LEAVE_OUT_MARGIN, first + intel.GLOBAL_STEPS + intel.LEAVE_OUT_MARGIN)
    kept = np.setdiff1d(np.arange(intel.N_SCANS), left_out)
    ref = build_map(log.poses[kept], log.ranges[kept], log.angles, max_range=intel.Z_MAX)
    # the control lies on the whole run's grid: cut out the part build_map's own grid covers
    i0, j0 = np.round((ref.origin - sp.map.origin) / ref.resolution).astype(int)[::-1]
    assert i0 >= 0 and j0 >= 0
    rows, cols = ref.log_odds.shape
    inner = sp.map.log_odds[i0:i0 + rows, j0:j0 + cols]
    # occupied, free and unknown cells are those of the map built from the kept scans; the rest is unknown
    assert np.array_equal(np.sign(inner), np.sign(ref.log_odds))
    np.testing.assert_allclose(inner, ref.log_odds, atol=1e-12)
    outside = np.ones(sp.map.log_odds.shape, dtype=bool)
    outside[i0:i0 + rows, j0:j0 + cols] = False
    assert not sp.map.log_odds[outside].any()
    # the run's own scans built none of it: cells only they saw free are unknown, and there are some
    whole = intel._track_split("whole run").map
    assert ((whole.log_odds < 0) & (sp.map.log_odds == 0)).sum() > 100
    # the held-out poses in the control's frame
    np.testing.assert_allclose(sp.poses[:, :2] + sp.map.origin, log.poses[intel.HELD_OUT, :2], atol=1e-12)


def test_a_runs_cost_counts_every_pose_scored():
    field = intel.split().field()
    counting = intel.CountingField(field)
    poses = intel.split().poses[:7]
    scan = intel.split().ranges[0, ::intel.BEAM_STEP]
    np.testing.assert_array_equal(counting.log_likelihood(poses, scan), field.log_likelihood(poses, scan))
    counting.log_likelihood(poses[:3], scan)
    assert counting.evaluations == 10
    assert counting.angles is field.angles  # everything else is the field's own


def test_the_drift_correction_takes_out_the_measured_drift():
    log = intel.split().log
    rate = intel.drift_rate(log)
    # the heading drifts clockwise as the robot drives: a few hundredths of a radian per metre
    assert -0.1 < rate < -0.005
    odo = np.array([[0.1, 2.0, -0.2], [0.0, -1.0, 0.0]])
    fixed = intel.drift_corrected(odo, rate)
    np.testing.assert_allclose(fixed[:, 1], odo[:, 1])
    np.testing.assert_allclose((fixed[:, 0] + fixed[:, 2]) - (odo[:, 0] + odo[:, 2]), -rate * np.abs(odo[:, 1]))
    # corrected over the map half, the summed heading error of its steps vanishes
    rel = log.relative_motion()[1:]
    true = relative_pose(log.poses[:-1], log.poses[1:])[:, 2]
    steps = slice(intel.MAP_PART.start, intel.N_SCANS - 1)
    err = wrap_angle(rel[steps, 2] - rate * np.hypot(rel[steps, 0], rel[steps, 1]) - true[steps])
    assert abs(err.sum()) < 1e-9


def test_a_global_run_depends_on_its_seed_only():
    a, b = intel.global_row(3, method="uniform"), intel.global_row(3, method="uniform")
    assert a == b
    assert intel.global_row(4, method="uniform")["start_scan"] != a["start_scan"]
    state = np.random.get_state()[1].copy()
    intel.global_row(3, method="uniform")
    assert np.array_equal(np.random.get_state()[1], state)
    with pytest.raises(ParameterError, match="method"):
        intel.global_row(3, method="bootstrap")


def test_the_tracking_runs_are_judged_by_the_global_runs_rule():
    """One lock-on rule: a stored tracking run is locked on exactly when its stored per-scan errors pass
    :func:`intel.locked_on_share`, the rule of the global runs; and a run lost for good is not locked on."""
    from pfcourse.studies.registry import STUDIES

    track = STUDIES["intel/tracking"].load()
    tol = intel.heading_tolerance(intel.split().log)
    for _, row in track.iterrows():
        assert len(row["position_error"]) == len(row["heading_error"]) == 455
        assert row["locked_on"] == intel.locked_on_share(row["position_error"], row["heading_error"], tol)
        if row["lost_scan"] >= 0:
            assert not row["locked_on"]


def test_the_injection_study_repeats_the_stored_cure_and_records_its_arms():
    """intel/injection: its run of the cure is intel/global's, run for run; its arms are the cure without
    injection and chapter 15's guarded cure, as recorded; its lock-on labels follow its per-scan errors."""
    from dataclasses import asdict

    from pfcourse.scenarios.maprobot import global_mcl
    from pfcourse.studies.registry import STUDIES

    assert intel.GUARDED_SETTINGS is global_mcl.CURE
    table = STUDIES["intel/injection"].load()
    record = table.attrs["provenance"]
    assert record["settings"] == json.loads(json.dumps(asdict(intel.GLOBAL_SETTINGS)))
    assert record["guarded_settings"] == json.loads(json.dumps(asdict(intel.GUARDED_SETTINGS)))
    runs = {m: g.sort_values("seed").reset_index(drop=True) for m, g in table.groupby("method")}
    assert sorted(runs) == sorted(intel.INJECTION_METHODS) and all(len(g) == intel.N_GLOBAL for g in runs.values())
    stored = STUDIES["intel/global"].load().query("method == 'scan'").sort_values("seed").reset_index(drop=True)
    for column in ("start_scan", "locked_on", "locked_from", "likelihood_evaluations"):
        assert (runs["scan"][column].to_numpy() == stored[column].to_numpy()).all(), column
    np.testing.assert_allclose(runs["scan"]["final_position_error"], stored["final_position_error"], rtol=0, atol=1e-9)
    tol = intel.heading_tolerance(intel.split().log)
    for g in runs.values():
        for _, row in g.iterrows():
            assert len(row["position_error"]) == intel.GLOBAL_STEPS
            assert row["locked_on"] == intel.locked_on_share(row["position_error"], row["heading_error"], tol)
            assert row["final_position_error"] == row["position_error"][-1]


def test_the_guards_do_not_act_on_a_filter_that_injects_nothing():
    """The chapter counts the uniform-only and no-injection arms (run with global_mcl.HAZARD) as the guarded cure's
    own: without injection the guards (confirm, mixture_evidence) never act, so the guarded settings give the
    stored rows, float for float."""
    from pfcourse.studies.registry import STUDIES

    stored = {m: g.set_index("seed") for m, g in STUDIES["intel/injection"].load().groupby("method")}
    uniform = STUDIES["intel/global"].load().query("method == 'uniform'").set_index("seed")
    for seed in (3, 17):
        for method, table in (("no_injection", stored["no_injection"]), ("uniform", uniform)):
            fresh = intel.global_row(seed, method=method, settings=intel.GUARDED_SETTINGS)
            row = table.loc[seed]
            assert fresh["locked_on"] == row["locked_on"] and fresh["likelihood_evaluations"] == row["likelihood_evaluations"]
            assert fresh["final_position_error"] == row["final_position_error"], (method, seed)
            assert fresh["window_margin"] == row["window_margin"], (method, seed)


def test_without_injection_a_run_scores_the_start_the_proposal_and_its_cloud_only():
    """The cost of the no-injection arm is fixed by the settings: the start's poses, the scan proposal's
    candidates and refinements, and the cloud's particles at each later scan (mean_particles x 39)."""
    from pfcourse.studies.registry import STUDIES

    S = intel.GLOBAL_SETTINGS
    proposal = S.candidates * S.headings + S.refine_rounds * S.refine_trials * S.keep
    runs = STUDIES["intel/injection"].load().query("method == 'no_injection'")
    expected = S.n_start + S.n_start_scan + proposal + np.round(runs["mean_particles"] * (intel.GLOBAL_STEPS - 1))
    np.testing.assert_array_equal(runs["likelihood_evaluations"].to_numpy(), expected.to_numpy())


def test_the_margin_check_leaves_out_more_scans_than_the_map_control():
    from pfcourse.studies.registry import STUDIES

    first = 200
    narrow, wide = intel.leave_out_split(first), intel.leave_out_split(first, margin=intel.MARGIN_CHECK)
    # every cell the wider cut still knows, the narrower one knows too (it left fewer scans out)
    assert ((wide.map.log_odds != 0) <= (narrow.map.log_odds != 0)).all()
    assert (narrow.map.log_odds != 0).sum() > (wide.map.log_odds != 0).sum()
    table = STUDIES["intel/map_control_margin"].load()
    assert (table["margin"] == intel.MARGIN_CHECK).all() and len(table) == intel.N_MARGIN_CHECK
    stored = STUDIES["intel/map_control"].load().sort_values("seed")
    assert (table.sort_values("seed")["start_scan"].to_numpy() == stored["start_scan"].to_numpy()[:len(table)]).all()
