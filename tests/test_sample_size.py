"""The engine with a variable number of particles (pfcourse.sample_size, ParticleFilter(sample_size=...)).

Checked against the exact answer (the Kalman filter of a 1-D random walk), against the
fixed-N engine it must reduce to, and for KLD-sampling's defining behaviour (few particles
for a tight cloud, the ceiling for a wide one).
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.collectors import Clouds
from pfcourse import LinearGaussianModel, ParticleFilter, kalman_filter
from pfcourse.errors import ModelError, ParameterError
from pfcourse.sample_size import KLDSampling, cell_codes, kld_bound

K = 25


def random_walk(sd_z: float = 1.0, sd_0: float = 3.0) -> LinearGaussianModel:
    return LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[sd_0**2]], Q=[[1.0]], R=[[sd_z**2]])


def data(model, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(size=K)) + rng.normal(0.0, np.sqrt(model.P0[0, 0]))
    return (x + rng.normal(0.0, np.sqrt(model.R[0, 0]), size=K))[:, None]


class Constant:
    """A policy that always asks for ``n`` particles, drawn in one batch."""

    def __init__(self, n: int) -> None:
        self.n = self.n_min = self.batch = n

    def reset(self) -> None:
        pass

    def needed(self, new_particles) -> int:
        return self.n


def test_constant_policy_is_sir_with_multinomial_resampling_at_every_step():
    # same random stream: SIR resamples at the end of step k, the adaptive engine draws the same
    # ancestors at the start of step k + 1, so every float agrees
    model, z = random_walk(), data(random_walk(), 0)
    fixed = ParticleFilter(model, 400, threshold=1.0, resampler="multinomial").run(z, 7)
    adaptive = ParticleFilter(model, 400, sample_size=Constant(400)).run(z, 7)
    assert np.array_equal(fixed.mean, adaptive.mean)
    assert np.array_equal(fixed.cov, adaptive.cov)
    assert np.array_equal(fixed.log_likelihood_increments, adaptive.log_likelihood_increments)
    assert np.array_equal(adaptive.sizes, np.full(K, 400))
    assert adaptive.particle_steps == 400 * K


def test_kld_engine_agrees_with_the_kalman_filter():
    # squared error of the mean in posterior sd's: Monte Carlo variance ~ c / N with c = O(1)
    # for a resampled bootstrap filter on this mixing model; allow c = 5 at the smallest N used
    model = random_walk()
    policy = KLDSampling([0.05], n_min=300)
    sq, n_used = [], []
    for seed in range(20):
        z = data(model, seed)
        kf = kalman_filter(model, z)
        res = ParticleFilter(model, 5000, sample_size=policy).run(z, seed)
        sd = np.sqrt(kf.cov[:, 0, 0])
        sq.append(((res.mean[:, 0] - kf.mean[:, 0]) / sd) ** 2)
        n_used.append(res.sizes[1:].min())
    assert np.mean(sq) < 5.0 / min(n_used)
    assert min(n_used) >= 300


def test_kld_likelihood_estimate_is_unbiased():
    # E[p^(z)] = p(z): the mean ratio over 300 seeds is 1 within 4 standard errors
    model = random_walk()
    z = data(model, 1)
    exact = kalman_filter(model, z).log_likelihood
    ratio = np.exp([ParticleFilter(model, 3000, sample_size=KLDSampling([0.1], n_min=100)).run(z, s).log_likelihood
                    - exact for s in range(300)])
    assert abs(ratio.mean() - 1.0) < 4 * ratio.std(ddof=1) / np.sqrt(ratio.size)


def test_kld_sizes_follow_the_spread_of_the_cloud():
    model = random_walk()
    z = data(model, 2)
    # posterior sd about 0.8: bins of 0.01 need thousands (bound > 4000 beyond ~ 200 bins), bins of 1
    # about 5-9 occupied bins, bound 130-290, reached within one batch of 100 more
    fine = ParticleFilter(model, 4000, sample_size=KLDSampling([0.01], n_min=50)).run(z, 0)
    coarse = ParticleFilter(model, 4000, sample_size=KLDSampling([1.0], n_min=50)).run(z, 0)
    assert fine.sizes[0] == coarse.sizes[0] == 4000  # step 0: the ceiling
    assert np.all(fine.sizes[1:] == 4000)  # the bound exceeds the ceiling
    assert np.all(coarse.sizes[1:] <= kld_bound(9) + 100) and np.all(coarse.sizes[1:] >= 100)
    assert coarse.particle_steps < fine.particle_steps / 10


def test_missing_measurements_keep_the_cloud_and_its_size():
    model = random_walk()
    z = data(model, 3)
    z[5:9] = np.nan
    res = ParticleFilter(model, 2000, sample_size=KLDSampling([0.5], n_min=100)).run(z, 0)
    assert np.all(res.sizes[5:9] == res.sizes[4])
    assert not res.resampled[5:9].any() and res.resampled[1:5].all()


def test_kld_bound_and_bins():
    assert kld_bound(1) == 1
    assert np.all(np.diff(kld_bound(np.arange(2, 100))) > 0)
    x = np.array([[0.1, 0.2, 0.0], [0.15, 0.25, 0.01], [1.1, 0.2, 0.0], [-0.1, 0.2, 0.0]])
    assert len(np.unique(cell_codes(x, (1.0, 1.0, 1.0)))) == 3
    assert len(np.unique(cell_codes(x[:, :1], (1.0,)))) == 3


@pytest.mark.parametrize("kwargs,error,match", [
    (dict(sample_size=object()), ModelError, "no callable reset"),
    (dict(sample_size=Constant(0)), ParameterError, "n_min"),
    (dict(sample_size=Constant(10), jitter=lambda x, rng: x), ParameterError, "jitter and sample_size"),
])
def test_bad_policies_are_named(kwargs, error, match):
    with pytest.raises(error, match=match):
        ParticleFilter(random_walk(), 100, **kwargs)


def test_bad_policy_output_and_settings_are_named():
    class Broken(Constant):
        def needed(self, new_particles):
            return None

    with pytest.raises(ModelError, match="step 1: sample_size.needed must return a count"):
        ParticleFilter(random_walk(), 100, sample_size=Broken(10)).run(data(random_walk(), 0), 0)
    with pytest.raises(ParameterError, match="the clouds collector needs a fixed number"):
        ParticleFilter(random_walk(), 100, sample_size=Constant(10)).run(data(random_walk(), 0), 0, collect=[Clouds()])
    with pytest.raises(ParameterError, match="bin_size"):
        KLDSampling([0.0])
    with pytest.raises(ParameterError, match="2 widths"):
        ParticleFilter(random_walk(), 100, sample_size=KLDSampling([1.0, 1.0])).run(data(random_walk(), 0), 0)
