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
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** what the linear landmark model of Part I simulates and what each of its
# parameters $m_0$, $P_0$, $Q$, $R$ means physically, and how to write its three densities,
# $p(x_0)$, $p(x_k \mid x_{k-1})$ and $p(z_k \mid x_k)$, when only some landmarks are in view.
#
# **You need** Gaussian vectors and their affine maps; matrices in NumPy and a random generator.
#
# **Time:** about eighteen minutes to read, plus about seven minutes for the folded blocks; the exercises are extra.
# :::
#
# Before filtering anything we need data, and we need to know exactly how it was made: a
# particle filter is only as right as the model it assumes. Here is the scene. A robot drives
# round a circle among landmarks whose positions it does not know. When a landmark is in its
# field of view, the robot measures where the landmark is *relative to itself*, with a small
# error. From these readings alone it must estimate both its own path and the map, a miniature
# of simultaneous localisation and mapping (SLAM).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display

from pfcourse import evidence
from pfcourse.book.exercises import check_log_likelihood
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import control_panel, scale_slider, seed_box
from pfcourse.book.figures.landmarks import animate_landmarks, landmark_scene
from pfcourse.scenarios.landmarks.scenario import circle_scenario, quadrant_scenario, simulate
from pfcourse.book.style import COLORS, use_style

use_style()
scenario = quadrant_scenario()
sim = simulate(scenario, rng=2024)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, ax = plt.subplots(figsize=(5.5, 5.5))
landmark_scene(scenario, sim, ax=ax)
ax.set_title("One run of the two-landmark model (50 s)")
ax.legend(loc="lower left")
plt.show()

# %% [markdown]
# The figure is one run of $50$ s. The robot (its true path, the blue line) goes round the origin;
# the two landmarks sit still; a landmark is in view when it lies up and to the right of the
# robot. The animation replays the run step by step: a landmark in view turns green, and its
# measured offset is drawn from the robot.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
HTML(animate_landmarks(scenario, sim).to_jshtml())

# %% [markdown]
# ## The two-landmark model and its parameters
#
# At each step of $\Delta t = 1$ s the robot turns by $\omega = \pi/4$ rad about the origin
# (once round every $8$ s), perturbed by a small random step. Landmark $j$, at $l^j$, is in view
# when $l^j_x - r_x > 0$ and $l^j_y - r_y > 0$, where $r_k$ is the robot's position at step
# $k$. The state stacks the robot's and the landmarks' positions, in metres, in the world frame:
#
# $$
# \begin{aligned}
# x_k &= \left(r_{x}, r_{y}, l^1_{x}, l^1_{y}, l^2_{x}, l^2_{y}\right)_k^\top,\\
# x_k &= F x_{k-1} + B + w_k,\\
# z_k &= H_k x_k + v_k ,
# \end{aligned}
# $$
#
# with $w_k \sim \mathcal N(0, Q)$ and $v_k \sim \mathcal N(0, R)$. Here are the matrices, in NumPy;
# the package's `quadrant_scenario()` holds the same matrices, as the cell checks.

# %%
import numpy as np
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate

a = np.pi / 4  # the turn per step, omega * dt (rad)
Omega = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
F = np.eye(6)
F[:2, :2] = Omega  # the robot turns; the landmarks stay
B = np.zeros(6)  # turning about the origin adds no constant
m0 = np.array([2.0, 0.0, -1.0, 4.0, 4.0, -1.0])
P0 = np.diag([0.1, 0.2, 0.2, 0.2, 0.2, 0.2])
Q = np.diag([0.05**2, 0.05**2, 1e-20, 1e-20, 1e-20, 1e-20])
R = 0.1**2 * np.eye(4)
# offsets l^1 - r and l^2 - r, when both are in view
H = np.array([[-1, 0, 1, 0, 0, 0],
              [0, -1, 0, 1, 0, 0],
              [-1, 0, 0, 0, 1, 0],
              [0, -1, 0, 0, 0, 1]], dtype=float)

ref = quadrant_scenario()
ours = (m0, P0, Q, R, F, B, H)
theirs = (ref.mX0, ref.PX0, ref.Qw, ref.Rv, ref.F, ref.B, ref.model().H)
print("same as quadrant_scenario():",
      all(np.allclose(u, v) for u, v in zip(ours, theirs)))

# %% [markdown]
# What they mean physically:
#
# - **$m_0$** is the expected initial state: the robot starts near $(2, 0)$ m, the landmarks near
#   $(-1, 4)$ m and $(4, -1)$ m.
# - **$P_0$** is the covariance of the initial state, how far the truth may be from $m_0$. Its
#   diagonal holds variances in m²: $0.2$ m² is a standard deviation of $\sqrt{0.2} \approx 0.45$ m,
#   so the landmarks are known to within about a metre at the start.
# - **$Q$** is the covariance of the process noise $w_k$: each step of the robot is perturbed by
#   $0.05$ m (standard deviation) per axis, while the landmarks get a variance of $10^{-20}$ m²:
#   they do not move. For a particle filter this means a particle's landmark coordinates are
#   never perturbed after the first draw, so resampling can only copy values drawn at the start.
# - **$R$** is the covariance of the measurement noise $v_k$: every measured coordinate is off by
#   $0.1$ m (standard deviation).
#
# ## The simulator, in NumPy
#
# :::{admonition} Algorithm 1.1: one run of the landmark model
# :class: algorithm
# 1. **Initial state.** Draw $x_0 = m_0 + L_0 e_0$, with $L_0 L_0^\top = P_0$ (Cholesky) and $e_0 \sim \mathcal N(0, I)$.
# 2. **For** $k = 1, 2, \dots$ up to the last step: *move*, $x_k = F x_{k-1} + B + w_k$ with $w_k = L_Q e_k$ and $L_Q L_Q^\top = Q$.
# 3. **For every** $k$ and landmark $j$: *see*, is $l^j_k - r_k$ in the field of view (never at $k = 0$)?
#    *Measure*, $z^j_k = l^j_k - r_k + v^j_k$ if so, NaN ("not a number") in its two coordinates if not.
# :::
#
# The lines below are Algorithm 1.1. They draw the normal variates in the same order as the
# package's `simulate` (initial state, then all process noises, then all measurement noises),
# so the same seed must give the same arrays.

# %%
def simulate_numpy(n_steps, rng):
    """One run: states (n, 6), measurements (n, 4), seen (n, 2), n = n_steps."""
    x = np.empty((n_steps, 6))
    # x_0 ~ N(m_0, P_0)
    x[0] = m0 + np.linalg.cholesky(P0) @ rng.standard_normal(6)
    # w_k ~ N(0, Q), one row per step
    w = rng.standard_normal((n_steps, 6)) @ np.linalg.cholesky(Q).T
    for k in range(1, n_steps):
        x[k] = F @ x[k - 1] + B + w[k]
    # v_k ~ N(0, R)
    v = rng.standard_normal((n_steps, 4)) @ np.linalg.cholesky(R).T
    # offsets l^j - r, shape (n_steps, landmark, axis)
    offsets = x[:, 2:].reshape(n_steps, 2, 2) - x[:, None, :2]
    # in view: up and to the right; nothing is measured at k = 0
    seen = (offsets[..., 0] > 0) & (offsets[..., 1] > 0)
    seen[0] = False
    z = offsets.reshape(n_steps, 4) + v
    z[~np.repeat(seen, 2, axis=1)] = np.nan  # unseen landmark: NaN
    return x, z, seen


x, z, seen = simulate_numpy(50, np.random.default_rng(2024))
sim = simulate(ref, rng=2024)
print("same states:      ", np.array_equal(x, sim.truth))
print("same measurements:",
      np.array_equal(z, sim.measurements, equal_nan=True))
print("same visibility:  ", np.array_equal(seen, sim.seen))

# %% [markdown]
# The arrays are identical. `simulate` returns the times of the steps, `sim.T`
# ($t_k = k\,\Delta t$; the attribute's name, not the last step $T$ of {doc}`../notation`), the
# states `truth` (one row per step, what the filter tries to recover and never sees),
# the `measurements` (the offsets $l^1 - r$ then $l^2 - r$, NaN for a landmark out of view; the
# first row is all NaN) and the visibility `seen`.
#
# ## What the robot gets to see
#
# The measurements are the only input of every filter in this part: a time series with holes.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
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
# How often is a landmark in view, in general? One run cannot say; we simulate
# {glue:text}`model_visibility_runs:d` seeded runs. Landmark $1$ is in view at
# {glue:text}`model_seen_share_l1:.0%` ({glue:text}`model_seen_share_l1_low:.0%`-{glue:text}`model_seen_share_l1_high:.0%`)
# of the steps on average.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
n_runs = 500
seen_runs = np.array([simulate(scenario, rng=seed).seen[1:] for seed in range(n_runs)])  # (runs, steps, 2)
shares = {"landmark 1": seen_runs[..., 0].mean(axis=1), "landmark 2": seen_runs[..., 1].mean(axis=1),
          "both at once": seen_runs.all(axis=2).mean(axis=1), "nothing": (~seen_runs.any(axis=2)).mean(axis=1)}
table = np.array(list(shares.values()))  # (4, runs)
means, lows, highs = evidence.run_interval(lambda r: table[:, r].mean(axis=1), n_runs)
rows = pd.DataFrame({"in view": list(shares), "mean share of steps": means, "95 % low": lows, "95 % high": highs})
values = {name: (means[i], lows[i], highs[i]) for i, name in enumerate(shares)}
never = evidence.rate(shares["nothing"] == 1.0)
# paired over the runs: landmark 1's share minus landmark 2's
diff_runs = shares["landmark 1"] - shares["landmark 2"]
diff, diff_low, diff_high = evidence.run_interval(lambda r: diff_runs[r].mean(), n_runs)
glue_values("model_", visibility_runs=n_runs, seen_share_l1=values["landmark 1"][0],
            seen_share_l1_low=values["landmark 1"][1], seen_share_l1_high=values["landmark 1"][2],
            seen_share_l2=values["landmark 2"][0], both_share=values["both at once"][0],
            nothing_share=values["nothing"][0], never_share=never.estimate,
            seen_share_diff_low=100 * diff_low, seen_share_diff_high=100 * diff_high)
EvidenceBlock(
    f"landmark 1 is in view at {values['landmark 1'][0]:.0%} of the steps",
    notes=[f"{n_runs} runs of simulate (seeds 0 to {n_runs - 1}), steps 1 to 49 (nothing is measured at step 0).",
           "Mean over the runs of the share of steps, with its 95 % percentile-bootstrap interval over the runs "
           "(the book's page Reading the evidence explains it).",
           f"Landmark 1's share minus landmark 2's, paired over the runs: {100 * diff:+.1f} points, 95 % interval "
           f"{100 * diff_low:+.1f} to {100 * diff_high:+.1f} points.",
           f"Runs that never see a landmark: {never.successes} of {n_runs} "
           f"({never.estimate:.1%}; 95 % Wilson interval {never.low:.1%} to {never.high:.1%})."],
    tables=[("Share of the steps at which ... is in view", rows,
             {"mean share of steps": ".1%", "95 % low": ".1%", "95 % high": ".1%"})],
)

# %% [markdown]
# Landmark $2$ is seen about as often ({glue:text}`model_seen_share_l2:.0%`): the paired difference
# lies between {glue:text}`model_seen_share_diff_low:+.1f` and
# {glue:text}`model_seen_share_diff_high:+.1f` percentage points. Both are seen at once rarely, and
# the robot sees nothing at
# {glue:text}`model_nothing_share:.0%` of the steps on average. A filter must carry its estimate
# through those gaps with the dynamics alone.
#
# ## The $M$-landmark variant
#
# The second variant has $M = 5$ landmarks around a circle. The robot goes round a centre
# $c = (2, 1)$ m once every $40$ s, and sees a triangle pointing along its direction of travel
# ($45^\circ$ either side, $6$ m deep). Turning about a centre other than the origin adds a
# constant to the dynamics, $r_k = c + \Omega (r_{k-1} - c) + w_k = \Omega r_{k-1} + (I - \Omega)\,c + w_k$,
# with $\Omega$ the rotation by $\omega\,\Delta t$: that constant is $B$ (zero for the landmarks).
# The figure shows one run and, on the right, which landmark is in view at each step.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
scenario5 = circle_scenario(n_landmarks=5)
sim5 = simulate(scenario5, rng=2024)
print("B =", np.round(scenario5.B, 3))

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.5), width_ratios=[1, 1.3])
landmark_scene(scenario5, sim5, ax=ax1, limits=(-4.0, 8.0))
ax1.set_title("Five landmarks, triangular field of view")
ax1.legend(loc="lower left")
ax2.imshow(sim5.seen.T, aspect="auto", interpolation="nearest", cmap="Greens",
           extent=(sim5.T[0] - 0.5, sim5.T[-1] + 0.5, 5.5, 0.5))
ax2.set_yticks(range(1, 6), [f"L{j}" for j in range(1, 6)])
ax2.set_xlabel("time t (s)")
ax2.set_title("Which landmark is in view (green) at each step")
ax2.grid(False)
plt.show()

# %% tags=["hide-input"] jupyter={"source_hidden": true}
HTML(animate_landmarks(scenario5, sim5, limits=(-4.0, 8.0)).to_jshtml())

# %% [markdown]
# Each landmark comes into view, stays a few steps and leaves, so the rows of the measurement
# matrix that apply at step $k$ change with it. We now turn the simulator into the three
# densities every filter needs.
#
# (model-densities)=
# ## The three densities
#
# **Initial density.** The simulator draws $x_0 = m_0 + L_0 e_0$ with $e_0 \sim \mathcal N(0, I)$.
# An affine map of a Gaussian vector is Gaussian, here with mean $m_0$ and covariance
# $L_0 \operatorname{Cov}(e_0) L_0^\top = P_0$:
#
# $$
# \begin{aligned}
# p(x_0) &= \mathcal N(x_0;\, m_0,\, P_0)\\
# &\propto \exp\!\left(-\tfrac12 (x_0 - m_0)^\top P_0^{-1} (x_0 - m_0)\right),
# \end{aligned}
# $$
#
# whose normalising constant is $1 / \sqrt{(2\pi)^{d} \det P_0}$, with $d = 2 + 2M$ the
# dimension of the state.
#
# **Transition density.** Given $x_{k-1}$, the next state $x_k = F x_{k-1} + B + w_k$ is a constant
# plus the noise $w_k \sim \mathcal N(0, Q)$, independent of the past, so
#
# $$
# \begin{aligned}
# p(x_k \mid x_{k-1}) &= \mathcal N(x_k;\, F x_{k-1} + B,\, Q),\\
# F = \begin{pmatrix} \Omega & 0 \\ 0 & I_{2M} \end{pmatrix}&, \quad
# B = \begin{pmatrix} (I - \Omega)\, c \\ 0 \end{pmatrix}
# \end{aligned}
# $$
#
# ($c = 0$ in the two-landmark model). The landmark block of $Q$ is $10^{-20} I$: for the
# landmarks this density is almost a Dirac mass at the previous position.
#
# **Measurement density.** Let $\mathcal V_k \subseteq \{1, \dots, M\}$ be the landmarks in view at step $k$.
# Each gives $z^j_k = l^j_k - r_k + v^j_k = H^j x_k + v^j_k$, with $H^j = (-I_2, 0, \dots, I_2, \dots, 0)$
# ($I_2$ in block $j + 1$). Stacking the visible landmarks gives a measurement matrix and a noise
# covariance whose *size changes with time*:
#
# $$
# \begin{aligned}
# H_k &= \begin{pmatrix} H^{j_1} \\ \vdots \\ H^{j_{|\mathcal V_k|}} \end{pmatrix}, \qquad R_k = R[\mathcal I_k, \mathcal I_k],\\
# p(z_k \mid x_k) &= \mathcal N(z_k;\, H_k x_k,\, R_k),
# \end{aligned}
# $$
#
# where $\mathcal I_k = \{2j - 1, 2j : j \in \mathcal V_k\}$ lists the measurement *coordinates* of the visible
# landmarks ($R$ is $2M \times 2M$, indexed by coordinates) and $R[\mathcal I_k, \mathcal I_k]$ keeps those rows
# and columns. With nothing in view there is no measurement and $p(z_k \mid x_k) = 1$: the step
# is a pure prediction. In code, the non-NaN entries of a row of `z` are $z_k$, and the same
# mask picks $H_k$ and $R_k$ out of the matrices above (Exercise 1.4 turns this into the
# log-likelihood of a whole cloud of particles):

# %%
# a step with only landmark 2 in view
k = int(np.flatnonzero(seen[:, 1] & ~seen[:, 0])[0])
measured = ~np.isnan(z[k])  # the coordinates in view
H_k, R_k = H[measured], R[np.ix_(measured, measured)]
print(f"step {k}: z_k = {z[k][measured].round(3)}")
print("H_k =\n", H_k.astype(int))
print("R_k =\n", R_k)

# %% [markdown]
# (model-exact)=
# **Which model the Kalman filter solves exactly.** Whether a landmark is in view depends on
# the true state: it is seen only when it lies up and to the right of the robot. So the *pattern
# of NaN* is itself information, and the true posterior given the data is not Gaussian (a
# landmark not seen is not up and to the right, which cuts the Gaussian). The filters of Part I
# treat the visibility pattern as given, a known input that chooses $H_k$ and
# $R_k$, and ignore what it implies about the geometry. For that model, the one that treats
# visibility as given, the initial density is Gaussian and every step applies an affine map to
# Gaussian vectors ($F x_{k-1} + B + w_k$, then $H_k x_k + v_k$ with $H_k$ fixed by the pattern),
# so every filtering density $p(x_k \mid z_{1:k})$ is Gaussian and the Kalman filter computes
# its mean and covariance exactly: {doc}`kalman` derives it. In the rest of Part I it is the
# right answer against which every particle filter, which makes the same simplification, is
# measured.
#
# ## Try it
#
# The panel simulates either variant with the chosen seed and measurement-noise scale (a factor
# on the standard deviations in $R$), and draws the world and which landmarks are in view.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_model(variant, noise_scale, seed):
    sc = quadrant_scenario() if variant == "two landmarks" else circle_scenario(5)
    sc = sc.with_(Rv=noise_scale**2 * sc.Rv)
    s = simulate(sc, rng=seed)
    limits = None if variant == "two landmarks" else (-4.0, 8.0)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.2), width_ratios=[1, 1.3])
    landmark_scene(sc, s, ax=a1, limits=limits)
    for j in range(sc.n_landmarks):
        in_view = s.seen[:, j]
        a1.plot(s.truth[in_view, 0] + s.measurements[in_view, 2 * j],
                s.truth[in_view, 1] + s.measurements[in_view, 2 * j + 1], ".", ms=3, color=COLORS["seen"])
    a1.set_title("robot + measured offsets (dots)")
    a2.imshow(s.seen.T, aspect="auto", interpolation="nearest", cmap="Greens",
              extent=(s.T[0] - 0.5, s.T[-1] + 0.5, sc.n_landmarks + 0.5, 0.5))
    a2.set_yticks(range(1, sc.n_landmarks + 1), [f"L{j}" for j in range(1, sc.n_landmarks + 1)])
    a2.set_xlabel("time t (s)")
    a2.set_title("landmarks in view (green)")
    a2.grid(False)


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(
    draw_model,
    grid={"variant": ("two landmarks", "five landmarks"), "noise_scale": (0.3, 1.0, 3.0), "seed": (2024, 1, 2)},
    variant=widgets.Dropdown(options=["two landmarks", "five landmarks"], description="variant"),
    noise_scale=scale_slider("measurement sd factor"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise} 1.1 Units of the process noise
# :label: ex-model-units
# :nonumber:
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
# ```{exercise} 1.2 Two landmarks rarely at once
# :label: ex-model-visibility
# :nonumber:
# In the two-landmark model, why are the two landmarks rarely in view at the same time?
# Use the initial positions and the field of view.
# ```
#
# ```{solution} ex-model-visibility
# :class: dropdown
# A landmark is in view when it is up and to the right of the robot. Landmark $1$ starts near
# $(-1, 4)$ and landmark $2$ near $(4, -1)$, while the robot circles the origin at about $2$ m.
# Landmark $1$ is to the right of the robot only when the robot is on the far left of its circle,
# landmark $2$ above it only when the robot is at the bottom; both hold only on the lower-left
# part of the circle, a short arc. Over the {glue:text}`model_visibility_runs:d` runs above, both
# are in view at {glue:text}`model_both_share:.0%` of the steps on average.
# ```
#
# ```{exercise} 1.3 The likelihood by hand
# :label: ex-model-likelihood
# :nonumber:
# Write $p(z_k \mid x_k)$ at a step where only landmark $2$ of the two-landmark model is in
# view: give $H_k$ and $R_k$ explicitly. What is it at a step where no landmark is in view?
# ```
#
# ```{solution} ex-model-likelihood
# :class: dropdown
# $H_k = \begin{pmatrix} -1 & 0 & 0 & 0 & 1 & 0 \\ 0 & -1 & 0 & 0 & 0 & 1 \end{pmatrix}$ and
# $R_k = 0.1^2 I_2$, so $p(z_k \mid x_k) = \mathcal N(z_k;\, l^2_k - r_k,\, 0.01 I_2)$, the matrices
# printed above. With no landmark in view there is no measurement; the likelihood is the
# constant $1$, and both the Kalman filter and the particle filter only predict.
# ```
#
# ```{exercise} 1.4 The log-likelihood of a cloud, and have it checked
# :label: ex-model-code
# :nonumber:
# (Coding.) Write `log_likelihood(x, z, H, R)`: for particles `x` of shape `(N, 6)`, a measurement
# `z` of shape `(4,)` with NaN for an unseen landmark, the full matrices $H$ ($4 \times 6$) and $R$
# ($4 \times 4$), return the `N` values $\log \mathcal N(z_k;\, H_k x^i,\, R_k)$, normalising constant
# included, and zeros when nothing is in view. The checker compares with the exact log-density
# on clouds with both, one or no landmark in view, and names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_log_likelihood


def log_likelihood(x, z, H, R):
    """Your function: log N(z_k; H_k x^i, R_k) for each row x^i, shape (N,)."""
    ...  # replace with your code


print(check_log_likelihood(log_likelihood))

# %% [markdown]
# ```{solution} ex-model-code
# :class: dropdown
# Keep the measured coordinates of $z$, their rows of $H$ and their block of $R$, then evaluate
# the Gaussian log-density for all particles at once; the code is in the folded cell below (in
# JupyterLab, click its margin to unfold it). It also agrees with `model.log_likelihood` on a
# cloud drawn from $p(x_0)$ at every step of the run above.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def log_likelihood(x, z, H, R):
    seen = ~np.isnan(z)                      # the measured coordinates
    if not seen.any():
        return np.zeros(len(x))              # nothing in view: p(z_k | x_k) = 1
    d = z[seen] - x @ H[seen].T              # z_k - H_k x^i, (N, 2 |V_k|)
    R_k = R[np.ix_(seen, seen)]              # the block of the visible landmarks
    quad = np.einsum("ij,ij->i", d @ np.linalg.inv(R_k), d)
    return -0.5 * (quad + seen.sum() * np.log(2 * np.pi) + np.linalg.slogdet(R_k)[1])


model = scenario.model()
cloud = model.sample_initial(200, np.random.default_rng(0))
print("agrees with model.log_likelihood:", all(
    np.allclose(log_likelihood(cloud, zk, model.H, model.R), model.log_likelihood(cloud, zk, k))
    for k, zk in enumerate(sim.measurements)))
print(check_log_likelihood(log_likelihood))

# %% [markdown]
# ## Takeaways
#
# - The landmark model is linear and Gaussian: $x_k = F x_{k-1} + B + w_k$ with $w_k \sim \mathcal N(0, Q)$,
#   $z_k = H_k x_k + v_k$ with $v_k \sim \mathcal N(0, R)$, started from $\mathcal N(m_0, P_0)$.
# - $P_0$ says how well the start is known, $Q$ how much the state moves at random (nothing, for the
#   landmarks), $R$ how noisy a measured offset is; all are covariances, in m².
# - Only the landmarks in view are measured: $H_k$ keeps their rows of $H$ and $R_k$ their block of $R$,
#   and with nothing in view the likelihood is $1$.
# - Because every map is affine and every noise Gaussian, the Kalman filter is exact for the model
#   that treats the visibility pattern as given ({doc}`kalman`): it is the reference for every
#   particle filter of Part I, which treats visibility the same way.
#
# :::{dropdown} From the labs
# This chapter answers the first two questions of the landmark lab (the first lab the book
# comes from): what the parameters
# $m_0$, $P_0$, $Q$, $R$ mean physically (the list under the matrices above) and which three
# densities define the model ({ref}`model-densities`). The two-landmark variant is the lab's
# first set-up and the five-landmark one its later variant; {doc}`../labs` describes the labs.
# :::
