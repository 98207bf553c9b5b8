# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Terrain-aided navigation over a real elevation model
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** how a particle filter finds an aircraft on a real elevation map from a radar
# altimeter alone: the altimeter's likelihood on the map, why the posterior has several modes and
# an extended Kalman filter fails, and which conclusions about the filter's settings hold over a
# hundred flights.
#
# **You need** {doc}`../part1/sir` and {doc}`../part1/kalman`; bilinear interpolation; NumPy
# arrays; paired tests ({doc}`../evidence`).
#
# **Time:** about seventeen minutes to read; the notebook runs in about twenty seconds (the studies
# are stored).
# :::
#
# An aircraft flies over hills without satellite navigation. It knows its airspeed and its
# turn rate, so it can dead-reckon, but its starting point is known only to within a few
# kilometres. Its one sensor is a radar altimeter, which measures the height of the aircraft
# *above the ground*. Together with a digital elevation model (DEM) of the region, a series of
# such readings is a terrain profile, and the filter's job is to find where on the map the
# aircraft must be flying to see that profile {cite:p}`bergman1999`. The measurement function is
# a map lookup, with no formula and a slope that changes from one map cell (about a hundred
# metres) to the next, and a profile can fit several places at once: a problem made for a particle filter.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import HTML, display
from myst_nb import glue

from pfcourse import evidence

from pfcourse.studies.registry import STUDIES
from pfcourse.studies.terrain import DIVERGED_ERROR, diverged, final_errors, flight_study, flight_summary
from pfcourse.seeding import data_rng, filter_rng
from pfcourse.metrics import position_error
from pfcourse.scenarios.terrain.scenario import AircraftScenario, extended_kalman_filter, simulate
from pfcourse.book.figures.clouds import animate_clouds
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.collectors import Clouds
from pfcourse.filter import ParticleFilter
from pfcourse.book.style import COLORS, plain_log_axis, use_style
from pfcourse.scenarios.terrain.map import hillshade, load_jacksboro
from pfcourse.book.panels import (
    control_panel,
    particle_slider,
    scale_slider,
    scheme_dropdown,
    seed_box,
    threshold_slider,
)

use_style()

# %% [markdown]
# ## The map
#
# matplotlib ships a real elevation model from the US Geological Survey,
# `jacksboro_fault_dem.npz`: {glue:text}`terrain_rows:d` by {glue:text}`terrain_columns:d` heights
# in metres on a grid of $3$ arc-seconds, in the
# Cumberland Mountains of Tennessee. Two things must be right before any filtering.
#
# - **Which row is north.** In the file, the first row is the northern edge. Its field `ymax`
#   ($36.446°$) is the latitude of that edge, but its field `ymin` is *not* the southern edge
#   (it lies north of `ymax`), so the southern edge is computed as `ymax` minus
#   {glue:text}`terrain_rows:d` rows. The
#   check: with this reading, the highest cell of the map falls on the published summit of
#   Cross Mountain ($1077$ m, $36.19833°$ N, $84.23056°$ W); read the other way up, it would be
#   {glue:text}`terrain_flipped_summit_km:.0f` km away.
# - **Degrees to metres.** A degree of latitude is $R\pi/180 \approx 111.2$ km on a sphere
#   of radius $R = 6371$ km, and a degree of longitude is that times $\cos\varphi$: at
#   $\varphi \approx 36.3°$ a cell is {glue:text}`terrain_dx:.1f` m wide (east-west) and
#   {glue:text}`terrain_dy:.1f` m tall (north-south).
#
# `load_jacksboro` does both and puts the map in metres, with the origin at the centre of the
# south-west cell; heights between the grid nodes are bilinear. The tests
# (`tests/test_terrain.py`) check the orientation, the units and the interpolation.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
terrain = load_jacksboro()
lon, lat = terrain.to_lonlat(*np.multiply(np.unravel_index(np.argmax(terrain.heights), terrain.shape)[::-1], (terrain.dx, terrain.dy)))
print(f"cells: {terrain.dx:.1f} m (east) x {terrain.dy:.1f} m (north); grid {terrain.shape[1]} x {terrain.shape[0]}")
print(f"map: {terrain.width / 1000:.1f} km x {terrain.height_extent / 1000:.1f} km between node centres")
print(f"heights: {terrain.heights.min():.0f} m to {terrain.heights.max():.0f} m")
print(f"highest cell at {lat:.4f} N, {-lon:.4f} W (Cross Mountain: 36.1983 N, 84.2306 W)")
# the same cell if the rows were read the other way up (row j taken for row ny - 1 - j): how far north or south
row = np.unravel_index(np.argmax(terrain.heights), terrain.shape)[0]
flipped_km = abs(terrain.shape[0] - 1 - 2 * row) * terrain.dy / 1000
print(f"read upside down, the highest cell would be {flipped_km:.1f} km from the summit")
glue("terrain_rows", int(terrain.shape[0]), display=False)
glue("terrain_columns", int(terrain.shape[1]), display=False)
glue("terrain_dx", float(terrain.dx), display=False)
glue("terrain_dy", float(terrain.dy), display=False)
glue("terrain_flipped_summit_km", float(flipped_km), display=False)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
KM = 1000.0
extent_km = np.array(terrain.extent) / KM
shade = hillshade(terrain)


def draw_map(ax, shaded=True, window=None):
    """The terrain with axes in km: hillshade coloured by height, or (lighter files) filled contours.

    With ``window = ((x0, x1), (y0, y1))`` in km, the contours are computed on that part of
    the grid only (the same picture inside the window, and a faster widget redraw).
    """
    if shaded:
        ax.imshow(shade, origin="lower", extent=extent_km, cmap="gray")
        mappable = ax.imshow(terrain.heights, origin="lower", extent=extent_km, cmap="terrain", alpha=0.45,
                             vmin=150, vmax=1150)
    else:
        x, y, h = terrain.x_nodes / KM, terrain.y_nodes / KM, terrain.heights
        if window is not None:
            (x0, x1), (y0, y1) = window
            i = slice(max(np.searchsorted(x, x0) - 1, 0), np.searchsorted(x, x1) + 1)
            j = slice(max(np.searchsorted(y, y0) - 1, 0), np.searchsorted(y, y1) + 1)
            x, y, h = x[i], y[j], h[j, i]
        mappable = ax.contourf(x, y, h, levels=np.arange(200, 1101, 100), cmap="terrain", vmin=150, vmax=1150,
                               alpha=0.7)
    ax.set_xlabel("east x (km)")
    ax.set_ylabel("north y (km)")
    ax.set_aspect("equal")
    ax.grid(False)
    return mappable


fig, ax = plt.subplots(figsize=(6.5, 6.5))
fig.colorbar(draw_map(ax), ax=ax, shrink=0.8, label="terrain height (m)")
ax.contour(terrain.x_nodes / KM, terrain.y_nodes / KM, terrain.heights, levels=[400, 600, 800, 1000],
           colors="k", linewidths=0.4, alpha=0.6)
# Contours unlabelled (labels of close contours fall on each other; the colour scale gives heights)
ax.set_title("Jacksboro fault DEM (USGS), shaded relief;\ncontours at 400, 600, 800 and 1000 m")
plt.show()

# %% [markdown]
# The map has two kinds of terrain. To the north-west, the Cumberland plateau is cut by a
# dense tree of steep valleys; to the south-east, beyond the straight line of the Jacksboro
# fault, lies a low valley crossed by long parallel ridges. Both are hard for a terrain
# navigator: the plateau's valleys look alike, and a flight along the valley sees nearly flat
# ground.
#
# ## The scenario, scaled to the map
#
# The aircraft's state is $x = (x, y, z, \psi)$: position east and north, altitude, and
# heading $\psi$ (counter-clockwise from east). It flies at speed $V$ and turn rate
# $\omega$, and the altimeter reads the height above the terrain $h$:
#
# $$
# \begin{aligned}
# x_{k+1} &= x_k + V\,\Delta t\cos\psi_k, & y_{k+1} &= y_k + V\,\Delta t\sin\psi_k, \\
# z_{k+1} &= z_k, & \psi_{k+1} &= \psi_k + \omega\,\Delta t, \\
# y^{\text{alt}}_k &= z_k - h(x_k, y_k) + v_k, & v_k &\sim \mathcal N(0, R).
# \end{aligned}
# $$
#
# The filter adds process noise $w_k \sim \mathcal N(0, Q_f\,\Delta t)$ to the dynamics and
# assumes $v_k \sim \mathcal N(0, R_f)$. The true aircraft flies the dynamics without noise:
# $Q_f$ is the filter's allowance for model error, not a property of the aircraft.
#
# The settings are the lab's (Lab B, {doc}`../labs`) with **every horizontal length divided by
# $3$**, so that the flight and its prior fit this map; the time axis is kept. The flight starts
# near $(21, 11)$ km heading $150°$ (north-west), turning right, and crosses from the valley onto
# the plateau. The altitude, $1500$ m, clears the highest summit.
#
# :::{dropdown} The lab's settings, and why the lengths are divided by 3
# The lab's flight does not fit this map: at $300$ m/s for $80$ s it covers $24$ km, and its
# initial uncertainty of $5$ km (one standard deviation) is a sixth of our map's width.
#
# | parameter | lab | here | why |
# | --- | --- | --- | --- |
# | speed $V$ | $300$ m/s | $100$ m/s | length / $3$: an $8$ km flight |
# | prior std of $x$, $y$ | $5000$ m | $1667$ m | length / $3$: the $3\sigma$ cloud ($10$ km wide) fits on the map |
# | turn rate $\omega$, $\Delta t$, duration | $-0.01$ rad/s, $1$ s, $80$ s | same | time axis kept, so the gap ($50$–$75$ s) and the measurement periods are the lab's |
# | prior std of $z$, $\psi$ | $100$ m, $20°$ | same | vertical and angular, not horizontal lengths |
# | $Q_f$ | $\mathrm{diag}(3, 3, 0.6, 0.001 \cdot 180/\pi)^2$ | same | see below |
# | $R = R_f$ | $20^2$ m² | same | the altimeter is the same |
# | particles, threshold | $3000$, $\mathrm{ESS} < 0.5N$, multinomial | same | |
#
# The heading entry of $Q_f$ is the one the lab's code actually used: it meant $0.001$ rad
# but multiplied by $180/\pi$ instead of $\pi/180$, which gives $0.057$ rad ($3.3°$) per second.
# We keep the value that produced the lab's numbers.
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
scenario = AircraftScenario()
print("speed", scenario.speed, "m/s; omega", scenario.omega, "rad/s; dt", scenario.dt, "s; duration", scenario.duration, "s")
print("x0 =", np.round(scenario.x0, 3))
print("prior std  =", np.round(np.sqrt(np.diag(scenario.P0)), 3))
print("Qf std (per s) =", np.round(np.sqrt(np.diag(scenario.Qf)), 4))

fig, ax = plt.subplots(figsize=(6.5, 6.5))
fig.colorbar(draw_map(ax, shaded=False), ax=ax, shrink=0.8, label="terrain height (m)")
for r in range(30):
    fl = simulate(scenario, terrain, data_rng(0, r))
    ax.plot(fl.truth[:, 0] / KM, fl.truth[:, 1] / KM, "-", color=COLORS["truth"], lw=0.8, alpha=0.6)
    ax.plot(fl.truth[0, 0] / KM, fl.truth[0, 1] / KM, "o", color=COLORS["truth"], ms=2)
prior = scenario.model(terrain).sample_initial(3000, np.random.default_rng(1))
ax.plot(prior[:, 0] / KM, prior[:, 1] / KM, ".", color=COLORS["particles"], ms=1, alpha=0.3)
ax.set_title("30 true flights (start: dot) and 3000 draws of the prior")
plt.show()

# %% [markdown]
# Every true flight starts at a draw from the prior and follows the same arc; the orange
# cloud is where the filter must look at the start. All flights stay on the map.
#
# ## The filter
#
# The filter is the bootstrap filter of {doc}`../part1/sir` with this model. Its one new piece is
# the likelihood. The altimeter reads $y_k = z_k - h(x_k, y_k) + v_k$, so a particle
# $x^i = (x^i, y^i, z^i, \psi^i)$ predicts the reading $z^i - h(x^i, y^i)$ and
#
# $$
# \log p(y_k \mid x^i) = -\frac{\bigl(y_k - z^i + h(x^i, y^i)\bigr)^2}{2 R_f} - \frac{1}{2}\log(2\pi R_f),
# $$
#
# with $h$ the bilinear height: inside the cell with corners $h_{00}, h_{10}, h_{01}, h_{11}$ and
# fractional position $(s, t) \in [0, 1]^2$, $h = (1-s)(1-t) h_{00} + s(1-t) h_{10} + (1-s)t\, h_{01} + st\, h_{11}$.
# A particle off the map has no terrain under it: likelihood zero, log-likelihood $-\infty$.
#
# :::{admonition} Algorithm 17.1: the bootstrap particle filter for terrain navigation
# :class: algorithm
# 1. **Initialise.** Draw $x_0^i \sim \mathcal N(\hat x_0, P_0)$, $i = 1, \dots, N$; $\log W_0^i = -\log N$.
# 2. **For** $k = 1, 2, \dots$:
#    1. *propagate:* $x_k^i = f(x_{k-1}^i) + w_k^i$, $w_k^i \sim \mathcal N(0, Q_f \Delta t)$, heading wrapped;
#    2. *weight:* if a reading $y_k$ arrived, $\log \tilde w_k^i = \log W_{k-1}^i + \log p(y_k \mid x_k^i)$ with
#       the bilinear height of the DEM ($-\infty$ off the map); normalise with a logsumexp;
#    3. *estimate:* $\hat x_k = \sum_i W_k^i x_k^i$ (the heading by its circular mean);
#    4. *resample* (multinomial) if $\mathrm{ESS}_k = 1/\sum_i (W_k^i)^2 < \tau N$, $\tau = 0.5$.
# :::
#
# `ParticleFilter(scenario.model(terrain), N, threshold=0.5, resampler="multinomial")` runs it.
# The weighting step in NumPy, on the engine's own particles of a flight, checked against the
# model's compiled likelihood:

# %%
import numpy as np


def altimeter_log_likelihood(particles, reading, terrain, Rf):
    """log N(y; z - h(x, y), Rf) per particle; -inf off the map."""
    # the ground under each particle (bilinear on the DEM), NaN off the map
    ground = terrain.height(particles[:, 0], particles[:, 1])
    # the height above the ground each particle predicts
    predicted = particles[:, 2] - ground
    log_lik = (-0.5 * (reading - predicted) ** 2 / Rf
               - 0.5 * np.log(2 * np.pi * Rf))
    return np.where(np.isnan(ground), -np.inf, log_lik)


# %% tags=["hide-input"] jupyter={"source_hidden": true}
model = scenario.model(terrain)
check_flight = simulate(scenario, terrain, data_rng(0, 0))
stored = ParticleFilter(model, 3000, threshold=0.5, resampler="multinomial").run(
    check_flight.measurements, rng=filter_rng(0, 0), collect=[Clouds()])
TOLERANCE = 1e-9  # in log-likelihood: round-off only
worst = 0.0
for k in (1, 5, 20, 80):
    ours = altimeter_log_likelihood(stored.particles[k], check_flight.measurements[k, 0], terrain, scenario.Rf)
    engine = model.log_likelihood(stored.particles[k], check_flight.measurements[k], k)
    assert np.array_equal(np.isinf(ours), np.isinf(engine))  # the same particles off the map
    worst = max(worst, np.abs(ours - engine)[np.isfinite(ours)].max())
print(f"largest difference from the engine's likelihood at steps 1, 5, 20, 80: {worst:.1e} (below {TOLERANCE:.0e})")
glue_values("terrain_likelihood_", tolerance=TOLERANCE)

# %% [markdown]
# The two agree to round-off (below {glue:text}`terrain_likelihood_tolerance:.0e`). One run is
# not evidence, so before looking at one flight we run the filter on $60$ seeded flights, to show
# a typical flight and a failed one.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
baseline_60 = flight_study(scenario, terrain, 60, seed=0)
final = final_errors(baseline_60)
print(f"final horizontal error over 60 flights: median {np.median(final):.0f} m, "
      f"10-90 %: {np.quantile(final, 0.1):.0f} to {np.quantile(final, 0.9):.0f} m")
print(f"diverged (final error > {DIVERGED_ERROR:.0f} m): {diverged(baseline_60).sum()} of 60")
good = int(np.flatnonzero(~diverged(baseline_60))[0])
bad = int(np.flatnonzero(diverged(baseline_60))[0])
print("a converged flight:", good, "  a diverged flight:", bad)
baseline_60_lost = evidence.rate(diverged(baseline_60))
print(f"share lost: {baseline_60_lost}")
glue("terrain_pf60_lost", baseline_60_lost.estimate, display=False)
glue("terrain_pf60_low", baseline_60_lost.low, display=False)
glue("terrain_pf60_high", baseline_60_lost.high, display=False)
glue("terrain_pf60_flights", int(len(final)), display=False)
glue("terrain_diverged_flight", bad, display=False)

# %% [markdown]
# The baseline loses the aircraft in {glue:text}`terrain_pf60_lost:.0%` of the
# {glue:text}`terrain_pf60_flights:d` flights (95 % interval {glue:text}`terrain_pf60_low:.0%` to
# {glue:text}`terrain_pf60_high:.0%`): more than half. We come back to this
# below, and the next chapter ({doc}`terrain_cure`) measures why on $100$ flights and finds
# remedies; first, a flight where it works. The filter is rerun on that flight with the same seed,
# storing the particles.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
pf = ParticleFilter(scenario.model(terrain), 3000, threshold=0.5, resampler="multinomial")
flight = simulate(scenario, terrain, data_rng(0, good))
run = pf.run(flight.measurements, rng=filter_rng(0, good), collect=[Clouds()])
err = run.mean - flight.truth  # estimate - truth, the book's sign
sig = np.sqrt(np.diagonal(run.cov, axis1=1, axis2=2))
t = flight.T

fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
for ax, j, name in zip(axes[:2], (0, 1), ("x (east)", "y (north)")):
    ax.fill_between(t, -3 * sig[:, j], 3 * sig[:, j], color=COLORS["estimate"], alpha=0.2, label=r"$\pm 3\sigma$ of the filter")
    ax.plot(t, err[:, j], color=COLORS["estimate"], label="error (estimate - truth)")
    ax.set_ylabel(f"{name} error (m)")
    ax.set_yscale("symlog", linthresh=100)
    ax.set_yticks([-1e4, -1e3, -100, 0, 100, 1e3, 1e4])
axes[2].plot(t, flight.terrain_height, color=COLORS["truth"], label="terrain under the aircraft")
axes[2].plot(t, flight.truth[:, 2] - flight.measurements[:, 0], ".", ms=3, color=COLORS["estimate"], label="altitude - altimeter reading")
axes[2].set_ylabel("height (m)")
axes[2].set_xlabel("time t (s)")
axes[0].set_title(f"Flight {good}: position error and 3-sigma band (N = 3000)")
(h0, l0), (h2, l2) = axes[0].get_legend_handles_labels(), axes[2].get_legend_handles_labels()
fig.legend(h0 + h2, l0 + l2, loc="upper center", ncols=2, bbox_to_anchor=(0.5, 0.0))  # under the figure, off the data
plt.show()
e_h = position_error(flight.truth, run.mean)
z = np.abs(err[:, :2]) / sig[:, :2]  # error in units of the filter's standard deviation, x and y
glue_values("terrain_error_", t0=float(e_h[0]), max=float(e_h.max()), final=float(e_h[-1]))

# %% [markdown]
# On this flight the horizontal error starts at {glue:text}`terrain_error_t0:.0f` m (the
# distance from the truth to the prior's mean), reaches {glue:text}`terrain_error_max:.0f` m while
# the filter hesitates between candidate places, and ends at
# {glue:text}`terrain_error_final:.0f` m once the flight has seen enough terrain. The error stays
# inside the $\pm 3\sigma$ band nearly everywhere (evidence below). The panels are linear below
# $100$ m and logarithmic above; the bottom panel is the terrain profile the readings reveal.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
EvidenceBlock(
    "the error of this flight stays inside the filter's 3-sigma band nearly everywhere",
    notes=[f"Horizontal error at t = 0, 10, 30, 80 s: {', '.join(f'{v:.0f}' for v in e_h[[0, 10, 30, 80]])} m; "
           f"largest {e_h.max():.0f} m at t = {t[np.argmax(e_h)]:.0f} s.",
           f"Error outside the band at {int(np.sum(z > 3))} of {z.size} (time, axis) points of the top two panels, "
           f"at t = {', '.join(f'{v:.0f}' for v in t[np.any(z > 3, axis=1)])} s; largest {z.max():.2f} sigma. "
           f"The prior's standard deviation is {np.sqrt(scenario.P0[0, 0]):.0f} m per axis."],
)

# %% [markdown]
# The animation shows the cloud over the map (every $3$ s; scrub with the slider). Each frame
# draws $600$ of the $3000$ particles, chosen by weight.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def map_window(flight, zoom=6.0):
    """Background of the cloud animation: the map around the middle of the flight (km)."""
    centre = flight.truth[len(flight.T) // 2, :2] / KM

    def draw(ax):
        heights = draw_map(ax, shaded=False)
        ax.figure.colorbar(heights, cax=ax.inset_axes([1.03, 0.1, 0.04, 0.8]), label="terrain height (m)")
        ax.set_xlim(centre[0] - zoom, centre[0] + zoom)
        ax.set_ylim(centre[1] - zoom, centre[1] + zoom)

    return draw


anim = animate_clouds(
    {"PF": run}, None, flight.truth, range(0, 81, 3), None, 250, blocks=[(0, 1)], ellipses=False,
    scale=1 / KM, unit="km", max_points=600, by_weight=True, trail=True, background=map_window(flight),
    title=lambda name, k, res: f"t = {flight.T[k]:.0f} s, error {position_error(flight.truth[k], res.mean[k]):.0f} m",
    legend=True,
)
HTML(anim.to_jshtml())

# %% [markdown]
# ## Why this problem needs a particle filter
#
# Watch the first seconds of the animation: the cloud does not shrink as one blob. After a
# few readings it breaks into separate clusters, each a place on the map whose terrain
# profile fits the readings so far, and only later do all but one die out. The posterior is
# *multimodal*. Each snapshot's title gives the share of the weight within $500$ m of the truth
# (the cross): at $t = 0$ the weights are equal and this is the prior's mass near the truth; it
# grows only as the readings rule out the other places, and the rest of the weight sits on the
# other candidate clusters.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, axes = plt.subplots(1, 4, figsize=(10, 3.5), layout="constrained")
for ax, k in zip(axes, (0, 4, 10, 30)):
    heights = draw_map(ax, shaded=False)
    w = run.weights[k]
    idx = np.random.default_rng(1).choice(len(w), 800, p=w)
    ax.plot(run.particles[k, idx, 0] / KM, run.particles[k, idx, 1] / KM, ".", ms=1.5, color=COLORS["particles"])
    ax.plot(flight.truth[k, 0] / KM, flight.truth[k, 1] / KM, "x", color=COLORS["truth"], ms=8, mew=2)
    near = np.sum(w[position_error(flight.truth[k], run.particles[k]) <= 500.0])
    ax.set_title(f"t = {k} s\n{near:.0%} of weight within 500 m")
    c = flight.truth[k, :2] / KM
    ax.set_xlim(c[0] - 6, c[0] + 6)
    ax.set_ylim(c[1] - 6, c[1] + 6)
    if k:
        ax.set_ylabel("")
fig.colorbar(heights, ax=axes, shrink=0.8, label="terrain height (m)")
plt.show()

# %% [markdown]
# A Kalman filter carries one Gaussian, so it must pick one of these modes, and an extended
# Kalman filter (EKF) picks it by linearising the terrain at its current estimate: its
# measurement Jacobian is $H = [-\partial h/\partial x, -\partial h/\partial y, 1, 0]$, the
# local slope of the DEM. With a prior $1.7$ km wide over terrain whose slope changes every
# $100$ m, that slope says nothing about where the aircraft is. `extended_kalman_filter` runs
# the EKF with exactly this Jacobian, on $100$ flights (the first $60$ are the particle
# filter's), from the same prior, and from a prior about $50$ times tighter ($30$ m).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
ekf = flight_study(scenario, terrain, 100, seed=0, method="ekf")
tight = scenario.with_(P0=np.diag([30.0, 30.0, 5.0, 0.01]) ** 2, Qf=np.diag([1.0, 1.0, 0.1, 0.001]) ** 2)
ekf_tight = flight_study(tight, terrain, 100, seed=0, method="ekf")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
ekf_lost = evidence.rate(diverged(ekf))
ekf_vs_pf = evidence.paired_rates(diverged(ekf)[:len(baseline_60)], diverged(baseline_60))
# the exercise on a wide Rf: the EKF with Rf = 200^2 on the first 50 flights, against Rf = 20^2 on the same flights
ekf_wide = flight_study(scenario.with_(Rf=200.0**2), terrain, 50, seed=0, method="ekf")
# "one flight in three converges, to tens or a hundred metres": the converged share of the particle filter's
# flights with its Wilson interval, and the final errors of the converged flights
pf_converged = evidence.rate(~diverged(baseline_60))
converged_final = final_errors(baseline_60)[~diverged(baseline_60)]
glue_values("terrain_", ekf_lost=ekf_lost.estimate, ekf_low=ekf_lost.low,
            ekf_vs_pf=f"{ekf_vs_pf.only_a} / {ekf_vs_pf.only_b}", ekf_vs_pf_p=ekf_vs_pf.pvalue,
            ekf_tight_lost=int(diverged(ekf_tight).sum()), ekf_flights=len(ekf),
            ekf_wide_lost=float(diverged(ekf_wide).mean()), ekf_first50_lost=float(diverged(ekf)[:50].mean()),
            pf60_converged=pf_converged.successes, pf60_converged_low=pf_converged.low,
            pf60_converged_high=pf_converged.high, pf60_converged_q10=float(np.quantile(converged_final, 0.1)),
            pf60_converged_median=float(np.median(converged_final)),
            pf60_converged_q90=float(np.quantile(converged_final, 0.9)))
summaries = pd.DataFrame([{"filter": name, **flight_summary(res)} for name, res in (
    ("EKF, wide prior", ekf), ("PF (N = 3000), wide prior", baseline_60), ("EKF, 30 m prior and small Qf", ekf_tight))])
EvidenceBlock(
    "the EKF loses almost every flight from the wide prior (the lab's), and almost none from a tight one",
    notes=[f"EKF lost share: {ekf_lost}. EKF vs particle filter on the same {len(baseline_60)} flights: "
           f"{ekf_vs_pf}.",
           f"Particle filter (N = 3000) converged: {pf_converged}; final error of the {len(converged_final)} "
           f"converged flights: median {np.median(converged_final):.0f} m, 10-90 % {np.quantile(converged_final, 0.1):.0f} "
           f"to {np.quantile(converged_final, 0.9):.0f} m, largest {converged_final.max():.0f} m.",
           f"EKF with Rf = 200^2 on the first 50 flights: lost {diverged(ekf_wide).mean():.2f} "
           f"(Rf = 20^2 on the same flights: {diverged(ekf)[:50].mean():.2f})."],
    tables=[("Lost share and final error (m) per filter", summaries[["filter", "diverged", "final_median", "final_q10",
                                                                      "final_q90"]],
             {"diverged": ".2f", "final_median": ".0f", "final_q10": ".0f", "final_q90": ".0f"})],
)

# %% [markdown]
# The EKF diverges from the wide prior in almost every flight
# ({glue:text}`terrain_ekf_lost:.0%` of {glue:text}`terrain_ekf_flights:d`), far more often than the
# particle filter on the same flights (evidence above). The
# EKF is not broken: started from a $30$ m prior with small process noise, its linearisation holds
# and it loses {glue:text}`terrain_ekf_tight_lost:d` flights. Its failure from the wide prior is
# the multimodality above, not a bug.
#
# The particle filter's own failure rate is what a single run cannot show. On our map about one
# flight in three converges ({glue:text}`terrain_pf60_converged:d` of
# {glue:text}`terrain_pf60_flights:d`), to a median {glue:text}`terrain_pf60_converged_median:.0f` m,
# and the others are lost kilometres away: a single final error is a draw from a very wide,
# two-humped distribution.

# %% [markdown]
# ## Each setting, on a filter that works
#
# Around a filter that loses two flights in three, a study of its settings compares divergence
# noise. The chapter {doc}`terrain_cure` finds a filter that works: the **regularised particle
# filter** with $N = 30\,000$ (after each resampling every particle moves by a Gaussian kernel
# draw at $0.2$ times the optimal bandwidth). Here each study varies one setting of the lab's
# around that baseline, on the same {glue:text}`studies_flights:d` flights for every setting. With
# every setting that takes too long for this page, so the runs were computed by
# `python3 tasks.py study terrain_studies` and stored in `book/data/terrain_studies.csv` with
# their provenance; a test re-computes a sample of rows.
#
# Each setting is compared with the baseline **on the same flights**: the share of flights lost,
# and, on the flights both converge on, the median ratio of final errors with its 95 % interval.
# Each study's table and tests, and the lab's single-run answer, are in its evidence block.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
studies_table = STUDIES["terrain_studies"].load()
studies_meta = studies_table.attrs["provenance"]
base_rows = studies_table[studies_table["study"] == "baseline"].sort_values("flight")
# wall time of one run, as stored by the study (one row per flight and setting; indicative only)
base_s = evidence.median_interval(base_rows["seconds"].to_numpy())
fast_rows = studies_table[studies_table["setting"] == "every 0.1 s, dt = 0.1 s"].sort_values("flight")
fast_s = evidence.paired(fast_rows["seconds"].to_numpy(), base_rows["seconds"].to_numpy(), ratio=True)
glue_values("studies_", flights=int(studies_meta["n_flights"]), base_seconds=base_s[0], base_seconds_low=base_s[1],
            base_seconds_high=base_s[2], fast_over_base=fast_s.median, fast_over_base_low=fast_s.low,
            fast_over_base_high=fast_s.high)
base_lost_flags = base_rows["lost"].to_numpy(bool)
base_lost = evidence.rate(base_lost_flags)
glue_values("studies_", base_lost=base_lost.estimate, base_low=base_lost.low, base_high=base_lost.high,
            base_error=float(np.median(base_rows.loc[~base_rows["lost"], "final_error"])))
EvidenceBlock(
    f"the baseline loses {base_lost.estimate:.2f} of the {studies_meta['n_flights']} flights",
    notes=[f"Made by {studies_meta['code']} at commit {studies_meta['git_commit'][:10]}; {studies_meta['seeds']}.",
           f"Baseline (regularised, N = 30 000): lost {base_lost}; median final error of the converged flights "
           f"{np.median(base_rows.loc[~base_rows['lost'], 'final_error']):.0f} m.",
           f"Wall time of a baseline run when the study was computed: median {base_s[0]:.2f} s (95 % interval "
           f"{base_s[1]:.2f}-{base_s[2]:.2f} s, shared machine); a 10 Hz run takes {fast_s.median:.1f} times as long "
           f"(median paired ratio, {fast_s.low:.1f}-{fast_s.high:.1f})."],
)


# %% tags=["remove-input"] jupyter={"source_hidden": true}
def versus_baseline(study):
    """Each setting of ``study`` against the baseline: lost share, McNemar, paired error ratio; and the table."""
    rows, out = [], {}
    names = ["baseline"] + list(studies_table.loc[studies_table["study"] == study, "setting"].unique())
    for name in names:
        g = base_rows if name == "baseline" else studies_table[
            (studies_table["study"] == study) & (studies_table["setting"] == name)].sort_values("flight")
        lost = g["lost"].to_numpy(bool)
        r = evidence.rate(lost)
        line = {"setting": name, "flights": len(g), "lost": r.estimate, "lost 95% CI": f"{r.low:.2f}-{r.high:.2f}",
                "median final error, converged (m)": (np.median(g.loc[~g["lost"], "final_error"])
                                                      if (~g["lost"]).any() else np.nan)}
        if name != "baseline":
            mc = evidence.paired_rates(lost, base_lost_flags)
            both = ~lost & ~base_lost_flags
            line.update({"lost here / baseline only": f"{mc.only_a} / {mc.only_b}", "McNemar p": mc.pvalue,
                         "difference of lost shares": f"{mc.difference:+.2f} ({mc.difference_low:+.2f} to "
                                                      f"{mc.difference_high:+.2f})",
                         "both converged": int(both.sum())})
            ratio = None
            if both.sum() >= 6:  # fewer pairs cannot reach p < 0.05 with the signed-rank test
                ratio = evidence.paired(g["final_error"].to_numpy()[both], base_rows["final_error"].to_numpy()[both],
                                        ratio=True)
                line.update({"error ratio": ratio.median, "ratio 95% CI": f"{ratio.low:.2f}-{ratio.high:.2f}",
                             "Wilcoxon p": ratio.pvalue})
            out[name] = (r, mc, ratio)
        rows.append(line)
    return out, pd.DataFrame(rows)


def study_evidence(prefix, study, title, notes=()):
    """Glue each setting's lost share, McNemar p, error ratio and its interval; the study's evidence block."""
    results, table = versus_baseline(study)
    for k, (name, (r, mc, ratio)) in enumerate(results.items()):
        glue_values(f"{prefix}_{k}_", lost=r.estimate, p_lost=mc.pvalue, diff_low=mc.difference_low,
                    diff_high=mc.difference_high)
        if ratio is not None:
            glue_values(f"{prefix}_{k}_", ratio=ratio.median, ratio_low=ratio.low, ratio_high=ratio.high,
                        p_ratio=ratio.pvalue)
    formats = {c: f for c, f in (("lost", ".2f"), ("McNemar p", ".2g"), ("median final error, converged (m)", ".0f"),
                                 ("error ratio", ".2f"), ("Wilcoxon p", ".2g")) if c in table.columns}
    return EvidenceBlock(title, notes=["Same flights and filter seeds for every row (see Reading the evidence)."]
                         + list(notes), tables=[(f"Study of {study} against the baseline", table, formats)])


study_evidence("qf", "Qf", "only Qf x 10 and x 100 change the outcome",
               notes=["The lab report, one flight each: Qf / 10 ended 177 m from the truth against 309 m for the "
                      "baseline, Qf x 10 420 m, Qf x 100 1144 m (diverged)."])

# %% [markdown]
# **$Q_f$.** Around the working baseline, $Q_f \times 0.1$ changes nothing the
# study can detect (error ratio {glue:text}`qf_0_ratio:.2f`, 95 % interval
# {glue:text}`qf_0_ratio_low:.2f`-{glue:text}`qf_0_ratio_high:.2f`), while $Q_f \times 10$ loses
# {glue:text}`qf_1_lost:.2f` of the flights: a larger $Q_f$ spreads the cloud over more places
# than the particles can cover.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
study_evidence("rf", "Rf", "the true Rf loses the fewest flights; a larger Rf is less accurate",
               notes=["The lab report: a larger Rf spreads the particles more and slows convergence."])

# %% [markdown]
# **$R_f$.** With a filter that works, the true value loses the fewest flights: $R_f = 10^2$ loses
# {glue:text}`rf_0_lost:.2f`, and on the flights both converge $R_f = 50^2$ ends
# {glue:text}`rf_1_ratio:.2f` times the baseline's error: a likelihood wider than the altimeter's
# noise throws information away.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
study_evidence("n", "N", "fewer particles lose more flights; once found, the error changes less",
               notes=["The lab report, one flight each: N = 300 ended 8018 m from the truth, N = 30 000 78 m."])

# %% [markdown]
# **$N$.** Around the regularised filter, $N = 3000$ loses {glue:text}`n_0_lost:.2f` of the
# flights; on the flights that converge its error ratio is only
# {glue:text}`n_0_ratio:.2f`. The number of particles decides whether the filter finds the
# aircraft; once found, its accuracy is the terrain's.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
th = studies_table[studies_table["study"] == "threshold"]
glue_values("th_", resamplings_every=int(th.loc[th["setting"] == "threshold 1", "resamplings"].median()),
            resamplings_base=int(base_rows["resamplings"].median()))
study_evidence("th", "threshold", "never resampling loses flights; resampling at every reading changes little",
               notes=["The lab report: threshold 0 (never resample) degenerates, 0.5 works, 1 degenerates too.",
                      f"Resamplings per flight (median): baseline {int(base_rows['resamplings'].median())}, "
                      + ", ".join(f"{n} {int(g['resamplings'].median())}" for n, g in th.groupby("setting"))])

# %% [markdown]
# **Resampling threshold.** Without resampling (threshold $0$) the filter loses
# {glue:text}`th_0_lost:.2f` of the flights. Resampling at every reading (threshold $1$) loses
# {glue:text}`th_1_lost:.2f`, not told apart from the baseline, with an error ratio of
# {glue:text}`th_1_ratio:.2f`: it adds resampling noise, little enough here.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
gap_rows = studies_table[studies_table["study"] == "gap"].sort_values("flight")
ok = ~gap_rows["lost"].to_numpy(bool)
assert np.array_equal(base_rows["flight"].to_numpy(), gap_rows["flight"].to_numpy())
# the growth run by run: sigma at 75 s over sigma at 50 s in the gap run, and the gap run's sigma at 75 s over the
# baseline's on the same flights (converged flights of the gap run)
gap_growth = evidence.paired(gap_rows["sigma_75"].to_numpy()[ok], gap_rows["sigma_50"].to_numpy()[ok], ratio=True)
gap_vs_base = evidence.paired(gap_rows["sigma_75"].to_numpy()[ok], base_rows["sigma_75"].to_numpy()[ok], ratio=True)
assert gap_growth.verdict() == "A higher" and gap_vs_base.verdict() == "A higher"
glue_values("gap_", sigma_50=float(np.median(gap_rows["sigma_50"].to_numpy()[ok])),
            sigma_75=float(np.median(gap_rows["sigma_75"].to_numpy()[ok])), sigma_growth=gap_growth.median,
            sigma_growth_low=gap_growth.low, sigma_growth_high=gap_growth.high, sigma_growth_n=gap_growth.n,
            sigma_vs_base=gap_vs_base.median, sigma_vs_base_low=gap_vs_base.low, sigma_vs_base_high=gap_vs_base.high)
study_evidence("gap", "gap", "the gap grows the uncertainty and loses flights",
               notes=["The lab report: the uncertainty grows during the gap, but the estimate stays good.",
                      f"Filter sigma, gap run, flights it converges on: median {np.median(gap_rows['sigma_50'][ok]):.0f} m "
                      f"at 50 s, {np.median(gap_rows['sigma_75'][ok]):.0f} m at 75 s; run by run, 75 s over 50 s: "
                      f"{gap_growth}; gap run over the baseline at 75 s, same flights: {gap_vs_base}."])

# %% [markdown]
# **Measurement gap.** Run by run, the filter's standard deviation ends the $25$ s without
# readings at {glue:text}`gap_sigma_growth:.1f` times what it was at $50$ s (95 % interval
# {glue:text}`gap_sigma_growth_low:.1f`-{glue:text}`gap_sigma_growth_high:.1f`). And the estimate
# does not stay good: the gap loses {glue:text}`gap_0_lost:.2f` of the flights, because at $50$ s many flights
# have not yet settled on one place.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
per = studies_table[studies_table["study"] == "period"]
fast = per[per["setting"] == "every 0.1 s, dt = 0.1 s"]
glue_values("period_", fast_resamplings=float(fast["resamplings"].median()),
            base_resamplings=float(base_rows["resamplings"].median()),
            resampling_ratio=float(fast["resamplings"].median() / base_rows["resamplings"].median()))
study_evidence("period", "period", "measuring at 10 Hz ends closer to the truth; every 10 s loses most flights",
               notes=["The lab report measured 'every 0.1 s' by testing mod(t, 0.1) == 0 on a filter that steps "
                      "every second, which is true at every step: its 10 Hz run was the baseline."] +
                     [f"{name}: resamplings per flight median {g['resamplings'].median():.0f}, median ESS/N at readings "
                      f"{g['median_ess_fraction'].median():.2f}"
                      for name, g in [("every 1 s (baseline)", base_rows)] + list(per.groupby("setting"))])

# %% [markdown]
# **Measurement period.** A $10$ Hz filter needs $\Delta t = 0.1$ s ($801$ steps, $Q_f$ per second
# unchanged). At $10$ Hz the regularised filter ends at {glue:text}`period_1_ratio:.2f` times the
# baseline's error ({glue:text}`period_1_ratio_low:.2f`-{glue:text}`period_1_ratio_high:.2f`): the
# ten times more readings help, as they should, here where the filter's map is the world's
# ({doc}`terrain_cure` re-measures it with a map that is not, and there it fails). The kernel
# move after each resampling keeps the cloud from running out of distinct particles.
#
# Every $10$ s, the filter loses {glue:text}`period_0_lost:.2f` of the flights: eight readings are
# too few.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
study_evidence("scheme", "scheme", "the three resampling schemes are not told apart",
               notes=["The lab report, from single runs: stratified first, then systematic, then multinomial."])

# %% [markdown]
# **Resampling scheme** {cite:p}`hol2006`. Against multinomial (the baseline), stratified ends at
# {glue:text}`scheme_0_ratio:.2f` times its error
# ({glue:text}`scheme_0_ratio_low:.2f`-{glue:text}`scheme_0_ratio_high:.2f`) and systematic at
# {glue:text}`scheme_1_ratio:.2f`: no difference detected, and the intervals bound any difference
# in accuracy to a few percent (a difference in losses of a few flights in a hundred could still
# hide in the study).
#
# The figure gathers the losses of every setting against the baseline's interval.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
order = [(s, n) for s in ("Qf", "Rf", "N", "threshold", "gap", "period", "scheme")
         for n in studies_table.loc[studies_table["study"] == s, "setting"].unique()]
fig, ax = plt.subplots(figsize=(7, 4.6), constrained_layout=True)
for y, (study, name) in enumerate(order):
    g = studies_table[(studies_table["study"] == study) & (studies_table["setting"] == name)]
    r = evidence.rate(g["lost"].to_numpy(bool))
    ax.errorbar(r.estimate, y, xerr=[[r.estimate - r.low], [r.high - r.estimate]], fmt="o", ms=4,
                color=COLORS["estimate"], capsize=2)
ax.axvspan(base_lost.low, base_lost.high, color=COLORS["kalman"], alpha=0.2, label="baseline, 95 % interval")
ax.axvline(base_lost.estimate, color=COLORS["kalman"], lw=1)
ax.set_yticks(range(len(order)), [f"{s}: {n}" for s, n in order])
ax.invert_yaxis()
ax.set_xlabel("share of the 100 flights lost (95 % interval)")
ax.legend(loc="lower right")
plt.show()

# %% [markdown]
# ## Try it
#
# The panel reruns one flight with the settings you choose and draws the truth, the estimate
# and the final cloud, with the error over time. Seed {glue:text}`terrain_diverged_flight:d` is a
# flight that the baseline loses: the page shows it with the other settings at the values the panel
# opens with; in JupyterLab, try more particles or a larger $R_f$ on it.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw(qf_scale=1.0, rf_scale=1.0, n_particles=3000, threshold=0.5, scheme="multinomial", seed=0):
    sc = scenario.with_(Qf=scenario.Qf * qf_scale, Rf=scenario.Rf * rf_scale)
    fl = simulate(sc, terrain, data_rng(0, seed))
    res = ParticleFilter(sc.model(terrain), n_particles, threshold=threshold, resampler=scheme).run(
        fl.measurements, rng=filter_rng(0, seed), collect=[Clouds()])
    # the map's colour bar (taken from the left axes) keeps clear of the error axis's labels
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2), width_ratios=[1, 1.3], gridspec_kw={"wspace": 0.38})
    c = fl.truth[40, :2] / KM
    fig.colorbar(draw_map(ax1, shaded=False, window=((c[0] - 7, c[0] + 7), (c[1] - 7, c[1] + 7))), ax=ax1,
                 shrink=0.8, label="terrain height (m)")
    idx = np.random.default_rng(0).choice(n_particles, min(n_particles, 600), p=res.weights[-1])
    ax1.plot(res.particles[-1, idx, 0] / KM, res.particles[-1, idx, 1] / KM, ".", ms=2, color=COLORS["particles"])
    ax1.plot(fl.truth[:, 0] / KM, fl.truth[:, 1] / KM, color=COLORS["truth"], label="truth")
    ax1.plot(res.mean[:, 0] / KM, res.mean[:, 1] / KM, color=COLORS["estimate"], label="estimate")
    ax1.set_xlim(c[0] - 7, c[0] + 7)
    ax1.set_ylim(c[1] - 7, c[1] + 7)
    ax1.legend(loc="lower left")
    e = position_error(fl.truth, res.mean)
    ax2.plot(fl.T, e, color=COLORS["estimate"], label="horizontal error")
    ax2.plot(fl.T, 3 * np.sqrt(res.cov[:, 0, 0] + res.cov[:, 1, 1]), "--", color=COLORS["estimate"], alpha=0.6,
             label=r"$3\sqrt{P_{xx} + P_{yy}}$")
    plain_log_axis(ax2, "y")
    ax2.set_xlabel("time t (s)")
    ax2.set_ylabel("error (m)")
    ax2.legend(loc="upper right")
    ax2.set_title(f"final error {e[-1]:.0f} m")


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
panel = control_panel(
    draw,
    grid={"n_particles": (300, 1000, 3000), "rf_scale": (1.0, 2.0, 5.0)},
    qf_scale=scale_slider("Qf scale"),
    rf_scale=scale_slider("Rf scale"),
    n_particles=particle_slider(3000, 2, 3),
    threshold=threshold_slider(0.5),
    scheme=scheme_dropdown("multinomial"),
    seed=seed_box(0),
)
display(panel)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 17.1 Metres per cell
# :label: ex-terrain-units
# :nonumber:
# A cell of the DEM spans $3$ arc-seconds in each direction. Compute its width and height in
# metres at the map's latitude (about $36.3°$ N), and explain why a map that treated degrees of
# longitude and latitude alike would stretch every east-west slope.
# ```
#
# ```{solution} ex-terrain-units
# :class: dropdown
# $3$ arc-seconds is $1/1200$ degree. North-south: $6371\,\text{km} \times \pi/180 / 1200
# \approx 92.7$ m. East-west: the same times $\cos 36.3° \approx 0.806$, about $74.7$ m. Treating
# both as $92.7$ m would make the map $24\,\%$ too wide, and every east-west height difference would
# be spread over $24\,\%$ more distance: slopes, and so the EKF's Jacobian, would be $24\,\%$ too small
# in $x$, and a particle's $x$ would map to the wrong column.
# ```
#
# ```{exercise} 17.2 A wider likelihood
# :label: ex-terrain-rf
# :nonumber:
# With the bootstrap filter, the first version of this chapter's study of $R_f$ found that
# $R_f = 50^2$ diverges less often than the true noise variance $R_f = 20^2$ (the regularised
# filter above does not). Explain why using a likelihood wider than the truth can help a particle filter
# with too few particles, and what it costs once the filter has converged.
# ```
#
# ```{solution} ex-terrain-rf
# :class: dropdown
# With $3000$ particles in a prior kilometres wide, the particle nearest the truth is typically
# $100$ m or more away, where the terrain height can differ by tens of metres. The likelihood
# with $R_f = 20^2$ gives such a particle a weight $e^{-(40/20)^2/2} \approx 0.14$ of the best
# possible, or far less, and a particle elsewhere that matches the readings by chance wins the
# resampling. A wider $R_f$ keeps the near-truth particles alive until later readings
# separate the modes. The cost: the filter ignores part of the information in each reading,
# so it converges more slowly and its final cloud is wider than needed (the converged runs'
# errors in the table). More particles fix the same problem without the cost.
# ```
#
# ```{exercise} 17.3 A wider likelihood for the EKF
# :label: ex-terrain-ekf
# :nonumber:
# Use `extended_kalman_filter` on the flights of the chapter with the wide prior, but with
# $R_f = 200^2$. Does a very wide $R_f$ rescue the EKF as a wider $R_f$ helped the particle
# filter? Measure the divergence rate over $50$ flights and explain.
# ```
#
# ```{solution} ex-terrain-ekf
# :class: dropdown
# `flight_summary(flight_study(scenario.with_(Rf=200.0**2), terrain, 50, method="ekf"))["diverged"]`
# is {glue:text}`terrain_ekf_wide_lost:.2f`: the EKF still loses the aircraft in most flights
# ({glue:text}`terrain_ekf_first50_lost:.2f` with $R_f = 20^2$ on the same $50$ flights). A wider $R_f$ only makes each EKF update smaller;
# it does not change the direction of the update, which comes from the terrain slope at the
# current estimate, kilometres from the truth, and so carries no information about where the
# truth is. The particle filter, by contrast, evaluates the likelihood everywhere in the
# prior; widening it only delays the choice between modes.
# ```
#
# ```{exercise} 17.4 Write the altimeter's likelihood, and have it checked
# :label: ex-terrain-likelihood
# :nonumber:
# (Coding.) Write `my_log_likelihood(particles, y, heights, dx, dy, rf)`: the weighting step
# of Algorithm 17.1 without the help of `TerrainMap.height`. `particles` has shape `(N, 4)`, rows
# $(x, y, z, \psi)$ in metres; `heights[i, j]` is the terrain height at $(j\,dx, i\,dy)$, row $0$
# the southern edge; `rf` is the variance $R_f$. Interpolate the height bilinearly, return
# $\log \mathcal N(y; z - h(x, y), R_f)$ for each particle, and $-\infty$ for a particle outside
# $[0, (n_x - 1)\,dx] \times [0, (n_y - 1)\,dy]$. The checker compares it with the exact values on
# a small map whose cells are not square, and names the typical mistakes.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_altimeter_likelihood


def my_log_likelihood(particles, y, heights, dx, dy, rf):
    """Your altimeter log-likelihood: return an array of shape (N,)."""
    ...  # replace with your code


print(check_altimeter_likelihood(my_log_likelihood))

# %% [markdown]
# ```{solution} ex-terrain-likelihood
# :class: dropdown
# The cell's corner $(i, j)$ is the integer part of $(y/dy, x/dx)$, kept inside the grid so that
# a particle on the last row or column still has a cell; $(s, t)$ are the fractional parts. The
# code is in the folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_log_likelihood(particles, y, heights, dx, dy, rf):
    ny, nx = heights.shape
    col, row = particles[:, 0] / dx, particles[:, 1] / dy
    inside = (col >= 0) & (col <= nx - 1) & (row >= 0) & (row <= ny - 1)
    j = np.clip(np.floor(col), 0, nx - 2).astype(int)
    i = np.clip(np.floor(row), 0, ny - 2).astype(int)
    s, t = np.clip(col - j, 0, 1), np.clip(row - i, 0, 1)
    h = ((1 - s) * (1 - t) * heights[i, j] + s * (1 - t) * heights[i, j + 1]
         + (1 - s) * t * heights[i + 1, j] + s * t * heights[i + 1, j + 1])
    log_lik = -0.5 * (y - (particles[:, 2] - h)) ** 2 / rf - 0.5 * np.log(2 * np.pi * rf)
    return np.where(inside, log_lik, -np.inf)


print(check_altimeter_likelihood(my_log_likelihood))

# %% [markdown]
# ## Takeaways
#
# - Terrain navigation weighs each particle by the altimeter's likelihood on the map: a bilinear
#   height lookup, $-\infty$ off the map; nothing in it needs a formula or a derivative.
# - A terrain profile fits several places at once, so the posterior is multimodal and an EKF,
#   which linearises one slope at its own guess, loses almost every flight from a wide prior.
# - The lab's filter loses most flights too: one run that converged said nothing about that, and
#   a hundred seeded flights with common random numbers and paired tests do.
# - Around a filter that works, the number of particles decides whether the aircraft is found;
#   $Q_f$, $R_f$ and the resampling threshold matter at their extremes, and the scheme makes no difference the
#   study detects.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab B ({doc}`../labs`) flies this scenario (its lengths three times ours) and asks how $Q_f$,
# $R_f$, $N$, the resampling threshold and scheme, a gap in the readings and the reading period
# change the final error. Its report answered from one run each; the baseline run it took as the
# filter's accuracy ended $309$ m from the truth, while that filter loses most flights here
# ("Why this problem needs a particle filter"). Each setting's study above gives the report's
# single-run answer in its evidence block beside the hundred-flight one; its $10$ Hz run was in
# fact the $1$ Hz baseline.
# :::
