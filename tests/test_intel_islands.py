"""intel/islands: chapter 15's cure with islands on the Intel log (issue 41 item 4, the cure as it now is).

Each islands run is paired with the guarded cure's run of the same seed and length: ``intel/injection``
(arm ``guarded``) at 40 scans and ``intel/long_runs`` (arm ``guarded``) at 80.  The generic re-computation
of a seeded sample of rows is tests/test_stored_studies.py's; this file checks the method, the pairing and
what the provenance promises.
"""

import json
from dataclasses import asdict

import numpy as np
import pytest

from pfcourse.scenarios.maprobot import global_mcl
from pfcourse.studies import intel
from pfcourse.studies.registry import STUDIES


class _Stop(Exception):
    pass


@pytest.mark.parametrize("method, expected", [("islands", global_mcl.ISLANDS), ("guarded", global_mcl.CURE),
                                              ("scan", global_mcl.HAZARD)])
def test_each_method_runs_its_own_settings(monkeypatch, method, expected):
    seen = {}

    def fake(grid, field, motion, scans, odometry, rng, s, **kw):
        seen["settings"], seen["scans"] = s, len(scans)
        raise _Stop

    monkeypatch.setattr(intel, "global_mcl", fake)
    with pytest.raises(_Stop):
        intel.global_row(3, method=method, steps=intel.LONG_STEPS)
    assert seen["settings"] == expected and seen["scans"] == intel.LONG_STEPS
    # the islands differ from the guarded cure only by the islands
    assert global_mcl.ISLANDS.islands > 0 and global_mcl.CURE.islands == 0


def test_the_islands_rows_use_islands_row_lengths():
    assert intel.ISLANDS_SETTINGS is global_mcl.ISLANDS
    assert intel.ISLANDS_STEPS == (intel.GLOBAL_STEPS, intel.LONG_STEPS)


def test_the_stored_runs_are_paired_with_the_guarded_cure_and_record_their_protocol():
    table = STUDIES["intel/islands"].load()
    record = table.attrs["provenance"]
    assert record["islands_settings"] == json.loads(json.dumps(asdict(intel.ISLANDS_SETTINGS)))
    assert "fixed on chapter 15's development drives" in record["protocol"]
    assert "judged here once, unchanged" in record["protocol"]
    partners = {intel.GLOBAL_STEPS: STUDIES["intel/injection"].load(), intel.LONG_STEPS: STUDIES["intel/long_runs"].load()}
    assert sorted(table["steps"].unique()) == sorted(partners)
    for steps, other in partners.items():
        runs = table[table["steps"] == steps].sort_values("seed").reset_index(drop=True)
        guarded = other[other["method"] == "guarded"].sort_values("seed").reset_index(drop=True)
        assert runs["seed"].tolist() == guarded["seed"].tolist() == list(range(intel.N_GLOBAL))
        assert runs["start_scan"].tolist() == guarded["start_scan"].tolist()
        assert runs["start_scan"].tolist() == [intel.global_start(s, steps) for s in range(intel.N_GLOBAL)]
        # the lock-on rule's bookkeeping: a run never locked on carries locked_from = steps
        assert (runs["locked_from"] <= steps).all()
        assert (runs.loc[~runs["locked_on"], "locked_from"] == steps).all()
        # the islands score more poses than the guarded cure: each island scores its proposal and 200 poses a scan
        s = intel.ISLANDS_SETTINGS
        extra = s.islands * s.island_size * steps
        assert np.median(runs["likelihood_evaluations"] - guarded["likelihood_evaluations"]) >= extra
