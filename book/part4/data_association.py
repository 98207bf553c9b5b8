# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # When the landmarks look alike: unknown data association
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** what a filter must do when a reading does not say which landmark it comes from,
# when some readings are false and some landmarks go unseen: the likelihood becomes a mixture
# over the possible origins, which a particle filter weighs and an EKF must replace by a choice.
#
# **You need** {doc}`../part2/robot` and {doc}`../part2/robot_vs_kalman`; the log-domain weights of
# {doc}`../part1/sis`; Poisson and uniform distributions.
#
# **Time:** about twenty-one minutes to read; the notebook runs in under half a minute.
# :::
#
# ## The idea: a reading from somewhere
#
# The lab's robot ({doc}`../part2/robot`) knows which landmark each range and bearing comes from.
# Real landmarks (posts, trees, reflectors) often look alike, and a real sensor also misses
# landmarks and reports returns from things that are not landmarks. This chapter gives the
# robot's sensor three such faults, at every measurement step:
#
# - the landmark the sensor looks at (one of the $M$, each with probability $1/M$) is
#   **detected** with probability $P_D$, giving $z = h_j(x_k) + v$, $v \sim \mathcal N(0, R)$,
#   **without** its index $j$;
# - a number of **clutter** readings, Poisson with mean $\lambda$, appear, each uniform over the
#   sensor's range $[0, r_{\max}]$ and bearing $(-\pi, \pi]$, of density
#   $c(z) = 1 / (2 \pi r_{\max})$;
# - the readings of a step come in random order.
#
# **One reading.** Suppose a step brings one reading $z$. It either is the landmark's (detected,
# probability $P_D$; landmark $j$ with probability $1/M$; and no clutter appeared, probability
# $e^{-\lambda}$), or it is clutter (missed, probability $1 - P_D$; exactly one clutter
# reading, probability $\lambda e^{-\lambda}$, at density $c(z)$). The law of total probability
# over these $M + 1$ origins gives
#
# $$
# p(z \mid x) \;=\; e^{-\lambda} \Big[ (1 - P_D)\, \lambda\, c(z)
#   \;+\; \sum_{j=1}^{M} \frac{P_D}{M}\, \mathcal N\big(z;\, h_j(x),\, R\big) \Big].
# $$
#
# With $P_D = 1$, $\lambda = 0$ and $M = 1$ this is the known-association likelihood of
# {doc}`../part2/robot`. The clutter term is a floor: a reading that no landmark explains makes
# a particle unlikely, not impossible.
#
# **Several readings.** With $n$ readings $Z = \{z_1, \dots, z_n\}$, at most one is the
# landmark's; the others are clutter, $n - 1$ (or $n$) Poisson points. Summing over which reading
# $i$ is the landmark's, and which landmark $j$ it is,
#
# $$
# p(Z \mid x) \;=\; e^{-\lambda} \Big[ (1 - P_D)\, \lambda^{n} c^{n}
#   \;+\; \sum_{i=1}^{n} \sum_{j=1}^{M} \frac{P_D}{M}\, \mathcal N\big(z_i;\, h_j(x), R\big)\, \lambda^{n-1} c^{n-1} \Big],
# $$
#
# the one-reading mixture when $n = 1$. A step with no reading has $p = (1 - P_D)\, e^{-\lambda}$
# whatever $x$: it changes no weight. Each term is a product, so **in the log domain** each is a sum
# of logs, and the bracket is one $\operatorname{logsumexp}$ over $nM + 1$ terms per particle: no
# Gaussian density is ever exponentiated, and a particle far from every landmark keeps a finite
# log-weight {cite:p}`bartse1975`.
#
# :::{admonition} Algorithm 24.1: the particle filter with anonymous readings
# :class: algorithm
# 1. **Initialise** $x_0^i$ around the start; $\log W_0^i = -\log N$.
# 2. **For** $k = 1, 2, \dots$:
#    1. *propose* $x_k^i \sim p(x_k \mid x_{k-1}^i)$ (the odometry);
#    2. *weight*, if the step has readings $z_1, \dots, z_n$: for every particle, reading $i$ and
#       landmark $j$, $\ell_{ij}^i = \log \mathcal N\big(z_i;\, h_j(x_k^i), R\big)$ (bearing innovation
#       wrapped), and
#       $\log \tilde w_k^i = \log W_{k-1}^i - \lambda + \operatorname{logsumexp}\big(
#       \log(1 - P_D) + n \log \lambda + n \log c,\;
#       \{\log \tfrac{P_D}{M} + (n - 1)(\log \lambda + \log c) + \ell_{ij}^i\}_{i, j}\big)$;
#    3. *normalise*, estimate and resample as in {doc}`../part1/sir`.
# :::
#
# **The EKF must choose.** A Kalman update needs one Gaussian measurement; a mixture is not one.
# The classic answer is **nearest-neighbour association with a gate**
# {cite:p}`barshalom2001,thrun2005`: for each reading, compute for every landmark the innovation
# $\nu_j = z - h_j(\hat m)$, its covariance $S_j = H_j P H_j^\top + R$ and the squared Mahalanobis
# distance $d_j^2 = \nu_j^\top S_j^{-1} \nu_j$; take the nearest landmark, and update with it only
# if $d_j^2 \le \gamma$, with $\gamma$ the $99\,\%$ quantile of $\chi^2_2$ (a correct reading falls
# outside the gate once in a hundred); otherwise call the reading clutter.
#
# :::{admonition} Algorithm 24.2: the EKF with nearest-neighbour association
# :class: algorithm
# 1. **Predict** $\hat m, P$ with the odometry, as the robot's EKF ({doc}`../part2/robot_vs_kalman`).
# 2. **For each reading** $z$ of the step: $j^\star = \arg\min_j d_j^2$; if $d_{j^\star}^2 \le \gamma$,
#    update with landmark $j^\star$ (gain $K_k = P H^\top S^{-1}$, Joseph form for $P$); else discard $z$.
# :::
#
# The EKF's choice is all or nothing: when two landmarks, or a landmark and a clutter reading,
# both fit, it commits to one and its covariance says it is sure. The particle filter keeps every
# origin in the weights. Where does that matter? When the filter is uncertain. The robot here
# drives forward at $0.5$ m/s for $300$ s among the lab's $M = 5$ landmarks, with no reading for
# $100$ s in the middle, $P_D = 0.9$, $r_{\max} = 200$ m, and the filters' noise covariances twice
# the true ones (as in {doc}`../part2/robot_vs_kalman`). Without readings the heading uncertainty
# grows, and at tens of metres a small heading error moves a predicted landmark by metres.

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.special import logsumexp, xlogy

from pfcourse import evidence
from pfcourse.exercises import check_anonymous_likelihood
from pfcourse.experiments import association as study
from pfcourse.experiments.registry import STUDIES
from pfcourse.figures.report import EvidenceBlock, glue_values
from pfcourse.filter import ParticleFilter
from pfcourse.metrics import position_error
from pfcourse.robot import RobotModel
from pfcourse.robot.association import AssociationModel, run_nn_ekf
from pfcourse.seeding import filter_rng
from pfcourse.style import COLORS, use_style

use_style()
RUN, CLUTTER = 5, 4.0  # the run drawn below, and the clutter rate lambda of the headline comparison
sim, sensor, data = study.simulate_run(RUN, CLUTTER)
model = AssociationModel(RobotModel.for_simulation(sim), sensor)

# %% [markdown]
# ## The mixture weight in NumPy, checked on the package
#
# The function below is the *weight* step of Algorithm 24.1 for a cloud `x` of shape $(N, 3)$ and the
# readings of one step (rows of NaN pad a step to a fixed width): every particle against every
# reading and every landmark at once, then one `logsumexp` per particle.

# %%
def mixture_weight(x, readings, landmarks, R, p_detect, clutter_rate, max_range):
    """log p(Z | x^i) for every particle (rows of x): the mixture over the readings' origins."""
    Z = readings[~np.isnan(readings).all(axis=1)]  # the step's n readings, (n, 2)
    n, M = len(Z), len(landmarks)
    log_c = -np.log(2 * np.pi * max_range)  # clutter: uniform in range and bearing
    d = landmarks[None, :, :] - x[:, None, :2]  # (N, M, 2): from each particle to each landmark
    predicted = np.stack([np.hypot(d[..., 0], d[..., 1]),
                          np.arctan2(d[..., 1], d[..., 0]) - x[:, None, 2]], axis=-1)
    nu = Z[None, :, None, :] - predicted[:, None]  # (N, n, M, 2) innovations
    nu[..., 1] = np.angle(np.exp(1j * nu[..., 1]))  # bearing wrapped to (-pi, pi]
    log_gauss = -0.5 * (np.einsum("...a,ab,...b->...", nu, np.linalg.inv(R), nu)
                        + np.linalg.slogdet(2 * np.pi * R)[1])
    missed = np.log1p(-p_detect) + xlogy(n, clutter_rate) + n * log_c  # all n readings are clutter
    found = np.log(p_detect / M) + xlogy(n - 1, clutter_rate) + (n - 1) * log_c + log_gauss
    terms = np.concatenate([np.full((len(x), 1), missed), found.reshape(len(x), -1)], axis=1)
    return logsumexp(terms, axis=1) - clutter_rate


steps = np.flatnonzero((~np.isnan(data.readings).all(axis=2)).any(axis=1))  # steps with readings
cloud = model.sample_initial(1000, np.random.default_rng(1))
worst = max(np.max(np.abs(mixture_weight(cloud, data.readings[k], sim.landmarks, model.base.r_est,
                                         sensor.p_detect, sensor.clutter_rate, sensor.max_range)
                       - model.log_likelihood(cloud, data.readings[k], k))) for k in steps[:20])
TOLERANCE = 1e-9
print(f"largest difference from the package's log-likelihood over {len(steps[:20])} steps: below "
      f"{TOLERANCE:.0e}: {worst < TOLERANCE}")

# %% [markdown]
# The two agree to round-off (below {glue:text}`association_check_tolerance:.0e` on
# $1000$ particles at every one of the first $20$ steps with readings). The package's
# `AssociationModel` gives that log-likelihood to the engine, `ParticleFilter`, unchanged.
#
# ## One run: the particle filter and the EKF on the same readings
#
# Run $5$ at a clutter rate of $\lambda = 4$ readings per step, with $N = 500$ particles. It is
# a run in which the EKF goes wrong, chosen to show how; the study below says how often.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values("association_", check_tolerance=TOLERANCE)

# %%
pf = ParticleFilter(model, study.N_PARTICLES).run(data.readings, rng=filter_rng(0, RUN))
ekf, chosen = run_nn_ekf(model, data.readings)
t = np.arange(len(sim.truth)) * sim.scenario.dt
k, i = np.nonzero(data.origin == -1)  # clutter readings, drawn where they point from the true pose
angle = sim.truth[k, 2] + data.readings[k, i, 1]
clutter_xy = sim.truth[k, :2] + data.readings[k, i, :1] * np.column_stack([np.cos(angle), np.sin(angle)])

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 4.2))
ax1.scatter(*clutter_xy.T, s=4, color=COLORS["unseen"], alpha=0.4, label="clutter readings")
ax1.plot(*sim.landmarks.T, "k^", ms=9, label="landmarks (alike)")
ax1.plot(*sim.truth[:, :2].T, "--", color=COLORS["truth"], label="truth")
ax1.plot(*pf.mean[:, :2].T, color=COLORS["estimate"], label="particle filter")
ax1.plot(*ekf.mean[:, :2].T, color=COLORS["kalman"], label="nearest-neighbour EKF")
view = np.vstack([sim.landmarks, sim.truth[:, :2]])
ax1.set(xlim=(view[:, 0].min() - 15, view[:, 0].max() + 15), ylim=(view[:, 1].min() - 15, view[:, 1].max() + 15),
        xlabel="x (m)", ylabel="y (m)", aspect="equal")
ax1.set_title(f"Run {RUN}, clutter rate {CLUTTER:g} per step")
ax2.axvspan(100, 200, color=COLORS["unseen"], alpha=0.2, label="no readings")
ax2.semilogy(t, position_error(sim.truth, pf.mean), color=COLORS["estimate"], label="particle filter")
ax2.semilogy(t, position_error(sim.truth, ekf.mean), color=COLORS["kalman"], label="nearest-neighbour EKF")
ax2.set(xlabel="time t (s)", ylabel="position error (m)")
handles = ax1.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0][:1]
ax2.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1))  # one legend for both panels
plt.tight_layout()
plt.show()

# %% [markdown]
# Both filters drift through the gap alike. When the readings return, the EKF's covariance has
# grown, so its gates are wide; a clutter reading falls inside one, the EKF takes it for a landmark
# and jumps away from the truth. Now confident and wrong, its gates are narrow and in the wrong
# place: it makes {glue:text}`association_run_wrong:d` wrong associations in the run and discards
# {glue:text}`association_run_gated:.0%` of the readings as clutter, and never recovers. The
# particle filter weighs every origin: the clutter reading explains the readings that follow
# worse than the landmark does, and the weights settle on the right association.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
run_wrong = int(np.sum((chosen >= 0) & (chosen != data.origin)))
pf_run_rmse, ekf_run_rmse = study.position_rmse(sim.truth, pf.mean), study.position_rmse(sim.truth, ekf.mean)
run_gated = np.sum(chosen == -1) / data.counts.sum()
glue_values("association_", run_wrong=run_wrong, run_gated=run_gated, run_pf_rmse=pf_run_rmse,
            run_ekf_rmse=ekf_run_rmse)
EvidenceBlock(
    f"in run {RUN} the EKF makes {run_wrong} wrong associations",
    notes=[f"Readings in the run: {int(data.counts.sum())}, of which clutter {int(data.clutter_counts.sum())}; "
           f"readings the EKF gated out as clutter: {int(np.sum(chosen == -1))}.",
           f"Position RMSE over the run: particle filter {pf_run_rmse:.2f} m, EKF {ekf_run_rmse:.2f} m.",
           f"Final position error: particle filter {position_error(sim.truth, pf.mean)[-1]:.2f} m, "
           f"EKF {position_error(sim.truth, ekf.mean)[-1]:.2f} m."],
)

# %% [markdown]
# ## How often, and how much: a hundred runs
#
# Each of $n_\text{runs} = 100$ runs simulates its robot and readings once; the particle filter
# and the EKF filter the same readings (common random numbers), at clutter rates $\lambda = 0$,
# $1$, $2$ and $4$ per step, the robot and its detections the same at every rate. The
# $400$ pairs of runs take several minutes on two cores, so they are a stored study
# (`python3 tasks.py study data_association`, `book/data/data_association.csv` with its
# provenance; a test re-computes a sample of its rows). The error of a run is its position RMSE,
# $\sqrt{\tfrac1K \sum_k \lVert \hat p_k - p_k \rVert^2}$, and a filter **loses** a run when its
# RMSE is more than $2$ times the other filter's on the same readings.

# %%
table = STUDIES["data_association"].load()
LOSS_FACTOR = 2.0


def compare(r):
    """The two filters on the runs at clutter rate r: mean RMSEs and their paired difference, losses."""
    t = table[table["clutter_rate"] == r]
    ekf, pf = t["ekf_rmse_m"].to_numpy(), t["pf_rmse_m"].to_numpy()
    means = evidence.run_interval(lambda runs: np.array([pf[runs].mean(), ekf[runs].mean(),
                                                         ekf[runs].mean() - pf[runs].mean()]), len(t))
    return {"pf": pf.mean(), "ekf": ekf.mean(), "means": np.array(means)[:, :2],  # (value, low, high) x filter
            "difference": tuple(float(v[2]) for v in means),
            "ratio": evidence.paired(ekf, pf, ratio=True),
            "ekf_loses": evidence.rate(ekf > LOSS_FACTOR * pf), "pf_loses": evidence.rate(pf > LOSS_FACTOR * ekf),
            "wrong": t["ekf_wrong"].mean(), "clutter": t["clutter"].mean(), "runs": len(t)}


rates = sorted(table["clutter_rate"].unique())
results = {r: compare(r) for r in rates}
main = results[CLUTTER]
print(f"lambda = {CLUTTER:g}: mean RMSE, particle filter {main['pf']:.2f} m, EKF {main['ekf']:.2f} m; "
      "EKF - PF: {:.2f} m (95 % interval {:.2f} to {:.2f})".format(*main["difference"]))
print(f"the EKF loses: {main['ekf_loses']}; the particle filter loses: {main['pf_loses']}")

# %%
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 3.6))
for key, name, color, shift in (("pf", "particle filter", COLORS["estimate"], -0.05),
                                ("ekf", "nearest-neighbour EKF", COLORS["kalman"], 0.05)):
    m, lo, hi = np.array([results[r]["means"][:, 0 if key == "pf" else 1] for r in rates]).T
    ax1.errorbar(np.array(rates) + shift, m, yerr=[m - lo, hi - m], marker="o", capsize=3, color=color, label=name)
    losses = [results[r][f"{key}_loses"] for r in rates]
    share = np.array([x.estimate for x in losses])
    ax2.errorbar(np.array(rates) + shift, 100 * share,
                 yerr=[100 * (share - [x.low for x in losses]), 100 * (np.array([x.high for x in losses]) - share)],
                 marker="o", capsize=3, color=color, label=name)
ax1.set(xlabel=r"clutter rate $\lambda$ (readings per step)", ylabel="mean position RMSE (m)")
ax1.set_title("Mean over 100 runs, 95 % interval")
ax2.set(xlabel=r"clutter rate $\lambda$ (readings per step)", ylabel="runs lost (%)")
ax2.set_title("RMSE more than twice the other filter's")
ax2.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
plt.tight_layout()
plt.show()

# %% [markdown]
# At $\lambda = 4$ clutter readings per step the mean position RMSE over the runs is
# {glue:text}`association_pf_rmse_m:.2f` m for the particle filter and
# {glue:text}`association_ekf_rmse_m:.2f` m for the EKF on the same runs.
#
# The EKF's excess is {glue:text}`association_difference:.2f` m (95 % interval
# {glue:text}`association_difference_low:.2f` to {glue:text}`association_difference_high:.2f` m),
# and it comes from the runs the EKF loses, {glue:text}`association_ekf_loses:.0%` of them.
#
# The typical run tells another story: run by run, the median ratio of the EKF's RMSE to the
# particle filter's is {glue:text}`association_median_ratio:.2f`: in most runs the two are within
# a few percent of each other, the EKF often slightly ahead, since $N = 500$ particles add a Monte
# Carlo error the EKF does not have. The EKF is as good when it chooses right; clutter makes it choose wrong more often (it loses
# {glue:text}`association_ekf_loses_clean:.0%` of the runs without clutter, where the look-alike
# landmarks alone mislead it), while the particle filter loses almost none. The evidence block
# gives every clutter rate.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
diff, low, high = main["difference"]
glue_values("association_", pf_rmse_m=main["pf"], ekf_rmse_m=main["ekf"], difference=diff, difference_low=low,
            difference_high=high, ekf_loses=main["ekf_loses"].estimate, ekf_loses_low=main["ekf_loses"].low,
            ekf_loses_high=main["ekf_loses"].high, median_ratio=main["ratio"].median,
            ekf_loses_clean=results[0.0]["ekf_loses"].estimate, runs=main["runs"])


at = table[table["clutter_rate"] == CLUTTER]
excess = (at["ekf_rmse_m"] - at["pf_rmse_m"]).to_numpy()
lost = at["ekf_rmse_m"].to_numpy() > LOSS_FACTOR * at["pf_rmse_m"].to_numpy()
kept = evidence.run_interval(lambda runs: excess[~lost][runs].mean(), int(np.sum(~lost)))
lost_share = excess[lost].sum() / len(excess)


def row_of(r):
    x = results[r]
    return {"clutter rate (per step)": r, "PF mean RMSE (m)": x["pf"], "EKF mean RMSE (m)": x["ekf"],
            "EKF - PF (m)": x["difference"][0],
            "95 % interval (m)": f"{x['difference'][1]:.2f} to {x['difference'][2]:.2f}",
            "EKF/PF median ratio": x["ratio"].median,
            "ratio interval": f"{x['ratio'].low:.2f} to {x['ratio'].high:.2f}", "Wilcoxon p": x["ratio"].pvalue,
            "EKF loses": str(x["ekf_loses"]), "PF loses": str(x["pf_loses"]),
            "EKF wrong associations (mean per run)": x["wrong"], "clutter readings (mean per run)": x["clutter"]}


EvidenceBlock(
    f"at a clutter rate of {CLUTTER:g} the EKF's mean error exceeds the particle filter's by {diff:.2f} m",
    notes=[f"{main['runs']} runs per clutter rate (seeds 0 to {main['runs'] - 1}): the robot and its readings from "
           "pfcourse.seeding.data_rng(0, r), the particle filter from filter_rng(0, r); the EKF is deterministic. "
           f"N = {study.N_PARTICLES} particles, bootstrap, systematic resampling when ESS < N/2; gate: the "
           "99 % quantile of chi-square with 2 degrees of freedom.",
           f"Mean RMSE difference EKF - PF at lambda = {CLUTTER:g}: {diff:.2f} m, 95 % interval {low:.2f} to "
           f"{high:.2f} m (percentile bootstrap over the runs).",
           f"EKF / PF RMSE run by run: {main['ratio']}.",
           f"Runs the EKF loses (RMSE more than {LOSS_FACTOR:g} times the PF's): {main['ekf_loses']}; runs the "
           f"particle filter loses: {main['pf_loses']}.",
           f"Where the excess comes from: over the runs the EKF does not lose, the mean RMSE difference EKF - PF "
           f"is {kept[0]:.2f} m (95 % interval {kept[1]:.2f} to {kept[2]:.2f} m); the lost runs contribute "
           f"{lost_share:.2f} m of the {diff:.2f} m mean excess.",
           "Wilson intervals for shares; see Reading the evidence (evidence.md)."],
    tables=[("Both filters on the same runs, by clutter rate", pd.DataFrame([row_of(r) for r in rates]),
             {"PF mean RMSE (m)": ".2f", "EKF mean RMSE (m)": ".2f", "EKF - PF (m)": ".2f",
              "EKF/PF median ratio": ".2f", "Wilcoxon p": ".2g", "EKF wrong associations (mean per run)": ".1f",
              "clutter readings (mean per run)": ".0f"})],
)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 24.1 An empty step
# :label: ex-assoc-empty
# :nonumber:
# A measurement step brings no reading at all. Write $p(\varnothing \mid x)$ for the model of this
# chapter and say what it does to the particles' weights. Would it still be uninformative if the
# detection probability depended on the distance to the landmark?
# ```
#
# ```{solution} ex-assoc-empty
# :class: dropdown
# No reading means a miss and no clutter: $p(\varnothing \mid x) = (1 - P_D)\, e^{-\lambda}$, the same for
# every $x$, so the normalised weights do not change. If $P_D$ fell with the distance, a silent step
# would favour the particles far from the landmarks: "nothing seen" then carries information, and
# the weight is the probability of a miss and no clutter,
# $e^{-\lambda} \tfrac1M \sum_j \big(1 - P_D(x, l^j)\big)$.
# ```
#
# ```{exercise} 24.2 The likelihood of one anonymous reading
# :label: ex-assoc-code
# :nonumber:
# (Coding.) Write `my_anonymous(x, z, landmarks, R, p_detect, clutter_rate, max_range)`: the
# log-likelihood $\log p(z \mid x^i)$ of one reading $z = (r, b)$ for every particle $x^i$ (rows of
# `x`, shape $(N, 3)$), by the one-reading mixture above, in the log domain with `logsumexp`
# ($R$ is a covariance; wrap the bearing innovation). The checker compares it with the exact
# value on three readings and names the mistake it sees.
# ```

# %% tags=["answer"]
def my_anonymous(x, z, landmarks, R, p_detect, clutter_rate, max_range):
    """Your function: return log p(z | x^i), shape (N,)."""
    ...  # replace with your code


print(check_anonymous_likelihood(my_anonymous))

# %% [markdown]
# ```{solution} ex-assoc-code
# :class: dropdown
# One Gaussian log-density per landmark and particle, the clutter term beside them, and
# `logsumexp` over the $M + 1$ terms; the code is in the folded cell below (in JupyterLab, click its
# margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_anonymous(x, z, landmarks, R, p_detect, clutter_rate, max_range):
    d = landmarks[None, :, :] - x[:, None, :2]  # (N, M, 2)
    nu = np.stack([z[0] - np.hypot(d[..., 0], d[..., 1]),
                   z[1] - np.arctan2(d[..., 1], d[..., 0]) + x[:, None, 2]], axis=-1)
    nu[..., 1] = np.angle(np.exp(1j * nu[..., 1]))  # wrapped bearing innovation
    log_gauss = -0.5 * (np.einsum("...a,ab,...b->...", nu, np.linalg.inv(R), nu)
                        + np.linalg.slogdet(2 * np.pi * R)[1])
    with np.errstate(divide="ignore"):  # lambda = 0: no clutter term, log 0 = -inf
        clutter = np.log((1 - p_detect) * clutter_rate / (2 * np.pi * max_range))
    terms = np.column_stack([np.full(len(x), clutter), np.log(p_detect / len(landmarks)) + log_gauss])
    return logsumexp(terms, axis=1) - clutter_rate


print(check_anonymous_likelihood(my_anonymous))

# %% [markdown]
# ## Takeaways
#
# - When readings are anonymous, missed and polluted by clutter, the likelihood of a step is a
#   mixture over the readings' origins: every landmark, weighted $P_D / M$, and the clutter.
# - In the log domain the mixture is one `logsumexp` per particle over $nM + 1$ terms; the clutter
#   term keeps a particle that no landmark explains unlikely rather than impossible.
# - A particle filter needs nothing more: the weights carry every association. An EKF must choose
#   one, by nearest neighbour and a gate, and a wrong choice is made with confidence.
# - The EKF is as accurate as the particle filter while it chooses right; its risk is a tail of lost
#   runs, which grows with the clutter and with the filter's uncertainty (here, after a gap).
