"""The stored studies of Part V (book/data/likelihood/): every table has its provenance and no failed
run; the PMMH chains are what pfcourse.studies.likelihood_studies computes (the first iterations
of a seeded choice of chain re-computed: a long chain takes minutes). The other tables' rows are
re-computed by tests/test_stored_studies.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.studies import likelihood_studies as ls
from pfcourse.studies.registry import STUDIES

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
    """The first iterations of a stored chain, re-computed from its row's setting and seed, float for float."""
    chains = STUDIES["likelihood/pmmh"].load()
    row = sample(chains, 1, 3).iloc[0]
    fresh = ls.pmmh_row(int(row["seed"]), int(row["n_particles"]), iterations=12)
    for key in ("theta", "log_likelihood", "accepted"):
        assert np.array_equal(fresh[key], row[key][:12]), key
