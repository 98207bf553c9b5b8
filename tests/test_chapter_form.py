"""Every chapter rewritten in the book's form keeps it (issue 29; README, "Working on the book").

The form, in the order a reader meets it: a header (what the chapter teaches, what it needs,
how long it takes), the idea and an algorithm box, figures, claims that quote at most four
glued numbers per paragraph (the rest folded in evidence blocks), a "try it" panel, a checked
coding exercise, and takeaways; at most about 2,500 words of prose. What can be counted is
checked here, for the chapters of ``IN_FORM``; a chapter joins the list when it is rewritten.
For every chapter: a solution's code stays folded in the HTML book and in JupyterLab.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import jupytext
import pytest
import yaml

from pfcourse.book.report import GLUE_ROLE, paragraphs_outside_folds
from test_first_text import FIRST_TEXT
from test_start_here import folded_minutes, reading_minutes

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
from reading_times import in_words  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
CHAPTERS = sorted(BOOK.rglob("*.py"))
IN_FORM = ["onramp", "part1/model", "part1/kalman", "part1/importance_sampling", "part1/sis", "part1/sir",
           "part1/why_it_works", "part1/resampling_schemes", "part1/proposals", "part1/rao_blackwell", "part1/auxiliary",
           "part2/robot", "part2/global_localization", "part2/robot_vs_kalman", "part2/map_robot", "part2/map_global",
           "part2/real_robot",
           "part2/terrain", "part2/terrain_cure", "part2/terrain_marginalised", "part3/robot_studies",
           "part3/resampling_studies", "part3/sensing_studies", "part4/pf_vs_kalman",
           "part4/data_association", "part5/likelihood", "part5/particle_mcmc", "part5/smoothing",
           "part5/static_parameters"]
MAX_NUMBERS_PER_PARAGRAPH = 4
MAX_MINUTES_NOT_YET_CUT = 33
WORDS = {in_words(n): n for n in range(100)}
GLUE = GLUE_ROLE


def numbered_chapters() -> list[str]:
    """The chapters of the parts, in the book's order: chapter ``n`` is ``[n - 1]``."""
    entries = []
    for part in yaml.safe_load((ROOT / "_toc.yml").read_text())["parts"]:
        if part["caption"].startswith("Part"):
            entries += [s["file"].removeprefix("book/") for c in part["chapters"] for s in c.get("sections", [])]
    return entries


def chapter_number(doc: str) -> int:
    """A chapter's number in the book: its place among the parts' chapters; 0 for the on-ramp, before them."""
    return 0 if doc == "onramp" else numbered_chapters().index(doc) + 1


def cells(doc: str) -> list:
    return jupytext.read(BOOK / f"{doc}.py").cells


def markdown(doc: str) -> str:
    return "\n\n".join(c.source for c in cells(doc) if c.cell_type == "markdown")


@pytest.mark.parametrize("doc", IN_FORM)
def test_the_header_says_what_it_teaches_needs_and_takes(doc):
    text = markdown(doc)
    header = re.search(r":::\{admonition\} In this chapter\n:class: chapter-header\n(.*?)\n:::", text, re.S)
    assert header, f"{doc}: no header (':::{{admonition}} In this chapter' with ':class: chapter-header')"
    body = header.group(1)
    for part in ("**You learn**", "**You need**", "**Time:**"):
        assert part in body, f"{doc}: the header has no {part}"
    minutes = re.search(r"about ([a-z-]+) minutes to read", body)
    assert minutes and minutes.group(1) in WORDS, f"{doc}: say 'about <number in words> minutes to read'"
    stated, expected = WORDS[minutes.group(1)], reading_minutes([BOOK / f"{doc}.py"])
    assert abs(stated - expected) <= max(2, 0.25 * expected), f"{doc}: header says {stated} min, prose reads in {expected}"
    # the folded blocks by the same rule, and the exercises named as extra, on the header's one time line
    line = re.search(r"^\*\*Time:\*\*[^\n]*$", body, re.M).group(0)
    folded = re.search(r"plus about ([a-z-]+) minutes? for the folded blocks", line)
    expected = folded_minutes([BOOK / f"{doc}.py"])
    assert folded and folded.group(1) in WORDS, f"{doc}: say 'plus about <number in words> minutes for the folded blocks'"
    assert abs(WORDS[folded.group(1)] - expected) <= max(2, 0.25 * expected), (
        f"{doc}: header says {folded.group(1)} minutes for the folded blocks, they read in {expected}")
    assert re.search(r"; the exercises? (is|are) extra\.$", line), f"{doc}: the time line names the exercises as extra"
    assert "notebook runs" not in body, f"{doc}: the header states no execution time (the README's benchmark does)"


@pytest.mark.parametrize("doc", IN_FORM)
def test_an_algorithm_box_comes_before_the_first_study(doc):
    text = markdown(doc)
    box = re.search(r":::\{admonition\} Algorithm (\d+)\.(\d+)[^\n]*\n:class: algorithm\n", text)
    assert box, f"{doc}: no algorithm box (':::{{admonition}} Algorithm n.m: ...' with ':class: algorithm')"
    assert int(box.group(1)) == chapter_number(doc), f"{doc}: the algorithm's number is not the chapter's"


@pytest.mark.parametrize("doc", IN_FORM)
def test_paragraphs_quote_at_most_four_glued_numbers_outside_evidence(doc):
    worst = max(paragraphs_outside_folds(markdown(doc)), key=lambda p: len(GLUE.findall(p)))
    assert len(GLUE.findall(worst)) <= MAX_NUMBERS_PER_PARAGRAPH, (
        f"{doc}: a paragraph quotes {len(GLUE.findall(worst))} glued numbers (at most "
        f"{MAX_NUMBERS_PER_PARAGRAPH}; fold the rest into an evidence block): {worst[:200]!r}")


@pytest.mark.parametrize("doc", IN_FORM)
def test_the_chapter_reads_in_about_twenty_minutes(doc):
    # A rewritten chapter (tests/test_first_text.py's FIRST_TEXT) reads in at most 25 minutes by the
    # honest rule; the others, not yet cut (issue 39), may not grow past MAX_MINUTES_NOT_YET_CUT.
    minutes = reading_minutes([BOOK / f"{doc}.py"])
    limit = 25 if doc in FIRST_TEXT else MAX_MINUTES_NOT_YET_CUT
    assert minutes <= limit, f"{doc}: {minutes} minutes to read (at most {limit}): cut or fold"


@pytest.mark.parametrize("doc", IN_FORM)
def test_exercises_are_numbered_by_chapter_and_one_is_checked(doc):
    text, number = markdown(doc), chapter_number(doc)
    titles = re.findall(r"```\{exercise\} (\d+)\.(\d+) [^\n]+\n:label: [^\n]+\n:nonumber:\n", text)
    assert len(titles) == text.count("{exercise}"), f"{doc}: every exercise is titled 'n.m ...' and :nonumber:"
    assert [(int(c), int(e)) for c, e in titles] == [(number, e) for e in range(1, len(titles) + 1)]
    tagged = [(c.metadata.get("tags", []), c.source) for c in cells(doc) if c.cell_type == "code"]
    answers = [src for tags, src in tagged if "answer" in tags]
    solutions = [src for tags, src in tagged if "solution" in tags]
    assert answers and all("check_" in a for a in answers), f"{doc}: no answer cell calling a pfcourse.book.exercises checker"
    assert len(solutions) == len(answers), f"{doc}: every answer cell needs its solution cell"


@pytest.mark.parametrize("doc", IN_FORM)
def test_the_reference_solutions_pass_their_checkers(doc):
    notebook = json.loads((BOOK / f"{doc}.ipynb").read_text())
    for cell in notebook["cells"]:
        if "solution" in cell.get("metadata", {}).get("tags", []):
            text = "".join("".join(o.get("text", "")) for o in cell.get("outputs", []))
            assert "every check passed" in text, f"{doc}: a stored solution does not pass its checker: {text!r}"


@pytest.mark.parametrize("doc", IN_FORM)
def test_takeaways_end_the_chapter(doc):
    sections = re.split(r"^## ", markdown(doc), flags=re.M)
    assert sections[-1].startswith("Takeaways\n"), f"{doc}: the last section is not '## Takeaways'"
    assert 3 <= len(re.findall(r"^- ", sections[-1], flags=re.M)) <= 5, f"{doc}: three to five takeaways"


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.stem)
def test_solution_code_is_folded_in_the_book_and_in_jupyterlab(path):
    for cell in jupytext.read(path).cells:
        if cell.cell_type == "code" and "solution" in cell.metadata.get("tags", []):
            assert "hide-input" in cell.metadata["tags"], f"{path.name}: a solution cell is not folded in HTML"
            assert cell.metadata.get("jupyter", {}).get("source_hidden") is True, (
                f"{path.name}: a solution cell is not folded in JupyterLab (jupyter.source_hidden)")


def test_the_fold_pattern_skips_dropdowns_and_keeps_the_rest():
    text = ("Claim with {glue:text}`a`.\n\n```{solution} ex\n:class: dropdown\n{glue:text}`b` {glue:text}`c`\n```\n\n"
            ":::{admonition} Evidence\n:class: dropdown\n{glue:text}`d`\n:::\n\nEnd {glue:text}`e`.")
    kept = paragraphs_outside_folds(text)
    assert [len(GLUE.findall(p)) for p in kept] == [1, 1]
