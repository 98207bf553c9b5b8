"""The checker of the map-bias exercise (terrain_marginalised): the reference answer passes, each typical
mistake is named in its own sentence, and bad returns are reported."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises import check_bias_update


def _student(m, P, ground, reading, rf, mistake=None):
    """A student's (altitude, bias) update written independently of the checker, right unless a mistake is named."""
    H = np.array([1.0, 1.0])
    m_new, P_new, log_lik = np.empty_like(m), np.empty_like(P), np.empty(len(m))
    for i in range(len(m)):
        cov = np.array([[P[i, 0], P[i, 1]], [P[i, 1], P[i, 2]]])
        h = np.array([1.0, 0.0]) if mistake == "bias" else H
        nu = reading - (h @ m[i] + (ground[i] if mistake == "ground" else -ground[i]))
        if mistake == "sign":
            nu = -nu
        S = H @ cov @ H + rf if mistake != "cross" else cov[0, 0] + cov[1, 1] + rf
        K = cov @ H / S
        if mistake == "one_gain":
            K = np.array([K[0], K[0]])
        m_new[i] = m[i] + K * nu
        full = cov if mistake == "no_cov" else cov - np.outer(K, K) * S
        P_new[i] = [full[0, 0], full[1, 1], full[0, 1]] if mistake == "order" else [full[0, 0], full[0, 1], full[1, 1]]
        s_lik = rf if mistake == "r" else S
        log_lik[i] = -0.5 * nu**2 / s_lik - 0.5 * np.log(2 * np.pi * s_lik)
    return m_new, P_new, log_lik


def test_the_reference_bias_update_passes():
    report = check_bias_update(_student)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says", [
    ("bias", "leaves out the map bias"),
    ("cross", "leaves out the covariance of altitude and bias"),
    ("r", "uses Rf where it needs S"),
    ("no_cov", "covariance is not updated"),
    ("one_gain", "both states get the altitude's gain"),
    ("sign", "the innovation has the wrong sign"),
    ("ground", "the ground height is added"),
    ("order", "covariance columns are in the wrong order"),
])
def test_bias_update_mistakes_are_named(mistake, says):
    report = check_bias_update(lambda *a, **kw: _student(*a, **kw, mistake=mistake))
    assert not report.ok and says in str(report), str(report)


def test_bias_update_bad_returns_and_unknown_errors_are_reported():
    assert "returned None" in str(check_bias_update(lambda **kw: None))
    assert "raised" in str(check_bias_update(lambda **kw: 1 / 0))
    assert "three arrays" in str(check_bias_update(lambda **kw: (1, 2)))

    def wrong_log(m, P, ground, reading, rf):
        m_new, P_new, log_lik = _student(m, P, ground, reading, rf)
        return m_new, P_new, log_lik + 1.0  # a constant off: no known mistake

    assert "log-weight increments differ" in str(check_bias_update(wrong_log))
