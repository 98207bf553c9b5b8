"""Checkers of Part V (learning and smoothing: chapters 22-23)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.special import logsumexp

from pfcourse.exercises.checking import CheckReport, _answer, _settled, _shaped


# ---------------------------------------------------------------- chapter 25: the likelihood estimator
ESTIMATOR_MISTAKES = {
    "forgot_previous_weights": "it averages the new weights with 1/N instead of the previous weights W_(k-1): "
                               "after a step without resampling the particles do not count equally, so "
                               "p^(z_k | z_(1:k-1)) = sum_i W_(k-1)^i w_k^i",
    "mean_of_logs": "it averages the log-weights instead of the weights: the mean of log w is below the log of "
                    "the mean (Jensen), so the estimate is too low and no longer unbiased; take the logsumexp of "
                    "log W_(k-1) + log w_k",
    "plain_mean_of_logs": "it averages the log-weights instead of the weights (and without the previous weights "
                          "W_(k-1)): the mean of log w is below the log of the mean (Jensen), so the estimate is "
                          "too low; take the logsumexp of log W_(k-1) + log w_k",
    "no_reset_after_resampling": "it keeps the weights W_k after a resampling: resampled particles carry equal "
                                 "weights 1/N (their copies already stand for W_k), so set log W = -log N "
                                 "whenever resampled[k] is true",
    "unnormalised_weights": "it carries the unnormalised weights W_(k-1) w_k to the next step: divide them by "
                            "their sum p^(z_k | z_(1:k-1)), else each factor counts the earlier ones again",
}


def likelihood_estimate(log_w: np.ndarray, resampled: np.ndarray, mistake: str | None = None) -> float:
    """``log p^(z_{1:K}) = sum_k log sum_i W_{k-1}^i w~_k^i`` from a filter's log-weights (Algorithm 25.1).

    ``log_w[k, i] = log w~_k^i`` (``0`` at a step without measurement), ``resampled[k]`` whether the cloud
    was resampled after step ``k`` (then ``W_k^i = 1/N``); ``W_{-1}^i = 1/N``, ``W_k^i = W_{k-1}^i w~_k^i /
    p^(z_k | z_{1:k-1})``.  ``mistake`` (a key of :data:`ESTIMATOR_MISTAKES`) computes that mistake instead.
    """
    log_w = np.asarray(log_w, dtype=float)
    n = log_w.shape[1]
    log_W, total = np.full(n, -np.log(n)), 0.0
    for k, row in enumerate(log_w):
        if mistake == "forgot_previous_weights":
            log_W = np.full(n, -np.log(n))
        a = log_W + row
        if mistake in ("mean_of_logs", "plain_mean_of_logs"):
            step = float(np.sum(np.exp(log_W) * row)) if mistake == "mean_of_logs" else float(np.mean(row))
        else:
            step = float(logsumexp(a))
        total += step
        log_W = a if mistake == "unnormalised_weights" else a - logsumexp(a)
        if resampled[k] and mistake != "no_reset_after_resampling":
            log_W = np.full(n, -np.log(n))
    return total


ESTIMATOR_RESAMPLED = np.array([False, True, False, False, True, False, False, True, False, False])


def check_likelihood_estimate(fn: Callable, n_particles: int = 8, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(log_w, resampled) -> float``, the log of the particle likelihood estimate.

    ``log_w`` (``(K, N)``) holds ``log w~_k^i`` of a filter's run and ``resampled`` (``(K,)``) whether the
    cloud was resampled after each step (:data:`ESTIMATOR_RESAMPLED`: some steps are, some are not, so the
    previous weights matter). The answer must equal :func:`likelihood_estimate` to ``rtol`` on ordinary
    log-weights and on log-weights near ``-1000`` (whose exponentials underflow); an answer that does not is
    compared with each mistake of :data:`ESTIMATOR_MISTAKES`, and the report names the one that fits.
    """
    report = CheckReport("likelihood estimator")
    log_w = np.random.default_rng(seed).normal(-2.0, 1.5, size=(ESTIMATOR_RESAMPLED.size, n_particles))
    answers = []
    for case in (log_w, log_w - 1000.0):
        answer = _answer(report, lambda: fn(case.copy(), ESTIMATOR_RESAMPLED.copy()), "fn(log_w, resampled)",
                         "compute and return log p^(z_1:K), one float")
        if answer is None:
            return report
        try:
            answers.append(float(answer))
        except (TypeError, ValueError):
            report.problems.append(f"the function returned {type(answer).__name__}, not one float: return the "
                                   "sum over the steps of log sum_i W_(k-1)^i w_k^i")
            return report

    def fits(mistake: str | None, case: int = 0) -> bool:
        shift = -1000.0 * case
        return bool(np.isclose(answers[case], likelihood_estimate(log_w + shift, ESTIMATOR_RESAMPLED, mistake),
                               rtol=rtol, atol=1e-9))

    if fits(None) and fits(None, 1):
        return report
    if fits(None):
        report.problems.append(f"with log-weights near -1000 the answer is {answers[1]:.6g}, not "
                               f"{likelihood_estimate(log_w - 1000.0, ESTIMATOR_RESAMPLED):.6g}: exp(-1000) "
                               "underflows to 0, so sum the weights in the log domain (scipy.special.logsumexp)")
        return report
    for mistake, why in ESTIMATOR_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your estimate matches a known mistake: {why}")
            return report
    report.problems.append(f"the answer is {answers[0]:.6g}, the estimate is "
                           f"{likelihood_estimate(log_w, ESTIMATOR_RESAMPLED):.6g}: add log sum_i W_(k-1)^i w_k^i "
                           "over the steps, with W normalised after each step and reset to 1/N after a resampling")
    return report


#: The smoothing exercise's case: a scalar AR(1) transition x_{k+1} = 0.9 x_k + w, w ~ N(0, 0.5),
#: five stored clouds of 30 particles (spread 1 about a drifting centre), random filter weights, and
#: random smoothed weights at step k + 1; the checked step is k = 2.
BACKWARD_K, BACKWARD_N, BACKWARD_STEPS = 2, 30, 5


BACKWARD_MISTAKES = {
    "no_filter_weight": "the filter weight W_k^i is missing in front of the sum: the smoothed weight is the "
                        "filter's weight times how well particle i predicts the smoothed cloud at k + 1",
    "wrong_axis": "the predictive density is summed over the wrong axis: for each particle j at k + 1 it is "
                  "sum_l W_k^l f(x_(k+1)^j | x_k^l), a sum over the particles at step k (the second index "
                  "of log_transition's matrix)",
    "wrong_time": "the transition is taken at the wrong time: the backward step from k + 1 to k needs "
                  "f(x_(k+1)^j | x_k^i) and the filter weights W_k of step k, not another step's",
}


def _backward_case(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, Callable]:
    rng = np.random.default_rng(seed)
    centres = np.cumsum(rng.normal(0, 0.5, BACKWARD_STEPS))
    particles = (centres[:, None] + rng.standard_normal((BACKWARD_STEPS, BACKWARD_N)))[:, :, None]
    weights = rng.dirichlet(np.ones(BACKWARD_N), BACKWARD_STEPS)
    smoothed_next = rng.dirichlet(np.ones(BACKWARD_N))

    def log_transition(new: np.ndarray, old: np.ndarray) -> np.ndarray:
        """``[log N(new_j; 0.9 old_i, 0.5)]_{j, i}``."""
        d = np.asarray(new, dtype=float)[:, 0][:, None] - 0.9 * np.asarray(old, dtype=float)[:, 0][None, :]
        return -0.5 * d**2 / 0.5 - 0.5 * np.log(2 * np.pi * 0.5)

    return particles, weights, smoothed_next, log_transition


def backward_weights(k: int, particles: np.ndarray, weights: np.ndarray, smoothed_next: np.ndarray,
                     log_transition: Callable, mistake: str | None = None) -> np.ndarray:
    """FFBSm's backward step, in the log domain:
    ``W_{k|K}^i = W_k^i sum_j W_{k+1|K}^j f(x_{k+1}^j | x_k^i) / sum_l W_k^l f(x_{k+1}^j | x_k^l)``;
    ``mistake`` (a key of :data:`BACKWARD_MISTAKES`) computes that mistake instead."""
    new, old, w = particles[k + 1], particles[k], weights[k]
    if mistake == "wrong_time":
        new, old, w = particles[k], particles[k - 1], weights[k - 1]
    log_f = np.asarray(log_transition(new, old), dtype=float)  # [j, i]
    with np.errstate(divide="ignore"):
        log_w, log_next = np.log(w), np.log(smoothed_next)
    if mistake == "wrong_axis":
        log_den = logsumexp(log_f + log_w[None, :], axis=0)[None, :]
    else:
        log_den = logsumexp(log_f + log_w[None, :], axis=1)[:, None]
    log_s = logsumexp(log_next[:, None] + log_f - log_den, axis=0)
    if mistake != "no_filter_weight":
        log_s = log_s + np.log(weights[k])
    return np.exp(log_s - logsumexp(log_s))


def check_backward_weights(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(k, particles, weights, smoothed_next, log_transition) -> (N,)``: FFBSm's smoothed weights
    ``W_{k|K}`` of one backward step (:func:`backward_weights`) on :func:`_backward_case`, to round-off; a
    wrong answer is compared with each mistake of :data:`BACKWARD_MISTAKES`, and the one it computes is named.
    ``particles`` is ``(K, N, 1)``, ``weights`` ``(K, N)``, ``smoothed_next`` ``(N,)`` the smoothed weights
    at ``k + 1``, and ``log_transition(new, old)`` the matrix ``[log f(new_j | old_i)]_{j, i}``."""
    report = CheckReport("FFBSm backward weights")
    particles, weights, smoothed_next, log_transition = _backward_case()
    k = BACKWARD_K
    answer = _answer(report, lambda: fn(k, particles.copy(), weights.copy(), smoothed_next.copy(), log_transition),
                     "fn(k, particles, weights, smoothed_next, log_transition)",
                     "compute the smoothed weights and return them, one per particle")
    if answer is None or not _shaped(report, answer, (BACKWARD_N,), "one smoothed weight per particle of step k"):
        return report
    answer = np.asarray(answer, dtype=float)
    if not np.all(np.isfinite(answer)) or np.any(answer < 0):
        report.problems.append("some weights are negative, NaN or infinite: compute them in the log domain "
                               "(logsumexp) and exponentiate at the end")
        return report
    if not np.isclose(answer.sum(), 1.0, rtol=1e-9):
        report.problems.append(f"the weights sum to {answer.sum():.6g}, not 1: normalise them (divide by their sum)")
        return report

    def fits(mistake: str | None) -> bool:
        return np.allclose(answer, backward_weights(k, particles, weights, smoothed_next, log_transition, mistake),
                           rtol=rtol, atol=1e-12)

    if _settled(report, fits, BACKWARD_MISTAKES):
        return report
    i = int(np.argmax(np.abs(answer - backward_weights(k, particles, weights, smoothed_next, log_transition))))
    report.problems.append(f"particle {i}'s smoothed weight is {answer[i]:.4g}, not "
                           f"{backward_weights(k, particles, weights, smoothed_next, log_transition)[i]:.4g}: "
                           "check the ratio f(x_(k+1)^j | x_k^i) / sum_l W_k^l f(x_(k+1)^j | x_k^l) and its "
                           "weighting by the smoothed weights W_(k+1|K)^j")
    return report
