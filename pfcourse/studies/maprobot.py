"""Studies of the map robot (chapter *A robot on a map*): tracking, AMCL's cubes, KLD-sampling, the sensor cost.

The scenario (the map, the scanner, the odometry, the simulated drives with an optional kidnapping, the filter's
model and the map robot's filters) is :mod:`pfcourse.scenarios.maprobot.drive`; this module holds the rows of
the stored studies and their run lengths.  It also imports the scenario's names it uses (``DT``, ``MOTION``,
``simulate``, ``book_map``, ``field``, ...), which :mod:`pfcourse.studies.map_global` reads from here.
"""

from __future__ import annotations

import numpy as np

from pfcourse import metrics
from pfcourse.metrics import locked_on
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.drive import (  # noqa: F401  (DT ... WEIGHTINGS: read by studies.map_global)
    AMCL_KLD,
    DT,
    FIELD_SIGMA,
    FILTERS,
    INJECT,
    MOTION,
    NOMINAL_N,
    SCANNER,
    WEIGHTINGS,
    Injection,
    MapRun,
    book_drive,
    book_map,
    drive_model,
    errors,
    field,
    run_filter,
    simulate,
)
from pfcourse.seeding import filter_rng

GLOBAL_STEPS, GLOBAL_N = 200, NOMINAL_N
KIDNAP_STEPS, KIDNAP_STEP, KIDNAP_N = 240, 40, NOMINAL_N
TRACKING_STEPS, TRACKING_N = 160, 300


def ess_scores(ess: np.ndarray, n_particles: int) -> dict:
    """The ESS after weighting, as a share of ``N``: its mean over the steps after the first and its 10th percentile."""
    share = np.asarray(ess[1:], dtype=float) / n_particles
    return {"mean_ess_share": float(share.mean()), "p10_ess_share": float(np.quantile(share, 0.1))}


def tracking_row(seed: int, n_particles: int = TRACKING_N, weighting: str = "product") -> dict:
    """Tracking from the known start (bootstrap), beams combined by ``weighting``: position RMSE (m),
    heading RMSE (rad), locked on (:func:`pfcourse.scenarios.maprobot.lock_on.locked_on`), the largest heading error
    (rad) over the steps the rule looks at (the last ``lock_on.WINDOW_S``), the ESS (share of N)."""
    run = simulate(seed, TRACKING_STEPS)
    res = run_filter(run, seed, n_particles, start=run.truth[0], weighting=weighting)
    pos, head = errors(run.truth, res.mean)
    return {"position_rmse": float(metrics.rmse(pos)), "heading_rmse": float(metrics.rmse(head)),
            "locked_on": bool(lock_on.locked_on(pos, head, DT)),
            "locked_on_every_step_5deg": bool(locked_on(pos, head, DT)),
            "max_window_heading_error": float(np.max(head[-int(np.ceil(lock_on.WINDOW_S / DT - 1e-9)):])),
            **ess_scores(res.ess, n_particles)}


def amcl_global_row(seed: int, weighting: str, method: str = "injection", n_particles: int = GLOBAL_N) -> dict:
    """Global localization (uniform start) by ``method`` with beams combined by ``weighting``: locked on
    (:func:`pfcourse.scenarios.maprobot.lock_on.locked_on`), the final position error (m), the ESS (share of N)."""
    run = simulate(seed, GLOBAL_STEPS)
    res = run_filter(run, seed, n_particles, method, weighting=weighting)
    pos, head = errors(run.truth, res.mean)
    return {"locked_on": bool(lock_on.locked_on(pos, head, DT)), "final_position_error": float(pos[-1]),
            **ess_scores(res.ess, n_particles)}


def kld_tracking_row(seed: int) -> dict:
    """Tracking from the known start (as :func:`tracking_row`, same drive) by KLD-sampling with
    :data:`AMCL_KLD`: position RMSE (m), locked on, and the number of particles after step 0."""
    run = simulate(seed, TRACKING_STEPS)
    pf = FILTERS["kld"].build(drive_model(run, start=run.truth[0]))
    res = pf.run(run.scans, rng=filter_rng(seed, 0))
    pos, head = errors(run.truth, res.mean)
    return {"position_rmse": float(metrics.rmse(pos)), "locked_on": bool(lock_on.locked_on(pos, head, DT)),
            "mean_particles": float(np.mean(res.sizes[1:])), "max_particles_after_start": int(np.max(res.sizes[1:]))}


def sensor_cost_row(seed: int, n_particles: int = TRACKING_N, repeats: int = 3) -> dict:
    """The cost of weighting one cloud by one scan: the likelihood field against the beam model, on the
    scan at step 68 of drive ``seed``, ``n_particles`` poses around the truth (sd 0.2 m, 0.2 m, 0.05 rad).
    Deterministic: the look-ups of the field and the grid cells the beam model's ray casting visits; the
    wall times (s, best of ``repeats``) are indicative only."""
    import time

    from pfcourse.scenarios.maprobot.amcl import beam_log_likelihood

    run = simulate(seed, 69)
    grid, f, z = book_map(), field(), run.scans[68]
    rng = np.random.default_rng(seed)
    poses = run.truth[68] + rng.standard_normal((n_particles, 3)) * (0.2, 0.2, 0.05)
    poses = poses[grid.is_free(poses)]
    times = {"field": [], "beam": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        f.log_likelihood(poses, z)
        times["field"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        beam_log_likelihood(grid, SCANNER, poses, z)
        times["beam"].append(time.perf_counter() - t0)
    steps = len(np.arange(grid.resolution / 4, SCANNER.max_range + grid.resolution / 4, grid.resolution / 4))
    return {"n_poses": len(poses), "field_lookups": int(len(poses) * np.sum(z < SCANNER.max_range)),
            "beam_cells": int(len(poses) * SCANNER.n_beams * steps),
            "field_seconds": min(times["field"]), "beam_seconds": min(times["beam"])}
