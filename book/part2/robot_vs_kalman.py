# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # The robot: particle filter against EKF and UKF
#
# The previous chapter tracked the robot with a particle filter. Is it worth it? The
# classical answers to a nonlinear model are the **extended Kalman filter** (EKF), which
# linearizes the motion and measurement functions at the current estimate, and the
# **unscented Kalman filter** (UKF), which propagates a few deterministic *sigma points*
# through them {cite:p}`labbe2020`. Both keep one mean and one covariance. This chapter runs
# the three filters on *the same* simulated runs and compares them with statistics over many
# runs, not one.
#
# Both Kalman filters come from `filterpy` and read the same data as the particle filter
# (odometry rows and measurement rows $(j, r, b)$, NaN when absent); see
# `pfcourse.robot.kalman`. Two details matter for angles:
#
# - the measurement residual $z - h_j(\hat x)$ wraps its bearing to $(-\pi, \pi]$, and the
#   heading estimate is wrapped after every step;
# - in the UKF, the means of headings and bearings over sigma points are circular means,
#   and every difference between angles is wrapped.
#
# The EKF propagates the odometry noise with the Jacobian $G = \partial f/\partial u$:
# $P \leftarrow F P F^\top + G Q_\text{est} G^\top$; the UKF adds the same $G Q_\text{est}
# G^\top$ as additive process noise.

# %%
import matplotlib.pyplot as plt
import numpy as np
from myst_nb import glue

from pfcourse import evidence

from pfcourse.diagnostics import chi2_band
from pfcourse.filter import ParticleFilter
from pfcourse.style import COLORS, use_style
from pfcourse.robot.scenario import INITIAL_STD, RobotModel, simulate_robot
from pfcourse.experiments.robot import compare_filters
from pfcourse.robot.kalman import run_ekf, run_ukf
from pfcourse.robot.figures import robot_map

use_style()

# %% [markdown]
# ## One run first
#
# The three estimated paths on one run of the default scenario, zoomed on the start where
# the filters converge from the initial guess.

# %%
sim = simulate_robot(rng=3, n_steps=200)
model = RobotModel.for_simulation(sim)
pf = ParticleFilter(model, 300).run(sim.measurements, 3)
ekf = run_ekf(model, sim.measurements)
ukf = run_ukf(model, sim.measurements)
ax = robot_map(sim, {"particle filter": pf.mean, "EKF": ekf.mean, "UKF": ukf.mean}, odometry=True)
ax.set_xlim(-2.5, 3.5)
ax.set_ylim(-51, -44)
ax.set_title("First 200 s of one run")
plt.show()
print(f"largest distance between the EKF and UKF means: "
      f"{np.max(np.hypot(*(ekf.mean[:, :2] - ukf.mean[:, :2]).T)):.3f} m")

# %% [markdown]
# The EKF and UKF paths are nearly indistinguishable: with a measurement every second, the
# estimate is always within decimetres of the truth, and over a few decimetres the range
# and bearing functions are almost linear, so linearizing them costs nothing.
#
# ## Monte Carlo comparison
#
# Now {glue:text}`n_runs:d` seeded runs of {glue:text}`n_steps:d` s each of the default scenario (five landmarks in new random
# places every run, $N = 300$, $Q_\text{est} = 2 Q_\text{true}$,
# $R_\text{est} = 2 R_\text{true}$). For every run and filter we record the position and
# heading RMSE and the normalised estimation error squared,
# $\text{NEES}_k = e_k^\top P_k^{-1} e_k$, over the steps after a {glue:text}`burn_in_s:d` s transient. For a
# consistent filter, $\text{NEES}_k \sim \chi^2_3$, so its average over the {glue:text}`n_runs:d` runs at
# step $k$ must fall in a known band {cite:p}`barshalom2001`.

# %%
N_RUNS = 50
BURN_IN = 20
N_STEPS = 150
glue("n_runs", N_RUNS, display=False)
glue("n_steps", N_STEPS, display=False)
glue("burn_in_s", BURN_IN, display=False)
# The three filters of a run are timed one after the other, forward on even runs and backward on
# odd ones, so that a slow moment of the machine hits them alike (the results do not depend on the order).
runs = [compare_filters(seed, filters=("pf", "ekf", "ukf")[::1 if seed % 2 == 0 else -1], n_steps=N_STEPS,
                        burn_in=BURN_IN) for seed in range(N_RUNS)]
names = {"pf": "particle filter (N = 300)", "ekf": "EKF", "ukf": "UKF"}
legend = {"pf": "particle filter (N = 300)", "ekf": "EKF (hidden under the UKF)", "ukf": "UKF"}
colors = {"pf": COLORS["estimate"], "ekf": COLORS["kalman"], "ukf": "tab:purple"}


def column(key, attr):
    return np.array([getattr(r[key], attr) for r in runs])


failed = {k: int(column(k, "failed").sum()) for k in names}
print("runs in which a filter failed:", failed)
print(f"{'filter':28s} {'position RMSE (m)':>22s} {'heading RMSE (deg)':>22s} {'mean NEES':>18s}")
for key, label in names.items():
    pos = column(key, "position_rmse")
    head = np.degrees(column(key, "heading_rmse"))
    nees_mean = column(key, "mean_nees")
    q = lambda a: f"{np.median(a):.3f} [{np.quantile(a, 0.1):.3f}, {np.quantile(a, 0.9):.3f}]"
    print(f"{label:28s} {q(pos):>22s} {q(head):>22s} {np.median(nees_mean):6.2f} [{np.quantile(nees_mean, 0.1):.2f}, {np.quantile(nees_mean, 0.9):.2f}]")
print(f"(median [10 %, 90 % quantiles] over {N_RUNS} runs)")

# %% [markdown]
# Run time per run (seconds of wall-clock time on the machine that built this page; the
# output of this cell is not compared when the notebook is tested, since timings vary). The
# three filters of each run were timed side by side, in alternating order; each filter's time
# is divided by another's on the same run, and the ratios get a median, a 95 % bootstrap
# interval and a Wilcoxon signed-rank test (`pfcourse.evidence.paired`):

# %% tags=["nbval-ignore-output"]
for key, label in names.items():
    print(f"{label:28s} median {1000 * np.median(column(key, 'seconds')):7.1f} ms per {N_STEPS}-step run")
print(f"ratios of run times, {N_RUNS} runs timed side by side:")
for a, b in (("pf", "ekf"), ("ukf", "ekf"), ("ukf", "pf")):
    cmp = evidence.paired(column(a, "seconds"), column(b, "seconds"), ratio=True)
    print(f"  {a.upper()} / {b.upper()}: {cmp}")
    for suffix, value in (("", cmp.median), ("_low", cmp.low), ("_high", cmp.high)):
        glue(f"time_{a}_over_{b}{suffix}", value, display=False)

# %%
diff = column("pf", "position_rmse") - column("ekf", "position_rmse")
diff_u = column("ukf", "position_rmse") - column("ekf", "position_rmse")
print(f"PF minus EKF position RMSE: median {np.median(diff):+.3f} m, PF better in "
      f"{int(np.sum(diff < 0))} of {N_RUNS} runs")
print(f"UKF minus EKF position RMSE: largest |difference| {np.max(np.abs(diff_u)):.4f} m")
# paired tests over the runs (same seeds for the three filters): PF against EKF
pos_test = evidence.paired(column("pf", "position_rmse"), column("ekf", "position_rmse"))
head_test = evidence.paired(np.degrees(column("pf", "heading_rmse")), np.degrees(column("ekf", "heading_rmse")))
nees_test = evidence.paired(column("pf", "mean_nees"), column("ekf", "mean_nees"))
print("position RMSE (m), PF - EKF:", pos_test, "->", pos_test.verdict())
print("heading RMSE (deg), PF - EKF:", head_test, "->", head_test.verdict())
print("mean NEES, PF - EKF:", nees_test, "->", nees_test.verdict())
glue("pf_better_runs", int(np.sum(diff < 0)), display=False)
glue("pos_diff_median_m", pos_test.median, display=False)
glue("pos_diff_low_m", pos_test.low, display=False)
glue("pos_diff_high_m", pos_test.high, display=False)
glue("pos_diff_p", pos_test.pvalue, display=False)
glue("head_diff_median_deg", head_test.median, display=False)
glue("head_diff_low_deg", head_test.low, display=False)
glue("head_diff_high_deg", head_test.high, display=False)
glue("head_diff_p", head_test.pvalue, display=False)
glue("nees_diff_median", nees_test.median, display=False)
glue("nees_diff_low", nees_test.low, display=False)
glue("nees_diff_high", nees_test.high, display=False)
glue("nees_diff_p", nees_test.pvalue, display=False)
glue("ukf_ekf_max_diff_mm", float(1000 * np.max(np.abs(diff_u))), display=False)

# %%
fig, axes = plt.subplots(1, 3, figsize=(10, 3.8))
for i, (key, label) in enumerate(names.items()):
    for ax, values in zip(axes[:2], (column(key, "position_rmse"), np.degrees(column(key, "heading_rmse")))):
        jitter = np.random.default_rng(i).uniform(-0.15, 0.15, N_RUNS)
        ax.plot(i + jitter, values, ".", color=colors[key], alpha=0.5)
        ax.plot([i - 0.3, i + 0.3], [np.median(values)] * 2, "-", color="k", lw=2)
    steps = np.arange(BURN_IN, N_STEPS)
    mean_nees = np.mean([r[key].nees for r in runs], axis=0)
    axes[2].plot(steps, mean_nees, color=colors[key], lw=1, label=legend[key])
lo, hi = chi2_band(3, N_RUNS)
axes[2].axhspan(lo, hi, color="0.85", label=f"95 % band of χ²₃ / {N_RUNS} runs")
axes[2].set_ylim(0, None)
axes[2].set_xlabel("time (s)")
axes[2].set_ylabel(f"NEES averaged over {N_RUNS} runs")
axes[2].legend(fontsize=7, loc="upper right")
for ax, lab in zip(axes[:2], ("position RMSE per run (m)", "heading RMSE per run (deg)")):
    ax.set_xticks(range(3), ["PF", "EKF", "UKF"])
    ax.set_ylabel(lab)
axes[0].set_title(f"{N_RUNS} runs, black bar: median", fontsize=10)
plt.tight_layout()
plt.show()
inside = {k: float(np.mean((np.mean([r[k].nees for r in runs], axis=0) >= lo)
                           & (np.mean([r[k].nees for r in runs], axis=0) <= hi))) for k in names}
below = {k: float(np.mean(np.mean([r[k].nees for r in runs], axis=0) < lo)) for k in names}
print(f"chi2 band for the run-average of NEES: [{lo:.2f}, {hi:.2f}]")
print("fraction of steps inside the band:", {k: round(v, 2) for k, v in inside.items()})
print("fraction of steps below the band: ", {k: round(v, 2) for k, v in below.items()})
glue("pf_inside_band", inside["pf"], display=False)
glue("ekf_below_band", below["ekf"], display=False)
glue("ukf_below_band", below["ukf"], display=False)

# %% [markdown]
# What the numbers say, for this scenario:
#
# - **The EKF is slightly more accurate than the particle filter, with far less computation.**
#   Over the {glue:text}`n_runs:d` paired runs, the particle filter's position RMSE exceeds the EKF's
#   by a median of {glue:text}`pos_diff_median_m:.3f` m (95 % bootstrap interval
#   {glue:text}`pos_diff_low_m:.3f` to {glue:text}`pos_diff_high_m:.3f` m, Wilcoxon signed-rank
#   p = {glue:text}`pos_diff_p:.1g`; the particle filter is better in only {glue:text}`pf_better_runs:d` of the
#   {glue:text}`n_runs:d` runs), and its heading RMSE by a median of {glue:text}`head_diff_median_deg:.3f`° (interval
#   {glue:text}`head_diff_low_deg:.3f` to {glue:text}`head_diff_high_deg:.3f`°, p =
#   {glue:text}`head_diff_p:.1g`): real differences, but of about a centimetre and under a hundredth of a degree.
#   The EKF evaluates the model once per step, with its Jacobian, where the particle filter
#   evaluates it $N = 300$ times. In wall time the two are close on this page: the particle
#   filter's run takes {glue:text}`time_pf_over_ekf:.2f` times the EKF's (median ratio over the
#   {glue:text}`n_runs:d` runs timed side by side, 95 % interval
#   {glue:text}`time_pf_over_ekf_low:.2f`-{glue:text}`time_pf_over_ekf_high:.2f`; timing cell above),
#   but only because `filterpy`'s EKF runs each step in Python while the particle filter's
#   inner loops are compiled (`pfcourse.kernels`).
#   With a measurement every second and errors of a few decimetres, the posterior is close
#   to Gaussian and the linearization is accurate: the particle filter's Monte Carlo error
#   only adds noise to the estimate.
# - **The UKF brings nothing over the EKF here**: its position RMSE differs from the EKF's by at
#   most {glue:text}`ukf_ekf_max_diff_mm:.1f` mm in any run, and `filterpy`'s UKF, which calls the model in
#   Python once per sigma point, takes the longest per run: {glue:text}`time_ukf_over_ekf:.1f` times
#   the EKF's time ({glue:text}`time_ukf_over_ekf_low:.1f`-{glue:text}`time_ukf_over_ekf_high:.1f`) and
#   {glue:text}`time_ukf_over_pf:.1f` times the particle filter's
#   ({glue:text}`time_ukf_over_pf_low:.1f`-{glue:text}`time_ukf_over_pf_high:.1f`; median paired
#   ratios and 95 % intervals, timing cell).
# - **Consistency.** The EKF and UKF are conservative: their run-averaged NEES lies below
#   the χ² band at {glue:text}`ekf_below_band:.0%` (EKF) and {glue:text}`ukf_below_band:.0%` (UKF) of the steps,
#   as it should when a filter assumes twice the true noise
#   variances. The particle filter's NEES is higher (its time-averaged NEES exceeds the EKF's by a
#   median of {glue:text}`nees_diff_median:.2f` over the runs, 95 % interval
#   {glue:text}`nees_diff_low:.2f` to {glue:text}`nees_diff_high:.2f`, Wilcoxon p =
#   {glue:text}`nees_diff_p:.1g`) and its run average falls inside the band at
#   {glue:text}`pf_inside_band:.0%` of the steps. That is not better calibration but two errors
#   partly cancelling: the Monte Carlo error of $300$ particles adds to the estimation error
#   while the assumed noise inflates the covariance. Exercise {ref}`ex-robot-nees` removes
#   the inflation and separates the two effects.
#
# ## Where the Gaussian filters need care: a poor initial guess
#
# The comparison above is the Kalman filters' home ground. Widen the initial uncertainty to
# standard deviations of {glue:text}`wide_sd_m:.0f` m, {glue:text}`wide_sd_m:.0f` m and
# {glue:text}`wide_sd_rad:.1f` rad (about {glue:text}`wide_sd_deg:.0f`°), the prior of all three filters,
# and run {glue:text}`n_runs:d` shorter runs ({glue:text}`n_steps_wide:d` s), since the differences are made in the first steps.

# %%
wide = (5.0, 5.0, 0.5)
N_STEPS_WIDE = 60
runs_wide = [compare_filters(seed, n_steps=N_STEPS_WIDE, initial_std=wide) for seed in range(N_RUNS)]
wide_pos, wide_nees = {}, {}
for key, label in names.items():
    pos = wide_pos[key] = np.array([r[key].position_rmse for r in runs_wide])
    nees_mean = wide_nees[key] = np.array([r[key].mean_nees for r in runs_wide])
    print(f"{label:28s} position RMSE median {np.median(pos):.3f} m [90 % quantile {np.quantile(pos, 0.9):.3f}], "
          f"mean NEES median {np.median(nees_mean):.1f}")
wide_test = evidence.paired(wide_pos["pf"], wide_pos["ekf"], ratio=True)
print("position RMSE, PF / EKF:", wide_test, "->", wide_test.verdict())
volume_ratio = float(np.prod(np.array(wide) / np.array(INITIAL_STD)))
print(f"prior volume (product of the standard deviations) {volume_ratio:.0f} times that of the default prior")
glue("n_steps_wide", N_STEPS_WIDE, display=False)
glue("wide_sd_m", wide[0], display=False)
glue("wide_sd_rad", wide[2], display=False)
glue("wide_sd_deg", float(np.degrees(wide[2])), display=False)
glue("wide_volume_ratio", volume_ratio, display=False)
glue("wide_pf_rmse", float(np.median(wide_pos["pf"])), display=False)
glue("wide_ekf_rmse", float(np.median(wide_pos["ekf"])), display=False)
glue("wide_ukf_rmse", float(np.median(wide_pos["ukf"])), display=False)
glue("wide_ratio", wide_test.median, display=False)
glue("wide_ratio_low", wide_test.low, display=False)
glue("wide_ratio_high", wide_test.high, display=False)
glue("wide_ratio_p", wide_test.pvalue, display=False)
glue("wide_pf_nees", float(np.median(wide_nees["pf"])), display=False)
glue("wide_ekf_nees", float(np.median(wide_nees["ekf"])), display=False)

# %% [markdown]
# The ordering is reversed from what one might expect. The EKF and UKF converge from the
# wide prior without trouble (median position RMSE {glue:text}`wide_ekf_rmse:.2f` and
# {glue:text}`wide_ukf_rmse:.2f` m): a few measurements of different landmarks pin the state down
# before linearization errors accumulate. The particle filter with $N = 300$ is now the weak one:
# median position RMSE {glue:text}`wide_pf_rmse:.2f` m, a median of {glue:text}`wide_ratio:.1f` times
# the EKF's on the same run (95 % interval {glue:text}`wide_ratio_low:.1f` to
# {glue:text}`wide_ratio_high:.1f`, Wilcoxon p = {glue:text}`wide_ratio_p:.1g`, {glue:text}`n_runs:d`
# paired runs). It spreads $300$ particles over a prior volume {glue:text}`wide_volume_ratio:.0f` times
# larger than before (the product of the ratios of the standard deviations of $p_x$, $p_y$ and
# $\theta$), the first measurements leave a handful of
# them with weight, and resampling then concentrates the cloud on those, a little off and
# too confident (median NEES {glue:text}`wide_pf_nees:.0f`, against {glue:text}`wide_ekf_nees:.1f` for
# the EKF). This is the sample-impoverishment failure of the previous
# chapter, in a milder form; more particles fix it, at a price.
#
# The honest summary for this robot: when the initial guess is good, or merely Gaussian, an
# EKF does the job with a fraction of the computation. The particle filter earns its cost when the
# posterior is not one bump: global localization and the kidnapped robot (previous chapter,
# {doc}`global_localization`). A gap of $100$ s, readings every $5$ or $20$ s, or only one or two
# landmarks do not make it: the previous chapter runs the EKF beside the particle filter in those
# settings, and the EKF is as accurate or more in each.
#
# ## Exercises
#
# ```{exercise}
# :label: ex-robot-jacobian
# Derive the measurement Jacobian $H = \partial h_j / \partial x$ used by the EKF, for
# $(d_x, d_y) = \ell^j - p$ and $q = d_x^2 + d_y^2$. Check it against finite differences at
# one state with `pfcourse.robot.kalman.measurement_jacobian` and `pfcourse.robot.scenario.range_bearing`.
# ```
#
# ```{solution} ex-robot-jacobian
# :class: dropdown
# The range is $\sqrt q$, with $\partial \sqrt q/\partial p_x = -d_x/\sqrt q$ and
# $\partial \sqrt q / \partial p_y = -d_y / \sqrt q$; it does not depend on $\theta$. The bearing
# is $\operatorname{atan2}(d_y, d_x) - \theta$, whose derivatives are $d_y / q$ in $p_x$,
# $-d_x/q$ in $p_y$ and $-1$ in $\theta$. So
# $H = \begin{pmatrix} -d_x/\sqrt q & -d_y/\sqrt q & 0 \\ d_y/q & -d_x/q & -1\end{pmatrix}$.
# A central difference with step $10^{-6}$ agrees to about $10^{-9}$; take care to wrap the
# difference of the two bearings before dividing by the step.
# ```
#
# ```{exercise}
# :label: ex-robot-nees
# Why is the time-averaged NEES of all three filters below $3$ in the default comparison?
# What would you expect with $Q_\text{est} = Q_\text{true}$ and $R_\text{est} = R_\text{true}$?
# Check it with `compare_filters(seed, q_scale=1.0, r_scale=1.0, n_steps=150, burn_in=20)`
# over a few seeds.
# ```
#
# ```{solution} ex-robot-nees
# :class: dropdown
# The filters assume twice the true variances of both the odometry and the measurement
# errors, so their covariance $P_k$ is roughly twice the true error covariance and
# $e^\top P^{-1} e$ is roughly halved: about $1.5$ instead of $3$. With the true variances, the
# EKF and UKF, whose linearization is accurate here, give a time-averaged NEES close to $3$;
# the particle filter's is clearly larger, because its covariance estimated from $300$
# particles is noisy and its Monte Carlo error adds to the error $e_k$ without being fully
# accounted for in $P_k$.
# ```
