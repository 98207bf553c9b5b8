"""The Intel Research Lab log (book/data/intel): the map from one part of the run, localization on the other.

:func:`split` reads the log, builds the log-odds map from the corrected poses of the *map part*
(the second half of the run, scans ``MAP_PART``) and returns the *held-out part* (the first
half, ``HELD_OUT``) in the map's frame: its scans, its corrected poses (the reference), its
odometry.  The second half builds the map because it passes closer to where the first half
goes than the other way round (the chapter measures it), so fewer of the held-out scans see
walls the map lacks.

:func:`global_run` is global localization from a uniform start at one held-out scan, with the
cure of issue 41: many particles at the start, their number shrinking by KLD-sampling, and
*sensor resetting weighted correctly*: at each scan a share of the cloud is drawn from a
proposal built from the scan (candidate poses uniform in the known free space, scored by the
likelihood field; a Gaussian kernel around candidates picked by their score), and each particle
is weighted as stratified importance sampling of the kidnap model's transition
``(1 - eps) p_odo + eps u``:

    odometry particle:  W ∝ (1 - eps) / M  p(z | x),
    injected particle:  W ∝ eps / R  u(x) / q(x)  p(z | x),

``M`` and ``R`` the numbers of each, ``u`` the uniform density on the known free space and
``q`` the proposal's density (the kernel mixture, evaluated exactly).  Its row: whether it locked
on by :func:`locked_on_share` (position within 1 m and heading within :func:`heading_tolerance`
for at least ``LOCK_SHARE`` of the last ``LOCK_WINDOW`` scans).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.special import logsumexp

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array
from pfcourse.errors import ParameterError
from pfcourse.scenarios.maprobot.carmen import CarmenLog, read_carmen, relative_pose
from pfcourse.scenarios.maprobot.grid import OccupancyGrid
from pfcourse.scenarios.maprobot.likelihood_field import LikelihoodField
from pfcourse.metrics import locked_on
from pfcourse.scenarios.maprobot.mapping import LogOddsMap, build_map
from pfcourse.scenarios.maprobot.motion import OdometryModel
from pfcourse.metrics import heading_error, position_error
from pfcourse.sample_size import cell_codes, kld_bound
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

    def field(self, beam_step: int = BEAM_STEP, z_hit: float = Z_HIT, z_rand: float = Z_RAND,
              beta: float = 1.0) -> LikelihoodField:
        """The likelihood field on every ``beam_step``-th beam; ``beta < 1``: its log tempered by ``beta``."""
        field = LikelihoodField(self.grid, self.log.angles[::beam_step], max_range=Z_MAX, z_hit=z_hit,
                                z_rand=z_rand, sigma=SIGMA)
        return field if beta == 1.0 else TemperedField(field, beta)


@dataclass(frozen=True, eq=False)
class TemperedField:
    """``beta log p(z | x)`` of a likelihood field (the scan counted as ``beta`` of its beams' evidence)."""

    field: LikelihoodField
    beta: float

    def __getattr__(self, name):
        return getattr(self.field, name)

    def log_likelihood(self, poses: Array, z: Array) -> Array:
        return self.beta * self.field.log_likelihood(poses, z)


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


def uniform_log_density(free: OccupancyGrid, x: Array) -> Array:
    """``log u(x)``: ``-log(A_free 2 pi)`` on the known free space, ``-inf`` elsewhere."""
    return np.where(free.is_free(x), -np.log(free.free_area * 2 * np.pi), -np.inf)


def scan_proposal(free: OccupancyGrid, field: LikelihoodField, z: Array, n: int, rng: np.random.Generator, *,
                  positions: int = 1000, headings: int = 36, beam_step: int = 3, temper: float = 0.5,
                  h: tuple[float, float] = (0.25, 0.1), keep: int = 200):
    """Sensor resetting's proposal, from the scan ``z``: ``positions`` points uniform in the known free
    space, each with ``headings`` headings evenly spaced (a random offset), scored by ``temper`` times
    the likelihood field on every ``beam_step``-th beam; the ``keep`` best candidates are kept; ``n`` poses are drawn from Gaussian kernels (``h``: m, rad) around candidates picked
    in proportion to their score.  Returns the poses and their exact ``log q(x)`` (the kernel mixture
    over the kept candidates)."""
    xy = free.sample_free(positions, rng)[:, :2]
    theta = wrap_angle(rng.random() * 2 * np.pi / headings + np.arange(headings) * 2 * np.pi / headings)
    c = np.column_stack([np.repeat(xy, headings, axis=0), np.tile(theta, positions)])
    coarse = LikelihoodField(field.grid, field.angles[::beam_step], max_range=field.max_range, z_hit=field.z_hit,
                             z_rand=field.z_rand, sigma=field.sigma)
    s = temper * coarse.log_likelihood(c, z[::beam_step])
    kept = np.argpartition(-s, keep)[:keep]
    c, s = c[kept], s[kept]
    log_v = s - logsumexp(s)
    pick = rng.choice(len(c), size=n, p=np.exp(log_v))
    x = c[pick] + rng.standard_normal((n, 3)) * np.array([h[0], h[0], h[1]])
    x[:, 2] = wrap_angle(x[:, 2])
    # q(x) = sum_c v_c N(x; c, diag(h^2)), the heading difference wrapped
    d = x[:, None, :] - c[None, :, :]
    d[..., 2] = wrap_angle(d[..., 2])
    log_k = (-0.5 * ((d[..., 0] ** 2 + d[..., 1] ** 2) / h[0] ** 2 + d[..., 2] ** 2 / h[1] ** 2)
             - 1.5 * np.log(2 * np.pi) - 2 * np.log(h[0]) - np.log(h[1]))
    return x, logsumexp(log_k + log_v[None, :], axis=1)


#: Global localization's settings: particles at the start (uniform, and drawn from the scan), the
#: KLD-sampling bounds and bins, the share of the cloud drawn from the scan at every
#: ``INJECT_EVERY``-th scan, the kidnap model's eps, and the run's length in scans.
N_START, N_START_SCAN = 20000, 2000
N_MIN, N_MAX = 500, 3000
KLD_BIN = (0.5, 0.5, float(np.deg2rad(10.0)))
KLD_EPSILON, KLD_DELTA = 0.05, 0.01
INJECT_SHARE, INJECT_EVERY = 0.1, 2
KIDNAP_EPS = 0.01
#: Scans of history an injected pose is carried through before it is weighed against the cloud.
HISTORY = 5
GLOBAL_STEPS = 40
N_GLOBAL = 100


def global_start(seed: int) -> int:
    """The held-out scan a global run starts at: uniform among those that leave GLOBAL_STEPS scans."""
    return int(np.random.default_rng([41, seed]).integers(0, N_SCANS // 2 - GLOBAL_STEPS))


def stratified(parts: list[tuple[float, Array, Array]]) -> tuple[Array, Array]:
    """Particles and log-weights of a stratified mixture: ``(mass, particles, log w)`` per part, each part's
    weights ``mass / n_part * w``."""
    x = np.concatenate([p for _, p, _ in parts])
    log_w = np.concatenate([np.log(mass) - np.log(len(p)) + lw for mass, p, lw in parts])
    return x, log_w


def global_filter(sp: Split, first: int, steps: int, rng: np.random.Generator, *, inject_share: float = INJECT_SHARE,
                  eps: float = KIDNAP_EPS, n_start: int = N_START, n_start_scan: int = N_START_SCAN,
                  history: int = HISTORY, z_hit: float = Z_HIT, z_rand: float = Z_RAND, beta: float = 1.0,
                  n_min: int = N_MIN):
    """Global localization on held-out scans ``first ... first + steps - 1``: estimates ``(steps, 3)``
    and the number of particles at each step.

    Step 0 draws ``n_start`` poses from the uniform prior ``u`` and ``n_start_scan`` from the scan's
    proposal ``q``, weighted as a stratified sample of ``u`` (half the mass each:
    ``p(z | x)`` and ``u / q p(z | x)``).  Each later step resamples to the KLD bound's number of
    particles and moves them by the odometry.  Every ``INJECT_EVERY``-th scan from ``history`` on, a
    share of poses is drawn from the proposal of the scan ``history`` steps back and carried to now
    by the odometry, each scan scoring them: a pose with a history.  Their weight is that of a
    kidnapping ``history`` steps ago, relative to the tracked cloud's own predictive likelihood
    ``Z_j`` of those scans:

        log W = log eps - log R + log u - log q + sum_{j=k-h}^{k} log p(z_j | x_j) - sum_{j=k-h}^{k-1} log Z_j,

    and a moved particle's ``log (1 - eps) - log M + log p(z_k | x_k)``."""
    field = sp.field(z_hit=z_hit, z_rand=z_rand, beta=beta)
    zs = sp.ranges[first:first + steps, ::BEAM_STEP]
    odo = sp.odometry[first:first + steps]
    parts = [(0.5, sp.free.sample_free(n_start, rng), None)]
    if n_start_scan > 0:
        q_x, log_q = scan_proposal(sp.free, field, zs[0], n_start_scan, rng)
        parts.append((0.5, q_x, uniform_log_density(sp.free, q_x) - log_q))
    else:
        parts[0] = (1.0, parts[0][1], None)
    x, log_w = stratified([(m, p, field.log_likelihood(p, zs[0]) + (0.0 if extra is None else extra))
                           for m, p, extra in parts])
    log_z = np.zeros(steps)  # the tracked cloud's predictive log-likelihood of each scan
    est, sizes = np.empty((steps, 3)), np.empty(steps, dtype=int)
    for k in range(steps):
        if k > 0:
            W = np.exp(log_w - logsumexp(log_w))
            bins = len(np.unique(cell_codes(x[_resample(W, N_MAX, rng)], KLD_BIN)))
            n = int(np.clip(kld_bound(bins, KLD_EPSILON, KLD_DELTA), n_min, N_MAX))
            inject = inject_share > 0 and k > history and k % INJECT_EVERY == 0
            r = int(round(inject_share * n)) if inject else 0
            moved = MOTION.sample(x[_resample(W, n - r, rng)], odo[k], rng)
            lw_m = field.log_likelihood(moved, zs[k])
            log_z[k] = logsumexp(lw_m) - np.log(len(moved))
            if r > 0:
                j0 = k - history
                inj, log_q = scan_proposal(sp.free, field, zs[j0], r, rng)
                lw_r = uniform_log_density(sp.free, inj) - log_q + field.log_likelihood(inj, zs[j0])
                for j in range(j0 + 1, k + 1):
                    inj = MOTION.sample(inj, odo[j], rng)
                    lw_r = lw_r + field.log_likelihood(inj, zs[j])
                lw_r = lw_r - log_z[j0:k].sum()
                x, log_w = stratified([(1 - eps, moved, lw_m), (eps, inj, lw_r)])
            else:
                x, log_w = moved, lw_m
        W = np.exp(log_w - logsumexp(log_w))
        est[k] = [W @ x[:, 0], W @ x[:, 1], np.angle(W @ np.exp(1j * x[:, 2]))]
        sizes[k] = len(x)
    return est, sizes


def _resample(W: Array, m: int, rng: np.random.Generator) -> Array:
    """Systematic resampling of ``m`` ancestors from normalised weights ``W``."""
    c = np.cumsum(W)
    c[-1] = 1.0
    return np.searchsorted(c, (rng.random() + np.arange(m)) / m, side="right").clip(max=len(W) - 1)


#: The global-localization filters of the stored study: the cure (sensor resetting from the scan, with
#: history) and the same filter with uniform particles only (as many at the start, no injection).
METHODS = {"scan": "sensor resetting from the scan", "uniform": "uniform start only",
           "tempered": "uniform start, field tempered"}
#: The tempered filter: the field's log-likelihood times TEMPER_BETA, at least TEMPER_N_MIN particles.
TEMPER_BETA, TEMPER_N_MIN = 0.3, 2000
GLOBAL_COLUMNS = ("method", "seed", "start_scan", "locked_on", "final_position_error", "final_heading_error",
                  "mean_particles")


def global_row(seed: int, *, method: str = "scan") -> dict:
    """One global run: start scan from the seed, filter seeded by it (``method``: ``"scan"`` the cure,
    ``"uniform"`` the same number of uniform particles at the start and no injection, ``"tempered"`` that
    with the field's log tempered by ``TEMPER_BETA`` and at least ``TEMPER_N_MIN`` particles); lock-on
    and errors."""
    sp = split()
    first = global_start(seed)
    if method not in METHODS:
        raise ParameterError(f"method must be one of {list(METHODS)}, got {method!r}")
    options = {} if method == "scan" else {"inject_share": 0.0, "n_start": N_START + N_START_SCAN, "n_start_scan": 0}
    if method == "tempered":
        options.update(beta=TEMPER_BETA, n_min=TEMPER_N_MIN)
    est, sizes = global_filter(sp, first, GLOBAL_STEPS, np.random.default_rng([41, seed, 1]), **options)
    truth = sp.poses[first:first + GLOBAL_STEPS]
    pos, head = position_error(truth, est), heading_error(truth, est)
    return {"start_scan": first, "locked_on": locked_on_share(pos, head, heading_tolerance(sp.log)),
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "mean_particles": float(sizes[1:].mean())}


#: Tracking from the known start (the chapter's MCL): the odometry noise a_1..a_4, the particle count,
#: the start spread, the seeds (the chapter's run is seed 1) and the maps the first half is tracked on.
TRACK_A = (0.01, 0.005, 0.01, 0.005)
TRACK_N, TRACK_START_STD = 1000, (0.2, 0.2, 0.05)
TRACK_SEEDS = range(1, 31)
TRACK_MAPS = {"second half": MAP_PART, "whole run": slice(0, N_SCANS)}
TRACK_COLUMNS = ("map", "seed", "median_position_error", "p90_position_error", "final_position_error",
                 "final_heading_error", "tracking_at_end", "lost_scan")


@lru_cache(maxsize=2)
def _track_split(map_name: str) -> Split:
    if map_name == "second half":
        return split()
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
    ``tracking_at_end``: the last scan within ``LOCK_POSITION_M`` and the heading tolerance."""
    from pfcourse.filter import ParticleFilter
    from pfcourse.scenarios.maprobot import MapRobotModel

    def systematic(W, rng):  # the chapter's resampler, draw for draw
        c = np.cumsum(W)
        return np.searchsorted(c / c[-1], (np.arange(len(W)) + rng.random()) / len(W))

    sp = _track_split(map)
    model = MapRobotModel(sp.grid, sp.field(), sp.odometry, motion=OdometryModel(TRACK_A), start=sp.poses[0],
                          start_std=TRACK_START_STD)
    run = ParticleFilter(model, TRACK_N, threshold=1.0, resampler=systematic).run(
        sp.ranges[:, ::BEAM_STEP], rng=np.random.default_rng(seed))
    pos, head = position_error(sp.poses, run.mean), heading_error(sp.poses, run.mean)
    far = pos > LOCK_POSITION_M
    tail = np.flatnonzero(~far)
    lost = -1 if not far[-1] else int(tail[-1] + 1 if len(tail) else 0)
    return {"median_position_error": float(np.median(pos)), "p90_position_error": float(np.quantile(pos, 0.9)),
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "tracking_at_end": bool(pos[-1] < LOCK_POSITION_M and head[-1] < heading_tolerance(sp.log)),
            "lost_scan": lost}
