# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Sequential importance sampling
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** how importance sampling runs through time: each particle carries a weight
# that is the likelihood of its whole path; you write that filter in twenty lines of NumPy,
# and you watch its weights degenerate until one particle holds them all, whatever the
# number of particles.
#
# **You need** {doc}`model` and {doc}`importance_sampling`; Gaussian densities; NumPy arrays
# and a random generator.
#
# **Time:** about fifteen minutes to read, plus about twelve minutes for the folded blocks; the exercises are extra.
# :::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# Setup: the book's engine, figures, evidence and glue helpers (not needed to follow the chapter).
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display
from scipy.special import logsumexp

from pfcourse import evidence
from pfcourse.book.exercises import check_sis
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.book.figures.bands import posterior_bands
from pfcourse.book.figures.clouds import animate_clouds
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.style import COLORS, plain_log_axis, use_style
from pfcourse.book.panels import control_panel, particle_slider, scale_slider, seed_box
from pfcourse.seeding import run_filter_seed, study_filter_seed

use_style()
LABELS = ["robot x", "robot y", "L1 x", "L1 y", "L2 x", "L2 y"]
scenario = quadrant_scenario()
model = scenario.model()  # the simulator's own noise models

# %% [markdown]
# (sis-algorithm)=
# ## The idea: weight whole paths
#
# A robot moves among two landmarks it sees now and then ({doc}`model`). A filter must update
# its belief as each measurement arrives, so the importance sampling of
# {doc}`importance_sampling` has to run through time. The trick is to sample whole paths
# $x_{0:k}$, one step at a time, and keep each path's weight up to date. The posterior of a
# path factorises by the model's structure:
#
# $$
# p(x_{0:k} \mid z_{1:k}) \;\propto\; p(x_0) \prod_{j=1}^{k} p(x_j \mid x_{j-1})\, p(z_j \mid x_j) .
# $$
#
# Draw $x_0^i \sim p(x_0)$, then extend each path by $x_k^i \sim q(x_k \mid x_{k-1}^i, z_k)$. The
# target gains a factor $p(z_k \mid x_k)\, p(x_k \mid x_{k-1})$ and the proposal a factor $q$, so the
# unnormalised weight $\tilde w_k^i$ is the previous normalised weight times their ratio, the
# *incremental weight* $G_k^i$:
#
# $$
# \tilde w_k^i = W_{k-1}^i\, G_k^i, \qquad W_k^i = \frac{\tilde w_k^i}{\sum_j \tilde w_k^j},
# $$
#
# $$
# G_k^i = \frac{p(z_k \mid x_k^i)\, p(x_k^i \mid x_{k-1}^i)}{q(x_k^i \mid x_{k-1}^i, z_k)} .
# $$
#
# The simplest proposal is the transition itself, $q = p(x_k \mid x_{k-1})$, the *bootstrap*
# choice of {cite:t}`gordon1993`: it needs nothing but the simulator, and $G_k^i = p(z_k \mid x_k^i)$.
# Unrolled, **a particle's weight is the likelihood of its whole path**,
# $W_k^i \propto \prod_{j \le k} p(z_j \mid x_j^i)$. That product is also why SIS fails: each
# measurement multiplies the weights by a factor that favours a few paths, and the variance of
# the weights, taken over the data as well as the draws, can only grow with $k$
# {cite:p}`kong1994,doucet2000`; for one fixed data set it almost always grows too. The effective sample size
# $\mathrm{ESS}_k = 1 / \sum_i (W_k^i)^2$ counts how many particles still count.
#
# :::{admonition} Algorithm 4.1: sequential importance sampling with the bootstrap proposal
# :class: algorithm
# 1. **Initialise.** Draw $x_0^i \sim p(x_0)$ for $i = 1, \dots, N$; set $\log W_0^i = -\log N$.
# 2. **For** $k = 1, 2, \dots$:
#    1. *propose:* $x_k^i \sim p(x_k \mid x_{k-1}^i)$, here
#       $x_k^i \sim \mathcal N(F x_{k-1}^i,\ Q)$;
#    2. *weight:* $\log \tilde w_k^i = \log W_{k-1}^i + \log p(z_k \mid x_k^i)$ (the second term
#       is $0$ when nothing is measured);
#    3. *normalise:* $\log W_k^i = \log \tilde w_k^i - \operatorname{logsumexp}_j \log \tilde w_k^j$;
#    4. *estimate:* $\hat m_k = \sum_i W_k^i x_k^i$ and $\mathrm{ESS}_k = 1 / \sum_i (W_k^i)^2$.
# :::
#
# ## SIS in twenty lines
#
# The model of {doc}`model`, written out: the state is the robot's position and the two
# landmarks', $(r_x, r_y, l^1_x, l^1_y, l^2_x, l^2_y)$ in metres; the robot turns by $\pi/4$ a step
# about the origin; a landmark in view is measured as its offset $l^j - r$, with noise of
# $0.1$ m; NaN marks a landmark out of view.

# %%
import numpy as np
from scipy.special import logsumexp
from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate

c, s = np.cos(np.pi / 4), np.sin(np.pi / 4)
F = np.eye(6)
# the robot turns pi/4 a step about (0, 0); the landmarks stay
F[:2, :2] = [[c, -s], [s, c]]
# z = (l1 - r, l2 - r)
H = np.kron(np.hstack([-np.ones((2, 1)), np.eye(2)]), np.eye(2))
m0 = np.array([2.0, 0.0, -1.0, 4.0, 4.0, -1.0])
P0 = np.diag([0.1, 0.2, 0.2, 0.2, 0.2, 0.2])
Q = np.diag([0.05**2, 0.05**2, 1e-20, 1e-20, 1e-20, 1e-20])
sd_v = 0.1
Z = simulate(quadrant_scenario(), rng=2024).measurements  # (50, 4)


def sis(Z, N, rng):
    """Algorithm 4.1: the weighted means (T + 1, 6) and the ESS (T + 1,)."""
    L0, LQ = np.linalg.cholesky(P0), np.linalg.cholesky(Q)
    x = m0 + rng.standard_normal((N, 6)) @ L0.T
    log_W = np.full(N, -np.log(N))
    means, ess = [], []
    for k, z in enumerate(Z):
        if k > 0:
            # propose from the transition
            x = x @ F.T + rng.standard_normal((N, 6)) @ LQ.T
        # weight by log p(z_k | x_k), up to a constant, then normalise
        seen = ~np.isnan(z)
        nu = z[seen] - x @ H[seen].T
        log_W = log_W - 0.5 * np.sum(nu**2, axis=1) / sd_v**2
        log_W = log_W - logsumexp(log_W)
        W = np.exp(log_W)
        means.append(W @ x)
        ess.append(1 / np.sum(W**2))
    return np.array(means), np.array(ess)


means, ess = sis(Z, 100, np.random.default_rng(1))
print("ESS at steps 0 to 9:", np.round(ess[:10], 1))

# %% tags=["remove-input"] jupyter={"source_hidden": true}
sim = simulate(scenario, rng=2024)
kf = kalman_filter(model, sim.measurements)
res = ParticleFilter(model, 100, threshold=0.0).run(sim.measurements, rng=1,
                                                   collect=[Clouds()])
ROUND_OFF = 1e-9
same_model = all(np.allclose(a, b) for a, b in ((F, model.F), (H, model.H), (m0, model.m0), (P0, model.P0),
                                                (Q, model.Q), (sd_v**2 * np.eye(4), model.R))) and not model.B.any()
gap = max(np.abs(means - res.mean).max(), np.abs(ess - res.ess).max() / 100)
# a weight is the likelihood of its path: recomputed from the stored paths (no resampling: i keeps its index)
paths = res.particles  # (steps, N, 6)
log_path = np.cumsum([np.where(np.isnan(z)[None, :], 0.0, -0.5 * (z - x @ H.T) ** 2 / sd_v**2).sum(axis=1)
                      for z, x in zip(sim.measurements, paths)], axis=0)
W_path = np.exp(log_path - logsumexp(log_path, axis=1, keepdims=True))
path_gap = np.abs(W_path - res.weights).max()
print(f"the matrices are the package's model: {same_model}")
print(f"the twenty lines give the engine's means and ESS (within {ROUND_OFF:.0e}): {gap < ROUND_OFF}")
print(f"the engine's weights are the likelihoods of the paths (within {ROUND_OFF:.0e}): {path_gap < ROUND_OFF}")
glue_values(sis_path_weight_bound=ROUND_OFF, sis_first_below2=int(np.argmax(ess < 2)))

# %% [markdown]
# The ESS falls from $100$ to below $2$ already at step {glue:text}`sis_first_below2:d`. The same
# lines with the same seed give the means and ESS of the book's engine,
# `ParticleFilter(model, N, threshold=0)` (it resamples when the ESS falls below `threshold`
# times $N$, so with $0$ it never does: it is SIS),
# to round-off (below {glue:text}`sis_path_weight_bound:.0e`), and the engine's weights are the
# likelihoods of the stored paths, multiplied along each path. Now look at what that product
# does to the estimate.
#
# ## One run with $N = 100$ particles

# %% tags=["hide-input"] jupyter={"source_hidden": true}
posterior_bands(sim.T, sim.truth, kf, res, LABELS, "SIS", "SIS (N = 100) against the exact posterior; dashed: truth")
plt.show()

# %% [markdown]
# Within a few steps the SIS band (red) shrinks to a line while the exact one (green) does
# not: the cloud claims a certainty it does not have. The estimate follows whichever particle
# dominates; the band reopens briefly when another takes over, which happens
# {glue:text}`sis_dominant_changes` times after step $5$ in this run. The ESS falls to
# {glue:text}`sis_first_sighting_ess:.1f` at the first sighting of a landmark, step
# {glue:text}`sis_first_sighting_step:d`.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
leader = res.weights.argmax(axis=1)
changes = int(np.sum(leader[6:] != leader[5:-1]))
first_sighting = int(np.flatnonzero(sim.seen.any(axis=1))[0])
glue_values(sis_dominant_changes=changes, sis_first_sighting_step=first_sighting,
            sis_first_sighting_ess=float(res.ess[first_sighting]))
EvidenceBlock(
    "the weights of this run collapse",
    notes=[f"ESS at the first ten steps: {', '.join(f'{e:.1f}' for e in res.ess[:10])}.",
           f"Largest weight at step 10: {res.weights[10].max():.4f}.",
           f"The dominant particle changes {changes} times after step 5, at steps "
           f"{', '.join(str(k) for k in np.flatnonzero(leader[6:] != leader[5:-1]) + 6)}."],
    tables=[("Trace of the covariance of the robot and landmark positions (m²)",
             pd.DataFrame({"step k": [0, 5, 49], "SIS": [np.trace(res.cov[k]) for k in (0, 5, 49)],
                           "Kalman (exact)": [np.trace(kf.cov[k]) for k in (0, 5, 49)]}),
             {"SIS": ".2e", "Kalman (exact)": ".2e"})],
)

# %% [markdown]
# The weight histograms show where the mass goes: at step $k = 0$ every weight is $1/N$; after a
# couple of measurements most weights are negligible (the bar at $-30$ holds every weight below
# $10^{-30}$); soon one particle holds it all. The
# animation shows the cloud (dot size proportional to weight) with the 95 % ellipses of the
# robot and the two landmarks: SIS in red, the exact posterior in green.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
steps = [0, 2, 4, 8]
fig, axes = plt.subplots(1, 4, figsize=(10, 2.8), sharey=True)
for ax, k in zip(axes, steps):
    ax.hist(np.log10(np.maximum(res.weights[k], 1e-30)), bins=30, range=(-30, 0),
            color=COLORS["particles"])
    ax.set_title(f"k = {k}, ESS = {res.ess[k]:.1f}")
    ax.set_xlabel(r"$\log_{10} W_k^i$ (below $-30$: at $-30$)")
axes[0].set_ylabel("number of particles")
plt.show()

# %% tags=["hide-input"] jupyter={"source_hidden": true}
HTML(animate_clouds({"SIS, N = 100": res}, kf, sim.truth, range(0, 30), interval=200).to_jshtml())

# %% [markdown]
# (sis-degeneracy)=
# ## Does a larger N save SIS?
#
# One run shows the collapse; does it depend on the run, and does a larger $N$ help? For
# $N = 100$, $1000$ and $10\,000$ we run SIS on {glue:text}`sis_degeneracy_runs:d` simulations
# (common random numbers: the same data for every $N$) and record the first step at which
# $\mathrm{ESS} < 2$, "about one particle", over the first {glue:text}`sis_horizon:d` steps.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
n_runs, horizon = 50, 15
N_values = (100, 1000, 10_000)
ess = {N: np.empty((n_runs, horizon)) for N in N_values}
for seed in range(n_runs):
    Z = simulate(scenario, rng=seed).measurements[:horizon]
    for N in N_values:
        ess[N][seed] = ParticleFilter(model, N, threshold=0.0).run(Z, rng=study_filter_seed(seed)).ess


def first_below(e, level=2.0):
    hit = e < level
    return np.where(hit.any(axis=1), hit.argmax(axis=1), horizon).astype(float)


# run by run (paired: the same data), how many steps later N = 10 000 collapses than N = 100
later = first_below(ess[10_000]) - first_below(ess[100])
mean_delay, low, high = evidence.run_interval(lambda runs: later[runs].mean(), n_runs)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
k = np.arange(horizon)
for N, c in zip(N_values, ("tab:red", "tab:purple", "tab:blue")):
    med = np.median(ess[N] / N, axis=0)
    lo, hi = np.percentile(ess[N] / N, [10, 90], axis=0)
    ax1.semilogy(k, med, color=c, label=f"N = {N}")
    ax1.fill_between(k, lo, hi, color=c, alpha=0.2)
ax1.set_xlabel("step k")
ax1.set_ylabel("ESS / N")
ax1.set_title(f"SIS: median and 10-90 % band, {n_runs} runs")
ax1.legend(loc="lower left")  # the curves start at the top left
ax2.boxplot([first_below(ess[N]) for N in N_values], tick_labels=[str(N) for N in N_values])
ax2.set_xlabel("number of particles N")
ax2.set_ylabel("first step with ESS < 2")
ax2.set_title(f"Time to degeneracy, {n_runs} runs")
plt.show()

# %% [markdown]
# Multiplying $N$ by $100$ delays the collapse by {glue:text}`sis_delay_mean:.1f` steps on
# average ({glue:text}`sis_delay_mean_low:.1f` to {glue:text}`sis_delay_mean_high:.1f`), that is
# {glue:text}`sis_delay_per_decade:.1f` steps per factor of ten in $N$.
#
# Both are lower bounds: a run that never collapses within the window counts as collapsing at its
# end, and {glue:text}`sis_never_100:d`, {glue:text}`sis_never_1000:d` and
# {glue:text}`sis_never_10000:d` runs never did at the three $N$. Each step with a landmark
# in view multiplies the weights by a likelihood that is sharp ($0.1$ m noise) next to the prior
# spread of the landmarks ($\sqrt{0.2} \approx 0.45$ m), so the $N$ needed grows exponentially
# with the number of informative steps.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
delay = evidence.paired(first_below(ess[10_000]), first_below(ess[100]))
per_decade = mean_delay / np.log10(10_000 / 100)
medians = {N: float(np.median(first_below(ess[N]))) for N in N_values}
glue_values("sis_", degeneracy_runs=n_runs, horizon=horizon, median_first_100=medians[100],
            median_first_10000=medians[10_000], delay_median=delay.median, delay_low=delay.low,
            delay_high=delay.high, delay_pvalue=delay.pvalue, delay_mean=mean_delay, delay_mean_low=low,
            delay_mean_high=high, delay_per_decade=per_decade, delay_per_decade_low=low / 2,
            delay_per_decade_high=high / 2,
            decades_needed=int(round((horizon - medians[10_000]) / per_decade)),
            **{f"never_{N}": int(np.sum(first_below(ess[N]) == horizon)) for N in N_values})


def per_n_table():
    rows = []
    for N in N_values:
        f = first_below(ess[N])
        rows.append({"N": N, "median first step": np.median(f), "10 %": np.percentile(f, 10),
                     "90 %": np.percentile(f, 90), f"runs never below 2 in {horizon} steps": int(np.sum(f == horizon))})
    return pd.DataFrame(rows)


EvidenceBlock(
    f"a hundred times more particles delays the collapse by {mean_delay:.1f} steps on average",
    notes=[f"{n_runs} simulations (seeds 0 to {n_runs - 1}), the same for every N; filter seeds pfcourse.seeding.study_filter_seed(s) = s + 10**6.",
           f"Delay of N = 10 000 over N = 100, run by run: mean {mean_delay:.2f} steps, 95 % interval "
           f"{low:.2f} to {high:.2f} (percentile bootstrap over the runs). The delays are small whole "
           f"numbers, so their median ({delay.median:.0f}) and its interval say less than the mean; "
           f"Wilcoxon's signed-rank test of no delay: p = {delay.pvalue:.1g}, {delay.n} paired runs "
           "(see Reading the evidence)."],
    tables=[("First step with ESS < 2, over the runs", per_n_table(),
             {"median first step": ".0f", "10 %": ".0f", "90 %": ".0f"})],
)

# %% [markdown]
# Does broader measurement noise change the collapse? The same runs with the measurement
# noise's standard deviation doubled (simulator and filter alike): the ESS still falls below
# $2$ within {glue:text}`sis_horizon:d` steps in {glue:text}`sis_broad_collapsed:.0%` of the runs
# (at least {glue:text}`sis_broad_collapsed_low:.0%`).
#
# Broader noise delays the collapse by a
# median of {glue:text}`sis_broad_delay:.0f` step: later in {glue:text}`sis_broad_later:d` of the
# {glue:text}`sis_degeneracy_runs:d` runs, earlier in {glue:text}`sis_broad_earlier:d`. It does
# not stop it.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
sc2 = scenario.with_(Rv=2.0**2 * scenario.Rv)
ess_broad = np.array([ParticleFilter(sc2.model(), 100, threshold=0.0).run(simulate(sc2, rng=seed).measurements[:horizon],
                                                                          rng=study_filter_seed(seed)).ess
                      for seed in range(n_runs)])
first_broad, first_base = first_below(ess_broad), first_below(ess[100])
slower = evidence.paired(first_broad, first_base)
collapsed_broad = evidence.rate(first_broad < horizon)
n_later, n_earlier, sign_p = evidence.sign_test(first_base, first_broad)  # base < broad: later with x2
glue_values("sis_broad_", later=n_later, earlier=n_earlier, sign_p=sign_p, first=float(np.median(first_broad)),
            delay=slower.median, delay_low=slower.low, delay_high=slower.high, delay_p=slower.pvalue,
            collapsed=collapsed_broad.estimate, collapsed_low=collapsed_broad.low)
EvidenceBlock(
    "doubling the measurement noise does not stop the collapse",
    notes=[f"N = 100, measurement sd doubled vs the model's, same seeds: ESS < 2 first at step "
           f"{np.median(first_broad):.0f} vs {np.median(first_base):.0f} (medians); delay run by run "
           f"(steps): {slower}.",
           f"Sign test: the collapse comes later with the broader noise in {n_later} runs, earlier in "
           f"{n_earlier}, tied in {n_runs - n_later - n_earlier} (exact p = {sign_p:.1g}).",
           f"Runs with ESS < 2 within {horizon} steps with the broader noise: {collapsed_broad}."],
)

# %% [markdown]
# (log-domain)=
# ## Why the log domain
#
# A path's weight is a product of likelihoods, and a product of small numbers underflows: below
# about $e^{-745}$ a double is $0$. Multiply the weights themselves by the likelihoods, normalise
# at each step, and when every particle's weight underflows at once the weights become $0/0$. We
# run that linear-domain SIS on {glue:text}`linear_runs:d` simulations ($N = 100$), with the
# model's measurement noise ($\sigma_v = 0.1$ m) and with a ten times sharper one
# ($\sigma_v = 0.01$ m, simulator and filter alike). With $0.1$ m it fails in
# {glue:text}`linear_fail_sd01` runs (at most {glue:text}`linear_fail_sd01_high:.0%` of runs):
# the linear domain survives this sensor.
#
# With $0.01$ m it fails in {glue:text}`linear_fail_sd001`
# runs ({glue:text}`linear_fail_sd001_low:.0%` to {glue:text}`linear_fail_sd001_high:.0%`). The
# log-domain update cannot fail this way: subtracting the largest log-weight before
# exponentiating keeps the best particle at weight $e^0$.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def linear_sis_fails(Z, N, rng, model):
    """SIS with linear-domain weights W <- W p(z | x) / sum; True if they all underflow to 0."""
    x = model.sample_initial(N, rng)
    W = np.full(N, 1.0 / N)
    for k, z in enumerate(Z):
        if k > 0:
            x = model.sample_transition(x, k, rng)
        if not np.isnan(z).all():
            W = W * np.exp(model.log_likelihood(x, z, k))
            if W.sum() == 0.0:
                return True
            W = W / W.sum()
    return False


n_linear = 100
failures = {}
for sd in (0.1, 0.01):
    sc = scenario.with_(Rv=sd**2 * np.eye(4))
    m = sc.model()
    failures[sd] = evidence.rate(np.array([
        linear_sis_fails(simulate(sc, rng=s).measurements, 100, np.random.default_rng(study_filter_seed(s)), m)
        for s in range(n_linear)]))

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values("linear_", runs=n_linear, fail_sd01=failures[0.1].successes, fail_sd01_high=failures[0.1].high,
            fail_sd001=failures[0.01].successes, fail_sd001_low=failures[0.01].low, fail_sd001_high=failures[0.01].high)
EvidenceBlock(
    "linear-domain weights underflow with a sharp sensor",
    notes=[f"Landmark model, N = 100, {n_linear} simulations (seeds 0 to {n_linear - 1}), filter seeds 1000000 + s; "
           "the measurement noise is set in the simulator and the filter alike.",
           *(f"Measurement sd {sd} m: runs whose weights all underflow: {failures[sd]}." for sd in failures)],
)

# %% [markdown]
# ## How to choose N, and which importance function
#
# - **The importance function** here is the transition $p(x_k \mid x_{k-1})$: it places
#   particles blindly, then judges them by $z_k$. {doc}`proposals` builds the best one,
#   $p(x_k \mid x_{k-1}, z_k)$, which looks at $z_k$ first.
# - **The number of particles** should keep the Monte Carlo error,
#   $\approx \sqrt{\operatorname{tr} P_k / \mathrm{ESS}_k}$ with $P_k$ the posterior covariance
#   (the sum of its variances, $\operatorname{tr} P_k$, in m²), small next to the posterior spread. For
#   SIS no affordable $N$ does, as measured above.
# - **What goes wrong, and the fix:** the weights degenerate. The fix is to resample when the
#   ESS falls too low ({doc}`sir`), and to propose better ({doc}`proposals`).
#
# ## Try it
#
# The panel runs SIS for the chosen $N$, measurement noise scale (simulator and filter alike)
# and seed, and plots the ESS and the landmark $1$ estimate against the Kalman posterior.
# Which $N$ keeps the ESS above ten for the whole run?

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_sis(n_particles, noise_scale, seed):
    sc = scenario.with_(Rv=noise_scale**2 * scenario.Rv)
    s = simulate(sc, rng=seed)
    m = sc.model()
    r = ParticleFilter(m, n_particles, threshold=0.0).run(s.measurements, rng=run_filter_seed(seed))
    ref = kalman_filter(m, s.measurements)
    steps = np.arange(len(s.T))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.4))
    a1.plot(steps, r.ess, color=COLORS["estimate"])
    plain_log_axis(a1, "y")
    a1.set_xlabel("step k")
    a1.set_ylabel("ESS (particles)")
    a1.set_ylim(0.8, n_particles * 1.2)
    a2.plot(steps, ref.mean[:, 2], color=COLORS["kalman"], label="Kalman")
    a2.plot(steps, r.mean[:, 2], color=COLORS["estimate"], label="SIS")
    a2.plot(steps, s.truth[:, 2], "--", color=COLORS["truth"], label="truth")
    a2.set_xlabel("step k")
    a2.set_ylabel("L1 x (m)")
    a2.legend()


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(draw_sis, grid={"n_particles": (10, 100, 1000, 10000), "noise_scale": (0.5, 1.0, 2.0)},
                      n_particles=particle_slider(100),
                      noise_scale=scale_slider("measurement sd factor"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise} 4.1 The weight update by hand
# :label: ex-sis-write
# :nonumber:
# Write the SIS weight update for a step at which only landmark $1$ is in
# view, with the transition as importance function, as an explicit function of $x_k^i$.
# ```
#
# ```{solution} ex-sis-write
# :class: dropdown
# $\log \tilde w_k^i = \log W_{k-1}^i - \frac{1}{2 \sigma_v^2}\,\lVert z_k - (l^{1,i}_k - r^i_k)\rVert^2 + c$
# with $\sigma_v = 0.1$ m and $c$ a constant common to all particles (it cancels in the
# normalisation). Landmark $2$ does not appear.
# ```
#
# ```{exercise} 4.2 How many particles would SIS need?
# :label: ex-sis-n
# :nonumber:
# From the {glue:text}`sis_degeneracy_runs:d`-run study above, estimate how
# many particles SIS would need to keep an ESS of at least $2$ for {glue:text}`sis_horizon:d` steps.
# ```
#
# ```{solution} ex-sis-n
# :class: dropdown
# Each factor of ten in $N$ delays the collapse by about {glue:text}`sis_delay_per_decade:.1f`
# steps on average. Reaching {glue:text}`sis_horizon:d` steps from about {glue:text}`sis_median_first_10000:.0f`
# at $N = 10^4$ would, at that rate, take some {glue:text}`sis_decades_needed:d` more factors of
# ten beyond $N = 10^4$: SIS is hopeless here, and the cure is not more particles.
# ```
#
# ```{exercise} 4.3 Write SIS, and have it checked
# :label: ex-sis-code
# :nonumber:
# (Coding.) The same filter on another model: write `my_sis(z, n_particles, rng, model)`, SIS
# with the bootstrap proposal for the scalar model $x_0 \sim \mathcal N(m_0, p_0)$,
# $x_k \sim \mathcal N(a x_{k-1}, q)$,
# $z_k = x_k + v_k$, $v_k \sim \mathcal N(0, r)$, whose parameters are `model.a`, `model.q`,
# `model.r`, `model.m0`, `model.p0` (variances, not standard deviations). `z` has shape `(T + 1,)`,
# NaN where nothing is measured (always at step $0$). Return the weighted means and the ESS,
# two arrays of shape `(T + 1,)`, and draw every random number from `rng`. The checker runs it
# against the Kalman filter, which is exact for this model, runs it twice on the same seed and
# once on another, and names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_sis


def my_sis(z, n_particles, rng, model):
    """Your SIS: return (means, ess), two arrays of shape (len(z),)."""
    ...  # replace with your code


print(check_sis(my_sis))

# %% [markdown]
# ```{solution} ex-sis-code
# :class: dropdown
# Algorithm 4.1 for a scalar state, with the weights in the log domain; the code is in the
# folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_sis(z, n_particles, rng, model):
    x = model.m0 + np.sqrt(model.p0) * rng.standard_normal(n_particles)
    log_w = np.full(n_particles, -np.log(n_particles))
    means, ess = [], []
    for k, zk in enumerate(z):
        if k > 0:  # propose from the transition
            x = model.a * x + np.sqrt(model.q) * rng.standard_normal(n_particles)
        if not np.isnan(zk):  # weight by the likelihood, then normalise
            log_w = log_w - 0.5 * (zk - x) ** 2 / model.r
            log_w = log_w - logsumexp(log_w)
        w = np.exp(log_w)
        means.append(w @ x)
        ess.append(1.0 / np.sum(w**2))
    return np.array(means), np.array(ess)


print(check_sis(my_sis))

# %% [markdown]
# ## Takeaways
#
# - SIS is importance sampling on the whole path: with the transition as proposal, a
#   particle's weight is the product of the likelihoods along its path.
# - That product degenerates: within a few informative steps one particle holds almost all
#   the weight, and the cloud's covariance collapses while the exact posterior's does not.
# - More particles only postpone the collapse, by about {glue:text}`sis_delay_per_decade:.1f`
#   steps per factor of ten in $N$ here; the cures are resampling ({doc}`sir`) and a proposal
#   that looks at the measurement ({doc}`proposals`).
# - The effective sample size, $1 / \sum_i (W_k^i)^2$, is the number to watch; keep the weights
#   in the log domain.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab A ({doc}`../labs`) asks to write SIS for the landmark model (its question 3: the twenty lines
# above and Exercise 4.1), how many particles and which importance function, what goes wrong
# and how to fix it (question 4: "Does a larger N save SIS?", "How to choose N" and
# Exercise 4.2), and to check the degeneracy of the weights with the effective sample size (question 5:
# the first run and its figures). The lab's code multiplied the weights themselves; "Why the
# log domain" measures when that fails.
# :::
