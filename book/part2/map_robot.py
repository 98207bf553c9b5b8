# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A robot on a map: likelihood-field Monte Carlo localization
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** Monte Carlo localization as robotics teaches it: a robot that drives through rooms
# and a corridor, its odometry modelled by rotation-translation-rotation, its range scanner scored by
# the likelihood field of an occupancy grid; and what it takes to find the robot when the rooms look alike.
#
# **You need** {doc}`robot` and {doc}`global_localization`; Gaussian densities; NumPy arrays.
#
# **Time:** about twenty-eight minutes to read; the notebook runs in about ten seconds on a quiet machine
# (longer on a busy one); its four studies are stored, as they take minutes.
# :::
#
# The robot of {doc}`robot` reads the range and bearing of landmarks it recognises. A robot in a
# building has neither: it has wheels that count their turns (odometry) and a laser scanner that
# measures the distance to the nearest wall in many directions, and it carries a map of the walls.
# This chapter localizes such a robot with the models of *Probabilistic Robotics*
# {cite:p}`thrun2005`: the odometry motion model (their table $5.6$) and the likelihood-field sensor
# model (their table $6.3$), inside the loop of Monte Carlo localization (MCL).
#
# **Why the map is simulated.** The classic laser logs (the Intel Research Lab, Freiburg or Orebro
# recordings) are distributed as files of dataset archives and robot-software bags, not as packages
# of the registries this book installs from, so a notebook cannot load one reproducibly. The map,
# the drive and the scans below are simulated, with the noise models the filter assumes and one it
# does not (the scanner's beam noise), and every run is seeded.

# %%
import json

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy.special import logsumexp

from pfcourse import evidence
from pfcourse.exercises import check_likelihood_field
from pfcourse.experiments import maprobot as study
from pfcourse.experiments.registry import STUDIES
from pfcourse.figures.report import EvidenceBlock, glue_values
from pfcourse.filter import ParticleFilter
from pfcourse.maprobot import MapRobotModel, OdometryModel
from pfcourse.maprobot.figures import draw_map, draw_scan
from pfcourse.maprobot.grid import ROUTE
from pfcourse.metrics import heading_error, position_error
from pfcourse.resampling import systematic
from pfcourse.style import COLORS, use_style

use_style()
grid = study.book_map()  # 0.1 m cells
scanner, field = study.SCANNER, study.field()
DEMO_SEED = 0
demo = study.simulate(DEMO_SEED, study.TRACKING_STEPS)
print(f"map {grid.width:.0f} m x {grid.height:.0f} m in {grid.occupied.size} cells, "
      f"{grid.free_area:.0f} m² free; {scanner.n_beams} beams, max range {scanner.max_range:.0f} m")

# %% [markdown]
# ## The map, the drive and a scan
#
# The map is an occupancy grid: the floor cut into square cells of $0.1$ m, each free or occupied.
# A corridor runs between two rows of four identical rooms, each with a door at its middle; a single
# box stands in one room. Almost every place has a twin: the map is symmetric under a half-turn
# about its centre and, away from the corridor's ends, under a shift by one room. Only the box, and
# the corridor's ends when they are in range, tell the twins apart.
#
# The robot drives a loop of waypoints at $0.5$ m/s, into three of the rooms (one of them the box's),
# and scans every $\Delta t = 0.5$ s: $24$ beams around it, up to $z_{\max} = 8$ m.

# %%
fig, ax = plt.subplots(figsize=(9, 5))
draw_map(ax, grid)
ax.plot(*np.vstack([ROUTE, ROUTE[:1]]).T, ":", color=COLORS["robot"], label="route (waypoints)")
ax.plot(demo.truth[:, 0], demo.truth[:, 1], color=COLORS["truth"], lw=1, label="one drive (80 s)")
k_show = 68  # in the box's room
draw_scan(ax, demo.truth[k_show], demo.scans[k_show], scanner.angles, scanner.max_range)
ax.plot([], [], "o-", color="tab:red", ms=3, label=f"its scan at t = {k_show * study.DT:.0f} s")
ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax.set_title("The map: four look-alike rooms on each side of a corridor, one box")
plt.show()

# %% [markdown]
# ## The odometry motion model
#
# Between two scans the wheel encoders report how the robot moved, as three numbers
# $u_k = (\delta_{\mathrm{rot1}}, \delta_{\mathrm{trans}}, \delta_{\mathrm{rot2}})$: turn by
# $\delta_{\mathrm{rot1}}$ towards the direction of travel, drive $\delta_{\mathrm{trans}}$ straight,
# turn by $\delta_{\mathrm{rot2}}$. From two odometry poses $(\bar x, \bar y, \bar\theta)$ and
# $(\bar x', \bar y', \bar\theta')$ these are
# $\delta_{\mathrm{trans}} = \sqrt{(\bar x' - \bar x)^2 + (\bar y' - \bar y)^2}$,
# $\delta_{\mathrm{rot1}} = \operatorname{atan2}(\bar y' - \bar y, \bar x' - \bar x) - \bar\theta$ and
# $\delta_{\mathrm{rot2}} = \bar\theta' - \bar\theta - \delta_{\mathrm{rot1}}$.
#
# Wheels slip, so the true motion differs from each increment by a zero-mean Gaussian error whose
# variance grows with the motion. Four parameters $a_1, \dots, a_4$ (the $\alpha_1, \dots, \alpha_4$ of
# {cite:t}`thrun2005`) say how much: rotation error per rotation and per distance, distance error per
# distance and per rotation,
#
# $$
# \hat\delta_{\mathrm{rot1}} = \delta_{\mathrm{rot1}} - \eta_1, \quad
# \hat\delta_{\mathrm{trans}} = \delta_{\mathrm{trans}} - \eta_2, \quad
# \hat\delta_{\mathrm{rot2}} = \delta_{\mathrm{rot2}} - \eta_3,
# $$
#
# $$
# \eta_1 \sim \mathcal N(0,\, a_1 \delta_{\mathrm{rot1}}^2 + a_2 \delta_{\mathrm{trans}}^2), \quad
# \eta_2 \sim \mathcal N(0,\, a_3 \delta_{\mathrm{trans}}^2 + a_4 (\delta_{\mathrm{rot1}}^2 + \delta_{\mathrm{rot2}}^2)), \quad
# \eta_3 \sim \mathcal N(0,\, a_1 \delta_{\mathrm{rot2}}^2 + a_2 \delta_{\mathrm{trans}}^2),
# $$
#
# and the pose moves by the perturbed increments:
#
# $$
# x' = x + \hat\delta_{\mathrm{trans}} \cos(\theta + \hat\delta_{\mathrm{rot1}}), \quad
# y' = y + \hat\delta_{\mathrm{trans}} \sin(\theta + \hat\delta_{\mathrm{rot1}}), \quad
# \theta' = \theta + \hat\delta_{\mathrm{rot1}} + \hat\delta_{\mathrm{rot2}} .
# $$
#
# Drawing $x_k^i$ this way from each particle's $x_{k-1}^i$ *is* sampling the transition
# $p(x_k \mid x_{k-1}, u_k)$: no density is ever evaluated. Here every $a_j = 0.05$, in the
# simulator and in the filter alike. The function below is the sampler in NumPy, for a whole cloud
# at once, checked against the package's.

# %%
A = np.array(study.MOTION.alphas)  # a_1, ..., a_4


def sample_motion(x, u, rng, A=A):
    """Table 5.6 for every row of x (N, 3): one standard normal triple per particle."""
    rot1, trans, rot2 = u
    sd = np.sqrt([A[0] * rot1**2 + A[1] * trans**2,
                  A[2] * trans**2 + A[3] * (rot1**2 + rot2**2),
                  A[0] * rot2**2 + A[1] * trans**2])
    e = rng.standard_normal((len(x), 3)) * sd
    heading = x[:, 2] + rot1 - e[:, 0]
    return np.column_stack([x[:, 0] + (trans - e[:, 1]) * np.cos(heading),
                            x[:, 1] + (trans - e[:, 1]) * np.sin(heading),
                            np.angle(np.exp(1j * (heading + rot2 - e[:, 2])))])


u = np.array([0.3, 1.0, 0.0])
start = np.zeros((2000, 3))
A_TURNS = np.array([0.05, 0.05, 0.002, 0.002])  # rotation errors dominate: the banana
cloud = sample_motion(start, u, np.random.default_rng(1), A_TURNS)
same = np.allclose(cloud, OdometryModel(tuple(A_TURNS)).sample(start, u, np.random.default_rng(1)), rtol=0, atol=1e-12)
print(f"the same poses as pfcourse.maprobot.OdometryModel.sample, to 1e-12: {same}")

# %%
fig, ax = plt.subplots(figsize=(6, 3.6))
ax.plot(cloud[:, 0], cloud[:, 1], ".", ms=2, color=COLORS["particles"], label="2000 draws of x'")
ax.plot(0, 0, "s", color=COLORS["truth"], label="x (heading along x)")
ax.set_xlabel("x (m)")
ax.set_ylabel("y (m)")
ax.set_aspect("equal")
ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax.set_title("One step of the odometry model: turn 0.3 rad, drive 1 m")
plt.show()

# %% [markdown]
# With rotation errors larger than distance errors ($a_1 = a_2 = 0.05$, $a_3 = a_4 = 0.002$ in this
# figure) the cloud is a banana: an error in the first rotation swings the robot along an arc, an
# error in the distance moves it along the arc's radius.
#
# ## The likelihood field
#
# The scanner simulated here follows the *beam model* of {cite:t}`thrun2005` (their section $6.3$): each
# beam returns the distance $z^\ast$ to the first wall along it plus Gaussian noise of $5$ cm with
# probability $0.85$, a short reading (something unmapped in the way) with probability $0.05$, no
# echo ($z = z_{\max}$) with probability $0.05$, and a random reading, uniform on $[0, z_{\max}]$,
# with probability $0.05$. Scoring a particle by the beam model would cast every one of its beams
# through the grid. The *likelihood field* does not: it takes the end point of beam $b$ seen from
# pose $x = (x, y, \theta)$,
#
# $$
# e_b = \big(x + z_b \cos(\theta + \phi_b),\; y + z_b \sin(\theta + \phi_b)\big),
# $$
#
# with $\phi_b$ the beam's angle on the robot, and scores it by its distance $d(e_b)$ to the nearest
# occupied cell. The beams are treated as independent, and a reading at $z_{\max}$ (no echo) says
# nothing and is left out:
#
# $$
# \log p(z_k \mid x_k) = \sum_{b:\, z_b < z_{\max}}
#   \log\Big( z_{\mathrm{hit}}\, \mathcal N\big(d(e_b); 0, \sigma_{\mathrm{hit}}^2\big)
#   + \frac{z_{\mathrm{rand}}}{z_{\max}} \Big) .
# $$
#
# The uniform term $z_{\mathrm{rand}} / z_{\max}$ keeps one stray reading from sending a good pose's
# weight to zero. The distances $d$ are computed once, for every cell, by a Euclidean distance
# transform of the grid (`scipy.ndimage.distance_transform_edt`), so a particle costs one look-up
# per beam. The filter uses $z_{\mathrm{hit}} = 0.9$, $z_{\mathrm{rand}} = 0.1$ and
# $\sigma_{\mathrm{hit}} = 0.2$ m, broader than the scanner's $5$ cm: the field is an approximation
# (it ignores what lies between the robot and the end point) and must be forgiving.
#
# The right panel scores the scan of the first figure at every position of the map, the heading held
# at the true one. Every room has a bright spot where the scan fits nearly as well as at the true
# place: these are the look-alikes the filter must tell apart.

# %%
xs, ys = np.arange(0.25, grid.width, 0.1), np.arange(0.25, grid.height, 0.1)
X, Y = np.meshgrid(xs, ys)
poses = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, demo.truth[k_show, 2])])
score = field.log_likelihood(poses, demo.scans[k_show]).reshape(X.shape)
score[~grid.is_free(poses).reshape(X.shape)] = np.nan
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.6))
im1 = draw_map(ax1, grid, values=grid.distance, cmap="viridis")
fig.colorbar(im1, ax=ax1, label="distance to a wall d (m)")
ax1.set_title("The distance transform of the grid")
im2 = ax2.imshow(score - np.nanmax(score), origin="lower", extent=(0.2, xs[-1] + 0.05, 0.2, ys[-1] + 0.05),
                 cmap="magma", vmin=-150, vmax=0)
ax2.plot(*demo.truth[k_show, :2], "x", color="tab:cyan", ms=10, mew=2)
ax2.set_xlabel("x (m)")
ax2.set_ylabel("y (m)")
ax2.grid(False)
fig.colorbar(im2, ax=ax2, label="log-likelihood minus its maximum")
ax2.set_title("The scan's log-likelihood; cross: the truth")
plt.show()

# %% [markdown]
# (map-mcl)=
# ## Monte Carlo localization with the likelihood field
#
# MCL is the bootstrap particle filter ({doc}`../part1/sir`) with these two models: move every
# particle by the odometry, weight it by the scan, resample. Robots resample at every scan with the
# low-variance (systematic) sampler {cite:p}`thrun2005`.
#
# :::{admonition} Algorithm 13.1: Monte Carlo localization with the likelihood field
# :class: algorithm
# 1. **Initialise.** Draw $x_0^i$, $i = 1, \dots, N$: around a known pose (tracking), or uniformly in
#    free space with a uniform heading (global localization).
# 2. **For** each scan $z_k$, $k = 0, 1, \dots$:
#    1. *move* (for $k > 0$): $x_k^i \sim p(x_k \mid x_{k-1}^i, u_k)$ by the odometry sampler; with
#       random injection, replace each particle, with probability $\varepsilon$, by a pose drawn
#       uniformly in free space;
#    2. *weight:* $\log \tilde w_k^i = \log p(z_k \mid x_k^i)$ by the likelihood field;
#    3. *normalise:* $W_k^i = \exp\big(\log \tilde w_k^i - \operatorname{logsumexp}_j \log \tilde w_k^j\big)$;
#    4. *estimate:* the weighted mean position, and the heading
#       $\hat\theta_k = \arg \sum_i W_k^i e^{\mathrm i \theta_k^i}$ (angles average on the circle);
#    5. *resample:* $x_k^i \leftarrow x_k^{A_i}$ with systematic ancestors $A_i$; every weight becomes $1/N$.
# :::
#
# **Random injection, weighted correctly.** A filter whose particles have all gathered in the wrong
# room never gets out: no step of the bootstrap filter creates a particle far from the others. The
# cure of {doc}`global_localization` is to admit, in the model, that the robot may be anywhere: the
# transition becomes $(1 - \varepsilon)\, p(x_k \mid x_{k-1}, u_k) + \varepsilon\, \mathcal U(x_k)$, with
# $\mathcal U$ uniform on free space, the *kidnap model*. Sampling particles from that mixture is
# the move of Algorithm 13.1 with injection; since the particles are drawn from the model's own transition, their
# weight is the likelihood alone, as in any bootstrap filter, and the filter targets the kidnap
# model's posterior without bias. The injected particles are thus weighted like the others, unlike
# those of augmented MCL ({doc}`global_localization`). Here $\varepsilon = 0.1$.
#
# The cell below is Algorithm 13.1 in NumPy, with the likelihood field written out; it runs on the
# drive of the first figure from the known start and is checked against the package's engine,
# `ParticleFilter` with the scenario's model, drawing from the same random stream.

# %%
def field_log_weights(x, z):
    """log p(z | x^i) for every particle (table 6.3 in the log domain)."""
    echo = z < field.max_range  # beams without an echo say nothing
    heading = x[:, 2:3] + field.angles[echo]
    ends = np.stack([x[:, 0:1] + z[echo] * np.cos(heading), x[:, 1:2] + z[echo] * np.sin(heading)], axis=-1)
    d = grid.distance_at(ends)  # distance transform at the end points (inf off the map)
    hit = np.exp(-0.5 * (d / field.sigma) ** 2) / (np.sqrt(2 * np.pi) * field.sigma)
    return np.log(field.z_hit * hit + field.z_rand / field.max_range).sum(axis=1)


def mcl(scans, odometry, n, rng, start, start_std):
    x = start + rng.standard_normal((n, 3)) * start_std  # 1. around the known start
    estimates = []
    for k, z in enumerate(scans):
        if k > 0:
            x = sample_motion(x, odometry[k], rng)  # 2.1 move by the odometry
        log_w = field_log_weights(x, z)  # 2.2 weight by the scan
        W = np.exp(log_w - logsumexp(log_w))  # 2.3 normalise
        estimates.append([W @ x[:, 0], W @ x[:, 1], np.angle(W @ np.exp(1j * x[:, 2]))])  # 2.4
        x = x[systematic(W, rng)]  # 2.5 resample
    return np.array(estimates)


N_DEMO = study.TRACKING_N
model = MapRobotModel(grid, field, demo.drive.odometry, motion=study.MOTION, start=demo.truth[0])
ours = mcl(demo.scans, demo.drive.odometry, N_DEMO, np.random.default_rng(7), demo.truth[0], model.start_std)
engine = ParticleFilter(model, N_DEMO, threshold=1.0).run(demo.scans, rng=np.random.default_rng(7))
TOL = 1e-9
gap = max(np.abs(ours[:, :2] - engine.mean[:, :2]).max(), heading_error(engine.mean, ours).max())
print(f"largest difference from the engine's estimates, metres or radians: below {TOL:.0e}: {gap < TOL}")
err = position_error(demo.truth, ours)
print(f"this run: position RMSE {np.sqrt(np.mean(err**2)):.3f} m with N = {N_DEMO}")

# %% [markdown]
# The loop and the engine give the same estimates to {glue:text}`lf_engine_tolerance:.0e`, at every
# step. From here on the studies run the engine.
#
# ## Tracking
#
# Started at the known pose with $N = 300$ particles, the filter follows the robot through rooms and
# corridor: over {glue:text}`lf_n_tracking:d` seeded drives of $80$ s, the position RMSE is
# {glue:text}`lf_tracking_rmse_m:.3f` m on average (95 % interval {glue:text}`lf_tracking_rmse_m_low:.3f`
# to {glue:text}`lf_tracking_rmse_m_high:.3f`), a fraction of the $0.2$ m width of the likelihood field.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
from pfcourse.figures.report import spread_table  # a spread over runs as a table with units

glue_values("lf_", engine_tolerance=TOL)
cost = {name: STUDIES[f"maprobot/{name}"].load().attrs["provenance"]["wall_seconds"]
        for name in ("tracking", "global", "kidnap")}


def stored(name):
    return (f"Stored study maprobot/{name} (book/data/maprobot/{name}.csv, provenance in {name}.json): "
            f"{cost[name]:.0f} s of computing on a shared 2-core machine.")


tracking = STUDIES["maprobot/tracking"].load()
rmse, low, high = evidence.run_interval(lambda r: tracking["position_rmse"].to_numpy()[r].mean(), len(tracking))
head_rmse, head_low, head_high = evidence.run_interval(lambda r: tracking["heading_rmse"].to_numpy()[r].mean(),
                                                       len(tracking))
tracked = evidence.rate(tracking["locked_on"].to_numpy())
glue_values("lf_", n_tracking=len(tracking), tracking_rmse_m=rmse, tracking_rmse_m_low=low,
            tracking_rmse_m_high=high)
EvidenceBlock(
    "tracking on the map is accurate",
    notes=[f"{len(tracking)} drives (seeds 0-{len(tracking) - 1}), N = {study.TRACKING_N}, 80 s each, bootstrap "
           "MCL resampling at every scan, started at the true pose with standard deviations 0.2 m, 0.2 m, 0.05 rad.",
           f"Mean over runs of the per-run position RMSE: {rmse:.3f} m (95 % interval {low:.3f}-{high:.3f}, "
           "percentile bootstrap over runs, see Reading the evidence).",
           f"Mean heading RMSE: {np.degrees(head_rmse):.2f} degrees (95 % interval {np.degrees(head_low):.2f}-"
           f"{np.degrees(head_high):.2f}).",
           f"Locked on at the end (within 1 m and 5 degrees over the last 20 s): {tracked}.",
           stored("tracking")],
    tables=[("Per-run position RMSE, over the runs", *spread_table(tracking["position_rmse"], "m", ".3f"))],
)

# %% [markdown]
# ### How many particles does KLD-sampling keep?
#
# AMCL, the localization package of ROS, does not fix $N$: it uses KLD-sampling {cite:p}`fox2003`
# ({doc}`global_localization`), which draws particles until their number exceeds a bound that grows
# with the number of histogram bins they occupy. With AMCL's default settings (at most $5000$ and at
# least $100$ particles, a bound $0.01$ on the Kullback-Leibler divergence at probability $0.99$, bins
# of $0.5$ m $\times$ $0.5$ m $\times$ $10°$), on the same drives, it keeps
# {glue:text}`lf_kld_mean_particles:.0f` particles on average while tracking (95 % interval
# {glue:text}`lf_kld_mean_particles_low:.0f` to {glue:text}`lf_kld_mean_particles_high:.0f`), several
# times the $N = 300$ that tracks well above, for a position RMSE {glue:text}`lf_kld_rmse_ratio:.2f`
# times that of the fixed $N = 300$ (median ratio over the drives). The bins are small next to the
# cloud of a robot this well tracked, so the bound asks for more particles than tracking needs.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
kld = STUDIES["maprobot/kld_tracking"].load().sort_values("seed")
cost["kld_tracking"] = kld.attrs["provenance"]["wall_seconds"]
assert (kld["seed"].to_numpy() == tracking["seed"].to_numpy()).all()
mean_n, mean_n_low, mean_n_high = evidence.run_interval(lambda r: kld["mean_particles"].to_numpy()[r].mean(), len(kld))
ratio = evidence.paired(kld["position_rmse"].to_numpy(), tracking["position_rmse"].to_numpy(), ratio=True)
glue_values("lf_", kld_mean_particles=mean_n, kld_mean_particles_low=mean_n_low, kld_mean_particles_high=mean_n_high,
            kld_rmse_ratio=ratio.median)
EvidenceBlock(
    "with AMCL's defaults, KLD-sampling keeps several times the particles tracking needs",
    notes=[f"The {len(kld)} drives of the tracking study, filtered by KLD-sampling (Fox 2003) with AMCL's defaults: "
           f"{study.AMCL_KLD}; step 0 draws the maximum, later steps draw in batches of 100 until the bound is met.",
           f"Mean number of particles after step 0: {mean_n:.0f} (95 % interval {mean_n_low:.0f}-{mean_n_high:.0f}, "
           "percentile bootstrap over the drives); largest after step 0 in any run: "
           f"{kld['max_particles_after_start'].max()}.",
           f"Position RMSE, KLD-sampling over fixed N = {study.TRACKING_N}, paired by drive: {ratio} "
           f"({ratio.verdict()}; see Reading the evidence).",
           f"Locked on at the end: {evidence.rate(kld['locked_on'].to_numpy())}.",
           stored("kld_tracking")],
)


# %% [markdown]
# ## Global localization among look-alike rooms
#
# Now the robot starts anywhere, and the filter knows nothing: its $N = 1000$ particles are drawn
# uniformly in free space. On this map the scan of one place matches several others, so the cloud
# first splits into the twins; as the robot drives, the box or the corridor's ends come into view
# and one twin wins, if the filter still has particles there. The run below shows both filters on
# one drive.

# %%
GLOBAL_SEED = 0
drive = study.simulate(GLOBAL_SEED, study.GLOBAL_STEPS)
t = np.arange(study.GLOBAL_STEPS) * study.DT
fig, ax = plt.subplots(figsize=(8, 3.4))
for method, color in [("bootstrap", COLORS["estimate"]), ("injection", COLORS["kalman"])]:
    res = study.run_filter(drive, GLOBAL_SEED, study.GLOBAL_N, method)
    ax.semilogy(t, np.maximum(position_error(drive.truth, res.mean), 1e-2), color=color,
                label=study.FILTERS[method].label)
ax.axhline(1.0, color=COLORS["unseen"], ls="--", label="locked-on tolerance (1 m)")
ax.set_xlabel("time t (s)")
ax.set_ylabel("position error (m)")
ax.set_title(f"Global localization, one drive, N = {study.GLOBAL_N}")
ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
plt.show()

# %% [markdown]
# Over $100$ seeded drives of $100$ s, the same drives and the same $N$ for both,
# the filter with random injection is locked on at the end (the book's definition: within $1$ m and
# $5°$ at every step of the last $20$ s) in {glue:text}`lf_global_lock_on_rate:.0%` of the runs
# (95 % interval {glue:text}`lf_global_lock_on_rate_low:.0%` to {glue:text}`lf_global_lock_on_rate_high:.0%`),
# the bootstrap filter in {glue:text}`lf_bootstrap_lock_on_rate:.0%`.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glob = STUDIES["maprobot/global"].load()
inj = glob[glob["method"] == "injection"].sort_values("seed")
boot = glob[glob["method"] == "bootstrap"].sort_values("seed")
assert (inj["seed"].to_numpy() == boot["seed"].to_numpy()).all()
pair = evidence.paired_rates(inj["locked_on"].to_numpy(), boot["locked_on"].to_numpy())
glue_values("lf_", n_global=len(inj), global_lock_on_rate=pair.a.estimate, global_lock_on_rate_low=pair.a.low,
            global_lock_on_rate_high=pair.a.high, bootstrap_lock_on_rate=pair.b.estimate,
            bootstrap_lock_on_rate_low=pair.b.low, bootstrap_lock_on_rate_high=pair.b.high)
summary = pd.DataFrame([{"method": m, "locked on": str(evidence.rate(g["locked_on"].to_numpy())),
                         "median final error (m)": g["final_position_error"].median()}
                        for m, g in [("injection", inj), ("bootstrap", boot)]])
EvidenceBlock(
    "random injection locks on more often than the bootstrap filter, on the same runs",
    notes=[f"{len(inj)} drives (seeds 0-{len(inj) - 1}), each filtered by both methods with N = {study.GLOBAL_N} "
           f"and the same filter seed; 100 s per drive, scans every {study.DT} s.",
           f"Paired comparison (injection A, bootstrap B): {pair} (see Reading the evidence).",
           f"Injection: epsilon = {study.INJECT} per scan, poses uniform in free space, weighted by the likelihood "
           "alone (the kidnap model's bootstrap filter).",
           stored("global")],
    tables=[("Lock-on by method (Wilson intervals)", summary, {"median final error (m)": ".2f"})],
)

# %% [markdown]
# ## The kidnapped robot
#
# The filter tracks the robot from its known start; after $20$ s the robot is carried to another
# waypoint of its route, and its odometry reports no motion: the cloud stays where the robot was. With
# injection, a particle that lands near the new pose scores far better than the lost cloud and takes
# over, but only a few land near enough: within the $100$ s left after the kidnapping, the filter
# recovers in {glue:text}`lf_kidnap_recovered_rate:.0%` of the runs. Those that recover take a median
# {glue:text}`lf_kidnap_recovery_median_s:.0f` s from the kidnapping to the step from which the estimate
# stays locked on (95 % interval {glue:text}`lf_kidnap_recovery_median_s_low:.0f` to
# {glue:text}`lf_kidnap_recovery_median_s_high:.0f` s). Uniform poses are a blunt tool in three
# dimensions: the reading-driven proposal of {doc}`global_localization` aims them, at the price of
# inverting the sensor model.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
kid = STUDIES["maprobot/kidnap"].load()
times = kid.loc[kid["recovered"], "recovery_s"].to_numpy()  # the runs that recover
med, med_low, med_high = evidence.median_interval(times)
recovered = evidence.rate(kid["recovered"].to_numpy())
glue_values("lf_", n_kidnap=len(kid), kidnap_recovered_rate=recovered.estimate, kidnap_recovery_median_s=med,
            kidnap_recovery_median_s_low=med_low, kidnap_recovery_median_s_high=med_high)
horizon = (study.KIDNAP_STEPS - study.KIDNAP_STEP) * study.DT
EvidenceBlock(
    "with injection the kidnapped robot is found again in some runs, slowly",
    notes=[f"{len(kid)} runs (seeds 0-{len(kid) - 1}), N = {study.KIDNAP_N}, injection epsilon = {study.INJECT}; "
           f"kidnapped at t = {study.KIDNAP_STEP * study.DT:.0f} s, run to t = {study.KIDNAP_STEPS * study.DT:.0f} s.",
           f"Tracked before the kidnapping (error < 1 m from 5 s on): {evidence.rate(kid['tracked_before'].to_numpy())}.",
           f"Recovered (locked on over the last 20 s of the run): {recovered}; the others are still lost "
           f"{horizon:.0f} s after the kidnapping, so the median over all runs is longer than the run.",
           f"Median recovery time of the {len(times)} runs that recover: {med:.1f} s, 95 % interval "
           f"{med_low:.1f}-{med_high:.1f} s (percentile bootstrap over those runs; see Reading the evidence). "
           "It is a median among survivors: it says how fast a recovery is when one happens, not how often.",
           stored("kidnap")],
    tables=[("Recovery time of the recovered runs", *spread_table(times, "s", ".1f"))],
)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 13.1 Why not the beam model?
# :label: ex-map-beam
# :nonumber:
# The simulator draws the scans from the beam model, and the filter scores them with the likelihood
# field. Count the grid cells the beam model must visit to score one particle's scan of $24$ beams of
# up to $8$ m on $0.1$ m cells, and compare with the likelihood field.
# ```
#
# ```{solution} ex-map-beam
# :class: dropdown
# Casting a beam visits up to $8 / 0.1 = 80$ cells, so a scan costs up to $24 \times 80 = 1920$ cell
# visits per particle, against $24$ look-ups in the precomputed distance transform: the likelihood
# field is about eighty times cheaper, and smooth in the pose, which a filter with few particles needs.
# ```
#
# ```{exercise} 13.2 Write the likelihood field, and have it checked
# :label: ex-map-code
# :nonumber:
# (Coding.) Write `my_field(poses, z, field)`: the log-likelihood of one scan `z` (shape `(B,)`) for
# each pose of a cloud `poses` (shape `(N, 3)`), by the likelihood field. `field.angles` are the beam
# angles $\phi_b$, `field.max_range`, `field.z_hit`, `field.z_rand` and `field.sigma` its parameters,
# and `field.grid.distance_at(points)` the distance $d$ to the nearest wall of each point
# (`points[..., :2]`, infinite off the map). The checker compares with their table $6.3$ on two scans and names
# the mistake it sees.
# ```

# %% tags=["answer"]
def my_field(poses, z, field):
    """Your likelihood field: return log p(z | x^i), shape (N,)."""
    ...  # replace with your code


print(check_likelihood_field(my_field))

# %% [markdown]
# ```{solution} ex-map-code
# :class: dropdown
# The function `field_log_weights` of the MCL cell above, with the field passed in; the code is in
# the folded cell below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_field(poses, z, field):
    echo = z < field.max_range
    heading = poses[:, 2:3] + field.angles[echo]
    ends = np.stack([poses[:, 0:1] + z[echo] * np.cos(heading), poses[:, 1:2] + z[echo] * np.sin(heading)], axis=-1)
    d = field.grid.distance_at(ends)
    hit = np.exp(-0.5 * (d / field.sigma) ** 2) / (np.sqrt(2 * np.pi) * field.sigma)
    return np.log(field.z_hit * hit + field.z_rand / field.max_range).sum(axis=1)


print(check_likelihood_field(my_field))

# %% [markdown]
# ## Takeaways
#
# - Monte Carlo localization on a map is the bootstrap particle filter with two robotics models: the
#   odometry model, sampled by perturbing rotation, translation and rotation, and the likelihood field,
#   which scores each beam's end point by its distance to the nearest wall.
# - The likelihood field costs one look-up per beam in a distance transform computed once, so a
#   whole cloud is weighted in a few vectorised lines.
# - Where places look alike, the bootstrap filter started from nowhere often settles in a twin and
#   stays there; injecting uniform poses, drawn from a kidnap model and weighted by the likelihood like the
#   others, lets the right place win when the robot sees what tells the twins apart.
# - The same injection finds a kidnapped robot again only when an injected pose lands near the truth,
#   which uniform draws in three dimensions do slowly: aiming them with the reading is the next step.
