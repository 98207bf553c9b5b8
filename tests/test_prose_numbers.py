"""No measured number is typed into the prose: every numeral a chapter's text states comes from
its outputs through myst-nb `glue` (``{glue:text}`name:.2f` ``), so the text cannot drift from
the computation (issue 18).

The rule the chapters follow, and this test enforces on the markdown cells of every chapter
source (``book/**/*.py``):

- a **numeral in the prose** (outside math, code, roles and links) is a statement about a result,
  and must be glued;
- a **setting** (a parameter of a scenario or of a study: $N = 300$, $100$ runs, a noise variance)
  is written in math, or glued from the variable the code uses (better: then it cannot drift
  either); a count in words ("two landmarks") is a setting too;
- the exemptions are conventions, not results: section numbers of headings, the reports' numbers
  (001 to 005), the lab's question numbers ("question 8"), confidence levels of intervals and bands (95 % interval, 10-90 % band), the
  reading times of the route table in start_here.md (checked by tests/test_start_here.py), the
  numbers of algorithms and exercises ("Algorithm 4.1"), and the
  short list ``EXEMPT`` below (each entry says why, and must still occur in its chapter).

What the test sees as a numeral: digits, with an optional decimal part, sign and per cent sign.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from prose_text import MATH_ROLES_CODE, markdown_cells

ROOT = Path(__file__).resolve().parents[1]
CHAPTERS = sorted((ROOT / "book").rglob("*.py"))
PAGES = sorted((ROOT / "book").rglob("*.md"))  # the introduction, the parts' pages, the references


# (chapter stem, phrase as written in the source, why it is not a measured number)
EXEMPT: list[tuple[str, str, str]] = [
    ("intro", "Python 3.11", "the version the quick start needs"),
    ("intro", "(chapter 12)", "a chapter of a cited book"),
    ("resampling_schemes", "version 2.0.0", "the filterpy release whose bug is shown (pinned in requirements.txt)"),
    ("rao_blackwell", "FastSLAM 1.0", "the name of an algorithm (Montemerlo et al.)"),
    ("rao_blackwell", "FastSLAM 2.0", "the name of an algorithm (Montemerlo et al.)"),
    ("auxiliary", "FastSLAM 2.0", "the name of an algorithm (Montemerlo et al.)"),
]

_REMOVED = [
    # Directives whose body is not prose (figures, glue figures, code, bibliography); an
    # admonition's body (note, tip, exercise, solution, ...) is prose and is checked.
    (r"^(`{3,}|:{3,})\{(?:figure|glue:figure|glue|code-cell|code|bibliography|math|raw)\}.*?^\1\s*$", " "),
    (r"^(`{3,})python\s*$.*?^\1\s*$", " "),  # a code block in an admonition (a capstone's solution)
    (r"^\([\w-]+\)=\s*$", " "),  # a label target, "(capstone-2)="
    (r"^\s*(?:`{3,}|:{3,})[^\n]*$", " "),  # the fence lines of the other directives (admonitions)
    *((pattern, " ") for pattern in MATH_ROLES_CODE),  # math, roles, code (tests/prose_text.py)
    (r"\]\([^)]*\)", "]"),  # link targets
    (r"<[^>]+>", " "),  # html tags and autolinks
    (r"^\s*:[a-z-]+:[^\n]*$", " "),  # directive options
    (r"^(\s*#{1,6}\s+)\d+(\.\d+)*\.?", r"\1"),  # section number of a heading
    (r"^(\s*)\d+\.\s", r"\1"),  # item number of an ordered list
    (r"(?i)\breports?\b[ ,()0-9and]*", " "),  # "report 002", "reports 002 and 004"
    (r"\(\s*00[1-5](?:\s*,\s*00[1-5])*\s*\)", " "),  # "(002, 004)"
    (r"\b00[1-5]\b", " "),  # a report's number in a table of the reports
    (r"(?i)\b(?:lab )?questions? \d+(?:\s*(?:,|and|to|-)\s*\d+)*", " "),  # "question 8": the lab's numbering
    (r"\b(?:10|5|2\.5|25)\s?[-–]\s?(?:90|95|97\.5|75)\s?%", " "),  # 10-90 % band
    # confidence levels and quantile bands: conventions of the statistics, not results
    (r"\b(?:50|80|90|95|99)\s?%(?=[- ]+(?:confidence|interval|intervals|band|bands|ellipse|ellipses|"
     r"region|level|quantile|Wilson|bootstrap|CI)\b)", " "),
    (r"\b(?:10|90|5|95|25|75)\s?%\s+quantile", " "),
    # the book's numbering of algorithms, exercises, figures and tables ("Algorithm 4.1")
    (r"\b(?:Algorithm|Exercise|Figure|Table)s? \d+\.\d+", " "),
    # reading times in a route table ("| 9 min |"): counted from the chapters' prose and
    # checked against it by tests/test_start_here.py
    (r"(?<=\|) \d+ min (?=\|)", " "),
]
_NUMERAL = re.compile(r"(?<![\w.])[-+−]?\d+(?:[.,]\d+)*(?:\s?%)?(?![\w])")


def prose(text: str) -> str:
    """The markdown cell's text with math, code, roles, links and the exempt conventions removed."""
    for pattern, replacement in _REMOVED:
        text = re.sub(pattern, replacement, text, flags=re.S | re.M)
    return text


def typed_numerals(source: Path) -> list[tuple[int, str, str]]:
    """(cell number, numeral, line) for every numeral left in the prose of a chapter."""
    exempt = [phrase for stem, phrase, _ in EXEMPT if stem == source.stem]
    found = []
    for number, text in enumerate(markdown_cells(source)):
        for phrase in exempt:
            text = text.replace(phrase, " ")
        for line in prose(text).splitlines():
            for match in _NUMERAL.finditer(line):
                found.append((number, match.group(0), " ".join(line.split())))
    return found


@pytest.mark.parametrize("source", CHAPTERS + PAGES, ids=lambda p: str(p.relative_to(ROOT / "book")))
def test_no_typed_number_in_the_prose(source: Path):
    found = typed_numerals(source)
    report = "\n".join(f"  cell {n}: {numeral!r} in: {line[:160]}" for n, numeral, line in found)
    assert not found, (
        f"{source.relative_to(ROOT)} states {len(found)} number(s) in its prose that are not glued "
        f"(glue a result; write a setting in math or glue it from the code's variable):\n{report}"
    )


def test_every_exemption_is_used_and_explained():
    assert len(EXEMPT) <= 20, "the exempt list is meant to be short"
    for stem, phrase, why in EXEMPT:
        sources = [s for s in CHAPTERS + PAGES if s.stem == stem]
        assert len(sources) == 1, f"exemption for unknown or ambiguous chapter {stem!r}"
        assert why.strip(), f"exemption {phrase!r} ({stem}) says not why"
        assert any(phrase in text for text in markdown_cells(sources[0])), f"exemption {phrase!r} no longer occurs in {stem}"


@pytest.mark.parametrize(
    ("text", "numerals"),
    [
        ("The error falls to 0.22 m in 65 % of the flights.", ["0.22", "65 %"]),
        ("With $N = 300$ and {glue:text}`rmse:.2f` m.", []),
        ("## 3. Terrain: the 95 % interval and the 10-90 % band", []),
        ("Report 002 finds 0.5 best; `np.full(3, 0.5)`.", ["0.5"]),
        ("Lab question 8 (and questions 3 and 4) asks for 12 runs.", ["12"]),
        ("A [link](https://doi.org/10.1000/1) and 2 of 100 runs.", ["2", "100"]),
        ("```{figure} a.png\n:name: fig-3\n\nCaption 1.5\n```\nthen 7", ["7"]),
        ("```{note}\nThe filter loses 12 flights.\n```", ["12"]),
    ],
)
def test_the_scanner_sees_numerals_in_prose_only(tmp_path, text, numerals):
    source = tmp_path / "chapter.py"
    body = "\n".join("# " + line if line else "#" for line in text.splitlines())
    source.write_text(f"# %% [markdown]\n{body}\n")
    assert [numeral for _, numeral, _ in typed_numerals(source)] == numerals
