"""The tables converted once into the registry's one schema (tools/convert_stored_studies.py) hold the
values they held: each, read by ``STUDIES[name].load()``, equals the table of the commit it was converted
from, read as it was read then (its literal columns by ``ast.literal_eval``, empty errors as ``""``, the
PMMH chains one row per iteration)."""

from __future__ import annotations

import ast
import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.studies.likelihood_studies import chain_rows
from pfcourse.studies.registry import STUDIES

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from convert_stored_studies import FROM  # noqa: E402


def old_table(path: str, **options) -> pd.DataFrame:
    done = subprocess.run(["git", "show", f"{FROM}:book/data/{path}"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"commit {FROM[:10]} is not in this clone (a shallow one): {done.stderr.strip()[:80]}")
    return pd.read_csv(io.StringIO(done.stdout), **options)


@pytest.mark.parametrize("name, literals", [("scheme", ["scheme"]), ("initial", ["initial"]), ("gap", ["gap"])])
def test_robot_studies_keep_their_values(name, literals):
    old = old_table(f"robot_studies/{name}.csv", converters={c: ast.literal_eval for c in literals})
    old["error"] = ["" if isinstance(v, float) else v for v in old["error"]]
    new = STUDIES[f"robot_studies/{name}"].load().rename(columns={"error_message": "error"})  # renamed later
    arrays = [c for c in new.columns if c not in old.columns]
    pd.testing.assert_frame_equal(new.drop(columns=arrays), old, check_exact=True)
    assert new[literals[0]].map(type).isin([str, type(None), tuple]).all()


def test_terrain_reference_names_its_repeat_column():
    old = old_table("terrain_reference.csv")
    new = STUDIES["terrain_reference"].load()
    pd.testing.assert_frame_equal(new.rename(columns={"repeat": "seed"}), old, check_exact=True)


def test_the_pmmh_chains_are_a_registered_study_with_the_same_values():
    old = old_table("likelihood/pmmh.csv")
    stored = STUDIES["likelihood/pmmh"].load()
    assert list(stored["n_particles"]) == sorted(old["n_particles"].unique())
    pd.testing.assert_frame_equal(chain_rows(stored), old, check_exact=True, check_dtype=False)
    assert chain_rows(stored)["theta"].dtype == np.float64 and chain_rows(stored)["accepted"].dtype == bool
