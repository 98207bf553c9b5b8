"""Checkers of Part III (parameter studies: chapters 20-22)."""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport, _answer, _settled


# The effective sample size from log-weights (chapter 21, exercise 21.1): cases whose weights underflow
# (log-weights near -1000) or overflow (near +800) in the linear domain, and an ordinary one.
ESS_CASES = (np.log(np.array([0.5, 0.25, 0.125, 0.125])), np.array([-1000.0, -1001.0, -1000.5, -1003.0, -1000.0]),
             np.array([800.0, 799.0, 801.0]), np.array([0.0, -np.inf, -1.0, -2.0]))


ESS_MISTAKES = {
    "not_normalised": "it computes 1 / sum(w^2) from weights that do not sum to one; normalise first, "
                      "W_i = w_i / sum_j w_j, then ESS = 1 / sum_i W_i^2",
    "fraction": "it returns ESS / N, a fraction; the exercise asks for the effective number of particles",
    "sum_over_sum_of_squares_linear": "it exponentiates the log-weights without subtracting their maximum, so they "
                                      "underflow to 0 or overflow to inf; subtract max(log w) before exp "
                                      "(the ESS does not change)",
}


def effective_sample_size_from_logs(log_weights: np.ndarray, mistake: str | None = None) -> float:
    """``ESS = 1 / sum_i W_i^2`` with ``W_i = exp(l_i - logsumexp(l))`` for log-weights ``l`` (any
    constant added to them cancels). ``mistake`` (a key of :data:`ESS_MISTAKES`) computes it instead."""
    log_weights = np.asarray(log_weights, dtype=float)
    with np.errstate(all="ignore"):
        if mistake == "not_normalised":
            w = np.exp(log_weights - np.max(log_weights))
            return float(1.0 / np.sum(w**2))
        if mistake == "sum_over_sum_of_squares_linear":
            w = np.exp(log_weights)
            return float(np.sum(w) ** 2 / np.sum(w**2))
        w = np.exp(log_weights - logsumexp(log_weights))
        ess = float(1.0 / np.sum(w**2))
    return ess / len(log_weights) if mistake == "fraction" else ess


def check_ess(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(log_weights) -> ess`` on :data:`ESS_CASES` against
    :func:`effective_sample_size_from_logs`; the mistakes of :data:`ESS_MISTAKES` are named."""
    report = CheckReport("effective sample size")
    answers = []
    for case in ESS_CASES:
        answer = _answer(report, lambda: fn(case.copy()), "fn(log_weights)", "return the ESS, a number")
        if answer is None:
            return report
        try:
            answers.append(float(answer))
        except (TypeError, ValueError):
            report.problems.append(f"the answer {answer!r} is not a number: return the ESS as one float")
            return report

    def fits(mistake: str | None) -> bool:
        expected = [effective_sample_size_from_logs(c, mistake) for c in ESS_CASES]
        return all((np.isnan(a) and np.isnan(e)) or np.isclose(a, e, rtol=rtol) for a, e in zip(answers, expected))

    if _settled(report, fits, ESS_MISTAKES):
        return report
    if any(not np.isfinite(a) for a in answers):
        report.problems.append("the ESS is not finite for log-weights near -1000 or +800: work in the log domain "
                               "(subtract the largest log-weight, or use logsumexp) before exponentiating")
        return report
    report.problems.append("the values differ from 1 / sum_i W_i^2 with normalised weights W_i; a weight of 0 "
                           "(log-weight -inf) must count for nothing")
    return report


# Adaptive resampling with residual resampling (chapter 21, exercise 21.1): the rule of Algorithm 21.1 with
# the scheme the chapter does not print.
ADAPTIVE_MISTAKES = {
    "reversed": "it resamples a cloud whose ESS is at least tau N, or keeps one whose ESS is below it: resample "
                "only when ESS < tau N, so that tau = 0 never resamples and a larger tau resamples more often",
    "kept_weights": "after resampling it keeps the old log-weights: each copy now stands for 1/N of the cloud, "
                    "so reset every log-weight to -log N (keeping the old ones counts the weights twice)",
    "multinomial": "a particle got fewer than floor(N W_i) copies: residual resampling first gives particle i "
                   "exactly floor(N W_i) copies and draws only the R = N - sum_i floor(N W_i) remaining ones",
    "systematic": "no particle ever got more than ceil(N W_i) copies, as with systematic or stratified "
                  "resampling: residual resampling draws the R remaining copies independently (multinomially) "
                  "from the residual weights N W_i - floor(N W_i), so a particle can get two of them",
    "biased": "the average number of copies of a particle is not N W_i: draw the R remaining copies with "
              "probabilities proportional to the residuals N W_i - floor(N W_i), normalised to sum to one",
    "overflow": "it exponentiates the log-weights without subtracting their logsumexp (or their maximum), so "
                "log-weights near 800 overflow to inf and the weights become NaN: normalise in the log domain, "
                "W_i = exp(l_i - logsumexp(l))",
    "not_strict": "it resamples a cloud of exactly equal weights at tau = 1, whose ESS equals N: the rule "
                  "resamples only when ESS < tau N, strictly, so equal weights are never resampled",
}


def adaptive_residual(particles: np.ndarray, log_w: np.ndarray, tau: float, rng: np.random.Generator,
                      mistake: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 21.1 with residual resampling: when ``ESS < tau N``, ``floor(N W_i)`` copies of particle ``i``
    and ``R = N - sum floor(N W_i)`` more drawn multinomially from the residuals; log-weights reset to
    ``-log N``. ``mistake`` (a key of :data:`ADAPTIVE_MISTAKES`) makes it instead."""
    n = len(log_w)
    if mistake == "overflow":
        with np.errstate(all="ignore"):
            w = np.exp(log_w) / np.sum(np.exp(log_w))
        if not np.isfinite(w).all():  # what rng.choice or the counts then do with NaN weights
            raise ValueError("probabilities contain NaN")
    else:
        w = np.exp(log_w - logsumexp(log_w))
    ess = 1.0 / np.sum(w ** 2)
    if mistake == "reversed":
        keep = ess < tau * n
    else:
        keep = ess > tau * n if mistake == "not_strict" else ess >= tau * n
    if keep:
        return particles, log_w
    if mistake == "multinomial":
        idx = rng.choice(n, size=n, p=w)
    elif mistake == "systematic":
        cum = np.cumsum(w)
        cum[-1] = 1.0
        idx = np.searchsorted(cum, (rng.random() + np.arange(n)) / n)
    else:
        counts = np.floor(n * w).astype(int)
        rest = n - counts.sum()
        if rest > 0:
            residual = np.ones(n) if mistake == "biased" else n * w - counts
            counts += np.bincount(rng.choice(n, size=rest, p=residual / residual.sum()), minlength=n)
        idx = np.repeat(np.arange(n), counts)
    new_w = log_w[idx] if mistake == "kept_weights" else np.full(n, -np.log(n))
    return particles[idx], new_w


def _adaptive_cases() -> dict[str, tuple[np.ndarray, float]]:
    """Log-weights and thresholds: kept (ESS at or above tau N) and resampled (ESS below it)."""
    uneven = np.log(np.array([3.9, 1.4, 1.3, 1.2, 0.6, 0.5, 0.5, 0.3, 0.2, 0.1]) / 10) + 800.0  # ESS ~ 4.7; exp overflows
    mild = np.log(np.linspace(1.0, 2.0, 10))  # ESS ~ 9.6
    return {"keep_low_tau": (uneven, 0.3), "keep_mild": (mild, 0.9), "keep_zero": (uneven, 0.0),
            "resample": (uneven, 0.5), "resample_mild": (mild, 1.0)}


#: Exactly equal weights at tau = 1 (ESS = N, not below it: kept). 16 equal log-weights of 0 give ESS = 16
#: exactly by logsumexp, by the maximum and by the sum, so no rounding decides the verdict.
EQUAL_CASE = (np.zeros(16), 1.0)


def check_adaptive_residual(fn: Callable, n_draws: int = 2000, seed: int = 0) -> CheckReport:
    """:func:`_check_adaptive_residual`, leaving NumPy's global ``np.random`` state as it was."""
    saved = np.random.get_state()
    try:
        return _check_adaptive_residual(fn, n_draws, seed)
    finally:
        np.random.set_state(saved)


def _check_adaptive_residual(fn: Callable, n_draws: int, seed: int) -> CheckReport:
    """Check ``fn(particles, log_w, tau, rng) -> (particles, log_w)``, adaptive resampling with residual
    resampling: clouds with ``ESS >= tau N`` come back unchanged, the others with equal log-weights; the
    generator is the one given; over ``n_draws`` resamplings every particle gets at least ``floor(N W_i)``
    copies, some get more than ``ceil(N W_i)`` (residual, not systematic), and the mean number of copies is
    ``N W_i`` within 5 standard errors. Each mistake of :data:`ADAPTIVE_MISTAKES` is named."""
    from pfcourse.book.exercises.part1 import _generator_problem

    report = CheckReport("check_adaptive_residual")
    signature = "fn(particles, log_w, tau, rng)"
    what = "return (particles, log_w): the cloud after the rule, and its log-weights"

    def call(log_w, tau, rng):
        n = len(log_w)
        answer = _answer(report, lambda: fn(np.arange(n, dtype=float), log_w.copy(), tau, rng), signature, what)
        if answer is None:
            return None
        try:
            parts, new_w = (np.asarray(a, dtype=float) for a in answer)
        except (TypeError, ValueError):
            report.problems.append("return a pair (particles, log_w) of two arrays")
            return None
        if parts.shape != (n,) or new_w.shape != (n,):
            report.problems.append(f"return N = {n} particles and N log-weights, not shapes {parts.shape} and "
                                   f"{new_w.shape}")
            return None
        if not np.isin(parts, np.arange(n)).all():
            report.problems.append("the particles returned are not copies of the particles given: resampling "
                                   "copies particles, it does not move them")
            return None
        return parts.astype(int), new_w

    rng = np.random.default_rng(seed)
    cases = _adaptive_cases()
    # log-weights near 800 overflow in the linear domain: the same cloud shifted to log-weights near 0 tells
    # that mistake from the others (an answer that works shifted and fails, or keeps the cloud, unshifted)
    log_w, tau = cases["resample"]
    try:
        with np.errstate(all="ignore"):
            high = fn(np.arange(len(log_w), dtype=float), log_w.copy(), tau, np.random.default_rng(seed))
            high_ok = np.isfinite(np.asarray(high[1], dtype=float)).all() and not np.allclose(high[1], log_w)
    except Exception:
        high_ok = False
    if not high_ok:
        try:
            with np.errstate(all="ignore"):
                low = fn(np.arange(len(log_w), dtype=float), log_w - 800.0, tau, np.random.default_rng(seed))
                low_ok = np.isfinite(np.asarray(low[1], dtype=float)).all() and not np.allclose(low[1], log_w - 800.0)
        except Exception:
            low_ok = False
        if low_ok:
            report.problems.append(ADAPTIVE_MISTAKES["overflow"])
            return report
    for name, (log_w, tau) in cases.items():
        out = call(log_w, tau, rng)
        if out is None:
            return report
        kept = np.array_equal(out[0], np.arange(len(log_w))) and np.allclose(out[1], log_w)
        if name.startswith("keep") and not kept or name.startswith("resample") and kept:
            report.problems.append(ADAPTIVE_MISTAKES["reversed"])
            return report
        if name.startswith("resample") and not np.allclose(out[1], out[1][0]):
            report.problems.append(ADAPTIVE_MISTAKES["kept_weights"])
            return report
    out = call(*EQUAL_CASE, rng)
    if out is None:
        return report
    if not (np.array_equal(out[0], np.arange(len(EQUAL_CASE[0]))) and np.allclose(out[1], EQUAL_CASE[0])):
        report.problems.append(ADAPTIVE_MISTAKES["not_strict"])
        return report
    log_w, tau = cases["resample"]
    problem = _generator_problem(lambda g: call(log_w, tau, g), lambda a, b: np.array_equal(a[0], b[0]),
                                 what="resampled cloud")
    if problem:
        report.problems.append(problem)
        return report
    n = len(log_w)
    w = np.exp(log_w - logsumexp(log_w))
    counts = np.empty((n_draws, n), dtype=int)
    for d in range(n_draws):
        out = call(log_w, tau, rng)
        if out is None:
            return report
        counts[d] = np.bincount(out[0], minlength=n)
    if (counts < np.floor(n * w)).any():
        report.problems.append(ADAPTIVE_MISTAKES["multinomial"])
        return report
    if not (counts > np.ceil(n * w)).any():
        report.problems.append(ADAPTIVE_MISTAKES["systematic"])
        return report
    se = counts.std(axis=0, ddof=1) / np.sqrt(n_draws) + 1e-12
    if np.max(np.abs(counts.mean(axis=0) - n * w) / se) > 5:
        report.problems.append(ADAPTIVE_MISTAKES["biased"])
    return report


# --- chapter 22, exercise 22.1: when a run locks on for good ----------------------------------------------
TIME_TO_LOCK_MISTAKES = {
    "first_entry": "it returns the first time the run is within the tolerances, though the run leaves them "
                   "again later; the time asked for is the start of the last stretch that lasts to the end",
    "steps": "it returns a step number, not a time: step k is at k * dt seconds",
    "not_strict": "it counts an error equal to the tolerance as within it; within means strictly below 1 m "
                  "and 5 degrees",
    "position_only": "it ignores the heading (or compares it, in radians, with 5, which every heading error "
                     "passes): a run is within the tolerances when the position error is below 1 m and the "
                     "heading error below 5 degrees, np.deg2rad(5) rad, at the same step",
    "last_exit": "it returns the time of the last step outside the tolerances, one step too early: the run "
                 "locks on at the next step",
}


def time_to_lock_reference(pos_err: np.ndarray, head_err: np.ndarray, dt: float,
                           mistake: str | None = None) -> float | None:
    """The time ``k0 * dt`` (s, step ``k`` at ``k * dt``) of the first step ``k0`` from which the run stays
    strictly within 1 m and 5 degrees to its end, ``None`` if its last step is not; or a mistake of
    :data:`TIME_TO_LOCK_MISTAKES`."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M

    pos_err, head_err = np.asarray(pos_err, dtype=float), np.asarray(head_err, dtype=float)
    heading_tol = LOCK_HEADING_RAD
    if mistake == "not_strict":
        ok = (pos_err <= LOCK_POSITION_M) & (head_err <= heading_tol)
    else:
        ok = (pos_err < LOCK_POSITION_M) & ((head_err < heading_tol) | (mistake == "position_only"))
    if mistake == "first_entry":
        return float(np.argmax(ok) * dt) if ok.any() else None
    if not ok[-1]:
        return None
    outside = np.flatnonzero(~ok)
    k0 = 0 if outside.size == 0 else int(outside[-1]) + 1
    if mistake == "last_exit":
        k0 -= 1
    return float(k0) if mistake == "steps" else float(k0 * dt)


def time_to_lock_cases() -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Runs ``(pos_err, head_err, dt)``: together they separate the right answer from every mistake."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M

    good_p, good_h = 0.5 * LOCK_POSITION_M, 0.5 * LOCK_HEADING_RAD
    cases = []
    p, h = np.full(40, good_p), np.full(40, good_h)
    p[:8], p[20] = 4.0, 2.0  # in at step 8, out again at step 20: locks on at step 21 (first_entry: 8)
    cases.append((p, h, 0.5))  # dt = 0.5 s: the time is 10.5 s, the step 21
    p, h = np.full(30, good_p), np.full(30, good_h)
    p[:5], h[12] = 3.0, 0.2  # heading off (0.2 rad, 11 degrees) at step 12: locks on at step 13
    cases.append((p, h, 1.0))
    p, h = np.full(30, good_p), np.full(30, good_h)
    p[:6], p[6] = 2.0, LOCK_POSITION_M  # exactly 1 m at step 6 is not within: locks on at step 7
    cases.append((p, h, 1.0))
    p, h = np.full(30, good_p), np.full(30, good_h)
    p[-1] = 1.5  # off at the last step: never locked on
    cases.append((p, h, 1.0))
    return cases


def check_time_to_lock(fn: Callable) -> CheckReport:
    """Check a student's ``fn(pos_err, head_err, dt) -> float or None`` against :func:`time_to_lock_reference`
    on :func:`time_to_lock_cases`; the mistakes of :data:`TIME_TO_LOCK_MISTAKES` are named."""
    report = CheckReport("time to lock on")
    answers = []
    for pos, head, dt in time_to_lock_cases():
        try:
            with np.errstate(all="ignore"):
                answer = fn(pos.copy(), head.copy(), dt)
        except Exception as exc:  # the student's error, reported
            report.problems.append(f"calling fn(pos_err, head_err, dt) raised {type(exc).__name__}: {exc}")
            return report
        if answer is not None and not isinstance(answer, (int, float, np.integer, np.floating)):
            report.problems.append(f"the answer {answer!r} is not a time in seconds or None")
            return report
        answers.append(None if answer is None else float(answer))

    def fits(mistake: str | None) -> bool:
        expected = [time_to_lock_reference(p, h, dt, mistake) for p, h, dt in time_to_lock_cases()]
        return all((a is None and e is None) or (a is not None and e is not None and np.isclose(a, e, rtol=1e-9))
                   for a, e in zip(answers, expected))

    if _settled(report, fits, TIME_TO_LOCK_MISTAKES):
        return report
    expected = [time_to_lock_reference(p, h, dt) for p, h, dt in time_to_lock_cases()]
    if all(a is None for a in answers):
        report.problems.append("your function returns None for every run, though most of the checker's runs lock "
                               "on: return the time (s) of the first step from which the run stays within 1 m and "
                               "5 degrees")
        return report
    wrong = next(i for i, (a, e) in enumerate(zip(answers, expected))
                 if (a is None) != (e is None) or (a is not None and not np.isclose(a, e, rtol=1e-9)))
    report.problems.append(f"run {wrong + 1} of the checker's runs gets {answers[wrong]} instead of {expected[wrong]}: "
                           "the time of the first step from which every step to the end is strictly within 1 m and "
                           "5 degrees, None if the last step is not")
    return report


# --- chapter 20, exercise 20.1: the ratio of mean squared errors and its bootstrap interval -------------
def _ratio_case(seed: int = 23, runs: int = 41) -> tuple[np.ndarray, np.ndarray]:
    """Two settings' errors on the same 41 runs: the worlds vary much, the per-run ratio little, and the
    ratio is larger in the harder worlds (so the ratio of mean squared errors, which weights the hard
    worlds most, is not the median of the per-run ratios)."""
    rng = np.random.default_rng(seed)
    world = rng.gamma(2.0, 0.2, runs)  # what each simulated world makes hard, shared by both settings
    ratio = np.exp(0.1 + 0.5 * (world - world.mean()) + 0.15 * rng.standard_normal(runs))
    return world * ratio, world


RATIO_CASE = _ratio_case()
#: The checker's resamples: with 20 000 the ends of a 95 % interval on RATIO_CASE stray from their limit by
#: about 0.003 of its width (0.016 at most over 200 seeds), so a tolerance of 0.03 width accepts every seed
#: and still refuses a 90 % interval, whose ends lie 0.07 width inside (80 %: 0.16; 99 %: 0.13 outside).
RATIO_BOOT = 20000
RATIO_TOL = 0.03
#: The confidence levels of the "wrong_level" mistake (the 95 % interval is asked for).
WRONG_LEVELS = (0.8, 0.9, 0.99)

RATIO_MISTAKES = {
    "reversed": "it divides b's mean squared error by a's; the ratio asked for is mean(a^2) / mean(b^2), the "
                "first setting over the second",
    "median_of_ratios": "it is the median of the per-run ratios a_r / b_r (the chapter's statistic); the ratio "
                        "asked for is that of the mean squared errors over the runs, mean(a^2) / mean(b^2)",
    "rmse": "it is the ratio of the root mean squared errors, sqrt(mean(a^2) / mean(b^2)); the ratio asked for "
            "is that of the mean squared errors, without the square root",
    "mean_of_ratios": "it averages the per-run ratios a_r^2 / b_r^2; the ratio asked for divides the two means, "
                      "mean(a^2) / mean(b^2), so that the runs with large errors weigh most",
    "run_quantiles": "its interval is the 2.5 % and 97.5 % quantiles of the per-run ratios a_r^2 / b_r^2, the "
                     "spread of the runs; the interval asked for is that of the ratio of the means: quantiles "
                     "of that ratio over bootstrap resamples of the runs",
    "unpaired": "it resamples a and b separately, which breaks the pairs: resample the runs, each run's "
                "a_r and b_r together (one set of indices for both)",
    "wrong_level": "its interval has the ends of an 80 %, 90 % or 99 % interval, not of the 95 % one asked for: "
                   "take the 2.5 % and 97.5 % quantiles of the bootstrap ratios, np.quantile(boot, [0.025, 0.975])",
}


def mse_ratio_reference(a: np.ndarray, b: np.ndarray, n_boot: int, rng: np.random.Generator,
                        mistake: str | None = None, level: float = 0.9) -> tuple[float, float, float]:
    """``(ratio, low, high)``: ``mean(a^2) / mean(b^2)`` and its 95 % percentile bootstrap interval
    (``n_boot`` resamples of the runs, each run's ``a`` and ``b`` together, drawn from ``rng``); or a
    mistake of :data:`RATIO_MISTAKES` (``"wrong_level"``: the interval at ``level`` instead)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if mistake == "reversed":
        a, b = b, a
    n = len(a)
    idx = rng.integers(0, n, (n_boot, n))
    sq_a, sq_b = a ** 2, b ** 2
    if mistake == "median_of_ratios":
        point, boot = np.median(a / b), np.median((a / b)[idx], axis=1)
    elif mistake == "mean_of_ratios":
        point, boot = np.mean(sq_a / sq_b), np.mean((sq_a / sq_b)[idx], axis=1)
    elif mistake == "unpaired":
        other = rng.integers(0, n, (n_boot, n))
        point, boot = sq_a.mean() / sq_b.mean(), sq_a[idx].mean(axis=1) / sq_b[other].mean(axis=1)
    else:
        point, boot = sq_a.mean() / sq_b.mean(), sq_a[idx].mean(axis=1) / sq_b[idx].mean(axis=1)
    if mistake == "run_quantiles":
        boot = sq_a / sq_b
    if mistake == "rmse":
        point, boot = np.sqrt(point), np.sqrt(boot)
    tail = (1.0 - level) / 2 if mistake == "wrong_level" else 0.025
    low, high = np.quantile(boot, [tail, 1.0 - tail])
    return float(point), float(low), float(high)


@functools.lru_cache(maxsize=None)
def _ratio_target(mistake: str | None, level: float = 0.9) -> tuple[float, float, float]:
    """:func:`mse_ratio_reference` on :data:`RATIO_CASE` with 100 000 resamples (ends within about 0.0013
    of the interval's width of their limit), computed once."""
    a, b = RATIO_CASE
    return mse_ratio_reference(a, b, 100_000, np.random.default_rng(12345), mistake, level)


def check_mse_ratio(fn: Callable, seed: int = 0) -> CheckReport:
    """:func:`_check_mse_ratio`, leaving NumPy's global ``np.random`` state as it was."""
    saved = np.random.get_state()
    try:
        return _check_mse_ratio(fn, seed)
    finally:
        np.random.set_state(saved)


def _check_mse_ratio(fn: Callable, seed: int) -> CheckReport:
    """Check ``fn(a, b, n_boot, rng) -> (ratio, low, high)`` on :data:`RATIO_CASE`: the ratio exactly, the
    interval with :data:`RATIO_BOOT` resamples within :data:`RATIO_TOL` of its width of a reference with many
    (ten times the bootstrap's own noise, less than half the shift of a 90 % interval's ends), and that every
    random number comes from ``rng``."""
    from pfcourse.book.exercises.part1 import _generator_problem

    report = CheckReport("ratio of mean squared errors and its bootstrap interval")
    a, b = RATIO_CASE
    answer = _answer(report, lambda: fn(a.copy(), b.copy(), RATIO_BOOT, np.random.default_rng(seed)),
                     "fn(a, b, n_boot, rng)", "return (ratio, low, high)")
    if answer is None:
        return report
    try:
        point, low, high = (float(v) for v in answer)
    except (TypeError, ValueError):
        report.problems.append("the answer is not three numbers: return (ratio, low, high)")
        return report
    if not low <= point <= high:
        report.problems.append(f"the interval {low:.3g} to {high:.3g} does not contain the ratio {point:.3g}: "
                               "return (ratio, low, high), low first")
        return report

    def close(ref: tuple[float, float, float]) -> bool:
        tol = RATIO_TOL * (ref[2] - ref[1])
        return bool(np.isclose(point, ref[0], rtol=1e-9) and abs(low - ref[1]) <= tol and abs(high - ref[2]) <= tol)

    def fits(mistake: str | None) -> bool:
        if mistake == "wrong_level":
            return any(close(_ratio_target(mistake, level)) for level in WRONG_LEVELS)
        return close(_ratio_target(mistake))

    if not _settled(report, fits, RATIO_MISTAKES):
        report.problems.append("the ratio or the interval differs from mean(a^2) / mean(b^2) and the 2.5 % and "
                               "97.5 % quantiles of that ratio over bootstrap resamples of the runs")
        return report
    if report.ok:
        problem = _generator_problem(lambda rng: fn(a.copy(), b.copy(), 50, rng),
                                     lambda x, y: bool(np.allclose(np.asarray(x, float), np.asarray(y, float))),
                                     what="interval")
        if problem:
            report.problems.append(problem)
    return report
