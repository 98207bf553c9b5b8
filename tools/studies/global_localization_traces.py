"""Compute the per-step tables of the chapter book/part2/global_localization: modes.csv and kld_trace.csv.

    python3 tasks.py study global_localization_traces [--runs 100]

``modes.csv`` has one row per (method, run, step) (pfcourse.experiments.global_localization.mode_rows)
and ``kld_trace.csv`` the quantiles over the runs of the KLD filters' particle counts per step:
neither is a table of one row per seeded run, so they are not registered studies (the chapter's
other tables are: ``python3 tasks.py study global_localization``). Run r uses seed r. Provenance
in book/data/global_localization/traces.json; tests/test_mcl_study.py re-computes sampled rows.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

import pfcourse  # noqa: F401  (pins the arithmetic first)
from pfcourse.experiments import global_localization as mcl_study
from pfcourse.experiments.provenance import launch_commit, write_provenance
from pfcourse.experiments.store import DATA, save
from pfcourse.robot.mcl import MethodSettings

OUT = DATA / "global_localization"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=100)
    args = parser.parse_args()
    seeds = range(args.runs)
    started, commit = time.time(), launch_commit()
    save(OUT / "modes.csv", pd.DataFrame([row for m in ("bootstrap", "mixture") for s in seeds
                                          for row in mcl_study.mode_rows(s, m)]))
    trace = []
    for m, n in mcl_study.TRACE:
        runs = [mcl_study.global_run(s, m, n, keep_trace=True) for s in seeds]
        used = np.array([r["n_used"] for r in runs])
        err = np.array([r["position_error"] for r in runs])
        for k in range(used.shape[1]):
            trace.append({"method": m, "n": n, "step": k, "n_used_median": float(np.median(used[:, k])),
                          "n_used_q10": float(np.quantile(used[:, k], 0.1)), "n_used_q90": float(np.quantile(used[:, k], 0.9)),
                          "error_median": float(np.median(err[:, k]))})
    save(OUT / "kld_trace.csv", pd.DataFrame(trace))
    write_provenance(
        OUT / "traces.json", code="tools/studies/global_localization_traces.py", commit=commit,
        seconds=time.time() - started, file=["modes.csv", "kld_trace.csv"],
        row_functions="pfcourse/experiments/global_localization.py (mode_rows, global_run)",
        seeds=f"run r uses seed r, r = 0..{args.runs - 1}, for every setting",
        settings={"kld_trace": mcl_study.TRACE, "method_settings": MethodSettings().__dict__},
    )


if __name__ == "__main__":
    main()
