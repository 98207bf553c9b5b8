"""The weighted circular mean is one sum, ``r = sum_i w_i exp(i a_i)`` (:func:`pfcourse.angles.resultant`).

``circular_mean(angles, weights)`` takes its direction; the global-localization cure
(``scenarios/maprobot/global_mcl.py``), the smoother's and the predictive moments
(``diagnostics.weighted_mean``) all call it. The cure used to write ``np.angle(W @ np.exp(1j * x[:, 2]))``
inline, and its stored studies (map_global, intel) were made with that expression, so the function must
give the same float, bit for bit, on every cloud where the mean is defined.

The one compiled exception is the engine's own mean (:func:`pfcourse.kernels.weighted_moments`, every
``FilterResult.mean``): sines and cosines of the deviations from the first particle, summed in one pass.
Replacing it by ``circular_mean`` would move every stored heading in its last bits, so it stays, named in
``tests/test_layout.py``'s exceptions, and is held here to ``circular_mean`` within the rounding bound of
the two sums: on the robot filter's clouds they differ at most steps, by at most 1.3e-15 rad (three
global runs of 200 steps, N = 2000; 1.4e-16 rad when tracking).
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from pfcourse.angles import circular_mean, resultant, resultant_direction, wrap_angle
from pfcourse.kernels import weighted_moments
from pfcourse.scenarios.maprobot import global_mcl

EPS = np.finfo(float).eps


def _clouds(n_clouds: int = 400):
    """Weighted clouds ``(x (N, 3), W)`` as the cure has them: tight, spread, across the +/-pi cut, uniform
    headings, one dominant particle, many zero weights; ``x[:, 2]`` is a strided column (not contiguous)."""
    rng = np.random.default_rng(44)
    for c in range(n_clouds):
        n = int(rng.choice([1, 2, 3, 7, 9, 31, 300, 2000, 22000]))
        x = rng.normal(size=(n, 3)) * [5.0, 5.0, rng.choice([0.01, 0.5, 3.0])]
        x[:, 2] = wrap_angle(x[:, 2] + rng.choice([0.0, np.pi, -np.pi / 2]))
        if c % 5 == 0:
            x[:, 2] = rng.uniform(-np.pi, np.pi, n)
        log_w = rng.normal(size=n) * rng.choice([0.1, 3.0, 30.0])
        if c % 7 == 0:
            log_w[rng.random(n) < 0.5] = -np.inf
            log_w[0] = 0.0
        w = np.exp(log_w - log_w.max())
        yield x, w / w.sum()


def test_circular_mean_is_the_cures_old_inline_expression_bit_for_bit():
    compared = 0
    for x, w in _clouds():
        old = np.angle(w @ np.exp(1j * x[:, 2]))  # global_mcl.py before issue 44
        new = circular_mean(x[:, 2], w)
        if abs(w @ np.exp(1j * x[:, 2])) > 1e-12:  # where the mean is defined (else NaN, tested below)
            assert new.tobytes() == np.float64(old).tobytes(), (len(w), old, float(new))
            compared += 1
    assert compared > 350


def test_the_cure_calls_circular_mean_for_its_heading():
    source = inspect.getsource(global_mcl.global_mcl)
    assert "circular_mean(x[:, 2], W)" in source and "exp(1j" not in source


def test_the_docstring_equation_and_the_undefined_mean():
    """``arg(sum w_i e^{i a_i}) = atan2(sum w_i sin a_i, sum w_i cos a_i)``, to rounding (the sums' order
    differs); NaN when the resultant vanishes (evenly spread angles)."""
    for x, w in _clouds(100):
        a = x[:, 2]
        direct = np.arctan2(np.sum(w * np.sin(a)), np.sum(w * np.cos(a)))
        r = abs(resultant(a, w))
        # each sum of n terms errs by at most n eps sum |w_i| = n eps (Higham's bound), turning the direction
        # by at most that over |r|
        bound = 2 * len(w) * EPS
        assert abs(wrap_angle(circular_mean(a, w) - direct)) <= bound / r
        assert abs(resultant(a, w) - complex(np.sum(w * np.cos(a)), np.sum(w * np.sin(a)))) <= bound
    spread = np.arange(8) * np.pi / 4
    assert np.isnan(circular_mean(spread, np.full(8, 1 / 8)))
    assert circular_mean(np.array([3.1, -3.1]), np.array([0.5, 0.5])) == pytest.approx(np.pi)


def test_each_slice_of_a_stack_is_the_slices_own_mean():
    rng = np.random.default_rng(1)
    a = rng.uniform(-np.pi, np.pi, (500, 4))
    w = rng.random(500)
    w /= w.sum()
    stacked = circular_mean(a, w, axis=0)
    assert stacked.shape == (4,)
    assert all(stacked[j].tobytes() == circular_mean(a[:, j], w).tobytes() for j in range(4))
    along_1 = circular_mean(a.T, w, axis=1)
    assert along_1.tobytes() == stacked.tobytes()


def test_resultant_direction_is_the_same_equation_summed_otherwise():
    """The sigma points' and grid filter's mean (signed weights, no check) is the direction of the same
    resultant, summed as two real dot products: equal to rounding, not bit for bit (module docstring of
    tests/test_circular_mean_once.py: its stored users would change in the last bits)."""
    rng = np.random.default_rng(2)
    for n in (7, 9, 55, 3000):
        a = rng.uniform(-np.pi, np.pi, n)
        w = rng.normal(size=n)
        r = resultant(a, w)
        # a sum of n terms errs by at most n eps sum |w_i| (Higham's bound), turning the direction by that / |r|
        assert abs(wrap_angle(resultant_direction(a, w) - np.angle(r))) <= 2 * n * EPS * np.sum(np.abs(w)) / abs(r)


def _moments_bound(a, w) -> float:
    """Rounding bound of the compiled mean against circular_mean: each of the two ways sums ``n`` terms, erring
    by at most ``n eps`` (Higham), which turns the direction by that over ``|r|``; adding back the origin and
    wrapping costs at most ``2 pi eps``."""
    return 2 * len(w) * EPS / abs(resultant(a, w)) + 2 * np.pi * EPS


def test_the_engine_s_compiled_mean_is_circular_mean_to_rounding():
    """kernels.weighted_moments (the named exception) against circular_mean: on the cure's clouds and on the
    robot filter's, within the rounding bound, and not bit for bit (else the exception should go)."""
    from pfcourse import ParticleFilter
    from pfcourse.collectors import Clouds
    from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot

    is_angle = np.array([False, False, True])
    differ = 0
    for x, w in _clouds(200):
        if abs(resultant(x[:, 2], w)) > 1e-12:
            mean = weighted_moments(np.ascontiguousarray(x), w, is_angle)[0][2]
            gap = abs(wrap_angle(mean - circular_mean(x[:, 2], w)))
            assert gap <= _moments_bound(x[:, 2], w)
            differ += gap > 0
    sim = simulate_robot(None, 2, n_steps=40)
    for initial, n in (("uniform", 2000), ("tracking", 300)):
        res = ParticleFilter(RobotModel.for_simulation(sim, initial=initial), n).run(sim.measurements, 2,
                                                                                     collect=[Clouds()])
        for k, (x, w) in enumerate(zip(res.particles, res.weights)):
            gap = abs(wrap_angle(res.mean[k, 2] - circular_mean(x[:, 2], w)))
            assert gap <= _moments_bound(x[:, 2], w), (initial, k, gap)
            differ += gap > 0
    assert differ > 50
