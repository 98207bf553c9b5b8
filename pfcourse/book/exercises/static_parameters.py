"""The static-parameters chapter's exercise: the sufficient-statistic step for a process-noise scale.

Model of the exercise: a scalar random walk ``x_k = x_{k-1} + w_k``, ``w_k ~ N(0, theta)``, with
``theta ~ IG(a_0, b_0)`` unknown, read as ``z_k = x_k + v_k``, ``v_k ~ N(0, r)``, ``r`` known. Given
the path, ``theta ~ IG(a_0 + k / 2, b_0 + sum (x_j - x_{j-1})^2 / 2)``. One step of Storvik's filter,
for particles ``x`` with statistics ``(a, b_i)``: draw ``theta_i ~ IG(a, b_i)`` (``b_i / Gamma(a, 1)``),
move ``x_i' = x_i + sqrt(theta_i) eps_i``, weight ``log N(z; x_i', r)``, update ``a' = a + 1/2`` and
``b_i' = b_i + (x_i' - x_i)^2 / 2``. Marginally the move ``x_i' - x_i`` is ``sqrt(b_i / a)`` times a
Student t with ``2a`` degrees of freedom: the checker tests that law.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats

from pfcourse.book.exercises.checking import CheckReport, _answer, _shaped
from pfcourse.book.exercises.part1 import _seed_problem

#: the known measurement-noise variance of the exercise
STORVIK_R = 0.5
STORVIK_MISTAKES = {
    "a_whole": "the shape gains 1/2 per step (one squared move, half a degree of freedom), not 1",
    "no_half": "the scale gains half the squared move, (x' - x)^2 / 2: the 1/2 is missing",
    "measurement_residual": "b learns from the moves x' - x, which theta governs, not from the measurement "
                            "residuals z - x' (their variance is r, which is known)",
    "variance_as_sd": "the weight reads the variance r as a standard deviation: use sqrt(r)",
    "mean_theta": "every particle moves with the posterior mean b / (a - 1) instead of a draw theta_i ~ IG(a, b_i): "
                  "the parameter's uncertainty is lost and the moves are too light-tailed",
    "gamma": "theta was drawn from a gamma with rate b; the inverse gamma is b / Gamma(a, 1)",
    "theta_as_sd": "the move uses theta as a standard deviation: x' = x + sqrt(theta) eps",
    "gamma_scale": "theta was drawn as 1 / rng.gamma(a, b), but NumPy's second argument is a SCALE, so that is "
                   "1 / (b Gamma(a, 1)); IG(a, b) is b / Gamma(a, 1), i.e. b / rng.gamma(a, 1.0)",
    "one_theta": "one theta is drawn for every particle; each particle draws its own from IG(a, b_i)",
}


def storvik_case(n: int = 20000, seed: int = 11) -> tuple[np.ndarray, float, np.ndarray, float]:
    """``(x, a, b, z)``: particles, the shared shape, one scale per particle, a measurement."""
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, 1.0, n), 3.0, 1.0 + 2.0 * rng.random(n), 0.4


def storvik_step_reference(x, a, b, z, rng):
    """The reference step (module docstring): ``(x_new, a_new, b_new, log_w)``."""
    theta = b / rng.gamma(a, 1.0, x.shape)
    x_new = x + np.sqrt(theta) * rng.standard_normal(x.shape)
    log_w = stats.norm.logpdf(z, x_new, np.sqrt(STORVIK_R))
    return x_new, a + 0.5, b + (x_new - x) ** 2 / 2, log_w


def _move_law(mistake: str | None, a: float, b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draws of the move ``x' - x`` under the reference (``None``) or a mistake, one per particle."""
    e = rng.standard_normal(b.shape)
    if mistake == "mean_theta":
        return np.sqrt(b / (a - 1)) * e
    if mistake == "gamma":
        return np.sqrt(rng.gamma(a, 1.0 / b)) * e
    if mistake == "gamma_scale":
        return np.sqrt(1.0 / rng.gamma(a, b)) * e
    if mistake == "theta_as_sd":
        return b / rng.gamma(a, 1.0, b.shape) * e
    return np.sqrt(b / rng.gamma(a, 1.0, b.shape)) * e


def check_storvik_step(fn: Callable, p_min: float = 1e-3) -> CheckReport:
    """Check ``fn(x, a, b, z, rng) -> (x_new, a_new, b_new, log_w)``, one sufficient-statistic step.

    The generator (NumPy's global state untouched, same seed same answer, another seed another);
    ``a' = a + 1/2``; ``b' = b + (x' - x)^2 / 2`` on the student's own moves; the log-weights
    ``log N(z; x', r)`` up to a constant; and the law of the moves (Kolmogorov-Smirnov against the
    Student t, ``p >= p_min``), each typical mistake of :data:`STORVIK_MISTAKES` named."""
    report = CheckReport("storvik_step")
    x, a, b, z = storvik_case()
    n = x.size
    state = np.random.get_state()

    def call(seed):
        return fn(x.copy(), a, b.copy(), z, np.random.default_rng(seed))

    signature = "storvik_step(x, a, b, z, rng)"
    answer = _answer(report, lambda: call(1), signature, "return (x_new, a_new, b_new, log_w)")
    if answer is None:
        np.random.set_state(state)
        return report
    if not isinstance(answer, tuple) or len(answer) != 4:
        np.random.set_state(state)
        report.problems.append("return four things, (x_new, a_new, b_new, log_w), as a tuple")
        return report
    problem = _seed_problem(state, answer, call(1), call(2), "particles", "rng.gamma(...), rng.standard_normal(...)")
    if problem is not None:
        report.problems.append(problem)
        return report
    x_new, a_new, b_new, log_w = answer
    for value, what in ((x_new, "one new particle per particle"), (b_new, "one scale b per particle"),
                        (log_w, "one log-weight per particle")):
        if not _shaped(report, value, (n,), what):
            return report
    x_new, b_new, log_w = (np.asarray(v, dtype=float) for v in (x_new, b_new, log_w))
    if not np.isclose(float(a_new), a + 0.5):
        key = "a_whole" if np.isclose(float(a_new), a + 1.0) else None
        report.problems.append(f"your function computes a known mistake: {STORVIK_MISTAKES[key]}" if key else
                               f"a_new is {float(a_new)}, not a + 1/2 = {a + 0.5}: each step adds one squared move")
        return report
    move = x_new - x
    candidates = {None: b + move**2 / 2, "no_half": b + move**2, "measurement_residual": b + (z - x_new) ** 2 / 2}
    if not np.allclose(b_new, candidates[None], rtol=1e-10, atol=1e-12):
        for key in ("no_half", "measurement_residual"):
            if np.allclose(b_new, candidates[key], rtol=1e-10, atol=1e-12):
                report.problems.append(f"your function computes a known mistake: {STORVIK_MISTAKES[key]}")
                return report
        report.problems.append("b_new is not b + (x_new - x)^2 / 2: the scale adds half the squared move of each "
                               "particle")
        return report

    def same_up_to_constant(u, v):
        d = u - v
        return bool(np.all(np.isfinite(d)) and np.ptp(d) < 1e-8)

    if not same_up_to_constant(log_w, stats.norm.logpdf(z, x_new, np.sqrt(STORVIK_R))):
        if same_up_to_constant(log_w, stats.norm.logpdf(z, x_new, STORVIK_R)):
            report.problems.append(f"your function computes a known mistake: {STORVIK_MISTAKES['variance_as_sd']}")
        else:
            report.problems.append("the log-weights are not log N(z; x_new, r) (up to a constant): weight each "
                                   "moved particle by its measurement density")
        return report
    scaled = move / np.sqrt(b / a)
    if stats.kstest(scaled, stats.t(2 * a).cdf).pvalue >= p_min:
        return report
    reference_rng = np.random.default_rng(2026)
    fits = {key: stats.ks_2samp(move, _move_law(key, a, b, reference_rng)).pvalue
            for key in ("mean_theta", "gamma", "gamma_scale", "theta_as_sd")}
    # one theta for all: the moves are Gaussian with one variance, whatever b_i
    fits["one_theta"] = stats.kstest(move / move.std(), "norm").pvalue
    best = max(fits, key=fits.get)
    if fits[best] >= p_min:
        report.problems.append(f"your function computes a known mistake: {STORVIK_MISTAKES[best]}")
        return report
    report.problems.append("the moves x_new - x do not follow sqrt(theta_i) eps with theta_i ~ IG(a, b_i) "
                           "(Kolmogorov-Smirnov against the Student t they should make): check the draw of theta")
    return report
