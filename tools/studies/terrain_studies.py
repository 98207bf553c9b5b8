"""Write book/data/terrain_studies.csv: the report's terrain studies on the regularised baseline.

    python3 tasks.py study terrain_studies [N_FLIGHTS]

One row per (study, setting, flight) of pfcourse.experiments.terrain_studies (100 flights by
default, the flights of book/data/terrain_remedies.csv); book/data/terrain_studies.json records
the provenance. tests/test_terrain_studies.py re-computes a seeded sample of rows.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse.experiments import terrain_studies as ts
from pfcourse.experiments.provenance import launch_commit, write_provenance, write_rows
from pfcourse.experiments.study import run_study
from pfcourse.terrain.map import load_jacksboro

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data"
_TERRAIN = None


def row(seed: int, pair: str, flight: int) -> dict:
    """run_study's run function: ``pair`` is ``"study/setting"``; ``seed`` is unused (flight seeds)."""
    global _TERRAIN
    if _TERRAIN is None:
        _TERRAIN = load_jacksboro()
    study, setting = pair.split("/", 1)
    out = ts.study_row(study, setting, flight, _TERRAIN)
    del out["study"], out["setting"], out["flight"]
    return out


def main(n_flights: int) -> None:
    start, commit = time.time(), launch_commit()
    pairs = [f"{s}/{n}" for s, n in ts.settings()]
    table = run_study(row, {"pair": pairs, "flight": list(range(n_flights))}, 1, progress=False)
    table[["study", "setting"]] = table["pair"].str.split("/", n=1, expand=True)
    columns = ["study", "setting", "flight", "final_error", "mean_error", "lost", "sigma_50", "sigma_75",
               "resamplings", "median_ess_fraction", "seconds"]
    write_rows(OUT / "terrain_studies.csv", table[columns].to_dict("records"))
    write_provenance(OUT / "terrain_studies.json", code="tools/studies/terrain_studies.py", commit=commit,
                     seconds=time.time() - start, row_code="pfcourse/experiments/terrain_studies.py (study_row)",
                     n_flights=n_flights, baseline={"N": ts.BASELINE_N, "threshold": ts.BASELINE_THRESHOLD,
                                                    "scheme": ts.BASELINE_SCHEME, "kernel_scale": ts.KERNEL_SCALE},
                     studies=ts.STUDIES,
                     seeds="flight r: pfcourse.seeding.data_rng(0, r) = default_rng([0, r, 0]); filter: pfcourse.seeding.filter_rng(0, r) = default_rng([0, r, 1])",
                     divergence="final horizontal error > 500 m or every particle lost",
                     seconds_column="wall time of one run on a shared 2-core machine: indicative only")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
