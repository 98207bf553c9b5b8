"""Issue 40's readings of Parts III and V: Holm's family-wise control, the likelihood studies' provenance."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pfcourse import evidence
from pfcourse.evidence import EvidenceError, Paired, holm, holm_verdicts
from pfcourse.studies import likelihood_studies as ls
from pfcourse.studies.registry import STUDIES

ROOT = Path(__file__).resolve().parents[1]


def test_holm_adjusts_a_textbook_family():
    # sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1 = 0.02, 0.03, 0.06, 0.04, then the running maximum
    assert np.allclose(holm([0.01, 0.04, 0.03, 0.005]), [0.03, 0.06, 0.06, 0.02], rtol=0, atol=1e-15)
    assert np.allclose(holm([0.5, 0.9]), [1.0, 1.0])  # capped at 1
    assert holm([0.2])[0] == 0.2  # a family of one is not adjusted


def test_holm_keeps_the_family_wise_error_rate_under_alpha_where_raw_tests_do_not():
    rng = np.random.default_rng(40)
    families, m, alpha = 20_000, 6, 0.05
    p = rng.uniform(size=(families, m))  # every null true
    holm_any = np.mean([np.any(holm(row) < alpha) for row in p])
    raw_any = np.mean(np.any(p < alpha, axis=1))
    sd = np.sqrt(alpha * (1 - alpha) / families)
    assert holm_any < alpha + 4 * sd  # exact for independent tests: 1 - (1 - alpha/m)^m = 0.0489
    assert abs(raw_any - (1 - (1 - alpha) ** m)) < 4 * np.sqrt(0.27 * 0.73 / families)  # 0.265 without control


def test_holm_never_lowers_a_p_value_and_keeps_their_order():
    p = np.random.default_rng(1).uniform(size=9) ** 3
    adjusted = holm(p)
    assert np.all(adjusted >= p)
    order = np.argsort(p)
    assert np.all(np.diff(adjusted[order]) >= 0)


@pytest.mark.parametrize("bad", [[], [0.1, np.nan], [-0.1, 0.5], [0.5, 1.5], [[0.1, 0.2]]])
def test_holm_refuses_what_is_not_a_family_of_p_values(bad):
    with pytest.raises(EvidenceError):
        holm(bad)


def test_holm_verdicts_withdraw_a_difference_that_only_the_raw_p_allowed():
    family = {level: Paired(100, 1.2, 1.05, 1.4, 0.03, ratio=True) for level in range(5)}
    family["clear"] = Paired(100, 2.0, 1.8, 2.2, 1e-6, ratio=True)
    assert all(c.verdict() == "A higher" for c in family.values())  # each alone: "different"
    verdicts = holm_verdicts(family)
    assert verdicts["clear"][0] == "A higher" and verdicts["clear"][1] == pytest.approx(6e-6)
    assert all(verdicts[level][0] == "no difference detected" for level in range(5))
    assert all(verdicts[level][1] == pytest.approx(0.15) for level in range(5))
    with pytest.raises(EvidenceError):
        holm_verdicts({"a": 0.03})


def test_holm_verdicts_on_real_paired_runs_keep_a_strong_effect():
    rng = np.random.default_rng(7)
    base = rng.lognormal(size=100)
    family = {f: evidence.paired(base * np.exp(rng.normal(np.log(f), 0.1, 100)), base, ratio=True)
              for f in (1.0, 1.01, 1.5)}
    verdicts = holm_verdicts(family)
    assert verdicts[1.5][0] == "A higher" and verdicts[1.0][0] == "no difference detected"


def test_each_likelihood_study_records_its_own_scenario():
    for name in ("bias", "ml", "smoothing_robot", "terrain_rf"):
        study = STUDIES[f"likelihood/{name}"]
        assert study.fields == ls.PROVENANCE_FIELDS[name]
    terrain = STUDIES["likelihood/terrain_rf"].fields
    assert "quadrant" not in json.dumps(terrain) and "AircraftScenario" in terrain["scenario"]
    assert "RobotScenario" in STUDIES["likelihood/smoothing_robot"].fields["scenario"]


def test_the_stored_altimeter_study_names_its_scenario_and_existing_code():
    record = json.loads((ROOT / "book/data/likelihood/terrain_rf.json").read_text())
    assert record["scenario"] == ls.PROVENANCE_FIELDS["terrain_rf"]["scenario"]
    assert "quadrant" not in json.dumps(record)
    # one schema (issue 44): row_code is a string naming one or more files, each "path (function)"
    entries = re.split(r",\s*(?=[\w/]+\.py)", record["row_code"])
    assert entries and isinstance(record["row_code"], str)
    for entry in entries:
        assert (ROOT / entry.split(" (")[0]).is_file(), entry
