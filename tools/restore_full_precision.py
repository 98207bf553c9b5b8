"""Re-store, at full precision, the global-localization tables an older script wrote with 10 significant digits.

Their provenance said so (``"significant_digits": {file: 10}``) and the registry compared them to that
precision (``Study.stored_rtol``), the last exception to "floats that round-trip". This tool re-computes every
row of each table from its setting and seed with today's row code (``Study.compute``, on run_study's
default process pool), checks
that every stored value equals the new one to those 10 digits (so nothing but the rounding changes), keeps
the wall-time columns (``volatile``) as the original run measured them, saves the table with floats that
round-trip, and records the conversion in the provenance (``conversions``), whose ``significant_digits``
entry it removes. Run once, on a committed tree: ``python3 tools/restore_full_precision.py``.
"""

from __future__ import annotations

import datetime
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pfcourse  # noqa: E402,F401  (first: it pins the arithmetic)
import numpy as np  # noqa: E402

from pfcourse.studies.registry import STUDIES, same  # noqa: E402
from pfcourse.studies.store import DATA  # noqa: E402

TABLES = ("anatomy", "lockon", "kidnap", "ekf_vs_pf")
DIGITS = 10


def restore(name: str) -> dict:
    study = STUDIES[f"global_localization/{name}"]
    old = study.load()
    new = study.compute()
    assert list(new.columns) == list(old.columns) and len(new) == len(old), name
    rtol = 10.0 ** (1 - DIGITS)
    for key in new.columns:
        if key in study.volatile:
            new[key] = old[key].values  # the original run's wall times
            continue
        bad = [i for i, (a, b) in enumerate(zip(old[key], new[key])) if not same(a, b, rtol)]
        assert not bad, f"{name}: {key} differs beyond {DIGITS} digits at rows {bad[:5]}"
    changed = int(sum(not same(a, b) for key in new.columns for a, b in zip(old[key], new[key])))
    study.save(new)
    return {"table": name, "rows": len(new), "values_rounded_before": changed}


def main() -> None:
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    done = [restore(name) for name in TABLES]
    for d in done:
        print(d, flush=True)
    path = DATA / "global_localization" / "provenance.json"
    record = json.loads(path.read_text())
    for name in TABLES:
        record["significant_digits"].pop(f"{name}.csv")
    if not record["significant_digits"]:
        del record["significant_digits"]
    record["conversions"].append({
        "date_utc": datetime.date.today().isoformat(), "tool": "tools/restore_full_precision.py", "from_commit": commit,
        "change": f"{', '.join(n + '.csv' for n in TABLES)}: every row re-computed from its setting and seed "
                  f"(Study.compute) and stored at full precision; every value equal to the stored one to its "
                  f"{DIGITS} significant digits; wall times (seconds, pf_seconds, ekf_seconds) kept from the original "
                  "run; significant_digits removed",
        "rows": {d["table"]: d["rows"] for d in done}})
    path.write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main()
