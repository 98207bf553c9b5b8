"""The stratified-resampler checker of Part I's resampling chapter (exercise 6.3: n new particles drawn
from N weights, n and N different; issue 39, item 6).

The reference passes; each typical mistake, the systematic scheme (one uniform shared by all) and the
multinomial one (uniforms anywhere) among them, is named in its own sentence, and a resampler that draws
from anything but the generator it is given is caught.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises.part1 import (STRATIFIED_DRAWS, STRATIFIED_WEIGHTS, _offspring_variances,
                                     check_stratified_resampler)


def invert(w, u, shift=0, cap=True):
    idx = np.searchsorted(np.cumsum(w), u, side="right") + shift
    return np.minimum(idx, len(w) - 1) if cap else idx


def stratified(w, n, rng):  # the chapter's solution: n strata of width 1 / n, one uniform in each
    return invert(w, (np.arange(n) + rng.random(n)) / n)


MISTAKES = {
    # one uniform for all strata: systematic resampling, unbiased, less variable than stratified here
    "systematic": (lambda w, n, rng: invert(w, (np.arange(n) + rng.random()) / n),
                   "the copies vary like systematic resampling's"),
    # independent uniforms anywhere in [0, 1): multinomial resampling
    "multinomial": (lambda w, n, rng: invert(w, np.sort(rng.random(n))),
                    "the copies vary like multinomial resampling's"),
    # NumPy's global generator instead of the one given
    "global state": (lambda w, n, rng: invert(w, (np.arange(n) + np.random.random(n)) / n),
                     "it draws from NumPy's global generator"),
    # a fresh unseeded generator inside the function
    "own generator": (lambda w, n, rng: stratified(w, n, np.random.default_rng()),
                      "two calls with generators of the same seed gave different answers"),
    # the midpoint of each stratum: no randomness at all
    "midpoints": (lambda w, n, rng: invert(w, (np.arange(n) + 0.5) / n),
                  "the result never changes with the seed: it is the midpoints' answer"),
    # a generator seeded inside the function: the same answer for every seed
    "seeded inside": (lambda w, n, rng: stratified(w, n, np.random.default_rng(0)),
                      "the result never changes with the seed: the rng it is given is not used"),
    # N strata, one per weight, instead of the n asked for
    "N strata": (lambda w, n, rng: stratified(w, len(w), rng), "returned 8 indices, one per weight"),
    # the index one too far, not capped
    "off by one": (lambda w, n, rng: invert(w, (np.arange(n) + rng.random(n)) / n, shift=1, cap=False),
                   "draw 0: an index is out of range"),
    # the index one too far, capped: the weightless particle after a heavy one gets its copies
    "shifted": (lambda w, n, rng: invert(w, (np.arange(n) + rng.random(n)) / n, shift=1),
                "a particle of weight 0 was chosen"),
    # strata of width 1 / (n + 1): the last part of the bar is never reached
    "narrow strata": (lambda w, n, rng: invert(w, (np.arange(n) + rng.random(n)) / (n + 1)),
                      "biased: particle"),
    # n uniforms in strata of width 1 / N: the bar is overrun, the cap piles copies on the last particle
    "strata of width 1/N": (lambda w, n, rng: invert(w, (np.arange(n) + rng.random(n)) / len(w)),
                            "biased: particle 7"),
    # float indices
    "float indices": (lambda w, n, rng: stratified(w, n, rng).astype(float), "returned dtype float64"),
}


def test_the_reference_passes_and_leaves_the_global_state_alone():
    np.random.seed(5)
    before = np.random.get_state()[1].copy()
    report = check_stratified_resampler(stratified)
    assert report.ok, str(report)
    assert np.array_equal(np.random.get_state()[1], before)


def test_the_package_stratified_resampler_passes():
    from pfcourse.resampling import stratified as package_stratified

    assert check_stratified_resampler(lambda w, n, rng: package_stratified(w, rng, n=n)).ok


@pytest.mark.parametrize("mistake", MISTAKES, ids=str)
def test_each_typical_mistake_gets_its_own_sentence(mistake):
    fn, says = MISTAKES[mistake]
    report = check_stratified_resampler(fn)
    assert len(report.problems) == 1, str(report)
    assert report.problems[0].startswith(says), str(report)


def test_the_global_generator_mistake_leaves_the_global_state_as_it_found_it():
    np.random.seed(11)
    before = np.random.get_state()[1].copy()
    check_stratified_resampler(MISTAKES["global state"][0])
    assert np.array_equal(np.random.get_state()[1], before)


def test_the_messages_are_distinct():
    assert len({says for _, says in MISTAKES.values()}) == len(MISTAKES)


def test_the_weights_tell_the_schemes_apart():
    """Particle 1 sits astride two of the n strata: systematic gives it one copy always, stratified 0, 1 or 2."""
    n = STRATIFIED_DRAWS
    exact = _offspring_variances(STRATIFIED_WEIGHTS, n)
    assert STRATIFIED_WEIGHTS.sum() == pytest.approx(1.0)
    assert n != STRATIFIED_WEIGHTS.size
    assert n * STRATIFIED_WEIGHTS[1] == pytest.approx(1.0)
    assert exact["systematic"][1] == pytest.approx(0.0)
    assert exact["stratified"][1] == pytest.approx(0.5)
    assert exact["multinomial"][1] == pytest.approx(11 / 12)


def test_the_exact_stratified_variances_are_those_measured():
    rng = np.random.default_rng(3)
    n = STRATIFIED_DRAWS
    counts = np.array([np.bincount(stratified(STRATIFIED_WEIGHTS, n, rng), minlength=8) for _ in range(20_000)])
    measured = counts.var(axis=0, ddof=1)
    # a count's variance, over 20000 draws, has a standard error below about 0.01 here
    assert np.allclose(measured, _offspring_variances(STRATIFIED_WEIGHTS, n)["stratified"], atol=0.04)


def test_nothing_returned_and_counts_returned_are_named():
    assert check_stratified_resampler(lambda w, n, rng: None).problems == [
        "the function returned None: write the resampler and return the n ancestor indices"]
    report = check_stratified_resampler(lambda w, n, rng: np.zeros((n, 2), dtype=int))
    assert report.problems[0].startswith("returned shape (12, 2)")


# The constant-velocity Kalman checker of the Kalman chapter (exercise 2.3): a model the chapter does not
# show, checked against the exact filter; a student's filter, right unless a mistake is named.
def student_cv(z, dt, q, r, m0, P0, *, nan_kept=False, swap_q=False, wrong_shape=False):
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    if swap_q:  # the corners of Q swapped: dt^3 / 3 on the velocity
        Q = q * np.array([[dt, dt**2 / 2], [dt**2 / 2, dt**3 / 3]])
    H = np.array([[1.0, 0.0]])
    m, P, log_lik, means, covs = m0, P0, 0.0, [], []
    for k, zk in enumerate(z):
        if k > 0:
            m, P = F @ m, F @ P @ F.T + Q
        if nan_kept or not np.isnan(zk):
            nu = np.array([zk]) - H @ m
            S = H @ P @ H.T + r
            K = P @ H.T @ np.linalg.inv(S)
            m, P = m + K @ nu, P - K @ S @ K.T
            log_lik += -0.5 * (nu @ np.linalg.solve(S, nu) + np.log(np.linalg.det(2 * np.pi * S)))
        means.append(m)
        covs.append(P)
    means = np.array(means)
    return (means[:, 0] if wrong_shape else means), np.array(covs), float(log_lik)


def test_the_reference_cv_filter_passes_and_is_the_package_filter():
    from pfcourse.book.exercises.part1 import CV_CASE, check_cv_kalman, cv_kalman
    from pfcourse.kalman import kalman_filter
    from pfcourse.linear_gaussian import LinearGaussianModel

    assert check_cv_kalman(student_cv).ok, str(check_cv_kalman(student_cv))
    c = CV_CASE
    dt, q = c["dt"], c["q"]
    lg = LinearGaussianModel(F=[[1.0, dt], [0.0, 1.0]], H=[[1.0, 0.0]], m0=c["m0"], P0=c["P0"],
                             Q=q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), R=[[c["r"]]])
    ref = kalman_filter(lg, c["z"][:, None])
    means, covs, log_lik = cv_kalman(**c)
    np.testing.assert_allclose(means, ref.mean, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(covs, ref.cov, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(log_lik, ref.log_likelihood, rtol=1e-12)


def test_every_named_cv_mistake_is_recognised_from_its_own_numbers():
    from pfcourse.book.exercises.part1 import CV_MISTAKES, check_cv_kalman, cv_kalman

    assert len(set(CV_MISTAKES.values())) == len(CV_MISTAKES) >= 4
    for mistake, why in CV_MISTAKES.items():
        report = check_cv_kalman(lambda z, dt, q, r, m0, P0, m=mistake: cv_kalman(z, dt, q, r, m0, P0, m))
        assert report.problems == [f"your filter computes a known mistake: {why}"], (mistake, str(report))


@pytest.mark.parametrize("mistake, says", [
    ({"nan_kept": True}, "the mean or the covariance is NaN at step 0"),
    ({"swap_q": True}, "at step 1 your mean is"),
    ({"wrong_shape": True}, "returned shapes (8,), (8, 2, 2) and ()"),
])
def test_a_students_other_cv_mistakes_get_their_own_sentence(mistake, says):
    from pfcourse.book.exercises.part1 import check_cv_kalman

    report = check_cv_kalman(lambda *a: student_cv(*a, **mistake))
    assert len(report.problems) == 1 and report.problems[0].startswith(says), str(report)


def test_a_cv_answer_of_the_wrong_form_is_named():
    from pfcourse.book.exercises.part1 import check_cv_kalman

    assert check_cv_kalman(lambda *a: None).problems == [
        "the function returned None: write the filter and return (means, covariances, log_likelihood)"]
    assert "raised ZeroDivisionError" in str(check_cv_kalman(lambda *a: 1 / 0))
    assert check_cv_kalman(lambda *a: student_cv(*a)[:2]).problems[0].startswith(
        "the answer is not (means, covariances, log_likelihood)")
    right_filter = check_cv_kalman(lambda *a: (*student_cv(*a)[:2], 0.0))
    assert right_filter.problems[0].startswith("the means and covariances are right, the log-likelihood is not")


# Typical mistakes of the constant-velocity filter with the noise variances, written as a student would.
def student_cv_noise(z, dt, q, r, m0, P0, *, piecewise_q=False, r_as_sd=False, q_as_sd=False):
    F = np.array([[1.0, dt], [0.0, 1.0]])
    if piecewise_q:  # filterpy's Q_discrete_white_noise(dim=2, dt=dt, var=q)
        Q = q * np.array([[dt**4 / 4, dt**3 / 2], [dt**3 / 2, dt**2]])
    else:
        Q = (q**2 if q_as_sd else q) * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    m, P, log_lik, means, covs = m0, P0, 0.0, [], []
    for k, zk in enumerate(z):
        if k > 0:
            m, P = F @ m, F @ P @ F.T + Q
        if not np.isnan(zk):
            S = P[0, 0] + (r**2 if r_as_sd else r)
            K = P[:, 0] / S
            nu = zk - m[0]
            m, P = m + K * nu, P - np.outer(K, K) * S
            log_lik -= 0.5 * (nu**2 / S + np.log(2 * np.pi * S))
        means.append(m)
        covs.append(P)
    return np.array(means), np.array(covs), log_lik


@pytest.mark.parametrize("mistake, says", [
    ({"piecewise_q": True}, "piecewise-constant acceleration"),
    ({"r_as_sd": True}, "r is already the variance"),
    ({"q_as_sd": True}, "q is already a variance"),
])
def test_a_wrong_process_or_reading_noise_is_named(mistake, says):
    from pfcourse.book.exercises.part1 import check_cv_kalman

    assert check_cv_kalman(student_cv_noise).ok
    report = check_cv_kalman(lambda *a: student_cv_noise(*a, **mistake))
    assert len(report.problems) == 1 and says in report.problems[0], str(report)


def test_the_block_of_the_inverse_of_r_is_named():
    from pfcourse.book.exercises.part1 import LIKELIHOOD_R, check_log_likelihood

    def block_of_inverse(x, z, H, R):
        seen = ~np.isnan(z)
        if not seen.any():
            return np.zeros(len(x))
        d = z[seen] - x @ H[seen].T
        quad = np.einsum("ij,jk,ik->i", d, np.linalg.inv(R)[np.ix_(seen, seen)], d)
        R_k = R[np.ix_(seen, seen)]
        return -0.5 * (quad + seen.sum() * np.log(2 * np.pi) + np.linalg.slogdet(R_k)[1])

    # the two differ only when measured and unmeasured coordinates are correlated
    assert LIKELIHOOD_R[1, 2] != 0
    report = check_log_likelihood(block_of_inverse)
    assert len(report.problems) == 1 and "inv(R)[seen, seen]" in report.problems[0], str(report)
