"""Studies of the chapter *Finding the robot on the map*: the twin margin, and the cure on the map robot.

Run ``seed`` is the drive of :func:`pfcourse.studies.maprobot.simulate` (the drives of map_robot's
stored studies); the cure's filter draws from
``numpy.random.default_rng([41, seed, 2])``.  Lock-on is :func:`pfcourse.scenarios.maprobot.lock_on.locked_on`
with the heading tolerance of three standard deviations of one straight step's odometry heading noise
(:data:`HEADING_TOL`).
"""

from __future__ import annotations

import numpy as np

from pfcourse.studies import maprobot as study
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.global_mcl import CURE, HAZARD, POOR_FIT, SETTINGS, GlobalSettings, global_mcl
from pfcourse.scenarios.maprobot.twins import exact_twin_estimate, twin_margin
from pfcourse.metrics import heading_error, position_error

#: One straight step of the drive (m): 0.5 m/s for DT.
STEP_M = 0.5 * study.DT
HEADING_TOL = lock_on.heading_tolerance(study.MOTION, STEP_M)
#: Decided: the truth's posterior odds against all its twins at least DECIDED_ODDS : 1 ...
DECIDED_ODDS = 99.0
#: ... at the share of the last window's steps the lock-on rule asks for.
MARGIN_TIMES_S = tuple(range(5, 101, 5))
TWIN_COLUMNS = ("seed", "decided", "final_margin", "final_best_margin",
                *(f"margin_{t}s" for t in MARGIN_TIMES_S))
GLOBAL_COLUMNS = ("seed", "locked_on", "locked_from_s", "final_position_error", "final_heading_error",
                  "mean_particles", "start_particles")
KIDNAP_COLUMNS = ("seed", "tracked_before", "recovered", "recovery_s", "final_position_error")
#: The fresh drives: runs FRESH_SEED, FRESH_SEED + 1, ... (the cure was designed on drives 0-149: 0-99, then these).
FRESH_SEED, FRESH_RUNS = 100, 50
#: The fresh drives' columns: the above, with when the run was lost (a false relocalization, :func:`lost_times`)
#: and, for a kidnapping, how far it moved the robot.
GLOBAL_FRESH_COLUMNS = (*GLOBAL_COLUMNS, "n_lost", "lost_s")
KIDNAP_FRESH_COLUMNS = (*KIDNAP_COLUMNS, "n_lost", "lost_s", "jump_m", "jump_deg")
#: A run is *lost* when, after LOST_AFTER_S of steps within the lock-on tolerances in a row, its estimate
#: leaves them for at least LOST_FOR_S with a position error above LOST_M at some step of that stretch.
LOST_AFTER_S, LOST_FOR_S, LOST_M = 10.0, 2.0, 2.0


def filter_rng(seed: int) -> np.random.Generator:
    return np.random.default_rng([41, seed, 2])


def decided(margin: np.ndarray) -> bool:
    """The evidence decides a drive: the margin (log-odds against all twins) above ``log(DECIDED_ODDS)``
    at the share of the last window's steps that lock-on asks for (:mod:`pfcourse.scenarios.maprobot.lock_on`)."""
    window = int(np.ceil(lock_on.WINDOW_S / study.DT - 1e-9))
    return bool(np.mean(margin[-window:] > np.log(DECIDED_ODDS)) >= lock_on.SHARE)


EXACT_COLUMNS = ("seed", "decided", "exact_locked_on", "exact_locked_from_s")
EXACT_KIDNAP_COLUMNS = ("seed", "exact_recovered", "exact_recovery_s", "exact_final_position_error")


def exact_kidnap_row(seed: int) -> dict:
    """The kidnap runs' twin bound: on ``seed``'s kidnap drive, the truth until the kidnapping, then an exact filter
    over the true path and its twins from the kidnapping on (:func:`exact_twin_estimate` on the steps after it,
    equal masses at the kidnapping: it knows when the robot was carried off, and that it is on one of those paths),
    judged as :func:`kidnap_row` judges the cure: recovered (locked on at the end), the time (s) from the kidnapping
    to the step from which it stays locked on (NaN if not recovered)."""
    k = study.KIDNAP_STEP
    run = study.simulate(seed, study.KIDNAP_STEPS, kidnap_at=k)
    est = np.vstack([run.truth[:k], exact_twin_estimate(study.book_map(), study.field(), run.truth[k:], run.scans[k:])])
    pos, head = position_error(run.truth, est), heading_error(run.truth, est)
    recovered = lock_on.locked_on(pos, head, study.DT, HEADING_TOL)
    start = lock_on.locked_from(pos, head, study.DT, HEADING_TOL)
    return {"exact_recovered": recovered,
            "exact_recovery_s": float((max(start, k) - k) * study.DT) if recovered else np.nan,
            "exact_final_position_error": float(pos[-1])}


def exact_row(seed: int) -> dict:
    """The bound judged by the lock-on rule itself: an exact filter over the truth and its twins
    (:func:`pfcourse.scenarios.maprobot.twins.exact_twin_estimate`) on ``seed``'s global drive, locked on or not."""
    run = study.simulate(seed, study.GLOBAL_STEPS)
    est = exact_twin_estimate(study.book_map(), study.field(), run.truth, run.scans)
    margin, _ = twin_margin(study.book_map(), study.field(), run.truth, run.scans)
    pos, head = position_error(run.truth, est), heading_error(run.truth, est)
    return {"decided": decided(margin), "exact_locked_on": lock_on.locked_on(pos, head, study.DT, HEADING_TOL),
            "exact_locked_from_s": lock_on.locked_from(pos, head, study.DT, HEADING_TOL) * study.DT}


def twin_row(seed: int) -> dict:
    """The twin margin of ``seed``'s global drive: decided, final margins, the margin every 5 s."""
    run = study.simulate(seed, study.GLOBAL_STEPS)
    margin, best = twin_margin(study.book_map(), study.field(), run.truth, run.scans)
    row = {"decided": decided(margin), "final_margin": float(margin[-1]), "final_best_margin": float(best[-1])}
    row.update({f"margin_{t}s": float(margin[int(round(t / study.DT)) - 1]) for t in MARGIN_TIMES_S})
    return row


def global_row(seed: int, settings: GlobalSettings = SETTINGS) -> dict:
    """The cure (:func:`pfcourse.scenarios.maprobot.global_mcl.global_mcl` with ``settings``) from a uniform start on
    ``seed``'s drive."""
    run = study.simulate(seed, study.GLOBAL_STEPS)
    res = global_mcl(study.book_map(), study.field(), study.MOTION, run.scans, run.drive.odometry, filter_rng(seed),
                     settings)
    pos, head = position_error(run.truth, res.mean), heading_error(run.truth, res.mean)
    return {"locked_on": lock_on.locked_on(pos, head, study.DT, HEADING_TOL),
            "locked_from_s": lock_on.locked_from(pos, head, study.DT, HEADING_TOL) * study.DT,
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "mean_particles": float(res.sizes[1:].mean()), "start_particles": int(res.sizes[0])}


def lost_times(pos: np.ndarray, head: np.ndarray, skip_step: int | None = None) -> list[float]:
    """The times (s) at which a run that had been within the lock-on tolerances for :data:`LOST_AFTER_S`
    in a row left them for :data:`LOST_FOR_S` or more, at least :data:`LOST_M` away at some step
    (a stretch starting at ``skip_step``, the kidnapping, is not counted)."""
    ok = lock_on.locked_steps(pos, head, HEADING_TOL)
    after, longer = int(round(LOST_AFTER_S / study.DT)), int(round(LOST_FOR_S / study.DT))
    times, run_ok, k = [], 0, 0
    while k < len(ok):
        if ok[k]:
            run_ok, k = run_ok + 1, k + 1
            continue
        j = k
        while j < len(ok) and not ok[j]:
            j += 1
        if run_ok >= after and j - k >= longer and pos[k:j].max() > LOST_M and k != skip_step:
            times.append(k * study.DT)
        run_ok, k = 0, j
    return times


def hazard_global_fresh_row(seed: int, settings: GlobalSettings = HAZARD) -> dict:
    """:func:`hazard_global_row` on a fresh drive, with the times the run was lost (:func:`lost_times`)."""
    run = study.simulate(seed, study.GLOBAL_STEPS)
    res = global_mcl(study.book_map(), study.field(), study.MOTION, run.scans, run.drive.odometry, filter_rng(seed),
                     settings)
    pos, head = position_error(run.truth, res.mean), heading_error(run.truth, res.mean)
    lost = lost_times(pos, head)
    return {"locked_on": lock_on.locked_on(pos, head, study.DT, HEADING_TOL),
            "locked_from_s": lock_on.locked_from(pos, head, study.DT, HEADING_TOL) * study.DT,
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "mean_particles": float(res.sizes[1:].mean()), "start_particles": int(res.sizes[0]),
            "n_lost": len(lost), "lost_s": lost[0] if lost else np.nan}


def hazard_kidnap_fresh_row(seed: int, settings: GlobalSettings = HAZARD) -> dict:
    """:func:`hazard_kidnap_row` on a fresh drive, with the times the run was lost (:func:`lost_times`, the
    kidnapping itself not counted) and the kidnapping's move (m, degrees)."""
    k = study.KIDNAP_STEP
    run = study.simulate(seed, study.KIDNAP_STEPS, kidnap_at=k)
    res = global_mcl(study.book_map(), study.field(), study.MOTION, run.scans, run.drive.odometry, filter_rng(seed),
                     settings, start=run.truth[0])
    pos, head = position_error(run.truth, res.mean), heading_error(run.truth, res.mean)
    recovered = lock_on.locked_on(pos, head, study.DT, HEADING_TOL)
    start = lock_on.locked_from(pos, head, study.DT, HEADING_TOL)
    lost = lost_times(pos, head, skip_step=k)
    a, b = run.truth[k - 1], run.truth[k]
    return {"tracked_before": bool(np.all(pos[10:k] < lock_on.POSITION_TOLERANCE_M)),
            "recovered": recovered,
            "recovery_s": float((max(start, k) - k) * study.DT) if recovered else np.nan,
            "final_position_error": float(pos[-1]), "n_lost": len(lost), "lost_s": lost[0] if lost else np.nan,
            "jump_m": float(np.hypot(*(b[:2] - a[:2]))),
            "jump_deg": float(np.degrees(abs(np.angle(np.exp(1j * (b[2] - a[2]))))))}


#: The held-out drives 150-249, not used in choosing the cure: the cure before hysteresis (:data:`HAZARD`) and the
#: cure (:data:`CURE`) on the same drives, paired (stored in two goes, drives 150-199 then 200-249: registry.extend).
HELDOUT_SEED, HELDOUT_RUNS = 150, 100


def heldout_hazard_global_row(seed: int) -> dict:
    """:func:`hazard_global_fresh_row` with :data:`HAZARD` (the cure before hysteresis) on a held-out drive."""
    return hazard_global_fresh_row(seed, HAZARD)


def heldout_hazard_kidnap_row(seed: int) -> dict:
    """:func:`hazard_kidnap_fresh_row` with :data:`HAZARD` (the cure before hysteresis) on a held-out drive."""
    return hazard_kidnap_fresh_row(seed, HAZARD)


def heldout_global_row(seed: int) -> dict:
    """:func:`hazard_global_fresh_row` with the cure :data:`pfcourse.scenarios.maprobot.global_mcl.CURE` on a
    held-out drive."""
    return hazard_global_fresh_row(seed, CURE)


def heldout_kidnap_row(seed: int) -> dict:
    """:func:`hazard_kidnap_fresh_row` with the cure :data:`pfcourse.scenarios.maprobot.global_mcl.CURE` on a
    held-out drive."""
    return hazard_kidnap_fresh_row(seed, CURE)


#: Uniform random injection (map_robot's ``injection`` filter, product weighting) at about the cure's cost:
#: :data:`INJECTION_N` particles, on the held-out drives, judged by the cure's lock-on rule, paired with the cure.
INJECTION_N = 5000
INJECTION_COLUMNS = ("seed", "locked_on", "locked_from_s", "final_position_error", "final_heading_error",
                     "injection_cpu_s", "cure_cpu_s")


def heldout_injection_row(seed: int, n_particles: int = INJECTION_N) -> dict:
    """Uniform random injection with ``n_particles`` from a uniform start on held-out drive ``seed``
    (:func:`pfcourse.studies.maprobot.run_filter`, its filter rng ``filter_rng(seed, 0)``), judged by
    :data:`HEADING_TOL`; and the CPU time (s, ``time.process_time``, volatile) of this filter and of the cure on the
    same drive, run one after the other in the same process."""
    import time

    run = study.simulate(seed, study.GLOBAL_STEPS)
    t0 = time.process_time()
    res = study.run_filter(run, seed, n_particles, "injection", weighting="product")
    t1 = time.process_time()
    global_mcl(study.book_map(), study.field(), study.MOTION, run.scans, run.drive.odometry, filter_rng(seed), CURE)
    t2 = time.process_time()
    pos, head = position_error(run.truth, res.mean), heading_error(run.truth, res.mean)
    return {"locked_on": lock_on.locked_on(pos, head, study.DT, HEADING_TOL),
            "locked_from_s": lock_on.locked_from(pos, head, study.DT, HEADING_TOL) * study.DT,
            "final_position_error": float(pos[-1]), "final_heading_error": float(head[-1]),
            "injection_cpu_s": t1 - t0, "cure_cpu_s": t2 - t1}


def poor_fit_global_row(seed: int) -> dict:
    """:func:`global_row` with the variant :data:`pfcourse.scenarios.maprobot.global_mcl.POOR_FIT`."""
    return global_row(seed, POOR_FIT)


def poor_fit_kidnap_row(seed: int) -> dict:
    """:func:`kidnap_row` with the variant :data:`pfcourse.scenarios.maprobot.global_mcl.POOR_FIT`."""
    return kidnap_row(seed, POOR_FIT)


def hazard_global_row(seed: int) -> dict:
    """:func:`global_row` with the kidnap model's prior, :data:`pfcourse.scenarios.maprobot.global_mcl.HAZARD`."""
    return global_row(seed, HAZARD)


def hazard_kidnap_row(seed: int) -> dict:
    """:func:`kidnap_row` with the kidnap model's prior, :data:`pfcourse.scenarios.maprobot.global_mcl.HAZARD`."""
    return kidnap_row(seed, HAZARD)


def kidnap_row(seed: int, settings: GlobalSettings = SETTINGS) -> dict:
    """The cure (``settings``) tracking ``seed``'s kidnap drive from the known start: recovered (locked on
    at the end), the time (s) from the kidnapping to the step from which it stays locked on (NaN if not
    recovered)."""
    run = study.simulate(seed, study.KIDNAP_STEPS, kidnap_at=study.KIDNAP_STEP)
    res = global_mcl(study.book_map(), study.field(), study.MOTION, run.scans, run.drive.odometry, filter_rng(seed),
                     settings, start=run.truth[0])
    pos, head = position_error(run.truth, res.mean), heading_error(run.truth, res.mean)
    recovered = lock_on.locked_on(pos, head, study.DT, HEADING_TOL)
    start = lock_on.locked_from(pos, head, study.DT, HEADING_TOL)
    return {"tracked_before": bool(np.all(pos[10:study.KIDNAP_STEP] < lock_on.POSITION_TOLERANCE_M)),
            "recovered": recovered,
            "recovery_s": float((max(start, study.KIDNAP_STEP) - study.KIDNAP_STEP) * study.DT) if recovered else np.nan,
            "final_position_error": float(pos[-1])}
