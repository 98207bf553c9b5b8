"""The prose of a chapter or page, as the prose tests read it: one definition of each piece.

Used by tests/test_start_here.py (the reading time: each piece counts as one word) and
tests/test_prose_numbers.py (typed numbers: each piece is removed).
"""

from __future__ import annotations

import re
from pathlib import Path

import jupytext

#: What is not running text: display math, inline math, a role (a glued number, a citation, a
#: link: ``{glue:text}`...```), inline code.  Patterns for ``re.S | re.M``, in this order.
MATH_ROLES_CODE = [
    r"\$\$.*?\$\$",  # display math
    r"(?<![\\$])\$(?!\$)(?:\\\$|[^$])+?(?<!\\)\$",  # inline math
    r"\{[a-z:]+\}`[^`]*`",  # roles: glue, cite, ref, numref, eq, doc, ...
    r"`[^`]*`",  # code
]


HIDDEN_CODE_TAGS = {"remove-input", "hide-input", "remove-cell"}


def visible_code_lines(source: Path) -> int:
    """Non-blank lines of the code a reader sees: code cells not tagged ``remove-input``,
    ``hide-input`` or ``remove-cell`` (a page: the lines of its fenced code blocks)."""
    if source.suffix == ".md":
        blocks = re.findall(r"^(`{3,})[^\n]*\n(.*?)^\1\s*$", source.read_text(), flags=re.S | re.M)
        return sum(1 for _, body in blocks for line in body.splitlines() if line.strip())
    return sum(1 for c in jupytext.read(source).cells
               if c.cell_type == "code" and not HIDDEN_CODE_TAGS & set(c.metadata.get("tags", []))
               for line in c.source.splitlines() if line.strip())


def markdown_cells(source: Path) -> list[str]:
    """The markdown cells of a chapter source, ``""`` for each code cell (a page: one cell)."""
    if source.suffix == ".md":
        return [source.read_text()]
    return [c.source if c.cell_type == "markdown" else "" for c in jupytext.read(source).cells]
