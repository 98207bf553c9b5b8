"""The Intel global runs judged by AMCL's kind of estimate (the study ``intel/cluster_estimate``).

Chapter 16 judges a global run by the cloud's weighted mean.  ROS ``amcl`` reports instead the mean of
its heaviest cluster; for a cloud split between the robot and a look-alike the two differ.
:func:`cluster_row` re-runs a run of ``intel/injection``'s arm ``guarded`` (chapter 15's cure on the
second half's map, the same start scan and filter seed) keeping the cloud of every scan, and judges it
by :func:`heaviest_cluster_mean` as well: particles binned in ``CLUSTER_BIN`` cells (x, y, heading),
the heaviest cell, then the weighted mean of the particles within ``CLUSTER_RADIUS`` of its centre.

The clouds are read where :func:`pfcourse.scenarios.maprobot.global_mcl.global_mcl` forms its mean
(its ``observe`` hook, which draws nothing); the filter itself is unchanged, so the run's
draws and its ``locked_on`` label are ``intel/injection``'s.
"""

from __future__ import annotations


import numpy as np

from pfcourse.angles import circular_mean
from pfcourse.checks import Array
from pfcourse.metrics import heading_error, position_error
from pfcourse.scenarios.maprobot import global_mcl as _global_mcl
from pfcourse.studies import intel

#: The clustering: cells of 1 m x 1 m x 30 degrees, then the particles within 1 m of the heaviest cell's mean.
CLUSTER_BIN = (1.0, 1.0, float(np.radians(30.0)))
CLUSTER_RADIUS = 1.0
CLUSTER_COLUMNS = ("seed", "start_scan", "locked_on", "locked_on_cluster", "final_position_error",
                   "final_cluster_error", "final_mass_near_reference")


def heaviest_cluster_mean(x: Array, W: Array) -> Array:
    """``(x, y, heading)``: the weighted mean (circular for the heading) of the particles within
    ``CLUSTER_RADIUS`` of the mean of the heaviest ``CLUSTER_BIN`` cell; ``W`` normalised weights."""
    cell = np.floor(x / np.asarray(CLUSTER_BIN)).astype(np.int64)
    _, which = np.unique(cell, axis=0, return_inverse=True)
    which = which.ravel()
    top = which == np.argmax(np.bincount(which, W))
    centre = W[top] @ x[top, :2] / W[top].sum()
    near = np.hypot(*(x[:, :2] - centre).T) < CLUSTER_RADIUS
    w = W[near]
    return np.array([*(w @ x[near, :2]) / w.sum(), circular_mean(x[near, 2], w)])


def cluster_row(seed: int) -> dict:
    """Run ``seed`` of ``intel/injection``'s ``guarded`` arm, judged by the cloud's mean (``locked_on``, the
    stored label) and by the heaviest cluster's mean (``locked_on_cluster``); ``final_mass_near_reference``:
    the weight within 1 m and the heading tolerance of the reference at the last scan."""
    sp = intel.split()
    first = intel.global_start(seed)
    run = slice(first, first + intel.GLOBAL_STEPS)
    odometry = sp.odometry[run].copy()
    odometry[0] = 0.0
    scans = sp.ranges[run, ::intel.BEAM_STEP]
    clouds = []
    res = _global_mcl.global_mcl(sp.free, sp.field(), intel.MOTION, scans, odometry,
                                 np.random.default_rng([41, seed, 1]), intel.GUARDED_SETTINGS,
                                 observe=lambda k, x, W: clouds.append((x.copy(), W.copy())))
    truth, tol = sp.poses[run], intel.heading_tolerance(sp.log)
    cluster = np.array([heaviest_cluster_mean(x, W) for x, W in clouds])
    pos, head = position_error(truth, res.mean), heading_error(truth, res.mean)
    x, W = clouds[-1]
    near = (position_error(truth[-1], x) < intel.LOCK_POSITION_M) & (heading_error(truth[-1], x) < tol)
    return {"start_scan": first, "locked_on": intel.locked_on_share(pos, head, tol),
            "locked_on_cluster": intel.locked_on_share(position_error(truth, cluster), heading_error(truth, cluster), tol),
            "final_position_error": float(pos[-1]), "final_cluster_error": float(position_error(truth[-1], cluster[-1])),
            "final_mass_near_reference": float(W[near].sum())}
