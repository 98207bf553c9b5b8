"""The Rao-Blackwellised particle filter for a linear-Gaussian map (FastSLAM style).

The state splits into a *robot* part ``r`` (the first ``n_robot`` components) and a *map*
part ``l`` (the rest).  When the dynamics, the process noise and the prior do not couple
the two blocks, the map given the robot path is linear-Gaussian:

.. math::

   p(r_{0:k}, l_k \\mid z_{0:k}) = p(r_{0:k} \\mid z_{0:k})\\; \\mathcal N(l_k;\\, m_k(r_{0:k}),\\, P_k(r_{0:k})),

so a particle carries a robot position ``r^i`` and the mean ``m^i`` and covariance ``P^i``
of its own Kalman filter over the map (Doucet et al. 2000; Montemerlo et al. 2002, 2003).
The engine (:class:`pfcourse.filter.ParticleFilter`) runs it unchanged: the particle array
packs ``(r^i, m^i, vec P^i)`` in one row of length ``n_r + n_l + n_l^2``
(:class:`RaoBlackwellModel`), the importance functions are ordinary proposals
(:class:`RaoBlackwellProposal`), and :meth:`RaoBlackwellModel.marginal` turns the engine's
weighted moments of the packed rows into the mean and covariance of the state, by the law
of total covariance ``Cov(l) = E_W[P^i] + Cov_W(m^i)``.

With measurements ``z_k = A r_k + C l_k + v_k`` (``A``, ``C``: the robot and map columns of
the observed rows of ``H``), predicted robot ``r^- = F_r r^i + B_r`` and map
``m^- = F_l m^i + B_l``, ``P^- = F_l P^i F_l^T + Q_l``:

* **prior proposal** (FastSLAM 1.0): ``r_k^i ~ N(r^-, Q_r)``, incremental weight
  ``N(z_k; A r_k^i + C m^-, C P^- C^T + R)``;
* **optimal proposal** (FastSLAM 2.0; exact here): with ``S = A Q_r A^T + C P^- C^T + R`` and
  ``G = Q_r A^T S^{-1}``, ``r_k^i ~ N(r^- + G (z_k - A r^- - C m^-), Q_r - G S G^T)``, incremental
  weight ``N(z_k; A r^- + C m^-, S)``, whatever ``r_k^i`` is drawn;

then each particle's map filter is updated with ``z_k - A r_k^i = C l_k + v_k``.
A time-0 measurement must go through the proposal as well: the model's
``log_likelihood`` cannot update the map, so it raises :class:`RaoBlackwellError`
(the landmark scenarios never measure at time 0).
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import Array, check_count, covariance_factor
from pfcourse.errors import ParameterError
from pfcourse.results import FilterResult
from pfcourse.gaussian import LOG_2PI
from pfcourse.linear_gaussian import LinearGaussianModel



class RaoBlackwellError(ParameterError):
    """The Rao-Blackwellised model was used where it cannot be (no proposal to update the map)."""


class RaoBlackwellModel:
    """Particles ``(r^i, m^i, vec P^i)`` for a linear-Gaussian model whose map is integrated out.

    ``model`` is a :class:`~pfcourse.linear_gaussian.LinearGaussianModel` whose first
    ``n_robot`` state components are the robot; ``F``, ``Q`` and ``P0`` must have no
    robot-map cross blocks (otherwise the map given the robot path is not the product this
    filter assumes) and the robot block of ``Q`` must be positive definite.
    """

    def __init__(self, model: LinearGaussianModel, n_robot: int = 2) -> None:
        d = model.dim_x
        nr = check_count(n_robot, "n_robot")
        if nr >= d:
            raise ParameterError(f"n_robot must be below the state dimension {d}, got {nr}")
        r, l = slice(0, nr), slice(nr, d)
        for name in ("F", "Q", "P0"):
            M = getattr(model, name)
            if np.any(M[r, l] != 0) or np.any(M[l, r] != 0):
                raise ParameterError(
                    f"{name} couples the robot (first {nr} components) and the map: the map given "
                    "the robot path is then not a separate Kalman filter"
                )
        self.base = model
        self.n_robot, self.n_map = nr, d - nr
        self.dim_state = d
        self.dim_x = nr + self.n_map + self.n_map**2
        self.Fr, self.Fl = model.F[r, r], model.F[l, l]
        self.Br, self.Bl = model.B[r], model.B[l]
        self.Qr, self.Ql = model.Q[r, r], model.Q[l, l]
        self._Qr_factor = covariance_factor(self.Qr)
        self._P0r_factor = covariance_factor(model.P0[r, r])
        if np.any(np.linalg.eigvalsh(self.Qr) <= 0):
            raise ParameterError("the robot block of Q must be positive definite")

    # -- packing ---------------------------------------------------------------------------
    def unpack(self, particles: Array) -> tuple[Array, Array, Array]:
        """Split rows into robot ``(N, n_r)``, map means ``(N, n_l)``, map covariances ``(N, n_l, n_l)``."""
        nr, nl = self.n_robot, self.n_map
        return (
            particles[:, :nr],
            particles[:, nr : nr + nl],
            particles[:, nr + nl :].reshape(-1, nl, nl),
        )

    def pack(self, robot: Array, mean: Array, cov: Array) -> Array:
        """The inverse of :meth:`unpack`; ``cov`` may be one ``(n_l, n_l)`` matrix shared by all rows."""
        n = robot.shape[0]
        cov = np.broadcast_to(cov, (n, self.n_map, self.n_map)).reshape(n, -1)
        return np.hstack([robot, np.broadcast_to(mean, (n, self.n_map)), cov])

    # -- the engine's model interface ------------------------------------------------------
    def sample_initial(self, n: int, rng: np.random.Generator) -> Array:
        """``r_0^i ~ N(m0_r, P0_r)``; every map filter starts at ``N(m0_l, P0_l)``."""
        nr = self.n_robot
        robot = self.base.m0[:nr] + rng.standard_normal((n, nr)) @ self._P0r_factor.T
        return self.pack(robot, self.base.m0[nr:], self.base.P0[nr:, nr:])

    def predict(self, particles: Array) -> tuple[Array, Array, Array]:
        """Predicted robot mean ``F_r r + B_r``, map mean ``F_l m + B_l`` and ``F_l P F_l^T + Q_l``."""
        robot, mean, cov = self.unpack(particles)
        cov, _ = _shared(cov)
        return (
            robot @ self.Fr.T + self.Br,
            mean @ self.Fl.T + self.Bl,
            self.Fl @ cov @ self.Fl.T + self.Ql,
        )

    def sample_transition(self, particles: Array, k: int, rng: np.random.Generator) -> Array:
        """No measurement: the robot moves through its prior, every map filter predicts."""
        r_pred, m_pred, P_pred = self.predict(particles)
        robot = r_pred + rng.standard_normal(r_pred.shape) @ self._Qr_factor.T
        return self.pack(robot, m_pred, P_pred)

    def log_likelihood(self, particles: Array, z: Array, k: int) -> Array:
        """Not available: weighting without updating the map filters would be wrong."""
        raise RaoBlackwellError(
            f"step {k}: RaoBlackwellModel weights and updates the map in its proposal; run the "
            "filter with proposal=RaoBlackwellProposal(...) and no measurement at time 0"
        )

    # -- the estimate ----------------------------------------------------------------------
    def marginal(self, result: FilterResult) -> FilterResult:
        """The state's weighted mean ``(K, d)`` and covariance ``(K, d, d)`` from a packed run.

        ``mean = (E_W r, E_W m)``; ``cov`` is the engine's weighted covariance of
        ``(r^i, m^i)`` plus ``E_W P^i`` in the map block (law of total covariance).
        Everything else (ESS, resampling, log-likelihood) is the engine's.
        """
        d, nr, nl = self.dim_state, self.n_robot, self.n_map
        K = result.mean.shape[0]
        cov = result.cov[:, :d, :d].copy()
        cov[:, nr:, nr:] += result.mean[:, d:].reshape(K, nl, nl)
        return FilterResult(
            mean=result.mean[:, :d].copy(),
            cov=cov,
            ess=result.ess,
            resampled=result.resampled,
            log_likelihood_increments=result.log_likelihood_increments,
            n_particles=result.n_particles,
            settings=dict(result.settings, rao_blackwellised=True),
        )


def _shared(cov: Array) -> tuple[Array, bool]:
    """``(cov[:1], True)`` when every particle has the same map covariance, else ``(cov, False)``.

    In a linear-Gaussian map the covariance does not depend on the robot path (only on which
    landmarks were seen when), so all particles share it; computing it once is exact.
    """
    if cov.shape[0] > 1 and np.array_equal(cov, np.broadcast_to(cov[:1], cov.shape)):
        return cov[:1], True
    return cov, False


def _matvec(M: Array, v: Array) -> Array:
    """``M_i v_i`` per row for ``M (B, a, b)`` with ``B`` in ``{1, N}`` and ``v (N, b)``."""
    if M.shape[0] == 1:
        return v @ M[0].T
    return np.einsum("nij,nj->ni", M, v)


def _batched_logpdf(innovation: Array, S: Array) -> tuple[Array, Array]:
    """``log N(innovation_i; 0, S_i)`` and ``S_i^{-1}`` for ``innovation (N, p)``, ``S (B, p, p)``, ``B`` in ``{1, N}``."""
    p = innovation.shape[1]
    chol = np.linalg.cholesky(S)
    S_inv = np.linalg.inv(S)
    maha = np.einsum("ni,nij,nj->n", innovation, np.broadcast_to(S_inv, (innovation.shape[0], p, p)), innovation)
    log_det = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=1, axis2=2)), axis=1)
    return -0.5 * (maha + log_det + p * LOG_2PI), S_inv


class RaoBlackwellProposal:
    """Robot proposal of the Rao-Blackwellised filter: ``optimal=False`` is FastSLAM 1.0, ``True`` 2.0.

    See the module docstring for the formulas.  Used as ``ParticleFilter(rb_model, N,
    proposal=RaoBlackwellProposal(optimal))``.
    """

    def __init__(self, optimal: bool = True) -> None:
        self.optimal = bool(optimal)

    @property
    def label(self) -> str:
        """Its name in a filter's label (:class:`pfcourse.filter_config.FilterSettings`)."""
        return "optimal proposal (FastSLAM 2.0)" if self.optimal else "prior proposal (FastSLAM 1.0)"

    def _parts(self, model: RaoBlackwellModel, particles: Array, z: Array):
        r_pred, m_pred, P_pred = model.predict(particles)
        mask, z_o, H_o, R_o = model.base.observed(z)
        A, C = H_o[:, : model.n_robot], H_o[:, model.n_robot :]
        S_map = C @ P_pred @ C.T + R_o  # (B, p, p)
        return r_pred, m_pred, P_pred, mask, z_o, A, C, S_map

    def log_predictive(self, model: RaoBlackwellModel, particles: Array, z: Array, k: int) -> Array:
        """``log p(z_k | r_{0:k-1}^i, z_{0:k-1}) = log N(z_k; A r^- + C m^-, A Q_r A^T + C P^- C^T + R)``."""
        r_pred, m_pred, P_pred, mask, z_o, A, C, S_map = self._parts(model, particles, z)
        if not mask.any():
            return np.zeros(particles.shape[0])
        innovation = z_o - r_pred @ A.T - m_pred @ C.T
        return _batched_logpdf(innovation, A @ model.Qr @ A.T + S_map)[0]

    def propose(self, model: RaoBlackwellModel, particles: Array, z: Array, k: int, rng: np.random.Generator):
        r_pred, m_pred, P_pred, mask, z_o, A, C, S_map = self._parts(model, particles, z)
        n = particles.shape[0]
        if not mask.any():
            return model.sample_transition(particles, k, rng), np.zeros(n)
        noise = rng.standard_normal(r_pred.shape)
        if self.optimal:
            innovation = z_o - r_pred @ A.T - m_pred @ C.T
            S = A @ model.Qr @ A.T + S_map
            log_inc, S_inv = _batched_logpdf(innovation, S)
            G = model.Qr @ A.T @ S_inv  # (B, n_r, p)
            r_mean = r_pred + _matvec(G, innovation)
            r_cov = model.Qr - G @ S @ np.swapaxes(G, 1, 2)
            r_cov = 0.5 * (r_cov + np.swapaxes(r_cov, 1, 2))
            L = np.linalg.cholesky(r_cov)
            robot = r_mean + _matvec(L, noise)
            map_innovation = z_o - robot @ A.T - m_pred @ C.T
        else:
            robot = r_pred + noise @ model._Qr_factor.T
            map_innovation = z_o - robot @ A.T - m_pred @ C.T
            log_inc, S_inv = _batched_logpdf(map_innovation, S_map)
        # The map's Kalman update given the robot: gain K = P^- C^T S_map^{-1} (Joseph form).
        S_map_inv = S_inv if not self.optimal else np.linalg.inv(S_map)
        gain = P_pred @ C.T @ S_map_inv  # (B, n_l, p)
        mean = m_pred + _matvec(gain, map_innovation)
        I_KC = np.eye(model.n_map) - gain @ C
        R_o = model.base.observed(z)[3]
        cov = I_KC @ P_pred @ np.swapaxes(I_KC, 1, 2) + gain @ R_o @ np.swapaxes(gain, 1, 2)
        cov = 0.5 * (cov + np.swapaxes(cov, 1, 2))
        return model.pack(robot, mean, cov if cov.shape[0] > 1 else cov[0]), log_inc
