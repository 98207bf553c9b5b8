"""Rows of the global-localization studies (chapter ``part2/global_localization``).

:func:`global_run` and :func:`kidnap_run` are the study runs (one seeded experiment of one
method of :mod:`pfcourse.scenarios.robot.mcl`, its metrics as a dict, with the lock-on window
:data:`LOCK_WINDOW` and the wrong-but-confident threshold :data:`CONFIDENT_QUANTILE`).  Each ``*_row`` function computes
one row (one seeded run of one setting) from public functions, so a
study can tabulate hundreds of them and a test can re-compute any row alone.  Run ``r`` of
every setting uses the seed ``r``: the same truths, landmarks and measurements for every
method and ``N`` (common random numbers).  The tables ``anatomy``, ``lockon``, ``kidnap`` and
``ekf_vs_pf``, ``modes`` (per-step arrays, :func:`mode_run`), ``kld_amcl`` and ``tracking_cost`` are the
registered studies ``global_localization/...`` of :mod:`pfcourse.studies.registry`.  The tables
``anatomy``, ``lockon``, ``kidnap`` and ``ekf_vs_pf`` were written with 10 significant digits
(``%.10g``) by the study's first script; a re-run writes floats that round-trip exactly (as
``modes``, re-run when it became a registered study, is stored).
"""

from __future__ import annotations

import math

import numpy as np

from scipy import stats

from pfcourse.collectors import Clouds
from pfcourse.diagnostics import nees
from pfcourse.metrics import (LOCK_WINDOW_S, heading_error, position_error, position_spread, rmse,
                              within_tolerances_from)
from pfcourse.scenarios.robot.scenario import ANGLE_INDICES, RobotModel, simulate_robot
from pfcourse.studies.robot import compare_filters
from pfcourse.filter_config import FilterSettings
from pfcourse.scenarios.robot.mcl import kld_policy, kidnap, kidnap_pose, run_settings, settings_of

#: Settings of the EKF-beside-PF study (the Part III settings the text compares).
EKF_SETTINGS = {
    "default": dict(n_steps=100),
    "gap 100-200 s": dict(n_steps=260, gap=(100.0, 200.0)),
    "dt_meas 5 s": dict(n_steps=200, dt_meas=5.0),
    "dt_meas 20 s": dict(n_steps=200, dt_meas=20.0),
    "1 landmark": dict(n_steps=100, n_landmarks=1),
    "2 landmarks": dict(n_steps=100, n_landmarks=2),
}


#: The stored studies' settings: N of the anatomy; (method, N) of the lock-on, kidnap and KLD-trace studies.
ANATOMY_N = [300, 1000, 2000, 10000, 30000, 100000]
LOCKON = [("bootstrap", 300), ("bootstrap", 1000), ("bootstrap", 2000), ("bootstrap", 10000), ("bootstrap", 30000),
          ("mixture", 300), ("mixture", 1000), ("mixture", 2000),
          ("augmented", 1000), ("augmented", 2000),
          ("kld", 2000), ("kld", 30000), ("kld_mixture", 2000),
          ("tempered", 300), ("tempered", 1000), ("tempered", 2000)]
KIDNAP = [("bootstrap", 2000), ("mixture", 2000), ("augmented", 2000), ("kld", 2000), ("kld_mixture", 2000),
          ("tempered", 2000)]
#: The stored tables' columns, in order.
COLUMNS = {
    "anatomy": ("seed", "n", "nearest_m", "consistent_1", "expected_1", "ess_1", "consistent_3"),
    "lockon": ("seed", "method", "n", "status", "error_message", "locked_on", "lock_time", "final_error", "final_heading_error",
               "final_sd", "final_nees", "wrong_confident", "particle_steps", "mean_n", "seconds"),
    "kidnap": ("seed", "method", "n", "tracking_before", "detection_s", "recovery_s", "recovered", "final_error",
               "final_nees", "particle_steps", "seconds"),
    "ekf_vs_pf": ("seed", "setting", "pf_position_rmse", "pf_heading_rmse", "pf_mean_nees", "pf_failed", "pf_seconds",
                  "ekf_position_rmse", "ekf_heading_rmse", "ekf_mean_nees", "ekf_failed", "ekf_seconds"),
}


#: A stored study's scores of a global run whose filter failed (every particle impossible: the study
#: runner's ``failed_scores``): not locked on, infinitely far, and not "wrong but confident".
FAILED_RUN = {"locked_on": False, "final_error": np.inf, "final_heading_error": np.inf, "final_sd": np.inf,
              "final_nees": np.inf, "wrong_confident": False}

#: Lock-on (:func:`pfcourse.metrics.locked_on`): the last ``LOCK_WINDOW`` steps of the robot's 1 s step.
LOCK_WINDOW = int(LOCK_WINDOW_S)
#: Wrong but confident: final NEES above this chi2_3 quantile.
CONFIDENT_QUANTILE = 0.999


def position_heading_errors(truth: Array, mean: Array) -> tuple[Array, Array]:
    """Per-step position error ``||p^ - p||`` (m) and absolute wrapped heading error (rad)
    (:mod:`pfcourse.metrics`)."""
    return position_error(truth, mean), heading_error(truth, mean)


def global_run(seed: int, settings: FilterSettings, *, n_steps: int = 60) -> dict:
    """One global-localization run (uniform prior) of the filter of ``settings`` (a record of
    :data:`pfcourse.scenarios.robot.mcl.FILTERS` with its ``N``): lock-on and its metrics.

    ``locked_on``: within 1 m and 5 deg at each of the last :data:`LOCK_WINDOW` steps;
    ``lock_time`` (s): the first time from which it stays so (NaN if never);
    ``final_nees``: NEES at the last step; ``wrong_confident``: not locked on and
    ``final_nees > chi2_3`` quantile :data:`CONFIDENT_QUANTILE`; ``particle_steps``: sum over
    steps of the likelihood evaluations (the number of particles, times the stages of progressive
    correction for ``tempered``); ``mean_n``: the mean number of particles.
    """
    sim = simulate_robot(None, seed, n_steps=n_steps)
    out = run_settings(sim, settings, seed)
    pos, head = position_heading_errors(sim.truth, out["mean"])
    start = within_tolerances_from(pos, head)
    locked = start <= n_steps - LOCK_WINDOW
    final_nees = float(nees(sim.truth[-1:], out["mean"][-1:], out["cov"][-1:], ANGLE_INDICES)[0])
    confident = final_nees > stats.chi2.ppf(CONFIDENT_QUANTILE, 3)
    return {
        "locked_on": bool(locked),
        "lock_time": float(start * sim.scenario.dt) if start < n_steps else np.nan,
        "final_error": float(pos[-1]),
        "final_heading_error": float(head[-1]),
        "final_sd": float(position_spread(out["cov"][-1])),
        "final_nees": final_nees,
        "wrong_confident": bool((not locked) and confident),
        "particle_steps": int(np.sum(out["likelihood_evaluations"])),
        "mean_n": float(np.mean(out["n_used"])),
        "seconds": float(out["seconds"]),
    }


def kidnap_run(seed: int, settings: FilterSettings, *, n_steps: int = 150, kidnap_step: int = 50,
               detect_distance: float = 5.0) -> dict:
    """One kidnapped-robot run: tracking from the known start, robot moved at ``kidnap_step``.

    ``detection_s``: time from the kidnapping to the first step whose estimate is more than
    ``detect_distance`` m from where the robot would have been without kidnapping (NaN if never);
    ``recovery_s``: time from the kidnapping to the step from which the estimate stays within
    1 m and 5 deg of the new truth until the end (NaN if it is not within them at the end);
    ``recovered``: within them at each of the last :data:`LOCK_WINDOW` steps.
    """
    base = simulate_robot(None, seed, n_steps=n_steps)
    sim = kidnap(base, kidnap_step, kidnap_pose(seed, base.truth[kidnap_step], base.scenario.half_width))
    out = run_settings(sim, settings, seed, global_start=False)
    pos, head = position_heading_errors(sim.truth, out["mean"])
    old_pos, _ = position_heading_errors(base.truth, out["mean"])
    after = np.arange(kidnap_step, n_steps)
    moved = np.flatnonzero(old_pos[after] > detect_distance)
    start = within_tolerances_from(pos, head)
    dt = sim.scenario.dt
    before_ok = bool(np.all(pos[10:kidnap_step] < 1.0))
    final_nees = float(nees(sim.truth[-1:], out["mean"][-1:], out["cov"][-1:], ANGLE_INDICES)[0])
    return {
        "tracking_before": before_ok,
        "detection_s": float(moved[0] * dt) if len(moved) else np.nan,
        "recovery_s": float((max(start, kidnap_step) - kidnap_step) * dt) if start < n_steps else np.nan,
        "recovered": bool(start <= n_steps - LOCK_WINDOW),
        "final_error": float(pos[-1]),
        "final_nees": final_nees,
        "particle_steps": int(np.sum(out["likelihood_evaluations"])),
        "seconds": float(out["seconds"]),
    }


def _mahalanobis(model: RobotModel, particles: np.ndarray, z: np.ndarray, k: int) -> np.ndarray:
    """``sqrt(nu^T REst^-1 nu)`` from the model's log-likelihood ``log_norm - |nu|^2 / 2``."""
    return np.sqrt(np.maximum(2.0 * (model._log_norm - model.log_likelihood(particles, z, k)), 0.0))


def anatomy_row(seed: int, n: int, within: float = 2.0) -> dict:
    """The bootstrap filter's uniform cloud at its first readings (no resampling).

    ``nearest_m``: position distance from the truth to the nearest particle at step 1;
    ``consistent_1``: particles whose innovation at ``z_1`` is within ``within`` standard
    deviations (``sqrt(nu^T REst^-1 nu) < within``); ``expected_1``: its expectation
    ``N pi within^2 s_r s_b r_1 f / A`` (the volume of that set of poses over the prior's; ``f``
    the fraction of the ring of radius ``r_1`` on the map);
    ``consistent_3``: particles within ``within`` of each of ``z_1, z_2, z_3``;
    ``ess_1``: effective sample size after weighting by ``z_1``.
    """
    n_particles = n
    sim = simulate_robot(None, seed, n_steps=4)
    model = RobotModel.for_simulation(sim, initial="uniform")
    rng = np.random.default_rng(seed)  # the filter's stream: initial cloud, then the moves
    x = model.sample_initial(n_particles, rng)
    ok = np.ones(n_particles, dtype=bool)
    out = {"seed": seed, "n": n_particles}
    for k in (1, 2, 3):
        x = model.sample_transition(x, k, rng)
        d = _mahalanobis(model, x, sim.measurements[k], k)
        ok &= d < within
        if k == 1:
            out["nearest_m"] = float(np.min(position_error(sim.truth[1], x)))
            out["consistent_1"] = int(ok.sum())
            s_r, s_b = np.sqrt(np.diag(model.r_est))
            area = (2 * model.half_width) ** 2
            r = sim.measurements[1, 1]
            phi = np.linspace(-np.pi, np.pi, 3600, endpoint=False)
            lm = sim.landmarks[int(sim.measurements[1, 0])]
            on_map = np.mean((np.abs(lm[0] + r * np.cos(phi)) <= model.half_width)
                             & (np.abs(lm[1] + r * np.sin(phi)) <= model.half_width))
            out["expected_1"] = float(n_particles * math.pi * within**2 * s_r * s_b * r * on_map / area)
            w = np.exp(model.log_likelihood(x, sim.measurements[1], 1) - np.max(model.log_likelihood(x, sim.measurements[1], 1)))
            out["ess_1"] = float(w.sum() ** 2 / np.sum(w**2))
    out["consistent_3"] = int(ok.sum())
    return out


def mode_run(seed: int, method: str, n_particles: int = 2000, n_steps: int = 21,
             radius: float = 2.0, heading: float = np.deg2rad(10.0)) -> dict:
    """Per step ``k`` (arrays of ``n_steps``): ``mass_near_truth``, the posterior weight within ``radius`` m
    and ``heading`` rad of the truth, and ``ess_fraction``, ESS / N.

    ``method`` is a method of :data:`pfcourse.scenarios.robot.mcl.FILTERS` (the study: ``"bootstrap"`` and
    ``"mixture"``).
    """
    sim = simulate_robot(None, seed, n_steps=n_steps)
    base = RobotModel.for_simulation(sim, initial="uniform")
    pf = settings_of(method, n_particles).build(base)
    res = pf.run(sim.measurements, seed, collect=[Clouds()])
    mass = np.empty(n_steps)
    for k in range(n_steps):
        near = (position_error(sim.truth[k], res.particles[k]) < radius) & (
            heading_error(sim.truth[k], res.particles[k]) < heading)
        mass[k] = float(res.weights[k][near].sum())
    return {"mass_near_truth": mass, "ess_fraction": res.ess / n_particles}


def lockon_row(seed: int, method: str, n: int, n_steps: int = 60) -> dict:
    """:func:`global_run` of ``method`` with ``n`` particles, without its per-step arrays."""
    return {"seed": seed, "method": method, "n": n, **global_run(seed, settings_of(method, n), n_steps=n_steps)}


def kidnap_row(seed: int, method: str, n: int) -> dict:
    """:func:`kidnap_run` of ``method`` with ``n`` particles and its defaults."""
    return {"seed": seed, "method": method, "n": n, **kidnap_run(seed, settings_of(method, n))}


def ekf_row(seed: int, setting: str, n_particles: int = 300, burn_in: int = 20) -> dict:
    """The particle filter and the EKF on the same run of one :data:`EKF_SETTINGS` setting."""
    r = compare_filters(seed, filters=("pf", "ekf"), n_particles=n_particles, burn_in=burn_in, **EKF_SETTINGS[setting])
    out = {"seed": seed, "setting": setting}
    for name in ("pf", "ekf"):
        m = r[name]
        out.update({f"{name}_position_rmse": m.position_rmse, f"{name}_heading_rmse": m.heading_rmse,
                    f"{name}_mean_nees": m.mean_nees, f"{name}_failed": m.failed, f"{name}_seconds": m.seconds})
    return out


#: KLD-sampling with the mixture proposal (``kld_mixture``) at other settings than the book's
#: (1 m x 1 m x 10 deg bins, eps = 0.05, delta = 0.01, n_min = 100, n_max = 2000): AMCL's defaults
#: (kld_err = 0.01; kld_z = 0.99, which AMCL's pf_resample_limit uses as the normal quantile itself,
#: so delta = 1 - Phi(0.99); bins of 0.5 m x 0.5 m x 10 deg, hard-coded in its pf_kdtree.c;
#: min_particles 500 as in Nav2, max_particles 5000 as in the ROS 1 node), and the book's bound on
#: AMCL's finer grid alone.  Values: the filters' settings records (``kld_mixture``'s, ``N`` = n_max).
KLD_SETTINGS = {
    "AMCL defaults": settings_of("kld_mixture", 5000).with_(sample_size=kld_policy(
        (0.5, 0.5, float(np.deg2rad(10.0))), n_min=500, epsilon=0.01, delta=float(stats.norm.sf(0.99)))),
    "book bound, 0.5 m bins": settings_of("kld_mixture", 2000).with_(
        sample_size=kld_policy((0.5, 0.5, float(np.deg2rad(10.0))))),
}
#: Methods and N of the tracking-cost study (what the mixture proposal spends while tracking).
TRACKING = [("bootstrap", 2000), ("mixture", 2000)]
COLUMNS["kld_amcl"] = ("seed", "setting", "status", "error_message", "locked_on", "lock_time", "final_error",
                       "final_heading_error", "final_sd", "final_nees", "wrong_confident", "particle_steps", "mean_n",
                       "seconds")
COLUMNS["tracking_cost"] = ("seed", "method", "n", "ess_fraction", "position_rmse", "heading_rmse_deg")
COLUMNS["modes"] = ("method", "seed", "mass_near_truth", "ess_fraction")
#: The methods of the per-step study ``modes`` (:func:`mode_run`, ``N = 2000``, steps 0-20).
MODES = ("bootstrap", "mixture")


def kld_amcl_row(seed: int, setting: str, n_steps: int = 60) -> dict:
    """:func:`global_run` of ``kld_mixture`` at one :data:`KLD_SETTINGS` setting."""
    return {"seed": seed, "setting": setting, **global_run(seed, KLD_SETTINGS[setting], n_steps=n_steps)}


def tracking_row(seed: int, method: str, n: int, n_steps: int = 50, burn_in: int = 10) -> dict:
    """Tracking from the known start (no kidnapping): what the mixture proposal spends on the poses it draws
    from the reading.

    ``ess_fraction``: mean of ESS_k / N over the measurement steps ``k >= burn_in`` (after weighting,
    before resampling); ``position_rmse`` (m) and ``heading_rmse_deg`` over the same steps.  ``method``
    is a method of :data:`pfcourse.scenarios.robot.mcl.FILTERS` (the study: ``"bootstrap"`` and ``"mixture"``, the kidnap
    model with its teleport and share).
    """
    sim = simulate_robot(None, seed, n_steps=n_steps)
    base = RobotModel.for_simulation(sim, initial="tracking")
    pf = settings_of(method, n).build(base)
    res = pf.run(sim.measurements, seed)
    steps = np.arange(burn_in, n_steps)
    steps = steps[sim.has_measurement[steps]]
    pos = position_error(sim.truth[steps], res.mean[steps])
    head = heading_error(sim.truth[steps], res.mean[steps])
    return {"seed": seed, "method": method, "n": n, "ess_fraction": float(np.mean(res.ess[steps]) / n),
            "position_rmse": float(rmse(pos)), "heading_rmse_deg": float(np.rad2deg(rmse(head)))}
