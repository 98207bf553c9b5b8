"""The checked exercise of the chapter "Why it works" (book/part1/why_it_works.py).

The reader writes the Feynman-Kac pair ``(M, G)`` of a guided filter for the scalar model
:data:`FK_MODEL` (``x_0 ~ N(0, 1)``, ``x_k = 0.9 x_{k-1} + w_k``, ``z_k = x_k + v_k``,
``w_k ~ N(0, 0.5)``, ``v_k ~ N(0, 0.5)``, nothing measured at step 0), with the proposal that
centres each new particle on the measurement, ``q(x_k | x_{k-1}, z_k) = N(z_k, FK_Q_VAR)``:
``make_guided(Z) -> (M, G)`` with ``M(k, x_prev, N, rng)`` (``N`` draws of ``x_0`` at ``k = 0``)
and ``G(k, x_prev, x) -> log G_k``, as in the chapter.  :func:`check_guided_fk` checks the draws
(generator, law), the potential against its exact value (each mistake of :data:`FK_MISTAKES`
named), and then what the chapter proves: run through the chapter's algorithm on data sets
simulated from the model, the likelihood estimate is unbiased against the exact (Kalman) one.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pfcourse.book.exercises.checking import CheckReport, _answer
from pfcourse.book.exercises.part1 import _seed_problem

#: The scalar model of the exercise: AR coefficient, process and measurement variances, prior variance.
FK_MODEL = {"a": 0.9, "q": 0.5, "r": 0.5, "p0": 1.0}
#: The variance of the guided proposal N(z_k, FK_Q_VAR).
FK_Q_VAR = 2.0
FK_STEPS = 20  # steps 0 .. FK_STEPS - 1; z_0 missing
FK_MISTAKES = {
    "bootstrap": "G is the bootstrap potential log p(z_k | x_k) alone; with particles drawn from q instead of "
                 "the transition it must also carry log p(x_k | x_(k-1)) - log q(x_k | x_(k-1), z_k)",
    "no_q": "G leaves out - log q(x_k | x_(k-1), z_k): the particles come from q, so its density must be "
            "divided out, or the filter targets the wrong law",
    "plus_q": "G adds log q(x_k | x_(k-1), z_k) instead of subtracting it: an importance weight is target over "
              "proposal",
    "no_transition": "G leaves out log p(x_k | x_(k-1)): the proposal ignores the parent, so the dynamics enter "
                     "only through this factor",
}


def fk_simulate(rng: np.random.Generator, n_steps: int = FK_STEPS) -> np.ndarray:
    """Data ``Z`` (shape ``(n_steps,)``) of :data:`FK_MODEL`, ``Z[0]`` missing (NaN)."""
    a, q, r, p0 = (FK_MODEL[k] for k in ("a", "q", "r", "p0"))
    x = np.empty(n_steps)
    x[0] = np.sqrt(p0) * rng.standard_normal()
    for k in range(1, n_steps):
        x[k] = a * x[k - 1] + np.sqrt(q) * rng.standard_normal()
    Z = x + np.sqrt(r) * rng.standard_normal(n_steps)
    Z[0] = np.nan
    return Z


def fk_exact_log_likelihood(Z: np.ndarray) -> float:
    """``log p(z_1:T)`` of :data:`FK_MODEL` by the Kalman filter (exact)."""
    a, q, r, p0 = (FK_MODEL[k] for k in ("a", "q", "r", "p0"))
    m, P, total = 0.0, p0, 0.0
    for k, z in enumerate(Z):
        if k > 0:
            m, P = a * m, a * a * P + q
        if np.isnan(z):
            continue
        S = P + r
        total += float(_log_normal(z - m, S))
        gain = P / S
        m, P = m + gain * (z - m), (1 - gain) * P
    return total


def _log_normal(residual, var: float) -> np.ndarray:
    """``log N(residual; 0, var)``."""
    return -0.5 * (residual**2 / var + np.log(2 * np.pi * var))


def fk_guided_exact(Z: np.ndarray, mistake: str | None = None) -> tuple[Callable, Callable]:
    """The reference ``(M, G)`` of the exercise for data ``Z`` (``mistake``: a key of :data:`FK_MISTAKES`,
    for ``G``'s typical mistakes)."""
    a, q, r, p0 = (FK_MODEL[k] for k in ("a", "q", "r", "p0"))

    def M(k, x_prev, N, rng):
        if k == 0:
            return np.sqrt(p0) * rng.standard_normal(N)
        return Z[k] + np.sqrt(FK_Q_VAR) * rng.standard_normal(len(x_prev))

    def G(k, x_prev, x):
        if k == 0:
            return np.zeros(len(x))
        lik = _log_normal(Z[k] - x, r)
        trans = _log_normal(x - a * x_prev, q)
        prop = _log_normal(x - Z[k], FK_Q_VAR)
        return {None: lik + trans - prop, "bootstrap": lik, "no_q": lik + trans, "plus_q": lik + trans + prop,
                "no_transition": lik - prop}[mistake]

    return M, G


def fk_run(M: Callable, G: Callable, n_steps: int, N: int, rng: np.random.Generator) -> float:
    """``log p^`` of the chapter's algorithm (resampling at every step, systematic) for a scalar ``(M, G)``."""
    x_prev, log_W, total = None, np.full(N, -np.log(N)), 0.0
    for k in range(n_steps):
        if k > 0:
            W = np.exp(log_W)
            u = (np.arange(N) + rng.random()) / N
            x_prev = x_prev[np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), N - 1)]
            log_W = np.full(N, -np.log(N))
        x = np.asarray(M(k, x_prev, N, rng), dtype=float)
        log_a = log_W + np.asarray(G(k, x_prev, x), dtype=float)
        top = log_a.max()
        inc = top + np.log(np.sum(np.exp(log_a - top)))  # logsumexp
        total += inc
        log_W = log_a - inc
        x_prev = x
    return total


def check_guided_fk(make_guided: Callable, n_runs: int = 200, n_particles: int = 100, seed: int = 0) -> CheckReport:
    """Check a reader's ``make_guided(Z) -> (M, G)``, the guided filter with ``q = N(z_k, FK_Q_VAR)`` as a
    Feynman-Kac pair (the chapter's exercise).

    In order: the pair's form; ``M`` draws from the generator it is given (NumPy's global state untouched,
    same seed same draws, another seed others); ``M_0`` is the prior ``N(0, 1)`` and ``M_k`` is ``q``, by
    the mean and variance of 20 000 draws within 5 standard errors (a right answer fails with probability
    below 1e-5); ``G`` equals the exact log-potential to 1e-9 on fixed particles (a wrong one is compared
    with each mistake of :data:`FK_MISTAKES`); and ``n_runs`` runs of the chapter's algorithm with
    ``n_particles`` particles, one simulated data set each, give a mean of ``p^ / p`` (``p`` the Kalman
    likelihood) within 4 standard errors of 1, that standard error below 0.25 (a right answer's is
    about 0.05).  The report's success line quotes that mean.
    """
    report = CheckReport("guided filter as a Feynman-Kac pair")
    data_rng = np.random.default_rng(seed)
    Z = fk_simulate(data_rng)
    pair = _answer(report, lambda: make_guided(Z.copy()), "make_guided(Z)", "return the pair (M, G)")
    if pair is None:
        return report
    if not isinstance(pair, tuple) or len(pair) != 2 or not all(callable(f) for f in pair):
        report.problems.append("make_guided(Z) must return a pair of functions (M, G)")
        return report
    M, G = pair
    x_prev = np.linspace(-2.0, 2.0, 50)
    k = 3
    state = np.random.get_state()
    draws = [_answer(report, lambda s=s: M(k, x_prev.copy(), len(x_prev), np.random.default_rng(s)),
                     "M(k, x_prev, N, rng)", "return the N new particles") for s in (1, 1, 2)]
    if any(d is None for d in draws):
        np.random.set_state(state)
        return report
    if np.shape(draws[0]) != (len(x_prev),):
        np.random.set_state(state)
        report.problems.append(f"M(k, x_prev, N, rng) returned shape {np.shape(draws[0])}, not ({len(x_prev)},): "
                               "one new particle per parent")
        return report
    problem = _seed_problem(state, (draws[0],), (draws[1],), (draws[2],), "particles", "rng.standard_normal()")
    if problem is not None:
        report.problems.append(f"M: {problem}")
        return report
    # the laws of M_0 and M_k, by their moments
    n_draw = 20_000
    first = _answer(report, lambda: M(0, None, n_draw, np.random.default_rng(3)), "M(0, None, N, rng)",
                    "return N draws of x_0 from the prior")
    if first is None:
        return report
    if np.shape(first) != (n_draw,):
        report.problems.append(f"M(0, None, N, rng) returned shape {np.shape(first)}, not ({n_draw},): at step 0 "
                               "draw N particles from the prior N(0, 1)")
        return report
    parents = np.repeat(x_prev, n_draw // len(x_prev))
    moved = np.asarray(M(k, parents, len(parents), np.random.default_rng(4)), dtype=float)

    def moments_fit(x, mean, var):
        se_mean, se_var = np.sqrt(var / x.size), var * np.sqrt(2.0 / x.size)
        return abs(x.mean() - mean) < 5 * se_mean and abs(x.var() - var) < 5 * se_var

    if not moments_fit(np.asarray(first, dtype=float), 0.0, FK_MODEL["p0"]):
        report.problems.append(f"M at step 0 draws with mean {np.mean(first):.3f} and variance {np.var(first):.3f}: "
                               "it must draw x_0 from the prior N(0, 1), since nothing is measured at step 0")
        return report
    if not moments_fit(moved, Z[k], FK_Q_VAR):
        transition = moments_fit(moved - FK_MODEL["a"] * parents, 0.0, FK_MODEL["q"])
        if transition:
            why = "it draws from the transition N(0.9 x_(k-1), 0.5), not from the proposal q = N(z_k, 2)"
        elif moments_fit(moved, Z[k], FK_Q_VAR**2):
            why = "its spread is the variance 2 used as a standard deviation: the proposal's sd is sqrt(2)"
        else:
            why = f"its draws have mean {moved.mean():.3f} and variance {moved.var():.3f}, not z_k = {Z[k]:.3f} and 2"
        report.problems.append(f"M at step k >= 1: {why}")
        return report
    # the potential, on fixed particles
    x = np.linspace(-3.0, 3.0, 50)
    got0 = _answer(report, lambda: G(0, None, x.copy()), "G(0, None, x)", "return one log-potential per particle")
    if got0 is None:
        return report
    if np.shape(got0) != x.shape or not np.allclose(np.asarray(got0, dtype=float), 0.0, rtol=0, atol=1e-12):
        report.problems.append("G at step 0 is not 0 for every particle: nothing is measured at step 0 (Z[0] is NaN), "
                               "so G_0 = 1, log G_0 = 0")
        return report
    got = _answer(report, lambda: G(k, x_prev.copy(), x.copy()), "G(k, x_prev, x)",
                  "return one log-potential per particle")
    if got is None:
        return report
    if np.shape(got) != x.shape:
        report.problems.append(f"G(k, x_prev, x) returned shape {np.shape(got)}, not {x.shape}: one value per particle")
        return report
    got = np.asarray(got, dtype=float)

    def g_fits(mistake):
        return np.allclose(got, fk_guided_exact(Z, mistake)[1](k, x_prev, x), rtol=0, atol=1e-9)

    if not g_fits(None):
        for mistake, why in FK_MISTAKES.items():
            if g_fits(mistake):
                report.problems.append(f"your G computes a known mistake: {why}")
                return report
        gap = got - fk_guided_exact(Z)[1](k, x_prev, x)
        if np.ptp(gap) < 1e-9:
            report.problems.append(f"G is off by the constant {gap[0]:.4f}: a constant does not move the particles, "
                                   "but it multiplies every likelihood increment, so keep the densities' constants")
        else:
            report.problems.append("G differs from log p(z_k | x_k) + log p(x_k | x_(k-1)) - log q(x_k | x_(k-1), z_k): "
                                   "check each of the three densities")
        return report
    # what the chapter proves: the likelihood estimate is unbiased
    ratios = np.empty(n_runs)
    for run in range(n_runs):
        Z_run = fk_simulate(data_rng)
        M_run, G_run = make_guided(Z_run)
        with np.errstate(all="ignore"):
            log_p = fk_run(M_run, G_run, len(Z_run), n_particles, np.random.default_rng([seed, run]))
        ratios[run] = np.exp(log_p - fk_exact_log_likelihood(Z_run))
    mean, se = ratios.mean(), ratios.std(ddof=1) / np.sqrt(n_runs)
    # a right G gives a standard error near 0.05 here; one above 0.25 is a mean of p^/p that no run count
    # can pin down, the sign of a G with a factor missing at some step
    if not np.isfinite(mean) or abs(mean - 1.0) > 4 * se or se > 0.25:
        report.problems.append(f"over {n_runs} data sets the mean of p^/p is {mean:.3f} (standard error {se:.3f}), "
                               "not 1: the likelihood estimate is biased, so some factor of G is wrong at some step")
        return report
    report.name += f" (mean p^/p over {n_runs} data sets: {mean:.3f}, standard error {se:.3f})"
    return report
