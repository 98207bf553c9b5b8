"""Monte Carlo localization that recovers: global localization and the kidnapped robot.

Three remedies for the bootstrap filter's failure from a uniform prior, on the robot of
:mod:`pfcourse.scenarios.robot` (state ``x = (p_x, p_y, theta)``, map ``[-w, w]^2``):

**1. A model that admits kidnapping, and a proposal from the measurement (mixture MCL).**
:class:`KidnapRobotModel` wraps a :class:`~pfcourse.scenarios.robot.RobotModel` and gives the robot,
at every step, a small probability ``eps`` of being teleported to a uniform pose::

    p(x_k | x_{k-1}) = (1 - eps_k) p_odo(x_k | x_{k-1}) + eps_k u(x_k),
    u(x) = 1 / (4 w^2 * 2 pi)  on the map, 0 outside,

with ``eps_1 = 1`` for global localization (the robot knows nothing at its first
measurement: ``x_1`` is uniform) and ``eps_k = eps`` afterwards.  ``p_odo`` is the
odometry transition ``x_k = f(x_{k-1}, u~_k + w)``, ``w ~ N(0, QEst)``, whose density is
``N(w; 0, QEst) / dt^3`` at the unique ``w`` that maps ``x_{k-1}`` to ``x_k``.

:func:`sensor_mixture_proposal` draws particle ``i`` from the mixture

    q(x_k | x_{k-1}^i, z_k) = (1 - phi_k) p_odo(x_k | x_{k-1}^i) + phi_k q_z(x_k),

where ``q_z`` places the robot where the reading ``z = (j, r, b)`` of landmark ``l^j``
says it may be: ``r' ~ N+(r, s_r^2)`` (truncated to ``r' > 0``), ``b' ~ N(b, s_b^2)``,
``phi ~ U(-pi, pi)``, ``p = l^j + r' (cos phi, sin phi)``, ``theta = wrap(phi + pi - b')``.
The map ``(r', phi, b') -> x`` has Jacobian determinant ``1 / r'``, so

    q_z(x) = N(h_r(x); r, s_r^2) N(wrap(b - h_b(x)); 0, s_b^2) / (Phi(r / s_r) 2 pi h_r(x)).

The weight is the engine's (:class:`pfcourse.proposals.DensityProposal`),
``log w = log p(z | x) + log p(x | x^i) - log q(x | x^i, z)``: an importance sampler of the
kidnap model's posterior, so the posterior is not biased.  ``phi_k = 1`` when ``eps_k = 1``
(every particle from the reading: exact importance sampling of ``p(x_1 | z_1)``).  This is
sensor resetting (Lenser and Veloso 2000) and mixture MCL (Thrun et al. 2001) with the
weights of the model that justifies them.

**2. Random injection driven by the likelihood (augmented MCL).**  :class:`AugmentedMCL`
(Thrun, Burgard and Fox 2005, table 8.3) keeps two exponential averages of the mean
likelihood ``w_avg = (1/N) sum_i p(z_k | x_k^i)`` (weights are uniform: it resamples at
every measurement),

    w_slow += a_slow (w_avg - w_slow),   w_fast += a_fast (w_avg - w_fast),

and after resampling replaces each particle, with probability ``max(0, 1 - w_fast / w_slow)``,
by a pose drawn from ``q_z`` (the current reading) or from ``u``.  It is a heuristic: the
injected particles are not weighted.

**3. KLD-sampling (Fox 2003).**  :func:`kld_filter` runs the engine with a
:class:`~pfcourse.sample_size.KLDSampling` policy: at every measurement step it draws particles
until their number exceeds the bound

    n(k) = (k - 1) / (2 eps) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_{1-delta})^3

(:func:`kld_bound`, the Wilson-Hilferty form of ``chi2_{k-1, 1-delta} / (2 eps)``), where
``k`` is the number of histogram bins the new particles occupy: with probability
``1 - delta`` the Kullback-Leibler divergence between the sample-based and the true binned
posterior is below ``eps``.  The number of particles follows the spread of the cloud.

:func:`run_settings` filters one simulation with one of these methods, the named configurations
:data:`FILTERS`, each a :class:`~pfcourse.filter_config.FilterSettings` record; the study runs (a whole
seeded experiment and its metrics, the lock-on window, the wrong-but-confident threshold) are
in :mod:`pfcourse.studies.global_localization`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.special import logsumexp

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_probability
from pfcourse.collectors import Stages
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.filter_config import FilterConfig, FilterSettings, configurations, lookup
from pfcourse.metrics import position_error
from pfcourse.results import FilterResult
from pfcourse.jitter import RegularisedJitter
from pfcourse.proposals import DensityProposal, ProgressiveCorrection
from pfcourse.sample_size import KLDSampling, kld_bound  # noqa: F401  (kld_bound: re-exported for the chapter)
from pfcourse.seeding import kidnap_rng
from pfcourse.scenarios.robot.scenario import ANGLE_INDICES, RobotModel, RobotSimulation, motion, range_bearing

_LOG_2PI = math.log(2.0 * math.pi)


class KidnapRobotModel:
    """The robot with a teleport probability: ``p(x_k | x_{k-1}) = (1 - eps_k) p_odo + eps_k u`` (module docstring).

    ``base`` gives the odometry, the covariances, the landmarks and the likelihood;
    ``teleport`` is ``eps``; ``global_start=True`` sets ``eps_1 = 1`` (uniform prior at the
    first step), ``False`` starts from ``base``'s initial cloud.
    """

    dim_x = 3
    angle_indices = ANGLE_INDICES

    def __init__(self, base: RobotModel, teleport: float = 1e-3, *, global_start: bool = True) -> None:
        self.base = base
        self.teleport = check_probability(teleport, "teleport")
        self.global_start = bool(global_start)
        self.half_width = base.half_width
        self.log_u = -math.log((2.0 * base.half_width) ** 2 * 2.0 * math.pi)
        q = np.asarray(base.q_est, dtype=float)
        self._q_inv = np.linalg.inv(q)
        self._q_log_norm = -1.5 * _LOG_2PI - 0.5 * float(np.linalg.slogdet(q)[1]) - 3.0 * math.log(base.dt)

    def eps(self, k: int) -> float:
        """Teleport probability of the step into ``x_k``."""
        return 1.0 if (self.global_start and k == 1) else self.teleport

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """``base``'s initial cloud (uniform if ``global_start``)."""
        if self.global_start:
            return uniform_poses(n, self.half_width, rng)
        return self.base.sample_initial(n, rng)

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """Odometry move, then each particle teleported to a uniform pose with probability ``eps_k``."""
        new = self.base.sample_transition(particles, k, rng)
        eps = self.eps(k)
        if eps > 0:
            jump = rng.random(len(new)) < eps
            new[jump] = uniform_poses(int(jump.sum()), self.half_width, rng)
        return new

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        return self.base.log_likelihood(particles, z, k)

    def log_uniform(self, x: Array) -> Array:
        """``log u(x)``: ``-log(4 w^2 2 pi)`` on the map, ``-inf`` off it."""
        inside = np.all(np.abs(x[:, :2]) <= self.half_width, axis=1)
        return np.where(inside, self.log_u, -np.inf)

    def odometry_log_density(self, new: Array, old: Array, k: int) -> Array:
        """``log p_odo(x_k | x_{k-1}) = log N(w; 0, QEst) - 3 log dt`` with ``w`` the noise mapping old to new."""
        dt = self.base.dt
        c, s = np.cos(old[:, 2]), np.sin(old[:, 2])
        dx, dy = new[:, 0] - old[:, 0], new[:, 1] - old[:, 1]
        w = np.empty((len(new), 3))
        w[:, 0] = (c * dx + s * dy) / dt
        w[:, 1] = (-s * dx + c * dy) / dt
        w[:, 2] = wrap_angle(new[:, 2] - old[:, 2]) / dt
        w -= self.base.odometry[k]
        return self._q_log_norm - 0.5 * np.einsum("ni,ij,nj->n", w, self._q_inv, w)

    def transition_log_density(self, new: Array, old: Array, k: int) -> Array:
        """``log[(1 - eps_k) p_odo(new | old) + eps_k u(new)]``."""
        eps = self.eps(k)
        parts = []
        if eps < 1:
            parts.append(math.log1p(-eps) + self.odometry_log_density(new, old, k))
        if eps > 0:
            parts.append(math.log(eps) + self.log_uniform(new))
        return parts[0] if len(parts) == 1 else np.logaddexp(parts[0], parts[1])


def uniform_poses(n: int, half_width: float, rng: np.random.Generator) -> Array:
    """``n`` poses uniform on ``[-w, w]^2 x (-pi, pi]``."""
    x = np.empty((n, 3))
    x[:, :2] = rng.uniform(-half_width, half_width, size=(n, 2))
    x[:, 2] = wrap_angle(rng.uniform(-np.pi, np.pi, size=n))
    return x


@dataclass(frozen=True)
class SensorPoseSampler:
    """``q_z``: poses consistent with one range-bearing reading (module docstring).

    ``landmarks`` ``(M, 2)``; ``r_cov`` the diagonal 2x2 covariance of the drawn reading
    (the filter's ``REst`` times ``spread**2``).
    """

    landmarks: Array
    r_cov: Array

    def __post_init__(self) -> None:
        r = np.asarray(self.r_cov, dtype=float)
        if r.shape != (2, 2) or r[0, 1] != 0 or r[1, 0] != 0 or not np.all(np.diag(r) > 0):
            raise ParameterError(f"the sensor proposal needs a diagonal positive 2x2 covariance, got {r.tolist()}")

    @property
    def sd(self) -> Array:
        return np.sqrt(np.diag(self.r_cov))

    def sample(self, z: Array, n: int, rng: np.random.Generator) -> Array:
        """Draw ``n`` poses from ``q_z`` for the reading ``z = (j, r, b)``."""
        j, r, b = int(z[0]), float(z[1]), float(z[2])
        s_r, s_b = self.sd
        ranges = r + s_r * rng.standard_normal(n)
        bad = ranges <= 0
        while bad.any():  # N+ : redraw the (rare) non-positive ranges
            ranges[bad] = r + s_r * rng.standard_normal(int(bad.sum()))
            bad = ranges <= 0
        bearings = b + s_b * rng.standard_normal(n)
        phi = rng.uniform(-np.pi, np.pi, n)
        x = np.empty((n, 3))
        x[:, 0] = self.landmarks[j, 0] + ranges * np.cos(phi)
        x[:, 1] = self.landmarks[j, 1] + ranges * np.sin(phi)
        x[:, 2] = wrap_angle(phi + np.pi - bearings)
        return x

    def log_density(self, x: Array, z: Array) -> Array:
        """``log q_z(x)`` (module docstring; the bearing's wrapped normal is kept to its main term)."""
        j, r, b = int(z[0]), float(z[1]), float(z[2])
        s_r, s_b = self.sd
        h = range_bearing(x, self.landmarks[j])
        nu_r = (r - h[:, 0]) / s_r
        nu_b = wrap_angle(b - h[:, 1]) / s_b
        return (-_LOG_2PI - math.log(s_r * s_b) - 0.5 * (nu_r**2 + nu_b**2)
                - stats.norm.logcdf(r / s_r) - _LOG_2PI - np.log(h[:, 0]))


def sensor_mixture_proposal(model: KidnapRobotModel, share: float = 0.1, spread: float = 1.0) -> DensityProposal:
    """The mixture ``(1 - phi_k) p_odo + phi_k q_z`` as an engine :class:`~pfcourse.proposals.DensityProposal`.

    ``phi_k = share``, or 1 at a step whose prior is uniform (``model.eps(k) == 1``).
    ``spread`` scales the standard deviations of the drawn reading (1: the filter's ``REst``).
    """
    share = check_probability(share, "share")
    if not spread > 0:
        raise ParameterError(f"spread must be positive, got {spread}")
    sensor = SensorPoseSampler(model.base.landmarks, spread**2 * np.asarray(model.base.r_est, dtype=float))

    def phi(k: int) -> float:
        return 1.0 if model.eps(k) == 1.0 else share

    def sample(particles: Array, z: Array, k: int, rng: np.random.Generator) -> Array:
        new = model.base.sample_transition(particles, k, rng)
        pick = rng.random(len(new)) < phi(k)
        new[pick] = sensor.sample(z, int(pick.sum()), rng)
        return new

    def log_density(new: Array, particles: Array, z: Array, k: int) -> Array:
        p = phi(k)
        log_q = np.log(p) + sensor.log_density(new, z) if p > 0 else np.full(len(new), -np.inf)
        if p < 1:
            log_q = np.logaddexp(math.log1p(-p) + model.odometry_log_density(new, particles, k), log_q)
        return log_q

    return DensityProposal(sample, log_density)


class AugmentedMCL:
    """Augmented MCL: a bootstrap proposal that tracks ``w_slow``, ``w_fast`` and a jitter that injects.

    Use one object as both the ``proposal`` and the ``jitter`` of a
    :class:`~pfcourse.filter.ParticleFilter` with ``threshold=1`` (uniform weights before each
    measurement, so the mean likelihood is ``w_avg``).  ``source`` is ``"sensor"`` (poses from
    ``q_z`` of the current reading, Lenser and Veloso 2000) or ``"uniform"``.
    ``injected`` records, per resampling, the injection probability ``max(0, 1 - w_fast / w_slow)``.
    Made without ``model`` (a template of a filter's settings), it draws on the model it is given by
    :meth:`for_model`, or else on the filter's at its first proposal.
    """

    #: what a filter's settings record of it (:func:`pfcourse.filter_config.describe`): not its state
    settings_fields = ("alpha_slow", "alpha_fast", "source")
    label = "augmented MCL"

    def __init__(self, model: RobotModel | None = None, *, alpha_slow: float = 0.01, alpha_fast: float = 0.1,
                 source: str = "sensor") -> None:
        if not 0 < alpha_slow < alpha_fast <= 1:
            raise ParameterError(f"need 0 < alpha_slow < alpha_fast <= 1, got {alpha_slow}, {alpha_fast}")
        if source not in ("sensor", "uniform"):
            raise ParameterError(f"source must be 'sensor' or 'uniform', got {source!r}")
        self.alpha_slow, self.alpha_fast, self.source = float(alpha_slow), float(alpha_fast), source
        self.model = self.sensor = None
        if model is not None:
            self.for_model(model)
        self.start()

    def start(self) -> None:
        """Called by the filter before step 0 of every run: no average yet, nothing injected (the map of
        :meth:`for_model` is kept: it is a setting, not the state of a run)."""
        self.w_slow = self.w_fast = None
        self.z = None
        self.injected: list[float] = []

    def for_model(self, model: RobotModel) -> AugmentedMCL:
        """This object, drawing its injected poses on ``model``'s map (a settings template has none yet)."""
        self.model = model
        self.sensor = SensorPoseSampler(model.landmarks, np.asarray(model.r_est, dtype=float))
        return self

    def update_averages(self, log_avg: float) -> None:
        """``w += alpha (w_avg - w)`` for both averages (in the log domain, so tiny likelihoods do not underflow)."""
        if self.w_slow is None:
            self.w_slow = self.w_fast = log_avg
            return
        for name, a in (("w_slow", self.alpha_slow), ("w_fast", self.alpha_fast)):
            old = getattr(self, name)
            setattr(self, name, np.logaddexp(math.log1p(-a) + old, math.log(a) + log_avg))

    def injection_probability(self) -> float:
        """``max(0, 1 - w_fast / w_slow)``."""
        if self.w_slow is None:
            return 0.0
        return float(max(0.0, 1.0 - math.exp(self.w_fast - self.w_slow)))

    def propose(self, model, particles, z, k, rng):
        if self.sensor is None:  # made without a model: inject on the filter's
            self.for_model(model)
        new = model.sample_transition(particles, k, rng)
        log_lik = model.log_likelihood(new, z, k)
        self.update_averages(float(logsumexp(log_lik) - math.log(len(log_lik))))
        self.z = np.asarray(z, dtype=float)
        return new, log_lik

    def __call__(self, particles: Array, rng: np.random.Generator) -> Array:
        p = self.injection_probability()
        self.injected.append(p)
        if p <= 0:
            return particles
        pick = rng.random(len(particles)) < p
        m = int(pick.sum())
        particles = particles.copy()
        if self.source == "sensor":
            particles[pick] = self.sensor.sample(self.z, m, rng)
        else:
            particles[pick] = uniform_poses(m, self.model.half_width, rng)
        return particles


class InjectionProbability:
    """Collector ``injected``: augmented MCL's injection probability ``max(0, 1 - w_fast / w_slow)`` at each
    resampling (the steps that resample; every measurement step with ``threshold = 1``), reported by the
    step as it runs, not read from the proposal after the run.  Refuses a filter whose jitter is not an
    :class:`AugmentedMCL`."""

    name = "injected"

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        if not isinstance(pf.jitter, AugmentedMCL):
            raise ParameterError(f"the collector {self.name!r} needs augmented MCL as the filter's jitter, "
                                 f"got {type(pf.jitter).__name__}")
        self.augmented, self.values = pf.jitter, []

    def collect(self, step) -> None:
        # the step's resampling injected with the probability of the averages its proposal just updated
        if step.resampled:
            self.values.append(self.augmented.injection_probability())

    def result(self) -> Array:
        return np.array(self.values, dtype=float)


def kld_filter(model, measurements: Array, rng: np.random.Generator | int, *, n_max: int = 20000,
               n_min: int = 100, epsilon: float = 0.05, delta: float = 0.01,
               bin_size: Sequence[float] = (1.0, 1.0, np.deg2rad(10.0)), proposal=None,
               batch: int = 100) -> FilterResult:
    """KLD-sampling MCL (Fox 2003): the engine with a :class:`~pfcourse.sample_size.KLDSampling` policy.

    Step 0 draws ``n_max`` particles from ``model.sample_initial``; each measurement step draws
    batches of ``batch`` (ancestors by multinomial resampling, then ``proposal``, the
    transition by default) until ``n >= max(n_min, kld_bound(bins))`` or ``n = n_max``, on a
    grid of ``bin_size`` = (m, m, rad). ``result.sizes`` is the number of particles per step.
    """
    policy = KLDSampling(bin_size, n_min=n_min, epsilon=epsilon, delta=delta, batch=batch)
    return FilterSettings(n_max, proposal=proposal, sample_size=policy).build(model).run(measurements, rng)


# ----------------------------------------------------------------------------- scenarios and runs

def kidnap(sim: RobotSimulation, step: int, pose: Sequence[float]) -> RobotSimulation:
    """The run ``sim`` with the true robot moved to ``pose`` at ``step`` (odometry unaware of it).

    From ``step`` on the truth follows the same true commands from ``pose``; each measurement
    keeps its landmark and its noise ``z - h(x_true)`` and is recomputed from the new truth.
    """
    K = sim.truth.shape[0]
    if not 1 <= step < K:
        raise ParameterError(f"kidnap step must be in 1..{K - 1}, got {step}")
    truth = sim.truth.copy()
    truth[step] = np.asarray(pose, dtype=float)
    truth[step, 2] = wrap_angle(truth[step, 2])
    for k in range(step + 1, K):
        truth[k] = motion(truth[k - 1], sim.controls[k], sim.scenario.dt)
    z = sim.measurements.copy()
    for k in np.flatnonzero(sim.has_measurement):
        if k < step:
            continue
        lm = sim.landmarks[int(z[k, 0])]
        noise = z[k, 1:] - range_bearing(sim.truth[k], lm)
        noise[1] = wrap_angle(noise[1])
        new = range_bearing(truth[k], lm) + noise
        z[k, 1:] = (new[0], wrap_angle(new[1]))
    return RobotSimulation(truth, sim.odometry_path, sim.controls, sim.odometry, z, sim.landmarks, sim.scenario)


@dataclass(frozen=True)
class KidnapModel:
    """The filter's model change of the mixture proposal: the robot of ``RobotModel`` with the teleport
    probability ``teleport`` (:class:`KidnapRobotModel`; a global start, ``eps_1 = 1``, when the robot's
    initial cloud is uniform)."""

    teleport: float = 1e-3

    @property
    def label(self) -> str:
        return f"kidnap model (eps = {self.teleport:g})"

    def apply(self, base: RobotModel) -> KidnapRobotModel:
        return KidnapRobotModel(base, self.teleport, global_start=base.initial == "uniform")


@dataclass(frozen=True)
class SensorMixture:
    """The template of :func:`sensor_mixture_proposal` in a filter's settings: ``share`` of the particles
    drawn from the reading (all of them at a uniform step), ``spread`` scaling its standard deviations."""

    share: float = 0.1
    spread: float = 1.0

    @property
    def label(self) -> str:
        return f"mixture proposal ({self.share:g} from the reading)"

    def for_model(self, model: KidnapRobotModel) -> DensityProposal:
        return sensor_mixture_proposal(model, self.share, self.spread)


def kld_policy(bin_size=(1.0, 1.0, float(np.deg2rad(10.0))), n_min: int = 100, epsilon: float = 0.05,
                delta: float = 0.01) -> KLDSampling:
    """The book's KLD-sampling bound (AMCL's grid is 0.5 m x 0.5 m x 10 deg), batches of 100."""
    return KLDSampling(bin_size, n_min=n_min, epsilon=epsilon, delta=delta, batch=100)


def _augmented(alpha_slow: float = 0.01, alpha_fast: float = 0.1) -> FilterSettings:
    aug = AugmentedMCL(alpha_slow=alpha_slow, alpha_fast=alpha_fast)
    return FilterSettings(2000, threshold=1.0, proposal=aug, jitter=aug)  # one object: proposal and injection


#: The global-localization methods as settings records (``N``: the study's grid gives it; 2000 nominal,
#: ``n_max`` for KLD-sampling): ``config.settings.with_(n_particles=N).build(base)``, ``base`` the robot's
#: :class:`RobotModel` (its initial cloud uniform for global localization, around the start for tracking).
#: Progressive correction tempers the first 10 readings (stages while ESS < N/2, a regularised kernel at
#: 0.5 h_opt on the heading), the bootstrap filter afterwards.
FILTERS: dict[str, FilterConfig] = configurations(*(FilterConfig.of(name, settings, n_from_grid=True) for name, settings in [
    ("bootstrap", FilterSettings(2000)),
    ("mixture", FilterSettings(2000, proposal=SensorMixture(0.1), model_change=KidnapModel(1e-3))),
    ("augmented", _augmented()),
    ("kld", FilterSettings(2000, sample_size=kld_policy())),
    ("kld_mixture", FilterSettings(2000, proposal=SensorMixture(0.02), model_change=KidnapModel(1e-3),
                                   sample_size=kld_policy())),
    ("tempered", FilterSettings(2000, threshold=1.0, proposal=ProgressiveCorrection(
        n_tempered=10, ess_fraction=0.5, kernel=RegularisedJitter(0.5, ANGLE_INDICES)))),
]))
METHODS = tuple(FILTERS)


def settings_of(method: str, n_particles: int) -> FilterSettings:
    """The settings record of ``method`` (one of :data:`FILTERS`) with ``N = n_particles`` (``n_max`` for KLD)."""
    return lookup(FILTERS, method, "method").settings.with_(n_particles=n_particles)


def run_settings(sim: RobotSimulation, settings: FilterSettings, seed: int, *, global_start: bool = True) -> dict:
    """Filter ``sim`` with the filter of ``settings`` (a record of :data:`FILTERS`, or a variant of one).

    Returns ``mean`` ``(K, 3)``, ``cov`` ``(K, 3, 3)``, ``n_used`` ``(K,)`` (particles per step),
    ``likelihood_evaluations`` ``(K,)`` (particles times the stages of progressive correction: the
    cost behind ``particle_steps``), ``seconds`` and, for
    augmented MCL, ``injected`` (probability per resampling).
    """
    base = RobotModel.for_simulation(sim, initial="uniform" if global_start else "tracking")
    out: dict = {}
    start = time.perf_counter()
    pf = settings.build(base)
    augmented = isinstance(pf.jitter, AugmentedMCL)
    res = pf.run(sim.measurements, seed, collect=[Stages()] + ([InjectionProbability()] if augmented else []))
    if augmented:
        out["injected"] = res.collected["injected"]
    out["seconds"] = time.perf_counter() - start
    out["mean"], out["cov"] = res.mean, res.cov
    out["n_used"] = res.sizes
    # each stage of progressive correction evaluates the likelihood of the whole cloud once more
    out["likelihood_evaluations"] = res.sizes * res.collected["stages"]
    return out


def run_method(sim: RobotSimulation, method: str, n_particles: int, seed: int, *, global_start: bool = True) -> dict:
    """:func:`run_settings` of the method ``method`` of :data:`FILTERS` with ``N = n_particles``."""
    return run_settings(sim, settings_of(method, n_particles), seed, global_start=global_start)


def kidnap_pose(seed: int, truth_at: Array, half_width: float = 60.0, min_distance: float = 30.0) -> Array:
    """A pose uniform on the map at least ``min_distance`` m from ``truth_at`` (per run:
    :func:`pfcourse.seeding.kidnap_rng` ``(seed)``)."""
    rng = kidnap_rng(seed)
    margin = 0.8 * half_width
    while True:
        pose = np.array([*rng.uniform(-margin, margin, 2), rng.uniform(-np.pi, np.pi)])
        if position_error(truth_at, pose) >= min_distance:
            return pose
