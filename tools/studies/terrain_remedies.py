"""Write book/data/terrain_remedies.csv: each (setting, flight) of pfcourse.experiments.terrain_remedies.

Usage: .venv/bin/python tools/studies/terrain_remedies.py N_FLIGHTS SETTING [SETTING ...]
Rows are appended (one line per run, flushed), so a long study can be stopped and resumed;
book/data/terrain_remedies.json records the provenance (git commit, seeds, code path).
"""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path

from pfcourse.experiments.provenance import launch_commit
from pfcourse.experiments.terrain_remedies import SETTINGS, run_one
from pfcourse.terrain.map import load_jacksboro

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data" / "terrain_remedies.csv"
FIELDS = ["setting", "flight", "N", "final_error", "mean_error", "lost", "evaluations", "seconds"]


def main() -> None:
    n_flights = int(sys.argv[1])
    settings = sys.argv[2:]
    for s in settings:
        if s not in SETTINGS:
            raise SystemExit(f"unknown setting {s!r}")
    terrain = load_jacksboro()
    done = set()
    if OUT.exists():
        with OUT.open() as f:
            done = {(r["setting"], int(r["flight"])) for r in csv.DictReader(f)}
    new = not OUT.exists()
    commit = launch_commit()
    meta_path = OUT.with_suffix(".json")
    meta = json.loads(meta_path.read_text()) if meta_path.exists() else {"runs": []}
    meta.update({"code": "pfcourse/experiments/terrain_remedies.py (run_one), tools/studies/terrain_remedies.py",
                 "seeds": "flight r: pfcourse.seeding.data_rng(0, r) = default_rng([0, r, 0]); filter: pfcourse.seeding.filter_rng(0, r) = default_rng([0, r, 1])",
                 "divergence": "final horizontal error > 500 m or every particle lost",
                 "seconds": "wall time of one run on a shared 2-core machine: indicative only"})
    meta["runs"].append({"commit": commit, "flights": n_flights, "settings": settings,
                         "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())})
    meta_path.write_text(json.dumps(meta, indent=1))
    with OUT.open("a", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        if new:
            w.writeheader()
        for s in settings:
            for r in range(n_flights):
                if (s, r) in done:
                    continue
                t0 = time.perf_counter()
                row = run_one(s, r, terrain)
                row["seconds"] = round(time.perf_counter() - t0, 3)
                w.writerow(row)
                f.flush()


if __name__ == "__main__":
    main()
