#!/usr/bin/env python3
"""Compute book/data/rao_blackwell.csv: six filters of scenario A against the Kalman posterior.

Run from the repository root (after committing the code it uses, so that the provenance
names it):  nice -n 5 .venv/bin/python tools/studies/rao_blackwell.py
Writes book/data/rao_blackwell.csv (one row per simulation, method and N; columns in
pfcourse.experiments.rb_study) and book/data/rao_blackwell.json (provenance: commit, seeds, settings,
code path, wall time).  tests/test_rao_blackwell.py re-computes a seeded sample of rows.
"""

from __future__ import annotations

import csv
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from pfcourse.experiments.rb_study import METHODS, THRESHOLD, run_rows  # noqa: E402

SETTINGS = {
    "quadrant": {"seeds": list(range(100)), "n_values": [30, 100, 300, 1000, 3000]},
    "circle": {"seeds": list(range(100)), "n_values": [100, 1000]},
}


def main() -> None:
    start = time.time()
    rows = []
    for name, cfg in SETTINGS.items():
        for seed in cfg["seeds"]:
            rows.extend(run_rows(name, seed, list(METHODS), cfg["n_values"]))
        print(f"{name}: {len(rows)} rows, {time.time() - start:.0f} s", flush=True)
    out = ROOT / "book" / "data"
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "rao_blackwell.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(float(v)) if isinstance(v, float) else v for k, v in row.items()})
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "pfcourse"], cwd=ROOT,
                                capture_output=True, text=True).stdout.strip())
    json.dump({
        "made_by": "tools/studies/rao_blackwell.py",
        "code": ["pfcourse/experiments/rb_study.py", "pfcourse/landmarks/rao_blackwell.py", "pfcourse/landmarks/auxiliary.py"],
        "git_commit": commit,
        "package_dirty_at_run": dirty,
        "settings": SETTINGS,
        "methods": METHODS,
        "threshold": THRESHOLD,
        "seeds": "simulation seed s, filter seed s + 10**6 (same for every method and N)",
        "rows": len(rows),
        "wall_seconds": round(time.time() - start, 1),
        "python": platform.python_version(),
        "machine": platform.machine(),
    }, open(out / "rao_blackwell.json", "w"), indent=1)


if __name__ == "__main__":
    main()
