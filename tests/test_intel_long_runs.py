"""intel/long_runs: the global runs of chapter 16 over LONG_STEPS scans (issue 41 item 4, run length).

The 40-scan runs can count only the cure's first admitted injection (first injection at scan ``history``,
``confirm`` wins in a row, lock-on at LOCK_SHARE of the last LOCK_WINDOW scans); the longer runs judge
injection with room for later admissions.  The generic re-computation of a seeded sample of rows is
tests/test_stored_studies.py's; this file checks what the chapter reads from the table.
"""

import json
from dataclasses import asdict

import numpy as np

from pfcourse.scenarios.maprobot import global_mcl
from pfcourse.studies import intel
from pfcourse.studies.registry import STUDIES


def test_forty_scans_leave_the_lock_on_window_one_admission_time_of_the_cure():
    s = intel.GUARDED_SETTINGS
    inject = [k for k in range(1, intel.GLOBAL_STEPS) if k >= s.history and k % s.inject_every == 0]
    need = int(np.ceil(intel.LOCK_SHARE * intel.LOCK_WINDOW))
    first_admission = inject[s.confirm - 1]
    assert intel.GLOBAL_STEPS - first_admission >= need  # an admission at scan 28 can still lock on
    assert intel.GLOBAL_STEPS - (first_admission + s.inject_every) < need  # one at 32 cannot
    # over LONG_STEPS scans, later admission times can too
    assert intel.LONG_STEPS - (first_admission + s.inject_every) >= need


def test_the_long_runs_record_their_arms_settings_and_start_rule():
    table = STUDIES["intel/long_runs"].load()
    record = table.attrs["provenance"]
    assert record["steps"] == intel.LONG_STEPS == 80
    assert intel.GLOBAL_SETTINGS is global_mcl.HAZARD and intel.GUARDED_SETTINGS is global_mcl.CURE
    assert record["settings"] == json.loads(json.dumps(asdict(intel.GLOBAL_SETTINGS)))
    assert record["guarded_settings"] == json.loads(json.dumps(asdict(intel.GUARDED_SETTINGS)))
    runs = {m: g.sort_values("seed").reset_index(drop=True) for m, g in table.groupby("method")}
    assert sorted(runs) == sorted(intel.LONG_METHODS)
    starts = [intel.global_start(s, intel.LONG_STEPS) for s in range(intel.N_GLOBAL)]
    for g in runs.values():
        assert g["seed"].tolist() == list(range(intel.N_GLOBAL))
        # the same draw rule as the 40-scan runs, among the starts that leave LONG_STEPS scans
        assert g["start_scan"].tolist() == starts
        assert g["start_scan"].max() < intel.N_SCANS // 2 - intel.LONG_STEPS
        assert (g["locked_from"] <= intel.LONG_STEPS).all()
        assert (g.loc[~g["locked_on"], "locked_from"] == intel.LONG_STEPS).all()
