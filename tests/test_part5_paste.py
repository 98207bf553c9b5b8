"""Part V's visible code, pasted into a blank session, imports pfcourse before NumPy (student_p5, item 14), so
the pasted session runs on the book's pinned arithmetic and prints no ReproducibilityWarning."""

import re

import pytest

from test_first_text import code_lines

PART5 = ["part5/likelihood", "part5/particle_mcmc", "part5/smoothing", "part5/static_parameters"]


@pytest.mark.parametrize("doc", PART5)
def test_the_visible_code_imports_pfcourse_before_numpy(doc):
    lines = code_lines(doc)
    first_pfcourse = next(i for i, line in enumerate(lines) if re.match(r"\s*(from|import) pfcourse", line))
    first_numpy = next(i for i, line in enumerate(lines) if re.match(r"\s*(import numpy|from numpy)", line))
    assert first_pfcourse < first_numpy, f"{doc}: NumPy is imported before pfcourse in the visible code"
