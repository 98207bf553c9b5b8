"""Property test (hypothesis): malformed models, measurements and settings thrown at the filter
give either a valid result (finite weights summing to 1, finite moments, a finite or -inf
log-likelihood) or a named PfcourseError, never another exception and never a NaN."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfcourse.collectors import Clouds
from pfcourse import ParticleFilter, StateSpaceModel
from pfcourse.errors import PfcourseError

BAD_VALUES = st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1e308, 1e9, 0.0, 1.0, -5.0])


def _output(kind: str, shape, fill: float, rng_value):
    if kind == "good":
        return rng_value
    if kind == "none":
        return None
    if kind == "complex":
        return np.zeros(shape) + 1j
    if kind == "object":
        return np.full(shape, None, dtype=object)
    if kind == "int":
        return np.zeros(shape, dtype=int)
    if kind == "fill":
        return np.full(shape, fill)
    if kind == "short":
        return np.zeros((shape[0] - 1,) + tuple(shape[1:])) if shape[0] > 1 else np.zeros((2,) + tuple(shape[1:]))
    if kind == "wide":
        return np.zeros(tuple(shape) + (2,))
    raise AssertionError(kind)


KINDS = st.sampled_from(["good", "good", "good", "none", "complex", "object", "int", "fill", "short", "wide"])
SETTING = st.one_of(st.integers(-2, 30), st.floats(allow_nan=True, allow_infinity=True), st.none(), st.booleans(),
                    st.just("10"))
MEASUREMENT = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(lambda v: np.array([v])),
    st.just(np.array([0.0, 1.0])),
    st.just(np.array([1j])),
    st.just("z"),
)


@settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=SETTING, threshold=st.one_of(SETTING, st.floats(0, 1)), dim_x=SETTING,
    init_kind=KINDS, trans_kind=KINDS, lik_kind=KINDS, lik_step=st.integers(0, 3), fill=BAD_VALUES,
    measurements=st.lists(MEASUREMENT, min_size=1, max_size=4),
    resampler=st.sampled_from(["systematic", "multinomial", "bad_range", "bad_dtype", "good_custom"]),
)
def test_filter_never_crashes_nor_returns_nan(n, threshold, dim_x, init_kind, trans_kind, lik_kind, lik_step, fill,
                                                measurements, resampler):
    def sample_initial(m, rng):
        return _output(init_kind, (m, 1), fill, rng.normal(size=(m, 1)))

    def sample_transition(x, k, rng):
        return _output(trans_kind, x.shape, fill, x + rng.normal(0, 0.3, x.shape))

    def log_likelihood(x, z, k):
        good = -0.5 * np.nansum((z[None, :1] - x[:, :1]) ** 2, axis=1)
        return _output(lik_kind, (len(x),), fill, good) if k == lik_step else good

    if resampler == "bad_range":
        resampler = lambda w, rng: np.full(len(w), 10**12)  # noqa: E731
    elif resampler == "bad_dtype":
        resampler = lambda w, rng: np.zeros(len(w))  # noqa: E731
    elif resampler == "good_custom":
        resampler = lambda w, rng: rng.integers(0, len(w), len(w))  # noqa: E731
    model = StateSpaceModel(dim_x, sample_initial, sample_transition, log_likelihood)
    try:
        with np.errstate(all="ignore"):
            result = ParticleFilter(model, n, threshold=threshold, resampler=resampler).run(
                measurements, 0, collect=[Clouds()])
    except PfcourseError:
        return
    assert np.all(np.isfinite(result.weights))
    np.testing.assert_allclose(result.weights.sum(axis=1), 1.0, atol=1e-9)
    assert np.all(np.isfinite(result.mean)) and np.all(np.isfinite(result.particles))
    assert np.all(np.isfinite(result.cov))  # an overflowing covariance is a NumericalError
    assert not np.isnan(result.log_likelihood)
    assert np.all(np.isfinite(result.ess))


# --- every public entry point, fuzzed over the shapes, dtypes and values of its parameters (issue 27) ---
import dataclasses  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

import pfcourse  # noqa: E402
from pfcourse.scenarios import landmarks, robot, terrain  # noqa: E402
from pfcourse import DensityProposal, FilterSettings, LinearGaussianModel, OptimalProposal, kalman_filter  # noqa: E402
from pfcourse.resampling import SCHEMES  # noqa: E402

K = 5
Z2 = np.array([[0.1, 0.2], [np.nan, 0.1], [0.3, 0.2], [0.0, 0.1], [0.2, np.nan]])
Z1 = np.array([[0.1], [np.nan], [0.3], [0.0], [0.2]])
LG = {"F": np.eye(2) * 0.9, "H": np.eye(2), "m0": np.zeros(2), "P0": np.eye(2), "Q": np.eye(2) * 0.1,
      "R": np.eye(2) * 0.25, "B": np.full(2, 0.1)}
LG1 = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[0.1]], R=[[0.25]])
HUGE = 1e308


def _set(v: np.ndarray, where: int, value) -> np.ndarray:
    out = np.array(v, dtype=float if not isinstance(value, complex) else complex)
    if out.size:
        out.flat[where % out.size] = value
    return out


def _with_none(v: np.ndarray, where: int) -> np.ndarray:
    out = np.array(v, dtype=object)
    if out.size:
        out.flat[where % out.size] = None
    return out


# Each mutation of a valid array ``v``: (bad value, reference) where ``reference`` is the valid value
# that the call must reproduce bit for bit if it accepts the bad one (None: no such value; then the
# result must only be valid).
ARRAY_MUTATIONS = {
    # shapes
    "empty": lambda v, i: (np.zeros((0,) + v.shape[1:]), None),
    "1-D": lambda v, i: (v.ravel() if v.ndim > 1 else v[i % len(v)], v if v.ndim == 2 and v.shape[1] == 1 else None),
    "wrong trailing dimension": lambda v, i: (np.concatenate([v, v[..., :1]], axis=-1), None),
    "extra axis": lambda v, i: (v[..., None], None),
    "list": lambda v, i: (v.tolist(), v),
    # dtypes
    "int": lambda v, i: (np.nan_to_num(v).astype(np.int64), np.nan_to_num(v).astype(np.int64).astype(float)),
    "bool": lambda v, i: (np.nan_to_num(v).astype(bool), np.nan_to_num(v).astype(bool).astype(float)),
    "complex, zero imaginary part": lambda v, i: (v + 0j, None),
    "complex": lambda v, i: (_set(v, i, 1j), None),
    "object of floats": lambda v, i: (v.astype(object), v),
    "object with None": lambda v, i: (_with_none(v, i), None),
    "strings": lambda v, i: (v.astype(str), None),
    # values
    "NaN": lambda v, i: (_set(v, i, np.nan), None),
    "+inf": lambda v, i: (_set(v, i, np.inf), None),
    "-inf": lambda v, i: (_set(v, i, -np.inf), None),
    "huge": lambda v, i: (_set(v, i, HUGE), None),
    "-huge": lambda v, i: (_set(v, i, -HUGE), None),
    "all huge": lambda v, i: (np.full(v.shape, 1e200), None),
    "negative": lambda v, i: (-np.abs(v) - 1.0, None),
}
# Each mutation of a valid scalar ``v`` (a count, a setting, a seed).
SCALAR_MUTATIONS = {
    "None": lambda v, i: (None, None),
    "NaN": lambda v, i: (np.nan, None),
    "+inf": lambda v, i: (np.inf, None),
    "-inf": lambda v, i: (-np.inf, None),
    "huge float": lambda v, i: (HUGE, None),
    "huge int": lambda v, i: (10 ** (12 + i % 400), None),
    "2**63": lambda v, i: (2**63, None),
    "negative": lambda v, i: (-1 - i % 10, None),
    "zero": lambda v, i: (0, None),
    "non-integer": lambda v, i: (v + 0.5, None),
    "bool": lambda v, i: (True, None),
    "string": lambda v, i: (str(v), None),
    "complex": lambda v, i: (complex(v), None),
    "1-element list": lambda v, i: ([v], None),
    "numpy float": lambda v, i: (np.float64(v), v),
    "numpy int": lambda v, i: ((np.int64(v), v) if float(v).is_integer() else (np.float32(0.5), None)),
}


def _arrays(result) -> list:
    """The float arrays of a result (an array, a tuple or a dataclass of them), for comparisons."""
    if dataclasses.is_dataclass(result):
        return [a for f in dataclasses.fields(result) for a in _arrays(getattr(result, f.name))]
    if isinstance(result, (tuple, list)):
        try:
            return [np.asarray(result, dtype=float)]  # numbers, as an array whatever the sequence type
        except (TypeError, ValueError):
            return [a for r in result for a in _arrays(r)]
    if isinstance(result, (np.ndarray, float, int, np.floating, np.integer)):
        return [np.asarray(result, dtype=float)]
    return []


def _valid_filter_result(r) -> None:
    assert np.all(np.isfinite(r.mean)) and np.all(np.isfinite(r.cov)) and np.all(np.isfinite(r.ess))
    if r.weights is not None:
        np.testing.assert_allclose(r.weights.sum(axis=1), 1.0, atol=1e-9)
    assert not np.isnan(r.log_likelihood)


def _valid_kalman_result(r) -> None:
    assert np.all(np.isfinite(r.mean)) and np.all(np.isfinite(r.cov))
    assert np.all(np.isfinite(r.log_likelihood_increments))


def _finite(*names):
    def check(r):
        for name in names:
            assert np.all(np.isfinite(getattr(r, name))), name
    return check


def _ieee(r, kwargs) -> None:
    """A pure formula (motion, range_bearing, the errors): NaN and inf propagate as in IEEE arithmetic,
    so its output must be finite when every input is finite and moderate (below 1e150)."""
    inputs = [np.asarray(v, dtype=float) for v in kwargs.values()]
    if all(np.all(np.isfinite(v)) and np.all(np.abs(v) < 1e150) for v in inputs):
        for a in _arrays(r):
            assert np.all(np.isfinite(a))


def _finite_array(r) -> None:
    assert np.all(np.isfinite(np.asarray(r, dtype=float)))


def _indices_of(weights_size):
    def check(idx):
        assert idx.dtype == np.int64 and np.all((idx >= 0) & (idx < weights_size))
    return check


def _lg_pf(proposal=None):
    def call(measurements=Z2, n_particles=20, threshold=0.5, rng=0):
        return pfcourse.ParticleFilter(LinearGaussianModel(**LG), n_particles, threshold=threshold,
                                       proposal=proposal).run(measurements, rng, collect=[Clouds()])
    return call


def _ssm_pf(dim_x=1, rng=0):
    d = dim_x if isinstance(dim_x, int) and 0 < dim_x < 10 else 1  # the model's own functions stay valid
    model = pfcourse.StateSpaceModel(
        dim_x, lambda n, g: g.normal(size=(n, d)), lambda x, k, g: x + g.normal(0, 0.3, x.shape),
        lambda x, z, k: -0.5 * (z[0] - x[:, 0]) ** 2)
    return pfcourse.ParticleFilter(model, 20).run(Z1, rng, collect=[Clouds()])


def _density_pf(proposed=np.zeros((20, 1)), log_q=np.zeros(20)):
    model = pfcourse.StateSpaceModel(1, lambda n, g: g.normal(size=(n, 1)), lambda x, k, g: x,
                                     lambda x, z, k: -0.5 * (z[0] - x[:, 0]) ** 2,
                                     transition_log_density=lambda new, old, k: np.zeros(len(old)))
    proposal = DensityProposal(sample=lambda x, z, k, g: proposed, log_density=lambda new, x, z, k: log_q)
    return pfcourse.ParticleFilter(model, 20, proposal=proposal).run(Z1, 0, collect=[Clouds()])


SIM = robot.simulate_robot(None, 0, n_steps=12)
ROBOT_MODEL = robot.RobotModel.for_simulation(SIM)
ROBOT_Z = SIM.measurements
TINY_TERRAIN = terrain.TerrainMap(np.array([[0.0, 50.0, 20.0, 0.0], [10.0, 80.0, 30.0, 5.0], [0.0, 40.0, 60.0, 10.0],
                                            [5.0, 20.0, 10.0, 0.0]]), dx=10000.0, dy=10000.0)
AIRCRAFT = dataclasses.asdict(terrain.AircraftScenario(duration=6.0))
FLIGHT = terrain.simulate(terrain.AircraftScenario(**AIRCRAFT), TINY_TERRAIN, 0)
FIELD = dataclasses.asdict(terrain.FieldScenario(duration=6.0))
QUADRANT = {**dataclasses.asdict(landmarks.quadrant_scenario()), "n_samples": K}
ROBOT_SCENARIO = {**{f.name: getattr(robot.RobotScenario(), f.name) for f in dataclasses.fields(robot.RobotScenario)},
                  "n_steps": 12, "gap": (3.0, 5.0), "landmarks": np.array([[0.0, 10.0], [5.0, -5.0]])}
ROBOT_MODEL_ARGS = {"landmarks": SIM.landmarks, "odometry": SIM.odometry, "q_est": 2 * robot.Q_TRUE,
                    "r_est": 2 * robot.R_TRUE, "dt": 1.0, "start": SIM.truth[0], "initial_std": np.array([1.0, 1.0, 0.1]),
                    "half_width": 60.0}
STATES = np.array([[0.0, 0.0, 0.1], [1.0, -2.0, 3.0], [5.0, 5.0, -1.0], [0.5, 0.0, 0.0]])


def _robot_pf(**changes):
    model = robot.RobotModel(**{**ROBOT_MODEL_ARGS, **changes})
    return pfcourse.ParticleFilter(model, 20).run(ROBOT_Z, 0, collect=[Clouds()])


def _terrain_pf(heights=TINY_TERRAIN.heights, dx=10000.0, dy=10000.0):
    model = terrain.TerrainModel(terrain.TerrainMap(heights, dx=dx, dy=dy), terrain.AircraftScenario(**AIRCRAFT))
    return pfcourse.ParticleFilter(model, 20).run(FLIGHT.measurements, 0, collect=[Clouds()])


def _flight(rng=0, initial_state=FLIGHT.truth[0], **fields):
    return terrain.simulate(terrain.AircraftScenario(**{**AIRCRAFT, **fields}), TINY_TERRAIN, rng,
                            initial_state=initial_state)


def _field_flight(rng=0, **fields):
    return terrain.simulate_field(terrain.FieldScenario(**{**FIELD, **fields}), TINY_TERRAIN, rng)


def _landmark_run(rng=0, **fields):
    return landmarks.simulate(landmarks.LandmarkScenario(**{**QUADRANT, **fields}), rng)


def _robot_run(rng=0, **fields):
    return robot.simulate_robot(robot.RobotScenario(**{**ROBOT_SCENARIO, **fields}), rng)


def _resample(name):
    def call(weights=np.full(5, 0.2), rng=0, n=5):
        return SCHEMES[name](weights, rng, n)
    return call


def _resampled_check(result) -> None:
    assert result.dtype == np.int64 and result.ndim == 1 and np.all(result >= 0)


# name -> (public names it exercises, call, valid keyword arguments, check of an accepted result)
ENTRY_POINTS = {
    "LinearGaussianModel + kalman_filter": (
        {"LinearGaussianModel", "kalman_filter"}, lambda **a: kalman_filter(LinearGaussianModel(**{**LG, **a}), Z2),
        dict(LG), _valid_kalman_result),
    "kalman_filter measurements": (
        {"kalman_filter"}, lambda measurements: kalman_filter(LinearGaussianModel(**LG), measurements),
        {"measurements": Z2}, _valid_kalman_result),
    "kalman_filter scalar measurements": (
        {"kalman_filter"}, lambda measurements: kalman_filter(LG1, measurements), {"measurements": Z1},
        _valid_kalman_result),
    "ParticleFilter.run (transition proposal)": (
        {"ParticleFilter", "TransitionProposal"}, _lg_pf(),
        {"measurements": Z2, "n_particles": 20, "threshold": 0.5, "rng": 0}, _valid_filter_result),
    "ParticleFilter.run (OptimalProposal)": (
        {"ParticleFilter", "OptimalProposal"}, _lg_pf(OptimalProposal()),
        {"measurements": Z2, "n_particles": 20, "rng": 0}, _valid_filter_result),
    "ParticleFilter.run scalar measurements": (
        {"ParticleFilter"}, lambda measurements: pfcourse.ParticleFilter(LG1, 20).run(measurements, 0),
        {"measurements": Z1}, _valid_filter_result),
    "StateSpaceModel": ({"StateSpaceModel"}, _ssm_pf, {"dim_x": 1, "rng": 0}, _valid_filter_result),
    "DensityProposal": ({"DensityProposal"}, _density_pf, {"proposed": np.zeros((20, 1)), "log_q": np.zeros(20)},
                        _valid_filter_result),
    **{f"resampling.{name}": ({name}, _resample(name), {"weights": np.full(5, 0.2), "rng": 0, "n": 5},
                              _resampled_check) for name in SCHEMES},
    "LandmarkScenario + simulate": (
        {"LandmarkScenario", "simulate"}, _landmark_run,
        {"rng": 0, **{k: QUADRANT[k] for k in ("n_samples", "dt", "omega", "centre", "mX0", "PX0", "Qw", "Rv",
                                                 "fov_half_angle", "fov_range")}}, _finite("truth")),
    "circle_scenario": ({"circle_scenario"}, lambda n_landmarks: landmarks.circle_scenario(n_landmarks),
                        {"n_landmarks": 5}, _finite("mX0", "PX0")),
    "rotation": ({"rotation"}, lambda angle: landmarks.rotation(angle), {"angle": 0.3}, _finite_array),
    "RobotScenario + simulate_robot": (
        {"RobotScenario", "simulate_robot"}, _robot_run,
        {"rng": 0, **{k: ROBOT_SCENARIO[k] for k in ("n_steps", "dt", "dt_meas", "gap", "q_true", "r_true", "start",
                                                    "half_width", "landmarks", "speed", "turn_rate")}},
        _finite("truth", "odometry")),
    "RobotScenario n_landmarks": ({"RobotScenario"}, lambda n_landmarks: _robot_run(landmarks=None, n_landmarks=n_landmarks),
                                  {"n_landmarks": 3}, _finite("truth", "landmarks")),
    "RobotModel + ParticleFilter": ({"RobotModel"}, _robot_pf, dict(ROBOT_MODEL_ARGS), _valid_filter_result),
    "RobotModel measurements": ({"RobotModel"}, lambda measurements: pfcourse.ParticleFilter(ROBOT_MODEL, 20).run(
        measurements, 0), {"measurements": ROBOT_Z}, _valid_filter_result),
    "TerrainModel measurements": ({"TerrainModel"}, lambda measurements: pfcourse.ParticleFilter(
        terrain.TerrainModel(TINY_TERRAIN, terrain.AircraftScenario(**AIRCRAFT)), 20).run(measurements, 0),
        {"measurements": FLIGHT.measurements}, _valid_filter_result),
    "run_ekf": ({"run_ekf"}, lambda measurements=ROBOT_Z, initial_cov=np.eye(3): robot.run_ekf(ROBOT_MODEL, measurements,
                                                                                              initial_cov),
                {"measurements": ROBOT_Z, "initial_cov": np.eye(3)}, _valid_kalman_result),
    "run_ukf": ({"run_ukf"}, lambda measurements=ROBOT_Z, initial_cov=np.eye(3), alpha=1.0:
                robot.run_ukf(ROBOT_MODEL, measurements, initial_cov, alpha=alpha),
                {"measurements": ROBOT_Z, "initial_cov": np.eye(3), "alpha": 1.0}, _valid_kalman_result),
    "motion": ({"motion"}, lambda states=STATES, controls=STATES, dt=1.0: robot.motion(states, controls, dt),
               {"states": STATES, "controls": STATES, "dt": 1.0}, _ieee),
    "range_bearing": ({"range_bearing"}, lambda states=STATES, landmark=np.array([3.0, 4.0]):
                      robot.range_bearing(states, landmark),
                      {"states": STATES, "landmark": np.array([3.0, 4.0])}, _ieee),
    "tracking_errors": ({"tracking_errors"}, lambda truth=STATES, estimate=STATES[::-1]:
                        robot.tracking_errors(truth, estimate), {"truth": STATES, "estimate": STATES[::-1]}, _ieee),
    "tracking_rmse": ({"tracking_rmse"}, lambda truth=STATES, estimate=STATES[::-1], start=0:
                      robot.tracking_rmse(truth, estimate, start),
             {"truth": STATES, "estimate": STATES[::-1], "start": 0}, _ieee),
    "AircraftScenario + simulate": (
        {"AircraftScenario", "simulate"}, _flight,
        {"rng": 0, "initial_state": FLIGHT.truth[0], **{k: AIRCRAFT[k] for k in (
            "speed", "omega", "dt", "duration", "x0", "P0", "Qf", "R", "Rf", "measurement_period")}},
        _finite("truth", "terrain_height")),
    "FieldScenario + simulate_field": (
        {"FieldScenario", "simulate_field"}, _field_flight,
        {"rng": 0, **{k: FIELD[k] for k in ("speed", "omega", "heading0", "dt", "duration", "x0", "sd0", "drift", "R")}},
        _finite("truth")),
    "TerrainMap + TerrainModel": ({"TerrainMap", "TerrainModel"}, _terrain_pf,
                                  {"heights": TINY_TERRAIN.heights, "dx": 10000.0, "dy": 10000.0}, _valid_filter_result),
    "FilterSettings.build + run": (
        {"FilterSettings"}, lambda **a: FilterSettings(**a).build(LinearGaussianModel(**LG)).run(Z2, 0),
        {"n_particles": 20, "threshold": 0.5}, _valid_filter_result),
}

#: Exported names that take no input to fuzz: the named errors, the result containers the package
#: fills (FilterResult, KalmanResult, the three simulations), constants and the argument-free factories.
NOT_FUZZED = {
    "CovarianceError", "DegenerateWeightsError", "NumericalError", "ParameterError", "PfcourseError", "ShapeError",
    "WeightError", "FilterResult", "KalmanResult", "LandmarkSimulation", "RobotSimulation", "Flight",
    "ANGLE_INDICES", "INITIAL_STD", "Q_TRUE", "R_TRUE", "quadrant_scenario", "load_jacksboro",
    # the engine's step record (filled by the engine, like FilterResult), the model's named error, and the
    # collectors, whose constructors take no argument
    "Step", "ModelError", "Collector", "Clouds", "Ancestors", "Moments", "Stages", "LastCloud", "ESS",
    "LogLikelihood", "Resampled", "Sizes",
}


def test_every_public_entry_point_is_fuzzed():
    exported = set(pfcourse.__all__) | set(landmarks.__all__) | set(robot.__all__) | set(terrain.__all__) | set(SCHEMES)
    covered = set().union(*(names for names, *_ in ENTRY_POINTS.values()))
    assert exported - NOT_FUZZED <= covered, sorted(exported - NOT_FUZZED - covered)
    assert NOT_FUZZED <= exported  # no stale exemption
    readme = " ".join((Path(__file__).parents[1] / "README.md").read_text().split())
    assert f"{len(ENTRY_POINTS)} entry points, {len(CASES)} of their parameters" in readme


CASES = [(entry, param) for entry, (_, _, valid, _) in ENTRY_POINTS.items() for param in valid]


def _outcome(call, kwargs):
    """``("ok", result)`` or ``("error", exception)`` for a named error; any other exception propagates."""
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a warning is not the answer: the result is checked instead
            return "ok", call(**kwargs)
    except PfcourseError as exc:
        return "error", exc


@pytest.mark.parametrize("entry, param", CASES, ids=[f"{e}: {p}" for e, p in CASES])
@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_entry_point_gives_a_named_error_or_a_correct_result(entry, param, data):
    _, call, valid, check = ENTRY_POINTS[entry]
    value = valid[param]
    is_array = isinstance(value, np.ndarray) or (isinstance(value, tuple) and len(value) > 1)
    mutations = ARRAY_MUTATIONS if is_array else SCALAR_MUTATIONS
    kind = data.draw(st.sampled_from(sorted(mutations)), label="mutation")
    where = data.draw(st.integers(0, 10**6), label="where")
    bad, reference = mutations[kind](np.asarray(value, dtype=float) if is_array else value, where)
    kwargs = {**valid, param: bad}
    status, result = _outcome(call, kwargs)
    if status == "error":
        assert isinstance(result, (ValueError, TypeError, FloatingPointError))  # the documented bases
        return
    check(result, kwargs) if check is _ieee else check(result)
    if reference is not None:  # the same input in another form: the same floats
        status_ref, expected = _outcome(call, {**valid, param: reference})
        assert status_ref == "ok"
        for got, want in zip(_arrays(result), _arrays(expected), strict=True):
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_valid_arguments_pass_the_checks(entry):
    """The harness itself: every entry point's valid arguments give a result its check accepts."""
    _, call, valid, check = ENTRY_POINTS[entry]
    check(call(**valid), valid) if check is _ieee else check(call(**valid))
