"""The printed book (`python3 tasks.py pdf`, issue 45): what a reader of the PDF must find.

Run by `tasks.py pdf` right after the build, on `_build/latex/particle-filters-measured.pdf`, with
poppler's pdfinfo, pdftotext and pdffonts. Checked:
- it has pages in the hundreds, and every chapter's title, in the order of the table of contents;
- every glued number of a sample of chapters, formatted as the HTML book formats it, is printed;
- each chapter's solutions are printed together at its end;
- no unresolved reference ("??"), no output printed as the Python repr of an HTML object or a widget,
  and every font embedded;
- nothing is printed past the text block's right edge (a wide table or a long code line must wrap or
  shrink, never run into the margin).
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
from pathlib import Path

import jupytext
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
PDF = ROOT / "_build" / "latex" / "particle-filters-measured.pdf"
#: Chapters whose every formatted glued number is looked for in the PDF: one from each part.
SAMPLE = ["book/part1/sir", "book/part2/robot", "book/part3/resampling_studies", "book/part4/data_association",
          "book/part5/smoothing"]
#: How far past the text block's right edge a word may end (points): a display equation's closing
#: full stop may stand a little out, as in print.
MARGIN_SLACK_PT = 16.0

pytestmark = pytest.mark.skipif(not PDF.exists(), reason="no PDF: run `python3 tasks.py pdf`")


def run(*cmd: str) -> str:
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


@pytest.fixture(scope="module")
def pages() -> list[str]:
    return run("pdftotext", "-layout", str(PDF), "-").split("\f")


def normalised(text: str) -> str:
    return re.sub(r"\s+", " ", text.replace("\u2010", "-").replace("\u2212", "-")).lower()


def chapter_titles() -> list[str]:
    """The title (first heading) of every chapter and page of the table of contents, in its order."""
    docs = []
    for part in yaml.safe_load((ROOT / "_toc.yml").read_text())["parts"]:
        for chapter in part["chapters"]:
            docs += [chapter["file"]] + [s["file"] for s in chapter.get("sections", [])]
    titles = []
    for doc in docs:
        source = ROOT / f"{doc}.py" if (ROOT / f"{doc}.py").exists() else ROOT / f"{doc}.md"
        text = source.read_text() if source.suffix == ".md" else "\n".join(
            c.source for c in jupytext.read(source).cells if c.cell_type == "markdown")
        titles.append(re.search(r"^# (.+)$", text, re.M).group(1).strip())
    return titles


def test_the_pdf_has_the_books_pages():
    info = run("pdfinfo", str(PDF))
    pages = int(re.search(r"^Pages:\s+(\d+)", info, re.M).group(1))
    assert 150 <= pages <= 600, f"the PDF has {pages} pages"
    assert "A4" in info


def test_every_chapter_title_is_printed_in_the_order_of_the_table_of_contents(pages):
    body = normalised(" ".join(pages[3:]))  # after the title page and the contents
    position = 0
    for title in chapter_titles():
        found = body.find(normalised(title), position)
        assert found >= 0, f"chapter {title!r} is not printed after the previous chapter"
        position = found


def glued_texts(doc: str) -> list[tuple[str, str]]:
    """(name, text as the book prints it) of each ``{glue:text}`name:format``` of a chapter."""
    notebook = json.loads((ROOT / f"{doc}.ipynb").read_text())
    values = {}
    for cell in notebook["cells"]:
        for output in cell.get("outputs", []):
            scrap = output.get("metadata", {}).get("scrapbook")
            if scrap:
                values[scrap["name"]] = output["data"][scrap["mime_prefix"] + "text/plain"]
    markdown = "\n".join(c.source for c in jupytext.read(ROOT / f"{doc}.py").cells if c.cell_type == "markdown")
    texts = []
    for name, spec in re.findall(r"\{glue:text\}`([A-Za-z0-9_]+):([^`]+)`", markdown):
        texts.append((name, format(ast.literal_eval(values[name]), spec)))
    return texts


@pytest.mark.parametrize("doc", SAMPLE)
def test_every_glued_number_of_the_chapter_is_printed(doc, pages):
    text = normalised(" ".join(pages))
    texts = glued_texts(doc)
    assert texts, f"{doc} quotes no formatted glued number"
    missing = [(name, shown) for name, shown in texts if shown.lower() not in text]
    assert not missing, f"{doc}: glued numbers not found in the PDF: {missing}"


def test_each_chapter_prints_its_solutions_at_its_end(pages):
    """Solutions follow the chapter's last section (tools/book_pdf.py), one block per chapter that has any."""
    chapters = [c for c in chapter_titles()]
    with_solutions = sum(1 for source in sorted((ROOT / "book").rglob("*.py"))
                         if "{solution}" in source.read_text() and str(source.relative_to(ROOT).with_suffix(""))
                         in (ROOT / "_toc.yml").read_text())
    text = " ".join(pages)
    assert chapters and text.count("Solutions to the exercises") == with_solutions, (
        f"{text.count('Solutions to the exercises')} solution blocks printed for {with_solutions} chapters with solutions")


def test_no_unresolved_reference(pages):
    hits = [i + 1 for i, page in enumerate(pages) if "??" in page]
    assert not hits, f"'??' (an unresolved reference) on pages {hits}"


def test_no_output_is_printed_as_a_python_repr_of_html_or_a_widget(pages):
    reprs = re.compile(r"<IPython\.core\.display\.HTML object>|^\s*(VBox|HBox|GridBox|interactive)\(children=", re.M)
    hits = [i + 1 for i, page in enumerate(pages) if reprs.search(page)]
    assert not hits, f"an HTML-only output printed as its Python repr on pages {hits}"


def test_every_font_is_embedded():
    rows = run("pdffonts", str(PDF)).splitlines()[2:]
    not_embedded = [row for row in rows if row.split()[-5] != "yes"]
    assert rows and not not_embedded, f"fonts not embedded: {not_embedded}"


def test_nothing_is_printed_past_the_text_blocks_right_edge():
    boxes = run("pdftotext", "-bbox", str(PDF), "-")
    words = []
    for number, page in enumerate(boxes.split("<page ")[1:], start=1):
        words += [(float(x), number, w) for x, w in re.findall(r'xMax="([\d.]+)" yMax="[\d.]+">([^<]*)<', page)]
    ends = sorted(x for x, _, _ in words)
    edge = ends[int(0.99 * len(ends))]  # the right edge of justified text
    past = sorted({(round(x - edge, 1), number, word) for x, number, word in words if x > edge + MARGIN_SLACK_PT},
                  reverse=True)
    assert not past, f"printed past the text block (points past its edge, page, word): {past[:10]}"
