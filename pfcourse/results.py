"""What the filters return: :class:`FilterResult` for the particle filter, :class:`KalmanResult`
for the whole Kalman family (the Kalman filter, the EKFs and the UKFs).

A Kalman-family result, for ``K`` steps, ``d`` states and ``m`` measured components:

* ``mean`` ``(K, d)`` and ``cov`` ``(K, d, d)``: the posterior ``N(m_k, P_k)`` after each update;
* ``innovation`` ``(K, m)``: ``y_k = z_k - z^_k`` (angle components wrapped), and
  ``innovation_cov`` ``(K, m, m)``: its covariance ``S_k`` (``H P^- H^T + R`` for the EKF, the
  unscented transform plus ``R`` for the UKF), both as the filter computed them, NaN at steps
  without a measurement (and in components not measured at that step);
* ``predicted`` ``(K, d)``: the predicted mean ``m^-_k`` and ``gain`` ``(K, d, m)`` the gain
  ``G_k``, so that ``m_k = m^-_k + G_k y_k`` (angles wrapped);
* ``log_likelihood_increments`` ``(K,)``: ``log N(y_k; 0, S_k)`` where the filter computes it;
* ``lost_at``: the first step at which the filter stopped (an estimate off a map), or ``None``;
  rows from there on are NaN.

The particle filter's result, :class:`FilterResult`, shares ``mean``, ``cov``
and ``log_likelihood``, so the comparisons take either.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pfcourse.checks import Array


@dataclass
class FilterResult:
    """Per-step output of :meth:`ParticleFilter.run` (``K`` steps, ``N`` particles, ``d`` states).

    ``mean`` ``(K, d)`` and ``cov`` ``(K, d, d)`` are the weighted moments after the
    update at each step (before any resampling); ``ess`` ``(K,)`` is the effective
    sample size at that moment; ``resampled`` ``(K,)`` says whether the cloud was
    resampled after it; ``log_likelihood_increments`` ``(K,)`` holds
    ``log p^(z_k | z_{0:k-1})`` (0 at steps without a measurement).  With the clouds
    collected (``run(..., collect=[Clouds()])``), ``particles`` ``(K, N, d)`` and ``weights``
    ``(K, N)`` hold the weighted cloud at each step.  ``sizes`` ``(K,)`` is the number of particles at
    each step (``n_particles`` throughout, unless the filter has a ``sample_size`` policy).
    ``collected`` holds the records of the collectors given to ``run``, by name
    (:mod:`pfcourse.collectors`).  ``settings`` is the filter's settings as plain data, in the schema of
    :meth:`pfcourse.filter_config.FilterSettings.record` (the record itself for a filter it built).
    """

    mean: Array
    cov: Array
    ess: Array
    resampled: Array
    log_likelihood_increments: Array
    n_particles: int
    particles: Array | None = None
    weights: Array | None = None
    settings: dict = field(default_factory=dict)
    sizes: Array | None = None
    collected: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.sizes is None:
            self.sizes = np.full(len(self.ess), self.n_particles, dtype=np.int64)

    @property
    def particle_steps(self) -> int:
        """Particles drawn over the run, ``sum_k N_k`` (``K N`` for a fixed ``N``): the cost unit."""
        return int(np.sum(self.sizes))

    @property
    def log_likelihood(self) -> float:
        """Estimate of the marginal log-likelihood ``log p(z_{0:K-1}) = sum_k log p^(z_k | z_{0:k-1})``."""
        with np.errstate(over="ignore"):  # increments near -1e308 sum to -inf: a likelihood that underflows
            return float(np.sum(self.log_likelihood_increments))

    @property
    def n_resamples(self) -> int:
        """How many times the cloud was resampled."""
        return int(np.sum(self.resampled))


@dataclass
class KalmanResult:
    """Per-step output of a Kalman-family filter (see the module docstring)."""

    mean: Array
    cov: Array
    innovation: Array | None = None
    innovation_cov: Array | None = None
    predicted: Array | None = None
    gain: Array | None = None
    log_likelihood_increments: Array | None = None
    lost_at: int | None = None
    name: str = "Kalman"

    @classmethod
    def empty(cls, n_steps: int, dim_x: int, dim_z: int, name: str) -> KalmanResult:
        """A result of ``n_steps`` NaN rows, for a filter to fill step by step."""
        nan = np.nan
        return cls(
            mean=np.full((n_steps, dim_x), nan),
            cov=np.full((n_steps, dim_x, dim_x), nan),
            innovation=np.full((n_steps, dim_z), nan),
            innovation_cov=np.full((n_steps, dim_z, dim_z), nan),
            predicted=np.full((n_steps, dim_x), nan),
            gain=np.full((n_steps, dim_x, dim_z), nan),
            log_likelihood_increments=np.zeros(n_steps),
            name=name,
        )

    def record_update(self, k: int, predicted: Array, innovation: Array, innovation_cov: Array, gain: Array,
                      components: Array | None = None) -> None:
        """Store the update of step ``k`` (arrays of any shape with ``d``, ``m``, ``m x m``, ``d x m`` entries),
        in the measured ``components`` (indices of ``m`` of the ``dim_z``; ``None``: all of them)."""
        d, m = self.gain.shape[1:]
        self.predicted[k] = np.reshape(predicted, d)
        if components is None:
            self.innovation[k] = np.reshape(innovation, m)
            self.innovation_cov[k] = np.reshape(innovation_cov, (m, m))
            self.gain[k] = np.reshape(gain, (d, m))
        else:
            self.innovation[k, components] = innovation
            self.innovation_cov[k][np.ix_(components, components)] = innovation_cov
            self.gain[k][:, components] = gain

    @property
    def log_likelihood(self) -> float:
        """``log p(z_{0:K-1}) = sum_k log N(y_k; 0, S_k)`` (exact for the linear Kalman filter)."""
        if self.log_likelihood_increments is None:
            raise AttributeError(f"the {self.name} run did not record its log-likelihood")
        with np.errstate(over="ignore"):  # increments near -1e308 sum to -inf: a likelihood that underflows
            return float(np.sum(self.log_likelihood_increments))
