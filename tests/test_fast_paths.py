"""The engine's fast paths give the same floats as the code they replace.

The stored notebooks are checked by strict nbval without re-execution, so a speed-up of
the shared engine must not change a single draw or decision: each fast path here is
compared, bit for bit, with the straightforward computation it replaces.
"""

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.diagnostics import _logsumexp, normalize_log_weights
from pfcourse.errors import DegenerateWeightsError
from pfcourse.scenarios.robot.scenario import Q_TRUE, R_TRUE, RobotModel, simulate_robot


def log_weight_vectors(count, seed=0):
    """Random log-weight vectors with the awkward cases: -inf entries, ties at the maximum, all equal."""
    rng = np.random.default_rng(seed)
    for t in range(count):
        n = int(rng.integers(1, 2000)) if t % 10 else int(rng.integers(1, 5))
        a = rng.standard_normal(n) * 10.0 ** rng.integers(-2, 4) + rng.uniform(-1e3, 1e3)
        if t % 4 == 1:
            a[rng.integers(0, n, size=max(1, n // 3))] = -np.inf
        elif t % 4 == 2:
            a[rng.integers(0, n, size=max(1, n // 5))] = a.max()
        elif t % 4 == 3:
            a = np.round(a)
        if t % 50 == 0:
            a[:] = a[0]
        yield a


def test_logsumexp_is_scipys_float_exactly():
    for a in log_weight_vectors(3000):
        assert _logsumexp(a) == float(logsumexp(a))


def test_logsumexp_of_all_minus_inf_is_minus_inf_and_normalisation_raises():
    a = np.full(5, -np.inf)
    assert _logsumexp(a) == -np.inf == float(logsumexp(a))
    with pytest.raises(DegenerateWeightsError):
        normalize_log_weights(a)


def test_normalised_weights_match_the_scipy_formula():
    for a in log_weight_vectors(300, seed=1):
        if not np.isfinite(a.max()):
            continue
        w, total = normalize_log_weights(a)
        expected_total = float(logsumexp(a))
        assert total == expected_total
        assert np.array_equal(w, np.exp(a - expected_total))


@pytest.mark.parametrize("q_scale", [0.3, 1.0, 2.0, 7.5])
def test_diagonal_noise_path_draws_the_same_particles_as_einsum(q_scale):
    sim = simulate_robot(rng=3, n_steps=20)
    fast = RobotModel(sim.landmarks, sim.odometry, q_scale * Q_TRUE, 2 * R_TRUE)
    slow = RobotModel(sim.landmarks, sim.odometry, q_scale * Q_TRUE, 2 * R_TRUE)
    assert fast._q_diagonal is not None
    slow._q_diagonal = None  # force the general (einsum) path
    x = fast.sample_initial(5000, np.random.default_rng(0))
    for k in range(1, 20):
        a = fast.sample_transition(x, k, np.random.default_rng(k))
        b = slow.sample_transition(x, k, np.random.default_rng(k))
        assert np.array_equal(a, b)
        x = a


def test_full_noise_factor_keeps_the_general_path():
    q = Q_TRUE.copy()
    q[0, 1] = q[1, 0] = 0.5 * Q_TRUE[0, 0]
    sim = simulate_robot(rng=3, n_steps=5)
    assert RobotModel(sim.landmarks, sim.odometry, q, R_TRUE)._q_diagonal is None
