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

In the kernel (an IPython startup file, :func:`kernel_startup`), ``glued`` is defined and
``myst_nb.glue`` records what it glues, so a markdown cell run after the cells that glue shows
the values of this run: change a setting, run the chapter, and its prose follows.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Callable

ROLE = re.compile(r"\{glue:text\}`([^`]+)`")
EXPRESSION = re.compile(r'\{eval\}`glued\(("(?:[^"\\]|\\.)*")\)`')
METADATA = "user_expressions"


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

    for cell in notebook.get("cells", []):
        if cell.get("cell_type") != "markdown":
            continue
        source = cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])
        expressions: list[dict[str, Any]] = []

        def replace(match: re.Match) -> str:
            text = value(match.group(1))
            if text is None:
                return match.group(0)
            expression = _expression(match.group(1))
            if all(e["expression"] != expression for e in expressions):
                expressions.append({
                    "expression": expression,
                    "result": {"status": "ok", "data": {"text/plain": text}, "metadata": {}},
                })
            return "{eval}`" + expression + "`"

        new = ROLE.sub(replace, source)
        if expressions:
            cell["source"] = new
            cell.setdefault("metadata", {})[METADATA] = expressions
    return notebook


def from_lab(notebook: dict) -> dict:
    """The reverse of :func:`to_lab` (in place; returns ``notebook``): the roles, no expressions' results."""
    for cell in notebook.get("cells", []):
        if cell.get("cell_type") != "markdown":
            continue
        source = cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])
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
        return model

    async def save(self, model, path=""):
        if model.get("type") == "notebook" and model.get("content") is not None:
            from_lab(model["content"])
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
