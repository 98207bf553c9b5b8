"""Checkers of Part IV (choosing a filter: chapters 20-21)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.metrics import rmse
from pfcourse.book.exercises.checking import CheckReport, _answer, _per_particle_answers, _settled


# The NEES consistency check over R runs (no chapter asks for it now; kept for a variant): errors of
# shape (R, K, d) and covariances (R, K, d, d) of a filter that is consistent at most steps, over-confident at a few.
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


# The NIS check with missing readings (chapter 23, exercise 23.1): innovations (R, K, m) and their
# covariances (R, K, m, m), NaN where run r had no reading at step k.
MISSING_NIS_MISTAKES = {
    "divided_by_all_runs": "it divides the sum of the NIS by all R runs, counting a run without a reading as a "
                           "NIS of 0; average over the n_k runs that have a reading at step k",
    "band_all_runs": "its band is that of an average over all R runs; at a step where only n_k runs have a "
                     "reading the average is chi2_(n_k m) / n_k, a wider band",
    "one_run_band": "its band is that of a single run, chi2_m quantiles; an average of n_k independent chi2_m "
                    "values is chi2_(n_k m) / n_k",
    "band_not_divided": "its band is the chi2_(n_k m) quantiles themselves, not divided by n_k: the band of the "
                        "sum over the runs, while the function returns their average",
    "cov_not_inverted": "it computes y^T S y; the NIS weighs the innovation by the inverse covariance, y^T S^-1 y",
    "fraction_over_all_steps": "its fraction counts the steps where no run has a reading (as outside the band); "
                               "a step without a reading says nothing: count only the steps with n_k >= 1",
}


def missing_nis_consistency(innovations: np.ndarray, covariances: np.ndarray, probability: float = 0.95,
                            mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The NIS check over ``R`` runs with missing readings: per step ``k``, the ``n_k`` runs with a reading,
    the average of their ``y^T S^-1 y``, the band ``chi2_(n_k m)^-1(a/2, 1 - a/2) / n_k``
    (``a = 1 - probability``; NaN where ``n_k = 0``) and the fraction of the steps with ``n_k >= 1``
    whose average lies in its band.  ``mistake`` (a key of :data:`MISSING_NIS_MISTAKES`) computes that
    mistake instead."""
    y, S = np.asarray(innovations, dtype=float), np.asarray(covariances, dtype=float)
    R, K, m = y.shape
    present = ~np.isnan(y).any(axis=2)
    safe_S = np.where(present[..., None, None], S, np.eye(m))
    weight = safe_S if mistake == "cov_not_inverted" else np.linalg.inv(safe_S)
    nis = np.einsum("rki,rkij,rkj->rk", np.where(present[..., None], y, 0.0), weight,
                    np.where(present[..., None], y, 0.0))
    n_k = present.sum(axis=0)
    seen = n_k > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        average = nis.sum(axis=0) / (R if mistake == "divided_by_all_runs" else n_k)
    average[~seen] = np.nan
    alpha = 1.0 - probability
    n_band = np.full(K, R) if mistake == "band_all_runs" else n_k
    dof = np.full(K, m) if mistake == "one_run_band" else n_band * m
    scale = 1.0 if mistake in ("one_run_band", "band_not_divided") else n_band
    with np.errstate(invalid="ignore", divide="ignore"):
        low = np.where(seen, stats.chi2.ppf(alpha / 2, np.maximum(dof, 1)) / scale, np.nan)
        high = np.where(seen, stats.chi2.ppf(1 - alpha / 2, np.maximum(dof, 1)) / scale, np.nan)
    inside = seen & (average >= low) & (average <= high)
    fraction = inside.sum() / (K if mistake == "fraction_over_all_steps" else seen.sum())
    return average, low, high, float(fraction)


def _missing_nis_case(seed: int = 0, runs: int = 12, steps: int = 60, m: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Innovations drawn from their covariances (a consistent filter) except over steps 40-49 (twice as
    large: over-confident); each run has a reading at a step with probability 0.6, none at steps 10-14."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(runs, steps, m, m))
    S = np.einsum("rkij,rklj->rkil", a, a) / m + 0.1 * np.eye(m)
    y = np.einsum("rkij,rkj->rki", np.linalg.cholesky(S), rng.normal(size=(runs, steps, m)))
    y[:, 40:50] *= 2.0
    missing = rng.random((runs, steps)) > 0.6
    missing[:, 10:15] = True
    y[missing] = np.nan
    S[missing] = np.nan
    return y, S


def check_missing_nis(fn: Callable, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(innovations, covariances) -> (average_nis, low, high, fraction)`` on
    :func:`_missing_nis_case`: each answer must equal :func:`missing_nis_consistency` (NaN where no run has
    a reading); a wrong answer is compared with each mistake of :data:`MISSING_NIS_MISTAKES`."""
    report = CheckReport("NIS check with missing readings")
    y, S = _missing_nis_case(seed)
    K = y.shape[1]
    answer = _answer(report, lambda: fn(y.copy(), S.copy()), "fn(innovations, covariances)",
                     "return (average_nis, low, high, fraction)")
    if answer is None:
        return report
    try:
        average, low, high, fraction = answer
        average, low, high = (np.asarray(v, dtype=float) for v in (average, low, high))
        fraction = float(fraction)
    except (TypeError, ValueError):
        report.problems.append("the answer is not (average_nis, low, high, fraction): return the per-step average, "
                               "the per-step band as two arrays and the fraction of steps inside it")
        return report
    for name, value in (("average_nis", average), ("low", low), ("high", high)):
        if value.shape != (K,):
            report.problems.append(f"{name} has shape {value.shape}, not ({K},): one value per step (the band "
                                   "depends on how many runs have a reading at that step)")
            return report

    def fits(mistake: str | None) -> bool:
        ref = missing_nis_consistency(y, S, mistake=mistake)
        return (all(np.allclose(a, b, rtol=rtol, equal_nan=True) for a, b in zip((average, low, high), ref[:3]))
                and abs(fraction - ref[3]) < 1e-12)

    if _settled(report, fits, MISSING_NIS_MISTAKES):
        return report
    ref = missing_nis_consistency(y, S)
    if not np.array_equal(np.isnan(average), np.isnan(ref[0])):
        report.problems.append("average_nis must be NaN exactly at the steps where no run has a reading (steps "
                               "10-14 here), and a number elsewhere")
    elif not np.allclose(average, ref[0], rtol=rtol, equal_nan=True):
        report.problems.append("the average NIS differs from the mean of y^T S^-1 y over the runs that have a "
                               "reading at the step: check the quadratic form and which runs you count")
    elif not (np.allclose(low, ref[1], rtol=rtol, equal_nan=True) and np.allclose(high, ref[2], rtol=rtol,
                                                                                  equal_nan=True)):
        report.problems.append("the band differs from the 2.5 % and 97.5 % quantiles of chi2_(n_k m) divided by "
                               "n_k, n_k the runs with a reading at the step (NaN where n_k = 0)")
    else:
        report.problems.append("the fraction differs from the share of the steps with a reading whose average "
                               "lies inside its band, bounds included")
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


# The anonymous range-only reading (chapter 24, exercise 24.2): a sensor that measures the range
# alone, clutter uniform over [0, r_max].
RANGE_ONLY_VAR = 0.5**2
#: Cases ``(r, p_detect, clutter_rate, max_range)``: ordinary, without clutter, dense clutter.
RANGE_ONLY_CASES = ((10.3, 0.8, 1.5, 30.0), (11.7, 0.9, 0.0, 30.0), (6.0, 0.6, 4.0, 50.0))
RANGE_ONLY_MISTAKES = {
    "bearing_density": "its clutter density is 1 / (2 pi r_max), that of a range-and-bearing sensor; a clutter "
                       "range alone is uniform over [0, r_max], of density 1 / r_max",
    "no_clutter": "it forgets the clutter term (1 - P_D) lambda / r_max: a range that no landmark explains then "
                  "makes a particle impossible instead of merely unlikely",
    "no_division": "it does not divide P_D by the number of landmarks M: each landmark is the one looked at with "
                   "probability 1/M",
    "sum_logs": "it sums the log-likelihoods of the terms instead of the likelihoods: the range comes from one "
                "landmark OR another OR the clutter, so the terms add as probabilities (logsumexp)",
    "sd_as_variance": "it uses the variance sigma^2 where the Gaussian needs the standard deviation (or the "
                      "reverse): the density of the range is N(r; |l^j - p|, sigma^2), sigma^2 the variance given",
    "linear_domain": "it adds the densities outside the log domain: for a particle far from every landmark "
                     "exp(log N) underflows to 0 and its log-likelihood becomes -inf; use logsumexp",
    "no_exp": "it misses the factor e^{-lambda} (no other clutter reading appeared), the term -lambda",
}


def range_only_log_likelihood(x: np.ndarray, r: float, landmarks: np.ndarray, var: float, p_detect: float,
                              clutter_rate: float, max_range: float, mistake: str | None = None) -> np.ndarray:
    """``log p(r | x^i) = -lambda + log[ (1 - P_D) lambda / r_max + sum_j (P_D / M) N(r; |l^j - p^i|, var) ]``
    for every particle (rows of ``x``, position in the first two columns); ``mistake`` (a key of
    :data:`RANGE_ONLY_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    dist = np.hypot(landmarks[:, 0][None] - x[:, :1], landmarks[:, 1][None] - x[:, 1:2])  # (N, M)
    v = np.sqrt(var) if mistake == "sd_as_variance" else var
    ell = -0.5 * (r - dist) ** 2 / v - 0.5 * np.log(2 * np.pi * v)
    M = 1 if mistake == "no_division" else len(landmarks)
    density = 1 / (2 * np.pi * max_range) if mistake == "bearing_density" else 1 / max_range
    with np.errstate(divide="ignore"):
        clutter = np.log((1 - p_detect) * clutter_rate * density)
    terms = np.column_stack([np.full(len(x), -np.inf if mistake == "no_clutter" else clutter),
                             np.log(p_detect / M) + ell])
    if mistake == "sum_logs":
        return -clutter_rate + np.sum(np.where(np.isinf(terms), 0.0, terms), axis=1)
    if mistake == "linear_domain":
        with np.errstate(divide="ignore", under="ignore"):
            return np.log(np.sum(np.exp(terms), axis=1)) - clutter_rate
    return logsumexp(terms, axis=1) - (0.0 if mistake == "no_exp" else clutter_rate)


def check_range_only_anonymous(fn: Callable, n_particles: int = 60, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, r, landmarks, var, p_detect, clutter_rate, max_range) -> (N,)``, the
    log-likelihood of one anonymous range ``r`` for a cloud ``x`` ``(N, 3)`` (five particles far from every
    landmark, where only the log domain keeps the value finite without clutter); each case of
    :data:`RANGE_ONLY_CASES` must equal :func:`range_only_log_likelihood`, and a wrong answer is compared
    with each mistake of :data:`RANGE_ONLY_MISTAKES`."""
    report = CheckReport("anonymous range-only log-likelihood")
    x = np.random.default_rng(seed).normal([0.0, 0.0, 0.0], [3.0, 3.0, 0.5], size=(n_particles, 3))
    x[:5, :2] += 300.0  # far from every landmark
    answers = _per_particle_answers(
        report, [lambda case=case: fn(x.copy(), case[0], ANONYMOUS_LANDMARKS.copy(), RANGE_ONLY_VAR, *case[1:])
                 for case in RANGE_ONLY_CASES],
        n_particles, "fn(x, r, landmarks, var, p_detect, clutter_rate, max_range)")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, range_only_log_likelihood(x, case[0], ANONYMOUS_LANDMARKS, RANGE_ONLY_VAR,
                                                            *case[1:], mistake=mistake),
                               rtol=rtol, atol=1e-9, equal_nan=True) for a, case in zip(answers, RANGE_ONLY_CASES))

    if _settled(report, fits, RANGE_ONLY_MISTAKES):
        return report
    report.problems.append("the values differ from -lambda + log[(1 - P_D) lambda / r_max + sum_j (P_D / M) "
                           "N(r; |l^j - p|, sigma^2)]: check each term, in the log domain, and add them with logsumexp")
    return report


# The capstone of Part IV (chapter 24, exercise 24.3): a whole particle filter for a model the Part has
# not shown, a target on a line in clutter, checked against its exact posterior (a Gaussian mixture over
# every history of associations, pruned only below 1e-12 of the largest weight).
#: The model: x = (position m, velocity m/s), x_k = F x_{k-1} + w_k, w_k ~ N(0, Q); a reading of the
#: position with probability p_detect (noise variance r), Poisson(clutter_rate) clutter uniform on [0, length].
CLUTTER_TARGET = {"dt": 1.0, "q": 0.5, "r": 1.0, "p_detect": 0.7, "clutter_rate": 3.0, "length": 30.0,
                  "m0": (10.0, 0.5), "P0": (4.0, 1.0), "steps": 12}
CLUTTER_PF_MISTAKES = {
    "no_miss": "it leaves out the event 'the target was missed and every reading is clutter', (1 - P_D) lambda c; "
               "then one reading must be the target's, and a step whose readings are all clutter drags the cloud",
    "density_not_divided": "its clutter density is 1 instead of 1 / L: a clutter reading is uniform over [0, L], so "
                           "the missed event weighs (1 - P_D) lambda / L",
    "all_readings_target": "it treats every reading of a step as a measurement of the target (a product of "
                           "Gaussians); at most one is the target's, so the likelihood is a sum over which one",
    "no_process_noise": "its particles move without process noise (x_k = F x_{k-1}); the model adds w_k ~ N(0, Q), "
                        "and without it the resampled copies of a particle never differ again",
    "miss_without_rate": "its missed event weighs (1 - P_D) / L, without the clutter rate lambda: when the target is "
                         "missed the step's readings are clutter, and that event's weight carries their rate, "
                         "(1 - P_D) lambda / L",
    "detect_without_pd": "its detection terms are N(z_i; p, 1) without the detection probability: a reading is the "
                         "target's only if the target was detected, so each term is P_D N(z_i; p, 1)",
    "miss_without_one_minus_pd": "its missed event weighs lambda / L, without (1 - P_D): the target is missed with "
                                 "probability 1 - P_D, so that event weighs (1 - P_D) lambda / L",
    "detect_over_n": "it divides P_D by the number of readings of the step: the readings' order says nothing, but "
                     "the factor that divides is common to every event and cancels, so the term is P_D N(z_i; p, 1) "
                     "beside (1 - P_D) lambda / L",
    "no_first_prediction": "it weighs the initial cloud at the first step without moving it: x_0 is the state "
                           "before the first step, so every step, the first too, starts with x_k = F x_{k-1} + w_k",
    "prior_mean": "it returns the mean of the predicted cloud, before the weights: the estimate after a step's "
                  "readings is the weighted mean, sum_i w_i p_i",
}
#: Particles and seeds of the statistical check, and its tolerance: the root-mean-square distance of the
#: estimates from an exact posterior mean, in units of that posterior's standard deviation.
#: The distance is that of the mean over the seeds: a correct filter's is about 0.03 on these data, forgetting
#: lambda in the missed event gives about 0.3 and dropping P_D from the detections about 0.14.
CLUTTER_PF_N, CLUTTER_PF_SEEDS, CLUTTER_PF_TOLERANCE = 2000, 8, 0.07
#: The seeds of the checker's data sets (clutter_target_readings): chosen among the first sixteen for steps
#: where the target is missed in clutter, so that the weights of the missed and detected events matter.
CLUTTER_PF_DATA = (9, 10, 13, 14)
#: A mistake is named when the answer's mean over the seeds lies within MATCH (root mean square, in units of
#: the two filters' Monte Carlo standard error) of the checker's filter making it, and every other listed
#: mistake lies beyond MARGIN; otherwise the report says how far the answer is, without naming a mistake.
CLUTTER_PF_MATCH, CLUTTER_PF_MARGIN = 2.0, 2.5


def _clutter_target_model() -> tuple[np.ndarray, np.ndarray]:
    c = CLUTTER_TARGET
    F = np.array([[1.0, c["dt"]], [0.0, 1.0]])
    Q = c["q"] * np.array([[c["dt"] ** 3 / 3, c["dt"] ** 2 / 2], [c["dt"] ** 2 / 2, c["dt"]]])
    return F, Q


def clutter_target_readings(seed: int = 0) -> list[np.ndarray]:
    """The checker's data: ``steps`` steps of readings (positions, m) of one simulated target."""
    c = CLUTTER_TARGET
    F, Q = _clutter_target_model()
    rng = np.random.default_rng(seed)
    x = rng.normal(c["m0"], np.sqrt(c["P0"]))
    readings = []
    for _ in range(c["steps"]):
        x = F @ x + rng.multivariate_normal(np.zeros(2), Q)
        z = list(rng.uniform(0.0, c["length"], rng.poisson(c["clutter_rate"])))
        if rng.random() < c["p_detect"]:
            z.append(x[0] + np.sqrt(c["r"]) * rng.standard_normal())
        readings.append(rng.permutation(np.array(z, dtype=float)))
    return readings


def clutter_target_posterior(readings: list[np.ndarray], mistake: str | None = None,
                             prune: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """The exact posterior mean and standard deviation of the position at each step (``(K,)`` each): a
    Kalman filter per history of associations, weighted (miss: ``(1 - P_D) lambda / L``; reading ``i``:
    ``P_D N(z_i; H m, S)``, the factors common to every event of a step cancelled), components below
    ``prune`` times the largest weight dropped.  ``mistake`` (a key of :data:`CLUTTER_PF_MISTAKES`) gives
    the exact posterior of that mistaken model instead."""
    c = CLUTTER_TARGET
    F, Q = _clutter_target_model()
    if mistake == "no_process_noise":
        Q = np.zeros((2, 2))
    miss_weight = (1 - c["p_detect"]) * c["clutter_rate"] / (1.0 if mistake == "density_not_divided" else c["length"])
    detect_weight = c["p_detect"]
    log_w, m, P = np.zeros(1), np.array([c["m0"]], dtype=float), np.diag(c["P0"])[None].astype(float)
    means, sds = [], []
    for z in readings:
        m = m @ F.T
        P = F @ P @ F.T + Q
        S = P[:, 0, 0] + c["r"]  # (C,)
        gain = P[:, :, 0] / S[:, None]  # (C, 2)
        if mistake == "all_readings_target":
            for zi in z:
                S = P[:, 0, 0] + c["r"]
                gain = P[:, :, 0] / S[:, None]
                log_w = log_w - 0.5 * ((zi - m[:, 0]) ** 2 / S + np.log(2 * np.pi * S))
                m = m + gain * (zi - m[:, 0])[:, None]
                P = P - gain[:, :, None] * P[:, None, 0, :]
        else:
            new_w, new_m, new_P = [], [], []
            if mistake != "no_miss" or len(z) == 0:
                new_w.append(log_w + np.log(miss_weight))
                new_m.append(m)
                new_P.append(P)
            for zi in z:
                nu = zi - m[:, 0]
                new_w.append(log_w + np.log(detect_weight) - 0.5 * (nu**2 / S + np.log(2 * np.pi * S)))
                new_m.append(m + gain * nu[:, None])
                new_P.append(P - gain[:, :, None] * P[:, None, 0, :])
            log_w, m, P = np.concatenate(new_w), np.concatenate(new_m), np.concatenate(new_P)
        keep = log_w >= log_w.max() + np.log(prune)
        log_w, m, P = log_w[keep] - logsumexp(log_w[keep]), m[keep], P[keep]
        w = np.exp(log_w)
        mean = w @ m[:, 0]
        means.append(mean)
        sds.append(np.sqrt(w @ (P[:, 0, 0] + (m[:, 0] - mean) ** 2)))
    return np.array(means), np.array(sds)


def clutter_pf_reference(readings: list[np.ndarray], n: int, rng: np.random.Generator,
                         mistake: str | None = None) -> np.ndarray:
    """A bootstrap particle filter of :data:`CLUTTER_TARGET` (multinomial resampling at every step): the
    posterior mean position after each step's readings; ``mistake`` (a key of :data:`CLUTTER_PF_MISTAKES`)
    makes that mistake."""
    c = CLUTTER_TARGET
    F, Q = _clutter_target_model()
    length = 1.0 if mistake == "density_not_divided" else c["length"]
    miss = {"miss_without_rate": 1 - c["p_detect"], "miss_without_one_minus_pd": c["clutter_rate"]}.get(
        mistake, (1 - c["p_detect"]) * c["clutter_rate"]) / length
    x = rng.normal(c["m0"], np.sqrt(c["P0"]), size=(n, 2))
    out = []
    for k, z in enumerate(readings):
        if mistake != "no_first_prediction" or k > 0:
            x = x @ F.T
            if mistake != "no_process_noise":
                x = x + rng.multivariate_normal(np.zeros(2), Q, size=n)
        log_g = -0.5 * (z[None, :] - x[:, :1]) ** 2 / c["r"] - 0.5 * np.log(2 * np.pi * c["r"])  # (n, readings)
        detect = {"detect_without_pd": 1.0, "detect_over_n": c["p_detect"] / max(len(z), 1)}.get(mistake, c["p_detect"])
        if mistake == "all_readings_target":
            log_w = log_g.sum(axis=1)
        else:
            missed = [] if (mistake == "no_miss" and len(z)) else [np.full((n, 1), np.log(miss))]
            log_w = logsumexp(np.concatenate(missed + [np.log(detect) + log_g], axis=1), axis=1)
        w = np.exp(log_w - logsumexp(log_w))
        out.append(x[:, 0].mean() if mistake == "prior_mean" else w @ x[:, 0])
        x = x[rng.choice(n, size=n, p=w)]
    return np.array(out)


NOT_FINITE = ("some estimates are not finite: keep the weights in the log domain and normalise them with "
              "logsumexp, so that a step whose readings fit no particle well still works")


def check_clutter_pf(fn: Callable, seed: int = 0) -> CheckReport:
    """Check a student's whole particle filter ``fn(readings, n, rng) -> (K,)`` posterior mean positions for
    the target of :data:`CLUTTER_TARGET`: it draws from ``rng`` alone (same seed, same answer; another seed,
    another; NumPy's global state untouched), and on the data sets :data:`CLUTTER_PF_DATA`, over
    :data:`CLUTTER_PF_SEEDS` seeds with :data:`CLUTTER_PF_N` particles, its estimates lie within
    :data:`CLUTTER_PF_TOLERANCE` posterior standard deviations (root mean square) of the exact posterior
    mean. An answer that does not is compared with the checker's own filter making each mistake of
    :data:`CLUTTER_PF_MISTAKES` (:func:`clutter_pf_reference`, other seeds), and the report names the one
    it fits."""
    from pfcourse.book.exercises.part1 import _seed_problem

    report = CheckReport("particle filter of a target in clutter")
    datasets = [clutter_target_readings(d) for d in CLUTTER_PF_DATA]
    K = len(datasets[0])

    def call(s, readings=datasets[0]):
        return fn([z.copy() for z in readings], CLUTTER_PF_N, np.random.default_rng([seed, s]))

    state = np.random.get_state()
    answer = _answer(report, lambda: call(0), "fn(readings, n, rng)", "return the posterior mean position at "
                     "each step, shape (K,)")
    if answer is None:
        np.random.set_state(state)
        return report
    answer = np.asarray(answer, dtype=float)
    if answer.shape != (K,):
        np.random.set_state(state)
        report.problems.append(f"the answer has shape {answer.shape}, not ({K},): return one posterior mean "
                               "position per step (after that step's readings)")
        return report
    if not np.isfinite(answer).all():
        np.random.set_state(state)
        report.problems.append(NOT_FINITE)
        return report
    again, other = np.asarray(call(0), dtype=float), np.asarray(call(1), dtype=float)
    problem = _seed_problem(state, (answer,), (again,), (other,), "estimates", "rng.normal(...), rng.random(...)")
    if problem:
        report.problems.append(problem)
        return report
    estimates = np.array([np.concatenate([np.asarray(call(s, readings), dtype=float) for readings in datasets])
                          for s in range(CLUTTER_PF_SEEDS)])
    np.random.set_state(state)
    if not np.isfinite(estimates).all():
        report.problems.append(NOT_FINITE)
        return report
    exact = [clutter_target_posterior(readings) for readings in datasets]
    mean, sd = np.concatenate([m for m, _ in exact]), np.concatenate([v for _, v in exact])
    student = estimates.mean(axis=0)
    distance = float(rmse((student - mean) / sd))
    if distance <= CLUTTER_PF_TOLERANCE:
        return report
    # A mistaken filter is compared with the same mistake made by the checker's own filter, on other seeds:
    # the exact posterior of a mistaken model is no help, since a mistaken filter is itself far from it.
    scores = {}
    for mistake in CLUTTER_PF_MISTAKES:
        theirs = np.array([np.concatenate([clutter_pf_reference(readings, CLUTTER_PF_N,
                                                                np.random.default_rng([seed, 100, s]), mistake)
                                           for readings in datasets]) for s in range(CLUTTER_PF_SEEDS)])
        spread = np.sqrt((estimates.var(axis=0, ddof=1) + theirs.var(axis=0, ddof=1)) / CLUTTER_PF_SEEDS)
        scores[mistake] = float(rmse((student - theirs.mean(axis=0)) / (spread + 1e-3 * sd)))
    best, *others = sorted(scores, key=scores.get)
    np.random.set_state(state)
    if scores[best] <= CLUTTER_PF_MATCH and all(scores[m] > CLUTTER_PF_MARGIN for m in others):
        report.problems.append(f"your function computes a known mistake: {CLUTTER_PF_MISTAKES[best]}")
        return report
    report.problems.append(f"the estimates, averaged over {CLUTTER_PF_SEEDS} seeds, are {distance:.2f} posterior "
                           f"standard deviations (root mean square over {len(datasets)} data sets and {K} steps) "
                           f"from the exact posterior mean, more than the {CLUTTER_PF_TOLERANCE} a particle filter "
                           f"with {CLUTTER_PF_N} particles stays within: check the motion, the weight of each "
                           "event (missed: (1 - P_D) lambda / L; reading i: P_D N(z_i; p, 1)) and the resampling")
    return report
