"""One-off conversion of the stored tables of older scripts into the one schema of the study registry
(issue 44, item 3).  Run once, from the repository's root, on the tables of commit ``FROM``:

    .venv/bin/python tools/convert_stored_studies.py

* ``robot_studies/scheme.csv``, ``robot_studies/initial.csv``: the names of the grid's ``scheme`` and
  ``initial`` were stored as quoted Python literals (``'multinomial'``); they are plain words now (only
  values that are neither numbers nor words, ``gap``'s ``None`` and tuples, are literals);
* ``terrain_reference.csv``: the filter's repeat was stored in a column ``seed`` (a flight's seed is in
  ``flight``); the column is named after its grid parameter, ``repeat``;
* ``likelihood/pmmh.csv``: the PMMH chains, one row per iteration written by ``tools/studies/pmmh.py``,
  become the registered study ``likelihood/pmmh``: one row per chain, its arrays in ``pmmh.npz``;
* ``global_localization/provenance.json``: the tables its first script stored with 10 significant digits
  say so (``significant_digits``), which the re-computation test reads (the Study field ``rtol`` went);
* the provenance of the studies whose filters became settings records (``rao_blackwell``, the
  global-localization and map-robot studies, ``terrain_remedies`` and ``terrain_equal_cost``) gains
  those records (``filters``, ``settings``).

Idempotent: a second run writes the same files -- the files of that conversion, which
``tools/convert_study_records.py`` converted again (the message column ``error_message``, the one provenance
schema): run that one after this one, never this one alone.

Every other value is unchanged, byte for byte: ``tests/test_converted_studies.py`` compares each
converted table, read by ``STUDIES[name].load()``, with the table of ``FROM`` read as it was read then.
Each converted provenance record lists the change under ``conversions``.
"""

from __future__ import annotations

import ast
import csv
import io
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import pfcourse  # noqa: E402,F401  (first: it pins NumPy's arithmetic)
import numpy as np  # noqa: E402
from pfcourse.filter_config import records  # noqa: E402
from pfcourse.scenarios.robot import mcl  # noqa: E402
from pfcourse.studies import global_localization, maprobot, rb_study, terrain_remedies  # noqa: E402
from pfcourse.studies.provenance import write_rows  # noqa: E402
from pfcourse.studies.store import DATA  # noqa: E402

#: The commit whose tables are converted (main when the conversion was written).
FROM = "cee0c326b6e84d8f680e5386355fef0236bbde26"
TOOL = "tools/convert_stored_studies.py"
DATE = "2026-11-27"


def old_text(path: str) -> str:
    """The file ``book/data/<path>`` at :data:`FROM`."""
    return subprocess.run(["git", "show", f"{FROM}:book/data/{path}"], cwd=ROOT, capture_output=True, text=True,
                          check=True).stdout


def old_rows(path: str) -> list[dict]:
    return list(csv.DictReader(io.StringIO(old_text(path))))


def write_csv(path: Path, rows: list[dict]) -> None:
    """Rows of strings, written as they are (every number keeps its stored digits)."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def note(provenance: str, change: str, **record) -> None:
    """Add ``record`` to the provenance file and list ``change`` under its ``conversions``."""
    path = DATA / provenance
    data = json.loads(path.read_text())
    data.update(record)
    entry = {"date_utc": DATE, "tool": TOOL, "from_commit": FROM, "change": change}
    if entry not in data.setdefault("conversions", []):  # idempotent: a second run changes nothing
        data["conversions"].append(entry)
    path.write_text(json.dumps(data, indent=2, default=str) + "\n")


def unquote(path: str, columns: tuple[str, ...]) -> None:
    rows = old_rows(path)
    for row in rows:
        for column in columns:
            row[column] = ast.literal_eval(row[column])
    write_csv(DATA / path, rows)


def rename(path: str, old: str, new: str) -> None:
    rows = [{(new if k == old else k): v for k, v in row.items()} for row in old_rows(path)]
    write_csv(DATA / path, rows)


def pmmh() -> None:
    """The long table of chains -> one row per chain (``n_particles``, ``iterations``, ``run``, ``seed``), its
    arrays in ``pmmh.npz`` (the floats as stored: ``repr`` round-trips)."""
    from pfcourse.studies.likelihood_studies import PMMH_ITERATIONS, PMMH_SEED
    rows, arrays = [], {"theta": [], "log_likelihood": [], "accepted": []}
    chains = {}
    for row in old_rows("likelihood/pmmh.csv"):
        chains.setdefault(int(row["n_particles"]), []).append(row)
    for n, chain in chains.items():
        assert [int(r["iteration"]) for r in chain] == list(range(PMMH_ITERATIONS))
        rows.append({"n_particles": n, "iterations": PMMH_ITERATIONS, "run": 0, "seed": PMMH_SEED})
        arrays["theta"].append([float(r["theta"]) for r in chain])
        arrays["log_likelihood"].append([float(r["log_likelihood"]) for r in chain])
        arrays["accepted"].append([1.0 if r["accepted"] == "True" else 0.0 for r in chain])
    write_rows(DATA / "likelihood" / "pmmh.csv", rows)
    np.savez_compressed(DATA / "likelihood" / "pmmh.npz", **{k: np.array(v) for k, v in arrays.items()})
    old = json.loads(old_text("likelihood/pmmh.json"))
    record = {**old, "code": "pfcourse/studies/registry.py (first: tools/studies/likelihood.py)",
              "row": "pmmh_row", "row_code": "pfcourse/studies/likelihood_studies.py (pmmh_row)",
              "grid": {"n_particles": old["n_particles"], "iterations": [old["iterations"]]}, "n_runs": 1,
              "failures": "raise", "seeds": f"run r: seed {PMMH_SEED} + r; the chain's generator "
                                            "replicate_seed(seed, n_particles)", "rows": len(rows)}
    (DATA / "likelihood" / "pmmh.json").write_text(json.dumps(record, indent=2) + "\n")
    note("likelihood/pmmh.json", "one row per iteration (n_particles, iteration, theta, log_likelihood, accepted) "
         "-> one row per chain (n_particles, iterations, run, seed), theta, log_likelihood and accepted (1.0/0.0) "
         "as arrays in pmmh.npz: the registered study likelihood/pmmh; every value unchanged")


def main() -> None:
    unquote("robot_studies/scheme.csv", ("scheme",))
    unquote("robot_studies/initial.csv", ("initial",))
    note("robot_studies/provenance.json", "scheme.csv and initial.csv: the grid's names written as plain words, "
         "not quoted Python literals (gap.csv keeps None and tuples as literals); every value unchanged")
    rename("terrain_reference.csv", "seed", "repeat")
    note("terrain_reference.json", "column seed (the filter's repeat, 1 or 2) renamed repeat, its grid parameter; "
         "every value unchanged")
    pmmh()
    note("global_localization/provenance.json", "significant_digits: the tables this record's first script "
         "wrote with %.10g (a re-run writes floats that round-trip exactly); the filters as settings records",
         significant_digits={f"{name}.csv": 10 for name in ("anatomy", "lockon", "kidnap", "ekf_vs_pf")},
         filters=records(mcl.FILTERS))
    note("global_localization/kld_amcl.json", "settings: the filters as settings records",
         settings={name: s.record() for name, s in global_localization.KLD_SETTINGS.items()})
    note("global_localization/tracking_cost.json", "filters: the filters as settings records",
         filters=records(mcl.FILTERS))
    note("rao_blackwell.json", "filters: the six filters as settings records", filters=records(rb_study.FILTERS))
    for name in ("tracking", "amcl_global", "sensor_cost", "kld_tracking"):
        note(f"maprobot/{name}.json", "filters: the filters as settings records", filters=records(maprobot.FILTERS))
    note("terrain_remedies.json", "settings: the filters as settings records", settings=records(terrain_remedies.FILTERS))
    note("terrain_equal_cost.json", "settings: the filters as settings records (model_change added: none)",
         settings=records(terrain_remedies.EQUAL_COST_FILTERS))


if __name__ == "__main__":
    main()
