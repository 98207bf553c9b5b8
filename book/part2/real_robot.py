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
# robot on a map that was not built from the scans it localizes.
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
# Seattle, recorded by Dirk Hähnel and shared through Radish, the Robotics Data Set Repository
# {cite:p}`howard2003radish`, and asks the questions of {doc}`map_robot` of it.

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
from pfcourse.experiments import intel
from pfcourse.experiments.registry import STUDIES
from pfcourse.figures.report import EvidenceBlock, glue_values
from pfcourse.figures.widgets import control_panel
from pfcourse.filter import ParticleFilter
from pfcourse.maprobot import LikelihoodField, MapRobotModel, OdometryModel
from pfcourse.maprobot.carmen import relative_pose
from pfcourse.maprobot.figures import draw_map
from pfcourse.maprobot.mapping import build_map
from pfcourse.metrics import heading_error, position_error
from pfcourse.style import COLORS, use_style

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
# This copy is *corrected*: the pose on each `FLASER` line is not the odometry but the estimate of
# GMapping {cite:p}`grisetti2007`, a particle-filter SLAM method run over the whole log. After each scan
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
from pfcourse.maprobot.carmen import read_carmen

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
turn_error = np.angle(np.exp(1j * (log.relative_motion()[1:, 2] - true_turn)))
glue_values("intel_", n_scans=log.n_scans, n_odometry=log.n_odometry, minutes=minutes, path_m=path_m,
            no_echo_share=1 - log.returned.mean(), step_m=np.median(u[1:, 1]),
            full_dead_reckoning_m=position_error(log.poses[-1], dr_full[-1]),
            full_dead_reckoning_deg=np.degrees(heading_error(log.poses[-1], dr_full[-1])),
            under_rotation_deg=np.degrees(-turn_error.mean()))

# %% [markdown]
# The robot drove {glue:text}`intel_path_m:.0f` m in {glue:text}`intel_minutes:.0f` minutes, scanning
# every {glue:text}`intel_step_m:.2f` m or so (the median step).
#
# Chained from the first pose, the odometry alone ends {glue:text}`intel_full_dead_reckoning_m:.0f` m and
# {glue:text}`intel_full_dead_reckoning_deg:.0f` degrees away from the corrected pose: the heading
# change the encoders report falls short of the corrected one by about
# {glue:text}`intel_under_rotation_deg:.1f` degrees a step on average, and those small errors compound.
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
# per scan. A beam with no echo is left out. A cell ends up occupied where $l > 0$, free where $l < 0$,
# unknown where no beam came.
#
# :::{admonition} Algorithm 14.1: occupancy grid mapping with known poses
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
print(f"the same log-odds as pfcourse.maprobot.mapping.build_map, cell for cell: {same_map}")
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
           "The reference is GMapping's corrected trajectory, itself an estimate: errors of a few centimetres "
           "are within its own uncertainty."],
)

# %% [markdown]
# The NumPy loop and the package's engine give the same estimates to
# {glue:text}`intel_engine_tolerance:.0e`. The odometry noise comes from the map half only: there
# the encoders' heading error per step has an RMS of {glue:text}`intel_turn_rms_map_deg:.1f`
# degrees against the corrected poses, and the model's $a_j$ give a heading spread of
# {glue:text}`intel_model_turn_sd_deg:.1f` degrees at a median step, a little wider, as a filter's
# noise should be.
#
# From the known start, with $N = 1000$ particles, the filter tracks the whole first half: its median
# position error is {glue:text}`intel_tracking_median_error_m:.3f` m, against
# {glue:text}`intel_dead_reckoning_final_error_m:.1f` m for the odometry alone at the end.
#
# **What the reference is.** The "truth" here is GMapping's estimate, not a surveyed trajectory. An
# error of a few centimetres against it is below what the reference itself can promise: the number
# says that MCL agrees with a good SLAM solution, not that the robot was within that distance of
# where the filter put it. The large errors mean more: dead reckoning many metres off is off, whatever
# the reference's centimetres.

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
# {glue:text}`intel_heading_tolerance_deg:.1f` degrees, is the tolerance. And the rule asks for
# {glue:text}`intel_lock_share:.0%` of the last $15$ scans, not all of them, so that one bad scan
# does not count as a lost robot.
#
# **The filter.** It follows the cure of {doc}`global_localization` and {doc}`map_robot`:
# $22000$ particles at the start, $2000$ of them drawn where the first scan fits; KLD-sampling
# {cite:p}`fox2003` then shrinks the cloud to a few hundred once it has gathered. At every second
# scan a tenth of the cloud is reset from the scan {cite:p}`lenser2000`: candidate poses on the
# known free space are scored by the likelihood field, new poses are drawn around the best, carried
# forward by the odometry through five scans and weighted as a kidnapping that happened then, against
# the cloud's own record of those scans: with $\varepsilon$ the kidnap model's probability, $u$ the
# uniform density on free space, $q$ the density the reset poses are drawn from and $Z_j$ the cloud's
# mean likelihood of scan $j$, each of the $R$ reset poses weighs
# $\frac{\varepsilon}{R} \frac{u(x)}{q(x)} \prod_{j=k-5}^{k} p(z_j \mid x_j) / \prod_{j=k-5}^{k-1} Z_j$
# against $\frac{1 - \varepsilon}{M}\, p(z_k \mid x_k)$ for each of the $M$ moved particles
# (the module `pfcourse.experiments.intel` writes it out). Each run covers $40$ scans of the held-out half, from a
# seeded start; {glue:text}`intel_n_global:d` seeded runs per filter are stored (the heavy part, about
# {glue:text}`intel_global_minutes:.0f` minutes of computing).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
study = STUDIES["intel/global"].load()
scan = study[study["method"] == "scan"].sort_values("seed")
unif = study[study["method"] == "uniform"].sort_values("seed")
temp = study[study["method"] == "tempered"].sort_values("seed")
assert (scan["seed"].to_numpy() == unif["seed"].to_numpy()).all()
assert (temp["seed"].to_numpy() == unif["seed"].to_numpy()).all()
pair = evidence.paired_rates(scan["locked_on"].to_numpy(), unif["locked_on"].to_numpy())
pair_t = evidence.paired_rates(temp["locked_on"].to_numpy(), unif["locked_on"].to_numpy())
wall = json.loads(STUDIES["intel/global"].path.with_suffix(".json").read_text())["wall_seconds"]
turn_rms_all = intel.odometry_heading_rms(log)
glue_values("intel_", n_global=len(scan), global_minutes=wall / 60, turn_rms_deg=np.degrees(turn_rms_all),
            heading_tolerance_deg=np.degrees(intel.heading_tolerance(log)), lock_share=intel.LOCK_SHARE,
            global_lock_on_rate=pair.a.estimate, global_lock_on_rate_low=pair.a.low,
            global_lock_on_rate_high=pair.a.high, global_uniform_lock_on_rate=pair.b.estimate,
            global_gain_high_points=100 * pair.difference_high,
            global_mean_particles=pd.concat([scan, unif])["mean_particles"].mean(),
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
           f"Paired comparison (tempered field A, uniform start only B): {pair_t}. The tempered filter multiplies "
           f"the field's log-likelihood by {intel.TEMPER_BETA} and keeps at least {intel.TEMPER_N_MIN} particles.",
           f"Stored study intel/global (book/data/intel/global.csv, provenance in global.json): {wall:.0f} s of "
           "computing on a shared 2-core machine."],
    tables=[("Lock-on by filter (Wilson intervals)", summary,
             {"median final error (m)": ".2f", "mean particles": ".0f"})],
)

# %% [markdown]
# With sensor resetting the filter locks on in {glue:text}`intel_global_lock_on_rate:.0%` of the runs
# ({glue:text}`intel_global_lock_on_rate_low:.0%`-{glue:text}`intel_global_lock_on_rate_high:.0%`);
# the same filter with uniform particles only, in {glue:text}`intel_global_uniform_lock_on_rate:.0%`.
#
# The resetting does not pay on this log: on the same runs, a gain of more than
# {glue:text}`intel_global_gain_high_points:.0f` points is excluded by the data. Here the cure, as
# built, does not work.
#
# What goes wrong is visible in the particle counts. From the second scan on, KLD-sampling keeps about
# {glue:text}`intel_global_mean_particles:.0f` particles, near its floor of $500$: after one or two scans the whole
# weight sits on one place. The likelihood field, with its beams counted as independent evidence, is
# far more confident than a map built from other scans supports, so the first place that fits a scan
# well wins, right or wrong, and a pose reset from a later scan can look right at a wrong place for a
# few scans too.
#
# **A test of that diagnosis.** The uniform filter with the field's log-likelihood multiplied by
# $\beta = 0.3$ (each scan counted as about a third of its beams' evidence) and at least $2000$
# particles locks on in {glue:text}`intel_global_tempered_lock_on_rate:.0%` of the same runs,
# {glue:text}`intel_global_tempered_gain_points:.0f` points more than without
# ({glue:text}`intel_global_tempered_gain_low_points:.0f` to
# {glue:text}`intel_global_tempered_gain_high_points:.0f`). The diagnosis holds, and the cure is far
# from complete: a real robot found from nowhere needs a sensor model that knows the map is imperfect,
# and evidence gathered over a longer drive than the $40$ scans used here.
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
# ```{exercise} 14.1 The beam model instead of the likelihood field
# :label: ex-intel-beam
# :nonumber:
# (Coding.) The likelihood field scores where a beam *ends*. The beam model {cite:p}`thrun2005`
# scores the range itself against the range $z^\ast_b$ the map predicts along the beam (ray-cast).
# Write `my_beam(z, z_star, beam)`: the log-likelihood of a scan `z` (shape `(B,)`) for each of `N`
# poses whose predicted ranges are the rows of `z_star` (shape `(N, B)`), with
# $p(z_b) = z_{\mathrm{hit}}\, \mathcal N(z_b; z^\ast_b, \sigma^2) + z_{\mathrm{rand}} / z_{\max}$
# for a beam with an echo ($z_b < z_{\max}$) and $p(z_b) = z_{\mathrm{none}}$ for one without.
# `beam` has the attributes `z_hit`, `z_rand`, `z_none`, `sigma` and `z_max`. Unlike the field,
# a beam with no echo counts. The checker names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.exercises.real_robot import check_beam_model


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
# ```{exercise} 14.2 A map from the other half
# :label: ex-intel-other
# :nonumber:
# Build the map from the first half (`MAP = slice(0, 455)`) and track the second half from its
# corrected start. Which half's scans see walls the other half's map lacks? Use the panel to find them.
# ```
#
# ## Takeaways
#
# - A real log needs its format read with care: here the odometry between scans is the last odometry
#   pose seen from the corrected pose, and a robot backing up is a negative translation.
# - With known poses, mapping is a sum of log-odds per cell: an inverse sensor model adds evidence for
#   the cell a beam ends in and against the cells it crosses.
# - Measured on scans the map was not built from, MCL tracks a real robot to centimetres of a SLAM
#   reference, where the odometry alone drifts metres away; the reference is itself an estimate.
# - Finding the robot from nowhere is harder on a real map than on a simulated one: a likelihood field
#   more confident than the map collapses the cloud on the first place that fits; resetting poses from
#   the scan did not cure it on this log, tempering the field helped a little.
#
# :::{admonition} From the labs
# :class: dropdown
# The robot lab (Lab C of {doc}`../labs`) asks how a filter started with a cloud over the whole map
# fares, and what the filter's assumed noise changes. Its robot was simulated; this chapter asks the
# same of a real one, in "Tracking on the held-out half" (the noise set from the odometry's own
# errors) and "Global localization".
# :::
