"""Checkers of Part IV (choosing a filter: chapters 20-21)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.exercises.checking import CheckReport, _answer, _per_particle_answers, _settled


# The NEES consistency check over R runs (chapter 23, exercise 23.1): errors of shape (R, K, d) and
# covariances (R, K, d, d) of a filter that is consistent at most steps, over-confident at a few.
CONSISTENCY_MISTAKES = {
    "one_run_band": "its band is that of a single run, chi2_d quantiles; the average of R independent chi2_d "
                    "values is chi2_(R d) / R, a band R times narrower in relative terms",
    "band_not_divided": "its band is the chi2_(R d) quantiles themselves, not divided by R: that is the band of "
                        "the sum over the runs, while the function returns their average",
    "cov_not_inverted": "it computes e^T P e; the NEES weighs the error by the inverse covariance, e^T P^-1 e",
    "one_sided": "its band is one-sided (0 up to the 95 % quantile); a consistent filter's average must be "
                 "neither too large nor too small, so cut 2.5 % from each side",
    "summed": "it sums the NEES over the runs instead of averaging them; the band is for the average",
}


def nees_consistency(errors: np.ndarray, covariances: np.ndarray, probability: float = 0.95,
                     mistake: str | None = None) -> tuple[np.ndarray, tuple[float, float], float]:
    """The NEES check over ``R`` runs: ``NEES_rk = e_rk^T P_rk^-1 e_rk``, its average over the runs per
    step, the band ``chi2_(R d)^-1(a/2, 1 - a/2) / R`` (``a = 1 - probability``) and the fraction of the
    steps whose average lies in it. ``mistake`` (a key of :data:`CONSISTENCY_MISTAKES`) computes that
    mistake instead."""
    from scipy import stats

    errors, covariances = np.asarray(errors, dtype=float), np.asarray(covariances, dtype=float)
    R, _, d = errors.shape
    weight = covariances if mistake == "cov_not_inverted" else np.linalg.inv(covariances)
    nees = np.einsum("rki,rkij,rkj->rk", errors, weight, errors)
    average = nees.sum(axis=0) if mistake == "summed" else nees.mean(axis=0)
    alpha = 1.0 - probability
    quantiles = [0.0, 1 - alpha] if mistake == "one_sided" else [alpha / 2, 1 - alpha / 2]
    dof, scale = (d, 1.0) if mistake == "one_run_band" else (R * d, 1.0 if mistake == "band_not_divided" else R)
    low, high = (float(v) for v in stats.chi2.ppf(quantiles, dof) / scale)
    return average, (low, high), float(np.mean((average >= low) & (average <= high)))


def _consistency_case(seed: int = 0, runs: int = 20, steps: int = 60, d: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Errors drawn from the covariances (a consistent filter) except over steps 40-49, where the true
    errors are twice as large as the covariance says (an over-confident spell)."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(runs, steps, d, d))
    covariances = np.einsum("rkij,rklj->rkil", a, a) / d + 0.1 * np.eye(d)
    errors = np.einsum("rkij,rkj->rki", np.linalg.cholesky(covariances), rng.normal(size=(runs, steps, d)))
    errors[:, 40:50] *= 2.0
    return errors, covariances


def check_consistency(fn: Callable, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(errors, covariances) -> (average_nees, (low, high), fraction)``.

    On :func:`_consistency_case` (20 runs, 60 steps, 3 dimensions), the three answers must equal
    :func:`nees_consistency` to ``rtol``; a wrong answer is compared with each mistake of
    :data:`CONSISTENCY_MISTAKES` and the report names the one that fits.
    """
    report = CheckReport("NEES consistency check")
    errors, covariances = _consistency_case(seed)
    answer = _answer(report, lambda: fn(errors.copy(), covariances.copy()), "fn(errors, covariances)",
                     "return (average_nees, (low, high), fraction)")
    if answer is None:
        return report
    try:
        average, band, fraction = answer
        average, band, fraction = np.asarray(average, dtype=float), tuple(float(b) for b in band), float(fraction)
    except (TypeError, ValueError):
        report.problems.append("the answer is not (average_nees, (low, high), fraction): return the per-step "
                               "average, the band as two numbers and the fraction of steps inside it")
        return report
    if average.shape != (errors.shape[1],):
        report.problems.append(f"average_nees has shape {average.shape}, not ({errors.shape[1]},): average the "
                               "NEES over the runs (axis 0), one value per step")
        return report

    def fits(mistake: str | None) -> bool:
        ref_average, ref_band, ref_fraction = nees_consistency(errors, covariances, mistake=mistake)
        return (np.allclose(average, ref_average, rtol=rtol) and np.allclose(band, ref_band, rtol=rtol)
                and abs(fraction - ref_fraction) < 1e-12)

    if _settled(report, fits, CONSISTENCY_MISTAKES):
        return report
    ref_average, ref_band, _ = nees_consistency(errors, covariances)
    if not np.allclose(average, ref_average, rtol=rtol):
        report.problems.append("the run-averaged NEES differs from the mean over the runs of e^T P^-1 e: check "
                               "the quadratic form, step by step and run by run")
    elif not np.allclose(band, ref_band, rtol=rtol):
        report.problems.append(f"the band {band} differs from the 2.5 % and 97.5 % quantiles of chi2_(R d) "
                               f"divided by R, {tuple(round(b, 4) for b in ref_band)}")
    else:
        report.problems.append("the fraction differs from the share of steps whose average lies inside the "
                               "band, bounds included")
    return report


#: Landmarks, measurement covariance and sensor of the anonymous-reading checker.
ANONYMOUS_LANDMARKS = np.array([[10.0, 0.0], [0.0, 12.0], [-9.0, -4.0]])


ANONYMOUS_R = np.diag([0.5, np.deg2rad(2.0)]) ** 2


#: Cases ``(z, p_detect, clutter_rate, max_range)``: an ordinary reading, one with its bearing
#: near pi (where a bearing that is not wrapped is wrong), one without clutter.
ANONYMOUS_CASES = (
    (np.array([10.2, 0.05]), 0.8, 1.5, 30.0),
    (np.array([9.1, 3.1]), 0.9, 0.5, 30.0),
    (np.array([12.1, 1.55]), 0.7, 0.0, 30.0),
)


ANONYMOUS_MISTAKES = {
    "no_clutter": "it forgets the clutter term (1 - P_D) lambda c(z): a reading that no landmark explains then "
                  "makes a particle impossible instead of merely unlikely",
    "no_division": "it does not divide P_D by the number of landmarks M: each landmark is the one looked at with "
                   "probability 1/M, so the detection terms are (P_D / M) N(z; h_j(x), R)",
    "sum_logs": "it sums the log-likelihoods of the terms instead of the likelihoods: the reading comes from one "
                "landmark OR another OR the clutter, so the terms add as probabilities, with logsumexp in the "
                "log domain",
    "no_wrap": "it does not wrap the bearing innovation to (-pi, pi]: a reading at 179 degrees is then 358 "
               "degrees from a prediction at -179 degrees instead of 2",
    "no_exp": "it misses the factor e^{-lambda} (the probability that no other clutter reading appeared), "
              "the term -lambda of the log-likelihood",
}


def anonymous_log_likelihood(x: np.ndarray, z: np.ndarray, landmarks: np.ndarray, R: np.ndarray, p_detect: float,
                             clutter_rate: float, max_range: float, mistake: str | None = None) -> np.ndarray:
    """``log p(z | x^i)`` of one anonymous range-bearing reading for every particle (rows of ``x``):

    ``-lambda + log[ (1 - P_D) lambda c + sum_j (P_D / M) N(z; h_j(x), R) ]``, ``c = 1 / (2 pi r_max)``,
    ``h_j(x) = (|l^j - p|, wrap(atan2(l^j - p) - theta))``, the bearing innovation wrapped; ``mistake``
    (a key of :data:`ANONYMOUS_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    dx = landmarks[:, 0][None] - x[:, 0][:, None]  # (N, M)
    dy = landmarks[:, 1][None] - x[:, 1][:, None]
    nu_r = z[0] - np.hypot(dx, dy)
    nu_b = z[1] - (np.arctan2(dy, dx) - x[:, 2][:, None])
    if mistake != "no_wrap":
        nu_b = np.angle(np.exp(1j * nu_b))
    ell = -0.5 * (nu_r**2 / R[0, 0] + nu_b**2 / R[1, 1]) - np.log(2 * np.pi) - 0.5 * np.log(R[0, 0] * R[1, 1])
    M = 1 if mistake == "no_division" else len(landmarks)
    with np.errstate(divide="ignore"):
        clutter = np.log((1 - p_detect) * clutter_rate / (2 * np.pi * max_range))
        terms = np.column_stack([np.full(len(x), -np.inf if mistake == "no_clutter" else clutter),
                                 np.log(p_detect / M) + ell])
    if mistake == "sum_logs":
        return -clutter_rate + np.sum(np.where(np.isinf(terms), 0.0, terms), axis=1)
    return logsumexp(terms, axis=1) - (0.0 if mistake == "no_exp" else clutter_rate)


def check_anonymous_likelihood(fn: Callable, n_particles: int = 60, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, landmarks, R, p_detect, clutter_rate, max_range) -> (N,)``, the
    log-likelihood of one anonymous reading ``z = (range, bearing)`` for a cloud ``x`` ``(N, 3)``.

    Each case of :data:`ANONYMOUS_CASES` must equal :func:`anonymous_log_likelihood` to ``rtol``; an
    answer that does not is compared with each mistake of :data:`ANONYMOUS_MISTAKES` (forgotten
    clutter, ``P_D`` not divided by ``M``, log-likelihoods summed, bearing not wrapped, no
    ``e^{-lambda}``), and the report names the one that fits.
    """
    report = CheckReport("anonymous-reading log-likelihood")
    x = np.random.default_rng(seed).normal([0.0, 0.0, 0.0], [3.0, 3.0, 0.5], size=(n_particles, 3))
    answers = _per_particle_answers(
        report, [lambda case=case: fn(x.copy(), case[0].copy(), ANONYMOUS_LANDMARKS.copy(), ANONYMOUS_R.copy(),
                                      *case[1:]) for case in ANONYMOUS_CASES],
        n_particles, "fn(x, z, landmarks, R, p_detect, clutter_rate, max_range)")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, anonymous_log_likelihood(x, *case[:1], ANONYMOUS_LANDMARKS, ANONYMOUS_R,
                                                           *case[1:], mistake=mistake),
                               rtol=rtol, atol=1e-9, equal_nan=True) for a, case in zip(answers, ANONYMOUS_CASES))

    if _settled(report, fits, ANONYMOUS_MISTAKES):
        return report
    report.problems.append("the values differ from -lambda + log[(1 - P_D) lambda c + sum_j (P_D / M) N(z; h_j(x), R)] "
                           "with c = 1 / (2 pi r_max): check each term, in the log domain, and add them with logsumexp")
    return report
