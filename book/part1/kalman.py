# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # The exact answer: the Kalman filter
#
# The previous chapter showed ({ref}`model-densities`) that every filtering density of the
# landmark model is Gaussian and that the Kalman filter computes it exactly. This chapter
# runs it, through `filterpy`, on both variants. Its output, the mean $m_k$ and covariance
# $P_k$ of $p(x_k \mid z_{1:k})$, is the reference that every particle filter of Part I is
# scored against.
#
# At each step the filter predicts with the dynamics, then updates with the rows $H_k$,
# $R_k$ of the landmarks in view (none: no update):
#
# $$
# \begin{aligned}
# m_k^- &= F m_{k-1} + B, & P_k^- &= F P_{k-1} F^\top + Q_w,\\
# S_k &= H_k P_k^- H_k^\top + R_k, & K_k &= P_k^- H_k^\top S_k^{-1},\\
# m_k &= m_k^- + K_k (z_k - H_k m_k^-), & P_k &= (I - K_k H_k) P_k^- .
# \end{aligned}
# $$

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML, display
from matplotlib.animation import FuncAnimation
from matplotlib.ticker import MultipleLocator
from myst_nb import glue
from scipy import stats

from pfcourse.diagnostics import chi2_band, nees
from pfcourse.kalman import kalman_filter
from pfcourse.landmarks.scenario import circle_scenario, quadrant_scenario, simulate
from pfcourse.landmarks.figures import landmark_scene
from pfcourse.style import COLORS, ellipse_patch, use_style
from pfcourse.figures.widgets import control_panel, scale_slider, seed_box

use_style()
LABELS = ["robot x", "robot y", "L1 x", "L1 y", "L2 x", "L2 y"]

# %% [markdown]
# ## Estimates and $3\sigma$ bands on the two-landmark variant

# %%
scenario = quadrant_scenario()
sim = simulate(scenario, rng=2024)
kf = kalman_filter(scenario.model(), sim.measurements)


def plot_estimates(scenario, sim, kf, axes, labels):
    sd = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
    for j, ax in enumerate(axes.flat):
        ax.fill_between(sim.T, kf.mean[:, j] - 3 * sd[:, j], kf.mean[:, j] + 3 * sd[:, j],
                        color=COLORS["kalman"], alpha=0.25, label=r"$\pm 3\sigma$")
        ax.plot(sim.T, sim.truth[:, j], color=COLORS["truth"], lw=1, label="truth")
        ax.plot(sim.T, kf.mean[:, j], color=COLORS["kalman"], lw=1.2, label="Kalman mean")
        ax.set_ylabel(f"{labels[j]} (m)")
    for ax in axes[-1]:
        ax.set_xlabel("time t (s)")
    axes.flat[0].legend(loc="upper right", fontsize=8)


fig, axes = plt.subplots(3, 2, figsize=(9, 6.5), sharex=True)
plot_estimates(scenario, sim, kf, axes, LABELS)
fig.suptitle("Kalman filter, two landmarks (seed 2024)")
plt.show()

# %% [markdown]
# The bands follow the measurements: each landmark's band stays at its prior width
# ($3\sqrt{0.2} \approx 1.3$ m) until the landmark is first seen, then collapses. The robot's
# band narrows too, because seeing a landmark whose position is partly known pins down the
# robot. The numbers, at a few instants:

# %%
sd = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
first_seen = [int(np.argmax(sim.seen[:, j])) for j in range(2)]
print("first seen at steps:", first_seen)
for k in (0, *first_seen, 49):
    print(f"k = {k:2d}: posterior sd (m) =", np.round(sd[k], 3))

# %% [markdown]
# ## What happens to a landmark's uncertainty while it is unseen
#
# Between two sightings, a landmark's own variance does not change at all: its block of $F$ is
# the identity and its process noise is $10^{-20}$, so $P_k^-$ keeps its landmark block. But
# the landmark is *correlated* with the robot (both were estimated from the same relative
# measurements), and the robot keeps moving and getting measured through the other landmark.
# An update that sharpens the robot also sharpens, through the correlation, the landmark
# that is out of view. The figure shows the landmark standard deviations with the steps at
# which each landmark is in view.

# %%
fig, ax = plt.subplots(figsize=(7, 3.5))
for j, c in zip(range(2), ("tab:purple", "tab:brown")):
    ax.semilogy(sim.T, sd[:, 2 + 2 * j], color=c, label=f"sd of L{j + 1} x")
    seen_t = sim.T[sim.seen[:, j]]
    ax.plot(seen_t, np.full(seen_t.shape, 0.5 + 0.1 * j), "|", color=c, ms=8,
            label=f"L{j + 1} in view")
ax.set_xlabel("time t (s)")
ax.set_ylabel("posterior sd (m)")
ax.set_title("Landmark uncertainty shrinks at sightings, stays flat or shrinks in between")
ax.legend(loc="lower left", ncols=2, fontsize=8)
plt.show()

# %%
unseen_steps = ~sim.seen[1:, 0]
change = np.diff(sd[:, 2])[unseen_steps]
print(f"L1 unseen on {unseen_steps.sum()} steps; its sd grew on {np.sum(change > 1e-12)} of them "
      f"and shrank by more than 1e-4 m on {np.sum(change < -1e-4)}")
glue("kalman_l1_unseen_steps", int(unseen_steps.sum()), display=False)
glue("kalman_l1_unseen_shrank", int(np.sum(change < -1e-4)), display=False)

# %% [markdown]
# It never grows (it cannot: no process noise), and it shrinks on some unseen steps, those
# at which the *other* landmark is measured. This is the mechanism of SLAM: correlations
# carry information between the map and the robot.
#
# ## Is it consistent? The NEES over many runs
#
# "The bands contain the truth" is a check by eye. The normalised estimation error squared,
# $\epsilon_k = (x_k - m_k)^\top P_k^{-1}(x_k - m_k)$, is $\chi^2_6$ for an exact filter; its
# average over $R$ runs must stay inside the $\chi^2$ band of the average. Here
# $R$ = {glue:text}`kalman_nees_runs:d`:

# %%
n_runs = 200
eps = np.array([
    nees(s.truth, (r := kalman_filter(scenario.model(), s.measurements)).mean, r.cov)
    for s in (simulate(scenario, rng=seed) for seed in range(n_runs))
])
lo, hi = chi2_band(6, n_runs)
inside = np.mean((eps.mean(axis=0) >= lo) & (eps.mean(axis=0) <= hi))
print(f"average NEES over {n_runs} runs: {eps.mean():.2f} (6 expected); "
      f"inside the 95 % band [{lo:.2f}, {hi:.2f}] at {inside:.0%} of the {eps.shape[1]} steps")
# the steps of a run are correlated: the test takes the run as the unit (its time-averaged NEES)
per_run = eps.mean(axis=1)
ci = stats.bootstrap((per_run,), np.mean, n_resamples=9999, method="percentile",
                     random_state=np.random.default_rng(0)).confidence_interval
t_p = stats.ttest_1samp(per_run, 6.0).pvalue
print(f"time-averaged NEES of a run, mean over the {n_runs} runs: {per_run.mean():.2f} "
      f"(95 % bootstrap interval over runs {ci.low:.2f} to {ci.high:.2f}; t-test against 6: p = {t_p:.2f})")
glue("kalman_nees_runs", n_runs, display=False)
glue("kalman_nees_mean", float(eps.mean()), display=False)
glue("kalman_nees_mean_low", float(ci.low), display=False)
glue("kalman_nees_mean_high", float(ci.high), display=False)
glue("kalman_nees_mean_p", float(t_p), display=False)
glue("kalman_nees_inside", float(inside), display=False)
glue("kalman_nees_steps", int(eps.shape[1]), display=False)

fig, ax = plt.subplots(figsize=(7, 3.2))
ax.plot(sim.T, eps.mean(axis=0), color=COLORS["kalman"], label=f"mean NEES, {n_runs} runs")
ax.fill_between(sim.T, *np.percentile(eps, [10, 90], axis=0), color=COLORS["kalman"], alpha=0.2,
                label="10-90 % of runs")
ax.axhspan(lo, hi, color="gray", alpha=0.3, label="95 % band of the mean")
ax.set_xlabel("time t (s)")
ax.set_ylabel("NEES (dimensionless)")
ax.legend(loc="upper right", fontsize=8)
plt.show()

# %% [markdown]
# The average NEES over all steps and runs is {glue:text}`kalman_nees_mean:.2f` for $6$
# expected. The steps of a run are correlated, so the test takes the run as its unit: the mean
# of the time-averaged NEES of the {glue:text}`kalman_nees_runs:d` runs has a 95 % bootstrap
# interval of {glue:text}`kalman_nees_mean_low:.2f` to {glue:text}`kalman_nees_mean_high:.2f`, which
# contains $6$ ($t$-test $p$ = {glue:text}`kalman_nees_mean_p:.2f`). The mean over runs lies
# inside the band at {glue:text}`kalman_nees_inside:.0%` of the
# {glue:text}`kalman_nees_steps:d` steps, in line with the $95\%$ of an exact filter (each
# step's mean is inside with probability $0.95$; the correlated steps make this share a check
# by eye, not a test). The bands of the first figure are honest.
#
# ## The five-landmark variant
#
# With five landmarks and the triangular field of view, each landmark is seen during a
# passage and then left alone; the robot's uncertainty drops each time a new landmark enters
# the view. The animation shows the 95 % ellipses of the robot and of every landmark as the
# run goes on.

# %%
scenario5 = circle_scenario()
sim5 = simulate(scenario5, rng=2024)
kf5 = kalman_filter(scenario5.model(), sim5.measurements)


def animate_ellipses(scenario, sim, kf, limits, every=2):
    fig, ax = plt.subplots(figsize=(5, 5), dpi=72)
    landmark_scene(scenario, sim, ax=ax, limits=limits)
    patches = []
    title = ax.set_title("")

    def draw(k):
        for p in patches:
            p.remove()
        patches.clear()
        for j in range(1 + scenario.n_landmarks):
            blk = slice(2 * j, 2 * j + 2)
            color = COLORS["robot"] if j == 0 else COLORS["kalman"]
            patches.append(ax.add_patch(ellipse_patch(kf.mean[k, blk], kf.cov[k, blk, blk],
                                                      color=color, lw=1.5)))
        patches.append(ax.plot(*sim.truth[k, :2], "o", color=COLORS["truth"], ms=4)[0])
        title.set_text(f"t = {sim.T[k]:.0f} s: 95 % ellipses (Kalman)")
        return patches

    anim = FuncAnimation(fig, draw, frames=range(0, len(sim.T), every), blit=False)
    plt.close(fig)
    return anim


HTML(animate_ellipses(scenario5, sim5, kf5, (-4.0, 8.0)).to_jshtml())

# %%
sd5 = np.sqrt(np.diagonal(kf5.cov, axis1=1, axis2=2))
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.semilogy(sim5.T, sd5[:, 0], color=COLORS["robot"], lw=2, label="robot x")
for j in range(5):
    ax.semilogy(sim5.T, sd5[:, 2 + 2 * j], lw=1, label=f"L{j + 1} x")
ax.set_xlabel("time t (s)")
ax.set_ylabel("posterior sd (m)")
ax.set_title("Five landmarks: each sd drops when its landmark passes through the view")
ax.legend(ncols=3, fontsize=8)
plt.show()
print("final sd of the landmark x coordinates (m):", np.round(sd5[-1, 2::2], 3))

# %% [markdown]
# ## Try it
#
# The panel re-runs the simulation and the Kalman filter with the measurement noise and the
# robot's process noise scaled (the filter uses the same scaled values as the simulator).
# On the default run (seed $2024$) at the panel's three settings of each scale:

# %%
widths = {}
for scale in (0.3, 1.0, 3.0):
    sc = scenario.with_(Rv=scale**2 * scenario.Rv)  # same trajectory: only the measurement noise changes
    sd = np.sqrt(np.diagonal(kalman_filter(sc.model(), simulate(sc, rng=2024).measurements).cov, axis1=1, axis2=2))
    Qw = scenario.Qw.copy()
    Qw[:2, :2] *= scale**2
    sc = scenario.with_(Qw=Qw)
    s = simulate(sc, rng=2024)
    sd_q = np.sqrt(np.diagonal(kalman_filter(sc.model(), s.measurements).cov, axis1=1, axis2=2))
    unseen = ~s.seen[1:].any(axis=1)  # steps with no landmark in view
    widths[scale] = (float(sd[:, 2:].mean()), float(np.median(np.diff(sd_q[:, 0])[unseen])), int(unseen.sum()))
    print(f"scale {scale}: Rv scaled -> landmark sd {widths[scale][0]:.3f} m (mean over time and "
          f"coordinates); robot Qw scaled -> robot x sd grows by {widths[scale][1]:.4f} m per step "
          f"(median over its {widths[scale][2]} steps without a landmark in view)")
for scale, key in ((0.3, "low"), (1.0, "mid"), (3.0, "high")):
    glue(f"kalman_panel_landmark_sd_{key}", widths[scale][0], display=False)
    glue(f"kalman_panel_robot_growth_{key}", widths[scale][1], display=False)

# %% [markdown]
# Scaling the measurement noise's standard deviation by $0.3$, $1$ and $3$ gives landmark bands
# of mean standard deviation {glue:text}`kalman_panel_landmark_sd_low:.3f`,
# {glue:text}`kalman_panel_landmark_sd_mid:.3f` and {glue:text}`kalman_panel_landmark_sd_high:.3f` m
# (the trajectory is the same, and the Kalman covariance does not depend on the measured
# values, so these are exact for this run); scaling the robot's process noise the same way
# makes the robot band grow by {glue:text}`kalman_panel_robot_growth_low:.4f`,
# {glue:text}`kalman_panel_robot_growth_mid:.4f` and {glue:text}`kalman_panel_robot_growth_high:.4f` m
# per step between sightings (median over the steps with no landmark in view, one run).

# %%
def draw_kalman(noise_scale, process_scale, seed):
    Rv = noise_scale**2 * scenario.Rv
    Qw = scenario.Qw.copy()
    Qw[:2, :2] *= process_scale**2
    sc = scenario.with_(Rv=Rv, Qw=Qw)
    s = simulate(sc, rng=seed)
    r = kalman_filter(sc.model(), s.measurements)
    fig, axes = plt.subplots(3, 2, figsize=(9, 6), sharex=True)
    plot_estimates(sc, s, r, axes, LABELS)
    axes[0, 0].xaxis.set_major_locator(MultipleLocator(25))  # shared by the six axes; fewer ticks redraw faster


# %% tags=["nbval-ignore-output"]
display(control_panel(draw_kalman, grid={"noise_scale": (0.3, 1.0, 3.0), "process_scale": (0.3, 1.0, 3.0)},
                      noise_scale=scale_slider("Rv sd scale"),
                      process_scale=scale_slider("robot Qw sd scale"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-kalman-exact
# Lab question 2 asks why the Kalman filter is exact here. Name the two properties of the
# model the argument uses, and one change of the model that would break it.
# ```
#
# ```{solution} ex-kalman-exact
# :class: dropdown
# Linearity (dynamics and measurements affine in the state) and Gaussian noise, independent
# of the state and of each other. Then prediction and update map Gaussians to Gaussians.
# Measuring the landmarks in range and bearing (nonlinear), or heavy-tailed noise, would
# break it: the posterior would no longer be Gaussian.
# ```
#
# ```{exercise}
# :label: ex-kalman-unseen
# With the numbers printed above, how much did landmark $1$'s standard deviation shrink on the
# steps where it was *not* in view, and why is that not a contradiction?
# ```
#
# ```{solution} ex-kalman-unseen
# :class: dropdown
# It never grew, and it shrank noticeably (by more than $10^{-4}$ m) on
# {glue:text}`kalman_l1_unseen_shrank:d` of its {glue:text}`kalman_l1_unseen_steps:d` unseen steps,
# steps at which landmark $2$ was measured.
# The landmark estimate is correlated with the robot estimate; a measurement of landmark $2$
# sharpens the robot, and through the cross-covariance, landmark $1$.
# ```
#
# ```{exercise}
# :label: ex-kalman-code
# (Coding.) Write the Kalman filter of this chapter in plain NumPy (predict with $F$, $B$,
# $Q_w$; update with the visible rows of $H$ and $R_v$), run it on the simulation above and
# check that its means agree with `kalman_filter(model, sim.measurements).mean` to round-off.
# ```
#
# ````{solution} ex-kalman-code
# :class: dropdown
# ```{code} python
# def my_kalman(Z, model):
#     m, P, means = model.m0.copy(), model.P0.copy(), []
#     for k, z in enumerate(Z):
#         if k > 0:
#             m, P = model.F @ m + model.B, model.F @ P @ model.F.T + model.Q
#         seen = ~np.isnan(z)
#         if seen.any():
#             H, R = model.H[seen], model.R[np.ix_(seen, seen)]
#             S = H @ P @ H.T + R
#             K = P @ H.T @ np.linalg.inv(S)
#             m, P = m + K @ (z[seen] - H @ m), (np.eye(len(m)) - K @ H) @ P
#         means.append(m)
#     return np.array(means)
#
# print(np.abs(my_kalman(sim.measurements, model) - kalman_filter(model, sim.measurements).mean).max())  # ~1e-15
# ```
# ````
