"""The study figures draw the median and the 10-90 % band they promise."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ShapeError
from pfcourse.book.figures.study import summary_band, time_band


def test_summary_band_draws_the_quantiles():
    summary = pd.DataFrame({"q10": [1.0, 2.0], "q50": [2.0, 3.0], "q90": [4.0, 5.0], "n_ok": [9, 10],
                            "n_failed": [1, 0]}, index=[0.5, 1.0])
    fig, ax = plt.subplots()
    summary_band(summary, ax)
    line = ax.lines[0]
    np.testing.assert_array_equal(line.get_xdata(), [0.5, 1.0])
    np.testing.assert_array_equal(line.get_ydata(), [2.0, 3.0])
    band = ax.collections[0].get_paths()[0].vertices
    assert band[:, 1].min() == 1.0 and band[:, 1].max() == 5.0
    assert [t.get_text() for t in ax.texts] == ["1 failed"]
    plt.close(fig)


def test_summary_band_categorical_and_bad_input():
    summary = pd.DataFrame({"q10": [1.0], "q50": [2.0], "q90": [4.0]}, index=["systematic"])
    fig, ax = plt.subplots()
    summary_band(summary, ax, categorical=True)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["systematic"]
    with pytest.raises(ShapeError, match="q10, q50 and q90"):
        summary_band(summary.drop(columns="q90"), ax)
    plt.close(fig)


def test_time_band_median_over_runs():
    values = np.arange(12.0).reshape(4, 3)  # 4 runs, 3 steps
    fig, ax = plt.subplots()
    time_band([0, 1, 2], values, ax)
    np.testing.assert_allclose(ax.lines[0].get_ydata(), np.median(values, axis=0))
    with pytest.raises(ShapeError):
        time_band([0, 1], values, ax)
    plt.close(fig)
