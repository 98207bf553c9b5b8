"""Studies of the map robot (chapter *A robot on a map*): tracking, AMCL's cubes, KLD-sampling, the sensor cost;
the drives (with an optional kidnapping) are also those of *Global localization on the map*.

Every run ``seed`` drives the book's map (:func:`pfcourse.scenarios.maprobot.grid.rooms_and_corridor`) along
:data:`pfcourse.scenarios.maprobot.grid.ROUTE` from a waypoint drawn from the run's data stream
(:func:`pfcourse.seeding.data_rng`), with the scanner :data:`SCANNER`; the filter draws from
:func:`pfcourse.seeding.filter_rng` (the same stream for every method: common random numbers), the
kidnapping from :func:`pfcourse.seeding.kidnap_rng`.  The filters resample at every step
(``threshold = 1``, systematic), as Monte Carlo localization does.
"""

from __future__ import annotations

from dataclasses import dataclass
import copy
from functools import lru_cache
from types import SimpleNamespace

import numpy as np

from pfcourse.checks import check_probability
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.sample_size import KLDSampling
from pfcourse.scenarios.maprobot.grid import ROUTE, OccupancyGrid, rooms_and_corridor
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.scenarios.maprobot.model import MapRobotModel
from pfcourse.scenarios.maprobot.motion import Drive, OdometryModel, simulate_drive
from pfcourse.scenarios.maprobot.scanner import Scanner
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.amcl import CubesLikelihoodField
from pfcourse.metrics import heading_error, locked_on, position_error
from scipy import stats
from pfcourse.seeding import data_rng, filter_rng, kidnap_rng
from pfcourse import metrics

DT = 0.5  # s between scans
MOTION = OdometryModel((0.05, 0.05, 0.05, 0.05))
SCANNER = Scanner(n_beams=24, max_range=8.0)
FIELD_SIGMA = 0.2  # m, the likelihood field's sigma (wider than the scanner's 0.05 m: the model is approximate)
INJECT = 0.1  # the kidnap model's probability of being carried anywhere per step
GLOBAL_STEPS, GLOBAL_N = 200, 1000
KIDNAP_STEPS, KIDNAP_STEP, KIDNAP_N = 240, 40, 1000
TRACKING_STEPS, TRACKING_N = 160, 300
#: KLD-sampling with ROS 1 amcl's defaults (navigation 1.17.3, amcl/cfg/AMCL.cfg): at most 5000 and at
#: least 100 particles, kld_err = 0.01, kld_z = 0.99; kld_z is the standard normal quantile z_{1-delta}
#: (pf.c's pf_resample_limit), so delta = 1 - Phi(0.99) = 0.161; bins of 0.5 m x 0.5 m x 10 degrees.
AMCL_KLD = {"n_max": 5000, "n_min": 100, "epsilon": 0.01, "delta": float(stats.norm.sf(0.99)),
            "bin_size": (0.5, 0.5, float(np.deg2rad(10.0)))}
#: How a scan's beams are combined into a weight: the product of the likelihood field (the book's),
#: or AMCL's 1 + sum of cubes (pfcourse.scenarios.maprobot.amcl).
WEIGHTINGS = ("product", "cubes")


@lru_cache(maxsize=1)
def book_map() -> OccupancyGrid:
    """The book's map at 0.1 m cells (built once per process)."""
    return rooms_and_corridor(0.1)


def field(grid: OccupancyGrid | None = None, weighting: str = "product") -> LikelihoodField:
    """The filter's likelihood field for :data:`SCANNER` on ``grid`` (the book's map by default); with
    ``weighting="cubes"``, AMCL's sum of cubes of the same beam probabilities."""
    kind = {"product": LikelihoodField, "cubes": CubesLikelihoodField}[weighting]
    return kind(grid or book_map(), SCANNER.angles, SCANNER.max_range, sigma=FIELD_SIGMA)


@dataclass(frozen=True)
class MapRun:
    """One simulated drive and its scans ``(K, B)``."""

    drive: Drive
    scans: np.ndarray

    @property
    def truth(self) -> np.ndarray:
        return self.drive.truth


def simulate(seed: int, n_steps: int, kidnap_at: int | None = None) -> MapRun:
    """Run ``seed``'s drive and scans; with ``kidnap_at``, the robot is carried at that step to a waypoint
    of the route drawn by :func:`~pfcourse.seeding.kidnap_rng` and drives on from there, its odometry
    unaware of the jump (it reads no motion at that step)."""
    grid, rng = book_map(), data_rng(seed, 0)
    start = int(rng.integers(len(ROUTE)))
    drive = simulate_drive(ROUTE, n_steps, rng, motion=MOTION, dt=DT, start=start)
    if kidnap_at is not None:
        jump = int(kidnap_rng(seed).integers(len(ROUTE)))  # the waypoint it is carried to
        rest = simulate_drive(ROUTE, n_steps - kidnap_at, rng, motion=MOTION, dt=DT, start=jump)
        drive = Drive(truth=np.vstack([drive.truth[:kidnap_at], rest.truth]),
                      odometry=np.vstack([drive.odometry[:kidnap_at], rest.odometry]), dt=DT)
    scans = np.array([SCANNER.sample(SCANNER.true_ranges(grid, x), rng) for x in drive.truth])
    return MapRun(drive=drive, scans=scans)


def errors(truth: np.ndarray, mean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and heading (rad) errors of an estimate, per step."""
    return position_error(truth, mean), heading_error(truth, mean)


def drive_model(run: MapRun, *, start: np.ndarray | None = None, weighting: str = "product") -> MapRobotModel:
    """The model of ``run``'s drive: its odometry, from ``start`` (tracking) or uniform in free space (``None``),
    beams combined by ``weighting``."""
    return MapRobotModel(book_map(), field(weighting=weighting), run.drive.odometry, motion=MOTION, start=start)


@dataclass(frozen=True)
class Injection:
    """The filter's model change of random injection: the robot carried anywhere in free space with
    probability ``inject`` per step (the kidnap model's transition, :class:`MapRobotModel`'s ``inject``)."""

    inject: float

    @property
    def label(self) -> str:
        return f"injection, ε = {self.inject:g}"

    def apply(self, model: MapRobotModel) -> MapRobotModel:
        changed = copy.copy(model)
        changed.inject = check_probability(self.inject, "inject")
        return changed


#: The map robot's filters as settings records: ``build(drive_model(run, ...))``.  Monte Carlo localization
#: resampling at every step (``N``: the study's, 1000 nominal: ``config.settings.with_(n_particles=N)``), and
#: KLD-sampling with :data:`AMCL_KLD` (``N`` at most ``n_max``).
FILTERS: dict[str, FilterConfig] = configurations(
    *(FilterConfig.of(name, settings, n_from_grid=True) for name, settings in [
        ("bootstrap", FilterSettings(GLOBAL_N, threshold=1.0)),
        ("injection", FilterSettings(GLOBAL_N, threshold=1.0, model_change=Injection(INJECT)))]),
    FilterConfig.of("kld", FilterSettings(AMCL_KLD["n_max"], sample_size=KLDSampling(
        AMCL_KLD["bin_size"], n_min=AMCL_KLD["n_min"], epsilon=AMCL_KLD["epsilon"], delta=AMCL_KLD["delta"]))),
)


def run_filter(run: MapRun, seed: int, n_particles: int, method: str = "bootstrap", *,
               start: np.ndarray | None = None, weighting: str = "product"):
    """The filter ``method`` of :data:`FILTERS` on ``run`` (beams combined by ``weighting``): the engine's result."""
    settings = lookup(FILTERS, method, "method").settings.with_(n_particles=n_particles)
    pf = settings.build(drive_model(run, start=start, weighting=weighting))
    return pf.run(run.scans, rng=filter_rng(seed, 0))


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


def book_drive(seed: int = 0, n_steps: int = TRACKING_STEPS) -> SimpleNamespace:
    """The map robot's map and the drive ``seed`` as plain arrays, for code a reader can paste:
    ``distance`` (the distance transform of the grid, m, rows along y), ``resolution`` (m),
    ``occupied`` (bool), ``angles`` (beam angles, rad), ``max_range`` (m), ``alphas`` (a_1..a_4),
    ``scans`` ``(K, B)``, ``odometry`` ``(K, 3)`` (row k moves the robot from step k - 1 to k) and
    ``truth`` ``(K, 3)``."""
    grid, run = book_map(), simulate(seed, n_steps)
    return SimpleNamespace(distance=grid.distance.copy(), resolution=grid.resolution, occupied=grid.occupied.copy(),
                           angles=SCANNER.angles.copy(), max_range=SCANNER.max_range, alphas=MOTION.alphas,
                           scans=run.scans, odometry=run.drive.odometry, truth=run.truth)


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
