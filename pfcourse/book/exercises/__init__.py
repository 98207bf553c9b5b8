"""Statistical checks of code a student writes in the exercises of the book, one module per part
(:mod:`.part1` to :mod:`.part5`; the report and shared helpers in :mod:`.checking`).

Each ``check_*`` function runs the student's function on cases with a known answer and
returns a :class:`CheckReport`: ``ok`` and a list of ``problems``, each a sentence saying
what is wrong and, where it can, why.  It never raises on a wrong answer (a student's
exception is reported as a problem); ``str(report)`` prints the verdict.

* :func:`check_two_beacon_filter` - ``fn(z, n_particles, rng, model) -> means``: the on-ramp's particle
  filter for a robot on a rail ranging two beacons (:mod:`.onramp`), against the exact grid; one
  beacon read, no motion noise, a standard deviation squared, the unweighted mean and a missing
  reading used are named, and the filter must draw from the generator it is given.
* :func:`check_cv_kalman` - the Kalman filter of a constant-velocity model (chapter 2's variant),
  against the exact filter; six typical mistakes named (:mod:`.part1`).
* :func:`check_stratified_resampler` - ``fn(weights, n, rng) -> indices``: stratified resampling, told
  apart from systematic and multinomial by the exact offspring variance of a particle that straddles
  two strata; it must draw from the generator it is given (:mod:`.part1`).
* :func:`check_resampler` - ``fn(weights, rng) -> indices``: right type, shape and range,
  particles of weight 0 never chosen, and *unbiased*: the mean number of copies of particle
  ``i`` over many draws is ``N W_i`` (a z-test per particle at 5 standard errors), and no more
  variable than multinomial resampling (``sum_i Var N_i`` at most 1.5 times ``sum_i N W_i (1 - W_i)``).
* :func:`check_importance_sampler` - ``fn(z, sd_v, n, rng) -> (estimate, ess)``: self-normalised
  importance sampling of a Gaussian posterior mean with a proposal that is not the prior, against the
  exact mean; weights that leave out the proposal or the prior, the likelihood alone, a variance read
  as a standard deviation and a generator other than ``rng`` are named.
* :func:`check_weight_update` - ``fn(log_weights, log_likelihoods) -> log_weights``: the
  normalised log-domain update ``log W_i + log p(z | x_i) - logsumexp_j(...)``, checked on
  ordinary values and on likelihoods of ``e^{-1000}`` that underflow in the linear domain.
* :func:`check_evidence_increment` - ``fn(log_W, log_lik) -> log p(z_k | z_1:k-1)``: the
  log-domain estimate ``logsumexp_i(log W_i + log p(z_k | x_i))``; underflow, dropped old weights, the
  increment instead of its log, the max not added back and a spurious ``log N`` are named.
* :func:`check_sis` - ``fn(z, n_particles, rng, model) -> (means, ess)``: a whole SIS filter
  on a scalar linear-Gaussian model (:class:`ScalarModel`), against the Kalman filter, which
  is exact. A wrong filter is compared with what the typical mistakes converge to (weights
  that forget the previous step, particles moved without process noise, a variance read as a
  standard deviation), so the report can say which mistake it sees, not only that the numbers
  are off.
* :func:`check_ancestors` - ``fn(ancestors) -> origins``: the genealogy of a resampled cloud,
  each final particle's ancestor at step 0, on random ancestor indices; the steps followed
  forwards, one generation only and the last step left out are named.
* :func:`check_multinomial_resampler` - ``fn(weights, rng) -> indices``: multinomial resampling
  (``N`` independent draws), drawn from the generator it is given (NumPy's global state untouched,
  same seed same answer, another seed another), unbiased, and told apart from stratified and
  systematic resampling (too little offspring variance) and from one shared uniform (too much).
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
* :func:`check_storvik_step` - ``fn(x, a, b, z, rng) -> (x_new, a_new, b_new, log_w)``: one step of
  Storvik's sufficient-statistic filter for a random walk's unknown process-noise variance
  (:mod:`.static_parameters`): the generator, the conjugate update and the weights exactly, the law of
  the moves by a Kolmogorov-Smirnov test against the Student t; the mistakes of :data:`STORVIK_MISTAKES`
  are named.
* :func:`check_fastslam2_move` - ``fn(r_pred, m_pred, P_pred, z, A, C, Qr, R, rng) -> (robots, log_w)``:
  FastSLAM 2.0's robot move and weight for a cloud, against :func:`fastslam2_exact` (the weights up to a
  constant, the robots standardised by the exact proposal); the generator is checked, and the mistakes
  of :data:`FASTSLAM2_MISTAKES` are named (the weight without the motion noise, ``S`` without the map,
  the weight at the new robot, the transition as move, the covariance not shrunk).
* :func:`check_apf_second_stage` - ``fn(log_lik, log_pred, ancestors) -> log_weights``: the auxiliary
  filter's second-stage weights with the transition as proposal; the mistakes of
  :data:`APF_MISTAKES` are named (first stage not divided out, divided at the particle's own index,
  multiplied in again, not normalised).
* :func:`check_guided_fk` - ``make_guided(Z) -> (M, G)``: the Feynman-Kac pair of a guided filter whose
  proposal is ``N(z_k, 2)`` on a scalar model (:mod:`.why_it_works`); the generator and the laws of ``M``
  are checked, ``G`` against its exact value (the bootstrap potential kept, ``log q`` left out or added,
  the transition left out are named), then the unbiasedness of its likelihood estimate against Kalman.
* :func:`check_apf_step` - ``fn(x, log_w, z, rng) -> (x_new, log_evidence)``: one fully adapted step
  of the auxiliary filter on a scaled-sensor AR(1) model (:data:`APF_STEP_MODEL`), against the exact
  mixture it draws from (:func:`apf_step_exact`): the generator is checked, and the mistakes of
  :data:`APF_STEP_MISTAKES` are named (``W_(k-1)`` dropped, the predictive variance ``r``, the scale
  ``c`` forgotten, the transition as move, moved then resampled).
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
* :func:`check_velocity_motion` - ``fn(x, u, sd, dt, rng) -> (N, 3)``: chapter 11's variant motion model,
  every particle driven along an arc by its own noisy ``(v, omega)``; a large cloud's means and spreads
  against the model's, headings wrapped, one draw per particle, the generator; the mistakes of
  :data:`VELOCITY_MISTAKES` (a straight step, the arc turned the wrong way, ``sd`` read as a variance, the
  noise put on the pose) are named.
* :func:`check_range_bearing_jacobian` - ``fn(state, landmark) -> (2, 3)``: the EKF's measurement
  Jacobian of range and bearing at three poses; the mistakes of :data:`JACOBIAN_MISTAKES` (offset
  reversed, ``+1`` for the heading, ``q`` for ``sqrt(q)``, ``dx`` and ``dy`` swapped) are named.
* :func:`check_relative_jacobian` - ``fn(state, landmark) -> (2, 3)``: chapter 13's variant sensor, the
  Jacobian of the landmark measured in the robot's frame ``R(theta)^T (l - p)``; the mistakes of
  :data:`RELATIVE_MISTAKES` (``R`` not transposed, offset reversed, heading column zero or of the wrong
  sign) are named.
* :func:`check_consistency` - ``fn(errors, covariances) -> (average_nees, band, fraction)``: the
  NEES check of a filter over ``R`` runs (chapter 23), the run-averaged NEES per step, the 95 % band
  of an average of ``R`` chi-square variables with ``d`` degrees of freedom and the fraction of steps
  inside it, against :func:`nees_consistency`; the mistakes of :data:`CONSISTENCY_MISTAKES` (a single
  run's band, the band not divided by ``R``, ``P`` not inverted, a one-sided band, the runs summed)
  are named.
* :func:`check_ess` - ``fn(log_weights) -> ess``: the effective sample size ``1 / sum_i W_i^2`` from
  log-weights (chapter 21), on cases that underflow and overflow in the linear domain; weights not
  normalised, a fraction instead of a number and exponentiation without the maximum subtracted are named.
* :func:`check_pose_density` - ``fn(x, z, landmark, sd) -> (N,)``: the log-density ``log q_z(x)`` of a
  pose drawn from a range-bearing reading (chapter 12), against :func:`pose_reading_log_density`; the
  mistakes of :data:`POSE_DENSITY_MISTAKES` (the bearing added, the Jacobian ``1 / h_r``, the
  direction's ``1 / (2 pi)`` or the truncation ``Phi(r / s_r)`` left out, the residual not wrapped,
  standard deviations read as variances) are named.
* :func:`check_bearing_pose_draw` - ``fn(b, landmark, sd_b, r_max, n, rng) -> (n, 3)``: chapter 12's variant,
  poses drawn from a bearing-only reading; a large cloud's statistics against the model's, the generator, and
  the mistakes of :data:`BEARING_POSE_MISTAKES` (range uniform instead of the disc, half a circle, no ``pi``,
  the bearing's sign, ``sd`` as a variance) named.
* :func:`check_beam_reading` - ``fn(z_star, scanner, rng) -> z``: one reading per beam drawn from the four-part
  beam model (chapter 14's coding exercise), checked by the shares of readings below, near and beyond ``z*``
  and at ``z_max``, and by the generator it draws from; the mistakes of :data:`BEAM_MISTAKES` are named;
* :func:`check_likelihood_field` - ``fn(poses, z, field) -> (N,)``: the likelihood-field log-weights of one
  scan for a cloud of poses (Thrun, Burgard and Fox 2005, table 6.3), against :func:`field_log_weights`;
  the mistakes of :data:`FIELD_MISTAKES` (max-range beams kept, the heading left out of the beam's
  direction, no ``z_rand / z_max`` term, no Gaussian constant, a product of densities that underflows)
  are named.
* :func:`check_reset_weights` - ``fn(z, n, rng, corridor) -> (poses, log_w)``: poses drawn from a reading
  (sensor resetting) for a door-distance sensor in a corridor, weighted ``u / q p`` (the chapter
  *Finding the robot on the map*, :mod:`.map_global`); the generator is checked, and equal weights,
  the likelihood alone, the prior left out and the kernel's constant left out are named.
* :func:`check_takeover` - ``fn(log_prior_odds, sd, confirm, T, runs, rng) -> share``: exercise 15.1, how often a
  look-alike stratum takes over a right cloud under hysteresis (:mod:`.map_global`), against the exact streak
  probability; the generator is checked and the mistakes of :data:`TAKEOVER_MISTAKES` are named.
* :func:`check_random_beams` - ``fn(z, z_star, beam, k, rng) -> (N,)``: the beam model's log-likelihood on
  ``k`` beams drawn at random among a scan's echoes, the same for every pose (the real robot's chapter,
  :mod:`.real_robot`); the beams summed are solved for, the generator is checked, and the mistakes of
  :data:`RANDOM_BEAM_MISTAKES` are named.
* :func:`check_mse_ratio` - ``fn(a, b, n_boot, rng) -> (ratio, low, high)``: the ratio of two settings' mean
  squared errors over the same runs and its 95 % percentile bootstrap interval (chapter 20's coding exercise);
  the ratio reversed, the chapter's median of ratios, the RMSE ratio, the mean of per-run ratios, the runs' own
  quantiles and an unpaired bootstrap are named, and the generator is checked.
* :func:`check_time_to_lock` - ``fn(pos_err, head_err, dt) -> float or None``: the time from which a run stays
  locked on to its end (chapter 22's coding exercise); the first entry, a step number, ``<=``, the heading
  ignored and the last step outside are named.

Each Part ends with a capstone (:mod:`.capstones`):

* :func:`check_sv_filter` - ``fn(y, n, rng, model) -> (means, log_likelihood)``: Part I's capstone, a
  particle filter for the stochastic volatility model :class:`SVModel`, against a converged grid; its
  means tested for bias and its likelihood for unbiasedness over seeded runs, seven typical mistakes named.
* :func:`check_bearing_filter` - ``fn(z, observer, n, rng, model) -> (means, log_likelihood)``: Part II's
  capstone, a particle filter for bearing-only tracking of a drifting target from a moving observer
  (:class:`BearingModel`), against a converged grid in the plane; eight typical mistakes named.
* :func:`check_count_filter` - ``fn(y, n, rng, model) -> means`` and :func:`check_count_study` -
  ``fn(filter_fn, y, model, n_values, n_runs, seed) -> rmse``: Part III's capstone, a particle filter for
  Poisson counts with a hidden log-rate (:class:`CountModel`) against a converged grid, and a seeded study
  of its RMSE against the number of particles with common random numbers; nine typical mistakes named.
* :func:`check_sv_pairs` - ``fn(y, n, rng, model) -> e``: Part V's capstone, a particle smoother of PAIRS of
  states for the same model, ``e_k = E[(x_k+1 - phi x_k)^2 | y_1..y_T]``, against the grid's; six typical
  mistakes named, the ancestral lines by their spread, the generator checked.
"""

from __future__ import annotations

from pfcourse.book.exercises.capstones import SVModel, check_sv_filter, sv_bootstrap, sv_grid  # noqa: F401
from pfcourse.book.exercises.capstones import (  # noqa: F401
    BearingModel, bearing_bootstrap, bearing_grid, check_bearing_filter)
from pfcourse.book.exercises.capstones import check_sv_pairs, sv_grid_pairs, sv_pairs  # noqa: F401
from pfcourse.book.exercises.checking import (  # noqa: F401
    CheckReport,
    _answer,
    _cloud_answers,
    _per_particle_answers,
    _settled,
    _shaped,
)
from pfcourse.book.exercises.map_global import (  # noqa: F401
    RESET_MISTAKES,
    TAKEOVER_MISTAKES,
    check_reset_weights,
    check_takeover,
)
from pfcourse.book.exercises.real_robot import (  # noqa: F401
    RANDOM_BEAM_MISTAKES,
    check_random_beams,
)
from pfcourse.book.exercises.onramp import (  # noqa: F401
    INFLATION,
    TWO_BEACONS,
    TWO_BEACON_MISTAKES,
    check_two_beacon_filter,
    two_beacon_case,
    two_beacon_grid,
)
from pfcourse.book.exercises.part1 import (  # noqa: F401
    APF_MISTAKES,
    KALMAN_CASE,
    KALMAN_MISTAKES,
    IS_TOY_CASE,
    IS_UNDERFLOW_CASE,
    IS_TOY_MISTAKES,
    LANDMARK_CASE,
    LANDMARK_MISTAKES,
    LIKELIHOOD_CASES,
    LIKELIHOOD_H,
    LIKELIHOOD_MISTAKES,
    LIKELIHOOD_R,
    PROPOSAL_MODEL,
    PROPOSAL_PARENTS,
    PROPOSAL_Z,
    SIS_CASE,
    ScalarModel,
    _VARIANCE_MARGIN,
    _fits,
    _log_normal,
    _origins,
    _per_step_answer,
    _proposal_mistakes,
    _scalar_filter,
    APF_STEP_MISTAKES,
    APF_STEP_MODEL,
    apf_second_stage,
    apf_step_exact,
    fastslam2_exact,
    FASTSLAM2_CASE,
    FASTSLAM2_MISTAKES,
    check_ancestors,
    check_apf_second_stage,
    check_apf_step,
    check_cv_kalman,
    check_fastslam2_move,
    check_importance_sampler,
    check_kalman,
    check_landmark_update,
    check_log_likelihood,
    check_multinomial_resampler,
    check_optimal_proposal,
    check_resampler,
    check_sis,
    check_stratified_resampler,
    check_weight_update,
    check_evidence_increment,
    evidence_increment_case,
    landmark_log_likelihood,
    landmark_update,
    scalar_kalman,
    scalar_optimal_proposal,
    toy_is_limit,
    toy_is_ess_ratio,
)
from pfcourse.book.exercises.why_it_works import (  # noqa: F401
    FK_MISTAKES,
    check_guided_fk,
    fk_exact_log_likelihood,
    fk_guided_exact,
    fk_simulate,
)
from pfcourse.book.exercises.part2 import (  # noqa: F401
    ALTIMETER_DX,
    ALTIMETER_DY,
    ALTIMETER_HEIGHTS,
    ALTIMETER_MISTAKES,
    ALTIMETER_RF,
    ALTITUDE_CASE,
    ALTITUDE_MISTAKES,
    BEAM_CASE,
    BEAM_MISTAKES,
    BIAS_CASE,
    BIAS_MISTAKES,
    FIELD_MISTAKES,
    FieldCase,
    JACOBIAN_CASES,
    JACOBIAN_MISTAKES,
    JITTER_COV,
    JITTER_N,
    JITTER_SCALE,
    POSE_DENSITY_CASES,
    POSE_DENSITY_MISTAKES,
    BEARING_POSE_CASE,
    BEARING_POSE_MISTAKES,
    RANGE_BEARING_LANDMARK,
    RANGE_BEARING_MISTAKES,
    RANGE_BEARING_R,
    RANGE_BEARING_Z,
    RELATIVE_CASES,
    RELATIVE_MISTAKES,
    VELOCITY_MISTAKES,
    _RoomGrid,
    _named_mistake,
    _poses_near_reading,
    _wrap,
    _wrap,
    altimeter_log_likelihood,
    altitude_update,
    check_altitude_update,
    check_beam_reading,
    check_bias_update,
    check_likelihood_field,
    check_bearing_pose_draw,
    check_pose_density,
    check_range_bearing_jacobian,
    check_relative_jacobian,
    check_range_bearing_log_weights,
    check_epanechnikov_move,
    check_robust_altimeter,
    robust_altimeter_log_likelihood,
    ROBUST_ALTIMETER_MISTAKES,
    epanechnikov_bandwidth,
    epanechnikov_move,
    check_velocity_motion,
    beam_reading_reference,
    field_log_weights,
    pose_reading_log_density,
    bearing_pose_draw,
    range_bearing_jacobian,
    relative_landmark_jacobian,
    range_bearing_log_weights,
    velocity_motion,
)
from pfcourse.book.exercises.part3 import (  # noqa: F401
    ADAPTIVE_MISTAKES,
    ESS_CASES,
    ESS_MISTAKES,
    adaptive_residual,
    check_adaptive_residual,
    check_ess,
    effective_sample_size_from_logs,
    RATIO_CASE,
    RATIO_MISTAKES,
    TIME_TO_LOCK_MISTAKES,
    check_mse_ratio,
    check_time_to_lock,
    mse_ratio_reference,
    time_to_lock_cases,
    time_to_lock_reference,
)
from pfcourse.book.exercises.capstones import (  # noqa: F401  (Part III's capstone)
    CountModel,
    check_count_filter,
    check_count_study,
    count_bootstrap,
    count_data,
    count_grid,
)
from pfcourse.book.exercises.part4 import (  # noqa: F401
    ANONYMOUS_CASES,
    ANONYMOUS_LANDMARKS,
    ANONYMOUS_MISTAKES,
    ANONYMOUS_R,
    CLUTTER_PF_MISTAKES,
    CLUTTER_TARGET,
    CONSISTENCY_MISTAKES,
    MISSING_NIS_MISTAKES,
    RANGE_ONLY_CASES,
    RANGE_ONLY_MISTAKES,
    RANGE_ONLY_VAR,
    _consistency_case,
    _missing_nis_case,
    anonymous_log_likelihood,
    clutter_target_posterior,
    clutter_target_readings,
    check_anonymous_likelihood,
    check_clutter_pf,
    check_consistency,
    check_missing_nis,
    check_range_only_anonymous,
    missing_nis_consistency,
    nees_consistency,
    range_only_log_likelihood,
)
from pfcourse.book.exercises.particle_mcmc import check_ancestor_index  # noqa: F401
from pfcourse.book.exercises.part5 import (  # noqa: F401
    BACKWARD_K,
    BACKWARD_MISTAKES,
    BACKWARD_N,
    BACKWARD_STEPS,
    ADAPTED_MISTAKES,
    ESTIMATOR_MISTAKES,
    ESTIMATOR_RESAMPLED,
    _backward_case,
    adapted_log_likelihood,
    check_adapted_likelihood,
    check_fixed_lag,
    fixed_lag_reference,
    backward_weights,
    check_backward_weights,
    check_likelihood_estimate,
    likelihood_estimate,
)
from pfcourse.book.exercises.static_parameters import (  # noqa: F401
    STORVIK_MISTAKES,
    STORVIK_R,
    check_storvik_step,
    storvik_case,
    storvik_step_reference,
)
