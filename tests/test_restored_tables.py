"""The four global-localization tables re-stored at full precision (tools/restore_full_precision.py) hold what
they held: each old value, written by its first script with ``%.10g``, is the new value written with ``%.10g``,
exactly; the wall times are the original run's; the provenance records the conversion and no rounding."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.studies.registry import STUDIES
from pfcourse.studies.store import DATA

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from restore_full_precision import DIGITS, TABLES  # noqa: E402

RECORD = json.loads((DATA / "global_localization" / "provenance.json").read_text())
CONVERSION = next(c for c in RECORD["conversions"] if c.get("tool") == "tools/restore_full_precision.py")


def old_table(path: str) -> pd.DataFrame:
    commit = CONVERSION["from_commit"]
    done = subprocess.run(["git", "show", f"{commit}:book/data/{path}"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"commit {commit[:10]} is not in this clone (a shallow one): {done.stderr.strip()[:80]}")
    return pd.read_csv(io.StringIO(done.stdout), keep_default_na=False, dtype=str)


def number(text: str) -> float:
    return np.nan if text == "" else float(text)


@pytest.mark.parametrize("name", TABLES)
def test_the_old_table_is_the_new_one_rounded_to_ten_digits(name):
    study = STUDIES[f"global_localization/{name}"]
    old = old_table(study.table)
    new = pd.read_csv(DATA / study.table, keep_default_na=False, dtype=str)
    assert list(new.columns) == list(old.columns) and len(new) == len(old) == CONVERSION["rows"][name]
    rounded = 0
    for column in new.columns:
        for a, b in zip(old[column], new[column]):
            if a == b:
                continue
            assert column not in study.volatile, column  # the original run's wall times, kept
            x, y = number(a), number(b)
            if np.isnan(x) and np.isnan(y):  # a missing value, written "" then and "nan" now
                continue
            assert x == float(f"{y:.{DIGITS}g}"), (column, a, b)
            rounded += x != y
    assert rounded > len(new)  # there was rounding to undo


def test_no_table_is_rounded_any_more():
    assert "significant_digits" not in RECORD
    for name in TABLES:
        table = STUDIES[f"global_localization/{name}"].load()
        floats = table.select_dtypes(float).to_numpy().ravel()
        floats = floats[np.isfinite(floats)]
        # values with more than 10 significant digits now exist in every table
        assert any(float(f"{v:.{DIGITS}g}") != v for v in floats), name
