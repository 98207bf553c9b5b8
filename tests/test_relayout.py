"""tools/relayout.py on a small repository: files move, every reference follows, a second run changes
nothing, a file added later at an old path is moved and rewritten, stored outputs stay as they were."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import relayout  # noqa: E402

NOTEBOOK = {
    "cells": [
        {"cell_type": "markdown", "id": "a", "metadata": {},
         "source": ["The report lives in `pfcourse.figures.report`.\n", "See pfcourse/style.py."]},
        {"cell_type": "code", "execution_count": 1, "id": "b", "metadata": {},
         "outputs": [{"name": "stdout", "output_type": "stream", "text": ["pfcourse.style is printed\n"]}],
         "source": ["%matplotlib inline\n", "from pfcourse import style\n",
                    "from pfcourse.landmarks.scenario import LandmarkScenario, simulate_run, aa\n",
                    "print('pfcourse.style is printed')"]},
    ],
    "metadata": {}, "nbformat": 4, "nbformat_minor": 5,
}


def write(root: Path, rel: str, text: str) -> None:
    (root / rel).parent.mkdir(parents=True, exist_ok=True)
    (root / rel).write_text(text)


def git(root: Path, *args: str) -> str:
    return subprocess.run(["git", *args], cwd=root, check=True, capture_output=True, text=True).stdout


@pytest.fixture
def repo(tmp_path: Path) -> Path:
    files = {
        "pfcourse/__init__.py": "from pfcourse.filter import go\n",
        "pfcourse/filter.py": "from . import kernels\n\ndef go():\n    return kernels\n",
        "pfcourse/kernels.py": "",
        "pfcourse/errors.py": "",
        "pfcourse/executor.py": "from .errors import *  # noqa\n",
        "pfcourse/style.py": "import pfcourse.narrow_figures as nf\n",
        "pfcourse/narrow_figures.py": "",
        "pfcourse/figures/__init__.py": "",
        "pfcourse/figures/report.py": "from pfcourse import style\n",
        "pfcourse/landmarks/__init__.py": "from pfcourse.landmarks.scenario import LandmarkScenario\n",
        "pfcourse/landmarks/scenario.py": "LandmarkScenario = simulate_run = aa = 1\n"
                                          "DATA = Path(__file__).resolve().parents[2] / 'book'\n",
        "pfcourse/landmarks/figures.py": "from pfcourse.style import x\n",
        "pfcourse/experiments/__init__.py": "",
        "pfcourse/experiments/likelihood.py": "",
        "pfcourse/experiments/store.py": "",
        "pfcourse/experiments/registry.py": (
            "from pfcourse.experiments import (likelihood,  # methods\n    store)\n"
            "from pfcourse.landmarks import figures as lf\n"
            "PATH = 'pfcourse/experiments/store.py'\n"),
        "tests/test_x.py": "import pfcourse.figures.report\nmock = 'pfcourse.executor.stats'\nPATTERN = r'pfcourse\\.exercises\\s'\n",
        "README.md": "The tree: `pfcourse/figures/` and `pfcourse.experiments.registry`.\n",
    }
    for rel, text in files.items():
        write(tmp_path, rel, text)
    write(tmp_path, "book/x.ipynb", json.dumps(NOTEBOOK, sort_keys=True, indent=1) + "\n")
    git(tmp_path, "init", "-q")
    git(tmp_path, "add", "-A")
    git(tmp_path, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "old layout")
    return tmp_path


def test_moves_and_rewrites(repo: Path) -> None:
    plan, changed = relayout.relayout(repo)
    assert {(str(old), str(new)) for old, new, _ in plan} >= {
        ("pfcourse/figures/report.py", "pfcourse/book/report.py"),
        ("pfcourse/landmarks/figures.py", "pfcourse/book/figures/landmarks.py"),
        ("pfcourse/experiments/likelihood.py", "pfcourse/likelihood.py"),
        ("pfcourse/experiments/registry.py", "pfcourse/studies/registry.py"),
        ("pfcourse/style.py", "pfcourse/book/style.py"),
    }
    assert not (repo / "pfcourse/figures").exists() and not (repo / "pfcourse/experiments").exists()
    assert (repo / "pfcourse/book/__init__.py").exists() and (repo / "pfcourse/scenarios/__init__.py").exists()
    # a path from the module's own file still reaches the repository's root, one folder deeper
    assert "Path(__file__).resolve().parents[3] / 'book'" in (repo / "pfcourse/scenarios/landmarks/scenario.py").read_text()
    registry = (repo / "pfcourse/studies/registry.py").read_text()
    assert "from pfcourse import likelihood  # methods\nfrom pfcourse.studies import store\n" in registry
    assert "from pfcourse.book.figures import landmarks as lf\n" in registry
    assert "PATH = 'pfcourse/studies/store.py'" in registry
    assert (repo / "pfcourse/book/report.py").read_text() == "from pfcourse.book import style\n"
    assert (repo / "pfcourse/studies/executor.py").read_text() == "from pfcourse.errors import *  # noqa\n"
    assert (repo / "pfcourse/filter.py").read_text().startswith("from pfcourse import kernels\n")
    assert (repo / "tests/test_x.py").read_text() == ("import pfcourse.book.report\n"
                                                      "mock = 'pfcourse.studies.executor.stats'\n"
                                                      "PATTERN = r'pfcourse\\.book\\.exercises\\s'\n")
    assert "`pfcourse/book/figures/` and `pfcourse.studies.registry`" in (repo / "README.md").read_text()
    nb = json.loads((repo / "book/x.ipynb").read_text())
    markdown, code = nb["cells"]
    assert "".join(markdown["source"]) == ("The report lives in `pfcourse.book.report`.\n"
                                           "See pfcourse/book/style.py.")
    assert code["source"][:2] == ["%matplotlib inline\n", "from pfcourse.book import style\n"]
    # the longer scenario path is wrapped at a chapter's 80 columns
    assert all(len(line.rstrip("\n")) <= 80 for line in code["source"])
    assert "".join(code["source"][2:4]).startswith("from pfcourse.scenarios.landmarks.scenario import (\n")
    assert code["outputs"] == NOTEBOOK["cells"][1]["outputs"]  # outputs are never rewritten
    # nor the strings of a chapter's code, which its stored outputs print
    assert code["source"][-1] == "print('pfcourse.style is printed')"
    # moved with git mv: the index has the new paths, not the old ones
    index = git(repo, "ls-files").split()
    assert "pfcourse/book/report.py" in index and "pfcourse/figures/report.py" not in index


def test_second_run_changes_nothing(repo: Path) -> None:
    relayout.relayout(repo)
    git(repo, "add", "-A")
    before = git(repo, "status", "--porcelain")
    plan, changed = relayout.relayout(repo)
    assert plan == [] and changed == []
    assert git(repo, "status", "--porcelain") == before


def test_files_added_later_at_old_paths(repo: Path) -> None:
    relayout.relayout(repo)
    git(repo, "add", "-A")
    git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "new layout")
    # another branch, merged after the move, adds a study module and a test at the old paths
    write(repo, "pfcourse/experiments/new_study.py", "from pfcourse.experiments.store import x\n"
                                                      "from pfcourse import executor\n")
    git(repo, "add", "-A")
    write(repo, "tests/test_new.py", "from pfcourse.experiments import new_study\n")
    plan, changed = relayout.relayout(repo)
    assert [(str(o), str(n)) for o, n, _ in plan] == [("pfcourse/experiments/new_study.py",
                                                      "pfcourse/studies/new_study.py")]
    assert (repo / "pfcourse/studies/new_study.py").read_text() == ("from pfcourse.studies.store import x\n"
                                                                   "from pfcourse.studies import executor\n")
    assert (repo / "tests/test_new.py").read_text() == "from pfcourse.studies import new_study\n"
    assert not (repo / "pfcourse/experiments").exists()


def test_new_names_never_start_with_old_ones() -> None:
    """What makes a second run a no-op: no module's new name is moved again."""
    for old, new in relayout.MOVES.items():
        assert relayout.new_name(new) == new, (old, new)
