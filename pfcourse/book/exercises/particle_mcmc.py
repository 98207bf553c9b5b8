"""The checked exercise of the chapter on particle MCMC: ancestor sampling for a model that remembers two steps.

:func:`check_ancestor_index` - ``fn(log_W, past, future, a, b, s, rng) -> j``: one draw of the reference
particle's ancestor in conditional SMC with ancestor sampling for the second-order autoregression
``x_k = a x_{k-1} + b x_{k-2} + s v_k`` (``v_k ~ N(0, 1)``), whose particles carry their last two states
(``past[j] = (x_{k-1}^j, x_{k-2}^j)``) and whose reference continues with ``future = (x'_k, x'_{k+1}, ...)``.
The chapter prints the step for a Markov model, ``P(j) ∝ W_j f(x'_k | x_{k-1}^j)``; here the reference's
next TWO states depend on the ancestor (Lindsten, Jordan and Schön 2014, non-Markovian models):

    ``P(j) ∝ W_j N(x'_k; a x_{k-1}^j + b x_{k-2}^j, s^2) N(x'_{k+1}; a x'_k + b x_{k-1}^j, s^2)``,

the second factor absent at the last step (``future`` of length 1); every later factor of the grafted path is
the same for every ``j`` and cancels. Checked on the frequencies of many draws (a chi-square test against the
exact probabilities); the typical mistakes of :data:`ANCESTOR_MISTAKES` are named when their frequencies fit
instead (the chapter's one-step formula copied among them), the last step is checked on its own, log-weights
near ``-1000`` (not normalised, as the statement allows) must not underflow, and the draws must come from the
generator given (NumPy's global state untouched, same seed same draws, another seed other draws).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport, _answer
from pfcourse.book.exercises.part1 import _seed_problem

#: The case: a damped oscillation (``a = 1.6``, ``b = -0.8``: roots of modulus 0.89), noise ``s = 0.5``; six
#: particles of step k - 1 (row j: ``x_{k-1}^j, x_{k-2}^j``; row 0 the reference's own past), their
#: normalised weights, and the reference's states from step k on. Chosen so that 3000 draws tell every
#: mistake of :data:`ANCESTOR_MISTAKES` from the exact probabilities and from each other (chi-square
#: noncentrality at least 160, ``tests/test_exercise_particle_mcmc.py``), and so that the most probable
#: ancestor (1) is not the reference's own past (0).
ANCESTOR_CASE = {
    "log_W": np.log([0.15, 0.2, 0.1, 0.25, 0.1, 0.2]),
    "past": np.array([[0.8, 0.2], [1.1, 0.9], [0.3, -0.4], [0.5, 0.9], [1.3, 0.4], [0.9, 1.2]]),
    "future": np.array([1.2, 1.0, 0.5, 0.1]),
    "a": 1.6,
    "b": -0.8,
    "s": 0.5,
}
N_DRAWS, LAST_DRAWS, LEVEL = 3000, 1500, 1e-4
#: The sentence for an answer that fails only on log-weights near -1000 (which the statement allows: they need
#: not be normalised): it exponentiated before normalising.
UNDERFLOW = ("it exponentiates before normalising: the log-weights need not be normalised, and with log-weights "
             "near -1000 exp gives 0 for every particle (0 / 0 is NaN); normalise in the log domain (subtract the "
             "largest log term, or logsumexp) before exp")


def ancestor_probabilities(log_W, past, future, a, b, s, mistake: str | None = None) -> np.ndarray:
    """``P(j)`` of ancestor sampling for the second-order autoregression (module docstring), or what a mistake
    of :data:`ANCESTOR_MISTAKES` draws from."""
    log_W, past, future = np.asarray(log_W, float), np.asarray(past, float), np.atleast_1d(np.asarray(future, float))
    if mistake == "own_past":
        return np.eye(len(log_W))[0]
    x1, x2 = (past[:, 1], past[:, 0]) if mistake == "swapped" else (past[:, 0], past[:, 1])
    var = {"variance": s, "no_half": s ** 2 / 2}.get(mistake, s ** 2)
    first = -0.5 * (future[0] - a * x1 - b * x2) ** 2 / var
    second = np.zeros_like(first)
    if len(future) > 1:
        second = -0.5 * (future[1] - a * future[0] - b * (x2 if mistake == "second_lag" else x1)) ** 2 / var
    terms = {"markov": log_W + first, "weights": log_W, "no_weights": first + second}.get(
        mistake, log_W + first + second)
    return np.exp(terms - logsumexp(terms))


ANCESTOR_MISTAKES = {
    "markov": "it scores only the move to x'_k, the chapter's one-step formula; in this model x'_k+1 = a x'_k "
              "+ b x_k-1 + s v also depends on the ancestor's x_k-1^j, so the factor N(x'_k+1; a x'_k + b "
              "x_k-1^j, s^2) belongs to the weight too",
    "weights": "it draws by the weights W_j alone; ancestor sampling also asks how likely each particle's past "
               "is to lead to the reference's future",
    "no_weights": "it draws by the transition densities alone; the weights W_j of step k - 1 are the other "
                  "factor (an unlikely particle is an unlikely ancestor)",
    "swapped": "it reads past[j] as (x_k-2, x_k-1); row j holds (x_k-1^j, x_k-2^j), the newer state first",
    "second_lag": "its second factor uses x_k-2^j; x'_k+1 = a x'_k + b x_k-1 + s v, so the ancestor enters "
                  "it through x_k-1^j",
    "variance": "it divides the squared residuals by 2 s; s is the noise's standard deviation, so each "
                "log-density is -(residual)^2 / (2 s^2)",
    "no_half": "its log-densities are -(residual / s)^2, without the factor 1/2: the log of the Gaussian density "
               "N(r; 0, s^2) is -r^2 / (2 s^2) up to a constant, and without the 1/2 every factor is squared",
    "own_past": "it always returns 0, the reference's own past, as a stacked state (x_k, x_k-1) does: its "
                "transition copies x_k-1 exactly, a density that is zero for every other particle, so ancestor "
                "sampling is switched off and, as in conditional SMC without it, the early path barely moves; "
                "score each particle by the reference's next two states instead",
}


def _call(fn: Callable, case: dict, rng: np.random.Generator) -> object:
    return fn(case["log_W"].copy(), case["past"].copy(), case["future"].copy(), case["a"], case["b"], case["s"],
              rng)


def _draws(report: CheckReport, fn: Callable, case: dict, rng: np.random.Generator, n: int) -> np.ndarray | None:
    """``n`` draws of ``fn`` on ``case`` from ``rng``, each an integer index in range, or ``None`` after reporting."""
    size = len(case["past"])
    out = np.empty(n, dtype=int)
    for t in range(n):
        j = _answer(report, lambda: _call(fn, case, rng), "fn(log_W, past, future, a, b, s, rng)",
                    "return the drawn index j")
        if j is None:
            return None
        if isinstance(j, (bool, np.bool_)) or not isinstance(j, (int, np.integer)) or not 0 <= j < size:
            report.problems.append(f"the answer {j!r} is not an integer index in [0, {size}): return one ancestor j, "
                                   "e.g. rng.choice(len(past), p=probabilities)")
            return None
        out[t] = j
    return out


def _fits(counts: np.ndarray, p: np.ndarray) -> bool:
    """Whether ``counts`` are draws from ``p`` (chi-square test at :data:`LEVEL`; a count where ``p`` is 0 fails)."""
    expected = counts.sum() * p
    if np.any((counts > 0) & (expected < 1e-9)):
        return False
    keep = expected >= 1e-9
    return stats.chisquare(counts[keep], expected[keep] * counts[keep].sum() / expected[keep].sum()).pvalue > LEVEL


def check_ancestor_index(fn: Callable) -> CheckReport:
    """Check ``fn(log_W, past, future, a, b, s, rng) -> j`` (module docstring)."""
    state = np.random.get_state()
    try:
        return _check_ancestor_index(fn, state)
    finally:
        np.random.set_state(state)


def _check_ancestor_index(fn: Callable, state: tuple) -> CheckReport:
    report = CheckReport("ancestor sampling, two steps of memory")
    case, size = ANCESTOR_CASE, len(ANCESTOR_CASE["past"])
    exact = ancestor_probabilities(**case)
    first = []
    for seed in (1, 1, 2):
        first.append(_draws(report, fn, case, np.random.default_rng(seed), 20))
        if first[-1] is None:
            return report
    for index, why in ((0, ANCESTOR_MISTAKES["own_past"]),
                       (int(np.argmax(exact)), "it returns the same index every time: the ancestor must be drawn "
                                               "at random (with rng), not chosen as the most probable one")):
        if np.all(first[0] == index) and np.all(first[2] == index):
            report.problems.append(why)
            return report
    problem = _seed_problem(state, (first[0],), (first[1],), (first[2],), "ancestors",
                            "rng.choice(..., p=...) or rng.random()")
    if problem:
        report.problems.append(problem)
        return report
    draws = _draws(report, fn, case, np.random.default_rng(2026), N_DRAWS)
    if draws is None:
        return report
    counts = np.bincount(draws, minlength=size)
    if not _fits(counts, exact):
        for mistake, why in ANCESTOR_MISTAKES.items():
            if _fits(counts, ancestor_probabilities(**case, mistake=mistake)):
                report.problems.append(f"the draws follow a known mistake: {why}")
                return report
        share = ", ".join(f"{c / N_DRAWS:.2f}" for c in counts)
        want = ", ".join(f"{p:.2f}" for p in exact)
        report.problems.append(f"over {N_DRAWS} draws the ancestors' shares are {share}, not {want}: draw j with "
                               "probability proportional to W_j times the density of the reference's states that "
                               "depend on particle j's past")
        return report
    last = {**case, "future": case["future"][:1]}
    draws = _draws(report, fn, last, np.random.default_rng(7), LAST_DRAWS)
    if draws is None:
        report.problems[-1] += (" (at the last step k = T, where future holds x'_T alone: no x'_k+1 follows, so "
                                "the second factor is absent)")
        return report
    if not _fits(np.bincount(draws, minlength=size), ancestor_probabilities(**last)):
        report.problems.append("at the last step k = T (future holds x'_T alone) the draws go wrong: no x'_k+1 "
                               "follows there, so only W_j N(x'_T; a x_T-1^j + b x_T-2^j, s^2) remains")
        return report
    tiny = {**case, "log_W": case["log_W"] - 1000.0}
    draws = _draws(report, fn, tiny, np.random.default_rng(11), 600)
    if draws is None:
        report.problems.append(f"{UNDERFLOW} ({report.problems.pop()})")
        return report
    if not _fits(np.bincount(draws, minlength=size), exact):
        report.problems.append(f"{UNDERFLOW} (the draws then follow other probabilities)")
    return report
