"""book/data/terrain_confirmation.csv: the terrain filter chosen on flights 0-99, run on fresh flights.

The study (tools/studies/terrain_confirmation.py) was committed, with its criterion, before its
data; this test checks that the stored table is what that code computes (a seeded sample of rows
re-computed), that its flights are fresh (no other stored terrain study used them), and that the
provenance names the criterion.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.terrain.map import load_jacksboro

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "book" / "data"
sys.path.insert(0, str(ROOT / "tools" / "studies"))
import terrain_confirmation as tc  # noqa: E402

TABLE = pd.read_csv(DATA / "terrain_confirmation.csv")
SAMPLE = TABLE.iloc[np.random.default_rng(2027).choice(len(TABLE), size=3, replace=False)]


@pytest.fixture(scope="module")
def terrain():
    return load_jacksboro()


def test_every_setting_has_every_fresh_flight_and_the_criterion_is_recorded():
    meta = json.loads((DATA / "terrain_confirmation.json").read_text())
    assert meta["code"] == "tools/studies/terrain_confirmation.py" and len(meta["git_commit"]) == 40
    assert meta["criterion"] == tc.CRITERION and meta["flights"] == [100, 199]
    assert set(TABLE["setting"]) == set(tc.SETTINGS)
    for _, group in TABLE.groupby("setting"):
        assert sorted(group["flight"]) == list(tc.FLIGHTS)


def test_the_flights_are_fresh():
    for other in ("terrain_remedies.csv", "terrain_studies.csv"):
        used = set(pd.read_csv(DATA / other)["flight"])
        assert not used & set(tc.FLIGHTS), f"{other} used flights of the confirmation"


@pytest.mark.parametrize("row", list(SAMPLE.itertuples(index=False)), ids=lambda r: f"{r.setting}-{r.flight}")
def test_sampled_rows_are_recomputed(row, terrain):
    fresh = tc.run(row.setting, int(row.flight), terrain)
    np.testing.assert_allclose([fresh["final_error"], fresh["mean_error"]], [row.final_error, row.mean_error],
                               rtol=1e-9)
    assert fresh["lost"] == bool(row.lost)


# ---- book/data/terrain_cost_matched.csv (tools/studies/terrain_cost_matched.py), decided in advance too

import terrain_cost_matched as tm  # noqa: E402

COST = pd.read_csv(DATA / "terrain_cost_matched.csv")


def test_the_cost_matched_study_has_its_flights_and_criterion():
    meta = json.loads((DATA / "terrain_cost_matched.json").read_text())
    assert meta["code"] == "tools/studies/terrain_cost_matched.py" and meta["criterion"] == tm.CRITERION
    assert meta["flights"] == [200, 299] and not set(tm.FLIGHTS) & set(tc.FLIGHTS)
    for _, group in COST.groupby("setting"):
        assert sorted(group["flight"]) == list(tm.FLIGHTS)


@pytest.mark.parametrize("row", list(COST.iloc[np.random.default_rng(2028).choice(len(COST), size=2, replace=False)]
                                     .itertuples(index=False)), ids=lambda r: f"{r.setting}-{r.flight}")
def test_sampled_cost_matched_rows_are_recomputed(row, terrain):
    fresh = tm.run(row.setting, int(row.flight), terrain)
    np.testing.assert_allclose([fresh["final_error"], fresh["mean_error"]], [row.final_error, row.mean_error],
                               rtol=1e-9)
    assert fresh["lost"] == bool(row.lost)
