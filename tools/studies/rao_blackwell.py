#!/usr/bin/env python3
"""Compute book/data/rao_blackwell.csv: six filters of scenario A against the Kalman posterior.

Run from the repository root (after committing the code it uses, so that the provenance
names it):  nice -n 5 .venv/bin/python tools/studies/rao_blackwell.py
Writes book/data/rao_blackwell.csv (one row per simulation, method and N; columns in
pfcourse.experiments.rb_study) and book/data/rao_blackwell.json (provenance: commit, seeds, settings,
code path, wall time).  tests/test_rao_blackwell.py re-computes a seeded sample of rows.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from pfcourse.experiments.provenance import launch_commit, write_provenance, write_rows  # noqa: E402
from pfcourse.experiments.rb_study import METHODS, THRESHOLD, run_rows  # noqa: E402

SETTINGS = {
    "quadrant": {"seeds": list(range(100)), "n_values": [30, 100, 300, 1000, 3000]},
    "circle": {"seeds": list(range(100)), "n_values": [100, 1000]},
}


def main() -> None:
    start, commit = time.time(), launch_commit()
    rows = []
    for name, cfg in SETTINGS.items():
        for seed in cfg["seeds"]:
            rows.extend(run_rows(name, seed, list(METHODS), cfg["n_values"]))
        print(f"{name}: {len(rows)} rows, {time.time() - start:.0f} s", flush=True)
    out = ROOT / "book" / "data"
    out.mkdir(parents=True, exist_ok=True)
    write_rows(out / "rao_blackwell.csv", rows)
    write_provenance(
        out / "rao_blackwell.json", code="tools/studies/rao_blackwell.py", commit=commit,
        seconds=time.time() - start,
        row_code=["pfcourse/experiments/rb_study.py", "pfcourse/landmarks/rao_blackwell.py", "pfcourse/proposals.py"],
        settings=SETTINGS, methods=METHODS, threshold=THRESHOLD,
        seeds="simulation seed s, filter seed s + 10**6 (same for every method and N)", rows=len(rows),
    )


if __name__ == "__main__":
    main()
