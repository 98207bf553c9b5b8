"""Recompute a seeded random sample of the stored terrain study (book/data/terrain_remedies.csv)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from pfcourse.terrain.map import load_jacksboro
from pfcourse.experiments.terrain_remedies import SETTINGS, run_one

DATA = Path(__file__).resolve().parents[1] / "book" / "data" / "terrain_remedies.csv"


def stored_rows():
    with DATA.open() as f:
        return list(csv.DictReader(f))


def test_stored_rows_are_reproduced():
    rows = [r for r in stored_rows() if int(r["N"]) <= 10000 and r["setting"] in SETTINGS]
    pick = np.random.default_rng(17).choice(len(rows), 4, replace=False)
    terrain = load_jacksboro()
    for i in pick:
        row = rows[i]
        new = run_one(row["setting"], int(row["flight"]), terrain)
        assert new["final_error"] == pytest.approx(float(row["final_error"]), rel=1e-9), row
        assert new["mean_error"] == pytest.approx(float(row["mean_error"]), rel=1e-9), row
        assert str(new["lost"]) == row["lost"]


def test_every_setting_has_at_least_100_flights_or_is_marked_expensive():
    counts = {}
    for r in stored_rows():
        counts[r["setting"]] = counts.get(r["setting"], 0) + 1
    for name, n in counts.items():
        assert n >= 100 or SETTINGS[name][0] >= 100000, (name, n)
