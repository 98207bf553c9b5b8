"""Part V's static-parameter studies: Liu-West, the sufficient-statistic filter and SMC^2 against the exact posterior.

The parameter is the scale ``theta`` of the landmark model's measurement noise, ``R = theta R_0``
with ``R_0 = 0.5^2 I`` m^2, process noise ``0.05^2`` m^2 on every coordinate (the model of
Part V's likelihood chapter), prior ``theta ~ IG(3, 2)`` (mean 1, sd 1). One dataset, simulated
with ``theta = 1`` (seed 7), and many seeded runs of each sampler on it: the error of a run is
``(posterior mean - exact mean) / exact sd`` at the last step, the exact posterior from the
Kalman likelihood on a grid of ``log theta``.

- :func:`main_row`: the three samplers on the chapter's ``K = 50`` steps;
- :func:`long_row`: Liu-West and the sufficient-statistic filter on the first ``T`` steps of a
  longer simulation (seed 7, ``LONG_K`` steps), where path degeneracy of the statistics shows
  (``LONG_N`` particles; the study ``long_big`` repeats Liu-West at ``T = 400`` with 5000).

Run ``r`` has seed ``r``: every sampler draws from ``numpy.random.default_rng(r)`` (common
random numbers across the samplers of one run).
"""

from __future__ import annotations

import time
from functools import lru_cache

import numpy as np

from pfcourse.errors import ParameterError
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate
from pfcourse.static_parameters import (InverseGamma, NoiseScaleProblem, liu_west, smc2,
                                        sufficient_statistic_filter)

DATA_SEED = 7
PRIOR = InverseGamma(3.0, 2.0)
N_RUNS = 100
#: (method, N): N particles for Liu-West and the sufficient statistics, N_theta for SMC^2
MAIN_GRIDS = ({"method": ["liu_west", "storvik"], "n": [1000, 5000]},)
#: SMC^2 is the expensive one: fewer runs (its study is a table of its own)
SMC2_GRID = {"method": ["smc2"], "n": [100]}
SMC2_RUNS = 50
SMC2_NX = 100
LONG_K = 400
LONG_GRIDS = ({"method": ["storvik"], "T": [50, 400]}, {"method": ["liu_west"], "T": [400]})
LONG_T = [50, 400]
LONG_N = 1000
#: Liu-West on the long data with five times the particles (static_parameters/long_big): does N shrink its error?
LONG_BIG_GRID = {"method": ["liu_west"], "T": [400], "n": [5000]}
LONG_BIG_COLUMNS = ("method", "T", "n", "run", "seed", "status", "mean", "sd", "exact_mean", "exact_sd", "error",
                    "sd_ratio", "evaluations", "ancestors", "seconds")
U_GRID_MAIN = np.linspace(np.log(0.3), np.log(2.5), 61)
U_GRID_LONG = np.linspace(np.log(0.4), np.log(2.2), 121)
MAIN_COLUMNS = ("method", "n", "run", "seed", "status", "mean", "sd", "exact_mean", "exact_sd", "error", "sd_ratio",
                "evaluations", "moves", "acceptance", "ancestors", "seconds")
LONG_COLUMNS = ("method", "T", "run", "seed", "status", "mean", "sd", "exact_mean", "exact_sd", "error", "sd_ratio",
                "evaluations", "ancestors", "seconds")
PROVENANCE = {
    "model": "quadrant landmark model, Qw = 0.05^2 I_6 m^2, R = theta 0.5^2 I_4 m^2; data simulated with theta = 1, seed 7",
    "prior": "theta ~ inverse-gamma(3, 2)",
    "exact": "Kalman log-likelihood on a grid of log theta in [log 0.3, log 2.5] (61 points; 121 in [log 0.4, log 2.2] for the long runs), "
             "trapezoid rule",
    "seeds": "run r: numpy.random.default_rng(r) for every sampler (common random numbers)",
    "smc2": f"N_theta = n, N_x = {SMC2_NX}, ESS threshold 0.5, one PMMH move per resampling, random walk on log theta "
            "with the particles' sd",
    "liu_west": "delta = 0.98, kernel on log theta after resampling at every measured step, no auxiliary step",
}


def scenario():
    return quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))


def problem() -> NoiseScaleProblem:
    return NoiseScaleProblem(scenario().model(), PRIOR)


def data() -> np.ndarray:
    """The chapter's dataset: 50 steps, theta = 1, seed 7."""
    return simulate(scenario(), DATA_SEED).measurements


def long_data(T: int) -> np.ndarray:
    """The first ``T`` steps of a ``LONG_K``-step simulation (theta = 1, seed 7)."""
    if not 2 <= T <= LONG_K:
        raise ParameterError(f"T must be in [2, {LONG_K}], got {T!r}")
    return simulate(scenario().with_(n_samples=LONG_K), DATA_SEED).measurements[:T]


@lru_cache(maxsize=None)
def exact(T: int | None = None):
    """The exact posterior (GridPosterior) on the chapter's data (``T=None``) or the long data's first ``T`` steps."""
    if T is None:
        return problem().exact_posterior(data(), U_GRID_MAIN)
    return problem().exact_posterior(long_data(T), U_GRID_LONG)


def run_sampler(method: str, n: int, Z: np.ndarray, rng: np.random.Generator):
    p = problem()
    if method == "liu_west":
        return liu_west(p, Z, n, rng)
    if method == "storvik":
        return sufficient_statistic_filter(p, Z, n, rng)
    if method == "smc2":
        return smc2(p, Z, n, SMC2_NX, rng)
    raise ParameterError(f"method must be liu_west, storvik or smc2, got {method!r}")


def _scores(result, reference, seconds) -> dict:
    return {"mean": result.mean, "sd": result.sd, "exact_mean": reference.mean, "exact_sd": reference.sd,
            "error": (result.mean - reference.mean) / reference.sd, "sd_ratio": result.sd / reference.sd,
            "evaluations": int(result.evaluations),
            "ancestors": float(result.extra.get("ancestors_of_first_step", np.nan)), "seconds": seconds}


def main_row(seed: int, method: str, n: int) -> dict:
    """One run of ``method`` on the chapter's data, scored against the exact posterior."""
    start = time.perf_counter()
    result = run_sampler(method, n, data(), np.random.default_rng(seed))
    seconds = time.perf_counter() - start
    scores = _scores(result, exact(), seconds)
    acceptance = result.extra.get("acceptance", [])
    scores["moves"] = len(result.extra.get("moves", []))
    scores["acceptance"] = float(np.mean(acceptance)) if acceptance else np.nan
    return scores


def long_row(seed: int, method: str, T: int, n: int = LONG_N) -> dict:
    """One run of ``method`` (``n`` particles, by default ``LONG_N``) on the first ``T`` steps of the long data."""
    start = time.perf_counter()
    result = run_sampler(method, n, long_data(T), np.random.default_rng(seed))
    seconds = time.perf_counter() - start
    return _scores(result, exact(T), seconds)
