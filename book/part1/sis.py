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
# The Kalman filter is exact for the landmark model; a particle filter is not, and this is
# precisely why the model is a good place to learn one: every particle estimate can be
# compared with the exact posterior. This chapter writes sequential importance sampling
# (SIS), runs it with the simulator's own noise models, and watches it fail.
#
# (sis-algorithm)=
# ## The SIS algorithm (lab question 3)
#
# (Notation: we write $z_{1:k}$ because in this model the first measurement comes after the
# first move; `pfcourse`'s docstrings say $z_{0:k}$, since the engine also accepts a
# measurement at time $0$.)
#
# SIS represents $p(x_k \mid z_{1:k})$ by $N$ particles $x_k^i$ with normalised weights
# $W_k^i$. It needs an **importance function** $q(x_k \mid x_{k-1}, z_k)$ from which new
# particles are drawn; here, as in the lab, we take the transition density itself,
# $q = p(x_k \mid x_{k-1}) = \mathcal N(F x_{k-1} + B, Q_w)$ (the *bootstrap* choice of
# {cite:t}`gordon1993`). With it, the weight update reduces to the likelihood.
#
# 1. **Initialise.** Draw $x_0^i \sim \mathcal N(m_{X0}, P_{X0})$ and set $W_0^i = 1/N$.
# 2. **For** $k = 1, \dots, K-1$:
#    1. *propose*: $x_k^i = F x_{k-1}^i + B + w_k^i$, $w_k^i \sim \mathcal N(0, Q_w)$;
#    2. *weight*: if landmarks $V_k$ are in view, with $H_k$, $R_k$ of that step,
#       $\log \tilde w_k^i = \log W_{k-1}^i + \log \mathcal N(z_k;\, H_k x_k^i,\, R_k)$;
#       otherwise $\tilde w_k^i = W_{k-1}^i$;
#    3. *normalise*: $W_k^i = \exp\big(\log \tilde w_k^i - \operatorname{logsumexp}_j \log \tilde w_k^j\big)$;
#    4. *estimate*: $\hat m_k = \sum_i W_k^i x_k^i$,
#       $\hat P_k = \sum_i W_k^i (x_k^i - \hat m_k)(x_k^i - \hat m_k)^\top$,
#       $\mathrm{ESS}_k = 1 / \sum_i (W_k^i)^2$.
#
# The weights are kept in the log domain: with four measured coordinates of standard
# deviation $0.1$ m, a particle whose robot is $1$ m off in $x$ misplaces both landmarks' $x$
# by $1$ m: its likelihood is lower by a factor $e^{-2 \times 1^2 / (2 \times 0.1^2)} = e^{-100}$,
# and a product of a few such factors can underflow to zero in floating point. How often the
# lab's linear-domain weights actually fail is measured in {ref}`log-domain`. In `pfcourse` this algorithm is
# `ParticleFilter(model, N, threshold=0)` (threshold $0$: never resample); the same algorithm in
# twenty lines of NumPy, giving the same numbers, is in {ref}`write-sis`.

# %%
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import HTML, display
from myst_nb import glue

from pfcourse import evidence
from pfcourse.filter import ParticleFilter
from pfcourse.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.figures.bands import posterior_bands
from pfcourse.figures.clouds import animate_clouds
from pfcourse.style import COLORS, ellipse_patch, plain_log_axis, use_style
from pfcourse.figures.widgets import control_panel, particle_slider, scale_slider, seed_box

use_style()
LABELS = ["robot x", "robot y", "L1 x", "L1 y", "L2 x", "L2 y"]
scenario = quadrant_scenario()
model = scenario.model()  # the simulator's own noise models
sim = simulate(scenario, rng=2024)
kf = kalman_filter(model, sim.measurements)

# %% [markdown]
# ## One run with the lab's $N = 100$ particles (lab questions 4 and 5)

# %%
sis = ParticleFilter(model, 100, threshold=0.0)
res = sis.run(sim.measurements, rng=1, store_particles=True)
posterior_bands(sim.T, sim.truth, kf, res, LABELS, "SIS", "SIS (N = 100) against the exact posterior; dashed: truth")
plt.show()

# %% [markdown]
# Within a few steps the SIS band (red) shrinks to a line: the "posterior covariance" of the
# cloud goes to zero while the exact one (green) does not. The estimate then follows the
# robot's motion with the error of whichever particle dominates at the time; the band
# reopens briefly when the dominant particle changes, which it does
# {glue:text}`sis_dominant_changes` times after step $5$ in this run (counted below). The
# effective sample size tells the same story in numbers.

# %%
print("ESS at the first 10 steps:", np.round(res.ess[:10], 1))
print(f"largest weight at step 10: {res.weights[10].max():.4f}")
leader = res.weights.argmax(axis=1)
changes = int(np.sum(leader[6:] != leader[5:-1]))
print(f"the dominant particle changes {changes} times after step 5 "
      f"(at steps {np.flatnonzero(leader[6:] != leader[5:-1]) + 6})")
glue("sis_dominant_changes", changes, display=False)
first_sighting = int(np.flatnonzero(sim.seen.any(axis=1))[0])
print(f"first landmark sighting at step {first_sighting}: ESS {res.ess[first_sighting]:.1f}")
glue("sis_first_sighting_step", first_sighting, display=False)
glue("sis_first_sighting_ess", float(res.ess[first_sighting]), display=False)
for k in (0, 5, 49):
    print(f"k = {k:2d}: trace of the SIS covariance {np.trace(res.cov[k]):.2e} m^2, "
          f"Kalman {np.trace(kf.cov[k]):.2e} m^2")

# %% [markdown]
# The weight histograms show where the mass goes: at step $k = 0$ every weight is $1/N$; after a
# couple of measurements most weights are negligible; soon one particle holds it all.

# %%
steps = [0, 2, 4, 8]
fig, axes = plt.subplots(1, 4, figsize=(10, 2.8), sharey=True)
for ax, k in zip(axes, steps):
    ax.hist(np.log10(np.maximum(res.weights[k], 1e-30)), bins=30, range=(-30, 0),
            color=COLORS["particles"])
    ax.set_title(f"k = {k}, ESS = {res.ess[k]:.1f}")
    ax.set_xlabel(r"$\log_{10} W_k^i$")
axes[0].set_ylabel("number of particles")
plt.show()

# %% [markdown]
# ## Ellipses collapsing
#
# The animation shows the cloud (dot size proportional to weight) and the 95 % ellipses of
# the robot and of the two landmarks: SIS in red, the exact posterior in green. Scrub it:
# the red ellipses vanish within a few steps while the green ones shrink only as
# information arrives.

# %%
HTML(animate_clouds({"SIS, N = 100": res}, kf, sim.truth, range(0, 30), interval=200).to_jshtml())

# %% [markdown]
# (sis-degeneracy)=
# ## Degeneracy in numbers: how fast does the ESS reach one particle? (lab question 5)
#
# One run shows the collapse; does it depend on the run, and does a larger $N$ save SIS?
# For $N = 100$, $1000$ and $10\,000$ we run SIS on {glue:text}`sis_degeneracy_runs:d` independent
# simulations (seeds $s = 0, 1, \dots$, filter seeds $1000 + s$) and record the first step at which
# $\mathrm{ESS} < 2$, "about one particle". Only the first {glue:text}`sis_horizon:d` steps are
# run, since that is where it happens.

# %%
n_runs, horizon = 50, 15
N_values = (100, 1000, 10_000)
ess = {N: np.empty((n_runs, horizon)) for N in N_values}
for seed in range(n_runs):
    Z = simulate(scenario, rng=seed).measurements[:horizon]
    for N in N_values:
        ess[N][seed] = ParticleFilter(model, N, threshold=0.0).run(Z, rng=1000 + seed).ess


def first_below(e, level=2.0):
    hit = e < level
    return np.where(hit.any(axis=1), hit.argmax(axis=1), horizon).astype(float)


for N in N_values:
    f = first_below(ess[N])
    print(f"N = {N:6d}: ESS < 2 first at step {np.median(f):.0f} (median), "
          f"10-90 % of runs {np.percentile(f, 10):.0f}-{np.percentile(f, 90):.0f}, "
          f"never within {horizon} steps in {np.sum(f == horizon)} of {n_runs} runs")
delay = evidence.paired(first_below(ess[10_000]), first_below(ess[100]))
print(f"delay of N = 10000 over N = 100, run by run (steps): {delay}")
per_decade = delay.median / np.log10(10_000 / 100)
medians = {N: float(np.median(first_below(ess[N]))) for N in N_values}
glue("sis_degeneracy_runs", n_runs, display=False)
glue("sis_horizon", horizon, display=False)
glue("sis_median_first_100", medians[100], display=False)
glue("sis_median_first_10000", medians[10_000], display=False)
glue("sis_delay_median", delay.median, display=False)
glue("sis_delay_low", delay.low, display=False)
glue("sis_delay_high", delay.high, display=False)
glue("sis_delay_pvalue", delay.pvalue, display=False)
glue("sis_decades_needed", int(round((horizon - medians[10_000]) / per_decade)), display=False)

# %%
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
ax1.legend(fontsize=8, loc="lower left")  # the curves start at the top left
ax2.boxplot([first_below(ess[N]) for N in N_values], tick_labels=[str(N) for N in N_values])
ax2.set_xlabel("number of particles N")
ax2.set_ylabel("first step with ESS < 2")
ax2.set_title(f"Time to degeneracy, {n_runs} runs")
plt.show()

# %% [markdown]
# In the run above ($N = 100$) the ESS drops to {glue:text}`sis_first_sighting_ess:.1f` at the
# *first* sighting of a landmark (step {glue:text}`sis_first_sighting_step:d`). Multiplying $N$ by
# $100$ buys only a couple of steps: the median time to degeneracy moves from step
# {glue:text}`sis_median_first_100:.0f` to step {glue:text}`sis_median_first_10000:.0f`, about one
# step per factor of ten (run by run, the median delay is {glue:text}`sis_delay_median:.0f` steps,
# 95 % interval {glue:text}`sis_delay_low:.0f` to {glue:text}`sis_delay_high:.0f`, Wilcoxon
# $p$ = {glue:text}`sis_delay_pvalue:.1g`). This is the general behaviour of SIS: the variance of
# the weights grows (roughly exponentially) with time, and here each step with a visible
# landmark multiplies the weights by a likelihood that is sharp ($0.1$ m noise) compared with
# the prior spread of the landmarks ($\sqrt{0.2} \approx 0.45$ m).
#
# ## How to choose N, and which importance function (lab question 4)
#
# - **The importance function** used here is the transition $p(x_k \mid x_{k-1})$, the only one
#   that needs nothing but a simulator. It ignores $z_k$: particles are placed blindly, then
#   judged. {doc}`proposals` builds the best one, $p(x_k \mid x_{k-1}, z_k)$.
# - **The number of particles** should make the ESS after the updates large enough for the
#   Monte Carlo error $\approx \sqrt{\operatorname{tr} P / \mathrm{ESS}}$ to be small compared
#   with the posterior spread. For SIS no $N$ achieves that here: the measurements above show
#   the ESS reaches about one particle in a handful of steps for every $N$ that runs in reasonable time,
#   because the number needed grows exponentially with the number of informative steps.
# - **What goes wrong, and the fix**: the weights degenerate. The fix is to resample when the
#   ESS falls too low ({doc}`sir`), and to propose better ({doc}`proposals`).
#
# ## Try it
#
# The panel runs SIS for the chosen $N$, measurement noise scale (the simulator and the
# filter use the same scaled $R_v$) and seed, and plots the ESS and the landmark $1$ estimate
# against the Kalman posterior. Does broader measurement noise change the collapse? The runs
# of the study above ($N = 100$, first {glue:text}`sis_horizon:d` steps) again, with the
# measurement noise's standard deviation doubled (the panel's largest scale), same seeds:

# %%
sc2 = scenario.with_(Rv=2.0**2 * scenario.Rv)
ess_broad = np.array([ParticleFilter(sc2.model(), 100, threshold=0.0).run(simulate(sc2, rng=seed).measurements[:horizon],
                                                                          rng=1000 + seed).ess
                      for seed in range(n_runs)])
first_broad, first_base = first_below(ess_broad), first_below(ess[100])
slower = evidence.paired(first_broad, first_base)
collapsed_broad = evidence.rate(first_broad < horizon)
n_later, n_earlier, sign_p = evidence.sign_test(first_base, first_broad)  # base < broad: later with x2
print(f"N = 100, Rv sd x2 vs x1: ESS < 2 first at step {np.median(first_broad):.0f} vs {np.median(first_base):.0f} "
      f"(median); delay run by run (steps): {slower}")
print(f"sign test: the collapse comes later with the broader noise in {n_later} runs, earlier in {n_earlier}, "
      f"tied in {n_runs - n_later - n_earlier} (exact p = {sign_p:.1g})")
print(f"runs with ESS < 2 within {horizon} steps at Rv sd x2: {collapsed_broad}")
glue("sis_broad_later", n_later, display=False)
glue("sis_broad_earlier", n_earlier, display=False)
glue("sis_broad_sign_p", sign_p, display=False)
glue("sis_broad_first", float(np.median(first_broad)), display=False)
glue("sis_broad_delay", slower.median, display=False)
glue("sis_broad_delay_low", slower.low, display=False)
glue("sis_broad_delay_high", slower.high, display=False)
glue("sis_broad_delay_p", slower.pvalue, display=False)
glue("sis_broad_collapsed", collapsed_broad.estimate, display=False)
glue("sis_broad_collapsed_low", collapsed_broad.low, display=False)

# %% [markdown]
# Doubling the noise slows the collapse, by little: the ESS falls below $2$ first at step
# {glue:text}`sis_broad_first:.0f` in the median run, against {glue:text}`sis_median_first_100:.0f`;
# run by run the collapse comes later in {glue:text}`sis_broad_later:d` of the
# {glue:text}`sis_degeneracy_runs:d` runs and earlier in {glue:text}`sis_broad_earlier:d` (sign test
# $p$ = {glue:text}`sis_broad_sign_p:.0e`; median delay {glue:text}`sis_broad_delay:.0f` step,
# 95 % interval {glue:text}`sis_broad_delay_low:.0f` to {glue:text}`sis_broad_delay_high:.0f`, Wilcoxon
# $p$ = {glue:text}`sis_broad_delay_p:.0e`). It does not stop it: the ESS still falls below $2$
# within {glue:text}`sis_horizon:d` steps in {glue:text}`sis_broad_collapsed:.0%` of the runs
# (95 % Wilson interval from {glue:text}`sis_broad_collapsed_low:.0%`).

# %%
def draw_sis(n_particles, noise_scale, seed):
    sc = scenario.with_(Rv=noise_scale**2 * scenario.Rv)
    s = simulate(sc, rng=seed)
    m = sc.model()
    r = ParticleFilter(m, n_particles, threshold=0.0).run(s.measurements, rng=seed + 1)
    ref = kalman_filter(m, s.measurements)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.4))
    a1.plot(s.T, r.ess, color=COLORS["estimate"])
    plain_log_axis(a1, "y")
    a1.set_xlabel("time t (s)")
    a1.set_ylabel("ESS (particles)")
    a1.set_ylim(0.8, n_particles * 1.2)
    a2.plot(s.T, ref.mean[:, 2], color=COLORS["kalman"], label="Kalman")
    a2.plot(s.T, r.mean[:, 2], color=COLORS["estimate"], label="SIS")
    a2.plot(s.T, s.truth[:, 2], "--", color=COLORS["truth"], label="truth")
    a2.set_xlabel("time t (s)")
    a2.set_ylabel("L1 x (m)")
    a2.legend(fontsize=8)


# %% tags=["nbval-ignore-output"]
display(control_panel(draw_sis, grid={"n_particles": (10, 100, 1000, 10000), "noise_scale": (0.5, 1.0, 2.0)},
                      n_particles=particle_slider(100),
                      noise_scale=scale_slider("Rv sd scale"), seed=seed_box(2024)))

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-sis-write
# (Lab question 3.) Write the SIS weight update for a step at which only landmark $1$ is in
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
# ```{exercise}
# :label: ex-sis-n
# (Lab question 4.) From the {glue:text}`sis_degeneracy_runs:d`-run statistics above, estimate how
# many particles SIS would need to keep an ESS of at least $2$ for {glue:text}`sis_horizon:d` steps.
# ```
#
# ```{solution} ex-sis-n
# :class: dropdown
# Each factor of ten in $N$ delays the median first step with $\mathrm{ESS} < 2$ by about one
# step, from the printed medians and the paired delay. Reaching {glue:text}`sis_horizon:d` steps
# from about {glue:text}`sis_median_first_10000:.0f` at $N = 10^4$ would, at that rate, take some
# {glue:text}`sis_decades_needed:d` more factors of ten beyond $N = 10^4$: SIS is hopeless here,
# and the cure is not more particles.
# ```
#
# ```{exercise}
# :label: ex-sis-code
# (Coding.) Take `my_filter` of {ref}`write-sis` with `threshold=0` and record, at each
# step, the largest normalised weight. Over seeds $0$ to $19$ with $N = 100$ and $N = 10^4$, at
# which step does it first exceed $0.99$? Compare with the ESS curves above.
# ```
#
# ```{solution} ex-sis-code
# :class: dropdown
# Add `top.append(W.max())` next to `esss.append(...)` and return it; then
# `np.argmax(np.array(top) > 0.99)` per run. With a hundred times more particles the step
# comes later, but still early in a $50$-step run, as the ESS curves showed: degeneracy is
# postponed, not cured.
# The engine gives the same number from `res.weights.max(axis=1)` with `store_particles=True`.
# ```
