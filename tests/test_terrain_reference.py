"""book/data/terrain_reference.csv: the large bootstrap filters that stand for the exact posterior.

One seeded row (a N = 500 000 run, a few seconds) is re-computed and must give the same numbers;
the table has both sizes and both seeds for each of its flights.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from pfcourse.terrain.map import load_jacksboro

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "book" / "data"
sys.path.insert(0, str(ROOT / "tools" / "studies"))
import terrain_reference as tref  # noqa: E402

TABLE = pd.read_csv(DATA / "terrain_reference.csv")


def test_every_flight_has_both_sizes_and_both_seeds():
    meta = json.loads((DATA / "terrain_reference.json").read_text())
    assert meta["code"] == "tools/studies/terrain_reference.py" and len(meta["git_commit"]) == 40
    assert sorted(TABLE["flight"].unique()) == list(tref.FLIGHTS)
    for _, g in TABLE.groupby("flight"):
        assert sorted(zip(g["N"], g["seed"])) == sorted((n, s) for n in tref.SIZES for s in tref.SEEDS)


def test_a_sampled_row_is_recomputed():
    small = TABLE[TABLE["N"] == min(tref.SIZES)]
    row = small.iloc[np.random.default_rng(2029).integers(len(small))]
    fresh = tref.run(int(row["flight"]), int(row["N"]), int(row["seed"]), load_jacksboro())
    for key in ("mean_x", "mean_y", "sd_x", "sd_y", "true_x", "true_y"):
        np.testing.assert_allclose(fresh[key], row[key], rtol=1e-9, err_msg=key)
