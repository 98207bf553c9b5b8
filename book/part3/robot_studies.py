# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Which settings matter? The robot filter under Monte Carlo
#
# The two lab reports on the robot (scenario C of the course) each turn the knobs of the
# particle filter one at a time: the process and measurement noise the filter assumes, the
# resampling threshold and scheme, a gap in the measurements, the measurement period, the
# number of landmarks. Each setting is judged from **one run**: one simulated path, one set
# of landmarks, one draw of the noises, one cloud of particles. Such a run can show a
# difference that is only luck, and hide one that is real. The reports also disagree: on
# the resampling threshold, one finds values near 1/3 best, another says that a threshold
# of 1 brings back degeneracy, a third says that thresholds above 0.5 stop the resampling.
#
# This chapter repeats every one of those experiments **100 times** per setting and looks
# at the distribution of the result. For each parameter it states the reports' claim, shows
# the median and the 10-90 % band of the error over the runs, and gives a verdict with the
# numbers. Where the linear model of Part I can answer the question against the exact
# (Kalman) posterior, it does so too.

# %%
from functools import partial

import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML
from matplotlib.animation import FuncAnimation
from myst_nb import glue

from pfcourse.filter import ParticleFilter
from pfcourse.landmarks.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.style import COLORS, plain_log_axis, use_style
from pfcourse.experiments.robot import pf_run
from pfcourse import evidence
from pfcourse.experiments.study import SerialExecutor, run_study, summarize
from pfcourse.figures.study import summary_band, time_band
from pfcourse.figures.widgets import control_panel

use_style()

# %% [markdown]
# ## How a study is run
#
# One *run* simulates the robot scenario of {doc}`../part2/robot` with a given seed (five
# landmarks placed at random, odometry and measurement noises) and filters it; its result
# is a handful of numbers. We use:
#
# - the **position RMSE** $\sqrt{\frac{1}{K - k_0} \sum_{k \ge k_0} \lVert \hat p_k - p_k \rVert^2}$
#   (m) after a transient of $k_0 = 20$ s;
# - the time-averaged **NEES** $\frac{1}{K - k_0}\sum_k e_k^\top P_k^{-1} e_k$, which is
#   about 3 for a filter whose covariance matches its errors (below 3: the filter is
#   pessimistic, above: over-confident) {cite:p}`barshalom2001`;
# - the filter's own position standard deviation $\sqrt{P_{xx} + P_{yy}}$, averaged over
#   time, and the **jitter** of the estimated path, the RMS of
#   $(\hat p_k - \hat p_{k-1}) - (p_k - p_{k-1})$ (m per step): how much the estimate
#   jumps around compared with the robot's real motion;
# - the mean effective sample size as a fraction of $N$ and the number of resamplings.
#
# `pfcourse.experiments.study.run_study` repeats a run over a grid of settings. Run $r$ uses the seed
# `replicate_seed(0, r)` **in every setting**, so all settings are compared on the same 100
# simulated worlds (*common random numbers*): a difference between two settings is then a
# difference of the filter, not of the data, and a paired comparison run by run is
# possible. Any row can be re-run alone with `pfcourse.experiments.robot.compare_filters`,
# which gives the same numbers.
#
# **Horizon.** The reports run 1000 s. The robot moves at 2.5 cm/s along a gentle curve,
# and the filter's error settles within about half a minute of the start (the gap study
# below plots it: the median error falls from about 0.35 m to below 0.2 m in the first
# 30 s and then stays level), so after the transient every second looks like every other.
# Runs of 100 s, scored after their first 20 s, measure that steady state at a tenth of the
# price of 1000 s; what remains of the transient after 20 s is the same for every setting. Studies that need longer runs (the
# measurement period, the gap) say so. Each run is one `pfcourse.experiments.robot.pf_run`:
# the robot simulator and the same `ParticleFilter` as in the other chapters. The nine
# studies below (100 runs per setting) are too heavy to re-run every time this page executes,
# so `tools/studies/robot_studies.py` ran them once with `run_study`, on
# every core (next section), and stored the tables in `book/data/robot_studies/` with their
# provenance; this page reads them (`robot_study` below refuses a grid that was not stored),
# and `tests/test_robot_studies_data.py` re-runs a seeded sample of rows and requires the
# same numbers.
#
# Unless a section varies it, every run uses the reports' defaults: $N = 300$,
# $Q_\text{est} = 2 Q_\text{true}$, $R_\text{est} = 2 R_\text{true}$, resampling
# (systematic) when $\text{ESS} < 0.5 N$, a measurement every second, five landmarks, and an
# initial cloud around the true start. Because of the common random numbers, this default
# setting gives exactly the same numbers in every study where it appears.
#
# ## Studies on every core, or on a cluster
#
# The runs of a study are independent, so `run_study` hands them, ten runs of one setting
# at a time, to a `concurrent.futures.Executor`, and puts the rows back in grid order as
# they come. By default the executor is a process pool with one worker per core. Any other
# executor with the same interface works unchanged, because a row depends only on its
# setting and its seed: `executor=SerialExecutor()` runs everything in this process, and
# a `dask.distributed` cluster spreads the runs over several machines:
#
# ```python
# from dask.distributed import Client
# client = Client("scheduler-address:8786")   # or Client(LocalCluster(n_workers=4))
# table = run_study(partial(pf_run, n_steps=100), {"n_particles": [100, 300]}, 100,
#                   executor=client.get_executor())
# ```
#
# The cell below runs one small study twice, in this process and on the process pool, and
# compares the two tables (every column but the wall time `seconds`).

# %%
from pfcourse.experiments import robot_studies as stored
from pfcourse.experiments.robot_studies import BURN_IN, N_RUNS, N_STEPS


def robot_study(grid, **fixed):
    """pf_run over `grid` (N_RUNS seeded runs per setting, n_steps=N_STEPS, burn_in=BURN_IN):
    the table stored by tools/studies/robot_studies.py, which ran exactly
    run_study(partial(pf_run, n_steps=N_STEPS, burn_in=BURN_IN, **fixed), grid, N_RUNS)."""
    return stored.find(grid, **fixed)


small = partial(pf_run, n_steps=30)
serial = run_study(small, {"n_particles": [50, 200]}, 20, progress=False, executor=SerialExecutor())
pooled = run_study(small, {"n_particles": [50, 200]}, 20, progress=False)
same_tables = serial.drop(columns="seconds").equals(pooled.drop(columns="seconds"))
glue("executor_same_rows", "identical" if same_tables else "different", display=False)
glue("executor_rows", len(serial), display=False)
print(f"{len(serial)} rows; serial and process-pool tables {'identical' if same_tables else 'DIFFER'}")

# %% [markdown]
# The two tables of {glue:text}`executor_rows` rows are {glue:text}`executor_same_rows`.

# %%
def show(table, by, metrics, digits=3):
    """Print median [10 %, 90 %] of each metric per setting, and the number of failed runs."""
    parts = []
    for name, label in metrics.items():
        s = summarize(table, by, name)
        parts.append(s.apply(lambda r: f"{r.q50:.{digits}f} [{r.q10:.{digits}f}, {r.q90:.{digits}f}]", axis=1)
                     .rename(label))
    out = pd.concat(parts, axis=1)
    out["failed"] = summarize(table, by, name)["n_failed"]
    print(out.to_string())


def median(table, by, metric):
    """Median of a metric per setting (a Series indexed by the setting)."""
    return summarize(table, by, metric)["q50"]


def paired_vs(table, by, reference, metric="position_rmse"):
    """Each setting against ``reference`` on the same seeds: median ratio of ``metric``, its 95 % interval, Wilcoxon p.

    Returns ``{setting: pfcourse.evidence.Paired}``; runs that failed in either setting are left out.
    """
    ref = table[table[by] == reference].set_index("seed")[metric]
    out, rows = {}, []
    for value, g in table.groupby(by, sort=False):
        if value == reference:
            continue
        x = g.set_index("seed")[metric]
        common = x.index.intersection(ref.index)
        ok = np.isfinite(x[common].to_numpy()) & np.isfinite(ref[common].to_numpy())
        cmp = evidence.paired(x[common].to_numpy()[ok], ref[common].to_numpy()[ok], ratio=True)
        out[value] = cmp
        rows.append({by: value, f"{metric} ratio to {by} = {reference:g}": cmp.median, "95% CI low": cmp.low,
                     "95% CI high": cmp.high, "Wilcoxon p": cmp.pvalue, "paired runs": cmp.n,
                     "verdict": cmp.verdict().replace("A ", "")})
    print(pd.DataFrame(rows).set_index(by).to_string(float_format=lambda v: f"{v:.3g}"))
    return out


# %% [markdown]
# ## Number of particles
#
# **Claim.** The robot reports keep $N = 300$ throughout; the terrain report (001) finds
# that 300 particles give a biased estimate and 30 000 a good one, from one run each (the
# terrain chapter, {doc}`../part2/terrain`, studies that scenario with statistics). The
# course's question is the general one: how many particles does this robot need?

# %%
n_table = robot_study({"n_particles": [20, 50, 100, 300, 1000]})
show(n_table, "n_particles", {"position_rmse": "position RMSE (m)", "mean_nees": "mean NEES",
                              "mean_position_sd": "filter's sd (m)"})

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
summary_band(summarize(n_table, "n_particles", "position_rmse"), axes[0], color=COLORS["estimate"])
summary_band(summarize(n_table, "n_particles", "mean_nees"), axes[1], color=COLORS["estimate"])
axes[1].axhline(3, color="k", ls="--", lw=1, label="3: consistent")
for ax in axes:
    ax.set_xscale("log")
    ax.set_xlabel("number of particles N")
axes[0].set_ylabel("position RMSE (m)")
axes[1].set_yscale("log")
axes[1].set_ylabel("time-averaged NEES")
axes[1].legend()
fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs per N", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# **Verdict.** The error falls steeply up to about 100 particles and slowly after that: the
# median RMSE goes from 0.44 m with 20 particles to 0.23 m with 100, 0.18 m with 300 and
# 0.17 m with 1000 (printed above); 1000 particles buy little over 300. The error does not tend to zero: it
# tends to the error of the exact posterior mean, which no number of particles can beat.
# The NEES shows what the RMSE hides. With 20 or 50 particles the filter is badly
# over-confident (median NEES 71 and 7.7, against 3 for a consistent filter): its cloud is
# narrower than its errors (its own standard deviation *shrinks* as $N$ falls, while the
# error grows). A small cloud does not know what it does not know. From 300 particles on,
# the NEES is below 3, which is what a filter that assumes twice the true noise variances
# should show. So 300 is a sound choice for this robot; below 100 the error bars lie.

# %% [markdown]
# ## Process noise assumed by the filter ($Q_\text{est}$)
#
# **Claims.** Report 002: a larger $Q_\text{est}$ means the filter trusts the odometry less,
# which gives a jerkier estimated path, a larger and more variable covariance and a wider
# cloud. Report 004: results degrade when the factor is below about 1 or above about 5;
# too small a factor makes the filter over-confident, too large a one makes it unstable.
#
# We scale $Q_\text{est} = s \, Q_\text{true}$ for $s$ from 0.25 to 100 (the default is 2).
# This study keeps the per-step errors, for the animation further down.

# %%
q_values = [0.25, 0.5, 1, 2, 5, 20, 100]
q_table = robot_study({"q_scale": q_values}, keep_errors=True)
show(q_table, "q_scale", {"position_rmse": "position RMSE (m)", "mean_nees": "mean NEES",
                          "mean_position_sd": "filter's sd (m)", "estimate_jitter": "jitter (m/step)"})
q_vs = paired_vs(q_table, "q_scale", 2)
for q in (0.25, 0.5, 20, 100):
    glue(f"q_ratio_{q:g}", q_vs[q].median, display=False)
    glue(f"q_ratio_{q:g}_low", q_vs[q].low, display=False)
    glue(f"q_ratio_{q:g}_high", q_vs[q].high, display=False)
# the prose says no scale is measurably better than the default: the page fails if that changes
assert all(c.verdict() != "A lower" for c in q_vs.values())

# %%
def noise_scale_figure(table, key, name):
    fig, axes = plt.subplots(1, 3, figsize=(10, 3.5))
    summary_band(summarize(table, key, "position_rmse"), axes[0], color=COLORS["estimate"], label="error (RMSE)")
    summary_band(summarize(table, key, "mean_position_sd"), axes[0], color=COLORS["kalman"], label="filter's own sd")
    summary_band(summarize(table, key, "mean_nees"), axes[1], color=COLORS["estimate"])
    axes[1].axhline(3, color="k", ls="--", lw=1, label="3: consistent")
    summary_band(summarize(table, key, "estimate_jitter"), axes[2], color=COLORS["estimate"])
    axes[0].set_ylabel("position (m)")
    axes[1].set_ylabel("time-averaged NEES")
    axes[1].set_yscale("log")
    axes[2].set_ylabel("jitter of the estimate (m per step)")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel(f"{name} (multiple of the true covariance)")
        ax.axvline(2, color="0.6", lw=1, ls=":")
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs per setting (dotted: the default, 2)", fontsize=10)
    plt.tight_layout()
    plt.show()


noise_scale_figure(q_table, "q_scale", "$Q_{est}$ scale")

# %% [markdown]
# **Verdict.** Report 002's description holds, and the numbers size it: from the default
# (2) to 100 times $Q_\text{true}$ the jitter of the estimated path grows from 0.044 to
# 0.195 m per step and the filter's own standard deviation from 0.23 to 0.63 m. Report 004's
# bracket is roughly right on the high side and misleading on the low side. The median RMSE
# stays between 0.18 and 0.20 m from a factor 0.5 to 5 and rises beyond (0.24 m at 20,
# 0.37 m at 100). Paired run by run with the default, the RMSE is {glue:text}`q_ratio_0.5:.2f`
# times the default's at 0.5 (95 % interval {glue:text}`q_ratio_0.5_low:.2f`-{glue:text}`q_ratio_0.5_high:.2f`),
# {glue:text}`q_ratio_0.25:.2f` times at 0.25 ({glue:text}`q_ratio_0.25_low:.2f`-{glue:text}`q_ratio_0.25_high:.2f`),
# {glue:text}`q_ratio_20:.2f` at 20 and {glue:text}`q_ratio_100:.2f` at 100; no scale is measurably
# better than 2 (table above). Below 1 the filter also becomes over-confident: its median NEES is 5 at 0.5 and 15 at 0.25 (90 % quantile 56),
# against 3 for a consistent filter. That is report 004's "over-fitting", made measurable.
# Large factors keep the filter honest (NEES near 1, a pessimistic filter) but waste the
# odometry's information. The default, 2, sits at the bottom of the RMSE curve.

# %% [markdown]
# ### Scrub it: the error over time for each $Q_\text{est}$
#
# The animation below needs no Python kernel. Each frame is one value of the scale: the
# median and 10-90 % band over the 100 runs of the position error at each second (red),
# and of the filter's own standard deviation $\sqrt{P_{xx} + P_{yy}}$ (green). Where the
# green band lies below the red one, the filter claims more precision than it has.

# %%
t = np.arange(N_STEPS)
fig, ax = plt.subplots(figsize=(5.5, 4.0), dpi=72)


def q_frame(i):
    ax.clear()
    rows = q_table[(q_table["q_scale"] == q_values[i]) & (q_table["status"] == "ok")]
    time_band(t, np.stack(rows["position_error"].to_numpy()), ax, color=COLORS["estimate"], label="error")
    time_band(t, np.stack(rows["position_sd"].to_numpy()), ax, color=COLORS["kalman"], label="filter's sd")
    ax.set_ylim(0, 1.4)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position (m)")
    ax.set_title(f"QEst = {q_values[i]} QTrue ({len(rows)} runs)", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)


anim = FuncAnimation(fig, q_frame, frames=len(q_values), interval=900)
plt.close(fig)
HTML(anim.to_jshtml())

# %% [markdown]
# ## Measurement noise assumed by the filter ($R_\text{est}$)
#
# **Claims.** Report 002: a larger $R_\text{est}$ makes the filter trust the landmarks less,
# so the estimated path is smoother, the covariance larger, and in the limit the weights
# stay uniform and the filter cannot locate the robot. Report 004: results degrade below a
# factor of about 1 (not enough diversity among the particles) and above about 5 (the filter
# is slow to correct and follows the odometry).

# %%
r_table = robot_study({"r_scale": [0.25, 0.5, 1, 2, 5, 20, 100]})
show(r_table, "r_scale", {"position_rmse": "position RMSE (m)", "mean_nees": "mean NEES",
                          "mean_position_sd": "filter's sd (m)", "estimate_jitter": "jitter (m/step)",
                          "mean_ess_fraction": "mean ESS / N"})
r_vs = paired_vs(r_table, "r_scale", 2)
glue("r_ratio_min", min(c.median for c in r_vs.values()), display=False)
glue("r_ratio_max", max(c.median for c in r_vs.values()), display=False)
glue("r_ratio_100", r_vs[100].median, display=False)
glue("r_ratio_100_low", r_vs[100].low, display=False)
glue("r_ratio_100_high", r_vs[100].high, display=False)
glue("r_ratio_100_p", r_vs[100].pvalue, display=False)

# %%
noise_scale_figure(r_table, "r_scale", "$R_{est}$ scale")

# %% [markdown]
# **Verdict.** The direction of report 002's claims holds: with a larger $R_\text{est}$ the
# path is smoother (jitter from 0.064 m per step at 0.25 down to 0.032 at 100), the
# covariance wider (filter's standard deviation from 0.11 m to 0.92 m) and the weights more
# even (mean ESS from 23 % to 73 % of $N$). But the filter does **not** lose the robot: the
# median RMSE stays between 0.18 and 0.21 m over the whole range, from a quarter to 100
# times the true variance (printed above). Paired with the reports' setting ($R_\text{est}$
# scale 2) on the same runs, the median RMSE ratios run from {glue:text}`r_ratio_min:.2f` to
# {glue:text}`r_ratio_max:.2f`; even at 100 times the true variance the ratio is
# {glue:text}`r_ratio_100:.2f` (95 % interval
# {glue:text}`r_ratio_100_low:.2f`-{glue:text}`r_ratio_100_high:.2f`, Wilcoxon p =
# {glue:text}`r_ratio_100_p:.2g`): no difference is detected from a scale of 1 upwards, and the
# intervals of the paired table bound it to about a tenth of the error either way. Only the
# scales below the truth (0.25 and 0.5) are measurably worse. The landmarks are observed every second, and even
# a filter that believes the range error is 10 times larger than it is averages many of them.
# Report 004's bracket (degradation below 1 and above 5) is right about the filter's
# *honesty*, not about its accuracy: below 1 the filter is over-confident (median NEES 6.5
# at 0.5, 16 at 0.25), above 5 it is more and more pessimistic (NEES 0.34 at 100, its
# standard deviation five times its error). Accuracy is not the only thing that a wrong
# noise model spoils: the covariance that comes with the estimate is wrong too.

# %% [markdown]
# ## Resampling threshold, from 0 to 1
#
# **Claims, and a contradiction.** The filter resamples when $\text{ESS} < \theta N$.
# Report 002 finds that a small threshold leaves the weights degenerate, a large one
# resamples constantly, which it calls counter-productive, and that only values near 1/3
# work well. Report 001 (terrain) finds 0 degenerate, 0.5 good, and 1 degenerate again.
# Report 004 says that above 0.5 resampling no longer happens, so the degeneracy stays.
# The last claim reverses the rule: a larger $\theta$ resamples *more* often, and
# $\theta = 1$ resamples at every step whose weights are not exactly equal.

# %%
thresholds = [0.0, 0.1, 0.2, 1 / 3, 0.5, 0.7, 1.0]
th_table = robot_study({"threshold": thresholds})
th_table["threshold"] = th_table["threshold"].round(3)
show(th_table, "threshold", {"position_rmse": "position RMSE (m)", "mean_ess_fraction": "mean ESS / N",
                             "resamples": "resamplings"})
# How many SIS runs are sure of a wrong answer: a time-averaged NEES above a million (the ideal
# is 3). Not "all the weight on one particle to working precision", a count that a last-bit
# change of the arithmetic moves by a few runs (tasks.py knife-edge); the smallest SIS NEES is
# many orders of magnitude above this line, so the count is not on a knife-edge.
sis = th_table[th_table["threshold"] == 0.0]
sis_overconfident = int((sis["mean_nees"] > 1e6).sum())
sis_collapsed_majority = bool(np.isinf(sis["mean_nees"]).sum() > len(sis) / 2)
glue("sis_robot_overconfident_runs", sis_overconfident, display=False)
glue("sis_robot_runs", len(sis), display=False)
th_vs = paired_vs(th_table, "threshold", 0.333)
glue("th1_vs_third", th_vs[1.0].median, display=False)
glue("th1_vs_third_low", th_vs[1.0].low, display=False)
glue("th1_vs_third_high", th_vs[1.0].high, display=False)
glue("th1_vs_third_p", th_vs[1.0].pvalue, display=False)
glue("th_half_vs_third", th_vs[0.5].median, display=False)
glue("th_half_vs_third_low", th_vs[0.5].low, display=False)
glue("th_half_vs_third_high", th_vs[0.5].high, display=False)
print(f"threshold 0: time-averaged NEES above 1e6 in {sis_overconfident} of {len(sis)} runs; all the weight on "
      f"one particle (to working precision) at some step in {'most' if sis_collapsed_majority else 'few'} of them")

# %%
fig, axes = plt.subplots(1, 3, figsize=(10, 3.5))
summary_band(summarize(th_table, "threshold", "position_rmse"), axes[0], color=COLORS["estimate"])
summary_band(summarize(th_table[th_table["threshold"] > 0], "threshold", "mean_nees"), axes[1],
             color=COLORS["estimate"])
summary_band(summarize(th_table, "threshold", "resamples"), axes[2], color=COLORS["estimate"])
axes[0].set_ylabel("position RMSE (m)")
axes[1].set_ylabel("time-averaged NEES (θ > 0)")
axes[1].axhline(3, color="k", ls="--", lw=1)
axes[2].set_ylabel(f"resamplings in {N_STEPS - 1} measurement steps")
for ax in axes:
    ax.set_xlabel("threshold θ (resample when ESS < θN)")
fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs per threshold", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# On the robot, any threshold that resamples at all does the job: the median RMSE is
# 0.18-0.20 m from $\theta = 0.2$ to 1 and 0.21 m at 0.1, while $\theta = 0$ (no resampling,
# SIS) is 3.7 times worse (0.68 m), with a mean ESS below 1 % of $N$ and, in
# {glue:text}`sis_robot_overconfident_runs` of {glue:text}`sis_robot_runs` runs, a
# time-averaged NEES above a million: the filter is sure of a position it is far from, and in
# most runs all the weight sits (to working precision) on a single particle at some step. This
# is the degeneracy all reports describe. The number of resamplings grows with $\theta$, up to one at every
# measurement step at $\theta = 1$ (99 of 99), which contradicts report 004 directly. And a
# threshold of 1 is not degenerate: its mean ESS is the largest of all (64 % of $N$,
# measured before each resampling), and its RMSE (0.179 m) is the smallest, by a margin
# well inside the spread of the runs. Run by run (table above the figure, the same seeds for
# every threshold), the RMSE at $\theta = 1$ is {glue:text}`th1_vs_third:.3f` times that at
# $\theta = 1/3$ (95 % interval {glue:text}`th1_vs_third_low:.3f`-{glue:text}`th1_vs_third_high:.3f`,
# Wilcoxon p = {glue:text}`th1_vs_third_p:.2g`), and at $\theta = 0.5$
# {glue:text}`th_half_vs_third:.3f` times ({glue:text}`th_half_vs_third_low:.3f`-{glue:text}`th_half_vs_third_high:.3f`):
# report 002's "only values near 1/3 work well" is not supported: resampling at every step is,
# if anything, slightly more accurate here, by a few percent of the error.
#
# The robot's error is dominated by the posterior's own spread, so small differences of
# Monte Carlo error drown in it. The linear landmark model of Part I has an exact answer,
# the Kalman filter, so there we can measure the particle filter's own error: the distance
# between its posterior mean and the exact one. Report 000's set-up: two landmarks, 50 steps,
# $N = 100$ particles, 100 runs per threshold.

# %%
LINEAR = quadrant_scenario()
LINEAR_MODEL = LINEAR.model()
exact = {}  # Kalman filter of each seed, computed once per execution and shared by the settings


def distance_to_exact(seed, threshold):
    sim = simulate(LINEAR, seed)
    if seed not in exact:
        exact[seed] = kalman_filter(LINEAR_MODEL, sim.Z).mean
    pf = ParticleFilter(LINEAR_MODEL, 100, threshold=threshold).run(sim.Z, rng=seed)
    gap = pf.mean - exact[seed]
    return {
        "robot_gap": float(np.sqrt(np.mean(np.sum(gap[:, :2] ** 2, axis=1)))),
        "landmark_gap": float(np.sqrt(np.mean(np.sum(gap[:, 2:] ** 2, axis=1) / 2))),
        "resamples": pf.n_resamples,
    }


lin_table = run_study(distance_to_exact, {"threshold": [0.0, 0.1, 1 / 3, 1.0]}, N_RUNS, progress=False)
lin_table["threshold"] = lin_table["threshold"].round(3)
show(lin_table, "threshold", {"robot_gap": "robot: PF mean - exact (m)",
                              "landmark_gap": "landmark: PF mean - exact (m)", "resamples": "resamplings"})

# %%
fig, ax = plt.subplots(figsize=(6, 3.6))
summary_band(summarize(lin_table, "threshold", "robot_gap"), ax, color=COLORS["estimate"], label="robot position")
summary_band(summarize(lin_table, "threshold", "landmark_gap"), ax, color=COLORS["particles"], label="landmark position")
ax.set_xlabel("resampling threshold θ")
ax.set_ylabel("RMS distance to the exact mean (m)")
ax.set_title(f"Linear model, N = 100: median and 10-90 % band over {N_RUNS} runs", fontsize=10)
ax.legend()
plt.show()

# %% [markdown]
# **Verdict.** Against the exact posterior the picture is the same: without resampling the
# robot estimate is 0.36 m (median) from the exact mean, four times further than with any
# threshold from 0.1 to 1 (0.09 m for all of them, printed above). Report 002's "near 1/3 is
# best" and report 001's "1 is degenerate" are not supported; report 004's "above 0.5 there
# is no resampling" is false by construction. What is true in the reports is the mechanism
# they point at: resampling at every step adds some Monte Carlo noise (a resampled cloud
# carries duplicates), which is why the usual advice is an intermediate threshold such as
# 0.5 {cite:p}`doucet2011`. On these two models that noise is too small to be seen next to
# the spread of the runs.
#
# The landmark columns tell another story. Whatever the threshold, the landmark estimate
# stays about 0.12 m from the exact mean, more than the robot's: the landmarks have
# (almost) no process noise, so once resampling has duplicated particles their landmark
# coordinates never diversify again. No threshold cures that; report 000's fix (a small
# process noise on the landmarks) or a better proposal does (exercise
# {ref}`ex-studies-linear-n`).

# %% [markdown]
# ## Resampling scheme
#
# **Claim.** Report 004 switches from low-variance (systematic) resampling to multinomial
# resampling and finds the filter slightly better: a more regular weight histogram and
# smaller $x$ and $y$ errors. Theory says the opposite direction, if anything: residual and
# stratified resampling never add more variance than multinomial resampling
# {cite:p}`douc2005`, and systematic resampling is usually the best in practice
# {cite:p}`hol2006`. With common random numbers we can compare the schemes run by run.

# %%
scheme_table = robot_study({"scheme": ["multinomial", "residual", "stratified", "systematic"]})
show(scheme_table, "scheme", {"position_rmse": "position RMSE (m)", "mean_nees": "mean NEES",
                              "mean_ess_fraction": "mean ESS / N"})
paired = scheme_table.pivot(index="run", columns="scheme", values="position_rmse")
diff = paired["multinomial"] - paired["systematic"]
print(f"\nmultinomial minus systematic, paired over the {N_RUNS} runs: median {diff.median():+.4f} m, "
      f"mean {diff.mean():+.4f} m (standard error {diff.std() / np.sqrt(len(diff)):.4f} m); "
      f"multinomial better in {int((diff < 0).sum())} of {len(diff)} runs")

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
summary_band(summarize(scheme_table, "scheme", "position_rmse"), axes[0], color=COLORS["estimate"], categorical=True)
axes[0].set_ylabel("position RMSE (m)")
axes[1].hist(diff, bins=25, color=COLORS["estimate"], alpha=0.7)
axes[1].axvline(0, color="k", lw=1)
axes[1].set_xlabel("RMSE multinomial - RMSE systematic, same run (m)")
axes[1].set_ylabel("number of runs")
axes[0].set_title(f"Median and 10-90 % over {N_RUNS} runs", fontsize=10)
axes[1].set_title("Paired differences", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# **Verdict.** The four schemes are indistinguishable in accuracy: median RMSE 0.18-0.19 m
# with the same spread (left). Run by run (right), multinomial resampling is better than
# systematic in 48 runs of 100 and worse in the others, and the mean difference (+0.009 m,
# standard error 0.007 m) is not distinguishable from zero; if anything it goes against
# multinomial resampling, whose filter is also a little more over-confident (median NEES
# 2.4 against 1.9). Report 004's improvement came from one run. The reasons to prefer
# systematic resampling remain its lower variance in theory and its cost: one uniform draw
# instead of $N$.

# %% [markdown]
# ## A gap in the measurements
#
# **Claims.** Report 002 removes the measurements between 250 s and 350 s: the filter
# then follows the odometry alone, drifts, its uncertainty grows, and when measurements
# come back it corrects almost at once, with no lasting effect. Report 004 (with the same
# gap) sees little change: some more error and covariance, mostly in the heading, and a
# fast recovery.
#
# A gap of the same 100 s length from 100 s to 200 s, in runs of 260 s, measures the same
# thing: the filter has long reached its steady state at 100 s, and the 60 s after the gap
# show the recovery. We keep the per-step errors and compare with the same runs without a
# gap.

# %%
GAP = (100.0, 200.0)
gap_table = robot_study({"gap": [None, GAP]}, n_steps=260, keep_errors=True)
t_gap = np.arange(260)


def errors(table, gap, name):
    rows = table[(table["gap"].apply(lambda g: g == gap)) & (table["status"] == "ok")]
    return np.stack(rows[name].to_numpy())


fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
for gap, color, label in ((None, COLORS["kalman"], "no gap"), (GAP, COLORS["estimate"], "gap 100-200 s")):
    time_band(t_gap, errors(gap_table, gap, "position_error"), axes[0], color=color, label=label)
    time_band(t_gap, np.degrees(errors(gap_table, gap, "heading_error")), axes[1], color=color, label=label)
for ax in axes:
    ax.axvspan(*GAP, color="0.9", zorder=0)
    ax.set_xlabel("time (s)")
    ax.legend(loc="upper left")
axes[0].set_ylabel("position error (m)")
axes[1].set_ylabel("heading error (deg)")
fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs (grey: no measurements)", fontsize=10)
plt.tight_layout()
plt.show()

with_gap = errors(gap_table, GAP, "position_error")
without = errors(gap_table, None, "position_error")
sd_gap = errors(gap_table, GAP, "position_sd")
end = int(GAP[1]) - 1
print(f"position error at t = {end} s (last step of the gap): median {np.median(with_gap[:, end]):.2f} m "
      f"[90 %: {np.quantile(with_gap[:, end], 0.9):.2f}], without gap {np.median(without[:, end]):.2f} m")
print(f"filter's own sd at that step: median {np.median(sd_gap[:, end]):.2f} m")
head_gap = np.degrees(errors(gap_table, GAP, "heading_error"))
head_no = np.degrees(errors(gap_table, None, "heading_error"))
print(f"heading error at t = {end} s: median {np.median(head_gap[:, end]):.1f} deg, "
      f"without gap {np.median(head_no[:, end]):.1f} deg")
for after in (1, 5, 20, 59):
    k = end + after
    print(f"{after:2d} s after the gap: position error median {np.median(with_gap[:, k]):.2f} m "
          f"(without gap {np.median(without[:, k]):.2f} m), 90 % quantile {np.quantile(with_gap[:, k], 0.9):.2f} m")

# %% [markdown]
# **Verdict.** Both reports are right about the shape, and the statistics give the sizes.
# At the end of the 100 s without measurements the median position error is 0.37 m against
# 0.15 m in the same runs without a gap, and the heading error 6.6° against 0.5° (90 %
# quantile up to 17°): the heading, which only the landmarks correct, is what drifts most
# (report 004 saw it in the covariance). The filter knows it: its own position standard
# deviation has grown to 0.58 m. After the gap the two errors recover at different speeds.
# The heading is back to normal at the first measurement: one bearing fixes it, given a
# position known to a few decimetres. The position takes longer: one second after the gap
# its median error is still 0.32 m, after 5 s 0.25 m, after 20 s 0.18 m, and after a minute
# it is back to the no-gap level (0.15 m against 0.13 m); each range measurement only
# corrects the position along one direction. So "no lasting effect" (both reports) holds;
# "corrected almost at once" (report 002) holds for the heading, not for the position, whose
# error takes tens of seconds to return to normal.

# %% [markdown]
# ## The measurement period
#
# **Claims.** Report 002: the shorter the interval `dt_meas` between measurements, the
# closer the estimate follows the truth and the smaller its uncertainty; between
# measurements the covariance grows and drops at each measurement, a small periodic
# version of the gap. Report 004 tries `dt_meas = 0.1` s with predictions every second and
# finds that the filter diverges, "because the measurement rate is higher than the
# prediction rate".
#
# Our simulator takes at most one measurement per prediction step. With a period of 20 s,
# 100 s would hold only four measurements after the transient, so these runs last 200 s.

# %%
dt_table = robot_study({"dt_meas": [1.0, 2.0, 5.0, 10.0, 20.0]}, n_steps=200)
show(dt_table, "dt_meas", {"position_rmse": "position RMSE (m)", "heading_rmse": "heading RMSE (rad)",
                           "mean_nees": "mean NEES", "mean_position_sd": "filter's sd (m)"})

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
summary_band(summarize(dt_table, "dt_meas", "position_rmse"), axes[0], color=COLORS["estimate"], label="error (RMSE)")
summary_band(summarize(dt_table, "dt_meas", "mean_position_sd"), axes[0], color=COLORS["kalman"], label="filter's own sd")
dt_table["heading_rmse_deg"] = np.degrees(dt_table["heading_rmse"])
summary_band(summarize(dt_table, "dt_meas", "heading_rmse_deg"), axes[1], color=COLORS["estimate"])
axes[0].set_ylabel("position (m)")
axes[0].legend()
axes[1].set_ylabel("heading RMSE (deg)")
for ax in axes:
    ax.set_xscale("log")
    ax.set_xlabel("time between measurements dt_meas (s)")
fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs of 200 s", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# **Verdict on report 002.** Confirmed and sized: the median position RMSE grows from
# 0.18 m with a measurement every second to 0.22 m every 2 s, 0.30 m every 5 s and 0.40 m
# every 20 s, and the heading RMSE from 0.8° to 3.2°; the filter's own standard deviation
# grows with them (0.23 m to 0.75 m) and the filter stays consistent (NEES below 3).
#
# **Verdict on report 004.** Its explanation is not the cause. A filter can absorb several
# measurements between two predictions (it updates the weights with each). What happens in
# the reports' code is simpler: a measurement is taken when `k * dt_pred % dt_meas == 0`,
# and with `dt_meas = 0.1` this floating-point test never holds:

# %%
ks = np.arange(1, 1001)
hits = int(np.sum(ks * 1.0 % 0.1 == 0))
print(f"steps k in 1..1000 with k * 1.0 % 0.1 == 0: {hits}")
print(f"for example 1.0 % 0.1 = {1.0 % 0.1!r} and 3.0 % 0.1 = {3.0 % 0.1!r}")

# %% [markdown]
# So with `dt_meas = 0.1` the simulated robot is never measured, and the filter
# follows the drifting odometry: it looks like divergence, and it is a measurement gap as
# long as the run. The lesson is one for all code that tests times: compare integer step
# counts, not remainders of floats.

# %% [markdown]
# ## The number of landmarks
#
# **Claims.** Report 002: going from 2 to 3 landmarks cuts the position and heading errors
# sharply; beyond 3 the covariance trend stays about the same. Report 004: the number of
# landmarks changes little.
#
# One landmark is observed per measurement step, drawn at random, so more landmarks do not
# mean more measurements; they mean more *directions* to measure from.

# %%
lm_table = robot_study({"n_landmarks": [1, 2, 3, 5, 10, 30]})
show(lm_table, "n_landmarks", {"position_rmse": "position RMSE (m)", "heading_rmse": "heading RMSE (rad)",
                               "mean_nees": "mean NEES"})

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
summary_band(summarize(lm_table, "n_landmarks", "position_rmse"), axes[0], color=COLORS["estimate"])
lm_table["heading_rmse_deg"] = np.degrees(lm_table["heading_rmse"])
summary_band(summarize(lm_table, "n_landmarks", "heading_rmse_deg"), axes[1], color=COLORS["estimate"])
axes[0].set_ylabel("position RMSE (m)")
axes[1].set_ylabel("heading RMSE (deg)")
for ax in axes:
    ax.set_xscale("log")
    ax.set_ylim(0, None)
    ax.set_xlabel("number of landmarks")
fig.suptitle(f"Median and 10-90 % band over {N_RUNS} runs per number", fontsize=10)
plt.tight_layout()
plt.show()

# %% [markdown]
# **Verdict.** The big step is from one landmark to two: the median RMSE falls from 0.40 m
# to 0.22 m (and its 90 % quantile from 1.00 m to 0.38 m). From 2 to 3 it still falls, to
# 0.18 m, and beyond 3 the median stays at 0.18-0.19 m (printed above): report 004's "little
# influence" holds from three landmarks on. What more landmarks still buy is fewer bad runs:
# the 90 % quantile keeps shrinking, from 0.34 m with 3 landmarks to 0.24 m with 30, since a
# bad layout (all landmarks on one side) becomes unlikely.
#
# Report 002 places the big step between 2 and 3 landmarks. Its code draws the landmark to
# observe with `np.random.randint(0, nLandmarks - 1)`, whose upper bound is *excluded*: the
# last landmark is never observed.

# %%
legacy = np.random.RandomState(123456)
for m in (2, 3, 5):
    observed = np.unique(legacy.randint(0, m - 1, size=10_000))
    print(f"nLandmarks = {m}: landmarks ever observed {observed.tolist()} of {list(range(m))}")

# %% [markdown]
# So report 002's "2 landmarks" is one landmark seen and its "3" is two: its jump is our
# jump from one landmark to two, and the verdict agrees with it once the off-by-one is
# accounted for.

# %% [markdown]
# ## Good or uniform initialization
#
# **Claim.** The reports start the cloud around the true position and leave the uniform
# start (global localization) commented out in their code; they do not study it. The
# robot chapter ({doc}`../part2/robot`) shows that locking on from a uniform cloud takes
# thousands of particles. Here we measure the price of not knowing the start, with 100 runs
# of 50 s per setting: we count a run as *locked on* when its final position error is below
# 1 m and its heading error below 5°.

# %%
init_table = robot_study({"initial": ["tracking", "uniform"], "n_particles": [300, 1000]}, n_steps=50)
init_table["locked_on"] = ((init_table["final_position_error"] < 1.0)
                           & (init_table["final_heading_error"] < np.deg2rad(5.0)))
show(init_table, ["initial", "n_particles"], {"position_rmse": "position RMSE after 20 s (m)",
                                              "final_position_error": "final error (m)"}, digits=2)
locked = init_table.groupby(["initial", "n_particles"], sort=False)["locked_on"].sum()
print("\nruns locked on after 50 s, of 100:\n" + locked.to_string())

# %%
fig, ax = plt.subplots(figsize=(6.5, 3.6))
s = summarize(init_table, ["initial", "n_particles"], "final_position_error")
s.index = [f"{a}\nN = {n}" for a, n in s.index]
summary_band(s, ax, color=COLORS["estimate"], categorical=True)
ax.set_yscale("log")
ax.set_ylabel("final position error (m)")
ax.set_title(f"After 50 s: median and 10-90 % over {N_RUNS} runs", fontsize=10)
plt.show()

# %% [markdown]
# **Verdict.** Knowing the start is worth more than any other setting of this chapter. From
# the reports' initial cloud (1 m, 1 m, 0.1 rad around the truth) every run is locked on
# after 50 s, at 0.18 m. From a cloud uniform over the map, 300 particles lock on in none of
# the 100 runs and 1000 particles in 2: the other runs end tens of metres off (median final
# error 29 m and 22 m), on a cluster of particles that fits the measurements of a few
# seconds but not the truth. Global localization is possible, but it needs the tens of
# thousands of particles measured in {doc}`../part2/robot`, or a smarter initialization
# (for example sampling the first cloud from the first measurement).

# %% [markdown]
# ## Summary
#
# | parameter | the reports' claim (one run each) | what 100 runs per setting show |
# |---|---|---|
# | number of particles $N$ | 300 throughout (002, 004); terrain report 001: 300 biased, 30 000 good | RMSE 0.44 m with 20, 0.23 m with 100, 0.18 m with 300, 0.17 m with 1000; below 100 the filter is over-confident (median NEES 71 at 20, 7.7 at 50). 300 is enough here |
# | $Q_\text{est}$ scale | 002: larger gives a jerkier path and a wider covariance; 004: worse below about 1 and above about 5 | jerkier and wider: yes (jitter 0.044 to 0.195 m/step from 2 to 100). RMSE 0.18-0.20 m from 0.5 to 5, 0.24 m at 20, 0.37 m at 100. Below 1 not less accurate but over-confident (NEES 5 at 0.5, 15 at 0.25) |
# | $R_\text{est}$ scale | 002: larger gives a smoother path, wider covariance, eventually no localization; 004: worse below about 1 and above about 5 | smoother and wider: yes. Loses the robot: no, RMSE 0.18-0.21 m from 0.25 to 100. Outside 1-5 the covariance is wrong (NEES 16 at 0.25, 0.34 at 100), not the estimate |
# | resampling threshold $\theta$ | 002: near 1/3 best; 001: 1 degenerates; 004: above 0.5 no resampling | only $\theta = 0$ fails (0.68 m against 0.18-0.21 m); 0.2 to 1 are equivalent; $\theta = 1$ resamples at every step and has the largest ESS. Linear model: 0.36 m from the exact mean at 0, 0.09 m for every $\theta > 0$. None of the three claims holds |
# | resampling scheme | 004: multinomial slightly better than low-variance | no detectable difference: paired mean +0.009 m (s.e. 0.007 m) against multinomial, which is better in 48 runs of 100 |
# | measurement gap (100 s) | 002: drift, then near-instant correction, no lasting effect; 004: little change, mostly in heading | at the end of the gap 0.37 m against 0.15 m, heading 6.6° against 0.5°; heading back at once, position within about a minute; no lasting effect: confirmed |
# | measurement period | 002: shorter is better; 004: 0.1 s diverges, measurements faster than predictions | 002 confirmed: 0.18 m (1 s) to 0.40 m (20 s). 004: a floating-point test that never fires, so no measurement at all |
# | number of landmarks | 002: big gain from 2 to 3, then flat; 004: little influence | big gain from 1 to 2 (0.40 to 0.22 m), flat from 3 (0.18-0.19 m), fewer bad runs with more landmarks. 002's step is an off-by-one in its code |
# | initialization | not studied (uniform start commented out) | tracking start: 100 of 100 runs locked on; uniform start: 0 of 100 with 300 particles, 2 of 100 with 1000 |

# %% [markdown]
# ## Try it: how many runs does a study need?
#
# Every study above used {glue:text}`n_runs_per_setting` seeded runs per setting. The panel
# redraws one of them from its first runs only (run $r$ has the same seed in every study, so
# the first 10 runs are a 10-run study): the median and 10-90 % band of the position RMSE,
# with the median of all the runs dashed. Compare how far the medians of 5 or 10 runs stray
# from the dashed line with the differences the studies were asked to find: the verdicts
# above rest on paired tests over all the runs, not on medians of a few.

# %%
PANEL_STUDIES = {"n_particles": n_table, "q_scale": q_table, "r_scale": r_table, "threshold": th_table,
                 "dt_meas": dt_table, "n_landmarks": lm_table}
glue("n_runs_per_setting", N_RUNS, display=False)


def draw_first_runs(parameter, n_runs):
    table = PANEL_STUDIES[parameter]
    fig, ax = plt.subplots(figsize=(6.5, 3.5))
    summary_band(summarize(table[table["run"] < n_runs], parameter, "position_rmse"), ax,
                 color=COLORS["estimate"], label=f"first {n_runs} runs")
    whole = summarize(table, parameter, "position_rmse")
    ax.plot(whole.index, whole["q50"], "--", color=COLORS["truth"], lw=1, label=f"median of all {N_RUNS}")
    if parameter != "threshold":
        plain_log_axis(ax, "x", subs=(1.0, 2.0, 5.0))
    ax.set_xlabel(parameter)
    ax.set_ylabel("position RMSE (m)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))


# %% tags=["nbval-ignore-output"]
control_panel(
    draw_first_runs,
    columns=2,
    grid={"parameter": tuple(PANEL_STUDIES), "n_runs": (5, 10, 20, 50, 100)},
    parameter=widgets.Dropdown(options=list(PANEL_STUDIES), value="threshold", description="study"),
    n_runs=widgets.SelectionSlider(options=[5, 10, 20, 50, 100], value=10, description="first runs"),
)

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-studies-paired
# The scheme study compares multinomial and systematic resampling on the same 100 runs.
# Estimate the standard error of the difference of the mean RMSEs twice: from the paired
# differences (as above), and as if the two schemes had been run on independent sets of
# 100 runs, $\sqrt{(s_1^2 + s_2^2)/100}$. How many more runs would the unpaired design
# need for the same precision?
# ```
#
# ```{solution} ex-studies-paired
# :class: dropdown
# With `paired = scheme_table.pivot(index="run", columns="scheme", values="position_rmse")`,
# the paired standard error is `(paired.multinomial - paired.systematic).std() / 10` and the
# unpaired one `np.sqrt(paired.multinomial.var() + paired.systematic.var()) / 10`. The
# RMSE of a run depends mostly on its simulated world (landmark layout, noises), which both
# schemes share, so the two RMSEs are strongly correlated and their difference varies much
# less than either. The ratio of the two variances is the factor of extra runs an unpaired
# study would need; here it is large (compute it), which is why every study of this chapter
# uses common random numbers.
# ```
#
# ```{exercise}
# :label: ex-studies-linear-n
# On the linear model, measure how the distance between the particle filter's mean and
# the exact Kalman mean falls with $N$ (say $N = 30, 100, 300, 1000$, threshold 0.5, 50 runs
# each, with `distance_to_exact` adapted to take `n_particles`). A Monte Carlo error
# should fall as $1/\sqrt N$: by a factor of about 5.8 from 30 to 1000 particles. Does the
# robot part follow that rate? The landmark part? Then give the landmarks a small process
# noise, as report 000 does (landmark entries of $Q_w$ equal to 0.0025, with
# `LINEAR.with_(Qw=...)` in the simulation *and* the model), and compare again.
# ```
#
# ```{solution} ex-studies-linear-n
# :class: dropdown
# Neither part follows $1/\sqrt N$, and the book has measured it: in {doc}`../part1/sir`
# (50 runs per $N$, threshold 1/3) the landmark error against the exact mean falls only from
# 0.368 m to 0.164 m between 100 and 3000 particles, a log-log slope of -0.24 where a healthy
# filter has -0.5. The landmarks have (almost) no process noise, so their particles are
# fixed by the first resamplings and never rejuvenated: the filter carries the sampling
# error of its first steps to the end of the run, whatever $N$. Since the measurements are
# landmark positions *relative to the robot*, the robot estimate inherits that landmark
# error. With process noise on every component the model changes (and so does the exact
# posterior), the particles keep diversifying, and the distance to the exact mean becomes a
# genuine Monte Carlo error again: {doc}`../part4/pf_vs_kalman` fits a slope of -0.43 there,
# against -0.27 with the static landmarks.
# ```
#
# ```{exercise}
# :label: ex-studies-budget
# From the tables printed in this chapter, which change of the defaults moves the median
# position RMSE more: more than tripling the number of particles (300 to 1000), or halving
# the measurement rate (`dt_meas` from 1 s to 2 s)? What does that say about where the
# error of this filter comes from?
# ```
#
# ```{solution} ex-studies-budget
# :class: dropdown
# Tripling $N$ lowers the median RMSE by about 0.013 m (0.183 m to 0.170 m), while
# measuring half as often raises it by about 0.04 m (0.177 m to 0.215 m, on the 200 s runs
# of that study). With 300 particles the error of this filter is dominated by what the data
# can tell (the spread of the exact posterior), not by the Monte Carlo error of the cloud:
# more particles only matter once the cloud is too small to represent the posterior (below
# about 100 particles here, where the NEES shoots up).
# ```
