# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Terrain navigation that converges
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** why the baseline terrain filter loses the aircraft (its prior is too wide for its
# particles), how a kernel move after each resampling (the regularised particle filter) keeps it,
# how far the filter that works is from the posterior Cramér-Rao bound, and what a map that is not
# the truth does to it.
#
# **You need** {doc}`terrain` and {doc}`../part1/resampling_schemes`; covariance matrices and their square
# roots; paired tests ({doc}`../evidence`).
#
# **Time:** about twenty-three minutes to read, plus about twenty-six minutes for the folded blocks; the exercises are extra.
# :::
#
# The previous chapter's particle filter ($N = 3000$ particles, resampling
# when $\mathrm{ESS} < N/2$), loses the aircraft in a large share of the flights. This chapter
# measures why, tries the standard remedies on the *same* flights, and compares the filter that
# converges with the bound on the accuracy of any estimator.
#
# **Lost**, everywhere below: the filter's final horizontal error exceeds $500$ m (about five DEM
# cells) or every particle died. The studies cost minutes, so they were computed by
# `python3 tasks.py study NAME` and stored in `book/data/` with their provenance; a test recomputes
# a sample of their rows. Flight $r$ is the same in every setting (common random numbers), so
# settings are compared flight by flight with paired tests.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from myst_nb import glue
from scipy import stats

from pfcourse import evidence
from pfcourse.studies.registry import STUDIES
from pfcourse.studies.terrain_field import map_error_family
from pfcourse.studies.terrain_remedies import FILTERS, MODEL_FLIGHT_SEED, model_flight
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.jitter import RegularisedJitter, optimal_bandwidth
from pfcourse.metrics import rmse
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.book.style import use_style
from pfcourse.scenarios.terrain.map import MAP_ERROR_CORRELATION_CELLS, MAP_ERROR_SD, MAP_SMOOTHING_CELLS, load_jacksboro
from pfcourse.scenarios.terrain.pcrb import (horizontal_bound, pcrb_recursion, terrain_bound_noise_free,
                                   weighted_pcrb_recursion)
from pfcourse.scenarios.terrain.scenario import AircraftScenario, dynamics_jacobian, measurement_jacobian, simulate

use_style()
terrain = load_jacksboro()
scenario = AircraftScenario()
data = STUDIES["terrain_remedies"].load()
provenance = data.attrs["provenance"]
print("study commits:", sorted({r["commit"][:10] for r in provenance["runs"]}))

# %% [markdown]
# ## The first lesson: the baseline filter loses the aircraft

# %% tags=["hide-input"] jupyter={"source_hidden": true}
runs = data.pivot(index="flight", columns="setting", values="lost")  # NaN where a setting has fewer flights
final = data.pivot(index="flight", columns="setting", values="final_error")
base = runs["bootstrap N=3000"].astype(bool)
k, n = int(base.sum()), int(base.count())
ci = evidence.rate(k, n)
glue_values("terrain_baseline_", diverged=float(k / n), lo=ci.low, hi=ci.high, runs=n)
print(f"bootstrap N = 3000: {k} of {n} flights lost ({k / n:.0%}, Wilson 95 % CI {ci.low:.0%} to {ci.high:.0%})")

# %% [markdown]
# The baseline filter loses {glue:text}`terrain_baseline_diverged:.0%` of
# {glue:text}`terrain_baseline_runs` flights ({glue:text}`terrain_baseline_lo:.0%`-{glue:text}`terrain_baseline_hi:.0%`).
#
# ## Why it fails: the prior is too big for its particles
#
# A particle can only be rescued by the readings if it starts within the likelihood's reach of
# the truth: horizontally within a fraction of a map cell (about a hundred metres), in altitude
# within a few tens of metres, and in heading close enough that dead reckoning does not carry it away (an error
# $\delta\psi$ moves it sideways by $V t\,\delta\psi$: $1°$ is $140$ m after $8$ km). The prior
# is $1667$ m (one standard deviation) in $x$ and $y$, $100$ m in altitude and $20°$ in heading.
# The cell below draws the filter's own initial cloud for $N = 3000$, $30\,000$ and $10^5$ on
# $100$ flights and measures the particle nearest to the truth.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
P0_std = np.sqrt(np.diag(scenario.P0))
model = scenario.model(terrain)
sizes = [3000, 30000, 100000]
truths = [simulate(scenario, terrain, data_rng(0, r)).truth for r in range(100)]  # the 100 flights
rows = []
for N in sizes:
    for r in range(100):
        truth = truths[r][0]
        cloud = model.sample_initial(N, filter_rng(0, r))
        d = (cloud - truth) / P0_std
        d[:, 3] = np.angle(np.exp(1j * (cloud[:, 3] - truth[3]))) / P0_std[3]
        horiz = np.hypot(cloud[:, 0] - truth[0], cloud[:, 1] - truth[1])
        i = np.argmin(np.sum(d**2, axis=1))      # nearest in the prior's own metric
        j = np.argmin(horiz)                     # nearest horizontally
        rows.append({"N": N, "flight": r, "nearest horizontal (m)": horiz[j],
                     "its altitude error (m)": abs(cloud[j, 2] - truth[2]),
                     "its heading error (deg)": np.degrees(abs(d[j, 3] * P0_std[3])),
                     "nearest in prior metric: horizontal (m)": horiz[i],
                     "... altitude (m)": abs(cloud[i, 2] - truth[2]),
                     "... heading (deg)": np.degrees(abs(d[i, 3] * P0_std[3]))})
nearest = pd.DataFrame(rows)
near = nearest.drop(columns="flight").groupby("N").median()
print("medians over 100 flights of the particle nearest to the truth at t = 0")
print(near.round(1).to_string())

# %% tags=["remove-input"] jupyter={"source_hidden": true}
horizontal = nearest.pivot(index="flight", columns="N", values="nearest horizontal (m)")
near_slope, near_slope_low, near_slope_high = evidence.log_slope(horizontal[sizes].to_numpy().T, sizes)
glue_values("terrain_near_", h_3000=float(near.loc[3000, "nearest horizontal (m)"]),
            psi_3000=float(near.loc[3000, "... heading (deg)"]),
            h2_3000=float(near.loc[3000, "nearest in prior metric: horizontal (m)"]),
            drift_3000=float(8000 * np.tan(np.radians(near.loc[3000, "... heading (deg)"]))),
            psi1_3000=float(near.loc[3000, "its heading error (deg)"]),
            h_100000=float(near.loc[100000, "nearest horizontal (m)"]),
            slope=near_slope, slope_low=near_slope_low, slope_high=near_slope_high)
EvidenceBlock(
    "the nearest particle comes closer only like N to the power -1/2",
    notes=[f"Log-log slope of the median horizontal distance of the nearest particle against N: {near_slope:.2f} "
           f"(95 % bootstrap interval {near_slope_low:.2f} to {near_slope_high:.2f}, the 100 flights resampled "
           "together, three values of N). The nearest of N points of a two-dimensional density comes closer like "
           "N^(-1/2); in the four dimensions of the state, like N^(-1/4) per component.",
           f"With N = 3000, the particle nearest in all four components together (in the prior's metric) is "
           f"{near.loc[3000, 'nearest in prior metric: horizontal (m)']:.0f} m away horizontally and "
           f"{near.loc[3000, '... heading (deg)']:.1f} degrees off in heading, which alone would carry it "
           f"{8000 * np.tan(np.radians(near.loc[3000, '... heading (deg)'])):.0f} m sideways over the 8 km flight."],
)

# %% [markdown]
# With $3000$ particles the particle nearest the truth horizontally is typically
# {glue:text}`terrain_near_h_3000:.0f` m away, within a cell, but it carries a random altitude
# and heading from the prior: its heading is {glue:text}`terrain_near_psi1_3000:.0f`° off
# (median), enough to fly it off the truth's terrain profile within seconds. Even $10^5$
# particles leave the nearest one {glue:text}`terrain_near_h_100000:.0f` m away: in four
# dimensions the nearest particle comes closer like $N^{-1/4}$ per component, so more particles
# help slowly. A filter that *moves* its particles after the first readings, instead of waiting
# for one to have been drawn in the right place, should help more.
#
# ## The idea: move the copies after each resampling
#
# Resampling replaces the cloud by copies of its heavy particles. With no process noise in the
# aircraft's altitude and little in its heading, the copies stay nearly identical, and the
# cloud soon holds a few distinct values only (sample impoverishment). The **regularised
# particle filter** {cite:p}`musso2001` resamples from a smoothed version of the weighted
# cloud: a kernel density estimate with a Gaussian kernel of covariance $h^2 \hat\Sigma$, $\hat\Sigma$ the cloud's
# covariance. Drawing from it is drawing a particle and moving it by a kernel draw,
#
# $$
# x^i \leftarrow x^i + h\, \hat\Sigma^{1/2} \varepsilon^i, \qquad \varepsilon^i \sim \mathcal N(0, I_d),
# \qquad h_\text{opt} = \left(\frac{4}{d + 2}\right)^{1/(d+4)} N^{-1/(d+4)},
# $$
#
# with $\hat\Sigma^{1/2}$ any matrix $A$ such that $A A^\top = \hat\Sigma$, $d$ the dimension of the state and
# $h_\text{opt}$ the bandwidth that minimises the mean integrated squared error of the kernel
# estimate when the density is Gaussian. Here the early posterior is several blobs kilometres apart, so $\hat\Sigma$ is kilometres
# wide and $h_\text{opt}$ itself throws every particle off its terrain match: the chapter's filter
# uses $h = 0.2\,h_\text{opt}$, a factor chosen on flights $0$ to $11$ among $0.05$, $0.2$ and $1$.
#
# :::{admonition} Algorithm 18.1: the regularised particle filter (kernel move after resampling)
# :class: algorithm
# 1. Run the particle filter of {doc}`terrain` (Algorithm 17.1): propagate, weight by the
#    altimeter's likelihood, normalise.
# 2. **If** $\mathrm{ESS}_k < \tau N$: resample, then **move** the equally weighted cloud:
#    1. $\hat\Sigma = \frac{1}{N-1}\sum_i (x^i - \bar x)(x^i - \bar x)^\top$, with heading deviations from
#       the circular mean, wrapped;
#    2. a square root $A = V \Lambda^{1/2}$ from the eigen-decomposition $\hat\Sigma = V \Lambda V^\top$
#       (it exists even when $\hat\Sigma$ is singular);
#    3. $h = c\, h_\text{opt}(N, d)$ with $c = 0.2$;
#    4. $x^i \leftarrow x^i + h A \varepsilon^i$, $\varepsilon^i \sim \mathcal N(0, I_d)$ drawn
#       independently for each particle; wrap the heading.
# :::
#
# The move in NumPy, run on a resampled cloud from the filter and checked against the package's
# `RegularisedJitter`, which the engine calls as its `jitter` hook:

# %%
import numpy as np


def regularised_move(particles, scale, rng, angle=3):
    """Algorithm 18.1, step 2: x^i + h S^(1/2) eps^i, h = scale * h_opt."""
    n, d = particles.shape
    x = particles.copy()
    a = x[:, angle]
    mean_angle = np.arctan2(np.mean(np.sin(a)), np.mean(np.cos(a)))
    # the heading's deviations from its mean, wrapped
    x[:, angle] = np.angle(np.exp(1j * (a - mean_angle)))
    S = np.cov(x, rowvar=False)
    eigenvalues, V = np.linalg.eigh(S)
    A = V * np.sqrt(np.clip(eigenvalues, 0.0, None))  # A A^T = S
    h = scale * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
    moved = particles + h * rng.standard_normal((n, d)) @ A.T
    # wrap the heading to (-pi, pi]
    moved[:, angle] = np.angle(np.exp(1j * moved[:, angle]))
    return moved


# %% tags=["hide-input"] jupyter={"source_hidden": true}
flight = simulate(scenario, terrain, data_rng(0, 0))
pf = FILTERS["bootstrap N=3000"].build(scenario.model(terrain))
# step the filter through the first six readings; the loop leaves the last step's weighted cloud
for last in pf.steps(flight.measurements[:6], rng=filter_rng(0, 0)):
    pass
resampled = last.particles[np.random.default_rng(5).choice(3000, 3000, p=last.weights)]
ours = regularised_move(resampled, 0.2, np.random.default_rng(7))
package = RegularisedJitter(0.2, (3,))(resampled, np.random.default_rng(7))
TOLERANCE = 1e-9  # metres and radians: the same draws, so round-off only
print(f"largest difference from pfcourse.jitter.RegularisedJitter: {np.abs(ours - package).max():.1e} "
      f"(below {TOLERANCE:.0e}: {np.abs(ours - package).max() < TOLERANCE})")
print(f"h = 0.2 h_opt = {0.2 * optimal_bandwidth(3000, 4):.3f}; move sd in x, y: "
      f"{np.std(ours[:, 0] - resampled[:, 0]):.0f} m, {np.std(ours[:, 1] - resampled[:, 1]):.0f} m")
glue_values("terrain_move_", tolerance=TOLERANCE, sd_x=float(np.std(ours[:, 0] - resampled[:, 0])))

# %% [markdown]
# The two agree to round-off (below {glue:text}`terrain_move_tolerance:.0e`) with the same
# random draws. On this cloud, five seconds into flight $0$, the move's standard deviation in $x$
# is {glue:text}`terrain_move_sd_x:.0f` m.
#
# ## The remedies, on the same flights
#
# Besides the regularised filter, the study tries the bootstrap filter with more particles
# ($10^4$, $3 \times 10^4$, $10^5$), the **progressive correction** {cite:p}`oudjane2000`
# (the first five readings brought in as likelihoods raised to powers $\lambda_j$ summing to $1$,
# each the largest keeping the effective sample size at $N/2$, with resampling and a kernel move
# between stages), and $Q_f$ scaled like every other horizontal length (divided by $3$). Cost is
# counted here in **likelihood evaluations** ($N$ per reading, plus $N$ per extra stage), relative
# to the bootstrap filter with $N = 30\,000$; processor time comes after. Each setting is compared
# with the baseline flight by flight (the tests are in the evidence block).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
ref_cost = 30000 * 80
table = []
for name in [s for s in FILTERS if s in runs.columns]:
    lost = runs[name].dropna().astype(bool)
    common = lost.index.intersection(base.index)
    versus = evidence.paired_rates(lost[common], base[common])  # exact McNemar on the same flights
    both = common[~base[common] & ~lost[common]]
    d = final.loc[both, name] - final.loc[both, "bootstrap N=3000"]
    # NaN when there is nothing to test: too few flights, or the same final errors (the baseline)
    p_w = (evidence.paired(final.loc[both, name], final.loc[both, "bootstrap N=3000"]).pvalue
           if len(both) > 10 and np.any(d != 0) else np.nan)
    evals = data.loc[data.setting == name, "evaluations"].mean()
    ci = evidence.rate(lost.sum(), lost.count())
    table.append({"setting": name, "flights": int(lost.count()), "lost": int(lost.sum()),
                  "lost rate": lost.mean(), "95 % CI": f"{ci.low:.2f}-{ci.high:.2f}",
                  "rescued / newly lost vs baseline": f"{versus.only_b} / {versus.only_a}",
                  "McNemar p": versus.pvalue,
                  "median final error, converged (m)": final.loc[~lost, name].median(),
                  "Wilcoxon p (both converged)": p_w,
                  "cost vs bootstrap N=30000": FILTERS[name].n_particles * evals / ref_cost,
                  "median s/flight": data.loc[data.setting == name, "seconds"].median()})
table = pd.DataFrame(table).set_index("setting")
affordable = table[table["cost vs bootstrap N=30000"] <= 1.0 + 1e-9]
best = affordable["lost rate"].idxmin()


def versus(a, b):
    """Exact McNemar test of settings a and b on their common flights, and the difference of lost shares."""
    la, lb = runs[a].dropna().astype(bool), runs[b].dropna().astype(bool)
    common = la.index.intersection(lb.index)
    return evidence.paired_rates(la[common], lb[common])


pairs = {"terrain_rpf3k_vs_boot30k": ("regularised N=3000", "bootstrap N=30000"),
         "terrain_trpf_vs_rpf": ("tempered+regularised N=3000", "regularised N=3000"),
         "terrain_qf3": ("bootstrap N=3000, Qf/3", "bootstrap N=3000"),
         "terrain_boot100k_vs_boot30k": ("bootstrap N=100000", "bootstrap N=30000")}
comparisons = {key: versus(a, b) for key, (a, b) in pairs.items()}
for key, v in comparisons.items():
    glue_values(key, _diff_low=v.difference_low, _diff_high=v.difference_high)
glue_values("terrain_", best_diverged=float(table.loc[best, "lost rate"]), best_name=best,
            best_ci=table.loc[best, "95 % CI"], best_cost=float(table.loc[best, "cost vs bootstrap N=30000"]),
            best_mcnemar=float(table.loc[best, "McNemar p"]), best_lost=int(table.loc[best, "lost"]),
            best_flights=int(table.loc[best, "flights"]),
            boot30k_diverged=float(table.loc["bootstrap N=30000", "lost rate"]),
            boot100k_diverged=float(table.loc["bootstrap N=100000", "lost rate"]),
            boot100k_cost=float(table.loc["bootstrap N=100000", "cost vs bootstrap N=30000"]),
            rpf3k_diverged=float(table.loc["regularised N=3000", "lost rate"]),
            rpf30k_diverged=float(table.loc["regularised N=30000", "lost rate"]),
            rpf30k_ci=table.loc["regularised N=30000", "95 % CI"],
            rpf_h1_diverged=float(table.loc["regularised h=1 N=3000", "lost rate"]),
            tempered_diverged=float(table.loc["tempered N=3000", "lost rate"]),
            tempered_p=float(table.loc["tempered N=3000", "McNemar p"]),
            qf3_diverged=float(table.loc["bootstrap N=3000, Qf/3", "lost rate"]),
            qf3_mcnemar=float(table.loc["bootstrap N=3000, Qf/3", "McNemar p"]),
            rpf3k_vs_boot30k_p=comparisons["terrain_rpf3k_vs_boot30k"].pvalue,
            trpf_vs_rpf_p=comparisons["terrain_trpf_vs_rpf"].pvalue,
            boot100k_vs_boot30k_p=comparisons["terrain_boot100k_vs_boot30k"].pvalue)
EvidenceBlock(
    f"the {best} filter loses the fewest flights at no more likelihood evaluations than the bootstrap filter "
    "with N = 30 000",
    notes=[f"{len(runs)} flights, the same for every setting. Cost: "
           "likelihood evaluations relative to the bootstrap filter with N = 30 000; the wall time per flight was "
           "measured on a shared machine and is indicative only. McNemar: exact test on the flights lost by one "
           "setting and not the baseline; Wilcoxon: signed-rank test of the final errors on the flights both "
           "converge (see Reading the evidence)."]
          + [f"{pairs[key][0]} vs {pairs[key][1]}: lost by the first only / by the second only "
             f"{v.only_a} / {v.only_b}, exact McNemar p = {v.pvalue:.2g}; difference of lost shares "
             f"{v.difference:+.2f} (95 % interval {v.difference_low:+.3f} to {v.difference_high:+.3f})"
             for key, v in comparisons.items()],
    tables=[("Every setting against the baseline (bootstrap N = 3000) on the same flights",
             table.reset_index(), {"lost rate": ".2f", "McNemar p": ".2g", "median final error, converged (m)": ".0f",
                                   "Wilcoxon p (both converged)": ".2g", "cost vs bootstrap N=30000": ".2f",
                                   "median s/flight": ".2f"})],
)

# %% [markdown]
# At no more likelihood evaluations than the bootstrap filter with $30\,000$ particles, the
# filter that loses fewest is the **{glue:text}`terrain_best_name`** filter:
# {glue:text}`terrain_best_diverged:.0%` of the flights ({glue:text}`terrain_best_ci`), far fewer
# than the baseline on the same flights.
#
# In processor time its kernel move makes it dearer, so the fair test gives it the bootstrap
# filter's wall time instead: with $N = 20\,000$, at {glue:text}`terrain_cost_time_ratio:.2f` times
# that time, it loses {glue:text}`terrain_cost_lost` of $100$ fresh flights against the bootstrap
# filter's {glue:text}`terrain_cost_boot_lost` (below). Setting by setting (the table is in the
# evidence above):
#
# - **Particles** help slowly: the bootstrap filter still loses
#   {glue:text}`terrain_boot30k_diverged:.0%` with $30\,000$ particles and
#   {glue:text}`terrain_boot100k_diverged:.0%` with $10^5$, at
#   {glue:text}`terrain_boot100k_cost:.1f` times the cost.
#
# - **Regularisation** with $3000$ particles loses {glue:text}`terrain_rpf3k_diverged:.0%`, not
#   told apart from the bootstrap filter with ten times as many (difference
#   {glue:text}`terrain_rpf3k_vs_boot30k_diff_low:+.2f` to {glue:text}`terrain_rpf3k_vs_boot30k_diff_high:+.2f`). With the textbook bandwidth $h_\text{opt}$ it
#   loses {glue:text}`terrain_rpf_h1_diverged:.0%`: the formula assumes one Gaussian blob.
#
# - **Progressive correction** alone loses {glue:text}`terrain_tempered_diverged:.0%`, not told
#   apart from the baseline; added to the regularised filter it changes the lost share by
#   {glue:text}`terrain_trpf_vs_rpf_diff_low:+.2f` to {glue:text}`terrain_trpf_vs_rpf_diff_high:+.2f`
#   (95 % interval), no change the study can detect. So the
#   losses are not made at the first readings alone: our reading (not measured here) is that the
#   loss of diversity over the following tens of seconds, which the kernel move repairs, is what
#   loses the aircraft.
#
# - **$Q_f$ divided by $3$** loses {glue:text}`terrain_qf3_diverged:.0%` (difference to the baseline
#   {glue:text}`terrain_qf3_diff_low:+.2f` to {glue:text}`terrain_qf3_diff_high:+.2f`): the scaling rule can be applied to $Q_f$ with no change
#   the study can see. The heading entry ($3.3°$ per second) is what lets the particles turn back
#   onto the truth; a horizontal noise of $1$ or $3$ m per second is small beside the cells.
#
# The previous chapter ({doc}`terrain`) runs its studies around this filter, on the
# same flights (there its baseline loses a share
# {glue:text}`terrain.ipynb::studies_base_lost:.2f` of them, the rows of this study). The figure
# shows the final errors of five settings, sorted: the lost flights lie right of the $500$ m line.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
shown = ["bootstrap N=3000", "bootstrap N=30000", "bootstrap N=100000", "regularised N=3000", "regularised N=30000"]
fig, ax = plt.subplots(figsize=(7.5, 3.8))
for colour, name in zip(plt.get_cmap("tab10").colors, shown):  # five curves, five distinct colours
    e = np.sort(final[name].dropna().to_numpy())
    ax.step(e, np.arange(1, len(e) + 1) / len(e), where="post", color=colour, label=name)
ax.axvline(500, color="k", lw=0.8, ls="--")
ax.text(520, 0.03, "lost ->")
ax.set_xscale("log")
ax.set_xlabel("final horizontal error (m)")
ax.set_ylabel("share of flights with a smaller error")
ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0))
ax.set_title(f"Final error over the same {len(final)} flights")
plt.show()

# %% [markdown]
# ## Confirmed on flights it had never seen
#
# A filter chosen as the best of many settings on the same $100$ flights looks better than it
# is: among a dozen settings, one is likely to be lucky on those flights. The choice was
# therefore put to a test decided before it ran and committed with its criterion before its
# data existed (the registered study `terrain_confirmation`): the regularised filter with
# **stratified** resampling, the setting that lost the fewest of flights $0$ to $99$ in the
# studies of {doc}`terrain`, flies the fresh flights $100$ to $199$; it passes if it
# loses **fewer than $5$ of the $100$**. The regularised filter with multinomial resampling and
# the bootstrap filter with $N = 30\,000$ fly the same flights, so losses and wall times are paired.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
BOOT = "bootstrap N=30000"


def against_bootstrap(study, candidate, prefix):
    """A fresh-flight study: the candidate's losses (Wilson), paired with the bootstrap filter's
    (exact McNemar) and its wall time per flight (paired ratio); glued under ``prefix``."""
    table = STUDIES[study].load()
    lost = table.pivot(index="flight", columns="setting", values="lost").astype(bool)
    secs = table.pivot(index="flight", columns="setting", values="seconds")
    loss = evidence.rate(lost[candidate])
    versus = evidence.paired_rates(lost[candidate], lost[BOOT])
    time = evidence.paired(secs[candidate], secs[BOOT], ratio=True)
    glue_values(prefix + "_", lost=int(loss.successes), lo=loss.low, hi=loss.high, boot_lost=int(lost[BOOT].sum()),
                vs_boot_p=versus.pvalue, time_ratio=time.median, time_lo=time.low, time_hi=time.high)
    notes = [f"{name}: lost {evidence.rate(lost[name])}" for name in lost.columns]
    notes += [f"{candidate} vs {BOOT}: {versus}", f"wall time per flight, {candidate} / {BOOT}: {time}"]
    return lost, loss, notes


CAND = "regularised, stratified (candidate)"
MULT = "regularised, multinomial (chapter's baseline)"
lost_c, cand_rate, notes_c = against_bootstrap("terrain_confirmation", CAND, "terrain_fresh")
cand_vs_mult = evidence.paired_rates(lost_c[CAND], lost_c[MULT])
confirm_meta = STUDIES["terrain_confirmation"].load().attrs["provenance"]
glue_values("terrain_fresh_", flights=int(cand_rate.n), mult_lost=int(lost_c[MULT].sum()),
            vs_mult_p=float(cand_vs_mult.pvalue))
lost_m, _, notes_m = against_bootstrap("terrain_cost_matched", "regularised, stratified, N=20000", "terrain_cost")
# the two sets of fresh flights, seen by the same bootstrap filter (different flights: Fisher's exact test)
harder = stats.fisher_exact([[lost_m[BOOT].sum(), (~lost_m[BOOT]).sum()],
                             [lost_c[BOOT].sum(), (~lost_c[BOOT]).sum()]])
glue_values("terrain_", sets_p=float(harder.pvalue))
EvidenceBlock(
    "the candidate meets its criterion on fresh flights, at the bootstrap filter's cost in likelihood evaluations",
    notes=[f"Criterion, decided in advance: {confirm_meta['criterion']}: "
           f"{'met' if cand_rate.successes < 5 else 'not met'} ({cand_rate.successes} lost)."]
          + notes_c + [f"candidate vs multinomial: {cand_vs_mult}",
                       "Cost-matched test (the registered study terrain_cost_matched, flights 200-299): the same filter "
                       "with N = 20 000, which takes the bootstrap filter's wall time:"] + notes_m
          + [f"The bootstrap filter with N = 30 000 loses {lost_m[BOOT].sum()} of flights 200-299 and "
             f"{lost_c[BOOT].sum()} of flights 100-199: Fisher's exact p = {harder.pvalue:.3f}, so the second set is "
             "harder and the two loss rates of the regularised filter do not measure the effect of N alone."],
)

# %% [markdown]
# **The criterion is met**: the candidate loses {glue:text}`terrain_fresh_lost` of the
# {glue:text}`terrain_fresh_flights` fresh flights ({glue:text}`terrain_fresh_lo:.0%`-{glue:text}`terrain_fresh_hi:.0%`), far fewer than the
# bootstrap filter with $N = 30\,000$ on the same flights (evidence above). The interval still reaches above
# $5\,\%$: a hundred flights cannot prove a loss rate below it, only that this filter loses few.
#
# **At what cost?** The same number of likelihood evaluations as the bootstrap filter with
# $N = 30\,000$, but the kernel move makes a flight {glue:text}`terrain_fresh_time_ratio:.2f`
# times as long (median of the per-flight ratios). A second test, decided in advance, gave the
# regularised filter the bootstrap filter's wall time ($N = 20\,000$, flights $200$ to $299$): it
# loses {glue:text}`terrain_cost_lost` of $100$ against the bootstrap filter's
# {glue:text}`terrain_cost_boot_lost`, on flights harder than the previous hundred (evidence
# above). The verdict: **fewer than $5\,\%$ lost at the bootstrap filter's cost in likelihood
# evaluations, yes; at its wall time, far fewer lost than the bootstrap filter, but not fewer than
# $5\,\%$** (on this machine, shared with other work).

# %% [markdown]
# ## The yardstick: the posterior Cramér-Rao bound, read right
#
# How good is the filter that converges? The posterior Cramér-Rao bound {cite:p}`tichavsky1998`
# bounds the **mean squared error over the prior and the noise** of any estimator: averaged over
# flights drawn from the prior and over the altimeter's noise,
# $\mathbb E\,[(\hat x_k - x_k)(\hat x_k - x_k)^\top] \succeq B_k$. For terrain navigation
# {cite:p}`bergman1999` its information comes from the DEM's slope along the flight,
# $H_k = [-\partial h/\partial x, -\partial h/\partial y, 1, 0]$, through the recursion
#
# $$
# J_{k+1} = Q^{-1} + H_{k+1}^\top R^{-1} H_{k+1} - Q^{-1} F_k (J_k + F_k^\top Q^{-1} F_k)^{-1} F_k^\top Q^{-1},
# \qquad J_0 = P_0^{-1},
# $$
#
# with $F_k$ the Jacobian of the dynamics (`pfcourse.scenarios.terrain.pcrb`, which the tests check against the
# Kalman covariance in the linear-Gaussian case). The expectation in $D$'s terms is over the
# flights: the bound is computed along many flights drawn from the model, their information
# averaged at every step, and only then inverted. That is the bound; we call it the **strict**
# bound. Inverting each flight's own information and averaging the inverses (the **per-flight**
# bound, the one conditioned on a known path, as {cite:t}`bergman1999` plots it) gives a larger
# number, which is not guaranteed to bound anything.
#
# Which model? The filter assumes the process noise $Q_f$; the simulated aircraft has none (its
# $Q_f$ is only the filter's allowance for model error), so the flights of the studies above obey
# the limit $Q \to 0$, $J_{k+1} = F_k^{-\top} J_k F_k^{-1} + H_{k+1}^\top R^{-1} H_{k+1}$. To ask
# how much the filter extracts from its *own* model, a second study (`terrain_model_flights`)
# flies $100$ fresh aircraft that really wander as $Q_f$ says, with the filter's altimeter noise,
# and runs the same filter on them. Each set of flights is compared with its own bound, at every
# step, by the filter's root-mean-square error over the same flights.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
# Flights as simulated (no process noise): the filter's stored error paths and the Q -> 0 bound.
X = np.array(truths)  # the same 100 flights
free = np.array([terrain_bound_noise_free(scenario, terrain, x) for x in X])  # (flights, steps, 4, 4)
B = free[:, :, 0, 0] + free[:, :, 1, 1]  # per-flight B_xx + B_yy (m^2)
B_strict = horizontal_bound(np.linalg.inv(np.linalg.inv(free).mean(axis=0)))  # averaged information (m)
paths = STUDIES["terrain_error_paths"].load().sort_values("flight")
assert paths["setting"].eq(best).all()  # the stored paths are the best filter's
E = np.stack(paths["errors"].to_numpy())  # horizontal error (m), (flights, steps)
converged = ~paths["lost"].to_numpy(bool)
assert np.allclose(E[:, -1], final[best].to_numpy())  # the same runs as the remedies study

# Flights drawn from the filter's own model (process noise Q_f dt): stored errors, the Q_f bound.
mf = STUDIES["terrain_model_flights"].load().sort_values("flight")
assert mf["setting"].eq(best).all()
E_m = np.stack(mf["errors"].to_numpy())
kept_m = ~mf["lost"].to_numpy(bool)
X_m = np.array([model_flight(scenario, terrain, data_rng(MODEL_FLIGHT_SEED, r))[0].truth for r in mf["flight"]])
F_m = np.array([[dynamics_jacobian(x, scenario.speed, scenario.dt) for x in tr] for tr in X_m])
H_m = np.array([[measurement_jacobian(x, terrain) for x in tr] for tr in X_m])


model_terms = (np.linalg.inv(scenario.P0), F_m, scenario.Qf * scenario.dt, H_m, np.array([[scenario.Rf]]),
               scenario.measured())


def qf_bound(weights):
    """The Q_f bound (m) at every step, the information averaged over the flights with ``weights``
    (one row per weighting: all ones is the strict bound, a bootstrap resample's counts, or one
    flight alone for its per-flight bound), shape (rows, steps)."""
    bound = weighted_pcrb_recursion(*model_terms, weights)
    return np.sqrt(bound[..., 0, 0] + bound[..., 1, 1])


Bm_strict = qf_bound(np.ones((1, len(X_m))))[0]
assert np.allclose(Bm_strict, horizontal_bound(pcrb_recursion(*model_terms)))  # the same recursion
Bm_per = rmse(qf_bound(np.eye(len(X_m))), axis=0)  # RMS of the per-flight bounds (m)


t = scenario.times
fig, axes = plt.subplots(2, 1, figsize=(7.5, 6.4), sharex=True)
panels = [("flights as simulated (no process noise)", E, converged, B_strict, np.sqrt(B.mean(axis=0))),
          ("flights drawn from the filter's model ($Q_f$)", E_m, kept_m, Bm_strict, Bm_per)]
for ax, (title, err, kept, strict, per) in zip(axes, panels):
    ax.plot(t, rmse(err[kept], axis=0), label="filter, kept flights")
    ax.plot(t, strict, "k--", label="bound (strict)")
    ax.plot(t, per, "k:", label="per-flight bounds, RMS")
    ax.set_yscale("log")
    ax.set_ylabel("horizontal RMSE (m)")
    ax.set_title(f"{title}: {kept.sum()} of {len(err)} kept")
axes[1].set_xlabel("time t (s)")
# one legend for both panels, below them, off the data
fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=3)
fig.subplots_adjust(bottom=0.15, hspace=0.3)
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}


def counts(r, n):
    """Bootstrap resamples of flight indices (rows) as counts per flight, shape (rows, n)."""
    r = np.atleast_2d(r)
    return np.stack([np.bincount(row, minlength=n) for row in r]).astype(float)


def kept_rmse(err, kept, w):
    """The final RMSE (m) of the kept flights under each row of counts ``w``."""
    return np.sqrt((w * kept * err**2).sum(axis=1) / (w * kept).sum(axis=1))


def ratio_free(r):
    """Kept flights' final RMSE over the strict noise-free bound, per resample (flights as simulated)."""
    w = counts(r, len(E))
    info = np.einsum("bm,mij->bij", w / w.sum(axis=1, keepdims=True), np.linalg.inv(free[:, -1]))
    out = kept_rmse(E[:, -1], converged, w) / horizontal_bound(np.linalg.inv(info))
    return out if np.ndim(r) == 2 else out[0]


def ratio_model(r):
    """Kept flights' final RMSE over the strict Q_f bound, per resample (flights from the filter's model)."""
    w = counts(r, len(E_m))
    out = kept_rmse(E_m[:, -1], kept_m, w) / qf_bound(w)[:, -1]
    return out if np.ndim(r) == 2 else out[0]


ratio = evidence.run_interval(ratio_free, len(E), vectorized=True, n_resamples=999)
ratio_per = np.sqrt(np.mean(E[converged, -1] ** 2) / B[:, -1].mean())
ratio_f = evidence.run_interval(ratio_model, len(E_m), vectorized=True, n_resamples=999)
ratio_f_all = rmse(E_m[:, -1]) / Bm_strict[-1]
glue_values("terrain_", best_rmse_over_noise_free_bound=ratio[0], best_rmse_over_noise_free_bound_lo=ratio[1],
            best_rmse_over_noise_free_bound_hi=ratio[2], best_rmse_over_noise_free_per_flight_bound=ratio_per,
            best_rmse_over_filter_bound=ratio_f[0], best_rmse_over_filter_bound_lo=ratio_f[1],
            best_rmse_over_filter_bound_hi=ratio_f[2], rmse_all_over_filter_bound=ratio_f_all,
            filter_bound_strict_final=float(Bm_strict[-1]), filter_bound_per_flight_final=float(Bm_per[-1]),
            noise_free_bound_strict_final=float(B_strict[-1]),
            noise_free_bound_per_flight_final=float(np.sqrt(B[:, -1].mean())),
            filter_heading_noise_deg=float(np.degrees(np.sqrt(scenario.Qf[3, 3]))),
            converged_rmse=float(rmse(E[converged], axis=0)[-1]), all_rmse=float(rmse(E, axis=0)[-1]), converged_n=int(converged.sum()),
            model_rmse=float(rmse(E_m[kept_m], axis=0)[-1]), model_all_rmse=float(rmse(E_m, axis=0)[-1]),
            model_flights=len(E_m), model_lost=int((~kept_m).sum()))
EvidenceBlock(
    f"on the filter's own model its error is {ratio_f[0]:.1f} times the bound; on the flights as simulated "
    f"{ratio[0]:.1f} times theirs",
    notes=[f"Final step (80 s), filter {best}. Strict bound: the information J_k averaged over the flights, then "
           "inverted (the posterior Cramér-Rao bound as Tichavsky et al. define it, its expectation estimated over "
           "the same flights); per-flight: each flight's bound, then the root of their mean.",
           f"Flights as simulated (terrain_error_paths, flights 0-99, no process noise, bound with Q -> 0): RMSE of "
           f"the {converged.sum()} kept flights {rmse(E[converged], axis=0)[-1]:.0f} m, of all {rmse(E, axis=0)[-1]:.0f} m; strict "
           f"bound {B_strict[-1]:.1f} m, per-flight {np.sqrt(B[:, -1].mean()):.1f} m. Ratio of the kept flights' "
           f"RMSE to the strict bound {ratio[0]:.2f} ({ratio[1]:.2f} to {ratio[2]:.2f}), to the per-flight bound "
           f"{ratio_per:.2f}.",
           f"Flights drawn from the filter's model (terrain_model_flights: {len(E_m)} flights with process noise "
           f"Q_f dt and altimeter noise R_f, a flight that left the map drawn again; the same filter): "
           f"{(~kept_m).sum()} lost; RMSE of the {kept_m.sum()} kept {rmse(E_m[kept_m], axis=0)[-1]:.0f} m, of all "
           f"{rmse(E_m, axis=0)[-1]:.0f} m; strict Q_f bound {Bm_strict[-1]:.0f} m, per-flight {Bm_per[-1]:.0f} m. Ratio "
           f"of the kept flights' RMSE to the strict bound {ratio_f[0]:.2f} ({ratio_f[1]:.2f} to {ratio_f[2]:.2f}); "
           f"of all flights' {ratio_f_all:.1f}.",
           "Intervals: 95 % percentile bootstrap over the flights (evidence.run_interval, 999 resamples), the "
           "strict bound recomputed on each resample (its expectation is estimated from the same flights).",
           "The kept flights are a selection (the filter's own verdict), so their RMSE is not exactly what the "
           "bound limits; the RMSE over all flights is, and the lost flights put it far above the bound."],
)

# %% [markdown]
# On flights drawn from its own model the filter's final RMSE, over the flights it keeps, is
# {glue:text}`terrain_best_rmse_over_filter_bound:.1f`
# ({glue:text}`terrain_best_rmse_over_filter_bound_lo:.1f`-{glue:text}`terrain_best_rmse_over_filter_bound_hi:.1f`)
# times the bound, {glue:text}`terrain_filter_bound_strict_final:.0f` m.
#
# On the flights as simulated it is {glue:text}`terrain_best_rmse_over_noise_free_bound:.1f`
# times theirs, {glue:text}`terrain_noise_free_bound_strict_final:.0f` m.
#
# Neither is near $1$, and the two are close (their intervals, in the evidence block, overlap): the
# filter is about as far from its bound when its model is right as when its $Q_f$ is far larger
# than the truth's (no) process noise. So the mismatch of the model does not explain the gap.
#
# Nor does the bound say that a better filter would be five times as accurate. It is built from
# the local slopes of the map, averaged over the flights before inversion, and the flights differ
# widely in what their terrain tells: the per-flight bounds, each computed as if that flight's
# path were the only one, have a root mean square of
# {glue:text}`terrain_filter_bound_per_flight_final:.0f` m on the model's flights. The average is
# carried by the flights over rich terrain, and slopes cannot see the look-alike places where the
# posterior itself stays wide. The bound says that no filter can do better; how close this filter
# is to the best possible one is what the reference posterior below measures, flight by flight.
#
# Over all the model's flights, the {glue:text}`terrain_model_lost:d` lost ones included, the
# RMSE is {glue:text}`terrain_rmse_all_over_filter_bound:.0f` times the bound: losing the aircraft,
# not the accuracy once found, dominates the error. The field's own problem, with the heading
# known from an inertial system, is the next chapter's reference.
#
# ## A map that is not the truth
#
# So far the world and the filter use the same DEM, bilinear between the same nodes: the filter
# knows the terrain exactly. A real map is coarser than the ground and has errors. Here the
# filter's map is the world's DEM smoothed by a Gaussian of one cell (what a coarser survey, or a
# wide altimeter footprint, sees) plus a random error field of standard deviation
# {glue:text}`terrain_map_sd_field:.0f` m correlated over about two cells
# (`pfcourse.scenarios.terrain.map.mismatched_map`), drawn afresh for each flight from its own seeded stream
# (`pfcourse.seeding.map_error_rng`). The study `terrain_map_error` flies the baseline, the best
# filter, the best filter measuring at $10$ Hz, and the best filter told of its map's error
# ($R_f$ increased by the map error's variance) over the true map with the filter on the wrong one.
# The $10$ Hz runs take seconds each, so the study has $50$ flights (flights $0$ to $49$), not $100$;
# the intervals say what that costs.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
mm = STUDIES["terrain_map_error"].load()
mm_lost = mm.pivot(index="flight", columns="setting", values="lost").astype(bool)
mm_final = mm.pivot(index="flight", columns="setting", values="final_error")
flights = mm_lost.index.to_numpy()
studies = STUDIES["terrain_studies"].load()
fast = studies[studies["setting"] == "every 0.1 s, dt = 0.1 s"].set_index("flight").loc[flights]
slow = studies[studies["setting"] == "baseline"].set_index("flight").loc[flights]
true_map = {"bootstrap N=3000": runs["bootstrap N=3000"].loc[flights].astype(bool),
            "regularised N=30000": runs["regularised N=30000"].loc[flights].astype(bool),
            "regularised N=30000, 10 Hz": fast["lost"].astype(bool)}
mm_rows = []
for name in mm_lost.columns:
    r = evidence.rate(mm_lost[name])
    row = {"setting": name, "flights": r.n, "lost, map error": r.estimate, "95 % interval": f"{r.low:.2f}-{r.high:.2f}"}
    if name in true_map:
        v = evidence.paired_rates(mm_lost[name], true_map[name])
        row.update({"lost, true map": true_map[name].mean(), "more lost / fewer (McNemar)": f"{v.only_a} / {v.only_b}",
                    "McNemar p": v.pvalue})
    row["median final error, converged (m)"] = mm_final.loc[~mm_lost[name], name].median()
    mm_rows.append(row)
mm_table = pd.DataFrame(mm_rows)


def error_ratio(errors_a, errors_b, lost_a, lost_b):
    """Median ratio of final errors, a over b, on the flights both converge (paired, with its interval)."""
    both = ~lost_a.to_numpy() & ~lost_b.to_numpy()
    return evidence.paired(np.asarray(errors_a)[both], np.asarray(errors_b)[both], ratio=True)


best_mm = evidence.rate(mm_lost["regularised N=30000"])
best_vs_true = evidence.paired_rates(mm_lost["regularised N=30000"], true_map["regularised N=30000"])
base_mm = evidence.rate(mm_lost["bootstrap N=3000"])
hz_mm = error_ratio(mm_final["regularised N=30000, 10 Hz"], mm_final["regularised N=30000"],
                    mm_lost["regularised N=30000, 10 Hz"], mm_lost["regularised N=30000"])
hz_true = error_ratio(fast["final_error"], slow["final_error"], fast["lost"].astype(bool), slow["lost"].astype(bool))
told = error_ratio(mm_final["regularised N=30000, Rf + map error"], mm_final["regularised N=30000"],
                   mm_lost["regularised N=30000, Rf + map error"], mm_lost["regularised N=30000"])
told_vs = evidence.paired_rates(mm_lost["regularised N=30000, Rf + map error"], mm_lost["regularised N=30000"])
hz_lost = evidence.rate(mm_lost["regularised N=30000, 10 Hz"])
hz_vs = evidence.paired_rates(mm_lost["regularised N=30000, 10 Hz"], mm_lost["regularised N=30000"])
# every comparison of lost flights the two map-error studies make, Holm-adjusted over the family
mb = STUDIES["terrain_map_bias"].load()
mb_lost = mb.pivot(index="flight", columns="setting", values="lost").astype(bool)
family = map_error_family(mm_lost, mb_lost, true_map)
hz_holm = family["regularised, 10 Hz vs 1 Hz"][1]
glue_values("terrain_map_", sd_field=MAP_ERROR_SD, sd_total=float(mm["map_error_sd"].mean()),
            error_best_lost=best_mm.estimate, error_best_lo=best_mm.low, error_best_hi=best_mm.high,
            error_best_true=true_map["regularised N=30000"].mean(), error_best_p=best_vs_true.pvalue,
            error_base_lost=base_mm.estimate, error_flights=int(best_mm.n),
            hz_ratio=hz_mm.median, hz_lo=hz_mm.low, hz_hi=hz_mm.high, hz_true=hz_true.median,
            told_lost=float(mm_lost["regularised N=30000, Rf + map error"].mean()), told_p=told_vs.pvalue,
            told_ratio=told.median, told_lo=told.low, told_hi=told.high, hz_lost=hz_lost.estimate,
            hz_lost_lo=hz_lost.low, hz_lost_hi=hz_lost.high, hz_vs_p=hz_vs.pvalue, hz_vs_holm_p=hz_holm,
            family_size=len(family), hz_true_lost=float(true_map["regularised N=30000, 10 Hz"].mean()),
            hz_true_holm_p=family["regularised N=30000, 10 Hz, map error vs true map"][1])
assert hz_holm >= 0.05 and family["regularised N=30000, 10 Hz, map error vs true map"][1] < 0.05  # the prose's reading
family_table = pd.DataFrame([{"comparison (A vs B)": name, "flights": t.a.n, "lost A": t.a.estimate,
                              "lost B": t.b.estimate, "only A / only B": f"{t.only_a} / {t.only_b}",
                              "McNemar p": t.pvalue, "Holm p": p} for name, (t, p) in family.items()])
EvidenceBlock(
    f"with the map error, the best filter loses {best_mm.estimate:.0%} of {best_mm.n} flights",
    notes=[f"Filter's map: the true DEM smoothed by a Gaussian of {MAP_SMOOTHING_CELLS:g} cell plus an error field of "
           f"{MAP_ERROR_SD:g} m standard deviation correlated over {MAP_ERROR_CORRELATION_CELLS:g} cells; the whole "
           f"difference from the true DEM has a standard deviation of {mm['map_error_sd'].mean():.1f} m over the map "
           f"(mean over the flights' maps). {best_mm.n} flights (the 10 Hz runs are expensive); every setting sees the "
           "same flights, filter seeds and maps, and the true-map rows are the stored runs of the same flights.",
           f"Best filter, map error vs true map, same flights: {best_vs_true}.",
           f"10 Hz vs 1 Hz, lost, map error, same flights: {hz_vs}.",
           f"10 Hz over 1 Hz, final error on the flights both converge, map error: {hz_mm}; true map, same flights: "
           f"{hz_true}.",
           f"Told of its map error (R_f = R + map variance) vs not told: lost {told_vs}; final error ratio {told}.",
           f"The family: every comparison of lost flights in the two map-error studies (terrain_map_error, flights "
           f"0-{flights[-1]}, and terrain_map_bias of the next chapter, flights 0-{mb_lost.index[-1]}), "
           f"{len(family)} exact McNemar tests, Holm's adjustment over all of them (evidence.holm)."],
    tables=[("Lost shares with the mismatched map, and on the true map for the same flights", mm_table,
             {"lost, map error": ".2f", "lost, true map": ".2f", "McNemar p": ".2g",
              "median final error, converged (m)": ".0f"}),
            ("Every comparison of the map-error studies, Holm-adjusted", family_table,
             {"lost A": ".2f", "lost B": ".2f", "McNemar p": ".2g", "Holm p": ".2g"})],
)

# %% [markdown]
# With the map error the best filter loses {glue:text}`terrain_map_error_best_lost:.0%`
# ({glue:text}`terrain_map_error_best_lo:.0%`-{glue:text}`terrain_map_error_best_hi:.0%`) of the
# flights, against {glue:text}`terrain_map_error_best_true:.0%` on the true map for the same
# flights: more, by a difference that fifty flights do not resolve (the evidence gives its interval).
#
# **Measuring faster with a wrong map: a warning, not a verdict.** Measuring ten times a second,
# the same filter loses {glue:text}`terrain_map_hz_lost:.0%` of the flights, against
# {glue:text}`terrain_map_error_best_lost:.0%` at $1$ Hz on the same flights and maps. Taken alone
# the difference looks real; corrected for all the comparisons of the two map-error studies (this
# one and the next chapter's, in the evidence block), fifty flights do not establish it.
#
# What they do establish is that at $10$ Hz the wrong map costs flights: the
# same filter loses {glue:text}`terrain_map_hz_true_lost:.0%` of them on the true map. The mechanism
# is plausible: at $100$ m/s ten readings a second fall $10$ m
# apart, inside one patch of map error, and a filter that treats their errors as independent counts
# the same error many times.
#
# On the flights both converge, the $10$ Hz filter's final error is
# {glue:text}`terrain_map_hz_ratio:.2f` times the $1$ Hz filter's
# ({glue:text}`terrain_map_hz_lo:.2f`-{glue:text}`terrain_map_hz_hi:.2f`), against
# {glue:text}`terrain_map_hz_true:.2f` on the true map.
#
# **Telling the filter** by adding the map error's variance to $R_f$ (its standard deviation is
# {glue:text}`terrain_map_sd_total:.0f` m, beside the altimeter's $20$ m) changes the $1$ Hz
# filter's final error by a factor of {glue:text}`terrain_map_told_ratio:.2f`: a wider likelihood
# does not model an error that is the same from one reading to the next. {doc}`terrain_marginalised`
# carries the error as a state instead, and inflates $R_f$ by the readings per correlation length.

# %% [markdown]
# ## A reference posterior for five flights
#
# A reference posterior says what the exact filter would answer on a given flight. Here the reference is the bootstrap filter (no
# kernel, no tempering: consistent as $N$ grows) run with as many particles as the book can afford: $N = 5 \times 10^5$ and $10^6$, two independent seeds each, on flights $0$ to
# $4$ (`python3 tasks.py study terrain_reference`). Distances between posterior means are measured
# in units of the posterior's own spread at the final step,
# $\sigma = \sqrt{\operatorname{var} x + \operatorname{var} y}$.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
reference = STUDIES["terrain_reference"].load()
big, half = reference["N"].max(), reference["N"].min()
rows = []
for flight_id, g in reference.groupby("flight"):
    g = g.set_index(["N", "repeat"])
    sigma = float(np.mean(np.hypot(g.loc[big, "sd_x"], g.loc[big, "sd_y"])))
    m_big = g.loc[big, ["mean_x", "mean_y"]].to_numpy()  # two seeds
    m_half = g.loc[half, ["mean_x", "mean_y"]].to_numpy()
    ref_mean = m_big.mean(axis=0)
    sim = simulate(scenario, terrain, data_rng(0, flight_id))
    pf = FILTERS["regularised N=30000"].build(scenario.model(terrain))
    estimate = pf.run(sim.measurements, rng=filter_rng(0, flight_id)).mean[-1, :2]
    rows.append({"flight": flight_id, "posterior sd (m)": sigma,
                 "seeds apart, N=5e5 (sd)": np.linalg.norm(m_half[0] - m_half[1]) / sigma,
                 "seeds apart, N=1e6 (sd)": np.linalg.norm(m_big[0] - m_big[1]) / sigma,
                 "N doubled, same seed (sd)": np.max(np.linalg.norm(m_big - m_half, axis=1)) / sigma,
                 "regularised N=30000 to reference (sd)": np.linalg.norm(estimate - ref_mean) / sigma,
                 "truth to reference (sd)": np.linalg.norm(sim.truth[-1, :2] - ref_mean) / sigma,
                 "truth to reference (m)": np.linalg.norm(sim.truth[-1, :2] - ref_mean)})
ref_table = pd.DataFrame(rows)
glue_values("terrain_ref_", doubling_max=float(ref_table["N doubled, same seed (sd)"].max()),
            seeds_max=float(ref_table["seeds apart, N=1e6 (sd)"].max()),
            half_seeds_max=float(ref_table["seeds apart, N=5e5 (sd)"].max()),
            filter_median=float(ref_table["regularised N=30000 to reference (sd)"].median()),
            filter_max=float(ref_table["regularised N=30000 to reference (sd)"].max()),
            truth_median=float(ref_table["truth to reference (sd)"].median()), flights=int(len(ref_table)),
            far=int((ref_table["truth to reference (m)"] > 500).sum()),
            lost_rule_sd=float((500 / ref_table["posterior sd (m)"]).min()))
EvidenceBlock(
    "how far the reference itself moves with N and the seed",
    notes=["Five flights fixed in advance (the first five): an illustration, not a study."],
    tables=[("Distances between final posterior means, in posterior standard deviations", ref_table,
             {c: ".2f" for c in ref_table.columns if c != "flight"})],
)

# %% [markdown]
# With $10^6$ particles the two seeds' final means are at most
# {glue:text}`terrain_ref_seeds_max:.2f` posterior standard deviations apart, and doubling $N$ at a
# fixed seed moves the mean by at most {glue:text}`terrain_ref_doubling_max:.2f`: the reference is
# settled to about that much, no better. The regularised filter with $N = 30\,000$ ends a median
# {glue:text}`terrain_ref_filter_median:.2f` posterior standard deviations from it (at most
# {glue:text}`terrain_ref_filter_max:.2f`): its own error, Monte Carlo and kernel, is of the same
# order as the posterior's spread on these flights, not negligible beside it.
#
# The reference also checks the rule that calls a flight lost. Its mean ends more than $500$ m from
# the truth on {glue:text}`terrain_ref_far:d` of the {glue:text}`terrain_ref_flights:d` flights, but
# on the widest posterior $500$ m is only {glue:text}`terrain_ref_lost_rule_sd:.1f` standard
# deviations: a filter that is right but uncertain can cross the line, so "lost" counts a few such
# flights besides the ones where the particles missed the aircraft.
#
# ## Try it
#
# The panel reruns flight {glue:text}`terrain_panel_flight:d`, one the bootstrap filter loses, with the
# kernel's scale $c$ ($h = c\,h_\text{opt}$; $c = 0$ is the bootstrap filter) and the number of
# particles you choose, and draws the cloud at the end of the flight beside the error over time.
# At $N = 3000$, compare $c = 0$, $0.2$ and $1$: no move, the chapter's move, and the textbook
# bandwidth that throws the particles off their terrain match.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
import ipywidgets as widgets
from IPython.display import display

from pfcourse.book.figures.terrain import flight_figure
from pfcourse.book.panels import control_panel, particle_slider
from pfcourse.collectors import LastCloud
from pfcourse.filter_config import FilterSettings

PANEL_FLIGHT = 2  # lost by the bootstrap filter with N = 3000, kept by the regularised one (terrain_remedies)
panel_flight = simulate(scenario, terrain, data_rng(0, PANEL_FLIGHT))
glue_values("terrain_panel_", flight=PANEL_FLIGHT)


def draw(kernel_scale=0.2, n_particles=3000):
    """The regularised filter (kernel_scale = 0: the bootstrap filter) on the panel's flight."""
    jitter = RegularisedJitter(kernel_scale, (3,)) if kernel_scale > 0 else None
    settings = FilterSettings(n_particles=n_particles, threshold=0.5, resampler="multinomial", jitter=jitter)
    res = settings.build(scenario.model(terrain)).run(panel_flight.measurements, rng=filter_rng(0, PANEL_FLIGHT),
                                                      collect=[LastCloud()])
    name = "no move (bootstrap)" if kernel_scale == 0 else f"kernel move at {kernel_scale:g} h_opt"
    flight_figure(terrain, panel_flight, res.mean, res.collected["last_cloud"],
                  f"{name}, N = {n_particles}")


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
panel = control_panel(
    draw,
    grid={"kernel_scale": (0.0, 0.2, 1.0), "n_particles": (1000, 3000, 10000)},
    kernel_scale=widgets.SelectionSlider(options=[0.0, 0.05, 0.1, 0.2, 0.5, 1.0], value=0.2,
                                         description="kernel scale c"),
    n_particles=particle_slider(3000, 2, 4),
    alt="flight 2: the filter's final cloud over the map and its horizontal error over time",
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 18.1 The bandwidth of a multimodal cloud
# :label: ex-terrain-bandwidth
# :nonumber:
# Compute the regularised filter's optimal bandwidth $h_\text{opt}$ for $N = 3000$ and
# $N = 30\,000$ particles in the aircraft's four-dimensional state, and the standard deviation
# of the kernel's move in $x$ when the cloud is a single blob of $50$ m, and when it is two
# equal blobs $4$ km apart. Which of the two situations does the formula assume?
# ```
#
# ```{solution} ex-terrain-bandwidth
# :class: dropdown
# $h_\text{opt} = (4/6)^{1/8} N^{-1/8}$: `optimal_bandwidth(3000, 4)` $\approx 0.35$ and
# `optimal_bandwidth(30000, 4)` $\approx 0.26$. The move's standard deviation in $x$ is
# $h\sqrt{\hat\Sigma_{xx}}$: about $17$ m (or $13$ m) for the $50$ m blob, but for two blobs $4$ km apart
# $\sqrt{\hat\Sigma_{xx}} \approx 2$ km and the move is about $700$ m ($500$ m), which throws the particles
# of each blob off its terrain match. The formula is optimal for a Gaussian density, the
# single blob; this is why the chapter's filter uses $0.2\,h_\text{opt}$.
# ```
#
# ```{exercise} 18.2 The optimal kernel: Epanechnikov's
# :label: ex-terrain-jitter
# :nonumber:
# (Coding.) The Gaussian kernel of Algorithm 18.1 is convenient, not optimal. Among kernels,
# the mean integrated squared error of the smoothed cloud is smallest for the Epanechnikov
# kernel {cite:p}`musso2001`, which is zero outside the unit ball:
#
# $$
# K(\varepsilon) = \frac{d + 2}{2 c_d}\bigl(1 - \lVert\varepsilon\rVert^2\bigr)
# \ \text{for}\ \lVert\varepsilon\rVert < 1, \qquad c_d = \frac{\pi^{d/2}}{\Gamma(d/2 + 1)},
# $$
#
# with the bandwidth $h_\text{opt} = A N^{-1/(d+4)}$,
# $A = \bigl(8\, c_d^{-1} (d + 4) (2\sqrt\pi)^d\bigr)^{1/(d+4)}$ ($c_d$ is the unit ball's volume).
# Write `my_move(particles, scale, rng)`: the move $x^i + h \hat\Sigma^{1/2}\varepsilon^i$ of an equally
# weighted cloud `particles` of shape `(N, d)` (no angles), with $\varepsilon^i$ drawn from $K$ with
# `rng` and $h$ = `scale` $\times\, h_\text{opt}$. The kernel is round, so $\varepsilon^i$ is a direction
# uniform on the sphere times a radius $r$: work out the density of $r$ before you draw it (a shell
# of radius $r$ has area proportional to $r^{d-1}$). The checker moves a cloud of correlated
# particles, checks the law of the moves' lengths and their covariance, and names the typical
# mistakes.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_epanechnikov_move


def my_move(particles, scale, rng):
    """Your Epanechnikov move: an array shaped like particles."""
    ...  # replace with your code


print(check_epanechnikov_move(my_move))

# %% [markdown]
# ```{solution} ex-terrain-jitter
# :class: dropdown
# The radius has density proportional to $r^{d-1}(1 - r^2)$ on $[0, 1]$; with $u = r^2$ that is
# $u^{d/2 - 1}(1 - u)$, a $\mathrm{Beta}(d/2, 2)$ law, so $r = \sqrt u$. A direction uniform on the
# sphere is $g / \lVert g\rVert$ with $g$ standard normal. Then $\varepsilon^i = r\, g / \lVert g\rVert$, and
# the move is that of Algorithm 18.1 with this $\varepsilon$ and this $h$ (any square root of
# $\hat\Sigma$ will do, here Cholesky's). The moves' covariance is $h^2 \hat\Sigma / (d + 4)$, smaller
# than the Gaussian kernel's for the same $h$, which is one reason its $h_\text{opt}$ is larger.
# The code is in the folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
from scipy.special import gamma


def my_move(particles, scale, rng):
    n, d = particles.shape
    c_d = np.pi ** (d / 2) / gamma(d / 2 + 1)  # the unit ball's volume
    A_d = (8 / c_d * (d + 4) * (2 * np.sqrt(np.pi)) ** d) ** (1 / (d + 4))
    h = scale * A_d * n ** (-1 / (d + 4))
    g = rng.standard_normal((n, d))
    r = np.sqrt(rng.beta(d / 2, 2, n))  # r^2 ~ Beta(d/2, 2)
    eps = g / np.linalg.norm(g, axis=1, keepdims=True) * r[:, None]
    L = np.linalg.cholesky(np.cov(particles, rowvar=False))  # L L^T = S
    return particles + h * eps @ L.T


print(check_epanechnikov_move(my_move))

# %% [markdown]
# ## Takeaways
#
# - The baseline filter loses most flights because its four-dimensional prior is too wide for its
#   particles: the nearest one comes closer only slowly as $N$ grows.
# - Moving the copies after each resampling by a kernel draw, at a fraction of the textbook
#   bandwidth when the cloud is multimodal, keeps the aircraft at the bootstrap filter's cost in
#   likelihood evaluations, and a test on fresh flights decided in advance confirms it.
# - The posterior Cramér-Rao bound limits the mean squared error over the prior and the noise:
#   computed so, on flights drawn from the filter's own model, the filter is several times above
#   it, as on the noise-free flights. A bound built from the map's slopes is far from attainable
#   here; it is a floor, not a target.
# - A filter tested on the map that generated its data is flattered: at ten readings a second a
#   map that is not the truth costs it many flights, because the map's errors repeat from one
#   reading to the next.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab B ({doc}`../labs`) asks how the filter's settings change its final error, and its report
# answered from one run each: its baseline filter happened to converge in that run, while it
# loses most flights here ("The first lesson"). The regularised filter and the test on fresh
# flights answer what to change; the bound and the map-error study say how far the answer can be
# trusted.
# :::
