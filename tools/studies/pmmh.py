"""Part V's PMMH chains, stored under book/data/likelihood/ (the other Part V studies are registered:
pfcourse.studies.likelihood_studies, `python3 tasks.py study likelihood`).

    python3 tasks.py study pmmh

``pmmh.csv``: one PMMH chain per N in N_PMMH on the chapter's dataset (theta scales Rv).

A chain is not a table of independent seeded runs (each row depends on the one before), so it
is not a registered study; each file has a ``.json`` beside it with its provenance, and
``tests/test_likelihood_data.py`` re-computes the first iterations of a seeded choice of chain.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import pfcourse  # noqa: F401  (pins the arithmetic before numpy computes anything)
from pfcourse.studies.likelihood_studies import (BOUNDS, DATA_SEED, N_PMMH, PMMH_ITERATIONS, PMMH_SEED,
                                                     PMMH_STEP, PMMH_THETA0, SCENARIO_TEXT, pmmh_chain)
from pfcourse.studies.provenance import launch_commit, write_provenance

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "book" / "data" / "likelihood"


def main(parts: list[str]) -> None:
    commit = launch_commit()
    OUT.mkdir(parents=True, exist_ok=True)
    if "pmmh" in parts:
        start = time.perf_counter()
        frames, seeds = [], {}
        for n in N_PMMH:
            chain, seeds[n] = pmmh_chain(n)
            frames.append(pd.DataFrame({"n_particles": n, "iteration": np.arange(chain.theta.size),
                                        "theta": chain.theta, "log_likelihood": chain.log_likelihood,
                                        "accepted": chain.accepted}))
        pd.concat(frames).to_csv(OUT / "pmmh.csv", index=False)
        write_provenance(OUT / "pmmh.json", code="tools/studies/pmmh.py", commit=commit,
                         seconds=time.perf_counter() - start, file="pmmh.csv", data_seed=DATA_SEED,
                         n_particles=N_PMMH, iterations=PMMH_ITERATIONS, step_log_theta=PMMH_STEP,
                         theta0=PMMH_THETA0, prior=f"log-uniform on {BOUNDS}", chain_seeds=seeds,
                         seeds=f"replicate_seed({PMMH_SEED}, n_particles)", scenario=SCENARIO_TEXT)


if __name__ == "__main__":
    main(sys.argv[1:] or ["pmmh"])
