"""The Intel Research Lab log (book/data/intel): the map from one part of the run, localization on the other.

:func:`split` reads the log, builds the log-odds map from the corrected poses of the *map part*
(the second half of the run, scans ``MAP_PART``) and returns the *held-out part* (the first
half, ``HELD_OUT``) in the map's frame: its scans, its corrected poses (the reference), its
odometry.  The second half builds the map because it passes closer to where the first half
goes than the other way round (the chapter measures it), so fewer of the held-out scans see
walls the map lacks.

:func:`global_row` is global localization from a uniform start at a seeded held-out scan, by the
cure of chapter 15 (:func:`pfcourse.scenarios.maprobot.global_mcl.global_mcl`) with the settings of one
record, :data:`GLOBAL_SETTINGS`; it is locked on by :func:`locked_on_share` (position within 1 m and
heading within :func:`heading_tolerance` for at least ``LOCK_SHARE`` of the last ``LOCK_WINDOW``
scans); the tracking runs (:func:`tracking_row`) are judged by the same rule.  Its variants measure why
the log is harder than the simulated map: the same filter on a map of the whole run (no wall missing),
on the map control (:func:`leave_out_split`: every scan but the run's own, so the map is not the scans
being localized), and with the odometry's heading drift taken out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache
import time

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ParameterError
from pfcourse.filter_config import FilterSettings
from pfcourse.scenarios.maprobot.carmen import CarmenLog, read_carmen, relative_pose
from pfcourse.scenarios.maprobot.grid import OccupancyGrid
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.metrics import locked_on
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.global_mcl import CURE, HAZARD, ISLANDS, SETTINGS, GlobalSettings, global_mcl
from pfcourse.scenarios.maprobot.mapping import L_FREE, L_OCC, LogOddsMap, build_map, scan_cells
from pfcourse.scenarios.maprobot.motion import OdometryModel
from pfcourse.metrics import heading_error, position_error
from pfcourse import metrics

#: The map part and the held-out part of the run (scan indices): the second half maps, the first is localized.
N_SCANS = 910
MAP_PART = slice(N_SCANS // 2, N_SCANS)
HELD_OUT = slice(0, N_SCANS // 2)
#: Ranges used (m): every real echo of the Intel scanner is shorter (its longest is 25.38 m).
Z_MAX = 25.5
#: The likelihood field (every ``BEAM_STEP``-th beam) and the odometry model of the filters.
BEAM_STEP = 4
SIGMA = 0.2
Z_HIT, Z_RAND = 0.9, 0.1
MOTION = OdometryModel((0.01, 0.005, 0.01, 0.005))
#: Lock-on: the last ``LOCK_WINDOW`` scans, at least ``LOCK_SHARE`` of them within 1 m and the tolerance.
LOCK_WINDOW = 15
LOCK_SHARE = 0.8
LOCK_POSITION_M = 1.0


@dataclass(frozen=True, eq=False)
class Split:
    """The map (from ``MAP_PART``) and the held-out scans in its frame."""

    log: CarmenLog
    map: LogOddsMap
    grid: OccupancyGrid
    free: OccupancyGrid
    poses: Array  # held-out corrected poses, map frame
    ranges: Array  # held-out scans
    odometry: Array  # held-out increments, row 0 zero

    def field(self, beam_step: int = BEAM_STEP, z_hit: float = Z_HIT, z_rand: float = Z_RAND) -> LikelihoodField:
        """The likelihood field on every ``beam_step``-th beam."""
        return LikelihoodField(self.grid, self.log.angles[::beam_step], max_range=Z_MAX, z_hit=z_hit,
                               z_rand=z_rand, sigma=SIGMA)


@lru_cache(maxsize=1)
def split() -> Split:
    log = read_carmen()
    m = build_map(log.poses[MAP_PART], log.ranges[MAP_PART], log.angles, max_range=Z_MAX)
    odometry = log.odometry()[HELD_OUT].copy()
    odometry[0] = 0.0
    return Split(log=log, map=m, grid=m.grid(), free=m.free_grid(), poses=m.to_map(log.poses[HELD_OUT]),
                 ranges=log.ranges[HELD_OUT], odometry=odometry)


def odometry_heading_rms(log: CarmenLog) -> float:
    """RMS (rad) of the heading the odometry reports for one step between scans, minus the corrected one."""
    true = relative_pose(log.poses[:-1], log.poses[1:])[:, 2]
    return float(metrics.rmse(wrap_angle(log.relative_motion()[1:, 2] - true)))


def heading_tolerance(log: CarmenLog) -> float:
    """The lock-on heading tolerance (rad): three times the odometry's RMS heading error of one step,
    the error a filter that is locked on may carry between two scans."""
    return 3.0 * odometry_heading_rms(log)


def locked_on_share(pos_err: Array, head_err: Array, tolerance: float) -> bool:
    """Locked on: within ``LOCK_POSITION_M`` and ``tolerance`` at ``LOCK_SHARE`` or more of the last
    ``LOCK_WINDOW`` steps."""
    return locked_on(pos_err, head_err, 1.0, LOCK_WINDOW, share=LOCK_SHARE, position_tolerance=LOCK_POSITION_M,
                     heading_tolerance=tolerance)


#: The global runs of ``intel/global`` and ``intel/map_control``: one record, chapter 15's cure before its guards
#: (:data:`pfcourse.scenarios.maprobot.global_mcl.HAZARD`: many particles at the start, some drawn from
#: the scan, KLD-sampling with AMCL's delta, poses drawn from the scan injected as a kidnapping with a
#: history, at the kidnap model's prior mass); the chapter's cure is :data:`GUARDED_SETTINGS`.  The stored
#: study's provenance records every field of it, and a test fails while the stored table was made with other settings.
GLOBAL_SETTINGS: GlobalSettings = HAZARD
#: The cure the first stored runs used (``intel/global_previous``): augmented MCL's ratio as the injected mass.
PREVIOUS_SETTINGS: GlobalSettings = SETTINGS
#: Chapter 15's guarded cure (hysteresis ``confirm`` and the mixture's evidence, :data:`global_mcl.CURE`),
#: measured on the same runs in ``intel/injection`` (method ``guarded``).
GUARDED_SETTINGS: GlobalSettings = CURE
#: Chapter 15's cure with islands (:data:`global_mcl.ISLANDS`: the guarded cure and four independent 200-pose
#: filters from the uniform start, adopted on evidence), measured in ``intel/islands`` (method ``islands``).
ISLANDS_SETTINGS: GlobalSettings = ISLANDS
#: Scans per run, and runs per filter.
GLOBAL_STEPS = 40
N_GLOBAL = 100


#: The longer runs of ``intel/long_runs``: with 40 scans the lock-on window (the last 15) can see only the
#: cure's first admitted injection (scans 20, 24, 28 with ``confirm = 3``), so injection is also judged on 80.
LONG_STEPS = 80
#: The methods of ``intel/long_runs``: the guarded cure, the cure without injection, the cure before its guards.
LONG_METHODS = ("guarded", "no_injection", "scan")


def global_start(seed: int, steps: int = GLOBAL_STEPS) -> int:
    """The held-out scan a global run starts at: uniform among those that leave ``steps`` scans."""
    return int(np.random.default_rng([41, seed]).integers(0, N_SCANS // 2 - steps))


def uniform_only(settings: GlobalSettings) -> GlobalSettings:
    """``settings`` without the scan: as many particles at the start, all uniform, and no injection."""
    return replace(settings, n_start=settings.n_start + settings.n_start_scan, n_start_scan=0, inject_share=0.0)


def drift_rate(log: CarmenLog, part: slice = MAP_PART) -> float:
    """The odometry's heading drift (rad per metre of odometry travel) over the steps of ``part``: the
    summed heading error of a step (odometry minus corrected) over the summed odometry travel."""
    true = relative_pose(log.poses[:-1], log.poses[1:])[:, 2]
    rel = log.relative_motion()[1:]
    steps = slice(part.start, (part.stop if part.stop is not None else log.n_scans) - 1)
    error = wrap_angle(rel[steps, 2] - true[steps])
    return float(error.sum() / np.hypot(rel[steps, 0], rel[steps, 1]).sum())


def drift_corrected(odometry: Array, rate: float) -> Array:
    """Odometry increments ``(rot1, trans, rot2)`` with the heading drift ``rate`` (rad/m) taken out,
    half of it from each rotation."""
    out = np.array(odometry, dtype=float)
    out[:, 0] -= 0.5 * rate * np.abs(out[:, 1])
    out[:, 2] -= 0.5 * rate * np.abs(out[:, 1])
    return out


#: The global-localization filters of the stored studies, all on the same runs and filter seeds: the cure
#: (GLOBAL_SETTINGS) on the second half's map; the same filter with uniform particles only; the cure on a map
#: of the whole run (the scans it localizes built that map: no wall missing or moved); the cure with the
#: odometry's heading drift, measured on the map half, taken out; the cure on the map control, a map of every
#: scan of the run but the run's own and ``LEAVE_OUT_MARGIN`` on each side of it (:func:`leave_out_split`).
METHODS = {"scan": "the cure (poses from the scan)", "uniform": "uniform particles only",
           "whole_map": "the cure, map of the whole run", "drift_corrected": "the cure, odometry drift removed",
           "leave_out": "the cure, map of every scan but the run's own",
           "no_injection": "the cure without injection (poses from the scan at the start only)",
           "guarded": "chapter 15's guarded cure (hysteresis and the mixture's evidence)",
           "islands": "chapter 15's cure with islands (the guarded cure and independent filters adopted on evidence)"}
#: The methods of ``intel/global`` (and of ``intel/global_previous``), and of the map control ``intel/map_control``.
GLOBAL_METHODS = ("scan", "uniform", "whole_map", "drift_corrected")
CONTROL_METHODS = ("leave_out",)
#: The methods of ``intel/injection``: the cure again (with its per-scan errors), without injection, and guarded;
#: every one on the runs and filter seeds of ``intel/global``.
INJECTION_METHODS = ("scan", "no_injection", "guarded")
PREVIOUS_COLUMNS = ("method", "seed", "start_scan", "locked_on", "locked_from", "final_position_error",
                    "final_heading_error", "mean_particles", "window_margin")
GLOBAL_COLUMNS = PREVIOUS_COLUMNS + ("likelihood_evaluations",)
#: The methods of ``intel/guarded_maps``: chapter 15's guarded cure (:data:`GUARDED_SETTINGS`) on the map of the
#: whole run, with the odometry's drift taken out, and on the map control; the runs and filter seeds of ``intel/global``.
GUARDED_MAP_METHODS = ("whole_map", "drift_corrected", "leave_out")
#: Per-scan columns of ``intel/injection`` (stored in injection.npz): the errors against the corrected poses.
INJECTION_ARRAYS = ("position_error", "heading_error")
INJECTION_COLUMNS = GLOBAL_COLUMNS + ("seconds", "cpu_seconds") + INJECTION_ARRAYS
#: ``intel/islands``: the islands over the run lengths of ``intel/injection`` and ``intel/long_runs``, each run
#: paired with the guarded cure's run of the same seed and length.
ISLANDS_STEPS = (GLOBAL_STEPS, LONG_STEPS)
ISLANDS_COLUMNS = ("steps",) + GLOBAL_COLUMNS
#: The map control leaves out the run's scans and this many scans before and after them.
LEAVE_OUT_MARGIN = 10


class CountingField:
    """A likelihood field that counts the poses it scores (the cost of a run in likelihood evaluations:
    one evaluation is one pose scored against one scan's beams)."""

    def __init__(self, field: LikelihoodField):
        self.field, self.evaluations = field, 0

    def log_likelihood(self, poses: Array, z: Array) -> Array:
        out = self.field.log_likelihood(poses, z)
        self.evaluations += len(out)
        return out

    def __getattr__(self, name):
        return getattr(self.field, name)


@lru_cache(maxsize=1)
def _whole_run_cells() -> tuple[LogOddsMap, list, Array, Array]:
    """The whole run's map, each scan's crossed and end cells on its grid, and the counts over all scans."""
    log = split().log
    whole = _track_split("whole run").map
    shape = whole.log_odds.shape
    cells = list(scan_cells(log.poses, log.ranges, log.angles, whole.origin, shape, max_range=Z_MAX,
                            resolution=whole.resolution))
    n_free, n_occ = np.zeros(shape, dtype=np.int64), np.zeros(shape, dtype=np.int64)
    for free, ends in cells:
        n_free.flat[free] += 1
        n_occ.flat[ends] += 1
    return whole, cells, n_free, n_occ


#: The map control's robustness check (``intel/map_control_margin``): a wider margin on the first runs.
MARGIN_CHECK = 60
N_MARGIN_CHECK = 40


def margin_row(seed: int, *, margin: int = MARGIN_CHECK) -> dict:
    """The map control (:func:`global_row`, ``leave_out``) with ``margin`` scans left out on each side."""
    return global_row(seed, method="leave_out", margin=margin)


def long_row(seed: int, *, method: str = "guarded") -> dict:
    """:func:`global_row` over ``LONG_STEPS`` scans (the study ``intel/long_runs``): the start scan drawn by the
    same rule among those that leave ``LONG_STEPS`` scans, the same filter seeds."""
    return global_row(seed, method=method, steps=LONG_STEPS)


def islands_row(seed: int, *, steps: int = GLOBAL_STEPS) -> dict:
    """:func:`global_row` with chapter 15's islands (:data:`ISLANDS_SETTINGS`) over ``steps`` scans (the study
    ``intel/islands``): the start scan and filter seeds of ``intel/injection`` (40) or ``intel/long_runs`` (80)."""
    return global_row(seed, method="islands", steps=steps)


def islands_control_row(seed: int) -> dict:
    """The map control (:func:`leave_out_split`) with chapter 15's islands over ``GLOBAL_STEPS`` scans (the study
    ``intel/islands_map_control``), paired with ``intel/guarded_maps``' arm ``leave_out``."""
    return global_row(seed, method="leave_out", settings=ISLANDS_SETTINGS)


def injection_row(seed: int, *, method: str = "scan") -> dict:
    """:func:`global_row` with its per-scan errors (the study ``intel/injection``)."""
    return global_row(seed, method=method, per_scan=True)


def leave_out_split(first: int, steps: int = GLOBAL_STEPS, margin: int = LEAVE_OUT_MARGIN) -> Split:
    """The map control for a run over held-out scans ``first .. first + steps - 1``: the log-odds map of every
    scan of the log except ``first - margin .. first + steps + margin - 1`` (on the whole run's grid; a cell
    only the left-out scans saw is unknown), so the map is not the scans being localized."""
    sp = split()
    whole, cells, n_free, n_occ = _whole_run_cells()
    n_free, n_occ = n_free.copy(), n_occ.copy()
    for free, ends in cells[max(first - margin, 0):min(first + steps + margin, N_SCANS)]:
        n_free.flat[free] -= 1
        n_occ.flat[ends] -= 1
    m = LogOddsMap(log_odds=n_free * L_FREE + n_occ * L_OCC, resolution=whole.resolution, origin=whole.origin)
    return Split(log=sp.log, map=m, grid=m.grid(), free=m.free_grid(), poses=m.to_map(sp.log.poses[HELD_OUT]),
                 ranges=sp.ranges, odometry=sp.odometry)


def global_row(seed: int, *, method: str = "scan", settings: GlobalSettings | None = None,
               per_scan: bool = False, margin: int = LEAVE_OUT_MARGIN, steps: int = GLOBAL_STEPS) -> dict:
    """One global run of ``steps`` (``GLOBAL_STEPS``) held-out scans from :func:`global_start`, the filter
    (:func:`pfcourse.scenarios.maprobot.global_mcl.global_mcl`, ``settings``, :data:`GLOBAL_SETTINGS` by
    default) drawing from ``default_rng([41, seed, 1])``; ``method`` one of :data:`METHODS`.

    ``locked_from``: the first scan from which it stays locked on (``GLOBAL_STEPS``: never);
    ``window_margin``: over the lock-on window, the scans' log-likelihood at the corrected poses minus at
    the filter's estimates (positive: the reference explains the scans better than where the filter
    is, so the evidence was there; negative: the filter's wrong place fits the scans better);
    ``likelihood_evaluations``: the poses the filter scored against a scan over the run (its cost);
    ``margin``: the scans left out on each side of the run by the map control (``leave_out``);
    ``per_scan``: add the errors of every scan, ``position_error`` (m) and ``heading_error`` (rad), and the
    filter's CPU time ``cpu_seconds`` (the process's, not the wall clock: the machine is shared)."""
    if method not in METHODS:
        raise ParameterError(f"method must be one of {list(METHODS)}, got {method!r}")
    s = settings if settings is not None else GLOBAL_SETTINGS
    first = global_start(seed, steps)
    sp = (_track_split("whole run") if method == "whole_map" else leave_out_split(first, steps, margin=margin) if method == "leave_out"
          else split())
    s = uniform_only(s) if method == "uniform" else s
    s = replace(s, inject_share=0.0) if method == "no_injection" else GUARDED_SETTINGS if method == "guarded" else s
    s = ISLANDS_SETTINGS if method == "islands" else s
    cpu = time.process_time()
    run = slice(first, first + steps)
    odometry = sp.odometry[run].copy()
    odometry[0] = 0.0
    if method == "drift_corrected":
        odometry = drift_corrected(odometry, drift_rate(sp.log))
    field = sp.field()
    scans = sp.ranges[run, ::BEAM_STEP]
    counting = CountingField(field)
    res = global_mcl(sp.free, counting, MOTION, scans, odometry, np.random.default_rng([41, seed, 1]), s)
    cpu = time.process_time() - cpu
    truth = sp.poses[run]
    pos, head = position_error(truth, res.mean), heading_error(truth, res.mean)
    tol = heading_tolerance(sp.log)
    last = slice(steps - LOCK_WINDOW, steps)
    margin = sum(field.log_likelihood(truth[k][None], scans[k])[0] - field.log_likelihood(res.mean[k][None], scans[k])[0]
                 for k in range(last.start, last.stop))
    extra = {"cpu_seconds": cpu, "position_error": pos, "heading_error": head} if per_scan else {}
    return {**extra, "start_scan": first, "locked_on": locked_on_share(pos, head, tol),
            "locked_from": lock_on.locked_from(pos, head, 1.0, tol, position_tol=LOCK_POSITION_M,
                                               window_s=LOCK_WINDOW, share=LOCK_SHARE),
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "mean_particles": float(res.sizes[1:].mean()), "window_margin": float(margin),
            "likelihood_evaluations": counting.evaluations}


#: Tracking from the known start (the chapter's MCL): the odometry noise a_1..a_4, the particle count,
#: the start spread, the seeds (the chapter's run is seed 1) and the maps the first half is tracked on.
TRACK_A = (0.01, 0.005, 0.01, 0.005)
TRACK_N, TRACK_START_STD = 1000, (0.2, 0.2, 0.05)
TRACK_SEEDS = range(1, 31)
#: The tracking filter (the chapter's MCL): bootstrap, systematic resampling at every scan, ``TRACK_N`` particles.
TRACK_FILTER = FilterSettings(TRACK_N, threshold=1.0, resampler="systematic")
#: "second half, drift corrected": the second half's map, the odometry's heading drift (measured on the map
#: half, :func:`drift_rate`) taken out of the held-out increments.
TRACK_MAPS = {"second half": MAP_PART, "whole run": slice(0, N_SCANS), "second half, drift corrected": MAP_PART}
TRACK_COLUMNS = ("map", "seed", "median_position_error", "p90_position_error", "final_position_error",
                 "final_heading_error", "locked_on", "lost_scan", "position_error", "heading_error")
#: Per-scan columns of the tracking runs (stored in tracking.npz): the errors against the corrected poses.
TRACK_ARRAYS = ("position_error", "heading_error")


@lru_cache(maxsize=3)
def _track_split(map_name: str) -> Split:
    if map_name == "second half":
        return split()
    if map_name == "second half, drift corrected":
        sp = split()
        return replace(sp, odometry=drift_corrected(sp.odometry, drift_rate(sp.log)))
    if map_name not in TRACK_MAPS:
        raise ParameterError(f"map must be one of {list(TRACK_MAPS)}, got {map_name!r}")
    sp, log = split(), split().log
    part = TRACK_MAPS[map_name]
    m = build_map(log.poses[part], log.ranges[part], log.angles, max_range=Z_MAX)
    return Split(log=log, map=m, grid=m.grid(), free=m.free_grid(), poses=m.to_map(log.poses[HELD_OUT]),
                 ranges=sp.ranges, odometry=sp.odometry)


def tracking_row(seed: int, *, map: str = "second half") -> dict:  # noqa: A002 (the study's setting)
    """One tracking run of the first half from the corrected start (the chapter's filter, systematic
    resampling at every scan), filter seeded by ``default_rng(seed)``, on the map ``map``. ``lost_scan``:
    the first scan from which the position error stays above ``LOCK_POSITION_M`` to the end (-1: never);
    ``locked_on``: the global runs' rule (:func:`locked_on_share`) on the last scans of the run;
    ``position_error`` (m) and ``heading_error`` (rad): per scan, against the corrected poses."""
    from pfcourse.scenarios.maprobot import MapRobotModel

    sp = _track_split(map)
    model = MapRobotModel(sp.grid, sp.field(), sp.odometry, motion=OdometryModel(TRACK_A), start=sp.poses[0],
                          start_std=TRACK_START_STD)
    run = TRACK_FILTER.build(model).run(sp.ranges[:, ::BEAM_STEP], rng=np.random.default_rng(seed))
    pos, head = position_error(sp.poses, run.mean), heading_error(sp.poses, run.mean)
    far = pos > LOCK_POSITION_M
    tail = np.flatnonzero(~far)
    lost = -1 if not far[-1] else int(tail[-1] + 1 if len(tail) else 0)
    return {"median_position_error": float(np.median(pos)), "p90_position_error": float(np.quantile(pos, 0.9)),
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "locked_on": locked_on_share(pos, head, heading_tolerance(sp.log)),
            "lost_scan": lost, "position_error": pos, "heading_error": head}
