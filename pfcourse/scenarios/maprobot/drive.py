"""The map robot's drive: the book's map, scanner and odometry, the simulation of a drive (with an optional
kidnapping), the filter's model and the map robot's filters as settings records.

Every drive ``seed`` runs on the book's map (:func:`pfcourse.scenarios.maprobot.grid.rooms_and_corridor`) along
:data:`pfcourse.scenarios.maprobot.grid.ROUTE` from a waypoint drawn from the run's data stream
(:func:`pfcourse.seeding.data_rng`), at :data:`SPEED` with a scan every :data:`DT` seconds by :data:`SCANNER`;
the filter draws from :func:`pfcourse.seeding.filter_rng` (the same stream for every method: common random
numbers), the kidnapping from :func:`pfcourse.seeding.kidnap_rng`.  The filters resample at every step
(``threshold = 1``, systematic), as Monte Carlo localization does.  The studies that run these drives are in
:mod:`pfcourse.studies.maprobot`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import lru_cache
from types import SimpleNamespace

import numpy as np
from scipy import stats

from pfcourse.checks import check_probability
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.metrics import heading_error, position_error
from pfcourse.sample_size import KLDSampling
from pfcourse.scenarios.maprobot.amcl import CubesLikelihoodField
from pfcourse.scenarios.maprobot.grid import ROUTE, OccupancyGrid, rooms_and_corridor
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.scenarios.maprobot.model import MapRobotModel
from pfcourse.scenarios.maprobot.motion import Drive, OdometryModel, simulate_drive
from pfcourse.scenarios.maprobot.scanner import Scanner
from pfcourse.seeding import data_rng, filter_rng, kidnap_rng

DT = 0.5  # s between scans
SPEED = 0.5  # m/s, the forward speed of the drive
STEP_M = SPEED * DT  # m, the length of a straight step between two scans
MOTION = OdometryModel((0.05, 0.05, 0.05, 0.05))
SCANNER = Scanner(n_beams=24, max_range=8.0)
FIELD_SIGMA = 0.2  # m, the likelihood field's sigma (wider than the scanner's 0.05 m: the model is approximate)
INJECT = 0.1  # the kidnap model's probability of being carried anywhere per step
#: The number of particles the filters of :data:`FILTERS` are recorded with (a study sets its own).
NOMINAL_N = 1000
#: The length of the drive :func:`book_drive` loads (80 s).
BOOK_DRIVE_STEPS = 160
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
    drive = simulate_drive(ROUTE, n_steps, rng, motion=MOTION, dt=DT, speed=SPEED, start=start)
    if kidnap_at is not None:
        jump = int(kidnap_rng(seed).integers(len(ROUTE)))  # the waypoint it is carried to
        rest = simulate_drive(ROUTE, n_steps - kidnap_at, rng, motion=MOTION, dt=DT, speed=SPEED, start=jump)
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
        ("bootstrap", FilterSettings(NOMINAL_N, threshold=1.0)),
        ("injection", FilterSettings(NOMINAL_N, threshold=1.0, model_change=Injection(INJECT)))]),
    FilterConfig.of("kld", FilterSettings(AMCL_KLD["n_max"], sample_size=KLDSampling(
        AMCL_KLD["bin_size"], n_min=AMCL_KLD["n_min"], epsilon=AMCL_KLD["epsilon"], delta=AMCL_KLD["delta"]))),
)


def run_filter(run: MapRun, seed: int, n_particles: int, method: str = "bootstrap", *,
               start: np.ndarray | None = None, weighting: str = "product"):
    """The filter ``method`` of :data:`FILTERS` on ``run`` (beams combined by ``weighting``): the engine's result."""
    settings = lookup(FILTERS, method, "method").settings.with_(n_particles=n_particles)
    pf = settings.build(drive_model(run, start=start, weighting=weighting))
    return pf.run(run.scans, rng=filter_rng(seed, 0))


def book_drive(seed: int = 0, n_steps: int = BOOK_DRIVE_STEPS) -> SimpleNamespace:
    """The map robot's map and the drive ``seed`` as plain arrays, for code a reader can paste:
    ``distance`` (the distance transform of the grid, m, rows along y), ``resolution`` (m),
    ``occupied`` (bool), ``angles`` (beam angles, rad), ``max_range`` (m), ``alphas`` (a_1..a_4),
    ``scans`` ``(K, B)``, ``odometry`` ``(K, 3)`` (row k moves the robot from step k - 1 to k) and
    ``truth`` ``(K, 3)``."""
    grid, run = book_map(), simulate(seed, n_steps)
    return SimpleNamespace(distance=grid.distance.copy(), resolution=grid.resolution, occupied=grid.occupied.copy(),
                           angles=SCANNER.angles.copy(), max_range=SCANNER.max_range, alphas=MOTION.alphas,
                           scans=run.scans, odometry=run.drive.odometry, truth=run.truth)
