"""Glued numbers in JupyterLab (tools/lab_glue.py): every role of the book becomes an inline
expression with the value myst-nb would print, every cross-reference to another page a link to
it, and saving gives back the file unchanged."""

from __future__ import annotations

import asyncio
import builtins
import copy
import json
import re
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


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_cross_chapter_reference_becomes_a_link_and_comes_back_unchanged(path: Path):
    """Opened, every {ref}/{numref}/{doc} whose target is on another page is a markdown link to
    that page (which exists), and the roles left point into the notebook itself; saved, the
    notebook is the one on disk (glue roles and links translated together, as the lab does)."""
    original = nbformat.read(path, as_version=4)
    lab = lab_glue.links_to_lab(lab_glue.to_lab(copy.deepcopy(original), _loader(path)), path, ROOT / "book")
    labels, _ = lab_glue.label_index(ROOT / "book")
    for cell in lab["cells"]:
        if cell["cell_type"] != "markdown":
            continue
        for match in lab_glue.XREF.finditer(cell["source"]):  # left: a section of this notebook
            target = match.group(3) or match.group(4)
            assert match.group(1) != "doc" and labels[target][0] == path and labels[target][2], (path.name, match.group(0))
        for entry in cell.get("metadata", {}).get(lab_glue.LINKS, []):
            assert entry["link"] in cell["source"] and entry["role"] not in cell["source"]
            link = re.fullmatch(r"\[(.+)\]\(([^()]+)\)", entry["link"])
            if link is None:  # an exercise or a paragraph of this notebook: its title
                text = re.fullmatch(r"\*([^*]+)\*", entry["link"]).group(1)
                assert labels[re.search(r"<?([^<>`]+)>?`$", entry["role"]).group(1)][0] == path
            else:
                text, target = link.groups()
                assert (path.parent / target).is_file() and (path.parent / target).resolve() != path.resolve()
            assert text.strip() and "`" not in text, entry
    back = lab_glue.links_from_lab(lab_glue.from_lab(lab))
    assert back == original


def test_a_reference_to_another_page_links_to_it_with_the_sections_title(tmp_path: Path):
    (tmp_path / "part1").mkdir()
    other = {"cells": [{"cell_type": "markdown", "metadata": {}, "source":
                        "# The model\n\n(model-densities)=\n## The three densities\n\ntext\n\n(a-paragraph)=\n"
                        "A paragraph.\n\n```{exercise} 1.2 Draw it\n:label: ex-draw\n:nonumber:\nDraw.\n```\n"}]}
    (tmp_path / "part1" / "model.ipynb").write_text(json.dumps(other))
    (tmp_path / "notation.md").write_text("# Notation\n\nsymbols\n")
    here = tmp_path / "part1" / "kalman.ipynb"
    source = ("# Kalman\n\n(own)=\n## Own section\n\nSee {ref}`model-densities`, {ref}`these <model-densities>`, "
              "{numref}`ex-draw`, {ref}`a-paragraph`, {doc}`model`, {doc}`the symbols <../notation>`, "
              "{doc}`/part1/model`, {ref}`own`, {ref}`nowhere` and {doc}`missing`; {ref}`model-densities` again; "
              "{ref}`ex-own` and {ref}`that paragraph <own-paragraph>` here.\n\n(own-paragraph)=\nA paragraph.\n\n"
              "```{exercise} 2.1 Own\n:label: ex-own\n:nonumber:\nDo it.\n```\n")
    notebook = {"cells": [{"cell_type": "markdown", "metadata": {}, "source": source}]}
    here.write_text(json.dumps(notebook))
    lab = lab_glue.links_to_lab(copy.deepcopy(notebook), here, tmp_path)
    shown = lab["cells"][0]["source"]
    assert shown == ("# Kalman\n\n(own)=\n## Own section\n\nSee [The three densities](model.ipynb), [these](model.ipynb), "
                     "[Exercise 1.2: Draw it](model.ipynb), [The model](model.ipynb), [The model](model.ipynb), "
                     "[the symbols](../notation.md), [The model](model.ipynb), {ref}`own`, {ref}`nowhere` and "
                     "{doc}`missing`; [The three densities](model.ipynb) again; *Exercise 2.1: Own* and "
                     "*that paragraph* here.") + source[source.index(" here.") + len(" here."):]
    assert lab_glue.links_from_lab(lab) == notebook
    # a link the reader deleted in JupyterLab is not restored; the others are
    lab = lab_glue.links_to_lab(copy.deepcopy(notebook), here, tmp_path)
    lab["cells"][0]["source"] = lab["cells"][0]["source"].replace("[these](model.ipynb), ", "")
    assert lab_glue.links_from_lab(lab)["cells"][0]["source"] == source.replace("{ref}`these <model-densities>`, ", "")


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
    links = [e["link"] for c in markdown for e in c["metadata"].get(lab_glue.LINKS, [])]
    assert links and all(link in "".join(c["source"] for c in markdown) for link in links)
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
