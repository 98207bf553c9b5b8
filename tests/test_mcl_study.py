"""The per-step table of the global-localization chapter (modes.csv) is what its row function computes.

A seeded run of each method is re-computed with pfcourse.experiments.global_localization and must give
the same numbers (stored with 10 significant digits); see tools/studies/global_localization_traces.py.
The chapter's other tables are registered studies, re-computed by tests/test_stored_studies.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from pfcourse.experiments import global_localization as mcl_study
from pfcourse.experiments.registry import same

DATA = Path(__file__).resolve().parents[1] / "book" / "data" / "global_localization"
RNG = np.random.default_rng(2026)


def test_provenance_names_the_code_commit_and_seeds():
    prov = json.loads((DATA / "provenance.json").read_text())
    assert prov["code"] and len(prov["git_commit"]) == 40 and "seed" in prov["seeds"]  # the chapter prints them


def test_mode_rows():
    table = pd.read_csv(DATA / "modes.csv")
    for method in ("bootstrap", "mixture"):
        seed = int(RNG.integers(0, table["seed"].max() + 1))
        stored = table[(table["method"] == method) & (table["seed"] == seed)].sort_values("step")
        fresh = mcl_study.mode_run(seed, method)
        for key in ("mass_near_truth", "ess_fraction"):
            assert all(same(s, f, rtol=1e-9) for s, f in zip(stored[key], fresh[key])), key
