"""The store of the book's heavy studies: one table per study under ``book/data/``, read and written one way.

A stored table is a CSV file, one row per run, with floats written by ``repr`` so that they
round-trip exactly (:func:`pfcourse.studies.provenance.write_rows`).  Two kinds of column
need more than a number or a plain word:

* ``literals``: settings that are neither numbers nor words (``None``, tuples), written as
  Python literals and read back with :func:`ast.literal_eval` (a study's are the columns of its
  grid that hold such values: :attr:`pfcourse.studies.registry.Study.literals`);
* ``arrays``: per-step columns (one NumPy array per row), kept beside the table in
  ``NAME.npz`` (one 2-D array per column, one row per table row; a row all NaN, a failed run
  that the study gives no scores, reads back as NaN).

The ``error_message`` column of :func:`~pfcourse.studies.study.run_study`'s rows is text: its empty
messages are read back as ``""`` (not NaN, what ``pandas.read_csv`` gives), so that :func:`load` returns the table as
``run_study`` made it (``seconds`` as stored).  The provenance of a table (code, commit,
seeds, settings, wall time) is the JSON record of
:func:`pfcourse.studies.provenance.write_provenance`, written beside it.
"""

from __future__ import annotations

import ast
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from pfcourse.studies.provenance import write_rows

DATA = Path(__file__).resolve().parents[2] / "book" / "data"
#: The column of run_study's failure messages (text, ``""`` for a run that did not fail).
MESSAGE = "error_message"


def save(path: Path, table: pd.DataFrame, *, literals: Sequence[str] = (), arrays: Sequence[str] = ()) -> None:
    """Write ``table`` to the CSV file ``path`` (and its ``arrays`` columns to ``path`` with suffix ``.npz``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = [c for c in arrays if c in table.columns]
    scalars = table.drop(columns=arrays).copy()
    for column in literals:
        scalars[column] = scalars[column].map(repr)
    write_rows(path, scalars.to_dict("records"))
    if arrays:
        width = max(len(v) for v in table[arrays[0]] if isinstance(v, np.ndarray))
        stacked = {}
        for column in arrays:
            out = np.full((len(table), width), np.nan)
            for i, value in enumerate(table[column]):
                if isinstance(value, np.ndarray):
                    out[i] = value
            stacked[column] = out
        np.savez_compressed(path.with_suffix(".npz"), **stacked)


def load(path: Path, *, literals: Sequence[str] = (), arrays: Sequence[str] = ()) -> pd.DataFrame:
    """The table stored at ``path`` by :func:`save` (floats exact: pandas >= 3 parses them precisely)."""
    path = Path(path)
    table = pd.read_csv(path, converters={column: ast.literal_eval for column in literals})
    if MESSAGE in table.columns:  # a message is text; read_csv reads an empty one as NaN
        table[MESSAGE] = ["" if isinstance(v, float) else v for v in table[MESSAGE]]
    arrays_path = path.with_suffix(".npz")
    if arrays and arrays_path.exists():
        with np.load(arrays_path) as stored:
            for column in arrays:
                table[column] = [np.nan if np.isnan(row).all() else row for row in stored[column]]
    return table
