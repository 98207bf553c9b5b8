"""Every stored study's provenance follows the one schema, its filters recorded as settings records from the
code (not prose), and the tables converted by tools/convert_study_records.py hold the values they held."""

from __future__ import annotations

import io
import json
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from pfcourse.studies.provenance import SCHEMA
from pfcourse.studies.registry import NO_FILTER_RECORD, STUDIES, Study
from pfcourse.studies.store import DATA

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from convert_study_records import FROM, renames_message  # noqa: E402
from restore_full_precision import TABLES as RESTORED_TABLES  # noqa: E402

RESTORED = {f"global_localization/{name}" for name in RESTORED_TABLES}

REGISTERED = list(STUDIES.values())  # map_global/ and intel/ too: run() wrote theirs in the schema


def exception(study: Study) -> str | None:
    return next((why for key, why in NO_FILTER_RECORD.items() if study.name == key or study.name.startswith(key + "/")), None)


@pytest.mark.parametrize("study", REGISTERED, ids=[s.name for s in REGISTERED])
def test_provenance_follows_the_one_schema(study: Study):
    record = json.loads((DATA / study.provenance).read_text())
    required = set(SCHEMA) - {"filters"} - ({"git_commit", "working_tree_modified"} if "runs" in record else set())
    assert required <= set(record) or (set(required) - {"wall_seconds"} <= set(record) and "seconds" in record), \
        sorted(required - set(record))
    assert not {"made_by", "package_dirty_at_run"} & set(record)
    codes = record["row_code"] if isinstance(record["row_code"], list) else [record["row_code"]]
    assert study.row_code in codes
    for path in re.findall(r"[\w/]+\.py", study.row_code):  # the code that re-computes the rows exists
        assert (ROOT / path).exists(), path


@pytest.mark.parametrize("study", REGISTERED, ids=[s.name for s in REGISTERED])
def test_a_study_s_filters_are_recorded_from_the_code(study: Study):
    """The provenance's ``filters`` are the records the rows build from, as data: a record changed in the code
    without re-running (or re-recording) the study fails here; a study without one says why."""
    record = json.loads((DATA / study.provenance).read_text())
    if not study.filters:
        assert exception(study), f"{study.name} builds no filter from a record and is not a listed exception"
        return
    assert exception(study) is None
    stored = record["filters"]
    for name, value in study.filter_records().items():
        assert stored[name] == value, name


def old_table(path: str) -> pd.DataFrame:
    done = subprocess.run(["git", "show", f"{FROM}:book/data/{path}"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"commit {FROM[:10]} is not in this clone (a shallow one): {done.stderr.strip()[:80]}")
    return pd.read_csv(io.StringIO(done.stdout))


RENAMED = [s for s in REGISTERED if "error_message" in (DATA / s.table).read_text().split("\n", 1)[0].split(",")]


def test_every_table_with_run_study_s_messages_was_renamed():
    assert len(RENAMED) >= 30
    for study in REGISTERED:
        header = (DATA / study.table).read_text().split("\n", 1)[0].split(",")
        assert not renames_message(study, header), study.name  # no "error" column of messages is left


@pytest.mark.parametrize("study", RENAMED, ids=[s.name for s in RENAMED])
def test_a_converted_table_holds_the_values_it_held(study: Study):
    """Read as it was read at FROM (an ``error`` column of messages, empty ones as ""), the old table equals
    the converted one read by ``STUDIES[name].load()``, every value exactly (to the 10 significant digits it
    held, for a table re-stored since at full precision: tests/test_restored_tables.py)."""
    old = old_table(study.table)
    old["error"] = ["" if isinstance(v, float) else v for v in old["error"]]
    new = pd.read_csv(DATA / study.table)
    new["error_message"] = ["" if isinstance(v, float) else v for v in new["error_message"]]
    exact = {"check_exact": True} if study.name not in RESTORED else {"check_exact": False, "rtol": 1e-9,
                                                                       "atol": 0.0, "check_dtype": False}
    pd.testing.assert_frame_equal(new.rename(columns={"error_message": "error"}), old, **exact)
    loaded = study.load()
    assert list(loaded["error_message"]) == list(old["error"])


def test_a_study_refuses_filters_that_are_not_settings_records():
    from pfcourse.errors import ParameterError
    from pfcourse.filter_config import FilterSettings

    base = dict(name="x", row=dict, grid={"a": [1]}, n_runs=1, table="x.csv", provenance="x.json")
    with pytest.raises(ParameterError, match="must be a FilterSettings or a FilterConfig"):
        Study(**base, filters={"pf": "bootstrap, N = 300"})  # prose is not a record
    with pytest.raises(ParameterError, match="filters must be a dict"):
        Study(**base, filters=[FilterSettings(10)])
    assert Study(**base, filters={"pf": FilterSettings(10)}).filter_records()["pf"]["label"] == \
        "bootstrap, systematic at ESS < 0.5 N, N = 10"


def test_the_schema_s_known_exceptions_are_listed_in_one_place():
    from pfcourse.studies.registry import SCHEMA_EXCEPTIONS

    flights = {s.name for s in STUDIES.values() if s.seed_column != "seed"}
    assert flights == set(SCHEMA_EXCEPTIONS["seed_column flight"])
    assert {s.seed_column for s in STUDIES.values()} == {"seed", "flight"}
    assert set(SCHEMA_EXCEPTIONS) == {"seed_column flight"}
    # every stored table round-trips its floats: no provenance records a rounded table any more
    assert not [s.name for s in STUDIES.values() if "significant_digits" in s.provenance_record()]
