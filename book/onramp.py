# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Particle filters in twenty minutes
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** what a particle filter computes and how: Bayes' rule on a grid first, then the
# same answer from a cloud of samples that move, get weighted and get resampled; you write the
# whole filter yourself, in NumPy, and check it against the exact answer.
#
# **You need** Bayes' rule and the Gaussian density; NumPy arrays and a random generator
# (`rng = np.random.default_rng(seed)`).
#
# **Time:** about nineteen minutes to read, plus about thirteen minutes for the folded blocks; the exercise is extra.
# :::
#
# ## The scene
#
# A robot runs along a straight rail, $20$ m long. Next to the rail, $10$ m along it and $2$ m
# off it, stands a beacon. Every second the robot drives about half a metre forward (its wheels
# slip a little) and then measures its distance to the beacon (the reading is off by about half a
# metre). Nobody told it where it started. **Where is it now?**
#
# Here is the whole model in NumPy. Type it into a blank notebook: everything in this chapter
# builds on these lines.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# Setup (hidden): the book's figure style and the glue of numbers into the text.
import ipywidgets as widgets
from IPython.display import display

from pfcourse.book.exercises.onramp import two_beacon_grid
from pfcourse.book.report import glue_values
from pfcourse.book.panels import control_panel
from pfcourse.book.style import COLORS, use_style

use_style()

# %%
import numpy as np
import matplotlib.pyplot as plt
from scipy.stats import norm

# the rail (m), the beacon's place along it and its distance off it (m)
RAIL = (0.0, 20.0)
BEACON, OFFSET = 10.0, 2.0
# each step: 0.5 m forward, give or take 0.2 m; readings off by 0.5 m
SPEED, MOTION_SD, RANGE_SD = 0.5, 0.2, 0.5


def beacon_range(x):
    """Distance (m) from position x on the rail to the beacon."""
    return np.hypot(x - BEACON, OFFSET)


def simulate(steps, rng, motion_sd=MOTION_SD, range_sd=RANGE_SD):
    """True positions and range readings of one run from 2 m."""
    x, truth, z = 2.0, [], []
    for _ in range(steps):
        x = x + SPEED + motion_sd * rng.standard_normal()
        truth.append(x)
        z.append(beacon_range(x) + range_sd * rng.standard_normal())
    return np.array(truth), np.array(z)


truth, z = simulate(30, np.random.default_rng(1))

# %% tags=["hide-input"] jupyter={"source_hidden": true}
fig, ax = plt.subplots(figsize=(6.4, 2.6))
ax.plot(RAIL, [0, 0], color="0.4", lw=4, solid_capstyle="butt")
ax.plot(BEACON, OFFSET, "*", ms=16, color=COLORS["kalman"])
ax.annotate("beacon", (BEACON, OFFSET), xytext=(8, 4), textcoords="offset points")
angle = np.linspace(0, 2 * np.pi, 400)
ax.plot(BEACON + z[0] * np.cos(angle), OFFSET + z[0] * np.sin(angle), ":", color=COLORS["estimate"])
for side in (-1, 1):
    place = BEACON + side * np.sqrt(max(z[0] ** 2 - OFFSET**2, 0))
    ax.plot(place, 0, "o", color=COLORS["estimate"], ms=8, mfc="none", mew=2)
ax.plot(truth[0], 0, "s", color=COLORS["robot"], ms=9, label="the robot (unknown to it)")
ax.set_xlim(-1, 21)
ax.set_ylim(-1.5, 4.5)
ax.set_aspect("equal")
ax.set_xlabel("position along the rail (m)")
ax.set_yticks([])
ax.set_title(f"The first reading, {z[0]:.1f} m, fits two places (circles)")
ax.legend(loc="upper left", frameon=False)
plt.show()

# %% [markdown]
# One reading cannot tell the robot which side of the beacon it is on: both circled places are at
# the right distance. Keep that in mind; the answer we want is not one number but a **belief**
# over the whole rail, a probability for every place.
#
# ## Bayes' rule on a grid: the exact answer
#
# Cut the rail into cells $1$ cm wide and keep one probability per cell. Before the first
# reading every cell on the rail is equally likely. Then each step does two things.
#
# - **Predict.** The robot moves, so the belief moves with it: every cell's probability slides
#   $0.5$ m forward and spreads out by the wheel slip. Writing $z_{1:k-1}$ for the readings
#   $z_1, \dots, z_{k-1}$ received so far,
#
#   $$
#   p(x_k \mid z_{1:k-1}) = \int p(x_k \mid x_{k-1})\, p(x_{k-1} \mid z_{1:k-1})\, dx_{k-1} .
#   $$
#
# - **Update.** A reading $z_k$ arrives. Bayes' rule multiplies each cell by how well it
#   explains the reading, the *likelihood* $p(z_k \mid x_k)$, a Gaussian centred on the cell's
#   distance to the beacon, then rescales so the cells add up to one:
#
#   $$
#   p(x_k \mid z_{1:k}) \propto p(z_k \mid x_k)\, p(x_k \mid z_{1:k-1}) .
#   $$
#
# On a grid the integral is a sum (a convolution), and the whole filter is a short loop. It is
# called the *histogram filter*.

# %%
# cells 1 cm wide, far enough past the rail's ends that nothing leaks out
cells = np.arange(-10.0, 40.0, 0.01)
# one step's move, cell by cell: 0.5 m forward plus the slip
moves = np.arange(-500, 501) * 0.01


def grid_filter(z, motion_sd=MOTION_SD, range_sd=RANGE_SD):
    """The belief over the cells after each reading, shape (steps, cells)."""
    p = ((cells >= RAIL[0]) & (cells <= RAIL[1])).astype(float)
    p /= p.sum()
    kernel = norm.pdf(moves, SPEED, motion_sd)
    kernel /= kernel.sum()
    beliefs = []
    for zk in z:
        # predict: slide and spread
        p = np.convolve(p, kernel, mode="same")
        # update: Bayes' rule, then rescale to add up to one
        p = p * norm.pdf(zk, beacon_range(cells), range_sd)
        p /= p.sum()
        beliefs.append(p)
    return np.array(beliefs)


beliefs = grid_filter(z)

# %% [markdown]
# Watch the first step, one layer at a time: the belief before the reading (flat over the rail),
# the likelihood of the reading (two bumps, one each side of the beacon), and their product,
# rescaled (with a flat belief before, it has the likelihood's shape).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
flat = ((cells >= RAIL[0]) & (cells <= RAIL[1])).astype(float)
kernel = norm.pdf(moves, SPEED, MOTION_SD)
prior = np.convolve(flat / flat.sum(), kernel / kernel.sum(), mode="same") / 0.01
likelihood = norm.pdf(z[0], beacon_range(cells), RANGE_SD)
posterior = beliefs[0] / 0.01
fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), sharey=True)
layers = [("before the reading", prior, COLORS["particles"]),
          ("the reading's likelihood", likelihood / np.trapezoid(likelihood, cells), COLORS["kalman"]),
          ("after: Bayes' rule", posterior, COLORS["estimate"])]
for i, ax in enumerate(axes):
    for title, curve, colour in layers[: i + 1]:
        faded = title != layers[i][0]
        ax.plot(cells, curve, color=colour, alpha=0.35 if faded else 1, lw=1 if faded else 2)
    ax.axvline(truth[0], color=COLORS["truth"], ls="--", lw=1)
    ax.set_xlim(-1, 21)
    ax.set_title(layers[i][0])
    ax.set_xlabel("position x (m)")
axes[0].set_ylabel("probability per metre")
plt.show()

# %% [markdown]
# The dashed line is where the robot really is. After one reading the belief has two peaks, as
# the scene said it must. As the robot moves on, only one of them keeps agreeing with the readings
# (on the far side the distance would grow, not shrink), and the other fades.
#
# The grid is exact up to its cells, and we can check how much those cost: a second grid
# with cells half as wide, written independently of this one, moves the belief's mean by at most
# {glue:text}`onramp_grid_precision_mm:.1f` mm over the run. So below, the grid **is** the right
# answer, to well under a millimetre.
#
# ## Particles: samples of the belief
#
# The grid has $5000$ cells for one number, the position. A robot on a floor has three numbers
# (two coordinates and a heading): a floor $20$ m square at the same spacing, with the heading in
# steps of one degree, is $2000 \times 2000 \times 360 \approx 1.4 \times 10^9$ cells, and an aircraft
# or a map of landmarks is hopeless. The way out is to keep **samples** of the belief instead of
# the belief itself: $N$ guesses, *particles*, scattered so that more of them sit where the belief
# is high. A histogram of the particles then looks like the belief.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
draw_rng = np.random.default_rng(7)
fig, axes = plt.subplots(1, 2, figsize=(10, 2.9), sharey=True)
for ax, n in zip(axes, (100, 2000)):
    sample = draw_rng.choice(cells, size=n, p=beliefs[0])
    ax.hist(sample, bins=np.arange(-1, 21, 0.5), density=True, color=COLORS["particles"], alpha=0.6,
            label=f"{n} particles")
    ax.plot(cells, posterior, color=COLORS["estimate"], lw=2, label="the grid's belief")
    ax.plot(sample, np.full(n, -0.01), "|", color=COLORS["particles"], ms=8, alpha=0.3)
    ax.set_xlim(-1, 21)
    ax.set_xlabel("position x (m)")
    ax.set_title(f"{n} samples of the belief after step 1")
    ax.legend(loc="upper center", frameon=False)
axes[0].set_ylabel("probability per metre")
plt.show()

# %% [markdown]
# With more particles the histogram hugs the curve more closely. A particle filter never builds
# the grid: it moves the particles through the same two steps, predict and update, and the cloud
# stays approximately a sample of the exact belief at every step (the more particles, the closer).
#
# ## Predict, weight, resample
#
# Three moves per step, drawn below for $20$ particles at the second step (they start as a sample
# of the belief after the first):
#
# 1. **Predict.** Move every particle as the robot moves: $0.5$ m forward plus its own random
#    slip. The cloud slides and spreads, as the grid's belief did.
# 2. **Weight.** Give each particle a weight, the likelihood of the reading at its position:
#    a particle at the right distance from the beacon gets a large weight, one far off almost none.
#    The weighted cloud is, approximately, a weighted sample of the updated belief.
# 3. **Resample.** Draw $N$ new particles from the old ones, each picked with probability equal to
#    its weight. Heavy particles get copied, light ones vanish, and all weights are equal again.
#
# :::{admonition} Algorithm 0.1: the particle filter
# :class: algorithm
# Draw $N$ particles $x_0^1, \dots, x_0^N$ from the belief before any reading. Then, for each
# reading $z_k$, $k = 1, 2, \dots$:
# 1. *predict:* move each particle, $x_k^i = x_{k-1}^i + u + w_k^i$, with $u$ the commanded move
#    and $w_k^i$ a fresh draw of the slip;
# 2. *weight:* give particle $i$ the weight $W_k^i \propto p(z_k \mid x_k^i)$, rescaled so the
#    weights add up to one;
# 3. *estimate:* the position is about the weighted mean of the particles, $\sum_i W_k^i x_k^i$;
# 4. *resample:* draw $N$ indices $a^1, \dots, a^N$, each index $j$ with probability $W_k^j$, and
#    replace particle $i$ by a copy of particle $a^i$.
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
pic_rng = np.random.default_rng(3)
n_pic = 20
# step 2: from a sample of the belief after step 1 to the reading z[1]
before = pic_rng.choice(cells, size=n_pic, p=beliefs[0])
after = before + SPEED + MOTION_SD * pic_rng.standard_normal(n_pic)
w_pic = norm.pdf(z[1], beacon_range(after), RANGE_SD)
w_pic /= w_pic.sum()
picked = after[pic_rng.choice(n_pic, size=n_pic, p=w_pic)]
likelihood_2 = norm.pdf(z[1], beacon_range(cells), RANGE_SD)
fig, axes = plt.subplots(3, 1, figsize=(6.4, 5.6), sharex=True)
axes[0].plot(before, np.full(n_pic, 1.0), "o", color="0.6", ms=5, label="before")
axes[0].plot(after, np.zeros(n_pic), "o", color=COLORS["particles"], ms=5, label="after the move")
for a, b in zip(before, after):
    axes[0].annotate("", (b, 0.08), (a, 0.92), arrowprops=dict(arrowstyle="->", color="0.6", lw=0.8))
axes[0].set_title("1. predict: every particle moves, with its own slip")
axes[1].scatter(after, np.zeros(n_pic), s=20 + 900 * w_pic, color=COLORS["particles"], alpha=0.7)
axes[1].plot(cells, likelihood_2 / likelihood_2.max() * 0.9 - 0.45, color=COLORS["kalman"], lw=1)
axes[1].set_title("2. weight: dot area = likelihood of the reading (green)")
counts = {}
for x in np.sort(picked):
    counts[x] = counts.get(x, 0) + 1
    axes[2].plot(x, counts[x] - 1, "o", color=COLORS["estimate"], ms=5)
axes[2].set_title("3. resample: heavy particles copied (stacked), light ones gone")
for ax in axes:
    ax.set_yticks([])
    ax.set_xlim(-1, 21)
axes[0].set_ylim(-0.4, 1.4)
axes[1].set_ylim(-0.6, 0.6)
axes[2].set_ylim(-0.8, max(counts.values()) + 0.2)
axes[2].set_xlabel("position x (m)")
plt.show()

# %% [markdown]
# ## The whole filter
#
# Here it is, the algorithm box line by line. The weights are computed from their logarithms,
# with the largest subtracted before exponentiating: a reading far from every particle would
# otherwise make every weight round to zero. The log-weight drops the Gaussian's normalising
# constant, $-\log(\sqrt{2\pi}\,\sigma)$: it is the same for every particle, so it cancels when
# the weights are rescaled to add up to one.

# %%
def particle_filter(z, n, rng, motion_sd=MOTION_SD, range_sd=RANGE_SD):
    """The particle filter's estimate of the position after each reading."""
    # before any reading: anywhere on the rail
    x = rng.uniform(*RAIL, size=n)
    means = []
    for zk in z:
        # predict: move every particle, each with its own slip
        x = x + SPEED + motion_sd * rng.standard_normal(n)
        # weight: likelihood of the reading, from its logarithm
        log_w = -0.5 * ((zk - beacon_range(x)) / range_sd) ** 2
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        means.append(w @ x)
        # resample: n draws, each particle picked with probability w
        x = x[rng.choice(n, size=n, p=w)]
    return np.array(means)


pf_means = particle_filter(z, 1000, np.random.default_rng(2))
grid_means = beliefs @ cells
print(f"last step: particles {pf_means[-1]:.2f} m, grid {grid_means[-1]:.2f} m")

# %% [markdown]
# ## Does it find the robot?
#
# The picture below runs the two filters side by side over the whole run: in the background the
# grid's belief at every step (darker is more probable), on top the grid's mean and the particle
# filter's, with $N = 1000$ particles.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
steps = np.arange(1, len(z) + 1)


def belief_picture(ax, beliefs, steps):
    """The belief at every step, in rows 10 cm high from -1 m to 21 m: darker is more probable."""
    start = int(np.searchsorted(cells, -1.0 - 0.005))
    rows = beliefs[:, start:start + 2200].reshape(len(beliefs), 220, 10).sum(axis=2)
    ax.imshow(np.sqrt(rows.T), origin="lower", aspect="auto", cmap="Greys", interpolation="nearest",
              extent=(steps[0] - 0.5, steps[-1] + 0.5, -1, 21), vmax=np.sqrt(rows.max()), alpha=0.6)


fig, ax = plt.subplots(figsize=(8, 3.6))
belief_picture(ax, beliefs, steps)
ax.plot(steps, truth, "--", color=COLORS["robot"], label="the robot")
ax.plot(steps, grid_means, color=COLORS["kalman"], lw=3, label="grid (exact)")
ax.plot(steps, pf_means, color=COLORS["estimate"], lw=1.5, label="particles, N = 1000")
ax.set_xlabel("step k")
ax.set_ylabel("position x (m)")
ax.legend(loc="lower right", frameon=True, fontsize=9)
plt.show()

distance = np.abs(pf_means - grid_means)
fine_means, _ = two_beacon_grid(z[:, None], {"beacons": (BEACON,), "offset": OFFSET, "speed": SPEED,
                                             "motion_sd": MOTION_SD, "range_sd": RANGE_SD, "rail": RAIL},
                                cell=0.005)
glue_values("onramp_", pf_grid_distance=float(distance.mean()), pf_grid_distance_last=float(distance[-1]),
            grid_precision_mm=1000 * float(np.abs(fine_means - grid_means).max()), steps=len(z),
            first_mean=float(grid_means[0]))

# %% [markdown]
# At the first step the grid's mean sits near the middle of the rail, at
# {glue:text}`onramp_first_mean:.1f` m, and the particles' with it: the belief has two peaks, and
# its mean falls between them, where the robot certainly is not. A mean is a poor summary of two peaks; the belief is the
# answer. Within a few steps one peak wins and the means follow the robot.
#
# Averaged over the {glue:text}`onramp_steps:d` steps, the particle filter's mean is
# {glue:text}`onramp_pf_grid_distance:.3f` m from the grid's exact mean (at the last step,
# {glue:text}`onramp_pf_grid_distance_last:.3f` m). That is the price of using a thousand samples
# instead of the belief itself. Does it shrink with more particles? Run the filter a hundred times
# for each $N$, each time with another seed, and average:

# %%
gaps, per_run = {}, {}
for n in (10, 100, 1000):
    runs = [particle_filter(z, n, np.random.default_rng(s)) for s in range(100)]
    per_run[n] = np.array([np.abs(m - grid_means).mean() for m in runs])
    gaps[n] = per_run[n].mean()
    print(f"N = {n:>4}: {gaps[n]:.3f} m from the grid, averaged over the run")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# a run "loses the robot" when its particles follow the wrong peak: over 2 m from the grid on
# average over the run (the runs fall into two groups, under 1 m and near 10 m, with none between)
LOST_M = 2.0
lost_10 = per_run[10] > LOST_M
assert not ((per_run[10] > 1.0) & (per_run[10] < 5.0)).any()
glue_values("onramp_", shrink_100_to_1000=float(gaps[100] / gaps[1000]), gap_10=float(gaps[10]),
            lost_10=int(lost_10.sum()), lost_10_off=float(per_run[10][lost_10].mean()),
            kept_10_off=float(per_run[10][~lost_10].mean()), lost_runs=len(per_run[10]))

# %% [markdown]
# Ten times more particles, from $N = 100$ to $1000$, bring the filter
# {glue:text}`onramp_shrink_100_to_1000:.1f` times closer to the grid: about $\sqrt{10}$, the rate
# at which an average of random samples improves.
#
# With $10$ particles the average hides two
# kinds of run: in {glue:text}`onramp_lost_10:d` of {glue:text}`onramp_lost_runs:d` runs the ten
# particles settle on the wrong peak and lose the robot, about
# {glue:text}`onramp_lost_10_off:.0f` m off over the run; the others are about
# {glue:text}`onramp_kept_10_off:.2f` m off (the panel below shows a run where they lose it).
#
# ## Why resample? Degeneracy, seen
#
# Delete the resample line and keep multiplying the weights from step to step instead (a
# particle's weight is then the likelihood of its whole path). The particles never move towards
# the good region; they only gain or lose weight. Here are the weights of $100$ particles,
# against their positions, after $1$, $5$ and $30$ steps (the dashed line is the robot).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def weights_without_resampling(z, n, rng, show):
    x = rng.uniform(*RAIL, size=n)
    log_w = np.zeros(n)
    kept = {}
    for k, zk in enumerate(z, start=1):
        x = x + SPEED + MOTION_SD * rng.standard_normal(n)
        log_w = log_w - 0.5 * ((zk - beacon_range(x)) / RANGE_SD) ** 2
        if k in show:
            w = np.exp(log_w - log_w.max())
            kept[k] = (x.copy(), w / w.sum())
    return kept


shown_steps = (1, 5, 30)
kept = weights_without_resampling(z, 100, np.random.default_rng(4), shown_steps)
fig, axes = plt.subplots(1, 3, figsize=(10, 2.9), sharey=True)
for ax, k in zip(axes, shown_steps):
    x, w = kept[k]
    ax.axvline(truth[k - 1], color="0.55", ls="--", lw=1, zorder=0)
    ax.vlines(x, 0, w, color=COLORS["particles"], lw=1.5)
    ax.plot(x, w, "o", color=COLORS["particles"], ms=3)
    ax.set_xlim(-1, 38)
    ax.set_title(f"after step {k}")
    ax.set_xlabel("position x (m)")
axes[0].set_ylabel("weight")
plt.show()
glue_values("onramp_", heaviest_last=float(kept[shown_steps[-1]][1].max()))

# %% [markdown]
# After one step many particles share the weight. After five, a handful. After thirty, one
# particle holds {glue:text}`onramp_heaviest_last:.0%` of it: the cloud of $100$ has become a
# single guess, and it cannot follow the robot any better than one guess can. This collapse is
# called **degeneracy**, and resampling is its cure: it throws the weightless particles away and
# puts copies where the weight is, so the slip of the next move spreads them over the good region
# again.
#
# ## Try it
#
# The panel runs both filters on a fresh run for the number of particles and the two noise
# levels you choose. The dots are the particles after each step (at most a hundred of them),
# the grey background is the exact belief. With $10$ particles, does the filter still find the
# robot? What does a very precise range reading ($0.1$ m) do to the first steps?

# %% tags=["remove-input", "nbval-ignore-output"] jupyter={"source_hidden": true}
def draw(n_particles, range_sd, motion_sd):
    truth_, z_ = simulate(30, np.random.default_rng(11), motion_sd, range_sd)
    beliefs_ = grid_filter(z_, motion_sd, range_sd)
    rng = np.random.default_rng(12)
    x = rng.uniform(*RAIL, size=n_particles)
    clouds, means = [], []
    for zk in z_:
        x = x + SPEED + motion_sd * rng.standard_normal(n_particles)
        log_w = -0.5 * ((zk - beacon_range(x)) / range_sd) ** 2
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        means.append(w @ x)
        x = x[rng.choice(n_particles, size=n_particles, p=w)]
        clouds.append(x[:100])
    fig, ax = plt.subplots(figsize=(8, 3.6))
    belief_picture(ax, beliefs_, steps)
    clouds = np.array(clouds)
    ax.plot(np.repeat(steps, clouds.shape[1]), clouds.ravel(), ".", color=COLORS["particles"], ms=3, alpha=0.5)
    ax.plot(steps, beliefs_ @ cells, color=COLORS["kalman"], lw=3, label="grid (exact)")
    ax.plot(steps, means, color=COLORS["estimate"], lw=1.5, label=f"particles, N = {n_particles}")
    ax.plot(steps, truth_, "--", color=COLORS["robot"], label="the robot")
    ax.set_xlabel("step k")
    ax.set_ylabel("position x (m)")
    ax.set_ylim(-1, 21)
    ax.legend(loc="lower right", fontsize=9)


display(control_panel(
    draw, grid={"n_particles": (10, 100, 1000), "range_sd": (0.1, 0.5, 2.0)},
    side={"motion_sd": (0.05, 0.2, 0.5)},
    n_particles=widgets.SelectionSlider(options=[10, 30, 100, 300, 1000], value=1000,
                                        description="particles N"),
    range_sd=widgets.SelectionSlider(options=[0.1, 0.2, 0.5, 1.0, 2.0], value=0.5,
                                     description="reading noise (m)"),
    motion_sd=widgets.SelectionSlider(options=[0.05, 0.1, 0.2, 0.5], value=0.2,
                                      description="wheel slip (m)"),
    alt="the particle filter against the grid's belief over one run"))

# %% [markdown]
# ## Exercise
#
# ```{exercise} 0.1 Two beacons, and a reading that goes missing
# :label: ex-onramp-two-beacons
# :nonumber:
# A second beacon now stands $16$ m along the rail, also $2$ m off it. At each step the robot
# reads its distance to both, `z[k] = (to A, to B)`, but beacon B's reading is sometimes lost:
# then `z[k, 1]` is `nan`. Write `my_filter(z, n_particles, rng, model)`, a particle filter that
# returns its estimate of the position after each step, an array of shape `(len(z),)`. The model
# is a dictionary: `model["beacons"]` (both places along the rail, m), `model["offset"]` (m),
# `model["speed"]`, `model["motion_sd"]`, `model["range_sd"]` (m) and `model["rail"]` (its two
# ends: before the first step the robot is anywhere between them). Draw every random number from
# `rng`. The checker runs your filter with $5000$ particles against the exact grid for two
# beacons, and names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_two_beacon_filter


def my_filter(z, n_particles, rng, model):
    """Your filter: z of shape (steps, 2), NaN where a reading is lost."""
    ...  # replace with your code


print(check_two_beacon_filter(my_filter))

# %% [markdown]
# ```{solution} ex-onramp-two-beacons
# :class: dropdown
# The chapter's filter with a weight that adds the log-likelihoods of the readings present
# (a lost reading says nothing, so it adds nothing); the code is in the folded cell below.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_filter(z, n_particles, rng, model):
    beacons = np.asarray(model["beacons"])
    x = rng.uniform(*model["rail"], size=n_particles)
    means = []
    for zk in z:
        x = x + model["speed"] + model["motion_sd"] * rng.standard_normal(n_particles)
        log_w = np.zeros(n_particles)
        for b, zb in zip(beacons, zk):
            if not np.isnan(zb):
                r = np.hypot(x - b, model["offset"])
                log_w -= 0.5 * ((zb - r) / model["range_sd"]) ** 2
        w = np.exp(log_w - log_w.max())
        w /= w.sum()
        means.append(w @ x)
        x = x[rng.choice(n_particles, size=n_particles, p=w)]
    return np.array(means)


print(check_two_beacon_filter(my_filter))

# %% [markdown]
# ## Takeaways
#
# - A filter's answer is a belief, a probability over every place the robot could be; Bayes'
#   rule on a grid computes it exactly, by predicting (move and spread) and updating (multiply by
#   the likelihood, rescale).
# - A particle filter keeps samples of that belief instead of the belief: it moves them, weights
#   them by the likelihood and resamples them, and with enough particles its estimate matches
#   the grid's.
# - Without resampling the weights pile onto one particle (degeneracy); resampling puts the
#   particles back where the weight is.
# - Take the logarithm of the weights and subtract the largest before exponentiating, so that no
#   reading can make every weight round to zero.
#
# ### A map of the book
#
# | if you now ask | read |
# | --- | --- |
# | why the weights and the resampling are right, and how many particles to use | {doc}`part1/index`, on a model whose exact answer is the Kalman filter |
# | how a robot on a floor, or an aircraft over hills, finds itself | {doc}`part2/index` |
# | which settings matter: particles, noise, resampling, sensors | {doc}`part3/index` |
# | when to use a Kalman filter instead | {doc}`part4/index` |
# | how to learn the noise levels from the data, and where the robot was | {doc}`part5/index` |
#
# {doc}`start_here` gives the route through the book and the time each chapter takes.
