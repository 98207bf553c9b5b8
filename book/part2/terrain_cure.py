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
# **You learn** why the lab's terrain filter loses the aircraft (its prior is too wide for its
# particles), how a kernel move after each resampling (the regularised particle filter) keeps it,
# how far the filter that works is from the posterior Cramér-Rao bound, and what a map that is not
# the truth does to it.
#
# **You need** {doc}`terrain` and {doc}`../part1/resampling_schemes`; covariance matrices and their square
# roots; paired tests ({doc}`../evidence`).
#
# **Time:** about thirty minutes to read; the notebook runs in under twenty seconds (the studies
# are stored).
# :::
#
# The previous chapter's particle filter, the lab report's ($N = 3000$ particles, resampling
# when $\mathrm{ESS} < N/2$), loses the aircraft in a large share of the flights. This chapter
# measures why, tries the standard remedies on the *same* flights, and compares the filter that
# converges with the best accuracy any estimator can reach.
#
# **Lost**, everywhere below: the filter's final horizontal error exceeds $500$ m (about five DEM
# cells) or every particle died. The studies cost minutes, so they were computed by
# `python3 tasks.py study NAME` and stored in `book/data/` with their provenance; a test recomputes
# a sample of their rows. Flight $r$ is the same in every setting (common random numbers), so
# settings are compared flight by flight with paired tests.

# %%
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from myst_nb import glue
from scipy import stats

from pfcourse import evidence
from pfcourse.exercises import check_regularised_jitter
from pfcourse.experiments.registry import STUDIES
from pfcourse.experiments.terrain_remedies import FILTERS
from pfcourse.figures.report import EvidenceBlock, glue_values
from pfcourse.jitter import RegularisedJitter, optimal_bandwidth
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.style import use_style
from pfcourse.terrain.map import MAP_ERROR_CORRELATION_CELLS, MAP_ERROR_SD, MAP_SMOOTHING_CELLS, load_jacksboro
from pfcourse.terrain.pcrb import horizontal_bound, terrain_bound_noise_free, terrain_pcrb
from pfcourse.terrain.scenario import AircraftScenario, simulate

use_style()
terrain = load_jacksboro()
scenario = AircraftScenario()
data = STUDIES["terrain_remedies"].load()
provenance = data.attrs["provenance"]
print("study commits:", sorted({r["commit"][:10] for r in provenance["runs"]}))

# %% [markdown]
# ## The first lesson: the report's filter loses the aircraft

# %%
runs = data.pivot(index="flight", columns="setting", values="lost")  # NaN where a setting has fewer flights
final = data.pivot(index="flight", columns="setting", values="final_error")
base = runs["bootstrap N=3000"].astype(bool)
k, n = int(base.sum()), int(base.count())
ci = evidence.rate(k, n)
glue_values("terrain_baseline_", diverged=float(k / n), lo=ci.low, hi=ci.high, runs=n)
print(f"bootstrap N = 3000: {k} of {n} flights lost ({k / n:.0%}, Wilson 95 % CI {ci.low:.0%} to {ci.high:.0%})")

# %% [markdown]
# The report's filter loses {glue:text}`terrain_baseline_diverged:.0%` of
# {glue:text}`terrain_baseline_runs` flights (95 % Wilson interval
# {glue:text}`terrain_baseline_lo:.0%` to {glue:text}`terrain_baseline_hi:.0%`). Its single
# run in the report happened to converge.
#
# ## Why it fails: the prior is too big for its particles
#
# A particle can only be rescued by the readings if it starts within the likelihood's reach of
# the truth: horizontally within a fraction of a $90$ m cell, in altitude within a few tens of
# metres, and in heading close enough that dead reckoning does not carry it away (an error
# $\delta\psi$ moves it sideways by $V t\,\delta\psi$: $1°$ is $140$ m after $8$ km). The prior
# is $1667$ m (one standard deviation) in $x$ and $y$, $100$ m in altitude and $20°$ in heading.
# The cell below draws the filter's own initial cloud for $N = 3000$, $30\,000$ and $10^5$ on
# $100$ flights and measures the particle nearest to the truth.

# %%
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
def regularised_move(particles, scale, rng, angle=3):
    """Algorithm 18.1, step 2: x^i + h S^(1/2) eps^i, h = scale * h_opt(N, d), heading wrapped."""
    n, d = particles.shape
    x = particles.copy()
    mean_angle = np.arctan2(np.mean(np.sin(x[:, angle])), np.mean(np.cos(x[:, angle])))
    x[:, angle] = np.angle(np.exp(1j * (x[:, angle] - mean_angle)))  # deviations, wrapped
    S = np.cov(x, rowvar=False)
    eigenvalues, V = np.linalg.eigh(S)
    A = V * np.sqrt(np.clip(eigenvalues, 0.0, None))  # A A^T = S
    h = scale * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
    moved = particles + h * rng.standard_normal((n, d)) @ A.T
    moved[:, angle] = np.angle(np.exp(1j * moved[:, angle]))  # wrap to (-pi, pi]
    return moved


flight = simulate(scenario, terrain, data_rng(0, 0))
pf = FILTERS["bootstrap N=3000"].build(scenario, terrain)
# step the filter through the first six readings and keep the last step's weighted cloud
last = list(pf.steps(flight.measurements[:6], rng=filter_rng(0, 0)))[-1]
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
# counted in likelihood evaluations ($N$ per reading, plus one per extra stage), relative to the
# bootstrap filter with $N = 30\,000$. Each setting is compared with the baseline flight by
# flight: the exact McNemar test on the flights lost by one and not the other, and a Wilcoxon
# signed-rank test of the final errors on the flights both converge.

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
    f"the {best} filter loses the fewest flights at no more than the bootstrap filter's cost",
    notes=[f"{len(runs)} flights, the same for every setting (regularised h=1 was run on flights 0-11 only). Cost: "
           "likelihood evaluations relative to the bootstrap filter with N = 30 000; the wall time per flight was "
           "measured on a shared machine and is indicative only. McNemar: exact test on the flights lost by one "
           "setting and not the baseline; Wilcoxon: signed-rank test of the final errors on the flights both "
           "converge (see Reading the evidence)."]
          + [f"{pairs[key][0]} vs {pairs[key][1]}: lost by the first only / by the second only "
             f"{v.only_a} / {v.only_b}, exact McNemar p = {v.pvalue:.2g}; difference of lost shares "
             f"{v.difference:+.2f} (95 % interval {v.difference_low:+.2f} to {v.difference_high:+.2f})"
             for key, v in comparisons.items()],
    tables=[("Every setting against the baseline (bootstrap N = 3000) on the same flights",
             table.reset_index(), {"lost rate": ".2f", "McNemar p": ".2g", "median final error, converged (m)": ".0f",
                                   "Wilcoxon p (both converged)": ".2g", "cost vs bootstrap N=30000": ".2f",
                                   "median s/flight": ".2f"})],
)

# %% [markdown]
# The best filter at a cost no greater than the bootstrap filter with $30\,000$ particles is the
# **{glue:text}`terrain_best_name`** filter: it loses {glue:text}`terrain_best_diverged:.0%` of the
# flights (95 % interval {glue:text}`terrain_best_ci`), far fewer than the baseline on the same
# flights (exact McNemar $p$ = {glue:text}`terrain_best_mcnemar:.1e`). Setting by setting (the table is in the evidence
# above):
#
# - **Particles** help slowly: the bootstrap filter still loses
#   {glue:text}`terrain_boot30k_diverged:.0%` with $30\,000$ particles and
#   {glue:text}`terrain_boot100k_diverged:.0%` with $10^5$, at
#   {glue:text}`terrain_boot100k_cost:.1f` times the cost.
#
# - **Regularisation** with $3000$ particles loses {glue:text}`terrain_rpf3k_diverged:.0%`, not
#   told apart from the bootstrap filter with ten times as many (McNemar $p$ =
#   {glue:text}`terrain_rpf3k_vs_boot30k_p:.2f`). With the textbook bandwidth $h_\text{opt}$ it
#   loses {glue:text}`terrain_rpf_h1_diverged:.0%`: the formula assumes one Gaussian blob.
#
# - **Progressive correction** alone loses {glue:text}`terrain_tempered_diverged:.0%` ($p$ =
#   {glue:text}`terrain_tempered_p:.2f` against the baseline); added to the regularised filter it
#   changes nothing the study can detect ($p$ = {glue:text}`terrain_trpf_vs_rpf_p:.2f`). So the
#   losses are not made at the first readings alone: our reading (not measured here) is that the
#   loss of diversity over the following tens of seconds, which the kernel move repairs, is what
#   loses the aircraft.
#
# - **$Q_f$ divided by $3$** loses {glue:text}`terrain_qf3_diverged:.0%` ($p$ =
#   {glue:text}`terrain_qf3_mcnemar:.2f`): the scaling rule can be applied to $Q_f$ with no change
#   the study can see. The heading entry ($3.3°$ per second) is what lets the particles turn back
#   onto the truth; a horizontal noise of $1$ or $3$ m per second is small beside the cells.
#
# The previous chapter ({doc}`terrain`) re-runs the report's studies around this filter, on the
# same flights (there its baseline loses a share
# {glue:text}`terrain.ipynb::studies_base_lost:.2f` of them, the rows of this study). The figure
# shows the final errors of five settings, sorted: the lost flights lie right of the $500$ m line.

# %%
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
# report's studies of {doc}`terrain`, flies the fresh flights $100$ to $199$; it passes if it
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
# {glue:text}`terrain_fresh_flights` fresh flights (95 % Wilson interval
# {glue:text}`terrain_fresh_lo:.0%` to {glue:text}`terrain_fresh_hi:.0%`), far fewer than the
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
# evaluations, yes; at its wall time, not shown** (on this machine, shared with other work).

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
# with $F_k$ the Jacobian of the dynamics (`pfcourse.terrain.pcrb`, which the tests check against the
# Kalman covariance in the linear-Gaussian case). The simulated aircraft has no
# process noise ($Q_f$ is only the filter's allowance for model error), so the bound of the flights
# as simulated is the limit $Q \to 0$, $J_{k+1} = F_k^{-\top} J_k F_k^{-1} + H_{k+1}^\top R^{-1} H_{k+1}$.
# We evaluate it along each of the $100$ true flights and average it over them:
# $\bar B_k = \frac{1}{100}\sum_r (B_{k,xx}^r + B_{k,yy}^r)$ bounds the mean of the squared
# horizontal error, and $\sqrt{\bar B_k}$ its root (RMSE). It is not a bound for any one flight, and
# a median over flights of a per-flight ratio is not what it limits: the comparison is the
# filter's RMSE over the same flights against $\sqrt{\bar B_k}$. The filter's error at every step
# of the $100$ flights is a stored study (`terrain_error_paths`).

# %%
X = np.array(truths)  # the same 100 flights
free = np.array([terrain_bound_noise_free(scenario, terrain, x) for x in X])  # (flights, steps, 4, 4)
B = free[:, :, 0, 0] + free[:, :, 1, 1]  # B_xx + B_yy along each flight (m^2)
paths = STUDIES["terrain_error_paths"].load().sort_values("flight")
assert paths["setting"].eq(best).all()  # the stored paths are the best filter's
E = np.stack(paths["errors"].to_numpy())  # horizontal error (m), (flights, steps)
converged = ~paths["lost"].to_numpy(bool)
assert np.allclose(E[:, -1], final[best].to_numpy())  # the same runs as the remedies study


def rmse(errors):
    """Root of the mean squared error over the flights (rows), at every step."""
    return np.sqrt(np.mean(errors**2, axis=0))


t = scenario.times
fig, ax = plt.subplots(figsize=(7.5, 3.8))
ax.plot(t, rmse(E), label=f"{best}, all {len(E)} flights")
ax.plot(t, rmse(E[converged]), label=f"{best}, {converged.sum()} converged")
ax.plot(t, np.sqrt(B.mean(axis=0)), "k--", label=r"bound $\sqrt{\bar B_k}$ (no process noise)")
ax.set_yscale("log")
ax.set_xlabel("time t (s)")
ax.set_ylabel("horizontal RMSE (m)")
ax.legend(loc="upper right")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
ratio = evidence.run_interval(lambda r: np.sqrt(np.mean(E[r][converged[r], -1] ** 2) / np.mean(B[r, -1])), len(E))
ratio_all = evidence.run_interval(lambda r: np.sqrt(np.mean(E[r, -1] ** 2) / np.mean(B[r, -1])), len(E))
model_bounds = np.array([terrain_pcrb(scenario, terrain, x) for x in X])
model_B = model_bounds[:, -1, 0, 0] + model_bounds[:, -1, 1, 1]
averaged_information = horizontal_bound(terrain_pcrb(scenario, terrain, X))[-1]
glue_values("terrain_", best_rmse_over_bound=ratio[0], best_rmse_over_bound_lo=ratio[1],
            best_rmse_over_bound_hi=ratio[2], rmse_all_over_bound=ratio_all[0],
            bound_final=float(np.sqrt(B[:, -1].mean())), converged_rmse=float(rmse(E[converged])[-1]),
            all_rmse=float(rmse(E)[-1]), converged_n=int(converged.sum()))
EvidenceBlock(
    f"the converged flights' RMSE is {ratio[0]:.1f} times the averaged bound at 80 s",
    notes=[f"Final step (80 s), {len(E)} flights of {best}: RMSE over the {converged.sum()} converged flights "
           f"{rmse(E[converged])[-1]:.0f} m, over all flights {rmse(E)[-1]:.0f} m; the bound's RMS "
           f"sqrt(mean(B_xx + B_yy)) = {np.sqrt(B[:, -1].mean()):.1f} m.",
           f"Ratios with 95 % percentile-bootstrap intervals over the flights (evidence.run_interval): converged "
           f"{ratio[0]:.2f} ({ratio[1]:.2f} to {ratio[2]:.2f}); all flights {ratio_all[0]:.1f} "
           f"({ratio_all[1]:.1f} to {ratio_all[2]:.1f}).",
           "The converged flights are a selection (the filter's own verdict on which flights it kept), so their "
           "RMSE is not what the bound limits; the RMSE over all flights is.",
           f"With the filter's process noise Q_f (a bound for an aircraft that has that noise, not for these flights) "
           f"the RMS of the per-flight bounds is {np.sqrt(model_B.mean()):.0f} m. Averaging the information over the "
           f"flights before inverting it (the strict Bayesian bound) gives {averaged_information:.0f} m, lower, as "
           "the convexity of the inverse requires: the RMS of per-flight bounds is the conservative reading."],
)

# %% [markdown]
# At the end of the flight the converged flights' RMSE, {glue:text}`terrain_converged_rmse:.0f` m,
# is {glue:text}`terrain_best_rmse_over_bound:.1f` times the bound's RMS (95 % bootstrap interval
# over the flights {glue:text}`terrain_best_rmse_over_bound_lo:.1f` to
# {glue:text}`terrain_best_rmse_over_bound_hi:.1f`).
#
# What the ratio means: the filter's mean squared error is about the square of it, some nine
# times the least any estimator could reach on average over these flights. Not all of that gap is
# the filter's. The bound counts only the local slope of the terrain along the true flight; it
# cannot see that two places can have nearly the same profile, which the filter has to resolve
# and which keeps its posterior wide. And it limits the error over *all* flights, whose RMSE,
# with the lost ones, is {glue:text}`terrain_all_rmse:.0f` m. The figure shows the gap from the
# start: the bound falls within seconds, the filter's RMSE only after it has chosen among the
# candidate places. A near-exact answer for these flights, a grid filter with altitude integrated
# out, is the subject of the next chapter, which separates the filter's share of the gap from the
# problem's.
#
# ## A map that is not the truth
#
# So far the world and the filter use the same DEM, bilinear between the same nodes: the filter
# knows the terrain exactly. A real map is coarser than the ground and has errors. Here the
# filter's map is the world's DEM smoothed by a Gaussian of one cell (what a coarser survey, or a
# wide altimeter footprint, sees) plus a random error field of standard deviation
# {glue:text}`terrain_map_sd_field:.0f` m correlated over about two cells
# (`pfcourse.terrain.map.mismatched_map`), drawn afresh for each flight from its own seeded stream
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
glue_values("terrain_map_", sd_field=MAP_ERROR_SD, sd_total=float(mm["map_error_sd"].mean()),
            error_best_lost=best_mm.estimate, error_best_lo=best_mm.low, error_best_hi=best_mm.high,
            error_best_true=true_map["regularised N=30000"].mean(), error_best_p=best_vs_true.pvalue,
            error_base_lost=base_mm.estimate, error_flights=int(best_mm.n),
            hz_ratio=hz_mm.median, hz_lo=hz_mm.low, hz_hi=hz_mm.high, hz_true=hz_true.median,
            told_lost=float(mm_lost["regularised N=30000, Rf + map error"].mean()), told_p=told_vs.pvalue,
            told_ratio=told.median, told_lo=told.low, told_hi=told.high, hz_lost=hz_lost.estimate,
            hz_lost_lo=hz_lost.low, hz_lost_hi=hz_lost.high, hz_vs_p=hz_vs.pvalue)
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
           f"Told of its map error (R_f = R + map variance) vs not told: lost {told_vs}; final error ratio {told}."],
    tables=[("Lost shares with the mismatched map, and on the true map for the same flights", mm_table,
             {"lost, map error": ".2f", "lost, true map": ".2f", "McNemar p": ".2g",
              "median final error, converged (m)": ".0f"})],
)

# %% [markdown]
# With the map error the best filter loses {glue:text}`terrain_map_error_best_lost:.0%` of the
# flights (95 % Wilson interval {glue:text}`terrain_map_error_best_lo:.0%` to
# {glue:text}`terrain_map_error_best_hi:.0%`), against {glue:text}`terrain_map_error_best_true:.0%`
# on the true map for the same flights: more, by a difference that fifty flights do not resolve
# (the evidence gives its interval).
#
# **The $10$ Hz claim does not survive the map error.** Measuring ten times a second, the same
# filter loses {glue:text}`terrain_map_hz_lost:.0%` of the flights (95 % interval
# {glue:text}`terrain_map_hz_lost_lo:.0%` to {glue:text}`terrain_map_hz_lost_hi:.0%`), more than at
# $1$ Hz on the same flights and maps (exact McNemar $p$ = {glue:text}`terrain_map_hz_vs_p:.3f`).
#
# On the flights both converge, its final error is {glue:text}`terrain_map_hz_ratio:.2f` times the
# $1$ Hz filter's ({glue:text}`terrain_map_hz_lo:.2f` to {glue:text}`terrain_map_hz_hi:.2f`),
# against {glue:text}`terrain_map_hz_true:.2f` on the true map. The reason: at $100$ m/s ten
# readings a second fall $10$ m apart, inside one patch of map error correlated over about two
# cells. Their errors are not independent, and the filter, which treats them as independent,
# counts the same error ten times and becomes sure of a wrong place.
#
# **Telling the filter** does not help here: adding the map error's variance to $R_f$ (its
# standard deviation is {glue:text}`terrain_map_sd_total:.0f` m, beside the altimeter's $20$ m)
# changes the $1$ Hz filter's final error by a factor of {glue:text}`terrain_map_told_ratio:.2f`
# ({glue:text}`terrain_map_told_lo:.2f` to {glue:text}`terrain_map_told_hi:.2f`): a wider
# likelihood does not model an error that is the same from one reading to the next.

# %% [markdown]
# ## A reference posterior for five flights
#
# A reference posterior says what the exact filter would answer on a given flight. Here the reference is the bootstrap filter (no
# kernel, no tempering: consistent as $N$ grows) run with so many particles that **doubling $N$
# changes nothing**: $N = 5 \times 10^5$ and $10^6$, two independent seeds each, on flights $0$ to
# $4$ (`python3 tasks.py study terrain_reference`). Distances between posterior means are measured
# in units of the posterior's own spread at the final step,
# $\sigma = \sqrt{\operatorname{var} x + \operatorname{var} y}$.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
reference = STUDIES["terrain_reference"].load()
big, half = reference["N"].max(), reference["N"].min()
rows = []
for flight_id, g in reference.groupby("flight"):
    g = g.set_index(["N", "seed"])
    sigma = float(np.mean(np.hypot(g.loc[big, "sd_x"], g.loc[big, "sd_y"])))
    m_big = g.loc[big, ["mean_x", "mean_y"]].to_numpy()  # two seeds
    m_half = g.loc[half, ["mean_x", "mean_y"]].to_numpy()
    ref_mean = m_big.mean(axis=0)
    sim = simulate(scenario, terrain, data_rng(0, flight_id))
    pf = FILTERS["regularised N=30000"].build(scenario, terrain)
    estimate = pf.run(sim.measurements, rng=filter_rng(0, flight_id)).mean[-1, :2]
    rows.append({"flight": flight_id, "posterior sd (m)": sigma,
                 "seeds apart, N=5e5 (sd)": np.linalg.norm(m_half[0] - m_half[1]) / sigma,
                 "seeds apart, N=1e6 (sd)": np.linalg.norm(m_big[0] - m_big[1]) / sigma,
                 "N doubled, same seed (sd)": np.max(np.linalg.norm(m_big - m_half, axis=1)) / sigma,
                 "regularised N=30000 to reference (sd)": np.linalg.norm(estimate - ref_mean) / sigma,
                 "truth to reference (sd)": np.linalg.norm(sim.truth[-1, :2] - ref_mean) / sigma})
ref_table = pd.DataFrame(rows)
glue_values("terrain_ref_", doubling_max=float(ref_table["N doubled, same seed (sd)"].max()),
            seeds_max=float(ref_table["seeds apart, N=1e6 (sd)"].max()),
            half_seeds_max=float(ref_table["seeds apart, N=5e5 (sd)"].max()),
            filter_median=float(ref_table["regularised N=30000 to reference (sd)"].median()),
            filter_max=float(ref_table["regularised N=30000 to reference (sd)"].max()),
            truth_median=float(ref_table["truth to reference (sd)"].median()), flights=int(len(ref_table)))
EvidenceBlock(
    "the reference is settled to a tenth of the posterior's spread",
    notes=["Five flights fixed in advance (the first five): an illustration, not a study."],
    tables=[("Distances between final posterior means, in posterior standard deviations", ref_table,
             {c: ".2f" for c in ref_table.columns if c != "flight"})],
)

# %% [markdown]
# With $10^6$ particles the two seeds' final means are at most
# {glue:text}`terrain_ref_seeds_max:.2f` posterior standard deviations apart, and doubling $N$ at a
# fixed seed moves the mean by at most {glue:text}`terrain_ref_doubling_max:.2f`: the reference is
# settled. The regularised filter with $N = 30\,000$ ends a median
# {glue:text}`terrain_ref_filter_median:.2f` posterior standard deviations from it (at most
# {glue:text}`terrain_ref_filter_max:.2f`): its own error, Monte Carlo and kernel, is of the same
# order as the posterior's spread on these flights, not negligible beside it.
#
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
# ```{exercise} 18.2 Write the kernel move, and have it checked
# :label: ex-terrain-jitter
# :nonumber:
# (Coding.) Write `my_move(particles, scale, rng)`: the regularised filter's move of an equally
# weighted cloud `particles` of shape `(N, d)` (no angles), $x^i + h \hat\Sigma^{1/2}\varepsilon^i$ with
# $h$ = `scale` $\times\, h_\text{opt}(N, d)$, $\hat\Sigma$ the cloud's covariance and $\varepsilon^i$
# standard normal, drawn from `rng`. The checker moves a cloud of correlated particles of very
# different scales and tests that the moves have mean zero and covariance $h^2 \hat\Sigma$; it names the
# typical mistakes.
# ```

# %% tags=["answer"]
def my_move(particles, scale, rng):
    """Your kernel move: return the moved particles, an array of the shape of particles."""
    ...  # replace with your code


print(check_regularised_jitter(my_move))

# %% [markdown]
# ```{solution} ex-terrain-jitter
# :class: dropdown
# The move of Algorithm 18.1 without the heading; any square root of $\hat\Sigma$ will do (here Cholesky's).
# The code is in the folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_move(particles, scale, rng):
    n, d = particles.shape
    h = scale * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
    A = np.linalg.cholesky(np.cov(particles, rowvar=False))  # A A^T = S
    return particles + h * rng.standard_normal((n, d)) @ A.T


print(check_regularised_jitter(my_move))

# %% [markdown]
# ## Takeaways
#
# - The lab's filter loses most flights because its four-dimensional prior is too wide for its
#   particles: the nearest one comes closer only slowly as $N$ grows.
# - Moving the copies after each resampling by a kernel draw, at a fraction of the textbook
#   bandwidth when the cloud is multimodal, keeps the aircraft at the bootstrap filter's cost in
#   likelihood evaluations, and a test on fresh flights decided in advance confirms it.
# - The posterior Cramér-Rao bound limits the mean squared error over the prior and the noise:
#   compare the RMSE over many flights with the root of the averaged bound, never one flight or a
#   median of per-flight ratios.
# - A filter tested on the map that generated its data is flattered: with a map that is not the
#   truth, measuring ten times a second loses more flights instead of fewer, because the map's
#   errors repeat from one reading to the next.
