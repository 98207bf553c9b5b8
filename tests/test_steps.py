"""The steppable filter (ParticleFilter.steps) and the collectors of ParticleFilter.run.

``run`` is the loop over ``steps`` with collectors, so the two must agree float for float (same
random draws in the same order) for every kind of step: fixed N with each resampler, jitter, a
custom resampler, missing measurements, angles, a proposal with stages, a variable N.  A
collector written by a user in five lines works; malformed ones are refused by name before the
first step; the ancestors collector's lines are those the clouds descend by.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse import LinearGaussianModel, ParticleFilter, StateSpaceModel
from pfcourse.collectors import ALWAYS, Ancestors, Clouds, Collector, Stages
from pfcourse.errors import ModelError, ParameterError
from pfcourse.jitter import RegularisedJitter
from pfcourse.kernels import weighted_moments
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.proposals import ProgressiveCorrection
from pfcourse.resampling import systematic
from pfcourse.scenarios.robot.scenario import RobotModel, simulate_robot
from pfcourse.sample_size import KLDSampling


@pytest.fixture(scope="module")
def landmarks():
    scenario = quadrant_scenario()
    z = simulate(scenario, 3).measurements[:30].copy()
    z[[4, 5, 11]] = np.nan  # steps without a measurement: the cloud moves, the weights stay
    return scenario.model(), z


def random_walk(r: float = 1.0) -> LinearGaussianModel:
    return LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[9.0]], Q=[[1.0]], R=[[r]])


def walk_data(k: int = 20) -> np.ndarray:
    rng = np.random.default_rng(0)
    return (np.cumsum(rng.normal(size=k)) + rng.normal(size=k))[:, None]


def _filters(landmarks):
    model, z = landmarks
    robot = simulate_robot(None, 2, n_steps=25)
    walk = random_walk()
    tempered = ProgressiveCorrection(n_tempered=3, kernel=RegularisedJitter(0.3, (0,)))
    return {
        "systematic 0.5": (ParticleFilter(model, 150), z),
        "multinomial 1.0": (ParticleFilter(model, 150, threshold=1.0, resampler="multinomial"), z),
        "SIS": (ParticleFilter(model, 150, threshold=0.0), z),
        "residual + jitter": (ParticleFilter(model, 150, resampler="residual",
                                             jitter=RegularisedJitter(0.3)), z),
        "custom resampler": (ParticleFilter(model, 150, resampler=lambda w, rng: systematic(w, rng)), z),
        "robot (angles)": (ParticleFilter(RobotModel.for_simulation(robot), 300), robot.measurements),
        "progressive correction": (ParticleFilter(random_walk(0.01), 300, threshold=1.0, proposal=tempered),
                                   walk_data()),
        "KLD (variable N)": (ParticleFilter(walk, 2000, sample_size=KLDSampling([0.5], n_min=50)), walk_data()),
    }


CASES = ["systematic 0.5", "multinomial 1.0", "SIS", "residual + jitter", "custom resampler", "robot (angles)",
         "progressive correction", "KLD (variable N)"]


def same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("case", CASES)
def test_run_and_steps_agree_float_for_float(landmarks, case):
    pf, z = _filters(landmarks)[case]
    fixed = pf.sample_size is None
    extra = [Stages()] + ([Clouds(), Ancestors()] if fixed else [])
    result = pf.run(z, 11, collect=extra)
    pf = _filters(landmarks)[case][0]  # a new filter: progressive correction counts the readings it saw
    steps = list(pf.steps(z, 11))  # kept: the filter never writes into a yielded step
    assert [s.k for s in steps] == list(range(len(z)))
    assert same([s.ess for s in steps], result.ess)
    assert same([s.log_likelihood_increment for s in steps], result.log_likelihood_increments)
    assert same([s.resampled for s in steps], result.resampled)
    assert same([s.size for s in steps], result.sizes)
    assert same([s.stages for s in steps], result.collected["stages"])
    is_angle = np.isin(np.arange(pf.dim_x), pf.angle_indices)
    for s in steps:
        mean, cov = weighted_moments(s.particles, s.weights, is_angle)
        assert same(mean, result.mean[s.k]) and same(cov, result.cov[s.k])
        np.testing.assert_allclose(np.exp(s.log_weights), s.weights, rtol=1e-14, atol=0)
    if fixed:
        assert same(np.stack([s.particles for s in steps]), result.particles)
        assert same(np.stack([s.weights for s in steps]), result.weights)
        lines = np.tile(np.arange(pf.n_particles), (len(z), 1))
        for s in steps[:-1]:
            if s.resampled:
                lines[s.k + 1] = s.ancestors
        assert same(lines, result.collected["ancestors"])
    else:
        assert result.sizes.min() < pf.n_particles  # the policy did vary N
    if case == "progressive correction":
        assert result.collected["stages"][1] > 1 and np.all(result.collected["stages"][4:] == 1)


def test_a_clouds_ancestors_are_the_resampled_parents():
    """With a transition that does not move (x_k = x_{k-1}) and no jitter, step k + 1's cloud is step
    k's cloud at the drawn ancestors; with a variable N the ancestors index the previous cloud."""
    still = StateSpaceModel(dim_x=1, sample_initial=lambda n, rng: rng.normal(size=(n, 1)),
                            sample_transition=lambda x, k, rng: x.copy(),
                            log_likelihood=lambda x, z, k: -0.5 * (z[0] - x[:, 0]) ** 2)
    z = walk_data(8) * 0.1
    steps = list(ParticleFilter(still, 40, threshold=1.0).steps(z, 3))
    assert sum(s.resampled for s in steps[:-1]) >= 5
    for s, after in zip(steps, steps[1:]):
        expected = s.particles[s.ancestors] if s.resampled else s.particles
        assert same(after.particles, expected)
    variable = list(ParticleFilter(still, 500, sample_size=KLDSampling([0.2], n_min=30)).steps(z, 3))
    for before, s in zip(variable, variable[1:]):
        assert s.resampled and len(s.ancestors) == s.size
        assert same(s.particles, before.particles[s.ancestors])


class LargestWeight(Collector):
    name = "largest_weight"

    def fetch(self, step):
        return step.weights.max()


class Path_:
    """A collector that does not derive from Collector: the protocol alone."""

    name = "path"

    def start(self, pf, n_steps):
        self.means = []

    def collect(self, step):
        self.means.append(step.weights @ step.particles)

    def result(self):
        return np.array(self.means)


def test_a_collector_of_five_lines_works_and_serves_many_runs(landmarks):
    model, z = landmarks
    pf = ParticleFilter(model, 100)
    largest = LargestWeight()
    first = pf.run(z, 2, collect=[largest, Path_()])
    again = pf.run(z, 2, collect=[largest])  # start() resets it: one object, many runs
    expected = [s.weights.max() for s in pf.steps(z, 2)]
    assert same(first.collected["largest_weight"], np.array(expected))
    assert same(again.collected["largest_weight"], first.collected["largest_weight"])
    assert np.allclose(first.collected["path"], first.mean, rtol=0, atol=1e-9)
    assert set(first.collected) == {"largest_weight", "path"}


class Counting:
    """A model that counts its draws, to show a refused run never started."""

    dim_x = 1

    def __init__(self):
        self.calls = 0

    def sample_initial(self, n, rng):
        self.calls += 1
        return rng.normal(size=(n, 1))

    def sample_transition(self, x, k, rng):
        return x + rng.normal(size=x.shape)

    def log_likelihood(self, x, z, k):
        return -0.5 * (z[0] - x[:, 0]) ** 2


class NoName:
    def collect(self, step):
        pass

    def result(self):
        return None


class NoResult:
    name = "no_result"

    def collect(self, step):
        pass


class NoFetch(Collector):
    name = "no_fetch"


class Named(LargestWeight):
    def __init__(self, name):
        self.name = name


@pytest.mark.parametrize("collect, error, message", [
    ([NoName()], ModelError, "a collector needs a name"),
    ([NoResult()], ModelError, "'no_result' has no callable result"),
    ([NoFetch()], ModelError, "'no_fetch' has no fetch"),
    ([LargestWeight], ModelError, r"the class LargestWeight \(write LargestWeight\(\)\)"),
    (LargestWeight(), ModelError, "collect must be a list of collectors"),
    ([LargestWeight(), LargestWeight()], ParameterError, "two collectors are named 'largest_weight'"),
    ([Named("ess")], ParameterError, "two collectors are named 'ess' .each run collects moments, ess"),
], ids=["no name", "no result", "Collector without fetch", "a class", "not a list", "a name twice",
        "an always-collected name"])
def test_a_bad_collector_is_refused_by_name_before_the_first_step(collect, error, message):
    model = Counting()
    with pytest.raises(error, match=message):
        ParticleFilter(model, 10).run(walk_data(5), 0, collect=collect)
    assert model.calls == 0


def test_clouds_and_ancestors_need_a_fixed_number_of_particles():
    pf = ParticleFilter(random_walk(), 100, sample_size=KLDSampling([1.0]))
    for collector, what in ((Clouds(), "clouds"), (Ancestors(), "ancestors")):
        with pytest.raises(ParameterError, match=f"the {what} collector needs a fixed number of particles"):
            pf.run(walk_data(5), 0, collect=[collector])


def test_steps_checks_its_inputs_when_called_and_a_loop_may_stop_early():
    pf = ParticleFilter(Counting(), 10)
    with pytest.raises(ParameterError):
        pf.steps(walk_data(5), None)  # no generator: refused at the call, not at the first step
    with pytest.raises(ModelError, match="proposal.propose must return"):
        ParticleFilter(Counting(), 10, proposal=type("P", (), {"propose": lambda *a: (1,)})()).run(walk_data(3), 0)
    first = next(iter(pf.steps(walk_data(5), 4)))
    assert first.k == 0 and first.size == 10
    assert first.ancestors is None or first.ancestors.shape == (10,)


def test_a_proposals_stages_must_be_a_count():
    class Staged:
        def __init__(self, stages):
            self.stages = stages

        def propose(self, model, particles, z, k, rng):
            new = model.sample_transition(particles, k, rng)
            return new, model.log_likelihood(new, z, k), self.stages

    for bad in (0, 1.5, True, None):
        with pytest.raises(ModelError, match="stages must be a count >= 1"):
            ParticleFilter(Counting(), 10, proposal=Staged(bad)).run(walk_data(3), 0)
    stages = ParticleFilter(Counting(), 10, proposal=Staged(3)).run(walk_data(3), 0, collect=[Stages()])
    assert list(stages.collected["stages"]) == [1, 3, 3]  # step 0 is weighted by the model, once


def test_the_always_collected_records_are_the_results_fields(landmarks):
    model, z = landmarks
    result = ParticleFilter(model, 50).run(z, 1)
    assert result.collected == {} and result.particles is None
    assert [c.name for c in ALWAYS] == ["moments", "ess", "resampled", "log_likelihood_increments", "sizes"]
