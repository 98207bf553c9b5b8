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
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** the Bayesian filtering recursion that every filter of the book approximates,
# why the Kalman filter solves it exactly for a linear-Gaussian model, and how it handles
# measurements that are missing; its output is the reference every particle filter of Part I
# is scored against.
#
# **You need** {doc}`model`; conditioning a Gaussian vector on some of its components;
# NumPy's matrix products and `np.linalg.solve`.
#
# **Time:** about eighteen minutes to read, plus about fourteen minutes for the folded blocks; the exercises are extra.
# :::
#
# Here is the answer this chapter derives, on the run of {doc}`model`: for each coordinate of
# the state, the filter's estimate (green) and a band of three standard deviations about it,
# against the truth (black). The bands are wide until a landmark is first seen, then narrow,
# and they keep the truth inside. Every particle filter of Part I is scored against
# these bands.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display
from matplotlib.animation import FuncAnimation
from matplotlib.ticker import MultipleLocator
from scipy import stats

from pfcourse import evidence
from pfcourse.diagnostics import chi2_band, nees
from pfcourse.kalman import kalman_filter
from pfcourse.book.figures.landmarks import landmark_scene
from pfcourse.scenarios.landmarks.scenario import circle_scenario, quadrant_scenario, simulate
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.style import COLORS, ellipse_patch, plain_log_axis, use_style
from pfcourse.book.panels import control_panel, scale_slider, seed_box

use_style()
LABELS = ["robot x", "robot y", "L1 x", "L1 y", "L2 x", "L2 y"]


def plot_estimates(sim, kf, axes, labels):
    sd = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
    for j, ax in enumerate(axes.flat):
        ax.fill_between(sim.T, kf.mean[:, j] - 3 * sd[:, j], kf.mean[:, j] + 3 * sd[:, j],
                        color=COLORS["kalman"], alpha=0.25, label=r"$\pm 3\sigma$")
        ax.plot(sim.T, sim.truth[:, j], color=COLORS["truth"], lw=1, label="truth")
        ax.plot(sim.T, kf.mean[:, j], color=COLORS["kalman"], lw=1.2, label="Kalman mean")
        ax.set_ylabel(f"{labels[j]} (m)")
    for ax in axes[-1]:
        ax.set_xlabel("time t (s)")
    axes.flat[0].figure.legend(*axes.flat[0].get_legend_handles_labels(), loc="upper center", ncols=3, frameon=False, bbox_to_anchor=(0.5, 0.95))  # above the panels, off the data


scenario = quadrant_scenario()
model = scenario.model()
sim = simulate(scenario, rng=2024)
kf = kalman_filter(model, sim.measurements)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, axes = plt.subplots(3, 2, figsize=(9, 6.5), sharex=True)
plot_estimates(sim, kf, axes, LABELS)
fig.suptitle("Kalman filter, two landmarks (seed 2024)")
plt.show()

# %% [markdown]
# (kalman-recursion)=
# ## The idea: predict, then update
#
# The filtering density $p(x_k \mid z_{1:k})$ is computed from the previous one in two steps
# {cite:p}`arulampalam2002`. **Predict**: the state moves by the transition density, so by the
# law of total probability
#
# $$
# \begin{aligned}
# p(x_k \mid z_{1:k-1}) = \int & p(x_k \mid x_{k-1})\\
# & \times p(x_{k-1} \mid z_{1:k-1})\, dx_{k-1} .
# \end{aligned}
# $$
#
# **Update**: Bayes' rule weighs the prediction by the likelihood of the new measurement,
#
# $$
# p(x_k \mid z_{1:k}) = \frac{p(z_k \mid x_k)\, p(x_k \mid z_{1:k-1})}{p(z_k \mid z_{1:k-1})} ,
# $$
#
# $$
# \begin{aligned}
# p(z_k \mid z_{1:k-1}) = \int & p(z_k \mid x_k)\\
# & \times p(x_k \mid z_{1:k-1})\, dx_k .
# \end{aligned}
# $$
#
# The denominator, the **likelihood increment**, is the density of the new measurement given
# the past ones; their product over the steps is the likelihood of all the data,
# $p(z_{1:k}) = \prod_{j \le k} p(z_j \mid z_{1:j-1})$, which {doc}`../part5/likelihood` uses to
# learn the noise levels. When nothing is measured at step $k$, $p(z_k \mid x_k) = 1$: the
# update changes nothing and the increment is $1$. The recursion starts from $p(x_0)$.
#
# In general the two integrals have no closed form, which is why the rest of the book
# approximates them with particles. For one family of models they do.
#
# (kalman-exact)=
# ## The exact solution for a linear-Gaussian model
#
# Take the landmark model of {doc}`model`: $x_0 \sim \mathcal N(m_0, P_0)$,
# $x_k = F x_{k-1} + B + w_k$ with $w_k \sim \mathcal N(0, Q)$, and $z_k = H_k x_k + v_k$ with
# $v_k \sim \mathcal N(0, R_k)$, all noises independent. (The scenario calls $Q$ and $R$ `Qw`
# and `Rv`.) Suppose $p(x_{k-1} \mid z_{1:k-1}) = \mathcal N(m_{k-1}, P_{k-1})$: Gaussian in.
#
# **Predict.** $x_k$ is an affine function of the independent Gaussians $x_{k-1}$ and $w_k$,
# so it is Gaussian, with
#
# $$
# \begin{aligned}
# m_k^- &= F m_{k-1} + B,\\
# P_k^- &= F P_{k-1} F^\top + Q .
# \end{aligned}
# $$
#
# **Update.** Given $z_{1:k-1}$, the pair $(x_k, z_k)$ is jointly Gaussian, since
# $z_k = H_k x_k + v_k$ is affine in $(x_k, v_k)$. The measurement's predicted mean is
# $H_k m_k^-$; the **innovation** $\nu_k = z_k - H_k m_k^-$ is what the measurement says that the
# prediction did not, and its covariance is $S_k = H_k P_k^- H_k^\top + R_k$. The
# cross-covariance of $x_k$ and $z_k$ is $P_k^- H_k^\top$. Conditioning a jointly Gaussian pair
# $(a, b)$ on $b$ gives a Gaussian, with mean $\mu_a + \Sigma_{ab} \Sigma_{bb}^{-1} (b - \mu_b)$ and
# covariance $\Sigma_{aa} - \Sigma_{ab} \Sigma_{bb}^{-1} \Sigma_{ba}$ (means $\mu$, covariance blocks
# $\Sigma$). With $a = x_k$, $b = z_k$, $\Sigma_{ab} = P_k^- H_k^\top$ and $\Sigma_{bb} = S_k$:
#
# $$
# \begin{aligned}
# K_k &= P_k^- H_k^\top S_k^{-1},\\
# m_k &= m_k^- + K_k \nu_k,\\
# P_k &= P_k^- - K_k S_k K_k^\top = (I - K_k H_k) P_k^- .
# \end{aligned}
# $$
#
# Gaussian out: by induction from $p(x_0)$, every filtering density is Gaussian and these
# equations compute its mean and covariance exactly {cite:p}`kalman1960`. The **gain** $K_k$
# weighs the prediction's uncertainty $P_k^-$ against the innovation's $S_k$. The likelihood
# increment is the density of $z_k$ given the past, $\mathcal N(z_k; H_k m_k^-, S_k)$, that is
#
# $$
# p(z_k \mid z_{1:k-1}) = \mathcal N(\nu_k;\, 0,\, S_k) .
# $$
#
# **Missing measurements.** A landmark out of view leaves NaN in its coordinates of $z_k$.
# The likelihood then involves only the measured coordinates, so the update uses the rows of
# $H$ for them and the matching rows and columns of $R$ ({ref}`model-densities`): $H_k$ and
# $R_k$ change size from step to step, and the argument above does not change. When nothing
# is measured the update is skipped: $m_k = m_k^-$, $P_k = P_k^-$. Which coordinates are
# measured depends on the true state (a landmark is seen only up and to the right of the
# robot), so this filter is exact for the model that treats the visibility pattern as given,
# a known input choosing $H_k$ and $R_k$ ({ref}`which model it solves exactly <model-exact>`): the model every filter of Part I
# assumes.
#
# :::{admonition} Algorithm 2.1: the Kalman filter, with missing measurements
# :class: algorithm
# 1. **Initialise.** The prediction for step $0$ is $p(x_0)$ itself: $m_0^- = m_0$ and
#    $P_0^- = P_0$; the log-likelihood is $\ell = 0$.
# 2. **For** $k = 0, 1, 2, \dots$:
#    1. *Predict* (from $k = 1$ on): $m_k^- = F m_{k-1} + B$ and $P_k^- = F P_{k-1} F^\top + Q$.
#    2. *Select* the rows of $H$, and the rows and columns of $R$, of the coordinates of $z_k$
#       that are not NaN: they are $H_k$ and $R_k$. If there are none, set $m_k = m_k^-$ and
#       $P_k = P_k^-$ and go to the next step.
#    3. *Update:* the innovation $\nu_k = z_k - H_k m_k^-$, its covariance
#       $S_k = H_k P_k^- H_k^\top + R_k$, the gain $K_k = P_k^- H_k^\top S_k^{-1}$, then
#       $m_k = m_k^- + K_k \nu_k$ and $P_k = P_k^- - K_k S_k K_k^\top$.
#    4. *Likelihood:* add $\log \mathcal N(\nu_k; 0, S_k)$ to $\ell$, that is
#       $-\tfrac12 \left(\nu_k^\top S_k^{-1} \nu_k + \log \det (2\pi S_k)\right)$.
# :::
#
# Here is the algorithm in plain NumPy. The model's matrices are those written out in
# {doc}`model`; `quadrant_scenario().model()` holds them as `F`, `B`, `Q`, `H`, `R`, `m0`, `P0`.

# %%
import numpy as np
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate


def kalman(Z, model):
    """Algorithm 2.1: means, covariances and log-likelihood."""
    m, P, log_lik = model.m0, model.P0, 0.0
    means, covs = [], []
    for k, z in enumerate(Z):
        if k > 0:  # predict
            m = model.F @ m + model.B
            P = model.F @ P @ model.F.T + model.Q
        seen = ~np.isnan(z)  # the measured coordinates
        if seen.any():  # update with the measured rows
            H, R = model.H[seen], model.R[np.ix_(seen, seen)]
            nu = z[seen] - H @ m  # innovation
            S = H @ P @ H.T + R  # its covariance
            K = np.linalg.solve(S, H @ P).T  # gain P H^T S^-1
            m = m + K @ nu
            P = P - K @ S @ K.T
            log_det = np.linalg.slogdet(2 * np.pi * S)[1]
            log_lik -= 0.5 * (nu @ np.linalg.solve(S, nu) + log_det)
        means.append(m)
        covs.append(P)
    return np.array(means), np.array(covs), log_lik


two = quadrant_scenario().model()
Z = simulate(quadrant_scenario(), rng=2024).measurements
means, covs, log_lik = kalman(Z, two)
print("final robot position:", means[-1, :2].round(3))
print(f"log-likelihood: {log_lik:.2f}")

# %% [markdown]
# In `pfcourse` this is `kalman_filter(model, measurements)`, whose steps follow the `filterpy`
# library's equations {cite:p}`labbe2020` (the package's tests compare the two on the same data).
# On both variants of the model the lines above give its output:

# %% tags=["hide-input"] jupyter={"source_hidden": true}
ROUND_OFF = 1e-9
for sc in (quadrant_scenario(), circle_scenario()):
    m_ = sc.model()
    Z_ = simulate(sc, rng=2024).measurements
    means_, covs_, log_lik_ = kalman(Z_, m_)
    ref = kalman_filter(m_, Z_)
    worst = max(np.abs(means_ - ref.mean).max(),
                np.abs(covs_ - ref.cov).max(),
                abs(log_lik_ - ref.log_likelihood))
    print(f"{sc.n_landmarks} landmarks, same as kalman_filter "
          f"to {ROUND_OFF:.0e}: {worst < ROUND_OFF}")
glue_values("kalman_", check_bound=ROUND_OFF)

# %% [markdown]
# Means, covariances and log-likelihood agree with the package's filter to round-off (below
# {glue:text}`kalman_check_bound:.0e`) on both variants; the package writes the covariance
# update in Joseph's form, $(I - K_k H_k) P_k^- (I - K_k H_k)^\top + K_k R_k K_k^\top$, equal in
# exact arithmetic and more robust to round-off (a sum of two positive semi-definite terms).
#
# ## The bands of the first figure
#
# The bands follow the measurements. Each landmark's band keeps its prior width
# ($3\sqrt{0.2} \approx 1.3$ m) until the landmark is first seen; at that step landmark $1$'s
# standard deviation drops from {glue:text}`kalman_l1_sd_before_seen:.3f` m to
# {glue:text}`kalman_l1_sd_first_seen:.3f` m, and further sightings narrow it more. The robot's band
# narrows too: a measured offset to a landmark whose position is partly known pins down the robot.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
sd = np.sqrt(np.diagonal(kf.cov, axis1=1, axis2=2))
first_seen = [int(np.argmax(sim.seen[:, j])) for j in range(2)]
glue_values("kalman_", l1_sd_first_seen=sd[first_seen[0], 2], l1_sd_before_seen=sd[first_seen[0] - 1, 2])
EvidenceBlock(
    "the bands narrow when a landmark is first seen",
    notes=[f"In this run (seed 2024) landmark 1 is first seen at step {first_seen[0]}, landmark 2 at step "
           f"{first_seen[1]}. The covariances of a Kalman filter depend on which coordinates are measured, "
           "not on the measured values, so these standard deviations are exact for this pattern of sightings."],
    tables=[("Posterior standard deviations (m)",
             pd.DataFrame([{"step k": k, **dict(zip(LABELS, sd[k]))} for k in (0, *first_seen, len(sd) - 1)]),
             {label: ".3f" for label in LABELS})],
)

# %% [markdown]
# ## Is it consistent? The NEES over many runs
#
# "The bands contain the truth" is a check by eye. The normalised estimation error squared,
# $\mathrm{NEES}_k = (x_k - m_k)^\top P_k^{-1}(x_k - m_k)$, is $\chi^2_6$-distributed, with
# mean $6$, when the filter is exact for the model that generates the data
# {cite:p}`barshalom2001`: here, the model that treats visibility as given, a pattern of
# sightings chosen independently of the state. Our simulator's visibility depends on the true
# state, so against it the check is of a close approximation, not of an exact filter. The
# steps of a run are correlated, so the run is the unit: we average the NEES over the steps of
# each of $n_\text{runs} = 200$ seeded runs, and plot the mean over the runs at each step.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
n_runs = 200
runs = [simulate(scenario, rng=seed) for seed in range(n_runs)]  # seeds 0 .. n_runs - 1
run_kf = [kalman_filter(model, s.measurements) for s in runs]
eps = np.array([nees(s.truth, r.mean, r.cov) for s, r in zip(runs, run_kf)])  # (runs, steps)
per_run = eps.mean(axis=1)
mean_nees, low, high = evidence.run_interval(lambda r: per_run[r].mean(), n_runs)

lo, hi = chi2_band(6, n_runs)
fig, ax = plt.subplots(figsize=(7, 3.2))
ax.plot(sim.T, eps.mean(axis=0), color=COLORS["kalman"], label=f"mean NEES, {n_runs} runs")
ax.fill_between(sim.T, *np.percentile(eps, [10, 90], axis=0), color=COLORS["kalman"], alpha=0.2,
                label="10-90 % of runs")
ax.axhspan(lo, hi, color="gray", alpha=0.3, label="95 % band of the mean")
ax.set_xlabel("time t (s)")
ax.set_ylabel("NEES (dimensionless)")
ax.legend(loc="upper right")
plt.show()

# %% [markdown]
# Over these runs the time-averaged NEES has mean
# {glue:text}`kalman_nees_mean:.2f` ({glue:text}`kalman_nees_mean_low:.2f`-{glue:text}`kalman_nees_mean_high:.2f`),
# for $6$ expected: the data exclude an overconfidence of the bands beyond
# {glue:text}`kalman_nees_excess_high:.0f` % in the NEES.
#
# As a control, the same runs' true
# states are measured again with the visibility pattern of another run, which does not depend
# on this run's state: the model for which the filter is exact. Its mean NEES is
# {glue:text}`kalman_nees_control_mean:.2f`
# ({glue:text}`kalman_nees_control_low:.2f`-{glue:text}`kalman_nees_control_high:.2f`), so
# $200$ runs cannot tell the simulator from the exact case: a bias of a few percent from the
# state-dependent visibility would be too small for them to resolve.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
inside = np.mean((eps.mean(axis=0) >= lo) & (eps.mean(axis=0) <= hi))
t_p = stats.ttest_1samp(per_run, 6.0).pvalue
# control: each run's true states, fresh measurement noise, and the visibility of run s + 1
# (another run, independent of this run's state), for which the filter is exact
L_R = np.linalg.cholesky(model.R)
control = []
for s, sim_s in enumerate(runs):
    noise = np.random.default_rng(10_000 + s).standard_normal(sim_s.measurements.shape) @ L_R.T
    z_c = sim_s.truth @ model.H.T + noise
    z_c[~np.repeat(runs[(s + 1) % n_runs].seen, 2, axis=1)] = np.nan
    kf_c = kalman_filter(model, z_c)
    control.append(nees(sim_s.truth, kf_c.mean, kf_c.cov).mean())
control = np.array(control)
c_mean, c_low, c_high = evidence.run_interval(lambda r: control[r].mean(), n_runs)
d_mean, d_low, d_high = evidence.run_interval(lambda r: (per_run[r] - control[r]).mean(), n_runs)
glue_values("kalman_nees_", runs=n_runs, mean=mean_nees, mean_low=low, mean_high=high, mean_p=t_p,
            inside=inside, steps=eps.shape[1], excess_high=100 * (high / 6 - 1), control_mean=c_mean,
            control_low=c_low, control_high=c_high)
EvidenceBlock(
    f"the Kalman filter's NEES: mean {mean_nees:.2f} for 6 expected, control {c_mean:.2f}",
    notes=[f"{n_runs} simulations of the two-landmark variant (seeds 0 to {n_runs - 1}), {eps.shape[1]} steps each.",
           f"Mean over the runs of the time-averaged NEES: {mean_nees:.2f}, 95 % interval {low:.2f} to {high:.2f} "
           f"(percentile bootstrap over the runs; see Reading the evidence); t-test against 6: p = {t_p:.2f}.",
           f"The mean NEES over the runs lies in the 95 % chi-square band [{lo:.2f}, {hi:.2f}] at {inside:.0%} of "
           f"the {eps.shape[1]} steps; each step's mean is inside with probability 0.95 for an exact filter, and "
           "the steps are correlated, so this share is a check by eye, not a test.",
           f"Control (visibility of run s + 1, independent of run s's state; measurement noise from seed "
           f"10000 + s): mean NEES {c_mean:.2f}, 95 % interval {c_low:.2f} to {c_high:.2f}. Paired by run, "
           f"simulator minus control: {d_mean:+.2f} ({d_low:+.2f} to {d_high:+.2f}).",
           "A bias of a few percent needs thousands of runs to resolve; these 200 exclude only larger ones."],
)

# %% [markdown]
# ## A landmark out of view still gets sharper
#
# Between two sightings a landmark's own variance cannot grow: its block of $F$ is the
# identity and its process noise is $10^{-20}$ m². But the landmark is *correlated* with the
# robot (both were estimated from the same relative measurements), and the robot keeps being
# measured through the other landmark. An update that sharpens the robot sharpens, through
# the cross-covariance in $P_k^- H_k^\top$, the landmark that is out of view. The ticks mark the
# steps at which each landmark is in view.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, ax = plt.subplots(figsize=(7, 3.5))
for j, c in zip(range(2), ("tab:purple", "tab:brown")):
    ax.plot(sim.T, sd[:, 2 + 2 * j], color=c, label=f"sd of L{j + 1} x")
    seen_t = sim.T[sim.seen[:, j]]
    ax.plot(seen_t, np.full(seen_t.shape, 0.5 + 0.1 * j), "|", color=c, ms=8, label=f"L{j + 1} in view")
ax.set_xlabel("time t (s)")
ax.set_ylabel("posterior sd (m)")
plain_log_axis(ax, "y", subs=(1.0, 2.0, 5.0))
ax.set_title("Landmark uncertainty shrinks at sightings, stays flat or shrinks in between")
ax.legend(loc="lower left", ncols=2)
plt.show()

# %% [markdown]
# In this run landmark $1$ is out of view on {glue:text}`kalman_l1_unseen_steps:d` steps. Its
# standard deviation grows on none of them and shrinks by more than $10^{-4}$ m on
# {glue:text}`kalman_l1_unseen_shrank:d`, each a step at which landmark $2$ is measured. This is
# the mechanism of SLAM: correlations carry information between the map and the robot.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def unseen_changes(sim, kf):
    """Change of landmark 1's x sd over each step where it is out of view, and whether landmark 2 is seen."""
    sd1 = np.sqrt(kf.cov[:, 2, 2])
    unseen = ~sim.seen[1:, 0]
    return np.diff(sd1)[unseen], sim.seen[1:, 1][unseen]


change, other_seen = unseen_changes(sim, kf)
glue_values("kalman_", l1_unseen_steps=change.size, l1_unseen_shrank=np.sum(change < -1e-4))
pooled = [unseen_changes(s, r) for s, r in zip(runs, run_kf)]
all_change = np.concatenate([c for c, _ in pooled])
all_other = np.concatenate([o for _, o in pooled])
shrank = all_change < -1e-4
EvidenceBlock(
    "an unseen landmark's uncertainty never grows, and shrinks only when the other landmark is measured",
    notes=[f"This run: landmark 2 is in view at {int(np.sum(other_seen[change < -1e-4]))} of the "
           f"{int(np.sum(change < -1e-4))} unseen steps on which landmark 1's sd shrank by more than 1e-4 m.",
           f"Over {n_runs} runs (seeds 0 to {n_runs - 1}), {all_change.size} steps with landmark 1 out of view: "
           f"its sd never grew by more than {max(all_change.max(), 0.0):.1e} m (its process noise is 1e-20 m²); it shrank "
           f"by more than 1e-4 m on {int(shrank.sum())} of them, and landmark 2 was measured at "
           f"{int(np.sum(all_other[shrank]))} of those {int(shrank.sum())}."],
)

# %% [markdown]
# ## The five-landmark variant
#
# With five landmarks and the triangular field of view, each landmark is seen during one
# passage and then left alone; the robot's uncertainty drops each time a new landmark enters
# the view. The animation shows the 95 % ellipses of the robot and of every landmark.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
scenario5 = circle_scenario()
model5 = scenario5.model()
sim5 = simulate(scenario5, rng=2024)
kf5 = kalman_filter(model5, sim5.measurements)


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
            patches.append(ax.add_patch(ellipse_patch(kf.mean[k, blk], kf.cov[k, blk, blk], color=color, lw=1.5)))
        patches.append(ax.plot(*sim.truth[k, :2], "o", color=COLORS["truth"], ms=4)[0])
        title.set_text(f"t = {sim.T[k]:.0f} s: 95 % ellipses (Kalman)")
        return patches

    anim = FuncAnimation(fig, draw, frames=range(0, len(sim.T), every), blit=False)
    plt.close(fig)
    return anim


HTML(animate_ellipses(scenario5, sim5, kf5, (-4.0, 8.0)).to_jshtml())

# %% tags=["hide-input"] jupyter={"source_hidden": true}
sd5 = np.sqrt(np.diagonal(kf5.cov, axis1=1, axis2=2))
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.plot(sim5.T, sd5[:, 0], color=COLORS["robot"], lw=2, label="robot x")
for j in range(5):
    ax.plot(sim5.T, sd5[:, 2 + 2 * j], lw=1, label=f"L{j + 1} x")
plain_log_axis(ax, "y", subs=(1.0, 2.0, 5.0))
ax.set_ylim(top=0.6)  # the prior sd, 0.45 m, below the top tick
ax.set_xlabel("time t (s)")
ax.set_ylabel("posterior sd (m)")
ax.set_title("Five landmarks: each sd drops when its landmark passes through the view")
ax.legend(ncols=3)
plt.show()

# %% [markdown]
# By the end of a run the landmarks' standard deviation (per coordinate) has fallen from
# $\sqrt{0.2} \approx 0.45$ m to {glue:text}`kalman_five_final_sd:.3f` m on average over
# {glue:text}`kalman_five_runs:d` runs
# ({glue:text}`kalman_five_final_sd_low:.3f`-{glue:text}`kalman_five_final_sd_high:.3f` m).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
n_runs5 = 100
final5, all_seen5 = [], []
for seed in range(n_runs5):
    s5 = simulate(scenario5, rng=seed)
    final5.append(np.sqrt(np.diagonal(kalman_filter(model5, s5.measurements).cov[-1]))[2:])
    all_seen5.append(s5.seen.any(axis=0).all())
final5 = np.array(final5)  # (runs, landmark coordinates)
mean5, low5, high5 = evidence.run_interval(lambda r: final5[r].mean(), n_runs5)
every_seen = evidence.rate(np.array(all_seen5))
glue_values("kalman_five_", runs=n_runs5, final_sd=mean5, final_sd_low=low5, final_sd_high=high5)
EvidenceBlock(
    f"the landmarks' final sd falls to {mean5:.3f} m on average",
    notes=[f"{n_runs5} simulations of the five-landmark variant (seeds 0 to {n_runs5 - 1}): mean over runs and "
           f"landmark coordinates of the final posterior sd, {mean5:.3f} m (95 % interval {low5:.3f} to {high5:.3f}, "
           f"percentile bootstrap over the runs); prior sd {np.sqrt(scenario5.PX0[2, 2]):.3f} m.",
           f"Runs in which every landmark is seen at least once: {every_seen}.",
           "Final sd of the landmark x coordinates in the run shown (seed 2024), m: "
           + ", ".join(f"L{j + 1} {v:.3f}" for j, v in enumerate(sd5[-1, 2::2])) + "."],
)

# %% [markdown]
# ## Try it
#
# The panel re-runs the simulation and the Kalman filter with the measurement noise and the
# robot's process noise scaled (the filter uses the same scaled values as the simulator). On
# the default run, scaling the measurement noise's standard deviation from $0.3$ to $3$ times
# its default value widens the landmark bands from a mean standard deviation of
# {glue:text}`kalman_panel_landmark_sd_low:.3f` m to {glue:text}`kalman_panel_landmark_sd_high:.3f` m.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
rows = []
for scale in (0.3, 1.0, 3.0):
    sc = scenario.with_(Rv=scale**2 * scenario.Rv)  # same trajectory: only the measurement noise changes
    sd_r = np.sqrt(np.diagonal(kalman_filter(sc.model(), simulate(sc, rng=2024).measurements).cov, axis1=1, axis2=2))
    Qw = scenario.Qw.copy()
    Qw[:2, :2] *= scale**2
    sc = scenario.with_(Qw=Qw)
    s = simulate(sc, rng=2024)
    sd_q = np.sqrt(np.diagonal(kalman_filter(sc.model(), s.measurements).cov, axis1=1, axis2=2))
    unseen = ~s.seen[1:].any(axis=1)  # steps with no landmark in view
    rows.append({"sd scale": scale, "landmark sd, R scaled (m)": sd_r[:, 2:].mean(),
                 "robot x sd growth per unseen step, Q scaled (m)": np.median(np.diff(sd_q[:, 0])[unseen]),
                 "steps with nothing in view": int(unseen.sum())})
panel = pd.DataFrame(rows)
for (_, row), key in zip(panel.iterrows(), ("low", "mid", "high")):
    glue_values("kalman_panel_", **{f"landmark_sd_{key}": row.iloc[1], f"robot_growth_{key}": row.iloc[2]})
EvidenceBlock(
    "more measurement noise, wider landmark bands; more process noise, faster robot growth",
    notes=["One run (seed 2024). Scaling the measurement noise leaves the trajectory unchanged, and a Kalman "
           "covariance does not depend on the measured values, so the landmark sds are exact for this run. The "
           "robot's growth is the median, over the steps with no landmark in view, of the change of its x sd."],
    tables=[("Mean landmark sd (over time and coordinates), and the robot's growth between sightings", panel,
             {"sd scale": ".1f", "landmark sd, R scaled (m)": ".3f",
              "robot x sd growth per unseen step, Q scaled (m)": ".4f"})],
)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_kalman(noise_scale, process_scale, seed):
    Qw = scenario.Qw.copy()
    Qw[:2, :2] *= process_scale**2
    sc = scenario.with_(Rv=noise_scale**2 * scenario.Rv, Qw=Qw)
    s = simulate(sc, rng=seed)
    r = kalman_filter(sc.model(), s.measurements)
    fig, axes = plt.subplots(3, 2, figsize=(9, 6), sharex=True)
    plot_estimates(s, r, axes, LABELS)
    axes[0, 0].xaxis.set_major_locator(MultipleLocator(25))  # shared by the six axes; fewer ticks redraw faster


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(draw_kalman, grid={"noise_scale": (0.3, 1.0, 3.0), "process_scale": (0.3, 1.0, 3.0)},
                      noise_scale=scale_slider("measurement sd factor"),
                      process_scale=scale_slider("robot process sd factor"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise} 2.1 Why exact?
# :label: ex-kalman-exact
# :nonumber:
# Name the two properties of the model that make the Kalman filter exact
# here, and one change of the model that would break it.
# ```
#
# ```{solution} ex-kalman-exact
# :class: dropdown
# Linearity (dynamics and measurements affine in the state) and Gaussian noise, independent
# of the state and of each other. Then prediction and update map Gaussians to Gaussians. (The
# visibility pattern is treated as given: it chooses $H_k$ and $R_k$ and is not itself modelled
# as a measurement.)
# Measuring the landmarks in range and bearing (nonlinear), or heavy-tailed noise, would
# break it: the posterior would no longer be Gaussian.
# ```
#
# ```{exercise} 2.2 Sharper while unseen
# :label: ex-kalman-unseen
# :nonumber:
# How many times did landmark $1$'s standard deviation shrink on the steps where it was
# *not* in view, and why is that not a contradiction?
# ```
#
# ```{solution} ex-kalman-unseen
# :class: dropdown
# It never grew, and it shrank noticeably (by more than $10^{-4}$ m) on
# {glue:text}`kalman_l1_unseen_shrank:d` of its {glue:text}`kalman_l1_unseen_steps:d` unseen steps,
# steps at which landmark $2$ was measured. The landmark estimate is correlated with the
# robot estimate; a measurement of landmark $2$ sharpens the robot, and through the
# cross-covariance, landmark $1$.
# ```
#
# ```{exercise} 2.3 A tracker with a velocity, and have it checked
# :label: ex-kalman-code
# :nonumber:
# (Coding.) A cart moves on a line with a velocity that drifts at random. Its state is
# $x_k = (\xi_k, \dot\xi_k)$, position (m) and velocity (m/s), sampled every $\Delta t$ seconds; a
# random acceleration of spectral density $\sigma_a^2$ (white noise whose variance, integrated
# over a time $\Delta t$, is $\sigma_a^2 \Delta t$, in m²/s³) gives
#
# $$
# \begin{aligned}
# x_k &= \begin{pmatrix} 1 & \Delta t \\ 0 & 1 \end{pmatrix} x_{k-1} + w_k,\\
# Q &= \sigma_a^2 \begin{pmatrix} \Delta t^3/3 & \Delta t^2/2 \\ \Delta t^2/2 & \Delta t \end{pmatrix},
# \end{aligned}
# $$
#
# with $w_k \sim \mathcal N(0, Q)$. Only the position is measured, $z_k = \xi_k + v_k$ with
# $v_k \sim \mathcal N(0, \sigma_v^2)$, NaN where nothing is measured (always at step $0$), and
# $x_0 \sim \mathcal N(m_0, P_0)$. Write `my_cv_kalman(z, dt, q, r, m0, P0)` for this model, with
# `q` $= \sigma_a^2$ and `r` $= \sigma_v^2$ (variances): `z` has shape `(K,)`; return the filtering means `(K, 2)`, covariances `(K, 2, 2)` and the
# log-likelihood. The checker compares them with the exact ones and names the mistake it sees.
# Which of the model's matrices differ from the landmark model's, and how does the filter learn
# a velocity it never measures?
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_cv_kalman


def my_cv_kalman(z, dt, q, r, m0, P0):
    """Your filter: return (means (K, 2), covariances (K, 2, 2), log-lik)."""
    ...  # replace with your code


print(check_cv_kalman(my_cv_kalman))

# %% [markdown]
# ```{solution} ex-kalman-code
# :class: dropdown
# Algorithm 2.1 with $F = \begin{pmatrix} 1 & \Delta t \\ 0 & 1 \end{pmatrix}$, the $Q$ above,
# $H = (1, 0)$ and $B = 0$; the code is in the folded cell below (in JupyterLab, click its margin
# to unfold it). The velocity is never measured, but the prediction couples it to the position
# (the off-diagonal of $F P F^\top$): two positions measured $\Delta t$ apart say how fast the
# cart moved, so the gain $K_k$ has a velocity row too.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_cv_kalman(z, dt, q, r, m0, P0):
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    H = np.array([[1.0, 0.0]])
    m, P, log_lik = m0, P0, 0.0
    means, covs = [], []
    for k, zk in enumerate(z):
        if k > 0:  # predict
            m, P = F @ m, F @ P @ F.T + Q
        if not np.isnan(zk):  # update, and add the likelihood increment
            nu = np.array([zk]) - H @ m
            S = H @ P @ H.T + r
            K = np.linalg.solve(S, H @ P).T
            m, P = m + K @ nu, P - K @ S @ K.T
            log_lik -= 0.5 * (nu @ np.linalg.solve(S, nu) + np.linalg.slogdet(2 * np.pi * S)[1])
        means.append(m)
        covs.append(P)
    return np.array(means), np.array(covs), log_lik


print(check_cv_kalman(my_cv_kalman))

# %% [markdown]
# ## Takeaways
#
# - Every filter of the book approximates one recursion: predict with the transition
#   density, update with the likelihood by Bayes' rule; the update's normaliser is the
#   likelihood increment $p(z_k \mid z_{1:k-1})$.
# - For a linear-Gaussian model the recursion maps a Gaussian to a Gaussian, and the Kalman
#   filter computes its mean and covariance exactly, with the increment
#   $\mathcal N(\nu_k; 0, S_k)$.
# - A missing measurement drops its rows of $H$ and its rows and columns of $R$; with nothing
#   measured, the update is skipped.
# - Correlations carry information: measuring one landmark sharpens the robot and, through
#   it, a landmark out of view.
# - The filter is exact when visibility is treated as given, and against the simulator its NEES
#   averages about its dimension, so its output is the reference every particle filter of Part I
#   is scored against.
#
# :::{dropdown} From the labs
# This chapter answers the landmark lab's second question, why the Kalman filter is exact
# for this model ({ref}`kalman-exact`), and computes the lab's reference estimates and their
# bands on both variants; {doc}`../labs` describes the labs.
# :::
