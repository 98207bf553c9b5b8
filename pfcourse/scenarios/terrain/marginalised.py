"""The marginalised particle filter for terrain navigation (Schön, Gustafsson and Nordlund 2005).

In the model of :mod:`pfcourse.scenarios.terrain.scenario` the altitude ``z`` enters linearly: it moves as a
random walk, ``z_k = z_{k-1} + w_z`` with ``w_z ~ N(0, q dt)`` (``q = Qf[2, 2]``), independent of
the horizontal position ``p = (x, y)`` and the heading ``psi``, and the altimeter reads
``y_k = z_k - h(p_k) + v_k``, ``v_k ~ N(0, Rf)``.  Given a path ``p_{0:k}`` the altitude is therefore
a scalar linear-Gaussian model, and its posterior is one Gaussian ``N(m_k, P_k)`` computed by a
Kalman filter.  A particle carries the sampled ``(x, y, psi)`` and the altitude's ``(m, P)``:

* predict: ``m^- = m``, ``P^- = P + q dt``;
* weight by the predictive density ``N(y_k; m^- - h(p_k), S)``, ``S = P^- + Rf``;
* update: ``K = P^- / S``, ``m = m^- + K (y_k - m^- + h(p_k))``, ``P = (1 - K) P^-``.

``P`` does not depend on the path (only on which steps were measured), so every particle carries
the same number; it is kept in the particle's row anyway, so the engine resamples it like the rest.

The engine (:class:`pfcourse.filter.ParticleFilter`) runs it unchanged: a row is
``(x, y, m, psi, P)`` (:class:`MarginalisedTerrainModel`; the heading keeps index 3 and the altitude
mean index 2, so :func:`pfcourse.metrics.position_error` reads the rows as it reads the bootstrap
filter's), and the weighting and the Kalman update happen together in :class:`AltitudeKalmanProposal`.
"""

from __future__ import annotations

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, covariance_factor
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.gaussian import LOG_2PI
from pfcourse.scenarios.terrain.compiled import bilinear
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.scenario import AircraftScenario, _check_flight

#: The sampled components of the state (x, y, psi) among the scenario's four.
HORIZONTAL = [0, 1, 3]


def altimeter_innovation(reading: float, altitude: Array, ground: Array) -> tuple[Array, Array]:
    """The altimeter's innovation ``nu = y - (z - h)`` of each particle, ``z`` its predicted altitude (mean) and
    ``h`` the ground under it, and where the particle is off the map (``h`` NaN; there ``nu = 0``)."""
    off = np.isnan(ground)
    return np.where(off, 0.0, reading - (altitude - np.where(off, 0.0, ground))), off


def innovation_log_density(nu: Array, s: Array, off: Array) -> Array:
    """``log N(nu; 0, S) = -(nu^2 / S + log S + log 2 pi) / 2`` of each particle's innovation, the log predictive
    density of the reading (the particle's weight increment), ``-inf`` off the map."""
    return np.where(off, -np.inf, -0.5 * (nu * nu / s + np.log(s) + LOG_2PI))


def altitude_kalman_update(mean: Array, var: Array | float, ground: Array, reading: float,
                           rf: float) -> tuple[Array, Array, Array]:
    """The Kalman update of every particle's altitude, and its log predictive density.

    ``mean``, ``var``: the predicted altitude ``m^-``, ``P^-`` of each particle; ``ground``: ``h(p^i)``
    (NaN off the map); ``reading``: ``y_k``; ``rf``: the altimeter's variance ``Rf``.  With the
    innovation ``nu = y_k - (m^- - h)`` and ``S = P^- + Rf``::

        K = P^- / S,   m = m^- + K nu,   P = (1 - K) P^-,   log N(nu; 0, S).

    Off the map the log density is ``-inf`` and the altitude is left as predicted.
    """
    mean = np.asarray(mean, dtype=float)
    var = np.broadcast_to(np.asarray(var, dtype=float), mean.shape)
    nu, off = altimeter_innovation(reading, mean, ground)
    s = var + rf
    gain = var / s
    return mean + gain * nu, (1.0 - gain) * var, innovation_log_density(nu, s, off)


class MarginalisedTerrainModel:
    """Rows ``(x, y, m, psi, P)``: sampled position and heading, and the altitude's Kalman mean and variance.

    The scenario's ``P0`` and ``Qf`` must not couple the altitude with the other components (otherwise
    the altitude given the path is not a separate scalar Kalman filter): :class:`ParameterError`.
    """

    dim_x = 5
    angle_indices = (3,)

    def __init__(self, terrain: TerrainMap, scenario: AircraftScenario) -> None:
        _check_flight(scenario, terrain)
        for name in ("P0", "Qf"):
            M = getattr(scenario, name)
            if np.any(M[2, HORIZONTAL] != 0) or np.any(M[HORIZONTAL, 2] != 0):
                raise ParameterError(f"{name} couples the altitude with position or heading: the altitude given "
                                     "the path is then not a separate Kalman filter")
        self.terrain, self.scenario = terrain, scenario
        self._init_factor = covariance_factor(scenario.P0[np.ix_(HORIZONTAL, HORIZONTAL)])
        self._noise_factor = covariance_factor(scenario.Qf[np.ix_(HORIZONTAL, HORIZONTAL)] * scenario.dt)
        self._q = float(scenario.Qf[2, 2] * scenario.dt)
        self._heights = np.ascontiguousarray(terrain.heights, dtype=float)

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """``(x, y, psi) ~ N`` of the prior's horizontal block; every altitude filter starts at ``N(x0_z, P0_zz)``."""
        s = self.scenario
        rows = np.empty((n, 5))
        rows[:, HORIZONTAL] = s.x0[HORIZONTAL] + rng.standard_normal((n, 3)) @ self._init_factor.T
        rows[:, 3] = wrap_angle(rows[:, 3])
        rows[:, 2], rows[:, 4] = s.x0[2], s.P0[2, 2]
        return rows

    def move_horizontally(self, particles: Array, rng: np.random.Generator) -> Array:
        """A copy of the rows with position and heading moved through the dynamics plus noise::

            x += V dt cos(psi) + w_x,   y += V dt sin(psi) + w_y,   psi <- wrap(psi + omega dt + w_psi),

        ``(w_x, w_y, w_psi) ~ N(0, Q_h dt)``, ``Q_h`` the horizontal block of ``Qf``; the other columns as they were."""
        s = self.scenario
        psi = particles[:, 3]
        out = particles.copy()
        noise = rng.standard_normal((len(particles), 3)) @ self._noise_factor.T
        out[:, 0] += s.speed * s.dt * np.cos(psi) + noise[:, 0]
        out[:, 1] += s.speed * s.dt * np.sin(psi) + noise[:, 1]
        out[:, 3] = wrap_angle(psi + s.omega * s.dt + noise[:, 2])
        return out

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """Position and heading through the dynamics plus noise; altitude predicted, ``P^- = P + q dt``."""
        out = self.move_horizontally(particles, rng)
        out[:, 4] += self._q
        return out

    def ground(self, particles: Array) -> Array:
        """``h(x, y)`` under every particle (bilinear; NaN off the map)."""
        return bilinear(self._heights, self.terrain.dx, self.terrain.dy,
                        np.ascontiguousarray(particles[:, 0]), np.ascontiguousarray(particles[:, 1]))

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """Not available: weighting without updating the altitude filters would be wrong."""
        raise ParameterError(f"step {k}: MarginalisedTerrainModel weights and updates the altitude in its proposal; "
                             "run it with proposal=AltitudeKalmanProposal() (marginalised_filter does) and no "
                             "reading at time 0")


class AltitudeKalmanProposal:
    """Move ``(x, y, psi)`` through the transition, then weight and update each altitude filter.

    The log increment is ``log N(y_k; m^- - h(p_k^i), P^- + Rf)``, the likelihood of the reading with
    the altitude integrated out (:func:`altitude_kalman_update`).
    """

    def propose(self, model: MarginalisedTerrainModel, particles: Array, z: Array, k: int,
                rng: np.random.Generator) -> tuple[Array, Array]:
        new = model.sample_transition(particles, k, rng)
        new[:, 2], new[:, 4], log_inc = altitude_kalman_update(new[:, 2], new[:, 4], model.ground(new),
                                                               float(np.ravel(z)[0]), float(model.scenario.Rf))
        return new, log_inc


def marginalised_filter(terrain: TerrainMap, scenario: AircraftScenario, n_particles: int, **options):
    """The engine set up as the marginalised filter: ``ParticleFilter(model, N, proposal=AltitudeKalmanProposal())``."""
    return ParticleFilter(MarginalisedTerrainModel(terrain, scenario), n_particles,
                          proposal=AltitudeKalmanProposal(), **options)
