# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Monte Carlo localization of a robot
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** Monte Carlo localization (MCL), the particle filter as robotics teaches it:
# move every particle with the noisy odometry, weight it by a range-bearing reading, resample;
# written in NumPy, then used to track a robot and to find one that starts anywhere on the map.
#
# **You need** {doc}`../part1/sir` (the bootstrap filter, resampling when the ESS is low);
# sines and cosines of a heading; NumPy arrays.
#
# **Time:** about nineteen minutes to read, plus about seventeen minutes for the folded blocks; the exercises are extra.
# :::
#
# A wheeled robot knows its map, five landmarks at known positions, but not where it is. Its
# wheels tell it how it moved (*odometry*), with an error; a sensor measures the range and the
# bearing of one landmark at a time, and knows which one. This is the classic setting of Monte
# Carlo localization {cite:p}`thrun2005`.
#
# ## The model
#
# The state is the pose $x_k = (x, y, \theta)$: position (m) and heading (rad). In the robot's
# frame the command is $u = (v_x, v_y, \omega)$, two speeds and a turn rate; over a step
# $\Delta t$ the robot moves by
#
# $$
# f(x, u) = \begin{pmatrix} x + (v_x\cos\theta - v_y \sin\theta)\,\Delta t \\
#  y + (v_x \sin\theta + v_y\cos\theta)\,\Delta t \\
#  \operatorname{wrap}(\theta + \omega\,\Delta t) \end{pmatrix},
# $$
#
# where $\operatorname{wrap}$ maps an angle to $(-\pi, \pi]$. The odometry $u_k$ is the true
# command read with an error $e_k \sim \mathcal N(0, Q)$, so the truth moves as
# $x_k = f(x_{k-1}, u_k - e_k)$. Integrating $u_k$ alone is *dead reckoning*. The filter's
# transition puts the error back as noise:
#
# $$
# x_k = f(x_{k-1}, u_k + w_k), \qquad w_k \sim \mathcal N(0, Q_\text{est}).
# $$
#
# At a measurement step the robot sees landmark $j$, at position $l^j$, and measures
#
# $$
# z_k = h_j(x_k) + v_k, \quad h_j(x) = \begin{pmatrix} \lVert l^j - (x, y) \rVert \\
# \operatorname{wrap}\big(\operatorname{atan2}(l^j_y - y,\ l^j_x - x) - \theta\big)\end{pmatrix},
# \quad v_k \sim \mathcal N(0, R),
# $$
#
# with $R = \operatorname{diag}(\sigma_r^2, \sigma_b^2)$: range and bearing errors. The
# settings: $\Delta t = 1$ s, {glue:text}`n_steps:d` steps, {glue:text}`n_landmarks:d` landmarks
# drawn uniformly in $[-60, 60]^2$ m, one of them seen every second; the filter assumes twice
# the true variances, $Q_\text{est} = 2Q$ and $R_\text{est} = 2R$. The evidence block lists
# the standard deviations.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display
from ipywidgets import Checkbox, IntSlider
from matplotlib.ticker import MaxNLocator, MultipleLocator
from scipy.special import logsumexp

from pfcourse import evidence
from pfcourse.angles import wrap_angle
from pfcourse.checks import as_generator
from pfcourse.diagnostics import nees
from pfcourse.errors import DegenerateWeightsError
from pfcourse.book.exercises import check_velocity_motion
from pfcourse.studies.registry import STUDIES
from pfcourse.studies.robot import global_localization_run
from pfcourse.book.figures.clouds import animate_clouds
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import (control_panel, particle_slider, scale_slider, scheme_dropdown, seed_box,
                                      threshold_slider)
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.seeding import run_filter_seed
from pfcourse.metrics import LOCK_WINDOW_S, heading_error, locked_on, position_error, position_spread
from pfcourse.book.figures.robot import error_bands, landmarks_background, robot_map, sight_overlay
from pfcourse.scenarios.robot.scenario import INITIAL_STD, RobotModel, motion, simulate_robot, tracking_errors, tracking_rmse
from pfcourse.book.style import COLORS, plain_log_axis, use_style

use_style()
sim = simulate_robot(rng=3)
sc = sim.scenario
model = RobotModel.for_simulation(sim)
glue_values(n_steps=int(sc.n_steps), n_landmarks=int(sc.n_landmarks), init_sd_pos=float(INITIAL_STD[0]),
            init_sd_heading=float(INITIAL_STD[2]))
sd = {"odometry, forward (m/s)": np.sqrt(sc.q_true[0, 0]), "odometry, sideways (m/s)": np.sqrt(sc.q_true[1, 1]),
      "odometry, turn rate (deg/s)": np.degrees(np.sqrt(sc.q_true[2, 2])), "range (m)": np.sqrt(sc.r_true[0, 0]),
      "bearing (deg)": np.degrees(np.sqrt(sc.r_true[1, 1]))}
EvidenceBlock("the lab's noise levels", notes=["The filter assumes twice these variances (standard deviations "
                                               "multiplied by the square root of two)."],
              tables=[("Standard deviations of the errors (simulation)",
                       pd.DataFrame({"error": list(sd), "true sd": list(sd.values()),
                                     "filter's sd": [v * np.sqrt(2) for v in sd.values()]}),
                       {"true sd": ".3g", "filter's sd": ".3g"})])

# %% [markdown]
# ## The idea: Monte Carlo localization
#
# MCL is the bootstrap particle filter of {doc}`../part1/sir` in robot terms. Each particle
# $x_k^i$ is a guess of the pose. The proposal is the motion model: every particle moves with
# the odometry plus its own draw of the noise, so the cloud spreads as the robot's uncertainty
# grows. A reading then weights each particle by how well it explains what the robot saw,
# $p(z_k \mid x_k^i) = \mathcal N(\nu_k^i; 0, R_\text{est})$, with the *innovation*
# $\nu_k^i = \big(z_r - h_r(x_k^i),\ \operatorname{wrap}(z_b - h_b(x_k^i))\big)$. The wrap matters:
# a measured bearing of $179°$ and a predicted one of $-179°$ are $2°$ apart, not $358°$, and
# without it the particles nearest the truth would lose their weight (Exercise 11.1).
#
# :::{admonition} Algorithm 11.1: Monte Carlo localization
# :class: algorithm
# 1. **Initialise.** Draw $x_0^i \sim p(x_0)$ for $i = 1, \dots, N$; set $\log W_0^i = -\log N$.
# 2. **For** $k = 1, 2, \dots$:
#    1. *sample the motion model:* $x_k^i = f(x_{k-1}^i, u_k + w_k^i)$, $w_k^i \sim \mathcal N(0, Q_\text{est})$;
#    2. *weight:* if landmark $j$ is measured,
#       $\log \tilde w_k^i = \log W_{k-1}^i + \log \mathcal N(\nu_k^i; 0, R_\text{est})$;
#    3. *normalise:* $\log W_k^i = \log \tilde w_k^i - \operatorname{logsumexp}_l \log \tilde w_k^l$;
#       estimate $\hat m_k = \sum_i W_k^i x_k^i$ (a circular mean for $\theta$);
#    4. *resample* if $\mathrm{ESS}_k = 1/\sum_i (W_k^i)^2 < \tau N$: draw ancestors $a_k^i$ with
#       probabilities $W_k^{a}$ (systematic), set $x_k^i \leftarrow x_k^{a_k^i}$ and $W_k^i = 1/N$.
# :::
#
# Table 8.2 of {cite:t}`thrun2005` is this loop with resampling at every step and linear weights;
# here the weights live in the log domain and resampling waits for the ESS to fall below
# $\tau N$, as everywhere in this book.

# %% [markdown]
# The data of one run come from one helper, as plain arrays: the odometry $u_k$ (one row per
# second), the readings $(j, z_r, z_b)$ (NaN when no landmark is seen), the landmarks and the
# true path. The filter's noise is twice the simulator's.

# %%
from pfcourse.scenarios.robot.scenario import simulate_robot
import matplotlib.pyplot as plt
import numpy as np
from scipy.special import logsumexp

sim = simulate_robot(rng=3)
# the filter's covariances: twice the true ones
Q_est, R_est = 2 * sim.scenario.q_true, 2 * sim.scenario.r_true
# the initial cloud: the true start plus noise of 1 m, 1 m and 0.1 rad
x0_sd = np.array([1.0, 1.0, 0.1])
print(sim.odometry.shape, sim.measurements.shape, sim.landmarks.shape)

# %% [markdown]
# In NumPy, Algorithm 11.1 is the loop below, with one helper for angles. Row $0$ of the data is
# the start, with no move and no reading (`sim.measurements[0]` is NaN), hence `if k > 0`:


# %%
def wrap(a):
    """Angles mapped to (-pi, pi]."""
    return a - 2 * np.pi * np.ceil((a - np.pi) / (2 * np.pi))


def mcl(odometry, readings, landmarks, Q_est, R_est, x0, x0_sd, n, tau, rng):
    """Algorithm 11.1 with dt = 1 s; returns the (K, 3) posterior means."""
    # the lab's Q is diagonal: one sd per command
    q_sd = np.sqrt(np.diag(Q_est))
    R_inv = np.linalg.inv(R_est)
    log_norm = -np.log(2 * np.pi) - 0.5 * np.linalg.slogdet(R_est)[1]
    x = x0 + x0_sd * rng.standard_normal((n, 3))
    x[:, 2] = wrap(x[:, 2])
    log_W = np.full(n, -np.log(n))
    means = []
    for k, (u, z) in enumerate(zip(odometry, readings)):
        if k > 0:
            # 1. move: the odometry plus noise, then f
            v = u + q_sd * rng.standard_normal((n, 3))
            c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
            x = np.column_stack([x[:, 0] + v[:, 0] * c - v[:, 1] * s,
                                 x[:, 1] + v[:, 0] * s + v[:, 1] * c,
                                 wrap(x[:, 2] + v[:, 2])])
        if not np.isnan(z[0]):
            # 2. weight by the range and bearing of landmark j
            d = landmarks[int(z[0])] - x[:, :2]
            bearing = np.arctan2(d[:, 1], d[:, 0]) - x[:, 2]
            nu = np.column_stack([z[1] - np.hypot(d[:, 0], d[:, 1]),
                                  wrap(z[2] - bearing)])
            quad = np.einsum("ij,jk,ik->i", nu, R_inv, nu)
            log_W = log_W + log_norm - 0.5 * quad
            # 3. normalise
            log_W = log_W - logsumexp(log_W)
        W = np.exp(log_W)
        heading = np.arctan2(W @ np.sin(x[:, 2]), W @ np.cos(x[:, 2]))
        means.append([W @ x[:, 0], W @ x[:, 1], heading])
        # 4. resample (systematic) when the ESS is low
        if 1.0 / np.sum(W**2) < tau * n:
            u0 = (np.arange(n) + rng.random()) / n
            a = np.searchsorted(np.cumsum(W), u0, side="right")
            x, log_W = x[np.minimum(a, n - 1)], np.full(n, -np.log(n))
    return np.array(means)


# %% [markdown]
# ## Tracking from a good initial guess
#
# The initial cloud is the truth plus Gaussian noise of standard deviations
# {glue:text}`init_sd_pos:.0f` m in each coordinate and {glue:text}`init_sd_heading:.1f` rad in
# heading. Run the loop with $N = 300$ particles and $\tau = 1/2$, and draw the true path, dead
# reckoning and the filter's estimate:

# %%
N, TAU = 300, 0.5
rng = np.random.default_rng(4)
mine = mcl(sim.odometry, sim.measurements, sim.landmarks, Q_est, R_est,
           sim.truth[0], x0_sd, N, TAU, rng)
fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
for ax in axes:
    ax.plot(*sim.landmarks.T, "k*", ms=10, label="landmarks")
    ax.plot(*sim.truth[:, :2].T, "k", lw=3, label="truth")
    ax.plot(*sim.odometry_path[:, :2].T, "--", color="tab:blue",
            label="dead reckoning")
    ax.plot(*mine[:, :2].T, color="tab:red", label="particle filter")
    ax.set(xlabel="x (m)", ylabel="y (m)")
axes[0].set(title="the map", aspect="equal")
axes[1].set(title="zoom on the path", xlim=(-12, 8), ylim=(-52, -24))
axes[0].legend(loc="upper left")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
model = RobotModel.for_simulation(sim)
assert run_filter_seed(3) == 4  # the seed of the visible run
result = ParticleFilter(model, N, threshold=TAU, resampler="systematic").run(
    sim.measurements, rng=run_filter_seed(3))
gap = tracking_errors(result.mean, mine)
ROUND_OFF = 1e-9
assert np.abs(gap).max() < ROUND_OFF
glue_values(mcl_bound=ROUND_OFF)
EvidenceBlock(
    "the NumPy loop is the engine's run",
    notes=[f"Same filter seed (run_filter_seed(3) = 4; the data use 3), same scenario run, N = {N}, "
           f"tau = {TAU}, systematic resampling; the engine resampled at {result.n_resamples} of {len(gap)} "
           "steps. The engine draws its random numbers in the same order: the start, one noise draw per "
           "particle and step, one uniform per resampling.",
           "The remaining differences come from the order of floating-point operations (the engine computes the "
           "weighted mean relative to the first particle, and the range as sqrt(dx^2 + dy^2))."],
    tables=[("Largest absolute difference over the run", pd.DataFrame(
        {"coordinate": ["x (m)", "y (m)", "heading (rad)"],
         "max |engine - NumPy| below 1e-12": np.abs(gap).max(axis=0) < 1e-12}), {})],
)

# %% [markdown]
# The estimate lies on the true path; dead reckoning does not. Over $100$ seeded runs, dead
# reckoning ends a median {glue:text}`dr_final_m:.1f` m
# ({glue:text}`dr_final_low_m:.1f`-{glue:text}`dr_final_high_m:.1f`) from the true position.
#
# The filter, run on the same $100$ simulations, ends a median {glue:text}`pf_final_m:.2f` m from
# it, and closer than dead reckoning in {glue:text}`pf_closer_runs:d` of them.
#
# The package's engine (`ParticleFilter`), which the next chapters call, runs this
# very loop: with the same seed its means agree with these to round-off (below
# {glue:text}`mcl_bound:.0e` m and rad at every step).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def odometry_of(seed):
    """The odometry u_k of simulation `seed` without the rest of the simulation: the true commands plus the
    errors of simulate_robot's odometry stream (the second of the four generators it spawns)."""
    errors = as_generator(seed).spawn(4)[1].standard_normal((sc.n_steps, 3)) * np.sqrt(np.diag(sc.q_true))
    u = sc.true_controls() + errors
    u[0] = 0.0
    return u


DR_RUNS = 100
odo = np.array([odometry_of(s) for s in range(DR_RUNS)])  # (runs, K, 3)
pose = np.tile(sim.truth[0], (DR_RUNS, 1))
for k in range(1, sc.n_steps):  # dead reckoning of every run at once
    pose = motion(pose, odo[:, k], sc.dt)
assert np.array_equal(pose[3], sim.odometry_path[-1])  # the same path as simulate_robot's (seed 3)
final = position_error(sim.truth[-1], pose)  # the true path is the same in every run (fixed commands)
med, low, high = evidence.median_interval(final)
pos_pf, head_pf = tracking_rmse(sim.truth, result.mean)
pos_odo, head_odo = tracking_rmse(sim.truth, sim.odometry_path)
walk_sd = float(np.degrees(np.sqrt(sc.q_true[2, 2])) * sc.dt * np.sqrt(sc.n_steps - 1))
glue_values("dr_", runs=DR_RUNS, final_m=med, final_low_m=low, final_high_m=high)
glue_values(pf_max_error_m=float(position_error(sim.truth, result.mean).max()))
# the filter on the same 100 simulations: a stored study (about a second a run)
dr_study = STUDIES["robot/dead_reckoning"].load().sort_values("seed")
assert np.allclose(dr_study["dr_final_m"].to_numpy(), final)  # the same dead reckoning, run by run
dr_vs_pf = evidence.paired(dr_study["dr_final_m"].to_numpy(), dr_study["pf_final_m"].to_numpy(), ratio=True)
glue_values(pf_final_m=float(dr_study["pf_final_m"].median()),
            pf_closer_runs=int(np.sum(dr_study["pf_final_m"] < dr_study["dr_final_m"])))
EvidenceBlock(
    "dead reckoning drifts, the filter does not",
    notes=[f"Final position error of dead reckoning over {DR_RUNS} seeded runs (seeds 0 to {DR_RUNS - 1}): median "
           f"{med:.2f} m, 95 % bootstrap interval {low:.2f} to {high:.2f} m; 10-90 % range "
           f"{np.quantile(final, 0.1):.2f} to {np.quantile(final, 0.9):.2f} m (see Reading the evidence).",
           f"Why: the heading error of dead reckoning is a random walk of sd {np.degrees(np.sqrt(sc.q_true[2, 2])):.1f} "
           f"deg per step, {walk_sd:.0f} deg after {sc.n_steps - 1} steps (in distribution), which bends the path.",
           f"The run shown (seed 3): particle filter position RMSE {pos_pf:.2f} m and heading RMSE "
           f"{np.degrees(head_pf):.2f} deg; dead reckoning {pos_odo:.2f} m and {np.degrees(head_odo):.2f} deg; "
           f"largest position error of the filter {position_error(sim.truth, result.mean).max():.2f} m. "
           "The next chapter but one compares filters over many runs.",
           f"The filter (N = {N}, threshold {TAU}, systematic) on the same {len(dr_study)} simulations (stored "
           f"study robot/dead_reckoning, book/data/robot/dead_reckoning.csv): final position error median "
           f"{dr_study['pf_final_m'].median():.2f} m, 10-90 % range {dr_study['pf_final_m'].quantile(0.1):.2f} to "
           f"{dr_study['pf_final_m'].quantile(0.9):.2f} m; largest error over a run, worst run "
           f"{dr_study['pf_max_m'].max():.2f} m. Dead reckoning over the filter, final error, paired by run: "
           f"{dr_vs_pf} ({dr_vs_pf.verdict()}; see Reading the evidence)."],
)

# %% [markdown]
# ### Is the filter's uncertainty honest?
#
# The filter gives more than an estimate: its weighted covariance $\hat P_k$ says how far off
# it believes it is. The figure plots the error per coordinate against the filter's own
# $\pm 3\sigma$ band.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
error_bands(sim, result.mean, result.cov, label="particle filter error")
plt.suptitle(f"Error and ±3σ band of the particle filter (one run, N = {N})")
plt.tight_layout()
plt.show()

# %% [markdown]
# In every coordinate the error stays inside the band at every step. The time-averaged
# normalised error, $\text{NEES}_k = e_k^\top \hat P_k^{-1} e_k$, is {glue:text}`run_nees:.2f`; a
# consistent filter would average the state dimension, $3$. If $\hat P_k$ were exactly twice the
# error covariance, as the doubled variances suggest, it would average $3/2$; the Monte Carlo error
# of $300$ particles, which $\hat P_k$ does not fully count, raises it. The filter is cautious.
# {doc}`robot_vs_kalman` checks this over many runs.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
err = tracking_errors(sim.truth, result.mean)
sig = np.sqrt(np.diagonal(result.cov, axis1=1, axis2=2))
inside = np.mean(np.abs(err) <= 3 * sig, axis=0)
assert inside.min() == 1.0, "the prose says: inside the band at every step"
run_nees = nees(sim.truth, result.mean, result.cov, model.angle_indices)
ess = result.ess[1:]
glue_values(inside_min=float(inside.min()), run_nees=float(run_nees.mean()), tracking_sd=float(np.median(sig[50:, :2])),
            ess_median=float(np.median(ess)), ess_worst=float(ess.min()))
EvidenceBlock(
    "the filter's uncertainty is honest, and cautious, in this run",
    notes=[f"Time-averaged NEES {run_nees.mean():.2f} over {len(run_nees)} steps (3 if the covariance were exactly right).",
           f"The filter's standard deviation of x and y: {INITIAL_STD[0]:.0f} m at t = 0, median "
           f"{np.median(sig[50:, :2]):.2f} m after t = 50 s.",
           f"Effective sample size: median {np.median(ess):.0f} of {N} over the run, smallest {ess.min():.0f}; "
           f"{result.n_resamples} resamplings."],
    tables=[("Share of steps with the error inside ±3σ", pd.DataFrame(
        {"coordinate": ["x", "y", "heading"], "share of steps": inside}), {"share of steps": ".3f"})],
)

# %% [markdown]
# ## Starting from nowhere
#
# Now the robot is switched on anywhere: the initial cloud is uniform over the
# $120 \times 120$ m square and over all headings. A single range-bearing reading says "you are
# on a circle around landmark $j$, facing a direction tied to where you are on that circle": a
# ring in $(x, y, \theta)$, nothing like one Gaussian. An extended or unscented Kalman filter,
# with one mean and one covariance, cannot even represent that prior; MCL needs only enough
# particles. The figure runs it with $N = 20\,000$.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
sim_g = simulate_robot(rng=5, n_steps=30)
model_g = RobotModel.for_simulation(sim_g, initial="uniform")
res_g = ParticleFilter(model_g, 20000).run(sim_g.measurements, rng=run_filter_seed(5), collect=[Clouds()])
snap = [0, 1, 2, 3, 10, 29]
fig, axes = plt.subplots(2, 3, figsize=(10.5, 7.2), sharex=True, sharey=True)
for ax, k in zip(axes.flat, snap):
    w = res_g.weights[k]
    alive = w > w.max() / 100
    ax.scatter(res_g.particles[k, :3000, 0], res_g.particles[k, :3000, 1], s=1, color="0.75")
    ax.scatter(res_g.particles[k, alive, 0], res_g.particles[k, alive, 1], s=6, color=COLORS["particles"])
    ax.plot(sim_g.landmarks[:, 0], sim_g.landmarks[:, 1], "*k", ms=10)
    for i, (lx, ly) in enumerate(sim_g.landmarks):
        ax.annotate(f"L{i}", (lx, ly), xytext=(4, 4), textcoords="offset points", fontsize=9)
    ax.plot(*sim_g.truth[k, :2], "o", color=COLORS["truth"], mfc="none", ms=12, mew=2)
    ax.plot(*res_g.mean[k, :2], "x", color=COLORS["estimate"], ms=10, mew=2)
    j = sim_g.landmark_index[k]
    ax.set_title(f"t = {k} s" + (f", sees L{j}" if j >= 0 else ", no measurement"))
    ax.set_aspect("equal")
# the last panel zoomed on the truth: a tight cluster, metres off
ZOOM = 3.0
last, (tx, ty) = axes.flat[-1], sim_g.truth[snap[-1], :2]
# the upper right quarter of the map holds no landmark in this run: the inset goes there
assert not np.any((sim_g.landmarks[:, 0] > 0) & (sim_g.landmarks[:, 1] > 0))
inset = last.inset_axes([0.55, 0.55, 0.43, 0.43])
for spine in inset.spines.values():
    spine.set_visible(True)
k = snap[-1]
inset.scatter(res_g.particles[k, :, 0], res_g.particles[k, :, 1], s=2, color=COLORS["particles"])
inset.plot(tx, ty, "o", color=COLORS["truth"], mfc="none", ms=10, mew=2)
inset.plot(*res_g.mean[k, :2], "x", color=COLORS["estimate"], ms=9, mew=2)
inset.set(xlim=(tx - ZOOM, tx + ZOOM), ylim=(ty - ZOOM, ty + ZOOM), xticks=[], yticks=[], aspect="equal")
last.indicate_inset_zoom(inset, edgecolor="0.3")
for ax in axes[-1]:
    ax.set_xlabel("x (m)")
for ax in axes[:, 0]:
    ax.set_ylabel("y (m)")
fig.suptitle("Uniform start, N = 20 000. Grey: 3000 of the particles; orange: particles with at least "
             f"1 % of the largest weight;\ncircle: truth; x: posterior mean; inset: the {2 * ZOOM:.0f} m square "
             "around the truth at t = 29 s")
plt.tight_layout()
plt.show()

# %% [markdown]
# Before any reading every particle is as good as any other, and the mean is the centre of the
# map. The first reading keeps the particles whose range *and* heading match it: a ring around
# the landmark, a posterior with no single peak, whose mean (the cross) is
# {glue:text}`ring_mean_error_m:.0f` m from the truth, and far from every particle that matters. One Gaussian is not an approximate summary of
# it but a wrong one.
#
# A reading of another landmark intersects the rings, and one cluster survives, but look at it
# closely (the inset). At $t = 2$ s the ESS is {glue:text}`nowhere_ess_t2:.0f`: one particle holds
# all the weight, and resampling copies it. From then on the mean stays
# {glue:text}`nowhere_err_min_m:.1f`-{glue:text}`nowhere_err_max_m:.1f` m from the truth, while the
# filter's own standard deviation is at most {glue:text}`nowhere_sd_max_m:.2f` m. The cloud is
# impoverished and confidently wrong: near the truth on the map's scale, but metres off on the
# scale of its own spread.
# Scrub through the same run (the animation draws the first $3000$ particles, marker area
# proportional to weight):

# %% tags=["remove-input"] jupyter={"source_hidden": true}
snap_rows = []
for k in snap:
    n_alive = int(np.sum(res_g.weights[k] > res_g.weights[k].max() / 100))
    snap_rows.append({"t (s)": k, "particles within 1 % of the best": n_alive, "ESS": res_g.ess[k],
                      "mean's distance from the truth (m)": float(position_error(sim_g.truth[k], res_g.mean[k])),
                      "filter's own sd (m)": float(position_spread(res_g.cov[k:k + 1])[0])})
glue_values(ring_mean_error_m=snap_rows[1]["mean's distance from the truth (m)"])
after = slice(2, None)  # from the second reading on
err_g = position_error(sim_g.truth, res_g.mean)[after]
sd_g = position_spread(res_g.cov)[after]
locked_g = locked_on(position_error(sim_g.truth, res_g.mean), heading_error(sim_g.truth, res_g.mean), sim_g.scenario.dt)
assert not locked_g and err_g.min() > 1.0, "the prose reads this run as a confident miss"
glue_values("nowhere_", ess_t2=float(res_g.ess[2]), err_min_m=float(err_g.min()), err_max_m=float(err_g.max()),
            sd_max_m=float(sd_g.max()))
EvidenceBlock("one Gaussian summarises the ring wrongly, and the cluster that survives is metres off",
              notes=["The run of the figure (data seed 5, filter seed run_filter_seed(5) = 6, N = 20 000), at the times of its panels.",
                     f"From t = 2 s to the end: distance of the mean from the truth {err_g.min():.2f} to {err_g.max():.2f} m, "
                     f"the filter's own position sd sqrt(P_xx + P_yy) {sd_g.min():.2f} to {sd_g.max():.2f} m; "
                     f"locked on by the rule of the next section: {locked_g}."],
              tables=[("The cloud at each panel's time", pd.DataFrame(snap_rows),
                       {"ESS": ".0f", "mean's distance from the truth (m)": ".1f",
                        "filter's own sd (m)": ".2f"})])

# %% tags=["hide-input"] jupyter={"source_hidden": true}
anim_g = animate_clouds({"PF": res_g}, None, sim_g.truth, list(range(0, 12)) + [15, 20, 25, 29],
                        (-sim_g.scenario.half_width, sim_g.scenario.half_width), 400, ellipses=False, max_points=3000,
                        trail=True, background=landmarks_background(sim_g), overlay=sight_overlay(sim_g),
                        title=lambda name, k, res: f"t = {k * sim_g.scenario.dt:.0f} s", legend=True)
HTML(anim_g.to_jshtml())

# %% [markdown]
# ### Does it lock on?
#
# A run is *locked on* when the posterior mean is within $1$ m and $5°$ of the truth at every
# step of the last $20$ s (`pfcourse.metrics.locked_on` with the landmark chapters' strict settings). Here the
# runs last $30$ s, and the same {glue:text}`lock_runs:d` simulated runs are filtered with each $N$:
# a few runs only, since the large clouds are expensive, so the intervals are wide.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
n_values = [1000, 3000, 10000, 30000]
seeds = range(12)
runs = [[global_localization_run(s, n, n_steps=30) for s in seeds] for n in n_values]
success = np.array([[r.locked_on for r in row] for row in runs])
rates = [evidence.rate(row) for row in success]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.errorbar(n_values, [r.estimate for r in rates], yerr=np.abs(np.array([[r.low - r.estimate, r.high - r.estimate]
                                                                        for r in rates]).T),
            fmt="o-", color=COLORS["estimate"], capsize=4)
plain_log_axis(ax, "x")  # ticks at 1000, 3000, 10000, 30000
ax.set_xlabel("number of particles N")
ax.set_ylabel("share of runs locked on")
ax.set_ylim(-0.05, 1.05)
ax.set_title(f"Global localization, {len(seeds)} seeded runs (95 % intervals)")
plt.show()

# %% [markdown]
# The bootstrap filter locks on in {glue:text}`lock_k_high:d` of the runs with $N = 30\,000$ and
# in {glue:text}`lock_k_low:d` with $N = 1000$. The runs that miss end a median
# {glue:text}`lock_missed_error_min:.1f` m or more from the truth (per $N$) *while their own
# standard deviation is at most {glue:text}`lock_missed_sd_max:.2f` m*.
# After the first readings the weight sits on a handful of particles; resampling copies them,
# and the motion noise spreads the copies by only centimetres per step, so a cluster that
# settled a few metres off stays there, confidently wrong. This is *sample impoverishment*.
# More particles help slowly. The cure is to draw some particles from the poses the reading
# allows: {doc}`global_localization` builds it and measures it over a hundred runs.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
trend = evidence.paired_rates(success[-1], success[0])
rows = []
for n, row, r in zip(n_values, runs, rates):
    missed = [x for x in row if not x.locked_on]
    rows.append({"N": n, "locked on": r.successes, "share": r.estimate, "95 % low": r.low, "95 % high": r.high,
                 "median final error of the misses (m)": np.median([x.position_error for x in missed]) if missed else np.nan,
                 "their median own sd (m)": np.median([x.position_sd for x in missed]) if missed else np.nan})
glue_values("lock_", runs=len(seeds), k_low=int(success[0].sum()), k_high=int(success[-1].sum()), p=trend.pvalue,
            missed_error_min=float(np.nanmin([r["median final error of the misses (m)"] for r in rows])),
            missed_sd_max=float(np.nanmax([r["their median own sd (m)"] for r in rows])))
EvidenceBlock(
    "more particles help slowly; the misses are confidently wrong",
    notes=[f"{len(seeds)} simulations (seeds 0 to {len(seeds) - 1}) of 30 s, the same for every N, filter seed = "
           f"simulation seed; locked on: within 1 m and 5 degrees at every step of the last {LOCK_WINDOW_S:.0f} s.",
           f"N = {n_values[-1]} against N = {n_values[0]} on the same runs: {trend} (see Reading the evidence). "
           f"With {len(seeds)} runs the intervals are wide; the next chapter's 100-run study gives the rates.",
           "Own sd: the filter's final position standard deviation sqrt(P_xx + P_yy)."],
    tables=[("Lock-on by number of particles", pd.DataFrame(rows),
             {"share": ".2f", "95 % low": ".2f", "95 % high": ".2f", "median final error of the misses (m)": ".1f",
              "their median own sd (m)": ".2f"})],
)

# %% [markdown]
# ## Try it yourself
#
# The panel runs the filter on a $400$-step run with your settings (tracking from the good
# initial guess) and plots the position error with its ±3σ band. `Q scale` and `R scale`
# multiply $Q$ and $R$ in the filter ($2$ by default), `time between readings (s)` is the period of the
# readings, `gap 250-350 s` removes the readings between $250$ s and $350$ s. Set `R scale` to $0.5$
# and watch the band close in on the error while the filter resamples far more often (the title
# counts the resamplings); set `resampling threshold` to $0$ (never resample) and watch the filter
# degenerate: its band collapses to nothing while the error stays large; turn on the gap and watch
# the band grow on odometry alone, then collapse at the next reading.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw(n_particles=300, q_scale=2.0, r_scale=2.0, threshold=0.5, scheme="systematic",
         dt_meas=1, gap=False, landmarks=5, seed=0, axes=None):
    s = simulate_robot(rng=seed, n_steps=400, dt_meas=float(dt_meas),
                       gap=(250.0, 350.0) if gap else None, n_landmarks=landmarks)
    m = RobotModel.for_simulation(s, q_scale=q_scale, r_scale=r_scale)
    if axes is None:  # fixed margins: tight_layout would cost a fifth of a widget update
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [1, 2]})
        fig.subplots_adjust(left=0.065, right=0.99, bottom=0.14, top=0.91, wspace=0.22)
    try:
        r = ParticleFilter(m, n_particles, threshold=threshold, resampler=scheme).run(s.measurements, run_filter_seed(seed))
    except DegenerateWeightsError as exc:  # every particle lost: say so instead of failing
        axes[1].text(0.5, 0.5, f"filter lost track at step {exc.step}", ha="center", transform=axes[1].transAxes)
        return
    t = np.arange(400.0)
    robot_map(s, {"particle filter": r.mean}, ax=axes[0], odometry=True, legend=False)
    axes[0].set_xlim(s.truth[:, 0].min() - 6, s.truth[:, 0].max() + 6)
    axes[0].set_ylim(s.truth[:, 1].min() - 3, s.truth[:, 1].max() + 3)
    axes[0].set_title("paths (black: truth, dashed: odometry)")
    axes[0].yaxis.set_major_locator(MaxNLocator(5))  # fewer tick labels: cheaper to redraw
    band = 3 * position_spread(r.cov)
    error = position_error(s.truth, r.mean)
    axes[1].fill_between(t, 0, band, color=COLORS["estimate"], alpha=0.2, lw=0, label="3 σ (position)")
    axes[1].plot(t, error, color=COLORS["estimate"], lw=0.8, label="position error")
    if gap:  # behind the band, which grows there
        axes[1].axvspan(250, 350, color="0.85", label="no measurements", zorder=0)
    if band.min() < error.min() / 10:  # a collapsed cloud: its spread falls to round-off, and a log
        axes[1].set_ylim(error.min() / 3, 3 * max(error.max(), band.max()))  # axis over every decade
                                                                           # down to it has no tick
    p, h = tracking_rmse(s.truth, r.mean)
    axes[1].set_title(f"RMSE {p:.2f} m, {np.degrees(h):.2f} deg; {r.n_resamples} resamplings")
    axes[1].set_xlabel("time (s)")
    axes[1].set_ylabel("position error (m)")
    axes[1].xaxis.set_major_locator(MultipleLocator(100))
    plain_log_axis(axes[1], "y")
    axes[1].legend(loc="upper right")


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
panel = control_panel(
    draw,
    grid={"n_particles": (30, 100, 300, 1000), "r_scale": (0.5, 2.0, 8.0)},
    n_particles=particle_slider(300, 1, 3),
    q_scale=scale_slider("Q scale", 2.0),
    r_scale=scale_slider("R scale", 2.0),
    threshold=threshold_slider(0.5),
    scheme=scheme_dropdown("systematic"),
    dt_meas=IntSlider(value=1, min=1, max=20, description="time between readings (s)"),
    gap=Checkbox(value=False, description="gap 250-350 s"),
    landmarks=IntSlider(value=5, min=1, max=20, description="landmarks"),
    seed=seed_box(0),
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 11.1 The bearing wrap
# :label: ex-robot-wrap
# :nonumber:
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
# ```{exercise} 11.2 The mean of two headings
# :label: ex-robot-heading-mean
# :nonumber:
# Two particles of equal weight have headings $179°$ and $-179°$. What do the arithmetic
# mean and the circular mean $\operatorname{atan2}(\sum_i W^i \sin\theta^i, \sum_i W^i\cos\theta^i)$
# give? Check your answer with `pfcourse.angles.circular_mean`.
# ```
#
# ```{solution} ex-robot-heading-mean
# :class: dropdown
# The arithmetic mean is $0°$, pointing the opposite way from both particles. The sines cancel
# and the cosines are both $\cos 179° \approx -0.9998$, so the circular mean is
# $\operatorname{atan2}(0, -0.9998) = 180°$, the right answer (returned as $\pi$, since
# angles are wrapped to $(-\pi, \pi]$).
# ```
#
# ```{exercise} 11.3 How lucky must the start be?
# :label: ex-robot-global
# :nonumber:
# In the global-localization runs, estimate the probability that at least one of $N$
# uniform particles lies within $1$ m and $5°$ of the true pose (the tolerances of the lock-on rule). How many particles make that
# probability $1/2$? Compare with the lock-on study and explain the difference.
# ```
#
# ```{solution} ex-robot-global
# :class: dropdown
# The target region has volume $\pi \times 1^2 \times (10° \times \pi/180) \approx 0.55$ m²·rad
# out of $120^2 \times 2\pi \approx 90\,500$ m²·rad: a fraction $p \approx 6.1\times 10^{-6}$.
# The probability that one of $N$ particles falls in it is $1 - (1-p)^N$, one half for
# $N \approx 0.69/p \approx 114\,000$. The filter locks on with fewer particles ($N = 30\,000$ in
# {glue:text}`lock_k_high:d` of the {glue:text}`lock_runs:d` runs of the study) because it
# does not need a particle right at the truth at time $0$: resampling keeps many particles on
# the first rings, and the motion noise lets them slide towards the intersection of the later
# rings.
# ```
#
# ```{exercise} 11.4 Another motion model, in code
# :label: ex-robot-code
# :nonumber:
# (Coding.) Many robots report a forward speed $v$ and a turn rate $\omega$, and drive along
# an arc rather than the chapter's straight step: a simplified *velocity motion model* (after
# {cite:t}`thrun2005`, table $5.3$, without its final rotation $\gamma$ and with noise of fixed size
# rather than scaled by the motion). Over a step $\Delta t$, with $\theta' = \theta + \omega
# \Delta t$, a pose moves to
#
# $$
# \begin{aligned}
# x' &= x + \tfrac{v}{\omega}\big(\sin\theta' - \sin\theta\big),\\
# y' &= y + \tfrac{v}{\omega}\big(\cos\theta - \cos\theta'\big),
# \end{aligned}
# $$
#
# and $\theta'$ is wrapped to $(-\pi, \pi]$.
#
# Write `my_velocity_motion(x, u, sd, dt, rng)`, the *move* of Algorithm 11.1 for this model: each row of
# `x` (shape `(N, 3)`) draws its own noisy command $(v + s_v e_1,\ \omega + s_\omega e_2)$,
# $e \sim \mathcal N(0, I)$, with `u` $= (v, \omega)$, `sd` $= (s_v, s_\omega)$ (standard
# deviations) and the generator `rng`, then drives along its arc. The checker moves $100\,000$
# copies of one pose and compares the cloud's mean and spread with the model's; it names the
# mistake it sees. Once it passes, put it in `mcl` as the *move* of a robot that reports
# $(v, \omega)$: which other line of the loop must change?
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_velocity_motion


def my_velocity_motion(x, u, sd, dt, rng):
    """Your velocity motion model: the (N, 3) moved cloud."""
    ...  # replace with your code


print(check_velocity_motion(my_velocity_motion))

# %% [markdown]
# ```{solution} ex-robot-code
# :class: dropdown
# One pair of standard normals per particle, the noisy command, then the arc; the code is in
# the folded cell below (in JupyterLab, click its margin to unfold it). In `mcl` only the move
# changes (its noise is the pair $(s_v, s_\omega)$): the weight and the resampling do not
# depend on the motion model.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_velocity_motion(x, u, sd, dt, rng):
    e = rng.standard_normal((len(x), 2))
    v, w = u[0] + sd[0] * e[:, 0], u[1] + sd[1] * e[:, 1]
    th, th_new = x[:, 2], x[:, 2] + w * dt
    return np.column_stack([x[:, 0] + v / w * (np.sin(th_new) - np.sin(th)),
                            x[:, 1] + v / w * (np.cos(th) - np.cos(th_new)),
                            wrap(th_new)])


print(check_velocity_motion(my_velocity_motion))

# %% [markdown]
# ## Takeaways
#
# - Monte Carlo localization is the bootstrap particle filter with the robot's motion model as
#   proposal and the range-bearing likelihood as weight; its loop fits in about twenty lines of
#   NumPy, and the engine runs exactly that loop.
# - Angles need care: wrap the bearing innovation, and average headings with a circular mean.
# - From a good initial guess MCL tracks the robot while dead reckoning drifts metres away, and
#   its covariance is an honest, here cautious, measure of its error.
# - From nowhere, the posterior is a set of rings no Gaussian can represent; the bootstrap
#   filter needs many particles and still locks on wrongly when resampling impoverishes the
#   cloud, which {doc}`global_localization` cures.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab C ({doc}`../labs`) localizes a robot among five landmarks from range-bearing readings. Its
# tracking question (a good initial guess: does the filter follow the robot, and is its
# uncertainty honest?) is answered in "Tracking from a good initial guess"; its global
# localization question is opened in "Starting from nowhere" and answered in
# {doc}`global_localization`.
# :::
