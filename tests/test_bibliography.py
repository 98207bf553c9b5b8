"""The bibliography lists only cited works (book/references.md), so every entry must be cited."""

from __future__ import annotations

import re
from pathlib import Path

BOOK = Path(__file__).resolve().parents[1] / "book"


def test_every_bibliography_entry_is_cited_and_every_citation_exists() -> None:
    keys = re.findall(r"^@\w+\{([^,\s]+),", (BOOK / "references.bib").read_text(), flags=re.M)
    assert len(keys) == len(set(keys)), "duplicate keys in book/references.bib"
    sources = [p for p in BOOK.rglob("*") if p.suffix in (".md", ".py") and "_build" not in p.parts]
    cited = set()
    for source in sources:
        for group in re.findall(r"\{cite(?::[a-z]+)*\}`([^`]+)`", source.read_text()):
            cited.update(key.strip() for key in group.split(","))
    assert not set(keys) - cited, f"entries never cited (cite them or remove them): {sorted(set(keys) - cited)}"
    assert not cited - set(keys), f"citations without an entry: {sorted(cited - set(keys))}"
