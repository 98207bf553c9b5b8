"""The stored study of SIR's fixes: the readings behave as theory says (its rows are re-computed by
tests/test_stored_studies.py)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from pfcourse.studies.sir_fixes_study import variant_row

DATA = Path(__file__).resolve().parents[1] / "book" / "data" / "sir_fixes.csv"


def test_unknown_variant_is_refused():
    with pytest.raises(ValueError, match="unknown variant"):
        variant_row("nonsense", 10, 0)


@pytest.mark.skipif(not DATA.exists(), reason="the study's data are not computed")
def test_exact_model_converges_and_static_sir_does_not():
    """With the noise in simulator and filter the filter's model is exact: error ~ N^-1/2."""
    with open(DATA) as f:
        rows = list(csv.DictReader(f))

    def median(variant, n):
        return np.median([float(r["error"]) for r in rows if r["variant"] == variant and int(r["N"]) == n])

    exact = np.log(median("noise_everywhere", 3000) / median("noise_everywhere", 100)) / np.log(30)
    static = np.log(median("sir", 3000) / median("sir", 100)) / np.log(30)
    assert -0.65 < exact < -0.35
    assert static > -0.35
