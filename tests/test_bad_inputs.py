"""Table of bad inputs to the public API (issue 14, "every bad input named").

Each row: a label, a call that feeds one bad input, the named ``pfcourse.errors`` class it
must raise and a fragment of the message (what was wrong, and at which step inside a run).
Rows whose expected class is ``None`` are valid but unusual inputs with a documented
treatment; their check function asserts that treatment.
"""

from __future__ import annotations

import numpy as np
import pytest

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
from pfcourse.landmarks.model import LinearGaussianModel
from pfcourse.landmarks.scenario import quadrant_scenario
from pfcourse.diagnostics import nees, nis
from pfcourse.experiments.study import SerialExecutor, run_study
from pfcourse.robot import RobotScenario, simulate_robot
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
row("rng = 'seed'", lambda: run(rng="seed"), ModelError, "rng")
row("rng = True", lambda: run(rng=True), ModelError, "rng")
row("rng = -1", lambda: run(rng=-1), ModelError, "rng")
row("rng = 1.5", lambda: run(rng=1.5), ModelError, "rng")

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
        ("n=0", W, 0, ParameterError, "n must be >= 1"),
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
row("store_particles with a variable N",
    lambda: ParticleFilter(rw_model(), N, sample_size=KLDSampling([1.0])).run(Z, 0, store_particles=True),
    ParameterError, "store_particles needs a fixed number")


# --- valid but unusual: documented treatments -------------------------------------------
def _offset(c):
    """Weights are invariant to a constant: the filter's answer moves only by the model's own
    rounding of ``c + log p`` (relative 2**-52 of ``c``), and the weights stay normalised."""
    base = run(rw_model())
    shifted = ParticleFilter(rw_model(loglik=lambda x, z, k: c - 0.5 * (z[0] - x[:, 0]) ** 2), N).run(
        Z, 0, store_particles=True)
    assert np.allclose(shifted.weights.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(np.isfinite(shifted.mean)) and np.all(np.isfinite(shifted.log_likelihood_increments))
    if abs(c) <= 1e9:  # the model's rounding of c - r^2/2 is 1e9 * 2**-53 ~ 1e-7 per particle
        np.testing.assert_allclose(shifted.mean, base.mean, atol=1e-5)
        np.testing.assert_allclose(shifted.log_likelihood_increments - c, base.log_likelihood_increments, atol=1e-5)


for c in [1e9, -1e9, 1e300, -1e300]:
    row(f"constant log-likelihood offset {c:g} (weights invariant)", lambda c=c: _offset(c), None, "invariant")


def _pm_1e308():
    r = ParticleFilter(rw_model(loglik=lambda x, z, k: np.where(np.arange(len(x)) % 2 == 0, 1e308, -1e308)), N,
                       threshold=0.0).run(Z, 0, store_particles=True)
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
    assert len(ROWS) >= 130
