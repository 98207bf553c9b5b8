# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Particle filter or Kalman filter?
#
# A particle filter can represent any posterior, at a price: $N$ evaluations of the model per
# step, a Monte Carlo error, and failure modes of its own (degeneracy, impoverishment). The
# Kalman family carries one mean and one covariance: the Kalman filter (KF) is exact for a
# linear Gaussian model, the extended Kalman filter (EKF) linearises the model at the current
# estimate, and the unscented Kalman filter (UKF) pushes $2d + 1$ sigma points through it
# {cite:p}`julier2004,labbe2020`. This chapter puts the three questions a user asks, on the
# three problems of the book, to numbers computed on the same seeded runs:
#
# - **accuracy**: the root-mean-square position error (RMSE) over a run;
# - **consistency**: does the filter know how wrong it is? The normalised estimation error
#   squared $\text{NEES}_k = e_k^\top P_k^{-1} e_k$ (with $e_k$ the error of the estimate and
#   $P_k$ the filter's covariance) and the normalised innovation squared
#   $\text{NIS}_k = y_k^\top S_k^{-1} y_k$ (with $y_k = z_k - \hat z_k$ the innovation and
#   $S_k$ its predicted covariance) are $\chi^2$ variables with $\dim x$ and $\dim z$ degrees
#   of freedom for a consistent filter {cite:p}`barshalom2001`. Averaged over $R$ runs, they
#   must fall in the 95 % band of an average of $R$ such variables; we report the **fraction
#   of steps inside the band** ($0.95$ expected). The NIS needs no truth, so it is the check
#   that works on real data;
# - **cost**: run time per step, and the number of model evaluations per step ($N$ for a
#   particle filter, $2d+1$ for the UKF, one plus Jacobians for the EKF).
#
# It ends with a decision table in which every recommendation cites a number computed here.

# %%
import time

import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display
from matplotlib import ticker
from matplotlib.animation import FuncAnimation
from myst_nb import glue
from scipy import stats

from pfcourse import evidence

from pfcourse.experiments.terrain import DIVERGED_ERROR
from pfcourse.terrain.scenario import AircraftScenario
from pfcourse.experiments.comparison import label, linear_convergence, robot_tracks, summarize_tracks, terrain_tracks
from pfcourse.diagnostics import chi2_band, fraction_in_band
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.robot.kalman import run_ekf, run_ukf
from pfcourse.robot.scenario import RobotModel, RobotScenario, simulate_robot
from pfcourse.seeding import sized_filter_rng
from pfcourse.style import COLORS, ellipse_patch, plain_log_axis, use_style
from pfcourse.terrain.map import load_jacksboro
from pfcourse.figures.legibility import overlapping_texts
from pfcourse.figures.widgets import control_panel

use_style()


def plain_log(ax, axes="xy"):
    """Log axes with ticks at 1, 2, 5 times powers of ten, labelled 0.1, 0.2, 0.5, 1, ..."""
    for name in axes:
        axis = getattr(ax, f"{name}axis")
        axis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(ticker.FormatStrFormatter("%g"))
        axis.set_minor_formatter(ticker.NullFormatter())


chapter_start = time.perf_counter()

# %% [markdown]
# **Run sizes.** The last cell prints the time this page took to execute. There are
# {glue:text}`linear_runs:d` runs per setting in the linear study, {glue:text}`robot_runs:d` in the
# robot study, {glue:text}`terrain_small_flights:d` and {glue:text}`terrain_wide_flights:d` flights
# in the two terrain studies. That is enough to separate the filters where the differences are
# large (each comparison below prints its test and interval), and the quantile bands show how much
# spread remains; the chapters of Part II run the same scenarios with more runs where they need
# finer estimates.
#
# ## 1. Linear Gaussian: the Kalman filter is the answer
#
# On the landmark model of Part I, the Kalman filter computes the exact posterior mean
# $m_k$, covariance $P_k$ and log-likelihood $\log p(z_{0:K})$. A particle filter estimates
# the same three quantities, each with a Monte Carlo error that should shrink like
# $1/\sqrt N$ {cite:p}`doucet2011`. We measure it on one simulated data set
# ({glue:text}`linear_steps:d` steps of the two-landmark model) and {glue:text}`linear_runs:d`
# independent particle-filter runs per $N$, for two
# versions of the model:
#
# - **every component moves**: process noise $0.05^2$ m² on the robot *and* the landmarks,
#   measurement noise $0.5^2$ m², a set-up in which the particle filter nears its
#   asymptotic regime at a few hundred particles (the unit tests use it);
# - **the report's model**: landmarks with process noise $10^{-20}$ m² (static) and
#   measurement noise $0.1^2$ m².
#
# The errors, per run, are the root-mean-square over steps and components of
# $\hat m_k - m_k$ (m), the root-mean-square over steps of the Frobenius norm
# $\lVert \hat P_k - P_k \rVert_F$ (m²), and $\log \hat p(z_{0:K}) - \log p(z_{0:K})$ (nats).

# %%
N_LINEAR = np.array([100, 300, 1000, 3000])
LINEAR_RUNS = 16
versions = {
    "every component moves": quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4), n_samples=15),
    "report's static landmarks": quadrant_scenario().with_(n_samples=15),
}
convergence, exact = {}, {}
for name, sc in versions.items():
    data = simulate(sc, 7)
    exact[name] = kalman_filter(sc.model(), data.measurements)
    convergence[name] = linear_convergence(sc.model(), data.measurements, exact[name], N_LINEAR, LINEAR_RUNS)
glue("linear_runs", LINEAR_RUNS, display=False)
glue("linear_steps", int(versions["every component moves"].n_samples), display=False)


def rms(a):
    return np.sqrt(np.mean(a**2, axis=1))


def rms_over_runs(a, axis):
    return np.sqrt(np.mean(a**2, axis=axis))


slopes = {}  # (slope, low, high): the fit of log(RMS over the runs) on log N, 95 % interval resampling the runs
print(f"fitted slope of log(RMS error) against log(N), {LINEAR_RUNS} runs per N (95 % bootstrap interval over the runs)")
for name, res in convergence.items():
    slopes[name] = {q: evidence.log_slope(getattr(res, q), N_LINEAR, center=rms_over_runs)
                    for q in ("mean_error", "cov_error", "loglik_error")}
    print(f"  {name:27s} " + "   ".join(f"{q.split('_')[0]:7s} {s:+.2f} ({lo:+.2f} to {hi:+.2f})"
                                          for q, (s, lo, hi) in slopes[name].items()))
for q in ("mean_error", "loglik_error"):
    for suffix, value in zip(("", "_low", "_high"), slopes["every component moves"][q]):
        glue(f"linear_{q.split('_')[0]}_slope{suffix}", value, display=False)

# %%
titles = {"mean_error": "posterior mean (m)", "cov_error": "posterior covariance (m²)",
          "loglik_error": "log-likelihood (nats)"}
styles = {"every component moves": COLORS["estimate"], "report's static landmarks": COLORS["particles"]}
fig, axes = plt.subplots(1, 3, figsize=(10, 3.8))
for ax, q in zip(axes, titles):
    for name, res in convergence.items():
        values = np.abs(getattr(res, q))
        lo, hi = np.quantile(values, [0.1, 0.9], axis=1)
        ax.fill_between(N_LINEAR, lo, hi, color=styles[name], alpha=0.2)
        s = slopes[name][q][0]
        ax.plot(N_LINEAR, rms(values), "o-", color=styles[name], label=f"{name}: slope {s:+.2f}")
    ref = rms(np.abs(getattr(convergence["every component moves"], q)))[0] * np.sqrt(N_LINEAR[0] / N_LINEAR)
    ax.plot(N_LINEAR, ref, "k--", lw=1, label=r"$1/\sqrt{N}$")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("number of particles N")
    ax.set_ylabel(f"error of the PF {titles[q]}")
    ax.legend(fontsize=7, loc="lower left")
    plain_log(ax)
axes[1].set_title(f"Particle filter minus Kalman filter: RMS over {LINEAR_RUNS} runs (line), 10-90 % of runs (band)",
                  fontsize=10)
plt.tight_layout()
plt.show()
kf_sd = np.sqrt(np.mean(np.diagonal(exact["every component moves"].cov, axis1=1, axis2=2)))
err_1000 = rms(convergence["every component moves"].mean_error)[N_LINEAR == 1000][0]
print(f"every component moves: mean error at N = 1000 is {err_1000:.4f} m, "
      f"{err_1000 / kf_sd:.2f} of the exact posterior standard deviation ({kf_sd:.3f} m, RMS over states and steps)")
bias = {name: res.loglik_error.mean(axis=1) for name, res in convergence.items()}
for name, b in bias.items():
    print(f"{name:27s} mean log-likelihood error at N = {N_LINEAR[0]}, {N_LINEAR[-1]}: {b[0]:+.2f}, {b[-1]:+.2f} nats")

# %% [markdown]
# When every component has process noise, the errors of the mean and of the log-likelihood
# fall close to the $1/\sqrt N$ line: the fitted slope is {glue:text}`linear_mean_slope:.2f` for
# the mean (95 % bootstrap interval over the runs {glue:text}`linear_mean_slope_low:.2f` to
# {glue:text}`linear_mean_slope_high:.2f`, a little shallower than $-1/2$ over this range of $N$)
# and {glue:text}`linear_loglik_slope:.2f` for the log-likelihood ({glue:text}`linear_loglik_slope_low:.2f`
# to {glue:text}`linear_loglik_slope_high:.2f`): the central limit theorem of particle filters at
# work {cite:p}`doucet2011`. The covariance error falls
# more slowly over this range of $N$: a second moment estimated from a resampled cloud needs
# more particles to reach its asymptotic regime. At $N = 1000$ the particle mean is off by
# about a tenth of the exact posterior standard deviation (printed above). The rate is also
# the bill: ten times more accuracy costs a hundred times more particles, while the Kalman
# filter has no error at all for one matrix update per step.
#
# With the report's static landmarks the slopes of the mean and covariance errors are
# clearly shallower, and the log-likelihood estimate is biased downwards by tens of nats at
# $N = 100$ (printed above; its error falls faster than $N^{-1/2}$ only because this bias
# shrinks): resampling copies
# landmark hypotheses that never move again, so the cloud of landmark positions thins out
# (sample impoverishment, Part I) and more particles help less than $1/\sqrt N$ promises. The
# particle filter is not wrong in theory here, but its constant in front of $N^{-1/2}$ is huge
# over the range of $N$ one can afford.
#
# The animation shows the cloud of the robot position at the last step for increasing $N$
# (the "every component moves" data set), against the Kalman filter's 95 % ellipse: the
# particle ellipse settles onto the exact one.

# %%
sc_anim = versions["every component moves"]
data_anim = simulate(sc_anim, 7)
kf_anim = kalman_filter(sc_anim.model(), data_anim.measurements)
frames_n = [30, 100, 300, 1000, 3000]
anim_runs = {n: ParticleFilter(sc_anim.model(), n).run(data_anim.measurements, sized_filter_rng(1, n), store_particles=True)
             for n in frames_n}

fig, ax = plt.subplots(figsize=(5.0, 5.9), dpi=72)
fig.subplots_adjust(left=0.16, right=0.96, top=0.94, bottom=0.26)  # room for the legend under the axes


def draw_frame(i):
    ax.clear()
    n = frames_n[i]
    run = anim_runs[n]
    idx = np.random.default_rng(0).choice(n, min(n, 600), p=run.weights[-1])
    ax.plot(run.particles[-1, idx, 0], run.particles[-1, idx, 1], ".", ms=3, color=COLORS["particles"],
            alpha=0.5, label="particles (up to 600, by weight)")
    ax.add_patch(ellipse_patch(kf_anim.mean[-1, :2], kf_anim.cov[-1, :2, :2], fill=False, color=COLORS["kalman"],
                               lw=2, label="Kalman 95 % ellipse"))
    ax.add_patch(ellipse_patch(run.mean[-1, :2], run.cov[-1, :2, :2], fill=False, color=COLORS["estimate"],
                               lw=2, ls="--", label="particle 95 % ellipse"))
    ax.plot(*data_anim.truth[-1, :2], "x", color=COLORS["truth"], ms=10, mew=2, label="truth")
    centre = kf_anim.mean[-1, :2]
    ax.set_xlim(centre[0] - 0.6, centre[0] + 0.6)
    ax.set_ylim(centre[1] - 0.6, centre[1] + 0.6)
    ax.set_xlabel("robot x (m)")
    ax.set_ylabel("robot y (m)")
    ax.set_title(f"N = {n}: robot position at t = {data_anim.T[-1]:.0f} s")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncols=2, fontsize=7)  # off the cloud


anim = FuncAnimation(fig, draw_frame, frames=len(frames_n), interval=800)
plt.close(fig)
HTML(anim.to_jshtml())

# %% [markdown]
# ## 2. Mildly nonlinear: the robot
#
# The previous chapters compared the particle filter with $N = 300$ particles, the EKF and the UKF
# on the robot with the noise variances overstated by a factor $2$ (the report's
# $Q_\text{est} = 2 Q_\text{true}$, $R_\text{est} = 2 R_\text{true}$), which makes every
# filter look conservative. Here every filter assumes the **true** variances, so that the
# $\chi^2$ checks are sharp, and the particle filter runs with $N = 100$, $300$ and $1000$. The
# same {glue:text}`robot_runs:d` seeded runs of {glue:text}`robot_duration:.0f` s (five random landmarks
# per run, one range-bearing reading per second) go through all five filters; the statistics use
# the steps after a {glue:text}`robot_burn_in:.0f` s transient.
#
# How the NIS is computed: for the EKF, $S_k = H_k P_k^- H_k^\top + R$; for the UKF, $S_k$ is
# the unscented transform of the predicted sigma points through $h$, plus $R$ (both as the
# filters computed them: every Kalman-family filter returns its innovations and their
# covariances, `pfcourse.results.KalmanResult`). For the particle filter, the
# predictive distribution of $z_k$ is the mixture $\sum_i W_{k-1}^i \, \mathcal N(z;
# h(x_k^i), R)$ over the *predicted* particles (moved, not yet weighted by $z_k$); $\hat z_k$
# and $S_k$ are its mean and covariance,
# $S_k = \sum_i W_{k-1}^i (h(x_k^i) - \hat z_k)(h(x_k^i) - \hat z_k)^\top + R$, with the
# bearing averaged on the circle and its deviations wrapped
# (`pfcourse.diagnostics.predictive_moments`).

# %%
N_ROBOT = (100, 300, 1000)
ROBOT_RUNS, ROBOT_STEPS, ROBOT_BURN_IN = 16, 100, 20
robot_runs = [robot_tracks(seed, N_ROBOT, n_steps=ROBOT_STEPS) for seed in range(ROBOT_RUNS)]
robot_table = summarize_tracks(robot_runs, dim_x=3, dim_z=2, burn_in=ROBOT_BURN_IN)
glue("robot_runs", ROBOT_RUNS, display=False)
glue("robot_duration", float(ROBOT_STEPS * RobotScenario.dt), display=False)
glue("robot_burn_in", float(ROBOT_BURN_IN * RobotScenario.dt), display=False)
for name, row in robot_table.iterrows():  # the consistency bullets below
    key = name.replace("PF N=", "pf").lower()
    glue(f"robot_{key}_nees_in", float(row["nees_in_band"]), display=False)
    glue(f"robot_{key}_nees_above", float(1 - row["nees_in_band"] - row["nees_below"]), display=False)
glue("robot_ukf_evaluations", int(robot_table.loc["UKF", "evaluations"]), display=False)

COLUMNS = {"rmse_q50": "RMSE median", "rmse_q10": "10 %", "rmse_q90": "90 %", "nees_median": "NEES median",
           "nees_in_band": "NEES in band", "nees_below": "below", "nis_median": "NIS median",
           "nis_in_band": "NIS in band", "nis_below": "below",
           "evaluations": "evals/step"}


def show(table, extra=(), digits=3):
    """Print the comparison table with `digits` significant digits."""
    cols = {**COLUMNS, **{c: c for c in extra}}
    print(table[list(cols)].rename(columns=cols).to_string(float_format=lambda v: f"{v:.{digits}g}"))


show(robot_table)
print(f"({ROBOT_RUNS} runs; RMSE of the position in m; 95 % bands for the {ROBOT_RUNS}-run average: "
      f"NEES {np.round(chi2_band(3, ROBOT_RUNS), 2)}, NIS {np.round(chi2_band(2, ROBOT_RUNS), 2)}; "
      f"medians of chi2_3 and chi2_2: {stats.chi2.median(3):.2f} and {stats.chi2.median(2):.2f})")

# paired, run by run: each particle filter's RMSE against the EKF's on the same run
rms = {(t.filter, t.n_particles): [] for t in robot_runs[0]}
for run in robot_runs:
    for t in run:
        rms[(t.filter, t.n_particles)].append(float(np.sqrt(np.mean(t.error[ROBOT_BURN_IN:] ** 2))))
ekf_key = next(k for k in rms if k[0] == "ekf")
for key in [k for k in rms if k[0] != "ekf"]:
    cmp = evidence.paired(rms[key], rms[ekf_key], ratio=True)
    who = f"{key[0].upper()} N={key[1]}" if key[1] else key[0].upper()
    print(f"{who:10s} RMSE / EKF RMSE: {cmp}")
    if not key[1]:
        glue(f"robot_{key[0]}_over_ekf", cmp.median, display=False)
        glue(f"robot_{key[0]}_over_ekf_low", cmp.low, display=False)
        glue(f"robot_{key[0]}_over_ekf_high", cmp.high, display=False)
    if key[1]:
        glue(f"robot_pf{key[1]}_over_ekf", cmp.median, display=False)
        glue(f"robot_pf{key[1]}_over_ekf_low", cmp.low, display=False)
        glue(f"robot_pf{key[1]}_over_ekf_high", cmp.high, display=False)
        glue(f"robot_pf{key[1]}_over_ekf_p", cmp.pvalue, display=False)

# the particle filters against each other, run by run (not only each against the EKF)
pf_keys = sorted(k for k in rms if k[0] == "pf")
for a, b in [(pf_keys[0], pf_keys[1]), (pf_keys[1], pf_keys[2]), (pf_keys[0], pf_keys[2])]:
    cmp = evidence.paired(rms[a], rms[b], ratio=True)
    print(f"PF N={a[1]:<4} RMSE / PF N={b[1]} RMSE: {cmp}")
    for suffix, value in (("", cmp.median), ("_low", cmp.low), ("_high", cmp.high), ("_p", cmp.pvalue)):
        glue(f"robot_pf{a[1]}_over_pf{b[1]}{suffix}", value, display=False)
    glue(f"robot_pf{a[1]}_over_pf{b[1]}_detectable", cmp.detectable, display=False)


def band_intervals(runs, dim_x, dim_z, burn_in, seed=0):
    """95 % bootstrap intervals over the runs of the fractions of steps in, below and above the band.

    The runs are resampled with replacement and the run-averaged NEES / NIS recomputed from them (as
    summarize_tracks does, against the band of an average of len(runs) chi-square variables).
    """
    R = len(runs)
    nees_band, nis_band = chi2_band(dim_x, R), chi2_band(dim_z, R)
    rows = {}
    for j, first in enumerate(runs[0]):
        with np.errstate(invalid="ignore", over="ignore"):
            nees_all = np.array([r[j].nees[burn_in:] for r in runs])
            nis_all = np.array([r[j].nis[burn_in:] for r in runs])
            nis_all = nis_all[:, ~np.all(np.isnan(nis_all), axis=0)]

            def fractions(idx):  # of the run-averaged NEES / NIS over the runs idx
                nees_avg, nis_avg = nees_all[idx].mean(axis=0), nis_all[idx].mean(axis=0)
                f_in = fraction_in_band(nees_avg, nees_band)
                f_below = fraction_in_band(nees_avg, (-np.inf, np.nextafter(nees_band[0], -np.inf)))
                return np.array([f_in, f_below, max(0.0, 1 - f_in - f_below), fraction_in_band(nis_avg, nis_band)])

            _, lo, hi = evidence.run_interval(fractions, R, seed=seed)
        rows[label(first)] = {f"{c} {b}": v for c, l, h in zip(("NEES in", "NEES below", "NEES above", "NIS in"), lo, hi)
                              for b, v in (("low", l), ("high", h))}
    return pd.DataFrame(rows).T


def glue_band(prefix, intervals, name, column, key):
    for bound in ("low", "high"):
        glue(f"{prefix}_{key}_{bound}", float(intervals.loc[name, f"{column} {bound}"]), display=False)


robot_band = band_intervals(robot_runs, 3, 2, ROBOT_BURN_IN)
print(f"\nfractions of steps in / below / above the band, 95 % bootstrap intervals over the {ROBOT_RUNS} runs:")
print(robot_band.to_string(float_format=lambda v: f"{v:.2f}"))
for name in ("EKF", "UKF", "PF N=100", "PF N=300"):
    glue_band("robot", robot_band, name, "NEES in", f"{name.replace('PF N=', 'pf').lower()}_nees_in")
glue_band("robot", robot_band, "PF N=1000", "NEES above", "pf1000_nees_above")

# %% [markdown]
# Run time per step on the machine that built this page (the output of this cell is not
# compared when the notebook is tested, since timings vary between machines; the ratios are
# what carries over). The five filters are timed side by side, in one loop over the first
# {glue:text}`robot_timing_reps:d` data sets, in alternating order (forward on one repetition,
# backward on the next), so that a slow moment of the machine hits them all alike; each
# filter's time is divided by the EKF's on the same repetition, and the ratios get a median, a
# 95 % bootstrap interval and a Wilcoxon signed-rank test (`pfcourse.evidence.paired`). Here and
# below, a "median paired ratio" is the median of the per-run ratios, its interval a percentile
# bootstrap over the runs, and the Wilcoxon $p$ tests whether the log ratios are symmetric about
# zero (which is not the same as a median ratio of one).

# %% tags=["nbval-ignore-output"]
def robot_filters(seed):
    """The five filters of the robot study on run ``seed``, as calls to time (no diagnostics)."""
    sim = simulate_robot(None, seed, n_steps=ROBOT_STEPS)
    model = RobotModel.for_simulation(sim, q_scale=1.0, r_scale=1.0)
    z = sim.measurements
    calls = {f"PF N={n}": (lambda n=n: ParticleFilter(model, n, threshold=0.5).run(z, sized_filter_rng(seed, n)))
             for n in N_ROBOT}
    calls["EKF"] = lambda: run_ekf(model, z)
    calls["UKF"] = lambda: run_ukf(model, z)
    return calls


TIMING_REPS = 8
seconds = {}
for rep in range(TIMING_REPS):
    calls = robot_filters(rep)
    for name in (list(calls) if rep % 2 == 0 else list(calls)[::-1]):
        start = time.perf_counter()
        calls[name]()
        seconds.setdefault(name, []).append(time.perf_counter() - start)
glue("robot_timing_reps", TIMING_REPS, display=False)
print(f"run time per step, {TIMING_REPS} repetitions timed side by side; ratio to the EKF on the same repetition")
for name, s in seconds.items():
    ms = 1000 * float(np.median(s)) / ROBOT_STEPS
    line = f"{name:10s} {ms:7.3f} ms per step (median)"
    if name != "EKF":
        cmp = evidence.paired(s, seconds["EKF"], ratio=True)
        key = name.replace("PF N=", "pf").lower()
        for suffix, value in (("", cmp.median), ("_low", cmp.low), ("_high", cmp.high)):
            glue(f"robot_time_{key}_over_ekf{suffix}", value, display=False)
        line += f"   / EKF: {cmp}"
    print(line)
n_lo, n_hi = N_ROBOT[0], N_ROBOT[-1]
growth = evidence.paired(seconds[f"PF N={n_hi}"], seconds[f"PF N={n_lo}"], ratio=True)
glue("robot_time_pf_growth", growth.median, display=False)
glue("robot_time_pf_growth_low", growth.low, display=False)
glue("robot_time_pf_growth_high", growth.high, display=False)
print(f"PF N={n_hi} / PF N={n_lo} ({n_hi // n_lo} times the particles): {growth}")

# %% [markdown]
# Three things stand out (numbers in the table above):
#
# - **Accuracy.** The EKF and UKF have the smallest median RMSE, and run by run they agree: the
#   UKF's RMSE is {glue:text}`robot_ukf_over_ekf:.3f` times the EKF's (median paired ratio,
#   95 % interval {glue:text}`robot_ukf_over_ekf_low:.3f`-{glue:text}`robot_ukf_over_ekf_high:.3f`). Run by run, the particle filter's RMSE is {glue:text}`robot_pf100_over_ekf:.2f`,
#   {glue:text}`robot_pf300_over_ekf:.2f` and {glue:text}`robot_pf1000_over_ekf:.2f` times the
#   EKF's at $N = 100$, $300$ and $1000$ (median paired ratios; 95 % intervals
#   {glue:text}`robot_pf100_over_ekf_low:.2f`-{glue:text}`robot_pf100_over_ekf_high:.2f`,
#   {glue:text}`robot_pf300_over_ekf_low:.2f`-{glue:text}`robot_pf300_over_ekf_high:.2f` and
#   {glue:text}`robot_pf1000_over_ekf_low:.2f`-{glue:text}`robot_pf1000_over_ekf_high:.2f`;
#   Wilcoxon p = {glue:text}`robot_pf100_over_ekf_p:.2g`, {glue:text}`robot_pf300_over_ekf_p:.2g`,
#   {glue:text}`robot_pf1000_over_ekf_p:.2g`; {glue:text}`robot_runs:d` paired runs). Paired
#   with each other on the same runs, the particle filter with $N = 100$ has
#   {glue:text}`robot_pf100_over_pf300:.2f` times the RMSE of $N = 300$ (95 % interval
#   {glue:text}`robot_pf100_over_pf300_low:.2f`-{glue:text}`robot_pf100_over_pf300_high:.2f`,
#   Wilcoxon p = {glue:text}`robot_pf100_over_pf300_p:.2g`) and
#   {glue:text}`robot_pf100_over_pf1000:.2f` times that of $N = 1000$
#   ({glue:text}`robot_pf100_over_pf1000_low:.2f`-{glue:text}`robot_pf100_over_pf1000_high:.2f`,
#   p = {glue:text}`robot_pf100_over_pf1000_p:.2g`); between $N = 300$ and $N = 1000$ the
#   study detects no difference ({glue:text}`robot_pf300_over_pf1000:.2f`,
#   {glue:text}`robot_pf300_over_pf1000_low:.2f`-{glue:text}`robot_pf300_over_pf1000_high:.2f`,
#   p = {glue:text}`robot_pf300_over_pf1000_p:.2g`: a factor up to
#   {glue:text}`robot_pf300_over_pf1000_detectable:.2f` either way could hide in
#   {glue:text}`robot_runs:d` runs). On this problem the
#   posterior is a single, nearly Gaussian bump, so linearising costs nothing and the particles
#   only add Monte Carlo error.
# - **Consistency.** The EKF and UKF, given the true noise levels, are consistent: NEES and
#   NIS medians close to those of $\chi^2_3$ and $\chi^2_2$, and the run-averaged NEES
#   inside its band at most steps (a fraction {glue:text}`robot_ekf_nees_in:.2f` of the
#   steps for the EKF, {glue:text}`robot_ukf_nees_in:.2f` for the UKF; 95 % bootstrap intervals over
#   the runs {glue:text}`robot_ekf_nees_in_low:.2f`-{glue:text}`robot_ekf_nees_in_high:.2f` and
#   {glue:text}`robot_ukf_nees_in_low:.2f`-{glue:text}`robot_ukf_nees_in_high:.2f`, printed below
#   the table). The particle filter's NEES is
#   far too large at $N = 100$ and $300$ (inside the band at a fraction
#   {glue:text}`robot_pf100_nees_in:.2f` and {glue:text}`robot_pf300_nees_in:.2f` of the steps;
#   intervals {glue:text}`robot_pf100_nees_in_low:.2f`-{glue:text}`robot_pf100_nees_in_high:.2f`
#   and {glue:text}`robot_pf300_nees_in_low:.2f`-{glue:text}`robot_pf300_nees_in_high:.2f`) and
#   still above the band at a fraction {glue:text}`robot_pf1000_nees_above:.2f` of the steps at
#   $N = 1000$ ({glue:text}`robot_pf1000_nees_above_low:.2f`-{glue:text}`robot_pf1000_nees_above_high:.2f`): its covariance, estimated from a resampled cloud, is too small for its
#   error. Its NIS, though, looks as good as the Kalman filters': the measurement noise $R$
#   dominates $S_k$ and hides the under-estimated state spread. On real data, where only the
#   NIS can be computed, this over-confidence would go unnoticed.
# - **Cost.** In model evaluations the EKF is by far the cheapest: one, with its Jacobian,
#   per step, against {glue:text}`robot_ukf_evaluations:d` for the UKF and $N$ for the particle
#   filter. Wall time on the machine that built this page tells a different story (timing cell),
#   because the implementations differ: `filterpy`'s EKF and UKF run each step in Python (the UKF
#   calls the model once per sigma point), while the particle filter's inner loops are compiled.
#   Measured side by side, the particle filter takes {glue:text}`robot_time_pf100_over_ekf:.1f`,
#   {glue:text}`robot_time_pf300_over_ekf:.1f` and {glue:text}`robot_time_pf1000_over_ekf:.1f`
#   times the EKF's time at $N = 100$, $300$ and $1000$ (95 % intervals
#   {glue:text}`robot_time_pf100_over_ekf_low:.1f`-{glue:text}`robot_time_pf100_over_ekf_high:.1f`,
#   {glue:text}`robot_time_pf300_over_ekf_low:.1f`-{glue:text}`robot_time_pf300_over_ekf_high:.1f`,
#   {glue:text}`robot_time_pf1000_over_ekf_low:.1f`-{glue:text}`robot_time_pf1000_over_ekf_high:.1f`),
#   the UKF {glue:text}`robot_time_ukf_over_ekf:.1f` times
#   ({glue:text}`robot_time_ukf_over_ekf_low:.1f`-{glue:text}`robot_time_ukf_over_ekf_high:.1f`).
#   Ten times more particles multiply the particle filter's time by only
#   {glue:text}`robot_time_pf_growth:.1f`
#   ({glue:text}`robot_time_pf_growth_low:.1f`-{glue:text}`robot_time_pf_growth_high:.1f`): at these
#   sizes a fixed per-step overhead is a large part of it.
#
# The accuracy-versus-cost figure puts the filters on one plot: the lower left is better. Its
# horizontal axis is the median run time over the runs of the study, where each run's filters
# ran one after the other in a fixed order; the ratios with their intervals are those of the
# side-by-side timing above.

# %%
def accuracy_cost(table, ax, title):
    # One marker per filter, named in a legend beside the axes (labels written next to the
    # points collide where two filters cost and score about the same).
    markers = iter("osD^vP*X")
    for name, row in table.iterrows():
        color = COLORS["estimate"] if name.startswith("PF") else (COLORS["kalman"] if name == "EKF" else "tab:purple")
        ax.errorbar(row["ms_per_step"], row["rmse_q50"],
                    yerr=[[row["rmse_q50"] - row["rmse_q10"]], [row["rmse_q90"] - row["rmse_q50"]]],
                    fmt=next(markers), color=color, capsize=3, label=name)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("run time per step (ms, this machine)")
    ax.set_ylabel("position RMSE (m): median, 10-90 %")
    ax.set_title(title, fontsize=10)
    plain_log(ax)


fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
accuracy_cost(robot_table, ax, f"Robot, {ROBOT_RUNS} runs: accuracy against cost")
assert not (clashes := overlapping_texts(fig)), clashes  # no label drawn over another (pfcourse.figures.legibility)
plt.show()

# %% [markdown]
# ## 3. Terrain navigation: from mildly nonlinear to multimodal
#
# The terrain problem of Part II is the same model in two regimes, depending on how well
# the aircraft's position is known at the start:
#
# - **small prior** ({glue:text}`terrain_small_prior_m:.0f` m, as in the terrain chapter's EKF check, with a small process
#   noise): the terrain is nearly linear over the prior's extent, the posterior is one bump;
# - **the report's prior** ({glue:text}`terrain_wide_prior_km:.1f` km in each horizontal direction): many places on the map fit
#   the first altimeter readings, and the posterior is multimodal for tens of seconds.
#
# All filters run on the same flights (the first flights of the terrain chapter's studies,
# with the same particle-filter seeds, so the $N = 3000$ runs of the report's prior are
# exactly that chapter's baseline runs). The terrain UKF is new here
# (`pfcourse.terrain.kalman`): filterpy's UKF with the heading averaged on the circle, stopped
# like the EKF when its estimate or a sigma point leaves the map. Accuracy is the RMS
# horizontal error over the second half of the flight (from {glue:text}`terrain_burn_in:.0f` s to
# {glue:text}`terrain_duration:.0f` s); a flight counts as diverged when its final error exceeds
# {glue:text}`terrain_diverged_error:.0f` m. The altimeter reading is a scalar, so the NIS has one
# degree of freedom and the NEES four.

# %%
terrain = load_jacksboro()
wide = AircraftScenario()
small = wide.with_(P0=np.diag([30.0, 30.0, 5.0, 0.01]) ** 2, Qf=np.diag([1.0, 1.0, 0.1, 0.001]) ** 2)
TERRAIN_BURN_IN = 40
# (scenario, particle numbers, flights, significant digits printed). From the report's prior
# most flights are lost, and a lost filter is chaotic: a last-bit change of the arithmetic
# (another CPU) moves its statistics by several per cent (the UKF's NEES median from 2.8e2 to
# 3.0e2; tasks.py knife-edge), so that table keeps one significant digit, all it can defend.
terrain_setups = {
    "terrain, small prior": (small, (100, 300, 1000), 12, 3),
    "terrain, report's prior": (wide, (300, 1000, 3000), 16, 1),
}
terrain_runs, terrain_tables = {}, {}
for name, (sc, n_values, n_runs, digits) in terrain_setups.items():
    terrain_runs[name] = [terrain_tracks(0, r, sc, terrain, n_values) for r in range(n_runs)]
    terrain_tables[name] = summarize_tracks(terrain_runs[name], dim_x=4, dim_z=1, burn_in=TERRAIN_BURN_IN,
                                     diverged_error=DIVERGED_ERROR)
    print(f"{name}: {n_runs} flights (RMSE of the horizontal position in m)")
    show(terrain_tables[name], extra=("diverged",), digits=digits)
    print()
glue("terrain_small_flights", terrain_setups["terrain, small prior"][2], display=False)
glue("terrain_wide_flights", terrain_setups["terrain, report's prior"][2], display=False)
glue("terrain_small_prior_m", float(np.sqrt(small.P0[0, 0])), display=False)
glue("terrain_wide_prior_km", float(np.sqrt(wide.P0[0, 0]) / 1000), display=False)
glue("terrain_burn_in", float(TERRAIN_BURN_IN * wide.dt), display=False)
glue("terrain_duration", float(wide.duration), display=False)
glue("terrain_diverged_error", float(DIVERGED_ERROR), display=False)

# %%
def per_flight(name, filter_label):
    """RMSE after the transient (m) and diverged flag of one filter, flight by flight."""
    j = [label(t) for t in terrain_runs[name][0]].index(filter_label)
    tracks = [run[j] for run in terrain_runs[name]]
    with np.errstate(over="ignore"):
        rmse = np.array([np.sqrt(np.mean(t.error[TERRAIN_BURN_IN:] ** 2)) for t in tracks])
    return rmse, np.array([not t.error[-1] <= DIVERGED_ERROR for t in tracks])


sp, wp = terrain_tables["terrain, small prior"], terrain_tables["terrain, report's prior"]
chi2_1, chi2_4 = float(stats.chi2.median(1)), float(stats.chi2.median(4))
glue("chi2_1_median", chi2_1, display=False)
glue("chi2_4_median", chi2_4, display=False)
print(f"medians of chi2_1 and chi2_4: {chi2_1:.2f} and {chi2_4:.2f}")

# small prior: how well, how consistent, and is the EKF's smaller median RMSE a difference?
glue("terrain_small_lost", int(round(sum(sp["diverged"] * len(terrain_runs["terrain, small prior"])))), display=False)
glue("terrain_small_rmse_min", float(sp["rmse_q50"].min()), display=False)
glue("terrain_small_rmse_max", float(sp["rmse_q50"].max()), display=False)
glue("terrain_small_nis_in_min", float(sp["nis_in_band"].min()), display=False)
glue("terrain_small_ekf_nees_below", float(sp.loc["EKF", "nees_below"]), display=False)
glue("terrain_small_ukf_nees_below", float(sp.loc["UKF", "nees_below"]), display=False)
glue("terrain_small_pf100_nees_above", float(1 - sp.loc["PF N=100", "nees_in_band"] - sp.loc["PF N=100", "nees_below"]),
     display=False)
small_band = band_intervals(terrain_runs["terrain, small prior"], 4, 1, TERRAIN_BURN_IN)
print(f"small prior: fractions of steps in / below / above the band, 95 % bootstrap intervals over the "
      f"{len(terrain_runs['terrain, small prior'])} flights:")
print(small_band.to_string(float_format=lambda v: f"{v:.2f}"))
nis_min = sp["nis_in_band"].idxmin()
glue_band("terrain_small", small_band, nis_min, "NIS in", "nis_in_min")
glue_band("terrain_small", small_band, "EKF", "NEES below", "ekf_nees_below")
glue_band("terrain_small", small_band, "UKF", "NEES below", "ukf_nees_below")
glue_band("terrain_small", small_band, "PF N=100", "NEES above", "pf100_nees_above")
ekf_rmse, _ = per_flight("terrain, small prior", "EKF")
print(f"small prior, {len(ekf_rmse)} flights: diverged flights, all filters: {sp['diverged'].sum() * len(ekf_rmse):.0f}")
for other in ("PF N=1000", "UKF"):
    cmp = evidence.paired(per_flight("terrain, small prior", other)[0], ekf_rmse, ratio=True)
    key = other.replace("PF N=", "pf").lower()
    for suffix, value in (("", cmp.median), ("_low", cmp.low), ("_high", cmp.high), ("_p", cmp.pvalue)):
        glue(f"terrain_small_{key}_over_ekf{suffix}", value, display=False)
    print(f"  {other} RMSE / EKF RMSE: {cmp}")

# report's prior: divergence rates with Wilson intervals, and does more particles lose fewer flights?
# (the lost flights are chaotic, see above: only counts and one significant digit are glued)
wide_lost = {name: per_flight("terrain, report's prior", name)[1] for name in wp.index}
n_wide = len(terrain_runs["terrain, report's prior"])
print(f"report's prior, {n_wide} flights: flights diverged (final error > {DIVERGED_ERROR:.0f} m)")
for name, lost in wide_lost.items():
    r = evidence.rate(lost)
    key = name.replace("PF N=", "pf").lower()
    glue(f"terrain_wide_{key}_lost", r.estimate, display=False)
    glue(f"terrain_wide_{key}_lost_low", r.low, display=False)
    glue(f"terrain_wide_{key}_lost_high", r.high, display=False)
    print(f"  {name:10s} {r}")
few, many = wp.index[wp.index.str.startswith("PF")][[0, -1]]
more = evidence.paired_rates(wide_lost[few], wide_lost[many])
glue("terrain_wide_pf_more_p", more.pvalue, display=False)
glue("terrain_wide_pf_more_only_few", more.only_a, display=False)
glue("terrain_wide_pf_more_only_many", more.only_b, display=False)
print(f"  {few} vs {many}: {more}")
ukf_nis = float(f"{wp.loc['UKF', 'nis_median'] / chi2_1:.1g}")
glue("terrain_wide_ukf_nis_over_chi2", ukf_nis, display=False)
# its 95 % bootstrap interval over the flights (the NIS of all steps of the resampled flights), one digit
j_ukf = [label(t) for t in terrain_runs["terrain, report's prior"][0]].index("UKF")
ukf_nis_flights = np.array([run[j_ukf].nis[TERRAIN_BURN_IN:] for run in terrain_runs["terrain, report's prior"]])
with np.errstate(invalid="ignore"):
    _, ukf_nis_low, ukf_nis_high = evidence.run_interval(
        lambda r: np.nanmedian(ukf_nis_flights[r]) / chi2_1, n_wide)
ukf_nis_low, ukf_nis_high = float(f"{ukf_nis_low:.1g}"), float(f"{ukf_nis_high:.1g}")
glue("terrain_wide_ukf_nis_over_chi2_low", ukf_nis_low, display=False)
glue("terrain_wide_ukf_nis_over_chi2_high", ukf_nis_high, display=False)
print(f"  UKF NIS median / chi2_1 median: {ukf_nis:.1g} (95 % bootstrap interval over the {n_wide} flights "
      f"{ukf_nis_low:.1g} to {ukf_nis_high:.1g})")

# %% [markdown]
# Run times of the terrain filters (not compared when the notebook is tested). On each flight
# of the study the filters ran one after the other (the particle filters, then the EKF and the
# UKF), so each filter's time is divided by the EKF's on the same flight: median ratio,
# 95 % bootstrap interval and Wilcoxon signed-rank test (`pfcourse.evidence.paired`). A Kalman filter
# that leaves the map stops there, so on the report's prior its time covers fewer steps. The
# accuracy-against-cost figures below place each filter at its median run time per step over
# the flights; the ratios with their intervals are these.

# %% tags=["nbval-ignore-output"]
for name, table in terrain_tables.items():
    flights = terrain_runs[name]
    labels = [label(t) for t in flights[0]]
    flight_seconds = {lab: np.array([run[j].seconds for run in flights]) for j, lab in enumerate(labels)}
    print(f"{name}, {len(flights)} flights: run time per step (median), ratio to the EKF on the same flight")
    for lab, sec in flight_seconds.items():
        line = f"  {lab:10s} {1000 * np.median(sec) / len(flights[0][0].error):7.3f} ms per step"
        if lab != "EKF":
            line += f"   / EKF: {evidence.paired(sec, flight_seconds['EKF'], ratio=True)}"
        print(line)

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
for ax, (name, table) in zip(axes, terrain_tables.items()):
    accuracy_cost(table, ax, f"{name}, {len(terrain_runs[name])} flights")
assert not (clashes := overlapping_texts(fig)), clashes
plt.show()

# %% [markdown]
# **Small prior.** The picture of the robot again: every filter tracks every flight (diverged
# flights, all filters together: {glue:text}`terrain_small_lost:d`) to a few tens of metres
# (median RMSE {glue:text}`terrain_small_rmse_min:.0f` to {glue:text}`terrain_small_rmse_max:.0f` m),
# and the EKF has the smallest median RMSE with the fewest model evaluations. Flight by flight,
# on {glue:text}`terrain_small_flights:d` flights, its lead over the UKF is resolved (the UKF's
# RMSE is {glue:text}`terrain_small_ukf_over_ekf:.2f` times the EKF's: median paired ratio,
# 95 % interval {glue:text}`terrain_small_ukf_over_ekf_low:.2f`-{glue:text}`terrain_small_ukf_over_ekf_high:.2f`,
# Wilcoxon p = {glue:text}`terrain_small_ukf_over_ekf_p:.2g`), its lead over the particle filter
# is not (with $N = 1000$: {glue:text}`terrain_small_pf1000_over_ekf:.2f`,
# {glue:text}`terrain_small_pf1000_over_ekf_low:.2f`-{glue:text}`terrain_small_pf1000_over_ekf_high:.2f`,
# p = {glue:text}`terrain_small_pf1000_over_ekf_p:.2g`). In measurement space all filters are
# consistent (NIS medians close to the $\chi^2_1$ median, {glue:text}`chi2_1_median:.2f`, and the
# run-averaged NIS in its band at a fraction {glue:text}`terrain_small_nis_in_min:.2f` of the
# steps or more; the lowest has a 95 % bootstrap interval over the flights of
# {glue:text}`terrain_small_nis_in_min_low:.2f`-{glue:text}`terrain_small_nis_in_min_high:.2f`).
# In state space the Kalman filters are conservative (NEES median below the
# $\chi^2_4$ median, {glue:text}`chi2_4_median:.2f`, and the run-averaged NEES below its band at a
# fraction {glue:text}`terrain_small_ekf_nees_below:.2f` of the steps for the EKF,
# {glue:text}`terrain_small_ukf_nees_below:.2f` for the UKF, fractions that
# {glue:text}`terrain_small_flights:d` flights pin down poorly: 95 % bootstrap intervals
# {glue:text}`terrain_small_ekf_nees_below_low:.2f`-{glue:text}`terrain_small_ekf_nees_below_high:.2f`
# and {glue:text}`terrain_small_ukf_nees_below_low:.2f`-{glue:text}`terrain_small_ukf_nees_below_high:.2f`): every filter allows for a process noise
# $Q_f$ that the true, noise-free flight does not have. That is a modelling choice, not a filter
# failure. The particle filter with $N = 100$ seems to err the other way, as on the robot: its
# run-averaged NEES lies above the band at a fraction
# {glue:text}`terrain_small_pf100_nees_above:.2f` of the steps, but over
# {glue:text}`terrain_small_flights:d` flights that fraction is not established (95 % bootstrap
# interval {glue:text}`terrain_small_pf100_nees_above_low:.2f`-{glue:text}`terrain_small_pf100_nees_above_high:.2f`).
#
# **The report's prior.** The order reverses. The EKF and UKF lose almost every flight
# ({glue:text}`terrain_wide_ekf_lost:.0%` and {glue:text}`terrain_wide_ukf_lost:.0%` of
# {glue:text}`terrain_wide_flights:d`; Wilson intervals printed above): a single Gaussian has to pick one of the candidate places, and the local
# slope of the terrain at a wrong guess says nothing about where the right one is. The UKF's
# nine sigma points sample the terrain over the prior's extent rather than its slope at one
# point, but nine points and one covariance cannot describe several separate modes
# (exercise {ref}`ex-kalman-ukf`). The particle filter is the only filter whose divergence
# rate falls as $N$ grows in this table, from {glue:text}`terrain_wide_pf300_lost:.0%` at
# $N = 300$ to {glue:text}`terrain_wide_pf3000_lost:.0%` at $N = 3000$ (Wilson interval
# {glue:text}`terrain_wide_pf3000_lost_low:.0%` to {glue:text}`terrain_wide_pf3000_lost_high:.0%`).
# On {glue:text}`terrain_wide_flights:d` flights that fall is a strong hint, not a proof: the
# flights lost only with the fewer particles and only with the more number
# {glue:text}`terrain_wide_pf_more_only_few:d` and {glue:text}`terrain_wide_pf_more_only_many:d`
# (exact McNemar p = {glue:text}`terrain_wide_pf_more_p:.2g`). With $N = 3000$ it still loses
# a large share of the flights: the chapter on the remedies ({doc}`../part2/terrain_cure`)
# measures {glue:text}`../part2/terrain_cure.ipynb::terrain_baseline_diverged:.0%` over
# {glue:text}`../part2/terrain_cure.ipynb::terrain_baseline_runs:d` flights, and
# {glue:text}`../part2/terrain_cure.ipynb::terrain_boot30k_diverged:.0%` with $N = 30\,000$.
# No filter is consistent here: lost flights dominate the run-averaged NEES and NIS. Note
# the UKF: its NIS median is only about {glue:text}`terrain_wide_ukf_nis_over_chi2:.0f` times the
# $\chi^2_1$ median (95 % bootstrap interval over the flights
# {glue:text}`terrain_wide_ukf_nis_over_chi2_low:.1g` to
# {glue:text}`terrain_wide_ukf_nis_over_chi2_high:.1g`, one significant digit) while it is lost in nearly every flight. A moderate NIS does not prove that a filter sits on the right mode;
# the innovation check is a weak alarm here.

# %% [markdown]
# ## 4. Which filter? A decision table
#
# Each recommendation cites the measurement above that supports it. The table is built
# from the computed results, so it changes if they do.

# %%
lin = slopes["every component moves"]
lin_static = slopes["report's static landmarks"]
static_bias = bias["report's static landmarks"][0]
rob = robot_table
sp = terrain_tables["terrain, small prior"]
wp = terrain_tables["terrain, report's prior"]
best_pf = wp[wp.index.str.startswith("PF")]["diverged"].idxmin()
rows = [
    ("Linear Gaussian (landmark model, §1)", "Kalman filter",
     f"exact; the PF's mean error falls as N^{lin['mean_error'][0]:+.2f} (theory: -1/2) and is "
     f"{err_1000 / kf_sd:.2f} posterior s.d. at N = 1000; with static landmarks N^{lin_static['mean_error'][0]:+.2f} "
     f"and a log-likelihood bias of {static_bias:+.0f} nats at N = {N_LINEAR[0]}",
     "1 vs N"),
    ("Mildly nonlinear, one bump (robot, §2)", "EKF (UKF equal, dearer)",
     f"median RMSE EKF {rob.loc['EKF', 'rmse_q50']:.3f} m vs PF N=1000 {rob.loc['PF N=1000', 'rmse_q50']:.3f} m; "
     f"NEES in band EKF {rob.loc['EKF', 'nees_in_band']:.2f} vs PF N=1000 {rob.loc['PF N=1000', 'nees_in_band']:.2f} "
     f"(NIS in band: {rob.loc['EKF', 'nis_in_band']:.2f} vs {rob.loc['PF N=1000', 'nis_in_band']:.2f})",
     "1 (+ Jacobians) vs N"),
    ("Mildly nonlinear (terrain, small prior, §3)", "EKF",
     f"diverged EKF {sp.loc['EKF', 'diverged']:.0%}, UKF {sp.loc['UKF', 'diverged']:.0%}; median RMSE EKF "
     f"{sp.loc['EKF', 'rmse_q50']:.0f} m vs PF N=1000 {sp.loc['PF N=1000', 'rmse_q50']:.0f} m",
     "1 vs N"),
    ("Multimodal (terrain, report's prior, §3)", f"particle filter, N as large as affordable ({best_pf})",
     f"diverged EKF {wp.loc['EKF', 'diverged']:.0%}, UKF {wp.loc['UKF', 'diverged']:.0%}, "
     + ", ".join(f"{i} {v:.0%}" for i, v in wp[wp.index.str.startswith('PF')]['diverged'].items()),
     "N vs 1 or 9"),
]
decision = pd.DataFrame(rows, columns=["problem", "pick", "evidence (computed above)", "model evaluations per step"])
display(HTML(decision.to_html(index=False)))

# %% [markdown]
# Two remarks on using the table.
#
# - **Check consistency on real data with the NIS.** A filter that is accurate in simulation
#   may be over-confident on data; the NIS needs no ground truth. But, as the robot's
#   particle filter showed, a NIS in its band does not prove that the state covariance is
#   right when the measurement noise dominates $S_k$.
# - **Cost ratios depend on the implementation.** In this book the particle filter's inner
#   loops are compiled (`pfcourse.kernels`) and the Kalman filters call `filterpy` in
#   Python once per step (the UKF once per sigma point), so the measured ratios (timing
#   cells) are far smaller than the evaluation counts suggest; a compiled EKF would change
#   the ratios again, not the accuracy or the consistency.
#
# ## Try it
#
# Pick a scenario and a number of particles: the left panel shows the position error of the
# particle filter and of the two Kalman filters (median over the runs and the 10-90 %
# band), the right panel the run-averaged NEES with its 95 % band. The panel reuses the runs
# above (no new computation), so a redraw is immediate; for $N$ not run in a scenario, the
# nearest $N$ that was is shown.

# %%
scenario_runs = {"robot": (robot_runs, 3), **{k: (v, 4) for k, v in terrain_runs.items()}}
FILTER_COLORS = {"pf": COLORS["estimate"], "ekf": COLORS["kalman"], "ukf": "tab:purple"}


def draw(scenario="robot", n_particles=300):
    runs, dim_x = scenario_runs[scenario]
    available = [t.n_particles for t in runs[0] if t.filter == "pf"]
    n = min(available, key=lambda a: abs(np.log(a / n_particles)))
    picks = [j for j, t in enumerate(runs[0]) if t.filter != "pf" or t.n_particles == n]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    fig.subplots_adjust(left=0.06, right=0.99, bottom=0.13, top=0.91, wspace=0.2)  # cheaper than tight_layout
    steps = np.arange(1, len(runs[0][0].error))
    for j in picks:
        t0 = runs[0][j]
        err = np.array([r[j].error[1:] for r in runs])
        with np.errstate(invalid="ignore"):
            q10, q50, q90 = np.quantile(err, [0.1, 0.5, 0.9], axis=0, method="inverted_cdf")
            avg_nees = np.mean([r[j].nees[1:] for r in runs], axis=0)
        ax1.fill_between(steps, q10, q90, color=FILTER_COLORS[t0.filter], alpha=0.15)
        ls = "--" if t0.filter == "ekf" else "-"
        ax1.plot(steps, q50, ls, color=FILTER_COLORS[t0.filter], label=label(t0))
        ax2.plot(steps, avg_nees, ls, color=FILTER_COLORS[t0.filter], lw=1, label=label(t0))
    lo, hi = chi2_band(dim_x, len(runs))
    ax2.axhspan(lo, hi, color="0.85", label=f"95 % band, {len(runs)} runs")
    ax1.set_xlabel("time (s)")
    ax2.set_xlabel("time (s)")
    ax1.set_ylabel("position error (m)")
    ax2.set_ylabel(f"NEES averaged over {len(runs)} runs")
    plain_log_axis(ax1, "y", subs=(1.0, 2.0, 5.0))  # as plain_log, without minor ticks (a faster redraw)
    plain_log_axis(ax2, "y", subs=(1.0, 2.0, 5.0))
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    shown = f"N = {n}" + ("" if n == n_particles else f" (nearest to {n_particles} that was run)")
    ax1.set_title(f"{scenario}, {shown}: median and 10-90 %", fontsize=10)


# %% tags=["nbval-ignore-output"]
panel = control_panel(
    draw,
    columns=2,
    grid={"scenario": tuple(scenario_runs), "n_particles": (100, 300, 1000, 3000)},
    scenario=widgets.Dropdown(options=list(scenario_runs), value="robot", description="scenario"),
    n_particles=widgets.Dropdown(options=[100, 300, 1000, 3000], value=300, description="particles N"),
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-kalman-slope
# The fitted slopes of the linear Gaussian section come from {glue:text}`linear_runs:d` runs per
# $N$. Explain why the error of the
# log-likelihood estimate has, besides its $1/\sqrt N$ spread, a *negative* mean that shrinks
# like $1/N$, although the likelihood estimate $\hat p(z_{0:K})$ itself is unbiased.
# ```
#
# ```{solution} ex-kalman-slope
# :class: dropdown
# $\hat p$ is unbiased, $E[\hat p] = p$, but the logarithm is concave, so by Jensen's
# inequality $E[\log \hat p] \le \log p$. Writing $\hat p = p (1 + \varepsilon)$ with
# $\operatorname{Var} \varepsilon = \sigma^2 / N$, a second-order expansion gives
# $E[\log \hat p] - \log p \approx -\sigma^2 / (2N)$: a bias of order $1/N$, smaller than the
# spread $\sigma / \sqrt N$ for large $N$. With the report's static landmarks $\sigma^2$ is
# huge, so the bias dominates over the range of $N$ computed (the mean errors printed in
# the linear Gaussian section).
# ```
#
# ```{exercise}
# :label: ex-kalman-nis
# In the robot study, the particle filter's NIS is close to its consistent value (the
# $\chi^2_2$ median) while its NEES is far above the $\chi^2_3$ median.
# Using $S_k = \operatorname{Cov}(h(x_k^i)) + R$, explain why the NIS is the less sensitive
# check here. Which change of the scenario would make the NIS more sensitive?
# ```
#
# ```{solution} ex-kalman-nis
# :class: dropdown
# With errors of a few decimetres the spread of the predicted measurements
# $\operatorname{Cov}(h(x_k^i))$ is small next to $R$ ($0.5$ m in range, $1°$ in bearing), so
# $S_k \approx R$ whatever the particle filter believes about its state: an under-estimated
# state covariance changes $S_k$ little, and the innovation, dominated by the measurement
# noise, is as large as expected. The NIS becomes sensitive when the state uncertainty
# projected into measurement space is comparable to $R$: more accurate sensors (smaller
# $R$), rarer measurements (`dt_meas` larger, so the prediction spreads more), or a gap in the
# measurements.
# ```
#
# ```{exercise}
# :label: ex-kalman-ukf
# Why does the UKF not rescue the terrain problem from the report's prior, although it does
# not linearise? Think of what $2d + 1 = 9$ sigma points can represent.
# ```
#
# ```{solution} ex-kalman-ukf
# :class: dropdown
# The UKF still assumes that the prior and the posterior are Gaussian: its sigma points
# match a mean and a covariance, and the update is the Kalman update with the sigma points'
# statistics. Spread over a {glue:text}`terrain_wide_prior_km:.1f` km prior, the nine points sample the terrain at nine places;
# their predicted altimeter readings give a variance and a cross-covariance that average
# over the whole region, and the update moves the estimate along that average slope. A
# multimodal posterior, several separate places that fit the readings, cannot be written as
# one mean and one covariance, whatever points are used to compute them. The `diverged`
# column of the terrain section measures the result.
# ```

# %% tags=["nbval-ignore-output"]
print(f"chapter computed in {time.perf_counter() - chapter_start:.0f} s on this machine")
