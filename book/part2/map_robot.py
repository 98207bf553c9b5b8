# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A robot on a map: likelihood-field Monte Carlo localization
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** Monte Carlo localization as robots run it: the odometry motion model, the
# likelihood field of an occupancy grid, the whole filter in thirty lines of NumPy; when a filter
# counts as locked on; and what AMCL, the localizer of ROS, does differently.
#
# **You need** {doc}`robot` and {doc}`../part1/sir`; Gaussian densities; NumPy arrays.
#
# **Time:** about twenty-four minutes to read, plus about nineteen minutes for the folded blocks; the exercises are extra.
# :::
#
# The robot of {doc}`robot` reads the range and bearing of landmarks it recognises. A robot in a
# building has neither: its wheels count their turns (odometry), a laser scanner measures the
# distance to the nearest wall in many directions, and it carries a map of the walls. This chapter
# tracks such a robot with the models of *Probabilistic Robotics* {cite:p}`thrun2005`.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# Setup: the book's engine, studies, figures and glue helpers (not needed to follow the chapter).
import json
from dataclasses import replace

import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display
from scipy.special import logsumexp

from pfcourse import evidence
from pfcourse.scenarios.maprobot import drive as scenario
from pfcourse.studies import maprobot as study
from pfcourse.studies.registry import STUDIES
from pfcourse.book.report import EvidenceBlock, glue_values, spread_table
from pfcourse.book.panels import control_panel, particle_slider
from pfcourse.filter import ParticleFilter
from pfcourse.scenarios.maprobot import MapRobotModel, OdometryModel
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.scenarios.maprobot.amcl import beam_log_likelihood
from pfcourse.scenarios.maprobot.scanner import cast_rays
from pfcourse.book.figures.maprobot import draw_map, draw_scan
from pfcourse.scenarios.maprobot.grid import ROUTE
from pfcourse.metrics import heading_error, position_error
from pfcourse.book.style import COLORS, use_style

use_style()
grid, scanner, field = scenario.book_map(), scenario.SCANNER, scenario.field()
demo = scenario.simulate(0, study.TRACKING_STEPS)


def stored(name):
    seconds = STUDIES[f"maprobot/{name}"].load().attrs["provenance"]["wall_seconds"]
    return (f"Stored study maprobot/{name} (book/data/maprobot/{name}.csv, provenance in {name}.json): "
            f"{seconds:.0f} s of computing on a shared 2-core machine.")


# %% [markdown]
# ## The picture: a scan laid on the map
#
# The map is an occupancy grid: the floor cut into square cells of $0.1$ m, each free or occupied.
# A corridor runs between two rows of four identical rooms; a single box stands in one room. The
# robot drives a loop through three of the rooms at $0.5$ m/s and scans every $\Delta t = 0.5$ s:
# $24$ beams around it, up to $z_{\max} = 8$ m.
#
# Lay a scan on the map from a guessed pose, and the idea of the whole chapter is in the picture
# below: from the true pose (left), the end of every beam lands on a wall; from a pose $0.5$ m off
# and turned by $0.2$ rad (right), the end points scatter in free space. Scoring a pose is
# measuring how far its end points fall from the walls.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
k_show = 68  # in the box's room
wrong = demo.truth[k_show] + np.array([0.5, 0.0, 0.2])
fig, axes = plt.subplots(1, 2, figsize=(10, 3.4))
for ax, pose, title in [(axes[0], demo.truth[k_show], "from the true pose"),
                        (axes[1], wrong, "from a pose 0.5 m and 0.2 rad off")]:
    draw_map(ax, grid)
    draw_scan(ax, pose, demo.scans[k_show], scanner.angles, scanner.max_range)
    ax.plot(*pose[:2], "o", color=COLORS["truth"], ms=5)
    ax.set_xlim(pose[0] - 6, pose[0] + 6)
    ax.set_ylim(max(pose[1] - 4, 0), pose[1] + 4)
    ax.set_title(f"The scan at t = {k_show * scenario.DT:.0f} s {title}")
plt.show()

# %% [markdown]
# The whole map and a drive are in the first folded cell below; the code loads them as plain arrays
# with one helper: the grid's *distance transform* (for every cell, the distance to the nearest wall,
# computed once by `scipy.ndimage.distance_transform_edt`), the scans, the odometry and the true path.

# %%
from pfcourse.scenarios.maprobot.drive import book_drive

# the map's distance transform (m), one drive of 80 s, its scans and odometry
drive = book_drive(seed=0)
dist, res = drive.distance, drive.resolution
print(f"map {dist.shape[1] * res:.0f} m x {dist.shape[0] * res:.0f} m, "
      f"{len(drive.scans)} scans of {drive.scans.shape[1]} beams")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, ax = plt.subplots(figsize=(9, 4.6))
draw_map(ax, grid)
ax.plot(*np.vstack([ROUTE, ROUTE[:1]]).T, ":", color=COLORS["robot"], label="route (waypoints)")
ax.plot(demo.truth[:, 0], demo.truth[:, 1], color=COLORS["truth"], lw=1, label="the drive (80 s)")
ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax.set_title("The map: four look-alike rooms on each side of a corridor, one box")
plt.show()

# %% [markdown]
# ## The odometry motion model
#
# Between two scans the wheel encoders report the motion as three numbers
# $u_k = (\delta_{\mathrm{rot1}}, \delta_{\mathrm{trans}}, \delta_{\mathrm{rot2}})$: turn by
# $\delta_{\mathrm{rot1}}$ towards the direction of travel, drive $\delta_{\mathrm{trans}}$ straight,
# turn by $\delta_{\mathrm{rot2}}$. Wheels slip, so each true increment differs from the reported
# one by a zero-mean Gaussian error whose variance grows with the motion; four parameters
# $a_1, \dots, a_4$ say how much ({cite:t}`thrun2005`, table $5.6$):
#
# $$
# \begin{aligned}
# \hat\delta_{\mathrm{rot1}} &= \delta_{\mathrm{rot1}} - \eta_1, &
# \eta_1 &\sim \mathcal N(0,\, a_1 \delta_{\mathrm{rot1}}^2 + a_2 \delta_{\mathrm{trans}}^2),\\
# \hat\delta_{\mathrm{trans}} &= \delta_{\mathrm{trans}} - \eta_2, &
# \eta_2 &\sim \mathcal N(0,\, a_3 \delta_{\mathrm{trans}}^2 + a_4 (\delta_{\mathrm{rot1}}^2 + \delta_{\mathrm{rot2}}^2)),\\
# \hat\delta_{\mathrm{rot2}} &= \delta_{\mathrm{rot2}} - \eta_3, &
# \eta_3 &\sim \mathcal N(0,\, a_1 \delta_{\mathrm{rot2}}^2 + a_2 \delta_{\mathrm{trans}}^2),
# \end{aligned}
# $$
#
# and the pose moves by the perturbed increments: $x' = x + \hat\delta_{\mathrm{trans}} \cos(\theta +
# \hat\delta_{\mathrm{rot1}})$, $y' = y + \hat\delta_{\mathrm{trans}} \sin(\theta + \hat\delta_{\mathrm{rot1}})$,
# $\theta' = \theta + \hat\delta_{\mathrm{rot1}} + \hat\delta_{\mathrm{rot2}}$. Drawing the next pose of
# each particle this way *is* sampling the transition $p(x_k \mid x_{k-1}, u_k)$; no density is ever
# evaluated. Here every $a_j = 0.05$, in the simulator and in the filter alike.

# %%
import numpy as np
from scipy.special import logsumexp

A = drive.alphas  # a_1, ..., a_4


def sample_motion(x, u, rng):
    """Table 5.6 for every row of x (N, 3): one standard normal triple each."""
    rot1, trans, rot2 = u
    sd = np.sqrt([A[0] * rot1**2 + A[1] * trans**2,
                  A[2] * trans**2 + A[3] * (rot1**2 + rot2**2),
                  A[0] * rot2**2 + A[1] * trans**2])
    e = rng.standard_normal((len(x), 3)) * sd
    heading = x[:, 2] + rot1 - e[:, 0]
    step = trans - e[:, 1]
    return np.column_stack([x[:, 0] + step * np.cos(heading),
                            x[:, 1] + step * np.sin(heading),
                            np.angle(np.exp(1j * (heading + rot2 - e[:, 2])))])


# %% [markdown]
# ## The likelihood field
#
# The scanner simulated here follows the *beam model* ({cite:t}`thrun2005`, section $6.3$): each beam
# returns the distance to the first wall along it plus Gaussian noise of $5$ cm with probability
# $0.85$, a short reading (something unmapped in the way) with probability $0.05$, no echo
# ($z = z_{\max}$) with probability $0.05$, and a reading uniform on $[0, z_{\max}]$ with
# probability $0.05$. Scoring a particle by the beam model would cast each of its beams through
# the grid. The *likelihood field* ({cite:t}`thrun2005`, table $6.3$) does not: it takes the end
# point $e_b$ of beam $b$, of reading $z_b$ and angle $\phi_b$ on the robot, seen from the pose
# $(x, y, \theta)$, and scores it by its distance $d(e_b)$ to the nearest wall. The beams are
# treated as independent, and a reading at $z_{\max}$ says nothing and is left out:
#
# $$
# \log p(z_k \mid x_k) = \sum_{b:\, z_b < z_{\max}}
#   \log\Big( z_{\mathrm{hit}}\, \mathcal N\big(d(e_b); 0, \sigma^2\big)
#   + \frac{z_{\mathrm{rand}}}{z_{\max}} \Big),
# \qquad e_b = \big(x + z_b \cos(\theta + \phi_b),\; y + z_b \sin(\theta + \phi_b)\big) .
# $$
#
# The uniform term keeps one stray reading from sending a good pose's weight to zero. A particle
# costs one look-up per beam in the distance transform. The filter uses $z_{\mathrm{hit}} = 0.9$,
# $z_{\mathrm{rand}} = 0.1$ and $\sigma = 0.2$ m, broader than the scanner's $5$ cm: the field is an
# approximation and must be forgiving.

# %%
Z_HIT, Z_RAND, SIGMA = 0.9, 0.1, 0.2  # the filter's field (sigma in m)
z_max, angles = drive.max_range, drive.angles


def distance_at(px, py):
    """Distance to the nearest wall at points (m); infinite off the map."""
    i, j = np.floor(py / res).astype(int), np.floor(px / res).astype(int)
    inside = (i >= 0) & (i < dist.shape[0]) & (j >= 0) & (j < dist.shape[1])
    d = dist[np.where(inside, i, 0), np.where(inside, j, 0)]
    return np.where(inside, d, np.inf)


def field_log_weights(x, z):
    """log p(z | x^i) for every particle: table 6.3 in the log domain."""
    echo = z < z_max  # beams without an echo say nothing
    heading = x[:, 2:3] + angles[echo]
    d = distance_at(x[:, 0:1] + z[echo] * np.cos(heading),
                    x[:, 1:2] + z[echo] * np.sin(heading))
    hit = np.exp(-0.5 * (d / SIGMA) ** 2) / (np.sqrt(2 * np.pi) * SIGMA)
    return np.log(Z_HIT * hit + Z_RAND / z_max).sum(axis=1)


# %% [markdown]
# Scored at every position of the map (the heading held at the true one), the scan of the first
# figure fits best at the truth, and nearly as well at a bright spot in each look-alike room: a
# filter that starts lost must tell these twins apart ({doc}`map_global`). A filter that starts
# at the known pose only has to follow the bright spot as the robot drives.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
xs, ys = np.arange(0.25, grid.width, 0.1), np.arange(0.25, grid.height, 0.1)
X, Y = np.meshgrid(xs, ys)
poses = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, demo.truth[k_show, 2])])
score = field.log_likelihood(poses, demo.scans[k_show]).reshape(X.shape)
score[~grid.is_free(poses).reshape(X.shape)] = np.nan
fig, ax = plt.subplots(figsize=(7.2, 4.9))
im = ax.imshow(score - np.nanmax(score), origin="lower", extent=(0.2, xs[-1] + 0.05, 0.2, ys[-1] + 0.05),
               cmap="magma", vmin=-150, vmax=0)
ax.plot(*demo.truth[k_show, :2], "x", color="tab:cyan", ms=10, mew=2)
ax.set_xlabel("x (m)")
ax.set_ylabel("y (m)")
ax.grid(False)
fig.colorbar(im, ax=ax, orientation="horizontal", fraction=0.06, pad=0.2,
             label="log-likelihood minus its maximum")
ax.set_title("The scan scored over the map (cross: truth)")
plt.show()

# %% [markdown]
# (map-mcl)=
# ## Monte Carlo localization with the likelihood field
#
# Monte Carlo localization (MCL) is the bootstrap particle filter ({doc}`../part1/sir`) with these two
# models: move every particle by the odometry, weight it by the scan, resample. Robots resample at
# every scan with the low-variance (systematic) sampler {cite:p}`thrun2005`.
#
# :::{admonition} Algorithm 14.1: Monte Carlo localization with the likelihood field
# :class: algorithm
# 1. **Initialise.** Draw $x_0^i$, $i = 1, \dots, N$, around the known start pose.
# 2. **For** each scan $z_k$, $k = 0, 1, \dots$:
#    1. *move* (for $k > 0$): $x_k^i \sim p(x_k \mid x_{k-1}^i, u_k)$ by the odometry sampler;
#    2. *weight:* $\log \tilde w_k^i = \log p(z_k \mid x_k^i)$ by the likelihood field;
#    3. *normalise:* $W_k^i = \exp\big(\log \tilde w_k^i - \operatorname{logsumexp}_j \log \tilde w_k^j\big)$;
#    4. *estimate:* the weighted mean position, and the heading
#       $\hat\theta_k = \arg \sum_i W_k^i e^{\mathrm i \theta_k^i}$ (angles average on the circle);
#    5. *resample:* $x_k^i \leftarrow x_k^{A_i}$ with systematic ancestors $A_i$.
# :::
#
# The cell below is Algorithm 14.1 in NumPy, run on the drive with $N = 300$ particles.

# %%
def systematic(W, rng):
    """Low-variance resampling: one uniform, N evenly spaced pointers."""
    n = len(W)
    pointers = (np.arange(n) + rng.random()) / n
    ancestors = np.searchsorted(np.cumsum(W), pointers, side="right")
    return np.minimum(ancestors, n - 1)


def mcl(scans, odometry, n, rng, start, start_sd=(0.2, 0.2, 0.05)):
    x = start + rng.standard_normal((n, 3)) * start_sd  # 1. around the start
    means, ess = [], []
    for k, z in enumerate(scans):
        if k > 0:
            x = sample_motion(x, odometry[k], rng)  # 2.1 move
        log_w = field_log_weights(x, z)  # 2.2 weight
        W = np.exp(log_w - logsumexp(log_w))  # 2.3 normalise
        heading = np.angle(W @ np.exp(1j * x[:, 2]))
        means.append([W @ x[:, 0], W @ x[:, 1], heading])  # 2.4 estimate
        ess.append(1 / np.sum(W**2))
        x = x[systematic(W, rng)]  # 2.5 resample
    return np.array(means), np.array(ess)


rng = np.random.default_rng(7)
est, ess = mcl(drive.scans, drive.odometry, 300, rng, drive.truth[0])
err = np.hypot(*(est[:, :2] - drive.truth[:, :2]).T)
rmse = np.sqrt(np.mean(err**2))
print(f"position RMSE {rmse:.3f} m; mean ESS {ess.mean():.0f} of 300")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
model = MapRobotModel(grid, field, demo.drive.odometry, motion=scenario.MOTION, start=demo.truth[0])
engine = ParticleFilter(model, study.TRACKING_N, threshold=1.0).run(demo.scans, rng=np.random.default_rng(7))
TOL = 1e-9
gap = max(np.abs(est[:, :2] - engine.mean[:, :2]).max(), heading_error(engine.mean, est).max(),
          np.abs(ess - engine.ess).max() / study.TRACKING_N)
same_draws = np.allclose(sample_motion(demo.truth[:50], (0.3, 1.0, 0.0), np.random.default_rng(1)),
                         OdometryModel(scenario.MOTION.alphas).sample(demo.truth[:50], (0.3, 1.0, 0.0),
                                                                   np.random.default_rng(1)), rtol=0, atol=1e-12)
assert gap < TOL and same_draws
glue_values("lf_", engine_tolerance=TOL)
print(f"Checked against the engine (pfcourse.ParticleFilter with the scenario's model, same random stream): "
      f"estimates and ESS equal to {TOL:.0e} at every step; the odometry sampler draws the package's poses.")

# %% [markdown]
# The loop and the book's engine give the same estimates to {glue:text}`lf_engine_tolerance:.0e` at
# every step, drawing from the same random stream. From here on the studies run the engine.

# %% [markdown]
# ## Tracking
#
# The figure shows the run of the cell above: the position error stays at a few centimetres, a
# fraction of the field's $\sigma = 0.2$ m, through rooms, doors and corridor. The effective sample
# size (ESS, $1 / \sum_i (W_k^i)^2$) after each weighting tells how many particles the scan leaves
# alive: a scan of $24$ beams is sharp next to the cloud that the odometry spreads in half a second.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
t = np.arange(len(est)) * scenario.DT
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.2))
ax1.plot(t, err, color=COLORS["estimate"])
ax1.set_xlabel("time t (s)")
ax1.set_ylabel("position error (m)")
ax1.set_title("Tracking: position error")
ax2.plot(t, ess / study.TRACKING_N, color=COLORS["estimate"])
ax2.set_ylim(0, 1)
ax2.set_xlabel("time t (s)")
ax2.set_ylabel("ESS / N")
ax2.set_title(f"The ESS after each scan, N = {study.TRACKING_N}")
plt.show()

# %% [markdown]
# Over {glue:text}`lf_n_tracking:d` seeded drives of $80$ s the position RMSE is
# {glue:text}`lf_tracking_rmse_m:.3f` m on average
# ({glue:text}`lf_tracking_rmse_m_low:.3f`-{glue:text}`lf_tracking_rmse_m_high:.3f`).
#
# The price of so sharp a scan is the ESS: on average {glue:text}`lf_tracking_ess_share:.0%` of
# $N$ after weighting, and {glue:text}`lf_tracking_ess_p10:.0%` in the tenth of the steps where it
# is lowest. $N = 300$ behaves like a few dozen independent particles, which is enough to track.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
tracking = STUDIES["maprobot/tracking"].load()
prod = tracking[tracking["weighting"] == "product"].sort_values("seed")
cubes = tracking[tracking["weighting"] == "cubes"].sort_values("seed")
assert (prod["seed"].to_numpy() == cubes["seed"].to_numpy()).all()
rmse, low, high = evidence.run_interval(lambda r: prod["position_rmse"].to_numpy()[r].mean(), len(prod))
head_rmse, head_low, head_high = evidence.run_interval(lambda r: prod["heading_rmse"].to_numpy()[r].mean(), len(prod))
ess_share = evidence.run_interval(lambda r: prod["mean_ess_share"].to_numpy()[r].mean(), len(prod))
glue_values("lf_", n_tracking=len(prod), tracking_rmse_m=rmse, tracking_rmse_m_low=low, tracking_rmse_m_high=high,
            tracking_ess_share=ess_share[0], tracking_ess_p10=prod["p10_ess_share"].mean())
EvidenceBlock(
    "tracking on the map is accurate, with a small ESS",
    notes=[f"{len(prod)} drives (seeds 0-{len(prod) - 1}), N = {study.TRACKING_N}, 80 s each, bootstrap MCL "
           "resampling at every scan, started at the true pose with standard deviations 0.2 m, 0.2 m, 0.05 rad.",
           f"Mean over runs of the per-run position RMSE: {rmse:.3f} m (95 % interval {low:.3f}-{high:.3f}, "
           "percentile bootstrap over runs, see Reading the evidence).",
           f"Mean heading RMSE: {np.degrees(head_rmse):.2f} degrees (95 % interval {np.degrees(head_low):.2f}-"
           f"{np.degrees(head_high):.2f}).",
           f"ESS after weighting, as a share of N, averaged over the steps after the first and the runs: "
           f"{ess_share[0]:.3f} (95 % interval {ess_share[1]:.3f}-{ess_share[2]:.3f}); its 10th percentile over "
           f"the steps, averaged over the runs: {prod['p10_ess_share'].mean():.3f}.",
           stored("tracking")],
    tables=[("Per-run position RMSE, over the runs", *spread_table(prod["position_rmse"], "m", ".3f")),
            ("Per-run mean ESS / N, over the runs", *spread_table(prod["mean_ess_share"], "share of N", ".3f"))],
)

# %% [markdown]
# ### When is a filter locked on?
#
# A study needs one yes-or-no verdict per run: did the filter end with the robot? The rule must
# fit the robot. Its odometry adds heading noise at every step, and a filter that tracks well
# carries some of it between two scans. On a straight step of length $d$
# ($\delta_{\mathrm{rot1}} = \delta_{\mathrm{rot2}} = 0$), the heading error is $-(\eta_1 + \eta_3)$,
# two independent errors of variance $a_2 d^2$ each, so one step adds
#
# $$
# \sigma_\theta = \sqrt{2 a_2}\, d
# $$
#
# of heading noise: with $a_2 = 0.05$ and $d = 0.5 \text{ m/s} \times 0.5 \text{ s} = 0.25$ m,
# $\sigma_\theta$ = {glue:text}`lf_step_heading_sd_deg:.1f`°. An estimate more than three of those
# from the true heading, {glue:text}`lf_heading_tolerance_deg:.1f`°, is farther off than one step of
# the odometry explains. **The book's map robot is locked on** when its position error is under
# $1$ m (a twin room is $5$ m away) and its heading error under $3 \sigma_\theta$ at $80\,\%$ or more
# of the steps of the run's last $20$ s: a filter in a twin room fails at every step, one sharp turn
# does not make a tracking filter lost.
#
# By this rule tracking locks on in {glue:text}`lf_tracking_lock_on_rate:.0%` of the drives
# ({glue:text}`lf_tracking_lock_on_rate_low:.0%`-{glue:text}`lf_tracking_lock_on_rate_high:.0%`).
#
# The tolerance is generous: {glue:text}`lf_tolerance_over_heading_rmse:.0f` times the heading RMSE
# of these tracking runs, and the largest heading error in the last $20$ s of any of them is
# {glue:text}`lf_tracking_max_window_heading_deg:.1f`°. It need not be tight, since what it must
# reject is a filter in a twin room, which is off by $180°$ or by $5$ m or more. The landmark
# chapters use the same function (`pfcourse.metrics.locked_on`) with a stricter convention, $5°$
# at every step of the window; it counts {glue:text}`lf_tracking_lock_on_rate_old:.0%` of these same
# runs as locked on.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
locked = evidence.rate(prod["locked_on"].to_numpy())
old_rule = evidence.rate(prod["locked_on_every_step_5deg"].to_numpy())
glue_values("lf_", step_heading_sd_deg=np.degrees(lock_on.step_heading_sd()),
            heading_tolerance_deg=np.degrees(lock_on.HEADING_TOLERANCE), tracking_lock_on_rate=locked.estimate,
            tracking_lock_on_rate_low=locked.low, tracking_lock_on_rate_high=locked.high,
            tracking_lock_on_rate_old=old_rule.estimate,
            tolerance_over_heading_rmse=lock_on.HEADING_TOLERANCE / head_rmse,
            tracking_max_window_heading_deg=float(np.degrees(prod["max_window_heading_error"].max())))
EvidenceBlock(
    "by a rule that fits the robot, tracking locks on in nearly every drive",
    notes=[f"The rule (pfcourse.scenarios.maprobot.lock_on.locked_on): position error < {lock_on.POSITION_TOLERANCE_M:g} m and "
           f"heading error < 3 sqrt(2 a_2) d = {np.degrees(lock_on.HEADING_TOLERANCE):.1f} degrees at "
           f"{lock_on.SHARE:.0%} or more of the steps of the last {lock_on.WINDOW_S:g} s "
           f"({int(np.ceil(lock_on.WINDOW_S / scenario.DT))} steps); a_2 = {lock_on.ALPHAS[1]}, d = {lock_on.STEP_M} m.",
           f"Locked on, the {len(prod)} tracking drives: {locked}.",
           f"The landmark chapters' convention (5 degrees at every step of the last 20 s) on the same runs: "
           f"{old_rule}.",
           f"Tolerance over the mean heading RMSE while tracking ({np.degrees(head_rmse):.2f} degrees): "
           f"{lock_on.HEADING_TOLERANCE / head_rmse:.1f}. Largest heading error in the last {lock_on.WINDOW_S:g} s, "
           f"over the runs: median {np.degrees(prod['max_window_heading_error'].median()):.1f}, largest "
           f"{np.degrees(prod['max_window_heading_error'].max()):.1f} degrees.",
           "The same rule, with the heading noise of its own odometry, scores the real robot of the next chapter.",
           stored("tracking")],
)

# %% [markdown]
# ### How many particles does KLD-sampling keep?
#
# AMCL does not fix $N$: it uses KLD-sampling {cite:p}`fox2003`, which draws particles until their
# number exceeds a bound that grows with the number of histogram bins they occupy, so that with
# probability $1 - \delta$ the Kullback-Leibler divergence between the sample and the true posterior
# stays under $\varepsilon$. The defaults of amcl in ROS Noetic are at most $5000$ and at least $100$ particles,
# `kld_err` $= 0.01$ and `kld_z` $= 0.99$, with bins of $0.5$ m $\times$ $0.5$ m $\times$ $10°$. Its
# `kld_z` is not $1 - \delta$ but the normal quantile $z_{1-\delta}$ that enters the bound, so
# $\delta$ = {glue:text}`lf_kld_delta:.2f`.
#
# Fox's KLD-sampling with amcl's numbers, on the same drives, counts the bins of the *moved*
# particles and keeps {glue:text}`lf_kld_mean_particles:.0f` particles on average while tracking
# ({glue:text}`lf_kld_mean_particles_low:.0f`-{glue:text}`lf_kld_mean_particles_high:.0f`), more than
# the $N = 300$ that tracks well, for a position RMSE {glue:text}`lf_kld_rmse_ratio:.2f` times that
# of the fixed $N$ (median ratio over the drives). amcl itself counts the bins of the *resampled*
# copies before they move: a tighter cloud, fewer bins, so it would keep fewer particles than this.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
kld = STUDIES["maprobot/kld_tracking"].load().sort_values("seed")
assert (kld["seed"].to_numpy() == prod["seed"].to_numpy()).all()
mean_n, mean_n_low, mean_n_high = evidence.run_interval(lambda r: kld["mean_particles"].to_numpy()[r].mean(), len(kld))
ratio = evidence.paired(kld["position_rmse"].to_numpy(), prod["position_rmse"].to_numpy(), ratio=True)
glue_values("lf_", kld_delta=scenario.AMCL_KLD["delta"], kld_mean_particles=mean_n, kld_mean_particles_low=mean_n_low,
            kld_mean_particles_high=mean_n_high, kld_rmse_ratio=ratio.median)
EvidenceBlock(
    "Fox's KLD-sampling with Noetic amcl's numbers keeps more particles than tracking needs",
    notes=[f"The {len(kld)} drives of the tracking study, filtered by KLD-sampling (Fox 2003): at most "
           f"{scenario.AMCL_KLD['n_max']}, at least {scenario.AMCL_KLD['n_min']} particles, epsilon = kld_err = "
           f"{scenario.AMCL_KLD['epsilon']}, delta = 1 - Phi(kld_z = 0.99) = {scenario.AMCL_KLD['delta']:.3f}, bins of "
           "0.5 m x 0.5 m x 10 degrees, counted on the moved particles (Fox 2003); amcl's pf_update_resample "
           "counts the resampled copies before the motion, a tighter set. Step 0 draws the maximum, later steps "
           "draw in batches of 100 until the bound is met (amcl adds one at a time), which can raise N by up to "
           "99 over a one-at-a-time count. The bound is (k - 1)/(2 eps) (1 - 2/(9(k - 1)) + sqrt(2/(9(k - 1))) z)^3 with "
           "z = kld_z in amcl's pf.c (pf_resample_limit), so kld_z is the quantile z_{1-delta}, not 1 - delta.",
           f"Mean number of particles after step 0: {mean_n:.0f} (95 % interval {mean_n_low:.0f}-{mean_n_high:.0f}, "
           f"percentile bootstrap over the drives); largest after step 0 in any run: "
           f"{kld['max_particles_after_start'].max()}.",
           f"Position RMSE, KLD-sampling over fixed N = {study.TRACKING_N}, paired by drive: {ratio} "
           f"({ratio.verdict()}; see Reading the evidence).",
           f"Locked on: {evidence.rate(kld['locked_on'].to_numpy())}.",
           stored("kld_tracking")],
)

# %% [markdown]
# ## AMCL as it is
#
# AMCL, the adaptive MCL of ROS ({cite:t}`thrun2005`, chapter $8$; KLD-sampling {cite:p}`fox2003`),
# is what most indoor robots run. It is Algorithm 14.1 with KLD-sampling, the odometry model, the
# likelihood field by default, and recovery by injected poses switched off by default. Its defaults
# differ between ROS Noetic and its successor nav2; the folded table quotes both from their sources. One
# difference from the book is in the code, not in the parameters: **AMCL does not multiply the
# beams' probabilities; it adds their cubes.** With the beam probability unnormalised,
#
# $$
# w(x) = 1 + \sum_{b:\, z_b < z_{\max}} p_b^3, \qquad
# p_b = z_{\mathrm{hit}} \exp\!\Big(-\frac{d(e_b)^2}{2 \sigma^2}\Big) + \frac{z_{\mathrm{rand}}}{z_{\max}},
# $$
#
# a scheme the source itself calls "ad-hoc". Every $p_b$ is at most one, so the best pose can
# outweigh the worst by a factor of at most one plus the number of beams; the product's ratio
# grows exponentially with the beams. The cubes flatten the weights: meant to be robust where people
# and furniture the map lacks block many beams (this chapter has no such runs), and a loss of
# information where the map is right.

# %% [markdown]
# :::{admonition} AMCL's defaults, ROS Noetic and nav2, from their sources
# :class: dropdown
# ROS Noetic: `ros-planning/navigation`, branch `noetic-devel` at commit `9ad6441` (amcl `1.17.3`),
# `amcl/cfg/AMCL.cfg` and `amcl/src/amcl/sensors/amcl_laser.cpp`. nav2: `ros-planning/navigation2`
# at commit `b6c36c3` (nav2_amcl `1.3.1`), `nav2_amcl/src/amcl_node.cpp` and
# `nav2_amcl/src/sensors/laser/likelihood_field_model.cpp`.
#
# | parameter | Noetic amcl | nav2 amcl | this chapter |
# | --- | --- | --- | --- |
# | particles, min - max | `100` - `5000` | `500` - `2000` | `300` fixed |
# | KLD error `kld_err` / `pf_err` | `0.01` | `0.05` | - |
# | KLD quantile `kld_z` / `pf_z` ($z_{1-\delta}$) | `0.99` | `0.99` | - |
# | laser model | `likelihood_field` | `likelihood_field` | likelihood field |
# | $z_{\mathrm{hit}}$, $z_{\mathrm{rand}}$ | `0.95`, `0.05` | `0.5`, `0.5` | `0.9`, `0.1` |
# | $\sigma_{\mathrm{hit}}$ (m) | `0.2` | `0.2` | `0.2` |
# | beams used per scan | `30` | `60` | `24` |
# | combining the beams | `1 + sum of cubes` | `1 + sum of cubes` | product |
# | odometry $a_1, \dots, a_4$ | `0.2` each | `0.2` each | `0.05` each |
# | `recovery_alpha_slow`, `_fast` | `0`, `0` (off) | `0`, `0` (off) | - |
# | `resample_interval` | `2` | `1` | `1` |
# | `update_min_d` (m), `update_min_a` (rad) | `0.2`, $\pi/6$ | `0.25`, `0.2` | every scan |
#
# Both sources carry the comment `this should have a normalization of 1/(sqrt(2pi)*sigma)` above
# the Gaussian term and `here we have an ad-hoc weighting scheme for combining beam probs` above
# the sum of cubes; the beam model (`laser_model_type: beam`) combines its beams the same way.
# :::

# %% [markdown]
# **What the cubes do**, measured on the drives of the tracking study with the same random numbers:
# the ESS after weighting rises to {glue:text}`lf_cubes_ess_share:.0%` of $N$ on average, and the
# position RMSE is {glue:text}`lf_cubes_rmse_ratio:.1f` times that of the product (median ratio over
# the drives): the cloud stays wide because the scan barely tells its particles apart. Tracking
# still locks on in {glue:text}`lf_cubes_tracking_lock_on_rate:.0%` of the drives.
#
# Started lost
# (uniform poses, $N = 1000$, random injection $\varepsilon = 0.1$, $100$ s), the cubes lock on in
# {glue:text}`lf_cubes_global_lock_on_rate:.0%` of the drives and the product in
# {glue:text}`lf_injection_lock_on_rate:.0%`, a difference these hundred drives leave open
# ({glue:text}`lf_cubes_global_diff_low:+.0f` to {glue:text}`lf_cubes_global_diff_high:+.0f` points).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
amcl_global = STUDIES["maprobot/amcl_global"].load()
inj = amcl_global[amcl_global["method"] == "injection"]
g_prod = inj[inj["weighting"] == "product"].sort_values("seed")
g_cubes = inj[inj["weighting"] == "cubes"].sort_values("seed")
g_boot = amcl_global[amcl_global["method"] == "bootstrap"].sort_values("seed")
assert (g_prod["seed"].to_numpy() == g_cubes["seed"].to_numpy()).all()
rmse_ratio = evidence.paired(cubes["position_rmse"].to_numpy(), prod["position_rmse"].to_numpy(), ratio=True)
ess_diff = evidence.paired(cubes["mean_ess_share"].to_numpy(), prod["mean_ess_share"].to_numpy())
track_pair = evidence.paired_rates(cubes["locked_on"].to_numpy(), prod["locked_on"].to_numpy())
global_pair = evidence.paired_rates(g_cubes["locked_on"].to_numpy(), g_prod["locked_on"].to_numpy())
boot_pair = evidence.paired_rates(g_prod["locked_on"].to_numpy(), g_boot["locked_on"].to_numpy())
glue_values("lf_", cubes_ess_share=cubes["mean_ess_share"].mean(), cubes_rmse_ratio=rmse_ratio.median,
            cubes_tracking_lock_on_rate=track_pair.a.estimate, cubes_global_lock_on_rate=global_pair.a.estimate,
            n_injection=len(g_prod), injection_lock_on_rate=global_pair.b.estimate,
            injection_lock_on_rate_low=global_pair.b.low, injection_lock_on_rate_high=global_pair.b.high, bootstrap_lock_on_rate=boot_pair.b.estimate,
            bootstrap_lock_on_rate_low=boot_pair.b.low, bootstrap_lock_on_rate_high=boot_pair.b.high,
            cubes_global_diff_low=100 * global_pair.difference_low, cubes_global_diff_high=100 * global_pair.difference_high)
summary = pd.DataFrame([
    {"drives": "tracking", "weighting": name, "mean ESS / N": g["mean_ess_share"].mean(),
     "10 % ESS / N": g["p10_ess_share"].mean(), "mean position RMSE (m)": g["position_rmse"].mean(),
     "locked on": str(evidence.rate(g["locked_on"].to_numpy()))} for name, g in [("product", prod), ("cubes", cubes)]
] + [
    {"drives": f"global, {m}", "weighting": name, "mean ESS / N": g["mean_ess_share"].mean(),
     "10 % ESS / N": g["p10_ess_share"].mean(), "mean position RMSE (m)": np.nan,
     "locked on": str(evidence.rate(g["locked_on"].to_numpy()))}
    for name, m, g in [("product", "injection", g_prod), ("cubes", "injection", g_cubes), ("product", "bootstrap", g_boot)]])
EvidenceBlock(
    "AMCL's sum of cubes keeps the ESS high and localizes worse",
    notes=[f"Tracking: the {len(prod)} drives of the tracking study, N = {study.TRACKING_N}, each filtered with the "
           "product of the likelihood field and with AMCL's 1 + sum of cubes of the same beam probabilities (the "
           "Gaussian unnormalised, as in amcl); same filter seed (common random numbers).",
           f"Mean ESS / N, cubes minus product, paired by drive: {ess_diff} (see Reading the evidence).",
           f"Position RMSE, cubes over product: {rmse_ratio} ({rmse_ratio.verdict()}).",
           f"Locked on while tracking (cubes A, product B): {track_pair}.",
           f"Global localization: {len(g_prod)} drives of 100 s from a uniform start, N = {study.GLOBAL_N}, random "
           f"injection epsilon = {scenario.INJECT} (the configuration of the chapter before {{doc}}`map_global`), "
           f"locked on by the book's rule; cubes A, product B: {global_pair}.",
           f"Product with injection (A) against the bootstrap filter without it (B), same drives: {boot_pair}.",
           stored("tracking"), stored("amcl_global")],
    tables=[("By weighting (Wilson intervals for the lock-on rates)", summary,
             {"mean ESS / N": ".3f", "10 % ESS / N": ".3f", "mean position RMSE (m)": ".3f"})],
)

# %% [markdown]
# ### The beam model beside the likelihood field
#
# The beam model is the scanner's own: it casts each beam of each particle through the grid to the
# first wall and scores the reading by the four-part mixture. It costs what the field avoids: the
# first wall is {glue:text}`lf_mean_first_wall_m:.1f` m away on average on this map, so a ray cast
# that stops there, as amcl's does, visits about {glue:text}`lf_cells_to_first_wall:.0f` cells for
# every look-up of the field. This book's NumPy marches every beam to $z_{\max}$ instead
# ({glue:text}`lf_beam_cells_per_lookup:.0f` quarter-cell steps a beam) and takes
# {glue:text}`lf_beam_cost_ratio:.0f` times the field's time per scan on $300$ particles: a bound
# for this code, not the model's cost.
#
# Each model is wrong somewhere. The field ignores what lies
# between the robot and the end point, so it scores a pose whose beams would have been stopped by
# a wall as if they had not been (it "sees through walls"; this chapter does not measure how often
# that matters). The beam model knows occlusion. Along a line through the truth (figure below),
# with each model's own $\sigma$ (the scanner's $0.05$ m for the beam model, AMCL's $0.2$ m for
# the field), the beam model stays within $10$ nats of its best over
# {glue:text}`lf_beam_width_cm:.0f` cm, the field over {glue:text}`lf_field_width_cm:.0f` cm. With
# the same $\sigma = 0.05$ m the field narrows to {glue:text}`lf_field_width_cm_equal:.0f` cm: the
# gap between centimetres and decimetres is mostly the choice of $\sigma$, not the model. Real
# scans add what neither models: beams that are not independent, glass, people.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
offsets = np.linspace(-0.6, 0.6, 121)
line = demo.truth[k_show] + offsets[:, None] * np.array([1.0, 0.0, 0.0])
ll_field = field.log_likelihood(line, demo.scans[k_show])
ll_beam = beam_log_likelihood(grid, scanner, line, demo.scans[k_show])
# the field with the scanner's own sigma, for a comparison at equal sigma
ll_field_equal = replace(field, sigma=scanner.sigma_hit).log_likelihood(line, demo.scans[k_show])


def width_cm(ll, within=10.0):
    """Length (cm) of the stretch of the line within ``within`` nats of its best."""
    return 100 * (offsets[1] - offsets[0]) * np.sum(ll >= ll.max() - within)


fig, ax = plt.subplots(figsize=(7, 3.2))
ax.plot(100 * offsets, ll_field - ll_field.max(), color=COLORS["estimate"], label="likelihood field")
ax.plot(100 * offsets, ll_beam - ll_beam.max(), color=COLORS["kalman"], label="beam model")
ax.plot(100 * offsets, ll_field_equal - ll_field_equal.max(), color=COLORS["estimate"], ls=":",
        label="likelihood field, σ = 0.05 m")
ax.axhline(-10, color=COLORS["unseen"], ls="--", lw=1, label="10 nats below the best")
ax.set_ylim(-150, 5)
ax.set_xlabel("shift of the pose along x from the truth (cm)")
ax.set_ylabel("log-likelihood minus its best")
ax.set_title("One scan scored along a line through the truth")
ax.legend(loc="lower center")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
cost = STUDIES["maprobot/sensor_cost"].load()
cost_ratio = cost["beam_seconds"] / cost["field_seconds"]
# the true ranges of the scanned beams on the poses of the cost study's scans (step 68 of its drives)
first_wall = np.concatenate([cast_rays(grid, scenario.simulate(int(s), 69).truth[68:69], scanner.angles,
                                       scanner.max_range).ravel() for s in cost["seed"]])
first_wall = first_wall[first_wall < scanner.max_range]
glue_values("lf_", beam_cells_per_lookup=float((cost["beam_cells"] / cost["field_lookups"]).median()),
            beam_cost_ratio=float(cost_ratio.median()), field_width_cm=width_cm(ll_field),
            beam_width_cm=width_cm(ll_beam), field_width_cm_equal=width_cm(ll_field_equal),
            mean_first_wall_m=first_wall.mean(), cells_to_first_wall=first_wall.mean() / grid.resolution)
EvidenceBlock(
    "our full-range beam model costs far more per scan than the field; its sharpness is mostly sigma",
    notes=[f"{len(cost)} scans (step 68 of drives 0-{len(cost) - 1}), each weighting the same {study.TRACKING_N} "
           "poses around the truth (sd 0.2 m, 0.2 m, 0.05 rad, those in free space kept) by both models, best of "
           "3 timings each; wall times on a shared 2-core machine, so only their ratio means much. Timings are not "
           "Monte Carlo estimates: 20 scans show their spread.",
           f"Median time per scan: field {1e3 * cost['field_seconds'].median():.2f} ms, beam model "
           f"{1e3 * cost['beam_seconds'].median():.0f} ms; ratio median {cost_ratio.median():.0f} "
           f"(range {cost_ratio.min():.0f}-{cost_ratio.max():.0f}).",
           "Cell visits: the field reads one cell per beam with an echo; the beam model marches every beam to "
           f"z_max in steps of a quarter cell ({int(cost['beam_cells'].iloc[0] / cost['n_poses'].iloc[0] / 24)} "
           "steps a beam) whatever the first wall (pfcourse.scenarios.maprobot.scanner.cast_rays); a cast that stops at "
           f"the first wall would visit about {first_wall.mean() / grid.resolution:.0f} cells a beam (mean true "
           f"range of the {len(first_wall)} beams with a wall in range at the truth of these scans: "
           f"{first_wall.mean():.2f} m, cells of {grid.resolution} m). The time ratio measures the full march.",
           f"Along the line of the figure (121 poses, 1 cm apart, heading true): within 10 nats of the best over "
           f"{width_cm(ll_field):.0f} cm (field, sigma 0.2 m), {width_cm(ll_field_equal):.0f} cm (field, "
           f"sigma 0.05 m) and {width_cm(ll_beam):.0f} cm (beam model, the scanner's sigma 0.05 m).",
           stored("sensor_cost")],
    tables=[("Beam model, time per scan (s), over the scans", *spread_table(cost["beam_seconds"], "s", ".3f")),
            ("Likelihood field, time per scan (ms), over the scans",
             *spread_table(1e3 * cost["field_seconds"], "ms", ".3f"))],
)

# %% [markdown]
# ## Starting lost
#
# Tracking starts from the known pose. Started anywhere, with the particles uniform in free space,
# the filter must tell the look-alike rooms apart, and plain MCL often settles in a twin and stays
# there: over $100$ drives of $100$ s with $N = 1000$, random injection of
# uniform poses ($\varepsilon = 0.1$) locks on in {glue:text}`lf_injection_lock_on_rate:.0%` of them
# ({glue:text}`lf_injection_lock_on_rate_low:.0%`-{glue:text}`lf_injection_lock_on_rate_high:.0%`), the
# bootstrap filter in {glue:text}`lf_bootstrap_lock_on_rate:.0%`. {doc}`map_global` measures how
# often the scans decide at all, and builds the filter that reaches that bound: enough particles at
# the start, KLD-sampling, and poses injected where the scan fits.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
EvidenceBlock(
    "random injection locks on more often than the bootstrap filter",
    notes=[f"{len(g_prod)} drives of 100 s from a uniform start, N = {study.GLOBAL_N}, product of the likelihood "
           f"field; injection epsilon = {scenario.INJECT} (A) against the bootstrap filter (B), same drives and "
           f"filter seeds: {boot_pair}.", stored("amcl_global")],
)

# %% [markdown]
# ## Try it
#
# The panel tracks the drive of this chapter with $N$ particles, the beams combined by the product
# of the likelihood field or by AMCL's sum of cubes, and the filter's random numbers drawn from one
# of three seeds. Which $N$ still tracks with the product, whatever the seed? What do the cubes do
# to the error and to the ESS?

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_tracking(n_particles, weighting, seed=0):
    res = scenario.run_filter(demo, seed, n_particles, start=demo.truth[0], weighting=weighting)
    time_s = np.arange(len(demo.truth)) * scenario.DT
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.2))
    a1.semilogy(time_s, np.maximum(position_error(demo.truth, res.mean), 1e-3), color=COLORS["estimate"])
    a1.set_ylim(1e-3, 20)
    a1.set_xlabel("time t (s)")
    a1.set_ylabel("position error (m)")
    a2.plot(time_s, res.ess / n_particles, color=COLORS["estimate"])
    a2.set_ylim(0, 1)
    a2.set_xlabel("time t (s)")
    a2.set_ylabel("ESS / N")


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(draw_tracking, grid={"n_particles": (20, 50, 300), "weighting": ("product", "cubes")},
                      side={"seed": (0, 1, 2)}, n_particles=particle_slider(300, 1, 3),
                      seed=widgets.SelectionSlider(options=[0, 1, 2], value=0, description="filter seed"),
                      weighting=widgets.Dropdown(options=["product", "cubes"], value="product",
                                                 description="beams combined by")))

# %% [markdown]
# ## Exercises
#
# ```{exercise} 14.1 How flat can AMCL's weights be?
# :label: ex-map-cubes
# :nonumber:
# With the chapter's field ($z_{\mathrm{hit}} = 0.9$, $z_{\mathrm{rand}} = 0.1$, $\sigma = 0.2$ m,
# $z_{\max} = 8$ m) and a scan of $22$ beams with an echo, what is the largest ratio between the
# weights of two poses under AMCL's sum of cubes, and under the product of the likelihood field?
# ```
#
# ```{solution} ex-map-cubes
# :class: dropdown
# Under the cubes each $p_b$ lies between $z_{\mathrm{rand}} / z_{\max} = 0.0125$ (end point far from
# any wall) and $0.9 + 0.0125 = 0.9125$ (on a wall), so $w$ lies between $1 + 22 \times 0.0125^3
# \approx 1$ and $1 + 22 \times 0.9125^3 \approx 17.7$: no pose outweighs another by more than
# about $18$. Under the product each beam's factor lies between $0.0125$ and
# $0.9 / (\sqrt{2\pi}\, 0.2) + 0.0125 \approx 1.81$, a ratio of about $145$ per beam and
# $145^{22} \approx 10^{47}$ for the scan: the product can single out one pose, the cubes cannot.
# ```
#
# ```{exercise} 14.2 Draw a scan from the beam model, and have it checked
# :label: ex-map-code
# :nonumber:
# (Coding.) The chapter scores scans; the simulator draws them from the beam model. Write
# `my_reading(z_star, scanner, rng)`: one reading per beam, for the true ranges `z_star`
# (shape `(B,)`), drawn with the generator `rng` from the four-part mixture of the section on the
# likelihood field, with weights `scanner.z_hit`, `scanner.z_short`, `scanner.z_max`,
# `scanner.z_rand`: a hit, Gaussian around $z^\ast$ of standard deviation `scanner.sigma_hit`,
# clipped to $[0, z_{\max}]$; a short reading, exponential of rate `scanner.lambda_short`
# truncated to $[0, z^\ast]$; exactly `scanner.max_range`; or uniform on $[0, z_{\max}]$. The
# checker draws many readings and compares their spread with the model's, and names the mistake
# it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_beam_reading


def my_reading(z_star, scanner, rng):
    """Your beam-model reading: one range per beam, shape like z_star."""
    ...  # replace with your code


print(check_beam_reading(my_reading))

# %% [markdown]
# ```{solution} ex-map-code
# :class: dropdown
# Draw each beam's part with one uniform against the cumulative weights, and all four candidate
# readings at once; a truncated exponential is drawn by inverting its distribution function,
# $z = -\log(1 - u (1 - e^{-\lambda z^\ast})) / \lambda$. The code is in the folded cell below
# (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_reading(z_star, scanner, rng):
    z_star = np.asarray(z_star, dtype=float)
    n = len(z_star)
    cut = np.cumsum([scanner.z_hit, scanner.z_short, scanner.z_max])
    part = np.searchsorted(cut, rng.random(n), side="right")
    hit = np.clip(z_star + scanner.sigma_hit * rng.standard_normal(n), 0.0, scanner.max_range)
    lam = scanner.lambda_short
    short = -np.log1p(-rng.random(n) * -np.expm1(-lam * z_star)) / lam
    rand = rng.random(n) * scanner.max_range
    no_echo = np.full(n, scanner.max_range)
    return np.choose(part, [hit, short, no_echo, rand])


print(check_beam_reading(my_reading))

# %% [markdown]
# ## Takeaways
#
# - Monte Carlo localization on a map is the bootstrap particle filter with two robotics models: the
#   odometry model, sampled by perturbing rotation, translation and rotation, and the likelihood
#   field, which scores each beam's end point by its distance to the nearest wall, one look-up per beam.
# - From the known start it tracks to a few centimetres with a few hundred particles, though a scan
#   leaves only a small share of them effective.
# - "Locked on" is one function whose heading tolerance fits the robot: here three steps' worth of
#   odometry noise over most of the last window, looser than the landmark chapters' $5°$ at every step.
# - AMCL adds the cubes of the beams' probabilities instead of multiplying them: its weights stay
#   flat, meant to be robust to what the map lacks, and it localizes less sharply; the beam model
#   knows occlusion and costs a ray cast per beam.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab C ({doc}`../labs`) localizes a robot among landmarks, from a known start (tracking) and from
# a cloud spread over the map (global localization). This chapter carries its tracking question to a
# robot with a laser scanner on a map of walls ("Tracking" and "When is a filter locked on?");
# {doc}`map_global` carries its global localization question.
# :::
