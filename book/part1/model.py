# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Simulating the landmark model
#
# Before filtering anything we need data, and we need to understand exactly how it was
# made: a particle filter is only as right as the model it assumes. This chapter simulates
# the two variants of the linear landmark model used throughout Part I and explains every
# variable the simulator returns.
#
# The set-up: a robot moves in the plane among $M$ landmarks whose positions are unknown
# to it. When a landmark is inside the robot's field of view, the robot measures the
# landmark's position *relative to itself*, $l^j - r$, with a small Gaussian error. It
# must estimate both its own position and the landmarks' positions: a miniature of
# simultaneous localization and mapping (SLAM).

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML
from myst_nb import glue

from pfcourse.landmarks.scenario import circle_scenario, quadrant_scenario, simulate
from pfcourse.landmarks.figures import animate_landmarks, landmark_scene
from pfcourse.style import COLORS, use_style

use_style()

# %% [markdown]
# ## The two-landmark variant
#
# The first variant has two landmarks. At each time step of $\Delta t = 1$ s the robot turns
# by $\omega = \pi/4$ rad about the origin, so it goes round once every $8$ s, perturbed by a
# small random step. A landmark is in view when it lies up and to the right of the robot:
# $l_x - r_x > 0$ and $l_y - r_y > 0$.
#
# The state at step $k$ stacks the robot position and the two landmark positions, all in the
# world frame, in metres:
#
# $$
# x_k = \left(r_{x}, r_{y}, l^1_{x}, l^1_{y}, l^2_{x}, l^2_{y}\right)_k^\top \in \mathbb{R}^6 .
# $$
#
# The scenario object holds the parameters of the simulator.

# %%
scenario = quadrant_scenario()
print("mX0 =", scenario.mX0)
print("diag(PX0) =", np.diag(scenario.PX0))
print("diag(Qw)  =", np.diag(scenario.Qw))
print("diag(Rv)  =", np.diag(scenario.Rv))

# %% [markdown]
# What they mean physically (lab question 1):
#
# - **`mX0`** is the expected initial state: the robot is believed to start near $(2, 0)$ m and
#   the landmarks near $(-1, 4)$ m and $(4, -1)$ m.
# - **`PX0`** is the covariance of the initial state: how far the truth may be from `mX0`.
#   Its diagonal holds variances in m²; a variance of $0.2$ m² is a standard deviation of
#   $\sqrt{0.2} \approx 0.45$ m, so the landmarks are known to within about a metre at the start.
# - **`Qw`** is the covariance of the process noise $w_k$ added at every step: the robot's
#   steps are perturbed by $0.05$ m (standard deviation) per axis, while the landmarks get
#   a variance of $10^{-20}$ m², a standard deviation of $10^{-10}$ m: they do not move.
#   This detail will matter a great deal for the particle filter.
# - **`Rv`** is the covariance of the measurement noise $v_k$: every measured coordinate is
#   off by $0.1$ m (standard deviation).
#
# ## One simulated run (lab question 1)
#
# `simulate` draws the initial state from $\mathcal N(\text{mX0}, \text{PX0})$, moves it with
# the dynamics, and measures the landmarks in view. The seed makes the run reproducible.

# %%
sim = simulate(scenario, rng=2024)
print("T:", sim.T.shape, " truth:", sim.truth.shape, " measurements:", sim.measurements.shape)
print("T[:5]           =", sim.T[:5])
print("truth[1]        =", np.round(sim.truth[1], 3))
print("measurements[1] =", np.round(sim.measurements[1], 3))
glue("model_t_last", float(sim.T[-1]), display=False)

# %% [markdown]
# - **`T`** holds the sampling instants $t_k = k\,\Delta t$, here from $0$ to {glue:text}`model_t_last:.0f` s.
# - **`truth`** holds the true state at each instant, one row per step, one column per state coordinate: what the
#   filter tries to recover and never sees.
# - **`measurements`** holds the measurements, one row per step, four columns: the offset
#   $l^1 - r$ (two coordinates) then $l^2 - r$. A landmark out of view gives NaN
#   ("not a number") in its two columns. The first row is all NaN: the first measurement
#   is taken after the first move.
#
# The figure shows the run in the world frame.

# %%
fig, ax = plt.subplots(figsize=(5.5, 5.5))
landmark_scene(scenario, sim, ax=ax)
ax.set_title("One run of the two-landmark model (50 s)")
ax.legend(loc="lower left")
plt.show()

# %% [markdown]
# The animation replays the run step by step: the shaded region is the field of view,
# a landmark in view is green and the green segment drawn from the robot is its
# measured offset $z^j_k$; a landmark out of view is grey. Press play or scrub the slider.

# %%
HTML(animate_landmarks(scenario, sim).to_jshtml())

# %% [markdown]
# ## What the robot gets to see
#
# The measurements are the only input of every filter in this part, so it is worth seeing
# them as the filter does: a time series with holes.

# %%
fig, axes = plt.subplots(2, 1, figsize=(7, 4.5), sharex=True)
for j, ax in enumerate(axes):
    ax.plot(sim.T, sim.measurements[:, 2 * j], "o-", ms=3, label=r"$l_x - r_x$")
    ax.plot(sim.T, sim.measurements[:, 2 * j + 1], "s-", ms=3, label=r"$l_y - r_y$")
    ax.set_ylabel(f"landmark {j + 1} (m)")
    ax.legend(loc="upper right", ncols=2)
axes[-1].set_xlabel("time t (s)")
axes[0].set_title("Measured offsets; gaps are steps where the landmark is out of view")
plt.show()

# %% [markdown]
# In this run each landmark is seen at some steps and not at others. How often, in general?
# One run cannot say; a few hundred seeded runs can.

# %%
n_runs = 500
seen = np.array([simulate(scenario, rng=seed).seen[1:] for seed in range(n_runs)])
seen_fraction = seen.mean(axis=1)
both = seen.all(axis=2).mean(axis=1)
for j in range(2):
    lo, med, hi = np.percentile(seen_fraction[:, j], [10, 50, 90])
    print(f"landmark {j + 1}: in view at {med:.0%} of steps (10-90 % of runs: {lo:.0%} to {hi:.0%})")
print(f"both at once: {np.median(both):.0%} of steps (median over {n_runs} runs)")
nothing = (~seen.any(axis=2)).mean(axis=1)
never = float(np.mean(nothing == 1.0))
print(f"nothing in view: {np.median(nothing):.0%} of steps (median over runs; 10-90 %: "
      f"{np.percentile(nothing, 10):.0%} to {np.percentile(nothing, 90):.0%}); "
      f"{never:.1%} of the runs never see a landmark")
glue("model_nothing_share", float(np.median(nothing)), display=False)
glue("model_never_share", never, display=False)
glue("model_seen_share_l1", float(np.median(seen_fraction[:, 0])), display=False)
glue("model_seen_share_l2", float(np.median(seen_fraction[:, 1])), display=False)
glue("model_both_share", float(np.median(both)), display=False)
glue("model_visibility_runs", n_runs, display=False)

# %% [markdown]
# So in a typical run each landmark is measured at roughly a third of the steps
# ({glue:text}`model_seen_share_l1:.0%` and {glue:text}`model_seen_share_l2:.0%`, medians over
# {glue:text}`model_visibility_runs:d` runs), and the
# robot sees nothing at all at {glue:text}`model_nothing_share:.0%` of the steps (median over
# runs); {glue:text}`model_never_share:.1%` of the runs never see a landmark. A filter must
# carry its estimate through those gaps using the dynamics alone.
#
# ## The $M$-landmark variant
#
# The second variant has $M = 5$ landmarks spread around a circle. The robot goes round a
# centre $c = (2, 1)$ m once every $40$ s, and its field of view is a triangle pointing along its
# direction of travel ($45^\circ$ either side, $6$ m deep). Turning about a centre other than the
# origin adds a constant term to the dynamics,
#
# $$
# r_k = c + R_\omega (r_{k-1} - c) + w_k = R_\omega r_{k-1} + (I - R_\omega)\,c + w_k ,
# $$
#
# which is the vector $B$ in $x_k = F x_{k-1} + B + w_k$ (zero for the landmarks).

# %%
scenario5 = circle_scenario(n_landmarks=5)
sim5 = simulate(scenario5, rng=2024)
print("B =", np.round(scenario5.B, 3))

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.5), width_ratios=[1, 1.3])
landmark_scene(scenario5, sim5, ax=ax1, limits=(-4.0, 8.0))
ax1.set_title("Five landmarks, triangular field of view")
ax1.legend(loc="lower left", fontsize=8)
ax2.imshow(sim5.seen.T, aspect="auto", interpolation="nearest", cmap="Greens",
           extent=(sim5.T[0] - 0.5, sim5.T[-1] + 0.5, 5.5, 0.5))
ax2.set_yticks(range(1, 6), [f"L{j}" for j in range(1, 6)])
ax2.set_xlabel("time t (s)")
ax2.set_title("Which landmark is in view (green) at each step")
ax2.grid(False)
plt.show()

# %%
HTML(animate_landmarks(scenario5, sim5, limits=(-4.0, 8.0)).to_jshtml())

# %% [markdown]
# Here the set of visible landmarks changes as the robot turns: each landmark comes into
# view, stays for a few steps and leaves. The rows of the measurement matrix that apply at
# step $k$ change with it. We now turn this into the densities $p(x_0)$,
# $p(x_k \mid x_{k-1})$ and $p(z_k \mid x_k)$ that every filter needs.
#
# (model-densities)=
# ## The three densities (lab question 2)
#
# **Initial density.** The simulator draws $x_0 = m_{X0} + L_0 e$ with $L_0 L_0^\top = P_{X0}$
# and $e \sim \mathcal N(0, I)$. An affine map of a Gaussian vector is Gaussian, with mean
# $m_{X0}$ and covariance $L_0 \operatorname{Cov}(e) L_0^\top = P_{X0}$:
#
# $$
# p(x_0) = \mathcal N(x_0;\, m_{X0},\, P_{X0})
# = \frac{1}{\sqrt{(2\pi)^{d} \det P_{X0}}}
#   \exp\!\left(-\tfrac12 (x_0 - m_{X0})^\top P_{X0}^{-1} (x_0 - m_{X0})\right),
# \qquad d = 2 + 2M .
# $$
#
# **Transition density.** Given $x_{k-1}$, the next state $x_k = F x_{k-1} + B + w_k$ is a
# constant plus the Gaussian noise $w_k \sim \mathcal N(0, Q_w)$, independent of the past, so
#
# $$
# p(x_k \mid x_{k-1}) = \mathcal N(x_k;\, F x_{k-1} + B,\, Q_w), \qquad
# F = \begin{pmatrix} R_\omega & 0 \\ 0 & I_{2M} \end{pmatrix}, \quad
# B = \begin{pmatrix} (I - R_\omega)\, c \\ 0 \end{pmatrix},
# $$
#
# with $R_\omega$ the rotation by $\omega\,\Delta t$. The landmark block of $Q_w$ is
# $10^{-20} I$: this density is, for the landmarks, almost a Dirac mass at the previous
# position.
#
# **Measurement density.** Let $V_k \subseteq \{1, \dots, M\}$ be the landmarks in view at
# step $k$. Each one gives $z^j_k = l^j_k - r_k + v^j_k$, that is
# $z^j_k = H^j x_k + v^j_k$ with $H^j = (-I_2, 0, \dots, I_2, \dots, 0)$ ($I_2$ in block
# $j + 1$). Stacking the visible landmarks gives a measurement matrix and a noise covariance
# whose *size changes with time*:
#
# $$
# H_k = \begin{pmatrix} H^{j_1} \\ \vdots \\ H^{j_{|V_k|}} \end{pmatrix} \in \mathbb R^{2|V_k| \times d},
# \qquad R_k = R_v[I_k, I_k] \in \mathbb R^{2|V_k| \times 2|V_k|},
# \qquad
# p(z_k \mid x_k) = \mathcal N(z_k;\, H_k x_k,\, R_k),
# $$
#
# where $I_k = \{2j - 1, 2j : j \in V_k\}$ lists the measurement *coordinates* of the visible
# landmarks ($R_v$ is $2M \times 2M$, indexed by coordinates, not by landmarks) and
# $R_v[I_k, I_k]$ keeps those rows and columns. When nothing is
# in view ($V_k = \emptyset$) there is no measurement and $p(z_k \mid x_k) = 1$: the
# step is a pure prediction. In the code, `sim.measurements[k]` holds NaN for the unseen landmarks, and
# `LinearGaussianModel.observed` extracts $z_k$, $H_k$ and $R_k$ from the non-NaN entries.
#
# A caveat: whether a landmark is visible depends on the true state, so strictly the
# *pattern of NaN* is itself information. The filters here, like the lab's, treat the
# visibility as given (they condition on which landmarks were seen but not on the
# geometry that implies it), which is the standard simplification.
#
# One step of the simulated run above, checked against these formulas:

# %%
from pfcourse.gaussian import gaussian_logpdf

model = scenario.model()
k = int(np.flatnonzero(sim.seen.any(axis=1))[0])
mask, z_k, H_k, R_k = model.observed(sim.measurements[k])
print(f"step {k}: landmarks in view {np.flatnonzero(sim.seen[k]) + 1}")
print("H_k =\n", H_k.astype(int))
print("R_k =\n", R_k)
by_hand = gaussian_logpdf(z_k - H_k @ sim.truth[k], R_k)[0]
print(f"log p(z_k | x_k) at the true state: {by_hand:.4f} (formula), "
      f"{model.log_likelihood(sim.truth[k][None], sim.measurements[k], k)[0]:.4f} (model)")

# %% [markdown]
# ### Why the Kalman filter is exact here
#
# Suppose $p(x_{k-1} \mid z_{1:k-1}) = \mathcal N(m_{k-1}, P_{k-1})$. Then $x_k$ is an affine
# function of the Gaussian pair $(x_{k-1}, w_k)$, so the prediction is Gaussian,
# $\mathcal N(F m_{k-1} + B,\; F P_{k-1} F^\top + Q_w)$. And $(x_k, z_k)$ is jointly Gaussian,
# since $z_k = H_k x_k + v_k$ is affine in $(x_k, v_k)$; conditioning a jointly Gaussian
# vector on some of its components gives a Gaussian whose mean and covariance are the Kalman
# update with the matrices $H_k$, $R_k$ of that step. By induction from $p(x_0)$, every
# filtering density is Gaussian and the Kalman recursions compute its mean and covariance
# *exactly*, for any sequence of visibility patterns: changing $H_k$ and $R_k$ with time
# changes nothing in the argument. This is why, in the rest of Part I, the Kalman filter is
# not "another method" but the **right answer**, against which every particle filter is
# measured.
#
# ## Try it
#
# The panel simulates either variant with the chosen seed and measurement-noise scale
# (a factor on the standard deviations in `Rv`), and draws the world and which landmarks are
# in view at each step.

# %%
import ipywidgets as widgets
from IPython.display import display

from pfcourse.figures.widgets import control_panel, scale_slider, seed_box


def draw_model(variant, noise_scale, seed):
    sc = quadrant_scenario() if variant == "two landmarks" else circle_scenario(5)
    sc = sc.with_(Rv=noise_scale**2 * sc.Rv)
    s = simulate(sc, rng=seed)
    limits = None if variant == "two landmarks" else (-4.0, 8.0)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.2), width_ratios=[1, 1.3])
    landmark_scene(sc, s, ax=a1, limits=limits)
    for j in range(sc.n_landmarks):
        seen = s.seen[:, j]
        a1.plot(s.truth[seen, 0] + s.measurements[seen, 2 * j], s.truth[seen, 1] + s.measurements[seen, 2 * j + 1], ".",
                ms=3, color=COLORS["seen"])
    a1.set_title("robot + measured offsets (dots)")
    a2.imshow(s.seen.T, aspect="auto", interpolation="nearest", cmap="Greens",
              extent=(s.T[0] - 0.5, s.T[-1] + 0.5, sc.n_landmarks + 0.5, 0.5))
    a2.set_yticks(range(1, sc.n_landmarks + 1), [f"L{j}" for j in range(1, sc.n_landmarks + 1)])
    a2.set_xlabel("time t (s)")
    a2.set_title("landmarks in view (green)")
    a2.grid(False)


# %% tags=["nbval-ignore-output"]
display(control_panel(
    draw_model,
    grid={"variant": ("two landmarks", "five landmarks"), "noise_scale": (0.3, 1.0, 3.0), "seed": (2024, 1, 2)},
    variant=widgets.Dropdown(options=["two landmarks", "five landmarks"], description="variant"),
    noise_scale=scale_slider("Rv sd scale"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-model-units
# The landmarks' process-noise variance is $10^{-20}$ m². What standard deviation is that, and
# how far would a landmark drift, in distribution, over the $50$ steps of a run?
# ```
#
# ```{solution} ex-model-units
# :class: dropdown
# The standard deviation per step is $\sqrt{10^{-20}} = 10^{-10}$ m. Independent steps add
# variances, so after $50$ steps the drift has variance $50 \times 10^{-20}$ m² and standard
# deviation $\sqrt{50} \times 10^{-10} \approx 7 \times 10^{-10}$ m: the landmarks are static
# for every practical purpose.
# ```
#
# ```{exercise}
# :label: ex-model-visibility
# In the two-landmark variant, why are the two landmarks rarely in view at the same time?
# Use the initial positions and the field of view.
# ```
#
# ```{solution} ex-model-visibility
# :class: dropdown
# A landmark is in view when it is up and to the right of the robot. Landmark $1$ starts near
# $(-1, 4)$ and landmark $2$ near $(4, -1)$, while the robot circles the origin at a radius of
# about $2$ m. Landmark $1$ is to the right of the robot only when the robot is on the far left of
# its circle, and landmark $2$ is above the robot only when the robot is at the bottom of it;
# both hold only around the lower-left part of the circle, a short arc. The
# {glue:text}`model_visibility_runs:d`-run statistics above put a number on it: both are in view
# at {glue:text}`model_both_share:.0%` of the steps (median over runs).
# ```
#
# ```{exercise}
# :label: ex-model-likelihood
# Write $p(z_k \mid x_k)$ at a step where only landmark $2$ of the two-landmark variant is in
# view: give $H_k$ and $R_k$ explicitly. What is it at a step where no landmark is in view?
# ```
#
# ```{solution} ex-model-likelihood
# :class: dropdown
# $H_k = \begin{pmatrix} -1 & 0 & 0 & 0 & 1 & 0 \\ 0 & -1 & 0 & 0 & 0 & 1 \end{pmatrix}$ and
# $R_k = 0.1^2 I_2$, so $p(z_k \mid x_k) = \mathcal N(z_k;\, l^2_k - r_k,\, 0.01 I_2)$. With no
# landmark in view there is no measurement; the likelihood is the constant $1$, and both the
# Kalman filter and the particle filter only predict.
# ```
#
# ```{exercise}
# :label: ex-model-code
# (Coding.) Write `sees(x)` that returns, for a state $x$ of the two-landmark model, which
# landmarks lie up and to the right of the robot, and check it against `scenario.visible` on
# $1000$ states drawn from the prior.
# ```
#
# ````{solution} ex-model-code
# :class: dropdown
# ```{code} python
# def sees(x):
#     rel = x[..., 2:].reshape(x.shape[:-1] + (2, 2)) - x[..., None, :2]
#     return (rel[..., 0] > 0) & (rel[..., 1] > 0)
#
# xs = scenario.model().sample_initial(1000, np.random.default_rng(0))
# assert np.array_equal(sees(xs), scenario.visible(xs))
# ```
# ````
