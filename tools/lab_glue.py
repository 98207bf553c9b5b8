"""Glued numbers readable in JupyterLab: the book's ``{glue:text}`` roles shown as their values.

The prose quotes results with myst-nb's role ``{glue:text}`key:.2f` ``, which Sphinx replaces by
the value glued in the notebook's outputs. jupyterlab-myst knows no glue (it would print
``key:.2f``), but it renders MyST's inline expressions ``{eval}`expr` `` from the results stored in
the markdown cell's metadata (``user_expressions``, the format of the Jupyter messaging
protocol's ``execute_request``), without a kernel, and re-evaluates them when the cell is run.

``python3 tasks.py lab`` (and the JupyterLab live test) start JupyterLab with
:class:`GlueContentsManager`, which translates on the way in and back on the way out:

- **opening** a notebook: every ``{glue:text}`content` `` of a markdown cell becomes
  ``{eval}`glued("content")` `` and the cell's ``user_expressions`` carry its value, formatted from the
  stored output exactly as myst-nb formats it (``myst_nb.core.variables.format_plain_text``;
  ``doc.ipynb::key:fmt``, a value glued by another chapter, is read from that notebook);
- **saving**: the reverse, so the file on disk keeps the roles the book needs and nothing else
  (``to_lab`` then ``from_lab`` gives back the notebook unchanged, tests/test_lab_glue.py).

Cross-references to another chapter are translated the same way (:func:`links_to_lab`,
:func:`links_from_lab`): jupyterlab-myst resolves ``{ref}``/``{numref}`` labels of the open
notebook's sections only, and shows any other as a bare label with a warning. On opening, a
``{ref}``, ``{numref}`` or ``{doc}`` whose target is not in the notebook becomes a plain markdown
link to the chapter that holds it (``[title](../part1/model.ipynb)``; the role's own text, else
the section's or the chapter's title, from :func:`label_index` over the book's pages), and one to
an exercise or a paragraph of the notebook itself becomes its title in italics; the cell's
``pfcourse_links`` metadata keeps each original role, and saving puts it back, byte for byte.

In the kernel (an IPython startup file, :func:`kernel_startup`), ``glued`` is defined and
``myst_nb.glue`` records what it glues, so a markdown cell run after the cells that glue shows
the values of this run: change a setting, run the chapter, and its prose follows.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any, Callable

ROLE = re.compile(r"\{glue:text\}`([^`]+)`")
EXPRESSION = re.compile(r'\{eval\}`glued\(("(?:[^"\\]|\\.)*")\)`')
METADATA = "user_expressions"
#: Cross-reference roles: ``{ref}`label` ``, ``{ref}`text <label>` ``, the same for numref and doc.
XREF = re.compile(r"\{(ref|numref|doc)\}`(?:([^`<]*?)\s*<([^`<>]+)>|([^`<>]+))`")
#: A target line ``(label)=``; and one before a heading, with the heading it names.
ANCHOR = re.compile(r"^\(([^()\s]+)\)=\s*$", re.M)
TARGET = re.compile(r"^\(([^()\s]+)\)=\s*\n+(#+)\s+(.+?)\s*$", re.M)
#: An exercise or solution directive with its title and ``:label:`` option.
LABELLED = re.compile(r"^(`{3,}|:{3,})\{(exercise|solution)\}\s*(.*?)\s*\n((?::[a-z-]+:.*\n)*)", re.M)
HEADING = re.compile(r"^#\s+(.+?)\s*$", re.M)
LINKS = "pfcourse_links"


def split(content: str) -> tuple[str | None, str, str]:
    """``[doc::]key[:fmt]`` -> (doc or None, key, format spec), as myst-nb's PasteTextRole reads it."""
    parts = content.rsplit(":", 1)
    key, fmt = (parts[0], parts[1]) if len(parts) == 2 else (parts[0], "s")
    doc, _, name = key.rpartition("::")
    return (doc or None), name, fmt


def stored_glue(notebook: dict) -> dict[str, str]:
    """Key -> text/plain of every value glued in a notebook's stored outputs (shown or not)."""
    values: dict[str, str] = {}
    for cell in notebook.get("cells", []):
        for output in cell.get("outputs", []) or []:
            name = (output.get("metadata") or {}).get("scrapbook", {}).get("name")
            if name is None:
                continue
            text = next((v for k, v in (output.get("data") or {}).items() if k.endswith("text/plain")), None)
            if text is not None:
                values[name] = text if isinstance(text, str) else "".join(text)
    return values


def _format(text: str, fmt: str) -> str:
    from myst_nb.core.variables import format_plain_text

    return format_plain_text(text, fmt)


def _expression(content: str) -> str:
    return f"glued({json.dumps(content)})"


def to_lab(notebook: dict, load: Callable[[str], dict]) -> dict:
    """Glue roles -> inline expressions with their stored values (in place; returns ``notebook``).

    ``load(doc)`` returns the notebook a cross-document role names (path relative to this one).
    A role whose value cannot be found is left as it is (JupyterLab then shows its key).
    """
    own = stored_glue(notebook)
    others: dict[str, dict[str, str]] = {}

    def value(content: str) -> str | None:
        doc, key, fmt = split(content)
        if doc is None:
            table = own
        else:
            if doc not in others:
                try:
                    others[doc] = stored_glue(load(doc))
                except (OSError, ValueError):
                    others[doc] = {}
            table = others[doc]
        if key not in table:
            return None
        try:
            return _format(table[key], fmt)
        except (ValueError, TypeError):
            return None

    def translate(match: re.Match, expressions: list[dict[str, Any]]) -> str | None:
        text = value(match.group(1))
        if text is None:
            return None
        expression = _expression(match.group(1))
        if all(e["expression"] != expression for e in expressions):
            expressions.append({
                "expression": expression,
                "result": {"status": "ok", "data": {"text/plain": text}, "metadata": {}},
            })
        return "{eval}`" + expression + "`"

    return _rewrite(notebook, ROLE, translate, METADATA)


def _markdown(cell: dict) -> str:
    return cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])


def _rewrite(notebook: dict, pattern: re.Pattern, translate: Callable[[re.Match, list], str | None],
             key: str) -> dict:
    """Each match of ``pattern`` in a markdown cell -> ``translate(match, records)`` (``None``: left
    as it is), which may append to the cell's ``records``; a cell with records keeps them in its
    metadata under ``key``. In place; returns ``notebook``."""
    for cell in notebook.get("cells", []):
        if cell.get("cell_type") != "markdown":
            continue
        records: list = []
        new = pattern.sub(lambda match: translate(match, records) or match.group(0), _markdown(cell))
        if records:
            cell["source"] = new
            cell.setdefault("metadata", {})[key] = records
    return notebook


def from_lab(notebook: dict) -> dict:
    """The reverse of :func:`to_lab` (in place; returns ``notebook``): the roles, no expressions' results."""
    for cell in notebook.get("cells", []):
        if cell.get("cell_type") != "markdown":
            continue
        source = _markdown(cell)
        new = EXPRESSION.sub(lambda m: "{glue:text}`" + json.loads(m.group(1)) + "`", source)
        if new != source:
            cell["source"] = new
        metadata = cell.get("metadata", {})
        if METADATA in metadata:
            kept = [e for e in metadata[METADATA] if not EXPRESSION.fullmatch("{eval}`" + e.get("expression", "") + "`")]
            if kept:
                metadata[METADATA] = kept
            else:
                del metadata[METADATA]
    return notebook




def page_targets(text: str) -> tuple[str | None, dict[str, tuple[str, bool]]]:
    """A page's title (its first ``#`` heading) and its labels -> (title, is a section's), from its markdown.

    Labels are ``(label)=`` targets (titled by the heading under them, else by the page's title) and
    the ``:label:`` of exercise directives (titled "Exercise 4.1: Title", as the HTML book shows
    them). Only a section's label is one jupyterlab-myst resolves within the notebook.
    """
    heading = HEADING.search(text)
    page = heading.group(1) if heading else None
    labels = {m.group(1): (page, False) for m in ANCHOR.finditer(text) if page is not None}  # a paragraph's
    labels.update({m.group(1): (m.group(3), True) for m in TARGET.finditer(text)})        # or a section's
    for m in LABELLED.finditer(text):
        label = re.search(r"^:label:\s*(\S+)", m.group(4), re.M)
        if label and m.group(2) == "exercise":
            number, _, title = m.group(3).partition(" ")
            labels[label.group(1)] = (f"Exercise {number}: {title}" if title else f"Exercise {number}", False)
    return page, labels


def _page_text(path: Path) -> str:
    if path.suffix == ".ipynb":
        notebook = json.loads(path.read_text(encoding="utf-8"))
        return "\n\n".join(_markdown(c) for c in notebook.get("cells", []) if c.get("cell_type") == "markdown")
    return path.read_text(encoding="utf-8")


_PAGES: dict[Path, tuple[float, tuple[str | None, dict[str, str]]]] = {}  # path -> (mtime, targets)


def label_index(root: Path) -> tuple[dict[str, tuple[Path, str, bool]], dict[Path, str]]:
    """Every page of the book under ``root`` (``.ipynb`` and ``.md``): ``label -> (page, title, is a
    section's)`` and ``page (without suffix) -> title``. Each page is read again only when it changed."""
    labels: dict[str, tuple[Path, str, bool]] = {}
    titles: dict[Path, str] = {}
    for path in sorted([*root.rglob("*.ipynb"), *root.rglob("*.md")]):
        if any(part.startswith((".", "_")) for part in path.relative_to(root).parts):
            continue
        mtime = path.stat().st_mtime
        if path not in _PAGES or _PAGES[path][0] != mtime:
            try:
                _PAGES[path] = (mtime, page_targets(_page_text(path)))
            except (OSError, ValueError):
                continue
        title, own = _PAGES[path][1]
        if title is not None:
            titles.setdefault(path.with_suffix(""), title)
        for label, (text, section) in own.items():
            labels.setdefault(label, (path, text, section))
    return labels, titles


def _link_text(text: str) -> str:
    return text.replace("[", "\\[").replace("]", "\\]")


def links_to_lab(notebook: dict, path: Path, root: Path) -> dict:
    """Cross-references out of the notebook at ``path`` -> markdown links (in place; returns it).

    A ``{ref}``/``{numref}`` to a label of another page of the book under ``root``, and every
    ``{doc}``, become ``[text](relative path of the page)``, ``text`` the role's own or the title
    of the section (or page); one to an exercise or a paragraph of this notebook, which
    jupyterlab-myst does not resolve either, becomes that text in italics; the cell's ``pfcourse_links`` metadata records each link and the role
    it replaces, in order, for :func:`links_from_lab`. A target that is not found stays a role.
    """
    path = Path(path)
    labels, titles = label_index(root)
    folder = path.parent

    def page(stem: Path) -> Path | None:
        for suffix in (".ipynb", ".md"):
            if stem.with_suffix(suffix).exists():
                return stem.with_suffix(suffix)
        return None

    def link(match: re.Match) -> str | None:
        kind, text, target = match.group(1), match.group(2), match.group(3) or match.group(4)
        if kind == "doc":
            stem = (root / target.lstrip("/")) if target.startswith("/") else (folder / target)
            stem = Path(os.path.normpath(stem))
            found = page(stem)
            if found is None or found.resolve() == path.resolve():
                return None
            title = titles.get(stem, target)
        else:
            if target not in labels:
                return None
            found, title, section = labels[target]
            if found.resolve() == path.resolve():  # in this notebook: jupyterlab-myst resolves a
                return None if section else f"*{text or title}*"  # section's label only
        relative = Path(os.path.relpath(found, folder)).as_posix()
        return f"[{_link_text(text or title)}]({relative})"

    def translate(match: re.Match, made: list[dict[str, str]]) -> str | None:
        new = link(match)
        if new is not None:
            made.append({"link": new, "role": match.group(0)})
        return new

    return _rewrite(notebook, XREF, translate, LINKS)


def links_from_lab(notebook: dict) -> dict:
    """The reverse of :func:`links_to_lab` (in place; returns ``notebook``): each recorded link, in
    order, back to its role; a link the reader edited away is left as it is."""
    for cell in notebook.get("cells", []):
        if cell.get("cell_type") != "markdown" or LINKS not in cell.get("metadata", {}):
            continue
        source, out, cursor = _markdown(cell), [], 0
        for entry in cell["metadata"].pop(LINKS):
            at = source.find(entry["link"], cursor)
            if at < 0:
                continue
            out += [source[cursor:at], entry["role"]]
            cursor = at + len(entry["link"])
        cell["source"] = "".join(out) + source[cursor:]
    return notebook


try:
    from jupyter_server.services.contents.largefilemanager import AsyncLargeFileManager
except ImportError:  # tasks.py's own Python, which only writes the command line
    AsyncLargeFileManager = object  # type: ignore[assignment,misc]


class GlueContentsManager(AsyncLargeFileManager):  # type: ignore[misc,valid-type]
    """JupyterLab's default contents manager, with the glue roles translated (see the module)."""

    async def get(self, path, content=True, type=None, format=None, require_hash=False):  # noqa: A002
        model = await super().get(path, content=content, type=type, format=format, require_hash=require_hash)
        if content and model.get("type") == "notebook" and model.get("content") is not None:
            folder = Path(self._get_os_path(path)).parent

            def load(doc: str) -> dict:
                return json.loads((folder / doc).read_text(encoding="utf-8"))

            to_lab(model["content"], load)
            links_to_lab(model["content"], Path(self._get_os_path(path)), Path(self.root_dir))
        return model

    async def save(self, model, path=""):
        if model.get("type") == "notebook" and model.get("content") is not None:
            links_from_lab(from_lab(model["content"]))
        return await super().save(model, path)


# --------------------------------------------------------------------------- in the kernel

GLUED: dict[str, str] = {}  # key -> text/plain of the value glued by this kernel


def glued(content: str) -> str:
    """The text a ``{glue:text}`content` `` role shows, from this kernel's glue calls (or, for
    ``doc::key``, from the stored notebook ``doc``)."""
    doc, key, fmt = split(content)
    if doc is None:
        if key not in GLUED:
            raise KeyError(f"{key!r} is not glued yet: run the cell that glues it")
        return _format(GLUED[key], fmt)
    table = stored_glue(json.loads(Path(doc).read_text(encoding="utf-8")))
    return _format(table[key], fmt)


def install_in_kernel() -> None:
    """Define ``glued`` for the kernel's expressions and make ``myst_nb.glue`` record its values."""
    import builtins

    import IPython
    import myst_nb

    original = myst_nb.glue

    def glue(name: str, variable: Any, display: bool = True) -> None:
        mimebundle, _ = IPython.core.formatters.format_display_data(variable)
        if "text/plain" in mimebundle:
            GLUED[name] = mimebundle["text/plain"]
        original(name, variable, display)

    glue.__doc__ = original.__doc__
    myst_nb.glue = glue
    builtins.glued = glued


def kernel_startup() -> str:
    """The IPython startup file that installs :func:`install_in_kernel` in JupyterLab's kernels."""
    folder = json.dumps(str(Path(__file__).resolve().parent))
    return f"import sys as _sys\n_sys.path.insert(0, {folder})\nimport lab_glue as _lab_glue\n_lab_glue.install_in_kernel()\n"


def reader_lab(folder: Path) -> tuple[list[str], dict[str, str]]:
    """The JupyterLab a reader gets: its options and environment, with its files under ``folder``.

    One set-up for ``python3 tasks.py lab`` and the JupyterLab browser test: glued numbers shown
    as values (the contents manager, and the kernels' startup file in ``folder/ipython``); no news
    pop-up and no update check (neither can be reached offline, and the pop-up covers a corner);
    ``--allow-root`` when run as root, as in a container; and JupyterLab's cell toolbar switched
    off: it measures a rendered markdown cell's children to avoid drawing over them, and throws an
    uncaught TypeError on every jupyterlab-myst cell (the toolbar holds only editing buttons).
    Returns ``(options, environment variables)``; ``PYTHONPATH`` must also name the tools folder.
    """
    import os

    startup = folder / "ipython" / "profile_default" / "startup"
    startup.mkdir(parents=True, exist_ok=True)
    (startup / "00-pfcourse-glue.py").write_text(kernel_startup())
    labconfig = folder / "config" / "labconfig"
    labconfig.mkdir(parents=True, exist_ok=True)
    (labconfig / "page_config.json").write_text(
        json.dumps({"disabledExtensions": {"@jupyterlab/cell-toolbar-extension": True}}))
    options = [
        "--ServerApp.contents_manager_class=lab_glue.GlueContentsManager",
        "--LabApp.news_url=None",
        "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
    ]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        options.append("--allow-root")
    return options, {"IPYTHONDIR": str(folder / "ipython"), "JUPYTER_CONFIG_DIR": str(folder / "config")}
