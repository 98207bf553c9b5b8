"""Compute the tables of the chapter book/part2/global_localization (about 10 min on one core).

    .venv/bin/python tools/studies/global_localization.py [--runs 100]

Writes CSV files and provenance.json under book/data/global_localization/.  Every row comes
from one function of pfcourse.experiments.global_localization called with the run's seed (run r uses seed r, the
same truths for every method and N); tests/test_mcl_study.py re-computes a random sample of
rows and requires the same numbers (wall times excepted).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from pfcourse.experiments import global_localization as mcl_study  # noqa: E402
from pfcourse.experiments.provenance import launch_commit, write_provenance  # noqa: E402
from pfcourse.robot.mcl import MethodSettings  # noqa: E402

OUT = ROOT / "book" / "data" / "global_localization"
ANATOMY_N = [300, 1000, 2000, 10000, 30000, 100000]
LOCKON = [("bootstrap", 300), ("bootstrap", 1000), ("bootstrap", 2000), ("bootstrap", 10000), ("bootstrap", 30000),
          ("mixture", 300), ("mixture", 1000), ("mixture", 2000),
          ("augmented", 1000), ("augmented", 2000),
          ("kld", 2000), ("kld", 30000), ("kld_mixture", 2000),
          ("tempered", 300), ("tempered", 1000), ("tempered", 2000)]
KIDNAP = [("bootstrap", 2000), ("mixture", 2000), ("augmented", 2000), ("kld", 2000), ("kld_mixture", 2000),
          ("tempered", 2000)]
TRACE = [("kld", 30000), ("kld_mixture", 2000)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=100)
    args = parser.parse_args()
    seeds = range(args.runs)
    OUT.mkdir(parents=True, exist_ok=True)
    started, commit = time.time(), launch_commit()

    def save(name, rows):
        pd.DataFrame(rows).to_csv(OUT / f"{name}.csv", index=False, float_format="%.10g")
        print(f"{name}: {len(rows)} rows, {time.time() - started:.0f} s", flush=True)

    save("anatomy", [mcl_study.anatomy_row(s, n) for n in ANATOMY_N for s in seeds])
    save("modes", [row for m in ("bootstrap", "mixture") for s in seeds for row in mcl_study.mode_rows(s, m)])
    save("lockon", [mcl_study.lockon_row(s, m, n) for m, n in LOCKON for s in seeds])
    trace = []
    for m, n in TRACE:
        from pfcourse.robot.mcl import global_run
        runs = [global_run(s, m, n, keep_trace=True) for s in seeds]
        used = np.array([r["n_used"] for r in runs])
        err = np.array([r["position_error"] for r in runs])
        for k in range(used.shape[1]):
            trace.append({"method": m, "n": n, "step": k, "n_used_median": float(np.median(used[:, k])),
                          "n_used_q10": float(np.quantile(used[:, k], 0.1)), "n_used_q90": float(np.quantile(used[:, k], 0.9)),
                          "error_median": float(np.median(err[:, k]))})
    save("kld_trace", trace)
    save("kidnap", [mcl_study.kidnap_row(s, m, n) for m, n in KIDNAP for s in seeds])
    save("ekf_vs_pf", [mcl_study.ekf_row(s, name) for name in mcl_study.EKF_SETTINGS for s in seeds])

    write_provenance(
        OUT / "provenance.json", code="tools/studies/global_localization.py", commit=commit,
        seconds=time.time() - started,
        row_functions="pfcourse/experiments/global_localization.py (anatomy_row, mode_rows, lockon_row, kidnap_row, ekf_row)",
        seeds=f"run r uses seed r, r = 0..{args.runs - 1}, for every setting",
        settings={"anatomy_n": ANATOMY_N, "lockon": LOCKON, "kidnap": KIDNAP, "kld_trace": TRACE,
                  "method_settings": MethodSettings().__dict__,
                  "ekf_settings": {k: {kk: list(v) if isinstance(v, tuple) else v for kk, v in d.items()}
                                   for k, d in mcl_study.EKF_SETTINGS.items()}},
    )


if __name__ == "__main__":
    main()
