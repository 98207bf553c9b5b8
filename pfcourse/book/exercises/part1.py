"""Checkers of Part I (the linear landmark model and a scalar linear model: chapters 1-9)."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from pfcourse.book.exercises.checking import CheckReport, _answer, _per_particle_answers, _settled, _shaped


_VARIANCE_MARGIN = 1.5  # a resampler adding more than 1.5 x multinomial's offspring variance is named


def check_resampler(fn: Callable, n_draws: int = 4000, seed: int = 0) -> CheckReport:
    """Check a resampler ``fn(weights, rng) -> N ancestor indices`` (see the module docstring).

    Unbiasedness: for weights ``W`` (``N = 7``, one of them 0) the copy counts ``N_i`` of
    ``n_draws`` calls must have mean ``N W_i`` within ``5 SE + 1e-9`` (SE from the sample
    standard deviation of the counts; a deterministic scheme with biased counts has SE 0 and
    fails). A correct unbiased scheme fails one of the 7 tests with probability below 1e-5.

    Variance: an unbiased scheme whose total offspring variance ``sum_i Var N_i`` exceeds
    ``1.5 sum_i N W_i (1 - W_i)``, multinomial resampling's, is named (one uniform shared by all
    particles gives ``Var N_i = N^2 W_i (1 - W_i)``, ``N`` times multinomial's). Multinomial,
    stratified, residual and systematic resampling stay at or below ``sum_i N W_i (1 - W_i)``; the
    relative standard error of the measured total is a few per cent over 4000 draws.
    """
    report = CheckReport("resampler")
    rng = np.random.default_rng(seed)
    w = np.array([0.05, 0.3, 0.0, 0.12, 0.08, 0.25, 0.2])
    n = w.size
    first = _answer(report, lambda: fn(w.copy(), rng), "fn(weights, rng)",
                    "write the resampler and return the N ancestor indices")
    if first is None or _index_problem(report, first, n, "use astype(int)"):
        return report
    counts = np.empty((n_draws, n))
    for t in range(n_draws):
        idx = np.asarray(fn(w.copy(), rng))
        if idx.min() < 0 or idx.max() >= n:
            report.problems.append(
                f"draw {t}: an index is out of range [0, {n}) (got {idx.min()}..{idx.max()}); "
                "a cumulative sum that ends just below 1 needs its last value set to 1"
            )
            return report
        counts[t] = np.bincount(idx, minlength=n)
    if counts[:, 2].any():
        report.problems.append(
            "a particle of weight 0 was chosen: u must select the i with cumsum[i-1] < u <= cumsum[i] "
            "(np.searchsorted(np.cumsum(w), u)), which never lands on a zero-width interval"
        )
    biased = _most_biased(counts, w, n)
    if biased is not None:
        i, mean_i, se_i = biased
        report.problems.append(
            f"biased: particle {i} of weight {w[i]} should get N W = {n * w[i]:.3f} copies on "
            f"average, it got {mean_i:.3f} (± {se_i:.3f}) over {n_draws} draws"
        )
    if np.all(counts.std(axis=0) == 0) and not np.allclose(n * w, np.round(n * w)):
        report.problems.append("the result never changes: the rng is not used")
    total_var, multinomial_var = counts.var(axis=0, ddof=1).sum(), float(np.sum(n * w * (1 - w)))
    if biased is None and total_var > _VARIANCE_MARGIN * multinomial_var:
        report.problems.append(
            f"the copy counts are right on average but too variable: sum of Var N_i is {total_var:.2f}, more "
            f"than multinomial resampling's sum of N W_i (1 - W_i) = {multinomial_var:.2f}; each particle "
            "needs a uniform of its own (u of shape (N,)), not one uniform shared by all"
        )
    try:
        idx = np.asarray(fn(np.full(n, 1.0 / n), rng))
        if idx.shape != (n,) or idx.min() < 0 or idx.max() >= n:
            report.problems.append("uniform weights give indices of the wrong shape or out of range")
    except Exception as exc:
        report.problems.append(f"uniform weights raised {type(exc).__name__}: {exc}")
    return report


#: The weights of :func:`check_stratified_resampler` (``N = 8``), in twelfths, and the number of particles
#: drawn, ``n = 12``: particle 1's segment straddles two of the twelve strata half and half (stratified:
#: 0, 1 or 2 copies; systematic: always exactly one), particle 2 weighs nothing.
STRATIFIED_WEIGHTS = np.array([0.5, 1.0, 0.0, 2.5, 1.5, 2.0, 3.0, 1.5]) / 12
STRATIFIED_DRAWS = 12


def _offspring_variances(w: np.ndarray, n: int | None = None) -> dict[str, np.ndarray]:
    """Exact ``Var N_i`` of each particle under stratified, systematic and multinomial resampling drawing
    ``n`` particles (``N``, the number of weights, by default)."""
    n = w.size if n is None else n
    c = np.concatenate([[0.0], np.cumsum(w)])
    lo, hi = np.arange(n) / n, np.arange(1, n + 1) / n
    p = n * np.clip(np.minimum(hi[None], c[1:, None]) - np.maximum(lo[None], c[:-1, None]), 0, None)
    r = n * w - np.floor(n * w + 1e-12)
    return {"stratified": (p * (1 - p)).sum(axis=1), "systematic": r * (1 - r), "multinomial": n * w * (1 - w)}


def _draws_from_its_generator(report: CheckReport, call: Callable, midpoints: np.ndarray | None = None) -> bool:
    """Whether ``call(rng)`` leaves NumPy's global state alone, repeats itself for one seed and changes
    with the seed; if not, say which, in one sentence, and return False. ``midpoints``, the answer of
    each stratum's midpoint in place of its uniform, tells that mistake from a generator made inside."""
    state = np.random.get_state()
    try:
        first, again = np.asarray(call(np.random.default_rng(1))), np.asarray(call(np.random.default_rng(1)))
        others = [np.asarray(call(np.random.default_rng(s))) for s in range(2, 12)]
        # each seed twice: a generator made inside the function can repeat an answer by chance (few weights,
        # narrow strata), but not on eleven seeds at once
        repeats = [np.asarray(call(np.random.default_rng(s))) for s in range(2, 12)]
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling fn(weights, n, rng) raised {type(exc).__name__}: {exc}")
        return False
    moved = not all(np.array_equal(a, b) for a, b in zip(state[1:], np.random.get_state()[1:]))
    np.random.set_state(state)
    if moved:
        report.problems.append(
            "it draws from NumPy's global generator (np.random.random, np.random.rand, ...), not from the rng it "
            "is given: draw with rng.random(...), so that a seeded run gives the same answer")
    elif not np.array_equal(first, again) or not all(np.array_equal(o, r) for o, r in zip(others, repeats)):
        report.problems.append(
            "two calls with generators of the same seed gave different answers: draw every uniform from the rng "
            "argument, and from nothing else")
    elif all(np.array_equal(first, o) for o in others):
        if midpoints is not None and np.array_equal(first, midpoints):
            report.problems.append(
                "the result never changes with the seed: it is the midpoints' answer, and each stratum needs a "
                "random uniform drawn with rng.random, not its midpoint")
        else:
            report.problems.append(
                "the result never changes with the seed: the rng it is given is not used (a generator seeded "
                "inside the function?); draw every uniform from the rng argument")
    return not report.problems


def _seed_problem(state: tuple, answer: tuple, again: tuple, other: tuple, what: str, how: str) -> str | None:
    """What is wrong with the draws of a function given a generator, or ``None``: ``answer`` and ``again``
    came from one seed, ``other`` from another, and NumPy's global state was ``state`` before (restored
    here). ``what`` names the drawn first item ("robots"), ``how`` the draws to use ("rng.random()")."""
    drew_global = not _same_state(state, np.random.get_state())
    np.random.set_state(state)
    if drew_global:
        return ("it draws from NumPy's global np.random instead of the generator rng it is given: "
                f"use {how} so that a seed gives one answer")
    if not np.array_equal(np.asarray(answer[0]), np.asarray(again[0])):
        return f"the same seed gave different {what}: draw every random number from rng"
    if np.array_equal(np.asarray(answer[0]), np.asarray(other[0])):
        return f"another seed gave the same {what}: the rng it is given is not used"
    return None


def _offspring_counts(report: CheckReport, draw: Callable, n_draws: int, n: int, n_weights: int,
                      rng: np.random.Generator, range_hint: str, zero_hint: str) -> np.ndarray | None:
    """Copy counts ``(n_draws, n_weights)`` of ``n_draws`` calls ``draw(rng)`` of ``n`` ancestor indices, or
    ``None`` with the problem reported: an index out of range (``range_hint`` says how to draw it), or the
    weight-0 particle (index 2 of both checkers' weights) chosen (``zero_hint`` says why it cannot be)."""
    counts = np.empty((n_draws, n_weights))
    for t in range(n_draws):
        idx = np.asarray(draw(rng))
        if idx.shape != (n,) or idx.min() < 0 or idx.max() >= n_weights:
            report.problems.append(f"draw {t}: an index is out of range [0, {n_weights}) (got {idx.min()}.."
                                   f"{idx.max()}): {range_hint}")
            return None
        counts[t] = np.bincount(idx, minlength=n_weights)
    if counts[:, 2].any():
        report.problems.append(f"a particle of weight 0 was chosen: {zero_hint}")
        return None
    return counts


def _unbiased_counts(report: CheckReport, draw: Callable, n_draws: int, n: int, w: np.ndarray,
                     rng: np.random.Generator, range_hint: str, zero_hint: str,
                     biased: Callable[[int, float, float], str]) -> np.ndarray | None:
    """The copy counts of :func:`_offspring_counts` (``n`` ancestors drawn on the weights ``w``), if they are
    unbiased, ``E N_i = n W_i`` within 5 standard errors for every particle (:func:`_most_biased`); ``None`` after
    reporting the problem, for a bias the sentence ``biased(i, mean_i, se_i)`` of the farthest particle."""
    counts = _offspring_counts(report, draw, n_draws, n, w.size, rng, range_hint, zero_hint)
    if counts is None:
        return None
    farthest = _most_biased(counts, w, n)
    if farthest is not None:
        report.problems.append(biased(*farthest))
        return None
    return counts


def _index_problem(report: CheckReport, answer: object, n: int, integer_hint: str, per: str = "particle") -> bool:
    """Whether a resampler's answer is not ``n`` integer ancestor indices, an array of shape ``(n,)`` and
    integer dtype (the index ``a^i`` of the parent of each new particle ``i``); if not, the problem is
    reported in one sentence (``integer_hint`` says how to get integers, ``per`` what each index is for)."""
    answer = np.asarray(answer)
    if answer.shape != (n,):
        report.problems.append(f"returned shape {answer.shape}; expected ({n},), one ancestor index per {per}")
        return True
    if answer.dtype.kind not in "iu":
        report.problems.append(f"returned dtype {answer.dtype}; indices must be integers ({integer_hint})")
        return True
    return False


def _most_biased(counts: np.ndarray, w: np.ndarray, n: int) -> tuple[int, float, float] | None:
    """The particle whose mean copy count is farthest from ``n W_i`` beyond 5 standard errors (an unbiased
    scheme gives ``E N_i = n W_i``): ``(i, mean, se)``, or ``None`` when every particle is within."""
    mean, se = counts.mean(axis=0), counts.std(axis=0, ddof=1) / np.sqrt(len(counts))
    if not (np.abs(mean - n * w) > 5 * se + 1e-9).any():
        return None
    i = int(np.argmax(np.abs(mean - n * w) - 5 * se))
    return i, float(mean[i]), float(se[i])


def check_stratified_resampler(fn: Callable, n_draws: int = 4000, seed: int = 0) -> CheckReport:
    """Check a stratified resampler ``fn(weights, n, rng) -> n ancestor indices``, drawing ``n`` particles
    from ``N`` weights, ``n`` and ``N`` different.

    The weights are :data:`STRATIFIED_WEIGHTS` (``N = 8``), ``n`` is :data:`STRATIFIED_DRAWS` (12). First
    the generator: NumPy's global state must be untouched, one seed must give one answer and eleven seeds
    more than one. Then ``n_draws`` calls (one generator seeded ``seed``): indices in range, no particle of
    weight 0 drawn, mean copy counts ``n W_i`` within ``5 SE + 1e-9``, and each particle's ``Var N_i``
    equal to stratified resampling's exact ``sum_j p_ij (1 - p_ij)`` within ``5 SE + 0.02`` (SE from the
    counts' fourth moment). Where the variances are wrong, the scheme whose exact variances are nearest
    (systematic, multinomial) is named: particle 1 (``n W_1 = 1``, astride two strata) has variance 0
    under systematic resampling, 1/2 under stratified and 11/12 under multinomial, about 50 standard
    errors apart at 4000 draws.
    """
    state = np.random.get_state()  # a student's draws from the global generator are undone
    try:
        return _check_stratified(fn, n_draws, seed)
    finally:
        np.random.set_state(state)


def _check_stratified(fn: Callable, n_draws: int, seed: int) -> CheckReport:
    report = CheckReport("stratified resampler")
    w = STRATIFIED_WEIGHTS
    N, n = w.size, STRATIFIED_DRAWS
    first = _answer(report, lambda: fn(w.copy(), n, np.random.default_rng(seed)), "fn(weights, n, rng)",
                    "write the resampler and return the n ancestor indices")
    if first is None:
        return report
    first = np.asarray(first)
    if first.shape == (N,):
        report.problems.append(f"returned {N} indices, one per weight; the resampler must draw n = {n} new "
                               "particles: n strata of width 1/n, one uniform in each, so n indices")
        return report
    if _index_problem(report, first, n, "use astype(int)", "new particle (indices, not copy counts)"):
        return report
    midpoints = np.minimum(np.searchsorted(np.cumsum(w), (np.arange(n) + 0.5) / n, side="right"), N - 1)
    if not _draws_from_its_generator(report, lambda g: fn(w.copy(), n, g), midpoints):
        return report
    counts = _unbiased_counts(
        report, lambda rng: fn(w.copy(), n, rng), n_draws, n, w, np.random.default_rng(seed),
        "the ancestor of u is the i with C[i-1] <= u < C[i], np.searchsorted(C, u, side='right'), capped at N - 1",
        "its segment of the bar has no width, so no uniform can select it; search the cumulative weights with "
        "side='right'",
        lambda i, mean_i, se_i: f"biased: particle {i} of weight {w[i]:.4f} should get n W = {n * w[i]:.3f} copies "
        f"on average, it got {mean_i:.3f} (± {se_i:.3f}) over {n_draws} draws; the uniforms must cover [0, 1) "
        "evenly, one in each of the n strata of width 1/n")
    if counts is None:
        return report
    var = counts.var(axis=0, ddof=1)
    var_se = np.sqrt(np.maximum(((counts - counts.mean(axis=0)) ** 4).mean(axis=0) - var**2, 0) / n_draws)
    exact = _offspring_variances(w, n)
    if np.all(np.abs(var - exact["stratified"]) <= 5 * var_se + 0.02):
        return report
    nearest = min(("systematic", "multinomial"), key=lambda s: np.abs(var - exact[s]).sum())
    fits_nearest = np.all(np.abs(var - exact[nearest]) <= 5 * var_se + 0.02)
    if fits_nearest and nearest == "systematic":
        report.problems.append(
            f"the copies vary like systematic resampling's (particle 1 got exactly one copy in every draw, "
            f"where stratified resampling gives it 0, 1 or 2, Var N_1 = {exact['stratified'][1]:.2f}): each "
            "stratum needs its own uniform, rng.random(n), not one uniform shared by all")
    elif fits_nearest:
        report.problems.append(
            f"the copies vary like multinomial resampling's (Var N_1 = {var[1]:.2f}, stratified gives "
            f"{exact['stratified'][1]:.2f}): put uniform j in its stratum, u_j = (j + U_j) / n, instead of "
            "anywhere in [0, 1)")
    else:
        i = int(np.argmax(np.abs(var - exact["stratified"]) / (var_se + 0.02)))
        report.problems.append(
            f"the copy counts are right on average but their variance is not stratified resampling's: particle "
            f"{i} has Var N_i = {var[i]:.2f}, where one independent uniform per stratum gives "
            f"{exact['stratified'][i]:.2f}")
    return report


def check_weight_update(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(log_weights, log_likelihoods) -> new normalised log-weights`` (module docstring)."""
    report = CheckReport("weight update")
    rng = np.random.default_rng(seed)
    cases = {
        "ordinary values": (np.log(rng.dirichlet(np.ones(50))), rng.normal(-3.0, 2.0, 50)),
        "likelihoods near e^-1000 (they underflow to 0 in the linear domain)": (
            np.full(50, -np.log(50)), rng.normal(-1000.0, 3.0, 50)),
        "one particle with weight 0 (log-weight -inf)": (
            np.concatenate([[-np.inf], np.full(49, -np.log(49))]), rng.normal(-3.0, 1.0, 50)),
    }
    for name, (logw, loglik) in cases.items():
        expected = logw + loglik - logsumexp(logw + loglik)
        try:
            with np.errstate(all="ignore"):
                answer = fn(logw.copy(), loglik.copy())
        except Exception as exc:
            report.problems.append(f"{name}: raised {type(exc).__name__}: {exc}")
            continue
        if answer is None:
            report.problems.append("the function returned None: write the update and return the new log-weights")
            break
        got = np.asarray(answer, dtype=float)
        if got.shape != expected.shape:
            report.problems.append(f"{name}: returned shape {got.shape}, expected {expected.shape}")
        elif np.isnan(got).any():
            report.problems.append(
                f"{name}: NaN in the result; subtract the largest log-weight before exponentiating "
                "(or use scipy.special.logsumexp)")
        elif np.allclose(np.exp(got), np.exp(expected), atol=1e-12, rtol=1e-9):
            continue
        elif np.allclose(got, np.exp(expected), atol=1e-12, rtol=1e-9):
            report.problems.append(f"{name}: you returned the weights W_i, not their logs: return the log-weights "
                                   "(do not exponentiate at the end)")
        elif np.isinf(got[np.isfinite(expected)]).any():
            report.problems.append(f"{name}: an infinite log-weight where the answer is finite: the weights underflowed to 0 in the "
                                   "linear domain, so stay in logs and use scipy.special.logsumexp")
        elif np.allclose(np.exp(got), np.exp(loglik - logsumexp(loglik)), atol=1e-12, rtol=1e-9):
            report.problems.append(f"{name}: the old weights log_W were dropped: the new weight is the old one times "
                                   "the likelihood, so add log_W to log_lik before normalising")
        elif np.allclose(np.exp(got), np.exp(logw + loglik - np.max(logw + loglik)), atol=1e-12, rtol=1e-9):
            report.problems.append(f"{name}: you subtracted the largest log-weight, which avoids overflow but does "
                                   "not normalise: subtract the logsumexp instead")
        else:
            total = np.exp(got).sum()
            hint = " (they do not sum to 1: normalise)" if abs(total - 1) > 1e-9 else ""
            report.problems.append(f"{name}: wrong weights{hint}; largest error "
                                   f"{np.abs(np.exp(got) - np.exp(expected)).max():.2e}")
    return report


#: The case of :func:`check_evidence_increment`: the predictive N(0, 1) of the state, represented by n draws
#: of the proposal N(q_mean, q_sd^2) weighted to it, and a measurement z = x + v, v ~ N(0, sd_v^2).
#: The exact increment is N(z; 0, 1 + sd_v^2).
EVIDENCE_CASE = dict(z=1.2, sd_v=0.5, q_mean=0.5, q_sd=1.5, n=2000)


def evidence_increment_case(seed: int = 0, shift: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Weighted particles of :data:`EVIDENCE_CASE`: ``(log_W, log_lik, exact log increment)``.

    ``shift`` is added to every log-likelihood (and so to the exact value): ``-1000`` makes likelihoods
    near ``e^-1000`` that underflow to 0 in the linear domain."""
    c = EVIDENCE_CASE
    x = c["q_mean"] + c["q_sd"] * np.random.default_rng(seed).standard_normal(c["n"])
    log_w = -0.5 * x**2 + 0.5 * ((x - c["q_mean"]) / c["q_sd"]) ** 2 + np.log(c["q_sd"])
    log_W = log_w - logsumexp(log_w)
    log_lik = -0.5 * ((c["z"] - x) / c["sd_v"]) ** 2 - np.log(c["sd_v"] * np.sqrt(2 * np.pi)) + shift
    var = 1.0 + c["sd_v"] ** 2
    exact = -0.5 * c["z"] ** 2 / var - 0.5 * np.log(2 * np.pi * var) + shift
    return log_W, log_lik, exact


def check_evidence_increment(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(log_W, log_lik) -> log p(z_k | z_{1:k-1})``, ``logsumexp_i(log W_i + log p(z_k | x_i))``.

    Two cases of :func:`evidence_increment_case`: ordinary likelihoods, and the same shifted by ``-1000``.
    An answer off by more than 1e-9 is compared with the typical mistakes (linear-domain underflow, the old
    weights dropped, the increment returned instead of its log, the max subtracted and not added back,
    ``log N`` subtracted from normalised weights), and each is named in its own sentence."""
    report = CheckReport("log evidence increment")
    for name, shift in (("ordinary likelihoods", 0.0),
                        ("likelihoods near e^-1000 (they underflow to 0 in the linear domain)", -1000.0)):
        log_W, log_lik, _ = evidence_increment_case(seed, shift)
        a = log_W + log_lik
        expected = logsumexp(a)
        answer = _answer(report, lambda: fn(log_W.copy(), log_lik.copy()), "fn(log_W, log_lik)",
                         "return log p(z_k | z_1:k-1), one number")
        if answer is None:
            return report
        if np.size(answer) != 1:
            report.problems.append(f"{name}: the answer has shape {np.shape(answer)}: return one number, the log of "
                                   "the increment, not one value per particle")
            return report
        got = float(np.asarray(answer, dtype=float).reshape(()))
        near = lambda value: np.isfinite(value) and abs(got - value) <= 1e-9 * max(1.0, abs(value))
        if near(expected):
            continue
        n = len(a)
        if not np.isfinite(got):
            report.problems.append(
                f"{name}: the answer is {got}: the terms W_i p(z | x_i) underflowed to 0 before the sum, so use "
                "logsumexp(log_W + log_lik), which subtracts the largest term before exponentiating")
        elif near(logsumexp(log_lik) - np.log(n)):
            report.problems.append(
                f"{name}: the old weights log_W were dropped: you averaged the likelihoods as if the particles were "
                "equally weighted, but each counts with its weight W_i, so add log_W to log_lik")
        elif near(np.exp(expected)):
            report.problems.append(
                f"{name}: you returned the increment p(z_k | z_1:k-1) itself, not its log: return the logsumexp "
                "without exponentiating it")
        elif near(expected - a.max()) or near(a.max()):
            report.problems.append(
                f"{name}: the largest term max_i(log W_i + log p(z | x_i)) was subtracted (or kept alone) instead of "
                "taking the logsumexp: subtract it before exponentiating, then add it back after the log")
        elif near(expected - np.log(n)):
            report.problems.append(
                f"{name}: log N was subtracted, but the weights W_i already sum to 1: the increment is "
                "sum_i W_i p(z | x_i), with no 1/N")
        else:
            report.problems.append(f"{name}: the answer {got:.6f} is not logsumexp_i(log W_i + log p(z | x_i)) = "
                                   f"{expected:.6f}; add the log-weights and the log-likelihoods, then logsumexp")
    return report


#: The case of :func:`check_importance_sampler`: the measurement z and the noise sd sd_v of the toy.
IS_TOY_CASE = (3.0, 0.5)
#: Its underflow case: z = 60, sd_v = 1, where p(z | x) p(x) = exp(-(x - 30)^2 - 900) / (2 pi) is below the
#: smallest positive float (about exp(-745)) at every x, so weights computed outside the log domain are all 0;
#: the proposal N(z/2, 1) is centred on the posterior N(30, 1/2) there, so ESS / n tends to 0.866.
IS_UNDERFLOW_CASE = (60.0, 1.0)

#: The typical mistakes of the importance-sampling exercise: the weight each one computes, in words.
IS_TOY_MISTAKES = {
    "likelihood_only": "the weight is the likelihood alone, as with the prior as proposal; with q = N(z/2, 1) "
                       "it is log p(z | x) + log p(x) - log q(x)",
    "no_proposal": "the weight leaves out - log q(x): draws from q must be divided by q, w = p(z | x) p(x) / q(x)",
    "proposal_added": "the weight adds log q(x) instead of subtracting it: draws from q must be divided by q, "
                      "log w = log p(z | x) + log p(x) - log q(x)",
    "no_prior": "the weight leaves out the prior, + log p(x): the target is the posterior, p(z | x) p(x) up to a "
                "constant",
    "sd_as_variance": "the likelihood uses sd_v^2 as its standard deviation: sd_v is the standard deviation of v "
                      "(scipy.stats.norm.logpdf(z, loc=x, scale=sd_v))",
}


def toy_is_limit(z: float, sd_v: float, mistake: str | None = None) -> tuple[float, float]:
    """Mean and variance of the density a self-normalised importance sampler with proposal N(z/2, 1)
    targets on the toy (prior N(0, 1), z = x + v, v ~ N(0, sd_v^2)): the posterior, or what the weight of
    ``mistake`` (a key of :data:`IS_TOY_MISTAKES`) makes of it, ``q x target-of-the-weight``.

    Every factor is Gaussian in x, so the limit is a product of Gaussians: precisions add (the proposal's
    with the sign it has in q x weight) and so do precision-weighted means.
    """
    if mistake is not None and mistake not in IS_TOY_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(IS_TOY_MISTAKES)}")
    lik_var = sd_v**4 if mistake == "sd_as_variance" else sd_v**2
    # (precision, mean) of the factors of q(x) w(x): the likelihood, the prior, the proposal
    factors = {"likelihood_only": [(1 / lik_var, z), (1.0, z / 2)],
               "no_proposal": [(1 / lik_var, z), (1.0, 0.0), (1.0, z / 2)],
               "proposal_added": [(1 / lik_var, z), (1.0, 0.0), (2.0, z / 2)],
               "no_prior": [(1 / lik_var, z)]}.get(mistake, [(1 / lik_var, z), (1.0, 0.0)])
    precision = sum(p for p, _ in factors)
    return sum(p * m for p, m in factors) / precision, 1 / precision


def _gauss_chi2(mean: float, var: float, q_mean: float, q_var: float) -> tuple[float, float]:
    """``E_q[w^2] = int pi^2 / q`` and the asymptotic variance ``sigma^2 = int pi^2 (x - mean)^2 / q`` of the
    self-normalised estimate of the mean of ``pi = N(mean, var)`` from draws of ``q = N(q_mean, q_var)``.

    ``pi^2 / q`` is a Gaussian of precision ``a = 2 / var - 1 / q_var`` times a constant ``C``; both
    integrals are infinite when ``a <= 0`` (``q`` much lighter-tailed than ``pi``).
    """
    a = 2 / var - 1 / q_var
    if a <= 0:
        return np.inf, np.inf
    b = 2 * mean / var - q_mean / q_var
    c = -mean**2 / var + q_mean**2 / (2 * q_var)
    C = np.sqrt(q_var) / (var * np.sqrt(a)) * np.exp(b * b / (2 * a) + c)
    return C, C * (1 / a + (b / a - mean) ** 2)


def toy_is_ess_ratio(z: float, sd_v: float, q_mean: float | None = None, q_var: float = 1.0) -> float:
    """The limit of ESS / n on the toy, ``1 / E_q[w^2]`` (proposal ``N(z/2, 1)`` unless given)."""
    mean, var = toy_is_limit(z, sd_v)
    return 1 / _gauss_chi2(mean, var, z / 2 if q_mean is None else q_mean, q_var)[0]


def check_importance_sampler(fn: Callable, n: int = 20_000, seed: int = 0) -> CheckReport:
    """Check ``fn(z, sd_v, n, rng) -> (estimate, ess)`` (importance sampling, exercise 3.1), leaving NumPy's
    global ``np.random`` state as it was.

    ``fn`` draws ``n`` particles from the proposal ``N(z / 2, 1)`` and returns the self-normalised estimate
    of the posterior mean of the toy (prior ``N(0, 1)``, ``z = x + v``, ``v ~ N(0, sd_v^2)``) and the ESS.
    The estimate must be within six Monte Carlo standard errors ``sqrt(sigma^2 / n)`` of the exact mean
    ``z / (1 + sd_v^2)`` at :data:`IS_TOY_CASE`, with ``sigma^2`` the exact asymptotic variance for this
    proposal (:func:`_gauss_chi2`; a correct sampler fails with probability about 2e-9); a wrong one is
    compared with the limits of :data:`IS_TOY_MISTAKES`, and the report names the mistake. The ESS / n
    must be within 10 % of its limit ``1 / E_q[w^2]`` (0.383 at :data:`IS_TOY_CASE`; its Monte Carlo
    standard deviation at n = 20 000 is 0.003, so 10 % is over ten of them), which tells the asked
    proposal from the prior, an exact posterior sampler or a wider Gaussian. The random numbers must come
    from ``rng`` (:func:`_generator_problem`, on 500 particles). A sampler right there is run again at
    :data:`IS_UNDERFLOW_CASE`, where weights computed outside the log domain underflow to 0 (the estimate
    becomes 0 / 0), and is held to the same six standard errors and 10 %.
    """
    saved = np.random.get_state()
    try:
        return _check_importance_sampler(fn, n, seed)
    finally:
        np.random.set_state(saved)


def _check_importance_sampler(fn: Callable, n: int, seed: int) -> CheckReport:
    report = CheckReport("importance sampler")
    z, sd_v = IS_TOY_CASE
    answer = _answer(report, lambda: fn(z, sd_v, n, np.random.default_rng(seed)), "fn(z, sd_v, n, rng)",
                     "write the sampler and return (estimate, ess)")
    if answer is None:
        return report
    try:
        estimate, ess = (float(v) for v in answer)
    except Exception:
        report.problems.append("return two numbers, (estimate, ess): the weighted mean of the draws and "
                               "1 / sum(W**2)")
        return report
    if not (np.isfinite(estimate) and np.isfinite(ess)):
        report.problems.append("the estimate or the ESS is NaN or infinite: keep the weights in the log domain and "
                               "subtract their logsumexp before exponentiating")
        return report
    if not 1 - 1e-9 <= ess <= n * (1 + 1e-9):
        report.problems.append(f"the ESS is {ess:.4g}, outside [1, n]: compute it from normalised weights, "
                               "1 / sum(W**2) with sum(W) = 1")
        return report
    problem = _generator_problem(lambda rng: float(fn(z, sd_v, 500, rng)[0]), lambda a, b: a == b,
                                 what="estimate")
    if problem is not None:
        report.problems.append(problem)
        return report

    def fits(mistake: str | None) -> bool:
        mean, var = toy_is_limit(z, sd_v, mistake)
        sigma2 = _gauss_chi2(mean, var, z / 2, 1.0)[1]
        return abs(estimate - mean) <= 6 * np.sqrt(sigma2 / n)

    ratio, expected = ess / n, toy_is_ess_ratio(z, sd_v)
    rtol = 0.1 * max(1.0, np.sqrt(20_000 / n))
    near = lambda r: abs(ratio - r) <= rtol * r  # noqa: E731
    if fits(None) and near(expected):
        _check_underflow_case(report, fn, n, seed)
        return report
    if ratio >= 1 - 1e-9:
        report.problems.append("the ESS equals n, so every weight is the same: the draws must come from the "
                               "proposal N(z/2, 1), not from the posterior, and carry the weight "
                               "p(z | x) p(x) / q(x)")
        return report
    if near(toy_is_ess_ratio(z, sd_v, 0.0, 1.0)):
        report.problems.append(f"the ESS / n is {ratio:.3f}, what draws from the prior N(0, 1) give: the "
                               f"exercise asks for the proposal N(z/2, 1), whose ESS / n is {expected:.3f}")
        return report
    if fits(None):
        report.problems.append(f"the estimate is right but the ESS / n is {ratio:.3f}, not about {expected:.3f}, "
                               "the value for draws from N(z/2, 1): draw x = z/2 + rng.standard_normal(n) "
                               "(standard deviation 1) and return 1 / sum(W**2) of the normalised weights")
        return report
    if _settled(report, fits, IS_TOY_MISTAKES):
        return report
    mean, var = toy_is_limit(z, sd_v)
    sigma2 = _gauss_chi2(mean, var, z / 2, 1.0)[1]
    report.problems.append(f"the estimate {estimate:.4f} is more than six Monte Carlo standard errors "
                           f"({np.sqrt(sigma2 / n):.4f}) from the exact posterior mean {mean:.4f}: check the "
                           "draws (x ~ N(z/2, 1)), the three terms of the log-weight and the normalisation")
    return report


def _check_underflow_case(report: CheckReport, fn: Callable, n: int, seed: int) -> None:
    """Run a sampler that is right at IS_TOY_CASE at IS_UNDERFLOW_CASE (its RuntimeWarnings silenced: the
    report says what went wrong)."""
    z, sd_v = IS_UNDERFLOW_CASE
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            estimate, ess = (float(v) for v in fn(z, sd_v, n, np.random.default_rng(seed)))
        except Exception as exc:
            report.problems.append(f"at z = {z:g}, sd_v = {sd_v:g} the sampler raised {type(exc).__name__}: {exc}")
            return
    mean, var = toy_is_limit(z, sd_v)
    sigma2 = _gauss_chi2(mean, var, z / 2, 1.0)[1]
    expected = toy_is_ess_ratio(z, sd_v)
    if np.isfinite(estimate) and not np.isfinite(ess) and abs(estimate - mean) <= 6 * np.sqrt(sigma2 / n):
        report.problems.append(
            f"at z = {z:g}, sd_v = {sd_v:g} the estimate {estimate:.4f} is right but the ESS is {ess}: there the "
            "weights are about e^-900, so exp(log_w) taken before subtracting the logsumexp underflows to 0 and "
            "the ESS divides 0 by 0; compute it as 1 / sum(W**2) from the normalised weights W")
    elif not (np.isfinite(estimate) and np.isfinite(ess)):
        report.problems.append(
            f"at z = {z:g}, sd_v = {sd_v:g} the estimate is {estimate:.4f} and the ESS {ess:.1f}: there p(z | x) p(x) is "
            "about e^-900, below the smallest float (about e^-745), so weights computed as densities or as "
            "exp(log_w) underflow to 0 and normalising them divides 0 by 0; keep the log-weights and subtract "
            "their logsumexp (or their max) before exponentiating")
    elif abs(estimate - mean) > 6 * np.sqrt(sigma2 / n) or abs(ess / n - expected) > 0.1 * max(
            1.0, np.sqrt(20_000 / n)) * expected:
        report.problems.append(
            f"at z = {z:g}, sd_v = {sd_v:g} the answer ({estimate:.4f}, ESS / n {ess / n:.3f}) is not the exact "
            f"posterior mean {mean:.4f} with ESS / n about {expected:.3f}, though it is right at z = 3: the tiny "
            "weights there (about e^-900) need the log domain all the way, logsumexp included")


@dataclass(frozen=True)
class ScalarModel:
    """``x_0 ~ N(m0, p0)``, ``x_k = a x_{k-1} + w_k`` with ``w_k ~ N(0, q)``, ``z_k = x_k + v_k``
    with ``v_k ~ N(0, r)``: ``p0``, ``q`` and ``r`` are *variances*."""

    a: float = 0.9
    q: float = 0.5
    r: float = 0.5
    m0: float = 0.0
    p0: float = 1.0


def _scalar_filter(z: np.ndarray, model: ScalarModel, last_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance over the steps of the posterior the weighted cloud estimates.

    ``last_only=False``: the Kalman filter, ``p(x_k | z_{1:k})``, exact for this model
    (:func:`scalar_kalman`). With ``last_only=True``, the limit of an SIS whose weights forget the
    previous step: the prior marginal of ``x_j`` updated by ``z_j`` alone (``j`` the last measured
    step), moved on to ``k``.
    """
    if not last_only:
        return scalar_kalman(z, model)[:2]
    a, q, r = model.a, model.q, model.r
    mean, var = np.empty(len(z)), np.empty(len(z))
    m, p = model.m0, model.p0  # the forgetful posterior
    prior_m, prior_p = model.m0, model.p0  # the prior marginal of x_k
    for k, zk in enumerate(z):
        if k > 0:
            m, p = a * m, a * a * p + q
            prior_m, prior_p = a * prior_m, a * a * prior_p + q
        if not np.isnan(zk):
            gain = prior_p / (prior_p + r)
            m, p = prior_m + gain * (zk - prior_m), (1 - gain) * prior_p
        mean[k], var[k] = m, p
    return mean, var


def _sis_ess_ratio(z: np.ndarray, model: ScalarModel, mode: str = "sis") -> np.ndarray:
    """The limit of ``ESS_k / N`` per step, ``1 / E[W^2]`` in closed form (Kong et al. 1994).

    ``mode="sis"``: the weight of a path drawn from the prior is ``prod_j N(z_j; x_j, r)`` over the
    measured steps, and with ``N(z; x, r)^2 = N(z; x, r/2) / sqrt(4 pi r)`` both ``E[w]`` and ``E[w^2]``
    are Gaussian densities of the measured ``z_j`` under the prior. ``"resample"``: a filter that
    resamples before each measured step weights the one-step predictive (Kalman) by the last
    likelihood only;
    ``"forget"``: a filter whose weights forget the previous steps weights the prior marginal by it.
    """
    from scipy import stats

    n_steps, r = len(z), model.r
    var = np.empty(n_steps)
    var[0] = model.p0
    for k in range(1, n_steps):
        var[k] = model.a**2 * var[k - 1] + model.q
    mean = model.m0 * model.a ** np.arange(n_steps)
    i, j = np.meshgrid(np.arange(n_steps), np.arange(n_steps), indexing="ij")
    cov = model.a ** np.abs(i - j) * var[np.minimum(i, j)]
    if mode == "resample":
        m_f, p_f = scalar_kalman(z, model)[:2]
    out = np.ones(n_steps)
    for k in range(n_steps):
        measured = np.flatnonzero(~np.isnan(z[:k + 1]))
        if measured.size == 0:
            continue
        if mode == "sis":
            idx, mu, S = measured, mean[measured], cov[np.ix_(measured, measured)]
        else:
            last = measured[-1]
            if mode == "forget":
                mu, S = mean[[last]], np.array([[var[last]]])
            elif last == 0:
                mu, S = np.array([model.m0]), np.array([[model.p0]])
            else:
                mu = np.array([model.a * m_f[last - 1]])
                S = np.array([[model.a**2 * p_f[last - 1] + model.q]])
            idx = np.array([last])
        d, zz = idx.size, z[idx]
        log_e2 = -d / 2 * np.log(4 * np.pi * r) + stats.multivariate_normal.logpdf(zz, mu, S + r / 2 * np.eye(d))
        log_e1 = stats.multivariate_normal.logpdf(zz, mu, S + r * np.eye(d))
        out[k] = np.exp(2 * log_e1 - log_e2)
    return out


#: The measurements of :func:`check_sis`: none at step 0 (the cloud is the prior), one missing later.
SIS_CASE = np.array([np.nan, 1.2, 2.0, np.nan, 0.3])


def check_sis(fn: Callable, n_particles: int = 20_000, seed: int = 0, z: np.ndarray = SIS_CASE) -> CheckReport:
    """Check a student's SIS ``fn`` (:func:`_check_sis`), leaving NumPy's global ``np.random`` state as it was."""
    saved = np.random.get_state()
    try:
        return _check_sis(fn, n_particles, seed, z)
    finally:
        np.random.set_state(saved)


def _check_sis(fn: Callable, n_particles: int, seed: int, z: np.ndarray) -> CheckReport:
    """Check a student's SIS ``fn(z, n_particles, rng, model) -> (means, ess)`` (module docstring).

    ``z`` (default :data:`SIS_CASE`) has shape ``(K,)`` with NaN where nothing is measured (at
    least at step 0); ``means`` and
    ``ess`` have shape ``(K,)``: the weighted mean of the particles and the effective sample size
    after each step. The means must agree with the Kalman filter's within six Monte Carlo
    standard errors, ``sqrt(P_k / ESS_k)`` with the reference ESS ``N / E[W_k^2]`` in closed form
    (:func:`_sis_ess_ratio`), at every step, and the ESS must be within 10 % of that reference (a correct SIS fails this with
    probability below 1e-6); a filter that does not is compared with the limits of the typical
    mistakes, and the report names the one that fits. The filter must draw its random numbers from
    the generator it is given (:func:`_generator_problem`, on 200 particles).
    """
    report = CheckReport("SIS")
    model = ScalarModel()
    answer = _per_step_answer(
        report, lambda: fn(np.array(z, dtype=float), n_particles, np.random.default_rng(seed), model),
        "fn(z, n_particles, rng, model)", "(means, ess)", ("mean", "ESS"), z.size)
    if answer is None:
        return report
    means, ess = answer
    k_steps = z.size
    bad = ~(np.isfinite(means) & np.isfinite(ess))
    if bad.any():
        k = int(np.argmax(bad))
        why = ("z[0] is NaN (nothing measured): skip the weight update when z_k is NaN" if np.isnan(z[k])
               else "weights that all underflow to 0 give 0/0: keep log-weights and subtract their logsumexp")
        report.problems.append(f"the mean or the ESS is NaN or infinite at step {k}; {why}")
        return report
    if abs(ess[0] - n_particles) > 1e-6 * n_particles:
        report.problems.append(f"the ESS at step 0 is {ess[0]:.6g}, not N = {n_particles}: nothing is measured "
                               "at step 0, so every weight is 1/N")
        return report
    if (ess < 1 - 1e-9).any() or (ess > n_particles * (1 + 1e-9)).any():
        k = int(np.argmax((ess < 1 - 1e-9) | (ess > n_particles * (1 + 1e-9))))
        report.problems.append(f"the ESS at step {k} is {ess[k]:.4g}, outside [1, N]: compute it from normalised "
                               "weights, 1 / sum(W**2) with sum(W) = 1")
        return report
    problem = _generator_problem(lambda rng: fn(np.array(z, dtype=float), 200, rng, model),
                                 lambda a, b: np.array_equal(np.asarray(a[0], dtype=float), np.asarray(b[0], dtype=float),
                                                             equal_nan=True), what="set of means")
    if problem is not None:
        report.problems.append(problem)
        return report
    exact = _scalar_filter(z, model)
    # the reference ESS, N / E[W^2] in closed form: it sets the tolerance, the student's does not
    rtol = 0.1 * max(1.0, np.sqrt(20_000 / n_particles))
    ref = np.maximum(n_particles * _sis_ess_ratio(z, model), 1.0)

    def near(ratio: np.ndarray) -> bool:
        target = np.maximum(n_particles * ratio, 1.0)
        return bool(np.all(np.abs(ess - target) <= rtol * target + 2.0))

    if _fits(means, ref, *exact):
        if near(_sis_ess_ratio(z, model)):
            return report
        if near(_sis_ess_ratio(z, model, "resample")):
            report.problems.append("your ESS is that of a filter that resamples at every step (SIR): SIS never "
                                   "resamples, so the weights keep multiplying and the ESS keeps falling")
            return report
        k = int(np.argmax(np.abs(ess - ref) / ref))
        report.problems.append(f"the means are right but the ESS at step {k} is {ess[k]:.4g}, not about "
                               f"{ref[k]:.4g} (1 / E[W^2] in closed form): return 1 / sum(W**2) of the "
                               "normalised weights after each step")
        return report
    mistakes = {
        "the particles are never weighted: multiply each weight by p(z_k | x_k) when z_k is measured, "
        "or the cloud stays the prior": (_scalar_filter(np.full_like(z, np.nan), model),
                                         np.ones(len(z))),
        "the weights forget the previous steps: multiply the new likelihood into the previous weights "
        "(log W_k = log W_(k-1) + log p(z_k | x_k)) instead of replacing them":
            (_scalar_filter(z, model, last_only=True), _sis_ess_ratio(z, model, "forget")),
        "the particles move without process noise: add w_k ~ N(0, q) with variance q (standard deviation "
        "sqrt(q)) when you propagate them": (_scalar_filter(z, ScalarModel(q=0.0)),
                                             _sis_ess_ratio(z, ScalarModel(q=0.0))),
        "the likelihood uses r as a standard deviation: r is the variance of v_k, so the standard deviation "
        "is sqrt(r)": (_scalar_filter(z, ScalarModel(r=model.r**2)), _sis_ess_ratio(z, ScalarModel(r=model.r**2))),
        "the process noise uses q as a standard deviation: q is the variance of w_k, so the standard "
        "deviation is sqrt(q)": (_scalar_filter(z, ScalarModel(q=model.q**2)),
                                 _sis_ess_ratio(z, ScalarModel(q=model.q**2))),
    }
    for why, ((mean, var), ratio) in mistakes.items():
        if _fits(means, np.maximum(n_particles * ratio, 1.0), mean, var):
            report.problems.append(f"your means match a known mistake, not the exact posterior: {why}")
            return report
    k = int(np.argmax(np.abs(means - exact[0]) / np.sqrt(exact[1] / ref)))
    report.problems.append(
        f"at step {k} your mean is {means[k]:.3f}, the exact (Kalman) mean is {exact[0][k]:.3f}, more than six "
        f"Monte Carlo standard errors ({np.sqrt(exact[1][k] / ref[k]):.3f}) away: check the proposal "
        "(x_k = a x_(k-1) + w_k), the log-likelihood of z_k and the weighted mean")
    return report


def _per_step_answer(report: CheckReport, call: Callable, signature: str, returns: str, names: tuple[str, ...],
                     k_steps: int, todo: str = "write the filter",
                     per: str = "per step, step 0 included") -> tuple | None:
    """The student's answer ``call()``: the tuple ``returns`` names, whose first ``len(names)`` entries are
    arrays of one value per step, shape ``(k_steps,)``, converted to float; the rest as they are. ``None``,
    with the problem reported in one sentence, when the call raises or returns ``None``, the wrong number
    of values or arrays of the wrong shape. ``todo`` says what to write, ``per`` what each value belongs
    to (a step by default; a parent for a proposal)."""
    expected = returns.count(",") + 1
    answer = _answer(report, call, signature, f"{todo} and return {returns}")
    if answer is None:
        return None
    try:
        with np.errstate(all="ignore"):
            answer = tuple(answer)
            if len(answer) != expected:
                report.problems.append(f"the function returned {len(answer)} values; return {expected}: {returns}")
                return None
            arrays = [np.asarray(v, dtype=float) for v in answer[:len(names)]]
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling {signature} raised {type(exc).__name__}: {exc}")
        return None
    if any(v.shape != (k_steps,) for v in arrays):
        shapes = " and ".join(str(v.shape) for v in arrays)
        report.problems.append(f"returned shapes {shapes}; expected ({k_steps},) each: "
                               f"one {' and one '.join(names)} {per}")
        return None
    return (*arrays, *answer[len(names):])


def _fits(means: np.ndarray, ess: np.ndarray, mean: np.ndarray, var: np.ndarray, z_max: float = 6.0) -> bool:
    """Whether the cloud's means agree with a posterior's within ``z_max`` Monte Carlo standard errors."""
    return bool(np.all(np.abs(means - mean) <= z_max * np.sqrt(var / np.clip(ess, 1, None)) + 1e-12))


def _origins(ancestors: np.ndarray, steps: range) -> np.ndarray:
    """Follow ``a = ancestors[k][a]`` over ``steps``, starting from every particle of the final step."""
    a = np.arange(ancestors.shape[1])
    for k in steps:
        a = ancestors[k][a]
    return a


def check_ancestors(fn: Callable, seed: int = 0) -> CheckReport:
    """Check a student's genealogy ``fn(ancestors) -> origins`` on random ancestor indices.

    ``ancestors`` has shape ``(K, N)``: ``ancestors[k, i]`` is :math:`a_k^i`, the particle of step
    ``k - 1`` that particle ``i`` of step ``k`` descends from (row 0 is unused). The answer must be,
    for each particle ``i`` of the final step ``K - 1``, the particle of step 0 its lineage starts from,

    .. math:: o^i = a_1^{a_2^{\\cdots a_{K-1}^i}},

    that is ``a = ancestors[k][a]`` for ``k = K - 1, ..., 1``. A wrong answer is compared with
    what the typical mistakes give (the steps followed forwards or the indexing turned round, one
    generation only, the last step left out, the first step left out), so the report names the
    mistake.
    """
    report = CheckReport("genealogy")
    rng = np.random.default_rng(seed)
    n_steps, n = 7, 12
    ancestors = np.sort(rng.integers(0, n, size=(n_steps, n)), axis=1)  # sorted, as the resamplers return them
    ancestors[0] = np.arange(n)
    ancestors[3] = np.arange(n)  # a step without resampling: each particle is its own parent
    answer = _answer(report, lambda: fn(ancestors.copy()), "fn(ancestors)",
                     "follow the ancestors back and return the origins")
    if answer is None:
        return report
    answer = np.asarray(answer)
    if answer.shape != (n,):
        report.problems.append(f"returned shape {answer.shape}; expected ({n},): one step-0 origin per particle "
                               "of the final step")
        return report
    if np.array_equal(answer, _origins(ancestors, range(n_steps - 1, 0, -1))):
        return report
    mistakes = {
        "the steps are followed forwards (k = 1, 2, ...), or the indexing is turned round (a[ancestors[k]] "
        "instead of ancestors[k][a], which composes the steps in the forward order): a lineage is read "
        "backwards, from the final step to step 0, a = ancestors[k][a] for k = K - 1, ..., 1":
            _origins(ancestors, range(1, n_steps)),
        "only one generation is followed: ancestors[K - 1] gives the parents at step K - 2, and their own "
        "parents must be followed down to step 0": ancestors[-1],
        "the last step is left out: the lineage of a particle of step K - 1 starts with its parent "
        "ancestors[K - 1][i]": _origins(ancestors, range(n_steps - 2, 0, -1)),
        "the first step is left out (the loop stops at k = 2): range(K - 1, 0, -1) runs down to k = 1, "
        "whose ancestors are the particles of step 0": _origins(ancestors, range(n_steps - 1, 1, -1)),
    }
    for why, wrong in mistakes.items():
        if np.array_equal(answer, wrong):
            report.problems.append(f"your origins match a known mistake: {why}")
            return report
    i = int(np.argmax(answer != _origins(ancestors, range(n_steps - 1, 0, -1))))
    report.problems.append(f"particle {i} of the final step descends from particle "
                           f"{_origins(ancestors, range(n_steps - 1, 0, -1))[i]} of step 0, not {answer[i]}: "
                           "follow a = ancestors[k][a] from k = K - 1 down to k = 1")
    return report


def _global_state_key() -> tuple:
    """NumPy's global ``np.random`` state, comparable with ``==``."""
    name, keys, pos, has_gauss, cached = np.random.get_state()
    return name, keys.tobytes(), pos, has_gauss, cached


def _generator_problem(call: Callable, same: Callable[[object, object], bool], seeds: tuple[int, ...] = (1, 2, 3, 4),
                       what: str = "answer") -> str | None:
    """One sentence if ``call(rng)`` does not draw its random numbers from the generator ``rng`` it is given.

    Checked in turn: NumPy's global ``np.random`` state is untouched (it is saved and restored); two
    generators of the same seed give the same answer (``same(a, b)``); another seed gives another
    answer for at least one of ``seeds[1:]``. ``None`` when all three hold, or when a call raises
    (the caller reports that).
    """
    saved = np.random.get_state()
    try:
        before = _global_state_key()
        first = call(np.random.default_rng(seeds[0]))
        touched = _global_state_key() != before
    except Exception:
        return None
    finally:
        np.random.set_state(saved)
    if touched:
        return ("it draws from NumPy's global generator (np.random.random, np.random.choice, ...), not from the "
                "generator rng it is given: use rng.random(...), so that a seed fixes the result")
    try:
        again = call(np.random.default_rng(seeds[0]))
        others = [call(np.random.default_rng(s)) for s in seeds[1:]]
    except Exception:
        return None
    if not same(first, again):
        return (f"two generators of the same seed gave different {what}s: draw every random number from the rng "
                "argument (no np.random.default_rng() of your own inside the function)")
    if all(same(first, other) for other in others):
        return (f"the {what} is the same whatever the generator's seed: the rng argument is not used, so the "
                "result is not random")
    return None


def check_multinomial_resampler(fn: Callable, n_draws: int = 4000, seed: int = 0) -> CheckReport:
    """Check multinomial resampling ``fn`` (:func:`_check_multinomial_resampler`), leaving NumPy's global
    ``np.random`` state as it was."""
    saved = np.random.get_state()
    try:
        return _check_multinomial_resampler(fn, n_draws, seed)
    finally:
        np.random.set_state(saved)


def _check_multinomial_resampler(fn: Callable, n_draws: int, seed: int) -> CheckReport:
    """Check multinomial resampling ``fn(weights, rng) -> N ancestor indices`` (SIR, exercise 5.3).

    The indices must be ``N`` independent draws from the weights, taken from the generator ``rng``
    (:func:`_generator_problem`: global state untouched, same seed same answer, another seed another
    answer). On ``W`` (``N = 7``, one weight 0), over ``n_draws`` calls: a particle of weight 0 is never
    chosen; the copy counts ``N_i`` have mean ``N W_i`` within ``5 SE + 1e-9``; and their total variance
    ``sum_i Var N_i`` is multinomial's ``sum_i N W_i (1 - W_i)`` within a factor ``[0.8, 1.25]``
    (measured 0.995 for multinomial, 0.37 stratified, 0.20 systematic, 0.43 residual, about 7 for one
    uniform shared by all; its relative standard error is about 2 % over 4000 draws). Residual
    resampling is told apart by its deterministic copies: at least ``floor(N W_i)`` in every draw, and
    sometimes more than ``ceil(N W_i)`` (which systematic resampling never gives). ``rng.choice(N, N,
    p=W)`` passes: it inverts the cumulative weights with ``N`` uniforms, as the exercise asks.
    """
    report = CheckReport("multinomial resampler")
    w = np.array([0.05, 0.3, 0.0, 0.12, 0.08, 0.25, 0.2])
    n = w.size
    first = _answer(report, lambda: fn(w.copy(), np.random.default_rng(seed)), "fn(weights, rng)",
                    "write the resampler and return the N ancestor indices")
    if first is None or _index_problem(report, first, n, "np.searchsorted gives them"):
        return report
    problem = _generator_problem(lambda rng: np.asarray(fn(w.copy(), rng)), np.array_equal, what="set of indices")
    if problem is not None:
        report.problems.append(problem)
        return report
    counts = _unbiased_counts(
        report, lambda rng: fn(w.copy(), rng), n_draws, n, w, np.random.default_rng(seed),
        "np.searchsorted on the cumulative weights gives 0..N-1, with the last cumulative weight set to 1",
        "a uniform u must select the i with cumsum[i-1] <= u < cumsum[i] (np.searchsorted(np.cumsum(W), u, "
        "side='right')), never a zero-width interval",
        lambda i, mean_i, se_i: f"biased: particle {i} of weight {w[i]} should get N W = {n * w[i]:.3f} copies on "
        f"average, it got {mean_i:.3f} (± {se_i:.3f}) over {n_draws} draws: each index is j with probability W_j")
    if counts is None:
        return report
    ratio = counts.var(axis=0, ddof=1).sum() / float(np.sum(n * w * (1 - w)))
    low, high = np.floor(n * w), np.ceil(n * w)
    if ratio < 0.8 and (counts >= low).all() and (counts > high).any():
        report.problems.append(
            f"the copy counts vary {ratio:.2f} times as much as multinomial resampling's, and every particle "
            "always gets at least floor(N W_i) copies: this is residual resampling (deterministic copies, then "
            "draws on the remainders); multinomial resampling draws N independent uniforms on [0, 1)")
    elif ratio < 0.8:
        report.problems.append(
            f"the copy counts vary {ratio:.2f} times as much as multinomial resampling's: this is a stratified or "
            "systematic resampler (uniforms spread over the strata [i/N, (i+1)/N)); multinomial resampling draws "
            "N independent uniforms on [0, 1)")
    elif ratio > 1.25:
        report.problems.append(
            f"the copy counts vary {ratio:.2f} times as much as multinomial resampling's: the N draws are not "
            "independent (one uniform shared by all particles?); draw N uniforms, rng.random(N)")
    return report


#: The measurements of :func:`check_kalman`: none at step 0 (the filter starts from the prior), two missing later.
KALMAN_CASE = np.array([np.nan, 1.2, 2.0, np.nan, 0.3, np.nan, -0.4])


#: The typical mistakes of a scalar Kalman filter, each as the flag of :func:`scalar_kalman` that makes
#: it, with the sentence that names it (what is wrong, and why).
KALMAN_MISTAKES = {
    "gain_with_p": "the gain divides by the predicted variance P_k^- instead of the innovation variance "
                   "S_k = P_k^- + r: K_k = P_k^- / S_k weighs the prediction against the measurement noise",
    "no_q": "the predicted variance forgets the process noise: P_k^- = a^2 P_(k-1) + q, the state moves "
            "by w_k ~ N(0, q) at every step",
    "r_as_sd": "the update uses r as a standard deviation: r is the variance of v_k, so S_k = P_k^- + r, "
               "not P_k^- + r^2",
    "q_as_sd": "the prediction uses q as a standard deviation: q is the variance of w_k, so P_k^- = a^2 P_(k-1) "
               "+ q, not + q^2",
    "predict_at_0": "step 0 is predicted: the filter starts from N(m0, p0) at step 0 and predicts only from "
                    "step 1 on",
    "nan_as_zero": "a missing measurement (NaN) is used as z_k = 0: when nothing is measured, skip the update "
                   "(the filtering density is then the predicted one)",
    "no_update_of_p": "the variance is not updated: after a measurement P_k = (1 - K_k) P_k^-, smaller than P_k^-",
    "loglik_with_p": "the log-likelihood uses P_k^- where it needs S_k: the increment is log N(nu_k; 0, S_k), "
                     "the innovation's density, with S_k = P_k^- + r",
    "loglik_no_constant": "the log-likelihood misses the normalising term: log N(nu_k; 0, S_k) = "
                          "-(nu_k^2 / S_k + log(2 pi S_k)) / 2",
}


def scalar_kalman(z: np.ndarray, model: ScalarModel, mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The Kalman filter of a :class:`ScalarModel`: ``(means, variances, log_likelihood)`` over the steps.

    Step 0 starts from ``N(m0, p0)``; step ``k > 0`` predicts ``m_k^- = a m_(k-1)``,
    ``P_k^- = a^2 P_(k-1) + q``. A measured ``z_k`` updates with the innovation
    ``nu_k = z_k - m_k^-``, its variance ``S_k = P_k^- + r`` and the gain ``K_k = P_k^- / S_k``:
    ``m_k = m_k^- + K_k nu_k``, ``P_k = (1 - K_k) P_k^-``, and adds
    ``log N(nu_k; 0, S_k) = -(nu_k^2 / S_k + log(2 pi S_k)) / 2`` to the log-likelihood; a NaN
    ``z_k`` (nothing measured) skips the update. ``mistake`` (a key of :data:`KALMAN_MISTAKES`)
    computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in KALMAN_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(KALMAN_MISTAKES)}")
    a = model.a
    q = model.q**2 if mistake == "q_as_sd" else 0.0 if mistake == "no_q" else model.q
    r = model.r**2 if mistake == "r_as_sd" else model.r
    m, p, log_lik = model.m0, model.p0, 0.0
    means, variances = np.empty(len(z)), np.empty(len(z))
    for k, zk in enumerate(z):
        if k > 0 or mistake == "predict_at_0":
            m, p = a * m, a * a * p + q
        if np.isnan(zk) and mistake == "nan_as_zero":
            zk = 0.0
        if not np.isnan(zk):
            nu, s = zk - m, p + r
            gain = 1.0 if mistake == "gain_with_p" else p / s
            s_lik = p if mistake == "loglik_with_p" else s
            log_lik += -0.5 * nu**2 / s_lik - (0.0 if mistake == "loglik_no_constant" else 0.5 * np.log(2 * np.pi * s_lik))
            m = m + gain * nu
            p = p if mistake == "no_update_of_p" else (1.0 - gain) * p
        means[k], variances[k] = m, p
    return means, variances, float(log_lik)


def check_kalman(fn: Callable, z: np.ndarray = KALMAN_CASE, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(z, model) -> (means, variances, log_likelihood)`` on a :class:`ScalarModel`.

    ``z`` (default :data:`KALMAN_CASE`) has shape ``(K,)``, NaN where nothing is measured;
    ``means`` and ``variances`` have shape ``(K,)``, the mean and variance of ``p(x_k | z_{1:k})``
    at every step, and ``log_likelihood`` is ``log p(z_{1:K}) = sum_k log N(nu_k; 0, S_k)``. The
    filter is deterministic, so each must equal :func:`scalar_kalman` to ``rtol``; a filter that
    does not is compared with every typical mistake of :data:`KALMAN_MISTAKES`, and the report
    names the one that fits.
    """
    report = CheckReport("Kalman filter")
    model = ScalarModel()
    z = np.array(z, dtype=float)
    answer = _per_step_answer(report, lambda: fn(z.copy(), model), "fn(z, model)",
                              "(means, variances, log_likelihood)", ("mean", "variance"), z.size)
    if answer is None:
        return report
    means, variances, log_lik = answer
    try:
        log_lik = float(np.asarray(log_lik, dtype=float).item())
    except (TypeError, ValueError):
        report.problems.append(f"the log-likelihood is {np.size(log_lik)} values, not one number: return the sum "
                               "of the increments log N(nu_k; 0, S_k) over the measured steps")
        return report
    bad = ~(np.isfinite(means) & np.isfinite(variances))
    if bad.any():
        k = int(np.argmax(bad))
        why = ("z_k is NaN (nothing measured): skip the update at such a step, the filtering density is then "
               "the predicted one" if np.isnan(z[k]) else "check the update of that step")
        report.problems.append(f"the mean or the variance is NaN or infinite at step {k}; {why}")
        return report
    if not np.isfinite(log_lik):
        report.problems.append("the log-likelihood is NaN or infinite: add log N(nu_k; 0, S_k) only at the steps "
                               "where something is measured (z_k not NaN)")
        return report

    def close(got, expected) -> bool:
        return bool(np.allclose(got, expected, rtol=rtol, atol=1e-12))

    exact = scalar_kalman(z, model)
    filtered = close(means, exact[0]) and close(variances, exact[1])
    if filtered and close(log_lik, exact[2]):
        return report
    for mistake, why in KALMAN_MISTAKES.items():
        wrong = scalar_kalman(z, model, mistake)
        if close(means, wrong[0]) and close(variances, wrong[1]) and (not filtered or close(log_lik, wrong[2])):
            if not (close(wrong[0], exact[0]) and close(wrong[1], exact[1])) or not close(wrong[2], exact[2]):
                report.problems.append(f"your filter computes a known mistake: {why}")
                return report
    if filtered:
        report.problems.append(
            f"the means and variances are right, the log-likelihood is not ({log_lik:.6f}, exact {exact[2]:.6f}): "
            "add log N(nu_k; 0, S_k) at every measured step and nothing at a missing one")
        return report
    wrong_means = ~np.isclose(means, exact[0], rtol=rtol, atol=1e-12)
    wrong_vars = ~np.isclose(variances, exact[1], rtol=rtol, atol=1e-12)
    k = int(np.argmax(wrong_means | wrong_vars))
    report.problems.append(
        f"at step {k} your mean and variance are {means[k]:.6f} and {variances[k]:.6f}, the exact ones "
        f"{exact[0][k]:.6f} and {exact[1][k]:.6f}: check the prediction (m_k^- = a m_(k-1), P_k^- = a^2 P_(k-1) + q) "
        "and the update of that step")
    return report


#: The case of :func:`check_cv_kalman`: a constant-velocity model sampled every ``dt = 0.5`` s; its
#: position is measured (variance ``r``), nothing at step 0, two readings missing later.
CV_CASE = {"z": np.array([np.nan, 0.9, 1.1, np.nan, 1.8, 2.6, np.nan, 3.1]), "dt": 0.5, "q": 0.2, "r": 0.25,
           "m0": np.array([0.0, 1.0]), "P0": np.diag([1.0, 0.5])}

#: The typical mistakes of a constant-velocity Kalman filter, each as the flag of :func:`cv_kalman`
#: that makes it, with the sentence that names it.
CV_MISTAKES = {
    "q_identity": "the process noise is q I: a random acceleration moves the position and the velocity "
                  "together, Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]",
    "dt_ignored": "the dynamics ignore the time step: the position moves by dt times the velocity, "
                  "F = [[1, dt], [0, 1]], not [[1, 1], [0, 1]]",
    "f_transposed": "F is transposed: the position moves by dt times the velocity, F = [[1, dt], [0, 1]], "
                    "and the velocity does not move with the position",
    "h_velocity": "the measurement is the position, not the velocity: H = [[1, 0]]",
    "predict_at_0": "the filter predicts before step 0: the estimate at step 0 is the prior (m0, P0), and the "
                    "first prediction comes at step 1",
    "loglik_no_constant": "the log-likelihood misses the normalising term: log N(nu; 0, S) = "
                          "-(nu^2 / S + log(2 pi S)) / 2",
    "q_piecewise": "your Q is the piecewise-constant acceleration's, q [[dt^4/4, dt^3/2], [dt^3/2, dt^2]] "
                   "(filterpy's Q_discrete_white_noise): this model's acceleration is white noise of spectral "
                   "density q, whose Q is q [[dt^3/3, dt^2/2], [dt^2/2, dt]]",
    "q_as_sd": "your Q is built from q squared: q is already a variance (sigma_a^2), so Q = q [[dt^3/3, dt^2/2], "
               "[dt^2/2, dt]] with q itself",
    "r_as_sd": "your innovation variance uses r squared: r is already the variance sigma_v^2 of a reading, "
               "so S = H P H^T + r",
}


def cv_kalman(z: np.ndarray, dt: float, q: float, r: float, m0: np.ndarray, P0: np.ndarray,
              mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The exact Kalman filter of the constant-velocity model (means ``(K, 2)``, covariances ``(K, 2, 2)``,
    log-likelihood), or the one that makes ``mistake`` (a key of :data:`CV_MISTAKES`)."""
    step = 1.0 if mistake == "dt_ignored" else dt
    F = np.array([[1.0, step], [0.0, 1.0]])
    F = F.T if mistake == "f_transposed" else F
    Q = q * np.eye(2) if mistake == "q_identity" else q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    if mistake == "q_piecewise":
        Q = q * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
    if mistake == "q_as_sd":
        Q = Q * q
    r = r**2 if mistake == "r_as_sd" else r
    H = np.array([0.0, 1.0]) if mistake == "h_velocity" else np.array([1.0, 0.0])
    m, P, log_lik = np.asarray(m0, float), np.asarray(P0, float), 0.0
    means, covs = [], []
    for k, zk in enumerate(z):
        if k > 0 or mistake == "predict_at_0":
            m, P = F @ m, F @ P @ F.T + Q
        if not np.isnan(zk):
            nu, s = zk - H @ m, H @ P @ H + r
            gain = P @ H / s
            m, P = m + gain * nu, P - np.outer(gain, gain) * s
            log_lik += -0.5 * nu**2 / s - (0.0 if mistake == "loglik_no_constant" else 0.5 * np.log(2 * np.pi * s))
        means.append(m)
        covs.append(P)
    return np.array(means), np.array(covs), log_lik


def check_cv_kalman(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(z, dt, q, r, m0, P0) -> (means (K, 2), covariances (K, 2, 2), log_likelihood)``, the Kalman
    filter of the constant-velocity model (position and velocity, the position measured), on
    :data:`CV_CASE` against the exact :func:`cv_kalman`; a wrong answer is compared with each mistake of
    :data:`CV_MISTAKES` so that the report names it."""
    report = CheckReport("constant-velocity Kalman filter")
    case = CV_CASE
    n_steps = case["z"].size
    answer = _answer(report, lambda: fn(case["z"].copy(), case["dt"], case["q"], case["r"], case["m0"].copy(),
                                        case["P0"].copy()),
                     "fn(z, dt, q, r, m0, P0)", "write the filter and return (means, covariances, log_likelihood)")
    if answer is None:
        return report
    try:
        means, covs, log_lik = answer
        means, covs, log_lik = np.asarray(means, float), np.asarray(covs, float), np.asarray(log_lik, float)
    except (TypeError, ValueError) as exc:
        report.problems.append(f"the answer is not (means, covariances, log_likelihood): {exc}")
        return report
    if means.shape != (n_steps, 2) or covs.shape != (n_steps, 2, 2) or log_lik.shape != ():
        report.problems.append(
            f"returned shapes {means.shape}, {covs.shape} and {log_lik.shape}; expected ({n_steps}, 2), "
            f"({n_steps}, 2, 2) and (): one mean and one covariance per step, step 0 included, and one number")
        return report
    if not (np.isfinite(means).all() and np.isfinite(covs).all()):
        k = int(np.argmax(~np.isfinite(means).all(axis=1) | ~np.isfinite(covs).all(axis=(1, 2))))
        report.problems.append(f"the mean or the covariance is NaN at step {k}: when z_k is NaN nothing is "
                               "measured, so skip the update (m_k = m_k^-, P_k = P_k^-)")
        return report

    def close(got, expected) -> bool:
        return bool(np.allclose(got, expected, rtol=rtol, atol=1e-12))

    exact = cv_kalman(**case)
    filtered = close(means, exact[0]) and close(covs, exact[1])
    if filtered and close(log_lik, exact[2]):
        return report
    for mistake, why in CV_MISTAKES.items():
        wrong = cv_kalman(**case, mistake=mistake)
        if close(means, wrong[0]) and close(covs, wrong[1]) and close(log_lik, wrong[2]):
            report.problems.append(f"your filter computes a known mistake: {why}")
            return report
    if filtered:
        report.problems.append(
            f"the means and covariances are right, the log-likelihood is not ({float(log_lik):.6f}, exact "
            f"{exact[2]:.6f}): add log N(nu_k; 0, S_k) at every measured step and nothing at a missing one")
        return report
    wrong = ~(np.isclose(means, exact[0], rtol=rtol, atol=1e-12).all(axis=1)
              & np.isclose(covs, exact[1], rtol=rtol, atol=1e-12).all(axis=(1, 2)))
    k = int(np.argmax(wrong))
    report.problems.append(
        f"at step {k} your mean is {np.round(means[k], 4).tolist()}, the exact one "
        f"{np.round(exact[0][k], 4).tolist()}: check the model's F, Q and H and the update of that step")
    return report


#: The parents and the measurement of :func:`check_optimal_proposal`.
PROPOSAL_PARENTS = np.array([-1.5, -0.2, 0.4, 1.1, 2.3])


PROPOSAL_Z = 0.8


#: The model of :func:`check_optimal_proposal`: ``q``, ``r`` and ``q + r`` all differ, so that a
#: variance put in the place of another is seen.
PROPOSAL_MODEL = ScalarModel(q=0.5, r=0.2)


def _log_normal(x: np.ndarray, mean: np.ndarray | float, var: float) -> np.ndarray:
    """``log N(x; mean, var)`` of a scalar Gaussian, elementwise."""
    return -0.5 * ((x - mean) ** 2 / var + np.log(2 * np.pi * var))


def scalar_optimal_proposal(x_prev: np.ndarray, z: float, model: ScalarModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The optimal proposal of a :class:`ScalarModel`: ``(means, variances, log_weights)`` per parent.

    .. math::

       p(x_k | x_{k-1}, z_k) = \\mathcal N\\big(\\sigma^2 (a x_{k-1} / q + z_k / r),\\ \\sigma^2\\big),
       \\quad \\sigma^2 = (1/q + 1/r)^{-1}, \\qquad
       \\log p(z_k | x_{k-1}) = \\log \\mathcal N(z_k;\\ a x_{k-1},\\ q + r).
    """
    x_prev = np.asarray(x_prev, dtype=float)
    var = 1.0 / (1.0 / model.q + 1.0 / model.r)
    return var * (model.a * x_prev / model.q + z / model.r), np.full(x_prev.shape, var), \
        _log_normal(z, model.a * x_prev, model.q + model.r)


def _proposal_mistakes(x: np.ndarray, z: float, model: ScalarModel) -> dict[str, dict[str, np.ndarray]]:
    """What each typical mistake computes, by output (mean, variance, log-weight), with its sentence."""
    a, q, r = model.a, model.q, model.r
    right, added = 1.0 / (1.0 / q + 1.0 / r), q + r
    m = right * (a * x / q + z / r)
    return {
        "variance": {
            "the variances are added (q + r) where the precisions add: 1 / sigma^2 = 1 / q + 1 / r, since "
            "both the transition and the measurement inform x_k": np.full(x.shape, added),
            "the variance is q, the transition's: conditioning on z_k shrinks it to (1/q + 1/r)^(-1)":
                np.full(x.shape, q),
        },
        "mean": {
            "the mean is the prediction a x_(k-1), blind to z_k: it is sigma^2 (a x_(k-1) / q + z_k / r), "
            "a precision-weighted average of prediction and measurement": a * x,
            "the mean misses the factor sigma^2: it is sigma^2 (a x_(k-1) / q + z_k / r), not the bare sum "
            "of the precision-weighted terms": a * x / q + z / r,
            "the mean uses q + r as its variance: the variances were added where the precisions add, "
            "sigma^2 = (1/q + 1/r)^(-1)": added * (a * x / q + z / r),
            "the mean forgets the dynamics' factor a: the prediction of x_k is a x_(k-1), not x_(k-1)":
                right * (x / q + z / r),
        },
        "log-weight": {
            "the log-weight uses the variance q alone: z_k = a x_(k-1) + w_k + v_k, so its variance given "
            "x_(k-1) is q + r": _log_normal(z, a * x, q),
            "the log-weight uses the variance r alone: z_k = a x_(k-1) + w_k + v_k, so its variance given "
            "x_(k-1) is q + r": _log_normal(z, a * x, r),
            "the log-weight is evaluated at the new particle (the proposal's mean) instead of the parent: "
            "the weight p(z_k | x_(k-1)) = N(z_k; a x_(k-1), q + r) depends only on x_(k-1)": _log_normal(z, m, r),
            "the log-weight is evaluated at the new particle's mean with variance q + r: the weight "
            "p(z_k | x_(k-1)) = N(z_k; a x_(k-1), q + r) is centred on the parent's prediction":
                _log_normal(z, m, added),
        },
    }


def check_optimal_proposal(fn: Callable, x_prev: np.ndarray = PROPOSAL_PARENTS, z: float = PROPOSAL_Z,
                           rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x_prev, z, model) -> (means, variances, log_weights)`` on a :class:`ScalarModel`.

    The model is :data:`PROPOSAL_MODEL`; ``x_prev`` (default :data:`PROPOSAL_PARENTS`) holds the parents ``x_{k-1}^i``, shape ``(N,)``, and
    ``z`` is one measurement; each output has shape ``(N,)``: the mean and variance of
    ``p(x_k | x_{k-1}^i, z_k)`` and ``log p(z_k | x_{k-1}^i)``. They must equal
    :func:`scalar_optimal_proposal` to ``rtol``, the log-weights up to one constant common to all
    parents (it cancels when the weights are normalised). A wrong output is compared with what each
    typical mistake of that output computes, and the report names the one that fits.
    """
    report = CheckReport("optimal proposal")
    model = PROPOSAL_MODEL
    x = np.array(x_prev, dtype=float)
    answer = _per_step_answer(report, lambda: fn(x.copy(), float(z), model), "fn(x_prev, z, model)",
                              "(means, variances, log_weights)", ("mean", "variance", "log-weight"), x.size,
                              todo="write the proposal", per="per parent")
    if answer is None:
        return report
    exact = scalar_optimal_proposal(x, z, model)
    outputs = dict(zip(("mean", "variance", "log-weight"), answer))

    def close(name: str, got: np.ndarray, expected: np.ndarray) -> bool:
        if name == "log-weight":  # a constant common to all parents cancels in the normalisation
            got, expected = got - got[0], expected - expected[0]
        return bool(np.all(np.isfinite(got)) and np.allclose(got, expected, rtol=rtol, atol=1e-12))

    mistakes = _proposal_mistakes(x, z, model)
    for (name, got), expected in zip(outputs.items(), exact):
        if close(name, got, expected):
            continue
        why = next((why for why, wrong in mistakes[name].items() if close(name, got, wrong)), None)
        if why is not None:
            report.problems.append(f"your {name} computes a known mistake: {why}")
            continue
        i = int(np.argmax(~np.isclose(got, expected, rtol=rtol, atol=1e-12) | ~np.isfinite(got)))
        report.problems.append(
            f"for the parent x_(k-1) = {x[i]:g} your {name} is {got[i]:.6f}, the exact one {expected[i]:.6f}: "
            "the proposal is N(sigma^2 (a x_(k-1) / q + z_k / r), sigma^2) with sigma^2 = (1/q + 1/r)^(-1), "
            "the log-weight log N(z_k; a x_(k-1), q + r)")
    return report


LANDMARK_MISTAKES: dict[str, str] = {
    "no_robot": "the innovation forgets the robot: the measurement is relative to the particle's robot, "
                "nu = z - A r - C m, not z - C m",
    "robot_sign": "the robot's term has the wrong sign: z = A r + C l + v, so nu = z - A r - C m",
    "s_without_r": "the innovation covariance misses the measurement noise: S = C P C^T + R, not C P C^T",
    "no_cov_update": "the covariance is not updated: after a measurement P' = (I - K C) P, smaller than P",
    "loglik_with_r": "the weight uses R where it needs S: the map is uncertain, so the predictive likelihood "
                     "is N(nu; 0, C P C^T + R), not N(nu; 0, R)",
}


def landmark_update(robot: np.ndarray, m: np.ndarray, P: np.ndarray, z: np.ndarray, A: np.ndarray, C: np.ndarray,
                    R: np.ndarray, mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """One particle's map update given its robot ``r``: ``(m', P', log N(nu; 0, S))``.

    ``z = A r + C l + v``, ``v ~ N(0, R)``, map ``l ~ N(m, P)``: innovation ``nu = z - A r - C m``,
    ``S = C P C^T + R``, gain ``K = P C^T S^{-1}``, ``m' = m + K nu``, ``P' = (I - K C) P``, and the
    particle's log-weight increment ``log N(nu; 0, S)``. ``mistake`` (a key of
    :data:`LANDMARK_MISTAKES`) computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in LANDMARK_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(LANDMARK_MISTAKES)}")
    robot_term = 0.0 if mistake == "no_robot" else -(A @ robot) if mistake == "robot_sign" else A @ robot
    nu = z - robot_term - C @ m
    S = C @ P @ C.T + (0.0 if mistake == "s_without_r" else R)
    gain = P @ C.T @ np.linalg.inv(S)
    cov = P if mistake == "no_cov_update" else (np.eye(len(m)) - gain @ C) @ P
    S_lik = R if mistake == "loglik_with_r" else S
    log_lik = -0.5 * (nu @ np.linalg.solve(S_lik, nu) + np.linalg.slogdet(2 * np.pi * S_lik)[1])
    return m + gain @ nu, cov, float(log_lik)


#: A particle of the two-landmark model seeing landmark 1: robot, map mean and covariance, z, A, C, R.
LANDMARK_CASE = dict(
    robot=np.array([0.7, -0.4]), m=np.array([2.0, 1.5, -1.0, 2.5]),
    P=np.array([[0.30, 0.05, 0.0, 0.0], [0.05, 0.20, 0.0, 0.0], [0.0, 0.0, 0.25, -0.04], [0.0, 0.0, -0.04, 0.35]]),
    z=np.array([1.1, 2.2]), A=-np.eye(2), C=np.hstack([np.eye(2), np.zeros((2, 2))]), R=0.01 * np.eye(2))


def check_landmark_update(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(robot, m, P, z, A, C, R) -> (m_new, P_new, log_lik)`` on :data:`LANDMARK_CASE`.

    The update is deterministic, so each output must equal :func:`landmark_update` to ``rtol``;
    one that does not is compared with every mistake of :data:`LANDMARK_MISTAKES`, and the report
    names the one that fits.
    """
    report = CheckReport("map update of one particle")
    case = {key: value.copy() for key, value in LANDMARK_CASE.items()}
    answer = _answer(report, lambda: fn(**case), "fn(robot, m, P, z, A, C, R)", "return (m_new, P_new, log_lik)")
    if answer is None:
        return report
    try:
        m_new, P_new, log_lik = answer
        m_new, P_new = np.asarray(m_new, dtype=float), np.asarray(P_new, dtype=float)
        log_lik = float(np.asarray(log_lik, dtype=float).item())
    except (TypeError, ValueError):
        report.problems.append("return three things: the new map mean (shape (4,)), its covariance (4, 4) and the "
                               "log-weight increment, one number")
        return report
    if m_new.shape != (4,) or P_new.shape != (4, 4):
        report.problems.append(f"the mean has shape {m_new.shape} and the covariance {P_new.shape}: expected (4,) "
                               "and (4, 4), the whole map of the particle")
        return report

    def same(got, expected) -> bool:
        return all(np.allclose(g, e, rtol=rtol, atol=1e-12) for g, e in zip(got, expected))

    got = (m_new, P_new, log_lik)
    if same(got, landmark_update(**LANDMARK_CASE)):
        return report
    for mistake, why in LANDMARK_MISTAKES.items():
        if same(got, landmark_update(**LANDMARK_CASE, mistake=mistake)):
            report.problems.append(f"your update computes a known mistake: {why}")
            return report
    exact = landmark_update(**LANDMARK_CASE)
    part = "mean" if not np.allclose(m_new, exact[0]) else "covariance" if not np.allclose(P_new, exact[1]) else \
        "log-weight increment"
    report.problems.append(f"the {part} differs from the Kalman update (nu = z - A r - C m, S = C P C^T + R, "
                           "K = P C^T S^-1, m' = m + K nu, P' = (I - K C) P, log N(nu; 0, S)): check that line")
    return report


# FastSLAM 2.0's robot move for a cloud (chapter 9, exercise 9.2): one landmark in view, measured as
# its offset from the robot, z = A r + C l + v with A = -I and C = [I, 0]; every particle shares the
# map covariance P_pred.
FASTSLAM2_CASE = dict(
    Qr=np.diag([0.04, 0.09]),
    R=np.array([[0.02, 0.005], [0.005, 0.03]]),
    P_pred=np.array([[0.05, 0.01, 0.0, 0.0], [0.01, 0.04, 0.0, 0.0], [0.0, 0.0, 0.2, 0.0], [0.0, 0.0, 0.0, 0.2]]),
    A=-np.eye(2),
    C=np.hstack([np.eye(2), np.zeros((2, 2))]),
    z=np.array([1.1, 0.4]),
)

FASTSLAM2_MISTAKES: dict[str, str] = {
    "fastslam1_weight": "the weight's covariance leaves out the robot's motion noise: the innovation z - A r^- - C m^- "
                        "is taken at the parent's prediction r^-, from which the robot still moves by Q_r, so its "
                        "covariance is S = A Q_r A^T + C P^- C^T + R, not C P^- C^T + R",
    "no_map_in_s": "S leaves out the map's uncertainty C P^- C^T: the landmark's position is not known, so "
                   "S = A Q_r A^T + C P^- C^T + R, in the weight and in the gain",
    "new_robot_weight": "the weight is evaluated at the new robot: with the optimal proposal it is the predictive "
                        "likelihood of the parent, N(z; A r^- + C m^-, S), whatever robot is drawn",
    "transition_move": "the robots move with the transition N(r^-, Q_r), blind to z: the optimal proposal is "
                       "N(r^- + G (z - A r^- - C m^-), Q_r - G S G^T) with G = Q_r A^T S^-1",
    "no_shrink": "the robots are drawn with the covariance Q_r: conditioning on z shrinks it to Q_r - G S G^T",
}


def fastslam2_exact(r_pred: np.ndarray, m_pred: np.ndarray, mistake: str | None = None,
                    case: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(means (N, 2), covariance (2, 2), log_w (N,))`` of FastSLAM 2.0's robot proposal and weight.

    ``S = A Q_r A^T + C P C^T + R``, ``G = Q_r A^T S^-1``, ``nu = z - A r^- - C m^-``: the new robot
    is ``N(r^- + G nu, Q_r - G S G^T)`` and the weight ``log N(nu; 0, S)``. ``mistake`` (a key of
    :data:`FASTSLAM2_MISTAKES` other than ``new_robot_weight``, which depends on the draw) gives what
    that mistake computes instead.
    """
    c = FASTSLAM2_CASE if case is None else case
    Qr, R, P, A, C, z = (c[k] for k in ("Qr", "R", "P_pred", "A", "C", "z"))
    S_map = C @ P @ C.T + R
    S = A @ Qr @ A.T + (R if mistake == "no_map_in_s" else S_map)
    nu = z - r_pred @ A.T - m_pred @ C.T
    S_w = S_map if mistake == "fastslam1_weight" else S
    log_w = -0.5 * (np.einsum("ij,ij->i", nu @ np.linalg.inv(S_w), nu) + np.linalg.slogdet(2 * np.pi * S_w)[1])
    G = Qr @ A.T @ np.linalg.inv(S)
    if mistake == "transition_move":
        return r_pred.copy(), Qr, log_w
    cov = Qr if mistake == "no_shrink" else Qr - G @ S @ G.T
    return r_pred + nu @ G.T, cov, log_w


def check_fastslam2_move(fn: Callable, n: int = 60, n_calls: int = 60, seed: int = 0) -> CheckReport:
    """Check a student's ``fn(r_pred, m_pred, P_pred, z, A, C, Qr, R, rng) -> (robots, log_w)`` (exercise 9.2).

    On :data:`FASTSLAM2_CASE`: the generator (same seed, same answer; another seed, another; NumPy's
    global state untouched); the log-weights against :func:`fastslam2_exact` up to a constant common
    to all particles; and the robots of ``n_calls`` seeded calls, standardised by the exact proposal
    (mean and Cholesky factor per particle), whose ``2 n n_calls`` values must have mean 0 and variance
    1 within 5 standard errors. A wrong answer is compared with each mistake of
    :data:`FASTSLAM2_MISTAKES`, and the report names it.
    """
    report = CheckReport("FastSLAM 2.0 robot move")
    c = FASTSLAM2_CASE
    rng = np.random.default_rng(seed)
    r_pred = rng.normal(0.0, 0.3, (n, 2))
    m_pred = np.array([1.0, 0.5, -1.0, 2.0]) + rng.normal(0.0, 0.3, (n, 4))

    def call(s):
        return fn(r_pred.copy(), m_pred.copy(), c["P_pred"].copy(), c["z"].copy(), c["A"].copy(), c["C"].copy(),
                  c["Qr"].copy(), c["R"].copy(), np.random.default_rng(s))

    state = np.random.get_state()
    answer = _answer(report, lambda: call(1), "fn(r_pred, m_pred, P_pred, z, A, C, Qr, R, rng)",
                     "return the new robots (shape (N, 2)) and their log-weights (shape (N,))")
    if answer is None:
        return report
    if not isinstance(answer, tuple) or len(answer) != 2:
        report.problems.append("the answer is not a pair: return (robots, log_w)")
        return report
    if not _shaped(report, answer[0], (n, 2), "one new robot per particle, shape (N, 2)") or \
            not _shaped(report, answer[1], (n,), "one log-weight per particle"):
        return report
    problem = _seed_problem(state, answer, *(call(1), call(2)), "robots", "rng.standard_normal(...)")
    if problem is not None:
        report.problems.append(problem)
        return report
    robots, log_w = np.asarray(answer[0], dtype=float), np.asarray(answer[1], dtype=float)

    def same_up_to_constant(a, b):
        d = a - b
        return bool(np.all(np.isfinite(d)) and np.ptp(d) < 1e-8)

    if not same_up_to_constant(log_w, fastslam2_exact(r_pred, m_pred)[2]):
        for mistake in ("fastslam1_weight", "no_map_in_s"):
            if same_up_to_constant(log_w, fastslam2_exact(r_pred, m_pred, mistake)[2]):
                report.problems.append(f"your function computes a known mistake: {FASTSLAM2_MISTAKES[mistake]}")
                return report
        S_map = c["C"] @ c["P_pred"] @ c["C"].T + c["R"]
        nu_new = c["z"] - robots @ c["A"].T - m_pred @ c["C"].T
        for S in (S_map, c["A"] @ c["Qr"] @ c["A"].T + S_map):
            at_new = -0.5 * np.einsum("ij,ij->i", nu_new @ np.linalg.inv(S), nu_new)
            if same_up_to_constant(log_w, at_new):
                report.problems.append(f"your function computes a known mistake: "
                                       f"{FASTSLAM2_MISTAKES['new_robot_weight']}")
                return report
        report.problems.append("the log-weights differ from log N(z; A r^- + C m^-, A Q_r A^T + C P^- C^T + R) "
                               "(up to a constant): check the innovation and S")
        return report
    draws = [robots] + [np.asarray(call(100 + t)[0], dtype=float) for t in range(n_calls - 1)]

    def fits(mistake):
        means, cov, _ = fastslam2_exact(r_pred, m_pred, mistake)
        L_inv = np.linalg.inv(np.linalg.cholesky(cov))
        e = np.concatenate([((d - means) @ L_inv.T).ravel() for d in draws])
        return abs(e.mean()) < 5 / np.sqrt(e.size) and abs(e.var() - 1.0) < 5 * np.sqrt(2.0 / e.size)

    if _settled(report, fits, {k: FASTSLAM2_MISTAKES[k] for k in ("transition_move", "no_shrink", "no_map_in_s")}):
        return report
    report.problems.append("the new robots do not follow N(r^- + G nu, Q_r - G S G^T), G = Q_r A^T S^-1: check the "
                           "gain, the innovation and the covariance's Cholesky factor")
    return report


APF_MISTAKES: dict[str, str] = {
    "no_division": "the first stage is not divided out: the ancestors were chosen in proportion to p^(z_k | x_(k-1)), "
                   "so the second-stage weight is p(z_k | x_k^i) / p^(z_k | x_(k-1)^(a_i))",
    "own_index": "the division uses particle i's own first-stage value: divide by that of its ancestor, "
                 "log_pred[ancestors], since particle i was moved from x_(k-1)^(a_i)",
    "multiplied": "the first-stage value is multiplied in again instead of divided out: subtract "
                  "log_pred[ancestors], do not add it",
    "unnormalised": "the log-weights are not normalised: subtract their logsumexp so the weights sum to one",
}


def apf_second_stage(log_lik: np.ndarray, log_pred: np.ndarray, ancestors: np.ndarray,
                     mistake: str | None = None) -> np.ndarray:
    """Normalised second-stage log-weights of the auxiliary filter with the transition as proposal.

    ``log W_k^i = log p(z_k | x_k^i) - log p^(z_k | x_(k-1)^(a_i)) - logsumexp(...)``: the transition
    and the proposal cancel, and the first-stage approximation ``p^`` of the ancestor is divided
    out. ``mistake`` (a key of :data:`APF_MISTAKES`) computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in APF_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(APF_MISTAKES)}")
    pred = {"no_division": 0.0, "own_index": log_pred, "multiplied": -log_pred[ancestors]}.get(mistake,
                                                                                                 log_pred[ancestors])
    log_w = log_lik - pred
    return log_w if mistake == "unnormalised" else log_w - logsumexp(log_w)


def check_apf_second_stage(fn: Callable, n: int = 12, seed: int = 0) -> CheckReport:
    """Check a student's ``fn(log_lik, log_pred, ancestors) -> log_weights`` against :func:`apf_second_stage`.

    ``log_lik`` holds ``log p(z_k | x_k^i)`` of the moved particles, ``log_pred`` the first-stage
    ``log p^(z_k | x_(k-1)^j)`` of the parents, ``ancestors`` the chosen parent of each particle.
    A wrong answer is compared with each mistake of :data:`APF_MISTAKES`, and the report names it.
    """
    report = CheckReport("second-stage weights")
    rng = np.random.default_rng(seed)
    log_lik, log_pred = rng.normal(-3.0, 2.0, n), rng.normal(-3.0, 2.0, n)
    ancestors = np.sort(rng.integers(0, n, n))
    answer = _answer(report, lambda: fn(log_lik.copy(), log_pred.copy(), ancestors.copy()),
                     "fn(log_lik, log_pred, ancestors)", "return the normalised log-weights, shape (N,)")
    if answer is None:
        return report
    if not _shaped(report, answer, (n,), "one log-weight per particle"):
        return report
    got = np.asarray(answer, dtype=float)
    if _settled(report, lambda mistake: np.allclose(got, apf_second_stage(log_lik, log_pred, ancestors, mistake),
                                                    atol=1e-10), APF_MISTAKES):
        return report
    report.problems.append("the log-weights differ from log p(z_k | x_k^i) - log p^(z_k | x_(k-1)^(a_i)), normalised: "
                           "check each term")
    return report


# The fully adapted auxiliary filter on a model the chapter does not show (chapter 10, exercise 10.3):
# x_k = a x_(k-1) + w_k, w_k ~ N(0, q); z_k = c x_k + v_k, v_k ~ N(0, r).
APF_STEP_MODEL = {"a": 0.8, "c": 2.0, "q": 0.5, "r": 0.4}

APF_STEP_MISTAKES: dict[str, str] = {
    "no_weights": "W_(k-1) is dropped from the first stage: the ancestors must be drawn in proportion to "
                  "W_(k-1)^i p(z_k | x_(k-1)^i) and the likelihood is log sum_i W_(k-1)^i p(z_k | x_(k-1)^i); "
                  "without W the step forgets every earlier measurement",
    "predictive_r": "the predictive likelihood p(z_k | x_(k-1)) is given the variance r; the state still moves "
                    "(variance q) before it is measured, so its variance is c^2 q + r",
    "no_c": "the sensor's scale c is forgotten: z_k = c x_k + v_k predicts c a x_(k-1) with variance c^2 q + r, "
            "and the optimal gain is c q / (c^2 q + r)",
    "transition_move": "the children move with the transition N(a x, q), not the optimal proposal: to leave the "
                       "step equally weighted each chosen parent must move by p(x_k | x_(k-1), z_k) = "
                       "N(a x + K (z - c a x), q r / (c^2 q + r)), K = c q / (c^2 q + r)",
    "move_then_resample": "the particles are moved, then resampled: the copies of a parent are then duplicates of "
                          "one moved particle; resample the parents first, then move each copy with its own noise",
}


def apf_step_exact(x: np.ndarray, log_w: np.ndarray, z: float, mistake: str | None = None,
                   model: dict | None = None) -> tuple[float, float, float]:
    """``(log p^(z_k | z_(1:k-1)), mean, variance)`` of one fully adapted step's new cloud, exactly.

    The new particles are drawn from the mixture ``sum_i lambda^i N(mu^i, v)`` with
    ``lambda^i`` proportional to ``W^i N(z; c a x^i, c^2 q + r)``, ``mu^i = a x^i + K (z - c a x^i)``
    and ``v = q r / (c^2 q + r)``; ``mistake`` (a key of :data:`APF_STEP_MISTAKES`) gives what that
    mistake draws instead.
    """
    if mistake is not None and mistake not in APF_STEP_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(APF_STEP_MISTAKES)}")
    m = APF_STEP_MODEL if model is None else model
    a, c, q, r = m["a"], m["c"], m["q"], m["r"]
    scale = 1.0 if mistake == "no_c" else c
    s = r if mistake == "predictive_r" else scale**2 * q + r
    log_p = -0.5 * ((z - scale * a * x) ** 2 / s + np.log(2 * np.pi * s))
    log_lam = log_p + (0.0 if mistake == "no_weights" else log_w)
    log_evidence = float(logsumexp(log_lam) - (np.log(len(x)) if mistake == "no_weights" else 0.0))
    lam = np.exp(log_lam - logsumexp(log_lam))
    if mistake == "transition_move":
        mu, v = a * x, q
    else:
        gain = scale * q / (scale**2 * q + r)
        mu, v = a * x + gain * (z - scale * a * x), q - gain * scale * q
    mean = float(lam @ mu)
    return log_evidence, mean, float(v + lam @ mu**2 - mean**2)


def check_apf_step(fn: Callable, n: int = 200, n_calls: int = 40, seed: int = 0) -> CheckReport:
    """Check a student's ``fn(x, log_w, z, rng) -> (x_new, log_evidence)``, the fully adapted step of
    the auxiliary filter on :data:`APF_STEP_MODEL` (exercise 10.3).

    On one weighted cloud of ``n`` particles: the generator (same seed, same answer; another seed,
    another; NumPy's global state untouched), the likelihood increment against
    ``log sum_i W^i N(z; c a x^i, c^2 q + r)`` to round-off, distinct children (no duplicates), and
    the mean and variance of the ``n_calls n`` children of ``n_calls`` seeded calls against the exact
    mixture's within 5 standard errors (a correct step fails with probability below 1e-5). A wrong
    answer is compared with each mistake of :data:`APF_STEP_MISTAKES`, and the report names it.
    """
    report = CheckReport("fully adapted auxiliary step")
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, n)
    log_w = -2.0 * (x - 1.0) ** 2  # earlier measurements favour x near 1
    log_w -= logsumexp(log_w)
    z = 2.5

    def call(s):
        return fn(x.copy(), log_w.copy(), z, np.random.default_rng(s))

    state = np.random.get_state()
    answer = _answer(report, lambda: call(1), "fn(x, log_w, z, rng)",
                     "return the new particles (shape (N,)) and the log-likelihood increment")
    if answer is None:
        return report
    if not isinstance(answer, tuple) or len(answer) != 2:
        report.problems.append("the answer is not a pair: return (x_new, log_evidence)")
        return report
    if not _shaped(report, answer[0], (n,), "one new particle per particle") or \
            not _shaped(report, np.asarray(answer[1]), (), "one number, log p^(z_k | z_(1:k-1))"):
        return report
    problem = _seed_problem(state, answer, *(call(1), call(2)), "particles",
                            "rng.random(), rng.standard_normal(), ...")
    if problem is not None:
        report.problems.append(problem)
        return report
    got = float(answer[1])
    if not np.isclose(got, apf_step_exact(x, log_w, z)[0], rtol=0, atol=1e-9):
        for mistake in ("no_weights", "predictive_r", "no_c"):
            if np.isclose(got, apf_step_exact(x, log_w, z, mistake)[0], rtol=0, atol=1e-9):
                report.problems.append(f"your function computes a known mistake: {APF_STEP_MISTAKES[mistake]}")
                return report
        report.problems.append(f"the log-likelihood increment is {got:.6f}, not log sum_i W^i N(z; c a x^i, "
                               f"c^2 q + r) = {apf_step_exact(x, log_w, z)[0]:.6f}: check that line")
        return report
    children = np.asarray(answer[0], dtype=float)
    if np.unique(children).size < 0.9 * n:
        report.problems.append(f"your function computes a known mistake: {APF_STEP_MISTAKES['move_then_resample']} "
                               f"({np.unique(children).size} distinct values among {n} particles)")
        return report
    pooled = np.concatenate([np.asarray(call(100 + t)[0], dtype=float) for t in range(n_calls)])
    mean, var = pooled.mean(), pooled.var(ddof=1)
    se_mean = np.sqrt(var / pooled.size)
    se_var = np.sqrt(max(np.mean((pooled - mean) ** 4) - var**2, 0.0) / pooled.size)

    def fits(mistake):
        _, m, v = apf_step_exact(x, log_w, z, mistake)
        return abs(mean - m) < 5 * se_mean and abs(var - v) < 5 * se_var

    if _settled(report, fits, {k: APF_STEP_MISTAKES[k] for k in ("transition_move", "no_weights", "no_c")}):
        return report
    _, m, v = apf_step_exact(x, log_w, z)
    report.problems.append(f"the new particles have mean {mean:.3f} and variance {var:.3f} over {pooled.size} draws, "
                           f"not the filtering density's {m:.3f} and {v:.3f}: check the ancestors' probabilities "
                           "and the optimal move")
    return report


def _same_state(a, b) -> bool:
    """Whether two states of NumPy's global generator (``np.random.get_state()``) are equal."""
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and tuple(a[2:]) == tuple(b[2:])


# The log-likelihood of a cloud of particles in the two-landmark model (chapter 1, exercise 1.4).
# H maps the state (r_x, r_y, l1_x, l1_y, l2_x, l2_y) to the offsets l^j - r; R has a different
# variance per landmark, so that its visible block differs from its leading block.
LIKELIHOOD_H = np.kron(np.hstack([-np.ones((2, 1)), np.eye(2)]), np.eye(2))


#: Correlated across the two landmarks (the 0.002 between coordinates 2 and 3), so that the inverse of
#: R's block differs from the block of R's inverse, and the checker can tell the two apart.
LIKELIHOOD_R = np.diag([0.01, 0.01, 0.04, 0.04]) + np.diag([0.004, 0.002, 0.01], 1) + np.diag([0.004, 0.002, 0.01], -1)


LIKELIHOOD_CASES = (np.array([1.2, 0.6, 0.8, -0.4]), np.array([np.nan, np.nan, 0.9, -0.3]),
                    np.array([1.1, 0.5, np.nan, np.nan]), np.full(4, np.nan))


LIKELIHOOD_MISTAKES = {
    "nan_as_zero": "it replaces a missing coordinate by 0 and keeps the whole R; an unmeasured landmark must "
                   "leave the density: keep only the rows of z and H that are measured and the block R[seen, seen]",
    "reversed_offset": "it predicts the measurement as r - l, the offset reversed; the model measures l^j - r, "
                       "that is H x with H's -I block on the robot",
    "r_as_sd": "it uses R as a matrix of standard deviations (R squared as the covariance); R is already the "
               "covariance of the measurement noise, in m²",
    "leading_block": "it takes the leading block R[:n, :n] of R instead of the block of the measured coordinates, "
                     "R[seen][:, seen]; the two differ when the visible landmark is not the first",
    "inverse_block": "it takes the block of R's inverse, inv(R)[seen, seen], instead of the inverse of R's "
                     "block, inv(R[seen, seen]); they differ when the measured coordinates are correlated with "
                     "unmeasured ones: invert R_k, the block of the coordinates measured",
    "no_constant": "it misses the normalising term -(n log(2 pi) + log det R_seen) / 2, which the exercise asks "
                   "for (it changes with the number n of coordinates measured)",
}


def landmark_log_likelihood(x: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray,
                            mistake: str | None = None) -> np.ndarray:
    """``log N(z_s; H_s x^i, R_ss)`` for every particle ``x^i`` (rows of ``x``), with ``s`` the
    measured (non-NaN) coordinates of ``z``, ``H_s`` their rows of ``H`` and ``R_ss`` their block of
    ``R``; ``0`` for every particle when nothing is measured. ``mistake`` (a key of
    :data:`LIKELIHOOD_MISTAKES`) computes that mistake instead."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    seen = ~np.isnan(z)
    if mistake == "nan_as_zero":
        seen = np.ones(z.size, dtype=bool)
    if not seen.any():
        return np.zeros(len(x))
    n = int(seen.sum())
    predicted = x @ H[seen].T * (-1.0 if mistake == "reversed_offset" else 1.0)
    d = np.where(np.isnan(z[seen]), 0.0, z[seen] - predicted)
    block = R[:n, :n] if mistake == "leading_block" else R[np.ix_(seen, seen)]
    if mistake == "r_as_sd":
        block = block @ block
    precision = np.linalg.inv(R)[np.ix_(seen, seen)] if mistake == "inverse_block" else np.linalg.inv(block)
    quad = np.einsum("ij,ij->i", d @ precision, d)
    constant = 0.0 if mistake == "no_constant" else n * np.log(2 * np.pi) + np.linalg.slogdet(block)[1]
    return -0.5 * (quad + constant)


def check_log_likelihood(fn: Callable, n_particles: int = 50, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, H, R) -> (N,)``, the log-likelihoods ``log p(z | x^i)`` of a cloud.

    ``x`` has shape ``(N, 6)`` (particles of the two-landmark model), ``z`` shape ``(4,)`` with NaN
    for an unseen landmark. Each case of :data:`LIKELIHOOD_CASES` (both landmarks seen, only the
    second, only the first, none) must equal :func:`landmark_log_likelihood` to ``rtol``; an answer
    that does not is compared with each mistake of :data:`LIKELIHOOD_MISTAKES`, and the report names
    the one that fits.
    """
    report = CheckReport("log-likelihood")
    x = np.random.default_rng(seed).normal([2.0, 0.0, 3.0, 0.5, 3.0, -0.5], 0.3, size=(n_particles, 6))
    answers = _per_particle_answers(
        report, [lambda z=z: fn(x.copy(), z.copy(), LIKELIHOOD_H.copy(), LIKELIHOOD_R.copy()) for z in LIKELIHOOD_CASES],
        n_particles, "fn(x, z, H, R)")
    if answers is None:
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("the log-likelihood is NaN when a landmark is out of view: drop the NaN "
                               "coordinates of z, with their rows of H and their rows and columns of R")
        return report
    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, landmark_log_likelihood(x, z, LIKELIHOOD_H, LIKELIHOOD_R, mistake),
                               rtol=rtol, atol=1e-9) for a, z in zip(answers, LIKELIHOOD_CASES))

    if _settled(report, fits, LIKELIHOOD_MISTAKES):
        return report
    if np.any(answers[-1] != 0.0):
        report.problems.append("with nothing in view (z all NaN) the likelihood is the constant 1: return "
                               "zeros, one per particle")
        return report
    case = next(c for c, (a, z) in enumerate(zip(answers, LIKELIHOOD_CASES))
                if not np.allclose(a, landmark_log_likelihood(x, z, LIKELIHOOD_H, LIKELIHOOD_R), rtol=rtol, atol=1e-9))
    report.problems.append(f"with z = {LIKELIHOOD_CASES[case]} the values differ from log N(z_k; H_k x^i, R_k): "
                           "check the quadratic form (z_k - H_k x^i)^T R_k^-1 (z_k - H_k x^i) and the constant "
                           "-(m log(2 pi) + log det R_k) / 2, with m the number of coordinates measured")
    return report
