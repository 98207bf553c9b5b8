"""Roughening adds jitter of standard deviation K E_j N^(-1/d) and nothing else."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.errors import ParameterError, ShapeError
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.jitter import Roughening, roughening_scale


def test_scale_is_k_times_range_times_n_to_minus_one_over_d():
    particles = np.array([[0.0, 0.0], [1.0, 4.0], [0.5, 2.0], [0.2, 1.0]])
    # N = 4, d = 2: N^(-1/2) = 0.5; ranges (1, 4).
    np.testing.assert_allclose(roughening_scale(particles, K=0.2), [0.1, 0.4])


def test_jitter_has_the_stated_standard_deviation_and_zero_mean():
    rng = np.random.default_rng(1)
    n, d = 20000, 3
    cloud = np.zeros((n, d))
    cloud[0] = [1.0, 2.0, 0.0]  # ranges (1, 2, 0)
    jittered = Roughening(K=0.5)(cloud, rng)
    sigma = 0.5 * np.array([1.0, 2.0, 0.0]) * n ** (-1 / d)
    noise = (jittered - cloud)[1:]
    # Sample sd of n Gaussian draws has relative standard error 1/sqrt(2n) ~ 0.005: allow 4 of them.
    np.testing.assert_allclose(noise[:, :2].std(axis=0), sigma[:2], rtol=0.02)
    assert np.all(noise[:, 2] == 0.0)
    # Mean within 4 standard errors sigma / sqrt(n).
    assert np.all(np.abs(noise[:, :2].mean(axis=0)) < 4 * sigma[:2] / np.sqrt(n))


def test_indices_restrict_the_jitter():
    rng = np.random.default_rng(2)
    cloud = rng.normal(size=(100, 4))
    out = Roughening(K=0.3, indices=[2, 3])(cloud, rng)
    np.testing.assert_array_equal(out[:, :2], cloud[:, :2])
    assert np.all(out[:, 2:] != cloud[:, 2:])


def test_bad_input_raises_named_errors():
    with pytest.raises(ShapeError):
        roughening_scale(np.zeros(5))
    with pytest.raises(ParameterError):
        roughening_scale(np.zeros((5, 2)), K=-1.0)


def test_filter_without_jitter_is_unchanged_and_jitter_diversifies_landmarks():
    scenario = quadrant_scenario()
    sim = simulate(scenario, rng=3)
    model = scenario.model()
    plain = ParticleFilter(model, 300, threshold=0.5).run(sim.measurements, rng=4)
    explicit_none = ParticleFilter(model, 300, threshold=0.5, jitter=None).run(sim.measurements, rng=4)
    np.testing.assert_array_equal(plain.mean, explicit_none.mean)
    rough = ParticleFilter(model, 300, threshold=0.5, jitter=Roughening(0.2)).run(
        sim.measurements, rng=4, collect=[Clouds()]
    )
    # Without jitter the static landmark coordinates keep at most as many distinct values
    # as survived the first resampling; with jitter every particle is distinct.
    assert len(np.unique(rough.particles[-1][:, 2])) == 300
    assert rough.n_resamples > 0
