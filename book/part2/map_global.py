# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Finding the robot on the map
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** how to tell whether a failure to find the robot is the map's or the filter's (the
# twin margin, an exact filter over the twins), and a filter built to reach that bound: poses
# drawn from the scan, injected as a kidnapping and weighted by their evidence; how it keeps the
# cloud it has; islands, small filters whose evidence over the whole run corrects a cloud on a
# twin; how it fares on drives it was not tuned on.
#
# **You need** {doc}`map_robot` (the odometry model, the likelihood field, MCL) and
# {doc}`global_localization` (random injection, augmented MCL, KLD-sampling); importance sampling.
#
# **Time:** about twenty-five minutes to read, plus about seventy-six minutes for the folded blocks; the exercise is extra.
# :::
#
# Put the robot of {doc}`map_robot` anywhere on its map, give the filter no idea where, and drive.
# The filter of that chapter, with random injection, is locked on at the end of only
# {glue:text}`lf_base_injection_rate:.0%` of the drives ({glue:text}`lf_base_bootstrap_rate:.0%`
# without injection). This chapter aims at $95$ % of the drives from a uniform start, and at finding
# a kidnapped robot again in $90$ % of kidnappings. The map has four look-alike rooms on each side
# of a corridor, so a miss may be the map's fault: this chapter first measures what the map allows.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import json
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from ipywidgets import SelectionSlider
from IPython.display import display
from scipy.special import logsumexp
from scipy.stats import chi2, norm

from pfcourse import evidence
from pfcourse.studies import map_global as mg
from pfcourse.studies import map_global_islands as mgi
from pfcourse.studies import maprobot as study
from pfcourse.studies.registry import STUDIES
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import control_panel
from pfcourse.scenarios.maprobot import global_mcl as engine
from pfcourse.scenarios.maprobot import lock_on
from pfcourse.book.figures.maprobot import draw_map
from pfcourse.scenarios.maprobot.twins import path_log_likelihoods, twin_margin, twin_poses
from pfcourse.metrics import heading_error, position_error
from pfcourse.sample_size import kld_bound as engine_kld_bound
from pfcourse.book.style import COLORS, use_style

use_style()
TOL = 1e-9  # the chapter's code and the package's give the same numbers to this


def stored(name):
    meta = STUDIES[f"map_global/{name}"].load().attrs["provenance"]
    return (f"Stored study map_global/{name} (book/data/map_global/{name}.csv, provenance in {name}.json): "
            f"{meta['wall_seconds']:.0f} s of computing on a shared 2-core machine.")


# %% [markdown]
# ## What the map allows: the twin margin
#
# Move the robot's whole path by a half-turn about the map's centre. The moved path, the *twin*,
# has the same odometry at every step and, in free space, the same prior under a uniform start.
# Shifts by $5$, $10$ or $15$ m along the corridor, with or without the half-turn, give thirteen
# twins. For one of these moves $T$, the posterior odds of the true path against its twin are the
# likelihood ratio of the scans alone:
#
# $$
# \log \frac{p(x_{0:k} \mid z_{0:k}, u_{1:k})}{p(T x_{0:k} \mid z_{0:k}, u_{1:k})}
# = \sum_{j=0}^{k} \Big( \log p(z_j \mid x_j) - \log p(z_j \mid T x_j) \Big) .
# $$
#
# A twin that runs into a wall has posterior zero from then on. The *twin margin* is the log-odds of
# the truth against all its twins together. Near zero, no filter can know which twin is the robot.

# %%
from pfcourse.studies import maprobot as study

import numpy as np
from scipy.special import logsumexp

grid, field, motion = study.book_map(), study.field(), study.MOTION
drive = study.simulate(1, 200)  # seed 1: 200 scans, 0.5 s apart


def wrap(a):
    return a - 2 * np.pi * np.ceil((a - np.pi) / (2 * np.pi))


def twin(path, turn, shift):
    """The path moved by a half-turn about the map's centre, then a shift."""
    x, y, th = path.T
    if turn:
        x, y, th = grid.width - x, grid.height - y, wrap(th + np.pi)
    return np.column_stack([x + shift, y, th])


def path_loglik(path, scans):
    ll = np.array([field.log_likelihood(p[None], z)[0]
                   for p, z in zip(path, scans)])
    # from its first pose in a wall on, a path is impossible
    return np.where(np.cumsum(~grid.is_free(path)) > 0, -np.inf, ll)


twins = [(t, s) for t in (False, True) for s in (-15, -10, -5, 0, 5, 10, 15)
         if t or s]
own = np.cumsum(path_loglik(drive.truth, drive.scans))
other = np.array([np.cumsum(path_loglik(twin(drive.truth, t, s), drive.scans))
                  for t, s in twins])
margin = own - logsumexp(other, axis=0)
print(f"twin margin at 20 s: {margin[39]:.1f} nats, at 100 s: {margin[-1]:.1f}")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
glue_values("lf_", seed1_margin_jump=float(np.abs(np.diff(margin[:60])).max()), seed1_margin_low=float(margin[:60].min()))
same_margin = np.allclose(margin, twin_margin(grid, field, drive.truth, drive.scans)[0], rtol=0, atol=TOL)
print(f"the same margin as pfcourse.scenarios.maprobot.twins.twin_margin, to {TOL:.0e}: {same_margin}")
t = np.arange(len(margin)) * study.DT
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.6), gridspec_kw={"width_ratios": [1.3, 1]})
draw_map(ax1, grid)
half = twin(drive.truth, True, 0)
ax1.plot(*drive.truth[:, :2].T, color=COLORS["truth"], lw=1.2, label="the drive (100 s)")
ax1.plot(*half[:, :2].T, color=COLORS["estimate"], lw=1.2, ls="--", label="its half-turn twin")
ax1.plot(*drive.truth[0, :2], "o", color=COLORS["truth"], ms=6)
ax1.plot(*half[0, :2], "o", color=COLORS["estimate"], ms=6)
ax1.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
ax1.set_title("Seed 1: the path and its twin (dots: start)")
twins_table = STUDIES["map_global/twins"].load()
cols = [f"margin_{s}s" for s in mg.MARGIN_TIMES_S]
q = twins_table[cols].quantile([0.1, 0.5, 0.9]).to_numpy()
ax2.fill_between(mg.MARGIN_TIMES_S, q[0], q[2], color=COLORS["particles"], alpha=0.3,
                 label="100 drives: 10-90 %")
ax2.plot(mg.MARGIN_TIMES_S, q[1], color=COLORS["particles"], label="100 drives: median")
ax2.plot(t + study.DT, margin, color=COLORS["truth"], label="seed 1")
ax2.axhline(np.log(mg.DECIDED_ODDS), color=COLORS["unseen"], ls="--", label="odds 99 : 1")
ax2.set_yscale("symlog", linthresh=10)
ax2.set_xlabel("time t (s)")
ax2.set_ylabel("twin margin (nats;\nlinear within ±10)")
ax2.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
ax2.set_title("The truth's log-odds against its twins")
plt.show()

# %% [markdown]
# The half-turn twin of seed $1$ runs through the rooms opposite the robot's, seeing the same
# walls. The margin moves in jumps of up to {glue:text}`lf_seed1_margin_jump:.1f` nats a scan and
# can favour the twins by chance: it falls to {glue:text}`lf_seed1_margin_low:.0f` nats in the first
# $30$ s, before the box or an end of the corridor comes into view.
#
# :::{admonition} Decided drives, and why that share is not a ceiling
# :class: dropdown
# Call a drive **decided** when the truth's posterior odds against its twins are at least
# $99 : 1$ at $80$ % of the steps of the last $20$ s. The evidence decides
# {glue:text}`lf_decided_rate:.0%` of the drives
# ({glue:text}`lf_decided_rate_low:.0%`-{glue:text}`lf_decided_rate_high:.0%`). That share is not a
# ceiling: a filter reports its weighted mean, and the lock-on rule below asks only that the mean be
# within $1$ m and a few degrees of the truth.
# :::
#
# The bound is the lock-on rule applied to an **exact filter
# over the truth and its thirteen twins** (masses $\propto$ the paths' likelihoods, weighted mean
# position, circular mean heading): it is locked on in {glue:text}`lf_exact_lock_on_rate:.0%` of
# the drives ({glue:text}`lf_exact_lock_on_rate_low:.0%`-{glue:text}`lf_exact_lock_on_rate_high:.0%`).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
decided = evidence.rate(twins_table["decided"].to_numpy())
late = twins_table.loc[~twins_table["decided"], ["seed", "final_margin", "margin_80s", "margin_90s"]]
glue_values("lf_", decided_rate=decided.estimate, decided_rate_low=decided.low, decided_rate_high=decided.high,
            n_twin_drives=len(twins_table))
exact_all = STUDIES["map_global/exact_twins"].load().sort_values("seed")
exact_table = exact_all[exact_all["seed"] < mg.FRESH_SEED]
assert (exact_table["seed"].to_numpy() == twins_table["seed"].to_numpy()).all()
assert (exact_table["decided"].to_numpy() == twins_table["decided"].to_numpy()).all()
exact = evidence.rate(exact_table["exact_locked_on"].to_numpy())
glue_values("lf_", exact_lock_on_rate=exact.estimate, exact_lock_on_rate_low=exact.low,
            exact_lock_on_rate_high=exact.high)
amcl_global = STUDIES["maprobot/amcl_global"].load()
base_inj = amcl_global[(amcl_global["method"] == "injection") & (amcl_global["weighting"] == "product")]
base_boot = amcl_global[amcl_global["method"] == "bootstrap"]
base_inj, base_boot = base_inj.sort_values("seed"), base_boot.sort_values("seed")
assert (base_inj["seed"].to_numpy() == twins_table["seed"].to_numpy()).all()
glue_values("lf_", base_injection_rate=base_inj["locked_on"].mean(), base_bootstrap_rate=base_boot["locked_on"].mean())
EvidenceBlock(
    "the evidence decides almost every drive by its end",
    notes=[f"{len(twins_table)} drives (seeds 0-{len(twins_table) - 1}, the drives of the global-localization "
           f"studies), 100 s each; thirteen twins (half-turn about the map's centre and shifts of 5, 10, 15 m "
           "either way, alone or after the half-turn); a twin pose in a wall or off the map ends its path.",
           f"Decided (odds at least {mg.DECIDED_ODDS:.0f} : 1 against all twins together at 80 % or more of the "
           f"last 20 s): {decided} (Wilson interval; see Reading the evidence).",
           f"Median margin at 20 s: {twins_table['margin_20s'].median():.1f} nats; at 100 s: "
           f"{twins_table['margin_100s'].median():.0f} nats; share at or below 0 at 20 s: "
           f"{(twins_table['margin_20s'] <= 0).mean():.2f}.",
           "A drive not decided is one whose margin is still too small, or was too small for part of the last "
           "20 s: the table lists them.",
           f"The bound, an exact filter over the truth and its 13 twins judged by the lock-on rule: {exact} "
           f"(Wilson interval). It is optimistic: it knows the true path up to the 13 moves (no odometry "
           f"error, no other look-alike poses); a filter may also be right on a drive the evidence does not "
           f"decide at 99 : 1, since its mean only has to be close. The margin is a ratio of densities along "
           f"two paths, not of posterior masses around them.",
           stored("twins"), stored("exact_twins")],
    tables=[("The drives the evidence does not decide (margins in nats)", late,
             {"final_margin": ".1f", "margin_80s": ".1f", "margin_90s": ".1f"})],
)

# %% [markdown]
# :::{admonition} Why the plain filter falls short
# :class: dropdown
# Early in a drive every twin fits. The likelihood field is
# sharp ($24$ beams, $\sigma_{\mathrm{hit}} = 0.2$ m), so after one scan a few poses carry nearly
# all the weight, and one twin may take every particle before the evidence has chosen. A uniform
# injected pose must land within centimetres of the truth and, with no history, scores no better
# than the twin's. The cure: many poses at the start; injected poses drawn where the scan fits,
# weighted by the evidence of several scans and the kidnap model's prior; and guards that keep the
# cloud in place.
# :::

# %% [markdown]
# ## Poses where the scan fits: sensor resetting
#
# Sensor resetting {cite:p}`lenser2000` draws new poses from the reading itself; for a laser scan,
# by scoring candidate poses:
#
# 1. draw $500$ positions uniformly in free space, each with $24$ evenly spaced headings;
# 2. score every candidate by the likelihood field, tempered ($\tfrac12 \log p(z \mid x)$, so that
#    near misses still count), and keep the best $200$;
# 3. move each kept candidate to the best of $8$ random nudges ($0.15$ m, $0.05$ rad), three times;
# 4. draw each pose by picking a candidate $c$ in proportion to its tempered score $v_c$, plus
#    Gaussian noise $h = (0.15\ \mathrm{m}, 0.15\ \mathrm{m}, 0.05\ \mathrm{rad})$.
#
# Given the candidates, the density of a pose so drawn is a mixture of Gaussian kernels,
#
# $$
# q(x) = \sum_c v_c\, \mathcal N\big(x;\, c,\, \operatorname{diag}(h^2)\big),
# $$
#
# with the heading difference wrapped to $(-\pi, \pi]$.

# %%
H = np.array([0.15, 0.15, 0.05])  # the kernel: m, m, rad


def systematic(W, m, rng):
    c = np.cumsum(W)
    c[-1] = 1.0
    u = (rng.random() + np.arange(m)) / m
    return np.searchsorted(c, u, side="right").clip(max=len(W) - 1)


def scan_proposal(z, n, rng, m=500, headings=24, keep=200, rounds=3, tries=8):
    """n poses drawn where scan z fits, and their log q(x)."""
    xy = grid.sample_free(m, rng)[:, :2]  # 1. candidates
    th = wrap((rng.random() + np.arange(headings)) * 2 * np.pi / headings)
    c = np.column_stack([np.repeat(xy, headings, axis=0), np.tile(th, m)])
    s = 0.5 * field.log_likelihood(c, z)  # 2. tempered scores, the best kept
    best = np.argpartition(-s, keep - 1)[:keep]
    c, s = c[best], s[best]
    for _ in range(rounds):  # 3. each moves to its best nudge, if better
        t = c[:, None] + rng.standard_normal((keep, tries, 3)) * H
        t[..., 2] = wrap(t[..., 2])
        ts = 0.5 * field.log_likelihood(t.reshape(-1, 3), z).reshape(keep, -1)
        j = ts.argmax(axis=1)
        up = ts[np.arange(keep), j] > s
        c[up], s[up] = t[up, j[up]], ts[up, j[up]]
    log_v = s - logsumexp(s)  # 4. kernels around candidates picked by score
    x = c[systematic(np.exp(log_v), n, rng)] + rng.standard_normal((n, 3)) * H
    x[:, 2] = wrap(x[:, 2])
    d = x[:, None] - c[None]
    d[..., 2] = wrap(d[..., 2])
    log_k = -0.5 * ((d / H) ** 2).sum(-1) - np.log((2 * np.pi)**1.5 * H.prod())
    return x, logsumexp(log_k + log_v, axis=1)


# seed 1 at 75 s: the robot in the corridor
k_room = 150
x_q, log_q = scan_proposal(drive.scans[k_room], 300, np.random.default_rng(5))
near = np.hypot(*(x_q[:, :2] - drive.truth[k_room, :2]).T) < 0.5
# one seeded draw: another seed gives another share
print(f"{near.mean():.0%} of the 300 poses are within 0.5 m of the robot")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
x_e, log_q_e = engine.scan_proposal(grid, field, drive.scans[k_room], 300, np.random.default_rng(5))
same_q = np.allclose(x_q, x_e, rtol=0, atol=TOL) and np.allclose(log_q, log_q_e, rtol=0, atol=TOL)
print(f"the same poses and log q as pfcourse.scenarios.maprobot.global_mcl.scan_proposal, to {TOL:.0e}: {same_q}")

# %% [markdown]
# ## Injected as a kidnapping, weighted by their evidence
#
# Augmented MCL ({cite:t}`thrun2005`, table $8.3$) gives its uniform injected poses the weight of
# the others; ours come from $q$ and need $u / q$. This book's construction: the robot may have been
# **carried anywhere $L$ scans ago**, with probability $\xi_k$ (here $L = 20$ scans, $10$ s). The cloud's $M$
# moved particles stand for "not carried", the $R$ injected poses for "carried at step $k - L$".
# A small filter of $R$ particles carries them from $q$ at step $k - L$ to now. Write
# $\ell_j = \frac{1}{M} \sum_i p(z_j \mid x_j^i)$ for the cloud's mean likelihood at scan $j$, its
# estimate of $p(z_j \mid z_{0:j-1})$. The injected pose's weight is an importance weight of the
# kidnap model, against the cloud's own account of the same scans:
#
# $$
# W \propto \frac{\xi_k}{R}\; \frac{u(x_{k-L})}{q(x_{k-L})}\;
# \frac{\prod_{j=k-L}^{k} p(z_j \mid x_j)}{\prod_{j=k-L}^{k-1} \ell_j}
# \qquad\text{against}\qquad
# W \propto \frac{1 - \xi_k}{M}\; p(z_k \mid x_k)
# $$
#
# for a moved particle, with $u = 1 / (A_{\mathrm{free}}\, 2\pi)$ the uniform density. The factor
# $u / q$ undoes the aim of the proposal. The small filter resamples at every scan, so the product
# of past likelihoods is carried by the product of its mean weights: what a pose with no history
# lacks. Over twenty scans a pose at the truth has seen the box and its twin has not.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def injected(scans, odometry, k, r, log_l, rng, L=20):
    """r poses carried L scans ago, their log-weights (without xi / R)."""
    x, log_q = scan_proposal(scans[k - L], r, rng)
    free = grid.is_free(x)
    log_u = np.where(free, -np.log(grid.free_area * 2 * np.pi), -np.inf)
    lw = log_u - log_q + field.log_likelihood(x, scans[k - L])
    log_evidence = 0.0
    for j in range(k - L + 1, k + 1):
        log_evidence += logsumexp(lw) - np.log(r)
        parent = systematic(np.exp(lw - logsumexp(lw)), r, rng)
        x = motion.sample(x[parent], odometry[j], rng)
        lw = field.log_likelihood(x, scans[j])
    # log_l[j]: the cloud's log mean likelihood at scan j
    return x, lw + log_evidence - log_l[k - L:k].sum()


# a stratum at 85 s on seed 1 (a record of zeros scales all weights alike)
x_r, lw_r = injected(drive.scans, drive.drive.odometry, 170, 200,
                     np.zeros(200), np.random.default_rng(3))
near_r = np.hypot(*(x_r[:, :2] - drive.truth[170, :2]).T) < 1
w_r = np.exp(lw_r - logsumexp(lw_r))
print(f"{w_r[near_r].sum():.0%} of its weight lies within 1 m of the robot")


# %% tags=["hide-input"] jupyter={"source_hidden": true}
log_z_demo = np.linspace(-5.0, 5.0, 200)  # any record of the cloud's evidence will do for the check
ours_inj = injected(drive.scans, drive.drive.odometry, 170, 200, log_z_demo, np.random.default_rng(3))
pkg_inj = engine.injected(grid, field, motion, drive.scans, drive.drive.odometry, 170, 200, log_z_demo,
                          np.random.default_rng(3))
same_inj = all(np.allclose(a, b, rtol=0, atol=TOL) for a, b in zip(ours_inj, pkg_inj))
print(f"the same poses and log-weights as pfcourse.scenarios.maprobot.global_mcl.injected, to {TOL:.0e}: {same_inj}")

# %% [markdown]
# ## How likely is a kidnapping?
#
# The prior $\xi_k$ is the kidnap model's of {doc}`global_localization`: carried away at a scan
# with probability $\xi = 10^{-3}$ (chosen by hand); an injection stands for the $4$ scans since
# the last, $\xi_k = 4 \xi$.
#
# :::{admonition} Going further: augmented MCL's rate as the prior
# :class: dropdown
# Augmented MCL's rate $1 - w_{\mathrm{fast}} / w_{\mathrm{slow}}$ (table $8.3$), from running
# averages of the cloud's mean likelihood $\ell_k$, is made to detect a kidnapping, not to be its
# probability. Table $8.3$ has no floor, and ROS's AMCL injects nothing by default (its recovery rates
# are $0$). Mixture-MCL {cite:p}`thrun2001` is a relative of the cure: it too mixes poses drawn from
# the sensor into the cloud with importance weights. The book's first variant gave that rate a floor of $0.01$; on a right cloud the rate sits
# at the floor at {glue:text}`lf_demo_ratio_floor_share:.0%` of the scans of the run below, so the
# floor, a number chosen by hand, decides whether a noisy stratum may replace a right cloud. On the
# drives it was tuned on it did no better than the kidnap prior (the evidence block of "Does it reach
# the bound?").
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
# a kidnapping once in 1000 scans; an injection every 4
xi, every = 1e-3, 4


def mix(moved, lw_m, inj, lw_r, xi_k):
    """The moved (mass 1 - xi_k) and injected (mass xi_k) particles."""
    a = np.log1p(-xi_k) - np.log(len(moved)) + lw_m
    b = np.log(xi_k) - np.log(len(inj)) + lw_r
    return np.concatenate([moved, inj]), np.concatenate([a, b])


# %% tags=["hide-input"] jupyter={"source_hidden": true}
rng_mix = np.random.default_rng(4)
moved_demo, lw_m_demo = rng_mix.normal(size=(300, 3)), rng_mix.normal(size=300)
inj_demo, lw_r_demo = ours_inj[0], ours_inj[1]
ours_mix = mix(moved_demo, lw_m_demo, inj_demo, lw_r_demo, every * xi)
pkg_mix = engine._stratified([(1 - every * xi, moved_demo, lw_m_demo), (every * xi, inj_demo, lw_r_demo)])
same_mix = all(np.allclose(a, b, rtol=0, atol=TOL) for a, b in zip(ours_mix, pkg_mix))
same_rho = engine.HAZARD.kidnap_hazard == xi and engine.HAZARD.inject_every == every
print(f"the same cloud as the engine's strata, to {TOL:.0e}: {same_mix}; the engine's hazard and cadence: {same_rho}")

# %% [markdown]
# ## Keeping the cloud it has
#
# A stratum that wins replaces the cloud: a strength after a kidnapping, a weakness when the cloud
# was right. Two guards keep the cloud.
#
# **The belief's evidence.** After a stratum replaces a wrong cloud, the cure records the
# evidence of the mixed cloud, not the wrong cloud's poor fit.
#
# :::{admonition} Going further: the evidence of an admitted stratum
# :class: dropdown
# A stratum is compared with the cloud's record of the last $L$ scans,
# $\prod_j \ell_j$. After a stratum replaces a wrong cloud, that record still holds the wrong
# cloud's poor fit, and the next stratum, even a twin's, wins against it. So at an admission the cure
# records the evidence of the mixed cloud instead.
#
# With $\hat B$ the stratum's mean weight over the cloud's, its estimated Bayes factor for the whole
# window $k - L, \dots, k$, the sum of the mixed weights is not a one-step predictive density but a
# factor of the cumulative normaliser:
#
# $$
# p(z_{0:k}) \approx p(z_{0:k-L-1}) \prod_{j=k-L}^{k-1} \ell_j
# \,\big[ (1 - \xi_k)\, \ell_k + \xi_k\, \hat B\, \ell_k \big] .
# $$
#
# The cure records that factor whenever a stratum is admitted. Later windows straddle the admission,
# so their comparison is approximate.
# :::
#
# **Hysteresis** is a decision rule, not part of any weight. A stratum's log-odds against the cloud
# are {glue:text}`lf_prior_log_odds:.1f` $+ \log \hat B$; a *win* is odds above $1 : 1$, a coin
# flip by the filter's own reckoning. The cure counts the injections in a row at which the fresh
# stratum out-weighs the cloud (a loss sets the count to $0$) and admits the winning stratum while the
# count is $3$ or more.
#
# :::{admonition} What the count does not ask
# :class: dropdown
# The count does not ask where the winning strata lie: one on the robot and two on its twin make
# three. An admission does not reset it: after three wins, a twin's first win is admitted at once.
# (Dropping a winning stratum is not Bayes.) The rule in NumPy is in the folded cell below.
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def admit(moved, lw_m, inj, lw_r, xi_k, streak, log_l_k, confirm=3):
    """Mix the stratum in while confirm injections in a row have won."""
    a = np.log1p(-xi_k) - np.log(len(moved)) + lw_m  # mass 1 - xi_k
    b = np.log(xi_k) - np.log(len(inj)) + lw_r  # mass xi_k
    x, lw = np.concatenate([moved, inj]), np.concatenate([a, b])
    w = np.exp(lw - logsumexp(lw))
    share = w[len(moved):].sum()
    # a win: this stratum outweighs the cloud, wherever its poses lie;
    # the count is not reset when a stratum is admitted
    streak = streak + 1 if share > 0.5 else 0
    if streak < confirm:
        return moved, lw_m, 0.0, streak, log_l_k
    # admitted: the returned log evidence replaces log_l[k] in the record
    # that injected() divides by (the belief's evidence)
    return x, lw, share, streak, logsumexp(lw)


# %% tags=["hide-input"] jupyter={"source_hidden": true}
same_admit = True
for streak0 in (0, 2):
    ours_adm = admit(moved_demo, lw_m_demo, inj_demo, lw_r_demo + 8.0, every * xi, streak0, -1.0)
    pkg_adm = engine.admit(moved_demo, lw_m_demo, inj_demo, lw_r_demo + 8.0, every * xi, streak0, -1.0, engine.CURE)
    same_admit &= all(np.allclose(a, b, rtol=0, atol=TOL) for a, b in zip(ours_adm, pkg_adm))
print(f"the same cloud, streak and evidence as pfcourse.scenarios.maprobot.global_mcl.admit, to {TOL:.0e}: "
      f"{same_admit}; the engine's confirm: {engine.CURE.confirm}")
glue_values("lf_", prior_log_odds=float(np.log(every * xi / (1 - every * xi))))

# %% [markdown]
# A kidnap run shows both. The filter tracks the robot from its known pose; at $20$ s the robot is
# carried to another waypoint while its odometry reports no motion (kidnap drive $5$; hysteresis
# alone dashed, the cure solid).
#
# :::{admonition} What the kidnap run shows
# :class: dropdown
# With hysteresis alone, a stratum finds the robot again at {glue:text}`lf_cascade_found_s:.0f` s.
# At {glue:text}`lf_cascade_lost_s:.0f` s a stratum on the half-turn twin wins once, with the count
# at {glue:text}`lf_cascade_twin_count:d`, and is admitted on that first win. With the belief's
# evidence too (the cure), no later stratum wins on this run.
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def trace(d, rng, s, start=None):
    """The engine's run on drive d, and per injection: the count after it, admitted or not, the stratum's weighted
    mean position and the robot's position then (the engine's admit, watched: same draws, same result)."""
    log, plain = [], engine.admit

    def watched(moved, lw_m, inj, lw_r, eps, streak, log_z_k, s_):
        out = plain(moved, lw_m, inj, lw_r, eps, streak, log_z_k, s_)
        w = np.exp(lw_r - logsumexp(lw_r))
        log.append((out[3], out[2] > 0, w @ inj[:, :2]))
        return out

    engine.admit = watched
    try:
        r = engine.global_mcl(grid, field, motion, d.scans, d.drive.odometry, rng, s, start=start)
    finally:
        engine.admit = plain
    steps = [k for k in range(len(d.scans)) if k >= s.history and k % s.inject_every == 0]
    assert len(steps) == len(log)
    return r, pd.DataFrame([dict(t=k * study.DT, count=c, admitted=a, off_m=float(np.hypot(*(m - d.truth[k, :2]))),
                                 off_cloud_m=float(np.hypot(*(m - r.mean[k, :2]))))
                            for k, (c, a, m) in zip(steps, log)])


kid_drive = study.simulate(5, study.KIDNAP_STEPS, kidnap_at=study.KIDNAP_STEP)
t_kid = np.arange(study.KIDNAP_STEPS) * study.DT
only_hysteresis = replace(engine.HAZARD, confirm=engine.CONFIRM)
fig, ax = plt.subplots(figsize=(8, 3.4))
for name, s_run, ls in (("hysteresis only", only_hysteresis, "--"), ("the cure", engine.CURE, "-")):
    r_kid, inj_log = trace(kid_drive, np.random.default_rng([41, 5, 2]), s_run, start=kid_drive.truth[0])
    err = position_error(kid_drive.truth, r_kid.mean)
    ax.semilogy(t_kid, np.maximum(err, 1e-2), ls=ls, label=name,
                color=COLORS["estimate"] if ls == "-" else COLORS["particles"])
    if ls == "--":  # found again (first step within the tolerances after the kidnapping), then 2 m away
        ok = lock_on.locked_steps(err, heading_error(kid_drive.truth, r_kid.mean), mg.HEADING_TOL)
        found = study.KIDNAP_STEP + np.flatnonzero(ok[study.KIDNAP_STEP:])[0]
        lost_at = found + np.flatnonzero(err[found:] > 2.0)[0]
        # the injection that hands the estimate away: a stratum more than 2 m from the robot, admitted; the one
        # before it won too, on the robot
        handover = inj_log[(inj_log["t"] == lost_at * study.DT)].iloc[0]
        before = inj_log[inj_log["t"] == handover["t"] - engine.HAZARD.inject_every * study.DT].iloc[0]
        assert handover["admitted"] and handover["off_m"] > 2 and before["admitted"] and before["off_m"] < 1
        glue_values("lf_", cascade_found_s=float(found * study.DT), cascade_lost_s=float(lost_at * study.DT),
                    cascade_twin_count=int(handover["count"]))
    else:  # the cure keeps the robot: no stratum wins after the first admission
        first = inj_log.index[inj_log["admitted"]][0]
        assert (inj_log.loc[first + 1:, "count"] == 0).all() and err[-1] < 1
ax.axvline(study.KIDNAP_STEP * study.DT, color=COLORS["unseen"], lw=0.8)
ax.axhline(1.0, color=COLORS["unseen"], ls=":", label="1 m")
ax.set_xlabel("time t (s); the robot is carried away at 20 s")
ax.set_ylabel("position error (m)")
ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), ncol=3)
ax.set_title("Kidnap drive 5: with hysteresis alone, the estimate flips robot-twin")
plt.show()

# %% [markdown]
# ## Islands: start hypotheses compared over the whole run
#
# The guards judge a stratum by the last $L$ scans and forget older evidence. On development
# drive {glue:text}`lf_isl_demo_seed:d` the cure sits on a twin to the end. Four small independent
# filters, *islands*, run beside the cloud from the same uniform start.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
import sys


def watch_islands(d, rng, s):
    """The engine's run on drive d, and per step k >= 1 the log-evidence of the cloud and of each island when
    global_mcl compares them (the engine's island_step, watched: same draws, same result)."""
    cloud, isl_z, plain = {}, {}, engine.island_step

    def watched(field_, motion_, z, u, island, rng_):
        f = sys._getframe(1)
        while "log_z" not in f.f_locals:  # global_mcl's frame: its record of the cloud's evidence
            f = f.f_back
        k = f.f_locals["k"]
        cloud[k] = float(f.f_locals["log_z"][:k + 1].sum())
        out = plain(field_, motion_, z, u, island, rng_)
        isl_z.setdefault(k, []).append(float(out[2].sum()))
        return out

    engine.island_step = watched
    try:
        r = engine.global_mcl(grid, field, motion, d.scans, d.drive.odometry, rng, s)
    finally:
        engine.island_step = plain
    steps = np.array(sorted(cloud))
    return r, steps, np.array([cloud[k] for k in steps]), np.array([isl_z[k] for k in steps])


isl_seed = 6
isl_drive = study.simulate(isl_seed, study.GLOBAL_STEPS)
res_isl, isl_steps, isl_cloud, isl_evidence = watch_islands(isl_drive, mg.filter_rng(isl_seed), engine.ISLANDS)
res_cure6 = engine.global_mcl(grid, field, motion, isl_drive.scans, isl_drive.drive.odometry,
                              mg.filter_rng(isl_seed), engine.CURE)
adopted = np.flatnonzero(res_isl.injected_mass == 1.0)
isl_margin6, _ = twin_margin(grid, field, isl_drive.truth, isl_drive.scans)
t6 = np.arange(study.GLOBAL_STEPS) * study.DT
err_isl, err_cure6 = position_error(isl_drive.truth, res_isl.mean), position_error(isl_drive.truth, res_cure6.mean)
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 5.6), sharex=True)
gap = isl_evidence.max(axis=1) - isl_cloud
ax1.plot(isl_steps * study.DT, gap, color=COLORS["estimate"], label="best island minus the cloud")
ax1.axhline(np.log(mg.DECIDED_ODDS), color=COLORS["unseen"], ls="--", label="log 99 (adopt above)")
ax1.set_ylabel("log-evidence gap (nats)")
ax1.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax1.set_title(f"Development drive {isl_seed}, from a uniform start")
ax2.semilogy(t6, np.maximum(err_cure6, 1e-2), color=COLORS["particles"], ls="--", label="the cure")
ax2.semilogy(t6, np.maximum(err_isl, 1e-2), color=COLORS["estimate"], label="with islands")
ax2.axhline(1.0, color=COLORS["unseen"], ls=":", label="1 m")
for ax in (ax1, ax2):
    for k_a in adopted:
        ax.axvline(k_a * study.DT, color=COLORS["truth"], lw=1)
ax2.plot([], [], color=COLORS["truth"], lw=1, label="an island adopted")
ax2.set_ylabel("position error (m)")
ax2.set_xlabel("time t (s)")
ax2.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
plt.show()
assert len(adopted) == 1 and err_cure6[-1] > 2 and err_isl[-1] < 1
glue_values("lf_", isl_demo_seed=isl_seed, isl_demo_adopt_s=float(adopted[0] * study.DT),
            isl_demo_decided_s=float(mgi.decided_from(isl_margin6) * study.DT),
            isl_demo_cure_end_m=float(err_cure6[-1]))

# %% [markdown]
# At {glue:text}`lf_isl_demo_adopt_s:.0f` s the gap touches $\log 99$ once, and the cloud takes
# that island's poses and record. The cure ends {glue:text}`lf_isl_demo_cure_end_m:.0f` m off.
#
# :::{admonition} Reading the figure
# :class: dropdown
# After the adoption the gap drops below zero: the islands keep running, and the cloud now carries
# the best record. The twin margin passes $99 : 1$ at the same step here
# ({glue:text}`lf_isl_demo_decided_s:.0f` s), though the two are computed from different things.
# :::
#
# Each island is a filter of $N = 200$ poses for the same model. With $w_j^i$ the weight of its
# pose $i$ at scan $j$, the product of its mean weights,
#
# $$
# \hat Z_k = \prod_{j=0}^{k} \frac{1}{N} \sum_{i=1}^{N} w_j^i ,
# \qquad \mathbb E\, \hat Z_k = p(z_{0:k} \mid u_{1:k}),
# $$
#
# is an unbiased estimate of the evidence {cite:p}`delmoral2004` (the claim is proved in
# {doc}`../part1/why_it_works`). A filter that has lost the robot's mode explains every later scan
# by a twin's path: its $\hat Z_k$ falls behind, with no window to forget it.
#
# :::{admonition} The cloud's record is not of the same kind
# :class: dropdown
# The cloud keeps a record too, $\sum_j \log \ell_j$, but not an unbiased estimate of the
# evidence: the guards drop strata, admissions rewrite it with the mixture's evidence, and an
# adoption copies the best of four records, which favours high ones.
# :::
#
# The cloud adopts an island whose $\log \hat Z_k$ beats its record by more than $\log 99$. That
# is a margin chosen on the development drives, not odds of $99 : 1$: the estimates of $200$-pose
# filters are noisy by several nats (below, two islands that both end on the robot end
# {glue:text}`lf_isl_robot_gap_nats:.1f` nats apart). The design follows the island particle model
# {cite:p}`verge2015`, with a hard selection in place of its weighting and resampling, so its
# guarantees do not carry over.

# %%
def start_islands(z0, n_islands, size, rng):
    """Small filters from the scan's proposal: (x, log w, record)."""
    out = []
    for _ in range(n_islands):
        x, log_q = scan_proposal(z0, size, rng)
        free = grid.is_free(x)
        log_u = np.where(free, -np.log(grid.free_area * 2 * np.pi), -np.inf)
        lw = log_u - log_q + field.log_likelihood(x, z0)
        out.append((x, lw, [logsumexp(lw) - np.log(size)]))
    return out


def island_step(island, z, u, rng):
    """Resample, move, weight; the record gains the log mean weight."""
    x, lw, record = island
    W = np.exp(lw - logsumexp(lw))
    x = motion.sample(x[systematic(W, len(x), rng)], u, rng)
    lw = field.log_likelihood(x, z)
    return x, lw, record + [logsumexp(lw) - np.log(len(x))]


def adopt(islands, log_z_cloud, margin=np.log(99)):
    """The island whose log-evidence beats the cloud's by margin, or None."""
    z = [np.sum(i[2]) for i in islands]
    best = int(np.argmax(z))
    return best if z[best] - log_z_cloud > margin else None


# four islands alone on drive 6 (no cloud): evidence and distance at 100 s
d6, rng = study.simulate(6, 200), np.random.default_rng(8)
isl = start_islands(d6.scans[0], 4, 200, rng)
for k in range(1, 200):
    isl = [island_step(i, d6.scans[k], d6.drive.odometry[k], rng) for i in isl]
for x, lw, record in isl:
    off = np.hypot(*(x[:, :2].mean(axis=0) - d6.truth[-1, :2]))
    print(f"log Z = {np.sum(record):8.1f}, mean {off:5.1f} m from the robot")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
ours_start = start_islands(isl_drive.scans[0], 4, 200, np.random.default_rng(9))
pkg_start = engine.start_islands(grid, field, isl_drive.scans[0], np.random.default_rng(9), engine.ISLANDS)
same_isl = all(np.allclose(a[0], b[0], rtol=0, atol=TOL) and np.allclose(a[1], b[1], rtol=0, atol=TOL)
               and np.allclose(a[2], b[2], rtol=0, atol=TOL) for a, b in zip(ours_start, pkg_start))
ours_step = island_step(ours_start[0], isl_drive.scans[1], isl_drive.drive.odometry[1], np.random.default_rng(10))
pkg_step = engine.island_step(field, motion, isl_drive.scans[1], isl_drive.drive.odometry[1], pkg_start[0],
                              np.random.default_rng(10))
same_isl &= all(np.allclose(a, b, rtol=0, atol=TOL) for a, b in zip(ours_step, pkg_step))
# the adoption test on the engine's own records of drive 6: it adopts at the steps where global_mcl did
ours_adopted = [k for k, c, zs in zip(isl_steps, isl_cloud, isl_evidence)
                if adopt([(None, None, [z]) for z in zs], c, np.log(mg.DECIDED_ODDS)) is not None]
same_adopt = np.array_equal(ours_adopted, adopted) and engine.ISLANDS.island_margin == np.log(mg.DECIDED_ODDS)
print(f"the same islands and step as pfcourse.scenarios.maprobot.global_mcl.start_islands and island_step, "
      f"to {TOL:.0e}: {same_isl}; the same adoptions as global_mcl on drive {isl_seed}: {same_adopt}")
assert same_isl and same_adopt
# the islands that end on the robot (within 1 m): how far apart their log-evidence ends
on_robot_z = [np.sum(r) for x, lw, r in isl if np.hypot(*(x[:, :2].mean(axis=0) - d6.truth[-1, :2])) < 1]
assert len(on_robot_z) >= 2
glue_values("lf_", isl_robot_gap_nats=float(np.ptp(on_robot_z)))

# %% [markdown]
# :::{admonition} Algorithm 15.1: global localization with evidence-weighted sensor resetting and islands
# :class: algorithm
# 1. **Start.** Draw $20000$ poses from $u$ and $2000$ from $q$ for the first scan; weight them
#    $p(z_0 \mid x)$ and $\frac{u}{q}\, p(z_0 \mid x)$, half the mass to each group. From a uniform
#    start, also $4$ islands of $200$ poses drawn from $q$, weighted $\frac{u}{q}\, p(z_0 \mid x)$.
# 2. **For** each scan $z_k$, $k = 1, 2, \dots$:
#    1. *size:* $M$ from the KLD bound for the bins of the weighted cloud, clipped to $[300, 5000]$
#       (here the floor, $300$, from the first scan on);
#    2. *move:* resample $M$ particles, move each by the odometry, weight by $p(z_k \mid x_k)$;
#       record $\ell_k$;
#    3. *inject* (every fourth scan, from $k = 20$ on): $R = \max(200, M / 10)$ poses carried since
#       step $k - L$, weighted as above, given the mass $\xi_k = 4 \xi$ against the cloud's
#       $1 - \xi_k$. If the stratum outweighs the cloud, add $1$ to the count, else set it to $0$.
#       While the count is $3$ or more, the cloud is the $M + R$ weighted particles and the scan's
#       evidence their summed weight; otherwise the stratum is dropped. (The count does not ask
#       where the strata lie; an admission does not reset it.)
#    4. *islands* (none when tracking from a known start, as in a kidnap run): move each island
#       one step, add its log mean weight to its record; if the best record beats the cloud's
#       $\sum_j \log \ell_j$ by more than $\log 99$, the cloud takes that island's poses,
#       weights and record. The islands keep running all drive, and an adoption can repeat.
#    5. *estimate:* weighted mean position and circular mean heading.
# :::
#
# The package's `global_mcl` is this algorithm (`ISLANDS`; without the islands step, the cure
# `CURE`).
# The cure without islands (steps $1$-$3$ and $5$), run on seed $1$:

# %% tags=["hide-input"] jupyter={"source_hidden": true}
res, demo_log = trace(drive, np.random.default_rng([41, 1, 2]), engine.CURE)
pos, head = position_error(drive.truth, res.mean), heading_error(drive.truth, res.mean)
# the dip: the estimate passes the robot on its half-turn twin (the closest approach before the evidence decides)
decided_at = np.flatnonzero(margin > np.log(mg.DECIDED_ODDS))
dip = int(np.argmin(pos[:decided_at[0]]))
fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(8, 6.6), sharex=True)
ax1.semilogy(t, np.maximum(pos, 1e-2), color=COLORS["estimate"], label="the filter's position error")
ax1.axhline(1.0, color=COLORS["unseen"], ls="--", label="lock-on tolerance (1 m)")
ax1.plot(t[dip], pos[dip], "v", ms=8, color=COLORS["truth"], label="the twin crosses the robot")
ax1.set_ylabel("error (m)")
ax1.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax1.set_title("The cure on seed 1, from a uniform start")
ax2.plot(t, np.degrees(head), color=COLORS["estimate"], label="the filter's heading error")
ax2.plot(t[dip], np.degrees(head[dip]), "v", ms=8, color=COLORS["truth"])
ax2.set_ylabel("heading error (°)")
ax2.set_yticks([0, 90, 180])
ax2.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
ax3.plot(t, np.clip(margin, -20, 60), color=COLORS["truth"], label="twin margin (cut at 60)")
ax3.axhline(np.log(mg.DECIDED_ODDS), color=COLORS["unseen"], ls="--", label="odds 99 : 1")
ax3.set_ylabel("nats")
ax3.set_xlabel("time t (s)")
ax3.legend(loc="upper left", bbox_to_anchor=(1.02, 1))
plt.show()
demo_locked = lock_on.locked_from(pos, head, study.DT, mg.HEADING_TOL)
on_robot = lock_on.locked_steps(pos, head, mg.HEADING_TOL)[1:]
# the injections from the evidence's decision to the admission that locks the filter on
decided_s, locked_s = float((decided_at[0] + 1) * study.DT), float(demo_locked * study.DT)
between = demo_log[(demo_log["t"] > decided_s) & (demo_log["t"] <= locked_s)]
assert between["admitted"].sum() == 1 and between["admitted"].iloc[-1]
wins = between[between["count"] > 0]
# without the guards, same random numbers until the first injection
res_hz = engine.global_mcl(grid, field, motion, drive.scans, drive.drive.odometry, np.random.default_rng([41, 1, 2]),
                           engine.HAZARD)
pos_hz, head_hz = position_error(drive.truth, res_hz.mean), heading_error(drive.truth, res_hz.mean)
glue_values("lf_", demo_decided_s=decided_s, demo_locked_s=locked_s,
            demo_start_particles=int(res.sizes[0]), demo_mean_particles=float(res.sizes[1:].mean()),
            demo_step1_particles=int(res.sizes[1]), demo_floor_particles=int(engine.HAZARD.n_min),
            demo_ratio_floor_share=float(np.mean(res.eps_augmented[1:][on_robot] <= engine.HAZARD.eps_min)),
            demo_dip_s=float(t[dip]), demo_dip_m=float(pos[dip]), demo_dip_heading_deg=float(np.degrees(head[dip])),
            demo_injections=len(between), demo_on_robot=int((between["off_m"] < 1).sum()), demo_wins=len(wins),
            demo_on_cloud=int(((between["off_cloud_m"] < 1) & (between["off_m"] >= 1)).sum()),
            demo_hazard_locked_s=float(lock_on.locked_from(pos_hz, head_hz, study.DT, mg.HEADING_TOL) * study.DT))


# %% [markdown]
# :::{admonition} What the run shows
# :class: dropdown
# From {glue:text}`lf_demo_start_particles:d` particles the bound asks for
# {glue:text}`lf_demo_step1_particles:d` after the first scan, then its floor of
# {glue:text}`lf_demo_floor_particles:d` ({glue:text}`lf_demo_mean_particles:.0f` on average with
# the injected poses).
#
# At {glue:text}`lf_demo_dip_s:.0f` s the position error dips to
# {glue:text}`lf_demo_dip_m:.2f` m, yet the heading is {glue:text}`lf_demo_dip_heading_deg:.0f`° off:
# the cloud sits on the half-turn twin, whose path crosses the robot's there (the marker).
#
# The evidence passes $99 : 1$ at {glue:text}`lf_demo_decided_s:.0f` s; the filter is locked on from
# {glue:text}`lf_demo_locked_s:.0f` s to the end.
#
# The delay is the guards' cost. Of the {glue:text}`lf_demo_injections:d` injections in between, the
# stratum lay on the robot at {glue:text}`lf_demo_on_robot:d` and won at
# {glue:text}`lf_demo_wins:d`, the last three in a row. At
# {glue:text}`lf_demo_on_cloud:d` it lay on the twin, within $1$ m of the estimate: such a stratum
# does not out-weigh the cloud already there, and its loss resets the count.
#
# Without the guards, with the same random numbers until the first injection, the filter is locked
# on from {glue:text}`lf_demo_hazard_locked_s:.0f` s.
# :::
#
# ## Does it reach the bound?
#
# **Locked on** is the rule of {doc}`map_robot`: within $1$ m and
# {glue:text}`lf_heading_tolerance_deg:.1f`° of the truth at $80$ % of the steps of the last $20$ s.
#
# :::{admonition} Where the heading tolerance comes from
# :class: dropdown
# A straight odometry step of $0.25$ m turns the heading by the two rotation errors
# $\eta_1 + \eta_3$ of {doc}`map_robot`'s odometry model, whose standard deviation is
# $\sqrt{2 a_2}\, \delta_{\mathrm{trans}}$ ($a_2 = 0.05$) = {glue:text}`lf_step_heading_sd_deg:.1f`°, and the
# rule allows three times that. It is loose: tracking from the known start ({doc}`map_robot`) has a
# heading RMSE of {glue:text}`lf_tracking_heading_rmse_deg:.1f`° and its largest heading error over the
# last $20$ s is at most {glue:text}`lf_tracking_max_heading_deg:.1f`°. It does not change the counts:
# every global miss below is a half-turn off or ends on the robot after the window.
# :::
#
# Islands were screened on development drives $0$-$149$ and judged once on
# {glue:text}`lf_n_heldout:d` new drives ($250$-$349$).
#
# From a uniform start the cure with islands is locked on at the end of
# {glue:text}`lf_global_lock_on_rate:.0%`
# ({glue:text}`lf_global_lock_on_rate_low:.0%`-{glue:text}`lf_global_lock_on_rate_high:.0%`) of them:
# the estimate meets the $0.95$ aimed at, the interval reaches below it. The map decides
# {glue:text}`lf_heldout_decided_share:.0%` of these drives.
#
# The exact filter over the twins is locked on in {glue:text}`lf_heldout_exact_rate:.0%` of the
# same drives. The islands differ from it by {glue:text}`lf_islands_exact_diff_pts:+.0f` points
# ({glue:text}`lf_islands_exact_diff_low_pts:+.0f` to {glue:text}`lf_islands_exact_diff_high_pts:+.0f`):
# the data exclude differences beyond these two. A filter can beat it: the exact filter's mean
# over the robot's path and its twins is no ceiling for a filter that commits to one mode.
#
# The cure without islands is locked on in {glue:text}`lf_heldout_cure_rate:.0%` of the same
# drives: the islands add {glue:text}`lf_islands_gain_pts:+.0f` points
# ({glue:text}`lf_islands_gain_low_pts:+.0f` to {glue:text}`lf_islands_gain_high_pts:+.0f`), not
# separated.
#
# Drive by drive they win {glue:text}`lf_isl_lockon_wins:d` and lose
# {glue:text}`lf_isl_lockon_losses:d`, which the cure locks on.
#
# :::{admonition} How the islands lose a drive, and the development gain
# :class: dropdown
# They lose drives {glue:text}`lf_isl_lost_seed_a:d` and {glue:text}`lf_isl_lost_seed_b:d`. On
# drive {glue:text}`lf_isl_lost_seed_b:d` an island moved a cloud locked on the robot to its
# half-turn twin at {glue:text}`lf_isl_280_lost_s:.0f` s; another brought it back at
# {glue:text}`lf_isl_280_back_s:.1f` s, too late for the window. On the development drives the gain
# was larger ({glue:text}`lf_isl_dev_locked:d` against {glue:text}`lf_isl_dev_cure_locked:d` of
# $150$), but in-sample: on new drives most of it disappeared.
# :::
#
# Their cost is separated. A **loss** is a cloud within the tolerances for $10$ s carried $2$ m
# or more away for $2$ s or more. Losses happened on {glue:text}`lf_isl_lost_drives:d` of the
# hundred drives with islands and on none without ({glue:text}`lf_isl_lost_diff_pts:+.0f` points,
# {glue:text}`lf_isl_lost_diff_low_pts:+.0f` to {glue:text}`lf_isl_lost_diff_high_pts:+.0f`).
#
# That is {glue:text}`lf_isl_losses_per_hour:.1f` losses an hour against none. In short:
# {glue:text}`lf_islands_gain_pts:+.0f` lock-on points, not separated, for about
# {glue:text}`lf_isl_lost_drives:d` pose jumps per {glue:text}`lf_n_heldout:d` drives, separated.
# The islands also score $800$ poses a scan, all drive.
#
# They passed their screen on a split of the losses defined after a look at the development
# drives, using the true path and the future, which no robot sees. By the
# challenger's budget rule below (every loss, global and kidnap) they would have failed there:
# {glue:text}`lf_isl_dev_budget_lost:d` losses against the cure's {glue:text}`lf_isl_dev_budget_cure:d`.
#
# :::{admonition} The losses split by the twin margin
# :class: dropdown
# A loss counts as a **false relocalization** if, from its step to the end of the drive, the twin
# margin stays above $\log 99$ (a second sense of "decided": from then on, not over the last
# $20$ s), and as a **flip** to a twin the map cannot yet tell from the robot otherwise. With
# islands, false relocalizations on the held-out drives and kidnap runs together happened
# {glue:text}`lf_false_reloc_per_hour:.2f`
# ({glue:text}`lf_false_reloc_per_hour_low:.3f`-{glue:text}`lf_false_reloc_per_hour_high:.1f`) times
# an hour, flips {glue:text}`lf_isl_flips_per_hour:.1f`
# ({glue:text}`lf_isl_flips_per_hour_low:.1f`-{glue:text}`lf_isl_flips_per_hour_high:.1f`) times an
# hour from a uniform start; the cure had neither on the same drives.
# :::
#
# ::::{admonition} History: the cure without islands on drives 150-249
# :class: dropdown
# The cure was designed on drives and kidnap runs $0$-$149$ and is measured on
# {glue:text}`lf_cure150_n:d` held-out drives ($150$-$249$), registered before any was run. The
# first half, examined drive by drive before the second ran, unchanged, gave
# {glue:text}`lf_heldout_first_half_rate:.0%`, the second {glue:text}`lf_heldout_second_half_rate:.0%`;
# these drives are now spent.
#
# From a uniform start the cure is locked on at the end of {glue:text}`lf_cure150_lock_on_rate:.0%`
# ({glue:text}`lf_cure150_lock_on_rate_low:.0%`-{glue:text}`lf_cure150_lock_on_rate_high:.0%`) of them.
# The $0.95$ aimed at was not met; the interval straddles it.
#
# The map is no excuse: the exact filter over the twins is locked on in
# {glue:text}`lf_cure150_exact_rate:.0%`, and the cure is
# {glue:text}`lf_heldout_exact_gap_pts:.0f` points below it
# ({glue:text}`lf_heldout_exact_gap_low_pts:.0f` to {glue:text}`lf_heldout_exact_gap_high_pts:.0f`).
#
# Without its guards the cure is locked on in {glue:text}`lf_heldout_hazard_rate:.0%` of the same
# drives ({glue:text}`lf_heldout_gain_pts:+.0f` points, {glue:text}`lf_heldout_gain_low_pts:+.0f` to
# {glue:text}`lf_heldout_gain_high_pts:+.0f`): not separated.
#
# The guards trade both ways: they win {glue:text}`lf_guards_win:d` drives, each a false
# relocalization without them, and lose {glue:text}`lf_misses_guards_lost:d`, which the unguarded cure
# and the exact filter lock on by {glue:text}`lf_miss_hazard_locked_by_s:.0f` s.
#
# :::{admonition} Why the guards lose a drive
# :class: dropdown
# A stratum at the truth is dropped when the scans that favour it leave the window before its third
# win: on drive $150$ the truth's advantage over its half-turn twin in the window falls from
# {glue:text}`lf_d150_window_before:.1f` to {glue:text}`lf_d150_window_after:.1f` nats within $4$ s,
# while over the whole drive it stays {glue:text}`lf_d150_cumulative:.1f`. The map decides how long
# such scans stay in view (the evidence block gives the times).
# :::
#
# :::{admonition} Going further: uniform injection at the cure's cost
# :class: dropdown
# With $5000$ particles, about as many poses a scan as the cure scores, uniform injection is locked
# on in {glue:text}`lf_inj5000_rate:.0%` of the same drives: the cure gains
# {glue:text}`lf_inj5000_gain_pts:.0f` points ({glue:text}`lf_inj5000_gain_low_pts:.0f` to
# {glue:text}`lf_inj5000_gain_high_pts:.0f`).
# :::
#
# **False relocalization** (a cloud within the tolerances for $10$ s carried $2$ m or more away for
# $2$ s or more), on the held-out drives and kidnap runs together, happened
# {glue:text}`lf_cure150_false_reloc_per_hour:.1f`
# ({glue:text}`lf_cure150_false_reloc_per_hour_low:.2f`-{glue:text}`lf_cure150_false_reloc_per_hour_high:.1f`) times
# an hour of driving with the cure: {glue:text}`lf_cure_false_relocs:d` events, both on kidnap runs.
#
# The cure's {glue:text}`lf_cure_false_relocs:d` false relocalizations (kidnap runs) are the map's
# ambiguity: over the $10$-s window before each, the scans favour the half-turn twin by
# {glue:text}`lf_reloc_window_a:.1f` and {glue:text}`lf_reloc_window_b:.1f` nats: the kidnap model's
# own posterior admits the twin. $\xi$, $L$ and the admission threshold control them, against a budget of
# false relocalizations.
#
# :::{admonition} How the count admitted a twin
# :class: dropdown
# On kidnap run {glue:text}`lf_reloc_seed:d` the count of three was made by a stratum on the robot
# at {glue:text}`lf_reloc_robot_win_s:.0f` s and {glue:text}`lf_reloc_twin_wins:d` on its twin; the
# twin was admitted at {glue:text}`lf_reloc_admit_s:.0f` s (the evidence block tells both).
# :::
#
# :::{admonition} What the guards cost, and what they save
# :class: dropdown
# Without its guards, false relocalizations happen {glue:text}`lf_hazard_false_reloc_per_hour:.1f`
# ({glue:text}`lf_hazard_false_reloc_per_hour_low:.1f`-{glue:text}`lf_hazard_false_reloc_per_hour_high:.1f`)
# times an hour.
#
# The price is time. On the kidnap runs both variants recover, the cure is locked on for good later
# in {glue:text}`lf_kidnap_later_share:.0%` of them, by a median of
# {glue:text}`lf_kidnap_delay_s:.0f` s ({glue:text}`lf_kidnap_delay_s_low:.0f`-{glue:text}`lf_kidnap_delay_s_high:.1f` s), about the two extra injections
# hysteresis waits.
# :::
#
# :::{admonition} Going further: a challenger kept, and a sequential test (screened, not adopted)
# :class: dropdown
# The guards forget: a stratum that loses once is dropped with its evidence. A *challenger* keeps it:
# a winning stratum stays beside the cloud as a small filter of $200$ poses, and its posterior
# log-odds against the cloud, $\Lambda = \log \frac{\xi_k}{1 - \xi_k} + \log \hat B$ at its birth,
# gain $\log \ell^{c}_j - \log \ell_j$ at every later scan. At $\Lambda \ge a$ it becomes the cloud,
# and the old cloud becomes the challenger with $-\Lambda$; at $\Lambda \le -20$ a challenger is
# dropped (so a swap can be undone only for $a < 20$). This is Wald's sequential test
# {cite:p}`wald1945`, as multi-hypothesis localization keeps competing hypotheses {cite:p}`jensfelt2001`
# (`global_mcl.CHALLENGER`).
#
# It was screened on the development drives $0$-$149$ against a budget: no more false relocalizations
# than the cure's {glue:text}`lf_chal_cure_lost:d` there. Thresholds $a$ of $4.6$, $8$ and $12$ nats
# all exceeded it, then $16$ to $30$ too (the fewest: {glue:text}`lf_chal_fewest_lost:d`), so it was
# not run on new drives. At $a = 20$ it locked on in {glue:text}`lf_chal_lock_on_20:.1%` of the global
# drives (the cure {glue:text}`lf_chal_cure_lock_on:.1%`) and recovered
# {glue:text}`lf_chal_recovered_20:.1%` of the kidnappings (the cure {glue:text}`lf_chal_cure_recovered:.1%`);
# its excess of false relocalizations there is small and not separated from the cure's (evidence
# block). {glue:text}`lf_chal_small_kidnap_losses:d` of its {glue:text}`lf_chal_fewest_lost:d` follow
# kidnappings of less than $1$ m: the cloud follows the robot by itself but keeps its record of the
# kidnap's scans, and the first stratum whose window starts at the kidnapping beats that record at
# every threshold up to $30$ nats, a flaw of the comparison, not of the threshold.
#
# The false swaps at low thresholds are not the noise of an honest test. If the scans came from the
# filter's own model and the cloud were the posterior, a stratum's likelihood ratio against the cloud
# would be a nonnegative martingale with mean at most $1$, and by Ville's inequality it would ever reach
# $a$ with probability at most $\frac{\xi_k}{1 - \xi_k} e^{-a}$: at $a = 4.6$, over the $45$ strata of
# a drive, at most {glue:text}`lf_chal_ville_low:.2f` false swaps in $150$ drives. The challenger lost
# {glue:text}`lf_chal_lost_low:d` of them. Part of the gap is the cloud, whose $300$ particles
# explain the scans less well than the robot's true path does; part is the sensor model: on the
# two held-out kidnap runs the cure lost, the exact path likelihoods favour the half-turn twin over one
# $10$-s window by {glue:text}`lf_reloc_window_a:.1f` and {glue:text}`lf_reloc_window_b:.1f` nats,
# which honest nats would allow for a given window and twin with probability at most $e^{-c}$ for
# $c$ nats. The likelihood field scores beams as if independent; a threshold in nats needs nats that
# are honest.
# :::
# ::::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# islands (global_mcl.ISLANDS): the development screen on drives 0-149, then new held-out drives 250-349
def by_seed(name):
    return STUDIES[f"map_global/{name}"].load().sort_values("seed").reset_index(drop=True)


def misses(table):
    """The drives a filter does not lock on, with how each ends."""
    return table.loc[~table["locked_on"].to_numpy(),
                     [c for c in ("seed", "final_position_error", "final_heading_error", "n_lost", "lost_s")
                      if c in table]]


dev = STUDIES["map_global/global_dev_islands"].load()
assert mgi.choose_margin(dev) == mgi.CHOSEN_ARM == "islands_99"
dev_rows = [{"arm": arm, "locked on": int(g["locked_on"].sum()), "drives": len(g),
             "false relocalizations after decided": int(g["n_lost_decided"].sum()),
             "flips before decided": int(g["n_lost"].sum() - g["n_lost_decided"].sum())}
            for arm, g in dev.groupby("arm", sort=False)]
h3 = STUDIES["map_global/global_heldout3"].load()
isl3 = h3[h3["arm"] == mgi.CHOSEN_ARM].sort_values("seed").reset_index(drop=True)
cure3 = h3[h3["arm"] == "cure"].sort_values("seed").reset_index(drop=True)
exact3 = by_seed("exact_heldout3")
kid3, kid_exact3 = by_seed("kidnap_heldout3"), by_seed("exact_kidnap_heldout3")
for table in (cure3, exact3, kid3, kid_exact3):
    assert (table["seed"].to_numpy() == isl3["seed"].to_numpy()).all()
assert isl3["seed"].min() == mgi.HELDOUT_SEED and len(isl3) == mgi.HELDOUT_RUNS
isl_rate = evidence.rate(isl3["locked_on"].to_numpy())
isl_vs_cure = evidence.paired_rates(isl3["locked_on"].to_numpy(), cure3["locked_on"].to_numpy())
isl_vs_exact = evidence.paired_rates(isl3["locked_on"].to_numpy(), exact3["exact_locked_on"].to_numpy())
isl_miss = ~isl3["locked_on"].to_numpy()
shared = isl_miss & ~exact3["exact_locked_on"].to_numpy()
# every miss of the islands ends a half-turn off or within 1 m of the truth (found after the window)
assert ((isl3.loc[isl_miss, "final_heading_error"] > np.pi / 2) | (isl3.loc[isl_miss, "final_position_error"] < 1)).all()
# false relocalizations after the evidence decided (global drives; the kidnap runs are the cure's, tracked from a
# known start: every loss there counts), and flips before it (global drives only)
hours3_global = len(isl3) * study.GLOBAL_STEPS * study.DT / 3600
hours3 = hours3_global + len(kid3) * study.KIDNAP_STEPS * study.DT / 3600


def garwood(events, h):
    """Events an hour over h hours and the exact (Garwood) 95 % Poisson interval."""
    low = chi2.ppf(0.025, 2 * events) / 2 if events else 0.0
    return events / h, low / h, chi2.ppf(0.975, 2 * events + 2) / 2 / h


isl_false = int(isl3["n_lost_decided"].sum() + kid3["n_lost"].sum())
isl_flips = int(isl3["n_lost"].sum() - isl3["n_lost_decided"].sum())
cure3_false = int(cure3["n_lost_decided"].sum() + kid3["n_lost"].sum())
false3, flips3 = garwood(isl_false, hours3), garwood(isl_flips, hours3_global)
# the primary count: every loss on the global drives, paired by drive with the cure (same drives, filter seeds)
isl_lost, cure_lost3 = isl3["n_lost"].to_numpy() > 0, cure3["n_lost"].to_numpy() > 0
lost_vs_cure = evidence.paired_rates(isl_lost, cure_lost3)
all3 = garwood(int(isl3["n_lost"].sum()), hours3_global)
# the development drives under the challenger's budget rule (every loss, global plus kidnap; the kidnap runs are the
# cure's there too)
kid_dev_lost = int(STUDIES["map_global/kidnap_dev_cure"].load()["n_lost"].sum())
dev_by = {arm: g for arm, g in dev.groupby("arm")}
dev_isl_lost = int(dev_by[mgi.CHOSEN_ARM]["n_lost"].sum()) + kid_dev_lost
dev_cure_lost = int(dev_by["cure"]["n_lost"].sum()) + kid_dev_lost
# paired on lock-on: the drives the islands win and lose against the cure
isl_on, cure_on = isl3["locked_on"].to_numpy(), cure3["locked_on"].to_numpy()
lost_seeds = isl3.loc[cure_on & ~isl_on, "seed"].tolist()
assert lost_seeds == [256, 280] and list(isl3.loc[isl3["seed"] == 280, "n_lost"]) == [1]
# drive 280 again with the islands: the steps at which an island was adopted
d280 = study.simulate(280, study.GLOBAL_STEPS)
r280 = engine.global_mcl(grid, field, motion, d280.scans, d280.drive.odometry, mg.filter_rng(280), engine.ISLANDS)
adopt280 = np.flatnonzero(r280.injected_mass == 1.0) * study.DT
glue_values("lf_", isl_lost_drives=int(isl_lost.sum()), cure3_lost_drives=int(cure_lost3.sum()),
            isl_lost_diff_pts=100 * lost_vs_cure.difference, isl_lost_diff_low_pts=100 * lost_vs_cure.difference_low,
            isl_lost_diff_high_pts=100 * lost_vs_cure.difference_high, isl_lost_p=lost_vs_cure.pvalue,
            isl_losses_per_hour=all3[0], isl_losses_per_hour_low=all3[1], isl_losses_per_hour_high=all3[2],
            isl_dev_budget_lost=dev_isl_lost, isl_dev_budget_cure=dev_cure_lost,
            isl_dev_locked=int(dev_by[mgi.CHOSEN_ARM]["locked_on"].sum()),
            isl_dev_cure_locked=int(dev_by["cure"]["locked_on"].sum()),
            isl_lockon_wins=int((isl_on & ~cure_on).sum()), isl_lockon_losses=len(lost_seeds),
            isl_lost_seed_a=lost_seeds[0], isl_lost_seed_b=lost_seeds[1],
            isl_280_lost_s=float(isl3.loc[isl3["seed"] == 280, "lost_s"].iloc[0]),
            isl_280_back_s=float(adopt280[-1]), heldout_decided_share=float(exact3["decided"].mean()))
# the cost is separated, and the cure has no loss on these drives (the prose says "none")
assert lost_vs_cure.difference_low > 0 and lost_vs_cure.pvalue < 0.05 and cure_lost3.sum() == 0
assert len(adopt280) >= 2 and adopt280[-1] > 80
assert adopt280[0] == isl3.loc[isl3['seed'] == 280, 'lost_s'].iloc[0]  # the first adoption is the loss
glue_values("lf_", n_heldout=len(isl3), global_lock_on_rate=isl_rate.estimate, global_lock_on_rate_low=isl_rate.low,
            global_lock_on_rate_high=isl_rate.high, heldout_exact_rate=isl_vs_exact.b.estimate,
            islands_exact_diff_pts=100 * isl_vs_exact.difference,
            islands_exact_diff_low_pts=100 * isl_vs_exact.difference_low,
            islands_exact_diff_high_pts=100 * isl_vs_exact.difference_high,
            islands_n_misses=int(isl_miss.sum()),
            heldout_cure_rate=isl_vs_cure.b.estimate, islands_gain_pts=100 * isl_vs_cure.difference,
            islands_gain_low_pts=100 * isl_vs_cure.difference_low,
            islands_gain_high_pts=100 * isl_vs_cure.difference_high,
            false_reloc_per_hour=false3[0], false_reloc_per_hour_low=false3[1], false_reloc_per_hour_high=false3[2],
            isl_false_relocs=isl_false, isl_flips_per_hour=flips3[0], isl_flips_per_hour_low=flips3[1],
            isl_flips_per_hour_high=flips3[2])
# what the prose says: 0.95 met by the estimate, not by the interval; the islands not separated from the exact
# filter nor from the cure on these drives
assert isl_rate.estimate >= 0.95 and isl_rate.low < 0.95
assert isl_vs_exact.difference_low < 0 < isl_vs_exact.difference_high
assert isl_vs_cure.difference_low < 0 < isl_vs_cure.difference_high
assert shared.sum() == isl_miss.sum()  # every drive the islands miss, the exact filter misses too
assert dev_isl_lost > dev_cure_lost  # under the challenger's budget rule the islands fail the screen
EvidenceBlock(
    "islands: the development screen, and the held-out drives against the cure and the bound",
    notes=["Protocol (pfcourse.studies.map_global_islands, written before any stored run). Before it, the cure's 12 "
           "misses on development drives 0-149 were looked at, and an unstored run of the 150 development drives "
           "was made at margins of 0 and 4.6 nats. Step 1, stored: on development drives 0-149, the arms below with "
           "the same filter seeds; the margin kept is the one with the most lock-ons among those whose false "
           "relocalizations after the evidence decided are no more than the cure's; it passes if it locks on more "
           f"often than the cure. Kept: {mgi.CHOSEN_ARM} (margin log 99 nats; re-derived from the stored table).",
           "A loss (2 s or more at 2 m or more from the truth after 10 s within the tolerances) counts as a false "
           "relocalization from the step on which the twin margin stays above log 99 to the end of the drive; "
           "before it, as a flip (the map does not yet tell the robot from its twins). This split was defined after "
           "the unstored look at the development drives, and it uses the true path and the future (the margin "
           "must stay above log 99 to the end): no robot can apply it. The primary count is every loss.",
           f"Every loss, held-out global drives ({hours3_global:.2f} hours): islands {int(isl3['n_lost'].sum())} "
           f"({all3[0]:.1f} an hour, Garwood 95 % interval {all3[1]:.1f}-{all3[2]:.1f}), the cure "
           f"{int(cure3['n_lost'].sum())}. Drives with a loss, paired by drive (islands A, the cure B): {lost_vs_cure}. "
           f"On development drives 0-149 under the challenger's budget rule (every loss, global plus kidnap): "
           f"islands {dev_isl_lost}, the cure {dev_cure_lost}; by that rule the islands would have failed the screen. "
           f"The development gain in lock-on ({int(dev_by[mgi.CHOSEN_ARM]['locked_on'].sum())} against "
           f"{int(dev_by['cure']['locked_on'].sum())} of 150) was in-sample.",
           f"Paired on lock-on, the islands win {int((isl_on & ~cure_on).sum())} held-out drives and lose "
           f"{len(lost_seeds)} (seeds {', '.join(map(str, lost_seeds))}), which the cure locks on. A re-run of drive "
           f"280 with the islands adopts an island at " + ", ".join(f"{v:.1f}" for v in adopt280) + " s: the first "
           "moves a cloud locked on the robot to its half-turn twin, the last brings it back, too late for the window.",
           f"Step 2: judged once on new drives {isl3['seed'].min()}-{isl3['seed'].max()}, registered before any run "
           f"there; filter seeds numpy.random.default_rng([41, seed, 2]) for both arms. Islands: {isl_rate} (Wilson "
           f"interval). Paired by drive (islands A, the cure B): {isl_vs_cure}. Paired by drive (islands A, the exact "
           f"filter over the truth and its 13 twins B): {isl_vs_exact}.",
           "The islands' misses (seeds " + ", ".join(str(v) for v in isl3.loc[isl_miss, "seed"]) + ") end within "
           "1 m of the truth but lock on too late for 80 % of the last 20 s; the exact filter misses seeds "
           + ", ".join(str(v) for v in exact3.loc[~exact3["exact_locked_on"].to_numpy(), "seed"]) + ".",
           f"False relocalizations after the evidence decided, held-out global drives and kidnap runs ({hours3:.2f} "
           f"hours): islands {isl_false} ({false3[0]:.2f} an hour, Garwood 95 % interval {false3[1]:.3f}-"
           f"{false3[2]:.2f}); the cure {cure3_false}. Flips before the evidence decided, global drives "
           f"({hours3_global:.2f} hours): islands {isl_flips} ({flips3[0]:.1f} an hour, {flips3[1]:.1f}-"
           f"{flips3[2]:.1f}); the cure {int(cure3['n_lost'].sum() - cure3['n_lost_decided'].sum())}.",
           f"Cost: four islands of {engine.ISLANDS.island_size} poses each, 800 poses scored a scan beside the cloud's; "
           "the scan proposal four times at the start.",
           stored("global_dev_islands"), stored("global_heldout3"), stored("exact_heldout3")],
    tables=[("Development drives 0-149 (150 drives)", pd.DataFrame(dev_rows), {}),
            ("The held-out drives the islands do not lock on", misses(isl3), {"final_position_error": ".2f",
                                                                          "final_heading_error": ".2f",
                                                                          "lost_s": ".1f"})],
)

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# the challenger's screen on development drives 0-149 (pfcourse.studies.map_global_challenger)
from pfcourse.studies import map_global_challenger as mgc


def dev_table(name):
    return STUDIES[f"map_global/{name}"].load().sort_values("seed").reset_index(drop=True)


chal_g = pd.concat([dev_table(n) for n in ("global_dev_challenger", "global_dev_challenger_high")])
chal_k = pd.concat([dev_table(n) for n in ("kidnap_dev_challenger", "kidnap_dev_challenger_high")])
cure_g, cure_k = dev_table("global_dev_cure"), dev_table("kidnap_dev_cure")
moved_k = cure_k["jump_m"].to_numpy() >= lock_on.POSITION_TOLERANCE_M
chal_rows = []
for a_nats, g_a in chal_g.groupby("swap_nats"):
    k_a = chal_k[chal_k["swap_nats"] == a_nats].sort_values("seed")
    g_a = g_a.sort_values("seed")
    chal_rows.append({"swap threshold a (nats)": a_nats, "global locked on": int(g_a["locked_on"].sum()),
                      "global lost": int(g_a["n_lost"].sum()),
                      "kidnappings recovered": int(k_a["recovered"].to_numpy()[moved_k].sum()),
                      "kidnap lost": int(k_a["n_lost"].sum()),
                      "false relocalizations": int(g_a["n_lost"].sum() + k_a["n_lost"].sum()),
                      "Ville bound, global (150 drives)": 150 * mgc.ville_bound(a_nats, every * xi, mgc.STRATA_GLOBAL),
                      "_g": g_a, "_k": k_a})
chal_table = pd.DataFrame(chal_rows)
cure_lost = int(cure_g["n_lost"].sum() + cure_k["n_lost"].sum())
assert not mgc.SCREEN_PASSED and (chal_table["false relocalizations"] > cure_lost).all()
at20 = chal_table[chal_table["swap threshold a (nats)"] == 20.0].iloc[0]
low = chal_table.iloc[0]
# paired with the cure on the same drives and filter seeds, at a = 20
g20 = evidence.paired_rates(at20["_g"]["locked_on"].to_numpy(), cure_g["locked_on"].to_numpy())
k20 = evidence.paired_rates(at20["_k"]["recovered"].to_numpy()[moved_k], cure_k["recovered"].to_numpy()[moved_k])
# at a = 20: the kidnap losses that follow kidnappings under 1 m, and the losses paired by run with the cure's
k20_lost = at20["_k"][at20["_k"]["n_lost"] > 0]
small = int((k20_lost["jump_m"] < lock_on.POSITION_TOLERANCE_M).sum())
lost20 = np.concatenate([at20["_g"]["n_lost"].to_numpy() > 0, at20["_k"]["n_lost"].to_numpy() > 0])
lost_cure = np.concatenate([cure_g["n_lost"].to_numpy() > 0, cure_k["n_lost"].to_numpy() > 0])
lost_pair = evidence.paired_rates(lost20, lost_cure)
assert lost_pair.difference_low < 0 < lost_pair.difference_high  # not separated
assert (chal_table.loc[chal_table["swap threshold a (nats)"] >= 20, "false relocalizations"]
        == at20["false relocalizations"]).all()
glue_values("lf_", chal_cure_lost=cure_lost, chal_fewest_lost=int(chal_table["false relocalizations"].min()),
            chal_lock_on_20=g20.a.estimate, chal_cure_lock_on=g20.b.estimate,
            chal_recovered_20=k20.a.estimate, chal_cure_recovered=k20.b.estimate,
            chal_ville_low=float(low["Ville bound, global (150 drives)"]), chal_lost_low=int(low["global lost"]),
            chal_small_kidnap_losses=small)
EvidenceBlock(
    "the challenger screened on development drives 0-149, against the cure there",
    notes=["Global drives and kidnap runs 0-149 (the drives the cure was designed on), the same drives and filter "
           "seeds as the cure recomputed there (map_global/global_dev_cure, kidnap_dev_cure). The challenger: the cure "
           "before its guards (xi = 0.001 a scan) with a winning stratum kept and tested sequentially, dropped at "
           "-20 nats; thresholds 4.6, 8, 12 first, then 16-30 when all three failed the budget.",
           f"The budget: no more false relocalizations (global and kidnap together) than the cure's {cure_lost}. "
           "Every threshold exceeded it; the pre-set rule (map_global_challenger.choose_swap_nats) chose none, so "
           "the challenger was not run on new drives.",
           f"At a = 20, paired by drive (challenger A, cure B): global lock-on {g20}; kidnappings recovered "
           f"(the {int(moved_k.sum())} runs the kidnapping moved) {k20}.",
           f"At a = 20, runs with a false relocalization, paired by run over the 300 global drives and kidnap runs "
           f"(challenger A, cure B): {lost_pair}. The budget is the cure's count on the drives its design was chosen "
           f"on. Of the challenger's kidnap losses at a = 20, {small} follow kidnappings of less than 1 m (runs "
           f"{', '.join(str(v) for v in k20_lost.loc[k20_lost['jump_m'] < 1, 'seed'])}), each lost 10 s after the "
           "kidnapping, when the first window that starts at the kidnapping is scored.",
           "Ville's bound assumes scans drawn from the filter's own likelihood field and a cloud that is the "
           "posterior; the drives' scans are ray-cast with noise, and the cloud is 300 particles."],
    tables=[("Per threshold (150 global drives, 150 kidnap runs; 'lost': false relocalizations, a run may have two)",
             chal_table.drop(columns=["_g", "_k"]),
             {"swap threshold a (nats)": ".1f", "Ville bound, global (150 drives)": ".1e"})])

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def exact_difference(p):
    """A - B of paired rates and its interval (the one of `evidence.paired_rates`, consistent with McNemar)."""
    return p.difference, p.difference_low, p.difference_high


held, held_hz, held_exact = by_seed("global_heldout"), by_seed("global_heldout_hazard"), by_seed("exact_heldout")
kid_held, kid_held_hz = by_seed("kidnap_heldout"), by_seed("kidnap_heldout_hazard")
for table in (held_hz, held_exact, kid_held, kid_held_hz):
    assert (table["seed"].to_numpy() == held["seed"].to_numpy()).all()
cure_rate = evidence.rate(held["locked_on"].to_numpy())
vs_hz = evidence.paired_rates(held["locked_on"].to_numpy(), held_hz["locked_on"].to_numpy())
hz_d = exact_difference(vs_hz)
vs_exact = evidence.paired_rates(held["locked_on"].to_numpy(), held_exact["exact_locked_on"].to_numpy())
hours = (len(held) * study.GLOBAL_STEPS + len(kid_held) * study.KIDNAP_STEPS) * study.DT / 3600


def lost(glob_table, kid_table):
    """Runs with a false relocalization, and their number per hour of driving."""
    runs = int((glob_table["n_lost"] > 0).sum() + (kid_table["n_lost"] > 0).sum())
    return runs, float(glob_table["n_lost"].sum() + kid_table["n_lost"].sum()) / hours


cure_lost, cure_per_hour = lost(held, kid_held)
hz_lost, hz_per_hour = lost(held_hz, kid_held_hz)
lost_pair = evidence.paired_rates(np.r_[held["n_lost"] > 0, kid_held["n_lost"] > 0],
                                  np.r_[held_hz["n_lost"] > 0, kid_held_hz["n_lost"] > 0])
# poses scored against the field per scan: the cloud, and per injection (every inject_every scans) the
# proposal's candidates and nudges and the look-back filter's R poses over history + 1 scans
cs = engine.CURE
per_injection = (cs.candidates * cs.headings + cs.keep * cs.refine_trials * cs.refine_rounds
                 + cs.inject_min * (cs.history + 1))
glue_values("lf_", cure150_n=len(held), cure150_lock_on_rate=cure_rate.estimate, cure150_lock_on_rate_low=cure_rate.low,
            cure150_lock_on_rate_high=cure_rate.high, heldout_hazard_rate=vs_hz.b.estimate,
            heldout_gain_pts=100 * hz_d[0], heldout_gain_low_pts=100 * hz_d[1], heldout_gain_high_pts=100 * hz_d[2],
            cure150_exact_rate=vs_exact.b.estimate, global_exact_p=vs_exact.pvalue,
            poses_per_scan=held["mean_particles"].mean() + per_injection / cs.inject_every,
            cure150_false_reloc_per_hour=cure_per_hour, heldout_lost_runs=cure_lost, heldout_runs=len(held) + len(kid_held),
            hazard_false_reloc_per_hour=hz_per_hour, hazard_lost_runs=hz_lost, false_reloc_p=lost_pair.pvalue,
            step_heading_sd_deg=np.degrees(lock_on.step_heading_sd(motion, mg.STEP_M)),
            heading_tolerance_deg=np.degrees(mg.HEADING_TOL))
# the cure's misses that the cure without its guards and the exact filter both lock on: the guards' doing
miss = ~held["locked_on"].to_numpy()
guards_lost = miss & held_hz["locked_on"].to_numpy() & held_exact["exact_locked_on"].to_numpy()
locked_by = max(held_hz.loc[guards_lost, "locked_from_s"].max(), held_exact.loc[guards_lost, "exact_locked_from_s"].max())
# the guards' trade both ways: the drives they win (the unguarded cure misses them, each after a false relocalization)
# and those they lose (the cure's misses that the unguarded cure and the exact filter lock on)
guards_win = held["locked_on"].to_numpy() & ~held_hz["locked_on"].to_numpy()
assert (held_hz.loc[guards_win, "n_lost"] > 0).all()
assert (guards_lost == (miss & held_hz["locked_on"].to_numpy())).all()
# the protocol: drives 150-249 registered before any was run; the first half reported and examined first
first_half = (held["seed"] < mg.HELDOUT_SEED + mg.HELDOUT_RUNS // 2).to_numpy()
kid_first = (kid_held["seed"] < mg.HELDOUT_SEED + mg.HELDOUT_RUNS // 2).to_numpy()
# every miss ends a half-turn off, or within 1 m of the truth (found after the window): the heading tolerance
# does not decide them
assert ((held.loc[miss, "final_heading_error"] > np.pi / 2) | (held.loc[miss, "final_position_error"] < 1)).all()
# map_robot's tracking runs (product weighting): the heading errors of a filter that follows the robot
trk = STUDIES["maprobot/tracking"].load()
trk = trk[trk["weighting"] == "product"]
# uniform injection with 5000 particles on the same held-out drives (about the cure's poses a scan), paired
inj5000 = by_seed("injection_heldout")
assert (inj5000["seed"].to_numpy() == held["seed"].to_numpy()).all()
vs_inj5000 = evidence.paired_rates(held["locked_on"].to_numpy(), inj5000["locked_on"].to_numpy())


def per_hour(events):
    """Events an hour of driving and the exact (Garwood) 95 % Poisson interval."""
    low = chi2.ppf(0.025, 2 * events) / 2 if events else 0.0
    return events / hours, low / hours, chi2.ppf(0.975, 2 * events + 2) / 2 / hours


cure_events = int(held["n_lost"].sum() + kid_held["n_lost"].sum())
hz_events = int(held_hz["n_lost"].sum() + kid_held_hz["n_lost"].sum())
cure_hour, hz_hour = per_hour(cure_events), per_hour(hz_events)
# the cure's two false relocalizations, both on kidnap runs: one the kidnapping hardly moved (left out of the
# recovery rate), lost after the kidnapping; the other lost before it, while tracking from the known start
lost_runs = kid_held[kid_held["n_lost"] > 0]
assert cure_events == 2 and len(lost_runs) == 2 and held["n_lost"].sum() == 0
unmoved = (lost_runs["jump_m"] < lock_on.POSITION_TOLERANCE_M) & (lost_runs["jump_deg"] < np.degrees(mg.HEADING_TOL))
lost_run, tracking_lost = lost_runs[unmoved], lost_runs[~unmoved]
assert len(lost_run) == 1 and (lost_run["lost_s"] > study.KIDNAP_STEP * study.DT).all()
assert len(tracking_lost) == 1 and (tracking_lost["lost_s"] < study.KIDNAP_STEP * study.DT).all()


def advantage(run):
    """Per scan, the log-likelihood of the true path minus that of its half-turn twin."""
    twin_half = twin_poses(run.truth, True, 0.0)
    return (path_log_likelihoods(grid, field, run.truth, run.scans)
            - path_log_likelihoods(grid, field, twin_half, run.scans))


def window_sum(d, k):
    """The truth's advantage over the look-back window of an injection at step k (scans k - L ... k)."""
    return float(d[k - cs.history:k + 1].sum())


# the window before each false relocalization (the injections up to the step it was lost): it favours the twin by
# more than the prior log-odds, so the kidnap model itself admits the twin's stratum
reloc_windows = {}
for seed, lost_at in zip(lost_runs["seed"], lost_runs["lost_s"]):
    d_k = advantage(study.simulate(int(seed), study.KIDNAP_STEPS, kidnap_at=study.KIDNAP_STEP))
    k_lost = int(round(lost_at / study.DT))
    reloc_windows[int(seed)] = [(k * study.DT, window_sum(d_k, k))
                                for k in range(k_lost - 8, k_lost + 1, cs.inject_every)]
    assert window_sum(d_k, k_lost) < np.log(every * xi / (1 - every * xi)) < 0
# drive 150, lost by the guards: the truth's stratum won at 44 and 46 s (a logged re-run), then the window's
# advantage fell while the whole drive's stayed: at 46, 48, 50 s
d150 = advantage(study.simulate(150, study.GLOBAL_STEPS))
k150 = [int(round(t_s / study.DT)) for t_s in (46, 48, 50)]
w150 = [window_sum(d150, k) for k in k150]
assert w150[0] > -np.log(every * xi / (1 - every * xi)) > w150[-1]
assert d150[:k150[-1] + 1].sum() > -np.log(every * xi / (1 - every * xi))
# the unmoved run, re-run and watched: which strata made the count that admitted a twin
reloc_seed = int(lost_run["seed"].iloc[0])
reloc_drive = study.simulate(reloc_seed, study.KIDNAP_STEPS, kidnap_at=study.KIDNAP_STEP)
reloc_res, reloc_log = trace(reloc_drive, np.random.default_rng([41, reloc_seed, 2]), engine.CURE,
                             start=reloc_drive.truth[0])
reloc_admit = reloc_log[reloc_log["admitted"]].iloc[0]
streak_rows = reloc_log.loc[reloc_admit.name - int(reloc_admit["count"]) + 1:reloc_admit.name]
assert reloc_admit["off_m"] > 2 and abs(reloc_admit["t"] - float(lost_run["lost_s"].iloc[0])) <= 2.0
assert (streak_rows["count"].to_numpy() == np.arange(1, len(streak_rows) + 1)).all()
reloc_on_robot = streak_rows[streak_rows["off_m"] < 1]
assert len(reloc_on_robot) == 1 and len(streak_rows) == engine.CONFIRM
# the price of the guards in time: paired times from which each variant stays locked on, where both do
both_glob = (held["locked_on"] & held_hz["locked_on"]).to_numpy()
later_glob = evidence.paired(held.loc[both_glob, "locked_from_s"], held_hz.loc[both_glob, "locked_from_s"])
sign_glob = evidence.sign_test(held_hz.loc[both_glob, "locked_from_s"], held.loc[both_glob, "locked_from_s"])
kid_moved_here = ((kid_held["jump_m"] >= lock_on.POSITION_TOLERANCE_M)
                  | (kid_held["jump_deg"] >= np.degrees(mg.HEADING_TOL))).to_numpy()
both_kid = kid_moved_here & (kid_held["recovered"] & kid_held_hz["recovered"]).to_numpy()
later_kid = evidence.paired(kid_held.loc[both_kid, "recovery_s"], kid_held_hz.loc[both_kid, "recovery_s"])
# (runs where the cure is later, runs where it is earlier, exact two-sided p); ties dropped
sign_kid = evidence.sign_test(kid_held_hz.loc[both_kid, "recovery_s"], kid_held.loc[both_kid, "recovery_s"])
assert later_kid.low > 0 and sign_kid[0] > sign_kid[1]
glue_values("lf_", kidnap_later_share=sign_kid[0] / int(both_kid.sum()), kidnap_delay_s=later_kid.median,
            kidnap_delay_s_low=later_kid.low, kidnap_delay_s_high=later_kid.high)
glue_values("lf_", reloc_seed=reloc_seed, reloc_robot_win_s=float(reloc_on_robot["t"].iloc[0]),
            reloc_twin_wins=int((streak_rows["off_m"] > 2).sum()),
            reloc_admit_s=float(reloc_admit["t"]))
glue_values("lf_", n_misses=int(miss.sum()), misses_guards_lost=int(guards_lost.sum()),
            miss_hazard_locked_by_s=float(locked_by),
            tracking_heading_rmse_deg=float(np.degrees(np.sqrt(np.mean(trk["heading_rmse"] ** 2)))),
            tracking_max_heading_deg=float(np.degrees(trk["max_window_heading_error"].max())),
            inj5000_rate=vs_inj5000.b.estimate, inj5000_gain_pts=100 * vs_inj5000.difference,
            inj5000_gain_low_pts=100 * vs_inj5000.difference_low, inj5000_gain_high_pts=100 * vs_inj5000.difference_high,
            cure150_false_reloc_per_hour_low=cure_hour[1], cure150_false_reloc_per_hour_high=cure_hour[2],
            hazard_false_reloc_per_hour_low=hz_hour[1], hazard_false_reloc_per_hour_high=hz_hour[2],
            cure_false_relocs=cure_events, guards_win=int(guards_win.sum()),
            heldout_first_half_rate=held["locked_on"].to_numpy()[first_half].mean(),
            heldout_second_half_rate=held["locked_on"].to_numpy()[~first_half].mean(),
            reloc_window_a=-reloc_windows[int(lost_runs["seed"].iloc[0])][-1][1],
            reloc_window_b=-reloc_windows[int(lost_runs["seed"].iloc[1])][-1][1],
            d150_window_before=w150[0], d150_window_after=w150[-1], d150_cumulative=float(d150[:k150[-1] + 1].sum()),
            heldout_exact_gap_pts=-100 * vs_exact.difference, heldout_exact_gap_low_pts=-100 * vs_exact.difference_high,
            heldout_exact_gap_high_pts=-100 * vs_exact.difference_low)
# what the prose says of the targets and the bound on these drives: 0.95 not met (the estimate below it, the interval
# on both sides); the cure below the exact filter (separated); the guards not separated from none
assert cure_rate.estimate < 0.95 and cure_rate.low < 0.95 < cure_rate.high
assert vs_exact.difference_high < 0 and vs_hz.difference_low < 0 < vs_hz.difference_high


# the cure before its guards, on the drives it was tuned on and the first fresh ones (100-149)
glob = by_seed("global_hazard")
aug = by_seed("global")
fresh = by_seed("global_fresh")
fresh_exact = STUDIES["map_global/exact_twins"].load().sort_values("seed")
fresh_exact = fresh_exact[fresh_exact["seed"] >= mg.FRESH_SEED]
exact_pair = evidence.paired_rates(glob["locked_on"].to_numpy(), exact_table["exact_locked_on"].to_numpy())
vs_aug = evidence.paired_rates(glob["locked_on"].to_numpy(), aug["locked_on"].to_numpy())
vs_inj = evidence.paired_rates(glob["locked_on"].to_numpy(), base_inj["locked_on"].to_numpy())
screen_note = ("Screened before the held-out drives (not stored; listed in the commits of the cure's branch): "
               "hysteresis alone lost kidnap run 5 to the cascade of the figure. On global drives 30-46 (which hold "
               "four of the unguarded cure's misses) the cure locked on in 13 of 17, the belief's evidence alone in "
               "12 of 16, uniform injection at N = 5000 (about the cure's cost) in 11 of 16; on kidnap runs 15-29 "
               "the cure recovered 13 of 15, the belief's evidence alone 14 of 15 (with two false relocalizations "
               "against none). The mixture-weighted start was not screened for lock-on.")
EvidenceBlock(
    "the cure on held-out drives, against its bound and the cure without its guards; the earlier drives",
    notes=[f"{len(held)} held-out drives (seeds {held['seed'].min()}-{held['seed'].max()}), 100 s each, uniform start; "
           "the filter of Algorithm 15.1 (20000 + 2000 poses at the start, 300-5000 after, an injection of 200 poses "
           "every 4 scans looking back 20 scans, xi = 0.001 per scan, admitted while at least three injections in a "
           "row have out-weighed the cloud (whichever strata won; not reset at an admission), the belief's evidence with the admitted stratum); random numbers from numpy.random.default_rng([41, seed, 2]) "
           "for both variants (common random numbers until the first injection).",
           f"Locked on (within 1 m and {np.degrees(mg.HEADING_TOL):.1f} degrees at 80 % of the last 20 s): "
           f"{cure_rate}.",
           f"Paired by drive (cure A, without its guards B): {vs_hz}.",
           f"Paired by drive (cure A, the exact filter over the twins B): {vs_exact}.",
           f"How the cure's {len(misses(held))} misses end: {int((misses(held)['final_position_error'] < 1).sum())} within "
           f"1 m of the truth (found, but too late for 80 % of the last 20 s), "
           f"{int((misses(held)['final_heading_error'] > np.pi / 2).sum())} on a half-turn twin (heading error above "
           f"90 degrees); {int((misses(held)['n_lost'] > 0).sum())} after a false relocalization (the table). "
           f"{int(guards_lost.sum())} of them are drives that the cure without its guards locks on (from "
           + ", ".join(f"{v:.1f}" for v in held_hz.loc[guards_lost, "locked_from_s"]) + " s) and the exact filter too "
           "(from " + ", ".join(f"{v:.1f}" for v in held_exact.loc[guards_lost, "exact_locked_from_s"]) + " s): the "
           f"guards lose them. The other {int((miss & ~guards_lost).sum())} the cure without its guards misses too; "
           "the exact filter locks on there from "
           + ", ".join(f"{v:.1f}" for v in held_exact.loc[miss & ~guards_lost, "exact_locked_from_s"]) + " s. An injected stratum claims only the evidence of its own window (the last 20 scans); "
           "evidence older than that, which the wrong cloud missed, is lost, and the count of three delays the "
           "correction further.",
           f"The guards' trade, drive by drive: they win {int(guards_win.sum())} drives (seeds "
           + ", ".join(str(v) for v in held.loc[guards_win, "seed"]) + "; the cure without its guards misses each "
           f"after a false relocalization) and lose {int(guards_lost.sum())} (seeds "
           + ", ".join(str(v) for v in held.loc[guards_lost, "seed"]) + "). A 'win' of a stratum is posterior odds "
           "above 1 : 1 against the cloud (share > 0.5), a coin flip by the filter's own reckoning; 'decided' asks "
           "99 : 1.",
           "Why a drive is lost to the guards, drive 150: the half-turn twin's cloud; in a logged re-run the truth's "
           "stratum won at 44 and 46 s and lost at 48 s. The truth's advantage over the twin in the look-back window "
           "(scans k - 20 ... k) at " + ", ".join(f"{k * study.DT:.0f} s: {w:.1f}" for k, w in zip(k150, w150))
           + f" nats; over the whole drive at {k150[-1] * study.DT:.0f} s: {d150[:k150[-1] + 1].sum():.1f} nats. "
           f"A stratum's expected log-odds are the window's advantage plus the prior log-odds "
           f"{np.log(every * xi / (1 - every * xi)):.1f}. Three wins in a row need the scans that tell the truth "
           "from the twin to stay in the window for 4 s, which the map decides. The exact filter is locked on from "
           f"{held_exact.loc[held_exact['seed'] == 150, 'exact_locked_from_s'].iloc[0]:.1f} s, the cure without "
           f"guards from {held_hz.loc[held_hz['seed'] == 150, 'locked_from_s'].iloc[0]:.1f} s.",
           f"Protocol. The cure was designed on drives and kidnap runs 0-149: tuned on 0-99, and the fresh runs "
           f"{mg.FRESH_SEED}-{mg.FRESH_SEED + mg.FRESH_RUNS - 1} (map_global/*_fresh), measured before the guards "
           "were built (the guards answer their false relocalizations). Drives 150-249 were registered before any "
           "held-out run; the first half "
           f"(150-199) was run, reported ({int(held['locked_on'][first_half].sum())}/{int(first_half.sum())} global "
           "drives locked on) and examined drive by drive by two reviews; the second half (200-249) was then run "
           f"with the same code ({int(held['locked_on'][~first_half].sum())}/{int((~first_half).sum())}). Drives "
           "150-249 are now spent: a changed cure must be judged on new drives registered in advance.",
           f"False relocalizations (2 s or more outside the tolerances, 2 m away, after 10 s within them), held-out "
           f"global drives and kidnap runs, runs with one: cure {cure_lost}, {cure_per_hour:.1f} an hour; without its "
           f"guards {hz_lost}, {hz_per_hour:.1f} an hour ({hours:.1f} hours of driving each). Exact (Garwood) 95 % "
           f"Poisson intervals of the rates: cure {cure_hour[1]:.3f}-{cure_hour[2]:.1f}, without its guards "
           f"{hz_hour[1]:.1f}-{hz_hour[2]:.1f} an hour. Paired by run, share of runs lost (cure A, without its guards "
           f"B): {lost_pair}.",
           f"The cure's false relocalizations are kidnap runs {int(lost_run['seed'].iloc[0])} and "
           f"{int(tracking_lost['seed'].iloc[0])}. Run {int(tracking_lost['seed'].iloc[0])} was lost at "
           f"{tracking_lost['lost_s'].iloc[0]:.0f} s, before its kidnapping at {study.KIDNAP_STEP * study.DT:.0f} s, "
           f"while tracking from the known start; it recovered "
           f"{tracking_lost['recovery_s'].iloc[0]:.0f} s after the kidnapping. Run {int(lost_run['seed'].iloc[0])} is "
           f"left out of the recovery rate: its kidnapping moved the robot {lost_run['jump_m'].iloc[0]:.2f} m and "
           f"{lost_run['jump_deg'].iloc[0]:.1f} degrees. The cloud was back on the robot when a twin's stratum was "
           f"admitted at {reloc_admit['t']:.0f} s (lost from {lost_run['lost_s'].iloc[0]:.0f} s), re-run and watched: "
           f"the count of three was a stratum on the robot at {reloc_on_robot['t'].iloc[0]:.0f} s (the cloud on the "
           f"robot too) and strata on a twin " + ", ".join(f"{v:.1f} m from the robot at {w:.0f} s" for v, w in
           zip(streak_rows.loc[streak_rows['off_m'] > 2, 'off_m'], streak_rows.loc[streak_rows['off_m'] > 2, 't']))
           + f"; the filter is locked on for good "
           f"only from {study.KIDNAP_STEP * study.DT + lost_run['recovery_s'].iloc[0]:.0f} s. Successive look-back "
           "windows share all but 4 of their scans, so a twin's wins are not independent from one injection to the next.",
           "Both are the map's ambiguity over the look-back window, not a noisy ratio: the true path's advantage "
           "over its half-turn twin in the window (scans k - 20 ... k) at the injections up to the step each was "
           "lost, " + "; ".join(f"run {seed}: " + ", ".join(f"{t_s:.0f} s {w:.1f}" for t_s, w in ws)
                               for seed, ws in reloc_windows.items())
           + f" nats, against the prior log-odds {np.log(every * xi / (1 - every * xi)):.1f}: the kidnap model "
           "(L = 20, xi_k = 4e-3) admits the twin by its own posterior, and no streak rule stops a twin that keeps "
           "winning. The controls are xi, L and the admission threshold, to be set against a budget of false "
           "relocalizations (the lock-on against false-relocalization curve on drives 0-149).",
           f"Cost: about {held['mean_particles'].mean() + per_injection / cs.inject_every:.0f} poses scored per scan "
           f"({per_injection} per injection, every {cs.inject_every} scans, plus the cloud). CPU time per 100-s drive "
           f"(process time, one after the other in the same single-threaded process, median over the "
           f"{len(inj5000)} drives): cure {inj5000['cure_cpu_s'].median():.1f} s, uniform injection with "
           f"{mg.INJECTION_N} particles {inj5000['injection_cpu_s'].median():.1f} s.",
           f"Uniform injection (map_robot's filter, product weighting) with {mg.INJECTION_N} particles on the same "
           f"held-out drives, judged by the same rule: {evidence.rate(inj5000['locked_on'].to_numpy())}; paired (cure A, "
           f"injection B): {vs_inj5000}.",
           f"Time to lock on for good, paired where both variants do (cure A, without its guards B). Held-out global "
           f"drives, locked_from_s: {later_glob}; the cure later on {sign_glob[0]}, earlier on {sign_glob[1]} "
           f"(sign test p = {sign_glob[2]:.2g}). Moved kidnap runs, recovery_s: {later_kid}; the cure later on "
           f"{sign_kid[0]}, earlier on {sign_kid[1]} (sign test p = {sign_kid[2]:.2g}). The sign test and the "
           "interval of the median see a typical delay of about two injections; the Wilcoxon test, which weighs the "
           "size of each difference, is pulled back by the runs where the unguarded filter settles much later. The random numbers are common only until the first injection.",
           screen_note,
           f"Without the guards, on the 100 drives it was tuned on (seeds 0-99): locked on {evidence.rate(glob['locked_on'].to_numpy())}; "
           f"against the exact filter {exact_pair}; against map_robot's uniform injection (N = 1000) {vs_inj}; "
           f"against the floored table-8.3 rate {vs_aug}.",
           f"Without the guards, fresh drives {mg.FRESH_SEED}-{mg.FRESH_SEED + mg.FRESH_RUNS - 1}: locked on "
           f"{evidence.rate(fresh['locked_on'].to_numpy())}; the exact filter {evidence.rate(fresh_exact['exact_locked_on'].to_numpy())}.",
           "Tried on seeds 0-99 before the guards: averaging rates alpha_slow = 0.01, alpha_fast = 0.5 for the floored "
           "rate (dropped after 14 screened drives); injecting only while that rate is above its floor, with a floor "
           "of 1000 particles (poor-fit, dropped); the kidnap prior xi = 1e-3 (kept) and 1e-4 (dropped).",
           stored("global_heldout"), stored("global_heldout_hazard"), stored("exact_heldout"),
           stored("injection_heldout"), stored("global_hazard"),
           stored("global") + " (the floored table-8.3 rate)", stored("global_fresh")],
    tables=[("The held-out drives the cure does not lock on", misses(held),
             {"final_position_error": ".2f", "final_heading_error": ".2f", "lost_s": ".1f"})],
)

# %% [markdown]
# ## The kidnapped robot
#
# Kidnap runs drive on for $100$ s after the kidnapping; runs it moved less than the lock-on
# tolerances are left out ({glue:text}`lf_heldout_not_kidnapped:d` of the held-out runs). Tracked
# from a known start, these runs have no islands.
#
# On the others it recovers (is locked on at the end) in
# {glue:text}`lf_kidnap_recovered_rate:.0%`
# ({glue:text}`lf_kidnap_recovered_rate_low:.0%`-{glue:text}`lf_kidnap_recovered_rate_high:.0%`): the
# estimate meets the $0.90$ aimed at, the interval reaches below it.
#
# :::{admonition} Against the exact filter
# :class: dropdown
# The exact filter over the twins, told when the kidnapping happened, recovers in
# {glue:text}`lf_kidnap_exact_rate:.0%`; the cure is {glue:text}`lf_kidnap_exact_gap_pts:.0f` points
# below it ({glue:text}`lf_kidnap_exact_gap_low_pts:.1f` to
# {glue:text}`lf_kidnap_exact_gap_high_pts:.0f`), not separated. The bound is optimistic: it knows
# the kidnap time and the twins, pays no $\xi$ and waits no $L$ scans.
# :::
#
# The cure is locked on for good a median {glue:text}`lf_kidnap_recovery_median_s:.0f` s after
# the kidnapping ({glue:text}`lf_kidnap_recovery_median_s_low:.0f`-{glue:text}`lf_kidnap_recovery_median_s_high:.0f` s).
# That is $L$ scans ($10$ s) plus two injections, the soonest an admitted stratum can lock it on:
# a latency, not a speed.
#
# :::{admonition} Why the interval has no width
# :class: dropdown
# {glue:text}`lf_kidnap_at_median_n:d` of the {glue:text}`lf_kidnap_recovered_n:d` runs that recover
# do so at exactly that time. {glue:text}`lf_kidnap_early_n:d` recover sooner, in
# {glue:text}`lf_kidnap_early_min_s:.0f`-{glue:text}`lf_kidnap_early_max_s:.0f` s, before any
# stratum could be admitted: there the cloud finds the robot by itself.
# :::
#
# :::{admonition} History: kidnap runs 150-249, and the guards
# :class: dropdown
# On the earlier held-out runs ($150$-$249$) the cure recovered in
# {glue:text}`lf_kidnap150_recovered_rate:.0%`
# ({glue:text}`lf_kidnap150_recovered_rate_low:.0%`-{glue:text}`lf_kidnap150_recovered_rate_high:.0%`),
# the exact filter in {glue:text}`lf_kidnap150_exact_rate:.0%`.
#
# Without its guards: {glue:text}`lf_kidnap_hazard_rate:.0%`. The guards win
# {glue:text}`lf_kidnap_guards_win:d` runs ({glue:text}`lf_kidnap_guards_win_relocs:d` false
# relocalizations without them) and lose {glue:text}`lf_kidnap_n_misses:d`, all the cure's misses there.
# :::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
kid_moved = ((kid_held["jump_m"] >= lock_on.POSITION_TOLERANCE_M)
             | (kid_held["jump_deg"] >= np.degrees(mg.HEADING_TOL))).to_numpy()
kid_pair = evidence.paired_rates(kid_held["recovered"].to_numpy()[kid_moved],
                                 kid_held_hz["recovered"].to_numpy()[kid_moved])
# the kidnap runs' bound: the exact filter over the true path and its twins from the kidnapping on
kid_exact = by_seed("exact_kidnap_heldout")
assert (kid_exact["seed"].to_numpy() == kid_held["seed"].to_numpy()).all()
kid_vs_exact = evidence.paired_rates(kid_held["recovered"].to_numpy()[kid_moved],
                                     kid_exact["exact_recovered"].to_numpy()[kid_moved])
kid_miss = kid_held.loc[kid_moved & ~kid_held["recovered"].to_numpy()]
kid_exact_miss = kid_exact.loc[kid_moved & ~kid_exact["exact_recovered"].to_numpy(), "seed"].tolist()
recovered = kid_pair.a
times = kid_held.loc[kid_moved & kid_held["recovered"].to_numpy(), "recovery_s"].to_numpy()
med, med_low, med_high = evidence.median_interval(times)
# the guards' trade on the kidnap runs: runs they win (the unguarded cure misses them, most after a false
# relocalization) and runs they lose (every run the cure misses)
kid_cure, kid_hz = kid_held["recovered"].to_numpy(), kid_held_hz["recovered"].to_numpy()
kid_win = kid_moved & kid_cure & ~kid_hz
assert (kid_moved & ~kid_cure & ~kid_hz).sum() == 0
glue_values("lf_", kidnap_guards_win=int(kid_win.sum()),
            kidnap_guards_win_relocs=int((kid_held_hz.loc[kid_win, "n_lost"] > 0).sum()))
glue_values("lf_", kidnap150_recovered_rate=recovered.estimate,
            kidnap150_recovered_rate_low=recovered.low, kidnap150_recovered_rate_high=recovered.high,
            kidnap_hazard_rate=kid_pair.b.estimate, kidnap150_exact_rate=kid_vs_exact.b.estimate,
            kidnap_n_misses=len(kid_miss))
# the held-out kidnap runs 250-349 (the cure: a robot tracked from a known start runs no islands) and their bound
kid3_moved = ((kid3["jump_m"] >= lock_on.POSITION_TOLERANCE_M)
              | (kid3["jump_deg"] >= np.degrees(mg.HEADING_TOL))).to_numpy()
kid3_vs_exact = evidence.paired_rates(kid3["recovered"].to_numpy()[kid3_moved],
                                      kid_exact3["exact_recovered"].to_numpy()[kid3_moved])
recovered3 = kid3_vs_exact.a
times3 = kid3.loc[kid3_moved & kid3["recovered"].to_numpy(), "recovery_s"].to_numpy()
med3, med3_low, med3_high = evidence.median_interval(times3)
# the cloud can find the robot by itself, before L scans and two injections
floor_s = engine.CURE.history * study.DT + 2 * engine.CURE.inject_every * study.DT
glue_values("lf_", kidnap_early_n=int((times3 < floor_s).sum()), kidnap_early_min_s=float(times3.min()),
            kidnap_early_max_s=float(times3[times3 < floor_s].max()), kidnap_at_median_n=int((times3 == med3).sum()),
            kidnap_recovered_n=len(times3), kidnap_floor_s=floor_s)
assert med3 == med3_low == med3_high == floor_s and times3.min() >= study.DT
glue_values("lf_", heldout_not_kidnapped=int((~kid3_moved).sum()), kidnap_recovered_rate=recovered3.estimate,
            kidnap_recovered_rate_low=recovered3.low, kidnap_recovered_rate_high=recovered3.high,
            kidnap_recovery_median_s=med3, kidnap_recovery_median_s_low=med3_low,
            kidnap_recovery_median_s_high=med3_high, kidnap_exact_rate=kid3_vs_exact.b.estimate,
            kidnap_exact_gap_pts=-100 * kid3_vs_exact.difference,
            kidnap_exact_gap_low_pts=-100 * kid3_vs_exact.difference_high,
            kidnap_exact_gap_high_pts=-100 * kid3_vs_exact.difference_low)
# what the prose says: 0.90 met by the estimate, the interval reaching below it; the cure below the exact filter
assert recovered3.estimate >= 0.90 and recovered3.low < 0.90
assert kid3_vs_exact.difference < 0
display(EvidenceBlock(
    "the kidnapped robot on held-out runs 250-349",
    notes=[f"{len(kid3)} held-out kidnap runs (seeds {kid3['seed'].min()}-{kid3['seed'].max()}): tracked from the "
           f"known start with the cure (no islands run from a known start), kidnapped at "
           f"t = {study.KIDNAP_STEP * study.DT:.0f} s, run to t = {study.KIDNAP_STEPS * study.DT:.0f} s; "
           f"{int((~kid3_moved).sum())} left out (moved less than 1 m and {np.degrees(mg.HEADING_TOL):.1f} degrees).",
           f"Recovered (locked on at the end): {recovered3} (Wilson interval). Paired by run (the cure A, the exact "
           f"filter over the twins after the kidnapping B): {kid3_vs_exact}.",
           f"Median time from the kidnapping to the step from which the filter stays locked on, over the "
           f"{len(times3)} runs that recover: {med3:.1f} s (95 % interval {med3_low:.1f}-{med3_high:.1f} s, "
           "percentile bootstrap): how fast, not how often.",
           f"False relocalizations on these runs: {int(kid3['n_lost'].sum())}.",
           stored("kidnap_heldout3"), stored("exact_kidnap_heldout3")],
    tables=[("The held-out kidnap runs the cure does not recover",
             kid3.loc[kid3_moved & ~kid3["recovered"].to_numpy(), ["seed", "final_position_error", "n_lost", "jump_m"]],
             {"final_position_error": ".2f", "jump_m": ".1f"})],
))
# what the prose says: 0.90 met by the estimate, not by the interval; the cure below the exact filter (separated);
# every run the cure misses is one the cure without its guards recovers
assert recovered.estimate >= 0.90 and recovered.low < 0.90 < recovered.high
assert kid_vs_exact.difference_high < 0 and kid_held_hz.loc[kid_miss.index, "recovered"].all()
# the exact filter's two misses are ambiguous late, not the map's alone: the cure misses them too, but the cure
# without its guards recovers both, and the exact filter ends on the robot (locked on too late for the window)
assert len(kid_exact_miss) == 2 and set(kid_exact_miss) <= set(kid_miss["seed"])
assert kid_held_hz.set_index("seed").loc[kid_exact_miss, "recovered"].all()
exact_miss_end = kid_exact.set_index("seed").loc[kid_exact_miss, "exact_final_position_error"]
assert (exact_miss_end < lock_on.POSITION_TOLERANCE_M).all()
kid = by_seed("kidnap_hazard")
fresh_kid = by_seed("kidnap_fresh")
fresh_moved = ((fresh_kid["jump_m"] >= lock_on.POSITION_TOLERANCE_M)
               | (fresh_kid["jump_deg"] >= np.degrees(mg.HEADING_TOL))).to_numpy()
EvidenceBlock(
    "the kidnapped robot, history: held-out runs 150-249, the guards, the earlier runs",
    notes=[f"{len(kid_held)} held-out runs (seeds {kid_held['seed'].min()}-{kid_held['seed'].max()}, drives of "
           f"pfcourse.studies.maprobot.simulate): tracked from the known start, kidnapped at "
           f"t = {study.KIDNAP_STEP * study.DT:.0f} s to a waypoint drawn by kidnap_rng(seed), run to "
           f"t = {study.KIDNAP_STEPS * study.DT:.0f} s; {int((~kid_moved).sum())} left out (moved less than 1 m and "
           f"{np.degrees(mg.HEADING_TOL):.1f} degrees).",
           f"Recovered (locked on at the end): cure {recovered}; paired with the cure without its guards: {kid_pair}; "
           f"paired with the exact filter over the twins after the kidnapping (the truth until the kidnapping, then "
           f"equal masses on the true path and its twins; it knows when the robot was carried off): {kid_vs_exact}.",
           f"The runs the cure misses end {', '.join(f'{e:.2f}' for e in kid_miss['final_position_error'])} m "
           f"from the truth ({int((kid_miss['final_position_error'] < 1).sum())} found again, too late for the window; "
           f"the table). The exact filter misses runs {', '.join(str(v) for v in kid_exact_miss)}: ambiguous late. "
           "It ends on the robot in both ("
           + ", ".join(f"{e:.2f}" for e in exact_miss_end)
           + " m) but is locked on too late for the window, and the cure without its guards recovers both: they "
           "are not the map's alone, since a weighted mean over the twins does not bound a filter that commits to "
           "one mode. Like the global bound, this one is optimistic: it knows the kidnap time and the 14 candidate "
           "paths (the truth and its 13 twins), pays no xi and has no latency of L scans.",
           f"The guards' trade: they win {int(kid_win.sum())} runs (seeds "
           + ", ".join(str(v) for v in kid_held.loc[kid_win, "seed"]) + f"; the cure without its guards misses "
           f"them, {int((kid_held_hz.loc[kid_win, 'n_lost'] > 0).sum())} after a false relocalization) and lose "
           f"{len(kid_miss)} (seeds {', '.join(str(v) for v in kid_miss['seed'])}, every run the cure misses).",
           f"The two halves of the held-out runs (moved ones recovered): 150-199 "
           f"{int(kid_held['recovered'][kid_moved & kid_first].sum())}/{int((kid_moved & kid_first).sum())}, "
           f"200-249 {int(kid_held['recovered'][kid_moved & ~kid_first].sum())}/{int((kid_moved & ~kid_first).sum())}; "
           "the first half reported and examined before the second was run with the same code (the protocol: the "
           "evidence block of 'Does it reach the bound?').",
           f"Median time from the kidnapping to the step from which the filter stays locked on, over the {len(times)} "
           f"runs that recover: {med:.1f} s (95 % interval {med_low:.1f}-{med_high:.1f} s, percentile bootstrap). "
           "A median among those that recover: it says how fast, not how often.",
           f"Without the guards, on the runs it was tuned on (seeds 0-99, all kept): recovered "
           f"{evidence.rate(kid['recovered'].to_numpy())}; fresh runs {mg.FRESH_SEED}-{mg.FRESH_SEED + mg.FRESH_RUNS - 1} "
           f"(moved ones): {evidence.rate(fresh_kid.loc[fresh_moved, 'recovered'].to_numpy())}.",
           stored("kidnap_heldout"), stored("kidnap_heldout_hazard"), stored("exact_kidnap_heldout"),
           stored("kidnap_hazard"), stored("kidnap_fresh")],
    tables=[("The held-out kidnap runs the cure does not recover",
             kid_held.loc[kid_moved & ~kid_held["recovered"].to_numpy(),
                          ["seed", "final_position_error", "n_lost", "lost_s", "jump_m"]],
             {"final_position_error": ".2f", "lost_s": ".1f", "jump_m": ".1f"})],
)

# %% [markdown]
# ## Explore: the poses a scan proposes
#
# $300$ poses of one draw from the proposal for seed $1$'s scan at $75$ s; the title averages ten
# draws.

# %% tags=["hide-input", "nbval-ignore-output"] jupyter={"source_hidden": true}
def draw(candidates=500, rounds=3, draws=10):
    s = engine.with_settings(candidates=candidates, refine_rounds=rounds)
    half_turn = twin(drive.truth[k_room][None], True, 0)[0]
    # the share of the poses within 0.5 m of the robot and of its half-turn twin, draw by draw (seeds 0 to draws - 1)
    near_robot, near_twin = [], []
    for seed in range(draws):
        x_s, _ = engine.scan_proposal(grid, field, drive.scans[k_room], 300, np.random.default_rng(seed), s)
        near_robot.append(np.mean(np.hypot(*(x_s[:, :2] - drive.truth[k_room, :2]).T) < 0.5))
        near_twin.append(np.mean(np.hypot(*(x_s[:, :2] - half_turn[:2]).T) < 0.5))
        if seed == 5:  # the draw shown: the one of the cell above at the default setting
            x = x_s
    fig, ax = plt.subplots(figsize=(8, 4.4))
    draw_map(ax, grid)
    ax.plot(x[:, 0], x[:, 1], ".", ms=4, color=COLORS["particles"], label="300 poses drawn from q")
    ax.plot(*drive.truth[k_room, :2], "x", ms=10, mew=2, color=COLORS["truth"], label="the robot")
    ax.plot(*half_turn[:2], "+", ms=10, mew=2, color=COLORS["estimate"], label="its half-turn twin")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=3)
    nudges = "1 round" if rounds == 1 else f"{rounds} rounds"
    ax.set_title(f"{candidates} x 24 candidates, {nudges} of nudges; within 0.5 m,\n"
                 f"mean of {draws} draws: of the robot {np.mean(near_robot):.0%}, "
                 f"of its twin {np.mean(near_twin):.0%}")


panel = control_panel(
    draw,
    grid={"candidates": (100, 500, 2000)},
    side={"rounds": (0, 1, 3)},
    candidates=SelectionSlider(options=[100, 500, 2000], value=500, description="candidate positions"),
    rounds=SelectionSlider(options=[0, 1, 3], value=3, description="rounds of nudges"),
)
display(panel)

# %% [markdown]
# ## Exercise
#
# ```{exercise} 15.1 How often does a look-alike take over?
# :label: ex-map-global-takeover
# :nonumber:
# (Coding.) A toy model of a twin's stratum the scans cannot tell from a right cloud. At each of $T$
# injections its estimated log-odds against the cloud are $\lambda + s\, e$, $e \sim \mathcal N(0, 1)$
# independent ($\lambda$ the prior log-odds, $s$ the spread of the estimated log Bayes factor), and it
# wins when they are positive. (The toy asks what noise alone does; the filter's two false
# relocalizations came from windows that favoured the twin. The filter's windows overlap, so its wins
# are not independent; the toy ignores that.) It takes over at the first injection that completes
# `confirm` wins in a row. This idealised rule counts the twin's own wins from zero; the coded rule
# (Algorithm 15.1) also admits a twin after other strata's wins (kidnap drive $5$), so the toy
# overstates the protection. Write `my_takeover(log_prior_odds, sd, confirm, T, runs,
# rng)` that returns the share of `runs` simulated drives in which the twin takes over, drawing
# `rng.standard_normal((runs, T))`. Then compare `confirm` $= 1$ and $3$ with the chapter's prior
# odds ($\xi_k = 4 \times 10^{-3}$), $T = 45$ injections (a $100$-s drive) and $s = 3$ nats (assumed,
# not measured). The checker compares your shares with exact ones
# and names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_takeover


def my_takeover(log_prior_odds, sd, confirm, T, runs, rng):
    """The share of the runs in which the twin's stratum takes over."""
    ...  # replace with your code


print(check_takeover(my_takeover))

# %% [markdown]
# ```{solution} ex-map-global-takeover
# :class: dropdown
# Draw all the injections at once, keep each run's current streak of wins (a loss resets it to
# zero), and mark a run taken over once its streak reaches `confirm`. In the toy a twin takes over
# in {glue:text}`lf_takeover_one:.0%` of the drives when one win suffices, and in
# {glue:text}`lf_takeover_three:.2%` when three in a row are needed. These are the toy's numbers, not
# the filter's: its windows overlap, so its wins are not independent and $s = 3$ was not measured.
# The code is in the folded cell below.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_takeover(log_prior_odds, sd, confirm, T, runs, rng):
    win = log_prior_odds + sd * rng.standard_normal((runs, T)) > 0
    streak = np.zeros(runs, dtype=int)
    taken = np.zeros(runs, dtype=bool)
    for t in range(T):
        streak = np.where(win[:, t], streak + 1, 0)
        taken |= streak >= confirm
    return taken.mean()


print(check_takeover(my_takeover))
lam = np.log(every * xi / (1 - every * xi))
shares = {c: float(my_takeover(lam, 3.0, c, 45, 20000, np.random.default_rng(0))) for c in (1, 3)}
print(f"taken over: confirm = 1 {shares[1]:.4f}, confirm = 3 {shares[3]:.4f}")
glue_values("lf_", takeover_one=shares[1], takeover_three=shares[3])

# %% [markdown]
# ## Takeaways
#
# - Before blaming a filter, measure what the map allows: an exact filter over the truth and its
#   twins, judged by the same lock-on rule.
# - Poses drawn from the scan are weighted by $u / q$ times the evidence of their history; their
#   prior is the kidnap model's $\xi$, chosen by hand. Count every loss, not only lock-on.
# - Islands, small filters whose mean weights estimate the evidence, are adopted at a margin chosen
#   on development drives ($\log 99$), not at true odds of $99 : 1$: the estimates are noisy.
# - On a hundred new drives from a uniform start the cure with islands locks on in
#   {glue:text}`lf_global_lock_on_rate:.0%`, not separated from the exact filter. Against the cure:
#   {glue:text}`lf_islands_gain_pts:+.0f` lock-on points, not separated, for pose jumps on
#   {glue:text}`lf_isl_lost_drives:d` drives (none without islands), separated.
# - It finds a kidnapped robot again in {glue:text}`lf_kidnap_recovered_rate:.0%` of the
#   kidnappings ($0.90$ aimed at), from a known pose with no islands; a kidnapping with the islands
#   running is untested.

# :::{admonition} Going further: how many particles (KLD-sampling's bound, and AMCL's kld_z)
# :class: dropdown
# The filter of Algorithm 15.1 starts with $20000$ poses uniform in free space and $2000$ drawn from the first
# scan, then sizes its cloud by KLD-sampling {cite:p}`fox2003`, clipped to
# $[300, 5000]$. Here the bound asks for the floor from the first scan on (the demo of seed $1$): the
# start, the scan proposal and the injections do the work.
#
# Cut the state space into bins ($0.5$ m $\times$ $0.5$ m $\times$ $10°$); if the posterior
# occupies $b$ bins, then with
#
# $$
# n = \frac{b - 1}{2 \varepsilon_\mathrm{KL}} \left( 1 - \frac{2}{9 (b - 1)}
#   + \sqrt{\frac{2}{9 (b - 1)}}\; z_{1 - \delta} \right)^3
# $$
#
# particles the Kullback-Leibler divergence between the particles' histogram and the true one stays
# below $\varepsilon_\mathrm{KL}$ with probability $1 - \delta$, $z_{1 - \delta}$ being the
# standard normal's $1 - \delta$ quantile. The filter uses $\varepsilon_\mathrm{KL} = 0.05$ (nav2's
# `pf_err`) and AMCL's $\delta$ of {glue:text}`lf_amcl_delta:.2f`: ROS's AMCL exposes
# $z_{1 - \delta}$ itself, as `kld_z = 0.99`, the quantile, not the probability, so
# $\delta = 1 - \Phi(0.99)$, a weaker guarantee than $\delta = 0.01$ and fewer particles. The
# folded cell below computes the bound.
#
# Is the collapse the start's weighting? As two groups of half the mass each, a uniform pose that
# happens to fit the scan carries a large share of the weight: on seed $1$ the start's effective
# sample size is {glue:text}`lf_start_ess_strata:.0f` of $22000$, and KLD asks for
# {glue:text}`lf_start_step1_strata:d` particles at step $1$. Weighting all the poses together by the
# mixture they were drawn from, $u\, p(z_0 \mid x) / (a u + (1 - a) q)$, with $u$ the uniform
# density over free poses, $q$ the density of the poses drawn from the scan (both defined in the
# sections above) and $a$ the share drawn uniformly, raises the ESS to {glue:text}`lf_start_ess_mixture:.0f`, yet KLD still asks for
# {glue:text}`lf_start_step1_mixture:d`: after one scan the posterior occupies few bins either way.
# That start is the package's `start_mixture` option; its effect on lock-on was not measured, and
# the cure keeps the two groups.
# :::

# %% tags=["hide-input"] jupyter={"source_hidden": true}
from scipy.stats import norm


def kld_bound(bins, eps_kl=0.05, delta=0.01):
    """Fox (2003): particles for a KL error below eps_kl, w.p. 1 - delta."""
    k = np.maximum(bins - 1.0, 1.0)
    a = 2 / (9 * k)
    n = k / (2 * eps_kl) * (1 - a + np.sqrt(a) * norm.ppf(1 - delta)) ** 3
    return np.where(bins <= 1, 1, np.ceil(n))


delta_amcl = 1 - norm.cdf(0.99)  # kld_z = 0.99 is the quantile z_{1-delta}
print(f"AMCL's kld_z = 0.99 means delta = {delta_amcl:.3f}")
for b in (5, 50, 500, 5000):
    print(f"{b:5d} bins: {kld_bound(b, 0.05, delta_amcl):6.0f} particles "
          f"(with delta = 0.01: {kld_bound(b, 0.05, 0.01):6.0f})")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
bins = np.array([1, 2, 5, 50, 500, 5000])
same_kld = np.array_equal(kld_bound(bins, 0.05, delta_amcl), engine_kld_bound(bins, 0.05, engine.AMCL_DELTA))
print(f"the same bound as pfcourse.sample_size.kld_bound with the package's AMCL delta: {same_kld}")
glue_values("lf_", amcl_delta=delta_amcl)
# the start on seed 1, weighted as two strata or by the mixture density: ESS and KLD's size at step 1
start_scores = {}
for how in ("strata", "mixture"):
    s_start = replace(engine.CURE, start_mixture=how == "mixture")
    x0, lw0 = engine.start_cloud(grid, field, drive.scans[0], np.random.default_rng([41, 1, 2]), s_start)
    w0 = np.exp(lw0 - logsumexp(lw0))
    start_scores[f"start_ess_{how}"] = float(1 / np.sum(w0**2))
    start_scores[f"start_step1_{how}"] = engine.kld_size(x0, w0, s_start, np.random.default_rng(0))
glue_values("lf_", **start_scores)


# %% [markdown]
# :::{admonition} From the labs
# :class: dropdown
# The robot lab (Lab C of {doc}`../labs`) asks how a filter started with a cloud over the whole
# map fares, and whether it finds the robot again after it is moved. This chapter answers both for
# a robot with a laser scanner: "Does it reach the bound?" and "The kidnapped robot".
# :::
