"""Checkers of Part V (learning and smoothing: chapters 22-23)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport, _answer, _settled, _shaped


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


#: The second likelihood exercise: the fully adapted filter on a scalar linear-Gaussian model,
#: ``x_0 ~ N(0, 1)``, ``x_k = a x_{k-1} + q v_k``, ``z_k = x_k + r w_k`` (``q``, ``r`` standard deviations),
#: 40 readings simulated with seed 11. The reading is less informative than the move (``r > q``), so that
#: ``p(z_k | x_(k-1))`` varies over the cloud and a filter that drops the weights is biased, and ``r != r^2``,
#: so that a variance written as ``r`` is seen.
ADAPTED_A, ADAPTED_Q, ADAPTED_R, ADAPTED_STEPS, ADAPTED_SEED = 0.9, 1.0, 1.5, 40, 11

ADAPTED_MISTAKES = {
    "bootstrap": ("your estimate is unbiased but as noisy as a bootstrap filter's: the fully adapted filter "
                  "weights x_(k-1)^i by p(z_k | x_(k-1)^i) = N(z_k; a x_(k-1)^i, q^2 + r^2) BEFORE it moves them, "
                  "then moves them from p(x_k | x_(k-1)^i, z_k)"),
    "log_sum": ("your log-likelihood is about K log N too large: each step's factor is the MEAN of the weights "
                "p(z_k | x_(k-1)^i), logsumexp(log w) - log N, not their sum"),
    "mean_log": ("your log-likelihood is the mean of the log-weights, below the log of the mean weight "
                 "(Jensen): each step adds logsumexp(log w) - log N"),
    "q_only": ("your weights use the variance q^2 of the move alone: the reading z_k = a x_(k-1) + q v + r w "
               "has variance q^2 + r^2 given x_(k-1)"),
    "r_not_squared": ("your weights use the variance q^2 + r: r is a standard deviation, so the reading has "
                      "variance q^2 + r^2 given x_(k-1)"),
    "r_only": ("your weights use the variance r^2 of the reading given x_k, the bootstrap's: given x_(k-1) the "
               "reading z_k = a x_(k-1) + q v + r w also carries the move's noise, so its variance is q^2 + r^2"),
    "prior_move": ("your particles move from the transition N(a x, q^2): after weighting by p(z_k | x_(k-1)) "
                   "they must move from p(x_k | x_(k-1), z_k), the Gaussian of variance s^2 = 1 / (1/q^2 + "
                   "1/r^2) and mean s^2 (a x_(k-1) / q^2 + z_k / r^2)"),
    "sd_as_var": ("your move draws with standard deviation s^2 = 1 / (1/q^2 + 1/r^2), which is the variance: "
                  "multiply the standard normals by s = sqrt(s^2)"),
    "no_resampling": ("your filter never resamples, and its factors average the weights with 1/N: the "
                      "particles that predict z_k badly keep counting equally, so resample by the weights "
                      "p(z_k | x_(k-1)^i) before the move (each factor is then the mean weight)"),
}


def adapted_data() -> np.ndarray:
    """The readings ``z_1..z_K`` of the fully adapted exercise."""
    rng = np.random.default_rng(ADAPTED_SEED)
    x, z = rng.standard_normal(), np.empty(ADAPTED_STEPS)
    for k in range(ADAPTED_STEPS):
        x = ADAPTED_A * x + ADAPTED_Q * rng.standard_normal()
        z[k] = x + ADAPTED_R * rng.standard_normal()
    return z


def scalar_kalman_log_likelihood(z: np.ndarray, a: float, q: float, r: float) -> float:
    """The exact ``log p(z_1..z_K)`` of the scalar model, ``x_0 ~ N(0, 1)``."""
    m, p, total = 0.0, 1.0, 0.0
    for zk in z:
        m, p = a * m, a * a * p + q * q
        s = p + r * r
        total += -0.5 * (np.log(2 * np.pi * s) + (zk - m) ** 2 / s)
        m, p = m + p / s * (zk - m), p - p * p / s
    return float(total)


def adapted_log_likelihood(z: np.ndarray, n: int, rng: np.random.Generator, a: float, q: float, r: float,
                           mistake: str | None = None) -> float:
    """The reference: ``log p^(z_1..z_K)`` of the fully adapted filter (multinomial resampling at every
    step); ``mistake`` (a key of :data:`ADAPTED_MISTAKES`) computes that mistake instead."""
    x = rng.standard_normal(n)
    s2 = 1.0 / (1.0 / q**2 + 1.0 / r**2)
    total = 0.0
    for zk in z:
        if mistake == "bootstrap":
            x = a * x + q * rng.standard_normal(n)
            var = np.full(n, r * r)
            centre = x
        else:
            variances = {"q_only": q * q, "r_not_squared": q * q + r, "r_only": r * r}
            var = np.full(n, variances.get(mistake, q * q + r * r))
            centre = a * x
        log_w = -0.5 * (np.log(2 * np.pi * var) + (zk - centre) ** 2 / var)
        if mistake == "mean_log":
            total += float(np.mean(log_w))
        else:
            total += float(logsumexp(log_w)) - (0.0 if mistake == "log_sum" else np.log(n))
        if mistake != "no_resampling":
            x = x[rng.choice(n, size=n, p=np.exp(log_w - logsumexp(log_w)))]
        if mistake == "prior_move":
            x = a * x + q * rng.standard_normal(n)
        elif mistake != "bootstrap":
            sd = s2 if mistake == "sd_as_var" else np.sqrt(s2)
            x = s2 * (a * x / q**2 + zk / r**2) + sd * rng.standard_normal(n)
    return total


#: Runs of the adapted checker, and how far (in standard errors) a mistake's runs may lie from the answer's
#: in mean and in log-spread for the mistake to be named.
ADAPTED_RUNS, ADAPTED_MATCH_Z = 200, 4.0

#: The two variances r^2 and q^2 + r lie close at the checker's q = 1, r = 1.5 (2.25 and 2.5), so the runs of
#: those two mistakes match each other's there; the probe tells them apart with 40 runs at r = 0.5, where they
#: are 0.25 and 1.5.
ADAPTED_VARIANCE_PAIR, ADAPTED_PROBE_R, ADAPTED_PROBE_RUNS = ("r_only", "r_not_squared"), 0.5, 40


def check_adapted_likelihood(fn: Callable, n: int = 100, n_runs: int = ADAPTED_RUNS, seed: int = 0) -> CheckReport:
    """:func:`_check_adapted_likelihood`, leaving NumPy's global ``np.random`` state as it was."""
    saved = np.random.get_state()
    try:
        return _check_adapted_likelihood(fn, n, n_runs, seed)
    finally:
        np.random.set_state(saved)


def _adapted_match(ell: np.ndarray, ref: np.ndarray) -> float:
    """The squared distance, in standard errors, between two sets of runs: their means (standard error of
    the difference) and the logs of their spreads (standard error ``sqrt(1 / (2 (n - 1)))`` for a near-Gaussian
    sample of each); about chi-square with 2 degrees of freedom when both come from one estimator."""
    d_mean = (ell.mean() - ref.mean()) / np.sqrt(ell.var(ddof=1) / ell.size + ref.var(ddof=1) / ref.size)
    se_log_spread = np.sqrt(1 / (2 * (ell.size - 1)) + 1 / (2 * (ref.size - 1)))
    d_spread = np.log(ell.std(ddof=1) / ref.std(ddof=1)) / se_log_spread
    return float(d_mean**2 + d_spread**2)


def _adapted_variance_probe(fn: Callable, z: np.ndarray, n: int, seed: int) -> str | None:
    """Which of :data:`ADAPTED_VARIANCE_PAIR` the answer computes: its runs at ``r = ADAPTED_PROBE_R`` (same
    readings, ``ADAPTED_PROBE_RUNS`` runs) against each mistake's there, the nearest by :func:`_adapted_match`
    when within ``ADAPTED_MATCH_Z``; ``None`` when neither is."""
    args = (ADAPTED_A, ADAPTED_Q, ADAPTED_PROBE_R)
    try:
        runs = np.array([float(fn(z.copy(), n, np.random.default_rng(seed + run), *args))
                         for run in range(ADAPTED_PROBE_RUNS)])
    except Exception:  # noqa: BLE001 - an answer that fails at another r is named by the main check's sentence
        return None
    if not np.all(np.isfinite(runs)):
        return None
    distances = {m: _adapted_match(runs, np.array([adapted_log_likelihood(z, n, np.random.default_rng(60_000 + r),
                                                                          *args, m)
                                                    for r in range(ADAPTED_PROBE_RUNS)]))
                 for m in ADAPTED_VARIANCE_PAIR}
    nearest = min(distances, key=distances.get)
    return nearest if distances[nearest] <= ADAPTED_MATCH_Z**2 else None


def _check_adapted_likelihood(fn: Callable, n: int, n_runs: int, seed: int) -> CheckReport:
    """Check ``fn(z, n, rng, a, q, r) -> float``, the fully adapted filter's ``log p^(z_1..z_K)``.

    In turn: one finite float; draws from the generator it is given; unbiasedness against the Kalman
    likelihood over ``n_runs`` seeded runs, ``mean + var / 2 - log p`` within 4 standard errors plus 0.05
    (``E[p^] = p`` for a near-Gaussian ``log p^``); a spread at most 1.3 times the reference's (a bootstrap
    filter's is about 1.7 times on these data). A biased answer is compared with each mistake of
    :data:`ADAPTED_MISTAKES` (``n_runs`` runs of :func:`adapted_log_likelihood` with that mistake): the
    nearest is named only when its runs match the answer's in mean AND in spread (:func:`_adapted_match`
    below ``ADAPTED_MATCH_Z ** 2``; the variances r^2 and q^2 + r, near each other here, are told apart by
    :func:`_adapted_variance_probe`), else the report says how far the answer is from the likelihood."""
    from pfcourse.book.exercises.part1 import _generator_problem

    report = CheckReport("check_adapted_likelihood")
    z = adapted_data()
    args = (ADAPTED_A, ADAPTED_Q, ADAPTED_R)
    answers = []
    for run in range(n_runs):
        answer = _answer(report, lambda: fn(z.copy(), n, np.random.default_rng(seed + run), *args),
                         "fn(z, n, rng, a, q, r)", "return log p^(z_1..z_K), one float")
        if answer is None:
            return report
        try:
            answers.append(float(answer))
        except (TypeError, ValueError):
            report.problems.append(f"the function returned {type(answer).__name__}, not one float")
            return report
        if not np.isfinite(answers[-1]):
            report.problems.append("the answer is NaN or infinite: compute the weights in the log domain and "
                                   "sum them with logsumexp")
            return report
    problem = _generator_problem(lambda rng: fn(z.copy(), 20, rng, *args), lambda u, v: float(u) == float(v),
                                 what="estimate")
    if problem:
        report.problems.append(problem)
        return report
    ell = np.array(answers)
    exact = scalar_kalman_log_likelihood(z, *args)
    se = ell.std(ddof=1) / np.sqrt(n_runs)

    def reference(mistake: str | None) -> np.ndarray:
        return np.array([adapted_log_likelihood(z, n, np.random.default_rng(50_000 + r), *args, mistake)
                         for r in range(n_runs)])

    gap = ell.mean() + ell.var(ddof=1) / 2 - exact
    if abs(gap) > 4 * se + 0.05:
        distances = {m: _adapted_match(ell, reference(m)) for m in ADAPTED_MISTAKES if m != "bootstrap"}
        nearest = min(distances, key=distances.get)
        if nearest in ADAPTED_VARIANCE_PAIR and distances[nearest] <= ADAPTED_MATCH_Z**2:
            nearest = _adapted_variance_probe(fn, z, n, seed)
        if nearest is not None and distances[nearest] <= ADAPTED_MATCH_Z**2:
            report.problems.append(ADAPTED_MISTAKES[nearest])
            return report
        report.problems.append(f"your log-likelihood averages {ell.mean():.2f} (spread {ell.std(ddof=1):.2f}) "
                               f"where log p(z) = {exact:.2f}: mean + var/2 is {gap:+.2f} nats off, so p^ is not "
                               "unbiased for p(z), the product over the steps of the mean weight "
                               "p(z_k | x_(k-1)^i) with the cloud resampled by those weights")
        return report
    if ell.std(ddof=1) > 1.3 * reference(None).std(ddof=1):
        report.problems.append(ADAPTED_MISTAKES["bootstrap"])
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


# ---------------------------------------------------------------- chapter 27: the fixed-lag smoother
FIXED_LAG_MISTAKES = {
    "filter_weights": ("it weights the ancestors with the filter weights W_k of step k: the ancestors at k of "
                       "the particles of step t = k + L carry THEIR weights, W_t^i"),
    "no_ancestry": ("it averages the particles of step k + L themselves: follow each one's ancestor indices "
                    "back to step k and average those ancestors' positions"),
    "one_step_short": ("it follows the ancestor indices one step too few: from step t, apply ancestors[t], "
                       "ancestors[t - 1], ..., ancestors[k + 1] (ancestors[j] points from step j to step j - 1)"),
    "shifted_ancestors": ("it applies ancestors[j - 1] where ancestors[j] belongs: ancestors[j, i] is the index "
                          "at step j - 1 of the parent of particle i of step j"),
    "end_not_clipped": ("its last L means are the filter's: near the end use t = min(k + L, T), the last step, "
                        "not the filter at k"),
    "from_end": ("it traces every step back from the last step T, the whole run's ancestral lines: each step k "
                 "has its own end t = min(k + L, T), L steps later"),
}


def fixed_lag_reference(particles: np.ndarray, weights: np.ndarray, ancestors: np.ndarray, lag: int,
                        mistake: str | None = None) -> np.ndarray:
    """``m_{k|t} = sum_i W_t^i x_k^{a(i, t -> k)}``, ``t = min(k + L, T)`` (``pfcourse.smoothing.
    fixed_lag_means``); ``mistake`` (a key of :data:`FIXED_LAG_MISTAKES`) computes that mistake instead."""
    n_steps, n, _ = particles.shape
    means = np.empty((n_steps, particles.shape[2]))
    for k in range(n_steps):
        t = k + lag if mistake == "end_not_clipped" else min(k + lag, n_steps - 1)
        if mistake == "from_end":
            t = n_steps - 1
        if t > n_steps - 1:
            means[k] = weights[k] @ particles[k]
            continue
        idx = np.arange(n)
        stop = k + 1 if mistake == "one_step_short" else k
        for j in range(t, stop, -1):
            idx = ancestors[j - 1 if mistake == "shifted_ancestors" else j][idx]
        at = t if mistake == "no_ancestry" else k
        w = weights[k] if mistake == "filter_weights" else weights[t]
        means[k] = w @ particles[at][idx if mistake != "no_ancestry" else np.arange(n)]
    return means


def _fixed_lag_case(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eight stored clouds of 12 particles in 2-D, random weights, random ancestor indices."""
    rng = np.random.default_rng(seed)
    particles = rng.normal(size=(8, 12, 2)) + np.arange(8)[:, None, None]
    weights = rng.dirichlet(np.ones(12), size=8)
    ancestors = rng.integers(0, 12, size=(8, 12))
    ancestors[0] = np.arange(12)
    return particles, weights, ancestors


def check_fixed_lag(fn: Callable, lag: int = 3, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(particles, weights, ancestors, lag) -> (T+1, d)``, the fixed-lag smoothed means, against
    :func:`fixed_lag_reference` on :func:`_fixed_lag_case` (lag 3 and lag 0); a wrong answer is compared with
    each mistake of :data:`FIXED_LAG_MISTAKES`, and the one it computes is named. The function draws no
    random numbers, so there is no generator to check."""
    report = CheckReport("fixed-lag smoother")
    particles, weights, ancestors = _fixed_lag_case()
    for case_lag in (lag, 0):
        answer = _answer(report, lambda: fn(particles.copy(), weights.copy(), ancestors.copy(), case_lag),
                         "fn(particles, weights, ancestors, lag)", "return the smoothed means, shape (T+1, d)")
        if answer is None:
            return report
        answer = np.asarray(answer, dtype=float)
        if answer.shape != (particles.shape[0], particles.shape[2]):
            report.problems.append(f"the answer has shape {answer.shape}, not {(particles.shape[0], particles.shape[2])}:"
                                   " one mean per step, with the state's dimension")
            return report
        if np.allclose(answer, fixed_lag_reference(particles, weights, ancestors, case_lag), rtol=rtol, atol=1e-12):
            continue
        for mistake, why in FIXED_LAG_MISTAKES.items():
            if np.allclose(answer, fixed_lag_reference(particles, weights, ancestors, case_lag, mistake),
                           rtol=rtol, atol=1e-12):
                report.problems.append(f"with lag {case_lag}: {why}")
                return report
        k = int(np.argmax(np.abs(answer - fixed_lag_reference(particles, weights, ancestors, case_lag)).sum(axis=1)))
        report.problems.append(f"with lag {case_lag} the mean of step {k} is {np.round(answer[k], 4)}, not "
                               f"{np.round(fixed_lag_reference(particles, weights, ancestors, case_lag)[k], 4)}: "
                               "trace the particles of step min(k + L, T) back to step k and weight them by W_t")
        return report
    return report
