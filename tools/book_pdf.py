"""Sphinx extension of the book: what the printed book (``python3 tasks.py pdf``) shows of outputs
that only a browser can show.

Loaded through ``sphinx: local_extensions`` in ``_config.yml``; it acts for the LaTeX builder only
(the HTML book is untouched). Four kinds of cell output are HTML alone, which LaTeX cannot typeset
(myst-nb would fall back to their plain-text form, a widget's repr or ``<IPython.core.display.HTML
object>``):

- **Evidence blocks** (``pfcourse.book.report.EvidenceBlock``, ``<details
  class="pfcourse-evidence">``): printed small, as "Evidence: <claim>", their notes as paragraphs
  and their tables as tables (the book's audit stays in the printed book).
- **Tables a chapter displays on their own** (``report.html_table``, ``<table class="pfcourse-table">``):
  typeset as tables.
- **Control panels** (``pfcourse.book.static_panel``, ``<div class="pfcourse-panel">``): the
  figure of the settings the page opens with, captioned with what the HTML book lets the reader
  change (each control and the values it offers).
- **Animations** (``FuncAnimation.to_jshtml()``): the last frame, captioned as an animation in the
  HTML book.

Three things are arranged for paper: chapters are numbered as in the HTML book (:class:`PartsOfChapters`),
each chapter's solutions are printed at its end (:class:`SolutionsAtChapterEnd`), and a solution's
folded code is printed with it (:class:`SolutionCodePrinted`; other folded code is not printed).

Each such output's mime bundle is replaced before myst-nb selects a mime type (its
``SelectMimeType`` post-transform runs at priority 4). Images are written under
``_build/pdf_images/`` (named by their content) and registered with the environment, so the
LaTeX builder copies them as any other figure.
"""

from __future__ import annotations

import base64
import hashlib
import re
from pathlib import Path
from typing import Any

from bs4 import BeautifulSoup
from docutils import nodes
from sphinx import addnodes
from sphinx.transforms.post_transforms import SphinxPostTransform

#: LaTeX preamble: evidence blocks in small type, indented; panel captions small, in italics.
PREAMBLE = r"""
\makeatletter
\@namedef{sphinxclasspfcourseevidence}{\par\begingroup\footnotesize\leftskip1.2em}
\@namedef{endsphinxclasspfcourseevidence}{\par\endgroup\medskip}
\@namedef{sphinxclasspfcoursepanelcaption}{\par\small\itshape}
\@namedef{endsphinxclasspfcoursepanelcaption}{\par\medskip}
\makeatother
% Headings with math become PDF bookmarks: under unicode-math (loaded by jupyter-book's LaTeX
% preamble) a Greek letter is a math character that a PDF string cannot hold.
\AtBeginDocument{\pdfstringdefDisableCommands{\def\vartheta{\textvartheta}\def\sigma{\textsigma}%
  \def\text#1{#1}\def\hat#1{#1}\def\log{log }}}
\providecommand{\textvartheta}{\ifmmode\vartheta\else ϑ\fi}
\providecommand{\textsigma}{\ifmmode\sigma\else σ\fi}
"""

DATA_URI = re.compile(r"data:image/png;base64,([A-Za-z0-9+/=]+)")
#: A frame of matplotlib's animation player; its base64 is broken into lines, each ending in a backslash.
JSHTML_FRAME = re.compile(r'frames\[(\d+)\]\s*=\s*"data:image/png;base64,((?:[A-Za-z0-9+/=]|\\\n)+)"')


def _html_of(bundle: nodes.Element) -> str | None:
    for child in bundle.children:
        if child.get("mime_type") == "text/html":
            return "".join(n.astext() for n in child.findall(nodes.raw))
    return None


def evidence_nodes(soup: BeautifulSoup) -> list[nodes.Node]:
    """An evidence block as docutils nodes: its title, notes and tables, in a small-type container."""
    details = soup.find("details", class_="pfcourse-evidence")
    box = nodes.container(classes=["pfcourseevidence"])
    title = details.find("summary").get_text(" ", strip=True)
    box += nodes.paragraph("", "", nodes.strong(text=title))
    for element in details.find_all(["p", "table"], recursive=False):
        if element.name == "p":
            text = element.get_text(" ", strip=True)
            if "pfcourse-table-caption" in (element.get("class") or []):
                box += nodes.paragraph("", "", nodes.emphasis(text=text))
            elif text:
                box += nodes.paragraph(text=text)
        else:
            box += table_node(element)
    return [box]


def table_node(table) -> nodes.table:
    """An HTML table (header row, body rows of text) as a docutils table."""
    header = [th.get_text(" ", strip=True) for th in table.find("thead").find_all("th")] if table.find("thead") else []
    rows = [[td.get_text(" ", strip=True) for td in tr.find_all(["td", "th"])]
            for tr in (table.find("tbody") or table).find_all("tr")]
    width = max([len(header), *map(len, rows)])
    result = nodes.table(classes=["pfcourse-table"])
    group = nodes.tgroup(cols=width)
    result += group
    for _ in range(width):
        group += nodes.colspec(colwidth=1)

    def row(cells: list[str]) -> nodes.row:
        r = nodes.row()
        for text in cells + [""] * (width - len(cells)):
            entry = nodes.entry()
            entry += nodes.paragraph(text=text)
            r += entry
        return r

    if header:
        head = nodes.thead()
        head += row(header)
        group += head
    body = nodes.tbody()
    for cells in rows:
        body += row(cells)
    group += body
    return result


class PrintedOutputs(SphinxPostTransform):
    """Replace evidence blocks, panels and animations by what a printed page can show."""

    default_priority = 3  # before myst-nb's SelectMimeType (4)
    builders = ("latex",)

    def run(self, **kwargs: Any) -> None:
        bundles = [n for n in self.document.findall(nodes.container)
                   if n.get("nb_element", "") == "mime_bundle"]
        for bundle in bundles:
            markup = _html_of(bundle)
            if markup is None:
                continue
            if 'class="pfcourse-evidence"' in markup:
                bundle.replace_self(evidence_nodes(BeautifulSoup(markup, "html.parser")))
            elif 'class="pfcourse-panel"' in markup:
                bundle.replace_self(self.panel_nodes(BeautifulSoup(markup, "html.parser")))
            elif markup.lstrip().startswith("<table") and "pfcourse-table" in markup:
                # a table a chapter displays on its own (report.html_table): typeset as a table
                bundle.replace_self(table_node(BeautifulSoup(markup, "html.parser").find("table")))
            elif JSHTML_FRAME.search(markup):
                frames = JSHTML_FRAME.findall(markup)
                last = max(frames, key=lambda f: int(f[0]))[1].replace("\\\n", "")
                caption = (f"An animation of {len(frames)} frames in the HTML book and in JupyterLab; "
                           "printed here, its last frame.")
                bundle.replace_self(self.figure(last, caption))

    def panel_nodes(self, soup: BeautifulSoup) -> list[nodes.Node]:
        image = soup.find("img", class_="pfcourse-panel-figure")
        controls = []
        for label in soup.find_all("label", class_="pfcourse-control"):
            name = label.find("span").get_text(strip=True)
            ticks = label.find("small", class_="pfcourse-ticks")
            options = [o.get_text(strip=True) for o in label.find_all("option")]
            current = label.find("output")
            values = ticks.get_text(strip=True).replace(" · ", ", ").replace("·", ",") if ticks else ", ".join(options)
            shown = current.get_text(strip=True) if current else next(
                (o.get_text(strip=True) for o in label.find_all("option") if o.has_attr("selected")), "")
            disabled = label.find("input", disabled=True) or label.find("select", disabled=True)
            if disabled:
                continue
            controls.append(f"{name} ({values}; shown: {shown})")
        caption = ("A control panel in the HTML book and in JupyterLab, printed at the settings it opens with. "
                   "There you can change " + "; ".join(controls) + ".")
        return self.figure(DATA_URI.search(image["src"]).group(1), caption)

    def figure(self, png_base64: str, caption: str) -> list[nodes.Node]:
        data = base64.b64decode(png_base64)
        folder = Path(self.app.srcdir) / "_build" / "pdf_images"
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / f"{hashlib.sha256(data).hexdigest()[:16]}.png"
        if not path.exists():
            path.write_bytes(data)
        relative = str(path.relative_to(self.app.srcdir))
        self.env.images.add_file(self.document.get("source", "pdf"), relative)
        image = nodes.image(uri=relative, candidates={"image/png": relative})
        note = nodes.container(classes=["pfcoursepanelcaption"])
        note += nodes.paragraph(text=caption)
        return [image, note]


class PartsOfChapters(SphinxPostTransform):
    """Number the printed book's chapters as the HTML book does.

    jupyter-book's LaTeX turns each caption of ``_toc.yml`` into a ``\\part``, under which a part's
    page (``book/partN/index``) is a chapter and the part's chapters are its sections (5.1, 5.2, ...),
    while the HTML book numbers its chapters through the parts (Algorithm 5.1 is chapter 5's). Here a
    part page's text goes onto the part's opening page and its chapters become chapters, numbered
    from 1 at Part I; the chapters before it ("Before you start") are lettered A, B, ...
    """

    default_priority = 800  # after sphinx-jupyterbook-latex arranged the parts (700)
    builders = ("latex",)

    def run(self, **kwargs: Any) -> None:
        parts = [s for s in self.document.findall(nodes.section) if str(s.get("docname", "")).startswith(
            ("Part ", "Before you start", "Back matter"))]
        for part in parts:
            for index in [s for s in part.findall(nodes.section)
                          if str(s.get("docname", "")).endswith("/index") and s is not part]:
                self.lift_chapters(part, index)
        front = next((p for p in parts if p["docname"].startswith("Before you start")), None)
        if front is not None:
            front.insert(1, nodes.raw("", r"\renewcommand{\thechapter}{\Alph{chapter}}"
                                          r"\renewcommand{\theHchapter}{front.\Alph{chapter}}", format="latex"))
            front.append(nodes.raw("", r"\renewcommand{\thechapter}{\arabic{chapter}}"
                                       r"\renewcommand{\theHchapter}{\arabic{chapter}}\setcounter{chapter}{0}",
                                   format="latex"))

    @staticmethod
    def lift_chapters(part: nodes.section, index: nodes.section) -> None:
        """The part page's body in place of the part page, followed by its chapters' files, as chapters."""

        def section_of(node: nodes.Node) -> nodes.Node | None:
            node = node.parent
            while node is not None and not isinstance(node, nodes.section):
                node = node.parent
            return node

        chapters = [f for f in index.findall(addnodes.start_of_file) if section_of(f) is index]
        for f in chapters:
            f.parent.remove(f)
        body = [c for c in index.children if not isinstance(c, nodes.title) and c.astext().strip()]
        holder = index.parent if isinstance(index.parent, addnodes.start_of_file) else index
        container, position = holder.parent, holder.parent.index(holder)
        container.remove(holder)
        for offset, node in enumerate([*body, *chapters]):
            container.insert(position + offset, node)


class SolutionsAtChapterEnd(SphinxPostTransform):
    """Print each chapter's solutions at its end, after its takeaways, as a course book does.

    The HTML book folds a solution under its exercise (a ``{solution}`` block and the code cell
    tagged ``solution`` that follows it); on paper they would give the answer away on the same page.
    """

    default_priority = 810
    builders = ("latex",)

    def run(self, **kwargs: Any) -> None:
        from sphinx_exercise.nodes import solution_node

        for start in list(self.document.findall(addnodes.start_of_file)):
            if start.get("docname") not in self.env.found_docs:  # a part's wrapper, not a chapter
                continue
            chapter = next((c for c in start.children if isinstance(c, nodes.section)), None)
            if chapter is None:
                continue
            moved = [n for n in chapter.findall(lambda n: isinstance(n, solution_node) or (
                isinstance(n, nodes.container) and n.get("nb_element") == "cell_code"
                and "solution" in n.get("cell_metadata", {}).get("tags", [])))]
            moved = [n for n in moved if not any(a in moved for a in _ancestors(n))]
            if not moved:
                continue
            for node in moved:
                node.parent.remove(node)
            chapter += nodes.rubric(text="Solutions to the exercises")
            chapter.extend(moved)


class SolutionCodePrinted(SphinxPostTransform):
    """Print a solution's code. Folded code (tag ``hide-input``: setup, glue, figure drawing) is left
    out of the printed book by sphinx-jupyterbook-latex, which cannot unfold it; a solution's code is
    folded in the HTML book only so that it does not give the answer away, and is the solution."""

    default_priority = 805  # after sphinx-jupyterbook-latex hid the folded inputs (400)
    builders = ("latex",)

    def run(self, **kwargs: Any) -> None:
        from sphinx_jupyterbook_latex.nodes import HiddenCellNode

        for cell in list(self.document.findall(nodes.container)):
            if "tag_solution" not in cell.get("classes", []):
                continue
            for hidden in [c for c in cell.children if isinstance(c, HiddenCellNode)
                           and "cell_input" in c.get("classes", [])]:
                shown = nodes.container("", *hidden.children, classes=hidden["classes"], nb_element="cell_code_source")
                hidden.replace_self(shown)


def _ancestors(node: nodes.Node) -> list[nodes.Node]:
    found, node = [], node.parent
    while node is not None:
        found.append(node)
        node = node.parent
    return found


def add_preamble(app, config) -> None:
    """The evidence blocks' and panel captions' LaTeX environments, after the configured preamble."""
    elements = dict(config.latex_elements or {})
    elements["preamble"] = elements.get("preamble", "") + PREAMBLE
    config.latex_elements = elements


def setup(app) -> dict[str, Any]:
    app.add_post_transform(PrintedOutputs)
    app.add_post_transform(PartsOfChapters)
    app.add_post_transform(SolutionsAtChapterEnd)
    app.add_post_transform(SolutionCodePrinted)
    app.connect("config-inited", add_preamble)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
