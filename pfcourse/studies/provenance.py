"""Provenance of a stored study: the code, the commit, the seeds and the time that made a table.

A study too heavy to run while the book executes is a record of
:mod:`pfcourse.studies.registry` and is stored under ``book/data/``. Beside each table goes a JSON record of
what made it, written by :func:`write_provenance` so that every study records the same
fields: the code (``code``), the commit it was launched from (``git_commit``, read by
:func:`launch_commit` when the script starts, whatever is committed while it runs), whether
the package or the tools differed from that commit (``working_tree_modified``), the date,
the Python and NumPy versions, the wall time, and the study's own fields (seeds, settings).
``tests/test_stored_studies.py`` re-computes a seeded sample of the stored rows from the recorded seeds.
"""

from __future__ import annotations

import csv
import json
import platform
import subprocess
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable

import numpy as np

ROOT = Path(__file__).resolve().parents[2]

#: The one schema of a stored study's provenance record: the keys every record has, what each says.
#: ``code`` and ``git_commit`` name what wrote the table, at that commit (it may have moved since);
#: ``row_code`` is the code that re-computes its rows today (tests/test_stored_studies.py); ``filters``
#: the particle filters its rows build, as settings records (``Study.filters``; the studies whose rows
#: build none through a record are :data:`pfcourse.studies.registry.NO_FILTER_RECORD`, each with its reason).
#: A study run in several goes lists its commits under ``runs`` in place of ``git_commit``; older records
#: converted to this schema list the change under ``conversions``.
SCHEMA = {
    "code": "the script or modules that wrote the table (a path, or a list of them), at git_commit",
    "git_commit": "the commit the run was launched from (or runs: [{commit, ...}] for a study run in goes)",
    "working_tree_modified": "whether pfcourse/ or tools/ differed from that commit",
    "wall_seconds": "the run's wall time on the machine that made it (seconds: a per-row column's meaning)",
    "row_code": "the code that re-computes the rows today: module (function), ...",
    "filters": "{name: the label and FilterSettings.record() of every particle filter the rows build}",
}


def _git(*args: str, root: Path = ROOT) -> str:
    return subprocess.run(["git", *args], cwd=root, capture_output=True, text=True).stdout.strip()


def launch_commit(root: Path = ROOT) -> str:
    """The commit checked out now (call it when the study starts)."""
    return _git("rev-parse", "HEAD", root=root)


def tree_modified(root: Path = ROOT, paths: Iterable[str] = ("pfcourse", "tools")) -> bool:
    """Whether tracked files under ``paths`` differ from the checked-out commit."""
    return bool(_git("status", "--porcelain", "--untracked-files=no", *paths, root=root))


def _record(code: str | list[str], commit: str, seconds: float, root: Path, fields: dict) -> dict:
    """The fields every record has (code, commit, tree state, date, versions, wall time), then ``fields``."""
    return {
        "code": code,
        "git_commit": commit,
        "working_tree_modified": tree_modified(root),
        "date_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "wall_seconds": round(float(seconds), 1),
        **fields,
    }


def _write(path: Path, record: dict) -> None:
    Path(path).write_text(json.dumps(record, indent=2, default=str) + "\n")


def write_provenance(path: Path, *, code: str | list[str], commit: str, seconds: float,
                     root: Path = ROOT, **fields: Any) -> dict:
    """Write the JSON provenance record of a stored table to ``path`` and return it."""
    record = _record(code, commit, seconds, root, fields)
    _write(path, record)
    return record


def append_rerun(path: Path, *, code: str | list[str], commit: str, seconds: float,
                 root: Path = ROOT, **fields: Any) -> dict:
    """Append the record of a re-run of one study of a group to the ``reruns`` list of the group's
    provenance file ``path``, keeping the group's record; return the appended entry."""
    record = json.loads(Path(path).read_text())
    entry = _record(code, commit, seconds, root, fields)
    record.setdefault("reruns", []).append(entry)
    _write(path, record)
    return entry


def write_rows(path: Path, rows: list[dict]) -> None:
    """Write dict rows as CSV, floats with ``repr`` (round-trip exact), columns of the first row."""
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(float(v)) if isinstance(v, float) else v for k, v in row.items()})
