"""Unknown data association: identical landmarks, missed detections and clutter.

The robot of :mod:`pfcourse.scenarios.robot.scenario` reads range and bearing to landmarks, but here
the landmarks look alike: a reading does not say which landmark it comes from.  At every
measurement step (the steps where the lab's sensor sees landmark ``j``):

* the sensor detects that landmark with probability ``P_D`` (the *detection probability*),
  giving the reading ``z = h_j(x_k) + v``, ``v ~ N(0, R)``, without its index;
* independently, ``n_c ~ Poisson(lambda)`` false readings (*clutter*) appear, each uniform
  over the sensor's range ``[0, r_max]`` and bearing ``(-pi, pi]``, of density
  ``c(z) = 1 / (2 pi r_max)``;
* the readings of the step are shuffled (their order says nothing).

**Likelihood of one step's readings** ``Z = {z_1, ..., z_n}`` (the set-density of this
model: at most one reading is the landmark's, the others are Poisson clutter)::

    p(Z | x) = e^{-lambda} [ (1 - P_D) lambda^n prod_l c(z_l)
                             + sum_i (P_D / M) sum_j N(z_i; h_j(x), R) lambda^{n-1} prod_{l != i} c(z_l) ],

the first term "missed, all readings are clutter", the others "reading ``i`` comes from
landmark ``j`` (each landmark equally likely to be the one looked at, ``1/M``), the rest is
clutter".  For one reading (``n = 1``) it is the mixture

    p(z | x) = e^{-lambda} [ (1 - P_D) lambda c(z) + sum_j (P_D / M) N(z; h_j(x), R) ],

which with ``P_D = 1``, ``lambda = 0`` and ``M = 1`` is the known-association likelihood of
:class:`~pfcourse.scenarios.robot.RobotModel`.  In the log domain every term is a log, and the sum is
one ``logsumexp`` over ``n M + 1`` terms per particle (:func:`mixture_log_likelihood`).
A step with no reading has ``p = (1 - P_D) e^{-lambda}``, the same for every state: it
leaves the weights unchanged (the engine skips it).

**The EKF must choose** (:func:`run_nn_ekf`): the nearest-neighbour standard filter
(Bar-Shalom, Daum and Huang 2009) computes, for every reading ``i`` and landmark ``j``, the
Mahalanobis distance ``d_ij^2 = nu_ij^T S_j^{-1} nu_ij``, ``nu_ij = z_i - h_j(m)``,
``S_j = H_j P H_j^T + R``, and updates once a step with the single pair of smallest ``d_ij^2``,
if it is inside the *gate* ``d_ij^2 <= gamma`` (a chi-square quantile with two degrees of
freedom); every other reading is taken for clutter.  ``rule="sequential"`` is the variant the
book first used (*sequential nearest neighbour*): every reading in turn, each gated one updating
with its nearest landmark before the next is associated, so that a step can bring several updates.

**The PDA filter** (:func:`run_pdaf`, Bar-Shalom and Tse 1975) does not choose: it linearises
``h_j`` at the predicted mean, so that under the Gaussian prediction ``N(m, P)`` the posterior of
the step is a mixture over the same origins as the particle filter's likelihood, one Kalman update
per event "reading ``i`` from landmark ``j``" and one "every reading is clutter" (the prediction
itself), weighted ``beta_0 ~ (1 - P_D P_G) lambda c`` and ``beta_ij ~ (P_D / M) N(z_i; h_j(m), S_j)``
(``P_G`` the gate probability, readings outside the gate of ``j`` left out); it keeps that
mixture's mean and covariance (:func:`pda_update`).

**How the data reach a filter**: :func:`simulate_readings` returns ``(K, C, 2)`` readings
``(range, bearing)``, rows of NaN padding each step to ``C`` (the largest count of the
run, at least 1), and the origin of each reading, ``(K, C)`` (the landmark's index, ``-1``
for clutter, ``-2`` for padding), which the filters never see.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.special import logsumexp, xlogy

from pfcourse.angles import wrap, wrap_angle
from pfcourse.checks import Array, as_generator, check_estimate, check_probability, check_real, numerical_step
from pfcourse.errors import MeasurementError, ModelError, ParameterError, ShapeError
from pfcourse.results import KalmanResult
from pfcourse.scenarios.robot.kalman import measurement_jacobian, measurement_residual, motion_jacobians, range_bearing_one
from pfcourse.scenarios.robot.scenario import RobotModel, RobotSimulation, motion

#: The chi-square gate of the nearest-neighbour EKF: 99 % of a correct reading's d^2 falls below it.
GATE_PROBABILITY = 0.99


@dataclass(frozen=True)
class ClutterSensor:
    """Detection probability ``p_detect`` (``P_D``), mean number of clutter readings per measurement
    step ``clutter_rate`` (``lambda``) and the sensor's maximum range ``max_range`` (m)."""

    p_detect: float = 0.9
    clutter_rate: float = 1.0
    max_range: float = 200.0

    def __post_init__(self) -> None:
        check_probability(self.p_detect, "p_detect")
        check_real(self.clutter_rate, "clutter_rate", low=0.0, high=1e6)
        check_real(self.max_range, "max_range", low=0.0, low_open=True, high=1e12)

    @property
    def clutter_log_density(self) -> float:
        """``log c(z) = -log(2 pi r_max)``: uniform over range and bearing."""
        return -float(np.log(2.0 * np.pi * self.max_range))


@dataclass(frozen=True)
class AnonymousReadings:
    """``readings`` ``(K, C, 2)`` (range, bearing; NaN rows pad a step) and ``origin`` ``(K, C)``
    (landmark index, ``-1`` clutter, ``-2`` padding)."""

    readings: Array
    origin: Array

    @property
    def counts(self) -> Array:
        """Number of readings at each step, ``(K,)``."""
        return np.sum(self.origin >= -1, axis=1)

    @property
    def clutter_counts(self) -> Array:
        """Number of clutter readings at each step, ``(K,)``."""
        return np.sum(self.origin == -1, axis=1)


def simulate_readings(sim: RobotSimulation, sensor: ClutterSensor, rng: np.random.Generator | int) -> AnonymousReadings:
    """The anonymous readings of run ``sim`` (module docstring): detections of the landmark the lab's
    sensor looks at, kept with probability ``P_D``, plus Poisson clutter, shuffled within each step.

    Four streams spawned from ``rng`` (detections, clutter counts, clutter readings, order), each
    drawn for every step, so a run's detections are the same whatever the clutter rate.
    """
    if not isinstance(sim, RobotSimulation):
        raise ParameterError(f"sim must be a RobotSimulation, got {type(sim).__name__}")
    if not isinstance(sensor, ClutterSensor):
        raise ParameterError(f"sensor must be a ClutterSensor, got {type(sensor).__name__}")
    detect_rng, count_rng, clutter_rng, order_rng = as_generator(rng).spawn(4)
    K = len(sim.measurements)
    measured = sim.has_measurement
    detected = (detect_rng.random(K) < sensor.p_detect) & measured
    n_clutter = np.where(measured, count_rng.poisson(sensor.clutter_rate, K), 0)
    width = max(1, int(np.max(detected + n_clutter)))
    readings = np.full((K, width, 2), np.nan)
    origin = np.full((K, width), -2, dtype=int)
    for k in np.flatnonzero(measured):
        fake = np.column_stack([clutter_rng.uniform(0.0, sensor.max_range, n_clutter[k]),
                                wrap_angle(clutter_rng.uniform(-np.pi, np.pi, n_clutter[k]))])
        rows = [fake]
        who = [np.full(n_clutter[k], -1)]
        if detected[k]:
            rows.append(sim.measurements[k, 1:][None])
            who.append(np.array([sim.landmark_index[k]]))
        rows, who = np.concatenate(rows), np.concatenate(who)
        order = order_rng.permutation(len(rows))
        readings[k, : len(rows)] = rows[order]
        origin[k, : len(rows)] = who[order]
    return AnonymousReadings(readings, origin)


def _present_readings(z: Array, k: int) -> Array:
    """The readings of one step, ``(n, 2)`` without the NaN padding."""
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or z.shape[1] != 2:
        raise ShapeError(f"step {k}: anonymous readings are (C, 2) rows of (range, bearing), got shape {z.shape}")
    present = ~np.isnan(z).all(axis=1)
    z = z[present]
    if not np.isfinite(z).all():
        raise MeasurementError(f"step {k}: a reading must have a finite range and bearing (or be a NaN row), got {z}")
    return z


def mixture_log_likelihood(base: RobotModel, sensor: ClutterSensor, particles: Array, z: Array, k: int = 0) -> Array:
    """``log p(Z | x^i)`` for every particle (module docstring), ``(N,)``.

    ``log p = -lambda + logsumexp( log(1 - P_D) + n log lambda + n log c,
                                   log(P_D / M) + log N(z_i; h_j(x), R) + (n - 1) log lambda + (n - 1) log c )``
    over the readings ``i`` and the landmarks ``j`` of ``base`` (``0 log 0 = 0``).
    """
    z = _present_readings(z, k)
    n, M = len(z), len(base.landmarks)
    lam, log_c = sensor.clutter_rate, sensor.clutter_log_density
    terms = [np.full(len(particles), np.log1p(-sensor.p_detect) if sensor.p_detect < 1 else -np.inf)
             + xlogy(n, lam) + n * log_c]
    shared = (np.log(sensor.p_detect) if sensor.p_detect > 0 else -np.inf) - np.log(M) + xlogy(n - 1, lam) + (n - 1) * log_c
    for r, b in z:
        for j in range(M):
            terms.append(shared + base.log_likelihood(particles, np.array([j, r, b]), k))
    with np.errstate(divide="ignore"):
        return logsumexp(np.array(terms), axis=0) - lam


class AssociationModel:
    """The robot with anonymous readings, a :class:`pfcourse.filter.Model`: the motion, the initial
    cloud and the map of ``base`` (a :class:`~pfcourse.scenarios.robot.RobotModel`), the likelihood of
    :func:`mixture_log_likelihood`.  Measurements are ``(K, C, 2)`` (:func:`simulate_readings`)."""

    def __init__(self, base: RobotModel, sensor: ClutterSensor) -> None:
        if not isinstance(base, RobotModel):
            raise ModelError(f"base must be a RobotModel, got {type(base).__name__}")
        if not isinstance(sensor, ClutterSensor):
            raise ParameterError(f"sensor must be a ClutterSensor, got {type(sensor).__name__}")
        self.base, self.sensor = base, sensor
        self.dim_x, self.angle_indices = base.dim_x, base.angle_indices

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """The initial cloud of ``base``."""
        return self.base.sample_initial(n, rng)

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """The odometry transition of ``base``."""
        return self.base.sample_transition(particles, k, rng)

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """The mixture over associations, :func:`mixture_log_likelihood`."""
        return mixture_log_likelihood(self.base, self.sensor, particles, z, k)


NN_RULES = ("nearest", "sequential")


def gate_threshold(gate_probability: float, dim: int = 2) -> float:
    """The chi-square gate ``gamma = chi2_dim.ppf(P_G)``: a correct reading's ``d^2 = nu^T S^{-1} nu`` (``dim``
    degrees of freedom) falls below it with probability ``P_G`` = ``gate_probability``, which must lie strictly
    between 0 and 1 (:class:`ParameterError` otherwise)."""
    p = check_probability(gate_probability, "gate_probability")
    if not 0 < p < 1:
        raise ParameterError(f"gate_probability must lie strictly between 0 and 1, got {p}")
    return float(stats.chi2.ppf(p, dim))


def innovation_distance(cov: Array, H: Array, R: Array, nu: Array) -> tuple[Array, float]:
    """The innovation covariance ``S = H P H^T + R`` and the squared Mahalanobis distance
    ``d^2 = nu^T S^{-1} nu`` of the innovation ``nu``, the quantity both the nearest-neighbour choice and the
    PDA gate compare."""
    S = H @ cov @ H.T + R
    return S, float(nu @ np.linalg.solve(S, nu))


def joseph_update(mean: Array, cov: Array, H: Array, R: Array, S: Array, nu: Array) -> tuple[Array, Array, Array]:
    """One Kalman update in Joseph form: ``K = P H^T S^{-1}``, ``m' = m + K nu``,
    ``P' = (I - K H) P (I - K H)^T + K R K^T`` (symmetric and positive for any gain); returns ``(m', P', K)``."""
    gain = np.linalg.solve(S, H @ cov).T  # P H^T S^-1 (S and P symmetric)
    IKH = np.eye(len(mean)) - gain @ H
    return mean + gain @ nu, IKH @ cov @ IKH.T + gain @ R @ gain.T, gain


def _checked_run(model: AssociationModel, readings: Array, gate_probability: float | None, initial_cov: Array | None,
                 name: str, gate_optional: bool) -> tuple[Array, RobotModel, Array, Array]:
    """The checks shared by :func:`run_nn_ekf` and :func:`run_pdaf` (``name``), in that order: the model, the gate
    (``None``, no gate, where ``gate_optional``), the readings' shape ``(K, C, 2)`` and the odometry's length. Returns
    the readings as floats, the robot model and the EKF's start ``x_0``, ``P_0`` (``initial_cov``, or the model's
    initial standard deviations squared on the diagonal)."""
    if not isinstance(model, AssociationModel):
        raise ModelError(f"{name} needs an AssociationModel, got {type(model).__name__}")
    if gate_probability is not None or not gate_optional:
        gate_threshold(gate_probability)
    readings = np.asarray(readings, dtype=float)
    if readings.ndim != 3 or readings.shape[2] != 2:
        raise ShapeError(f"readings must have shape (K, C, 2), got {readings.shape}")
    base = model.base
    if len(readings) > len(base.odometry):
        raise ShapeError(f"{len(readings)} steps of readings but only {len(base.odometry)} odometry rows")
    x = np.array(base.start, dtype=float)
    P = np.diag(np.asarray(base.initial_std, dtype=float) ** 2) if initial_cov is None else np.array(initial_cov, float)
    return readings, base, x, P


def _ekf_predict(x: Array, P: Array, base: RobotModel, k: int) -> tuple[Array, Array]:
    """The EKF's prediction through odometry ``u_k``: ``x^- = f(x, u_k)``, ``P^- = F P F^T + G Q G^T`` with
    ``F``, ``G`` the motion's Jacobians in the state and the control at ``x``."""
    u = base.odometry[k]
    F, G = motion_jacobians(x, u, base.dt)
    return motion(x, u, base.dt), F @ P @ F.T + G @ base.q_est @ G.T


def run_nn_ekf(model: AssociationModel, readings: Array, gate_probability: float = GATE_PROBABILITY,
               initial_cov: Array | None = None, rule: str = "nearest") -> tuple[KalmanResult, Array]:
    """The EKF of :mod:`pfcourse.scenarios.robot.kalman` that chooses an association: nearest neighbour by
    Mahalanobis distance, gated at ``gamma = chi2_2.ppf(gate_probability)`` (module docstring).

    ``rule="nearest"`` (the nearest-neighbour standard filter): at each step the one gated pair
    (reading, landmark) of smallest distance updates the mean and covariance, once.
    ``rule="sequential"``: the readings are taken one at a time, in their (shuffled) order; each
    gated one updates with its nearest landmark before the next is associated.  Returns the result
    and the ``(K, C)`` chosen landmark of each reading (``-1``: not used, taken for clutter;
    ``-2``: padding).
    """
    if rule not in NN_RULES:
        raise ParameterError(f"rule must be one of {NN_RULES}, got {rule!r}")
    readings, base, x, P = _checked_run(model, readings, gate_probability, initial_cov, "run_nn_ekf", False)
    gamma = gate_threshold(gate_probability)
    R = base.r_est
    out = KalmanResult.empty(len(readings), 3, 2, "NN-EKF")
    chosen = np.full(readings.shape[:2], -2, dtype=int)
    for k in range(len(readings)):
        with numerical_step(k, "NN-EKF"):
            if k > 0:
                x, P = _ekf_predict(x, P, base, k)
            present = [i for i, z in enumerate(readings[k]) if not np.isnan(z).all()]
            for i in present:
                if not np.isfinite(readings[k, i]).all():
                    raise MeasurementError(f"step {k}: a reading must have a finite range and bearing, "
                                           f"got {readings[k, i]}")
                chosen[k, i] = -1
            groups = [present] if rule == "nearest" else [[i] for i in present]
            for group in groups:
                d2, best = np.inf, None
                for i in group:
                    for j, landmark in enumerate(base.landmarks):
                        H = measurement_jacobian(x, landmark)
                        nu = measurement_residual(readings[k, i], range_bearing_one(x, landmark))
                        S, dj = innovation_distance(P, H, R, nu)
                        if dj < d2:
                            d2, best = dj, (i, j, H, S, nu)
                if d2 > gamma:
                    continue
                i, j, H, S, nu = best
                predicted = x.copy()
                x, P, gain = joseph_update(x, P, H, R, S, nu)
                x[2] = wrap(float(x[2]))
                chosen[k, i] = j
                out.record_update(k, predicted, nu, S, gain)
        check_estimate(k, "NN-EKF", x, P)
        out.mean[k] = x
        out.cov[k] = P
    return out, chosen


def pda_update(mean: Array, cov: Array, readings: Array, predicted: Array, jacobians: Array, R: Array,
               sensor: ClutterSensor, gate_probability: float | None = GATE_PROBABILITY,
               angle_index: int | None = 1) -> tuple[Array, Array, Array]:
    """One probabilistic data association update (Bar-Shalom and Tse 1975) over ``M`` look-alike origins.

    ``readings`` ``(n, 2)`` (no padding), ``predicted`` ``(M, 2)`` the predicted reading ``h_j(m)`` of
    each landmark and ``jacobians`` ``(M, 2, d)`` its Jacobian at ``mean``; ``R`` the measurement
    covariance.  Events: ``0``, every reading is clutter (weight ``(1 - P_D P_G) lambda c``, the
    prediction unchanged); ``(i, j)``, reading ``i`` comes from landmark ``j`` (weight
    ``(P_D / M) N(z_i; h_j(m), S_j)``, its Kalman update), kept when ``d_ij^2 <= gamma`` (the gate;
    ``gate_probability=None``: no gate, ``P_G = 1``).  Returns the moment-matched mean and
    covariance of the mixture of the events' posteriors, and the events' probabilities
    ``(1 + n M,)`` (``beta_0`` first, then ``beta_ij`` row by row; 0 outside the gate).
    The innovation's component ``angle_index`` is wrapped to ``(-pi, pi]``.
    """
    mean, cov = np.asarray(mean, float), np.asarray(cov, float)
    z = np.asarray(readings, float).reshape(-1, 2)
    n, M = len(z), len(predicted)
    if gate_probability is None:
        gamma, p_gate = np.inf, 1.0
    else:
        p_gate = check_probability(gate_probability, "gate_probability")
        gamma = gate_threshold(p_gate, z.shape[1])
    lam, log_c = sensor.clutter_rate, sensor.clutter_log_density
    with np.errstate(divide="ignore"):
        log_beta = [np.log1p(-sensor.p_detect * p_gate) + np.log(lam) + log_c if lam > 0 else -np.inf]
    means, covs = [mean], [cov]
    for i in range(n):
        for j in range(M):
            H = jacobians[j]
            nu = z[i] - predicted[j]
            if angle_index is not None:
                nu[angle_index] = wrap(float(nu[angle_index]))
            S, d2 = innovation_distance(cov, H, R, nu)
            if d2 > gamma:
                log_beta.append(-np.inf)
                means.append(mean)
                covs.append(cov)
                continue
            new_mean, new_cov, _ = joseph_update(mean, cov, H, R, S, nu)
            means.append(new_mean)
            covs.append(new_cov)
            log_beta.append(np.log(sensor.p_detect / M) - 0.5 * (d2 + np.linalg.slogdet(2 * np.pi * S)[1]))
    log_beta = np.array(log_beta)
    if not np.isfinite(log_beta).any():  # nothing in any gate and no clutter: nothing to learn
        return mean, cov, np.r_[1.0, np.zeros(n * M)]
    beta = np.exp(log_beta - logsumexp(log_beta))
    means, covs = np.array(means), np.array(covs)
    new_mean = beta @ means
    spread = means - new_mean
    new_cov = np.einsum("e,eab->ab", beta, covs) + np.einsum("e,ea,eb->ab", beta, spread, spread)
    return new_mean, 0.5 * (new_cov + new_cov.T), beta


def run_pdaf(model: AssociationModel, readings: Array, gate_probability: float | None = GATE_PROBABILITY,
             initial_cov: Array | None = None) -> tuple[KalmanResult, Array]:
    """The EKF of :mod:`pfcourse.scenarios.robot.kalman` with probabilistic data association (:func:`pda_update`):
    at each step with readings, every reading and every landmark at once, no choice made.

    Returns the result and the ``(K,)`` probability the filter gave, at each step, to "every
    reading is clutter" (``beta_0``; 1 at a step without readings).
    """
    readings, base, x, P = _checked_run(model, readings, gate_probability, initial_cov, "run_pdaf", True)
    out = KalmanResult.empty(len(readings), 3, 2, "PDAF")
    none_true = np.ones(len(readings))
    for k in range(len(readings)):
        with numerical_step(k, "PDAF"):
            if k > 0:
                x, P = _ekf_predict(x, P, base, k)
            z = _present_readings(readings[k], k)
            if len(z):
                predicted = np.array([range_bearing_one(x, landmark) for landmark in base.landmarks])
                jacobians = np.array([measurement_jacobian(x, landmark) for landmark in base.landmarks])
                x, P, beta = pda_update(x, P, z, predicted, jacobians, base.r_est, model.sensor, gate_probability)
                x[2] = wrap(float(x[2]))
                none_true[k] = beta[0]
        check_estimate(k, "PDAF", x, P)
        out.mean[k] = x
        out.cov[k] = P
    return out, none_true


__all__ = ["AnonymousReadings", "AssociationModel", "ClutterSensor", "GATE_PROBABILITY", "NN_RULES", "gate_threshold",
           "innovation_distance", "joseph_update", "mixture_log_likelihood", "pda_update", "run_nn_ekf", "run_pdaf",
           "simulate_readings"]
