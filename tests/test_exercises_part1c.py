"""The checker of the auxiliary chapter's coding exercise (9.3): the reference passes, and each typical
mistake gets its own sentence; the generator it is given is checked (issue 39)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp
from scipy.stats import norm

from pfcourse.book.exercises import APF_STEP_MISTAKES, APF_STEP_MODEL, check_apf_step

A, C, Q, R = (APF_STEP_MODEL[k] for k in ("a", "c", "q", "r"))


def _systematic(w, rng):
    n = len(w)
    cum = np.cumsum(w)
    cum[-1] = 1.0
    return np.searchsorted(cum, (np.arange(n) + rng.random()) / n)


def apf_step(x, log_w, z, rng, mistake=None):
    """The reference step, or the step with one typical mistake."""
    c = 1.0 if mistake == "no_c" else C
    s = R if mistake == "predictive_r" else c**2 * Q + R
    log_p = norm.logpdf(z, c * A * x, np.sqrt(s))
    log_lam = log_p if mistake == "no_weights" else log_w + log_p
    log_evidence = logsumexp(log_lam) - (np.log(len(x)) if mistake == "no_weights" else 0.0)
    lam = np.exp(log_lam - logsumexp(log_lam))
    gain = c * Q / (c**2 * Q + R)

    def move(parents, draw):
        if mistake == "transition_move":
            return A * parents + np.sqrt(Q) * draw(len(parents))
        return A * parents + gain * (z - c * A * parents) + np.sqrt(Q - gain * c * Q) * draw(len(parents))

    draw = np.random.standard_normal if mistake == "global_rng" else rng.standard_normal
    if mistake == "move_then_resample":
        return move(x, draw)[_systematic(lam, rng)], log_evidence
    if mistake == "fixed_seed":
        rng = np.random.default_rng(0)
        draw = rng.standard_normal
    return move(x[_systematic(lam, rng)], draw), log_evidence


def test_the_reference_passes():
    report = check_apf_step(apf_step)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", sorted(APF_STEP_MISTAKES))
def test_each_typical_mistake_gets_its_own_sentence(mistake):
    report = check_apf_step(lambda x, w, z, rng: apf_step(x, w, z, rng, mistake))
    assert not report.ok
    assert APF_STEP_MISTAKES[mistake] in str(report), str(report)
    others = [m for m in APF_STEP_MISTAKES if m != mistake]
    assert not any(APF_STEP_MISTAKES[m] in str(report) for m in others)


def test_the_generator_is_checked():
    state = np.random.get_state()
    report = check_apf_step(lambda x, w, z, rng: apf_step(x, w, z, rng, "global_rng"))
    assert "global np.random" in str(report)
    after = np.random.get_state()
    assert np.array_equal(state[1], after[1]) and state[2:] == after[2:]  # the checker restored NumPy's state
    assert "rng it is given is not used" in str(check_apf_step(lambda x, w, z, rng: apf_step(x, w, z, rng,
                                                                                              "fixed_seed")))


def test_an_unknown_error_is_described_and_bad_answers_are_named():
    wrong_evidence = check_apf_step(lambda x, w, z, rng: (apf_step(x, w, z, rng)[0], 0.0))
    assert "log-likelihood increment is 0.000000" in str(wrong_evidence)
    shifted = check_apf_step(lambda x, w, z, rng: (apf_step(x, w, z, rng)[0] + 0.3, apf_step(x, w, z, rng)[1]))
    assert "not the filtering density's" in str(shifted)
    assert "returned None" in str(check_apf_step(lambda x, w, z, rng: None))
    assert "not a pair" in str(check_apf_step(lambda x, w, z, rng: x))
    assert "shape" in str(check_apf_step(lambda x, w, z, rng: (x[:3], 0.0)))
    assert "raised ZeroDivisionError" in str(check_apf_step(lambda x, w, z, rng: 1 / 0))


# --- exercise 8.2: FastSLAM 2.0's robot move (rao_blackwell) ---------------------------------------

from pfcourse.book.exercises import FASTSLAM2_MISTAKES, check_fastslam2_move  # noqa: E402


def fastslam2_move(r_pred, m_pred, P_pred, z, A, C, Qr, R, rng, mistake=None):
    """The reference move, or the move with one typical mistake."""
    S_map = C @ P_pred @ C.T + R
    S = A @ Qr @ A.T + (R if mistake == "no_map_in_s" else S_map)
    nu = z - r_pred @ A.T - m_pred @ C.T
    G = Qr @ A.T @ np.linalg.inv(S)
    cov = Qr if mistake in ("no_shrink", "transition_move") else Qr - G @ S @ G.T
    mean = r_pred if mistake == "transition_move" else r_pred + nu @ G.T
    draw = np.random.standard_normal if mistake == "global_rng" else rng.standard_normal
    robots = mean + draw(r_pred.shape) @ np.linalg.cholesky(cov).T
    S_w = S_map if mistake == "fastslam1_weight" else S
    if mistake == "new_robot_weight":
        nu = z - robots @ A.T - m_pred @ C.T
        S_w = S_map
    log_w = -0.5 * np.einsum("ij,ij->i", nu @ np.linalg.inv(S_w), nu) - 0.5 * np.linalg.slogdet(2 * np.pi * S_w)[1]
    return robots, log_w


def test_the_fastslam2_reference_passes():
    report = check_fastslam2_move(fastslam2_move)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", sorted(FASTSLAM2_MISTAKES))
def test_each_fastslam2_mistake_gets_its_own_sentence(mistake):
    report = check_fastslam2_move(lambda *args: fastslam2_move(*args, mistake=mistake))
    assert not report.ok
    assert FASTSLAM2_MISTAKES[mistake] in str(report), str(report)
    assert not any(FASTSLAM2_MISTAKES[m] in str(report) for m in FASTSLAM2_MISTAKES if m != mistake)


def test_the_fastslam2_generator_is_checked_and_bad_answers_named():
    state = np.random.get_state()
    assert "global np.random" in str(check_fastslam2_move(lambda *a: fastslam2_move(*a, mistake="global_rng")))
    after = np.random.get_state()
    assert np.array_equal(state[1], after[1]) and state[2:] == after[2:]
    fixed = check_fastslam2_move(lambda *a: fastslam2_move(*a[:-1], np.random.default_rng(0)))
    assert "rng it is given is not used" in str(fixed)
    assert "returned None" in str(check_fastslam2_move(lambda *a: None))
    assert "not a pair" in str(check_fastslam2_move(lambda *a: a[0]))
    assert "shape" in str(check_fastslam2_move(lambda *a: (a[0][:3], a[0][:, 0])))
    shifted = check_fastslam2_move(lambda *a: (fastslam2_move(*a)[0] + 0.05, fastslam2_move(*a)[1]))
    assert "do not follow" in str(shifted)
    wrong_weight = check_fastslam2_move(lambda *a: (fastslam2_move(*a)[0], fastslam2_move(*a)[1] ** 2))
    assert "log-weights differ" in str(wrong_weight)


def test_the_weight_without_motion_noise_is_named_for_what_it_computes():
    """That mistake takes C P^- C^T + R at the parent's prediction: its sentence says so, and does not
    call it FastSLAM 1.0's weight (that one is taken at the new robot, the mistake new_robot_weight)."""
    message = FASTSLAM2_MISTAKES["fastslam1_weight"]
    assert "parent's prediction" in message and "A Q_r A^T" in message
    assert "FastSLAM 1.0" not in message
    assert "new robot" in FASTSLAM2_MISTAKES["new_robot_weight"]
