"""Checker of the on-ramp chapter ("Particle filters in twenty minutes", chapter 0 of the book).

:func:`check_two_beacon_filter` checks a reader's particle filter for a variant of the chapter's
robot: the same rail and motion, but *two* beacons, and the second beacon's reading missing (NaN)
at some steps. The exact answer is a fine grid (the histogram filter, :func:`two_beacon_grid`), so
the reader's means are compared with the grid's means within a Monte Carlo tolerance set by the measured
error variance of a correct filter (:data:`ERROR_VARIANCE`) and a Bonferroni z over the steps
(:func:`tolerance_z`), and three seeds' means must not scatter more than a correct filter's (a filter
that silently uses fewer particles fails); a filter that misses is compared with what each typical
mistake converges to (:data:`TWO_BEACON_MISTAKES`) or with the runs of the mistaken filter
(:data:`RUN_MISTAKES`), so the report names the mistake, in one sentence. The filter must draw every random number from
the generator it is given: the same seed gives the same answer, another seed another answer, and
NumPy's global generator is left untouched.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.stats import chi2, norm

from pfcourse.book.exercises.checking import CheckReport, _answer, _shaped

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

#: The measured error variance of a correct filter, step by step on the checker's case, in units of
#: var_k / N (var_k the exact posterior variance, N the particles): resampling at every step adds
#: variance over a plain sample of the posterior. Measured on the reference solution with N = 5000,
#: seeds 10000 to 10199 (REFERENCE_RUNS runs), the larger of the mean taken before and after
#: resampling at each step; tests/test_onramp_exercise.py re-measures it on other seeds.
ERROR_VARIANCE = (5.52, 5.53, 3.51, 5.13, 3.52, 3.18, 2.85, 2.79, 4.33, 3.50, 3.06, 3.02, 3.06, 6.11, 4.06, 3.82)
REFERENCE_RUNS = 200

#: The family-wise false-alarm rate of the check: a correct filter fails it with probability at most
#: this, over all the steps (Bonferroni: each step is tested at ALPHA / steps, two-sided).
ALPHA = 0.001

#: A grid mistake is named when the means lie within MISTAKE_Z standard errors sqrt(MISTAKE_INFLATION var_k / N)
#: of its limit: a filter with a mistake scatters about its limit more than a correct one about the exact
#: answer (no motion noise: the cloud collapses), and naming is a diagnosis, not an acceptance, so this band
#: is wider than the check's; the limits lie far outside each other's bands on the checker's case.
MISTAKE_INFLATION, MISTAKE_Z = 12.0, 6.0

#: The measured variances are estimates from REFERENCE_RUNS runs; they are raised to the upper
#: 1 - ALPHA bound of a chi-square estimate, so an unlucky measurement does not tighten the check.
INFLATION = float(max(ERROR_VARIANCE)) * (REFERENCE_RUNS - 1) / float(chi2.ppf(ALPHA, REFERENCE_RUNS - 1))


def _error_variance(steps: int, z_is_case: bool) -> np.ndarray:
    """The error variance per step, in units of var_k / N, raised for its estimation error (the measured
    one on the checker's own case; the largest measured, at every step, on other readings)."""
    margin = (REFERENCE_RUNS - 1) / chi2.ppf(ALPHA, REFERENCE_RUNS - 1)
    if z_is_case and steps == len(ERROR_VARIANCE):
        return np.asarray(ERROR_VARIANCE) * margin
    return np.full(steps, max(ERROR_VARIANCE) * margin)


def tolerance_z(steps: int) -> float:
    """The Bonferroni z over ``steps`` steps: each step two-sided at ALPHA / steps."""
    return float(norm.isf(ALPHA / (2 * steps)))


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

#: Mistakes whose particle filter does not settle near a grid's answer (a range of 0 m no place on the rail
#: explains; weights that depend on the whole path): the reference filter with the mistake
#: (:func:`two_beacon_mistaken_filter`), run with the reader's number of particles on MISTAKE_RUNS seeds,
#: gives the band the reader's means must lie in, and the sentence that names it.
RUN_MISTAKES = {
    "lost reading as 0": "your means match a filter that reads a lost reading (NaN) as a range of 0 m: a lost "
                         "reading says nothing, so leave it out of the weight instead of replacing it by 0",
    "carried weights": "your means match a filter that carries the log-weights over after resampling: "
                       "resampling already puts the weight into the number of copies, so start every step from "
                       "equal weights (log-weights 0) and add only that step's log-likelihoods",
}
MISTAKE_RUNS = 20


def two_beacon_mistaken_filter(z: np.ndarray, n_particles: int, rng: np.random.Generator, mistake: str,
                               model: dict = TWO_BEACONS) -> np.ndarray:
    """The reference filter with a mistake of :data:`RUN_MISTAKES`: "lost reading as 0" replaces a missing
    reading by 0; "carried weights" carries each particle's log-weight, with the particle, through
    resampling and adds the next step's log-likelihoods to it."""
    beacons = np.asarray(model["beacons"], dtype=float)
    x = rng.uniform(*model["rail"], size=n_particles)
    log_w = np.zeros(n_particles)
    means = []
    for zk in np.asarray(z, dtype=float):
        x = x + model["speed"] + model["motion_sd"] * rng.standard_normal(n_particles)
        if mistake != "carried weights":
            log_w = np.zeros(n_particles)
        if mistake == "lost reading as 0":
            zk = np.nan_to_num(zk, nan=0.0)
        for b, zb in zip(beacons, zk):
            if not np.isnan(zb):
                log_w = log_w - 0.5 * ((zb - np.hypot(x - b, model["offset"])) / model["range_sd"]) ** 2
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        means.append(w @ x)
        picked = rng.choice(n_particles, size=n_particles, p=w)
        x, log_w = x[picked], log_w[picked]
    return np.array(means)


def two_beacon_grid_fill(z: np.ndarray, model: dict = TWO_BEACONS) -> np.ndarray:
    """``z`` with each missing reading of beacon B replaced by the range from the exact mean (a reading
    the filter can use), to tell a filter that breaks on a missing reading from one that breaks anyway."""
    means, _ = two_beacon_grid(z, model)
    fill = np.hypot(means[:, None] - np.asarray(model["beacons"]), model["offset"])
    return np.where(np.isnan(z), fill, z)


#: Three runs (seeds seed, seed + 1, seed + 2) of a correct filter have a mean squared error, in units of the
#: measured error variance, about 1 (tests/test_onramp_exercise.py measures its spread); a filter that uses a
#: tenth of its particles has about 10. Above SCATTER_LIMIT the check says the means scatter too much.
SCATTER_LIMIT = 4.0


def _scatter(runs: list, exact_means: np.ndarray, exact_var: np.ndarray, n_particles: int) -> float:
    """The mean squared error of ``runs`` (a list of mean arrays) about the exact means, in units of the
    measured error variance of a correct filter (ERROR_VARIANCE, not raised)."""
    steps = len(exact_means)
    unit = (np.asarray(ERROR_VARIANCE) if steps == len(ERROR_VARIANCE) else np.full(steps, max(ERROR_VARIANCE)))
    errors = (np.asarray(runs, dtype=float) - exact_means) ** 2 / (unit * exact_var / n_particles)
    return float(errors.mean())


SCATTER_SENTENCE = ("your means scatter about the exact ones {ratio:.0f} times as much (in squared error, over three "
                    "seeds) as a correct filter's with {n} particles: does every step use all n_particles particles "
                    "(the draw, the move, the weights and the resampling)?")


def _scale(exact_var: np.ndarray, n_particles: int, z_is_case: bool) -> np.ndarray:
    """A correct filter's standard error per step: sqrt(error variance * var_k / N)."""
    return np.sqrt(_error_variance(len(exact_var), z_is_case) * exact_var / n_particles)


def _within(means: np.ndarray, exact_means: np.ndarray, exact_var: np.ndarray, n_particles: int,
            z_is_case: bool = True) -> bool:
    scale = _scale(exact_var, n_particles, z_is_case)
    return bool(np.all(np.abs(means - exact_means) <= tolerance_z(len(means)) * scale + 1e-12))


def _like_mistaken_runs(means: np.ndarray, z: np.ndarray, n_particles: int, model: dict, mistake: str) -> bool:
    """Whether ``means`` lie within the Bonferroni z of the mistaken filter's runs (their mean and spread over
    MISTAKE_RUNS seeds, with the reader's number of particles)."""
    runs = np.array([two_beacon_mistaken_filter(z, n_particles, np.random.default_rng(900_000 + s), mistake, model)
                     for s in range(MISTAKE_RUNS)])
    centre, spread = runs.mean(axis=0), runs.std(axis=0, ddof=1) * np.sqrt(1 + 1 / MISTAKE_RUNS)
    return bool(np.all(np.abs(means - centre) <= tolerance_z(len(means)) * spread + 1e-12))


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

    def quiet(s: int):
        """Another seed's means, or None if the call fails (not reported: the first run's problem is)."""
        try:
            with np.errstate(all="ignore"):
                return np.asarray(call(s)(), dtype=float)
        except Exception:
            return None

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
    z_is_case = z.shape == (CASE_STEPS, 2) and model is TWO_BEACONS and np.array_equal(z, two_beacon_case(),
                                                                                          equal_nan=True)
    if not _within(means, exact_means, exact_var, n_particles, z_is_case):
        for mistake, why in TWO_BEACON_MISTAKES.items():
            limit, limit_var = two_beacon_grid(z, model, mistake=mistake)
            if np.all(np.abs(means - limit) <= MISTAKE_Z * np.sqrt(MISTAKE_INFLATION * limit_var / n_particles)):
                report.problems.append(why)
                return report
        for mistake, why in RUN_MISTAKES.items():
            if _like_mistaken_runs(means, z, n_particles, model, mistake):
                report.problems.append(why)
                return report
        near = np.all(np.abs(means - exact_means) <= MISTAKE_Z * np.sqrt(MISTAKE_INFLATION * exact_var / n_particles))
        runs = [means] + [r for r in (quiet(seed + 1), quiet(seed + 2)) if r is not None and r.shape == means.shape]
        if near and len(runs) == 3 and _scatter(runs, exact_means, exact_var, n_particles) > SCATTER_LIMIT:
            report.problems = [SCATTER_SENTENCE.format(ratio=_scatter(runs, exact_means, exact_var, n_particles),
                                                       n=n_particles)]
            return report
        scale = _scale(exact_var, n_particles, z_is_case)
        k = int(np.argmax(np.abs(means - exact_means) / scale))
        report.problems.append(
            f"at step {k} your mean is {means[k]:.3f} m, the exact (grid) mean is {exact_means[k]:.3f} m, more than "
            f"{tolerance_z(len(means)):.1f} standard errors ({scale[k]:.3f} m) away: check the move, the two ranges "
            "and the weighted mean")
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
    third = run(seed + 2)
    runs = [means] + [np.asarray(r, dtype=float) for r in (other, third) if r is not None and np.shape(r) == means.shape]
    if len(runs) == 3 and _scatter(runs, exact_means, exact_var, n_particles) > SCATTER_LIMIT:
        report.problems.append(SCATTER_SENTENCE.format(ratio=_scatter(runs, exact_means, exact_var, n_particles),
                                                       n=n_particles))
    return report
