"""Every stored notebook is the executed form of its jupytext source, and is in the book."""

from __future__ import annotations

from pathlib import Path

import jupytext
import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted((ROOT / "book").rglob("*.py"))


def cells(notebook) -> list[tuple[str, str]]:
    return [(c.cell_type, c.source.strip()) for c in notebook.cells]


@pytest.mark.parametrize("source", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_stored_notebook_matches_its_source(source: Path):
    stored = source.with_suffix(".ipynb")
    assert stored.exists(), f"run `python3 tasks.py notebooks {source.relative_to(ROOT)}`"
    assert cells(nbformat.read(stored, as_version=4)) == cells(jupytext.read(source)), (
        f"{stored.name} is out of date: run `python3 tasks.py notebooks {source.relative_to(ROOT)}`"
    )


def test_every_notebook_has_a_source_and_is_in_the_table_of_contents():
    toc = (ROOT / "_toc.yml").read_text()
    for notebook in (ROOT / "book").rglob("*.ipynb"):
        if ".ipynb_checkpoints" in notebook.parts:
            continue
        assert notebook.with_suffix(".py").exists(), f"{notebook} has no .py source"
        assert str(notebook.relative_to(ROOT).with_suffix("")) in toc, f"{notebook} is not in _toc.yml"
