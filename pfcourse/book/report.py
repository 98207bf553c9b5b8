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
  printed table wraps into broken rows at the column edge; an HTML table scrolls). A float
  column given no format whose numbers carry more digits than a reader can use (a mean such as
  ``0.05973297374498274``) shows :data:`SIGNIFICANT_DIGITS` significant digits instead;
  other columns show as pandas shows them.

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


#: The significant digits of a float column that has no format and too many digits.
SIGNIFICANT_DIGITS = 4
#: A float "has too many digits" when its shortest repr carries more significant digits than this
#: (float noise such as 3.8000000000000007, or an unrounded mean); 0.25 or 1e-05 keep their text.
_MAX_PLAIN_DIGITS = 6


def _significant_digits(value: float) -> int:
    """How many significant digits the shortest repr of ``value`` shows (0.0597329 -> 6, 26.0 -> 2)."""
    mantissa = repr(abs(float(value))).split("e")[0]
    return len(mantissa.replace(".", "").strip("0"))


def significant(value: float, digits: int = SIGNIFICANT_DIGITS) -> str:
    """``value`` with ``digits`` significant digits, without trailing zeros, and without an exponent
    for everyday magnitudes: 0.05973297 -> "0.05973", 33.2307 -> "33.23", 26.0 -> "26",
    123456.7 -> "123457"; below 1e-4 in scientific notation (1.23456e-05 -> "1.235e-05")."""
    if not np.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    magnitude = int(np.floor(np.log10(abs(value))))
    if magnitude < -4:
        mantissa, exponent = f"{value:.{digits - 1}e}".split("e")
        return (mantissa.rstrip("0").rstrip(".") if "." in mantissa else mantissa) + "e" + exponent
    text = f"{value:.{max(0, digits - 1 - magnitude)}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def _default_format(column: pd.Series) -> pd.Series | None:
    """A float column with too many digits, shown with SIGNIFICANT_DIGITS; None to leave it as it is."""
    if not pd.api.types.is_float_dtype(column):
        return None
    values = column.dropna()
    if not any(_significant_digits(v) > _MAX_PLAIN_DIGITS for v in values if np.isfinite(v)):
        return None
    return pd.Series([significant(v) if pd.notna(v) else "" for v in column], index=column.index)


def _formatted(table: pd.DataFrame, formats: Mapping[str, str]) -> pd.DataFrame:
    unknown = set(formats) - set(table.columns)
    if unknown:
        raise ParameterError(f"formats name columns the table does not have: {sorted(unknown)}")
    shown = table.copy()
    for column in table.columns:
        if column in formats:
            shown[column] = [format(v, formats[column]) if pd.notna(v) else "" for v in table[column]]
        elif (default := _default_format(table[column])) is not None:
            shown[column] = default
    return shown.astype(str)


def html_table(table: pd.DataFrame, formats: Mapping[str, str] | None = None) -> str:
    """The table as HTML, without its index, each column in ``formats`` formatted with its spec."""
    shown = _formatted(table, formats or {})
    return shown.to_html(index=False, border=0, classes="pfcourse-table", escape=True)


def spread_table(values, unit: str, spec: str, percentiles: Sequence[float] = (0.1, 0.5, 0.9),
                 count: str = "runs") -> tuple[pd.DataFrame, dict[str, str]]:
    """The spread of ``values`` over runs as one table row with its units, and its formats.

    The numbers are pandas' ``describe`` (count, mean, standard deviation, minimum, the
    ``percentiles``, maximum); the columns are named for a reader, each with ``unit``
    ("mean (m)", "sd (m)", "10 % (m)", "median (m)", ...), the count as an integer and every
    other number with ``spec``. Use as ``tables=[(caption, *spread_table(...))]``.
    """
    if not unit or not isinstance(unit, str):
        raise ParameterError("a spread table needs the unit of its values (e.g. 'm', 's')")
    described = pd.Series(values, dtype=float).describe(percentiles=list(percentiles))
    names = {"count": count, "mean": f"mean ({unit})", "std": f"sd ({unit})", "min": f"min ({unit})",
             "max": f"max ({unit})", "50%": f"median ({unit})"}
    table = described.to_frame().T.rename(
        columns=lambda c: names.get(c, f"{c.rstrip('%')} % ({unit})" if c.endswith("%") else c))
    formats = {column: (".0f" if column == count else spec) for column in table.columns}
    return table.reset_index(drop=True), formats


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
