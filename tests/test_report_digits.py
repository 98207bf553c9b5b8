"""pfcourse.book.report: a table's float column given no format shows sensible digits (issue 39).

A raw ``describe()`` printed 17-digit floats (0.05973297374498274) in an evidence table. A float
column with no format and more digits than a reader can use now shows four significant digits;
a column that already reads well (1.0, 0.25, 1e-05) keeps its text, and a column given a format
keeps that format.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from pfcourse.errors import ParameterError
from pfcourse.book.report import SIGNIFICANT_DIGITS, EvidenceBlock, html_table, significant, spread_table


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0.05973297374498274, "0.05973"),
        (33.23076923076923, "33.23"),
        (3.8000000000000007, "3.8"),  # float noise, not a fifth digit
        (26.0, "26"),
        (-0.0012345678, "-0.001235"),
        (123456.7, "123457"),  # no exponent for an everyday magnitude
        (1.23456789e-05, "1.235e-05"),
        (9.99996, "10"),
        (0.0, "0"),
    ],
)
def test_significant_rounds_to_four_digits_without_trailing_zeros(value, text):
    assert SIGNIFICANT_DIGITS == 4
    assert significant(value) == text


def test_significant_keeps_the_value_within_its_rounding():
    rng = np.random.default_rng(39)
    for value in rng.lognormal(0.0, 6.0, 500) * rng.choice([-1, 1], 500):
        shown = float(significant(value))
        # four significant digits: within half a unit of the fourth digit
        assert abs(shown - value) <= 0.5 * 10 ** (np.floor(np.log10(abs(value))) - 3) * (1 + 1e-9)


def test_a_noisy_float_column_without_format_shows_four_significant_digits():
    runs = pd.Series([0.05973297374498274, 0.04884128163636181, 0.07715340119782887])
    table = runs.describe(percentiles=[0.5]).to_frame().T  # count 3.0, mean, std, min, 50%, max
    page = html_table(table)
    assert "<td>0.05973</td>" in page and "<td>0.04884</td>" in page and "<td>0.07715</td>" in page
    assert "0.0597329" not in page and "0.0488412" not in page
    assert "<td>3.0</td>" in page  # the count column reads well as it is: left alone
    text = repr(EvidenceBlock("x", tables=[("rmse (m)", table, {})]))
    assert "0.05973" in text and "0.0597329" not in text  # the plain-text form alike


def test_columns_that_read_well_or_have_a_format_are_left_as_they_were():
    table = pd.DataFrame({"N": [1.0, 20.0, 100.0], "p": [0.25, 1e-05, 0.5], "text": ["a", "b", "c"],
                          "n": [1, 2, 3], "error": [0.123456789, 0.5, 0.25]})
    page = html_table(table, {"error": ".2f"})
    for cell in ("1.0", "20.0", "100.0", "0.25", "1e-05", "0.5", "a", "3", "0.12", "0.50"):
        assert f"<td>{cell}</td>" in page, cell
    assert "0.1235" not in page  # a given format wins over the default


def test_missing_values_stay_empty_in_a_reformatted_column():
    table = pd.DataFrame({"x": [0.123456789123, float("nan")]})
    page = html_table(table)
    assert "<td>0.1235</td>" in page and "<td></td>" in page


def test_a_spread_table_names_its_columns_with_units_and_keeps_describes_numbers():
    values = np.random.default_rng(7).gamma(2.0, 0.03, 100)
    table, formats = spread_table(values, "m", ".3f")
    assert list(table.columns) == ["runs", "mean (m)", "sd (m)", "min (m)", "10 % (m)", "median (m)",
                                   "90 % (m)", "max (m)"]
    described = pd.Series(values).describe(percentiles=[0.1, 0.5, 0.9])
    assert table.iloc[0].tolist() == described.tolist()  # the numbers themselves are describe's
    page = html_table(table, formats)
    assert "<td>100</td>" in page and f"<td>{values.mean():.3f}</td>" in page
    assert f"<td>{np.median(values):.3f}</td>" in page and "<th></th>" not in page
    assert all(len(cell) <= 6 for cell in re.findall(r"<td>(.*?)</td>", page))


def test_a_spread_table_needs_a_unit():
    with pytest.raises(ParameterError, match="unit"):
        spread_table([1.0, 2.0], "", ".1f")
