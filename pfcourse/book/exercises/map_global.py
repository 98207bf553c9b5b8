"""The checked exercises of the chapter *Finding the robot on the map* (book/part2/map_global).

Exercise 15.1 (:func:`check_takeover`, at the end of this module): how often a look-alike stratum takes over a
right cloud when hysteresis asks for several wins in a row, against the exact streak probability.  A toy: the
injections' log Bayes factors are independent there, while the chapter's overlapping look-back windows make
successive wins correlated, and the spread ``sd`` is assumed, not measured.

The earlier exercise 15.1 (:func:`check_reset_weights`, kept and tested): poses drawn from a reading, weighted
correctly, for another sensor.

A robot stands somewhere in a corridor ``[0, L]`` (uniform prior ``u(x) = 1 / L``) with doors at known
places ``d_1, ..., d_D``; its sensor reads the distance to the nearest door with Gaussian noise:

    p(z | x) = N(z; min_i |x - d_i|, sigma^2).

The student's ``fn(z, n, rng, corridor) -> (x, log_w)`` draws ``n`` poses from the reading, as sensor
resetting does: ``corridor.m`` candidates uniform on ``[0, L]`` (``rng.uniform``), each picked with
probability ``v_j ∝ p(z | c_j)``, plus Gaussian noise of standard deviation ``corridor.h``, so that

    q(x) = sum_j v_j N(x; c_j, h^2),

and returns each pose's log-weight ``log u(x) - log q(x) + log p(z | x)`` (``-inf`` outside the
corridor).  Weighted so, the poses are an importance sample of the posterior of a robot with no
history, and the mean weight estimates the evidence ``Z = integral u(x) p(z | x) dx`` (the weight the
chapter's injected stratum carries).  :func:`check_reset_weights` checks that the function draws from
the generator it is given (same seed same answer, another seed another, NumPy's global state untouched),
replays the prescribed draws to name the mistakes it shows exactly (candidates picked without ``p=``,
normalised log-weights, weights instead of logs, the sign of ``log u``), and checks that over many calls
the mean weight estimates ``Z`` and the weighted mean the posterior mean, both computed exactly by
quadrature (:func:`exact_evidence`), within five standard errors *of the reference answer* over the
same seeds (a wrong heavy-tailed estimator cannot widen its own tolerance); each mistake of
:data:`RESET_MISTAKES` has its own message.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport
from pfcourse.book.exercises.part1 import _seed_problem


@dataclass(frozen=True)
class Corridor:
    """The exercise's corridor: length ``L`` (m), door positions, the sensor's ``sigma`` (m), the number
    of candidates ``m`` and the kernel's standard deviation ``h`` (m)."""

    L: float = 20.0
    doors: np.ndarray = field(default_factory=lambda: np.array([2.5, 7.5, 12.5, 17.5, 19.0]))
    sigma: float = 0.3
    m: int = 50
    h: float = 0.3

    def log_likelihood(self, x: np.ndarray, z: float) -> np.ndarray:
        """``log N(z; min_i |x - d_i|, sigma^2)`` for each position ``x``."""
        x = np.asarray(x, dtype=float)
        dist = np.abs(x[..., None] - self.doors).min(axis=-1)
        return -0.5 * ((z - dist) / self.sigma) ** 2 - np.log(np.sqrt(2 * np.pi) * self.sigma)

    def log_prior(self, x: np.ndarray) -> np.ndarray:
        """``log u(x)``: ``-log L`` in the corridor, ``-inf`` outside."""
        x = np.asarray(x, dtype=float)
        return np.where((x >= 0) & (x <= self.L), -np.log(self.L), -np.inf)


RESET_MISTAKES: dict[str, str] = {
    "equal": "every pose has the same weight: that is right only for poses drawn from the prior u (as table "
             "8.3's uniform injected poses are), and these were drawn from q; weight each pose by u p / q",
    "uniform_pick": "the candidates are picked uniformly (rng.choice without p=) while q is the likelihood-weighted "
                    "mixture: the poses do not come from the q of their weights; pass p = v to rng.choice",
    "normalised": "the log-weights are normalised (their logsumexp is 0): the mean weight must estimate the "
                  "evidence, so return log u - log q + log p unnormalised",
    "weights_not_logs": "the function returns the weights, not their logs: return log u(x) - log q(x) + log p(z | x)",
    "prior_sign": "log u enters with the wrong sign (+log L instead of -log L): the weight is u / q p, with "
                  "u = 1 / L",
    "likelihood_only": "the weight is the likelihood alone: the poses were drawn from q, not from the prior u, "
                       "so each must be weighted u(x) / q(x) p(z | x)",
    "no_prior": "the prior u(x) = 1 / L is left out: the poses then carry L times the evidence they have, "
                "and injected poses would outweigh a cloud that explains the reading as well",
    "kernel_constant": "q(x) lacks the Gaussian kernel's factor 1 / (sqrt(2 pi) h): q must be a density, or "
                       "the weights are off by that factor against the rest of the cloud",
}


def reset_answer(z: float, n: int, rng: np.random.Generator, corridor: Corridor,
                 mistake: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The reference draw and log-weights, or what one mistake of :data:`RESET_MISTAKES` computes."""
    if mistake is not None and mistake not in RESET_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(RESET_MISTAKES)}")
    c = rng.uniform(0.0, corridor.L, corridor.m)
    s = corridor.log_likelihood(c, z)
    log_v = s - logsumexp(s)
    pick_p = None if mistake == "uniform_pick" else np.exp(log_v)
    x = c[rng.choice(corridor.m, size=n, p=pick_p)] + corridor.h * rng.standard_normal(n)
    const = 0.0 if mistake == "kernel_constant" else np.log(np.sqrt(2 * np.pi) * corridor.h)
    log_q = logsumexp(log_v - 0.5 * ((x[:, None] - c) / corridor.h) ** 2 - const, axis=1)
    log_p = corridor.log_likelihood(x, z)
    if mistake == "equal":
        return x, np.zeros(n)
    if mistake == "likelihood_only":
        return x, log_p
    prior = np.where(corridor.log_prior(x) > -np.inf, 0.0, -np.inf) if mistake == "no_prior" else corridor.log_prior(x)
    if mistake == "prior_sign":
        prior = -prior
    log_w = prior - log_q + log_p
    if mistake == "normalised":
        return x, log_w - logsumexp(log_w)
    if mistake == "weights_not_logs":
        return x, np.exp(log_w)
    return x, log_w


def exact_evidence(z: float, corridor: Corridor, n_grid: int = 200001) -> tuple[float, float]:
    """``Z = integral u p(z | x) dx`` and the posterior mean of ``x``, by the trapezoidal rule on ``n_grid`` points."""
    x = np.linspace(0.0, corridor.L, n_grid)
    p = np.exp(corridor.log_likelihood(x, z)) / corridor.L
    Z = np.trapezoid(p, x)
    return float(Z), float(np.trapezoid(x * p, x) / Z)


READINGS = (1.1, 2.3)


def check_reset_weights(fn: Callable, corridor: Corridor = Corridor(), n: int = 2000, calls: int = 20) -> CheckReport:
    """Check ``fn(z, n, rng, corridor) -> (x, log_w)`` (module docstring)."""
    report = CheckReport("poses from the reading, weighted u / q p")
    state = np.random.get_state()

    def call(seed, z=READINGS[0]):
        try:
            out = fn(z, n, np.random.default_rng(seed), corridor)
            if out is None:
                report.problems.append("the function returned None: return the poses and their log-weights, "
                                       "two arrays of shape (n,)")
                return None
            x, log_w = out
            return np.asarray(x, dtype=float), np.asarray(log_w, dtype=float)
        except Exception as exc:  # a student's bug is reported, not raised
            report.problems.append(f"the function raised {type(exc).__name__}: {exc}")
            return None

    answer = call(1)
    if answer is None:
        np.random.set_state(state)
        return report
    x, log_w = answer
    if x.shape != (n,) or log_w.shape != (n,):
        np.random.set_state(state)
        report.problems.append(f"it must return two arrays of shape ({n},), poses and log-weights; got {x.shape} and "
                               f"{log_w.shape}")
        return report
    again, other = call(1), call(2)
    if again is None or other is None:
        np.random.set_state(state)
        return report
    problem = _seed_problem(state, answer, again, other, "poses", "rng.uniform(...), rng.choice(...) and "
                            "rng.standard_normal(...)")
    if problem is not None:
        report.problems.append(problem)
        return report
    named = _replayed_mistake(x, log_w, corridor, READINGS[0], n, seed=1)
    if named is not None:
        report.problems.append(RESET_MISTAKES[named])
        return report
    if np.ptp(log_w[np.isfinite(log_w)]) < 1e-12:
        report.problems.append(RESET_MISTAKES["equal"])
        return report
    log_p, log_u = corridor.log_likelihood(x, READINGS[0]), corridor.log_prior(x)
    inside = np.isfinite(log_u)
    if np.ptp(log_w[inside] - log_p[inside]) < 1e-9:
        report.problems.append(RESET_MISTAKES["likelihood_only"])
        return report
    if np.any(np.isfinite(log_w[~inside])):
        report.problems.append("a pose outside the corridor has a finite weight: u(x) = 0 there, so its weight is 0 "
                               "(log-weight -inf)")
        return report
    for z in READINGS:
        runs = [call(100 + t, z) for t in range(calls)]
        if any(r is None for r in runs):
            return report
        ratio, se, mean_x, _ = _estimates(runs, corridor, z)
        # the tolerance is the reference answer's spread over the same seeds, not the student's own
        _, ref_se, _, ref_se_x = _estimates([reset_answer(z, n, np.random.default_rng(100 + t), corridor)
                                             for t in range(calls)], corridor, z)
        Z, post_mean = exact_evidence(z, corridor)
        if abs(ratio - 1.0) > 5 * ref_se:
            factors = {"no_prior": corridor.L, "kernel_constant": 1.0 / (np.sqrt(2 * np.pi) * corridor.h)}
            rel = se / ratio  # the ratio's relative standard error: a factor is named only when it is precise
            for name, factor in factors.items():
                if rel < 0.05 and abs(ratio / factor - 1.0) < max(5 * rel, 0.02):
                    report.problems.append(RESET_MISTAKES[name])
                    return report
            report.problems.append(f"for z = {z} the mean weight is {ratio:.3f} times the evidence Z = {Z:.4g} "
                                   f"(+- {5 * ref_se:.3f} allowed): check that q is the whole mixture sum_j v_j N(x; c_j, h^2), "
                                   "with v_j the normalised likelihoods of the candidates")
            return report
        if abs(mean_x - post_mean) > 5 * ref_se_x + 1e-3:
            report.problems.append(f"for z = {z} the weighted mean position is {mean_x:.3f} m, the posterior mean "
                                   f"{post_mean:.3f} m: the weights do not follow the poses; weight each by u p / q")
            return report
    return report


def _replayed_mistake(x: np.ndarray, log_w: np.ndarray, corridor: Corridor, z: float, n: int,
                      seed: int) -> str | None:
    """The mistake of :data:`RESET_MISTAKES` that replaying the prescribed draws (``rng.uniform``, ``rng.choice``,
    ``rng.standard_normal`` from ``default_rng(seed)``) shows exactly, or None."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.0, corridor.L, corridor.m)
    uniform_x = c[rng.choice(corridor.m, size=n)] + corridor.h * rng.standard_normal(n)
    s = corridor.log_likelihood(c, z)
    log_v = s - logsumexp(s)
    log_q = logsumexp(log_v - 0.5 * ((x[:, None] - c) / corridor.h) ** 2
                      - np.log(np.sqrt(2 * np.pi) * corridor.h), axis=1)
    log_p, log_u = corridor.log_likelihood(x, z), corridor.log_prior(x)
    right = log_u - log_q + log_p
    inside = np.isfinite(log_u)

    def same(a, b):
        return bool(np.allclose(a[inside], b[inside], rtol=1e-9, atol=1e-9))

    with np.errstate(all="ignore"):
        if np.allclose(x, uniform_x, rtol=0, atol=1e-9):
            return "uniform_pick"
        if same(log_w, right - logsumexp(right)) and not same(log_w, right):
            return "normalised"
        if same(log_w, np.exp(right)) and not same(log_w, right):
            return "weights_not_logs"
        if same(log_w, -log_u - log_q + log_p):
            return "prior_sign"
    return None


def _estimates(runs, corridor: Corridor, z: float) -> tuple[float, float, float, float]:
    """Mean weight over the evidence (and its standard error), weighted mean position (and its standard
    error), over the calls' samples (one value per call, so that the errors are those between calls)."""
    Z, _ = exact_evidence(z, corridor)
    per_call = np.array([np.mean(np.exp(lw)) / Z for _, lw in runs])
    means = []
    for x, lw in runs:
        w = np.exp(lw - logsumexp(lw))
        means.append(w @ x)
    means = np.array(means)
    k = len(runs)
    return (float(per_call.mean()), float(per_call.std(ddof=1) / np.sqrt(k)),
            float(means.mean()), float(means.std(ddof=1) / np.sqrt(k)))


# --- Exercise 15.1 (since issue 41's hysteresis): how often a look-alike stratum takes over a right cloud ---

TAKEOVER_MISTAKES: dict[str, str] = {
    "total": "the twin takes over after confirm wins in all, not confirm wins in a row: a loss must reset the "
             "streak to 0 (hysteresis asks for consecutive injections)",
    "no_prior": "the prior odds are left out: the stratum's log posterior odds are log_prior_odds + the noisy "
                "log Bayes factor, and a kidnapping is a priori rare",
    "prior_sign": "the prior odds enter with the wrong sign: log_prior_odds is already the stratum's (negative) "
                  "log-odds against the cloud, so add it as it is",
    "variance": "sd is used as a variance (the noise scaled by sd ** 2): sd is the standard deviation "
                "of the log Bayes factor, so draw log_prior_odds + sd * rng.standard_normal(...)",
    "one_more": "the streak must exceed confirm (confirm + 1 wins in a row): the twin takes over at the "
                "confirm-th win in a row (streak >= confirm)",
    "last_only": "only the last confirm injections are looked at: the twin takes over at the first streak of "
                 "confirm wins anywhere in the T injections, and then it has the weight",
    "share_of_wins": "the function returns the share of injections the twin wins, not the share of drives it "
                     "takes over: a drive counts once, at its first streak of confirm wins in a row",
    "count": "the function returns a count of runs, not their share: divide by runs",
}

#: The checker's cases: (log prior odds, sd of the log Bayes factor, confirm, T injections).  The first is the
#: chapter's: xi_k = 4e-3 and 45 injections in a 100-s drive.
TAKEOVER_CASES = ((float(np.log(4e-3 / (1 - 4e-3))), 3.0, 1, 45), (float(np.log(4e-3 / (1 - 4e-3))), 3.0, 3, 45),
                  (-2.0, 1.5, 2, 20), (-2.0, 1.5, 2, 4))
TAKEOVER_RUNS = 20000
#: The case on which the generator is checked: no answer or mistake saturates at 0 or 1 there.
SEED_CASE = (-2.0, 1.5, 2, 4)


def takeover_answer(log_prior_odds: float, sd: float, confirm: int, T: int, runs: int, rng: np.random.Generator,
                    mistake: str | None = None) -> float:
    """The reference answer (the share of ``runs`` simulated drives in which a twin's stratum takes over within
    ``T`` injections), or what one mistake of :data:`TAKEOVER_MISTAKES` computes."""
    if mistake is not None and mistake not in TAKEOVER_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(TAKEOVER_MISTAKES)}")
    e = rng.standard_normal((runs, T))
    scale = sd ** 2 if mistake == "variance" else sd
    prior = 0.0 if mistake == "no_prior" else (-log_prior_odds if mistake == "prior_sign" else log_prior_odds)
    win = prior + scale * e > 0
    if mistake == "share_of_wins":
        return float(win.mean())
    if mistake == "total":
        hit = win.sum(axis=1) >= confirm
    elif mistake == "last_only":
        hit = win[:, T - confirm:].all(axis=1)
    else:
        need = confirm + 1 if mistake == "one_more" else confirm
        streak = np.zeros(runs, dtype=int)
        hit = np.zeros(runs, dtype=bool)
        for t in range(T):
            streak = np.where(win[:, t], streak + 1, 0)
            hit |= streak >= need
    share = float(hit.mean())
    return share * runs if mistake == "count" else share


def exact_takeover(p: float, confirm: int, T: int) -> float:
    """P(a run of ``confirm`` successes within ``T`` Bernoulli(``p``) trials), exactly (the streak's distribution)."""
    state = np.zeros(confirm + 1)  # state[j]: streak j (< confirm) and no takeover yet; state[confirm]: taken over
    state[0] = 1.0
    for _ in range(T):
        new = np.zeros_like(state)
        new[confirm] = state[confirm] + p * state[confirm - 1]
        new[0] = (1 - p) * state[:confirm].sum()
        new[1:confirm] = p * state[:confirm - 1]
        state = new
    return float(state[confirm])


def exact_takeover_case(log_prior_odds: float, sd: float, confirm: int, T: int,
                        mistake: str | None = None) -> float:
    """The exact value of :func:`takeover_answer` (its limit as ``runs`` grows), for the answer or a mistake."""
    from scipy.stats import binom, norm

    scale = sd ** 2 if mistake == "variance" else sd
    prior = 0.0 if mistake == "no_prior" else (-log_prior_odds if mistake == "prior_sign" else log_prior_odds)
    p = float(norm.cdf(prior / scale))
    if mistake == "share_of_wins":
        return p
    if mistake == "total":
        return float(binom.sf(confirm - 1, T, p))
    if mistake == "last_only":
        return p ** confirm
    return exact_takeover(p, confirm + 1 if mistake == "one_more" else confirm, T)


def check_takeover(fn: Callable, runs: int = TAKEOVER_RUNS) -> CheckReport:
    """Check ``fn(log_prior_odds, sd, confirm, T, runs, rng) -> share``: the generator (same seed same answer,
    another seed another, NumPy's global state untouched), then, per case of :data:`TAKEOVER_CASES`, the share
    against the exact one (:func:`exact_takeover_case`) within five binomial standard errors; a wrong share that
    equals a mistake's replayed draws, or lies within that mistake's own tolerance and outside the answer's, is
    named by :data:`TAKEOVER_MISTAKES`."""
    report = CheckReport("the share of drives a look-alike stratum takes over, with hysteresis")
    state = np.random.get_state()

    def call(case, seed):
        try:
            out = fn(*case, runs, np.random.default_rng(seed))
        except Exception as exc:  # a student's bug is reported, not raised
            report.problems.append(f"the function raised {type(exc).__name__}: {exc}")
            return None
        if out is None:
            report.problems.append("the function returned None: return the share of the runs in which the twin "
                                   "takes over, a number between 0 and 1")
            return None
        try:
            return float(out)
        except (TypeError, ValueError):
            report.problems.append(f"the function must return one number, the share; got {type(out).__name__}")
            return None

    first = call(SEED_CASE, 1)
    if first is None:
        np.random.set_state(state)
        return report
    again, other = call(SEED_CASE, 1), call(SEED_CASE, 2)
    if again is None or other is None:
        np.random.set_state(state)
        return report
    problem = _seed_problem(state, (np.array([first]),), (np.array([again]),), (np.array([other]),), "share",
                            "rng.standard_normal((runs, T))")
    if problem is not None:
        if first == other:  # e.g. a closed form such as (T - confirm + 1) p^confirm, with the draws ignored
            problem += "; simulate the drives with it, do not compute a closed form such as p^confirm"
        report.problems.append(problem)
        return report
    generic = None
    for case in TAKEOVER_CASES:
        share = call(case, 7)
        if share is None:
            return report
        if share > 1.0 + 1e-12:
            report.problems.append(TAKEOVER_MISTAKES["count"])
            return report
        right = exact_takeover_case(*case)
        se = max(np.sqrt(right * (1 - right) / runs), 0.5 / runs)
        if abs(share - right) <= 5 * se:
            continue
        names = [m for m in TAKEOVER_MISTAKES  # replayed draws first: exact
                 if m != "count" and share == takeover_answer(*case, runs, np.random.default_rng(7), m)]
        if not names:  # then each mistake's own limit
            names = [m for m in TAKEOVER_MISTAKES if m != "count" and abs(share - (lim := exact_takeover_case(
                *case, mistake=m))) <= 5 * max(np.sqrt(lim * (1 - lim) / runs), 0.5 / runs)]
        if len(names) == 1:
            report.problems.append(TAKEOVER_MISTAKES[names[0]])
            return report
        log_odds, sd, confirm, T = case
        wrong = (f"with log prior odds {log_odds:.2f}, sd {sd}, confirm {confirm} and T = {T} the share is {share:.4f}, "
                 f"the exact one {right:.4f} (+- {5 * se:.4f} allowed): a twin wins an injection when "
                 "log_prior_odds + sd * e > 0, and takes over at the first streak of confirm wins in a row")
        if not names:
            report.problems.append(wrong)
            return report
        generic = wrong  # several mistakes give this share: a later case tells them apart
    if generic is not None:
        report.problems.append(generic)
    return report
