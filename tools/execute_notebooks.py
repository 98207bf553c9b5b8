"""Turn notebook sources (jupytext percent scripts) into executed, stored notebooks.

    python tools/execute_notebooks.py book/part1/model.py [...]

Each ``X.py`` becomes ``X.ipynb`` next to it, executed top to bottom in a fresh
kernel (working directory: the notebook's folder), without widget state (the
HTML book shows each panel's static version, pfcourse/book/static_panel.py;
JupyterLab makes the widgets live when the cells run) and without timing metadata,
so that a re-run of an unchanged source gives the same file.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import jupytext
import nbformat
from nbclient import NotebookClient


# Run in the kernel before the notebook (an IPython startup file): widget model ids (comm)
# and animation ids (matplotlib's to_jshtml) come from uuid.uuid4, random on every run; they
# are drawn from a generator seeded by the notebook's name instead, so that re-executing an
# unchanged source stores an unchanged file.
SEEDED_UUIDS = """
import random as _random
import uuid as _uuid

_uuid_rng = _random.Random({seed!r})
_uuid.uuid4 = lambda: _uuid.UUID(int=_uuid_rng.getrandbits(128), version=4)
"""
# Run in the kernels of the book's execution and of the tests (conftest.py): myst-nb's glue imports
# nbformat, whose jsonschema loads its optional IRI format checker, rfc3987-syntax, which compiles a
# grammar at import: 1.2 s in every kernel, a tenth of the book's execution. Nothing in a chapter
# checks IRIs, so these kernels do without it (jsonschema then leaves the "iri" format unchecked).
NO_IRI_GRAMMAR = """
import sys as _sys
_sys.modules.setdefault("rfc3987_syntax", None)
"""


def execute(source: Path, extra_startup: str = "", store: bool = True) -> nbformat.NotebookNode:
    """Execute the notebook made from ``source``; store it as ``X.ipynb`` unless ``store`` is False.

    ``extra_startup`` is Python run in the kernel after the uuid seeding and before the
    notebook (tools/perturbed_arithmetic.py uses it). Returns the executed notebook.
    """
    with tempfile.TemporaryDirectory() as ipython_dir:
        startup = Path(ipython_dir) / "profile_default" / "startup"
        startup.mkdir(parents=True)
        (startup / "00-seeded-uuids.py").write_text(SEEDED_UUIDS.format(seed=source.stem))
        (startup / "00-no-iri-grammar.py").write_text(NO_IRI_GRAMMAR)
        if extra_startup:
            (startup / "01-extra.py").write_text(extra_startup)
        previous = os.environ.get("IPYTHONDIR")
        os.environ["IPYTHONDIR"] = ipython_dir
        try:
            return _execute(source, store)
        finally:
            if previous is None:
                os.environ.pop("IPYTHONDIR", None)
            else:
                os.environ["IPYTHONDIR"] = previous


def coalesce_streams(outputs: list) -> list:
    """Consecutive outputs of one stream (stdout, stderr) as one: where the kernel cut a printed
    text into messages depends on timing, and a stored file must not."""
    merged: list = []
    for output in outputs:
        if (output.get("output_type") == "stream" and merged and merged[-1].get("output_type") == "stream"
                and merged[-1].get("name") == output.get("name")):
            merged[-1]["text"] = merged[-1]["text"] + output["text"]
        else:
            merged.append(output)
    return merged


def _execute(source: Path, store: bool) -> nbformat.NotebookNode:
    notebook = jupytext.read(source)
    notebook.metadata["kernelspec"] = {
        "name": "python3",
        "display_name": "Python 3 (ipykernel)",
        "language": "python",
    }
    notebook.metadata.pop("jupytext", None)
    for index, cell in enumerate(notebook.cells):
        cell.id = f"cell-{index}"  # stable ids: an unchanged source gives an unchanged file
    start = time.perf_counter()
    NotebookClient(
        notebook,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(source.parent)}},
        record_timing=False,
        store_widget_state=True,  # nbclient needs it to capture Output widgets
    ).execute()
    notebook.metadata.pop("widgets", None)  # see the module docstring
    for cell in notebook.cells:
        if cell.cell_type == "code":
            cell.outputs = coalesce_streams(cell.outputs)
    target = source.with_suffix(".ipynb")
    if store:
        nbformat.write(notebook, target)
    print(f"{target}: executed in {time.perf_counter() - start:.1f} s", flush=True)
    return notebook


if __name__ == "__main__":
    for path in sys.argv[1:]:
        execute(Path(path).resolve())
