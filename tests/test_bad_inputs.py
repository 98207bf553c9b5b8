"""Table of bad inputs to the public API (issue 14, "every bad input named").

Each row: a label, a call that feeds one bad input, the named ``pfcourse.errors`` class it
must raise and a fragment of the message (what was wrong, and at which step inside a run).
Rows whose expected class is ``None`` are valid but unusual inputs with a documented
treatment; their check function asserts that treatment.
"""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.collectors import Clouds
from pfcourse import ParticleFilter, StateSpaceModel
from pfcourse import diagnostics, resampling
from pfcourse.errors import (
    CovarianceError,
    DegenerateWeightsError,
    MeasurementError,
    ModelError,
    NumericalError,
    ParameterError,
    PfcourseError,
    ShapeError,
    WeightError,
)
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario
from pfcourse.diagnostics import nees, nis
from pfcourse.studies.executor import SerialExecutor
from pfcourse.studies.study import run_study
from pfcourse.scenarios.robot import RobotScenario, simulate_robot
from pfcourse.sample_size import KLDSampling

N = 20


def rw_model(init=None, trans=None, loglik=None, dim_x=1, tld=None, angles=()):
    """A scalar random walk; any of its functions can be replaced by a bad one."""
    return StateSpaceModel(
        dim_x=dim_x,
        sample_initial=init or (lambda n, rng: rng.normal(0.0, 1.0, (n, dim_x))),
        sample_transition=trans or (lambda x, k, rng: x + rng.normal(0.0, 0.1, x.shape)),
        log_likelihood=loglik or (lambda x, z, k: -0.5 * (z[0] - x[:, 0]) ** 2),
        transition_log_density=tld,
        angle_indices=angles,
    )


Z = np.array([[0.1], [0.2], [0.0], [-0.1]])


def run(model=None, z=Z, n=N, rng=0, **kw):
    return ParticleFilter(model or rw_model(), n, **kw).run(z, rng)


def pf(**kw):
    return lambda: ParticleFilter(rw_model(), **kw)


def at_step(k, value):
    """A model function that returns ``value`` at step ``k`` and a good answer elsewhere."""
    def loglik(x, z, kk):
        return value(x) if kk == k else -0.5 * (z[0] - x[:, 0]) ** 2
    return loglik


def bad_resampler(indices):
    return lambda w, rng: indices


ROWS: list[tuple[str, object, type | None, str]] = []


def row(label, call, error, fragment):
    ROWS.append((label, call, error, fragment))


# --- ParticleFilter settings -------------------------------------------------------------
for value in [None, np.nan, np.inf, -np.inf, 0, -3, 1.5, "10", True, False, 2 + 0j, [10]]:
    row(f"n_particles={value!r}", pf(n_particles=value), ParameterError, "n_particles")
for value in [None, np.nan, np.inf, -0.1, 1.01, "0.5", True, 0.5j, [0.5]]:
    row(f"threshold={value!r}", pf(n_particles=N, threshold=value), ParameterError, "threshold")
for value in ["bogus", 3, None, 1.0]:
    row(f"resampler={value!r}", pf(n_particles=N, resampler=value), ParameterError, "resampling scheme")
row("proposal without propose", pf(n_particles=N, proposal=object()), ModelError, "propose")
row("jitter not callable", pf(n_particles=N, jitter=3.0), ModelError, "jitter")

# --- model attributes ----------------------------------------------------------------------
for value in [1.7, 0, -1, None, np.nan, np.inf, "2", True]:
    row(f"dim_x={value!r}", lambda v=value: ParticleFilter(rw_model(dim_x=v), N), ParameterError, "model.dim_x")
row("model without log_likelihood", lambda: ParticleFilter(object(), N), ModelError, "sample_initial")
row("angle index out of range", lambda: ParticleFilter(rw_model(angles=(3,)), N), ModelError, "angle_indices")
row("angle index not an integer", lambda: ParticleFilter(rw_model(angles=(0.5,)), N), ModelError, "angle_indices")
row("angle indices not a sequence", lambda: ParticleFilter(rw_model(angles=3), N), ModelError, "angle_indices")

# --- what the model returns ------------------------------------------------------------------
BAD_PARTICLES = [
    ("None", lambda n: None, ModelError, "returned None"),
    ("complex", lambda n: np.zeros((n, 1)) + 1j, ModelError, "complex"),
    ("object", lambda n: np.array([object()] * n).reshape(n, 1), ModelError, "object"),
    ("strings", lambda n: np.array([["a"]] * n), ModelError, "dtype"),
    ("bool", lambda n: np.zeros((n, 1), dtype=bool), ModelError, "bool"),
    ("1-D", lambda n: np.zeros(n), ShapeError, "shape (20,)"),
    ("too few rows", lambda n: np.zeros((n - 1, 1)), ShapeError, "shape (19, 1)"),
    ("too many columns", lambda n: np.zeros((n, 2)), ShapeError, "expected (20, 1)"),
    ("3-D", lambda n: np.zeros((n, 1, 1)), ShapeError, "shape (20, 1, 1)"),
    ("scalar", lambda n: 0.0, ShapeError, "shape ()"),
    ("NaN", lambda n: np.full((n, 1), np.nan), NumericalError, "NaN or infinite"),
    ("inf", lambda n: np.full((n, 1), np.inf), NumericalError, "NaN or infinite"),
]
for label, make, error, fragment in BAD_PARTICLES:
    row(f"sample_initial returns {label}", lambda m=make: run(rw_model(init=lambda n, rng: m(n))),
        error, "step 0: " if error is not ModelError else "step 0")
    row(f"sample_initial returns {label} (message)", lambda m=make: run(rw_model(init=lambda n, rng: m(n))),
        error, fragment)
    row(f"sample_transition returns {label}",
        lambda m=make: run(rw_model(trans=lambda x, k, rng: m(len(x)))), error, "step 1: sample_transition")

BAD_LOGLIK = [
    ("None", lambda x: None, ModelError, "is None"),
    ("complex", lambda x: np.zeros(len(x)) + 1j, ModelError, "complex"),
    ("object", lambda x: np.array([None] * len(x)), ModelError, "object"),
    ("bool", lambda x: np.ones(len(x), dtype=bool), ModelError, "bool"),
    ("wrong length", lambda x: np.zeros(len(x) - 1), ShapeError, "expected (20,)"),
    ("2-D", lambda x: np.zeros((len(x), 1)), ShapeError, "shape (20, 1)"),
    ("scalar", lambda x: 0.0, ShapeError, "shape ()"),
    ("NaN", lambda x: np.full(len(x), np.nan), NumericalError, "NaN or +inf"),
    ("one NaN", lambda x: np.r_[np.nan, np.zeros(len(x) - 1)], NumericalError, "for 1 particle"),
    ("+inf", lambda x: np.full(len(x), np.inf), NumericalError, "NaN or +inf"),
    ("all -inf", lambda x: np.full(len(x), -np.inf), DegenerateWeightsError, "zero likelihood"),
    ("list of None", lambda x: [None] * len(x), ModelError, "object"),
]
for label, value, error, fragment in BAD_LOGLIK:
    row(f"log_likelihood returns {label} at step 0", lambda v=value: run(rw_model(loglik=at_step(0, v))), error, "step 0")
    row(f"log_likelihood returns {label} at step 2", lambda v=value: run(rw_model(loglik=at_step(2, v))), error, fragment)

# --- custom resampler (checked before the compiled gather: no crash possible) ---------------
BAD_INDICES = [
    ("index 10**12", np.full(N, 10**12), ShapeError, "outside [0, 20)"),
    ("index 10**5", np.full(N, 10**5), ShapeError, "outside [0, 20)"),
    ("index N", np.full(N, N), ShapeError, "outside [0, 20)"),
    ("negative index", np.full(N, -1), ShapeError, "outside [0, 20)"),
    ("int64 min", np.full(N, np.iinfo(np.int64).min), ShapeError, "outside"),
    ("float indices", np.zeros(N), ModelError, "float64"),
    ("bool indices", np.zeros(N, dtype=bool), ModelError, "bool"),
    ("too few", np.zeros(N - 1, dtype=int), ShapeError, "shape (19,)"),
    ("2-D", np.zeros((N, 1), dtype=int), ShapeError, "shape (20, 1)"),
    ("None", None, ModelError, "object"),
    ("uint64 huge", np.full(N, 2**63 + 5, dtype=np.uint64), ShapeError, "outside"),
]
for label, indices, error, fragment in BAD_INDICES:
    row(f"resampler returns {label}", lambda i=indices: run(resampler=bad_resampler(i), threshold=1.0), error, fragment)
row("resampler returns good int32 indices", lambda: run(resampler=bad_resampler(np.arange(N, dtype=np.int32)), threshold=1.0), None, "valid")

# --- measurements --------------------------------------------------------------------------
for label, z, fragment in [
    ("a string", "abc", "sequence"),
    ("an integer", 5, "sequence"),
    ("None", None, "sequence"),
    ("a 0-d array", np.array(1.0), "0-d"),
    ("inf entry", np.array([[0.0], [np.inf]]), "inf"),
    ("-inf in a list", [np.array([0.0]), np.array([-np.inf])], "step 1"),
    ("complex entry", [np.array([0.0]), np.array([1j])], "step 1: the measurement must be a real array"),
    ("string entry", [np.array([0.0]), "z"], "step 1"),
    ("object entry", [np.array([0.0]), object()], "step 1"),
    ("shapes disagree", [np.array([0.0]), np.array([0.0, 1.0])], "step 1: the measurement has shape (2,)"),
]:
    row(f"measurements = {label}", lambda z=z: run(z=z), MeasurementError, fragment)
row("rng = 'seed'", lambda: run(rng="seed"), ParameterError, "rng")
row("rng = True", lambda: run(rng=True), ParameterError, "rng")
row("rng = -1", lambda: run(rng=-1), ParameterError, "rng")
row("rng = 1.5", lambda: run(rng=1.5), ParameterError, "rng")

# --- DensityProposal without transition_log_density --------------------------------------
from pfcourse import DensityProposal  # noqa: E402

_dp = DensityProposal(sample=lambda x, z, k, rng: x, log_density=lambda new, x, z, k: np.zeros(len(x)))
row("DensityProposal, model without transition_log_density", lambda: run(proposal=_dp), ModelError,
    "step 1: DensityProposal needs")
row("proposal returns one array", lambda: run(proposal=type("P", (), {"propose": lambda s, m, x, z, k, r: x})()),
    ModelError, "step 1: proposal.propose must return")
row("proposal returns NaN particles",
    lambda: run(proposal=type("P", (), {"propose": lambda s, m, x, z, k, r: (x * np.nan, np.zeros(len(x)))})()),
    NumericalError, "step 1: proposal.propose produced NaN")

# --- resampling functions -----------------------------------------------------------------
W = np.full(4, 0.25)
for name in ["multinomial", "stratified", "systematic", "residual"]:
    f = getattr(resampling, name)
    for label, w, n, error, fragment in [
        ("None weights", None, None, WeightError, "real array"),
        ("complex weights", W + 0j, None, WeightError, "complex"),
        ("NaN weight", np.r_[np.nan, W[1:]], None, WeightError, "finite"),
        ("negative weight", np.r_[-0.25, 0.75, 0.25, 0.25], None, WeightError, "non-negative"),
        ("unnormalised", W * 2, None, WeightError, "sum to 1"),
        ("empty", np.array([]), None, WeightError, "empty"),
        ("2-D", W[None, :], None, WeightError, "1-D"),
        ("n=0", W, 0, ParameterError, "n must be at least 1"),
        ("n=2.5", W, 2.5, ParameterError, "integer"),
        ("n=True", W, True, ParameterError, "integer"),
    ]:
        row(f"{name}({label})", lambda f=f, w=w, n=n: f(w, np.random.default_rng(0), n), error, fragment)

# --- diagnostics ----------------------------------------------------------------------------
row("normalize_log_weights(all -inf)", lambda: diagnostics.normalize_log_weights(np.full(3, -np.inf)),
    DegenerateWeightsError, "-inf")
row("normalize_log_weights(NaN)", lambda: diagnostics.normalize_log_weights(np.r_[0.0, np.nan]), WeightError, "NaN")
row("normalize_log_weights(+inf)", lambda: diagnostics.normalize_log_weights(np.r_[0.0, np.inf]), WeightError, "+inf")
row("normalize_log_weights(None)", lambda: diagnostics.normalize_log_weights(None), WeightError, "None")
row("normalize_log_weights(complex)", lambda: diagnostics.normalize_log_weights(np.r_[0j, 1]), WeightError, "complex")
row("normalize_log_weights(empty)", lambda: diagnostics.normalize_log_weights(np.array([])), ShapeError, "empty")
row("normalize_log_weights(2-D)", lambda: diagnostics.normalize_log_weights(np.zeros((2, 2))), ShapeError, "shape (2, 2)")
row("ess(NaN)", lambda: diagnostics.effective_sample_size(np.r_[np.nan, 1.0]), WeightError, "finite")
row("ess(unnormalised)", lambda: diagnostics.effective_sample_size(np.r_[2.0, 1.0]), WeightError, "sum to 1")
row("ess(None)", lambda: diagnostics.effective_sample_size(None), WeightError, "None")
row("ess(empty)", lambda: diagnostics.effective_sample_size([]), ShapeError, "empty")
row("ess(negative)", lambda: diagnostics.effective_sample_size([1.5, -0.5]), WeightError, "non-negative")
row("weighted_mean(length mismatch)", lambda: diagnostics.weighted_mean(np.zeros((3, 2)), W), ShapeError, "length 4")
row("weighted_mean(NaN weights)", lambda: diagnostics.weighted_mean(np.zeros((4, 2)), W * np.nan), WeightError, "finite")
row("weighted_mean(1-D particles)", lambda: diagnostics.weighted_mean(np.zeros(4), W), ShapeError, "particles")
row("weighted_covariance(complex particles)", lambda: diagnostics.weighted_covariance(np.zeros((4, 2)) + 1j, W),
    WeightError, "complex")

# --- landmark scenario and model -----------------------------------------------------------
for field, value in [("dt", np.nan), ("dt", 0.0), ("dt", -1.0), ("dt", None), ("omega", np.inf), ("omega", np.nan),
                     ("fov_range", -1.0), ("fov_range", 0.0), ("fov_half_angle", 4.0), ("fov_half_angle", True),
                     ("n_samples", 1.5), ("n_landmarks", 0), ("field_of_view", "circle")]:
    row(f"landmark scenario {field}={value!r}", lambda f=field, v=value: quadrant_scenario().with_(**{f: v}),
        ParameterError, field)
row("landmark scenario centre NaN", lambda: quadrant_scenario().with_(centre=np.array([np.nan, 0.0])), ParameterError, "centre")
row("landmark scenario Qw not symmetric", lambda: quadrant_scenario().with_(Qw=np.triu(np.ones((6, 6)))),
    CovarianceError, "Qw is not symmetric")


def _q_zero():
    m = LinearGaussianModel(F=np.eye(1), H=np.eye(1), m0=np.zeros(1), P0=np.eye(1), Q=np.zeros((1, 1)), R=np.eye(1))
    return m.transition_log_density(np.zeros((2, 1)), np.zeros((2, 1)), 1)


row("Q=0 transition_log_density blames Q", _q_zero, CovarianceError, "process noise covariance Q")


# --- diagnostics, the study runner, the robot scenario, the variable-N engine ---------------
_S = np.tile(np.eye(2), (3, 1, 1))
row("nis: S not positive definite", lambda: nis(np.ones((3, 2)), -_S), CovarianceError, "step 0 is not positive definite")
row("nis: S not symmetric", lambda: nis(np.ones((3, 2)), _S + np.array([[0.0, 0.5], [0.0, 0.0]])), CovarianceError,
    "step 0 is not symmetric")
row("nis: S with NaN at step 2", lambda: nis(np.ones((3, 2)), np.where(np.arange(3)[:, None, None] == 2, np.nan, _S)),
    CovarianceError, "step 2")
row("nis: shapes disagree", lambda: nis(np.zeros((3, 2)), np.tile(np.eye(3), (3, 1, 1))), ShapeError, "nis needs")
row("nees: shapes disagree", lambda: nees(np.zeros((3, 2)), np.zeros((4, 2)), _S), ShapeError, "nees needs")
row("run_study: grid is a list", lambda: run_study(lambda seed, a: {"x": a}, [1, 2], 2, progress=False),
    ParameterError, "grid must map parameter names")
row("run_study: row is a float", lambda: run_study(lambda seed, a: 3.0, {"a": [1]}, 2, progress=False,
                                                   executor=SerialExecutor()),
    ParameterError, "must return a mapping")
row("run_study: n_runs=0", lambda: run_study(lambda seed, a: {"x": a}, {"a": [1]}, 0), ParameterError, "n_runs")
row("run_study: empty grid values", lambda: run_study(lambda seed, a: {"x": a}, {"a": []}, 2), ParameterError,
    "non-empty list")
for field, value in [("dt", np.nan), ("dt", -1.0), ("n_steps", 0), ("n_steps", 2.5), ("half_width", -5.0)]:
    row(f"robot scenario {field}={value!r}", lambda f=field, v=value: simulate_robot(RobotScenario().with_(**{f: v}), 0),
        ParameterError, field)
row("sample_size without reset/needed", lambda: ParticleFilter(rw_model(), N, sample_size=object()), ModelError,
    "sample_size has no callable reset")
row("sample_size with jitter", lambda: ParticleFilter(rw_model(), N, sample_size=KLDSampling([1.0]),
                                                      jitter=lambda x, rng: x), ParameterError, "jitter and sample_size")
row("KLD bin_size of 0", lambda: KLDSampling([0.0]), ParameterError, "bin_size")
row("KLD bin_size for 2 components on a 1-D model",
    lambda: ParticleFilter(rw_model(), N, sample_size=KLDSampling([1.0, 1.0])).run(Z, 0), ParameterError, "2 widths")
row("the clouds of a variable N",
    lambda: ParticleFilter(rw_model(), N, sample_size=KLDSampling([1.0])).run(Z, 0, collect=[Clouds()]),
    ParameterError, "the clouds collector needs a fixed number")


# --- the remaining robot scenario fields -------------------------------------------------------
for field, value, error, fragment in [
    ("dt", np.inf, ParameterError, "dt must be finite"),
    ("dt", None, ParameterError, "dt must be a real number"),
    ("dt_meas", np.nan, ParameterError, "dt_meas must be at least dt"),
    ("dt_meas", None, ParameterError, "dt_meas must be at least dt"),
    ("gap", (5.0,), ParameterError, "gap must be (start, stop)"),
    ("gap", (np.nan, 10.0), ParameterError, "gap must be (start, stop)"),
    ("gap", ("a", "b"), ParameterError, "gap must be (start, stop)"),
    ("start", (np.nan, 0.0, 0.0), ParameterError, "start must be finite"),
    ("start", (0.0, 0.0), ShapeError, "start must have length 3"),
    ("speed", (np.inf, 0.0), ParameterError, "speed must be finite"),
    ("speed", 0.1, ShapeError, "speed must be a 1-D vector"),
    ("turn_rate", np.nan, ParameterError, "turn_rate must be finite"),
    ("half_width", np.inf, ParameterError, "half_width must be finite"),
    ("landmarks", np.array([[0.0, np.nan]]), ParameterError, "landmarks must be finite"),
]:
    row(f"robot scenario {field}={value!r}", lambda f=field, v=value: simulate_robot(RobotScenario().with_(**{f: v}), 0),
        error, fragment)
row("simulate_robot rng=1.5", lambda: simulate_robot(None, 1.5), ParameterError, "rng must be a numpy Generator")

# --- the terrain scenario (AircraftScenario, simulate) ---------------------------------------
from pfcourse.scenarios.terrain.map import TerrainMap  # noqa: E402
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate as simulate_flight  # noqa: E402

for field, value, error, fragment in [
    ("dt", np.nan, ParameterError, "dt must be finite"),
    ("dt", np.inf, ParameterError, "dt must be finite"),
    ("dt", 0.0, ParameterError, "dt must be positive"),
    ("dt", -1.0, ParameterError, "dt must be positive"),
    ("dt", None, ParameterError, "dt must be a real number"),
    ("dt", "1", ParameterError, "dt must be a real number"),
    ("dt", 1e-300, ParameterError, "duration / dt"),
    ("duration", -5.0, ParameterError, "duration must be positive"),
    ("speed", np.nan, ParameterError, "speed must be finite"),
    ("speed", -100.0, ParameterError, "speed must be non-negative"),
    ("speed", None, ParameterError, "speed must be a real number"),
    ("omega", np.nan, ParameterError, "omega must be finite"),
    ("omega", np.inf, ParameterError, "omega must be finite"),
    ("R", 0.0, ParameterError, "R must be positive"),
    ("R", None, ParameterError, "R must be a real number"),
    ("Rf", np.inf, ParameterError, "Rf must be finite"),
    ("Rf", -1.0, ParameterError, "Rf must be positive"),
    ("measurement_period", 0.0, ParameterError, "measurement_period must be positive"),
    ("gap", (50.0, 10.0), ParameterError, "gap must be (start, stop)"),
    ("gap", (10.0,), ParameterError, "gap must be (start, stop)"),
    ("x0", np.array([np.nan, 0.0, 0.0, 0.0]), ParameterError, "x0 must be finite"),
    ("x0", np.zeros(3), ShapeError, "x0 must have length 4"),
    ("x0", np.zeros((4, 1)), ShapeError, "x0 must be a 1-D vector"),
    ("P0", -np.eye(4), CovarianceError, "P0 is not positive semi-definite"),
    ("P0", np.eye(3), ShapeError, "P0 must have shape (4, 4)"),
    ("P0", np.full((4, 4), np.nan), CovarianceError, "P0 contains NaN"),
    ("Qf", np.triu(np.ones((4, 4))), CovarianceError, "Qf is not symmetric"),
    ("Qf", np.diag([1.0, 1.0, np.inf, 1.0]), CovarianceError, "Qf contains NaN or infinite"),
]:
    row(f"terrain scenario {field}={value!r}", lambda f=field, v=value: AircraftScenario().with_(**{f: v}), error,
        fragment)
_TINY_MAP = TerrainMap(np.zeros((3, 4)), dx=10.0, dy=20.0)
row("terrain simulate: scenario is a dict", lambda: simulate_flight({"dt": 1.0}, _TINY_MAP, 0), ParameterError,
    "scenario must be an AircraftScenario")
row("terrain simulate: terrain is an array", lambda: simulate_flight(AircraftScenario(), np.zeros((3, 4)), 0),
    ParameterError, "terrain must be a TerrainMap")
row("terrain simulate: rng = 'seed'", lambda: simulate_flight(AircraftScenario(), _TINY_MAP, "seed"), ParameterError,
    "rng must be a numpy Generator")
row("terrain simulate: initial_state with NaN",
    lambda: simulate_flight(AircraftScenario(), _TINY_MAP, 0, initial_state=[np.nan, 0.0, 0.0, 0.0]), ParameterError,
    "initial_state must be finite")
from pfcourse.scenarios.terrain.kalman import unscented_kalman_filter  # noqa: E402

for label, kw, fragment in [("alpha=0", {"alpha": 0.0}, "alpha must lie in (0.0"),
                            ("kappa=-4", {"kappa": -4.0}, "kappa must lie in (-4.0")]:  # four states
    row(f"terrain UKF {label}", lambda kw=kw: unscented_kalman_filter(AircraftScenario(), _TINY_MAP, np.zeros(3), **kw),
        ParameterError, fragment)
from pfcourse.scenarios.terrain.marginalised import MarginalisedTerrainModel  # noqa: E402
from pfcourse.scenarios.terrain.point_mass import PointMassFilter  # noqa: E402

row("terrain marginalised model: scenario is a dict", lambda: MarginalisedTerrainModel(_TINY_MAP, {"dt": 1.0}),
    ParameterError, "scenario must be an AircraftScenario")
row("terrain point-mass filter: cell = -1", lambda: PointMassFilter(_TINY_MAP, AircraftScenario(), cell=-1.0),
    ParameterError, "cell and heading_step must be positive")
row("terrain point-mass filter: terrain is an array", lambda: PointMassFilter(np.zeros((3, 4)), AircraftScenario()),
    ParameterError, "terrain must be a TerrainMap")

# --- kalman_filter (scenario A's exact reference) --------------------------------------------
from pfcourse.kalman import kalman_filter  # noqa: E402

_LG = LinearGaussianModel(F=np.eye(2), H=np.eye(2), m0=np.zeros(2), P0=np.eye(2), Q=np.eye(2), R=np.eye(2))
for label, z, error, fragment in [
    ("3 components for a 2-D measurement", [np.zeros(2), np.zeros(3)], MeasurementError, "step 1: the measurement has shape (3,)"),
    ("a (K, 1) array for a 2-D measurement", np.zeros((3, 1)), MeasurementError, "step 0: the measurement has shape (1,)"),
    ("+inf entry", np.array([[0.0, 0.0], [np.inf, 0.0]]), MeasurementError, "+/-inf"),
    ("complex entry", [np.zeros(2), np.array([1j, 0.0])], MeasurementError, "step 1: the measurement must be a real array"),
    ("a string", "zz", MeasurementError, "sequence"),
    ("None", None, MeasurementError, "sequence"),
]:
    row(f"kalman_filter measurements = {label}", lambda z=z: kalman_filter(_LG, z), error, fragment)
for label, changes, fragment in [
    ("a complex F (NumPy would drop the imaginary part)", {"F": np.eye(2) * (1 + 1j)}, "F must be a 2-D matrix of real numbers"),
    ("None inside H (NumPy would make it NaN)", {"H": [[None, 0.0], [0.0, 1.0]]}, "H must be a 2-D matrix of real numbers"),
    ("a string m0", {"m0": ["a", "b"]}, "m0 must be a 1-D vector of real numbers"),
    ("a complex m0 array", {"m0": np.array([1j, 0.0])}, "m0 must be a 1-D vector of real numbers"),
]:
    row(f"LinearGaussianModel with {label}",
        lambda changes=changes: LinearGaussianModel(**{"F": np.eye(2), "H": np.eye(2), "m0": np.zeros(2), "P0": np.eye(2),
                                                       "Q": np.eye(2), "R": np.eye(2), **changes}),
        ShapeError, fragment)
row("kalman_filter model = a StateSpaceModel", lambda: kalman_filter(rw_model(), Z), ModelError,
    "needs a LinearGaussianModel")


def _kalman_missing():
    """None, an empty array and all-NaN are missing steps; a NaN entry is an unobserved component."""
    full = kalman_filter(_LG, [np.zeros(2), np.array([0.5, 0.5])])
    r = kalman_filter(_LG, [np.zeros(2), None, np.array([]), np.full(2, np.nan), np.array([0.5, np.nan])])
    assert np.all(np.isnan(r.innovation[1:4])) and np.all(r.log_likelihood_increments[1:4] == 0.0)
    assert np.isnan(r.innovation[4, 1]) and not np.isnan(r.innovation[4, 0])
    assert np.all(np.isfinite(r.mean)) and full.mean.shape == (2, 2)


row("kalman_filter: None / empty / NaN measurements are missing", _kalman_missing, None, "missing")

# --- run_ekf / run_ukf (the robot's Kalman references) ----------------------------------------
from pfcourse.scenarios.robot.kalman import run_ekf, run_ukf  # noqa: E402
from pfcourse.scenarios.robot.scenario import RobotModel  # noqa: E402

_SIM = simulate_robot(None, 0, n_steps=6)
_RM = RobotModel.for_simulation(_SIM)


def _with_row(k, values):
    z = _SIM.measurements.copy()
    z[k] = values
    return z


for name, f in [("run_ekf", run_ekf), ("run_ukf", run_ukf)]:
    for label, call, error, fragment in [
        ("landmark index 7 of 5", lambda f=f: f(_RM, _with_row(2, (7.0, 10.0, 0.1))), MeasurementError,
         "step 2: landmark index 7.0 is not one of 0..4"),
        ("landmark index -1", lambda f=f: f(_RM, _with_row(2, (-1.0, 10.0, 0.1))), MeasurementError,
         "step 2: landmark index -1.0"),
        ("landmark index 1.5", lambda f=f: f(_RM, _with_row(3, (1.5, 10.0, 0.1))), MeasurementError,
         "step 3: landmark index 1.5"),
        ("NaN range with a landmark", lambda f=f: f(_RM, _with_row(3, (1.0, np.nan, 0.1))), MeasurementError,
         "step 3: range and bearing must be finite"),
        ("+inf bearing", lambda f=f: f(_RM, _with_row(3, (1.0, 10.0, np.inf))), MeasurementError, "+/-inf"),
        ("measurements (K, 2)", lambda f=f: f(_RM, _SIM.measurements[:, :2]), ShapeError, "shape (K, 3)"),
        ("more steps than odometry", lambda f=f: f(_RM, np.vstack([_SIM.measurements] * 2)), ShapeError,
         "only 6 odometry rows"),
        ("model is a LinearGaussianModel", lambda f=f: f(_LG, _SIM.measurements), ModelError, "need a RobotModel"),
        ("initial_cov not positive definite", lambda f=f: f(_RM, _SIM.measurements, np.zeros((3, 3))),
         CovarianceError, "initial_cov is not positive definite"),
        ("initial_cov 2x2", lambda f=f: f(_RM, _SIM.measurements, np.eye(2)), ShapeError, "initial_cov must have shape"),
    ]:
        row(f"{name}: {label}", call, error, fragment)
for label, kw, fragment in [("alpha=0", {"alpha": 0.0}, "alpha must lie in (0.0"),
                            ("alpha=NaN", {"alpha": np.nan}, "alpha must be finite"),
                            ("beta=inf", {"beta": np.inf}, "beta must be finite"),
                            ("kappa=-3", {"kappa": -3.0}, "kappa must lie in (-3.0"),
                            ("kappa=None", {"kappa": None}, "kappa must be a real number")]:
    row(f"run_ukf {label}", lambda kw=kw: run_ukf(_RM, _SIM.measurements, **kw), ParameterError, fragment)

# --- particles whose weighted covariance overflows ---------------------------------------------
_HUGE = lambda n, rng: np.where(np.arange(n)[:, None] % 2 == 0, 1e308, -1e308)  # noqa: E731
_FLAT = lambda x, z, k: np.zeros(len(x))  # noqa: E731  (a likelihood that does not see the magnitude)
row("particles near +/-1e308: covariance overflows at step 0",
    lambda: run(rw_model(init=_HUGE, loglik=_FLAT)), NumericalError,
    "step 0: the weighted covariance of the particles overflows")
row("particles spread to 1e200 at step 2: covariance overflows",
    lambda: run(rw_model(trans=lambda x, k, rng: x * 1e200 if k == 2 else x, loglik=_FLAT)), NumericalError,
    "step 2: the weighted covariance of the particles overflows")
row("weighted_covariance of +/-1e308 particles",
    lambda: diagnostics.weighted_covariance(np.array([[1e308], [-1e308]]), np.array([0.5, 0.5])), NumericalError,
    "the weighted covariance of the particles overflows")
row("weighted_covariance of NaN particles",
    lambda: diagnostics.weighted_covariance(np.array([[np.nan], [0.0]]), np.array([0.5, 0.5])), NumericalError,
    "NaN or infinite states")
row("heading with no circular mean is NaN, not an overflow (documented)",
    lambda: _no_circular_mean(), None, "valid")


def _no_circular_mean():
    """Two headings half a turn apart have no circular mean: NaN mean and variance of the heading,
    the position's moments still finite; the filter does not mistake it for an overflow."""
    cov = diagnostics.weighted_covariance(np.array([[0.0, 0.0], [1.0, np.pi]]), np.array([0.5, 0.5]), angle_indices=(1,))
    assert np.isnan(cov[1, 1]) and cov[0, 0] == 0.25


# --- issue 27: every array parameter of a constructor, checked when the object is built -------
from dataclasses import asdict  # noqa: E402

from pfcourse.scenarios.landmarks.scenario import LandmarkScenario, simulate as simulate_landmarks  # noqa: E402
from pfcourse.resampling import SCHEMES  # noqa: E402
from pfcourse.scenarios.terrain.scenario import TerrainModel  # noqa: E402

_LG_ARGS = {"F": np.eye(2), "H": np.eye(2), "m0": np.zeros(2), "P0": np.eye(2), "Q": np.eye(2), "R": np.eye(2),
            "B": np.zeros(2)}


def _lg(**changes):
    return LinearGaussianModel(**{**_LG_ARGS, **changes})


for name, value, error, fragment in [
    ("m0", [np.nan, 0.0], ParameterError, "m0 must be finite"),
    ("m0", [0.0, np.inf], ParameterError, "m0 must be finite"),
    ("m0", np.zeros((2, 1)), ShapeError, "m0 must be a 1-D vector"),
    ("m0", np.zeros(0), ShapeError, "m0 must have one entry per state"),
    ("P0", np.diag([1.0, np.nan]), CovarianceError, "P0 contains NaN"),
    ("P0", np.eye(3), ShapeError, "P0 must have shape (2, 2)"),
    ("P0", -np.eye(2), CovarianceError, "P0 is not positive semi-definite"),
    ("F", np.diag([1.0, np.nan]), ParameterError, "F must be finite"),
    ("F", np.diag([-np.inf, 1.0]), ParameterError, "F must be finite"),
    ("F", np.eye(3), ShapeError, "F must have shape (2, 2)"),
    ("F", np.ones(2), ShapeError, "F must be a 2-D matrix"),
    ("H", np.array([[np.nan, 0.0]]), ParameterError, "H must be finite"),
    ("H", np.eye(3), ShapeError, "H must have 2 columns"),
    ("H", np.zeros((0, 2)), ShapeError, "at least one row"),
    ("B", [np.inf, 0.0], ParameterError, "B must be finite"),
    ("B", np.zeros(3), ShapeError, "B must have length 2"),
    ("B", [1j, 0.0], ShapeError, "B must be a 1-D vector of real numbers"),
    ("Q", np.diag([np.inf, 1.0]), CovarianceError, "Q contains NaN"),
    ("Q", np.eye(1), ShapeError, "Q must have shape (2, 2)"),
    ("R", np.diag([1.0, np.nan]), CovarianceError, "R contains NaN"),
    ("R", np.zeros((2, 2)), CovarianceError, "R is not positive definite"),
    ("R", np.zeros((0, 0)), ShapeError, "R must be at least 1 x 1"),
]:
    row(f"LinearGaussianModel {name}={value!r}", lambda name=name, value=value: _lg(**{name: value}), error, fragment)

_QUADRANT = asdict(quadrant_scenario())
for name, value, error, fragment in [
    ("mX0", np.full(6, np.nan), ParameterError, "mX0 must be finite"),
    ("mX0", np.zeros(5), ShapeError, "mX0 must have length 6"),
    ("PX0", np.diag([np.inf] + [1.0] * 5), CovarianceError, "PX0 contains NaN or infinite"),
    ("PX0", -np.eye(6), CovarianceError, "PX0 is not positive semi-definite"),
    ("Qw", np.full((6, 6), np.nan), CovarianceError, "Qw contains NaN or infinite"),
    ("Qw", np.eye(5), ShapeError, "Qw must have shape (6, 6)"),
    ("Rv", np.diag([1.0, 1.0, 1.0, -np.inf]), CovarianceError, "Rv contains NaN or infinite"),
    ("Rv", np.zeros((4, 4)), CovarianceError, "Rv is not positive definite"),
    ("centre", [np.inf, 0.0], ParameterError, "centre must be finite"),
    ("n_samples", 10**13, ParameterError, "n_samples=1e+13 is too large for this machine"),
]:
    row(f"LandmarkScenario({name}={value!r}) (the constructor itself)",
        lambda name=name, value=value: LandmarkScenario(**{**_QUADRANT, name: value}), error, fragment)
for name, value, error, fragment in [
    ("q_true", np.diag([np.nan, 1.0, 1.0]), CovarianceError, "q_true contains NaN or infinite"),
    ("q_true", np.eye(2), ShapeError, "q_true must have shape (3, 3)"),
    ("r_true", np.diag([np.inf, 1.0]), CovarianceError, "r_true contains NaN or infinite"),
    ("r_true", -np.eye(2), CovarianceError, "r_true is not positive semi-definite"),
    ("start", (0.0, np.inf, 0.0), ParameterError, "start must be finite"),
    ("n_steps", 10**12, ParameterError, "n_steps=1e+12 is too large for this machine"),
    ("n_landmarks", 2**62, ParameterError, "n_landmarks=4.61e+18 is too large for this machine"),
]:
    row(f"RobotScenario({name}={value!r}) (the constructor itself)",
        lambda name=name, value=value: RobotScenario(**{name: value}), error, fragment)
for name, value, error, fragment in [
    ("x0", [0.0, 0.0, np.inf, 0.0], ParameterError, "x0 must be finite"),
    ("P0", np.diag([1.0, 1.0, 1.0, np.nan]), CovarianceError, "P0 contains NaN"),
    ("Qf", -np.eye(4), CovarianceError, "Qf is not positive semi-definite"),
    ("Qf", np.eye(3), ShapeError, "Qf must have shape (4, 4)"),
    ("R", np.inf, ParameterError, "R must be finite"),
]:
    row(f"AircraftScenario({name}={value!r}) (the constructor itself)",
        lambda name=name, value=value: AircraftScenario(**{name: value}), error, fragment)

_RM_ARGS = {"landmarks": _SIM.landmarks, "odometry": _SIM.odometry, "q_est": 2 * _SIM.scenario.q_true,
            "r_est": 2 * _SIM.scenario.r_true}
for name, value, error, fragment in [
    ("landmarks", np.array([[0.0, np.nan]]), ParameterError, "landmarks must be finite"),
    ("landmarks", np.zeros((0, 2)), ShapeError, "landmarks must have shape (M, 2) with M >= 1"),
    ("odometry", np.full((6, 3), np.inf), ParameterError, "odometry must be finite"),
    ("odometry", np.zeros(3), ShapeError, "odometry must be a 2-D matrix"),
    ("q_est", np.full((3, 3), np.nan), CovarianceError, "q_est contains NaN"),
    ("r_est", np.diag([1.0, np.inf]), CovarianceError, "r_est contains NaN"),
    ("start", (np.nan, 0.0, 0.0), ParameterError, "start must be finite"),
    ("initial_std", (1.0, 1.0, np.inf), ParameterError, "initial_std must be finite"),
    ("initial_std", (1.0, -1.0, 0.1), ParameterError, "initial_std must be non-negative"),
    ("dt", np.nan, ParameterError, "dt must be finite"),
    ("dt", 0.0, ParameterError, "dt must lie in (0.0"),
    ("half_width", np.inf, ParameterError, "half_width must be finite"),
]:
    row(f"RobotModel({name}={value!r})", lambda name=name, value=value: RobotModel(**{**_RM_ARGS, name: value}),
        error, fragment)
for label, call, error, fragment in [
    ("heights with NaN", lambda: TerrainMap(np.array([[0.0, np.nan], [0.0, 0.0]]), dx=1.0, dy=1.0),
     ParameterError, "heights must be finite"),
    ("complex heights", lambda: TerrainMap(np.zeros((2, 2)) + 1j, dx=1.0, dy=1.0), ShapeError,
     "heights must be a 2-D matrix of real numbers"),
    ("dx = NaN", lambda: TerrainMap(np.zeros((2, 2)), dx=np.nan, dy=1.0), ParameterError, "dx must be finite"),
    ("dy = None", lambda: TerrainMap(np.zeros((2, 2)), dx=1.0, dy=None), ParameterError, "dy must be a real number"),
    ("TerrainModel over an array", lambda: TerrainModel(np.zeros((3, 4)), AircraftScenario()), ParameterError,
     "terrain must be a TerrainMap"),
    ("TerrainModel of a dict scenario", lambda: TerrainModel(_TINY_MAP, {"dt": 1.0}), ParameterError,
     "scenario must be an AircraftScenario"),
]:
    row(f"TerrainMap / TerrainModel: {label}", call, error, fragment)


for label, z, error, fragment in [
    ("NaN landmark index with a range", (np.nan, 10.0, 0.1), ParameterError, "step 2: landmark index nan"),
    ("NaN range with a landmark", (1.0, np.nan, 0.1), MeasurementError, "step 2: range and bearing must be finite"),
]:
    row(f"ParticleFilter(RobotModel): {label}", lambda z=z: ParticleFilter(_RM, N).run(_with_row(2, z), 0), error,
        fragment)


# --- the Kalman filter never returns NaN silently ---------------------------------------------
for label, model, z, fragment in [
    ("F = 1e200 I: the covariance overflows at the first prediction", _lg(F=1e200 * np.eye(2)), np.ones((3, 2)),
     "step 1: the Kalman filter's prediction produced NaN or infinite"),
    ("H = 1e200 I: S overflows at the first update", _lg(H=1e200 * np.eye(2)), np.ones((3, 2)),
     "step 0: the Kalman filter's update produced NaN or infinite"),
    ("measurements of 1e308: the log-likelihood overflows", _lg(), np.full((3, 2), 1e308),
     "step 0: the Kalman filter"),
    ("m0 = 1e308 and F = ones: the mean overflows", _lg(m0=[1e308, 1e308], F=np.ones((2, 2))), np.ones((3, 2)),
     "step 0: the Kalman filter"),
]:
    row(f"kalman_filter: {label}", lambda model=model, z=z: kalman_filter(model, z), NumericalError, fragment)


# --- empty series, scalar series ---------------------------------------------------------------
for label, call in [
    ("ParticleFilter.run([])", lambda: run(z=[])),
    ("ParticleFilter.run(array (0, 1))", lambda: run(z=np.zeros((0, 1)))),
    ("ParticleFilter.run(array (0,))", lambda: run(z=np.zeros(0))),
    ("kalman_filter(model, [])", lambda: kalman_filter(_LG, [])),
    ("kalman_filter(model, array (0, 2))", lambda: kalman_filter(_LG, np.zeros((0, 2)))),
    ("run_ekf(model, array (0, 3))", lambda: run_ekf(_RM, np.zeros((0, 3)))),
    ("run_ukf(model, [])", lambda: run_ukf(_RM, [])),
]:
    row(f"empty measurements: {label}", call, MeasurementError, "measurements is empty: pass one measurement per step")

_LG1 = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[0.1]], R=[[0.25]])
_Z1 = [0.1, np.nan, 0.2, 0.0, -0.1]


def _same_result(a, b):
    """Two results of the same run: every array field the same floats (NaN where NaN)."""
    for name in ("mean", "cov", "ess", "log_likelihood_increments", "innovation", "gain"):
        if hasattr(a, name):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def _scalar_series(make_z, filter_run):
    reference = filter_run(np.array(_Z1)[:, None])
    assert np.isfinite(reference.mean).all() and reference.mean.shape == (5, 1)
    _same_result(filter_run(make_z()), reference)


for label, make_z in [("array (K,)", lambda: np.array(_Z1)), ("list of floats", lambda: list(_Z1)),
                      ("list of numpy floats", lambda: [np.float64(v) for v in _Z1])]:
    row(f"scalar measurements as {label} = the (K, 1) array (ParticleFilter)",
        lambda make_z=make_z: _scalar_series(make_z, lambda z: ParticleFilter(_LG1, N).run(z, 0)), None, "valid")
    row(f"scalar measurements as {label} = the (K, 1) array (kalman_filter)",
        lambda make_z=make_z: _scalar_series(make_z, lambda z: kalman_filter(_LG1, z)), None, "valid")


def _ints_and_none():
    """Integers and ``None`` (a missing step) in a list of scalars: as the (K, 1) float array with NaN."""
    _same_result(ParticleFilter(_LG1, N).run([1, None, 2], 0),
                 ParticleFilter(_LG1, N).run(np.array([[1.0], [np.nan], [2.0]]), 0))


row("scalar measurements as a list of ints and None = the (K, 1) array", _ints_and_none, None, "valid")
row("1-D series for a 2-D measurement model", lambda: kalman_filter(_LG, np.zeros(3)), MeasurementError,
    "step 0: the measurement has shape (1,), the model measures (2,)")


# --- particle counts: any size, any type -------------------------------------------------------
for value, fragment in [
    (10**12, "n_particles=1e+12 is too large for this machine"),
    (10**30, "n_particles=1e+30 is too large for this machine"),
    (2**63, "n_particles=9.22e+18 is too large for this machine"),
    (2**64 + 1, "is too large for this machine"),
    (10**400, "n_particles=10^400 is too large for this machine"),
    (1e30, "n_particles=1e+30 is too large for this machine"),
    (np.uint64(2**64 - 1), "is too large for this machine"),
    (10.5, "n_particles must be an integer"),
    (np.float64(2.5), "n_particles must be an integer"),
    (1e300 + 0.5, "is too large for this machine"),  # 1e300 + 0.5 is the integral float 1e300
    (-(10**400), "n_particles must be at least 1"),
    ("1e12", "n_particles must be an integer"),
    (np.bool_(True), "n_particles must be an integer"),
    (np.array(10), "n_particles must be an integer"),
]:
    row(f"n_particles={value!r:.40}", pf(n_particles=value), ParameterError, fragment)
row("n_particles=10**6 with dim_x=10**9", lambda: ParticleFilter(rw_model(dim_x=10**9), 10**6), ParameterError,
    "the particles (dim_x=1000000000")
row("n_particles = numpy float 10.0 (integral: accepted)",
    lambda: np.testing.assert_array_equal(run(n=np.float64(10.0)).mean, run(n=10).mean), None, "valid")
for scheme in SCHEMES:
    row(f"{scheme}(n=10**12)", lambda f=SCHEMES[scheme]: f(W, np.random.default_rng(0), 10**12), ParameterError,
        "n=1e+12 is too large for this machine")
    row(f"{scheme}(n=10**400)", lambda f=SCHEMES[scheme]: f(W, np.random.default_rng(0), 10**400), ParameterError,
        "n=10^400 is too large")
    row(f"{scheme}(n=5.0) (integral: accepted, as n_particles)",
        lambda f=SCHEMES[scheme]: np.testing.assert_array_equal(f(W, np.random.default_rng(0), 5.0),
                                                                f(W, np.random.default_rng(0), 5)), None, "valid")


# --- rng: must be given wherever the README says every draw is seeded -------------------------
_RNG_GIVEN = "rng must be given: pass a numpy Generator or an integer seed"
for label, call in [
    ("ParticleFilter.run(z) without rng", lambda: ParticleFilter(rw_model(), N).run(Z)),
    ("ParticleFilter.run(z, None)", lambda: run(rng=None)),
    ("landmarks simulate(scenario) without rng", lambda: simulate_landmarks(quadrant_scenario())),
    ("terrain simulate(scenario, terrain) without rng", lambda: simulate_flight(AircraftScenario(), _TINY_MAP)),
    ("simulate_robot(None, None)", lambda: simulate_robot(None, None)),
    ("simulate_robot(n_steps=5) without rng", lambda: simulate_robot(n_steps=5)),
] + [(f"{scheme}(weights) without rng", lambda f=SCHEMES[scheme]: f(W)) for scheme in SCHEMES] + [
    (f"{scheme}(weights, None)", lambda f=SCHEMES[scheme]: f(W, None)) for scheme in SCHEMES
]:
    row(label, call, ParameterError, _RNG_GIVEN)
row("resampler rng = 'seed'", lambda: resampling.systematic(W, "seed"), ParameterError, "rng must be a numpy Generator")
row("landmarks simulate: scenario is a dict", lambda: simulate_landmarks({"dt": 1.0}, 0), ParameterError,
    "scenario must be a LandmarkScenario")
row("simulate_robot: scenario is a dict", lambda: simulate_robot({"dt": 1.0}, 0), ParameterError,
    "scenario must be a RobotScenario")


# --- the map robot (pfcourse.scenarios.maprobot): refused when the object is built --------------------------------
def _map_rows():
    from pfcourse.errors import OffMapError
    from pfcourse.scenarios.maprobot import (LikelihoodField, MapRobotModel, OccupancyGrid, OdometryModel, Scanner,
                                   cast_rays, rooms_and_corridor)
    box = np.zeros((10, 10), dtype=bool)
    box[0, :] = box[-1, :] = box[:, 0] = box[:, -1] = True
    grid = OccupancyGrid(box, 0.1)
    lf = LikelihoodField(grid, np.zeros(1))
    return [
        ("OccupancyGrid of floats", lambda: OccupancyGrid(np.zeros((5, 5)), 0.1), ShapeError, "boolean"),
        ("OccupancyGrid all walls", lambda: OccupancyGrid(np.ones((5, 5), dtype=bool), 0.1), ParameterError,
         "no free cell"),
        ("OccupancyGrid resolution 0", lambda: OccupancyGrid(box, 0.0), ParameterError, "resolution"),
        ("rooms_and_corridor resolution 2 m", lambda: rooms_and_corridor(2.0), ParameterError, "resolution"),
        ("OdometryModel negative alpha", lambda: OdometryModel((0.1, -0.1, 0.1, 0.1)), ParameterError, "alpha_2"),
        ("OdometryModel two alphas", lambda: OdometryModel((0.1, 0.1)), ShapeError, "four numbers"),
        ("Scanner mixture weights not summing to 1", lambda: Scanner(z_hit=0.5), ParameterError, "must be 1"),
        ("Scanner with no beam", lambda: Scanner(n_beams=0), ParameterError, "n_beams"),
        ("cast_rays from inside a wall", lambda: cast_rays(grid, np.array([[0.05, 0.05, 0.0]]), np.zeros(1), 1.0),
         OffMapError, "in a wall"),
        ("LikelihoodField sigma 0", lambda: LikelihoodField(grid, np.zeros(1), sigma=0.0), ParameterError, "sigma"),
        ("LikelihoodField scan of the wrong length", lambda: lf.log_likelihood(np.zeros((2, 3)), np.ones(2)),
         MeasurementError, "1 ranges"),
        ("MapRobotModel odometry (K, 2)", lambda: MapRobotModel(grid, lf, np.zeros((5, 2))), ShapeError, "odometry"),
        ("MapRobotModel inject 2", lambda: MapRobotModel(grid, lf, np.zeros((5, 3)), inject=2.0), ParameterError,
         "inject"),
    ]


for _label, _call, _error, _fragment in _map_rows():
    row(f"map robot: {_label}", _call, _error, _fragment)


# --- valid but unusual: documented treatments -------------------------------------------
def _offset(c):
    """Weights are invariant to a constant: the filter's answer moves only by the model's own
    rounding of ``c + log p`` (relative 2**-52 of ``c``), and the weights stay normalised."""
    base = run(rw_model())
    shifted = ParticleFilter(rw_model(loglik=lambda x, z, k: c - 0.5 * (z[0] - x[:, 0]) ** 2), N).run(
        Z, 0, collect=[Clouds()])
    assert np.allclose(shifted.weights.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(np.isfinite(shifted.mean)) and np.all(np.isfinite(shifted.log_likelihood_increments))
    if abs(c) <= 1e9:  # the model's rounding of c - r^2/2 is 1e9 * 2**-53 ~ 1e-7 per particle
        np.testing.assert_allclose(shifted.mean, base.mean, atol=1e-5)
        np.testing.assert_allclose(shifted.log_likelihood_increments - c, base.log_likelihood_increments, atol=1e-5)


for c in [1e9, -1e9, 1e300, -1e300]:
    row(f"constant log-likelihood offset {c:g} (weights invariant)", lambda c=c: _offset(c), None, "invariant")


def _pm_1e308():
    r = ParticleFilter(rw_model(loglik=lambda x, z, k: np.where(np.arange(len(x)) % 2 == 0, 1e308, -1e308)), N,
                       threshold=0.0).run(Z, 0, collect=[Clouds()])
    assert np.allclose(r.weights.sum(axis=1), 1.0)
    assert np.all(np.isfinite(r.weights))


row("log-likelihood +/-1e308 (weights sum to 1)", _pm_1e308, None, "sum to 1")


def _missing():
    r = run(z=[None, np.array([np.nan]), np.array([0.1]), np.array([])])
    assert r.log_likelihood_increments[0] == 0.0 and r.log_likelihood_increments[1] == 0.0
    assert r.log_likelihood_increments[3] == 0.0


row("None / NaN / empty measurement is missing", _missing, None, "missing")
row("integer measurements accepted", lambda: run(z=np.array([[0], [1]])), None, "valid")
row("N = 1 (numpy integer)", lambda: run(n=np.int64(1)), None, "valid")
row("N = 5.0 (integral float)", lambda: run(n=5.0), None, "valid")
row("threshold = 0 (SIS)", lambda: run(threshold=0), None, "valid")


def _smoother_inputs():
    from pfcourse.smoothing import ffbsi, fixed_lag_means
    p, w = np.zeros((3, 4, 1)), np.ones((3, 4)) / 4
    return ffbsi, fixed_lag_means, p, w


row("ffbsi n_draws = 0", lambda: (lambda f, _, p, w: f(p, w, lambda a, b, k: np.zeros((len(a), len(b))), 0,
                                                       np.random.default_rng(0)))(*_smoother_inputs()),
    ParameterError, "n_draws")
row("ffbsi clouds not collected", lambda: _smoother_inputs()[0](np.zeros((3, 4)), np.ones((3, 4)) / 4,
                                                                           None, 2, np.random.default_rng(0)),
    ShapeError, "Clouds")
row("fixed_lag_means negative lag", lambda: (lambda _, f, p, w: f(p, w, np.zeros((3, 4), int), -1))(*_smoother_inputs()),
    ParameterError, "lag")



def _configs():
    from pfcourse.filter_config import FilterConfig, configurations, lookup
    return FilterConfig, configurations, lookup


row("FilterConfig without a callable build", lambda: _configs()[0]("a", "A", None), ParameterError, "callable build")
row("FilterConfig n_particles = 0", lambda: _configs()[0]("a", "A", dict, 0), ParameterError, "n_particles")
row("filter configurations named twice",
    lambda: _configs()[1](_configs()[0]("a", "A", dict), _configs()[0]("a", "B", dict)), ParameterError, "named twice")
row("unknown filter configuration", lambda: _configs()[2]({}, "sir"), ParameterError, "unknown filter configuration")

@pytest.mark.parametrize("label, call, error, fragment", ROWS, ids=[r[0] for r in ROWS])
def test_bad_input(label, call, error, fragment):
    if error is None:
        call()  # a documented treatment: the call asserts it (or simply succeeds)
        return
    assert issubclass(error, PfcourseError)
    with np.errstate(all="ignore"), pytest.raises(error) as info:
        call()
    assert fragment in str(info.value), f"{label}: {info.value!s}"


def test_table_is_large():
    assert len(ROWS) >= 440
    assert len({label for label, *_ in ROWS}) == len(ROWS)  # every row its own case


def test_readme_states_the_table():
    """README's "Using the package" gives the table's size: it must be the truth."""
    from pathlib import Path

    readme = " ".join((Path(__file__).parents[1] / "README.md").read_text().split())
    refused = sum(error is not None for _, _, error, _ in ROWS)
    assert f"tabulates {len(ROWS)} inputs ({refused} refused with their error and message, " \
           f"{len(ROWS) - refused} documented treatments)" in readme
