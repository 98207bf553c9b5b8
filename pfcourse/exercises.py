"""Statistical checks of code a student writes in the exercises of Part I.

Each ``check_*`` function runs the student's function on cases with a known answer and
returns a :class:`CheckReport`: ``ok`` and a list of ``problems``, each a sentence saying
what is wrong and, where it can, why.  It never raises on a wrong answer (a student's
exception is reported as a problem); ``str(report)`` prints the verdict.

* :func:`check_resampler` - ``fn(weights, rng) -> indices``: right type, shape and range,
  particles of weight 0 never chosen, and *unbiased*: the mean number of copies of particle
  ``i`` over many draws is ``N W_i`` (a z-test per particle at 5 standard errors), and no more
  variable than multinomial resampling (``sum_i Var N_i`` at most 1.5 times ``sum_i N W_i (1 - W_i)``).
* :func:`check_weight_update` - ``fn(log_weights, log_likelihoods) -> log_weights``: the
  normalised log-domain update ``log W_i + log p(z | x_i) - logsumexp_j(...)``, checked on
  ordinary values and on likelihoods of ``e^{-1000}`` that underflow in the linear domain.
* :func:`check_sis` - ``fn(z, n_particles, rng, model) -> (means, ess)``: a whole SIS filter
  on a scalar linear-Gaussian model (:class:`ScalarModel`), against the Kalman filter, which
  is exact. A wrong filter is compared with what the typical mistakes converge to (weights
  that forget the previous step, particles moved without process noise, a variance read as a
  standard deviation), so the report can say which mistake it sees, not only that the numbers
  are off.
* :func:`check_ancestors` - ``fn(ancestors) -> origins``: the genealogy of a resampled cloud,
  each final particle's ancestor at step 0, on random ancestor indices; the steps followed
  forwards, one generation only and the last step left out are named.
* :func:`check_kalman` - ``fn(z, model) -> (means, variances, log_likelihood)``: a scalar Kalman
  filter with missing measurements, against :func:`scalar_kalman` to round-off (it is
  deterministic); a wrong one is compared with what each mistake of :data:`KALMAN_MISTAKES`
  computes (the gain with ``P_k^-`` instead of ``S_k``, no process noise, a variance read as a
  standard deviation, a NaN used as 0, a log-likelihood with ``P_k^-`` or without its constant, ...).
* :func:`check_optimal_proposal` - ``fn(x_prev, z, model) -> (means, variances, log_weights)``: the
  optimal importance function ``p(x_k | x_{k-1}, z_k)`` of a scalar model and its weight
  ``p(z_k | x_{k-1})``, against :func:`scalar_optimal_proposal` to round-off; variances added instead
  of precisions, a mean blind to ``z_k``, the weight's variance ``q`` or ``r`` alone instead of
  ``q + r``, and the weight evaluated at the new particle instead of the parent are named.
* :func:`check_landmark_update` - ``fn(robot, m, P, z, A, C, R) -> (m_new, P_new, log_lik)``: one
  particle's Kalman update of its map in the Rao-Blackwellised filter, against :func:`landmark_update`
  to round-off; the mistakes of :data:`LANDMARK_MISTAKES` are named (the robot forgotten or of the
  wrong sign, ``S`` without ``R``, no covariance update, a weight with ``R`` instead of ``S``).
* :func:`check_apf_second_stage` - ``fn(log_lik, log_pred, ancestors) -> log_weights``: the auxiliary
  filter's second-stage weights with the transition as proposal; the mistakes of
  :data:`APF_MISTAKES` are named (first stage not divided out, divided at the particle's own index,
  multiplied in again, not normalised).
* :func:`check_log_likelihood` - ``fn(x, z, H, R) -> (N,)``: ``log N(z_s; H_s x^i, R_ss)`` for a cloud
  of the two-landmark model, ``s`` the measured coordinates of ``z`` (NaN for an unseen landmark),
  against :func:`landmark_log_likelihood`; the mistakes of :data:`LIKELIHOOD_MISTAKES` (NaN kept or
  read as 0, the offset ``r - l``, ``R`` read as standard deviations, the leading block of ``R``
  instead of the visible one, no normalising constant) are named.
* :func:`check_backward_weights` - ``fn(k, particles, weights, smoothed_next, log_transition) -> (N,)``:
  one backward step of FFBSm (the smoothing chapter), against :func:`backward_weights` to round-off;
  the mistakes of :data:`BACKWARD_MISTAKES` are named (the filter weight forgotten, the predictive
  density summed over the wrong axis, the transition of the wrong time).
* :func:`check_range_bearing_log_weights` - ``fn(x, landmark, z, R) -> (N,)``: the robot's
  ``log N(nu^i; 0, R)`` for a range-bearing reading, on a cloud that sees the landmark right behind
  it; the mistakes of :data:`RANGE_BEARING_MISTAKES` (bearing innovation not wrapped, heading not
  subtracted, ``R`` read as standard deviations, no normalising constant) are named.
* :func:`check_range_bearing_jacobian` - ``fn(state, landmark) -> (2, 3)``: the EKF's measurement
  Jacobian of range and bearing at three poses; the mistakes of :data:`JACOBIAN_MISTAKES` (offset
  reversed, ``+1`` for the heading, ``q`` for ``sqrt(q)``, ``dx`` and ``dy`` swapped) are named.
* :func:`check_consistency` - ``fn(errors, covariances) -> (average_nees, band, fraction)``: the
  NEES check of a filter over ``R`` runs (chapter 20), the run-averaged NEES per step, the 95 % band
  of an average of ``R`` chi-square variables with ``d`` degrees of freedom and the fraction of steps
  inside it, against :func:`nees_consistency`; the mistakes of :data:`CONSISTENCY_MISTAKES` (a single
  run's band, the band not divided by ``R``, ``P`` not inverted, a one-sided band, the runs summed)
  are named.
* :func:`check_ess` - ``fn(log_weights) -> ess``: the effective sample size ``1 / sum_i W_i^2`` from
  log-weights (chapter 18), on cases that underflow and overflow in the linear domain; weights not
  normalised, a fraction instead of a number and exponentiation without the maximum subtracted are named.
* :func:`check_lock_on` - ``fn(pos_err, head_err, dt, window_s) -> bool``: the book's one definition of
  *locked on* (:func:`pfcourse.metrics.locked_on`, chapter 19); the last step only, the heading ignored,
  the window read in steps and the whole run required are named.
* :func:`check_pose_density` - ``fn(x, z, landmark, sd) -> (N,)``: the log-density ``log q_z(x)`` of a
  pose drawn from a range-bearing reading (chapter 11), against :func:`pose_reading_log_density`; the
  mistakes of :data:`POSE_DENSITY_MISTAKES` (the bearing added, the Jacobian ``1 / h_r``, the
  direction's ``1 / (2 pi)`` or the truncation ``Phi(r / s_r)`` left out, the residual not wrapped,
  standard deviations read as variances) are named.
* :func:`check_likelihood_field` - ``fn(poses, z, field) -> (N,)``: the likelihood-field log-weights of one
  scan for a cloud of poses (Thrun, Burgard and Fox 2005, table 6.3), against :func:`field_log_weights`;
  the mistakes of :data:`FIELD_MISTAKES` (max-range beams kept, the heading left out of the beam's
  direction, no ``z_rand / z_max`` term, no Gaussian constant, a product of densities that underflows)
  are named.
* :func:`check_paired_se` - ``fn(a, b) -> (paired_se, unpaired_se)``: the standard error of a difference of
  means over the same runs, paired and as if unpaired (chapter 17); the population standard deviation,
  a division by ``n``, standard deviations added and the pairing ignored are named.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import stats
from scipy.special import logsumexp


@dataclass
class CheckReport:
    """Outcome of a check: ``ok`` when ``problems`` is empty."""

    name: str
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems

    def __str__(self) -> str:
        if self.ok:
            return f"{self.name}: every check passed"
        return f"{self.name}: {len(self.problems)} problem(s)\n" + "\n".join(f"- {p}" for p in self.problems)


def _answer(report: CheckReport, call: Callable, signature: str, what: str):
    """The student's answer ``call()``, or ``None`` after reporting, in one sentence, that the call
    raised (the student's error, reported, not raised) or returned ``None`` (``what`` to do instead)."""
    try:
        with np.errstate(all="ignore"):
            answer = call()
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling {signature} raised {type(exc).__name__}: {exc}")
        return None
    if answer is None:
        report.problems.append(f"the function returned None: {what}")
    return answer


_VARIANCE_MARGIN = 1.5  # a resampler adding more than 1.5 x multinomial's offspring variance is named


def check_resampler(fn: Callable, n_draws: int = 4000, seed: int = 0) -> CheckReport:
    """Check a resampler ``fn(weights, rng) -> N ancestor indices`` (see the module docstring).

    Unbiasedness: for weights ``W`` (``N = 7``, one of them 0) the copy counts ``N_i`` of
    ``n_draws`` calls must have mean ``N W_i`` within ``5 SE + 1e-9`` (SE from the sample
    standard deviation of the counts; a deterministic scheme with biased counts has SE 0 and
    fails). A correct unbiased scheme fails one of the 7 tests with probability below 1e-5.

    Variance: an unbiased scheme whose total offspring variance ``sum_i Var N_i`` exceeds
    ``1.5 sum_i N W_i (1 - W_i)``, multinomial resampling's, is named (one uniform shared by all
    particles gives ``Var N_i = N^2 W_i (1 - W_i)``, ``N`` times multinomial's). Multinomial,
    stratified, residual and systematic resampling stay at or below ``sum_i N W_i (1 - W_i)``; the
    relative standard error of the measured total is a few per cent over 4000 draws.
    """
    report = CheckReport("resampler")
    rng = np.random.default_rng(seed)
    w = np.array([0.05, 0.3, 0.0, 0.12, 0.08, 0.25, 0.2])
    n = w.size
    first = _answer(report, lambda: fn(w.copy(), rng), "fn(weights, rng)",
                    "write the resampler and return the N ancestor indices")
    if first is None:
        return report
    first = np.asarray(first)
    if first.shape != (n,):
        report.problems.append(f"returned shape {first.shape}; expected ({n},), one ancestor index per particle")
        return report
    if first.dtype.kind not in "iu":
        report.problems.append(f"returned dtype {first.dtype}; indices must be integers (use astype(int))")
        return report
    counts = np.empty((n_draws, n))
    for t in range(n_draws):
        idx = np.asarray(fn(w.copy(), rng))
        if idx.min() < 0 or idx.max() >= n:
            report.problems.append(
                f"draw {t}: an index is out of range [0, {n}) (got {idx.min()}..{idx.max()}); "
                "a cumulative sum that ends just below 1 needs its last value set to 1"
            )
            return report
        counts[t] = np.bincount(idx, minlength=n)
    if counts[:, 2].any():
        report.problems.append(
            "a particle of weight 0 was chosen: u must select the i with cumsum[i-1] < u <= cumsum[i] "
            "(np.searchsorted(np.cumsum(w), u)), which never lands on a zero-width interval"
        )
    mean, se = counts.mean(axis=0), counts.std(axis=0, ddof=1) / np.sqrt(n_draws)
    bad = np.abs(mean - n * w) > 5 * se + 1e-9
    if bad.any():
        i = int(np.argmax(np.abs(mean - n * w) - 5 * se))
        report.problems.append(
            f"biased: particle {i} of weight {w[i]} should get N W = {n * w[i]:.3f} copies on "
            f"average, it got {mean[i]:.3f} (± {se[i]:.3f}) over {n_draws} draws"
        )
    if np.all(counts.std(axis=0) == 0) and not np.allclose(n * w, np.round(n * w)):
        report.problems.append("the result never changes: the rng is not used")
    total_var, multinomial_var = counts.var(axis=0, ddof=1).sum(), float(np.sum(n * w * (1 - w)))
    if not bad.any() and total_var > _VARIANCE_MARGIN * multinomial_var:
        report.problems.append(
            f"the copy counts are right on average but too variable: sum of Var N_i is {total_var:.2f}, more "
            f"than multinomial resampling's sum of N W_i (1 - W_i) = {multinomial_var:.2f}; each particle "
            "needs a uniform of its own (u of shape (N,)), not one uniform shared by all"
        )
    try:
        idx = np.asarray(fn(np.full(n, 1.0 / n), rng))
        if idx.shape != (n,) or idx.min() < 0 or idx.max() >= n:
            report.problems.append("uniform weights give indices of the wrong shape or out of range")
    except Exception as exc:
        report.problems.append(f"uniform weights raised {type(exc).__name__}: {exc}")
    return report


def check_weight_update(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(log_weights, log_likelihoods) -> new normalised log-weights`` (module docstring)."""
    report = CheckReport("weight update")
    rng = np.random.default_rng(seed)
    cases = {
        "ordinary values": (np.log(rng.dirichlet(np.ones(50))), rng.normal(-3.0, 2.0, 50)),
        "likelihoods near e^-1000 (they underflow to 0 in the linear domain)": (
            np.full(50, -np.log(50)), rng.normal(-1000.0, 3.0, 50)),
        "one particle with weight 0 (log-weight -inf)": (
            np.concatenate([[-np.inf], np.full(49, -np.log(49))]), rng.normal(-3.0, 1.0, 50)),
    }
    for name, (logw, loglik) in cases.items():
        expected = logw + loglik - logsumexp(logw + loglik)
        try:
            with np.errstate(all="ignore"):
                answer = fn(logw.copy(), loglik.copy())
        except Exception as exc:
            report.problems.append(f"{name}: raised {type(exc).__name__}: {exc}")
            continue
        if answer is None:
            report.problems.append("the function returned None: write the update and return the new log-weights")
            break
        got = np.asarray(answer, dtype=float)
        if got.shape != expected.shape:
            report.problems.append(f"{name}: returned shape {got.shape}, expected {expected.shape}")
        elif np.isnan(got).any():
            report.problems.append(
                f"{name}: NaN in the result; subtract the largest log-weight before exponentiating "
                "(or use scipy.special.logsumexp)")
        elif not np.allclose(np.exp(got), np.exp(expected), atol=1e-12, rtol=1e-9):
            total = np.exp(got).sum()
            hint = " (they do not sum to 1: normalise)" if abs(total - 1) > 1e-9 else ""
            report.problems.append(f"{name}: wrong weights{hint}; largest error "
                                   f"{np.abs(np.exp(got) - np.exp(expected)).max():.2e}")
    return report


@dataclass(frozen=True)
class ScalarModel:
    """``x_0 ~ N(m0, p0)``, ``x_k = a x_{k-1} + w_k`` with ``w_k ~ N(0, q)``, ``z_k = x_k + v_k``
    with ``v_k ~ N(0, r)``: ``p0``, ``q`` and ``r`` are *variances*."""

    a: float = 0.9
    q: float = 0.5
    r: float = 0.5
    m0: float = 0.0
    p0: float = 1.0


def _scalar_filter(z: np.ndarray, model: ScalarModel, last_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance over the steps of the posterior the weighted cloud estimates.

    ``last_only=False``: the Kalman filter, ``p(x_k | z_{1:k})``, exact for this model
    (:func:`scalar_kalman`). With ``last_only=True``, the limit of an SIS whose weights forget the
    previous step: the prior marginal of ``x_j`` updated by ``z_j`` alone (``j`` the last measured
    step), moved on to ``k``.
    """
    if not last_only:
        return scalar_kalman(z, model)[:2]
    a, q, r = model.a, model.q, model.r
    mean, var = np.empty(len(z)), np.empty(len(z))
    m, p = model.m0, model.p0  # the forgetful posterior
    prior_m, prior_p = model.m0, model.p0  # the prior marginal of x_k
    for k, zk in enumerate(z):
        if k > 0:
            m, p = a * m, a * a * p + q
            prior_m, prior_p = a * prior_m, a * a * prior_p + q
        if not np.isnan(zk):
            gain = prior_p / (prior_p + r)
            m, p = prior_m + gain * (zk - prior_m), (1 - gain) * prior_p
        mean[k], var[k] = m, p
    return mean, var


#: The measurements of :func:`check_sis`: none at step 0 (the cloud is the prior), one missing later.
SIS_CASE = np.array([np.nan, 1.2, 2.0, np.nan, 0.3])


def check_sis(fn: Callable, n_particles: int = 20_000, seed: int = 0, z: np.ndarray = SIS_CASE) -> CheckReport:
    """Check a student's SIS ``fn(z, n_particles, rng, model) -> (means, ess)`` (module docstring).

    ``z`` (default :data:`SIS_CASE`) has shape ``(K,)`` with NaN where nothing is measured (at
    least at step 0); ``means`` and
    ``ess`` have shape ``(K,)``: the weighted mean of the particles and the effective sample size
    after each step. The means must agree with the Kalman filter's within six Monte Carlo
    standard errors, ``sqrt(P_k / ESS_k)``, at every step (a correct SIS fails this with
    probability below 1e-6); a filter that does not is compared with the limits of the typical
    mistakes, and the report names the one that fits.
    """
    report = CheckReport("SIS")
    model = ScalarModel()
    answer = _per_step_answer(
        report, lambda: fn(np.array(z, dtype=float), n_particles, np.random.default_rng(seed), model),
        "fn(z, n_particles, rng, model)", "(means, ess)", ("mean", "ESS"), z.size)
    if answer is None:
        return report
    means, ess = answer
    k_steps = z.size
    bad = ~(np.isfinite(means) & np.isfinite(ess))
    if bad.any():
        k = int(np.argmax(bad))
        why = ("z[0] is NaN (nothing measured): skip the weight update when z_k is NaN" if np.isnan(z[k])
               else "weights that all underflow to 0 give 0/0: keep log-weights and subtract their logsumexp")
        report.problems.append(f"the mean or the ESS is NaN or infinite at step {k}; {why}")
        return report
    if abs(ess[0] - n_particles) > 1e-6 * n_particles:
        report.problems.append(f"the ESS at step 0 is {ess[0]:.6g}, not N = {n_particles}: nothing is measured "
                               "at step 0, so every weight is 1/N")
        return report
    if (ess < 1 - 1e-9).any() or (ess > n_particles * (1 + 1e-9)).any():
        k = int(np.argmax((ess < 1 - 1e-9) | (ess > n_particles * (1 + 1e-9))))
        report.problems.append(f"the ESS at step {k} is {ess[k]:.4g}, outside [1, N]: compute it from normalised "
                               "weights, 1 / sum(W**2) with sum(W) = 1")
        return report
    exact = _scalar_filter(z, model)
    if _fits(means, ess, *exact):
        return report
    mistakes = {
        "the weights forget the previous steps: multiply the new likelihood into the previous weights "
        "(log W_k = log W_(k-1) + log p(z_k | x_k)) instead of replacing them":
            _scalar_filter(z, model, last_only=True),
        "the particles move without process noise: add w_k ~ N(0, q) with variance q (standard deviation "
        "sqrt(q)) when you propagate them": _scalar_filter(z, ScalarModel(q=0.0)),
        "the likelihood uses r as a standard deviation: r is the variance of v_k, so the standard deviation "
        "is sqrt(r)": _scalar_filter(z, ScalarModel(r=model.r**2)),
        "the process noise uses q as a standard deviation: q is the variance of w_k, so the standard "
        "deviation is sqrt(q)": _scalar_filter(z, ScalarModel(q=model.q**2)),
    }
    for why, (mean, var) in mistakes.items():
        if _fits(means, ess, mean, var):
            report.problems.append(f"your means match a known mistake, not the exact posterior: {why}")
            return report
    k = int(np.argmax(np.abs(means - exact[0]) / np.sqrt(exact[1] / np.clip(ess, 1, None))))
    report.problems.append(
        f"at step {k} your mean is {means[k]:.3f}, the exact (Kalman) mean is {exact[0][k]:.3f}, more than six "
        f"Monte Carlo standard errors ({np.sqrt(exact[1][k] / max(ess[k], 1)):.3f}) away: check the proposal "
        "(x_k = a x_(k-1) + w_k), the log-likelihood of z_k and the weighted mean")
    return report


def _per_step_answer(report: CheckReport, call: Callable, signature: str, returns: str, names: tuple[str, ...],
                     k_steps: int, todo: str = "write the filter",
                     per: str = "per step, step 0 included") -> tuple | None:
    """The student's answer ``call()``: the tuple ``returns`` names, whose first ``len(names)`` entries are
    arrays of one value per step, shape ``(k_steps,)``, converted to float; the rest as they are. ``None``,
    with the problem reported in one sentence, when the call raises or returns ``None``, the wrong number
    of values or arrays of the wrong shape. ``todo`` says what to write, ``per`` what each value belongs
    to (a step by default; a parent for a proposal)."""
    expected = returns.count(",") + 1
    answer = _answer(report, call, signature, f"{todo} and return {returns}")
    if answer is None:
        return None
    try:
        with np.errstate(all="ignore"):
            answer = tuple(answer)
            if len(answer) != expected:
                report.problems.append(f"the function returned {len(answer)} values; return {expected}: {returns}")
                return None
            arrays = [np.asarray(v, dtype=float) for v in answer[:len(names)]]
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling {signature} raised {type(exc).__name__}: {exc}")
        return None
    if any(v.shape != (k_steps,) for v in arrays):
        shapes = " and ".join(str(v.shape) for v in arrays)
        report.problems.append(f"returned shapes {shapes}; expected ({k_steps},) each: "
                               f"one {' and one '.join(names)} {per}")
        return None
    return (*arrays, *answer[len(names):])


def _fits(means: np.ndarray, ess: np.ndarray, mean: np.ndarray, var: np.ndarray, z_max: float = 6.0) -> bool:
    """Whether the cloud's means agree with a posterior's within ``z_max`` Monte Carlo standard errors."""
    return bool(np.all(np.abs(means - mean) <= z_max * np.sqrt(var / np.clip(ess, 1, None)) + 1e-12))


def _origins(ancestors: np.ndarray, steps: range) -> np.ndarray:
    """Follow ``a = ancestors[k][a]`` over ``steps``, starting from every particle of the final step."""
    a = np.arange(ancestors.shape[1])
    for k in steps:
        a = ancestors[k][a]
    return a


def check_ancestors(fn: Callable, seed: int = 0) -> CheckReport:
    """Check a student's genealogy ``fn(ancestors) -> origins`` on random ancestor indices.

    ``ancestors`` has shape ``(K, N)``: ``ancestors[k, i]`` is :math:`a_k^i`, the particle of step
    ``k - 1`` that particle ``i`` of step ``k`` descends from (row 0 is unused). The answer must be,
    for each particle ``i`` of the final step ``K - 1``, the particle of step 0 its lineage starts from,

    .. math:: o^i = a_1^{a_2^{\\cdots a_{K-1}^i}},

    that is ``a = ancestors[k][a]`` for ``k = K - 1, ..., 1``. A wrong answer is compared with
    what the typical mistakes give (the steps followed forwards, one generation only, the last
    step left out), so the report names the mistake.
    """
    report = CheckReport("genealogy")
    rng = np.random.default_rng(seed)
    n_steps, n = 7, 12
    ancestors = np.sort(rng.integers(0, n, size=(n_steps, n)), axis=1)  # sorted, as the resamplers return them
    ancestors[0] = np.arange(n)
    ancestors[3] = np.arange(n)  # a step without resampling: each particle is its own parent
    answer = _answer(report, lambda: fn(ancestors.copy()), "fn(ancestors)",
                     "follow the ancestors back and return the origins")
    if answer is None:
        return report
    answer = np.asarray(answer)
    if answer.shape != (n,):
        report.problems.append(f"returned shape {answer.shape}; expected ({n},): one step-0 origin per particle "
                               "of the final step")
        return report
    if np.array_equal(answer, _origins(ancestors, range(n_steps - 1, 0, -1))):
        return report
    mistakes = {
        "the steps are followed forwards (k = 1, 2, ...): a lineage is read backwards, from the final step "
        "to step 0, a = ancestors[k][a] for k = K - 1, ..., 1": _origins(ancestors, range(1, n_steps)),
        "only one generation is followed: ancestors[K - 1] gives the parents at step K - 2, and their own "
        "parents must be followed down to step 0": ancestors[-1],
        "the last step is left out: the lineage of a particle of step K - 1 starts with its parent "
        "ancestors[K - 1][i]": _origins(ancestors, range(n_steps - 2, 0, -1)),
    }
    for why, wrong in mistakes.items():
        if np.array_equal(answer, wrong):
            report.problems.append(f"your origins match a known mistake: {why}")
            return report
    i = int(np.argmax(answer != _origins(ancestors, range(n_steps - 1, 0, -1))))
    report.problems.append(f"particle {i} of the final step descends from particle "
                           f"{_origins(ancestors, range(n_steps - 1, 0, -1))[i]} of step 0, not {answer[i]}: "
                           "follow a = ancestors[k][a] from k = K - 1 down to k = 1")
    return report


# The Kalman checker (chapter 2, exercise 2.3). A scalar Kalman filter is deterministic, so the
# student's numbers must equal the exact ones to round-off; a filter that does not is compared
# with what each typical mistake computes, and the report names the mistake that fits.

#: The measurements of :func:`check_kalman`: none at step 0 (the filter starts from the prior), two missing later.
KALMAN_CASE = np.array([np.nan, 1.2, 2.0, np.nan, 0.3, np.nan, -0.4])

#: The typical mistakes of a scalar Kalman filter, each as the flag of :func:`scalar_kalman` that makes
#: it, with the sentence that names it (what is wrong, and why).
KALMAN_MISTAKES = {
    "gain_with_p": "the gain divides by the predicted variance P_k^- instead of the innovation variance "
                   "S_k = P_k^- + r: K_k = P_k^- / S_k weighs the prediction against the measurement noise",
    "no_q": "the predicted variance forgets the process noise: P_k^- = a^2 P_(k-1) + q, the state moves "
            "by w_k ~ N(0, q) at every step",
    "r_as_sd": "the update uses r as a standard deviation: r is the variance of v_k, so S_k = P_k^- + r, "
               "not P_k^- + r^2",
    "q_as_sd": "the prediction uses q as a standard deviation: q is the variance of w_k, so P_k^- = a^2 P_(k-1) "
               "+ q, not + q^2",
    "predict_at_0": "step 0 is predicted: the filter starts from N(m0, p0) at step 0 and predicts only from "
                    "step 1 on",
    "nan_as_zero": "a missing measurement (NaN) is used as z_k = 0: when nothing is measured, skip the update "
                   "(the filtering density is then the predicted one)",
    "no_update_of_p": "the variance is not updated: after a measurement P_k = (1 - K_k) P_k^-, smaller than P_k^-",
    "loglik_with_p": "the log-likelihood uses P_k^- where it needs S_k: the increment is log N(nu_k; 0, S_k), "
                     "the innovation's density, with S_k = P_k^- + r",
    "loglik_no_constant": "the log-likelihood misses the normalising term: log N(nu_k; 0, S_k) = "
                          "-(nu_k^2 / S_k + log(2 pi S_k)) / 2",
}


def scalar_kalman(z: np.ndarray, model: ScalarModel, mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """The Kalman filter of a :class:`ScalarModel`: ``(means, variances, log_likelihood)`` over the steps.

    Step 0 starts from ``N(m0, p0)``; step ``k > 0`` predicts ``m_k^- = a m_(k-1)``,
    ``P_k^- = a^2 P_(k-1) + q``. A measured ``z_k`` updates with the innovation
    ``nu_k = z_k - m_k^-``, its variance ``S_k = P_k^- + r`` and the gain ``K_k = P_k^- / S_k``:
    ``m_k = m_k^- + K_k nu_k``, ``P_k = (1 - K_k) P_k^-``, and adds
    ``log N(nu_k; 0, S_k) = -(nu_k^2 / S_k + log(2 pi S_k)) / 2`` to the log-likelihood; a NaN
    ``z_k`` (nothing measured) skips the update. ``mistake`` (a key of :data:`KALMAN_MISTAKES`)
    computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in KALMAN_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(KALMAN_MISTAKES)}")
    a = model.a
    q = model.q**2 if mistake == "q_as_sd" else 0.0 if mistake == "no_q" else model.q
    r = model.r**2 if mistake == "r_as_sd" else model.r
    m, p, log_lik = model.m0, model.p0, 0.0
    means, variances = np.empty(len(z)), np.empty(len(z))
    for k, zk in enumerate(z):
        if k > 0 or mistake == "predict_at_0":
            m, p = a * m, a * a * p + q
        if np.isnan(zk) and mistake == "nan_as_zero":
            zk = 0.0
        if not np.isnan(zk):
            nu, s = zk - m, p + r
            gain = 1.0 if mistake == "gain_with_p" else p / s
            s_lik = p if mistake == "loglik_with_p" else s
            log_lik += -0.5 * nu**2 / s_lik - (0.0 if mistake == "loglik_no_constant" else 0.5 * np.log(2 * np.pi * s_lik))
            m = m + gain * nu
            p = p if mistake == "no_update_of_p" else (1.0 - gain) * p
        means[k], variances[k] = m, p
    return means, variances, float(log_lik)


def check_kalman(fn: Callable, z: np.ndarray = KALMAN_CASE, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(z, model) -> (means, variances, log_likelihood)`` on a :class:`ScalarModel`.

    ``z`` (default :data:`KALMAN_CASE`) has shape ``(K,)``, NaN where nothing is measured;
    ``means`` and ``variances`` have shape ``(K,)``, the mean and variance of ``p(x_k | z_{1:k})``
    at every step, and ``log_likelihood`` is ``log p(z_{1:K}) = sum_k log N(nu_k; 0, S_k)``. The
    filter is deterministic, so each must equal :func:`scalar_kalman` to ``rtol``; a filter that
    does not is compared with every typical mistake of :data:`KALMAN_MISTAKES`, and the report
    names the one that fits.
    """
    report = CheckReport("Kalman filter")
    model = ScalarModel()
    z = np.array(z, dtype=float)
    answer = _per_step_answer(report, lambda: fn(z.copy(), model), "fn(z, model)",
                              "(means, variances, log_likelihood)", ("mean", "variance"), z.size)
    if answer is None:
        return report
    means, variances, log_lik = answer
    try:
        log_lik = float(np.asarray(log_lik, dtype=float).item())
    except (TypeError, ValueError):
        report.problems.append(f"the log-likelihood is {np.size(log_lik)} values, not one number: return the sum "
                               "of the increments log N(nu_k; 0, S_k) over the measured steps")
        return report
    bad = ~(np.isfinite(means) & np.isfinite(variances))
    if bad.any():
        k = int(np.argmax(bad))
        why = ("z_k is NaN (nothing measured): skip the update at such a step, the filtering density is then "
               "the predicted one" if np.isnan(z[k]) else "check the update of that step")
        report.problems.append(f"the mean or the variance is NaN or infinite at step {k}; {why}")
        return report
    if not np.isfinite(log_lik):
        report.problems.append("the log-likelihood is NaN or infinite: add log N(nu_k; 0, S_k) only at the steps "
                               "where something is measured (z_k not NaN)")
        return report

    def close(got, expected) -> bool:
        return bool(np.allclose(got, expected, rtol=rtol, atol=1e-12))

    exact = scalar_kalman(z, model)
    filtered = close(means, exact[0]) and close(variances, exact[1])
    if filtered and close(log_lik, exact[2]):
        return report
    for mistake, why in KALMAN_MISTAKES.items():
        wrong = scalar_kalman(z, model, mistake)
        if close(means, wrong[0]) and close(variances, wrong[1]) and (not filtered or close(log_lik, wrong[2])):
            if not (close(wrong[0], exact[0]) and close(wrong[1], exact[1])) or not close(wrong[2], exact[2]):
                report.problems.append(f"your filter computes a known mistake: {why}")
                return report
    if filtered:
        report.problems.append(
            f"the means and variances are right, the log-likelihood is not ({log_lik:.6f}, exact {exact[2]:.6f}): "
            "add log N(nu_k; 0, S_k) at every measured step and nothing at a missing one")
        return report
    wrong_means = ~np.isclose(means, exact[0], rtol=rtol, atol=1e-12)
    wrong_vars = ~np.isclose(variances, exact[1], rtol=rtol, atol=1e-12)
    k = int(np.argmax(wrong_means | wrong_vars))
    report.problems.append(
        f"at step {k} your mean and variance are {means[k]:.6f} and {variances[k]:.6f}, the exact ones "
        f"{exact[0][k]:.6f} and {exact[1][k]:.6f}: check the prediction (m_k^- = a m_(k-1), P_k^- = a^2 P_(k-1) + q) "
        "and the update of that step")
    return report


# The optimal proposal of the scalar model (chapter "Better importance functions"): the student
# writes the mean and variance of p(x_k | x_(k-1), z_k) and the log-weight log p(z_k | x_(k-1)),
# which are deterministic, so they must equal the exact formulas to round-off; a wrong answer is
# compared with what each typical mistake computes, and the report names the mistake that fits.

#: The parents and the measurement of :func:`check_optimal_proposal`.
PROPOSAL_PARENTS = np.array([-1.5, -0.2, 0.4, 1.1, 2.3])
PROPOSAL_Z = 0.8
#: The model of :func:`check_optimal_proposal`: ``q``, ``r`` and ``q + r`` all differ, so that a
#: variance put in the place of another is seen.
PROPOSAL_MODEL = ScalarModel(q=0.5, r=0.2)


def _log_normal(x: np.ndarray, mean: np.ndarray | float, var: float) -> np.ndarray:
    """``log N(x; mean, var)`` of a scalar Gaussian, elementwise."""
    return -0.5 * ((x - mean) ** 2 / var + np.log(2 * np.pi * var))


def scalar_optimal_proposal(x_prev: np.ndarray, z: float, model: ScalarModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The optimal proposal of a :class:`ScalarModel`: ``(means, variances, log_weights)`` per parent.

    .. math::

       p(x_k | x_{k-1}, z_k) = \\mathcal N\\big(\\sigma^2 (a x_{k-1} / q + z_k / r),\\ \\sigma^2\\big),
       \\quad \\sigma^2 = (1/q + 1/r)^{-1}, \\qquad
       \\log p(z_k | x_{k-1}) = \\log \\mathcal N(z_k;\\ a x_{k-1},\\ q + r).
    """
    x_prev = np.asarray(x_prev, dtype=float)
    var = 1.0 / (1.0 / model.q + 1.0 / model.r)
    return var * (model.a * x_prev / model.q + z / model.r), np.full(x_prev.shape, var), \
        _log_normal(z, model.a * x_prev, model.q + model.r)


def _proposal_mistakes(x: np.ndarray, z: float, model: ScalarModel) -> dict[str, dict[str, np.ndarray]]:
    """What each typical mistake computes, by output (mean, variance, log-weight), with its sentence."""
    a, q, r = model.a, model.q, model.r
    right, added = 1.0 / (1.0 / q + 1.0 / r), q + r
    m = right * (a * x / q + z / r)
    return {
        "variance": {
            "the variances are added (q + r) where the precisions add: 1 / sigma^2 = 1 / q + 1 / r, since "
            "both the transition and the measurement inform x_k": np.full(x.shape, added),
            "the variance is q, the transition's: conditioning on z_k shrinks it to (1/q + 1/r)^(-1)":
                np.full(x.shape, q),
        },
        "mean": {
            "the mean is the prediction a x_(k-1), blind to z_k: it is sigma^2 (a x_(k-1) / q + z_k / r), "
            "a precision-weighted average of prediction and measurement": a * x,
            "the mean misses the factor sigma^2: it is sigma^2 (a x_(k-1) / q + z_k / r), not the bare sum "
            "of the precision-weighted terms": a * x / q + z / r,
            "the mean uses q + r as its variance: the variances were added where the precisions add, "
            "sigma^2 = (1/q + 1/r)^(-1)": added * (a * x / q + z / r),
            "the mean forgets the dynamics' factor a: the prediction of x_k is a x_(k-1), not x_(k-1)":
                right * (x / q + z / r),
        },
        "log-weight": {
            "the log-weight uses the variance q alone: z_k = a x_(k-1) + w_k + v_k, so its variance given "
            "x_(k-1) is q + r": _log_normal(z, a * x, q),
            "the log-weight uses the variance r alone: z_k = a x_(k-1) + w_k + v_k, so its variance given "
            "x_(k-1) is q + r": _log_normal(z, a * x, r),
            "the log-weight is evaluated at the new particle (the proposal's mean) instead of the parent: "
            "the weight p(z_k | x_(k-1)) = N(z_k; a x_(k-1), q + r) depends only on x_(k-1)": _log_normal(z, m, r),
            "the log-weight is evaluated at the new particle's mean with variance q + r: the weight "
            "p(z_k | x_(k-1)) = N(z_k; a x_(k-1), q + r) is centred on the parent's prediction":
                _log_normal(z, m, added),
        },
    }


def check_optimal_proposal(fn: Callable, x_prev: np.ndarray = PROPOSAL_PARENTS, z: float = PROPOSAL_Z,
                           rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x_prev, z, model) -> (means, variances, log_weights)`` on a :class:`ScalarModel`.

    The model is :data:`PROPOSAL_MODEL`; ``x_prev`` (default :data:`PROPOSAL_PARENTS`) holds the parents ``x_{k-1}^i``, shape ``(N,)``, and
    ``z`` is one measurement; each output has shape ``(N,)``: the mean and variance of
    ``p(x_k | x_{k-1}^i, z_k)`` and ``log p(z_k | x_{k-1}^i)``. They must equal
    :func:`scalar_optimal_proposal` to ``rtol``, the log-weights up to one constant common to all
    parents (it cancels when the weights are normalised). A wrong output is compared with what each
    typical mistake of that output computes, and the report names the one that fits.
    """
    report = CheckReport("optimal proposal")
    model = PROPOSAL_MODEL
    x = np.array(x_prev, dtype=float)
    answer = _per_step_answer(report, lambda: fn(x.copy(), float(z), model), "fn(x_prev, z, model)",
                              "(means, variances, log_weights)", ("mean", "variance", "log-weight"), x.size,
                              todo="write the proposal", per="per parent")
    if answer is None:
        return report
    exact = scalar_optimal_proposal(x, z, model)
    outputs = dict(zip(("mean", "variance", "log-weight"), answer))

    def close(name: str, got: np.ndarray, expected: np.ndarray) -> bool:
        if name == "log-weight":  # a constant common to all parents cancels in the normalisation
            got, expected = got - got[0], expected - expected[0]
        return bool(np.all(np.isfinite(got)) and np.allclose(got, expected, rtol=rtol, atol=1e-12))

    mistakes = _proposal_mistakes(x, z, model)
    for (name, got), expected in zip(outputs.items(), exact):
        if close(name, got, expected):
            continue
        why = next((why for why, wrong in mistakes[name].items() if close(name, got, wrong)), None)
        if why is not None:
            report.problems.append(f"your {name} computes a known mistake: {why}")
            continue
        i = int(np.argmax(~np.isclose(got, expected, rtol=rtol, atol=1e-12) | ~np.isfinite(got)))
        report.problems.append(
            f"for the parent x_(k-1) = {x[i]:g} your {name} is {got[i]:.6f}, the exact one {expected[i]:.6f}: "
            "the proposal is N(sigma^2 (a x_(k-1) / q + z_k / r), sigma^2) with sigma^2 = (1/q + 1/r)^(-1), "
            "the log-weight log N(z_k; a x_(k-1), q + r)")
    return report


# --- Rao-Blackwellised filter: one particle's Kalman update of its map (chapter 8) ---

LANDMARK_MISTAKES: dict[str, str] = {
    "no_robot": "the innovation forgets the robot: the measurement is relative to the particle's robot, "
                "nu = z - A r - C m, not z - C m",
    "robot_sign": "the robot's term has the wrong sign: z = A r + C l + v, so nu = z - A r - C m",
    "s_without_r": "the innovation covariance misses the measurement noise: S = C P C^T + R, not C P C^T",
    "no_cov_update": "the covariance is not updated: after a measurement P' = (I - K C) P, smaller than P",
    "loglik_with_r": "the weight uses R where it needs S: the map is uncertain, so the predictive likelihood "
                     "is N(nu; 0, C P C^T + R), not N(nu; 0, R)",
}


def landmark_update(robot: np.ndarray, m: np.ndarray, P: np.ndarray, z: np.ndarray, A: np.ndarray, C: np.ndarray,
                    R: np.ndarray, mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, float]:
    """One particle's map update given its robot ``r``: ``(m', P', log N(nu; 0, S))``.

    ``z = A r + C l + v``, ``v ~ N(0, R)``, map ``l ~ N(m, P)``: innovation ``nu = z - A r - C m``,
    ``S = C P C^T + R``, gain ``K = P C^T S^{-1}``, ``m' = m + K nu``, ``P' = (I - K C) P``, and the
    particle's log-weight increment ``log N(nu; 0, S)``. ``mistake`` (a key of
    :data:`LANDMARK_MISTAKES`) computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in LANDMARK_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(LANDMARK_MISTAKES)}")
    robot_term = 0.0 if mistake == "no_robot" else -(A @ robot) if mistake == "robot_sign" else A @ robot
    nu = z - robot_term - C @ m
    S = C @ P @ C.T + (0.0 if mistake == "s_without_r" else R)
    gain = P @ C.T @ np.linalg.inv(S)
    cov = P if mistake == "no_cov_update" else (np.eye(len(m)) - gain @ C) @ P
    S_lik = R if mistake == "loglik_with_r" else S
    log_lik = -0.5 * (nu @ np.linalg.solve(S_lik, nu) + np.linalg.slogdet(2 * np.pi * S_lik)[1])
    return m + gain @ nu, cov, float(log_lik)


#: A particle of the two-landmark model seeing landmark 1: robot, map mean and covariance, z, A, C, R.
LANDMARK_CASE = dict(
    robot=np.array([0.7, -0.4]), m=np.array([2.0, 1.5, -1.0, 2.5]),
    P=np.array([[0.30, 0.05, 0.0, 0.0], [0.05, 0.20, 0.0, 0.0], [0.0, 0.0, 0.25, -0.04], [0.0, 0.0, -0.04, 0.35]]),
    z=np.array([1.1, 2.2]), A=-np.eye(2), C=np.hstack([np.eye(2), np.zeros((2, 2))]), R=0.01 * np.eye(2))


def check_landmark_update(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(robot, m, P, z, A, C, R) -> (m_new, P_new, log_lik)`` on :data:`LANDMARK_CASE`.

    The update is deterministic, so each output must equal :func:`landmark_update` to ``rtol``;
    one that does not is compared with every mistake of :data:`LANDMARK_MISTAKES`, and the report
    names the one that fits.
    """
    report = CheckReport("map update of one particle")
    case = {key: value.copy() for key, value in LANDMARK_CASE.items()}
    answer = _answer(report, lambda: fn(**case), "fn(robot, m, P, z, A, C, R)", "return (m_new, P_new, log_lik)")
    if answer is None:
        return report
    try:
        m_new, P_new, log_lik = answer
        m_new, P_new = np.asarray(m_new, dtype=float), np.asarray(P_new, dtype=float)
        log_lik = float(np.asarray(log_lik, dtype=float).item())
    except (TypeError, ValueError):
        report.problems.append("return three things: the new map mean (shape (4,)), its covariance (4, 4) and the "
                               "log-weight increment, one number")
        return report
    if m_new.shape != (4,) or P_new.shape != (4, 4):
        report.problems.append(f"the mean has shape {m_new.shape} and the covariance {P_new.shape}: expected (4,) "
                               "and (4, 4), the whole map of the particle")
        return report

    def same(got, expected) -> bool:
        return all(np.allclose(g, e, rtol=rtol, atol=1e-12) for g, e in zip(got, expected))

    got = (m_new, P_new, log_lik)
    if same(got, landmark_update(**LANDMARK_CASE)):
        return report
    for mistake, why in LANDMARK_MISTAKES.items():
        if same(got, landmark_update(**LANDMARK_CASE, mistake=mistake)):
            report.problems.append(f"your update computes a known mistake: {why}")
            return report
    exact = landmark_update(**LANDMARK_CASE)
    part = "mean" if not np.allclose(m_new, exact[0]) else "covariance" if not np.allclose(P_new, exact[1]) else \
        "log-weight increment"
    report.problems.append(f"the {part} differs from the Kalman update (nu = z - A r - C m, S = C P C^T + R, "
                           "K = P C^T S^-1, m' = m + K nu, P' = (I - K C) P, log N(nu; 0, S)): check that line")
    return report


# --- Auxiliary particle filter: the second-stage weights (chapter 9) ---

APF_MISTAKES: dict[str, str] = {
    "no_division": "the first stage is not divided out: the ancestors were chosen in proportion to p^(z_k | x_(k-1)), "
                   "so the second-stage weight is p(z_k | x_k^i) / p^(z_k | x_(k-1)^(a_i))",
    "own_index": "the division uses particle i's own first-stage value: divide by that of its ancestor, "
                 "log_pred[ancestors], since particle i was moved from x_(k-1)^(a_i)",
    "multiplied": "the first-stage value is multiplied in again instead of divided out: subtract "
                  "log_pred[ancestors], do not add it",
    "unnormalised": "the log-weights are not normalised: subtract their logsumexp so the weights sum to one",
}


def apf_second_stage(log_lik: np.ndarray, log_pred: np.ndarray, ancestors: np.ndarray,
                     mistake: str | None = None) -> np.ndarray:
    """Normalised second-stage log-weights of the auxiliary filter with the transition as proposal.

    ``log W_k^i = log p(z_k | x_k^i) - log p^(z_k | x_(k-1)^(a_i)) - logsumexp(...)``: the transition
    and the proposal cancel, and the first-stage approximation ``p^`` of the ancestor is divided
    out. ``mistake`` (a key of :data:`APF_MISTAKES`) computes instead what that mistake computes.
    """
    if mistake is not None and mistake not in APF_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(APF_MISTAKES)}")
    pred = {"no_division": 0.0, "own_index": log_pred, "multiplied": -log_pred[ancestors]}.get(mistake,
                                                                                                 log_pred[ancestors])
    log_w = log_lik - pred
    return log_w if mistake == "unnormalised" else log_w - logsumexp(log_w)


def check_apf_second_stage(fn: Callable, n: int = 12, seed: int = 0) -> CheckReport:
    """Check a student's ``fn(log_lik, log_pred, ancestors) -> log_weights`` against :func:`apf_second_stage`.

    ``log_lik`` holds ``log p(z_k | x_k^i)`` of the moved particles, ``log_pred`` the first-stage
    ``log p^(z_k | x_(k-1)^j)`` of the parents, ``ancestors`` the chosen parent of each particle.
    A wrong answer is compared with each mistake of :data:`APF_MISTAKES`, and the report names it.
    """
    report = CheckReport("second-stage weights")
    rng = np.random.default_rng(seed)
    log_lik, log_pred = rng.normal(-3.0, 2.0, n), rng.normal(-3.0, 2.0, n)
    ancestors = np.sort(rng.integers(0, n, n))
    answer = _answer(report, lambda: fn(log_lik.copy(), log_pred.copy(), ancestors.copy()),
                     "fn(log_lik, log_pred, ancestors)", "return the normalised log-weights, shape (N,)")
    if answer is None:
        return report
    got = np.asarray(answer, dtype=float)
    if got.shape != (n,):
        report.problems.append(f"the answer has shape {got.shape}: return one log-weight per particle, shape ({n},)")
        return report
    if np.allclose(got, apf_second_stage(log_lik, log_pred, ancestors), atol=1e-10):
        return report
    for mistake, why in APF_MISTAKES.items():
        if np.allclose(got, apf_second_stage(log_lik, log_pred, ancestors, mistake), atol=1e-10):
            report.problems.append(f"your weights compute a known mistake: {why}")
            return report
    report.problems.append("the log-weights differ from log p(z_k | x_k^i) - log p^(z_k | x_(k-1)^(a_i)), normalised: "
                           "check each term")
    return report


# The log-likelihood of a cloud of particles in the two-landmark model (chapter 1, exercise 1.4).
# H maps the state (r_x, r_y, l1_x, l1_y, l2_x, l2_y) to the offsets l^j - r; R has a different
# variance per landmark, so that its visible block differs from its leading block.
LIKELIHOOD_H = np.kron(np.hstack([-np.ones((2, 1)), np.eye(2)]), np.eye(2))
LIKELIHOOD_R = np.diag([0.01, 0.01, 0.04, 0.04]) + np.diag([0.004, 0.0, 0.01], 1) + np.diag([0.004, 0.0, 0.01], -1)
LIKELIHOOD_CASES = (np.array([1.2, 0.6, 0.8, -0.4]), np.array([np.nan, np.nan, 0.9, -0.3]),
                    np.array([1.1, 0.5, np.nan, np.nan]), np.full(4, np.nan))
LIKELIHOOD_MISTAKES = {
    "nan_as_zero": "it replaces a missing coordinate by 0 and keeps the whole R; an unmeasured landmark must "
                   "leave the density: keep only the rows of z and H that are measured and the block R[seen, seen]",
    "reversed_offset": "it predicts the measurement as r - l, the offset reversed; the model measures l^j - r, "
                       "that is H x with H's -I block on the robot",
    "r_as_sd": "it uses R as a matrix of standard deviations (R squared as the covariance); R is already the "
               "covariance of the measurement noise, in m²",
    "leading_block": "it takes the leading block R[:n, :n] of R instead of the block of the measured coordinates, "
                     "R[seen][:, seen]; the two differ when the visible landmark is not the first",
    "no_constant": "it misses the normalising term -(n log(2 pi) + log det R_seen) / 2, which the exercise asks "
                   "for (it changes with the number n of coordinates measured)",
}


def _per_particle_answers(report: CheckReport, calls: list[Callable], n_particles: int,
                          signature: str) -> list[np.ndarray] | None:
    """The answers of ``calls`` (one per case), each one log-likelihood per particle, ``(n_particles,)``;
    ``None`` after reporting, in one sentence, the first call that raised, returned None or the wrong shape."""
    answers = []
    for call in calls:
        answer = _answer(report, call, signature, "compute and return one log-likelihood per particle")
        if answer is None:
            return None
        answer = np.asarray(answer, dtype=float)
        if answer.shape != (n_particles,):
            report.problems.append(f"the answer has shape {answer.shape}, not ({n_particles},): return one "
                                   "log-likelihood per particle (a row of x)")
            return None
        answers.append(answer)
    return answers


def landmark_log_likelihood(x: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray,
                            mistake: str | None = None) -> np.ndarray:
    """``log N(z_s; H_s x^i, R_ss)`` for every particle ``x^i`` (rows of ``x``), with ``s`` the
    measured (non-NaN) coordinates of ``z``, ``H_s`` their rows of ``H`` and ``R_ss`` their block of
    ``R``; ``0`` for every particle when nothing is measured. ``mistake`` (a key of
    :data:`LIKELIHOOD_MISTAKES`) computes that mistake instead."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    seen = ~np.isnan(z)
    if mistake == "nan_as_zero":
        seen = np.ones(z.size, dtype=bool)
    if not seen.any():
        return np.zeros(len(x))
    n = int(seen.sum())
    predicted = x @ H[seen].T * (-1.0 if mistake == "reversed_offset" else 1.0)
    d = np.where(np.isnan(z[seen]), 0.0, z[seen] - predicted)
    block = R[:n, :n] if mistake == "leading_block" else R[np.ix_(seen, seen)]
    if mistake == "r_as_sd":
        block = block @ block
    quad = np.einsum("ij,ij->i", d @ np.linalg.inv(block), d)
    constant = 0.0 if mistake == "no_constant" else n * np.log(2 * np.pi) + np.linalg.slogdet(block)[1]
    return -0.5 * (quad + constant)


def check_log_likelihood(fn: Callable, n_particles: int = 50, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, H, R) -> (N,)``, the log-likelihoods ``log p(z | x^i)`` of a cloud.

    ``x`` has shape ``(N, 6)`` (particles of the two-landmark model), ``z`` shape ``(4,)`` with NaN
    for an unseen landmark. Each case of :data:`LIKELIHOOD_CASES` (both landmarks seen, only the
    second, only the first, none) must equal :func:`landmark_log_likelihood` to ``rtol``; an answer
    that does not is compared with each mistake of :data:`LIKELIHOOD_MISTAKES`, and the report names
    the one that fits.
    """
    report = CheckReport("log-likelihood")
    x = np.random.default_rng(seed).normal([2.0, 0.0, 3.0, 0.5, 3.0, -0.5], 0.3, size=(n_particles, 6))
    answers = _per_particle_answers(
        report, [lambda z=z: fn(x.copy(), z.copy(), LIKELIHOOD_H.copy(), LIKELIHOOD_R.copy()) for z in LIKELIHOOD_CASES],
        n_particles, "fn(x, z, H, R)")
    if answers is None:
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("the log-likelihood is NaN when a landmark is out of view: drop the NaN "
                               "coordinates of z, with their rows of H and their rows and columns of R")
        return report
    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, landmark_log_likelihood(x, z, LIKELIHOOD_H, LIKELIHOOD_R, mistake),
                               rtol=rtol, atol=1e-9) for a, z in zip(answers, LIKELIHOOD_CASES))

    if fits(None):
        return report
    for mistake, why in LIKELIHOOD_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    if np.any(answers[-1] != 0.0):
        report.problems.append("with nothing in view (z all NaN) the likelihood is the constant 1: return "
                               "zeros, one per particle")
        return report
    case = next(c for c, (a, z) in enumerate(zip(answers, LIKELIHOOD_CASES))
                if not np.allclose(a, landmark_log_likelihood(x, z, LIKELIHOOD_H, LIKELIHOOD_R), rtol=rtol, atol=1e-9))
    report.problems.append(f"with z = {LIKELIHOOD_CASES[case]} the values differ from log N(z_s; H_s x, R_ss): "
                           "check the quadratic form (z_s - H_s x)^T R_ss^-1 (z_s - H_s x) and the term -(1/2)")
    return report


# The NEES consistency check over R runs (chapter 20, exercise 20.1): errors of shape (R, K, d) and
# covariances (R, K, d, d) of a filter that is consistent at most steps, over-confident at a few.
CONSISTENCY_MISTAKES = {
    "one_run_band": "its band is that of a single run, chi2_d quantiles; the average of R independent chi2_d "
                    "values is chi2_(R d) / R, a band R times narrower in relative terms",
    "band_not_divided": "its band is the chi2_(R d) quantiles themselves, not divided by R: that is the band of "
                        "the sum over the runs, while the function returns their average",
    "cov_not_inverted": "it computes e^T P e; the NEES weighs the error by the inverse covariance, e^T P^-1 e",
    "one_sided": "its band is one-sided (0 up to the 95 % quantile); a consistent filter's average must be "
                 "neither too large nor too small, so cut 2.5 % from each side",
    "summed": "it sums the NEES over the runs instead of averaging them; the band is for the average",
}


def nees_consistency(errors: np.ndarray, covariances: np.ndarray, probability: float = 0.95,
                     mistake: str | None = None) -> tuple[np.ndarray, tuple[float, float], float]:
    """The NEES check over ``R`` runs: ``NEES_rk = e_rk^T P_rk^-1 e_rk``, its average over the runs per
    step, the band ``chi2_(R d)^-1(a/2, 1 - a/2) / R`` (``a = 1 - probability``) and the fraction of the
    steps whose average lies in it. ``mistake`` (a key of :data:`CONSISTENCY_MISTAKES`) computes that
    mistake instead."""
    from scipy import stats

    errors, covariances = np.asarray(errors, dtype=float), np.asarray(covariances, dtype=float)
    R, _, d = errors.shape
    weight = covariances if mistake == "cov_not_inverted" else np.linalg.inv(covariances)
    nees = np.einsum("rki,rkij,rkj->rk", errors, weight, errors)
    average = nees.sum(axis=0) if mistake == "summed" else nees.mean(axis=0)
    alpha = 1.0 - probability
    quantiles = [0.0, 1 - alpha] if mistake == "one_sided" else [alpha / 2, 1 - alpha / 2]
    dof, scale = (d, 1.0) if mistake == "one_run_band" else (R * d, 1.0 if mistake == "band_not_divided" else R)
    low, high = (float(v) for v in stats.chi2.ppf(quantiles, dof) / scale)
    return average, (low, high), float(np.mean((average >= low) & (average <= high)))


def _consistency_case(seed: int = 0, runs: int = 20, steps: int = 60, d: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Errors drawn from the covariances (a consistent filter) except over steps 40-49, where the true
    errors are twice as large as the covariance says (an over-confident spell)."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(runs, steps, d, d))
    covariances = np.einsum("rkij,rklj->rkil", a, a) / d + 0.1 * np.eye(d)
    errors = np.einsum("rkij,rkj->rki", np.linalg.cholesky(covariances), rng.normal(size=(runs, steps, d)))
    errors[:, 40:50] *= 2.0
    return errors, covariances


def check_consistency(fn: Callable, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(errors, covariances) -> (average_nees, (low, high), fraction)``.

    On :func:`_consistency_case` (20 runs, 60 steps, 3 dimensions), the three answers must equal
    :func:`nees_consistency` to ``rtol``; a wrong answer is compared with each mistake of
    :data:`CONSISTENCY_MISTAKES` and the report names the one that fits.
    """
    report = CheckReport("NEES consistency check")
    errors, covariances = _consistency_case(seed)
    answer = _answer(report, lambda: fn(errors.copy(), covariances.copy()), "fn(errors, covariances)",
                     "return (average_nees, (low, high), fraction)")
    if answer is None:
        return report
    try:
        average, band, fraction = answer
        average, band, fraction = np.asarray(average, dtype=float), tuple(float(b) for b in band), float(fraction)
    except (TypeError, ValueError):
        report.problems.append("the answer is not (average_nees, (low, high), fraction): return the per-step "
                               "average, the band as two numbers and the fraction of steps inside it")
        return report
    if average.shape != (errors.shape[1],):
        report.problems.append(f"average_nees has shape {average.shape}, not ({errors.shape[1]},): average the "
                               "NEES over the runs (axis 0), one value per step")
        return report

    def fits(mistake: str | None) -> bool:
        ref_average, ref_band, ref_fraction = nees_consistency(errors, covariances, mistake=mistake)
        return (np.allclose(average, ref_average, rtol=rtol) and np.allclose(band, ref_band, rtol=rtol)
                and abs(fraction - ref_fraction) < 1e-12)

    if fits(None):
        return report
    for mistake, why in CONSISTENCY_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    ref_average, ref_band, _ = nees_consistency(errors, covariances)
    if not np.allclose(average, ref_average, rtol=rtol):
        report.problems.append("the run-averaged NEES differs from the mean over the runs of e^T P^-1 e: check "
                               "the quadratic form, step by step and run by run")
    elif not np.allclose(band, ref_band, rtol=rtol):
        report.problems.append(f"the band {band} differs from the 2.5 % and 97.5 % quantiles of chi2_(R d) "
                               f"divided by R, {tuple(round(b, 4) for b in ref_band)}")
    else:
        report.problems.append("the fraction differs from the share of steps whose average lies inside the "
                               "band, bounds included")
    return report


# The effective sample size from log-weights (chapter 18, exercise 18.1): cases whose weights underflow
# (log-weights near -1000) or overflow (near +800) in the linear domain, and an ordinary one.
ESS_CASES = (np.log(np.array([0.5, 0.25, 0.125, 0.125])), np.array([-1000.0, -1001.0, -1000.5, -1003.0, -1000.0]),
             np.array([800.0, 799.0, 801.0]), np.array([0.0, -np.inf, -1.0, -2.0]))
ESS_MISTAKES = {
    "not_normalised": "it computes 1 / sum(w^2) from weights that do not sum to one; normalise first, "
                      "W_i = w_i / sum_j w_j, then ESS = 1 / sum_i W_i^2",
    "fraction": "it returns ESS / N, a fraction; the exercise asks for the effective number of particles",
    "sum_over_sum_of_squares_linear": "it exponentiates the log-weights without subtracting their maximum, so they "
                                      "underflow to 0 or overflow to inf; subtract max(log w) before exp "
                                      "(the ESS does not change)",
}


def effective_sample_size_from_logs(log_weights: np.ndarray, mistake: str | None = None) -> float:
    """``ESS = 1 / sum_i W_i^2`` with ``W_i = exp(l_i - logsumexp(l))`` for log-weights ``l`` (any
    constant added to them cancels). ``mistake`` (a key of :data:`ESS_MISTAKES`) computes it instead."""
    log_weights = np.asarray(log_weights, dtype=float)
    with np.errstate(all="ignore"):
        if mistake == "not_normalised":
            w = np.exp(log_weights - np.max(log_weights))
            return float(1.0 / np.sum(w**2))
        if mistake == "sum_over_sum_of_squares_linear":
            w = np.exp(log_weights)
            return float(np.sum(w) ** 2 / np.sum(w**2))
        w = np.exp(log_weights - logsumexp(log_weights))
        ess = float(1.0 / np.sum(w**2))
    return ess / len(log_weights) if mistake == "fraction" else ess


def check_ess(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(log_weights) -> ess`` on :data:`ESS_CASES` against
    :func:`effective_sample_size_from_logs`; the mistakes of :data:`ESS_MISTAKES` are named."""
    report = CheckReport("effective sample size")
    answers = []
    for case in ESS_CASES:
        answer = _answer(report, lambda: fn(case.copy()), "fn(log_weights)", "return the ESS, a number")
        if answer is None:
            return report
        try:
            answers.append(float(answer))
        except (TypeError, ValueError):
            report.problems.append(f"the answer {answer!r} is not a number: return the ESS as one float")
            return report

    def fits(mistake: str | None) -> bool:
        expected = [effective_sample_size_from_logs(c, mistake) for c in ESS_CASES]
        return all((np.isnan(a) and np.isnan(e)) or np.isclose(a, e, rtol=rtol) for a, e in zip(answers, expected))

    if fits(None):
        return report
    for mistake, why in ESS_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    if any(not np.isfinite(a) for a in answers):
        report.problems.append("the ESS is not finite for log-weights near -1000 or +800: work in the log domain "
                               "(subtract the largest log-weight, or use logsumexp) before exponentiating")
        return report
    report.problems.append("the values differ from 1 / sum_i W_i^2 with normalised weights W_i; a weight of 0 "
                           "(log-weight -inf) must count for nothing")
    return report


# Locked on, the book's one definition (chapter 19, exercise 19.1): runs of per-step errors whose verdict
# differs between the right definition and each mistake.
LOCK_MISTAKES = {
    "last_step": "it looks at the last step only; locked on means within the tolerances at every step of the "
                 "last window_s seconds",
    "position_only": "it ignores the heading; a robot within 1 m but facing the wrong way is not locked on",
    "window_in_steps": "it reads window_s as a number of steps; with a step of dt seconds the window holds "
                       "ceil(window_s / dt) steps",
    "whole_run": "it requires the tolerances over the whole run; only the last window_s seconds count",
}


def lock_on_cases() -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Runs ``(pos_err, head_err, dt)``: each separates the right definition from at least one mistake."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M

    good_p, good_h = 0.5 * LOCK_POSITION_M, 0.5 * LOCK_HEADING_RAD
    cases = []
    p, h = np.full(60, good_p), np.full(60, good_h)
    p[50] = 3.0  # off 10 s before the end: not locked (last_step says locked)
    cases.append((p, h.copy(), 1.0))
    p, h = np.full(60, good_p), np.full(60, good_h)
    h[-5:] = 3 * LOCK_HEADING_RAD  # heading off at the end (position_only says locked)
    cases.append((p, h, 1.0))
    p, h = np.full(120, good_p), np.full(120, good_h)
    p[90] = 3.0  # dt = 0.5 s: step 90 is 15 s before the end, inside the 20 s window (20 steps: outside)
    cases.append((p, h, 0.5))
    p, h = np.full(60, good_p), np.full(60, good_h)
    p[:10] = 50.0  # lost at the start, locked at the end (whole_run says not locked)
    cases.append((p, h, 1.0))
    return cases


def lock_on_reference(pos_err: np.ndarray, head_err: np.ndarray, dt: float, window_s: float = 20.0,
                      mistake: str | None = None) -> bool:
    """:func:`pfcourse.metrics.locked_on`, or a mistake of :data:`LOCK_MISTAKES`."""
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M, locked_on

    ok = (pos_err < LOCK_POSITION_M) & (head_err < LOCK_HEADING_RAD)
    if mistake == "last_step":
        return bool(ok[-1])
    if mistake == "position_only":
        return locked_on(pos_err, np.zeros_like(head_err), dt, window_s)
    if mistake == "window_in_steps":
        return bool(np.all(ok[-int(window_s):]))
    if mistake == "whole_run":
        return bool(np.all(ok))
    return locked_on(pos_err, head_err, dt, window_s)


def check_lock_on(fn: Callable) -> CheckReport:
    """Check a student's ``fn(pos_err, head_err, dt, window_s) -> bool`` against
    :func:`pfcourse.metrics.locked_on` on :func:`lock_on_cases`; the mistakes of :data:`LOCK_MISTAKES` are named."""
    report = CheckReport("locked on")
    answers = []
    for pos, head, dt in lock_on_cases():
        answer = _answer(report, lambda: fn(pos.copy(), head.copy(), dt, 20.0), "fn(pos_err, head_err, dt, window_s)",
                         "return True or False")
        if answer is None:
            return report
        if not isinstance(answer, (bool, np.bool_)):
            report.problems.append(f"the answer {answer!r} is not True or False: return one verdict per run")
            return report
        answers.append(bool(answer))

    def fits(mistake: str | None) -> bool:
        return answers == [lock_on_reference(p, h, dt, 20.0, mistake) for p, h, dt in lock_on_cases()]

    if fits(None):
        return report
    for mistake, why in LOCK_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    wrong = next(i for i, (a, (p, h, dt)) in enumerate(zip(answers, lock_on_cases())) if a != lock_on_reference(p, h, dt))
    report.problems.append(f"run {wrong + 1} of the checker's runs gets the wrong verdict: within 1 m and 5 degrees "
                           "(strictly) at every step of the last ceil(window_s / dt) steps")
    return report


# ----------------------------------------------------------------------------- chapter 11
#: Cases of :func:`check_pose_density`: (reading ``(r, b)``, landmark ``l``, standard deviations
#: ``(s_r, s_b)``): a far reading, a short one (where the truncation to ``r' > 0`` matters) and one
#: at a bearing near ``pi`` (where the bearing residual must be wrapped).
POSE_DENSITY_CASES = (
    (np.array([12.0, 0.7]), np.array([3.0, -4.0]), np.array([0.7, 0.025])),
    (np.array([0.9, -2.0]), np.array([-10.0, 5.0]), np.array([0.7, 0.05])),
    (np.array([20.0, 3.1]), np.array([0.0, 0.0]), np.array([0.7, 0.025])),
)
POSE_DENSITY_MISTAKES = {
    "bearing_added": "it predicts the bearing as atan2(l - p) + theta; the landmark is seen at its direction "
                     "minus the heading, h_b(x) = wrap(atan2(l_y - p_y, l_x - p_x) - theta)",
    "no_jacobian": "it misses the Jacobian term -log h_r(x): the ring of radius r' has circumference 2 pi r', so the "
                   "density of the position is the polar one divided by the radius",
    "no_direction": "it misses the direction's density 1 / (2 pi): the direction phi of the robot seen from the "
                    "landmark is drawn uniformly, the reading says nothing about it",
    "no_truncation": "it misses the truncation term -log Phi(r / s_r): the range r' is drawn positive only, so its "
                     "normal density is divided by P(r' > 0) = Phi(r / s_r)",
    "unwrapped": "it does not wrap the bearing residual b - h_b(x) into (-pi, pi]: near a bearing of pi a pose that "
                 "fits the reading gets a residual of almost 2 pi",
    "variance_for_sd": "it uses s_r and s_b as variances; they are the standard deviations of the range and bearing "
                       "noise",
}


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def pose_reading_log_density(x: np.ndarray, z: np.ndarray, landmark: np.ndarray, sd: np.ndarray,
                             mistake: str | None = None) -> np.ndarray:
    """``log q_z(x)`` of the pose drawn from a range-bearing reading (chapter 11, Algorithm 11.1):

        q_z(x) = N(h_r(x); r, s_r^2) N(wrap(b - h_b(x)); 0, s_b^2) / (Phi(r / s_r) 2 pi h_r(x)),

    ``h_r(x) = |l - p|``, ``h_b(x) = wrap(atan2(l_y - p_y, l_x - p_x) - theta)`` for each pose
    ``x = (p_x, p_y, theta)`` (rows), ``z = (r, b)``, ``sd = (s_r, s_b)``. ``mistake`` (a key of
    :data:`POSE_DENSITY_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    r, b = (float(v) for v in z)
    s_r, s_b = (float(v) ** 2 if mistake == "variance_for_sd" else float(v) for v in sd)
    dx, dy = landmark[0] - x[:, 0], landmark[1] - x[:, 1]
    h_r = np.hypot(dx, dy)
    h_b = np.arctan2(dy, dx) + (x[:, 2] if mistake == "bearing_added" else -x[:, 2])
    nu_b = (b - h_b) if mistake == "unwrapped" else _wrap(b - _wrap(h_b))
    log_q = (-np.log(2 * np.pi * s_r * s_b) - 0.5 * (((r - h_r) / s_r) ** 2 + (nu_b / s_b) ** 2))
    if mistake != "no_truncation":
        log_q -= stats.norm.logcdf(r / s_r)
    if mistake != "no_direction":
        log_q -= np.log(2 * np.pi)
    if mistake != "no_jacobian":
        log_q -= np.log(h_r)
    return log_q


def _poses_near_reading(z: np.ndarray, landmark: np.ndarray, sd: np.ndarray, n: int,
                        rng: np.random.Generator) -> np.ndarray:
    """``n`` poses near the ring of the reading (twice its noise), where the density is worth checking."""
    ranges = np.abs(z[0] + 2 * sd[0] * rng.standard_normal(n))
    phi = rng.uniform(-np.pi, np.pi, n)
    theta = _wrap(phi + np.pi - (z[1] + 2 * sd[1] * rng.standard_normal(n)))
    return np.column_stack([landmark[0] + ranges * np.cos(phi), landmark[1] + ranges * np.sin(phi), theta])


def check_pose_density(fn: Callable, n_poses: int = 40, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, landmark, sd) -> (N,)``: ``log q_z(x)`` of poses ``x`` (N, 3) for a
    reading ``z = (r, b)`` of the landmark at ``landmark`` with noise standard deviations ``sd = (s_r, s_b)``.

    Each case of :data:`POSE_DENSITY_CASES` must equal :func:`pose_reading_log_density` to ``rtol``;
    an answer that does not is compared with each mistake of :data:`POSE_DENSITY_MISTAKES`, and the
    report names the one that fits.
    """
    report = CheckReport("pose density")
    rng = np.random.default_rng(seed)
    cases = [(z, l, sd, _poses_near_reading(z, l, sd, n_poses, rng)) for z, l, sd in POSE_DENSITY_CASES]
    answers = []
    for z, l, sd, x in cases:
        answer = _answer(report, lambda: fn(x.copy(), z.copy(), l.copy(), sd.copy()), "fn(x, z, landmark, sd)",
                         "compute and return log q_z(x), one value per pose")
        if answer is None:
            return report
        answers.append(np.asarray(answer, dtype=float))
    wrong_shapes = [a.shape for a in answers if a.shape != (n_poses,)]
    if wrong_shapes:
        report.problems.append(f"the answer has shape {wrong_shapes[0]}, not ({n_poses},): return one log-density "
                               "per pose (a row of x)")
        return report
    if not all(np.isfinite(a).all() for a in answers):
        report.problems.append("some log-densities are NaN or infinite: every pose near the ring has a positive "
                               "density; compute it in the log domain")
        return report
    # the exact density first, then each mistake: the first that every case matches names the answer
    candidates = (None, *POSE_DENSITY_MISTAKES)
    matched = next((m for m in candidates if all(
        np.allclose(a, pose_reading_log_density(x, z, l, sd, m), rtol=rtol, atol=1e-9)
        for a, (z, l, sd, x) in zip(answers, cases))), "none")
    if matched is None:
        return report
    if matched != "none":
        report.problems.append(f"your function computes a known mistake: {POSE_DENSITY_MISTAKES[matched]}")
        return report
    case = next(c for c, (a, (z, l, sd, x)) in enumerate(zip(answers, cases))
                if not np.allclose(a, pose_reading_log_density(x, z, l, sd), rtol=rtol, atol=1e-9))
    report.problems.append(f"for the reading z = {cases[case][0]} the values differ from log q_z(x): check the two "
                           "Gaussian terms of the range and the wrapped bearing, and the terms -log Phi(r / s_r), "
                           "-log 2 pi and -log h_r(x)")
# --- chapter 21: the likelihood of one anonymous reading ------------------------------------------

#: Landmarks, measurement covariance and sensor of the anonymous-reading checker.
ANONYMOUS_LANDMARKS = np.array([[10.0, 0.0], [0.0, 12.0], [-9.0, -4.0]])
ANONYMOUS_R = np.diag([0.5, np.deg2rad(2.0)]) ** 2
#: Cases ``(z, p_detect, clutter_rate, max_range)``: an ordinary reading, one with its bearing
#: near pi (where a bearing that is not wrapped is wrong), one without clutter.
ANONYMOUS_CASES = (
    (np.array([10.2, 0.05]), 0.8, 1.5, 30.0),
    (np.array([9.1, 3.1]), 0.9, 0.5, 30.0),
    (np.array([12.1, 1.55]), 0.7, 0.0, 30.0),
)
ANONYMOUS_MISTAKES = {
    "no_clutter": "it forgets the clutter term (1 - P_D) lambda c(z): a reading that no landmark explains then "
                  "makes a particle impossible instead of merely unlikely",
    "no_division": "it does not divide P_D by the number of landmarks M: each landmark is the one looked at with "
                   "probability 1/M, so the detection terms are (P_D / M) N(z; h_j(x), R)",
    "sum_logs": "it sums the log-likelihoods of the terms instead of the likelihoods: the reading comes from one "
                "landmark OR another OR the clutter, so the terms add as probabilities, with logsumexp in the "
                "log domain",
    "no_wrap": "it does not wrap the bearing innovation to (-pi, pi]: a reading at 179 degrees is then 358 "
               "degrees from a prediction at -179 degrees instead of 2",
    "no_exp": "it misses the factor e^{-lambda} (the probability that no other clutter reading appeared), "
              "the term -lambda of the log-likelihood",
}


def anonymous_log_likelihood(x: np.ndarray, z: np.ndarray, landmarks: np.ndarray, R: np.ndarray, p_detect: float,
                             clutter_rate: float, max_range: float, mistake: str | None = None) -> np.ndarray:
    """``log p(z | x^i)`` of one anonymous range-bearing reading for every particle (rows of ``x``):

    ``-lambda + log[ (1 - P_D) lambda c + sum_j (P_D / M) N(z; h_j(x), R) ]``, ``c = 1 / (2 pi r_max)``,
    ``h_j(x) = (|l^j - p|, wrap(atan2(l^j - p) - theta))``, the bearing innovation wrapped; ``mistake``
    (a key of :data:`ANONYMOUS_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    dx = landmarks[:, 0][None] - x[:, 0][:, None]  # (N, M)
    dy = landmarks[:, 1][None] - x[:, 1][:, None]
    nu_r = z[0] - np.hypot(dx, dy)
    nu_b = z[1] - (np.arctan2(dy, dx) - x[:, 2][:, None])
    if mistake != "no_wrap":
        nu_b = np.angle(np.exp(1j * nu_b))
    ell = -0.5 * (nu_r**2 / R[0, 0] + nu_b**2 / R[1, 1]) - np.log(2 * np.pi) - 0.5 * np.log(R[0, 0] * R[1, 1])
    M = 1 if mistake == "no_division" else len(landmarks)
    with np.errstate(divide="ignore"):
        clutter = np.log((1 - p_detect) * clutter_rate / (2 * np.pi * max_range))
        terms = np.column_stack([np.full(len(x), -np.inf if mistake == "no_clutter" else clutter),
                                 np.log(p_detect / M) + ell])
    if mistake == "sum_logs":
        return -clutter_rate + np.sum(np.where(np.isinf(terms), 0.0, terms), axis=1)
    return logsumexp(terms, axis=1) - (0.0 if mistake == "no_exp" else clutter_rate)


def check_anonymous_likelihood(fn: Callable, n_particles: int = 60, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, landmarks, R, p_detect, clutter_rate, max_range) -> (N,)``, the
    log-likelihood of one anonymous reading ``z = (range, bearing)`` for a cloud ``x`` ``(N, 3)``.

    Each case of :data:`ANONYMOUS_CASES` must equal :func:`anonymous_log_likelihood` to ``rtol``; an
    answer that does not is compared with each mistake of :data:`ANONYMOUS_MISTAKES` (forgotten
    clutter, ``P_D`` not divided by ``M``, log-likelihoods summed, bearing not wrapped, no
    ``e^{-lambda}``), and the report names the one that fits.
    """
    report = CheckReport("anonymous-reading log-likelihood")
    x = np.random.default_rng(seed).normal([0.0, 0.0, 0.0], [3.0, 3.0, 0.5], size=(n_particles, 3))
    answers = _per_particle_answers(
        report, [lambda case=case: fn(x.copy(), case[0].copy(), ANONYMOUS_LANDMARKS.copy(), ANONYMOUS_R.copy(),
                                      *case[1:]) for case in ANONYMOUS_CASES],
        n_particles, "fn(x, z, landmarks, R, p_detect, clutter_rate, max_range)")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, anonymous_log_likelihood(x, *case[:1], ANONYMOUS_LANDMARKS, ANONYMOUS_R,
                                                           *case[1:], mistake=mistake),
                               rtol=rtol, atol=1e-9, equal_nan=True) for a, case in zip(answers, ANONYMOUS_CASES))

    if fits(None):
        return report
    for mistake, why in ANONYMOUS_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    report.problems.append("the values differ from -lambda + log[(1 - P_D) lambda c + sum_j (P_D / M) N(z; h_j(x), R)] "
                           "with c = 1 / (2 pi r_max): check each term, in the log domain, and add them with logsumexp")
    return report


# ---------------------------------------------------------------- chapter 22: the likelihood estimator
ESTIMATOR_MISTAKES = {
    "forgot_previous_weights": "it averages the new weights with 1/N instead of the previous weights W_(k-1): "
                               "after a step without resampling the particles do not count equally, so "
                               "p^(z_k | z_(1:k-1)) = sum_i W_(k-1)^i w_k^i",
    "mean_of_logs": "it averages the log-weights instead of the weights: the mean of log w is below the log of "
                    "the mean (Jensen), so the estimate is too low and no longer unbiased; take the logsumexp of "
                    "log W_(k-1) + log w_k",
    "plain_mean_of_logs": "it averages the log-weights instead of the weights (and without the previous weights "
                          "W_(k-1)): the mean of log w is below the log of the mean (Jensen), so the estimate is "
                          "too low; take the logsumexp of log W_(k-1) + log w_k",
    "no_reset_after_resampling": "it keeps the weights W_k after a resampling: resampled particles carry equal "
                                 "weights 1/N (their copies already stand for W_k), so set log W = -log N "
                                 "whenever resampled[k] is true",
    "unnormalised_weights": "it carries the unnormalised weights W_(k-1) w_k to the next step: divide them by "
                            "their sum p^(z_k | z_(1:k-1)), else each factor counts the earlier ones again",
}


def likelihood_estimate(log_w: np.ndarray, resampled: np.ndarray, mistake: str | None = None) -> float:
    """``log p^(z_{1:K}) = sum_k log sum_i W_{k-1}^i w~_k^i`` from a filter's log-weights (Algorithm 22.1).

    ``log_w[k, i] = log w~_k^i`` (``0`` at a step without measurement), ``resampled[k]`` whether the cloud
    was resampled after step ``k`` (then ``W_k^i = 1/N``); ``W_{-1}^i = 1/N``, ``W_k^i = W_{k-1}^i w~_k^i /
    p^(z_k | z_{1:k-1})``.  ``mistake`` (a key of :data:`ESTIMATOR_MISTAKES`) computes that mistake instead.
    """
    log_w = np.asarray(log_w, dtype=float)
    n = log_w.shape[1]
    log_W, total = np.full(n, -np.log(n)), 0.0
    for k, row in enumerate(log_w):
        if mistake == "forgot_previous_weights":
            log_W = np.full(n, -np.log(n))
        a = log_W + row
        if mistake in ("mean_of_logs", "plain_mean_of_logs"):
            step = float(np.sum(np.exp(log_W) * row)) if mistake == "mean_of_logs" else float(np.mean(row))
        else:
            step = float(logsumexp(a))
        total += step
        log_W = a if mistake == "unnormalised_weights" else a - logsumexp(a)
        if resampled[k] and mistake != "no_reset_after_resampling":
            log_W = np.full(n, -np.log(n))
    return total


ESTIMATOR_RESAMPLED = np.array([False, True, False, False, True, False, False, True, False, False])


def check_likelihood_estimate(fn: Callable, n_particles: int = 8, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(log_w, resampled) -> float``, the log of the particle likelihood estimate.

    ``log_w`` (``(K, N)``) holds ``log w~_k^i`` of a filter's run and ``resampled`` (``(K,)``) whether the
    cloud was resampled after each step (:data:`ESTIMATOR_RESAMPLED`: some steps are, some are not, so the
    previous weights matter). The answer must equal :func:`likelihood_estimate` to ``rtol`` on ordinary
    log-weights and on log-weights near ``-1000`` (whose exponentials underflow); an answer that does not is
    compared with each mistake of :data:`ESTIMATOR_MISTAKES`, and the report names the one that fits.
    """
    report = CheckReport("likelihood estimator")
    log_w = np.random.default_rng(seed).normal(-2.0, 1.5, size=(ESTIMATOR_RESAMPLED.size, n_particles))
    answers = []
    for case in (log_w, log_w - 1000.0):
        answer = _answer(report, lambda: fn(case.copy(), ESTIMATOR_RESAMPLED.copy()), "fn(log_w, resampled)",
                         "compute and return log p^(z_1:K), one float")
        if answer is None:
            return report
        try:
            answers.append(float(answer))
        except (TypeError, ValueError):
            report.problems.append(f"the function returned {type(answer).__name__}, not one float: return the "
                                   "sum over the steps of log sum_i W_(k-1)^i w_k^i")
            return report

    def fits(mistake: str | None, case: int = 0) -> bool:
        shift = -1000.0 * case
        return bool(np.isclose(answers[case], likelihood_estimate(log_w + shift, ESTIMATOR_RESAMPLED, mistake),
                               rtol=rtol, atol=1e-9))

    if fits(None) and fits(None, 1):
        return report
    if fits(None):
        report.problems.append(f"with log-weights near -1000 the answer is {answers[1]:.6g}, not "
                               f"{likelihood_estimate(log_w - 1000.0, ESTIMATOR_RESAMPLED):.6g}: exp(-1000) "
                               "underflows to 0, so sum the weights in the log domain (scipy.special.logsumexp)")
        return report
    for mistake, why in ESTIMATOR_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your estimate matches a known mistake: {why}")
            return report
    report.problems.append(f"the answer is {answers[0]:.6g}, the estimate is "
                           f"{likelihood_estimate(log_w, ESTIMATOR_RESAMPLED):.6g}: add log sum_i W_(k-1)^i w_k^i "
                           "over the steps, with W normalised after each step and reset to 1/N after a resampling")
    return report


# ----------------------------------------------------------------------------------------------
# Terrain navigation: the altimeter likelihood on a DEM, and the regularised filter's kernel move
# ----------------------------------------------------------------------------------------------

#: A small DEM for :func:`check_altimeter_likelihood`: 7 rows (north) by 9 columns (east), cells of
#: 80 m east-west and 100 m north-south (unequal, and a non-square grid, so swapped axes show).
ALTIMETER_HEIGHTS = 300.0 + 60.0 * np.sin(np.arange(7)[:, None] * 0.9) * np.cos(np.arange(9)[None, :] * 0.7) \
    + 25.0 * np.arange(9)[None, :]
ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_RF = 80.0, 100.0, 20.0**2
#: mistake -> the sentence that names it (:func:`altimeter_log_likelihood`'s ``mistake``).
ALTIMETER_MISTAKES = {
    "swapped": "x indexes the columns of the map (j = x / dx) and y its rows (i = y / dy), not the other way round",
    "nearest": "the height is read at the nearest node: interpolate bilinearly between the four corners of the cell",
    "rf_as_sd": "Rf is the variance of the altimeter's noise, so the standard deviation is sqrt(Rf)",
    "sign": "the altimeter reads the height above the ground, z - h(x, y), not h(x, y) - z",
    "no_constant": "the Gaussian log-density has the term -(1/2) log(2 pi Rf), which your values lack",
}


def altimeter_log_likelihood(particles: np.ndarray, y: float, heights: np.ndarray, dx: float, dy: float,
                             rf: float, mistake: str | None = None) -> np.ndarray:
    """``log N(y; z - h(x, y), Rf)`` of each particle ``(x, y, z, psi)``, ``h`` bilinear on ``heights[i, j]``
    at ``(j dx, i dy)``; ``-inf`` outside ``[0, (nx-1) dx] x [0, (ny-1) dy]``. With a ``mistake`` of
    :data:`ALTIMETER_MISTAKES`, what that mistake computes (for the checker)."""
    p = np.asarray(particles, dtype=float)
    h = np.asarray(heights, dtype=float)
    if mistake == "swapped":
        h, dx, dy = h.T, dy, dx
    ny, nx = h.shape
    col, row = p[:, 0] / dx, p[:, 1] / dy
    inside = (col >= 0) & (col <= nx - 1) & (row >= 0) & (row <= ny - 1)
    j = np.clip(np.floor(col), 0, nx - 2).astype(int)
    i = np.clip(np.floor(row), 0, ny - 2).astype(int)
    s, t = np.clip(col - j, 0, 1), np.clip(row - i, 0, 1)
    if mistake == "nearest":
        s, t = np.round(s), np.round(t)
    ground = (1 - s) * (1 - t) * h[i, j] + s * (1 - t) * h[i, j + 1] + (1 - s) * t * h[i + 1, j] + s * t * h[i + 1, j + 1]
    predicted = ground - p[:, 2] if mistake == "sign" else p[:, 2] - ground
    var = rf**2 if mistake == "rf_as_sd" else rf
    out = -0.5 * (y - predicted) ** 2 / var - (0.0 if mistake == "no_constant" else 0.5 * np.log(2 * np.pi * var))
    return np.where(inside, out, -np.inf)


def check_altimeter_likelihood(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(particles, y, heights, dx, dy, rf) -> (N,)``, the altimeter's log-likelihood on a DEM.

    ``log p(y | x^i) = log N(y; z^i - h(x^i, y^i), Rf)``, with ``h`` the bilinear height of the map
    ``heights[i, j]`` at ``(j dx, i dy)`` (row 0 the south) and ``-inf`` off the map. Compared with
    :func:`altimeter_log_likelihood` to round-off on particles drawn over the test map
    :data:`ALTIMETER_HEIGHTS` (a few of them off it); a wrong answer is compared with each mistake of
    :data:`ALTIMETER_MISTAKES` and the one that fits is named.
    """
    report = CheckReport("altimeter likelihood")
    rng = np.random.default_rng(seed)
    ny, nx = ALTIMETER_HEIGHTS.shape
    n = 200
    particles = np.column_stack([rng.uniform(-40, (nx - 1) * ALTIMETER_DX + 40, n),
                                 rng.uniform(-40, (ny - 1) * ALTIMETER_DY + 40, n),
                                 rng.normal(1000.0, 30.0, n), rng.uniform(-np.pi, np.pi, n)])
    y = 600.0
    answer = _answer(report, lambda: fn(particles.copy(), y, ALTIMETER_HEIGHTS.copy(), ALTIMETER_DX, ALTIMETER_DY,
                                        ALTIMETER_RF), "fn(particles, y, heights, dx, dy, rf)",
                     "return one log-likelihood per particle")
    if answer is None:
        return report
    answer = np.asarray(answer, dtype=float)
    if answer.shape != (n,):
        report.problems.append(f"the answer has shape {answer.shape}, not ({n},): return one log-likelihood per "
                               "particle (a row of particles)")
        return report
    exact = altimeter_log_likelihood(particles, y, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_RF)
    off = ~np.isfinite(exact)

    def fits(values):
        gone = ~np.isfinite(values)
        return (np.array_equal(gone, answer == -np.inf)
                and np.allclose(answer[~gone], values[~gone], rtol=1e-9, atol=1e-9))

    if fits(exact):
        return report
    for mistake, why in ALTIMETER_MISTAKES.items():
        if fits(altimeter_log_likelihood(particles, y, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY,
                                         ALTIMETER_RF, mistake)):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    if not np.all(answer[off] == -np.inf):
        report.problems.append("a particle off the map must get log-likelihood -inf (likelihood zero: there is no "
                               "terrain under it), not a number or NaN")
        return report
    k = int(np.argmax(np.where(off, -np.inf, np.abs(answer - exact))))
    report.problems.append(f"particle {k} at ({particles[k, 0]:.0f}, {particles[k, 1]:.0f}) m gets {answer[k]:.4f}, "
                           f"not {exact[k]:.4f}: check the bilinear weights (1-s)(1-t), s(1-t), (1-s)t, st and "
                           "the Gaussian log-density of y - (z - h)")
    return report


#: The cloud of :func:`check_regularised_jitter`: N particles in d = 3 dimensions, correlated and of
#: unequal scales (so that a move with S instead of S^{1/2}, or with the identity, shows).
JITTER_N = 20_000
JITTER_SCALE = 0.5
JITTER_COV = np.array([[400.0**2, 0.6 * 400.0 * 50.0, 0.0], [0.6 * 400.0 * 50.0, 50.0**2, 0.0], [0.0, 0.0, 0.2**2]])


def check_regularised_jitter(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(particles, scale, rng) -> moved``, the regularised filter's kernel move.

    ``x^i <- x^i + h S^{1/2} eps^i``, ``eps^i ~ N(0, I_d)`` independent for each particle, ``S`` the
    cloud's covariance and ``h = scale * h_opt``, ``h_opt = (4 / (d + 2))^{1/(d+4)} N^{-1/(d+4)}``. The
    moves ``D = moved - particles`` of a cloud of :data:`JITTER_N` correlated particles must have mean 0
    and covariance ``h^2 S``: whitened by ``S`` and divided by ``h^2``, the covariance of ``D`` must be
    the identity within 0.06 per entry (six standard errors, ``sqrt(2/N)`` each); the typical mistakes
    (no bandwidth, ``S`` for its square root, the identity for ``S``, one draw shared by every particle,
    the wrong exponent of ``N``) are named.
    """
    report = CheckReport("regularised jitter")
    rng = np.random.default_rng(seed)
    n, d = JITTER_N, JITTER_COV.shape[0]
    particles = rng.multivariate_normal([1000.0, -200.0, 1.0], JITTER_COV, n)
    answer = _answer(report, lambda: fn(particles.copy(), JITTER_SCALE, np.random.default_rng(seed + 1)),
                     "fn(particles, scale, rng)", "return the moved particles, an array like particles")
    if answer is None:
        return report
    moved = np.asarray(answer, dtype=float)
    if moved.shape != particles.shape:
        report.problems.append(f"the answer has shape {moved.shape}, not {particles.shape}: return every particle, moved")
        return report
    D = moved - particles
    S = np.cov(particles, rowvar=False)
    h = JITTER_SCALE * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
    L = np.linalg.cholesky(S)
    white = np.linalg.solve(L, D.T).T  # moves in the cloud's own coordinates: covariance h^2 I if right
    C = np.cov(white, rowvar=False)
    if np.all(np.abs(C) < 1e-12 * h**2):
        report.problems.append("every particle moves by the same amount (or not at all): draw one independent "
                               "eps^i ~ N(0, I_d) per particle, an (N, d) array")
        return report
    if np.max(np.abs(white.mean(axis=0)) / np.sqrt(np.diag(C))) > 6 / np.sqrt(n):
        report.problems.append("the moves do not average to zero: the kernel is centred on each particle, "
                               "x^i + h S^(1/2) eps^i with eps^i of mean 0")
        return report
    if np.max(np.abs(C / h**2 - np.eye(d))) < 0.06:
        return report
    ratio = np.trace(C) / d / h**2
    raw = np.cov(D, rowvar=False)
    if np.max(np.abs(C - np.eye(d))) < 0.06:
        why = "the moves have covariance S, not h^2 S: multiply the kernel draw by the bandwidth h = scale * h_opt"
    elif np.allclose(np.diag(raw) / h**2, 1.0, atol=0.06):
        why = ("the moves have the same spread in every direction: scale them by a square root of the cloud's "
               "covariance S, so a component spread over km moves by more than one spread over cm")
    elif np.allclose(np.diag(raw) / h**2, np.diag(S @ S), rtol=0.1):
        why = "the moves have covariance h^2 S^2: multiply eps by a square root of S (Cholesky or eigen), not by S"
    elif abs(ratio - (n ** (-1.0 / d) / n ** (-1.0 / (d + 4))) ** 2) < 0.1 * ratio:
        why = "the bandwidth uses N^(-1/d): the optimal one is (4 / (d + 2))^(1/(d+4)) N^(-1/(d+4))"
    else:
        why = (f"the moves' covariance is {ratio:.3g} times h^2 S (averaged over the axes), not h^2 S: check h_opt "
               "and the square root of S")
    report.problems.append(why)
    return report


# --- chapter 13: the likelihood-field log-weight of one scan for a cloud -------------------------------
#: The mistakes :func:`check_likelihood_field` names, each with its one-sentence reason.
FIELD_MISTAKES = {
    "max_range_kept": "beams at the maximum range z_max hit nothing and give no end point: leave them out of "
                      "the sum, as table 6.3 does",
    "no_heading": "a beam points along theta + a_b, the robot's heading plus the beam's angle, not along a_b alone",
    "no_rand": "the term z_rand / z_max is missing: without it an end point far from every wall makes the weight "
               "vanish, and one stray reading ruins a good pose",
    "no_constant": "the Gaussian density needs its factor 1 / (sqrt(2 pi) sigma): without it z_hit and z_rand "
                   "are mixed in the wrong proportion",
    "product": "the densities are multiplied and then logged: the product of hundreds of beams underflows to 0 "
               "(log 0 = -inf); add the logs instead",
}


def field_log_weights(poses: np.ndarray, z: np.ndarray, field, mistake: str | None = None) -> np.ndarray:
    """Table 6.3 in the log domain, ``sum_{b: z_b < z_max} log(z_hit N(d(e_b); 0, sigma^2) + z_rand / z_max)``
    (``field`` a :class:`pfcourse.maprobot.LikelihoodField`), or one mistake of :data:`FIELD_MISTAKES`."""
    use = np.ones(len(z), dtype=bool) if mistake == "max_range_kept" else z < field.max_range
    heading = (0.0 if mistake == "no_heading" else poses[:, 2:3]) + field.angles[use]
    ends = np.stack([poses[:, 0:1] + z[use] * np.cos(heading), poses[:, 1:2] + z[use] * np.sin(heading)], axis=-1)
    d = field.grid.distance_at(ends)
    norm = 1.0 if mistake == "no_constant" else np.sqrt(2 * np.pi) * field.sigma
    dens = field.z_hit * np.exp(-0.5 * (d / field.sigma) ** 2) / norm
    if mistake != "no_rand":
        dens = dens + field.z_rand / field.max_range
    with np.errstate(divide="ignore"):
        return np.log(np.prod(dens, axis=1)) if mistake == "product" else np.log(dens).sum(axis=1)


class _RoomGrid:
    """A 6 m x 4 m room of 0.1 m cells with a wall stub, and ``distance_at`` as
    :class:`pfcourse.maprobot.OccupancyGrid` has it (distance transform, ``inf`` off the map)."""

    resolution = 0.1

    def __init__(self) -> None:
        from scipy.ndimage import distance_transform_edt

        occ = np.zeros((40, 60), dtype=bool)
        occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
        occ[10:30, 30] = True
        self.occupied = occ
        self.distance = distance_transform_edt(~occ) * self.resolution

    def distance_at(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        j = np.floor(xy[..., 0] / self.resolution).astype(np.int64)
        i = np.floor(xy[..., 1] / self.resolution).astype(np.int64)
        inside = (i >= 0) & (i < self.occupied.shape[0]) & (j >= 0) & (j < self.occupied.shape[1])
        return np.where(inside, self.distance[np.where(inside, i, 0), np.where(inside, j, 0)], np.inf)


@dataclass(frozen=True)
class FieldCase:
    """What ``fn(poses, z, field)`` is given as ``field``: the grid and the likelihood field's parameters."""

    grid: _RoomGrid
    angles: np.ndarray
    max_range: float = 4.0
    z_hit: float = 0.9
    z_rand: float = 0.1
    sigma: float = 0.2


def check_likelihood_field(fn: Callable, n_particles: int = 40, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(poses, z, field) -> (N,)``: the likelihood-field log-weights of one scan ``z``
    (``(B,)``) for a cloud ``poses`` (``(N, 3)``) in a room, ``field`` a :class:`FieldCase` (its
    ``grid.distance_at``, ``angles``, ``max_range``, ``z_hit``, ``z_rand``, ``sigma``, as
    :class:`pfcourse.maprobot.LikelihoodField` has them).  Two cases: a scan of 24 beams and one of 360
    (where a product of densities underflows), about a fifth of the beams at the maximum range.  An answer off
    :func:`field_log_weights` by more than ``rtol`` is compared with each mistake of :data:`FIELD_MISTAKES`."""
    report = CheckReport("likelihood field")
    grid = _RoomGrid()
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(0.3, 5.7, n_particles), rng.uniform(0.3, 3.7, n_particles),
                             rng.uniform(-np.pi, np.pi, n_particles)])
    cases = []
    for n_beams in (24, 360):
        field = FieldCase(grid, np.linspace(-np.pi, np.pi, n_beams, endpoint=False))
        z = rng.uniform(0.1, field.max_range, n_beams)
        z[rng.random(n_beams) < 0.2] = field.max_range  # no echo
        cases.append((z, field))
    answers = _cloud_answers(report, [lambda z=z, f=f: fn(poses.copy(), z.copy(), f) for z, f in cases],
                             "fn(poses, z, field)", "compute and return one log-weight per pose", n_particles,
                             "log-weight per pose (a row of poses), summed over the beams")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, field_log_weights(poses, z, f, mistake), rtol=rtol, atol=1e-9)
                   for a, (z, f) in zip(answers, cases))

    if _settled(report, fits, FIELD_MISTAKES):
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("some log-weights are NaN: an end point off the map is infinitely far from a wall "
                               "(distance_at returns inf), whose Gaussian term is 0, not NaN")
        return report
    report.problems.append("the log-weights differ from table 6.3's: for each beam shorter than z_max, find its end "
                           "point, read its distance d to the nearest wall, and add log(z_hit N(d; 0, sigma^2) + "
                           "z_rand / z_max)")
    return report


def _cloud_answers(report: CheckReport, calls: list[Callable], signature: str, what: str, n: int,
                   one: str) -> list[np.ndarray] | None:
    """The answers of ``calls`` (one per case), each of shape ``(n,)``; ``None`` after reporting, in one
    sentence, the first that raised, returned ``None`` (``what`` to do) or has another shape (``one``
    value per row expected)."""
    answers = []
    for call in calls:
        answer = _answer(report, call, signature, what)
        if answer is None:
            return None
        answer = np.asarray(answer, dtype=float)
        if answer.shape != (n,):
            report.problems.append(f"the answer has shape {answer.shape}, not ({n},): return one {one}")
            return None
        answers.append(answer)
    return answers


def _settled(report: CheckReport, fits: Callable[[str | None], bool], mistakes: dict[str, str]) -> bool:
    """Whether the answer ``fits`` the reference (nothing to report) or one of ``mistakes`` (reported with
    its reason); ``False`` leaves the answer to the caller's own diagnosis."""
    if fits(None):
        return True
    for mistake, why in mistakes.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return True
    return False


# --- chapter 17: what common random numbers buy -------------------------------------------------------
#: Two settings' errors on the same 40 runs (the first run by run correlated with the second, as the
#: settings of a study with common random numbers are).
def _paired_case(seed: int = 17, runs: int = 40) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    world = rng.gamma(4.0, 0.1, runs)  # what each simulated world makes hard, shared by both settings
    return world + rng.normal(0.0, 0.05, runs), 1.05 * world + rng.normal(0.0, 0.05, runs)


PAIRED_CASE = _paired_case()
PAIRED_MISTAKES = {
    "ddof0": "it uses the population standard deviation (np.std's default, ddof=0); the sample standard "
             "deviation divides by n - 1 (ddof=1)",
    "over_n": "it divides the standard deviation by n instead of sqrt(n): the standard error of a mean is s / sqrt(n)",
    "unpaired_sum": "its unpaired standard error adds the standard deviations, (s_a + s_b) / sqrt(n); independent "
                    "errors add their variances: sqrt((s_a^2 + s_b^2) / n)",
    "paired_as_unpaired": "its paired standard error ignores the pairing (it is the unpaired one); pair the runs: "
                          "the standard deviation of the differences a_r - b_r, over sqrt(n)",
}


def paired_standard_errors(a: np.ndarray, b: np.ndarray, mistake: str | None = None) -> tuple[float, float]:
    """Standard errors of ``mean(a) - mean(b)``: paired ``sd(a - b) / sqrt(n)``, and as if the runs were
    independent, ``sqrt((sd(a)^2 + sd(b)^2) / n)`` (sample standard deviations, ``ddof=1``). ``mistake`` (a key
    of :data:`PAIRED_MISTAKES`) computes it instead."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n, ddof = len(a), 0 if mistake == "ddof0" else 1
    root = n if mistake == "over_n" else np.sqrt(n)
    sa, sb, sd = a.std(ddof=ddof), b.std(ddof=ddof), (a - b).std(ddof=ddof)
    unpaired = (sa + sb) / root if mistake == "unpaired_sum" else np.sqrt(sa**2 + sb**2) / root
    paired = unpaired if mistake == "paired_as_unpaired" else sd / root
    return float(paired), float(unpaired)


def check_paired_se(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(a, b) -> (paired_se, unpaired_se)`` on :data:`PAIRED_CASE` against
    :func:`paired_standard_errors`; the mistakes of :data:`PAIRED_MISTAKES` are named."""
    report = CheckReport("paired and unpaired standard errors")
    a, b = PAIRED_CASE
    answer = _answer(report, lambda: fn(a.copy(), b.copy()), "fn(a, b)", "return (paired_se, unpaired_se)")
    if answer is None:
        return report
    try:
        paired, unpaired = (float(v) for v in answer)
    except (TypeError, ValueError):
        report.problems.append("the answer is not two numbers: return (paired_se, unpaired_se)")
        return report

    def fits(mistake: str | None) -> bool:
        return bool(np.allclose([paired, unpaired], paired_standard_errors(a, b, mistake), rtol=rtol))

    if fits(None):
        return report
    for mistake, why in PAIRED_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    if paired > unpaired:
        report.problems.append("the paired standard error is larger than the unpaired one, although the runs are "
                               "strongly correlated: pair a_r with b_r of the same run")
        return report
    report.problems.append("the values differ from sd(a - b) / sqrt(n) and sqrt((sd(a)^2 + sd(b)^2) / n) with "
                           "sample standard deviations")
    return report


# --- Terrain navigation: each particle's altitude Kalman update (chapter 16) ---

ALTITUDE_MISTAKES: dict[str, str] = {
    "ground_sign": "the ground height has the wrong sign: the altimeter reads altitude minus ground, so the "
                   "predicted reading is m - h(p) and the innovation y - m + h(p)",
    "weight_with_r": "the weight uses Rf where it needs S = P + Rf: the altitude is uncertain, so the predictive "
                     "density of the reading is N(y; m - h(p), P + Rf), not N(y; m - h(p), Rf)",
    "no_var_update": "the variance is not updated: after a reading P' = (1 - K) P, smaller than P",
    "gain_over_r": "the gain is P / Rf: it is K = P / (P + Rf), which stays below one",
}


def altitude_update(mean: np.ndarray, var: np.ndarray, ground: np.ndarray, reading: float, rf: float,
                    mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every particle's altitude update: ``(m', P', log N(nu; 0, S))`` with ``nu = y - (m - h)``, ``S = P + Rf``,
    ``K = P / S``, ``m' = m + K nu``, ``P' = (1 - K) P``.  ``mistake`` (a key of :data:`ALTITUDE_MISTAKES`)
    computes instead what that mistake computes."""
    if mistake is not None and mistake not in ALTITUDE_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(ALTITUDE_MISTAKES)}")
    nu = reading - (mean + ground if mistake == "ground_sign" else mean - ground)
    s = var + rf
    gain = var / (rf if mistake == "gain_over_r" else s)
    s_lik = rf if mistake == "weight_with_r" else s
    log_lik = -0.5 * (nu * nu / s_lik + np.log(2 * np.pi * s_lik))
    return mean + gain * nu, var if mistake == "no_var_update" else (1.0 - gain) * var, log_lik


#: Five particles over the terrain: predicted altitude means, their common variance, ground heights, a reading, Rf.
ALTITUDE_CASE = dict(mean=np.array([1500.0, 1460.0, 1530.0, 1495.0, 1510.0]), var=np.full(5, 900.0),
                     ground=np.array([250.0, 310.0, 180.0, 270.0, 205.0]), reading=1225.0, rf=400.0)


def check_altitude_update(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(mean, var, ground, reading, rf) -> (mean_new, var_new, log_lik)`` on
    :data:`ALTITUDE_CASE`: each output must equal :func:`altitude_update` to ``rtol``; one that does not
    is compared with every mistake of :data:`ALTITUDE_MISTAKES`, and the report names the one that fits."""
    report = CheckReport("altitude Kalman update of every particle")
    case = {key: np.copy(value) if isinstance(value, np.ndarray) else value for key, value in ALTITUDE_CASE.items()}
    answer = _answer(report, lambda: fn(**case), "fn(mean, var, ground, reading, rf)",
                     "return (mean_new, var_new, log_lik)")
    if answer is None:
        return report
    try:
        got = tuple(np.broadcast_to(np.asarray(part, dtype=float), (5,)) for part in answer)
        if len(got) != 3:
            raise ValueError
    except (TypeError, ValueError):
        report.problems.append("return three arrays of one value per particle (shape (5,)): the new means, the new "
                               "variances and the log-weight increments")
        return report

    def same(expected) -> bool:
        return all(np.allclose(g, e, rtol=rtol, atol=1e-12) for g, e in zip(got, expected))

    if same(altitude_update(**ALTITUDE_CASE)):
        return report
    for mistake, why in ALTITUDE_MISTAKES.items():
        if same(altitude_update(**ALTITUDE_CASE, mistake=mistake)):
            report.problems.append(f"your update computes a known mistake: {why}")
            return report
    exact = altitude_update(**ALTITUDE_CASE)
    part = next(name for name, g, e in zip(("mean", "variance", "log-weight increment"), got, exact)
                if not np.allclose(g, e, rtol=rtol, atol=1e-12))
    report.problems.append(f"the {part} differs from the Kalman update (nu = y - (m - h), S = P + Rf, K = P / S, "
                           "m' = m + K nu, P' = (1 - K) P, log N(nu; 0, S)): check that line")
    return report


# --- the robot's range-bearing measurement (chapters 10 and 12) -----------------------------------

def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2 * np.pi)


#: A cloud of robot poses ``(x, y, theta)`` around ``(1, -50, 0.02)`` and landmark ``(-20, -50)`` seen
#: right behind: predicted bearings straddle the cut at +-pi, so a missing wrap shows.
RANGE_BEARING_LANDMARK = np.array([-20.0, -50.0])
RANGE_BEARING_Z = np.array([21.3, -3.13])
RANGE_BEARING_R = np.diag([0.5, np.deg2rad(1.0)]) ** 2 * 2.0

#: The typical mistakes of the log-weight of a range-bearing measurement, and why each is wrong.
RANGE_BEARING_MISTAKES = {
    "no_wrap": "the bearing innovation is not wrapped to (-pi, pi]: a bearing of 179 degrees against a "
               "prediction of -179 degrees is 2 degrees off, not 358, so well-placed particles lose their weight",
    "no_wrap_at_all": "the bearing innovation is not wrapped to (-pi, pi]: a bearing of 179 degrees against a "
                      "prediction of -179 degrees is 2 degrees off, not 358, so well-placed particles lose their weight",
    "no_heading": "the predicted bearing is the world direction atan2(dy, dx) without subtracting the "
                  "particle's heading theta: the sensor measures the bearing relative to the robot",
    "r_as_sd": "R is read as a matrix of standard deviations (you took its square): R holds variances",
    "no_constant": "the normalising term -log(2 pi) - log(det R) / 2 is missing: it cancels in the "
                   "normalised weights, but not in the likelihood of the data the filter estimates",
}


def range_bearing_log_weights(x: np.ndarray, landmark: np.ndarray, z: np.ndarray, R: np.ndarray,
                              mistake: str | None = None) -> np.ndarray:
    """``log N(nu^i; 0, R)`` with ``nu^i = (z_r - ||l - p^i||, wrap(z_b - (atan2(l_y - y^i, l_x - x^i) - theta^i)))``
    for every pose ``x^i = (x^i, y^i, theta^i)`` (rows of ``x``). ``mistake`` (a key of
    :data:`RANGE_BEARING_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    d = np.asarray(landmark, dtype=float) - x[:, :2]
    heading = 0.0 if mistake == "no_heading" else x[:, 2]
    bearing = np.arctan2(d[:, 1], d[:, 0]) - heading
    if mistake == "no_wrap_at_all":
        nu_b = z[1] - bearing
    elif mistake == "no_wrap":  # the prediction wrapped, the innovation not
        nu_b = z[1] - _wrap(bearing)
    else:
        nu_b = _wrap(z[1] - _wrap(bearing))
    nu = np.column_stack([z[0] - np.hypot(d[:, 0], d[:, 1]), nu_b])
    cov = R @ R if mistake == "r_as_sd" else R
    quad = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(cov), nu)
    constant = 0.0 if mistake == "no_constant" else 2 * np.log(2 * np.pi) + np.linalg.slogdet(cov)[1]
    return -0.5 * (quad + constant)


def _shaped(report: CheckReport, answer, shape: tuple[int, ...], what: str) -> bool:
    """Whether ``answer`` has ``shape``; if not, report it, saying ``what`` to return instead."""
    got = np.shape(answer)
    if got != shape:
        report.problems.append(f"the answer has shape {got}, not {shape}: return {what}")
    return got == shape


def _named_mistake(report: CheckReport, answer: np.ndarray, reference: Callable, mistakes: Mapping[str, str],
                   rtol: float, what: str) -> CheckReport:
    """Pass when ``answer`` equals ``reference(None)`` to ``rtol``; else name the mistake of ``mistakes``
    whose ``reference(mistake)`` it equals, or say in ``what`` which formula to check."""
    def fits(mistake: str | None) -> bool:
        return np.allclose(answer, reference(mistake), rtol=rtol, atol=1e-12)

    if fits(None):
        return report
    for mistake, why in mistakes.items():
        if fits(mistake):
            report.problems.append(f"your function computes a known mistake: {why}")
            return report
    report.problems.append(what)
    return report


def check_range_bearing_log_weights(fn: Callable, n_particles: int = 40, seed: int = 0,
                                    rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(x, landmark, z, R) -> (N,)``: the log-likelihood ``log N(nu^i; 0, R)`` of a range-bearing
    measurement ``z = (range, bearing)`` of ``landmark`` for a cloud ``x`` of robot poses ``(N, 3)``.

    The case (:data:`RANGE_BEARING_Z`) has predicted bearings on both sides of the cut at +-pi.
    The answer must equal :func:`range_bearing_log_weights` to ``rtol``; otherwise the report names
    the mistake of :data:`RANGE_BEARING_MISTAKES` it equals.
    """
    report = CheckReport("range-bearing log-weights")
    x = np.random.default_rng(seed).normal([1.0, -50.0, 0.02], [0.5, 0.5, 0.03], size=(n_particles, 3))
    x[:, 2] = _wrap(x[:, 2])
    args = (RANGE_BEARING_LANDMARK, RANGE_BEARING_Z, RANGE_BEARING_R)
    answer = _answer(report, lambda: fn(x.copy(), *(a.copy() for a in args)), "fn(x, landmark, z, R)",
                     "compute and return one log-weight per particle")
    if answer is None or not _shaped(report, answer, (n_particles,), "one log-weight per particle (a row of x)"):
        return report
    return _named_mistake(report, answer, lambda m: range_bearing_log_weights(x, *args, mistake=m),
                          RANGE_BEARING_MISTAKES, rtol,
                          "the values differ from log N(nu; 0, R): check the innovation "
                          "nu = (z_r - range, wrap(z_b - bearing)) and the quadratic form nu^T R^-1 nu / 2")


#: The typical mistakes of the measurement Jacobian of range and bearing, and why each is wrong.
JACOBIAN_MISTAKES = {
    "offset_reversed": "the signs of the position columns are reversed: with (dx, dy) = l - p the range "
                       "shrinks as the robot moves towards the landmark, so d range / dx = -dx / sqrt(q)",
    "heading_plus": "d bearing / d theta is +1: the bearing is atan2(dy, dx) - theta, so it is -1",
    "range_over_q": "the range row divides by q = dx^2 + dy^2 instead of sqrt(q): d sqrt(q) / dx = -dx / sqrt(q)",
    "bearing_swapped": "the bearing row swaps dx and dy: d atan2(dy, dx) / dx = dy / q and / dy = -dx / q",
}
JACOBIAN_CASES = (
    (np.array([1.0, -50.0, 0.3]), np.array([-20.0, -45.0])),
    (np.array([12.0, 7.0, -2.9]), np.array([15.0, 31.0])),
    (np.array([-3.0, 4.0, 3.1]), np.array([-40.0, -2.0])),
)


def range_bearing_jacobian(state: np.ndarray, landmark: np.ndarray, mistake: str | None = None) -> np.ndarray:
    """``H = dh/dx`` (2x3) of ``h(x) = (sqrt(q), atan2(dy, dx) - theta)``, ``(dx, dy) = l - p``, ``q = dx^2 + dy^2``:
    ``[[-dx/sqrt(q), -dy/sqrt(q), 0], [dy/q, -dx/q, -1]]``. ``mistake`` (a key of :data:`JACOBIAN_MISTAKES`)
    computes that mistake instead."""
    dx, dy = np.asarray(landmark, dtype=float) - np.asarray(state, dtype=float)[:2]
    q = dx * dx + dy * dy
    sign = -1.0 if mistake == "offset_reversed" else 1.0
    r = q if mistake == "range_over_q" else np.sqrt(q)
    bx, by = (-dx / q, dy / q) if mistake == "bearing_swapped" else (dy / q, -dx / q)
    return np.array([[-sign * dx / r, -sign * dy / r, 0.0],
                     [sign * bx, sign * by, 1.0 if mistake == "heading_plus" else -1.0]])


def check_range_bearing_jacobian(fn: Callable, rtol: float = 1e-6) -> CheckReport:
    """Check ``fn(state, landmark) -> (2, 3)``, the EKF's measurement Jacobian of range and bearing.

    On each case of :data:`JACOBIAN_CASES` the answer must equal :func:`range_bearing_jacobian` to
    ``rtol`` (so a careful finite difference passes too); otherwise the report names the mistake of
    :data:`JACOBIAN_MISTAKES` it equals.
    """
    report = CheckReport("range-bearing Jacobian")
    answers = []
    for state, landmark in JACOBIAN_CASES:
        answer = _answer(report, lambda: fn(state.copy(), landmark.copy()), "fn(state, landmark)",
                         "compute and return the 2 x 3 matrix H")
        if answer is None:
            return report
        if not _shaped(report, answer, (2, 3), "one row per measured quantity (range, bearing), one column "
                                               "per state component (x, y, theta)"):
            return report
        answers.append(np.asarray(answer, dtype=float))
    return _named_mistake(report, np.array(answers),
                          lambda m: np.array([range_bearing_jacobian(s, lm, m) for s, lm in JACOBIAN_CASES]),
                          JACOBIAN_MISTAKES, rtol,
                          "the matrix differs from dh/dx: differentiate sqrt(q) and atan2(dy, dx) - theta "
                          "with (dx, dy) = l - p, and compare with a central finite difference")


# --- the smoothing chapter: one backward step of FFBSm ---------------------------------------

#: The smoothing exercise's case: a scalar AR(1) transition x_{k+1} = 0.9 x_k + w, w ~ N(0, 0.5),
#: five stored clouds of 30 particles (spread 1 about a drifting centre), random filter weights, and
#: random smoothed weights at step k + 1; the checked step is k = 2.
BACKWARD_K, BACKWARD_N, BACKWARD_STEPS = 2, 30, 5
BACKWARD_MISTAKES = {
    "no_filter_weight": "the filter weight W_k^i is missing in front of the sum: the smoothed weight is the "
                        "filter's weight times how well particle i predicts the smoothed cloud at k + 1",
    "wrong_axis": "the predictive density is summed over the wrong axis: for each particle j at k + 1 it is "
                  "sum_l W_k^l f(x_(k+1)^j | x_k^l), a sum over the particles at step k (the second index "
                  "of log_transition's matrix)",
    "wrong_time": "the transition is taken at the wrong time: the backward step from k + 1 to k needs "
                  "f(x_(k+1)^j | x_k^i) and the filter weights W_k of step k, not another step's",
}


def _backward_case(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, Callable]:
    rng = np.random.default_rng(seed)
    centres = np.cumsum(rng.normal(0, 0.5, BACKWARD_STEPS))
    particles = (centres[:, None] + rng.standard_normal((BACKWARD_STEPS, BACKWARD_N)))[:, :, None]
    weights = rng.dirichlet(np.ones(BACKWARD_N), BACKWARD_STEPS)
    smoothed_next = rng.dirichlet(np.ones(BACKWARD_N))

    def log_transition(new: np.ndarray, old: np.ndarray) -> np.ndarray:
        """``[log N(new_j; 0.9 old_i, 0.5)]_{j, i}``."""
        d = np.asarray(new, dtype=float)[:, 0][:, None] - 0.9 * np.asarray(old, dtype=float)[:, 0][None, :]
        return -0.5 * d**2 / 0.5 - 0.5 * np.log(2 * np.pi * 0.5)

    return particles, weights, smoothed_next, log_transition


def backward_weights(k: int, particles: np.ndarray, weights: np.ndarray, smoothed_next: np.ndarray,
                     log_transition: Callable, mistake: str | None = None) -> np.ndarray:
    """FFBSm's backward step, in the log domain:
    ``W_{k|K}^i = W_k^i sum_j W_{k+1|K}^j f(x_{k+1}^j | x_k^i) / sum_l W_k^l f(x_{k+1}^j | x_k^l)``;
    ``mistake`` (a key of :data:`BACKWARD_MISTAKES`) computes that mistake instead."""
    new, old, w = particles[k + 1], particles[k], weights[k]
    if mistake == "wrong_time":
        new, old, w = particles[k], particles[k - 1], weights[k - 1]
    log_f = np.asarray(log_transition(new, old), dtype=float)  # [j, i]
    with np.errstate(divide="ignore"):
        log_w, log_next = np.log(w), np.log(smoothed_next)
    if mistake == "wrong_axis":
        log_den = logsumexp(log_f + log_w[None, :], axis=0)[None, :]
    else:
        log_den = logsumexp(log_f + log_w[None, :], axis=1)[:, None]
    log_s = logsumexp(log_next[:, None] + log_f - log_den, axis=0)
    if mistake != "no_filter_weight":
        log_s = log_s + np.log(weights[k])
    return np.exp(log_s - logsumexp(log_s))


def check_backward_weights(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(k, particles, weights, smoothed_next, log_transition) -> (N,)``: FFBSm's smoothed weights
    ``W_{k|K}`` of one backward step (:func:`backward_weights`) on :func:`_backward_case`, to round-off; a
    wrong answer is compared with each mistake of :data:`BACKWARD_MISTAKES`, and the one it computes is named.
    ``particles`` is ``(K, N, 1)``, ``weights`` ``(K, N)``, ``smoothed_next`` ``(N,)`` the smoothed weights
    at ``k + 1``, and ``log_transition(new, old)`` the matrix ``[log f(new_j | old_i)]_{j, i}``."""
    report = CheckReport("FFBSm backward weights")
    particles, weights, smoothed_next, log_transition = _backward_case()
    k = BACKWARD_K
    answer = _answer(report, lambda: fn(k, particles.copy(), weights.copy(), smoothed_next.copy(), log_transition),
                     "fn(k, particles, weights, smoothed_next, log_transition)",
                     "compute the smoothed weights and return them, one per particle")
    if answer is None:
        return report
    answer = np.asarray(answer, dtype=float)
    if answer.shape != (BACKWARD_N,):
        report.problems.append(f"the answer has shape {answer.shape}, not ({BACKWARD_N},): return one smoothed "
                               "weight per particle of step k")
        return report
    if not np.all(np.isfinite(answer)) or np.any(answer < 0):
        report.problems.append("some weights are negative, NaN or infinite: compute them in the log domain "
                               "(logsumexp) and exponentiate at the end")
        return report
    if not np.isclose(answer.sum(), 1.0, rtol=1e-9):
        report.problems.append(f"the weights sum to {answer.sum():.6g}, not 1: normalise them (divide by their sum)")
        return report

    def fits(mistake: str | None) -> bool:
        return np.allclose(answer, backward_weights(k, particles, weights, smoothed_next, log_transition, mistake),
                           rtol=rtol, atol=1e-12)

    if fits(None):
        return report
    for mistake, why in BACKWARD_MISTAKES.items():
        if fits(mistake):
            report.problems.append(f"your weights match a known mistake: {why}")
            return report
    i = int(np.argmax(np.abs(answer - backward_weights(k, particles, weights, smoothed_next, log_transition))))
    report.problems.append(f"particle {i}'s smoothed weight is {answer[i]:.4g}, not "
                           f"{backward_weights(k, particles, weights, smoothed_next, log_transition)[i]:.4g}: "
                           "check the ratio f(x_(k+1)^j | x_k^i) / sum_l W_k^l f(x_(k+1)^j | x_k^l) and its "
                           "weighting by the smoothed weights W_(k+1|K)^j")
    return report
