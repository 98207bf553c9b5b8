"""Checker of the on-ramp chapter ("Particle filters in twenty minutes", chapter 0 of the book).

:func:`check_two_beacon_filter` checks a reader's particle filter for a variant of the chapter's
robot: the same rail and motion, but *two* beacons, and the second beacon's reading missing (NaN)
at some steps. The exact answer is a fine grid (the histogram filter, :func:`two_beacon_grid`), so
the reader's means are compared with the grid's means within a Monte Carlo tolerance; a filter
that misses is compared with what each typical mistake converges to (:data:`TWO_BEACON_MISTAKES`),
so the report names the mistake, in one sentence. The filter must draw every random number from
the generator it is given: the same seed gives the same answer, another seed another answer, and
NumPy's global generator is left untouched.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.stats import norm

from pfcourse.exercises.checking import CheckReport, _answer, _shaped

#: The variant's model, as the exercise states it: beacons at 10 m and 16 m along the rail, both
#: 2 m off it; the robot moves 0.5 m a step with a motion noise of standard deviation 0.2 m; each
#: range reading has noise of standard deviation 0.5 m; before the first step the robot is
#: anywhere on the rail, from 0 to 20 m (uniform).
TWO_BEACONS = {"beacons": (10.0, 16.0), "offset": 2.0, "speed": 0.5, "motion_sd": 0.2, "range_sd": 0.5,
               "rail": (0.0, 20.0)}

#: Width (m) of the cells of the exact grid: halving it moves the grid's means by far less than the
#: Monte Carlo tolerance (tests/test_onramp_exercise.py measures it).
GRID_CELL = 0.01

#: Steps of the checker's run, and the steps at which beacon B's reading is missing.
CASE_STEPS = 16
CASE_MISSING_B = (0, 1, 2, 7, 8)
CASE_SEED = 20261127

#: Monte Carlo tolerance: a correct filter's mean at step k lies within TOLERANCE_Z standard errors
#: sqrt(INFLATION * var_k / N) of the exact mean (var_k the exact posterior variance). INFLATION
#: bounds the variance added by resampling at every step over a plain sample of the posterior:
#: measured on the reference filter over 200 seeds, the error's standard deviation is at most 2.6
#: such units at any step (mean taken after resampling; 2.3 before), so 12 (3.5 units) leaves a
#: margin (tests/test_onramp_exercise.py re-measures it), and the mistakes still lie 17 or more
#: tolerances' units away.
INFLATION = 12.0
TOLERANCE_Z = 6.0


def two_beacon_case(model: dict = TWO_BEACONS, steps: int = CASE_STEPS, missing=CASE_MISSING_B,
                    seed: int = CASE_SEED, start: float = 3.0) -> np.ndarray:
    """Readings ``(steps, 2)`` of a robot starting at ``start`` m: ranges to beacons A and B, NaN where missing."""
    rng = np.random.default_rng(seed)
    x, z = start, np.empty((steps, 2))
    for k in range(steps):
        x = x + model["speed"] + model["motion_sd"] * rng.standard_normal()
        z[k] = np.hypot(x - np.asarray(model["beacons"]), model["offset"]) + model["range_sd"] * rng.standard_normal(2)
    z[list(missing), 1] = np.nan
    return z


def two_beacon_grid(z: np.ndarray, model: dict = TWO_BEACONS, cell: float = GRID_CELL,
                    mistake: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Exact posterior means and variances (the histogram filter on cells ``cell`` m wide) of the
    two-beacon model, per step; with ``mistake``, what that mistake of :data:`TWO_BEACON_MISTAKES`
    converges to ("one beacon", "no motion noise", "sd as variance", "unweighted mean")."""
    speed, motion_sd, range_sd = model["speed"], model["motion_sd"], model["range_sd"]
    beacons = np.asarray(model["beacons"], dtype=float)
    if mistake == "no motion noise":
        motion_sd = 0.0
    if mistake == "sd as variance":
        range_sd = range_sd**2
    if mistake == "one beacon":
        beacons = beacons[:1]
    low, high = model["rail"]
    reach = speed * len(z) + 6 * model["motion_sd"] * np.sqrt(len(z)) + 1.0
    xs = np.arange(low - reach, high + reach, cell)
    p = ((xs >= low) & (xs <= high)).astype(float)
    p /= p.sum()
    half = int(np.ceil((speed + 8 * motion_sd) / cell))
    moves = np.arange(-half, half + 1) * cell
    if motion_sd > 0:
        kernel = norm.pdf(moves, speed, motion_sd)
    else:
        kernel = (np.abs(moves - speed) < cell / 2).astype(float)
    kernel /= kernel.sum()
    ranges = np.hypot(xs[:, None] - beacons, model["offset"])
    means, variances = np.empty(len(z)), np.empty(len(z))
    for k, zk in enumerate(np.asarray(z, dtype=float)):
        p = np.convolve(p, kernel, mode="same")
        if mistake == "unweighted mean":
            means[k] = xs @ p
            variances[k] = ((xs - means[k]) ** 2) @ p
        seen = ~np.isnan(zk[:len(beacons)])
        log_lik = norm.logpdf(zk[:len(beacons)][seen], ranges[:, seen], range_sd).sum(axis=1)
        with np.errstate(divide="ignore"):  # log 0 = -inf: a cell the robot cannot be in
            log_p = np.log(p) + log_lik
        p = np.exp(log_p - log_p.max())  # in the log domain: a reading no cell explains does not underflow
        p /= p.sum()
        if mistake != "unweighted mean":
            means[k] = xs @ p
            variances[k] = ((xs - means[k]) ** 2) @ p
    return means, variances


#: What each typical mistake converges to (a grid with the mistake, :func:`two_beacon_grid`), and the
#: sentence that names it.
TWO_BEACON_MISTAKES = {
    "one beacon": "your means match a filter that reads beacon A only: weight each particle by both "
                  "readings (add the two log-likelihoods)",
    "no motion noise": "your means match particles moved without motion noise: add motion_sd times a "
                       "standard normal draw to every particle's move",
    "sd as variance": "your means match a likelihood with range_sd**2 where range_sd goes: range_sd is the "
                      "standard deviation of a reading, so divide the residual by range_sd before squaring",
    "unweighted mean": "your means match the plain average of the moved particles, before the readings count: "
                       "take the weighted mean, w @ x with the normalised weights",
}


def two_beacon_grid_fill(z: np.ndarray, model: dict = TWO_BEACONS) -> np.ndarray:
    """``z`` with each missing reading of beacon B replaced by the range from the exact mean (a reading
    the filter can use), to tell a filter that breaks on a missing reading from one that breaks anyway."""
    means, _ = two_beacon_grid(z, model)
    fill = np.hypot(means[:, None] - np.asarray(model["beacons"]), model["offset"])
    return np.where(np.isnan(z), fill, z)


def _within(means: np.ndarray, exact_means: np.ndarray, exact_var: np.ndarray, n_particles: int) -> bool:
    scale = np.sqrt(INFLATION * exact_var / n_particles)
    return bool(np.all(np.abs(means - exact_means) <= TOLERANCE_Z * scale + 1e-12))


def _same_state(a: tuple, b: tuple) -> bool:
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and a[2:] == b[2:]


def check_two_beacon_filter(fn: Callable, n_particles: int = 5000, seed: int = 0,
                            z: np.ndarray | None = None, model: dict = TWO_BEACONS) -> CheckReport:
    """Check ``fn(z, n_particles, rng, model) -> means``: a particle filter for the two-beacon robot.

    ``z`` has shape ``(K, 2)`` (ranges to beacons A and B, NaN where a reading is missing); ``means``
    has shape ``(K,)``, the filter's estimate of the position after each step's readings. The
    means must lie within :data:`TOLERANCE_Z` standard errors of the exact (grid) means at every
    step; a filter that misses is compared with the limits of :data:`TWO_BEACON_MISTAKES`.
    """
    report = CheckReport("your two-beacon filter")
    z = two_beacon_case(model) if z is None else np.asarray(z, dtype=float)
    signature = "fn(z, n_particles, rng, model)"

    def call(s: int, readings: np.ndarray = z):
        return lambda: fn(readings.copy(), n_particles, np.random.default_rng(s), dict(model))

    def run(s: int):
        return _answer(report, call(s), signature, "write the filter and return its means, one per step")

    def fails(readings: np.ndarray) -> bool:
        """Whether the filter raises or returns a non-finite mean on ``readings``."""
        try:
            with np.errstate(all="ignore"):
                return not np.isfinite(np.asarray(call(seed, readings)(), dtype=float)).all()
        except Exception:
            return True

    def nan_named() -> bool:
        """Name the missing reading used, when the filter breaks on z and not on z with its gaps filled."""
        if np.isnan(z).any() and not fails(np.where(np.isnan(z), two_beacon_grid_fill(z, model), z)):
            k = int(np.argmax(np.isnan(z).any(axis=1)))
            report.problems.append(f"your filter breaks (NaN) at step {k}, where a missing reading (NaN) of "
                                   "beacon B comes in: leave a missing reading out of the weight instead of using it")
            return True
        return False

    before = np.random.get_state()
    try:
        try:
            with np.errstate(all="ignore"):
                answer = call(seed)()
        except Exception as exc:  # the student's error, reported
            if not nan_named():
                why = (": the weights are NaN, so they all underflowed to 0 (subtract the largest log-weight "
                       "before exponentiating)" if "NaN" in str(exc) else "")
                report.problems.append(f"calling {signature} raised {type(exc).__name__}: {exc}{why}")
            return report
        touched = not _same_state(before, np.random.get_state())
    finally:
        np.random.set_state(before)  # the reader's session keeps its own global state
    if answer is None:
        report.problems.append("the function returned None: write the filter and return its means, one per step")
        return report
    if not _shaped(report, answer, (len(z),), "one mean per step (an array of shape (K,))"):
        return report
    if touched:
        report.problems.append("your filter draws from NumPy's global generator (np.random....) instead of the "
                               "rng it is given: use rng.uniform, rng.normal and rng.choice, so a seed fixes the run")
        return report
    means = np.asarray(answer, dtype=float)
    bad = ~np.isfinite(means)
    if bad.any():
        if not nan_named():
            report.problems.append(f"your mean is NaN or infinite at step {int(np.argmax(bad))}: subtract the "
                                   "largest log-weight before exponentiating, so the weights cannot all underflow to 0")
        return report
    exact_means, exact_var = two_beacon_grid(z, model)
    if not _within(means, exact_means, exact_var, n_particles):
        for mistake, why in TWO_BEACON_MISTAKES.items():
            if _within(means, *two_beacon_grid(z, model, mistake=mistake), n_particles):
                report.problems.append(why)
                return report
        scale = np.sqrt(INFLATION * exact_var / n_particles)
        k = int(np.argmax(np.abs(means - exact_means) / scale))
        report.problems.append(
            f"at step {k} your mean is {means[k]:.3f} m, the exact (grid) mean is {exact_means[k]:.3f} m, more than "
            f"{TOLERANCE_Z:.0f} standard errors ({scale[k]:.3f} m) away: check the move, the two ranges and the "
            "weighted mean")
        return report
    again = run(seed)
    if again is None:
        return report
    if not np.array_equal(np.asarray(again, dtype=float), means, equal_nan=True):
        report.problems.append("two runs with the same seed gave different means: draw every random number from "
                               "the rng argument, not from a generator your function makes")
        return report
    other = run(seed + 1)
    if other is not None and np.array_equal(np.asarray(other, dtype=float), means, equal_nan=True):
        report.problems.append("two runs with different seeds gave the same means: your filter ignores the rng it "
                               "is given (a generator seeded inside the function?)")
    return report
