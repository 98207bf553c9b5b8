"""The front of the book tells the truth about the book (issue 29).

- The route table of book/start_here.md lists every chapter of the table of contents, once,
  in its order, and states a reading time that agrees with the chapter's prose;
- every part's page links to every chapter of its part.

Reading time (issue 39), as ``start_here.md`` states it: the words of the prose (markdown outside
code blocks and folded blocks such as evidence and solutions, exercises included; a formula, a code
span or a role counts as one word) at
150 words a minute, plus 30 s for each display equation outside folded blocks and 6 s for each
line of code the reader sees (code cells not hidden or removed), rounded up to a minute. A stated
time may be off by a quarter
or two minutes, whichever is more, so a small edit of a chapter does not force an edit here,
and a rewritten chapter (half as long) does.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
import yaml

from prose_text import MATH_ROLES_CODE, markdown_cells, visible_code_lines

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
WORDS_PER_MINUTE = 150
SECONDS_PER_DISPLAY_EQUATION = 30
SECONDS_PER_CODE_LINE = 6
START_HERE = (BOOK / "start_here.md").read_text()

_NOT_PROSE = [
    # folded evidence blocks: a dropdown (``:::{dropdown}``, ``:::{admonition} ... :class: dropdown``)
    r"^(:{3,}|`{3,})\{(?:dropdown|admonition|solution)\}[^\n]*\n(?:(?!\1)[^\n]*\n)*?\s*:class:[^\n]*dropdown.*?^\1\s*$",
    r"^(:{3,}|`{3,})\{dropdown\}.*?^\1\s*$",
    r"^(`{3,})(?!\{exercise\}).*?^\1\s*$",  # code blocks (an exercise's text is read)
]


def _unfolded_markdown(path: Path, patterns: list[str] = _NOT_PROSE) -> str:
    text = "\n".join(markdown_cells(path))
    for pattern in patterns:
        text = re.sub(pattern, " ", text, flags=re.S | re.M)
    return text


def display_equations(path: Path) -> int:
    """Display equations outside folded blocks: ``$$ ... $$`` and ``{math}`` directives."""
    text = _unfolded_markdown(path)
    folds_only = _unfolded_markdown(path, _NOT_PROSE[:2])
    fenced_math = len(re.findall(r"^(?::{3,}|`{3,})\{math\}", folds_only, flags=re.M))
    return len(re.findall(r"\$\$.*?\$\$", text, flags=re.S)) + fenced_math


def prose_words(path: Path) -> int:
    """Words of a chapter's (``.py``) or page's (``.md``) prose, folded evidence blocks excluded."""
    text = _unfolded_markdown(path)
    for pattern in MATH_ROLES_CODE:  # read as one word each: an equation, a formula, a role, code
        text = re.sub(pattern, " word ", text, flags=re.S | re.M)
    return len(re.findall(r"[A-Za-z][A-Za-z'-]*", text))


def reading_seconds(path: Path) -> float:
    return (60 * prose_words(path) / WORDS_PER_MINUTE + SECONDS_PER_DISPLAY_EQUATION * display_equations(path)
            + SECONDS_PER_CODE_LINE * visible_code_lines(path))


def reading_minutes(paths: list[Path]) -> int:
    return math.ceil(sum(reading_seconds(p) for p in paths) / 60)


def source_of(doc: str) -> Path:
    """book/partN/x (a toc entry) -> its source: the jupytext script of a chapter, or the page."""
    path = ROOT / doc
    return path.with_suffix(".py") if path.with_suffix(".py").exists() else path.with_suffix(".md")


def toc_parts() -> dict[str, list[str]]:
    """caption -> toc entries of the chapters (part pages excluded), in the book's order."""
    parts = {}
    for part in yaml.safe_load((ROOT / "_toc.yml").read_text())["parts"]:
        entries = []
        for chapter in part["chapters"]:
            entries += [s["file"] for s in chapter.get("sections", [])] or [chapter["file"]]
        parts[part["caption"]] = entries
    return parts


def route_rows() -> list[tuple[list[str], int]]:
    """(docs linked in the row, stated minutes) for each row of the route table."""
    rows = []
    for line in START_HERE.splitlines():
        minutes = re.search(r"\| (\d+) min \|", line)
        if minutes:
            rows.append((re.findall(r"\{doc\}`([^`]+)`", line), int(minutes.group(1))))
    return rows


def test_the_route_lists_every_chapter_once_in_the_books_order():
    chapters = [doc.removeprefix("book/") for part, docs in toc_parts().items()
                if part not in ("Back matter",) for doc in docs if doc != "book/start_here"]
    listed = [doc for docs, _ in route_rows() for doc in docs]
    assert listed == chapters


@pytest.mark.parametrize("row", range(len(route_rows())), ids=lambda i: route_rows()[i][0][0])
def test_each_reading_time_agrees_with_the_prose(row):
    docs, stated = route_rows()[row]
    expected = reading_minutes([source_of(f"book/{doc}") for doc in docs])
    assert abs(stated - expected) <= max(2, 0.25 * expected), (
        f"start_here.md says {stated} min for {', '.join(docs)}; their prose reads in about {expected} min "
        f"(prose at {WORDS_PER_MINUTE} words a minute, {SECONDS_PER_DISPLAY_EQUATION} s a display equation, "
        f"{SECONDS_PER_CODE_LINE} s a visible code line): update the route table")


def test_the_word_count_skips_math_code_and_folded_evidence(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("One two three $x_k = F x$ `code here`.\n\n:::{dropdown} Evidence: a claim\n"
                    "many words that are folded away\n:::\n\n```python\nprint(1)\n```\nfour\n")
    assert prose_words(page) == 6  # the formula and the code span read as a word each


@pytest.mark.parametrize("part", [p for p in toc_parts() if p.startswith("Part")])
def test_each_part_page_links_every_chapter_of_its_part(part):
    docs = toc_parts()[part]
    index = yaml.safe_load((ROOT / "_toc.yml").read_text())["parts"]
    page = next(p["chapters"][0]["file"] for p in index if p["caption"] == part)
    text = (ROOT / page).with_suffix(".md").read_text()
    linked = set(re.findall(r"\{doc\}`([^`]+)`", text))
    missing = [d for d in docs if Path(d).name not in linked]
    assert not missing, f"{page}.md does not link {missing}"


def test_the_reading_time_counts_prose_display_equations_and_visible_code(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(("word " * 150) + "\n\n$$\nx = 1\n$$\n\n```python\na = 1\n\nb = 2\n```\n\n"
                    ":::{dropdown} Evidence: folded\n$$\ny = 2\n$$\n:::\n")
    assert (prose_words(page), display_equations(page)) == (151, 1)  # the code block's words are not prose
    assert reading_seconds(page) == 60 * 151 / 150 + 30 + 2 * 6  # two visible code lines, the blank one not
    chapter = tmp_path / "chapter.py"
    chapter.write_text('# %% [markdown]\n# Some words.\n\n# %%\nx = 1\ny = 2\n\n'
                       '# %% tags=["remove-input"]\nhidden = 1\n\n# %% tags=["hide-input"]\nfolded = 2\n')
    assert reading_seconds(chapter) == 60 * 2 / 150 + 2 * 6  # hidden and folded code are not read
