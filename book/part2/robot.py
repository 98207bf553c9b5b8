# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Localizing a robot with range and bearing
#
# A wheeled robot knows its map: five landmarks at known positions. It does not know where
# it is. Two sources of information help it:
#
# - **odometry**: its wheels tell it, at every second, how fast it moved forward, sideways
#   and how fast it turned, with an error;
# - **a range-bearing sensor**: at each measurement step it sees one landmark, knows which one,
#   and measures how far away it is and at which angle relative to its own heading.
#
# The state $x_k = (p_x, p_y, \theta)$ is the position (m) and the heading (rad). The
# measurement is a nonlinear function of the state, and the heading is an angle, which lives
# on a circle: two reasons why the Kalman filter of Part I is no longer exact. This chapter
# builds the particle filter for it {cite:p}`thrun2005`, tracks the robot from a good initial
# guess, and then asks the harder question the Kalman filters cannot even pose: where is the
# robot if we have no idea at all?
#
# ## The model
#
# With the command $u = (v_x, v_y, \omega)$ expressed in the robot's frame and a step
# $\Delta t = 1$ s, the robot moves by
#
# $$
# f(x, u) = \begin{pmatrix} p_x + (v_x\cos\theta - v_y \sin\theta)\,\Delta t \\
#  p_y + (v_x \sin\theta + v_y\cos\theta)\,\Delta t \\
#  \operatorname{wrap}(\theta + \omega\,\Delta t) \end{pmatrix},
# $$
#
# where $\operatorname{wrap}$ maps an angle to $(-\pi, \pi]$. The truth follows the true
# commands, $x_k = f(x_{k-1}, u_k)$, but the robot only reads them with an error,
# $\tilde u_k = u_k + e_k$, $e_k \sim \mathcal N(0, Q_\text{true})$ with standard deviations
# {glue:text}`q_sd_vx:.2f` m/s, {glue:text}`q_sd_vy:.2f` m/s and {glue:text}`q_sd_omega_deg:.0f` deg/s. Integrating $\tilde u_k$ alone is *dead reckoning*; it
# drifts. Since $x_k = f(x_{k-1}, \tilde u_k - e_k)$, the filter's transition is
#
# $$
# x_k = f(x_{k-1}, \tilde u_k + w_k), \qquad w_k \sim \mathcal N(0, Q_\text{est}).
# $$
#
# The measurement of landmark $j$ at position $\ell^j$ is
#
# $$
# z_k = h_j(x_k) + v_k, \quad h_j(x) = \begin{pmatrix} \lVert \ell^j - p \rVert \\
# \operatorname{wrap}\big(\operatorname{atan2}(\ell^j_y - p_y, \ell^j_x - p_x) - \theta\big)\end{pmatrix},
# \quad v_k \sim \mathcal N(0, R_\text{true}),
# $$
#
# with standard deviations {glue:text}`r_sd_range:.1f` m and {glue:text}`r_sd_bearing_deg:.0f` deg. The particle filter's likelihood compares
# $z_k$ with $h_j$ at every particle through the *innovation*
# $\nu = (z_r - h_r,\ \operatorname{wrap}(z_b - h_b))$: without the wrap, a measured bearing
# of $179°$ and a predicted one of $-179°$ would be $358°$ apart instead of $2°$, and a perfectly
# placed particle would get weight zero.
#
# The defaults follow the lab (reports 002 and 004): {glue:text}`n_steps:d` steps, a start at $(1, -50, 0)$,
# {glue:text}`n_landmarks:d` landmarks drawn uniformly in $[-60, 60]^2$ m, one randomly chosen landmark observed every
# second, and a filter that assumes twice the true variances, $Q_\text{est} = 2Q_\text{true}$,
# $R_\text{est} = 2R_\text{true}$.
#
# **How the data are passed.** `pfcourse.robot.scenario.simulate_robot` returns the
# measurements as one array with a row $(j, r, b)$ per step (landmark index, range, bearing),
# or a row of NaN when there is no measurement; the generic
# `pfcourse.filter.ParticleFilter` skips the update on such rows. The odometry is
# held by the model (`pfcourse.robot.scenario.RobotModel`), which reads row $k$ when it moves
# the particles at step $k$. The same two arrays feed the extended and unscented Kalman
# filters of the next chapter.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML, display
from ipywidgets import Checkbox, IntSlider
from matplotlib.ticker import MaxNLocator, MultipleLocator
from myst_nb import glue

from pfcourse import evidence
from pfcourse.diagnostics import nees
from pfcourse.errors import DegenerateWeightsError
from pfcourse.filter import ParticleFilter
from pfcourse.style import COLORS, plain_log_axis, use_style
from pfcourse.robot.scenario import INITIAL_STD, RobotModel, rmse, simulate_robot, tracking_errors
from pfcourse.experiments.robot import global_localization_run
from pfcourse.figures.clouds import animate_clouds
from pfcourse.robot.figures import error_bands, landmarks_background, robot_map, sight_overlay
from pfcourse.figures.widgets import (
    control_panel,
    particle_slider,
    scale_slider,
    scheme_dropdown,
    seed_box,
    threshold_slider,
)

use_style()

# %% [markdown]
# ## A simulated run
#
# One seeded run: the true path, the odometry path and the landmarks.

# %%
sim = simulate_robot(rng=3)
print(f"{sim.scenario.n_steps} steps, {int(sim.has_measurement.sum())} measurements, "
      f"landmarks observed {np.bincount(sim.landmark_index[sim.has_measurement]).tolist()} times")
drift = np.hypot(*(sim.odometry_path[-1, :2] - sim.truth[-1, :2]))
print(f"odometry after {sim.truth.shape[0] - 1} s: {drift:.1f} m and "
      f"{np.degrees(tracking_errors(sim.truth, sim.odometry_path)[-1, 2]):.1f} deg from the truth")
sc = sim.scenario
step_sd_deg = float(np.degrees(np.sqrt(sc.q_true[2, 2])) * sc.dt)  # heading error of odometry per step
walk_sd_deg = step_sd_deg * float(np.sqrt(sc.n_steps - 1))
print(f"dead-reckoning heading error: a random walk of sd {step_sd_deg:.1f} deg per step, "
      f"sd {walk_sd_deg:.1f} deg after {sc.n_steps - 1} steps")
glue("q_sd_vx", float(np.sqrt(sc.q_true[0, 0])), display=False)
glue("q_sd_vy", float(np.sqrt(sc.q_true[1, 1])), display=False)
glue("q_sd_omega_deg", float(np.degrees(np.sqrt(sc.q_true[2, 2]))), display=False)
glue("r_sd_range", float(np.sqrt(sc.r_true[0, 0])), display=False)
glue("r_sd_bearing_deg", float(np.degrees(np.sqrt(sc.r_true[1, 1]))), display=False)
glue("n_steps", int(sc.n_steps), display=False)
glue("n_landmarks", int(sc.n_landmarks), display=False)
glue("heading_step_sd_deg", step_sd_deg, display=False)
glue("heading_walk_sd_deg", walk_sd_deg, display=False)

# %% [markdown]
# The robot drifts sideways and slowly swings its heading. The heading error of dead
# reckoning is a random walk of standard deviation {glue:text}`heading_step_sd_deg:.0f`° per step
# (about {glue:text}`heading_walk_sd_deg:.0f`° at the end of the run, in distribution), which bends the odometry path away from the truth.
#
# ## Tracking from a good initial guess
#
# The initial cloud is the truth plus Gaussian noise of standard deviations
# ({glue:text}`init_sd_pos:.0f` m, {glue:text}`init_sd_pos:.0f` m, {glue:text}`init_sd_heading:.1f` rad), the filter has $N = 300$ particles and resamples (systematic) when the effective
# sample size drops below $N/2$.

# %%
model = RobotModel.for_simulation(sim)
pf = ParticleFilter(model, 300, threshold=0.5, resampler="systematic")
result = pf.run(sim.measurements, rng=3, store_particles=True)
pos, head = rmse(sim.truth, result.mean)
pos_odo, head_odo = rmse(sim.truth, sim.odometry_path)
print(f"particle filter: position RMSE {pos:.2f} m, heading RMSE {np.degrees(head):.2f} deg")
print(f"odometry alone:  position RMSE {pos_odo:.2f} m, heading RMSE {np.degrees(head_odo):.2f} deg")
print(f"resampled at {result.n_resamples} of {sim.scenario.n_steps} steps")
glue("init_sd_pos", float(INITIAL_STD[0]), display=False)
glue("init_sd_heading", float(INITIAL_STD[2]), display=False)

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 5))
robot_map(sim, {"particle filter": result.mean}, ax=axes[0])
axes[0].set_title("The whole run")
robot_map(sim, {"particle filter": result.mean}, ax=axes[1])
axes[1].set_xlim(sim.truth[:, 0].min() - 8, sim.truth[:, 0].max() + 8)
axes[1].set_ylim(sim.truth[:, 1].min() - 3, sim.truth[:, 1].max() + 3)
axes[1].set_title("Zoom on the path")
axes[1].get_legend().remove()
plt.tight_layout()
plt.show()

# %% [markdown]
# At the scale of the map, the estimated path lies on the true one while odometry wanders
# off. The animation below follows the robot with a window of $\pm 2$ m: the cloud, each
# particle's marker sized by its weight, the posterior mean and the landmark seen at that
# step. Drag the slider to scrub through time.

# %%
frames = list(range(0, 15)) + list(range(100, 1000, 100))
anim = animate_clouds({"PF": result}, None, sim.truth, frames, None, 250, follow=2.0, ellipses=False,
                      max_points=3000, trail=True, background=landmarks_background(sim),
                      overlay=sight_overlay(sim), title=lambda name, k, res: f"t = {k * sim.scenario.dt:.0f} s",
                      legend=True)
HTML(anim.to_jshtml())

# %% [markdown]
# In the first steps the cloud shrinks from its initial spread (standard deviation
# {glue:text}`init_sd_pos:.0f` m per coordinate) as the range and bearing measurements from
# different landmarks cut it down, to about {glue:text}`tracking_sd:.2f` m (printed below; its
# larger standard deviation in $x$ and $y$ is within twice that from
# $t$ = {glue:text}`tracking_settled_s:.0f` s). Afterwards, in this run, it stays about that size
# (10-90 % range {glue:text}`tracking_sd_q10:.2f` to {glue:text}`tracking_sd_q90:.2f` m after
# $t = 50$ s): odometry noise spreads it at each step, each measurement trims it back.
#
# ### Is the filter's uncertainty honest?
#
# The filter does not only give an estimate: its weighted covariance says how far off it
# believes it is. The figure plots the error per coordinate against the filter's own
# $\pm 3\sigma$ band (heading error wrapped).

# %%
error_bands(sim, result.mean, result.cov, label="particle filter error")
plt.suptitle("Error and ±3σ band of the particle filter (one run, N = 300)")
plt.tight_layout()
plt.show()
err = tracking_errors(sim.truth, result.mean)
sig = np.sqrt(np.diagonal(result.cov, axis1=1, axis2=2))
inside = np.mean(np.abs(err) <= 3 * sig, axis=0)
print("fraction of steps inside ±3σ (x, y, heading):", np.round(inside, 3))
run_nees = nees(sim.truth, result.mean, result.cov, model.angle_indices)
print(f"time-averaged NEES {run_nees.mean():.2f} (3 if the covariance were exactly right)")
print("filter's standard deviation of x and y (m), at t = 0:", np.round(sig[0, :2], 2),
      " median after t = 50 s:", np.round(np.median(sig[50:, :2], axis=0), 2))
glue("tracking_sd", float(np.median(sig[50:, :2])), display=False)
# "shrinks in the first steps, then stays about that size": when the sd of x and y first falls within twice its
# later median, and its 10-90 % range after t = 50 s (this one run)
sd_xy = np.max(sig[:, :2], axis=1)
settled = int(np.argmax(sd_xy <= 2 * np.median(sig[50:, :2]))) * sim.scenario.dt
print(f"larger sd of x and y within twice its median after t = 50 s from t = {settled:.0f} s; after t = 50 s "
      f"its 10-90 % range is {np.quantile(sd_xy[50:], 0.1):.2f} to {np.quantile(sd_xy[50:], 0.9):.2f} m")
glue("tracking_settled_s", float(settled), display=False)
glue("tracking_sd_q10", float(np.quantile(sd_xy[50:], 0.1)), display=False)
glue("tracking_sd_q90", float(np.quantile(sd_xy[50:], 0.9)), display=False)
glue("inside_min", float(inside.min()), display=False)
glue("run_nees", float(run_nees.mean()), display=False)

# %% [markdown]
# In this run the error stays inside the band at {glue:text}`inside_min:.0%` of the steps in
# every coordinate (fractions printed above). The
# time-averaged normalised error (NEES, $e_k^\top P_k^{-1} e_k$, which averages to the state
# dimension $3$ for a consistent filter) is {glue:text}`run_nees:.2f`. A value below $3$ is expected here: the filter assumes twice the
# true noise variances, so it is cautious. The next chapter checks this over many runs.
#
# ### The weights
#
# A weight histogram shows how many particles really carry the estimate. Here it is at the
# step with the smallest effective sample size of the run, just before resampling, and at
# a typical step.

# %%
k_worst = int(np.argmin(result.ess[1:])) + 1
k_typical = int(np.argsort(result.ess[1:])[len(result.ess) // 2]) + 1
fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), sharey=True)
for ax, k in zip(axes, (k_worst, k_typical)):
    ax.hist(result.weights[k] * 300, bins=40, color=COLORS["particles"])
    ax.set_xlabel("N × weight (1 = uniform)")
    ax.set_title(f"t = {k} s, ESS = {result.ess[k]:.0f} of 300")
axes[0].set_ylabel("number of particles")
plt.tight_layout()
plt.show()
print(f"median ESS over the run: {np.median(result.ess[1:]):.0f}; smallest: {result.ess[k_worst]:.0f} (t = {k_worst} s)")
meas_sd = np.sqrt(np.diag(model.r_est))
proc_sd = np.sqrt(np.diag(model.q_est))
print(f"filter's standard deviations: measurement {meas_sd[0]:.2f} m and {np.degrees(meas_sd[1]):.2f} deg, "
      f"odometry {proc_sd[0]:.3f} m/s and {np.degrees(proc_sd[2]):.2f} deg/s")
glue("ess_worst", float(result.ess[k_worst]), display=False)
glue("ess_median", float(np.median(result.ess[1:])), display=False)
glue("filter_r_sd_range", float(meas_sd[0]), display=False)
glue("filter_r_sd_bearing_deg", float(np.degrees(meas_sd[1])), display=False)
glue("filter_q_sd_m", float(proc_sd[0] * sim.scenario.dt), display=False)
glue("filter_q_sd_deg", float(np.degrees(proc_sd[2]) * sim.scenario.dt), display=False)

# %% [markdown]
# Even at the worst step the effective sample size is {glue:text}`ess_worst:.0f`, and at a typical step
# about half of the cloud counts (median ESS {glue:text}`ess_median:.0f` of $300$): one measurement of
# {glue:text}`filter_r_sd_range:.1f` m and {glue:text}`filter_r_sd_bearing_deg:.1f`° (the filter's standard
# deviations) against a cloud with a standard deviation of {glue:text}`tracking_sd:.2f` m does not kill many particles.
#
# ## Global localization: starting from nowhere
#
# Now the robot is switched on anywhere on the map: the initial cloud is uniform over the
# $120 \times 120$ m square and over all headings. A single range-bearing measurement says
# "you are on a circle around landmark $j$, facing a direction tied to where you are on that
# circle": a ring in $(p_x, p_y, \theta)$, nothing like one Gaussian. An extended or
# unscented Kalman filter has one mean and one covariance and cannot even represent that
# prior; the particle filter just needs enough particles.

# %%
sim_g = simulate_robot(rng=5, n_steps=30)
model_g = RobotModel.for_simulation(sim_g, initial="uniform")
res_g = ParticleFilter(model_g, 20000).run(sim_g.measurements, rng=5, store_particles=True)
snap = [0, 1, 2, 3, 10, 29]
fig, axes = plt.subplots(2, 3, figsize=(10.5, 7.2), sharex=True, sharey=True)
for ax, k in zip(axes.flat, snap):
    w = res_g.weights[k]
    alive = w > w.max() / 100
    ax.scatter(res_g.particles[k, :3000, 0], res_g.particles[k, :3000, 1], s=1, color="0.75")
    ax.scatter(res_g.particles[k, alive, 0], res_g.particles[k, alive, 1], s=6, color=COLORS["particles"])
    ax.plot(sim_g.landmarks[:, 0], sim_g.landmarks[:, 1], "*k", ms=10)
    ax.plot(*sim_g.truth[k, :2], "o", color=COLORS["truth"], mfc="none", ms=12, mew=2)
    ax.plot(*res_g.mean[k, :2], "x", color=COLORS["estimate"], ms=10, mew=2)
    j = sim_g.landmark_index[k]
    ax.set_title(f"t = {k} s" + (f", sees L{j}" if j >= 0 else ", no measurement"), fontsize=10)
    ax.set_aspect("equal")
for ax in axes[-1]:
    ax.set_xlabel("x (m)")
for ax in axes[:, 0]:
    ax.set_ylabel("y (m)")
fig.suptitle("Uniform start, N = 20 000. Grey: 3000 of the particles; orange: particles with at least "
             "1 % of the largest weight;\ncircle: truth; x: posterior mean", fontsize=10)
plt.tight_layout()
plt.show()
for k in snap:
    e = tracking_errors(sim_g.truth[k:k + 1], res_g.mean[k:k + 1])[0]
    n_alive = int(np.sum(res_g.weights[k] > res_g.weights[k].max() / 100))
    print(f"t = {k:2d} s: {n_alive:5d} particles within 1 % of the best, ESS {res_g.ess[k]:7.0f}, "
          f"mean {np.hypot(e[0], e[1]):5.1f} m and {abs(np.degrees(e[2])):5.1f} deg from the truth")

# %% [markdown]
# Before any measurement every particle is as good as any other and the mean is the centre
# of the map. The first measurement keeps only the particles whose range to the observed
# landmark *and* whose heading match it: they lie along a ring around that landmark, a
# posterior with no single peak, whose mean (the cross) is tens of metres from the truth
# and from every particle that matters. This is where one Gaussian is not an approximate
# summary but a wrong one, and where an extended or unscented Kalman filter has nothing to
# offer. A measurement of another landmark intersects the rings; once only one cluster
# survives, the mean falls near the truth. Scrub through the same run (all $20\,000$ particles
# would be a heavy figure: the animation draws the first $3000$, marker area proportional
# to weight):

# %%
anim_g = animate_clouds({"PF": res_g}, None, sim_g.truth, list(range(0, 12)) + [15, 20, 25, 29],
                        (-sim_g.scenario.half_width, sim_g.scenario.half_width), 400, ellipses=False, max_points=3000, trail=True,
                        background=landmarks_background(sim_g), overlay=sight_overlay(sim_g),
                        title=lambda name, k, res: f"t = {k * sim_g.scenario.dt:.0f} s", legend=True)
HTML(anim_g.to_jshtml())

# %% [markdown]
# ### How many particles does it take?
#
# Locking on is a matter of luck: some particles must start close enough to the truth, in
# position *and* heading, to survive the first measurements. We call a run *locked on* if,
# after $30$ s, the posterior mean is within $1$ m and $5°$ of the truth, and count successes over
# {glue:text}`lock_runs:d` seeded runs for each $N$ (the same {glue:text}`lock_runs:d` simulated runs for every $N$).

# %%
n_values = [1000, 3000, 10000, 30000]
seeds = range(12)
runs = [[global_localization_run(s, n, n_steps=30) for s in seeds] for n in n_values]
success = np.array([[r.locked_on for r in row] for row in runs])
rate = success.mean(axis=1)
# Wilson 95 % interval of a binomial proportion
z, m = 1.96, len(seeds)
centre = (rate + z**2 / (2 * m)) / (1 + z**2 / m)
half = z * np.sqrt(rate * (1 - rate) / m + z**2 / (4 * m**2)) / (1 + z**2 / m)
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.errorbar(n_values, rate, yerr=[rate - (centre - half), centre + half - rate], fmt="o-",
            color=COLORS["estimate"], capsize=4)
ax.set_xscale("log")
ax.set_xlabel("number of particles N")
ax.set_ylabel("fraction of runs locked on")
ax.set_ylim(-0.05, 1.05)
ax.set_title(f"Global localization: success over {m} seeded runs (95 % Wilson intervals)")
plt.show()
missed_error, missed_sd = [], []
for n, row, ok in zip(n_values, runs, success):
    missed = [r for r in row if not r.locked_on]
    line = f"N = {n:6d}: locked on in {ok.sum():2d} of {m} runs"
    if missed:
        missed_error.append(np.median([r.position_error for r in missed]))
        missed_sd.append(np.median([r.position_sd for r in missed]))
        line += f"; the others end a median {missed_error[-1]:.1f} m off while claiming sd {missed_sd[-1]:.2f} m"
    print(line)
trend = evidence.paired_rates(success[-1], success[0])
print(f"N = {n_values[-1]} against N = {n_values[0]}, same runs:", trend)
glue("lock_runs", m, display=False)
glue("lock_n_low", n_values[0], display=False)
glue("lock_n_mid", n_values[1], display=False)
glue("lock_n_high", n_values[-1], display=False)
glue("lock_k_low", int(success[0].sum()), display=False)
glue("lock_k_mid", int(success[1].sum()), display=False)
glue("lock_k_high", int(success[-1].sum()), display=False)
glue("lock_only_high", trend.only_a, display=False)
glue("lock_only_low", trend.only_b, display=False)
glue("lock_p", trend.pvalue, display=False)
glue("missed_error_min", float(min(missed_error)), display=False)
glue("missed_sd_max", float(max(missed_sd)), display=False)

# %% [markdown]
# With a few thousand particles global localization mostly fails: it locks on in
# {glue:text}`lock_k_low:d` of {glue:text}`lock_runs:d` runs at $N$ = {glue:text}`lock_n_low:d` and
# {glue:text}`lock_k_mid:d` at $N$ = {glue:text}`lock_n_mid:d`, against {glue:text}`lock_k_high:d` at
# $N$ = {glue:text}`lock_n_high:d`. On the same runs, {glue:text}`lock_only_high:d` lock on only with
# the most particles and {glue:text}`lock_only_low:d` only with the fewest (exact McNemar p =
# {glue:text}`lock_p:.2f`): with {glue:text}`lock_runs:d` runs the intervals are wide and the rise is
# suggestive, not established at the $5\,\%$ level; read the curve as an order of magnitude. The
# next chapter's study of the bootstrap filter on $100$ runs settles it: a share
# {glue:text}`global_localization.ipynb::boot30k_rate:.2f` locks on with $N = 30\,000$, against
# {glue:text}`global_localization.ipynb::bootstrap_lock_on_rate:.2f` with $N$ =
# {glue:text}`global_localization.ipynb::best_n:d`. The failures
# are instructive: the printed lines show that a filter that
# missed ends {glue:text}`missed_error_min:.1f` m or more from the truth (medians per $N$) *while its
# own standard deviation is at most {glue:text}`missed_sd_max:.2f` m*. After the first two or three
# measurements the weight sits on a handful of
# particles; resampling copies them, and the transition spreads the copies by only
# {glue:text}`filter_q_sd_m:.2f` m per step, so a cluster that settled a few metres from the truth stays there, confidently
# wrong. This is sample impoverishment. More particles help slowly; drawing particles from the
# poses the reading allows, with the right weights, helps far more: the next chapter,
# {doc}`global_localization`, measures it and the other classical remedies.
#
# ## Try it yourself
#
# The panel runs the particle filter on a $400$-step run with your settings (tracking from
# the good initial guess) and plots the position error with its ±3σ band. `Q scale` and
# `R scale` multiply $Q_\text{true}$ and $R_\text{true}$ in the filter ($2$ and $2$ by default),
# `dt_meas` is the time between measurements, `gap` removes the measurements between $250$ s
# and $350$ s.

# %%
def draw(n_particles=300, q_scale=2.0, r_scale=2.0, threshold=0.5, scheme="systematic",
         dt_meas=1, gap=False, landmarks=5, seed=0, axes=None):
    s = simulate_robot(rng=seed, n_steps=400, dt_meas=float(dt_meas),
                       gap=(250.0, 350.0) if gap else None, n_landmarks=landmarks)
    m = RobotModel.for_simulation(s, q_scale=q_scale, r_scale=r_scale)
    if axes is None:  # fixed margins: tight_layout would cost a fifth of a widget update
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [1, 2]})
        fig.subplots_adjust(left=0.065, right=0.99, bottom=0.14, top=0.91, wspace=0.22)
    try:
        r = ParticleFilter(m, n_particles, threshold=threshold, resampler=scheme).run(s.measurements, seed)
    except DegenerateWeightsError as exc:  # every particle lost: say so instead of failing
        axes[1].text(0.5, 0.5, f"filter lost track at step {exc.step}", ha="center", transform=axes[1].transAxes)
        return
    e = tracking_errors(s.truth, r.mean)
    sd = np.sqrt(r.cov[:, 0, 0] + r.cov[:, 1, 1])
    t = np.arange(400.0)
    robot_map(s, {"particle filter": r.mean}, ax=axes[0], odometry=True, legend=False)
    axes[0].set_xlim(s.truth[:, 0].min() - 6, s.truth[:, 0].max() + 6)
    axes[0].set_ylim(s.truth[:, 1].min() - 3, s.truth[:, 1].max() + 3)
    axes[0].set_title("paths (black: truth, dashed: odometry)", fontsize=9)
    axes[0].yaxis.set_major_locator(MaxNLocator(5))  # fewer tick labels: cheaper to redraw
    axes[1].fill_between(t, 0, 3 * sd, color=COLORS["estimate"], alpha=0.2, lw=0, label="3 σ (position)")
    axes[1].plot(t, np.hypot(e[:, 0], e[:, 1]), color=COLORS["estimate"], lw=0.8, label="position error")
    if gap:
        axes[1].axvspan(250, 350, color="0.85", label="no measurements")
    p, h = rmse(s.truth, r.mean)
    axes[1].set_title(f"RMSE {p:.2f} m, {np.degrees(h):.2f} deg; {r.n_resamples} resamplings")
    axes[1].set_xlabel("time (s)")
    axes[1].set_ylabel("position error (m)")
    axes[1].xaxis.set_major_locator(MultipleLocator(100))
    plain_log_axis(axes[1], "y")
    axes[1].legend(loc="upper right")


# %% tags=["nbval-ignore-output"]
panel = control_panel(
    draw,
    grid={"n_particles": (30, 100, 300, 1000), "r_scale": (0.5, 2.0, 8.0)},
    n_particles=particle_slider(300, 1, 3),
    q_scale=scale_slider("Q scale", 2.0),
    r_scale=scale_slider("R scale", 2.0),
    threshold=threshold_slider(0.5),
    scheme=scheme_dropdown("systematic"),
    dt_meas=IntSlider(value=1, min=1, max=20, description="dt_meas (s)"),
    gap=Checkbox(value=False, description="gap 250-350 s"),
    landmarks=IntSlider(value=5, min=1, max=20, description="landmarks"),
    seed=seed_box(0),
)
display(panel)

# %% [markdown]
# Things to try: set `R scale` to $0.5$ (the filter trusts the sensor more than it should) and
# watch the error leave its band; set `threshold` to $0$ (no resampling) and see the filter
# degenerate after a few dozen steps; turn on the gap and watch the band grow while the
# robot runs on odometry alone, then collapse at the first measurement after it. Chapter
# studies in Part III repeat each of these over many seeded runs.
#
# ## Exercises
#
# ```{exercise}
# :label: ex-robot-wrap
# A particle has heading $0°$ and the landmark it looks at lies, from the particle, in the
# world direction $179.6°$. What bearing does $h_j$ predict? The robot measures $-179.8°$
# (the noise pushed it across the cut at $\pm 180°$). Compute the bearing innovation with and
# without wrapping, and the log-likelihood term $-\tfrac12 \nu_b^2/\sigma_b^2$ with the filter's
# $\sigma_b = \sqrt 2° \approx 1.41°$ in both cases.
# ```
#
# ```{solution} ex-robot-wrap
# :class: dropdown
# The prediction is $h_b = \operatorname{wrap}(179.6° - 0°) = 179.6°$. Without wrapping the
# innovation is $-179.8° - 179.6° = -359.4°$ and the term is
# $-\tfrac12 (359.4/1.41)^2 \approx -32\,500$: the particle gets weight $e^{-32\,500}$, zero.
# With wrapping, $\nu_b = \operatorname{wrap}(-359.4°) = 0.6°$ and the term is
# $-\tfrac12(0.6/1.41)^2 \approx -0.09$: a well-placed particle keeps its weight. The wrap
# matters exactly for the particles that are right, whenever the landmark is seen behind the
# robot.
# ```
#
# ```{exercise}
# :label: ex-robot-heading-mean
# Two particles of equal weight have headings $179°$ and $-179°$. What do the arithmetic
# mean and the circular mean $\operatorname{atan2}(\sum_i W_i \sin\theta_i, \sum_i W_i\cos\theta_i)$
# give? Check your answer with `pfcourse.angles.circular_mean`.
# ```
#
# ```{solution} ex-robot-heading-mean
# :class: dropdown
# The arithmetic mean is $0°$, pointing the opposite way from both particles. The sines cancel
# and the cosines are both $\cos 179° \approx -0.9998$, so the circular mean is
# $\operatorname{atan2}(0, -0.9998) = 180°$, the right answer (it is returned as $\pi$, since
# angles are wrapped to $(-\pi, \pi]$).
# ```
#
# ```{exercise}
# :label: ex-robot-global
# In the global-localization experiment, estimate the probability that at least one of $N$
# uniform particles lies within $1$ m and $2°$ of the true state. How many particles make that
# probability $1/2$? Compare with the success curve and explain the difference.
# ```
#
# ```{solution} ex-robot-global
# :class: dropdown
# The target region has volume $\pi \times 1^2 \times (4° \times \pi/180) \approx 0.22$ m²·rad
# out of $120^2 \times 2\pi \approx 90\,500$ m²·rad: a fraction $p \approx 2.4\times 10^{-6}$.
# The probability that one of $N$ particles falls in it is $1 - (1-p)^N$, one half for
# $N \approx 0.69/p \approx 290\,000$. The filter locks on with far fewer particles because it
# does not need a particle right at the truth at time $0$: resampling keeps many particles on
# the first rings, and the process noise ({glue:text}`filter_q_sd_m:.2f` m and
# {glue:text}`filter_q_sd_deg:.1f`° per step) lets them slide towards
# the intersection of the later rings.
# ```
