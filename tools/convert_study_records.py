"""One-off conversion of the stored studies to the registry's one provenance schema and message column
(issue 44's remainder).  Run from the repository's root; it reads the files of commit ``FROM`` and writes
the converted ones, so a second run writes the same files:

    .venv/bin/python tools/convert_study_records.py

Not map_global/ and intel/ (other branches were re-running them; the registry's run() writes their records
in the schema), but the two poor-fit variants, which are not re-run.

* **Tables**: run_study's message column ``error`` is named ``error_message`` (the header only: every value
  is unchanged, byte for byte), so that no metric can take its name (``sir_fixes`` and
  ``static_parameters`` have a metric ``error``, which stays);
* **Provenance** (:data:`pfcourse.studies.provenance.SCHEMA`): the filters each study's rows build, as
  settings records (``filters``: :meth:`pfcourse.studies.registry.Study.filter_records`), in place of the
  prose or the older keys that described them (:data:`REPLACED`); the current ``row_code`` (what the
  re-computation test runs today; a different one recorded at the run is kept as ``row_code_at_run``);
  the older schema's keys renamed (``made_by`` joins ``code``, ``package_dirty_at_run`` is
  ``working_tree_modified``).  Every other key and value is kept; the change is listed under
  ``conversions``.

``tests/test_study_records.py`` checks that every converted table, read by ``STUDIES[name].load()``, holds
the values of the table of ``FROM`` and that every provenance record follows the schema.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import pfcourse  # noqa: E402,F401  (first: it pins NumPy's arithmetic)
from pfcourse.studies.registry import STUDIES, Study  # noqa: E402
from pfcourse.studies.store import DATA, MESSAGE  # noqa: E402

#: The commit whose files are converted (main when the conversion was written).
FROM = "40102b0cdb212a75bda5820c9f34b121eb702957"
TOOL = "tools/convert_study_records.py"
DATE = "2026-11-27"
#: The folders whose studies other branches were re-running when this was written: left alone, since this
#: tool writes the files of FROM (their records, written by the registry's run(), follow the schema but for a stale row_code where a table
#: was stored under another study's name: the two poor-fit variants, not re-run, converted now).
LATER = ("map_global/", "intel/")
NOW = ("map_global/global_poor_fit", "map_global/kidnap_poor_fit")
#: Provenance keys that described a study's filters (in prose, or as the older ``settings``), replaced by
#: ``filters``; or, for robot_consistency_fixes, its settings' model part, now ``q_scale``.
REPLACED = {
    "linear_n.json": ("filter",), "why_it_works.json": ("filter",), "why_it_works_growth.json": ("filter",),
    "why_it_works_clt.json": ("filter",), "why_it_works_resampling.json": ("filter",),
    "terrain_reference.json": ("filter",), "robot/dead_reckoning.json": ("filter",),
    "data_association.json": ("n_particles",), "rb_five_landmarks.json": ("N",), "proposals.json": ("lab",),
    "terrain_field_pf.json": ("settings",), "robot_consistency_fixes.json": ("settings",),
    "terrain_remedies.json": ("settings",), "terrain_equal_cost.json": ("settings",),
    "global_localization/kld_amcl.json": ("settings",), "terrain_studies.json": ("baseline",),
    "terrain_mpf.json": ("filter",), "terrain_map_bias.json": ("filter",),
}


def git_show(path: str) -> str | None:
    done = subprocess.run(["git", "show", f"{FROM}:book/data/{path}"], cwd=ROOT, capture_output=True, text=True)
    return done.stdout if done.returncode == 0 else None


def renames_message(study: Study, header: list[str]) -> bool:
    """Whether the table's ``error`` column is run_study's messages (not a metric named ``error``)."""
    if "error" not in header or "status" not in header:
        return False
    return MESSAGE in study.columns if study.columns is not None else True


def convert_table(study: Study) -> bool:
    """Rename the message column of ``study``'s table of :data:`FROM` (the header only); whether it did."""
    text = git_show(study.table)
    if text is None:
        return False
    first, rest = text.split("\n", 1)
    header = first.split(",")
    if not renames_message(study, header):
        return False
    (DATA / study.table).write_text(",".join(MESSAGE if h == "error" else h for h in header) + "\n" + rest)
    return True


def convert_provenance(path: str, studies: list[Study], renamed: list[str]) -> None:
    """The provenance file ``path`` of :data:`FROM` in the one schema (module docstring)."""
    record = json.loads(git_show(path))
    changes = []
    if "made_by" in record:
        code = record.pop("code")
        record = {"code": [record.pop("made_by"), *(code if isinstance(code, list) else [code])], **record}
        changes.append("made_by joined code (the script that ran the study, then the modules it used)")
    if "package_dirty_at_run" in record:
        record = {("working_tree_modified" if k == "package_dirty_at_run" else k): v for k, v in record.items()}
        changes.append("package_dirty_at_run renamed working_tree_modified")
    current = sorted({s.row_code for s in studies})
    current = current[0] if len(current) == 1 else current
    if record.get("row_code") not in (None, current):
        record["row_code_at_run"] = record["row_code"]
        changes.append("row_code: the current row code (the one recorded at the run kept as row_code_at_run)")
    elif "row_code" not in record:
        changes.append("row_code: the current row code added")
    record["row_code"] = current
    dropped = [key for key in REPLACED.get(path, ()) if key in record]
    for key in dropped:
        del record[key]
    filters = {}
    for study in studies:
        filters.update(study.filter_records())
    if filters:
        record["filters"] = filters
        changes.append("filters: the filters the rows build, as settings records (pfcourse.filter_config)"
                       + (f", in place of {', '.join(dropped)}" if dropped else ""))
    if path == "robot_consistency_fixes.json":
        record["q_scale"] = STUDIES["robot_consistency_fixes"].fields["q_scale"]
    if renamed:
        changes.append(f"{', '.join(renamed)}: column error (run_study's failure messages) renamed error_message; "
                       "every value unchanged")
    entry = {"date_utc": DATE, "tool": TOOL, "from_commit": FROM, "change": "; ".join(changes)}
    record["conversions"] = [c for c in record.get("conversions", []) if c.get("tool") != TOOL] + [entry]
    (DATA / path).write_text(json.dumps(record, indent=2, default=str) + "\n")


def main(argv: list[str]) -> None:
    groups: dict[str, list[Study]] = {}
    renamed: dict[str, list[str]] = {}
    for study in STUDIES.values():
        if study.name.startswith(LATER) and study.name not in NOW:
            continue
        groups.setdefault(study.provenance, []).append(study)
        if convert_table(study):
            renamed.setdefault(study.provenance, []).append(Path(study.table).name)
    for path, studies in groups.items():
        if git_show(path) is not None:
            convert_provenance(path, studies, renamed.get(path, []))
    print(f"{sum(map(len, renamed.values()))} tables, {len(groups)} provenance records converted")


if __name__ == "__main__":
    main(sys.argv[1:])
