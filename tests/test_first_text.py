"""Chapters in the first-text form (issue 39) keep what a newcomer needs from them.

For each chapter of ``FIRST_TEXT`` (the lead adds the rewritten chapters):

- **code a reader can paste:** its visible code cells (not tagged ``remove-input``, ``hide-input`` or
  ``remove-cell``) import ``pfcourse`` on at most one line for the data or plotting helpers and one
  for the exercise checker, no visible line is longer than 80 characters (clipped at 1280 px
  otherwise), and the visible code runs, top to bottom, in a blank Python with NumPy, SciPy and
  Matplotlib;
- **an honest reading time:** the header's "about <n> minutes to read" agrees with the prose at 150
  words a minute, plus 30 s per display equation and 6 s per visible code line (folded blocks left
  out), and comes to at most about 25 minutes;
- **controls that do something:** every control of its panel shows a different figure for each
  value it offers, the others at their defaults.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import jupytext
import nbformat
import pytest

from test_start_here import reading_minutes

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
from reading_times import in_words  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
FIRST_TEXT = ["onramp", "part1/model", "part1/kalman", "part1/importance_sampling", "part1/sis", "part1/sir",
              "part1/why_it_works",
              "part1/resampling_schemes",
              "part1/proposals", "part1/rao_blackwell", "part1/auxiliary", "part2/map_robot", "part2/map_global",
              "part4/pf_vs_kalman", "part4/data_association", "part5/particle_mcmc", "part5/static_parameters",
              "part2/robot", "part2/robot_vs_kalman", "part2/global_localization",
              "part3/robot_studies", "part3/resampling_studies", "part3/sensing_studies",
              "part5/likelihood", "part5/smoothing", "part2/real_robot", "part2/terrain", "part2/terrain_cure",
              "part2/terrain_marginalised"]
HIDDEN = {"remove-input", "hide-input", "remove-cell"}
MAX_LINE = 80
MAX_MINUTES = 25
WORDS = {in_words(n): n for n in range(100)}
PFCOURSE_IMPORT = re.compile(r"^\s*(?:from\s+pfcourse[\w.]*\s+import\b|import\s+pfcourse\b)")
CHECKER_IMPORT = re.compile(r"^\s*from\s+pfcourse\.book\.exercises\s+import\s+check_\w+(\s*,\s*check_\w+)*\s*$")


def source(doc: str) -> Path:
    return BOOK / f"{doc}.py"


def visible_code(doc: str) -> list[str]:
    """The visible code cells of a chapter, in order."""
    return [c.source for c in jupytext.read(source(doc)).cells
            if c.cell_type == "code" and not HIDDEN & set(c.metadata.get("tags", []))]


def code_lines(doc: str) -> list[str]:
    return [line for cell in visible_code(doc) for line in cell.splitlines() if line.strip()]


def honest_minutes(doc: str) -> int:
    """The reading time of the rule (tests/test_start_here.py): prose, display equations, visible code."""
    return reading_minutes([source(doc)])


def stated_minutes(doc: str) -> int | None:
    text = "\n".join(c.source for c in jupytext.read(source(doc)).cells if c.cell_type == "markdown")
    found = re.search(r"\*\*Time:\*\*[^\n]*?about ([a-z-]+) minutes to read", text)
    return WORDS.get(found.group(1)) if found else None


@pytest.mark.parametrize("doc", FIRST_TEXT)
def test_visible_code_imports_pfcourse_at_most_once_for_helpers_and_once_for_the_checker(doc):
    imports = [line for line in code_lines(doc) if PFCOURSE_IMPORT.match(line)]
    checkers = [line for line in imports if CHECKER_IMPORT.match(line)]
    helpers = [line for line in imports if not CHECKER_IMPORT.match(line)]
    assert len(helpers) <= 1, f"{doc}: {len(helpers)} visible pfcourse import lines for helpers: {helpers}"
    assert len(checkers) <= 1, f"{doc}: {len(checkers)} visible import lines of exercise checkers: {checkers}"


@pytest.mark.parametrize("doc", FIRST_TEXT)
def test_no_visible_code_line_is_clipped(doc):
    long = [line for line in code_lines(doc) if len(line) > MAX_LINE]
    assert not long, f"{doc}: visible code lines longer than {MAX_LINE} characters: {long}"


@pytest.mark.parametrize("doc", FIRST_TEXT)
def test_the_visible_code_runs_in_a_blank_python(doc, tmp_path):
    script = tmp_path / f"{doc.replace('/', '_')}_visible.py"
    script.write_text("\n\n".join(visible_code(doc)) + "\n")
    env = dict(os.environ, MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, f"{doc}: the visible code fails in a blank Python:\n{done.stderr[-2000:]}"


@pytest.mark.parametrize("doc", FIRST_TEXT)
def test_the_header_states_the_honest_reading_time(doc):
    stated, honest = stated_minutes(doc), honest_minutes(doc)
    assert stated is not None, f"{doc}: the header says no 'about <number in words> minutes to read'"
    assert abs(stated - honest) <= max(2, 0.25 * honest), f"{doc}: the header says {stated} min, it reads in {honest}"
    assert honest <= MAX_MINUTES, f"{doc}: {honest} minutes to read; cut or fold to about {MAX_MINUTES}"


def panel_images(doc: str) -> dict | None:
    notebook = nbformat.read(source(doc).with_suffix(".ipynb"), as_version=4)
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            page = output.get("data", {}).get("text/html", "")
            if 'class="pfcourse-panel"' in page:
                return json.loads(re.search(r'class="pfcourse-panel-data">(.*?)</script>', page).group(1))
    return None


@pytest.mark.parametrize("doc", FIRST_TEXT)
def test_every_control_of_the_panel_changes_the_figure(doc):
    data = panel_images(doc)
    assert data is not None, f"{doc}: no panel"
    current = sum(i * s for i, s in zip(data["defaults"], data["strides"]))
    for k, name in enumerate(data["descriptions"]):
        count = len(data["labels"][k])
        if data["main"][k]:
            numbers = [current + (i - data["defaults"][k]) * data["strides"][k] for i in range(count)]
        else:
            numbers = data["side"][str(k)]
        images = [data["images"][n] for n in numbers]
        assert count >= 2 and len(set(images)) == count, f"{doc}: the control {name!r} leaves the figure unchanged"
