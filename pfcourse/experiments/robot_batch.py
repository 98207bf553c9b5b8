"""Many seeded runs of the robot particle filter at once: the same numbers, a fraction of the time.

A Monte Carlo study repeats :func:`pfcourse.experiments.robot.compare_filters`
(particle filter only) for hundreds of seeds.  Run one at a time, most of the
time goes into Python overhead per step, not into arithmetic on the particles.
:func:`pf_batch` filters ``B`` replicates together: the particles of all runs
form one ``(B, N, 3)`` array, and each step is one vectorized transition, one
likelihood and one normalisation for the whole batch.

**Same results as one run at a time.**  Replicate ``b`` uses its own generator
``default_rng(seeds[b])`` and draws from it exactly what
:class:`~pfcourse.filter.ParticleFilter` draws on a
:class:`~pfcourse.robot.scenario.RobotModel` (initial cloud, ``N x 3`` transition
normals per step, then the resampler's uniforms when that replicate resamples,
through the same :mod:`pfcourse.resampling` function), and
:func:`simulate_batch` reproduces :func:`~pfcourse.robot.scenario.simulate_robot` stream
by stream.  So row ``b`` equals ``compare_filters(seeds[b], filters=("pf",), ...)``
up to floating-point round-off (tested), and every row of a study can be re-run
alone with the public single-run function.

The per-step recursion for replicate ``b`` (see :mod:`pfcourse.filter`)::

    x_k^i = f(x_{k-1}^i, u~_k + w^i),  w^i ~ N(0, QEst)
    log w_k^i = log W_{k-1}^i + log N(nu_k^i; 0, REst)      (measurement steps only)
    W_k^i = exp(log w_k^i - logsumexp_j log w_k^j),   ESS_k = 1 / sum_i (W_k^i)^2
    resample when ESS_k < threshold N.

Metrics per replicate (steps ``k >= burn_in``), as in :mod:`pfcourse.experiments.robot`:
``position_rmse`` (m), ``heading_rmse`` (rad), ``mean_nees`` (``inf`` if all the
weight sat on one particle at some step, a zero covariance); plus the final
position and heading errors, the mean ``ESS / N`` over measurement steps, the
number of resamplings, the filter's own position standard deviation
``sd_k = sqrt(P_xx + P_yy)`` averaged over the steps (``mean_position_sd``), and
how jerky the estimated path is, ``estimate_jitter = sqrt(mean_k ||(p^_k - p^_{k-1})
- (p_k - p_{k-1})||^2)`` (m per step: 0 for an estimate that moves exactly as the
robot).  With ``keep_errors=True`` also the per-step arrays (length ``K``)
``position_error`` ``||p^_k - p_k||``, ``position_sd`` and ``heading_error`` ``|wrap(theta^_k - theta_k)|``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_count, check_probability, covariance_factor
from pfcourse.diagnostics import nees
from pfcourse.errors import DegenerateWeightsError, NumericalError, ParameterError, StepError
from pfcourse.resampling import get_resampler
from pfcourse.robot.scenario import ANGLE_INDICES, INITIAL_STD, RobotScenario, checked_scenario, motion, rmse


@dataclass(frozen=True)
class RobotBatch:
    """``B`` simulated runs of one scenario (``K`` steps, ``M`` landmarks).

    ``truth`` ``(K, 3)`` is shared: the true commands and start do not depend on
    the seed.  ``odometry`` ``(B, K, 3)``, ``measurements`` ``(B, K, 3)`` (rows
    ``(j, range, bearing)`` or NaN) and ``landmarks`` ``(B, M, 2)`` are per run;
    ``has_measurement`` ``(K,)`` is the same for every run.
    """

    truth: Array
    odometry: Array
    measurements: Array
    landmarks: Array
    has_measurement: Array
    scenario: RobotScenario


def simulate_batch(
    seeds: Sequence[int], scenario: RobotScenario | None = None, **changes
) -> RobotBatch:
    """Simulate the runs ``seeds`` of ``scenario`` (updated by ``changes``), as :func:`simulate_robot` would.

    Each seed's four streams (landmarks, odometry, measurement noise, landmark
    choice) are drawn as in :func:`~pfcourse.robot.scenario.simulate_robot`; the
    dead-reckoning path is not computed.
    """
    base = scenario if scenario is not None else RobotScenario()
    scenario = base.with_(**changes) if changes else checked_scenario(base)
    seeds = list(seeds)
    if not seeds:
        raise ParameterError("simulate_batch needs at least one seed")
    K = scenario.n_steps
    controls = scenario.true_controls()
    truth = np.empty((K, 3))
    truth[0] = scenario.start
    truth[0, 2] = wrap_angle(scenario.start[2])
    for k in range(1, K):
        truth[k] = motion(truth[k - 1], controls[k], scenario.dt)
    mask = scenario.measurement_mask()
    steps = np.flatnonzero(mask)
    q_factor = covariance_factor(scenario.q_true).T
    r_factor = covariance_factor(scenario.r_true).T
    B = len(seeds)
    odometry = np.empty((B, K, 3))
    measurements = np.full((B, K, 3), np.nan)
    landmarks = []
    for b, seed in enumerate(seeds):
        landmark_rng, odometry_rng, noise_rng, choice_rng = np.random.default_rng(seed).spawn(4)
        if scenario.landmarks is not None:
            lm = np.array(scenario.landmarks, dtype=float)
        else:
            w = scenario.half_width
            lm = landmark_rng.uniform(-w, w, size=(scenario.n_landmarks, 2))
        landmarks.append(lm)
        odometry[b] = controls + odometry_rng.standard_normal((K, 3)) @ q_factor
        odometry[b, 0] = 0.0
        noise = noise_rng.standard_normal((K, 2)) @ r_factor
        choice = choice_rng.integers(0, len(lm), size=K)
        z = _range_bearing_rows(truth[steps], lm[choice[steps]]) + noise[steps]
        measurements[b, steps, 0] = choice[steps]
        measurements[b, steps, 1] = z[:, 0]
        measurements[b, steps, 2] = wrap_angle(z[:, 1])
    return RobotBatch(truth, odometry, measurements, np.stack(landmarks), mask, scenario)


def _range_bearing_rows(states: Array, landmarks: Array) -> Array:
    """``h(x)`` of :func:`~pfcourse.robot.scenario.range_bearing` with one landmark per row: ``(n, 3)``, ``(n, 2)`` -> ``(n, 2)``."""
    dx = landmarks[..., 0] - states[..., 0]
    dy = landmarks[..., 1] - states[..., 1]
    out = np.empty(states.shape[:-1] + (2,))
    out[..., 0] = np.hypot(dx, dy)
    out[..., 1] = wrap_angle(np.arctan2(dy, dx) - states[..., 2])
    return out


def pf_batch(
    seeds: Sequence[int],
    *,
    n_particles: int = 300,
    q_scale: float = 2.0,
    r_scale: float = 2.0,
    threshold: float = 0.5,
    scheme: str = "systematic",
    initial: str = "tracking",
    initial_std=INITIAL_STD,
    burn_in: int = 0,
    keep_errors: bool = False,
    scenario: RobotScenario | None = None,
    **scenario_changes,
) -> list[dict | StepError]:
    """Simulate and filter the runs ``seeds`` together; one metrics dictionary per seed.

    Arguments as in :func:`pfcourse.experiments.robot.compare_filters` (particle
    filter only).  A replicate whose weights all vanish, or whose particles turn
    non-finite, is returned as the :class:`~pfcourse.errors.StepError` it would
    have raised (the study runner records it as a failed run); the other
    replicates go on.
    """
    n = check_count(n_particles, "n_particles")
    threshold = check_probability(threshold, "threshold")
    resampler = get_resampler(scheme)
    for name, value in (("q_scale", q_scale), ("r_scale", r_scale)):
        if not value > 0:
            raise ParameterError(f"{name} must be positive, got {value}")
    if initial not in ("tracking", "uniform"):
        raise ParameterError(f"initial must be 'tracking' or 'uniform', got {initial!r}")
    check_count(burn_in + 1, "burn_in + 1")
    batch = simulate_batch(seeds, scenario, **scenario_changes)
    s = batch.scenario
    K, B = s.n_steps, len(batch.odometry)
    if burn_in >= K:
        raise ParameterError(f"burn_in = {burn_in} leaves no step of the {K}")
    rngs = [np.random.default_rng(seed) for seed in seeds]
    q_factor = covariance_factor(q_scale * np.asarray(s.q_true))
    r_chol = np.linalg.cholesky(r_scale * np.asarray(s.r_true))
    a = np.linalg.inv(r_chol)
    log_norm = -np.log(2.0 * np.pi) - float(np.sum(np.log(np.diag(r_chol))))
    rows = np.arange(B)

    x = np.empty((B, n, 3))
    std = np.asarray(initial_std, dtype=float)
    for b, rng in enumerate(rngs):
        if initial == "uniform":
            x[b, :, :2] = rng.uniform(-s.half_width, s.half_width, size=(n, 2))
            x[b, :, 2] = wrap_angle(rng.uniform(-np.pi, np.pi, size=n))
        else:
            x[b] = batch.truth[0] + rng.standard_normal((n, 3)) * std
            x[b, :, 2] = wrap_angle(x[b, :, 2])
    log_w = np.full((B, n), -np.log(n))
    w = np.full((B, n), 1.0 / n)
    mean = np.empty((B, K, 3))
    cov = np.empty((B, K, 3, 3))
    ess = np.empty((B, K))
    n_resamples = np.zeros(B, dtype=int)
    failure: list[StepError | None] = [None] * B
    alive = np.ones(B, dtype=bool)

    for k in range(K):
        if k > 0:
            noise = np.stack([rng.standard_normal((n, 3)) for rng in rngs])
            controls = np.einsum("bij,kj->bik", noise, q_factor)
            controls += batch.odometry[:, k, None, :]
            x = motion(x, controls, s.dt)
        bad = alive & ~np.isfinite(x).all(axis=(1, 2))
        for b in np.flatnonzero(bad):
            failure[b] = NumericalError(f"step {k}: the model produced NaN or infinite particle states", step=k)
        alive &= ~bad
        x[~alive] = 0.0
        if batch.has_measurement[k]:
            z = batch.measurements[:, k]
            lm = batch.landmarks[rows, z[:, 0].astype(int)]
            dx = lm[:, 0, None] - x[..., 0]
            dy = lm[:, 1, None] - x[..., 1]
            nu_r = z[:, 1, None] - np.hypot(dx, dy)
            nu_b = wrap_angle(z[:, 2, None] - wrap_angle(np.arctan2(dy, dx) - x[..., 2]))
            e0 = a[0, 0] * nu_r
            e1 = a[1, 0] * nu_r + a[1, 1] * nu_b
            unnormalized = log_w + (log_norm - 0.5 * (e0 * e0 + e1 * e1))
            with np.errstate(invalid="ignore"):
                log_total = logsumexp(unnormalized, axis=1)
            bad = alive & ~np.isfinite(log_total)
            for b in np.flatnonzero(bad):
                failure[b] = DegenerateWeightsError(
                    f"step {k}: every particle has zero likelihood for the measurement; the filter has lost track",
                    step=k,
                )
            alive &= ~bad
            log_total[~alive] = 0.0
            unnormalized[~alive] = -np.log(n)
            w = np.exp(unnormalized - log_total[:, None])
            log_w = unnormalized - log_total[:, None]
        mean[:, k] = np.matmul(w[:, None, :], x)[:, 0]
        sin_sum = np.sum(w * np.sin(x[..., 2]), axis=1)
        cos_sum = np.sum(w * np.cos(x[..., 2]), axis=1)
        resultant = np.hypot(sin_sum, cos_sum)
        mean[:, k, 2] = np.where(resultant > 1e-12 * np.sum(np.abs(w), axis=1), np.arctan2(sin_sum, cos_sum), np.nan)
        dev = x - mean[:, k, None, :]
        dev[..., 2] = wrap_angle(dev[..., 2])
        c = np.matmul(np.swapaxes(dev * w[..., None], 1, 2), dev)
        cov[:, k] = 0.5 * (c + np.swapaxes(c, 1, 2))
        ess[:, k] = 1.0 / np.sum(w**2, axis=1)
        for b in np.flatnonzero(alive & (ess[:, k] < threshold * n * (1.0 - 1e-12))):
            x[b] = x[b][resampler(w[b], rngs[b])]
            log_w[b] = -np.log(n)
            w[b] = 1.0 / n
            n_resamples[b] += 1

    out: list[dict | StepError] = []
    meas_steps = np.flatnonzero(batch.has_measurement)
    for b in range(B):
        if failure[b] is not None:
            out.append(failure[b])
            continue
        pos, head = rmse(batch.truth, mean[b], burn_in)
        # inf when all weight sat on one particle at some step (a zero covariance)
        mean_nees = float(np.mean(nees(batch.truth[burn_in:], mean[b, burn_in:], cov[b, burn_in:], ANGLE_INDICES)))
        err = mean[b] - batch.truth
        err[:, 2] = wrap_angle(err[:, 2])
        distance = np.hypot(err[:, 0], err[:, 1])
        sd = np.sqrt(cov[b, :, 0, 0] + cov[b, :, 1, 1])
        jitter = np.diff(mean[b, burn_in:, :2], axis=0) - np.diff(batch.truth[burn_in:, :2], axis=0)
        row = {
            "position_rmse": pos,
            "heading_rmse": head,
            "mean_nees": mean_nees,
            "final_position_error": float(distance[-1]),
            "final_heading_error": float(abs(err[-1, 2])),
            "mean_ess_fraction": float(np.mean(ess[b, meas_steps]) / n) if meas_steps.size else 1.0,
            "resamples": int(n_resamples[b]),
            "mean_position_sd": float(np.mean(sd[burn_in:])),
            "estimate_jitter": float(np.sqrt(np.mean(np.sum(jitter**2, axis=1)))) if len(jitter) else 0.0,
        }
        if keep_errors:
            row["position_error"] = distance
            row["position_sd"] = sd
            row["heading_error"] = np.abs(err[:, 2])
        out.append(row)
    return out
