"""Checkers of Part III (parameter studies: chapters 17-19)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.special import logsumexp

from pfcourse.exercises.checking import CheckReport, _answer, _settled


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


# Locked on, the book's one definition (chapter 22, exercise 22.1): runs of per-step errors whose verdict
# differs between the right definition and each mistake.
LOCK_MISTAKES = {
    "last_step": "it looks at the last step only; locked on means within the tolerances at every step of the "
                 "last window_s seconds",
    "position_only": "it ignores the heading; a robot within 1 m but facing the wrong way is not locked on",
    "window_in_steps": "it reads window_s as a number of steps; with a step of dt seconds the window holds "
                       "ceil(window_s / dt) steps",
    "whole_run": "it requires the tolerances over the whole run; only the last window_s seconds count",
}


def lock_on_cases() -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Runs ``(pos_err, head_err, dt)``: each separates the right definition from at least one mistake."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M

    good_p, good_h = 0.5 * LOCK_POSITION_M, 0.5 * LOCK_HEADING_RAD
    cases = []
    p, h = np.full(60, good_p), np.full(60, good_h)
    p[50] = 3.0  # off 10 s before the end: not locked (last_step says locked)
    cases.append((p, h.copy(), 1.0))
    p, h = np.full(60, good_p), np.full(60, good_h)
    h[-5:] = 3 * LOCK_HEADING_RAD  # heading off at the end (position_only says locked)
    cases.append((p, h, 1.0))
    p, h = np.full(120, good_p), np.full(120, good_h)
    p[90] = 3.0  # dt = 0.5 s: step 90 is 15 s before the end, inside the 20 s window (20 steps: outside)
    cases.append((p, h, 0.5))
    p, h = np.full(60, good_p), np.full(60, good_h)
    p[:10] = 50.0  # lost at the start, locked at the end (whole_run says not locked)
    cases.append((p, h, 1.0))
    return cases


def lock_on_reference(pos_err: np.ndarray, head_err: np.ndarray, dt: float, window_s: float = 20.0,
                      mistake: str | None = None) -> bool:
    """:func:`pfcourse.metrics.locked_on`, or a mistake of :data:`LOCK_MISTAKES`."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M, locked_on

    ok = (pos_err < LOCK_POSITION_M) & (head_err < LOCK_HEADING_RAD)
    if mistake == "last_step":
        return bool(ok[-1])
    if mistake == "position_only":
        return locked_on(pos_err, np.zeros_like(head_err), dt, window_s)
    if mistake == "window_in_steps":
        return bool(np.all(ok[-int(window_s):]))
    if mistake == "whole_run":
        return bool(np.all(ok))
    return locked_on(pos_err, head_err, dt, window_s)


def check_lock_on(fn: Callable) -> CheckReport:
    """Check a student's ``fn(pos_err, head_err, dt, window_s) -> bool`` against
    :func:`pfcourse.metrics.locked_on` on :func:`lock_on_cases`; the mistakes of :data:`LOCK_MISTAKES` are named."""
    report = CheckReport("locked on")
    answers = []
    for pos, head, dt in lock_on_cases():
        answer = _answer(report, lambda: fn(pos.copy(), head.copy(), dt, 20.0), "fn(pos_err, head_err, dt, window_s)",
                         "return True or False")
        if answer is None:
            return report
        if not isinstance(answer, (bool, np.bool_)):
            report.problems.append(f"the answer {answer!r} is not True or False: return one verdict per run")
            return report
        answers.append(bool(answer))

    def fits(mistake: str | None) -> bool:
        return answers == [lock_on_reference(p, h, dt, 20.0, mistake) for p, h, dt in lock_on_cases()]

    if _settled(report, fits, LOCK_MISTAKES):
        return report
    wrong = next(i for i, (a, (p, h, dt)) in enumerate(zip(answers, lock_on_cases())) if a != lock_on_reference(p, h, dt))
    report.problems.append(f"run {wrong + 1} of the checker's runs gets the wrong verdict: within 1 m and 5 degrees "
                           "(strictly) at every step of the last ceil(window_s / dt) steps")
    return report


# --- chapter 20: what common random numbers buy -------------------------------------------------------
#: Two settings' errors on the same 40 runs (the first run by run correlated with the second, as the
#: settings of a study with common random numbers are).
def _paired_case(seed: int = 17, runs: int = 40) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    world = rng.gamma(4.0, 0.1, runs)  # what each simulated world makes hard, shared by both settings
    return world + rng.normal(0.0, 0.05, runs), 1.05 * world + rng.normal(0.0, 0.05, runs)


PAIRED_CASE = _paired_case()


PAIRED_MISTAKES = {
    "ddof0": "it uses the population standard deviation (np.std's default, ddof=0); the sample standard "
             "deviation divides by n - 1 (ddof=1)",
    "over_n": "it divides the standard deviation by n instead of sqrt(n): the standard error of a mean is s / sqrt(n)",
    "unpaired_sum": "its unpaired standard error adds the standard deviations, (s_a + s_b) / sqrt(n); independent "
                    "errors add their variances: sqrt((s_a^2 + s_b^2) / n)",
    "paired_as_unpaired": "its paired standard error ignores the pairing (it is the unpaired one); pair the runs: "
                          "the standard deviation of the differences a_r - b_r, over sqrt(n)",
}


def paired_standard_errors(a: np.ndarray, b: np.ndarray, mistake: str | None = None) -> tuple[float, float]:
    """Standard errors of ``mean(a) - mean(b)``: paired ``sd(a - b) / sqrt(n)``, and as if the runs were
    independent, ``sqrt((sd(a)^2 + sd(b)^2) / n)`` (sample standard deviations, ``ddof=1``). ``mistake`` (a key
    of :data:`PAIRED_MISTAKES`) computes it instead."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n, ddof = len(a), 0 if mistake == "ddof0" else 1
    root = n if mistake == "over_n" else np.sqrt(n)
    sa, sb, sd = a.std(ddof=ddof), b.std(ddof=ddof), (a - b).std(ddof=ddof)
    unpaired = (sa + sb) / root if mistake == "unpaired_sum" else np.sqrt(sa**2 + sb**2) / root
    paired = unpaired if mistake == "paired_as_unpaired" else sd / root
    return float(paired), float(unpaired)


def check_paired_se(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(a, b) -> (paired_se, unpaired_se)`` on :data:`PAIRED_CASE` against
    :func:`paired_standard_errors`; the mistakes of :data:`PAIRED_MISTAKES` are named."""
    report = CheckReport("paired and unpaired standard errors")
    a, b = PAIRED_CASE
    answer = _answer(report, lambda: fn(a.copy(), b.copy()), "fn(a, b)", "return (paired_se, unpaired_se)")
    if answer is None:
        return report
    try:
        paired, unpaired = (float(v) for v in answer)
    except (TypeError, ValueError):
        report.problems.append("the answer is not two numbers: return (paired_se, unpaired_se)")
        return report

    def fits(mistake: str | None) -> bool:
        return bool(np.allclose([paired, unpaired], paired_standard_errors(a, b, mistake), rtol=rtol))

    if _settled(report, fits, PAIRED_MISTAKES):
        return report
    if paired > unpaired:
        report.problems.append("the paired standard error is larger than the unpaired one, although the runs are "
                               "strongly correlated: pair a_r with b_r of the same run")
        return report
    report.problems.append("the values differ from sd(a - b) / sqrt(n) and sqrt((sd(a)^2 + sd(b)^2) / n) with "
                           "sample standard deviations")
    return report
