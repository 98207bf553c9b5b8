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
# The previous chapter's particle filter, the lab report's ($3000$ particles, resampling when
# $N_\text{eff} < N/2$), loses the aircraft in a large share of the flights. This chapter
# measures why, tries the standard remedies on the *same* flights, and compares the filters
# that converge with the best accuracy any estimator can reach, the posterior Cramér-Rao
# bound.
#
# **Divergence**, everywhere below: a flight is *lost* when the filter's final horizontal
# error exceeds $500$ m (about five DEM cells) or every particle died. Studies of $100$ flights
# cost minutes, more than a chapter may take to execute, so they were computed by
# `python3 tasks.py study terrain_remedies` (one row per setting and flight, with
# `pfcourse.experiments.terrain_remedies.run_one`) into `book/data/terrain_remedies.csv`; its provenance
# (git commit, seeds) is in `terrain_remedies.json`, and `tests/test_stored_studies.py`
# recomputes a random sample of the stored rows and requires the same numbers. Flight $r$
# is the same in every setting (common random numbers), so settings are compared flight by
# flight with paired tests.

# %%
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from myst_nb import glue
from scipy import stats

from pfcourse import evidence
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.terrain.scenario import AircraftScenario, simulate
from pfcourse.style import use_style
from pfcourse.terrain.map import load_jacksboro
from pfcourse.terrain.pcrb import horizontal_bound, terrain_bound_noise_free, terrain_pcrb
from pfcourse.jitter import optimal_bandwidth
from pfcourse.experiments.terrain_remedies import SETTINGS, make_filter

use_style()
terrain = load_jacksboro()
scenario = AircraftScenario()
data = pd.read_csv(Path("../data/terrain_remedies.csv"))
provenance = json.loads(Path("../data/terrain_remedies.json").read_text())
print("study commits:", sorted({r["commit"][:10] for r in provenance["runs"]}))

# %% [markdown]
# ## The first lesson: the report's filter loses the aircraft

# %%
runs = data.pivot(index="flight", columns="setting", values="lost")  # NaN where a setting has fewer flights
final = data.pivot(index="flight", columns="setting", values="final_error")
base = runs["bootstrap N=3000"].astype(bool)
k, n = int(base.sum()), int(base.count())
ci = evidence.rate(k, n)
lo, hi = ci.low, ci.high
glue("terrain_baseline_diverged", float(k / n), display=False)
glue("terrain_baseline_lo", float(lo), display=False)
glue("terrain_baseline_hi", float(hi), display=False)
glue("terrain_baseline_runs", n, display=False)
print(f"bootstrap N = 3000: {k} of {n} flights lost ({k / n:.0%}, Wilson 95 % CI {lo:.0%} to {hi:.0%})")

# %% [markdown]
# The report's filter loses {glue:text}`terrain_baseline_diverged:.0%` of
# {glue:text}`terrain_baseline_runs` flights (95 % Wilson interval
# {glue:text}`terrain_baseline_lo:.0%` to {glue:text}`terrain_baseline_hi:.0%`). Its single
# run in the report happened to converge.
#
# ## Why it fails: the prior is too big for $3000$ particles
#
# A particle can only be rescued by the readings if it starts within the likelihood's reach
# of the truth: horizontally within a fraction of a $90$ m cell (the terrain changes by tens of
# metres over a cell, and the altimeter's noise is $20$ m), in altitude within a few tens of
# metres, and in heading close enough that dead reckoning does not carry it away (an error of
# $\delta\psi$ moves it sideways by $V t\,\delta\psi$: $1°$ is $140$ m after $8$ km). The prior is
# $1667$ m (one standard deviation) in $x$ and $y$, $100$ m in altitude and $20°$ in heading. The
# cell below draws the filter's own initial cloud for $N = 3000$, $30\,000$ and $10^5$ on
# $100$ flights and
# measures the particle nearest to the truth, in each component.

# %%
P0_std = np.sqrt(np.diag(scenario.P0))
model = scenario.model(terrain)
sizes = [3000, 30000, 100000]
rows = []
for N in sizes:
    for r in range(100):
        truth = simulate(scenario, terrain, data_rng(0, r)).truth[0]
        cloud = model.sample_initial(N, filter_rng(0, r))
        d = (cloud - truth) / P0_std
        d[:, 3] = np.angle(np.exp(1j * (cloud[:, 3] - truth[3]))) / P0_std[3]
        horiz = np.hypot(cloud[:, 0] - truth[0], cloud[:, 1] - truth[1])
        i = np.argmin(np.sum(d**2, axis=1))      # nearest in the prior's own metric
        j = np.argmin(horiz)                     # nearest horizontally
        rows.append({"N": N, "nearest horizontal (m)": horiz[j],
                     "its altitude error (m)": abs(cloud[j, 2] - truth[2]),
                     "its heading error (deg)": np.degrees(abs(d[j, 3] * P0_std[3])),
                     "nearest in prior metric: horizontal (m)": horiz[i],
                     "... altitude (m)": abs(cloud[i, 2] - truth[2]),
                     "... heading (deg)": np.degrees(abs(d[i, 3] * P0_std[3]))})
near = pd.DataFrame(rows).groupby("N").median()
print("medians over 100 flights of the particle nearest to the truth at t = 0")
print(near.round(1).to_string())
glue("terrain_near_h_3000", float(near.loc[3000, "nearest horizontal (m)"]), display=False)
glue("terrain_near_psi_3000", float(near.loc[3000, "... heading (deg)"]), display=False)
glue("terrain_near_h2_3000", float(near.loc[3000, "nearest in prior metric: horizontal (m)"]), display=False)
glue("terrain_near_drift_3000", float(8000 * np.tan(np.radians(near.loc[3000, "... heading (deg)"]))), display=False)
glue("terrain_near_psi1_3000", float(near.loc[3000, "its heading error (deg)"]), display=False)
glue("terrain_near_h_100000", float(near.loc[100000, "nearest horizontal (m)"]), display=False)
# the log-log slope of the median horizontal distance against N, with a bootstrap interval over the flights
# (the flights are resampled together: flight r has the same truth for every N)
horizontal = pd.DataFrame(rows).assign(flight=np.tile(np.arange(100), len(sizes))).pivot(
    index="flight", columns="N", values="nearest horizontal (m)")
near_slope, near_slope_low, near_slope_high = evidence.log_slope(horizontal[sizes].to_numpy().T, sizes)
print(f"log-log slope of the median horizontal distance against N: {near_slope:.2f} "
      f"(95 % bootstrap interval {near_slope_low:.2f} to {near_slope_high:.2f}, 100 flights, 3 values of N)")
glue("terrain_near_slope", near_slope, display=False)
glue("terrain_near_slope_low", near_slope_low, display=False)
glue("terrain_near_slope_high", near_slope_high, display=False)

# %% [markdown]
# With $3000$ particles the particle nearest the truth horizontally is typically
# {glue:text}`terrain_near_h_3000:.0f` m away, within a cell, but it carries a random
# altitude and heading from the prior (its heading is {glue:text}`terrain_near_psi1_3000:.0f`°
# off, median). The particle nearest in all four components together, in the prior's own
# metric, is {glue:text}`terrain_near_h2_3000:.0f` m away horizontally and
# {glue:text}`terrain_near_psi_3000:.1f`° off in heading, which alone moves it
# {glue:text}`terrain_near_drift_3000:.0f` m sideways over the $8$ km flight if the process
# noise did not let its heading wander. The heading is the component that carries the error.
# The horizontal distance falls roughly like $N^{-1/2}$, the rate of the nearest of $N$ points
# in a two-dimensional prior: the log-log slope of its median is
# {glue:text}`terrain_near_slope:.2f` (95 % bootstrap interval
# {glue:text}`terrain_near_slope_low:.2f` to {glue:text}`terrain_near_slope_high:.2f` over the
# flights, from three values of $N$, printed above). Even $10^5$ particles leave the nearest one
# {glue:text}`terrain_near_h_100000:.0f` m away. The
# four-dimensional volume shrinks like $N^{-1/4}$ per component, which is why more particles
# help slowly, and why the remedies below, which *move* particles after the first readings
# instead of waiting for one to have been drawn in the right place, help more.
#
# ## The remedies, on the same flights
#
# - **More particles.** Bootstrap filters with $N = 10^4$ and $3 \times 10^4$.
# - **Regularised particle filter** {cite:p}`musso2001`. After each resampling, every particle
#   is moved by a Gaussian kernel, $x^i \leftarrow x^i + h\,S^{1/2}\varepsilon^i$, $S$ the
#   cloud's covariance; the bandwidth that is optimal for a Gaussian density is
#   $h_\text{opt} = (4/(d+2))^{1/(d+4)} N^{-1/(d+4)}$. The copies made by resampling become
#   distinct particles that explore the neighbourhood of the surviving modes. With $h_\text{opt}$ itself
#   (its $S$ measures a cloud spread over several modes kilometres apart) every move is
#   kilometres long and the filter is destroyed; we use $0.2\,h_\text{opt}$, a factor chosen on
#   flights $0$ to $11$ among $0.05$, $0.2$ and $1$ (so those $12$ of the $100$ flights are not independent of
#   the choice). It goes through the filter's `jitter` hook (`RegularisedJitter`).
# - **Progressive correction** {cite:p}`oudjane2000`. At the first five readings the
#   likelihood is brought in as $p(z\mid x)^{\lambda_1}, \dots, p(z\mid x)^{\lambda_m}$,
#   $\sum_j \lambda_j = 1$, each $\lambda_j$ the largest keeping the effective sample size at
#   $N/2$, with resampling and a regularised move between stages: the final target is the
#   posterior, reached without collapsing the cloud onto a few particles in one step. It is
#   an importance function (`ProgressiveCorrection`, the filter's `proposal` argument), with
#   the regularised kernel after the resamplings.
# - **$Q_f$ scaled like every other horizontal length** (divided by $3$: $1$ m per second instead
#   of $3$ m), to check the scenario's scaling rule.
#
# Cost is counted in likelihood evaluations: $N$ times the number of readings ($80$), plus one
# per extra stage of the progressive correction, relative to the bootstrap filter with
# $N = 30000$. Each setting is compared with the baseline flight by flight: the exact McNemar
# test on the flights lost by one and not the other, and, on the flights both converge, a
# Wilcoxon signed-rank test of the paired differences of the final errors (are they symmetric
# about zero?).

# %%
ref_cost = 30000 * 80
table = []
for name in [s for s in SETTINGS if s in runs.columns]:
    lost = runs[name].dropna().astype(bool)
    common = lost.index.intersection(base.index)
    versus = evidence.paired_rates(lost[common], base[common])  # exact McNemar on the same flights
    c, b, p_mc = versus.only_a, versus.only_b, versus.pvalue  # newly lost, rescued
    both = common[~base[common] & ~lost[common]]
    d = final.loc[both, name] - final.loc[both, "bootstrap N=3000"]
    # NaN when there is nothing to test: too few flights, or the same final errors (the baseline)
    p_w = (evidence.paired(final.loc[both, name], final.loc[both, "bootstrap N=3000"]).pvalue
           if len(both) > 10 and np.any(d != 0) else np.nan)
    evals = data.loc[data.setting == name, "evaluations"].mean()
    ci = evidence.rate(lost.sum(), lost.count())
    lo, hi = ci.low, ci.high
    table.append({"setting": name, "flights": int(lost.count()), "lost": int(lost.sum()),
                  "lost rate": lost.mean(), "95 % CI": f"{lo:.2f}-{hi:.2f}",
                  "rescued / newly lost vs baseline": f"{b} / {c}", "McNemar p": p_mc,
                  "median final error, converged (m)": final.loc[~lost, name].median(),
                  "Wilcoxon p (both converged)": p_w,
                  "cost vs bootstrap N=30000": SETTINGS[name][0] * evals / ref_cost,
                  "median s/flight": data.loc[data.setting == name, "seconds"].median()})
table = pd.DataFrame(table).set_index("setting")
pd.set_option("display.width", 200)
print(table.round(3).to_string())

# %%
affordable = table[table["cost vs bootstrap N=30000"] <= 1.0 + 1e-9]
best = affordable["lost rate"].idxmin()
glue("terrain_best_diverged", float(table.loc[best, "lost rate"]), display=False)
glue("terrain_best_name", best, display=False)
glue("terrain_best_ci", table.loc[best, "95 % CI"], display=False)
glue("terrain_best_cost", float(table.loc[best, "cost vs bootstrap N=30000"]), display=False)
glue("terrain_best_mcnemar", float(table.loc[best, "McNemar p"]), display=False)
glue("terrain_boot30k_diverged", float(table.loc["bootstrap N=30000", "lost rate"]), display=False)
glue("terrain_boot100k_diverged", float(table.loc["bootstrap N=100000", "lost rate"]), display=False)
glue("terrain_boot100k_cost", float(table.loc["bootstrap N=100000", "cost vs bootstrap N=30000"]), display=False)
glue("terrain_best_lost", int(table.loc[best, "lost"]), display=False)
glue("terrain_best_flights", int(table.loc[best, "flights"]), display=False)
glue("terrain_qf3_diverged", float(table.loc["bootstrap N=3000, Qf/3", "lost rate"]), display=False) if "bootstrap N=3000, Qf/3" in table.index else None
glue("terrain_qf3_mcnemar", float(table.loc["bootstrap N=3000, Qf/3", "McNemar p"]), display=False) if "bootstrap N=3000, Qf/3" in table.index else None
def mcnemar(a, b):
    """Exact McNemar test of settings a and b on their common flights: (a lost only, b lost only, p)."""
    la, lb = runs[a].dropna().astype(bool), runs[b].dropna().astype(bool)
    common = la.index.intersection(lb.index)
    versus = evidence.paired_rates(la[common], lb[common])
    return versus.only_a, versus.only_b, versus.pvalue


x, y, p = mcnemar("regularised N=3000", "bootstrap N=30000")
glue("terrain_rpf3k_vs_boot30k", f"{x} / {y}", display=False)
glue("terrain_rpf3k_vs_boot30k_p", float(p), display=False)
glue("terrain_rpf3k_diverged", float(table.loc["regularised N=3000", "lost rate"]), display=False)
glue("terrain_rpf30k_diverged", float(table.loc["regularised N=30000", "lost rate"]), display=False)
glue("terrain_rpf30k_ci", table.loc["regularised N=30000", "95 % CI"], display=False)
glue("terrain_rpf_h1_diverged", float(table.loc["regularised h=1 N=3000", "lost rate"]), display=False)
glue("terrain_tempered_diverged", float(table.loc["tempered N=3000", "lost rate"]), display=False)
glue("terrain_tempered_p", float(table.loc["tempered N=3000", "McNemar p"]), display=False)
x, y, p = mcnemar("tempered+regularised N=3000", "regularised N=3000")
glue("terrain_trpf_vs_rpf", f"{x} / {y}", display=False)
glue("terrain_trpf_vs_rpf_p", float(p), display=False)
print(f"regularised N=3000 vs bootstrap N=30000: lost by the first only / the second only, McNemar p: {mcnemar('regularised N=3000', 'bootstrap N=30000')}")
print(f"tempered+regularised N=3000 vs regularised N=3000: {mcnemar('tempered+regularised N=3000', 'regularised N=3000')}")
print(f"best at a cost <= bootstrap N = 30000: {best}, lost {table.loc[best, 'lost rate']:.0%} "
      f"({table.loc[best, '95 % CI']}), cost {table.loc[best, 'cost vs bootstrap N=30000']:.2f}")


def loss_difference(key, a, b):
    """Glue the 95 % interval of the lost share of a minus b, on their common flights (what "close" can hide)."""
    la, lb = runs[a].dropna().astype(bool), runs[b].dropna().astype(bool)
    common = la.index.intersection(lb.index)
    versus = evidence.paired_rates(la[common], lb[common])
    glue(f"{key}_diff_low", versus.difference_low, display=False)
    glue(f"{key}_diff_high", versus.difference_high, display=False)
    print(f"{a} vs {b}: {versus}")


loss_difference("terrain_rpf3k_vs_boot30k", "regularised N=3000", "bootstrap N=30000")
loss_difference("terrain_trpf_vs_rpf", "tempered+regularised N=3000", "regularised N=3000")
loss_difference("terrain_qf3", "bootstrap N=3000, Qf/3", "bootstrap N=3000")
loss_difference("terrain_boot100k_vs_boot30k", "bootstrap N=100000", "bootstrap N=30000")
x, y, p = mcnemar("bootstrap N=100000", "bootstrap N=30000")
glue("terrain_boot100k_vs_boot30k", f"{x} / {y}", display=False)
glue("terrain_boot100k_vs_boot30k_p", float(p), display=False)

# %% [markdown]
# The best filter at a cost no greater than the bootstrap filter with $30\,000$ particles is
# **{glue:text}`terrain_best_name`**: it loses {glue:text}`terrain_best_diverged:.0%` of the
# flights (95 % interval {glue:text}`terrain_best_ci`), at {glue:text}`terrain_best_cost:.2f`
# times that cost in likelihood evaluations (the last column of the table gives the median
# wall time per flight, measured on a shared machine: indicative only). Paired with
# the baseline on the same flights, the exact McNemar test gives
# $p$ = {glue:text}`terrain_best_mcnemar:.1e`. The table reads, setting by setting:
#
# - **Particles.** The bootstrap filter's losses fall with $N$, but slowly: with $30\,000$
#   particles it still loses {glue:text}`terrain_boot30k_diverged:.0%`, and with $10^5$
#   ({glue:text}`terrain_boot100k_cost:.1f` times the cost)
#   {glue:text}`terrain_boot100k_diverged:.0%` (on the same flights, lost by $10^5$ only / by
#   $30\,000$ only: {glue:text}`terrain_boot100k_vs_boot30k`, exact McNemar $p$ =
#   {glue:text}`terrain_boot100k_vs_boot30k_p:.2f`; the difference of lost shares lies within
#   {glue:text}`terrain_boot100k_vs_boot30k_diff_low:.2f` to
#   {glue:text}`terrain_boot100k_vs_boot30k_diff_high:.2f`).
# - **Regularisation.** With $3000$ particles the regularised filter loses
#   {glue:text}`terrain_rpf3k_diverged:.0%`, not told apart from the bootstrap filter with ten
#   times as many (flights lost by the first only / by the second only: {glue:text}`terrain_rpf3k_vs_boot30k`,
#   McNemar $p$ = {glue:text}`terrain_rpf3k_vs_boot30k_p:.2f`; the difference of lost shares
#   lies within {glue:text}`terrain_rpf3k_vs_boot30k_diff_low:.2f` to
#   {glue:text}`terrain_rpf3k_vs_boot30k_diff_high:.2f`), and with $30\,000$ particles
#   {glue:text}`terrain_rpf30k_diverged:.0%` ({glue:text}`terrain_rpf30k_ci`). With the
#   textbook bandwidth $h_\text{opt}$ it loses {glue:text}`terrain_rpf_h1_diverged:.0%`: the
#   formula assumes one Gaussian blob, and the early posterior here is several blobs kilometres
#   apart, so $S$ is kilometres wide and so is every move.
# - **Progressive correction** alone loses {glue:text}`terrain_tempered_diverged:.0%`
#   (McNemar against the baseline $p$ = {glue:text}`terrain_tempered_p:.2f`); added to the
#   regularised filter with $3000$ particles it changes nothing the study can detect (lost by the
#   first only / by the
#   second only: {glue:text}`terrain_trpf_vs_rpf`, $p$ = {glue:text}`terrain_trpf_vs_rpf_p:.2f`;
#   difference of lost shares within {glue:text}`terrain_trpf_vs_rpf_diff_low:.2f` to
#   {glue:text}`terrain_trpf_vs_rpf_diff_high:.2f`).
#   So the losses are not made at the first readings alone; our reading (not measured here)
#   is that the loss of particle diversity over the following tens of seconds, which the
#   kernel move repairs, is what loses the aircraft.
#
# **A baseline that works, nearly.** The target of this chapter is a filter that loses fewer than $5\,\%$ of
# $100$ flights at no more than the cost of the bootstrap filter with $30\,000$ particles. The best
# found here loses {glue:text}`terrain_best_lost` of {glue:text}`terrain_best_flights`: at
# the target, not below it, and its interval ({glue:text}`terrain_best_ci`) cannot separate it
# from $5\,\%$. The regularised filter is the baseline to build on: the previous chapter
# ({doc}`terrain`) re-runs the report's studies ($Q_f$, $R_f$, $N$, threshold, gap, period,
# scheme) around it, on the same flights (there its baseline loses a share
# {glue:text}`terrain.ipynb::studies_base_lost:.2f` of them, the rows of this study). Whether
# it really loses fewer than $5\,\%$ is settled below, on flights it has never seen.
#
# **$Q_f$.** Dividing its horizontal entries by $3$, like the scenario's other lengths, gives
# the row `bootstrap N=3000, Qf/3`: it loses {glue:text}`terrain_qf3_diverged:.0%`, with
# McNemar $p$ = {glue:text}`terrain_qf3_mcnemar:.2f` against the baseline on the same flights
# (difference of lost shares within {glue:text}`terrain_qf3_diff_low:.2f` to
# {glue:text}`terrain_qf3_diff_high:.2f`), so the scaling rule can be applied to $Q_f$ with no
# change the study can see. The heading
# entry ($3.3°$ per second), not the horizontal one, is what lets the
# baseline's particles turn back onto the truth; the horizontal noise of $1$ or $3$ m per second
# is small beside the $90$ m cells.
#
# The figure shows the final errors of each setting, sorted: the lost flights are those
# right of the $500$ m line, and the converged ones are read on the left.

# %%
fig, ax = plt.subplots(figsize=(7, 4))
for name in table.index:
    e = np.sort(final[name].dropna().to_numpy())
    ax.step(e, np.arange(1, len(e) + 1) / len(e), where="post", label=f"{name} ({len(e)} flights)")
ax.axvline(500, color="k", lw=0.8, ls="--")
ax.text(520, 0.03, "lost ->", fontsize=9)
ax.set_xscale("log")
ax.set_xlabel("final horizontal error (m)")
ax.set_ylabel("share of flights with a smaller error")
ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
ax.set_title("Final error over the same flights, per filter")
plt.show()

# %% [markdown]
# ## Confirmed on flights it had never seen
#
# A filter chosen as the best of many settings on the same $100$ flights looks better than it
# is: among a dozen settings, one is likely to be lucky on those flights. The choice was
# therefore put to a test decided before it ran, and committed with its criterion before its
# data existed (`tools/studies/terrain_confirmation.py`): the regularised filter with
# **stratified** resampling, the setting that lost the fewest of flights $0$ to $99$ in the report's
# studies of {doc}`terrain`, flies the fresh flights $100$ to $199$, used by no other study; it
# passes if it loses **fewer than $5$ of the $100$**. The regularised filter with multinomial
# resampling (the baseline above) and the bootstrap filter with $N = 30000$ fly the same
# flights, one after the other in a rotating order, so that losses and wall times are paired.

# %%
BOOT = "bootstrap N=30000"


def against_bootstrap(csv, candidate, prefix):
    """A fresh-flight study: the candidate's losses (Wilson), paired with the bootstrap filter's
    (exact McNemar) and its wall time per flight (paired ratio); glued under ``prefix``."""
    table = pd.read_csv(Path("../data") / csv)
    lost = table.pivot(index="flight", columns="setting", values="lost").astype(bool)
    secs = table.pivot(index="flight", columns="setting", values="seconds")
    loss = evidence.rate(lost[candidate])
    versus = evidence.paired_rates(lost[candidate], lost[BOOT])
    time = evidence.paired(secs[candidate], secs[BOOT], ratio=True)
    for name in lost.columns:
        print(f"{name:48s} lost {evidence.rate(lost[name])}")
    print(f"{candidate} vs {BOOT}: {versus}")
    print(f"wall time, {candidate} / {BOOT}, per flight: {time}")
    for key, value in (("lost", int(loss.successes)), ("lo", loss.low), ("hi", loss.high),
                       ("boot_lost", int(lost[BOOT].sum())), ("vs_boot_p", versus.pvalue),
                       ("time_ratio", time.median), ("time_lo", time.low), ("time_hi", time.high)):
        glue(f"{prefix}_{key}", value if isinstance(value, int) else float(value), display=False)
    return lost, loss


CAND = "regularised, stratified (candidate)"
MULT = "regularised, multinomial (chapter's baseline)"
lost_c, cand_rate = against_bootstrap("terrain_confirmation.csv", CAND, "terrain_fresh")
cand_vs_mult = evidence.paired_rates(lost_c[CAND], lost_c[MULT])
print(f"candidate vs multinomial: {cand_vs_mult}")
confirm_meta = json.loads(Path("../data/terrain_confirmation.json").read_text())
print(f"criterion, decided in advance: {confirm_meta['criterion']} -> "
      f"{'met' if cand_rate.successes < 5 else 'not met'} ({cand_rate.successes} lost)")
glue("terrain_fresh_flights", int(cand_rate.n), display=False)
glue("terrain_fresh_mult_lost", int(lost_c[MULT].sum()), display=False)
glue("terrain_fresh_vs_mult_p", float(cand_vs_mult.pvalue), display=False)

# %% [markdown]
# **The criterion is met**: the candidate loses {glue:text}`terrain_fresh_lost` of the
# {glue:text}`terrain_fresh_flights` fresh flights (95 % Wilson interval
# {glue:text}`terrain_fresh_lo:.0%` to {glue:text}`terrain_fresh_hi:.0%`), the regularised
# filter with multinomial resampling {glue:text}`terrain_fresh_mult_lost` (no difference the
# exact McNemar test can see, $p$ = {glue:text}`terrain_fresh_vs_mult_p:.2f`) and the bootstrap filter with
# $N = 30000$ {glue:text}`terrain_fresh_boot_lost` ($p$ = {glue:text}`terrain_fresh_vs_boot_p:.1e`).
# The interval still reaches above $5\,\%$: a hundred flights cannot prove a loss rate below it,
# only that this filter loses few.
#
# **At what cost?** The same number of likelihood evaluations as the bootstrap filter with
# $N = 30000$, but not the same time: the kernel move after each resampling (the cloud's
# covariance, its square root and $N$ Gaussian draws) makes a flight
# {glue:text}`terrain_fresh_time_ratio:.2f` times as long (median of the per-flight ratios,
# 95 % interval {glue:text}`terrain_fresh_time_lo:.2f` to {glue:text}`terrain_fresh_time_hi:.2f`).
# So a second test was decided in advance (`tools/studies/terrain_cost_matched.py`): the same
# filter with $N = 20000$, which takes the bootstrap filter's time, on yet other fresh flights
# ($200$ to $299$), with the same criterion.

# %%
lost_m, _ = against_bootstrap("terrain_cost_matched.csv", "regularised, stratified, N=20000", "terrain_cost")
# the two sets of fresh flights, seen by the same bootstrap filter (different flights: Fisher's exact test)
harder = stats.fisher_exact([[lost_m[BOOT].sum(), (~lost_m[BOOT]).sum()],
                             [lost_c[BOOT].sum(), (~lost_c[BOOT]).sum()]])
print(f"bootstrap N=30000 loses {lost_m[BOOT].sum()} of flights 200-299 and {lost_c[BOOT].sum()} of "
      f"flights 100-199: Fisher's exact p = {harder.pvalue:.3f}")
glue("terrain_sets_p", float(harder.pvalue), display=False)

# %% [markdown]
# **At the bootstrap filter's wall time the criterion is not met**: with $N = 20000$
# (median time ratio {glue:text}`terrain_cost_time_ratio:.2f`, interval
# {glue:text}`terrain_cost_time_lo:.2f` to {glue:text}`terrain_cost_time_hi:.2f`) the regularised
# filter loses {glue:text}`terrain_cost_lost` of $100$ flights ({glue:text}`terrain_cost_lo:.0%` to
# {glue:text}`terrain_cost_hi:.0%`). It still loses far fewer than the bootstrap filter on the
# same flights ({glue:text}`terrain_cost_boot_lost`, McNemar $p$ =
# {glue:text}`terrain_cost_vs_boot_p:.0e`), and these flights are harder than the previous
# hundred: the same bootstrap filter lost {glue:text}`terrain_fresh_boot_lost` of those
# (Fisher's exact test, $p$ = {glue:text}`terrain_sets_p:.3f`), so the two loss rates of the
# regularised filter do not measure the effect of $N$ alone. The verdict on the target this chapter set itself:
# **fewer than $5\,\%$ lost at the bootstrap filter's cost in likelihood evaluations, yes; at its
# wall time, not shown** (on this machine, whose timings are shared with other work).

# %% [markdown]
# ## The yardstick: the posterior Cramér-Rao bound
#
# How good is a converged filter? The posterior Cramér-Rao bound {cite:p}`tichavsky1998`
# bounds the mean squared error of any estimator; for terrain navigation
# {cite:p}`bergman1999` its information comes from the DEM's gradient along the flight,
# $H_k = [-\partial h/\partial x, -\partial h/\partial y, 1, 0]$ at the true position, through
# the recursion
#
# $$
# J_{k+1} = Q^{-1} + H_{k+1}^\top R^{-1} H_{k+1} - Q^{-1} F_k (J_k + F_k^\top Q^{-1} F_k)^{-1} F_k^\top Q^{-1},
# \qquad J_0 = P_0^{-1},
# $$
#
# with the filter's model ($Q = Q_f\,\Delta t$, $R = R_f$) and $F_k$ the Jacobian of the
# dynamics (`pfcourse.terrain.pcrb`; in the linear-Gaussian case it returns exactly the
# Kalman covariance, which the tests check). We compute it along each true flight (the
# bound given that flight's terrain). But the simulated aircraft has *no* process noise
# ($Q_f$ is the filter's allowance for model error), so the bound of the flights as they are
# simulated is the limit $Q \to 0$, $J_{k+1} = F_k^{-\top} J_k F_k^{-1} + H_{k+1}^\top R^{-1} H_{k+1}$,
# lower still. We compare each converged flight's final horizontal error with
# $\sqrt{B_{xx} + B_{yy}}$ at $80$ s of that bound.

# %%
X = np.array([simulate(scenario, terrain, data_rng(0, r)).truth for r in range(100)])
bounds = np.array([horizontal_bound(terrain_pcrb(scenario, terrain, x)) for x in X])
average = horizontal_bound(terrain_pcrb(scenario, terrain, X))
free = np.array([horizontal_bound(terrain_bound_noise_free(scenario, terrain, x)) for x in X])
conv = runs[best].index[runs[best] == False].to_numpy()  # noqa: E712 (NaN is neither)
ratio = final.loc[conv, best].to_numpy() / free[conv, -1]
ratio_model = final.loc[conv, best].to_numpy() / bounds[conv, -1]
glue("terrain_rmse_over_pcrb", float(np.median(ratio)), display=False)
glue("terrain_rmse_over_model_pcrb", float(np.median(ratio_model)), display=False)
glue("terrain_free_final_median", float(np.median(free[:, -1])), display=False)
glue("terrain_converged_n", int(len(conv)), display=False)
glue("terrain_pcrb_final_median", float(np.median(bounds[:, -1])), display=False)
glue("terrain_pcrb_average_final", float(average[-1]), display=False)
_, ratio_lo, ratio_hi = evidence.median_interval(ratio)
glue("terrain_ratio_lo", ratio_lo, display=False)
glue("terrain_ratio_hi", ratio_hi, display=False)
print(f"bound on the final horizontal RMS error: median over flights {np.median(bounds[:, -1]):.1f} m, "
      f"averaged-information bound {average[-1]:.1f} m")
print(f"noise-free bound (the flights as simulated): median final {np.median(free[:, -1]):.1f} m")
print(f"{best}: final error / noise-free bound over {len(conv)} converged flights: median {np.median(ratio):.2f} "
      f"(bootstrap 95 % CI {ratio_lo:.2f} to {ratio_hi:.2f}); / model bound: median {np.median(ratio_model):.2f}")

fig, ax = plt.subplots(figsize=(7, 3.5))
t = scenario.times
ax.fill_between(t, *np.quantile(bounds, [0.1, 0.9], axis=0), alpha=0.3, label="per-flight bound, 10-90 %")
ax.plot(t, np.median(bounds, axis=0), label="per-flight bound, median")
ax.plot(t, average, "--", label="bound with information averaged over flights")
ax.plot(t, np.median(free, axis=0), ":", label="noise-free bound (as simulated), median")
ax.set_yscale("log")
ax.set_xlabel("time t (s)")
ax.set_ylabel("horizontal RMS error bound (m)")
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# At the end of the flight the bound of the filter's model is typically
# {glue:text}`terrain_pcrb_final_median:.0f` m, and the noise-free bound
# {glue:text}`terrain_free_final_median:.1f` m. The {glue:text}`terrain_converged_n` converged
# flights of {glue:text}`terrain_best_name` end at a median
# {glue:text}`terrain_rmse_over_pcrb:.2f` times their flight's noise-free bound (bootstrap
# 95 % interval {glue:text}`terrain_ratio_lo:.2f` to {glue:text}`terrain_ratio_hi:.2f`): within
# a factor of two of the best any estimator can do on these flights. Against the bound of the
# filter's own model the median ratio is {glue:text}`terrain_rmse_over_model_pcrb:.2f`, below $1$:
# that "bound" assumes an aircraft that really has the process noise $Q_f$, and the simulated
# one has none, so it is not a bound for these flights; the noise-free one is.

# %% [markdown]
# ## A reference posterior for five flights
#
# The bound says how well any estimator could do on average; a reference posterior says what
# the exact filter would answer on a given flight. No grid can hold this posterior (four
# dimensions, kilometres wide at the start), so the reference is the bootstrap filter, which is
# consistent (no kernel, no tempering), run with so many particles that **doubling $N$ changes
# nothing**: `python3 tasks.py study terrain_reference` ran it with $N = 5 \times 10^5$ and $10^6$, two
# independent seeds each, on flights $0$ to $4$ (the first five, fixed in advance). Distances
# between posterior means are measured in units of the posterior's own spread,
# $\sigma = \sqrt{\operatorname{var} x + \operatorname{var} y}$ at the final step. The
# chapter's regularised filter ($N = 30000$) then flies the same five flights.

# %%
reference = pd.read_csv(Path("../data/terrain_reference.csv"))
big, half = reference["N"].max(), reference["N"].min()
rows = []
for flight, g in reference.groupby("flight"):
    g = g.set_index(["N", "seed"])
    sigma = float(np.mean(np.hypot(g.loc[big, "sd_x"], g.loc[big, "sd_y"])))
    m_big = g.loc[big, ["mean_x", "mean_y"]].to_numpy()  # two seeds
    m_half = g.loc[half, ["mean_x", "mean_y"]].to_numpy()
    ref_mean = m_big.mean(axis=0)
    sim = simulate(scenario, terrain, data_rng(0, flight))
    pf, _ = make_filter("regularised N=30000", scenario, terrain)
    estimate = pf.run(sim.measurements, rng=filter_rng(0, flight)).mean[-1, :2]
    rows.append({"flight": flight, "posterior sd (m)": sigma,
                 "seeds apart, N=5e5 (sd)": np.linalg.norm(m_half[0] - m_half[1]) / sigma,
                 "seeds apart, N=1e6 (sd)": np.linalg.norm(m_big[0] - m_big[1]) / sigma,
                 "N doubled, same seed (sd)": np.max(np.linalg.norm(m_big - m_half, axis=1)) / sigma,
                 "regularised N=30000 to reference (sd)": np.linalg.norm(estimate - ref_mean) / sigma,
                 "truth to reference (sd)": np.linalg.norm(sim.truth[-1, :2] - ref_mean) / sigma})
ref_table = pd.DataFrame(rows).set_index("flight")
print(ref_table.round(2).to_string())
glue("terrain_ref_doubling_max", float(ref_table["N doubled, same seed (sd)"].max()), display=False)
glue("terrain_ref_seeds_max", float(ref_table["seeds apart, N=1e6 (sd)"].max()), display=False)
glue("terrain_ref_half_seeds_max", float(ref_table["seeds apart, N=5e5 (sd)"].max()), display=False)
glue("terrain_ref_filter_median", float(ref_table["regularised N=30000 to reference (sd)"].median()), display=False)
glue("terrain_ref_filter_max", float(ref_table["regularised N=30000 to reference (sd)"].max()), display=False)
glue("terrain_ref_truth_median", float(ref_table["truth to reference (sd)"].median()), display=False)
glue("terrain_ref_flights", int(len(ref_table)), display=False)

# %% [markdown]
# **Is the reference settled?** With $10^6$ particles the two seeds' final means are at most
# {glue:text}`terrain_ref_seeds_max:.2f` posterior standard deviations apart on the
# {glue:text}`terrain_ref_flights` flights; with half as many they are up to
# {glue:text}`terrain_ref_half_seeds_max:.2f` apart, and doubling $N$ at a fixed seed moves the
# mean by at most {glue:text}`terrain_ref_doubling_max:.2f`: the halved runs still carry Monte
# Carlo error, the runs with $10^6$ particles agree to about a tenth of the posterior's
# spread, which is what the reference needs.
#
# **How far is the chapter's filter from it?** The regularised filter with $N = 30000$ ends a
# median {glue:text}`terrain_ref_filter_median:.2f` posterior standard deviations from the
# reference mean (at most {glue:text}`terrain_ref_filter_max:.2f`), and the truth a median
# {glue:text}`terrain_ref_truth_median:.2f` from it. The filter's own error (Monte Carlo and
# kernel) is therefore of the same order as the posterior's spread on these flights, not
# negligible beside it. Five flights are an illustration, not a study: the table gives them one
# by one.

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-terrain-bandwidth
# Compute the regularised filter's optimal bandwidth $h_\text{opt}$ for $N = 3000$ and
# $N = 30000$ particles in the aircraft's four-dimensional state, and the standard deviation
# of the kernel's move in $x$ when the cloud is a single blob of $50$ m, and when it is two
# equal blobs $4$ km apart. Which of the two situations does the formula assume?
# ```
#
# ```{solution} ex-terrain-bandwidth
# :class: dropdown
# $h_\text{opt} = (4/6)^{1/8} N^{-1/8}$: `optimal_bandwidth(3000, 4)` $\approx 0.35$ and
# `optimal_bandwidth(30000, 4)` $\approx 0.26$. The move's standard deviation in $x$ is
# $h\sqrt{S_{xx}}$: about $17$ m (or $13$ m) for the $50$ m blob, but for two blobs $4$ km apart
# $\sqrt{S_{xx}} \approx 2$ km and the move is about $700$ m ($500$ m), which throws the particles
# of each blob off its terrain match. The formula is optimal for a Gaussian density, the
# single blob; this is why the chapter's filter uses $0.2\,h_\text{opt}$.
# ```
