"""The stored studies of Part V (book/data/likelihood/): every table has its provenance and no failed
run; the PMMH chains are what pfcourse.studies.likelihood_studies computes (their first
iterations re-computed). The other tables are registered studies, whose rows
tests/test_stored_studies.py re-computes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.studies import likelihood_studies as ls

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "book" / "data" / "likelihood"


def sample(table: pd.DataFrame, k: int, salt: int) -> pd.DataFrame:
    rng = np.random.default_rng([2026, salt])
    return table.iloc[np.sort(rng.choice(len(table), size=k, replace=False))]


@pytest.mark.parametrize("name", ["bias", "ml", "pmmh", "smoothing_robot", "terrain_rf"])
def test_every_table_has_its_provenance(name):
    meta = json.loads((DATA / f"{name}.json").read_text())
    assert meta["file"] == f"{name}.csv"
    assert len(meta["git_commit"]) == 40
    table = pd.read_csv(DATA / f"{name}.csv")
    if "status" in table:
        assert (table["status"] == "ok").all()


def test_pmmh_chain_prefix():
    table = pd.read_csv(DATA / "pmmh.csv")
    n = int(sample(table.drop_duplicates("n_particles"), 1, 3)["n_particles"].iloc[0])
    stored = table[table["n_particles"] == n].sort_values("iteration").head(12)
    chain, _ = ls.pmmh_chain(n, n_iterations=12)
    np.testing.assert_allclose(chain.theta, stored["theta"], rtol=1e-12)
    np.testing.assert_allclose(chain.log_likelihood, stored["log_likelihood"], rtol=1e-12)
    np.testing.assert_array_equal(chain.accepted, stored["accepted"].to_numpy())
