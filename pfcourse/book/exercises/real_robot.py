"""The checked exercise of the real-robot chapter (book/part2/real_robot): the beam model on beams drawn
at random.

:func:`check_random_beams` checks a student's ``fn(z, z_star, beam, k, rng) -> (N,)``: draw ``k``
distinct beams at random (each with the same probability) among the beams of the scan ``z`` (``(B,)``)
that have an echo (``z_b < z_max``), the same beams for every pose, and return for each of ``N`` poses,
whose expected ranges are the rows of ``z_star`` (``(N, B)``), the beam model's log-likelihood of
those beams (Thrun, Burgard and Fox 2005, section 6.3, its hit and random parts):

    log p(z | x) = sum_{b drawn} log( z_hit N(z_b; z*_b, sigma^2) + z_rand / z_max ),

``beam`` holding ``z_hit``, ``z_rand``, ``z_none``, ``sigma`` and ``z_max``.

The checker does not need the student's draws to match its own: the answer is a sum over a set of
beams, so with more poses than beams it is solved for that set (least squares on the per-beam terms,
:func:`beam_terms`, plus a constant: in this reduced model a beam with no echo scores the same at every pose,
``log z_none`` or the formula at ``z_b = z*_b = z_max``; any other constant is named as a shift or a
normalisation).  The set must
be ``k`` distinct echo beams shared by every pose; over many seeds each echo beam must come up about as
often as the others, the same seed must give the same answer and another seed another, and NumPy's
global generator must be left alone.  Per-pose draws are caught directly: poses given the same
predicted ranges must get the same answer.  A per-beam density slip (the normaliser, ``z_hit`` or
``z_rand / z_max`` missing or wrong, the log of the sum split) is solved for as a sum of its own terms.
Each typical mistake of :data:`RANDOM_BEAM_MISTAKES` is named in
its own sentence.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pfcourse.book.exercises.checking import CheckReport, _cloud_answers


@dataclass(frozen=True)
class BeamCase:
    """The beam model's parameters (the probabilities of a hit, a random echo and no echo; m)."""

    z_hit: float = 0.8
    z_rand: float = 0.1
    z_none: float = 0.1
    sigma: float = 0.2
    z_max: float = 25.0


RANDOM_BEAM_MISTAKES: dict[str, str] = {
    "replacement": "a beam is drawn twice: draw k distinct beams (rng.choice(..., replace=False)), since a beam "
                   "counted twice counts its evidence twice",
    "no_echo": "beams with no echo are among those drawn: draw among the beams with an echo (z < z_max); in this "
               "model a beam without one scores the same at every pose (log z_none, or the formula with z_b = z*_b "
               "= z_max), so it is a draw wasted",
    "dropped": "k beams are drawn among all the beams and those without an echo then dropped, so fewer than k "
               "are summed, a different number from scan to scan: draw the k beams among those with an echo",
    "per_pose": "each pose is scored on beams of its own: draw one set of k beams for the scan and score every "
                "pose on it, or the weights compare different evidence",
    "global_rng": "the beams are drawn from NumPy's global generator (np.random), not from the generator rng "
                  "you are given, so a seeded run cannot be repeated",
    "fixed": "every seed gives the same beams: draw them at random with rng, not as a fixed pattern, or the "
             "beams never drawn are never used",
    "no_rand": "the term z_rand / z_max is missing: without it one echo far from the expected range (a person "
               "walking by) makes the weight vanish",
    "split_log": "the log of a sum is written as a sum of logs, log(z_hit N) + log(z_rand / z_max): the beam's "
                 "density is the sum z_hit N + z_rand / z_max, and its log does not split",
    "no_norm": "the Gaussian's normaliser 1 / (sqrt(2 pi) sigma) is missing: without it the hit part is no "
               "density, and its weight against z_rand / z_max is wrong",
    "sqrt_sigma": "the Gaussian's normaliser is 1 / sqrt(2 pi sigma): it is 1 / (sqrt(2 pi) sigma), sigma outside "
                  "the root, since the density of z_b has the units of 1 / sigma",
    "no_zhit": "z_hit is left out: the hit part is z_hit N(z_b; z*_b, sigma^2), the share of echoes that hit the "
               "predicted wall, or hit and random parts do not add up to a density",
    "mean": "the log-densities are averaged over the beams drawn: the beams are independent, so their logs "
            "add up",
    "no_zmax": "z_rand is not divided by z_max: the random part is a density spread evenly over [0, z_max], so "
               "its height is z_rand / z_max",
    "normalised": "the log-likelihoods are normalised (their largest value or their log-sum-exp subtracted): "
                  "return them as they are, the filter normalises the weights once, after adding them to the "
                  "log-weights",
    "shift": "every log-likelihood is off by the same constant: add only log(z_hit N(z_b; z*_b, sigma^2) + "
             "z_rand / z_max) over the beams drawn, with no term outside the sum",
}
#: Mistakes that change the per-beam terms (the others change which beams are summed); split_log before
#: no_rand, which it equals up to a constant.
_TERM_MISTAKES = ("split_log", "no_rand", "no_zmax", "no_norm", "sqrt_sigma", "no_zhit")


def beam_terms(z: np.ndarray, z_star: np.ndarray, beam: BeamCase, mistake: str | None = None) -> np.ndarray:
    """Per pose and beam ``(N, B)``: ``log(z_hit N(z_b; z*_b, sigma^2) + z_rand / z_max)`` for a beam with an
    echo, ``log z_none`` for one without, or what a mistake of :data:`_TERM_MISTAKES` makes of it."""
    echo = z < beam.z_max
    norm = {"no_norm": 1.0, "sqrt_sigma": 1 / np.sqrt(2 * np.pi * beam.sigma)}.get(
        mistake, 1 / (np.sqrt(2 * np.pi) * beam.sigma))
    z_hit = 1.0 if mistake == "no_zhit" else beam.z_hit
    hit = z_hit * np.exp(-0.5 * ((z - z_star) / beam.sigma) ** 2) * norm
    rand = {"no_rand": 0.0, "no_zmax": beam.z_rand}.get(mistake, beam.z_rand / beam.z_max)
    with np.errstate(divide="ignore"):
        if mistake == "split_log":
            return np.where(echo, np.log(hit) + np.log(rand), np.log(beam.z_none))
        return np.log(np.where(echo, hit + rand, beam.z_none))


def random_beams_log_likelihood(z: np.ndarray, z_star: np.ndarray, beam: BeamCase, k: int,
                                rng: np.random.Generator, mistake: str | None = None) -> np.ndarray:
    """The reference answer ``(N,)``, or what one mistake of :data:`RANDOM_BEAM_MISTAKES` computes."""
    if mistake is not None and mistake not in RANDOM_BEAM_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(RANDOM_BEAM_MISTAKES)}")
    pool = np.arange(len(z)) if mistake == "no_echo" else np.flatnonzero(z < beam.z_max)
    terms = beam_terms(z, z_star, beam, mistake)
    if mistake == "no_echo":
        # the natural form: the stated formula applied to every drawn beam, echo or not
        terms = beam_terms(np.minimum(z, beam.z_max - 1e-12), z_star, beam)
    if mistake == "fixed":
        picked = terms[:, pool[:k]]
    elif mistake == "global_rng":
        picked = terms[:, np.random.choice(pool, k, replace=False)]
    elif mistake == "replacement":
        picked = terms[:, rng.choice(pool, k, replace=True)]
    elif mistake == "dropped":
        drawn = rng.choice(len(z), k, replace=False)
        picked = terms[:, drawn[z[drawn] < beam.z_max]]
    elif mistake == "per_pose":
        picked = np.array([row[rng.choice(pool, k, replace=False)] for row in terms])
    else:
        picked = terms[:, rng.choice(pool, k, replace=False)]
    total = picked.mean(axis=1) if mistake == "mean" else picked.sum(axis=1)
    if mistake == "normalised":
        return total - np.logaddexp.reduce(total)
    return total + 0.5 if mistake == "shift" else total


def _no_echo_formula_term(beam: BeamCase) -> float:
    """The stated formula's log-density for a beam without an echo (``z_b = z*_b = z_max``): the same at
    every pose of the checker's case."""
    return float(np.log(beam.z_hit / (np.sqrt(2 * np.pi) * beam.sigma) + beam.z_rand / beam.z_max))


def _constant_mistake(answer: np.ndarray, s: np.ndarray, m: float, k: int, beam: BeamCase) -> str | None:
    """Name the mistake behind a sum of whole echo beams ``s`` plus a constant ``m log z_none`` that is not
    a whole number of no-echo beams scored by ``z_none`` (``None`` if the constant is zero)."""
    c = m * np.log(beam.z_none)
    if abs(c) < 1e-6:
        return None
    if np.isclose(answer.max(), 0.0, atol=1e-6) or np.isclose(np.logaddexp.reduce(answer), 0.0, atol=1e-6):
        return "normalised"
    extra = k - int(s.sum())
    for unit in (_no_echo_formula_term(beam), np.log(beam.z_none)):
        n = c / unit
        if 0 < extra and abs(n - round(n)) < 1e-5 and round(n) == extra:
            return "no_echo"
    # a mix of both kinds of no-echo beams
    a, b = _no_echo_formula_term(beam), np.log(beam.z_none)
    for n_formula in range(1, extra):
        if np.isclose(n_formula * a + (extra - n_formula) * b, c, atol=1e-6):
            return "no_echo"
    return "shift"


def random_beam_case(seed: int = 0, n_poses: int = 80, n_beams: int = 40) -> tuple[np.ndarray, np.ndarray, BeamCase]:
    """A scan of ``n_beams`` beams, about one in six with no echo, and the expected ranges of ``n_poses``
    poses near the scan's ranges (more poses than beams, so the beams summed can be solved for)."""
    rng = np.random.default_rng([16, seed])
    beam = BeamCase()
    z = rng.uniform(0.5, 12.0, n_beams)
    z[rng.random(n_beams) < 0.15] = beam.z_max
    z[:2] = beam.z_max, 3.0  # at least one beam without an echo and one with
    z_star = np.where(z < beam.z_max, z + rng.normal(0.0, 0.4, (n_poses, n_beams)), beam.z_max)
    return z, np.clip(z_star, 0.05, beam.z_max), beam


def beams_summed(answer: np.ndarray, terms: np.ndarray, echo: np.ndarray, z_none: float, tol: float = 1e-6):
    """Solve ``answer = terms[:, echo] @ s + c`` for the multiplicities ``s`` of the echo beams and the
    number ``m = c / log z_none`` of no-echo beams; ``None`` if no such sum fits (or ``s``, ``m`` are not
    whole numbers), else ``(s, m)``."""
    design = np.column_stack([terms[:, echo], np.ones(len(answer))])
    coef, *_ = np.linalg.lstsq(design, answer, rcond=None)
    if not np.allclose(design @ coef, answer, rtol=0, atol=tol * max(1.0, np.abs(answer).max())):
        return None
    s, m = coef[:-1], coef[-1] / np.log(z_none)
    if np.abs(s - np.round(s)).max() > 1e-5 or abs(m - round(m)) > 1e-5:
        return s, m  # a sum, but not of whole beams (e.g. a mean)
    return np.round(s).astype(int), int(round(m))


def _varying_count(fn: Callable, z: np.ndarray, z_star: np.ndarray, beam: BeamCase, k: int, seed: int,
                   n_seeds: int = 20) -> bool:
    """Whether the number of echo beams ``fn`` sums changes from seed to seed, never above ``k`` (``k`` drawn
    among all the beams, the no-echo ones dropped), rather than staying one wrong number."""
    echo = z < beam.z_max
    terms = beam_terms(z, z_star, beam)
    counts = set()
    for s_ in range(seed + 2, seed + 2 + n_seeds):
        fit = beams_summed(np.asarray(fn(z.copy(), z_star.copy(), beam, k, np.random.default_rng(s_)), dtype=float),
                           terms, echo, beam.z_none)
        if fit is None or not np.issubdtype(np.asarray(fit[0]).dtype, np.integer) or fit[1] != 0:
            return False
        counts.add(int(fit[0].sum()))
    return len(counts) > 1 and max(counts) <= k


def _per_pose(fn: Callable, z: np.ndarray, z_star: np.ndarray, beam: BeamCase, k: int, seed: int,
              n_same: int = 8) -> bool:
    """Whether ``fn`` scores poses with the same predicted ranges differently: the first ``n_same`` rows of
    ``z_star`` made identical, an answer that draws one set of beams gives them one value."""
    same = z_star.copy()
    same[:n_same] = z_star[0]
    try:
        got = np.asarray(fn(z.copy(), same, beam, k, np.random.default_rng(seed)), dtype=float)
    except Exception:  # noqa: BLE001 - a broken answer is reported by the first calls
        return False
    return got.shape == (len(same),) and bool(np.isfinite(got[:n_same]).all()) and np.ptp(got[:n_same]) > 1e-9


def check_random_beams(fn: Callable, k: int = 12, seed: int = 0, n_seeds: int = 200) -> CheckReport:
    """Check ``fn(z, z_star, beam, k, rng) -> (N,)`` (the module's docstring)."""
    report = CheckReport("beam model on random beams")
    z, z_star, beam = random_beam_case(seed)
    echo = z < beam.z_max
    terms = beam_terms(z, z_star, beam)
    saved = np.random.get_state()
    try:
        np.random.seed(12345)
        before = np.random.get_state()[1].copy()
        answers = _cloud_answers(report, [lambda s=s: fn(z.copy(), z_star.copy(), beam, k, np.random.default_rng(s))
                                          for s in (seed, seed, seed + 1)],
                                 "fn(z, z_star, beam, k, rng)", "compute and return one log-likelihood per pose",
                                 len(z_star), "log-likelihood per pose (a row of z_star)")
        touched = not np.array_equal(np.random.get_state()[1], before)
    finally:
        np.random.set_state(saved)
    if answers is None:
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("some log-likelihoods are NaN: every drawn beam's density is positive (z_rand / "
                               "z_max at least), so its log is a number")
        return report
    if touched:
        report.problems.append(RANDOM_BEAM_MISTAKES["global_rng"])
        return report
    if not np.array_equal(answers[0], answers[1]):
        report.problems.append("two calls with the same seed gave different answers: draw every random number "
                               "from the generator rng you are given")
        return report
    if _per_pose(fn, z, z_star, beam, k, seed):
        report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['per_pose']}")
        return report
    fit = beams_summed(answers[0], terms, echo, beam.z_none)
    if fit is None:
        for mistake in _TERM_MISTAKES:
            slip = beams_summed(answers[0], beam_terms(z, z_star, beam, mistake), echo, beam.z_none)
            if slip is not None and np.issubdtype(np.asarray(slip[0]).dtype, np.integer) and slip[1] == 0:
                report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[mistake]}")
                return report
        report.problems.append("the per-beam log-density is not log(z_hit N(z_b; z*_b, sigma^2) + z_rand / z_max): "
                               "the answer is no sum of these terms over the beams drawn, so compute each drawn "
                               "beam's density as the model writes it and add the logs")
        return report
    s, m = fit
    whole = np.abs(np.asarray(s, dtype=float) - np.round(s)).max() <= 1e-5
    if whole and (named := _constant_mistake(answers[0], np.round(s).astype(int), m, k, beam)) is not None:
        report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[named]}")
        return report
    if not np.issubdtype(np.asarray(s).dtype, np.integer):
        if np.allclose(s * k, np.round(s * k), atol=1e-5) and np.isclose(s.sum() + m, 1.0, atol=1e-5):
            report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['mean']}")
        else:
            report.problems.append("the log-likelihoods weigh the beams by fractions: add each drawn beam's "
                                   "log-density once")
        return report
    if s.sum() + m != k or (s < 0).any() or m < 0:
        if m == 0 and 0 < s.sum() < k and (s >= 0).all() and _varying_count(fn, z, z_star, beam, k, seed):
            report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['dropped']}")
        else:
            report.problems.append(f"the answer sums {s.sum() + m} beams, not k = {k}: draw exactly k beams")
        return report
    if m > 0:
        report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['no_echo']}")
        return report
    # over many seeds: distinct beams, not always the same, each echo beam about equally often
    counts = np.zeros(echo.sum())
    sets = set()
    for s_ in range(seed + 2, seed + 2 + n_seeds):
        got = fn(z.copy(), z_star.copy(), beam, k, np.random.default_rng(s_))
        got = np.asarray(got, dtype=float)
        fit = beams_summed(got, terms, echo, beam.z_none)
        if fit is not None and np.abs(fit[0] - np.round(fit[0])).max() <= 1e-5:
            named = _constant_mistake(got, np.round(fit[0]).astype(int), fit[1], k, beam)
            if named is not None:
                report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[named]}")
                return report
        if fit is None or not np.issubdtype(np.asarray(fit[0]).dtype, np.integer):
            report.problems.append(f"with the seed {s_} the answer is not a sum over beams of the scan: "
                                   "score every pose on the same k beams")
            return report
        s, m = fit
        if m > 0:
            report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['no_echo']}")
            return report
        if m == 0 and 0 < s.sum() < k:  # k beams with the first seed, fewer with this one
            report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['dropped']}")
            return report
        if s.max() > 1:
            report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['replacement']}")
            return report
        counts += s
        sets.add(tuple(np.flatnonzero(s)))
    if len(sets) == 1:
        report.problems.append(f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['fixed']}")
        return report
    p = k / echo.sum()
    expected, sd = n_seeds * p, np.sqrt(n_seeds * p * (1 - p))
    if np.abs(counts - expected).max() > 5 * sd:
        report.problems.append("some echo beams are drawn far more often than others over many seeds: give each "
                               "beam with an echo the same chance")
    return report
