"""The checked exercise of the real-robot chapter (book/part2/real_robot): the beam model instead of the
likelihood field.

:func:`check_beam_model` checks a student's ``fn(z, z_star, beam) -> (N,)``: the log-likelihood of one
scan ``z`` (``(B,)``) for ``N`` poses whose expected ranges (the distance to the first wall along
each beam, ray-cast on the map) are ``z_star`` (``(N, B)``), by a three-part beam model (Thrun,
Burgard and Fox 2005, section 6.3, without the "short" part):

    p(z_b | x) = z_hit N(z_b; z*_b, sigma^2) + z_rand / z_max    for a beam with an echo (z_b < z_max),
    p(z_b | x) = z_none                                            for a beam with no echo (z_b >= z_max),

    log p(z | x) = sum_b log p(z_b | x),

``beam`` holding ``z_hit``, ``z_rand``, ``z_none``, ``sigma`` and ``z_max``.  A beam with no echo adds
``log z_none`` to every pose alike, so it changes no normalised weight: leaving such beams out, as the
likelihood field does, is the same filter, and the checker does not call it a mistake (it accepts the
answer only with the term, which the exercise asks for).  An echo where a pose expects none is scored.  The answer is
compared with :func:`beam_log_likelihood` on a scan of 12 beams and one of 360 (where a product of
densities underflows); a wrong one with each mistake of :data:`BEAM_MISTAKES`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pfcourse.book.exercises.checking import CheckReport, _cloud_answers, _settled


@dataclass(frozen=True)
class BeamCase:
    """The beam model's parameters (the probabilities of a hit, a random echo and no echo; m)."""

    z_hit: float = 0.8
    z_rand: float = 0.1
    z_none: float = 0.1
    sigma: float = 0.2
    z_max: float = 25.0


BEAM_MISTAKES: dict[str, str] = {
    "no_rand": "the term z_rand / z_max is missing: without it one echo far from the expected range (a person "
               "walking by) makes the weight vanish",
    "no_constant": "the Gaussian density needs its factor 1 / (sqrt(2 pi) sigma): without it z_hit and z_rand "
                   "are mixed in the wrong proportion",
    "none_everywhere": "z_none is added to every beam: it is the probability of a beam with no echo, so it "
                       "belongs to those beams only",
    "product": "the densities are multiplied and then logged: the product of 360 beams underflows to 0 "
               "(log 0 = -inf); add the logs instead",
    "mean": "the log-densities are averaged over the beams: the beams are independent, so their logs add up",
}


def beam_log_likelihood(z: np.ndarray, z_star: np.ndarray, beam: BeamCase, mistake: str | None = None) -> np.ndarray:
    """The module's beam model, ``(N,)``, or what one mistake of :data:`BEAM_MISTAKES` computes."""
    if mistake is not None and mistake not in BEAM_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(BEAM_MISTAKES)}")
    echo = z < beam.z_max
    norm = 1.0 if mistake == "no_constant" else np.sqrt(2 * np.pi) * beam.sigma
    hit = beam.z_hit * np.exp(-0.5 * ((z - z_star) / beam.sigma) ** 2) / norm
    rand = 0.0 if mistake == "no_rand" else beam.z_rand / beam.z_max
    none = beam.z_none if mistake == "none_everywhere" else 0.0
    dens = np.where(echo, hit + rand + none, beam.z_none)
    with np.errstate(divide="ignore"):
        if mistake == "product":
            return np.log(np.prod(dens, axis=1))
        logs = np.log(dens)
        return logs.mean(axis=1) if mistake == "mean" else logs.sum(axis=1)


def beam_cases(n_poses: int, seed: int) -> list[tuple[np.ndarray, np.ndarray, BeamCase]]:
    """Two scans (12 and 360 beams) and the expected ranges of ``n_poses`` poses: some beams with no echo,
    some poses that expect none where the scan has one, one echo far off (a passer-by)."""
    rng = np.random.default_rng(seed)
    beam = BeamCase()
    cases = []
    for n_beams in (12, 360):
        truth = rng.uniform(0.5, 12.0, n_beams)
        truth[rng.random(n_beams) < 0.15] = beam.z_max  # nothing within range
        z = np.where(truth < beam.z_max, truth + rng.normal(0.0, beam.sigma, n_beams), beam.z_max)
        z[0] = 0.4 * truth[0] if truth[0] < beam.z_max else 2.0
        z_star = truth + rng.normal(0.0, 1.0, (n_poses, n_beams))
        z_star[rng.random((n_poses, n_beams)) < 0.1] = beam.z_max
        z_star = np.clip(z_star, 0.05, beam.z_max)
        cases.append((z, z_star, beam))
    return cases


def check_beam_model(fn: Callable, n_poses: int = 30, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(z, z_star, beam) -> (N,)`` against :func:`beam_log_likelihood` (the module's docstring)."""
    report = CheckReport("beam model")
    cases = beam_cases(n_poses, seed)
    answers = _cloud_answers(report, [lambda c=c: fn(c[0].copy(), c[1].copy(), c[2]) for c in cases],
                             "fn(z, z_star, beam)", "compute and return one log-likelihood per pose", n_poses,
                             "log-likelihood per pose (a row of z_star), summed over the beams")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, beam_log_likelihood(z, zs, b, mistake), rtol=rtol, atol=1e-9)
                   for a, (z, zs, b) in zip(answers, cases))

    if _settled(report, fits, BEAM_MISTAKES):
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("some log-likelihoods are NaN: every beam's density is positive (z_rand / z_max "
                               "or z_none at least), so its log is a number")
        return report
    report.problems.append("the log-likelihoods differ from the beam model's: for a beam with an echo add "
                           "log(z_hit N(z_b; z*_b, sigma^2) + z_rand / z_max), for one without add log(z_none)")
    return report
