"""A stateful proposal or jitter starts every run anew (issue 44, review pkg44b findings 1 and 4).

Progressive correction counts the readings it has tempered, augmented MCL carries its two likelihood
averages, the fully adapted auxiliary filter the ESS of its first stage.  The engine calls their
``start()`` (or ``reset()``) before step 0 of every run, so one filter run twice with one seed gives one
result, bit for bit, and a run left by ``break`` does not leak into the next.  Each check first makes
sure that the state matters in the run (stages above 1, an injection, a first stage below ``N``), so
that a filter which kept its state would fail it.  The first-stage ESS is reported per step by a
collector (:class:`pfcourse.proposals.FirstStageESS`), checked against its definition recomputed from
the clouds; the Rao-Blackwellisation study reads it so, and its stored auxiliary rows are unchanged.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from pfcourse import LinearGaussianModel, ParticleFilter
from pfcourse.collectors import Stages
from pfcourse.errors import ModelError, ParameterError
from pfcourse.filter_config import FilterSettings
from pfcourse.jitter import RegularisedJitter
from pfcourse.proposals import FirstStageESS, FullyAdaptedAuxiliary, LinearGaussianOptimal, ProgressiveCorrection
from pfcourse.scenarios.robot.mcl import AugmentedMCL, InjectionProbability
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot
from pfcourse.studies.registry import STUDIES, same

# A random walk seen through a sharp sensor (R = 0.01 against a prior variance of 9): the first
# readings are tempered in several stages.
WALK = LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[9.0]], Q=[[1.0]], R=[[0.01]])


def walk_data(k: int = 12) -> np.ndarray:
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.normal(size=k)) + 3.0 * rng.normal()
    return (x + 0.1 * rng.normal(size=k))[:, None]


def fields(result) -> list[bytes]:
    """Every float the run produced, as bytes: the moments, ESS, flags, increments and the collected records."""
    out = [result.mean.tobytes(), result.cov.tobytes(), result.ess.tobytes(), result.resampled.tobytes(),
           result.log_likelihood_increments.tobytes()]
    return out + [np.asarray(v).tobytes() for _, v in sorted(result.collected.items())]


def test_progressive_correction_starts_every_run_from_the_first_reading():
    pf = FilterSettings(500, threshold=1.0, proposal=ProgressiveCorrection(
        n_tempered=5, kernel=RegularisedJitter(0.5))).build(WALK)
    z = walk_data()
    first, second = (pf.run(z, 7, collect=[Stages()]) for _ in range(2))
    stages = first.collected["stages"]
    assert stages[1:6].max() > 1 and (stages[6:] == 1).all()  # the state matters: five readings tempered
    assert fields(first) == fields(second)


def test_augmented_mcl_starts_every_run_without_averages():
    sim = simulate_robot(None, 1, n_steps=20)
    base = RobotModel.for_simulation(sim, initial="uniform")
    aug = AugmentedMCL(base, alpha_slow=0.01, alpha_fast=0.3)
    pf = ParticleFilter(base, 300, threshold=1.0, proposal=aug, jitter=aug)
    first, second = (pf.run(sim.measurements, 2, collect=[InjectionProbability()]) for _ in range(2))
    assert first.collected["injected"].max() > 0  # the averages matter: the filter injected
    assert fields(first) == fields(second)
    assert aug.injected == list(second.collected["injected"])  # the object's own list is this run's only


def test_the_auxiliary_filter_s_first_stage_is_reported_per_run_and_per_step():
    z = walk_data()
    z[4] = np.nan  # a step without a measurement: no first stage
    pf = ParticleFilter(WALK, 200, threshold=1.0, proposal=FullyAdaptedAuxiliary(LinearGaussianOptimal()))
    first, second = (pf.run(z, 3, collect=[FirstStageESS()]) for _ in range(2))
    ess = first.collected["first_stage_ess"]
    assert ess.shape == (len(z),) and np.isnan(ess[[0, 4]]).all() and np.isfinite(np.delete(ess, [0, 4])).all()
    assert np.nanmin(ess) < 0.9 * 200  # the first stage is not uniform
    assert fields(first) == fields(second)


def test_the_first_stage_ess_is_its_definition_on_the_cloud_it_resampled():
    """``1 / sum_i beta_i^2``, ``beta_i`` proportional to ``W_{k-1}^i p(z_k | x_{k-1}^i)``, recomputed from the
    steps of the same seed (the cloud after its resampling, if it had one), to rounding."""
    z = walk_data()
    pf = ParticleFilter(WALK, 200, threshold=0.5, proposal=FullyAdaptedAuxiliary(LinearGaussianOptimal()))
    collected = pf.run(z, 5, collect=[FirstStageESS()]).collected["first_stage_ess"]
    previous = None
    for step in pf.steps(z, 5):
        if previous is not None:
            x, log_w = previous
            a = log_w + LinearGaussianOptimal().log_predictive(WALK, x, z[step.k], step.k)
            beta = np.exp(a - a.max())
            beta /= beta.sum()
            assert collected[step.k] == pytest.approx(1.0 / np.sum(beta**2), rel=1e-12)
        if step.resampled:
            previous = step.particles[step.ancestors], np.full(step.size, -np.log(step.size))
        else:
            previous = step.particles, step.log_weights


def test_the_first_stage_collector_refuses_a_filter_it_cannot_serve():
    with pytest.raises(ParameterError, match="needs FullyAdaptedAuxiliary"):
        ParticleFilter(WALK, 50).run(walk_data(), 1, collect=[FirstStageESS()])


class CountingJitter:
    """A jitter that keeps state: it moves the cloud by the number of resamplings it has seen, so a count
    carried from one run to the next moves the particles (started by ``reset()``)."""

    def __init__(self) -> None:
        self.seen = 0

    def reset(self) -> None:
        self.seen = 0

    def __call__(self, particles, rng):
        self.seen += 1
        return particles + 1e-3 * self.seen * rng.standard_normal(particles.shape)


def test_a_stateful_jitter_is_started_and_a_run_left_by_break_does_not_leak():
    jitter = CountingJitter()
    pf = ParticleFilter(WALK, 200, threshold=1.0, jitter=jitter)
    z = walk_data()
    first = pf.run(z, 11)
    for step in pf.steps(z, 11):  # a run left half-way
        if step.k == 5:
            break
    assert jitter.seen > 0
    assert fields(pf.run(z, 11)) == fields(first)


def test_a_start_that_is_not_a_method_is_refused_when_the_filter_is_built():
    class Broken:
        start = 3

        def propose(self, model, particles, z, k, rng):
            return particles, np.zeros(len(particles))

        def __call__(self, particles, rng):
            return particles

    with pytest.raises(ModelError, match="proposal's start"):
        ParticleFilter(WALK, 10, proposal=Broken())
    with pytest.raises(ModelError, match="jitter's start"):
        ParticleFilter(WALK, 10, jitter=Broken())


def test_the_auxiliary_rows_of_the_rao_blackwell_study_are_unchanged():
    """The study now collects the first-stage ESS per step (no proposal read after the run): a seeded sample of
    the stored auxiliary rows (the N <= 300 ones, quick) is re-computed float for float, ``ess`` included."""
    study = STUDIES["rao_blackwell"]
    stored = study.load()
    rows = stored[stored["method"].isin(["apf", "rb_apf"]) & (stored["N"] <= 300)]
    rng = np.random.default_rng([2026, zlib.crc32(b"first_stage_ess")])
    for i in rng.choice(len(rows), 4, replace=False):
        row = rows.iloc[int(i)]
        fresh = study.recompute(row)
        for key, value in fresh.items():
            if key in stored.columns and key not in study.volatile:
                assert same(row[key], value), f"row {row.name}: {key} {row[key]!r} != {value!r}"
