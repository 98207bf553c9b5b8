"""What a chapter shows of its evidence: glued numbers, and folded evidence blocks with tables.

The book's form (README, "Working on the book") keeps the plumbing out of the prose: a claim
quotes one glued number and its interval, and what backs it (the table over the settings, the
paired test, the detectable difference, the robustness checks) is folded beside it. This
module is that plumbing, so a chapter's visible code stays the code that teaches:

* :func:`glue_values` glues several named numbers in one call (myst-nb ``glue``, not displayed);
* :class:`EvidenceBlock` is a folded block titled by the claim it backs: an HTML ``<details>``
  element, closed until the reader opens it, in the HTML book and in JupyterLab alike (both
  render a cell's HTML output; no markdown directive is needed), holding notes and tables;
* :func:`html_table` renders a table as an HTML table with each column's number format (a
  printed table wraps into broken rows at the column edge; an HTML table scrolls).

The numbers an evidence block shows are formatted from the computation itself, so none is
typed. Its plain-text form (what ``print`` and strict nbval see) lists the same numbers.
"""

from __future__ import annotations

import html
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from pfcourse.errors import ParameterError


def glue_values(prefix: str = "", **values) -> None:
    """``glue(prefix + name, value, display=False)`` for each keyword: the prose quotes them.

    A NumPy scalar is glued as the Python number it holds (glued as it is, its text would be
    ``np.float64(0.05)``, which a ``{glue:text}`` role with a format cannot read).
    """
    from myst_nb import glue

    for name, value in values.items():
        glue(prefix + name, value.item() if isinstance(value, np.generic) else value, display=False)


def _formatted(table: pd.DataFrame, formats: Mapping[str, str]) -> pd.DataFrame:
    unknown = set(formats) - set(table.columns)
    if unknown:
        raise ParameterError(f"formats name columns the table does not have: {sorted(unknown)}")
    shown = table.copy()
    for column, spec in formats.items():
        shown[column] = [format(v, spec) if pd.notna(v) else "" for v in table[column]]
    return shown.astype(str)


def html_table(table: pd.DataFrame, formats: Mapping[str, str] | None = None) -> str:
    """The table as HTML, without its index, each column in ``formats`` formatted with its spec."""
    shown = _formatted(table, formats or {})
    return shown.to_html(index=False, border=0, classes="pfcourse-table", escape=True)


@dataclass
class EvidenceBlock:
    """A folded block of evidence: ``title`` (the claim it backs), notes, then tables.

    ``notes`` are sentences (plain text, numbers formatted by the caller from the computation);
    ``tables`` are ``(caption, DataFrame, formats)`` triples. Displayed as the last expression
    of a cell (or with ``display``), it renders closed, as ``Evidence: <title>``.
    """

    title: str
    notes: Sequence[str] = ()
    tables: Sequence[tuple[str, pd.DataFrame, Mapping[str, str]]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not isinstance(self.title, str) or not self.title.strip():
            raise ParameterError("an evidence block needs a title: the claim it backs")

    def _repr_html_(self) -> str:
        parts = [f'<details class="pfcourse-evidence"><summary>Evidence: {html.escape(self.title)}</summary>']
        parts += [f"<p>{html.escape(note)}</p>" for note in self.notes]
        for caption, table, formats in self.tables:
            parts.append(f'<p class="pfcourse-table-caption">{html.escape(caption)}</p>')
            parts.append(html_table(table, formats))
        parts.append("</details>")
        return "\n".join(parts)

    def __repr__(self) -> str:
        lines = [f"Evidence: {self.title}", *self.notes]
        for caption, table, formats in self.tables:
            lines += [caption, _formatted(table, formats).to_string(index=False)]
        return "\n".join(lines)


#: A glued number in a chapter's markdown: ``{glue:text}`key:fmt``` or ``{glue}`key```.
GLUE_ROLE = re.compile(r"\{glue(?::text)?\}`[^`]+`")
#: A folded block (an admonition or solution whose class includes ``dropdown``), with its fences.
FOLDED_BLOCK = re.compile(r"^(:{3,}|`{3,})\{(?:admonition|solution)\}[^\n]*\n(?:\s*:[a-z-]+:[^\n]*\n)*?"
                          r"\s*:class:[^\n]*dropdown.*?^\1\s*$", re.S | re.M)


def paragraphs_outside_folds(markdown: str) -> list[str]:
    """The paragraphs of ``markdown`` (separated by blank lines) outside folded blocks."""
    text = FOLDED_BLOCK.sub(" ", markdown)
    return [p for p in re.split(r"\n\s*\n", text) if p.strip()]


def glued_numbers_per_paragraph(markdown: str) -> list[int]:
    """How many glued numbers each paragraph outside folded blocks quotes (the book's form allows four)."""
    return [len(GLUE_ROLE.findall(p)) for p in paragraphs_outside_folds(markdown)]


def chapter_markdown(source: str | Path) -> str:
    """The markdown cells of a chapter's jupytext source ``book/partN/X.py``, joined by blank lines."""
    import jupytext

    return "\n\n".join(c.source for c in jupytext.read(Path(source)).cells if c.cell_type == "markdown")
