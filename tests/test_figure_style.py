"""Every chapter draws its figures in the book's one style (pfcourse.book.style.use_style)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHAPTERS = sorted((ROOT / "book").rglob("*.py"))


@pytest.mark.parametrize("source", CHAPTERS, ids=lambda p: str(p.relative_to(ROOT)))
def test_chapter_with_figures_uses_the_book_style(source: Path) -> None:
    text = source.read_text()
    if not re.search(r"^\s*(import matplotlib|from matplotlib)", text, flags=re.M):
        return
    assert re.search(r"^use_style\(\)|^plotting\.use_style\(\)", text, flags=re.M), (
        f"{source.name} draws figures: call pfcourse.book.style.use_style() at the top"
    )

