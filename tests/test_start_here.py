"""The front of the book tells the truth about the book (issue 29).

- The route table of book/start_here.md lists every chapter of the table of contents, once,
  in its order, and states a reading time that agrees with the chapter's prose;
- every part's page links to every chapter of its part.

Reading time (issue 39), as ``start_here.md`` states it: the words of the prose (markdown outside
code blocks and folded blocks such as evidence and solutions, exercises included; a formula, a code
span or a role counts as one word) at
150 words a minute, plus 30 s for each display equation outside folded blocks and 6 s for each
line of code the reader sees (code cells not hidden or removed), rounded up to a minute; the header's
own time line is not counted. The folded blocks (markdown folds other than solutions, folded code,
the stored evidence outputs) are read by the same rule, for the header's and the table's second
time; the core route's total of both is stated in the table's last row. A stated time may be off
by a quarter
or two minutes, whichever is more, so a small edit of a chapter does not force an edit here,
and a rewritten chapter (half as long) does.
"""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path

import jupytext
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
    # the header's time line, which tools/reading_times.py writes from these counts (counted, the
    # count would depend on the numbers it states)
    r"^\*\*Time:\*\*[^\n]*$",
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


# The folded blocks, read by the same rule (the header's "plus about M minutes for the folded
# blocks"): the markdown folds (evidence, "From the labs", "Going further"; the exercises' solutions
# are part of the exercises, which the header names as extra), the code folded under "show code"
# (cells tagged hide-input, solutions excepted), and the evidence blocks a hidden cell shows (the
# stored notebook's ``<details class="pfcourse-evidence">`` outputs; there every number of a table
# is read as a word).
_MARKDOWN_FOLDS = [
    r"^(:{3,}|`{3,})\{(?:dropdown|admonition)\}[^\n]*\n(?:(?!\1)[^\n]*\n)*?\s*:class:[^\n]*dropdown.*?^\1\s*$",
    r"^(:{3,}|`{3,})\{dropdown\}.*?^\1\s*$",
]
_EVIDENCE_HTML = re.compile(r'<details class="pfcourse-evidence">.*?</details>', re.S)
_TOKEN = re.compile(r"[A-Za-z0-9]+(?:['.-][A-Za-z0-9]+)*")


def _markdown_folds(path: Path) -> str:
    text, folds = "\n".join(markdown_cells(path)), []
    for pattern in _MARKDOWN_FOLDS:
        for found in re.finditer(pattern, text, flags=re.S | re.M):
            folds.append(found.group(0))
        text = re.sub(pattern, " ", text, flags=re.S | re.M)
    return "\n\n".join(folds)


def _evidence_outputs(path: Path) -> list[str]:
    """The text of the evidence blocks the stored notebook beside a chapter shows (tags stripped)."""
    notebook = path.with_suffix(".ipynb")
    if path.suffix != ".py" or not notebook.exists():
        return []
    blocks = []
    for cell in json.loads(notebook.read_text())["cells"]:
        for output in cell.get("outputs", []):
            page = "".join(output.get("data", {}).get("text/html", ""))
            blocks += [html.unescape(re.sub(r"<[^>]+>", " ", b)) for b in _EVIDENCE_HTML.findall(page)]
    return blocks


def folded_counts(path: Path) -> tuple[int, int, int]:
    """(words, display equations, code lines) of a chapter's folded blocks."""
    # the folds' own syntax is not read: the directive's name and its options
    folds = re.sub(r"^(:{3,}|`{3,})\{[a-z]+\}", r"\1", _markdown_folds(path), flags=re.M)
    folds = re.sub(r"^:[a-z-]+:[^\n]*$", " ", folds, flags=re.M)
    code_blocks = re.findall(r"^(`{3,})(?!\{)[^\n]*\n(.*?)^\1\s*$", folds, flags=re.S | re.M)
    code = sum(1 for _, body in code_blocks for line in body.splitlines() if line.strip())
    prose = re.sub(r"^(`{3,})(?!\{).*?^\1\s*$", " ", folds, flags=re.S | re.M)
    equations = len(re.findall(r"\$\$.*?\$\$", prose, flags=re.S)) + len(
        re.findall(r"^(?::{3,}|`{3,})\{math\}", prose, flags=re.M))
    for pattern in MATH_ROLES_CODE:
        prose = re.sub(pattern, " word ", prose, flags=re.S | re.M)
    words = len(re.findall(r"[A-Za-z][A-Za-z'-]*", prose))
    words += sum(len(_TOKEN.findall(block)) for block in _evidence_outputs(path))
    if path.suffix == ".py":
        code += sum(1 for c in jupytext.read(path).cells
                    if c.cell_type == "code" and "hide-input" in c.metadata.get("tags", [])
                    and "solution" not in c.metadata.get("tags", [])
                    for line in c.source.splitlines() if line.strip())
    return words, equations, code


def folded_seconds(path: Path) -> float:
    words, equations, code = folded_counts(path)
    return 60 * words / WORDS_PER_MINUTE + SECONDS_PER_DISPLAY_EQUATION * equations + SECONDS_PER_CODE_LINE * code


def folded_minutes(paths: list[Path]) -> int:
    return math.ceil(sum(folded_seconds(p) for p in paths) / 60)


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


ROUTE_ROW = re.compile(r"^\|[^\n]*\| (core|optional) \| (\d+) min \| (\d+) min \|", re.M)
TOTAL_ROW = re.compile(r"^\|[^\n]*\| \*\*the core route\*\* \|[^\n]*?\| (\d+) min \| (\d+) min \|", re.M)


def route_rows() -> list[tuple[list[str], int, int]]:
    """(docs linked in the row, stated minutes to read, stated minutes of folded blocks) for each
    chapter row of the route table (the total row excepted)."""
    rows = []
    for line in START_HERE.splitlines():
        found = ROUTE_ROW.match(line)
        if found:
            rows.append((re.findall(r"\{doc\}`([^`]+)`", line), int(found.group(2)), int(found.group(3))))
    return rows


def core_route_sources() -> list[Path]:
    """The sources of the route's core rows, in order."""
    return [source_of(f"book/{doc}") for line in START_HERE.splitlines()
            if (found := ROUTE_ROW.match(line)) and found.group(1) == "core"
            for doc in re.findall(r"\{doc\}`([^`]+)`", line)]


def _close(stated: int, expected: int) -> bool:
    """A stated time may be off by a quarter or two minutes, whichever is more."""
    return abs(stated - expected) <= max(2, 0.25 * expected)


def test_the_route_lists_every_chapter_once_in_the_books_order():
    chapters = [doc.removeprefix("book/") for part, docs in toc_parts().items()
                if part not in ("Back matter",) for doc in docs if doc != "book/start_here"]
    listed = [doc for docs, _, _ in route_rows() for doc in docs]
    assert listed == chapters


@pytest.mark.parametrize("row", range(len(route_rows())), ids=lambda i: route_rows()[i][0][0])
def test_each_reading_time_agrees_with_the_prose(row):
    docs, stated, stated_folded = route_rows()[row]
    sources = [source_of(f"book/{doc}") for doc in docs]
    expected, folded = reading_minutes(sources), folded_minutes(sources)
    assert _close(stated, expected), (
        f"start_here.md says {stated} min for {', '.join(docs)}; their prose reads in about {expected} min "
        f"(prose at {WORDS_PER_MINUTE} words a minute, {SECONDS_PER_DISPLAY_EQUATION} s a display equation, "
        f"{SECONDS_PER_CODE_LINE} s a visible code line): run tools/reading_times.py --write")
    assert _close(stated_folded, folded), (
        f"start_here.md says {stated_folded} min of folded blocks for {', '.join(docs)}; by the same rule they "
        f"read in about {folded} min: run tools/reading_times.py --write")


def test_the_core_routes_total_is_stated_and_honest():
    found = TOTAL_ROW.search(START_HERE)
    assert found, "the route table has no total row ('| ... | **the core route** | ... | n min | m min |')"
    core = core_route_sources()
    assert len(core) >= 10, core
    stated, stated_folded = int(found.group(1)), int(found.group(2))
    assert _close(stated, reading_minutes(core)), (
        f"the core route is said to read in {stated} min, its chapters read in {reading_minutes(core)}")
    assert _close(stated_folded, folded_minutes(core)), (
        f"the core route's folded blocks are said to take {stated_folded} min; they read in {folded_minutes(core)}")
    # what issue 39 asks of the core route: a first reading in about a working day, not a week
    assert reading_minutes(core) + folded_minutes(core) <= 8 * 60


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


def test_the_folded_time_counts_the_folds_by_the_same_rule(tmp_path):
    chapter = tmp_path / "chapter.py"
    chapter.write_text(
        '# %% [markdown]\n# Story words.\n#\n# :::{admonition} Evidence: a claim\n# :class: dropdown\n'
        '# five folded words are here\n#\n# $$\n# x = 1\n# $$\n# :::\n#\n'
        '# ```{solution} ex\n# :class: dropdown\n# solution words are the exercise\n# ```\n\n'
        '# %% tags=["hide-input"]\nfolded = 1\nalso = 2\n\n'
        '# %% tags=["solution", "hide-input"]\nanswer = 3\n\n# %% tags=["remove-input"]\nhidden = 4\n')
    notebook = {"cells": [{"cell_type": "code", "outputs": [{"data": {"text/html": (
        '<details class="pfcourse-evidence"><summary>Evidence: two words</summary>'
        '<table><tr><td>0.5</td><td>12</td></tr></table></details>')}}]}]}
    chapter.with_suffix(".ipynb").write_text(json.dumps(notebook))
    # "Evidence", "a", "claim", the five words and the equation (read as a word, as in the prose, and
    # counted as a display equation); the two lines of folded code (the solution's are the exercise's);
    # in the stored evidence block "Evidence", "two", "words", 0.5 and 12
    assert folded_counts(chapter) == (9 + 5, 1, 2)
    assert folded_seconds(chapter) == 60 * 14 / 150 + 30 + 2 * 6
    assert prose_words(chapter) == 2
