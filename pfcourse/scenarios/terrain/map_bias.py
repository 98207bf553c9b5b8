"""Map error carried as a state: the marginalised filter with a map-bias state beside the altitude.

A filter's map ``h_f`` is not the ground ``h``: with ``b(p) = h_f(p) - h(p)`` the altimeter's reading is

    y_k = z_k - h(p_k) + v_k = z_k + b(p_k) - h_f(p_k) + v_k,

so the map's error enters the reading exactly as the altitude does: linearly.  Along the flight ``b`` is
a correlated process (the error field is smooth), modelled as first-order Gauss-Markov **in the distance
flown** ``d = V dt`` per step:

    b_k = a b_{k-1} + w_b,   a = exp(-d / L),   w_b ~ N(0, sigma_b^2 (1 - a^2)),   b_0 ~ N(0, sigma_b^2),

``L`` the error's correlation length and ``sigma_b`` its standard deviation.  Given the path, the pair
``s = (z, b)`` is a linear-Gaussian model with ``F = diag(1, a)``, ``Q = diag(q dt, sigma_b^2 (1 - a^2))``
and ``H = [1, 1]``: a two-state Kalman filter in every particle, the marginalised filter of
:mod:`pfcourse.scenarios.terrain.marginalised` with one more linear state (Schön, Gustafsson and Nordlund 2005).
A row is ``(x, y, m_z, psi, m_b, P_zz, P_zb, P_bb)``; the weight is the predictive density
``N(y_k; m_z + m_b - h_f(p), S)``, ``S = H P^- H^T + Rf``.

The other remedy, :func:`inflated_rf`, keeps the filter as it is and inflates ``Rf`` by the map error's
variance times the readings per correlation length, ``Rf + n sigma_b^2`` with ``n = max(1, L / (V T))``
(``T`` the measurement period): ``n`` readings that share one map error carry the information of one.
"""

from __future__ import annotations

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.checks import Array, check_real
from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.terrain.map import TerrainMap
from pfcourse.scenarios.terrain.marginalised import (HORIZONTAL, MarginalisedTerrainModel, altimeter_innovation,
                                                     innovation_log_density)
from pfcourse.scenarios.terrain.scenario import AircraftScenario


def correlation_length(terrain: TerrainMap, correlation_cells: float) -> float:
    """The ``1/e`` distance (m) of an error field smoothed by a Gaussian of ``correlation_cells`` cells
    (:func:`pfcourse.scenarios.terrain.map.mismatched_map`): its correlation is ``exp(-d^2 / (4 c^2 s^2))``, ``s`` the
    mean node spacing, so it falls to ``1/e`` at ``2 c s``."""
    return 2.0 * float(correlation_cells) * 0.5 * (terrain.dx + terrain.dy)


def readings_per_length(scenario: AircraftScenario, length: float) -> float:
    """``max(1, L / (V T))``: the readings that fall within one correlation length ``L`` (m)."""
    return max(1.0, float(length) / (scenario.speed * scenario.measurement_period))


def inflated_rf(scenario: AircraftScenario, map_sd: float, length: float) -> float:
    """``Rf + n sigma_b^2`` with ``n`` = :func:`readings_per_length`."""
    return float(scenario.Rf + readings_per_length(scenario, length) * map_sd**2)


def bias_kalman_update(m: Array, P: Array, ground: Array, reading: float, rf: float) -> tuple[Array, Array, Array]:
    """The Kalman update of every particle's ``(z, b)`` and its log predictive density.

    ``m`` ``(N, 2)`` predicted means, ``P`` ``(N, 3)`` predicted ``(P_zz, P_zb, P_bb)``, ``ground`` ``h_f(p)``
    (NaN off the map).  ``H = [1, 1]``: ``nu = y - (m_z + m_b - h_f)``, ``S = P_zz + 2 P_zb + P_bb + Rf``,
    ``K = (P_zz + P_zb, P_zb + P_bb) / S``, ``m += K nu``, ``P -= K K^T S``.  Off the map: ``-inf``, unchanged.
    """
    nu, off = altimeter_innovation(reading, m[:, 0] + m[:, 1], ground)
    pzz, pzb, pbb = P[:, 0], P[:, 1], P[:, 2]
    s = pzz + 2.0 * pzb + pbb + rf
    kz, kb = (pzz + pzb) / s, (pzb + pbb) / s
    log_lik = innovation_log_density(nu, s, off)
    m_new = np.column_stack([m[:, 0] + kz * nu, m[:, 1] + kb * nu])
    P_new = np.column_stack([pzz - kz * kz * s, pzb - kz * kb * s, pbb - kb * kb * s])
    return m_new, P_new, log_lik


class MapBiasTerrainModel(MarginalisedTerrainModel):
    """Rows ``(x, y, m_z, psi, m_b, P_zz, P_zb, P_bb)``: the marginalised model with a map-bias state.

    ``map_sd`` (m) and ``length`` (m) are the bias's standard deviation and correlation length, both
    positive (:class:`ParameterError` otherwise, when the model is built).
    """

    dim_x = 8
    angle_indices = (3,)

    def __init__(self, terrain: TerrainMap, scenario: AircraftScenario, map_sd: float, length: float) -> None:
        super().__init__(terrain, scenario)
        self.map_sd, self.length = check_real(map_sd, "map_sd"), check_real(length, "length")
        if self.map_sd <= 0 or self.length <= 0:
            raise ParameterError(f"map_sd and length must be positive, got {map_sd} and {length}")
        self.a = float(np.exp(-scenario.speed * scenario.dt / self.length))
        self._qb = self.map_sd**2 * (1.0 - self.a**2)

    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """``(x, y, psi)`` from the prior's horizontal block; ``(z, b) ~ N((x0_z, 0), diag(P0_zz, sigma_b^2))``."""
        s = self.scenario
        rows = np.zeros((n, 8))
        rows[:, HORIZONTAL] = s.x0[HORIZONTAL] + rng.standard_normal((n, 3)) @ self._init_factor.T
        rows[:, 3] = wrap_angle(rows[:, 3])
        rows[:, 2], rows[:, 5], rows[:, 7] = s.x0[2], s.P0[2, 2], self.map_sd**2
        return rows

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """Position and heading as the marginalised model moves them; ``(z, b)`` predicted with ``F = diag(1, a)``."""
        out = self.move_horizontally(particles, rng)
        a = self.a
        out[:, 4] = a * particles[:, 4]
        out[:, 5] = particles[:, 5] + self._q
        out[:, 6] = a * particles[:, 6]
        out[:, 7] = a * a * particles[:, 7] + self._qb
        return out


class BiasKalmanProposal:
    """Move ``(x, y, psi)`` through the transition, then weight and update each ``(z, b)`` filter."""

    def propose(self, model: MapBiasTerrainModel, particles: Array, z: Array, k: int,
                rng: np.random.Generator) -> tuple[Array, Array]:
        new = model.sample_transition(particles, k, rng)
        m, P, log_inc = bias_kalman_update(new[:, [2, 4]], new[:, 5:8], model.ground(new),
                                           float(np.ravel(z)[0]), float(model.scenario.Rf))
        new[:, 2], new[:, 4], new[:, 5:8] = m[:, 0], m[:, 1], P
        return new, log_inc


def map_bias_filter(terrain: TerrainMap, scenario: AircraftScenario, n_particles: int, map_sd: float,
                    length: float, **options) -> ParticleFilter:
    """The engine set up as the marginalised filter with a map-bias state (:class:`MapBiasTerrainModel`)."""
    return ParticleFilter(MapBiasTerrainModel(terrain, scenario, map_sd, length), n_particles,
                          proposal=BiasKalmanProposal(), **options)


__all__ = ["BiasKalmanProposal", "MapBiasTerrainModel", "bias_kalman_update", "correlation_length",
           "inflated_rf", "map_bias_filter", "readings_per_length"]
