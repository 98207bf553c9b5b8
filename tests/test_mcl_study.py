"""The provenance the global-localization chapter prints (book/data/global_localization/provenance.json).

Every table of the chapter, the per-step ``modes`` included, is a registered study
(``global_localization/...`` of pfcourse.studies.registry), re-computed by tests/test_stored_studies.py.
"""

from __future__ import annotations

import json
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "book" / "data" / "global_localization"


def test_provenance_names_the_code_commit_and_seeds():
    prov = json.loads((DATA / "provenance.json").read_text())
    assert prov["code"] and len(prov["git_commit"]) == 40 and "seed" in prov["seeds"]  # the chapter prints them
