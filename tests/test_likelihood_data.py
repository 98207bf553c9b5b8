"""The stored studies of Part V (book/data/likelihood/) are what their scripts compute.

A seeded random sample of each table's rows is re-computed with the script's own run
function and must give the same numbers (the runs are seeded; the arithmetic is pinned).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "book" / "data" / "likelihood"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"study_{name}", ROOT / "tools" / "studies" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def sample(table: pd.DataFrame, k: int, salt: int) -> pd.DataFrame:
    rng = np.random.default_rng([2026, salt])
    return table.iloc[np.sort(rng.choice(len(table), size=k, replace=False))]


@pytest.fixture(scope="module")
def likelihood_study():
    return load("likelihood")


@pytest.fixture(scope="module")
def smoothing_study():
    return load("smoothing")


@pytest.mark.parametrize("name", ["bias", "ml", "pmmh", "pmmh2", "grid2", "smoothing_landmarks", "smoothing_robot",
                                  "robot_noise", "terrain_rf"])
def test_every_table_has_its_provenance(name):
    meta = json.loads((DATA / f"{name}.json").read_text())
    assert meta["file"] == f"{name}.csv"
    assert (ROOT / meta["code"]).exists()
    assert len(meta["git_commit"]) == 40
    table = pd.read_csv(DATA / f"{name}.csv")
    if "status" in table:
        assert (table["status"] == "ok").all()


def test_bias_rows(likelihood_study):
    table = pd.read_csv(DATA / "bias.csv")
    for _, row in sample(table, 3, 1).iterrows():
        got = likelihood_study.bias_run(int(row["seed"]), int(row["n_particles"]))
        assert got["log_ratio"] == pytest.approx(row["log_ratio"], rel=1e-12, abs=1e-12)


def test_ml_rows(likelihood_study):
    table = pd.read_csv(DATA / "ml.csv")
    for _, row in sample(table, 2, 2).iterrows():
        got = likelihood_study.ml_run(int(row["seed"]), int(row["n_particles"]))
        for key in ("theta_kalman", "theta_pf"):
            assert got[key] == pytest.approx(row[key], rel=1e-12)
        assert got["nfev_pf"] == row["nfev_pf"]


def test_pmmh_chain_prefix(likelihood_study):
    table = pd.read_csv(DATA / "pmmh.csv")
    n = int(sample(table.drop_duplicates("n_particles"), 1, 3)["n_particles"].iloc[0])
    stored = table[table["n_particles"] == n].sort_values("iteration").head(12)
    chain, _ = likelihood_study.pmmh_chain(n, n_iterations=12)
    np.testing.assert_allclose(chain.theta, stored["theta"], rtol=1e-12)
    np.testing.assert_allclose(chain.log_likelihood, stored["log_likelihood"], rtol=1e-12)
    np.testing.assert_array_equal(chain.accepted, stored["accepted"].to_numpy())


def test_pmmh2_chain_prefix(likelihood_study):
    table = pd.read_csv(DATA / "pmmh2.csv")
    n = int(sample(table.drop_duplicates("n_particles"), 1, 7)["n_particles"].iloc[0])
    stored = table[table["n_particles"] == n].sort_values("iteration").head(12)
    chain, _ = likelihood_study.pmmh2_chain(n, n_iterations=12)
    np.testing.assert_allclose(chain.theta, stored[["theta_q", "theta_r"]], rtol=1e-12)
    np.testing.assert_allclose(chain.log_likelihood, stored["log_likelihood"], rtol=1e-12)
    np.testing.assert_array_equal(chain.accepted, stored["accepted"].to_numpy())


def test_grid2_rows(likelihood_study):
    table = pd.read_csv(DATA / "grid2.csv")
    i = int(sample(table.drop_duplicates("i"), 1, 8)["i"].iloc[0])
    got = pd.DataFrame(likelihood_study.grid2_row(i))
    stored = table[table["i"] == i].sort_values("j")
    np.testing.assert_allclose(got["log_likelihood"], stored["log_likelihood"], rtol=1e-12)


def test_terrain_rf_rows(likelihood_study):
    table = pd.read_csv(DATA / "terrain_rf.csv")
    for _, row in sample(table, 1, 9).iterrows():
        got = likelihood_study.terrain_rf_run(int(row["seed"]), int(row["flight"]), int(row["n_particles"]))
        for key, value in got.items():
            assert value == pytest.approx(row[key], rel=1e-10), key


def test_smoothing_landmark_rows(smoothing_study):
    table = pd.read_csv(DATA / "smoothing_landmarks.csv")
    table = table[table["n_particles"] == min(table["n_particles"])]
    for _, row in sample(table, 1, 4).iterrows():
        got = smoothing_study.landmarks_run(int(row["seed"]), int(row["n_particles"]))
        for key, value in got.items():
            assert value == pytest.approx(row[key], rel=1e-10), key


def test_smoothing_robot_rows(smoothing_study):
    table = pd.read_csv(DATA / "smoothing_robot.csv")
    for _, row in sample(table, 1, 5).iterrows():
        got = smoothing_study.robot_run(int(row["seed"]), int(row["n_particles"]))
        for key, value in got.items():
            assert value == pytest.approx(row[key], rel=1e-10), key


def test_robot_noise_rows():
    study = load("robot_noise")
    table = pd.read_csv(DATA / "robot_noise.csv")
    for _, row in sample(table, 1, 6).iterrows():
        got = study.robot_noise_run(int(row["seed"]), int(row["n_particles"]))
        for key, value in got.items():
            assert value == pytest.approx(row[key], rel=1e-10), key
