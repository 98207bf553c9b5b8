"""The stored tables of the global-localization chapter are what their row functions compute.

A random (seeded) sample of rows of each table is re-computed with pfcourse.experiments.global_localization and
must give the same numbers (wall times excepted); see tools/studies/global_localization.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.experiments import global_localization as mcl_study

DATA = Path(__file__).resolve().parents[1] / "book" / "data" / "global_localization"
RNG = np.random.default_rng(2026)


def _sample(name: str, k: int, keep=None) -> pd.DataFrame:
    table = pd.read_csv(DATA / f"{name}.csv")
    if keep is not None:
        table = table[keep(table)]
    return table.iloc[RNG.choice(len(table), size=k, replace=False)]


def _same(stored: pd.Series, fresh: dict) -> None:
    for key, value in fresh.items():
        if "seconds" in key:
            continue
        got = stored[key]
        if isinstance(value, (bool, np.bool_)):
            assert bool(got) == bool(value), key
        elif isinstance(value, str):
            assert got == value, key
        else:
            np.testing.assert_allclose(float(got), float(value), rtol=1e-8, atol=1e-12, err_msg=key)


def test_provenance_names_the_script_and_seeds():
    prov = json.loads((DATA / "provenance.json").read_text())
    assert prov["code"] == "tools/studies/global_localization.py"
    assert len(prov["git_commit"]) == 40


@pytest.mark.parametrize("row", list(_sample("anatomy", 3).itertuples(index=False)))
def test_anatomy_rows(row):
    _same(pd.Series(row._asdict()), mcl_study.anatomy_row(int(row.seed), int(row.n)))


def test_mode_rows():
    table = pd.read_csv(DATA / "modes.csv")
    for method in ("bootstrap", "mixture"):
        seed = int(RNG.integers(0, table["seed"].max() + 1))
        stored = table[(table["method"] == method) & (table["seed"] == seed)].sort_values("step")
        for (_, s), fresh in zip(stored.iterrows(), mcl_study.mode_rows(seed, method)):
            _same(s, fresh)


# the 30 000-particle bootstrap runs take seconds each: sampled among the others
@pytest.mark.parametrize("row", list(_sample("lockon", 4, lambda t: (t["n"] <= 10000) | (t["method"] != "bootstrap"))
                                     .itertuples(index=False)))
def test_lockon_rows(row):
    _same(pd.Series(row._asdict()), mcl_study.lockon_row(int(row.seed), row.method, int(row.n)))


@pytest.mark.parametrize("row", list(_sample("kidnap", 3).itertuples(index=False)))
def test_kidnap_rows(row):
    _same(pd.Series(row._asdict()), mcl_study.kidnap_row(int(row.seed), row.method, int(row.n)))


@pytest.mark.parametrize("row", list(_sample("ekf_vs_pf", 2).itertuples(index=False)))
def test_ekf_rows(row):
    _same(pd.Series(row._asdict()), mcl_study.ekf_row(int(row.seed), row.setting))
