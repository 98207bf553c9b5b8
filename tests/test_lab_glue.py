"""Glued numbers in JupyterLab (tools/lab_glue.py): every role of the book becomes an inline
expression with the value myst-nb would print, and saving gives back the file unchanged."""

from __future__ import annotations

import asyncio
import builtins
import copy
import json
import shutil
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import lab_glue  # noqa: E402

NOTEBOOKS = sorted(p for p in (ROOT / "book").rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts)


def _loader(path: Path):
    return lambda doc: json.loads((path.parent / doc).read_text(encoding="utf-8"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_role_shows_its_value_and_comes_back_unchanged(path: Path):
    original = nbformat.read(path, as_version=4)  # as JupyterLab's server reads it (sources joined)
    lab = lab_glue.to_lab(copy.deepcopy(original), _loader(path))
    sources = [c["source"] for c in lab["cells"] if c["cell_type"] == "markdown"]
    left = [m.group(0) for s in sources for m in lab_glue.ROLE.finditer(s)]
    assert not left, f"{path.name}: roles whose value was not found: {left[:5]}"
    for cell in lab["cells"]:
        for expression in cell.get("metadata", {}).get(lab_glue.METADATA, []):
            text = expression["result"]["data"]["text/plain"]
            assert text and not text.startswith("np."), (path.name, expression)
            assert "{eval}`" + expression["expression"] + "`" in cell["source"]
    back = lab_glue.from_lab(lab)
    assert back == original


def test_values_are_formatted_as_myst_nb_formats_them():
    notebook = {"cells": [
        {"cell_type": "code", "source": "", "metadata": {}, "outputs": [
            {"output_type": "display_data", "metadata": {"scrapbook": {"name": "rate", "mime_prefix": ""}},
             "data": {"text/plain": "0.65432"}},
            {"output_type": "display_data", "metadata": {"scrapbook": {"name": "runs", "mime_prefix": "x"}},
             "data": {"application/papermill.record/text/plain": "100"}},
        ]},
        {"cell_type": "markdown", "metadata": {},
         "source": "lost {glue:text}`rate:.0%` of {glue:text}`runs:d` flights, {glue:text}`rate:.2f`; "
                   "{glue:text}`missing:.2f` and {glue:text}`other.ipynb::k:.1f`"},
    ]}
    lab = lab_glue.to_lab(notebook, lambda doc: {"cells": [{"cell_type": "code", "outputs": [
        {"metadata": {"scrapbook": {"name": "k"}}, "data": {"text/plain": "2.25"}}]}]})
    cell = lab["cells"][1]
    shown = {e["expression"]: e["result"]["data"]["text/plain"] for e in cell["metadata"]["user_expressions"]}
    assert shown == {'glued("rate:.0%")': "65%", 'glued("runs:d")': "100", 'glued("rate:.2f")': "0.65",
                     'glued("other.ipynb::k:.1f")': "2.2"}
    # a key that is glued nowhere stays a role (JupyterLab shows its name, the build fails on it)
    assert "{glue:text}`missing:.2f`" in cell["source"]


def test_the_contents_manager_translates_on_open_and_back_on_save(tmp_path: Path):
    pytest.importorskip("jupyter_server")
    chapter = next(p for p in NOTEBOOKS if lab_glue.ROLE.search(p.read_text(encoding="utf-8")))
    folder = tmp_path / chapter.parent.name
    shutil.copytree(chapter.parent, folder)
    name = f"{folder.name}/{chapter.name}"
    manager = lab_glue.GlueContentsManager(root_dir=str(tmp_path))
    before = (folder / chapter.name).read_bytes()

    async def open_and_save():
        model = await manager.get(name)
        opened = copy.deepcopy(model)
        await manager.save({"type": "notebook", "format": "json", "content": model["content"]}, name)
        return opened

    model = asyncio.run(open_and_save())
    markdown = [c for c in model["content"]["cells"] if c["cell_type"] == "markdown"]
    assert any("{eval}`glued(" in c["source"] for c in markdown)
    assert not any(lab_glue.ROLE.search(c["source"]) for c in markdown)
    assert (folder / chapter.name).read_bytes() == before


def test_the_kernel_side_shows_this_runs_values(monkeypatch):
    import myst_nb

    monkeypatch.setattr(myst_nb, "glue", myst_nb.glue)
    monkeypatch.setattr(lab_glue, "GLUED", {})
    monkeypatch.delattr(builtins, "glued", raising=False)
    lab_glue.install_in_kernel()
    from myst_nb import glue

    glue("ratio", 1.23456, display=False)
    assert builtins.glued("ratio:.2f") == "1.23"
    with pytest.raises(KeyError, match="run the cell that glues it"):
        builtins.glued("not_yet:.2f")
    monkeypatch.delattr(builtins, "glued")


def test_the_readers_lab_has_no_news_no_toolbar_and_runs_as_root(tmp_path, monkeypatch):
    import os

    for root_user in (True, False):
        monkeypatch.setattr(os, "geteuid", lambda r=root_user: 0 if r else 1000)
        options, env = lab_glue.reader_lab(tmp_path)
        assert ("--allow-root" in options) is root_user
    assert "--LabApp.news_url=None" in options
    assert "--ServerApp.contents_manager_class=lab_glue.GlueContentsManager" in options
    page = json.loads((Path(env["JUPYTER_CONFIG_DIR"]) / "labconfig" / "page_config.json").read_text())
    assert page["disabledExtensions"]["@jupyterlab/cell-toolbar-extension"] is True
    assert (Path(env["IPYTHONDIR"]) / "profile_default" / "startup" / "00-pfcourse-glue.py").read_text() == \
        lab_glue.kernel_startup()
