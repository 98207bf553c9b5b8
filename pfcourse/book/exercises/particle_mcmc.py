"""The checked exercise of the chapter on particle MCMC: ancestor sampling with correlated process noise.

:func:`check_ancestor_index` - ``fn(log_W, x_prev, x_ref, F, Q, rng) -> j``: one draw of the reference
particle's ancestor in conditional SMC with ancestor sampling for the linear model
``x_k = F x_{k-1} + w_k``, ``w_k ~ N(0, Q)`` with a full (correlated) ``Q``:
``P(j) ∝ W_j exp(-(x_ref - F x_j)^T Q^{-1} (x_ref - F x_j) / 2)``.  The chapter prints the step for
a model that supplies its own transition density; here the reader writes that density.  Checked on
the frequencies of many draws (a chi-square test against the exact probabilities); the typical
mistakes of :data:`ANCESTOR_MISTAKES` are named when their frequencies fit instead, weights of
``e^{-1000}`` must not underflow, and the draws must come from the generator given (NumPy's global
state untouched, same seed same draws, another seed other draws).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport, _answer
from pfcourse.book.exercises.part1 import _seed_problem

#: The case: a constant-velocity state (position, velocity), time step 1, white-noise acceleration of
#: intensity 0.5 (so Q is correlated: Q = 0.5 [[1/3, 1/2], [1/2, 1]]); six particles of step k - 1,
#: their normalised weights and the reference state at step k. Chosen so that every mistake of
#: :data:`ANCESTOR_MISTAKES` gives probabilities a chi-square test over :data:`N_DRAWS` draws tells
#: from the exact ones (and from each other).
ANCESTOR_CASE = {
    "log_W": np.log([0.1, 0.25, 0.2, 0.15, 0.2, 0.1]),
    "x_prev": np.array([[0.0, 1.0], [0.6, 0.3], [1.2, -0.2], [-0.3, 1.6], [0.9, 0.9], [1.5, 0.2]]),
    "x_ref": np.array([1.4, 0.8]),
    "F": np.array([[1.0, 1.0], [0.0, 1.0]]),
    "Q": 0.5 * np.array([[1.0 / 3.0, 0.5], [0.5, 1.0]]),
}
N_DRAWS, LEVEL = 3000, 1e-4


def _quadratic(d: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``d_j^T M d_j`` for each row ``d_j`` of ``d``."""
    return np.einsum("ni,ij,nj->n", d, M, d)


def ancestor_probabilities(log_W, x_prev, x_ref, F, Q, mistake: str | None = None) -> np.ndarray:
    """``P(j) ∝ W_j N(x_ref; F x_j, Q)``, or what a mistake of :data:`ANCESTOR_MISTAKES` draws from."""
    log_W, x_prev = np.asarray(log_W, float), np.asarray(x_prev, float)
    x_ref, F, Q = np.asarray(x_ref, float), np.asarray(F, float), np.asarray(Q, float)
    Q_inv = np.linalg.inv(Q)
    d = x_ref - x_prev @ F.T
    transition = -0.5 * _quadratic(d, Q_inv)
    terms = {None: log_W + transition,
             "weights": log_W,
             "transition": transition,
             "diagonal": log_W - 0.5 * _quadratic(d, np.diag(1.0 / np.diag(Q))),
             "covariance": log_W - 0.5 * _quadratic(d, Q),
             "reversed": log_W - 0.5 * _quadratic(x_prev - x_ref @ F.T, Q_inv),
             "no_dynamics": log_W - 0.5 * _quadratic(x_ref - x_prev, Q_inv),
             "transposed": log_W - 0.5 * _quadratic(x_ref - x_prev @ F, Q_inv)}[mistake]
    return np.exp(terms - logsumexp(terms))


ANCESTOR_MISTAKES = {
    "weights": "it draws by the weights W_j alone; ancestor sampling also asks how likely each particle is to "
               "move to the reference, the factor N(x_ref; F x_j, Q)",
    "transition": "it draws by the transition density alone; the weights W_j of step k - 1 are the other factor "
                  "(an unlikely particle is an unlikely ancestor)",
    "diagonal": "it treats the noise components as independent (the diagonal of Q only); the position and "
                "velocity noise are correlated, so the density needs the full inverse Q^-1",
    "covariance": "it multiplies the residual by Q itself; the Gaussian exponent is -(1/2) d^T Q^-1 d, with the "
                  "inverse of the covariance",
    "reversed": "it evaluates the residual x_j - F x_ref, the old state predicted from the new one; the "
                "transition goes forward: d_j = x_ref - F x_j",
    "no_dynamics": "it compares x_ref with x_j itself; the reference moved from F x_j (the position advanced by "
                   "the velocity), so d_j = x_ref - F x_j",
    "transposed": "it computes x_prev @ F, which applies F transposed to each row; with particles in rows, "
                  "F x_j for every j is x_prev @ F.T",
}


def _draws(report: CheckReport, fn: Callable, case: dict, rng: np.random.Generator, n: int) -> np.ndarray | None:
    """``n`` draws of ``fn`` on ``case`` from ``rng``, each an integer index in range, or ``None`` after reporting."""
    size = len(case["x_prev"])
    out = np.empty(n, dtype=int)
    for t in range(n):
        j = _answer(report, lambda: fn(case["log_W"].copy(), case["x_prev"].copy(), case["x_ref"].copy(),
                                       case["F"].copy(), case["Q"].copy(), rng),
                    "fn(log_W, x_prev, x_ref, F, Q, rng)", "return the drawn index j")
        if j is None:
            return None
        if isinstance(j, (bool, np.bool_)) or not isinstance(j, (int, np.integer)) or not 0 <= j < size:
            report.problems.append(f"the answer {j!r} is not an integer index in [0, {size}): return one ancestor j, "
                                   "e.g. rng.choice(len(x_prev), p=probabilities)")
            return None
        out[t] = j
    return out


def _fits(counts: np.ndarray, p: np.ndarray) -> bool:
    expected = counts.sum() * p
    if np.any((counts > 0) & (expected == 0)):
        return False
    keep = expected > 0
    return stats.chisquare(counts[keep], expected[keep] * counts[keep].sum() / expected[keep].sum()).pvalue > LEVEL


def check_ancestor_index(fn: Callable) -> CheckReport:
    """Check ``fn(log_W, x_prev, x_ref, F, Q, rng) -> j`` (module docstring)."""
    report = CheckReport("ancestor sampling, correlated noise")
    case, size = ANCESTOR_CASE, len(ANCESTOR_CASE["x_prev"])
    state = np.random.get_state()
    first = []
    for seed in (1, 1, 2):
        first.append(_draws(report, fn, case, np.random.default_rng(seed), 20))
        if first[-1] is None:
            np.random.set_state(state)
            return report
    top = int(np.argmax(ancestor_probabilities(**case)))
    if np.all(first[0] == top) and np.all(first[2] == top):
        np.random.set_state(state)
        report.problems.append("it returns the same index every time: the ancestor must be drawn at random "
                               "(with rng), not chosen as the most probable one")
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
    exact = ancestor_probabilities(**case)
    if not _fits(counts, exact):
        for mistake, why in ANCESTOR_MISTAKES.items():
            if _fits(counts, ancestor_probabilities(**case, mistake=mistake)):
                report.problems.append(f"the draws follow a known mistake: {why}")
                return report
        share = ", ".join(f"{c / N_DRAWS:.2f}" for c in counts)
        want = ", ".join(f"{p:.2f}" for p in exact)
        report.problems.append(f"over {N_DRAWS} draws the ancestors' shares are {share}, not {want}: draw j with "
                               "probability proportional to W_j exp(-(1/2) d_j^T Q^-1 d_j), d_j = x_ref - F x_j")
        return report
    tiny = {**case, "log_W": case["log_W"] - 1000.0}
    draws = _draws(report, fn, tiny, np.random.default_rng(7), 600)
    if draws is None:
        report.problems[-1] += " (with log-weights near -1000: exp underflows to 0; subtract the largest log term)"
        return report
    if not _fits(np.bincount(draws, minlength=size), exact):
        report.problems.append("with log-weights near -1000 the draws go wrong: exp(-1000) underflows to 0, so "
                               "normalise in the log domain (subtract the largest log term before exp)")
    return report
