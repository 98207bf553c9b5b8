# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A real robot: the Intel Research Lab log
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** how a laser log recorded by a real robot is read, how a map is built from scans at
# known poses (occupancy grid mapping), and how well Monte Carlo localization tracks and finds the
# robot on a map built from the other half of the run, and what such a test can and cannot show.
#
# **You need** {doc}`map_robot` (the odometry model, the likelihood field, MCL); Bayes' rule; NumPy.
#
# **Time:** about twenty-five minutes to read; the notebook runs in about fifteen seconds on a quiet
# machine (its global-localization runs are stored: they take minutes).
# :::
#
# Every robot of the book so far was simulated: the filter knew the noise that made the data. A real
# robot does not oblige. Its wheels slip by amounts no model states, people walk through its scans, and
# nobody measured where it truly was. This chapter takes a classic recording, the Intel Research Lab in
# Seattle, credited on Radish, the Robotics Data Set Repository {cite:p}`howard2003radish`, to Dirk
# Hähnel, and asks the questions of {doc}`map_robot` of it.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import json

import numpy as np
import matplotlib.pyplot as plt
import pandas as pd
from ipywidgets import Dropdown, SelectionSlider
from IPython.display import display
from scipy.ndimage import distance_transform_edt
from scipy.spatial import cKDTree
from scipy.special import logsumexp

from pfcourse import evidence
from pfcourse.studies import intel
from pfcourse.studies.registry import STUDIES
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import control_panel
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.maprobot import (
    LikelihoodField, MapRobotModel, OdometryModel)
from pfcourse.scenarios.maprobot.carmen import relative_pose
from pfcourse.book.figures.maprobot import draw_map
from pfcourse.scenarios.maprobot.mapping import build_map
from pfcourse.metrics import heading_error, position_error
from pfcourse.book.style import COLORS, use_style

use_style()
split = intel.split()  # the library's map and held-out scans, to check the chapter's code against

# %% [markdown]
# ## The log
#
# A CARMEN log is a text file, one message a line. Two kinds matter here. A `FLASER` line is a scan:
# $180$ ranges, one beam per degree from the robot's right to its left, followed by the pose the scan
# was taken at. A beam with no echo reads $81.83$ m. An `ODOM` line is the pose the wheel encoders
# have integrated so far.
#
# This copy is *corrected*: the pose on each `FLASER` line is not the odometry but a SLAM estimate over
# the whole log, loop closures included (GMapping's {cite:p}`grisetti2007`, a particle-filter SLAM
# method, as these logs are usually described; the file's source does not say). After each scan
# the `ODOM` lines restart from that corrected pose, so what the wheels measured between scans $k$ and
# $k+1$ is the last odometry pose before scan $k+1$, $\bar x_{k+1}$, seen from the corrected pose $x_k$:
#
# $$
# u_{k+1} = x_k^{-1} \oplus \bar x_{k+1}, \qquad
# x^{-1} \oplus x' = \big(R_\theta^\top (p' - p),\; \theta' - \theta\big),
# $$
#
# with $p$ the position and $R_\theta$ the rotation by the heading. The loader below does that, and
# turns $u_k$ into the $(\delta_{\mathrm{rot1}}, \delta_{\mathrm{trans}}, \delta_{\mathrm{rot2}})$ of
# the odometry model. A robot that backs up gets a negative $\delta_{\mathrm{trans}}$, not a half-turn.

# %%
from pfcourse.scenarios.maprobot.carmen import read_carmen

log = read_carmen()  # book/data/intel/intel-corrected.log.gz
u = log.odometry()  # (rot1, trans, rot2) from scan k - 1 to scan k
minutes = (log.times[-1] - log.times[0]) / 60
print(f"{log.n_scans} scans of {log.ranges.shape[1]} beams, "
      f"{log.n_odometry} odometry lines, {minutes:.0f} minutes")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
steps = relative_pose(log.poses[:-1], log.poses[1:])
path_m = np.hypot(*steps[:, :2].T).sum()
dr_full = log.dead_reckoning()
true_turn = steps[:, 2]
rel = log.relative_motion()[1:]
turn_error = np.angle(np.exp(1j * (rel[:, 2] - true_turn)))
odo_m = np.hypot(*rel[:, :2].T)
# a turn on the spot: more than 20 degrees, less than 0.1 m; a straight step: less than 5 degrees
on_spot = (np.abs(rel[:, 2]) > np.radians(20)) & (odo_m < 0.1)
straight = np.abs(rel[:, 2]) < np.radians(5)
dt = np.diff(log.times)
glue_values("intel_", n_scans=log.n_scans, n_odometry=log.n_odometry, minutes=minutes, path_m=path_m,
            no_echo_share=1 - log.returned.mean(), step_m=np.median(u[1:, 1]),
            full_dead_reckoning_m=position_error(log.poses[-1], dr_full[-1]),
            full_dead_reckoning_deg=np.degrees(heading_error(log.poses[-1], dr_full[-1])),
            heading_drift_rad_per_m=turn_error.sum() / odo_m.sum(),
            turn_step_bias_deg=np.degrees(turn_error[on_spot].mean()),
            straight_step_bias_deg=np.degrees(turn_error[straight].mean()),
            straight_step_m=np.median(odo_m[straight]), n_steps=len(dt), n_on_spot=int(on_spot.sum()),
            scan_dt_s=np.median(dt), n_time_reversals=int((dt < 0).sum()),
            on_spot_corrected_cm=100 * np.median(np.hypot(*steps[on_spot, :2].T)),
            on_spot_odometry_cm=100 * np.median(odo_m[on_spot]))
EvidenceBlock(
    "the log's steps and the odometry's heading error",
    notes=[f"{len(dt)} steps between scans: {on_spot.sum()} turns on the spot (more than 20 degrees, less than 0.1 m "
           f"of odometry travel), {straight.sum()} straight steps (less than 5 degrees, median "
           f"{np.median(odo_m[straight]):.2f} m); median step {np.median(u[1:, 1]):.2f} m; median time between "
           f"scans {np.median(dt):.2f} s; the timestamps decrease {(dt < 0).sum()} times.",
           f"Dead reckoning over the whole run ends {position_error(log.poses[-1], dr_full[-1]):.1f} m and "
           f"{np.degrees(heading_error(log.poses[-1], dr_full[-1])):.0f} degrees from the corrected pose.",
           f"Heading error of a step (odometry minus corrected): total over total odometry travel "
           f"{turn_error.sum() / odo_m.sum():.4f} rad/m; mean {np.degrees(turn_error[straight].mean()):.2f} degrees "
           f"on straight steps, {np.degrees(turn_error[on_spot].mean()):.2f} on turns on the spot, "
           f"{np.degrees(turn_error.mean()):.2f} over all steps."],
)

# %% [markdown]
# The robot drove {glue:text}`intel_path_m:.0f` m in {glue:text}`intel_minutes:.0f` minutes. The scans
# are not evenly spaced: they are the ones the SLAM run kept, and
# {glue:text}`intel_n_on_spot:d` of the steps between them are turns on the spot (more than $20$
# degrees, less than $0.1$ m of travel); the median time between scans is
# {glue:text}`intel_scan_dt_s:.1f` s, and the timestamps are not always increasing. (ROS's `amcl`,
# for comparison, updates after every $0.2$ m or $\pi/6$ of turn.)
#
# Chained from the first pose, the odometry alone ends {glue:text}`intel_full_dead_reckoning_m:.0f` m
# away from the corrected pose. Its heading error is not random: it drifts by
# {glue:text}`intel_heading_drift_rad_per_m:.3f` rad per metre driven (clockwise), whatever the turn.
# Straight steps are off by {glue:text}`intel_straight_step_bias_deg:.1f` degrees on average, turns on
# the spot by only {glue:text}`intel_turn_step_bias_deg:.2f`. A bias that compounds is exactly what the zero-mean noise of
# the odometry model does not describe; the filter below covers it only by a spread wide enough.
#
# The reference has a floor: on a turn on the spot the corrected pose moves a median
# {glue:text}`intel_on_spot_corrected_cm:.1f` cm, the odometry's {glue:text}`intel_on_spot_odometry_cm:.1f`
# cm (the corrected pose's reference point is apparently off the wheel axis), so a few
# centimetres against it say nothing.
#
# ## The picture: a map, a path, and the odometry drifting away
#
# The figure is the chapter in one look. The map (walls black, space seen free white, the rest grey)
# was built from the second half of the run; the black line is the corrected path of the first half,
# which the filters below localize; the red line is where the odometry alone puts the robot over that
# same first half.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
held = split.poses
dr_held = split.map.to_map(dr_full[intel.HELD_OUT])
fig, ax = plt.subplots(figsize=(7.5, 6.5))
shown = np.where(split.map.log_odds > 0, 1.0, np.where(split.map.log_odds < 0, 0.0, 0.25))
draw_map(ax, split.grid, values=shown, cmap="Greys", vmin=0, vmax=1)
ax.plot(held[:, 0], held[:, 1], color=COLORS["truth"], lw=1.2, label="corrected path, first half")
ax.plot(dr_held[:, 0], dr_held[:, 1], color=COLORS["estimate"], lw=1.2, label="odometry alone")
ax.plot(*held[0, :2], "o", color=COLORS["truth"], ms=6, label="start")
ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3)
ax.set_title("Map from the second half; the first half, corrected and dead-reckoned")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
dr_error = position_error(held, dr_held)
glue_values("intel_", dead_reckoning_final_error_m=dr_error[-1],
            held_out_minutes=(log.times[intel.HELD_OUT][-1] - log.times[0]) / 60)

# %% [markdown]
# Over the first half, {glue:text}`intel_held_out_minutes:.0f` minutes, dead reckoning ends
# {glue:text}`intel_dead_reckoning_final_error_m:.1f` m from the corrected pose. The map tells where the
# walls are; the filter's job is to keep the estimate on the black line.
#
# ## Mapping with known poses
#
# Localization needs a map, and a map needs poses. With the poses given (here by GMapping), mapping is
# the easy half of the problem {cite:p}`moravec1985`: each cell $m$ of a grid is occupied or free, and
# each scan is evidence about the cells its beams cross. Keeping, per cell, the *log-odds*
# $l(m) = \log \frac{p(m)}{1 - p(m)}$ of being occupied turns Bayes' rule into a sum. If the cells are
# independent and the prior is one half ($l = 0$),
#
# $$
# l_k(m) = l_{k-1}(m) + \log \frac{p(m \mid z_k, x_k)}{1 - p(m \mid z_k, x_k)},
# $$
#
# and the term added is the *inverse sensor model*: what one scan alone says about one cell. The
# simplest one, used here, adds $l_{\mathrm{occ}} = \log(0.7/0.3)$ to the cell where a beam ends
# and $l_{\mathrm{free}} = \log(0.4/0.6)$ to each cell it crosses before that, each cell at most once
# per scan. A beam with no echo is left out here, though mapping software often clears the free space
# along it up to a set range. The log-odds are not clamped either: practical maps bound $l$ so that
# a door that opens later can still flip its cells. A cell ends up occupied where $l > 0$, free where
# $l < 0$, unknown where no beam came.
#
# :::{admonition} Algorithm 16.1: occupancy grid mapping with known poses
# :class: algorithm
# 1. Set $l(m) = 0$ for every cell.
# 2. **For** each scan $z_k$ taken at the known pose $x_k$:
#    1. for each beam with an echo, find its end point; add $l_{\mathrm{occ}}$ to the cells of the end points;
#    2. add $l_{\mathrm{free}}$ to the other cells the beams cross, sampled every half cell.
# 3. Occupied: $l(m) > 0$. The likelihood field then needs the distance from each cell to the nearest
#    occupied one (a distance transform).
# :::

# %%
RES, Z_MAX = 0.1, 25.5  # cell side (m); longer ranges mean "no echo"
L_OCC, L_FREE = np.log(0.7 / 0.3), np.log(0.4 / 0.6)


def cells(px, py, origin, shape):
    """Flat indices of the distinct cells holding the points (px, py)."""
    j = np.floor((px - origin[0]) / RES).astype(int)
    i = np.floor((py - origin[1]) / RES).astype(int)
    return np.unique(i * shape[1] + j)


def map_scans(poses, ranges, angles, origin, shape):
    L = np.zeros(shape)
    s = np.arange(0.0, Z_MAX, RES / 2)  # sample points along a beam
    for (x, y, th), z in zip(poses, ranges):
        z, a = z[z < Z_MAX], th + angles[z < Z_MAX]
        ends = cells(x + z * np.cos(a), y + z * np.sin(a), origin, shape)
        # points along each beam, up to one cell short of its end
        on = s < z[:, None] - RES
        d = np.broadcast_to(s, on.shape)[on]
        c = np.broadcast_to(np.cos(a)[:, None], on.shape)[on]
        n = np.broadcast_to(np.sin(a)[:, None], on.shape)[on]
        crossed = cells(x + d * c, y + d * n, origin, shape)
        L.flat[np.setdiff1d(crossed, ends)] += L_FREE
        L.flat[ends] += L_OCC
    return L


MAP = slice(455, 910)  # the second half of the run builds the map
P, Z = log.poses[MAP], log.ranges[MAP]
h = P[:, 2:3] + log.angles
echo = Z < Z_MAX
ex = (P[:, 0:1] + Z * np.cos(h))[echo]
ey = (P[:, 1:2] + Z * np.sin(h))[echo]
# the grid covers every end point and pose, with 1 m to spare
both = np.concatenate([np.column_stack([ex, ey]), P[:, :2]])
origin = np.floor((both.min(axis=0) - 1.0) / RES) * RES
top = both.max(axis=0) + 1.0
shape = tuple(np.ceil((top - origin) / RES).astype(int)[::-1])
L = map_scans(P, Z, log.angles, origin, shape)
print(f"{shape[0]} x {shape[1]} cells, {(L > 0).sum()} occupied")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
same_map = np.array_equal(L, split.map.log_odds) and np.array_equal(origin, split.map.origin)
print(f"the same log-odds as pfcourse.scenarios.maprobot.mapping.build_map, cell for cell: {same_map}")
map_tree, held_tree = cKDTree(log.poses[MAP, :2]), cKDTree(log.poses[intel.HELD_OUT, :2])
held_to_map, map_to_held = map_tree.query(log.poses[intel.HELD_OUT, :2])[0], held_tree.query(log.poses[MAP, :2])[0]
glue_values("intel_", held_to_map_median_m=np.median(held_to_map), held_to_map_max_m=held_to_map.max(),
            map_to_held_median_m=np.median(map_to_held), map_to_held_max_m=map_to_held.max())

# %% [markdown]
# **Which half maps, and why.** A map built from the very scans it then localizes flatters the filter:
# every wall the filter sees is exactly where those scans put it. So the run is cut in two: the second
# half builds the map, the first half is localized on it. That way round, because the second half
# covers the first one better: each pose of the first half lies a median
# {glue:text}`intel_held_to_map_median_m:.1f` m from the second half's path, at most
# {glue:text}`intel_held_to_map_max_m:.1f` m; the other way round, the median is
# {glue:text}`intel_map_to_held_median_m:.1f` m and the largest {glue:text}`intel_map_to_held_max_m:.1f` m.
# The map still differs from what the first half sees: doors open or shut, people, and the second half's
# own errors.
#
# ## Tracking on the held-out half
#
# MCL is the filter of {doc}`map_robot`: move each particle by the odometry model, weight it by the
# likelihood field, resample. Two choices differ. The field uses every fourth beam ($45$ of $180$):
# neighbouring beams see the same wall, and counting them all as independent evidence makes the
# weights overconfident. And the odometry noise $a_1, \dots, a_4$ is set for this robot, not for the
# simulated one (next paragraph).

# %%
A = np.array([0.01, 0.005, 0.01, 0.005])  # odometry noise a_1 ... a_4
SIGMA, Z_HIT, Z_RAND = 0.2, 0.9, 0.1  # likelihood field
angles = log.angles[::4]  # every fourth beam
dist = distance_transform_edt(~(L > 0)) * RES  # metres to the nearest wall


def sample_motion(x, u, rng):
    rot1, trans, rot2 = u
    sd = np.sqrt([A[0] * rot1**2 + A[1] * trans**2,
                  A[2] * trans**2 + A[3] * (rot1**2 + rot2**2),
                  A[0] * rot2**2 + A[1] * trans**2])
    e = rng.standard_normal((len(x), 3)) * sd
    head = x[:, 2] + rot1 - e[:, 0]
    return np.column_stack([x[:, 0] + (trans - e[:, 1]) * np.cos(head),
                            x[:, 1] + (trans - e[:, 1]) * np.sin(head),
                            np.angle(np.exp(1j * (head + rot2 - e[:, 2])))])


def log_weights(x, z):
    """Likelihood field; x and the map in the map's frame."""
    z, a = z[z < Z_MAX], angles[z < Z_MAX]
    h = x[:, 2:3] + a
    j = np.floor((x[:, 0:1] + z * np.cos(h)) / RES).astype(int)
    i = np.floor((x[:, 1:2] + z * np.sin(h)) / RES).astype(int)
    inside = (i >= 0) & (i < shape[0]) & (j >= 0) & (j < shape[1])
    d = np.where(inside, dist[i * inside, j * inside], np.inf)
    g = np.exp(-0.5 * (d / SIGMA) ** 2) / (np.sqrt(2 * np.pi) * SIGMA)
    return np.log(Z_HIT * g + Z_RAND / Z_MAX).sum(axis=1)


def resample(W, rng):
    c = np.cumsum(W)
    points = (np.arange(len(W)) + rng.random()) / len(W)  # systematic
    return np.searchsorted(c / c[-1], points)


def mcl(scans, odometry, start, n, rng):
    x = start + rng.standard_normal((n, 3)) * [0.2, 0.2, 0.05]
    out = []
    for k, z in enumerate(scans):
        if k > 0:
            x = sample_motion(x, odometry[k], rng)
        lw = log_weights(x, z)
        W = np.exp(lw - logsumexp(lw))
        head = np.angle(W @ np.exp(1j * x[:, 2]))
        out.append([W @ x[:, 0], W @ x[:, 1], head])
        x = x[resample(W, rng)]
    return np.array(out)


HELD = slice(0, 455)  # the first half is localized
truth = log.poses[HELD] - [*origin, 0.0]  # corrected poses, map frame
odo = u[HELD].copy()
odo[0] = 0.0
est = mcl(log.ranges[HELD, ::4], odo, truth[0], 1000, np.random.default_rng(1))
err = np.hypot(*(est[:, :2] - truth[:, :2]).T)
print(f"median error {np.median(err):.3f} m, largest {err.max():.2f} m")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
model = MapRobotModel(split.grid, split.field(), split.odometry, motion=OdometryModel(tuple(A)),
                      start=split.poses[0], start_std=(0.2, 0.2, 0.05))
engine = ParticleFilter(model, 1000, threshold=1.0, resampler=resample).run(
    split.ranges[:, ::intel.BEAM_STEP], rng=np.random.default_rng(1))
TOL = 1e-9
gap = max(np.abs(est[:, :2] - engine.mean[:, :2]).max(), heading_error(engine.mean, est).max())
print(f"largest difference from the engine's estimates (m or rad) below {TOL:.0e}: {gap < TOL}")
assert np.allclose(truth, split.poses, atol=1e-9) and gap < TOL
head_err = np.degrees(heading_error(truth, est))
map_part = slice(intel.MAP_PART.start, None)
rms_map = np.sqrt(np.mean(turn_error[intel.MAP_PART.start:] ** 2))
sd_model = OdometryModel(tuple(A)).std(np.median(np.abs(u[map_part]), axis=0))
glue_values("intel_", tracking_median_error_m=np.median(err), tracking_p90_error_m=np.quantile(err, 0.9),
            tracking_max_error_m=err.max(), tracking_median_heading_deg=np.median(head_err),
            turn_rms_map_deg=np.degrees(rms_map),
            model_turn_sd_deg=np.degrees(np.hypot(sd_model[0], sd_model[2])),
            engine_tolerance=TOL)
# the same filter over seeds 1-30, on this map and on a map of the whole run (stored study)
track = STUDIES["intel/tracking"].load()
half, whole = track[track["map"] == "second half"], track[track["map"] == "whole run"]
assert np.isclose(half.loc[half["seed"] == 1, "median_position_error"].item(), np.median(err), rtol=0, atol=1e-12)
lost = half[half["lost_scan"] >= 0]
kept = half[half["tracking_at_end"]]
track_rate = evidence.rate(half["tracking_at_end"].to_numpy())
WINDOW = slice(289, 307)  # the scans where the tracking runs part
glue_values("intel_track_", n_seeds=len(half), share=track_rate.estimate, share_low=track_rate.low,
            share_high=track_rate.high, n_lost=len(lost), lost_first=int(lost["lost_scan"].min()),
            lost_last=int(lost["lost_scan"].max()), lost_final_min_m=lost["final_position_error"].min(),
            lost_final_max_m=lost["final_position_error"].max(),
            final_median_m=half["final_position_error"].median(),
            kept_median_m=kept["median_position_error"].median(), kept_p90_m=kept["p90_position_error"].median(),
            whole_share=whole["tracking_at_end"].mean(), whole_median_m=whole["median_position_error"].median(),
            whole_p90_m=whole["p90_position_error"].median(),
            seed1_window_heading_deg=head_err[WINDOW].max(),
            window_drift_deg=np.degrees(turn_error[WINDOW.start:WINDOW.stop - 1].sum()),
            window_path_min_m=held_to_map[WINDOW].min(), window_path_max_m=held_to_map[WINDOW].max())
EvidenceBlock(
    "tracking on the held-out half",
    notes=[f"One run, N = 1000, from the corrected start pose with standard deviations 0.2 m, 0.2 m, 0.05 rad; "
           f"{len(err)} scans of the first half on the map of the second half; every fourth beam.",
           "The NumPy loop and pfcourse's ParticleFilter (the same resampler, the same random stream) give "
           f"the same estimates to {TOL:.0e}.",
           f"Position error (m): median {np.median(err):.3f}, 90th percentile {np.quantile(err, 0.9):.3f}, "
           f"largest {err.max():.2f}; heading error (degrees): median {np.median(head_err):.2f}, "
           f"largest {head_err.max():.1f}.",
           f"Dead reckoning over the same scans ends {dr_error[-1]:.1f} m off (largest {dr_error.max():.1f} m).",
           "The reference is the corrected trajectory, itself an estimate: errors of a few centimetres "
           "are within its own uncertainty.",
           f"Stored study intel/tracking (book/data/intel/tracking.csv): the same filter, seeds 1-{half['seed'].max()}. "
           f"Second-half map: within 1 m and the heading tolerance at the last scan in {track_rate}; "
           f"{len(lost)} runs lose the robot for good at scans {lost['lost_scan'].min()}-{lost['lost_scan'].max()}, "
           f"final errors {lost['final_position_error'].min():.1f}-{lost['final_position_error'].max():.1f} m; "
           f"median over seeds of the final error {half['final_position_error'].median():.2f} m. "
           f"Whole-run map: {whole['tracking_at_end'].sum()} of {len(whole)} track; median error "
           f"{whole['median_position_error'].median():.3f} m (90th percentile {whole['p90_position_error'].median():.3f} m), "
           f"medians over seeds."],
)

# %% [markdown]
# The NumPy loop and the package's engine give the same estimates to
# {glue:text}`intel_engine_tolerance:.0e`. The odometry noise comes from the map half only: there
# the encoders' heading error per step has an RMS of {glue:text}`intel_turn_rms_map_deg:.1f`
# degrees against the corrected poses, and the model's $a_j$ give a heading spread of
# {glue:text}`intel_model_turn_sd_deg:.1f` degrees at a median step, a little wider, as a filter's
# noise should be.
#
# From the known start, with $N = 1000$ particles and the seed above, the filter tracks the whole
# first half: its median position error is {glue:text}`intel_tracking_median_error_m:.3f` m. But one
# run is one draw. Over the seeds $1$ to $30$, the same filter is still on the robot at the last scan
# in only {glue:text}`intel_track_share:.0%` of the runs
# ({glue:text}`intel_track_share_low:.0%`-{glue:text}`intel_track_share_high:.0%`).
#
# The other {glue:text}`intel_track_n_lost:d` runs lose the robot for good between scans
# {glue:text}`intel_track_lost_first:d` and {glue:text}`intel_track_lost_last:d`.
#
# Final error against
# final error: the median over the seeds is {glue:text}`intel_track_final_median_m:.2f` m, the
# odometry alone ends {glue:text}`intel_dead_reckoning_final_error_m:.1f` m off, and a lost run
# ends up to {glue:text}`intel_track_lost_final_max_m:.1f` m off, further than the odometry.
#
# **The failure has a place.** Over scans $289$-$306$ the odometry's heading drifts by
# {glue:text}`intel_track_window_drift_deg:.0f` degrees, while the path runs
# {glue:text}`intel_track_window_path_min_m:.1f` to {glue:text}`intel_track_window_path_max_m:.1f` m
# from any pose of the map half: the map there holds walls seen from elsewhere, or none. Even the
# run shown, which survives, is off by up to {glue:text}`intel_track_seed1_window_heading_deg:.0f`
# degrees of heading in that stretch.
#
# **What the reference is.** The "truth" here is a SLAM estimate, not a surveyed trajectory, and the
# same SLAM run placed the scans that built the map: the second half's poses were matched against a
# map that held the first half's scans, and its loop closures tie the two halves together. The
# reference and the map are registered to the same geometry, so the error measures how well two
# registrations agree, not how close the filter was to where the robot was. On a map built from the
# whole run, the scans it localizes included, every seed tracks, with a median error of
# {glue:text}`intel_track_whole_median_m:.3f` m (90th percentile {glue:text}`intel_track_whole_p90_m:.2f`
# m); on the second-half map the runs that track have {glue:text}`intel_track_kept_median_m:.3f` m. The large errors mean more: a filter or
# dead reckoning many metres off is off, whatever the reference's centimetres.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
t_min = (log.times[HELD] - log.times[0]) / 60
fig, ax = plt.subplots(figsize=(7.5, 3.4))
ax.semilogy(t_min, np.maximum(err, 1e-3), color=COLORS["estimate"], label="MCL, N = 1000")
ax.semilogy(t_min, np.maximum(dr_error, 1e-3), color=COLORS["kalman"], label="odometry alone")
ax.set_xlabel("time (min)")
ax.set_ylabel("position error (m)")
ax.set_title("Error against the corrected path, first half")
ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=2)
plt.show()

# %% [markdown]
# ## Global localization
#
# Now the filter starts with no idea where the robot is. **When is it locked on?** Within $1$ m,
# and within a heading tolerance that the robot's own noise sets: between two scans the odometry's
# heading drifts by its per-step error (RMS {glue:text}`intel_turn_rms_deg:.1f` degrees over the
# run), which a locked-on filter may carry until the next scan corrects it. Three times that,
# {glue:text}`intel_heading_tolerance_deg:.1f` degrees, is the tolerance: a convention, not derived
# from the filter's own heading spread while tracking, which would be the better rule. And the rule asks for
# {glue:text}`intel_lock_share:.0%` of the last $15$ scans, not all of them, so that one bad scan
# does not count as a lost robot.
#
# **The filter.** It follows the cure of {doc}`global_localization` and {doc}`map_robot`:
# $22000$ particles at the start, $2000$ of them drawn where the first scan fits; KLD-sampling
# {cite:p}`fox2003` then shrinks the cloud to a few hundred once it has gathered (its bound holds
# with probability $1 - \delta = 0.99$; ROS `amcl`'s `kld_z = 0.99` is not that: it is used as the
# normal quantile itself). At every second scan a fixed tenth of the cloud is drawn from the scan,
# Mixture-MCL's dual sampling {cite:p}`thrun2001` in the spirit of sensor resetting
# {cite:p}`lenser2000`. Each run covers $40$ scans of the held-out half, from a seeded start;
# {glue:text}`intel_n_global:d` seeded runs per filter are stored (the heavy part, about
# {glue:text}`intel_global_minutes:.0f` minutes of computing).
#
# :::{admonition} How the reset poses are weighed
# :class: dropdown
# Candidate poses on the
# known free space are scored by the likelihood field, new poses are drawn around the best, carried
# forward by the odometry through five scans and weighted as a kidnapping that happened then, against
# the cloud's own record of those scans: with $\varepsilon$ the kidnap model's probability, $u$ the
# uniform density on free space, $q$ the density the reset poses are drawn from and $Z_j$ the cloud's
# mean likelihood of scan $j$, each of the $R$ reset poses weighs
# $\frac{\varepsilon}{R} \frac{u(x)}{q(x)} \prod_{j=k-5}^{k} p(z_j \mid x_j) / \prod_{j=k-5}^{k-1} Z_j$
# against $\frac{1 - \varepsilon}{M}\, p(z_k \mid x_k)$ for each of the $M$ moved particles
# (the module `pfcourse.studies.intel` writes it out).
# :::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
study = STUDIES["intel/global"].load()
scan = study[study["method"] == "scan"].sort_values("seed")
unif = study[study["method"] == "uniform"].sort_values("seed")
temp = study[study["method"] == "tempered"].sort_values("seed")
assert (scan["seed"].to_numpy() == unif["seed"].to_numpy()).all()
assert (temp["seed"].to_numpy() == unif["seed"].to_numpy()).all()
pair = evidence.paired_rates(scan["locked_on"].to_numpy(), unif["locked_on"].to_numpy())
pair_t = evidence.paired_rates(temp["locked_on"].to_numpy(), unif["locked_on"].to_numpy())
wall = study.attrs["provenance"]["wall_seconds"]
turn_rms_all = intel.odometry_heading_rms(log)
tol = intel.heading_tolerance(log)


def at_end(g):
    return ((g["final_position_error"] < 1) & (g["final_heading_error"] < tol)).to_numpy()


pair_end = evidence.paired_rates(at_end(scan), at_end(unif))
late = int((at_end(scan) & ~scan["locked_on"].to_numpy()).sum())
BINS = (0, 100, 200, 300, 455)
near = map_tree.query(log.poses[intel.HELD_OUT, :2])[0]
by_start = []
for lo, hi in zip(BINS[:-1], BINS[1:]):
    inside = (scan["start_scan"] >= lo) & (scan["start_scan"] < hi)
    by_start.append({"start scans": f"{lo}-{hi - 1}", "runs": int(inside.sum()),
                     "locked on (resetting)": scan.loc[inside, "locked_on"].mean(),
                     "locked on (uniform)": unif.loc[inside.to_numpy(), "locked_on"].mean(),
                     "path to map half's path (m, median)": np.median(near[lo:hi])})
by_start = pd.DataFrame(by_start)
for i, r in by_start.iterrows():
    glue_values(f"intel_lock_bin{i}_", rate=r["locked on (resetting)"])
glue_values("intel_", lock_early_path_m=np.median(near[:200]), lock_late_path_m=np.median(near[200:]))
glue_values("intel_", global_end_rate=pair_end.a.estimate, global_uniform_end_rate=pair_end.b.estimate,
            global_end_gain_points=100 * pair_end.difference, global_end_gain_low_points=100 * pair_end.difference_low,
            global_end_gain_high_points=100 * pair_end.difference_high, global_late_lock=late)
glue_values("intel_", n_global=len(scan), global_minutes=wall / 60, turn_rms_deg=np.degrees(turn_rms_all),
            heading_tolerance_deg=np.degrees(intel.heading_tolerance(log)), lock_share=intel.LOCK_SHARE,
            global_lock_on_rate=pair.a.estimate, global_lock_on_rate_low=pair.a.low,
            global_lock_on_rate_high=pair.a.high, global_uniform_lock_on_rate=pair.b.estimate,
            global_tempered_lock_on_rate=pair_t.a.estimate, global_tempered_gain_points=100 * pair_t.difference,
            global_tempered_gain_low_points=100 * pair_t.difference_low,
            global_tempered_gain_high_points=100 * pair_t.difference_high)
summary = pd.DataFrame([{"filter": intel.METHODS[m], "locked on": str(evidence.rate(g["locked_on"].to_numpy())),
                         "median final error (m)": g["final_position_error"].median(),
                         "mean particles": g["mean_particles"].mean()}
                        for m, g in [("scan", scan), ("uniform", unif), ("tempered", temp)]])
EvidenceBlock(
    "global localization on the held-out half",
    notes=[f"{len(scan)} runs (seeds 0-{len(scan) - 1}); run s starts at a held-out scan drawn by "
           f"numpy.random.default_rng([41, s]) and lasts {intel.GLOBAL_STEPS} scans; both filters on the same "
           "runs with the same filter seed.",
           f"Locked on: within 1 m and {np.degrees(intel.heading_tolerance(log)):.1f} degrees at "
           f"{intel.LOCK_SHARE:.0%} or more of the last {intel.LOCK_WINDOW} scans.",
           f"Paired comparison (sensor resetting A, uniform start only B): {pair} (see Reading the evidence).",
           f"Judged at the final scan alone (within 1 m and the heading tolerance), resetting A, uniform B: "
           f"{pair_end}; {late} resetting runs end locked on but fail the window rule.",
           f"Paired comparison (tempered field A, uniform start only B): {pair_t}. The tempered filter multiplies "
           f"the field's log-likelihood by {intel.TEMPER_BETA} and keeps at least {intel.TEMPER_N_MIN} particles.",
           f"From the second scan on, KLD-sampling keeps a mean of {pd.concat([scan, unif])['mean_particles'].mean():.0f} "
           "particles (floor 500).",
           f"Stored study intel/global (book/data/intel/global.csv, provenance in global.json): {wall:.0f} s of "
           "computing on a shared 2-core machine."],
    tables=[("Lock-on by filter (Wilson intervals)", summary,
             {"median final error (m)": ".2f", "mean particles": ".0f"}),
            ("Lock-on (window rule) by start scan, and how far the runs' path lies from the map half's path",
             by_start, {"locked on (resetting)": ".0%", "locked on (uniform)": ".0%",
                        "path to map half's path (m, median)": ".2f"})],
)

# %% [markdown]
# With sensor resetting the filter locks on in {glue:text}`intel_global_lock_on_rate:.0%` of the runs
# ({glue:text}`intel_global_lock_on_rate_low:.0%`-{glue:text}`intel_global_lock_on_rate_high:.0%`);
# the same filter with uniform particles only, in {glue:text}`intel_global_uniform_lock_on_rate:.0%`.
#
# Resetting draws its poses from scan $6$ on (it needs five scans of history), so it locks on late,
# and the rule above looks only at the last $15$ scans: {glue:text}`intel_global_late_lock:d` of its
# runs end within $1$ m and the heading tolerance yet count as failures.
#
# Judged at the final scan, resetting ends on the robot in {glue:text}`intel_global_end_rate:.0%` of
# the runs, {glue:text}`intel_global_end_gain_points:.0f` points more than the uniform start on the
# same runs ({glue:text}`intel_global_end_gain_low_points:.0f` to
# {glue:text}`intel_global_end_gain_high_points:.0f`). It helps a little, late; it is far from a cure.
#
# **Where it fails.** The stored runs show it by where they start. Runs that start in the first $200$
# scans, where the path runs a median {glue:text}`intel_lock_early_path_m:.1f` m from the map half's
# path, lock on in {glue:text}`intel_lock_bin0_rate:.0%` (scans $0$-$99$) and
# {glue:text}`intel_lock_bin1_rate:.0%` ($100$-$199$) of the runs with resetting.
#
# Runs that start later, where the path runs a median {glue:text}`intel_lock_late_path_m:.1f` m from
# it, lock on in {glue:text}`intel_lock_bin2_rate:.0%` ($200$-$299$) and
# {glue:text}`intel_lock_bin3_rate:.0%` ($300$-$454$). Lock-on follows how close the start lies to
# where the map half went (the uniform start shows the same pattern, in the evidence block).
#
# :::{admonition} Going further: tempering the field, and what AMCL does
# :class: dropdown
# **Tempering the field.** The uniform filter with the field's log-likelihood multiplied by
# $\beta = 0.3$ (each scan counted as about a third of its beams' evidence) and at least $2000$
# particles locks on in {glue:text}`intel_global_tempered_lock_on_rate:.0%` of the same runs,
# {glue:text}`intel_global_tempered_gain_points:.0f` points more than without
# ({glue:text}`intel_global_tempered_gain_low_points:.0f` to
# {glue:text}`intel_global_tempered_gain_high_points:.0f`). That run changes two things at once, the
# tempering and a floor of $2000$ particles instead of $500$, so it does not say which of them helps,
# nor how far from the best achievable rate any of these filters is.
#
# **Next steps, not measured here.** ROS's `amcl` and nav2 meet the same overconfidence in other ways:
# an unnormalised hit term $z_{\mathrm{hit}} e^{-d^2 / 2\sigma^2} + z_{\mathrm{rand}} / z_{\max}$
# with distances capped at `laser_likelihood_max_dist` $= 2$ m; a scan weight of
# $1 + \sum_b p_b^3$ instead of the product over beams, which caps the ratio of two particles' weights
# at about $1 + B$ for $B$ beams; and `amcl`'s beam skipping, which drops the beams that most
# particles fail to explain.
# :::
#
# ## Try it: the map
#
# The panel rebuilds the map from a part of the run, at a cell size, from every scan or fewer. A
# coarser cell blurs the walls; fewer scans leave gaps; the first half maps rooms the second half
# passes by.

# %% tags=["hide-input", "nbval-ignore-output"] jupyter={"source_hidden": true}
PARTS = {"second half": slice(455, 910), "first half": slice(0, 455), "whole run": slice(0, 910)}


def draw(part="second half", cell=0.2, every=1):
    rows = np.arange(log.n_scans)[PARTS[part]][::every]
    m = build_map(log.poses[rows], log.ranges[rows], log.angles, max_range=Z_MAX, resolution=cell)
    shown = np.where(m.log_odds > 0, 1.0, np.where(m.log_odds < 0, 0.0, 0.25))
    fig, ax = plt.subplots(figsize=(6, 5.5))
    extent = (m.origin[0], m.origin[0] + shown.shape[1] * cell, m.origin[1], m.origin[1] + shown.shape[0] * cell)
    ax.imshow(shown, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1, interpolation="nearest")
    ax.plot(*log.poses[rows, :2].T, color=COLORS["truth"], lw=0.8)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.grid(False)
    ax.set_title(f"{part}, {cell} m cells, every {every} scan(s): {(m.log_odds > 0).sum()} occupied")


panel = control_panel(
    draw,
    grid={"part": tuple(PARTS)},
    side={"cell": (0.1, 0.2, 0.4), "every": (1, 4)},
    part=Dropdown(options=list(PARTS), value="second half", description="part of the run"),
    cell=SelectionSlider(options=[0.1, 0.2, 0.4], value=0.2, description="cell size (m)"),
    every=SelectionSlider(options=[1, 2, 4, 8], value=1, description="use every n-th scan"),
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 16.1 The beam model instead of the likelihood field
# :label: ex-intel-beam
# :nonumber:
# (Coding.) The likelihood field scores where a beam *ends*. The beam model {cite:p}`thrun2005`
# scores the range itself against the range $z^\ast_b$ the map predicts along the beam (ray-cast).
# Write `my_beam(z, z_star, beam)`: the log-likelihood of a scan `z` (shape `(B,)`) for each of `N`
# poses whose predicted ranges are the rows of `z_star` (shape `(N, B)`), with
# $p(z_b) = z_{\mathrm{hit}}\, \mathcal N(z_b; z^\ast_b, \sigma^2) + z_{\mathrm{rand}} / z_{\max}$
# for a beam with an echo ($z_b < z_{\max}$) and $p(z_b) = z_{\mathrm{none}}$ for one without.
# `beam` has the attributes `z_hit`, `z_rand`, `z_none`, `sigma` and `z_max`. Include the no-echo
# term, then explain why it changes no normalised weight (here $z_{\mathrm{none}}$ ignores $z^\ast_b$;
# in the full model of {cite:t}`thrun2005` it does not). The checker names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises.real_robot import check_beam_model


def my_beam(z, z_star, beam):
    """Return log p(z | x^i) for each row of z_star, shape (N,)."""
    ...  # replace with your code


print(check_beam_model(my_beam))

# %% [markdown]
# ```{solution} ex-intel-beam
# :class: dropdown
# One density per beam, its log summed over the beams; the code is in the folded cell below (in
# JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_beam(z, z_star, beam):
    echo = z < beam.z_max
    gauss = np.exp(-0.5 * ((z - z_star) / beam.sigma) ** 2) / (np.sqrt(2 * np.pi) * beam.sigma)
    dens = np.where(echo, beam.z_hit * gauss + beam.z_rand / beam.z_max, beam.z_none)
    return np.log(dens).sum(axis=1)


print(check_beam_model(my_beam))

# %% [markdown]
# ```{exercise} 16.2 A map from the other half
# :label: ex-intel-other
# :nonumber:
# Build the map from the first half (`MAP = slice(0, 455)`) and track the second half from its
# corrected start. Which half's scans see walls the other half's map lacks? Use the panel to find them.
# ```
#
# ## Takeaways
#
# - A real log needs its format read with care: here the odometry between scans is the last odometry
#   pose seen from the corrected pose, and its heading error is a drift per metre, not zero-mean noise.
# - With known poses, mapping is a sum of log-odds per cell: an inverse sensor model adds evidence for
#   the cell a beam ends in and against the cells it crosses.
# - One run is one draw: the run that tracked to centimetres is one of the seeds that survive; about a
#   third lose the robot where the odometry drifts and the map half never went. Report many seeds.
# - Against a SLAM reference that also registered the map, centimetre errors measure agreement
#   between two registrations, not accuracy; metres of error (dead reckoning, a lost filter) are real.
# - Finding the robot from nowhere works where the map covers the start, and rarely elsewhere;
#   resetting from the scan helps a little and late, tempering with more particles helps a little too.
#
# :::{admonition} From the labs
# :class: dropdown
# The robot lab (Lab C of {doc}`../labs`) asks how a filter started with a cloud over the whole map
# fares, and what the filter's assumed noise changes. Its robot was simulated; this chapter asks the
# same of a real one, in "Tracking on the held-out half" (the noise set from the odometry's own
# errors) and "Global localization".
# :::
