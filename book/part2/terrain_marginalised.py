# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Terrain navigation with altitude integrated out
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** how a terrain navigator samples only what it must: a Kalman filter for the
# altitude inside each particle (the marginalised particle filter), what it costs and how many
# flights it loses; the field's two-dimensional problem, where a grid filter is the exact answer;
# and how the same Kalman filter carries the map's error as a state.
#
# **You need** {doc}`terrain`, {doc}`terrain_cure` and {doc}`../part1/rao_blackwell`; the scalar
# Kalman filter; NumPy arrays.
#
# **Time:** about twenty-five minutes to read, plus about thirty-seven minutes for the folded blocks; the exercises are extra.
# :::
#
# ## The idea: the altitude is linear
#
# In the model of {doc}`terrain` the state is $x_k = (x_k, y_k, z_k, \psi_k)$ and the
# altimeter reads $y^{\text{alt}}_k = z_k - h(x_k, y_k) + v_k$ with $v_k \sim \mathcal N(0, R_f)$.
# Write $p_k = (x_k, y_k, \psi_k)$ for the horizontal position and the heading. The altitude
# moves as a random walk, $z_k = z_{k-1} + w^z_k$ with $w^z_k \sim \mathcal N(0, q)$ and
# $q = Q_f^{zz}\,\Delta t$, and it enters the reading *linearly*, with coefficient one. Given a
# path $p_{0:k}$, the ground heights $h(p_1), \dots, h(p_k)$ are known numbers, and the altitude
# is a scalar linear-Gaussian model: its posterior is one Gaussian,
#
# $$
# p(z_k \mid p_{0:k}, y^{\text{alt}}_{1:k}) = \mathcal N(z_k;\, m_k, P_k),
# $$
#
# computed by the Kalman filter of {doc}`../part1/kalman`. The joint posterior factorises
# exactly as in {doc}`../part1/rao_blackwell`:
# $p(p_{0:k}, z_k \mid y^{\text{alt}}_{1:k}) = p(p_{0:k} \mid y^{\text{alt}}_{1:k})\,
# \mathcal N(z_k; m_k, P_k)$, so the particles need only sample $p_{0:k}$, a space of three
# dimensions instead of four {cite:p}`schon2005`. Each particle $i$ carries $p_k^i$ and its
# own altitude filter $(m_k^i, P_k)$.
#
# **The weight** of a particle is the density of the reading with its altitude integrated out.
# Before the reading, the altitude is $\mathcal N(m_{k-1}^i, P_k^-)$ with $P_k^- = P_{k-1} + q$,
# so the reading is Gaussian too:
#
# $$
# p(y^{\text{alt}}_k \mid p_{0:k}^i, y^{\text{alt}}_{1:k-1})
#   = \mathcal N\big(y^{\text{alt}}_k;\; m_{k-1}^i - h(p_k^i),\; S_k\big), \qquad S_k = P_k^- + R_f .
# $$
#
# The bootstrap filter of {doc}`terrain` weights a particle that *sampled* an altitude by
# $\mathcal N(y^{\text{alt}}_k; z_k^i - h(p_k^i), R_f)$: a particle with the right position
# but an altitude $30$ m off is punished for the altitude. Here the altitude's uncertainty
# $P_k^-$ widens the density instead, and only the horizontal position is judged.
#
# **The update** is the scalar Kalman update with the innovation
# $\nu_k^i = y^{\text{alt}}_k - (m_{k-1}^i - h(p_k^i))$ and the gain $K_k = P_k^- / S_k$:
# $m_k^i = m_{k-1}^i + K_k \nu_k^i$ and $P_k = (1 - K_k) P_k^-$. The variance $P_k$ does not
# depend on the particle: it depends only on which steps had a reading. Every particle carries
# the same $P_k$, and only the means $m_k^i$ differ.
#
# :::{admonition} Algorithm 19.1: Marginalised particle filter for terrain navigation
# :class: algorithm
# **Input:** readings $y^{\text{alt}}_{1:K}$, the prior $\mathcal N(x_0, P_0)$ (no altitude
# cross-terms), $Q_f$, $R_f$, the map $h$, $N$.
#
# 1. Draw $p_0^i$ from the prior of $(x, y, \psi)$; set $m_0^i = $ the prior's altitude,
#    $P_0 = P_0^{zz}$ and $\log W_0^i = -\log N$.
# 2. For $k = 1, \dots, K$:
#    1. move $p_k^i$ through the dynamics with the noise of $Q_f$'s $(x, y, \psi)$ block;
#       predict $P_k^- = P_{k-1} + q$;
#    2. weight: $\log W_k^i = \log W_{k-1}^i + \log \mathcal N(\nu_k^i; 0, S_k)$
#       ($-\infty$ off the map), then normalise;
#    3. update each altitude: $m_k^i = m_{k-1}^i + K_k \nu_k^i$, $P_k = (1 - K_k) P_k^-$;
#    4. estimate $\hat p_k = \sum_i W_k^i p_k^i$, $\hat z_k = \sum_i W_k^i m_k^i$;
#    5. if $N_\text{eff} = 1 / \sum_i (W_k^i)^2 < N/2$, resample the rows $(p_k^i, m_k^i)$ and
#       reset the weights to $1/N$.
# :::
#
# ## The algorithm in NumPy, checked against the engine

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pfcourse import evidence
from pfcourse.studies.terrain_field import (COST_FILTERS, MAP_BIAS_RATES, MAP_BIAS_REMEDIES,
                                                MAP_BIAS_SETTINGS, map_error_family)
from pfcourse.studies.registry import STUDIES
from pfcourse.studies.terrain_marginalised import CELLS
from pfcourse.studies.terrain_remedies import FILTERS
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.filter import ParticleFilter
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.book.style import use_style
from pfcourse.scenarios.terrain.field import FieldModel, FieldPointMass, FieldScenario, simulate_field
from pfcourse.scenarios.terrain.marginalised import marginalised_filter
from pfcourse.scenarios.terrain.point_mass import PointMassFilter
from pfcourse.scenarios.terrain.scenario import AircraftScenario, simulate

use_style()

# %%
import numpy as np
from scipy.special import logsumexp

from pfcourse.scenarios.terrain import (
    AircraftScenario, FieldScenario, load_jacksboro, simulate, simulate_field)

terrain = load_jacksboro()  # the elevation map: terrain.height(x, y) in m
scenario = AircraftScenario()  # x0, P0, Qf, Rf, speed, omega, dt of the flights
SAMPLED = [0, 1, 3]  # x, y, psi: the components the particles sample


def wrap(a):
    """Angles to (-pi, pi]."""
    return np.angle(np.exp(1j * a))


def resample(W, rng):
    """Multinomial resampling: sorted uniforms through the weights' CDF."""
    cdf = np.cumsum(W)
    cdf[-1] = 1.0
    return np.searchsorted(cdf, np.sort(rng.random(len(W))), side="right")


def marginalised_pf(readings, terrain, sc, n, rng):
    """Algorithm 19.1: the weighted mean of (x, y) at each step."""
    L0 = np.linalg.cholesky(sc.P0[np.ix_(SAMPLED, SAMPLED)])
    Lq = np.linalg.cholesky(sc.Qf[np.ix_(SAMPLED, SAMPLED)] * sc.dt)
    # columns x, y, psi
    p = sc.x0[SAMPLED] + rng.standard_normal((n, 3)) @ L0.T
    p[:, 2] = wrap(p[:, 2])
    # every altitude filter starts at the prior
    m, P = np.full(n, sc.x0[2]), sc.P0[2, 2]
    log_w, means = np.full(n, -np.log(n)), []
    step = sc.speed * sc.dt
    for k, y in enumerate(readings):
        if k > 0:
            e = rng.standard_normal((n, 3)) @ Lq.T
            p = np.column_stack([
                p[:, 0] + step * np.cos(p[:, 2]) + e[:, 0],
                p[:, 1] + step * np.sin(p[:, 2]) + e[:, 1],
                wrap(p[:, 2] + sc.omega * sc.dt + e[:, 2])])
            P = P + sc.Qf[2, 2] * sc.dt  # P_k^-
            if not np.isnan(y):
                h = terrain.height(p[:, 0], p[:, 1])  # NaN off the map
                off = np.isnan(h)
                S = P + sc.Rf
                nu = np.where(off, 0.0, y - (m - h))
                log_lik = -0.5 * (nu**2 / S + np.log(2 * np.pi * S))
                log_w = np.where(off, -np.inf, log_w + log_lik)
                # the altitude's Kalman update
                K = P / S
                m, P = m + K * nu, (1 - K) * P
        W = np.exp(log_w - logsumexp(log_w))
        means.append(W @ p[:, :2])
        # resample (p, m) together when the ESS is below N/2
        if 1 / np.sum(W**2) < 0.5 * n * (1 - 1e-12):
            idx = resample(W, rng)
            p, m, log_w = p[idx], m[idx], np.full(n, -np.log(n))
    return np.array(means)


flight = simulate(scenario, terrain, np.random.default_rng(0))
readings = flight.measurements[:, 0]  # NaN: no reading
rng = np.random.default_rng(1)
ours = marginalised_pf(readings, terrain, scenario, 3000, rng)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
engine = marginalised_filter(terrain, scenario, 3000, threshold=0.5, resampler="multinomial")
res = engine.run(flight.measurements, rng=np.random.default_rng(1))
gap = np.abs(ours - res.mean[:, :2]).max()
TOLERANCE = 1e-6
print(f"the NumPy filter and the engine's estimates differ by less than "
      f"{TOLERANCE:.0e} m at every step: {gap < TOLERANCE}")
glue_values("terrain_mpf_", check_tolerance=TOLERANCE)

# %% [markdown]
# The NumPy filter and the library's (`pfcourse.scenarios.terrain.marginalised`) draw the same random
# numbers and agree within {glue:text}`terrain_mpf_check_tolerance:.0e` m at every step.
#
# ## Lost flights, on the same flights as every other filter
#
# The flights, seeds and rule are those of {doc}`terrain_cure` (lost: a final error above
# $500$ m); the marginalised filter ran on flights $0$ to $99$ at three sizes
# (`python3 tasks.py study terrain_mpf`), each comparison paired flight by flight.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
remedies = STUDIES["terrain_remedies"].load()
mpf = STUDIES["terrain_mpf"].load()
print("study commit:", mpf.attrs["provenance"]["git_commit"][:10])
table = pd.concat([remedies, mpf[remedies.columns.intersection(mpf.columns)]], ignore_index=True)
lost = table.pivot(index="flight", columns="setting", values="lost").astype(bool)
final = table.pivot(index="flight", columns="setting", values="final_error")
FAMILIES = {"bootstrap": "tab:red", "regularised": "tab:blue", "marginalised": "tab:green"}
SIZES = [3000, 10000, 30000]

rows, versus = [], {}
for family in FAMILIES:
    for n in SIZES:
        name = f"{family} N={n}"
        r = evidence.rate(lost[name])
        conv = ~lost[name]
        rms = np.sqrt(np.mean(final.loc[conv, name] ** 2))
        row = {"filter": family, "N": n, "lost": r.successes, "lost share": r.estimate,
               "95 % interval": f"{r.low:.2f}-{r.high:.2f}", "RMS final error, converged (m)": rms}
        if family != "bootstrap":
            v = evidence.paired_rates(lost[name], lost[f"bootstrap N={n}"])
            versus[(family, n)] = v
            row["vs bootstrap: only this / only bootstrap, McNemar p"] = f"{v.only_a} / {v.only_b}, {v.pvalue:.2g}"
        rows.append(row)
summary = pd.DataFrame(rows)
print(summary.drop(columns=["95 % interval"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))

fig, ax = plt.subplots(figsize=(7.0, 3.8))
for shift, (family, color) in zip((0.96, 1.0, 1.04), FAMILIES.items()):
    part = summary[summary["filter"] == family]
    rates = [evidence.rate(lost[f"{family} N={n}"]) for n in SIZES]
    ax.errorbar(np.array(SIZES) * shift, part["lost share"],
                yerr=[part["lost share"] - [r.low for r in rates], [r.high for r in rates] - part["lost share"]],
                marker="o", capsize=3, color=color, label=family)
ax.set_xscale("log")
ax.set_xticks(SIZES, [f"{n:,}" for n in SIZES])
ax.minorticks_off()
ax.set_xlabel("number of particles N")
ax.set_ylabel("share of the 100 flights lost")
ax.set_ylim(0, 0.8)
ax.legend(loc="upper right")
ax.set_title("Lost flights (final error > 500 m), 95 % Wilson intervals")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
v3, v30 = versus[("marginalised", 3000)], versus[("marginalised", 30000)]
r3, r30 = evidence.rate(lost["marginalised N=3000"]), evidence.rate(lost["marginalised N=30000"])
glue_values("terrain_mpf_", lost_n3000=r3.estimate, lost_n3000_low=r3.low, lost_n3000_high=r3.high,
            lost_n30000=r30.estimate, lost_n30000_low=r30.low, lost_n30000_high=r30.high,
            boot_n3000=v3.b.estimate, boot_n30000=v30.b.estimate, vs_boot_p3000=v3.pvalue, vs_boot_p30000=v30.pvalue,
            vs_boot_low3000=v3.difference_low, vs_boot_high3000=v3.difference_high,
            rpf_n3000=summary.set_index(["filter", "N"]).loc[("regularised", 3000), "lost share"])
vr = evidence.paired_rates(lost["marginalised N=3000"], lost["regularised N=3000"])
vb10 = evidence.paired_rates(lost["marginalised N=3000"], lost["bootstrap N=10000"])
glue_values("terrain_mpf_", vs_rpf_p3000=vr.pvalue)
both = (~lost["marginalised N=30000"] & ~lost["bootstrap N=30000"]).to_numpy()
err_m, err_b = final["marginalised N=30000"].to_numpy()[both], final["bootstrap N=30000"].to_numpy()[both]
ratio, ratio_low, ratio_high = evidence.run_interval(lambda r: np.sqrt(np.mean(err_m[r] ** 2) / np.mean(err_b[r] ** 2)),
                                                     int(both.sum()), seed=1)
glue_values("terrain_mpf_", rms_ratio=ratio, rms_ratio_low=ratio_low, rms_ratio_high=ratio_high, both_converged=int(both.sum()))
EvidenceBlock(
    "integrating the altitude out roughly halves the lost flights at every N, and is not told apart from the "
    "regularised filter",
    notes=[f"Flights 0-99, the same in every setting; lost: final horizontal error > 500 m. Paired against the "
           f"bootstrap at the same N (exact McNemar test on the flights lost by one filter only, "
           "the page Evidence of the book): " + "; ".join(f"{f} N = {n}: {v}" for (f, n), v in versus.items()) + ".",
           f"Marginalised against regularised at N = 3000: {vr}.",
           f"Flights both the marginalised and the bootstrap filter keep at N = 30000 ({int(both.sum())}): RMS final "
           f"error ratio marginalised / bootstrap {ratio:.2f} (95 % bootstrap interval over the flights "
           f"{ratio_low:.2f}-{ratio_high:.2f}).",
           f"Marginalised N = 3000 against the bootstrap filter with N = 10000, which costs more (the cost "
           f"table below): {vb10}."],
    tables=[("Each filter on flights 0-99", summary, {"lost share": ".2f", "RMS final error, converged (m)": ".0f"})],
)

# %% [markdown]
# The marginalised filter loses {glue:text}`terrain_mpf_lost_n3000:.2f`
# ({glue:text}`terrain_mpf_lost_n3000_low:.2f`-{glue:text}`terrain_mpf_lost_n3000_high:.2f`) of the
# flights at $N = 3000$, against {glue:text}`terrain_mpf_boot_n3000:.2f` for the bootstrap filter
# on the same flights.
#
# At $N = 3 \times 10^4$ it loses {glue:text}`terrain_mpf_lost_n30000:.2f`,
# against {glue:text}`terrain_mpf_boot_n30000:.2f`. On the flights both keep at that size, its RMS
# final error is {glue:text}`terrain_mpf_rms_ratio:.2f` times the bootstrap's.
#
# The gain has a simple source: the bootstrap filter spends its particles on a fourth dimension
# whose posterior is known in closed form. It does *not* beat
# the regularised filter of {doc}`terrain_cure`, which loses {glue:text}`terrain_mpf_rpf_n3000:.2f`
# of the flights at $N = 3000$. The two remedies treat different ills: the kernel refills the gaps
# that resampling leaves in the cloud, the Kalman filter removes a dimension.
#

# %% [markdown]
# **What does it cost?** Every filter of the terrain decision was timed on
# {glue:text}`terrain_cost_flights:d` flights in one process (the evidence block says how).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
costs = STUDIES["terrain_costs"].load()
print("study commit:", costs.attrs["provenance"]["git_commit"][:10])
cost_rows = []
for name, (cid, n) in COST_FILTERS.items():
    cpu = costs[f"cpu_{cid}"]
    row = {"filter": name, "N": n, "ms per run (median)": 1000 * cpu.median(),
           "µs per particle-step (Kalman: per step)": 1e6 * (cpu / (costs.steps * max(n, 1))).median(),
           "per particle-step / bootstrap's": np.nan, "95 % interval": ""}
    if n > 0:
        to_boot = evidence.paired(cpu / n, costs["cpu_boot3k"] / 3000, ratio=True)
        row.update({"per particle-step / bootstrap's": to_boot.median,
                    "95 % interval": f"{to_boot.low:.2f}-{to_boot.high:.2f}"})
    cost_rows.append(row)
cost_table = pd.DataFrame(cost_rows)
print(cost_table.drop(columns=["95 % interval"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))

# %% tags=["remove-input"] jupyter={"source_hidden": true}
mpf_cost = evidence.paired(costs["cpu_mpf3k"], costs["cpu_boot3k"], ratio=True)
rpf_cost = evidence.paired(costs["cpu_rpf30k"], costs["cpu_boot30k"], ratio=True)
glue_values("terrain_", mpf_cost_ratio=mpf_cost.median, mpf_cost_ratio_low=mpf_cost.low,
            mpf_cost_ratio_high=mpf_cost.high, rpf_cost_ratio=rpf_cost.median, cost_flights=len(costs))
glue_values("terrain_mpf_", boot_n10000=vb10.b.estimate, vs_boot10000_p=vb10.pvalue,
            vs_boot10000_high_pts=100 * vb10.difference_high, equal_cost_n=3000 * mpf_cost.median)
assert 3000 * mpf_cost.median < 10000  # the marginalised filter at N = 3000 costs less than the bootstrap at 10^4
# The bootstrap filter at about the equal-cost N, on the same flights and filter seeds (terrain_equal_cost).
eq = STUDIES["terrain_equal_cost"].load().set_index("flight").sort_index()
eq_n = int(eq.N.iloc[0])
veq = evidence.paired_rates(lost["marginalised N=3000"], eq.loc[lost.index, "lost"].astype(bool))
glue_values("terrain_mpf_", equal_cost_boot_n=eq_n, equal_cost_boot_lost=veq.b.estimate,
            vs_equal_cost_low_pts=-100 * veq.difference_high, vs_equal_cost_high_pts=-100 * veq.difference_low)
EvidenceBlock(
    f"the marginalised filter costs {mpf_cost.median:.2f} times the bootstrap filter per particle-step",
    notes=[f"Flights 0-{len(costs) - 1}, every filter in one process: a warm-up round (the compiled kernels), then "
           "two rounds in an order rotating with the round and the flight; processor time (time.process_time) of "
           "the faster round. Ratios: median of the per-flight ratios, 95 % bootstrap interval over the flights.",
           f"Marginalised / bootstrap, N = 3000: {mpf_cost}.",
           f"Regularised / bootstrap, N = 30000: {rpf_cost}.",
           f"At about the equal-cost size, the bootstrap filter with N = {eq_n} (study terrain_equal_cost, flights "
           f"0-99, the same flights and filter seeds) against the marginalised filter with N = 3000, lost flights: "
           f"marginalised vs bootstrap {veq}.",
           "The Kalman filters' rows are per step (they carry no particles)."],
    tables=[("Processor time of each filter, one run per flight", cost_table,
             {"ms per run (median)": ".3g", "µs per particle-step (Kalman: per step)": ".3g",
              "per particle-step / bootstrap's": ".2f"})],
)

# %% [markdown]
# Per particle and step the marginalised filter costs {glue:text}`terrain_mpf_cost_ratio:.2f` times the
# bootstrap filter ({glue:text}`terrain_mpf_cost_ratio_low:.2f`-{glue:text}`terrain_mpf_cost_ratio_high:.2f`):
# both read the map once per particle, and the scalar Kalman update is cheap beside it.
#
# For its price the bootstrap filter could run about
# {glue:text}`terrain_mpf_equal_cost_n:.0f` particles. Run with
# {glue:text}`terrain_mpf_equal_cost_boot_n:d` on the same flights, it loses
# {glue:text}`terrain_mpf_equal_cost_boot_lost:.2f` of them against the marginalised filter's
# {glue:text}`terrain_mpf_lost_n3000:.2f`.
#
# At equal cost the marginalised filter loses fewer flights, by
# {glue:text}`terrain_mpf_vs_equal_cost_low_pts:.0f` to
# {glue:text}`terrain_mpf_vs_equal_cost_high_pts:.0f` points (95 % interval, evidence above).
# Even with $10^4$ particles, more than twice the cost, the bootstrap filter loses
# {glue:text}`terrain_mpf_boot_n10000:.2f`.
#
# ## A grid filter over position and heading: lost or kept
#
# With the altitude integrated out the posterior lives in three dimensions, $(x, y, \psi)$,
# few enough for a grid. The **point-mass filter** {cite:p}`bergman1999thesis` holds the
# posterior as probabilities on a regular grid, cells of $\delta$ metres in position and bins of
# $\delta_\psi$ in heading, each grid point with its own altitude Gaussian, as a particle has. The
# prediction shifts and blurs the grid; the update multiplies each point's weight by the same
# predictive density as a particle's.
#
# :::{dropdown} How the grid moves, exactly
# - **The prediction, an exact shift and a convolution**: heading layer $j$ flies the
#   dead-reckoned path of its heading, and its displacement since the start,
#   $D_j(k) = \sum_{i<k} V \Delta t\,(\cos\psi_j(t_i), \sin\psi_j(t_i))$, is summed exactly.
#   The layer's array moves by *whole* cells, $n_j(k) = \operatorname{round}(D_j(k)/\delta)$ in
#   all, and its points are read at the lattice plus the remainder $D_j(k) - n_j(k)\,\delta$:
#   mass that keeps its heading is exactly where the dynamics put it. The heading noise is a
#   convolution along the heading axis with a discrete Gaussian kernel of exactly the variance
#   $Q_f^{\psi\psi}\Delta t$; the heading grid itself turns with the known rate $\omega$. The
#   arrays $w$, $w\,m$ and $w\,(m^2 + P)$ are moved by the same kernel, so the Gaussians that land
#   on one grid point merge into one with the right mean and variance.
# - **The update, a product**: every grid point's weight is multiplied by
#   $\mathcal N(y^{\text{alt}}_k; m - h(x, y), P + R_f)$, and its altitude gets the Kalman update.
# - Only a box of the lattice is held, the smallest that leaves out a negligible share of the
#   mass at each end of each axis, so the cost is that of the posterior's extent, not of the map.
#   Mass that changes heading bin still lands up to a cell from where it belongs, which is why
#   the grid must be refined until its answer stops moving.
# :::
#
# Below, one flight: the grid's posterior over the position (summed over the heading) after
# $20$ readings, with the marginalised filter's particles at the same time.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
SNAPSHOT, FLIGHT = 20, 3
SNAP_CELL, SNAP_HEADING = CELLS[1]  # one of the study's resolutions
fl = simulate(scenario, terrain, data_rng(0, FLIGHT))
grid = PointMassFilter(terrain, scenario, cell=SNAP_CELL, heading_step=np.radians(SNAP_HEADING))
grid.run(fl.measurements[: SNAPSHOT + 1], keep=SNAPSHOT)
pf = marginalised_filter(terrain, scenario, 3000, threshold=0.5, resampler="multinomial")
# the weighted cloud of the last step, the snapshot (the loop keeps no other step)
for cloud in pf.steps(fl.measurements[: SNAPSHOT + 1], rng=filter_rng(0, FLIGHT)):
    pass
post = grid.kept.sum(axis=0)
fig, ax = plt.subplots(figsize=(7.0, 4.6))
c = grid.cell / 2
im = ax.imshow(post / post.max(), origin="lower", cmap="Greys",
               extent=(grid.kept_x[0] - c, grid.kept_x[-1] + c, grid.kept_y[0] - c, grid.kept_y[-1] + c))
ax.plot(*cloud.particles[::5, :2].T, ".", ms=1.5, color="tab:green", label="marginalised PF (1 in 5)")
ax.plot(*fl.truth[SNAPSHOT, :2], "x", color="tab:red", ms=9, mew=2, label="truth")
ax.set_xlabel("east (m)")
ax.set_ylabel("north (m)")
ax.set_title(f"Flight {FLIGHT}, t = {SNAPSHOT} s: grid posterior (grey, {SNAP_CELL:.0f} m cells)")
fig.colorbar(im, ax=ax, label="posterior / its maximum")
ax.set_xlim(fl.truth[SNAPSHOT, 0] - 6000, fl.truth[SNAPSHOT, 0] + 6000)
ax.set_ylim(fl.truth[SNAPSHOT, 1] - 6000, fl.truth[SNAPSHOT, 1] + 6000)
ax.legend(loc="lower left")
plt.show()
near = np.hypot(*np.meshgrid(grid.kept_x - fl.truth[SNAPSHOT, 0], grid.kept_y - fl.truth[SNAPSHOT, 1])) < 1000
print(f"grid points held at t = {SNAPSHOT} s: {grid.kept.size:,}; posterior mass within 1 km of the truth: "
      f"{post[near].sum() / post.sum():.2f}")

# %% [markdown]
# After $20$ readings both still spread over kilometres: the profile flown so far matches
# several places of the map, and the grid holds every one of them.
#
# The grid ran on the first flights at five resolutions, from $\delta = 400$ m down, each
# dividing the cell and the heading bin by $\sqrt 2$ (`python3 tasks.py study terrain_grid`).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
gridrows = STUDIES["terrain_grid"].load()
print("study commit:", gridrows.attrs["provenance"]["git_commit"][:10])
flights = sorted(gridrows.flight.unique())
cells = sorted(gridrows.cell.unique(), reverse=True)  # coarse to fine
fine, coarse = cells[-1], cells[-2]  # the finest grid and the one before it
by = {c: gridrows[gridrows.cell == c].set_index("flight").loc[flights] for c in cells}
ends = {c: by[c][["final_x", "final_y"]].to_numpy() for c in cells}
truth_end = np.array([simulate(scenario, terrain, data_rng(0, r)).truth[-1, :2] for r in flights])
refine = {c: np.hypot(*(ends[c] - ends[f]).T) for c, f in zip(cells[:-1], cells[1:])}  # to the next finer grid
grows = []
for c in cells:
    e = by[c].final_error.to_numpy()
    rms, lo_, hi_ = evidence.run_interval(lambda r: np.sqrt(np.mean(e[r] ** 2)), len(e), seed=2)
    grows.append({"cell (m)": c, "heading bin (deg)": by[c].heading_deg.iloc[0], "lost": int(by[c].lost.sum()),
                  "RMS final error (m)": rms, "95 % interval (m)": f"{lo_:.0f}-{hi_:.0f}",
                  "to next finer: median (m)": np.median(refine[c]) if c in refine else np.nan,
                  "to next finer: largest (m)": refine[c].max() if c in refine else np.nan,
                  "grid points per step": by[c].cells.mean(), "s per flight": by[c].seconds.mean()})
gtable = pd.DataFrame(grows)
print(gtable.drop(columns=["95 % interval (m)"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))

# The particle filters' final means against the finest grid's, flight by flight.
mp = {n: mpf[mpf.N == n].set_index("flight").loc[flights, ["final_x", "final_y"]].to_numpy() for n in SIZES}
pf_ends = {f"marginalised N={n}": mp[n] for n in SIZES}
for name in ("bootstrap N=3000", "regularised N=3000"):  # their final means are not stored: re-run (same seeds)
    runs = []
    for r in flights:
        pf = FILTERS[name].build(scenario.model(terrain))
        runs.append(pf.run(simulate(scenario, terrain, data_rng(0, r)).measurements, rng=filter_rng(0, r)).mean[-1, :2])
    pf_ends[name] = np.array(runs)
    same = np.allclose(np.hypot(*(pf_ends[name] - truth_end).T), final.loc[flights, name], rtol=1e-9)
    print(f"{name}: re-run final errors equal the stored ones: {same}")
drows = []
for name, end in pf_ends.items():
    d = np.hypot(*(end - ends[fine]).T)
    e = np.hypot(*(end - truth_end).T)
    rmsd, lo_, hi_ = evidence.run_interval(lambda r: np.sqrt(np.mean(d[r] ** 2)), len(d), seed=3)
    drows.append({"filter": name, "median distance to the grid (m)": np.median(d), "RMS distance (m)": rmsd,
                  "95 % interval (m)": f"{lo_:.0f}-{hi_:.0f}", "flights > 500 m from the grid": int((d > 500).sum()),
                  "RMS final error (m)": np.sqrt(np.mean(e**2))})
dtable = pd.DataFrame(drows)
print(dtable.drop(columns=["95 % interval (m)"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))

# The bootstrap filter with a million particles (terrain_reference, two seeds) on the first flights.
reference = STUDIES["terrain_reference"].load()
big = reference[reference.N == reference.N.max()]
ref_mean = big.groupby("flight")[["mean_x", "mean_y"]].mean()
ref_flights = [r for r in ref_mean.index if r in flights]
to_ref = np.hypot(*(ends[fine][ref_flights] - ref_mean.loc[ref_flights].to_numpy()).T)
ref_spread = big.groupby("flight").apply(lambda t: np.hypot(*np.ptp(t[["mean_x", "mean_y"]].to_numpy(), axis=0)),
                                          include_groups=False).loc[ref_flights]
ref_sd = big.groupby("flight")[["sd_x", "sd_y"]].mean().loc[ref_flights].to_numpy()
grid_sd = by[fine].loc[ref_flights, ["final_sd_x", "final_sd_y"]].to_numpy()
print(f"finest grid to the bootstrap filter with N = {big.N.max():,}, flights {ref_flights}: "
      + ", ".join(f"{v:.0f}" for v in to_ref) + " m; the two seeds of that filter differ by "
      + ", ".join(f"{v:.0f}" for v in ref_spread) + " m")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
e_fine = by[fine].final_error.to_numpy()
grmse, grmse_low, grmse_high = evidence.run_interval(lambda r: np.sqrt(np.mean(e_fine[r] ** 2)), len(e_fine), seed=2)
glue_values("", terrain_grid_rmse_m=grmse)
dist = {row["filter"]: row for row in drows}
glue_values("terrain_grid_", rmse_low=grmse_low, rmse_high=grmse_high, flights=len(flights),
            lost=int(by[fine].lost.sum()), fine=fine, coarse=coarse, fine_heading=by[fine].heading_deg.iloc[0],
            shift_median=float(np.median(refine[coarse])), shift_max=float(refine[coarse].max()),
            ref_max=float(to_ref.max()), ref_flights=len(ref_flights),
            d30000_median=float(dist["marginalised N=30000"]["median distance to the grid (m)"]),
            d30000_rms=float(dist["marginalised N=30000"]["RMS distance (m)"]),
            d3000_boot_rms=float(dist["bootstrap N=3000"]["RMS distance (m)"]),
            d3000_rpf_rms=float(dist["regularised N=3000"]["RMS distance (m)"]),
            seconds=float(by[fine].seconds.mean()), points=float(by[fine].cells.mean()),
            mpf_lost=int(lost.loc[flights, "marginalised N=30000"].sum()),
            far_boot3000=int(dist["bootstrap N=3000"]["flights > 500 m from the grid"]),
            far_mpf3000=int(dist["marginalised N=3000"]["flights > 500 m from the grid"]))
EvidenceBlock(
    "the grid filter's refinement, its error on the first flights, and the particle filters' distance to it",
    notes=[f"Flights {flights[0]}-{flights[-1]}, the first of the stored flights (fewer than 100: a flight costs "
           f"{by[fine].seconds.mean():.0f} s on the finest grid under the load of a shared machine). Intervals: "
           "percentile bootstrap over the flights (the page Evidence of the book).",
           "Refinement: each grid divides the cell and the heading bin by the square root of two; the distance of "
           "each grid's final mean to the next finer one's, per flight (m): "
           + "; ".join(f"{c:.0f} m to {f:.0f} m: " + ", ".join(f"{v:.0f}" for v in refine[c])
                       for c, f in zip(cells[:-1], cells[1:])) + ".",
           f"The finest grid's final mean against the bootstrap filter with N = {big.N.max():,} (the mean of its two "
           f"seeds, study terrain_reference), flights {ref_flights[0]}-{ref_flights[-1]} (m): "
           + ", ".join(f"{v:.0f}" for v in to_ref) + "; its two seeds differ by "
           + ", ".join(f"{v:.0f}" for v in ref_spread) + " m. Final posterior standard deviations (x, y), grid "
           "against that filter (m): " + ", ".join(f"({g[0]:.0f}, {g[1]:.0f}) against ({r[0]:.0f}, {r[1]:.0f})"
                                                   for g, r in zip(grid_sd, ref_sd)) + ".",
           *[f"{name}: distance of its final mean to the {fine:.0f} m grid's, per flight (m): "
             + ", ".join(f"{v:.0f}" for v in np.hypot(*(end - ends[fine]).T)) + "." for name, end in pf_ends.items()]],
    tables=[("The grid filter at each resolution (distances: between final means, per flight)", gtable,
             {"RMS final error (m)": ".0f", "to next finer: median (m)": ".0f", "to next finer: largest (m)": ".0f",
              "grid points per step": ".3g", "s per flight": ".0f"}),
            (f"Each particle filter's final mean against the {fine:.0f} m grid's, flights {flights[0]}-{flights[-1]}",
             dtable, {"median distance to the grid (m)": ".0f", "RMS distance (m)": ".0f", "RMS final error (m)": ".0f"})],
)

# %% [markdown]
# What can this grid say? Its finest cells, {glue:text}`terrain_grid_fine:.0f` m, are coarser than
# the map's own spacing, and the last refinement still moves its final estimate by a median
# {glue:text}`terrain_grid_shift_median:.0f` m and up to {glue:text}`terrain_grid_shift_max:.0f` m
# (every step is in the evidence block). So it is **not** a reference for accuracy on this problem: its
# RMS final error, {glue:text}`terrain_grid_rmse_m:.0f` m, is largely its own resolution.
#
# It does tell a lost flight from a kept one, because a lost flight ends kilometres away. On the
# {glue:text}`terrain_grid_flights:d` flights the bootstrap filter with $N = 3000$ ends more than
# $500$ m from the grid's estimate on {glue:text}`terrain_grid_far_boot3000:d` and the marginalised
# filter with $N = 3000$ on {glue:text}`terrain_grid_far_mpf3000:d`, while the grid itself loses
# {glue:text}`terrain_grid_lost:d`: the lost flights are the particles' failure to represent the
# posterior, which the kernel of {doc}`terrain_cure` and the altitude's Kalman filter each repair. A grid fine enough to be a reference for accuracy
# needs a smaller problem: the field's.
#
# ## The field's problem: position only, against a converged grid
#
# The scenario of these chapters has a four-dimensional state whose heading the filter lets
# wander by {glue:text}`terrain_filter_heading_deg:.1f` degrees per second. A real terrain
# navigator is not in that position {cite:p}`bergman1999thesis`: its inertial navigation system
# (INS) gives the heading and the speed, so the displacement $u_k$ over each step is known up to a
# small drift, and a barometer gives the altitude. Only the horizontal position $p_k$ is left:
#
# $$
# p_k = p_{k-1} + u_k + w_k, \quad w_k \sim \mathcal N(0, \sigma_d^2 I), \qquad
# y_k = h(p_k) + v_k, \quad v_k \sim \mathcal N(0, R),
# $$
#
# with $y_k$ the barometric altitude minus the radar altimeter's reading, a measured terrain height.
# The flights below fly the same path with a drift of $\sigma_d$ =
# {glue:text}`terrain_field_drift:.0f` m per second per axis, the same prior and the same $R$. In two
# dimensions a grid can be much finer than the map. Write the position as the dead-reckoned one plus
# an error, $p_k = d_k + e_k$ with $d_k = x_0 + u_1 + \dots + u_k$: the known motion moves $d_k$,
# and the grid, over $e$, never moves. The prediction is only the drift's blur; the update reads
# the map at $d_k + e$.

# %%
from scipy import ndimage, special


def point_mass(readings, d, terrain, cell, sd0, drift, R):
    """Posterior mean of p_k, on a lattice of the error e = p - d_k."""
    half = np.ceil(4 * sd0 / cell) * cell
    e = np.arange(-half, half + cell / 2, cell)  # one axis of the lattice
    ex, ey = np.meshgrid(e, e)
    w = np.exp(-0.5 * (ex**2 + ey**2) / sd0**2)  # the prior N(0, sd0^2 I)
    w /= w.sum()
    # the drift as a discrete Gaussian kernel: I_n(t) e^(-t) for cells
    # n = -3..3 (scipy's ive) has variance t = drift^2 / cell^2 cells^2
    kernel = special.ive(np.arange(-3, 4), drift**2 / cell**2)
    means = []
    for k, y in enumerate(readings):
        if k > 0:  # predict: blur by the drift along each axis
            w = ndimage.convolve1d(w, kernel, axis=0, mode="constant")
            w = ndimage.convolve1d(w, kernel, axis=1, mode="constant")
        if not np.isnan(y):  # update: the reading's likelihood at each point
            h = terrain.height(d[k, 0] + ex, d[k, 1] + ey)  # NaN off the map
            with np.errstate(divide="ignore"):
                log_w = np.log(w) - 0.5 * (y - h) ** 2 / R
            log_w[np.isnan(h)] = -np.inf
            w = np.exp(log_w - log_w.max())
        w /= w.sum()
        means.append(d[k] + [np.sum(w * ex), np.sum(w * ey)])
    return np.array(means)


field = FieldScenario()  # the flight path, prior, drift and R of this section
fflight = simulate_field(field, terrain, np.random.default_rng(0))
d = field.dead_reckoning  # d_k, (K, 2)
ours_2d = point_mass(fflight.readings, d, terrain, 25.0, field.sd0,
                     field.drift, field.R)

# %% [markdown]
# The library's version (`pfcourse.scenarios.terrain.field`, checked against the Kalman filter on a tilted
# plane) holds only the box where the mass is: fast enough to run every flight at cells of $50$,
# $25$ and $12.5$ m, with the bootstrap filter ($N = 3000$) beside it. One flight first:

# %% tags=["hide-input"] jupyter={"source_hidden": true}
library = FieldPointMass(terrain, field, cell=25.0).run(fflight.readings)
print(f"the NumPy grid and the library's agree within "
      f"{np.abs(ours_2d - library.mean).max():.1e} m at every step")
fpf = ParticleFilter(FieldModel(terrain, field), 3000, threshold=0.5, resampler="multinomial")
fres = fpf.run(fflight.readings[:, None], rng=np.random.default_rng(1))
t = np.arange(field.n_steps) * field.dt
fig, ax = plt.subplots(figsize=(7.0, 3.6))
ax.plot(t, np.hypot(*(ours_2d - fflight.truth).T), color="k", label="grid, 25 m cells: error")
ax.plot(t, np.hypot(*library.sd.T), "k:", label="grid: posterior spread")
ax.plot(t, np.hypot(*(fres.mean - fflight.truth).T), color="tab:red", label="bootstrap PF, N = 3000: error")
ax.plot(t, np.hypot(*(fres.mean - ours_2d).T), color="tab:red", ls="--", label="bootstrap PF: distance to grid")
ax.set_yscale("log")
ax.set_xlabel("time t (s)")
ax.set_ylabel("horizontal distance (m)")
ax.legend(loc="upper right", fontsize="small")
ax.set_title("The field's 2-D problem, one flight")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
fs = STUDIES["terrain_field"].load()
more = STUDIES["terrain_field_pf"].load()  # the regularised filter, and the bootstrap filter with N = 30000
fend = {name: g.set_index("flight")[["final_x", "final_y"]] for name, g in fs.groupby("setting")}
fflights = fend["grid 12.5 m"].index
shift = np.hypot(*(fend["grid 25 m"] - fend["grid 12.5 m"]).to_numpy().T)
shift_coarse = np.hypot(*(fend["grid 50 m"] - fend["grid 25 m"]).to_numpy().T)
to_grid = np.hypot(*(fend["bootstrap N=3000"] - fend["grid 12.5 m"]).to_numpy().T)
to_grid_more = {name: np.hypot(*(g.set_index("flight").loc[fflights, ["final_x", "final_y"]]
                                 - fend["grid 12.5 m"]).to_numpy().T) for name, g in more.groupby("setting")}
fine_rows = fs[fs.setting == "grid 12.5 m"].set_index("flight")
grid_err = fine_rows.final_error.to_numpy()
grid_spread = np.hypot(fine_rows.final_sd_x, fine_rows.final_sd_y).to_numpy()
pf_lost = to_grid > 500.0
med_pf, med_pf_lo, med_pf_hi = evidence.median_interval(to_grid)
glue_values("terrain_", pointmass_refinement_shift_m=float(np.median(shift)),
            pointmass_refinement_shift_max_m=float(shift.max()), pf_to_pointmass_m=med_pf,
            pf_to_pointmass_low_m=med_pf_lo, pf_to_pointmass_high_m=med_pf_hi,
            field_drift=field.drift, field_flights=len(fflights), field_pf_far=int(pf_lost.sum()),
            field_grid_spread_m=float(np.median(grid_spread)),
            field_grid_rmse_m=float(np.sqrt(np.mean(grid_err**2))),
            field_pf_kept_median_m=float(np.median(to_grid[~pf_lost])), field_grid_max_error_m=float(grid_err.max()),
            filter_heading_deg=float(np.degrees(np.sqrt(scenario.Qf[3, 3]))),
            field_pf_in_spreads=float(med_pf / np.median(grid_spread)),
            field_rpf_to_pointmass_m=float(np.median(to_grid_more["regularised N=3000"])),
            field_rpf_far=int((to_grid_more["regularised N=3000"] > 500).sum()),
            field_boot30k_to_pointmass_m=float(np.median(to_grid_more["bootstrap N=30000"])),
            field_mc_error_m=float(np.median(grid_spread) / np.sqrt(3000)))
EvidenceBlock(
    "on the field's problem the grid has converged, and the bootstrap filter is measured against it",
    notes=[f"Flights 0-{fflights[-1]} of the 2-D problem (data_rng(0, r); filter_rng(0, r)); the grid filter at 50, "
           "25 and 12.5 m cells, the bootstrap filter with N = 3000 (multinomial resampling at ESS < N/2).",
           f"Refinement, distance between final means (m): 50 to 25 m median {np.median(shift_coarse):.1f}, largest "
           f"{shift_coarse.max():.1f}; 25 to 12.5 m median {np.median(shift):.2f}, largest {shift.max():.2f}.",
           f"The 12.5 m grid: RMS final error {np.sqrt(np.mean(grid_err**2)):.1f} m; median posterior spread "
           f"sqrt(sd_x^2 + sd_y^2) {np.median(grid_spread):.1f} m; largest final error {grid_err.max():.0f} m.",
           f"Bootstrap N = 3000, final distance to the 12.5 m grid's mean: median {med_pf:.1f} m (95 % interval "
           f"{med_pf_lo:.1f}-{med_pf_hi:.1f}); more than 500 m away on {pf_lost.sum()} of {len(to_grid)} flights; "
           f"on the others median {np.median(to_grid[~pf_lost]):.1f} m, largest {to_grid[~pf_lost].max():.0f} m.",
           *[f"{name} (study terrain_field_pf, the same flights and filter seeds; the regularised kernel at 0.2 x "
             f"the optimal bandwidth): median distance to the 12.5 m grid {np.median(d):.1f} m, more than 500 m "
             f"away on {(d > 500).sum()} of {len(d)} flights." for name, d in to_grid_more.items()]],
)

# %% [markdown]
# On these flights, halving the cells from $25$ m to $12.5$ m moves the final estimate by a
# median of {glue:text}`terrain_pointmass_refinement_shift_m:.1f` m (at most
# {glue:text}`terrain_pointmass_refinement_shift_max_m:.1f` m), against a posterior spread of about
# {glue:text}`terrain_field_grid_spread_m:.0f` m: this grid has converged, and it is the exact
# answer to compare with.
#
# The bootstrap filter with $N = 3000$ ends a median
# {glue:text}`terrain_pf_to_pointmass_m:.1f` m from it
# ({glue:text}`terrain_pf_to_pointmass_low_m:.1f`-{glue:text}`terrain_pf_to_pointmass_high_m:.1f`).
#
# It ends more than $500$ m away on {glue:text}`terrain_field_pf_far:d` of the
# {glue:text}`terrain_field_flights:d` flights, where the grid's own error never exceeds
# {glue:text}`terrain_field_grid_max_error_m:.0f` m.
#
# The median distance is {glue:text}`terrain_field_pf_in_spreads:.1f` posterior spreads, against
# a Monte Carlo error of about {glue:text}`terrain_field_mc_error_m:.1f` m for $3000$ independent
# draws. With a drift of {glue:text}`terrain_field_drift:.0f` m per second to spread them, the
# copies that resampling makes stay nearly on top of each other: sample impoverishment.
#
# The cure of {doc}`terrain_cure` works here too: the regularised filter, with the same $3000$
# particles, ends a median {glue:text}`terrain_field_rpf_to_pointmass_m:.1f` m from the grid (far
# from it on {glue:text}`terrain_field_rpf_far:d` flight); the bootstrap filter with ten times as
# many, {glue:text}`terrain_field_boot30k_to_pointmass_m:.1f` m.
#
# Which problem does the book solve? The lab's four-dimensional one in {doc}`terrain`,
# {doc}`terrain_cure` and most of this chapter; the field's two-dimensional one in this section,
# where a grid is exact.
#
# ## Map error as a state
#
# {doc}`terrain_cure` flew the filters over the true ground with a map that is not the truth, and
# found the map's error, smooth over a few hundred metres, read as signal. The marginalised filter
# {cite:p}`schon2005`, which terrain-aided navigation uses in the field {cite:p}`nordlund2009`,
# offers a remedy. With $b(p) = h_f(p) - h(p)$ the error of the
# filter's map $h_f$ under the aircraft, the reading is
#
# $$
# y^{\text{alt}}_k = z_k + b_k - h_f(p_k) + v_k ,
# $$
#
# so the map's error enters exactly as the altitude does: linearly. Along the flight it is a
# correlated process; model it as first-order Gauss-Markov in the distance flown, with the error's
# spread $\sigma_b$ and correlation length $L$,
#
# $$
# b_k = a\, b_{k-1} + w^b_k, \qquad a = e^{-V \Delta t / L}, \qquad
# w^b_k \sim \mathcal N\big(0, \sigma_b^2 (1 - a^2)\big),
# $$
#
# and integrate it out beside the altitude: each particle's Kalman filter now has two states,
# $(z, b)$, with $H = [1\;\; 1]$ (`pfcourse.scenarios.terrain.map_bias`). The cruder remedy keeps
# the filter and inflates $R_f$ by the map's variance times the number of readings that fall within
# one correlation length, $R_f + (L / V T)\, \sigma_b^2$: readings that share one error are worth one.
#
# Both ran on the {glue:text}`terrain_bias_flights:d` flights of that study, each with its own
# mismatched map, at $1$ Hz and at $10$ Hz, with $N = 3000$; $\sigma_b$ is the map's measured error and
# $L$ = {glue:text}`terrain_bias_length_m:.0f` m the distance at which its correlation falls to
# $1/e$ (`python3 tasks.py study terrain_map_bias`): each filter is told its map's true error
# statistics, so the results are the remedies at their best.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
mb = STUDIES["terrain_map_bias"].load()
print("study commit:", mb.attrs["provenance"]["git_commit"][:10])
mb_lost = mb.pivot(index="flight", columns="setting", values="lost").astype(bool)
mb_final = mb.pivot(index="flight", columns="setting", values="final_error")
mb_rows = []
for rate in MAP_BIAS_RATES:
    for remedy in MAP_BIAS_REMEDIES:
        name = f"{rate}: {remedy}"
        r = evidence.rate(mb_lost[name])
        kept = ~mb_lost[name]
        mb_rows.append({"rate": rate, "filter": remedy, "lost share": r.estimate,
                        "95 % interval": f"{r.low:.2f}-{r.high:.2f}",
                        "median final error, kept (m)": mb_final.loc[kept, name].median()})
mb_table = pd.DataFrame(mb_rows)
print(mb_table.drop(columns=["95 % interval"]).to_string(index=False, float_format=lambda v: f"{v:.3g}"))

fig, ax = plt.subplots(figsize=(7.0, 3.4))
for shift, (remedy, color) in zip((-0.2, 0.0, 0.2), zip(MAP_BIAS_REMEDIES, ("tab:green", "tab:orange", "tab:purple"))):
    rates = [evidence.rate(mb_lost[f"{rate}: {remedy}"]) for rate in MAP_BIAS_RATES]
    est = np.array([r.estimate for r in rates])
    ax.errorbar(np.arange(2) + shift, est, yerr=[est - [r.low for r in rates], [r.high for r in rates] - est],
                fmt="o", capsize=3, color=color, label="no remedy" if remedy == "marginalised" else remedy)
ax.set_xticks([0, 1], list(MAP_BIAS_RATES))
ax.set_xlim(-0.6, 1.6)
ax.set_ylabel("share of the flights lost")
ax.set_ylim(0, 1)
ax.legend(loc="upper right", title="marginalised filter, N = 3000")
ax.set_title("Mismatched map: lost flights, 95 % Wilson intervals")
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
mm = STUDIES["terrain_map_error"].load()
mm_lost = mm.pivot(index="flight", columns="setting", values="lost").astype(bool)
# the same flights on the true map: the remedies study, and the period study's 10 Hz runs
period = STUDIES["terrain_studies"].load()
period = period[period["setting"] == "every 0.1 s, dt = 0.1 s"].set_index("flight").loc[mm_lost.index]
true_map = {"bootstrap N=3000": lost.loc[mm_lost.index, "bootstrap N=3000"],
            "regularised N=30000": lost.loc[mm_lost.index, "regularised N=30000"],
            "regularised N=30000, 10 Hz": period["lost"].astype(bool)}
family = map_error_family(mm_lost, mb_lost, true_map)
holm_p = {name: p for name, (_, p) in family.items()}
share = {name: evidence.rate(mb_lost[name]) for name in MAP_BIAS_SETTINGS}
glue_values("terrain_", bias_state_lost_1hz=share["1 Hz: bias state"].estimate,
            bias_state_lost_10hz=share["10 Hz: bias state"].estimate,
            bias_none_lost_1hz=share["1 Hz: marginalised"].estimate,
            bias_none_lost_10hz=share["10 Hz: marginalised"].estimate,
            bias_inflated_lost_1hz=share["1 Hz: R inflated"].estimate,
            bias_inflated_lost_10hz=share["10 Hz: R inflated"].estimate,
            bias_state_holm_p_1hz=holm_p["marginalised 1 Hz, bias state vs none"],
            bias_state_holm_p_10hz=holm_p["marginalised 10 Hz, bias state vs none"],
            bias_inflated_holm_p_1hz=holm_p["marginalised 1 Hz, R inflated vs none"],
            bias_inflated_holm_p_10hz=holm_p["marginalised 10 Hz, R inflated vs none"],
            bias_none_rate_holm_p=holm_p["marginalised, marginalised, 10 Hz vs 1 Hz"],
            bias_state_rate_holm_p=holm_p["marginalised, bias state, 10 Hz vs 1 Hz"],
            bias_flights=len(mb_lost), bias_family=len(family),
            bias_length_m=float(mb["length"].iloc[0]), bias_map_sd_m=float(mb["map_error_sd"].mean()))
# correlation of the map error between readings 10 m apart (10 Hz at 100 m/s): the first-order model's
# exp(-d / L) against the error field's own exp(-(d / L)^2) (Gaussian-smoothed noise, L its 1/e distance)
L_b, d10 = float(mb["length"].iloc[0]), scenario.speed * 0.1
glue_values("terrain_", bias_gm_corr_10m=float(np.exp(-d10 / L_b)), bias_field_corr_10m=float(np.exp(-(d10 / L_b) ** 2)),
            bias_fresh_ratio=float((1 - np.exp(-d10 / L_b)) / (1 - np.exp(-(d10 / L_b) ** 2))))
established = [name for name, p in holm_p.items() if p < 0.05]
ours_established = [n for n in established if n.startswith("marginalised")]
assert set(ours_established) == {"marginalised 1 Hz, bias state vs none", "marginalised 10 Hz, bias state vs none",
                                 "marginalised 10 Hz, R inflated vs none",
                                 "marginalised 10 Hz, bias state vs R inflated"}, established
family_table = pd.DataFrame([{"comparison (A vs B)": name, "flights": t.a.n, "lost A": t.a.estimate,
                              "lost B": t.b.estimate, "only A / only B": f"{t.only_a} / {t.only_b}",
                              "McNemar p": t.pvalue, "Holm p": p} for name, (t, p) in family.items()])
EvidenceBlock(
    "carrying the map error as a state, against inflating R and against doing nothing, at 1 and 10 Hz",
    notes=[f"Flights 0-{mb_lost.index[-1]}, each flown over the true DEM with the filter on its own mismatched map "
           f"(map_error_rng(0, r), as in terrain_map_error; the map's error has a standard deviation of "
           f"{mb['map_error_sd'].mean():.1f} m on average); the same flights, filter seeds and maps in every setting.",
           f"Bias state: sigma_b = the map's measured error, L = {mb['length'].iloc[0]:.0f} m (2 x the smoothing's "
           "cells x the mean node spacing, where the error's correlation falls to 1/e). R inflated: R_f + "
           "max(1, L / (V T)) sigma_b^2.",
           f"Holm's adjustment is over the whole family of {len(family)} comparisons of lost flights of the two "
           "map-error studies (this one and terrain_map_error of the previous chapter)."],
    tables=[("Lost shares with the mismatched map", mb_table,
             {"lost share": ".2f", "median final error, kept (m)": ".0f"}),
            ("Every comparison of the map-error studies, Holm-adjusted", family_table,
             {"lost A": ".2f", "lost B": ".2f", "McNemar p": ".2g", "Holm p": ".2g"})],
)

# %% [markdown]
# With the wrong map and no remedy, the marginalised filter loses
# {glue:text}`terrain_bias_none_lost_1hz:.2f` of the flights at $1$ Hz and
# {glue:text}`terrain_bias_none_lost_10hz:.2f` at $10$ Hz.
#
# Carrying the error as a state, it loses
# {glue:text}`terrain_bias_state_lost_1hz:.2f` at $1$ Hz and {glue:text}`terrain_bias_state_lost_10hz:.2f`
# at $10$ Hz; inflating $R_f$, {glue:text}`terrain_bias_inflated_lost_1hz:.2f` and
# {glue:text}`terrain_bias_inflated_lost_10hz:.2f`.
#
# Corrected for all {glue:text}`terrain_bias_family:d` comparisons of the two map-error studies
# (evidence block), four differences among these filters stand: the bias state beats no remedy at both rates, inflating $R_f$ beats no remedy
# at $10$ Hz, and at $10$ Hz inflating $R_f$ beats the bias state. Whether measuring faster hurts or
# helps any of these filters, fifty flights do not settle.
#
# :::{dropdown} Going further: why the state may do worse at 10 Hz
# A likely reason, untested:
# readings $10$ m apart have map errors correlated at {glue:text}`terrain_bias_field_corr_10m:.4f`,
# while the first-order model says {glue:text}`terrain_bias_gm_corr_10m:.3f`, so it takes each
# reading's error for about {glue:text}`terrain_bias_fresh_ratio:.0f` times more fresh than it is.
# A smoother (second-order) bias model is the next thing to try.
# :::
#
# ## Try it
#
# The panel reruns flight {glue:text}`terrain_mpf_panel_flight:d` (lost by the bootstrap filter at
# $N = 3000$) with the filter and $N$ you choose: the final cloud and the error over time.
# Compare the filters at one $N$, then at $N = 1000$: which keep the flight?

# %% tags=["hide-input"] jupyter={"source_hidden": true}
import ipywidgets as widgets
from IPython.display import display

from pfcourse.book.figures.terrain import flight_figure
from pfcourse.book.panels import control_panel, particle_slider
from pfcourse.collectors import LastCloud
from pfcourse.filter_config import FilterSettings
from pfcourse.jitter import RegularisedJitter

PANEL_FLIGHT = 2  # lost by the bootstrap filter with N = 3000, kept by the marginalised one (terrain_mpf)
panel_flight = simulate(scenario, terrain, data_rng(0, PANEL_FLIGHT))
glue_values("terrain_mpf_panel_", flight=PANEL_FLIGHT)
PANEL_FILTERS = ("bootstrap", "marginalised", "regularised")


def draw(n_particles=3000, method="marginalised"):
    """One of the three filters of the chapter's comparison on the panel's flight."""
    if method == "marginalised":
        pf = marginalised_filter(terrain, scenario, n_particles, threshold=0.5, resampler="multinomial")
    else:
        jitter = RegularisedJitter(0.2, (3,)) if method == "regularised" else None
        pf = FilterSettings(n_particles=n_particles, threshold=0.5, resampler="multinomial",
                            jitter=jitter).build(scenario.model(terrain))
    res = pf.run(panel_flight.measurements, rng=filter_rng(0, PANEL_FLIGHT), collect=[LastCloud()])
    flight_figure(terrain, panel_flight, res.mean, res.collected["last_cloud"],
                  f"{method}, N = {n_particles}")


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
panel = control_panel(
    draw,
    grid={"n_particles": (1000, 3000, 10000), "method": PANEL_FILTERS},
    n_particles=particle_slider(3000, 2, 4),
    method=widgets.Dropdown(options=PANEL_FILTERS, value="marginalised", description="filter"),
    alt="flight 2: the filter's final cloud over the map and its horizontal error over time",
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 19.1 The altitude and the map's bias, updated together
# :label: ex-mpf-code
# :nonumber:
# (Coding.) The map-bias filter above gives each particle a Kalman filter of two states, the
# altitude and the map's bias, $s = (z, b)$, read through $H = [1\;\; 1]$. Write
# `my_bias_update(m, P, ground, reading, rf)`: for the predicted means `m` (shape `(N, 2)`,
# columns $z, b$), covariances `P` (shape `(N, 3)`, columns $P_{zz}, P_{zb}, P_{bb}$), the ground
# heights $h_f(p^i)$ of the filter's map, a reading $y^{\text{alt}}_k$ and $R_f$, return the updated
# means, the updated covariances (same layout) and the log-weight increments
# $\log \mathcal N(\nu^i; 0, S^i)$. The checker compares with the exact update and names the mistake
# it recognises.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_bias_update


def my_bias_update(m, P, ground, reading, rf):
    """Your update: return (m_new (N, 2), P_new (N, 3), log_lik (N,))."""
    ...  # replace with your code


print(check_bias_update(my_bias_update))

# %% [markdown]
# ```{solution} ex-mpf-code
# :class: dropdown
# With $H = [1\;\; 1]$: $\nu = y - (m_z + m_b - h_f)$, $S = P_{zz} + 2P_{zb} + P_{bb} + R_f$,
# $K = (P_{zz} + P_{zb},\; P_{zb} + P_{bb}) / S$, $m' = m + K\nu$, $P' = P - KK^\top S$. The code is in
# the folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_bias_update(m, P, ground, reading, rf):
    pzz, pzb, pbb = P.T
    nu = reading - (m[:, 0] + m[:, 1] - ground)  # innovation, H = [1, 1]
    S = pzz + 2 * pzb + pbb + rf  # H P H^T + Rf
    kz, kb = (pzz + pzb) / S, (pzb + pbb) / S  # K = P H^T / S
    m_new = m + np.column_stack([kz, kb]) * nu[:, None]
    P_new = np.column_stack([pzz - kz * kz * S, pzb - kz * kb * S, pbb - kb * kb * S])
    log_lik = -0.5 * (nu**2 / S + np.log(2 * np.pi * S))
    return m_new, P_new, log_lik


print(check_bias_update(my_bias_update))

# %% [markdown]
# ```{exercise} 19.2 Why one variance for all particles?
# :label: ex-mpf-variance
# :nonumber:
# Show from the update equations that $P_k$ is the same for every particle. Would it still be
# if the altimeter's noise grew with the height above the ground, $R_f(y^{\text{alt}})$? If the
# altitude entered the reading through a slope, $y^{\text{alt}}_k = c(p_k)\,z_k - h(p_k) + v_k$?
# ```
#
# ```{solution} ex-mpf-variance
# :class: dropdown
# $P_k^- = P_{k-1} + q$ and $P_k = P_k^- R_f / (P_k^- + R_f)$ involve neither $p_k^i$ nor the
# reading, so starting from one $P_0$ every particle keeps the same value. A noise variance that
# depends on the reading is still common to all particles (the reading is), so $P_k$ stays
# shared. A coefficient $c(p_k^i)$ enters the gain, $K = P^- c / (c^2 P^- + R_f)$, and makes
# $P_k$ depend on the particle's path: each particle must then carry its own variance, as the
# engine's rows allow.
# ```
#
# ## Takeaways
#
# - A state component that enters the model linearly can be integrated out exactly: each
#   particle carries a Kalman filter for it, samples only the rest, and is weighted by the
#   predictive density of the reading.
# - On the book's flights this roughly halves the lost flights at every $N$, at
#   {glue:text}`terrain_mpf_cost_ratio:.2f` times the cost per particle: the bootstrap filter
#   given the same processor time loses more.
# - A grid coarser than the map tells lost flights from kept ones, not accuracy. In the field's
#   problem a grid of $12.5$ m cells converges: the exact answer to measure filters against.
# - A map's error enters the reading linearly too: carried as a state (told the map's true error
#   statistics), it cuts the lost flights that a wrong map causes at both reading rates; an
#   inflated $R_f$ helps at $10$ Hz only.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab B ({doc}`../labs`) asks how the number of particles and the measurement rate change the
# filter's error. This chapter adds two answers: at equal cost, integrating the altitude out loses
# fewer flights than adding particles ("What does it cost?"); and with a map that is not the truth,
# modelling the map's error is what helps, while whether measuring faster helps is not settled
# ("Map error as a state"). The
# lab's heading noise, $0.001 \cdot 180/\pi$ rad per square-root second in its code, mixes radians
# and degrees; these chapters keep it so that their numbers stay the lab's, and "The field's
# problem" gives the navigation problem that slip hides.
# :::
