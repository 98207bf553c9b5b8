"""pfcourse.book.report: evidence blocks fold, show every number they are given, and refuse no title."""

from __future__ import annotations

import pandas as pd
import pytest

from pfcourse.errors import ParameterError
from pfcourse.book.report import EvidenceBlock, html_table

TABLE = pd.DataFrame({"N": [100, 1000], "error": [0.123456, 0.0456789], "method": ["SIS", "SIR <b>"]})


def test_an_evidence_block_is_closed_titled_by_its_claim_and_holds_its_tables():
    block = EvidenceBlock("SIR beats SIS", notes=["Wilcoxon p = 0.001 over 100 paired runs."],
                          tables=[("Median error (m)", TABLE, {"error": ".3f"})])
    page = block._repr_html_()
    assert page.startswith('<details class="pfcourse-evidence"><summary>Evidence: SIR beats SIS</summary>')
    assert " open" not in page.split(">", 1)[0]  # folded until the reader opens it
    assert "<td>0.123</td>" in page and "<td>0.046</td>" in page and "0.1234" not in page
    assert "SIR &lt;b&gt;" in page  # text is escaped, not markup
    text = repr(block)
    assert text.splitlines()[0] == "Evidence: SIR beats SIS" and "0.123" in text and "0.046" in text


def test_a_block_needs_a_title_and_formats_need_existing_columns():
    with pytest.raises(ParameterError, match="title"):
        EvidenceBlock("  ")
    with pytest.raises(ParameterError, match="errr"):
        html_table(TABLE, {"errr": ".2f"})


def test_a_missing_value_shows_as_an_empty_cell():
    table = pd.DataFrame({"x": [1.0, float("nan")]})
    assert "<td></td>" in html_table(table, {"x": ".1f"})


def test_glue_values_glues_numpy_scalars_as_plain_numbers(monkeypatch):
    import myst_nb
    import numpy as np

    from pfcourse.book.report import glue_values

    glued = {}
    monkeypatch.setattr(myst_nb, "glue", lambda name, value, display: glued.update({name: (value, display)}))
    glue_values("p_", a=np.float64(0.25), n=np.int64(3), text="mixture")
    assert glued == {"p_a": (0.25, False), "p_n": (3, False), "p_text": ("mixture", False)}
    assert type(glued["p_a"][0]) is float and type(glued["p_n"][0]) is int
