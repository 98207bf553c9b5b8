"""book/data/terrain_studies.csv: the baseline's rows are the regularised N = 30000 rows of
book/data/terrain_remedies.csv (same flights, same filter seeds). tests/test_stored_studies.py
re-computes a seeded sample of its rows and checks that it has every setting and flight.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ParameterError
from pfcourse.studies import terrain_studies as ts

DATA = Path(__file__).resolve().parents[1] / "book" / "data"
TABLE = pd.read_csv(DATA / "terrain_studies.csv")


def test_baseline_rows_are_the_regularised_rows_of_the_remedies_table():
    remedies = pd.read_csv(DATA / "terrain_remedies.csv")
    reg = remedies[remedies["setting"] == "regularised N=30000"].set_index("flight")
    base = TABLE[TABLE["study"] == "baseline"].set_index("flight")
    common = base.index.intersection(reg.index)
    assert len(common) == len(base)
    np.testing.assert_allclose(base.loc[common, "final_error"], reg.loc[common, "final_error"], rtol=1e-9)
    assert (base.loc[common, "lost"].astype(bool) == reg.loc[common, "lost"].astype(bool)).all()


def test_unknown_settings_are_named():
    with pytest.raises(ParameterError, match="unknown study/setting"):
        ts.configure("Qf", "Qf x 3")
