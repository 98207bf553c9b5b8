#!/usr/bin/env python3
"""Compute book/data/sir_fixes.csv: SIR's fixes on scenario A over N (pfcourse.experiments.sir_fixes_study).

Run from the repository root after committing the code:  nice -n 5 .venv/bin/python tools/studies/sir_fixes.py
Provenance in book/data/sir_fixes.json; tests/test_sir_fixes_study.py re-computes sampled rows.
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
from pfcourse.experiments.sir_fixes_study import LANDMARK_NOISE, variant_row  # noqa: E402

VARIANTS = ["sir", "noise_filter_only", "noise_everywhere",
            "roughening_0.05", "roughening_0.1", "roughening_0.2", "roughening_0.4"]
N_VALUES = [100, 300, 1000, 3000]
SEEDS = list(range(100))


def main() -> None:
    start, commit = time.time(), launch_commit()
    rows = [variant_row(v, n, s) for v in VARIANTS for n in N_VALUES for s in SEEDS]
    out = ROOT / "book" / "data"
    write_rows(out / "sir_fixes.csv", rows)
    write_provenance(out / "sir_fixes.json", code="tools/studies/sir_fixes.py", commit=commit,
                     seconds=time.time() - start, row_code=["pfcourse/experiments/sir_fixes_study.py"],
                     variants=VARIANTS, n_values=N_VALUES, seeds="0-99; filter seed s + 10**6; threshold N/3",
                     landmark_noise=LANDMARK_NOISE, rows=len(rows))

if __name__ == "__main__":
    main()
