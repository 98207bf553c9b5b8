# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Static parameters online
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** why a parameter put into the state of a particle filter stops being learned, and
# three ways to learn it as the data arrive: Liu and West's shrunk kernel, the sufficient-statistic
# filter, and SMC²; which of them targets the exact posterior, what each
# costs, and where the exact ones fail in practice.
#
# **You need** {doc}`likelihood` (the likelihood estimate, PMMH) and {doc}`../part1/sir`
# (resampling, the static landmarks); the inverse-gamma distribution; NumPy.
#
# **Time:** about twenty-four minutes to read, plus about sixteen minutes for the folded blocks; the exercises are extra.
# :::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import json
import time

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy import stats
from scipy.special import gammaln, logsumexp

from pfcourse import evidence
from pfcourse.studies import static_parameters_study as sps
from pfcourse.studies.registry import STUDIES, cross_check
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import control_panel, particle_slider, seed_box
from pfcourse.static_parameters import liu_west as engine_liu_west
from pfcourse.static_parameters import smc2 as engine_smc2
from pfcourse.static_parameters import sufficient_statistic_filter
from pfcourse.book.style import COLORS, use_style
from IPython.display import display

use_style()
PROBLEM = sps.problem()
EXACT = sps.exact()  # Kalman likelihood on a grid of log theta, with the prior
GLUE = {}

# %% [markdown]
# The likelihood chapter learned the noise scale $\vartheta$ of the landmark model after the
# fact: PMMH runs a particle filter over **all** the data at every iteration. A robot that must
# learn its sensor's noise while it drives cannot wait for the end, nor re-run the past at every
# step. It wants $p(\vartheta \mid z_{1:k})$ updated at each step $k$, as the filter updates the
# state.
#
# The obvious move is to put $\vartheta$ into the state, with the dynamics $\vartheta_k = \vartheta_{k-1}$,
# and run the bootstrap filter on $(x_k, \vartheta_k)$. The model is the one of {doc}`likelihood`:
# the two-landmark model, process noise $0.05^2$ m² on every coordinate, measurement noise
# $R = \vartheta R_0$ with $R_0 = 0.5^2 I$ m², data simulated with $\vartheta = 1$ (seed $7$,
# $K = 50$ steps). The prior is an inverse gamma, $\vartheta \sim \mathrm{IG}(3, 2)$ (mean $1$,
# standard deviation $1$), chosen because it is conjugate (below). The exact posterior is the
# Kalman likelihood times the prior on a grid of $\log\vartheta$.

# %%
# pfcourse first: it pins NumPy's arithmetic to the book's
from pfcourse.scenarios.landmarks import quadrant_scenario, simulate

import matplotlib.pyplot as plt
import numpy as np
from scipy.special import gammaln, logsumexp

# the landmark model of the likelihood chapter, R = theta R0
sc = quadrant_scenario().with_(Qw=0.05**2 * np.eye(6), Rv=0.5**2 * np.eye(4))
Z = simulate(sc, 7).measurements  # 50 steps, simulated with theta = 1
F, B, H = sc.F, sc.B, sc.H
LQ, L0 = np.linalg.cholesky(sc.Qw), np.linalg.cholesky(sc.PX0)
r0 = 0.5**2  # R0 = r0 I
A0, B0 = 3.0, 2.0  # prior theta ~ IG(A0, B0)


def move(x, rng):
    return x @ F.T + B + rng.standard_normal(x.shape) @ LQ.T


def residuals(x, z):
    """Coordinates measured, and sum of squared residuals / r0 per particle."""
    seen = ~np.isnan(z)
    return seen.sum(), np.sum((z[seen] - x @ H[seen].T) ** 2, axis=1) / r0


def systematic(log_w, rng):
    w = np.exp(log_w - logsumexp(log_w))
    u = (np.arange(w.size) + rng.random()) / w.size
    idx = np.searchsorted(np.cumsum(w), u, side="right")
    return np.minimum(idx, w.size - 1)


def theta_in_state(Z, n, rng):
    """Bootstrap filter on (x, theta), theta never moved."""
    x = sc.mX0 + rng.standard_normal((n, 6)) @ L0.T
    theta = B0 / rng.gamma(A0, 1.0, n)  # prior draws
    distinct = []
    for k, z in enumerate(Z):
        if k > 0:
            x = move(x, rng)
        if np.isnan(z).all():
            continue
        m, S = residuals(x, z)
        idx = systematic(-0.5 * (m * np.log(theta) + S / theta), rng)
        x, theta = x[idx], theta[idx]
        distinct.append(np.unique(theta).size)
    return theta, distinct


theta_naive, distinct = theta_in_state(Z, 1000, np.random.default_rng(0))
print(f"distinct theta values: {distinct[0]} after the first sighting, "
      f"{distinct[-1]} at the end")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
grid_theta, grid_density = EXACT.theta_density()
fig, axes = plt.subplots(1, 2, figsize=(7.5, 3), constrained_layout=True)
measured = np.flatnonzero(~np.isnan(Z).all(axis=1))
axes[0].plot(measured, distinct, color=COLORS["estimate"])
axes[0].set(yscale="log", xlabel="step k", ylabel="distinct values of ϑ")
axes[1].hist(theta_naive, bins=40, range=(0.3, 2.5), density=True, color="0.75", label="ϑ in the state")
axes[1].plot(grid_theta, grid_density, color=COLORS["kalman"], lw=2, label="exact posterior")
axes[1].set(xlabel="noise scale ϑ", ylabel="density (per unit of ϑ)", xlim=(0.3, 2.5))
axes[1].legend(loc="upper right")
plt.show()
GLUE.update(naive_distinct_first=distinct[0], naive_distinct_last=distinct[-1], exact_mean=EXACT.mean,
            exact_sd=EXACT.sd)

# %% [markdown]
# ## Why a parameter in the state stops being learned
#
# Nothing ever moves $\vartheta$: the only values the filter will ever hold are the $N$ drawn from
# the prior at step $0$. Resampling can copy them and drop them, never make new ones. After the
# first sighting {glue:text}`naive_distinct_first:d` distinct values remain of $1000$, at the end
# {glue:text}`naive_distinct_last:d`, and the histogram (right) is a few spikes where the exact
# posterior (mean {glue:text}`exact_mean:.2f`, standard deviation {glue:text}`exact_sd:.2f`) is a
# smooth bump. This is the degeneracy of the static landmarks of {doc}`../part1/sir`, in
# $\vartheta$ this time: the filter's answer is a re-weighting of the prior's draws, and more data
# only sharpen the weights. Three cures follow. The first changes the model a little; the other
# two keep it.
#
# ## Liu and West: a kernel that keeps mean and variance
#
# After each resampling, move every copy of $u = \log\vartheta$ by a Gaussian kernel. A plain
# jitter would add variance at every step, and the posterior would widen without end.
# {cite:t}`liuwest2001` shrink each value towards the particles' mean $\bar u$ before jittering:
#
# $$
# u^i \leftarrow a\, u^i + (1 - a)\, \bar u + h\, s_u\, \varepsilon^i, \qquad
# a = \frac{3\delta - 1}{2\delta},\quad h^2 = 1 - a^2 ,
# $$
#
# with $s_u$ the particles' standard deviation, $\varepsilon^i \sim \mathcal N(0, 1)$ and a discount
# factor $\delta$ near $1$ ($0.98$ here). The mean and the variance of the cloud of $u$ are kept; the
# copies are separated. But the kernel replaces the static parameter by a slowly moving one, so
# the filter no longer targets $p(\vartheta \mid z_{1:k})$ exactly, and more particles do not
# remove that bias in principle; at the $N$ of this chapter the Monte Carlo error is the larger
# one (measured below). Liu and West also look ahead with an auxiliary step, left out here.

# %%
def liu_west(Z, n, rng, delta=0.98):
    """Bootstrap filter on (x, u = log theta), u moved by the shrunk kernel."""
    a = (3 * delta - 1) / (2 * delta)
    h = np.sqrt(1 - a**2)
    x = sc.mX0 + rng.standard_normal((n, 6)) @ L0.T
    u = np.log(B0 / rng.gamma(A0, 1.0, n))
    for k, z in enumerate(Z):
        if k > 0:
            x = move(x, rng)
        if np.isnan(z).all():
            continue
        m, S = residuals(x, z)
        log_w = -0.5 * (m * u + S / np.exp(u))
        W = np.exp(log_w - logsumexp(log_w))
        if k < len(Z) - 1:
            idx = systematic(log_w, rng)
            x, u, W = x[idx], u[idx], np.full(n, 1 / n)
            # shrink towards the mean, then jitter: mean and variance kept
            e = rng.standard_normal(n)
            u = a * u + (1 - a) * u.mean() + h * u.std() * e
    return np.exp(u), W

# %% [markdown]
# ## Sufficient statistics: integrate the parameter out
#
# Given the state path, $\vartheta$ is easy. Each measured coordinate $j$ of step $k$ has residual
# $z_{k,j} - H_j x_k \sim \mathcal N(0, \vartheta r_0)$, and the inverse-gamma prior is conjugate to a
# Gaussian variance: with $m_k$ the coordinates measured up to step $k$ and $S_k$ the sum of their
# squared residuals divided by $r_0$,
#
# $$
# p(\vartheta \mid x_{0:k}, z_{1:k}) = \mathrm{IG}\bigl(a_k, b_k\bigr), \qquad
# a_k = a_0 + \tfrac{m_k}{2}, \quad b_k = b_0 + \tfrac{S_k}{2} .
# $$
#
# $(a_k, b_k)$ is a **sufficient statistic**: two numbers, updated at each step, summarise the whole
# path. So each particle carries its $x$ and its $b$ ($a$ is the same for all), and $\vartheta$ is
# integrated out. The weight of a moved particle is the predictive density of the new measurement,
# $p(z_k \mid x_k, a_{k-1}, b_{k-1}) = \int p(z_k \mid x_k, \vartheta)\, \mathrm{IG}(\vartheta; a_{k-1}, b^i_{k-1})\, d\vartheta$,
# a Student density with $m$ coordinates measured at step $k$ and squared residual $S$:
#
# $$
# \log p(z_k \mid x_k^i, b^i_{k-1}) = \log\frac{\Gamma(a_{k-1} + m/2)}{\Gamma(a_{k-1})}
#   + a_{k-1} \log b^i_{k-1} - \Bigl(a_{k-1} + \tfrac m2\Bigr) \log\Bigl(b^i_{k-1} + \tfrac{S^i}{2}\Bigr)
#   + \text{const} .
# $$
#
# The filter then targets $p(x_{0:k} \mid z_{1:k})$ with $\vartheta$ integrated out, and its
# posterior of $\vartheta$ is the mixture $\sum_i W^i\, \mathrm{IG}(a_k, b_k^i)$: exact as
# $N \to \infty$. {cite:t}`storvik2002` draws a $\vartheta^i$ from $\mathrm{IG}(a, b^i)$ at each step
# and weights with it; {cite:t}`fearnhead2002` uses the statistics to move $\vartheta$ by a Gibbs
# step given them, inside a resample-move filter. Integrating $\vartheta$ out of the weights, as
# here, is closer to the particle learning of {cite:t}`carvalho2010`. This chapter calls its
# version **the sufficient-statistic filter**.
#
# :::{admonition} Algorithm 28.1: the sufficient-statistic filter for a noise scale
# :class: algorithm
# 1. **Initialise.** $x_0^i \sim p(x_0)$, $b^i = b_0$, $a = a_0$.
# 2. **For** $k = 1, \dots, K$:
#    1. *move:* $x_k^i \sim p(x_k \mid x_{k-1}^i)$; if nothing is measured, go to the next step;
#    2. *weight:* $\log w^i = \log p(z_k \mid x_k^i, a, b^i)$, the Student density above;
#    3. *update:* $a \leftarrow a + m/2$, $b^i \leftarrow b^i + S^i / 2$;
#    4. *resample* $(x_k^i, b^i)$ together with the weights $w^i$.
# 3. **Return** $\sum_i W^i\, \mathrm{IG}(\vartheta; a, b^i)$: mean $\sum_i W^i b^i / (a - 1)$.
# :::

# %%
def sufficient_statistics(Z, n, rng):
    """Each particle carries x and b; theta is integrated out."""
    x = sc.mX0 + rng.standard_normal((n, 6)) @ L0.T
    a, b = A0, np.full(n, B0)
    for k, z in enumerate(Z):
        if k > 0:
            x = move(x, rng)
        if np.isnan(z).all():
            continue
        m, S = residuals(x, z)
        # predictive p(z_k | x_k, a, b): a Student density
        log_w = (gammaln(a + m / 2) - gammaln(a) + a * np.log(b)
                 - (a + m / 2) * np.log(b + S / 2))
        a, b = a + m / 2, b + S / 2  # the conjugate update
        W = np.exp(log_w - logsumexp(log_w))
        if k < len(Z) - 1:
            idx = systematic(log_w, rng)
            x, b, W = x[idx], b[idx], np.full(n, 1 / n)
    return a, b, W  # posterior: sum_i W_i IG(a, b_i)


a, b, W = sufficient_statistics(Z, 1000, np.random.default_rng(0))
print(f"posterior mean of theta: {W @ b / (a - 1):.3f}")

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# the chapter's code against pfcourse.static_parameters, same seed (matmul here, einsum there: round-off only)
TOL = 1e-9
ours_ss = W @ b / (a - 1)
theirs_ss = sufficient_statistic_filter(PROBLEM, Z, 1000, np.random.default_rng(0)).mean
theta_lw, W_lw = liu_west(Z, 1000, np.random.default_rng(0))
theirs_lw = engine_liu_west(PROBLEM, Z, 1000, np.random.default_rng(0)).mean
assert abs(ours_ss - theirs_ss) < TOL * theirs_ss and abs(W_lw @ theta_lw - theirs_lw) < TOL * theirs_lw
GLUE.update(code_tol=TOL, ss_mean_page=ours_ss)

# %% [markdown]
# With the same seed, both functions give the posterior means of `pfcourse.static_parameters` to
# within a relative {glue:text}`code_tol:.0e`.
#
# ## SMC²: a particle filter over parameters, each with its own filter
#
# The third cure keeps the model and needs no conjugacy. {cite:t}`chopin2013` run $N_\vartheta$
# values $\vartheta^j$, each with its own bootstrap filter of $N_x$ particles. At step $k$ every inner
# filter advances one step and reports its likelihood factor $\hat p(z_k \mid z_{1:k-1}, \vartheta^j)$
# ({doc}`likelihood`), and the weight of $\vartheta^j$ is multiplied by it. When the weights of the
# $\vartheta^j$ become uneven, they are resampled (each with its filter) and each is moved by one
# PMMH step: propose $\vartheta'$, run a **fresh** filter on $z_{1:k}$, accept with the PMMH ratio.
# Why it is exact: because $\hat p$ is unbiased, the pair ($\vartheta$, the inner filter's random
# numbers) has an extended target whose marginal in $\vartheta$ is $p(\vartheta \mid z_{1:k})$, for
# **every** $N_x$, and the PMMH move leaves it invariant, exactly as in {doc}`likelihood`. The price is
# that each move re-runs the filter from the start: a move at step $k$ costs $k N_\vartheta N_x$.
# Chopin and coauthors also let $N_x$ grow with $k$ (an exchange step that doubles it when the
# acceptance rate of the moves falls); this chapter keeps $N_x$ fixed.
#
# :::{admonition} Algorithm 28.2: SMC²
# :class: algorithm
# 1. **Initialise.** $\vartheta^j \sim p(\vartheta)$, each with a filter of $N_x$ particles; $\log W^j = -\log N_\vartheta$.
# 2. **For** $k = 1, \dots, K$:
#    1. *inner step:* every filter moves, weights, resamples, and gives $\ell^j_k = \log\hat p(z_k \mid z_{1:k-1}, \vartheta^j)$;
#    2. *reweight:* $\log W^j \leftarrow \log W^j + \ell^j_k$, normalised; $\log\hat p^j \leftarrow \log\hat p^j + \ell^j_k$;
#    3. *if* $\mathrm{ESS}(W) < N_\vartheta / 2$: resample the $\vartheta^j$ with their filters and their $\hat p^j$; then for each $j$
#       propose $u' = \log\vartheta^j + s_u \varepsilon$, run a fresh filter on $z_{1:k}$ at $e^{u'}$, and accept
#       with probability $\min\bigl(1, \hat p'\, p(\vartheta')\, \vartheta' / (\hat p^j\, p(\vartheta^j)\, \vartheta^j)\bigr)$
#       (the factor $\vartheta$ is the prior's change of variable to $u$).
# 3. **Return** the weighted $\vartheta^j$.
# :::
#
# Its NumPy, with the inner filters of every $\vartheta^j$ advanced together as one array, is folded
# below (about forty lines); it reproduces `pfcourse.static_parameters.smc2`.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def inner_step(x, z, k, theta, rng):
    """One step of every inner filter: x has shape (N_theta, N_x, 6)."""
    if k > 0:
        x = np.einsum("...j,ij->...i", x, F) + B + np.einsum("...j,ij->...i", rng.standard_normal(x.shape), LQ)
    if np.isnan(z).all():
        return x, np.zeros(x.shape[0])
    seen = ~np.isnan(z)
    S = np.sum((z[seen] - np.einsum("...j,ij->...i", x, H[seen])) ** 2, axis=-1) / r0
    log_g = -0.5 * (seen.sum() * (np.log(2 * np.pi * r0) + np.log(theta[:, None])) + S / theta[:, None])
    increment = logsumexp(log_g, axis=1) - np.log(x.shape[1])
    W = np.exp(log_g - logsumexp(log_g, axis=1, keepdims=True))
    cdf = np.cumsum(W, axis=1)
    cdf[:, -1] = 1.0
    u = (np.arange(x.shape[1]) + rng.random((x.shape[0], 1))) / x.shape[1]
    idx = np.array([np.searchsorted(c, v, side="right") for c, v in zip(cdf, u)])
    return np.take_along_axis(x, np.minimum(idx, x.shape[1] - 1)[:, :, None], axis=1), increment


def log_prior_u(theta):  # IG(A0, B0) density of theta, times theta (the change of variable to u)
    return A0 * np.log(B0) - gammaln(A0) - A0 * np.log(theta) - B0 / theta


def smc2(Z, n_theta, n_x, rng):
    theta = B0 / rng.gamma(A0, 1.0, n_theta)
    x = sc.mX0 + np.einsum("...j,ij->...i", rng.standard_normal((n_theta, n_x, 6)), L0)
    log_p, log_W = np.zeros(n_theta), np.full(n_theta, -np.log(n_theta))
    for k in range(1, len(Z)):
        x, ell = inner_step(x, Z[k], k, theta, rng)
        log_p, log_W = log_p + ell, log_W + ell - logsumexp(log_W + ell)
        if 1 / np.sum(np.exp(2 * log_W)) >= n_theta / 2 or k == len(Z) - 1:
            continue
        # resample the theta-particles with their filters (one systematic draw)
        W = np.exp(log_W)
        idx = np.minimum(np.searchsorted(np.cumsum(W), (np.arange(n_theta) + rng.random((1, 1))[0, 0]) / n_theta,
                                         side="right"), n_theta - 1)
        theta, x, log_p, log_W = theta[idx], x[idx], log_p[idx], np.full(n_theta, -np.log(n_theta))
        # one PMMH move each: a fresh filter on z_0..z_k at the proposed theta
        u = np.log(theta)
        new = np.exp(u + u.std() * rng.standard_normal(n_theta))
        x_new = sc.mX0 + np.einsum("...j,ij->...i", rng.standard_normal((n_theta, n_x, 6)), L0)
        log_p_new = np.zeros(n_theta)
        for j in range(k + 1):
            x_new, ell = inner_step(x_new, Z[j], j, new, rng)
            log_p_new += ell
        accept = np.log(rng.random(n_theta)) < log_p_new + log_prior_u(new) - log_p - log_prior_u(theta)
        theta, log_p = np.where(accept, new, theta), np.where(accept, log_p_new, log_p)
        x = np.where(accept[:, None, None], x_new, x)
    return theta, np.exp(log_W)


t0 = time.perf_counter()
theta_smc2, W_smc2 = smc2(Z, 100, sps.SMC2_NX, np.random.default_rng(0))
smc2_page_seconds = time.perf_counter() - t0
engine = engine_smc2(PROBLEM, Z, 100, sps.SMC2_NX, np.random.default_rng(0))
assert abs(W_smc2 @ theta_smc2 - engine.mean) < 1e-6 * engine.mean  # the same run as the engine's

# %% [markdown]
# ## The three against the exact posterior
#
# One run of each, seed $0$: Liu-West and the sufficient statistics with $N = 1000$, SMC² with
# $N_\vartheta = 100$ values and $N_x = 100$ particles each.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def ig_mixture(theta, a, b, W):
    """sum_i W_i IG(theta; a, b_i) on a grid of theta."""
    return np.exp(logsumexp(np.log(W)[:, None] + stats.invgamma.logpdf(theta[None, :], a, scale=b[:, None]), axis=0))


def draw_posteriors(ax, runs, title=None):
    ax.plot(grid_theta, grid_density, color=COLORS["kalman"], lw=2.5, label="exact (Kalman grid)")
    styles = {"Liu-West": ("tab:orange", "-"), "sufficient statistics": ("tab:blue", "--"), "SMC²": ("tab:green", ":")}
    for name, density in runs.items():
        ax.plot(grid_theta, density, color=styles[name][0], ls=styles[name][1], lw=1.8, label=name)
    ax.set(xlabel="noise scale ϑ", ylabel="density (per unit of ϑ)", xlim=(0.3, 2.0))
    if title:
        ax.set_title(title, loc="left")


def weighted_kde(theta, W):
    return stats.gaussian_kde(theta, weights=W)(grid_theta)


page_runs = {"Liu-West": weighted_kde(theta_lw, W_lw), "sufficient statistics": ig_mixture(grid_theta, a, b, W),
             "SMC²": weighted_kde(theta_smc2, W_smc2)}
fig, ax = plt.subplots(figsize=(6.4, 3.4), constrained_layout=True)
draw_posteriors(ax, page_runs)
ax.legend(loc="upper right")
plt.show()
page_errors = {"lw": (W_lw @ theta_lw - EXACT.mean) / EXACT.sd, "ss": (ours_ss - EXACT.mean) / EXACT.sd,
               "smc2": (W_smc2 @ theta_smc2 - EXACT.mean) / EXACT.sd}
GLUE.update(page_error_lw=page_errors["lw"], page_error_ss=page_errors["ss"], page_error_smc2=page_errors["smc2"])

# %% [markdown]
# Liu-West and SMC² are drawn as kernel density estimates of their weighted values; the sufficient
# statistics give their mixture of inverse gammas directly. In this run the posterior means lie
# {glue:text}`page_error_lw:.2f`, {glue:text}`page_error_ss:.2f` and {glue:text}`page_error_smc2:.2f`
# exact standard deviations from the exact mean (Liu-West, sufficient statistics, SMC²). One run
# says little; the stored study repeats each sampler $100$ times on these data ($50$ for SMC²),
# run $r$ with seed $r$ for all three.
#
# **The measure.** For each run, the error of its posterior mean in exact posterior standard
# deviations, $(\hat\mu - \mu) / \sigma$; over the runs, its median absolute value, its mean
# (the bias) and its standard deviation (the spread).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
main = pd.concat([STUDIES["static_parameters/main"].load(), STUDIES["static_parameters/smc2"].load()], ignore_index=True)
assert (main["status"] == "ok").all() and np.allclose(main["exact_mean"], EXACT.mean, rtol=1e-12)
measured_steps = int((~np.isnan(Z).all(axis=1)).sum())
label = {"liu_west": "Liu-West", "storvik": "sufficient statistics", "smc2": "SMC²"}
rows, err = [], {}
for (method, n), g in main.groupby(["method", "n"], sort=False):
    g = g.sort_values("run")
    e = g["error"].to_numpy()
    err[(method, n)] = e
    med = evidence.median_interval(np.abs(e))
    bias = evidence.run_interval(lambda r: e[r].mean(), e.size)
    size = f"N = {n}" if method != "smc2" else f"N_ϑ = {n}, N_x = {sps.SMC2_NX}"
    rows.append({"sampler": label[method], "size": size, "runs": e.size, "median |error|": med[0],
                 "its 95% CI": f"{med[1]:.2f} to {med[2]:.2f}", "bias (mean error)": bias[0],
                 "bias 95% CI": f"{bias[1]:.2f} to {bias[2]:.2f}", "spread (sd of error)": e.std(ddof=1),
                 "median sd / exact sd": g["sd_ratio"].median(),
                 "evaluations per measured step": g["evaluations"].median() / measured_steps,
                 "seconds per step": g["seconds"].median() / len(Z)})
table = pd.DataFrame(rows)
BIG = 5000
lw, ss, s2 = err[("liu_west", BIG)], err[("storvik", BIG)], err[("smc2", 100)]
lw_vs_ss = evidence.paired(np.abs(lw), np.abs(ss), ratio=True)
s2_vs_ss = evidence.paired(np.abs(s2), np.abs(ss[:s2.size]), ratio=True)  # SMC²: runs 0-49, the same seeds
s2_vs_lw = evidence.paired(np.abs(s2), np.abs(lw[:s2.size]), ratio=True)
lw_shrink = evidence.paired(np.abs(lw), np.abs(err[("liu_west", 1000)]), ratio=True)
ss_shrink = evidence.paired(np.abs(ss), np.abs(err[("storvik", 1000)]), ratio=True)
cost = table.set_index(["sampler", "size"])
smc2_evals = float(cost.loc[("SMC²", f"N_ϑ = 100, N_x = {sps.SMC2_NX}"), "evaluations per measured step"])
smc2_moves = main[main.method == "smc2"]["moves"].median()
smc2_accept = main[main.method == "smc2"]["acceptance"].median()
GLUE.update(liu_west_posterior_error=float(np.median(np.abs(lw))), storvik_posterior_error=float(np.median(np.abs(ss))),
            smc2_posterior_error=float(np.median(np.abs(s2))), lw_bias=float(lw.mean()), ss_bias=float(ss.mean()),
            smc2_bias=float(s2.mean()), lw_sd_ratio=float(main[(main.method == "liu_west") & (main.n == BIG)]["sd_ratio"].median()),
            lw_vs_ss=lw_vs_ss.median, lw_vs_ss_low=lw_vs_ss.low, lw_vs_ss_high=lw_vs_ss.high,
            s2_vs_ss=s2_vs_ss.median, s2_vs_ss_low=s2_vs_ss.low, s2_vs_ss_high=s2_vs_ss.high,
            s2_vs_lw=s2_vs_lw.median, s2_vs_lw_low=s2_vs_lw.low, s2_vs_lw_high=s2_vs_lw.high,
            lw_shrink=lw_shrink.median, lw_shrink_low=lw_shrink.low, lw_shrink_high=lw_shrink.high,
            ss_shrink=ss_shrink.median,
            evals_big=BIG, smc2_evals_per_step=smc2_evals, smc2_cost_ratio=smc2_evals / BIG,
            smc2_moves=float(smc2_moves), smc2_acceptance=float(smc2_accept),
            smc2_move_share=1 - 100 * sps.SMC2_NX / smc2_evals,
            ss_seconds_per_step=float(cost.loc[("sufficient statistics", f"N = {BIG}"), "seconds per step"]),
            smc2_seconds_per_step=float(cost.loc[("SMC²", f"N_ϑ = 100, N_x = {sps.SMC2_NX}"), "seconds per step"]))
EvidenceBlock(
    "Liu-West's error is about three times the sufficient statistics' at equal N; SMC² is not separated from Liu-West",
    notes=[f"Stored study static_parameters/main (provenance in book/data/static_parameters/main.json): "
           f"{sps.N_RUNS} runs per sampler on the chapter's data, run r with numpy.random.default_rng(r) for every "
           "sampler. Error = (posterior mean - exact mean) / exact sd at the last step; exact posterior from the Kalman "
           f"likelihood on {sps.U_GRID_MAIN.size} points of log ϑ, mean {EXACT.mean:.4f}, sd {EXACT.sd:.4f}.",
           "Medians with percentile-bootstrap intervals; bias with a bootstrap interval over the runs; paired "
           "comparisons on the same seeds: median ratio of |error| with its bootstrap interval and the Wilcoxon "
           "signed-rank test (pfcourse.evidence.paired).",
           f"Liu-West against sufficient statistics, N = {BIG}: {lw_vs_ss}.",
           f"SMC² against sufficient statistics (N = {BIG}), on SMC²'s {s2.size} runs: {s2_vs_ss}.",
           f"SMC² against Liu-West (N = {BIG}), on the same {s2.size} runs: {s2_vs_lw}.",
           f"Liu-West, N = {BIG} against N = 1000: {lw_shrink}.",
           f"Sufficient statistics, N = {BIG} against N = 1000: {ss_shrink}.",
           "Seeds are shared across N, but runs with different N are not otherwise coupled; the paired test is "
           "still valid, the pairing gains little.",
           f"SMC²: median number of PMMH moves {smc2_moves:.0f}, median acceptance {smc2_accept:.2f}. Evaluations = "
           "measurement densities evaluated (one per particle and measured step; SMC²'s re-runs included); seconds "
           "from the stored runs on a shared 2-core machine (indicative)."],
    tables=[("Posterior mean against the exact one, in exact posterior sds, and cost", table,
             {"median |error|": ".2f", "bias (mean error)": ".2f", "spread (sd of error)": ".2f",
              "median sd / exact sd": ".2f", "evaluations per measured step": ".0f", "seconds per step": ".4f"})],
)

# %% [markdown]
# Over $100$ runs each ($50$ for SMC², the expensive one), the median error of the posterior mean
# is {glue:text}`liu_west_posterior_error:.2f` exact standard deviations for Liu-West,
# {glue:text}`storvik_posterior_error:.2f` for the sufficient statistics (both with $N = 5000$)
# and {glue:text}`smc2_posterior_error:.2f` for SMC².
#
# Liu-West's error is {glue:text}`lw_vs_ss:.1f` times that of the sufficient statistics, run by
# run ({glue:text}`lw_vs_ss_low:.1f` to {glue:text}`lw_vs_ss_high:.1f`), with as many particles.
#
# Five times more particles multiply the sufficient statistics' error by
# {glue:text}`ss_shrink:.2f`, close to the $1/\sqrt 5$ of a Monte Carlo error, and Liu-West's by
# {glue:text}`lw_shrink:.2f` ({glue:text}`lw_shrink_low:.2f` to {glue:text}`lw_shrink_high:.2f`):
# over $50$ steps, most of Liu-West's error is Monte Carlo error, which more particles remove,
# not the kernel's bias.
#
# The biases are {glue:text}`lw_bias:.2f` (Liu-West), {glue:text}`ss_bias:.2f` (sufficient
# statistics) and {glue:text}`smc2_bias:.2f` (SMC²) standard deviations, intervals in the folded
# table. The exact samplers are exact only in the limit: the sufficient statistics' bias shrinks
# from $N = 1000$ to $N = 5000$, and SMC² with only $N_\vartheta = 100$ values is as biased as
# Liu-West.
#
# SMC²'s median error is {glue:text}`s2_vs_lw:.2f` times Liu-West's, run by run
# ({glue:text}`s2_vs_lw_low:.2f` to {glue:text}`s2_vs_lw_high:.2f`): the runs do not separate the two.
#
# They do not cost the same. The sufficient statistics evaluate $N$ measurement densities per
# measured step; SMC² evaluates {glue:text}`smc2_evals_per_step:.0f` per measured step on average,
# {glue:text}`smc2_cost_ratio:.1f` times as many as the sufficient statistics with $N = 5000$, a
# share {glue:text}`smc2_move_share:.2f` of them in the PMMH moves that re-run the filters from
# the start, and its error is {glue:text}`s2_vs_ss:.1f` times theirs, run by run. SMC² buys
# generality, not accuracy per evaluation: it needs no conjugate form, only a likelihood estimate.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
long = STUDIES["static_parameters/long"].load()
assert (long["status"] == "ok").all()
long_rows, long_err = [], {}
for (method, T), g in long.groupby(["method", "T"], sort=False):
    g = g.sort_values("run")
    e = g["error"].to_numpy()
    long_err[(method, T)] = g
    med = evidence.median_interval(np.abs(e))
    long_rows.append({"sampler": label[method], "steps T": T, "median |error|": med[0],
                      "its 95% CI": f"{med[1]:.2f} to {med[2]:.2f}", "bias (mean error)": e.mean(),
                      "spread (sd of error)": e.std(ddof=1), "median sd / exact sd": g["sd_ratio"].median(),
                      "median ancestors of step 1": g["ancestors"].median(), "exact sd of ϑ": g["exact_sd"].iloc[0]})
long_table = pd.DataFrame(long_rows)
T_LONG = max(sps.LONG_T)
ss_short, ss_long = (long_err[("storvik", T)]["error"].abs().to_numpy() for T in (min(sps.LONG_T), T_LONG))
growth = evidence.paired(ss_long, ss_short, ratio=True)
# Liu-West at T = 400 with five times the particles (study static_parameters/long_big; run r has long's seed r)
long_big = STUDIES["static_parameters/long_big"].load().sort_values("run")
assert (long_big["status"] == "ok").all()
LW_BIG_N = int(long_big["n"].iloc[0])
lw_long_small = long_err[("liu_west", T_LONG)].sort_values("run")
assert (lw_long_small["seed"].to_numpy() == long_big["seed"].to_numpy()).all()
lw_long_shrink = evidence.paired(long_big["error"].abs().to_numpy(), lw_long_small["error"].abs().to_numpy(), ratio=True)
lw_big_med = evidence.median_interval(long_big["error"].abs().to_numpy())
long_rows.append({"sampler": f"Liu-West, N = {LW_BIG_N}", "steps T": T_LONG, "median |error|": lw_big_med[0],
                  "its 95% CI": f"{lw_big_med[1]:.2f} to {lw_big_med[2]:.2f}", "bias (mean error)": long_big["error"].mean(),
                  "spread (sd of error)": long_big["error"].std(ddof=1), "median sd / exact sd": long_big["sd_ratio"].median(),
                  "median ancestors of step 1": long_big["ancestors"].median(), "exact sd of ϑ": long_big["exact_sd"].iloc[0]})
long_table = pd.DataFrame(long_rows)
GLUE.update(long_t=T_LONG, long_n=sps.LONG_N,
            ss_long_error=float(np.median(ss_long)), ss_short_error=float(np.median(ss_short)),
            ss_long_ancestors=float(long_err[("storvik", T_LONG)]["ancestors"].median()),
            ss_short_ancestors=float(long_err[("storvik", min(sps.LONG_T))]["ancestors"].median()),
            ss_long_spread=float(long_err[("storvik", T_LONG)]["error"].std(ddof=1)),
            ss_growth=growth.median, ss_growth_low=growth.low, ss_growth_high=growth.high,
            lw_long_sd_ratio=float(long_err[("liu_west", T_LONG)]["sd_ratio"].median()),
            lw_long_error=float(long_err[("liu_west", T_LONG)]["error"].abs().median()),
            lw_big_n=LW_BIG_N, lw_long_big_error=lw_big_med[0], lw_long_big_sd_ratio=float(long_big["sd_ratio"].median()),
            lw_long_shrink=lw_long_shrink.median, lw_long_shrink_low=lw_long_shrink.low,
            lw_long_shrink_high=lw_long_shrink.high)
EvidenceBlock(
    "path degeneracy: the sufficient statistics lose their spread of histories as T grows",
    notes=[f"Stored study static_parameters/long: the first T steps of one {sps.LONG_K}-step simulation (ϑ = 1, seed "
           f"{sps.DATA_SEED}), N = {sps.LONG_N}, {sps.N_RUNS} runs per setting (run r: default_rng(r)); the exact "
           f"posterior on {sps.U_GRID_LONG.size} points of log ϑ for each T. SMC² is left out: its PMMH moves re-run "
           "the filters from the start, so its cost grows like T².",
           f"'ancestors of step 1': how many particles of the first measured step the final cloud descends from.",
           f"Sufficient-statistic filter, T = {T_LONG} against T = {min(sps.LONG_T)}, |error| ratio on the same seeds: {growth}.",
           f"Liu-West at T = {T_LONG}, N = {LW_BIG_N} against N = {sps.LONG_N} (stored study "
           f"static_parameters/long_big, the same seeds): {lw_long_shrink}."],
    tables=[("Error of the posterior mean (exact sds) against the number of steps", long_table,
             {"median |error|": ".2f", "bias (mean error)": ".2f", "spread (sd of error)": ".2f",
              "median sd / exact sd": ".2f", "median ancestors of step 1": ".0f", "exact sd of ϑ": ".3f"})],
)

# %% [markdown]
# ## Where the exact filter fails: path degeneracy of the statistics
#
# The sufficient statistic $b^i$ sums over the particle's **whole path**. Resampling copies paths,
# and after enough steps every particle descends from one ancestor at the start
# ({doc}`smoothing`): the early part of every $b^i$ is then the same number, one draw of the early
# path instead of an average over it. The mixture $\sum_i W^i\,\mathrm{IG}(a, b^i)$ keeps its width,
# but its centre follows that one early history.
#
# The stored runs measure it on a longer simulation, with $N = 1000$. After $T =$
# {glue:text}`long_t:d` steps the final cloud descends from a median of
# {glue:text}`ss_long_ancestors:.0f` particle(s) of the first step, against
# {glue:text}`ss_short_ancestors:.0f` after $50$ steps.
#
# The median error grows from {glue:text}`ss_short_error:.2f` exact standard deviations after
# $50$ steps to {glue:text}`ss_long_error:.2f` after {glue:text}`long_t:d`. The filter is exact as
# $N \to \infty$ for a fixed $T$, but at a fixed $N$ its error grows with $T$: $N$ must grow with the
# data, as for the likelihood estimate.
#
# Liu-West fares worse over the long run: after {glue:text}`long_t:d` steps its posterior is
# {glue:text}`lw_long_sd_ratio:.2f` times as wide as the exact one, and its median error
# {glue:text}`lw_long_error:.2f` exact standard deviations: it is too sure of a wrong value.
# The kernel keeps the cloud's variance; what narrows it is resampling, which copies a few values
# faster than the small jitter separates them, and more particles slow that down.
#
# With five times the particles the median error is {glue:text}`lw_long_big_error:.2f`,
# a factor {glue:text}`lw_long_shrink:.2f` of that with $N = 1000$, run by run
# ({glue:text}`lw_long_shrink_low:.2f` to {glue:text}`lw_long_shrink_high:.2f`).
#
# Its posterior is then {glue:text}`lw_long_big_sd_ratio:.2f` times as wide as the exact one. At
# these $N$ most of Liu-West's error is Monte Carlo error, not the kernel's bias.
#
# ## Try it
#
# The panel runs the parameter-in-the-state filter, Liu-West and the sufficient statistics for a
# number of particles and a seed, and draws their posteriors of $\vartheta$ against the exact one.
# The first is a few spikes at every $N$; watch how the other two move with the seed.

# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
def draw_panel(n_particles, seed):
    naive, _ = theta_in_state(Z, n_particles, np.random.default_rng(seed))
    t_lw, w_lw = liu_west(Z, n_particles, np.random.default_rng(seed))
    a_, b_, w_ = sufficient_statistics(Z, n_particles, np.random.default_rng(seed))
    fig, ax = plt.subplots(figsize=(6.4, 3.4), constrained_layout=True)
    ax.hist(naive, bins=60, range=(0.3, 2.0), density=True, color="0.8", label="ϑ in the state")
    draw_posteriors(ax, {"Liu-West": weighted_kde(t_lw, w_lw), "sufficient statistics": ig_mixture(grid_theta, a_, b_, w_)},
                    title=f"N = {n_particles}, seed {seed}")
    ax.legend(loc="upper right", fontsize=8)


display(control_panel(draw_panel, grid={"n_particles": (100, 300, 1000)}, n_particles=particle_slider(300, 2, 3),
                      seed=seed_box(0)))

# %% tags=["remove-input"] jupyter={"source_hidden": true}
check = cross_check("static_parameters")
x_mean, x_sd = check["exact"]["mean"], check["exact"]["sd"]
ours_means = np.array([r["mean"] for r in check["pfcourse_smc2"]["runs"]])
their_means = np.array([r["mean"] for r in check["particles_smc2"]["runs"]])
ours_err = evidence.run_interval(lambda r: (ours_means[r].mean() - x_mean) / x_sd, ours_means.size)
their_err = evidence.run_interval(lambda r: (their_means[r].mean() - x_mean) / x_sd, their_means.size)
diff = stats.ttest_ind(ours_means / x_sd, their_means / x_sd, equal_var=False)
diff_ci = diff.confidence_interval(0.95)
GLUE.update(pf_minus_particles=(ours_means.mean() - their_means.mean()) / x_sd, pf_minus_particles_low=diff_ci.low,
            pf_minus_particles_high=diff_ci.high)
GLUE.update(particles_runs=int(their_means.size), particles_error=their_err[0], particles_error_low=their_err[1],
            particles_error_high=their_err[2], pf_smc2_error=ours_err[0], pf_smc2_error_low=ours_err[1],
            pf_smc2_error_high=ours_err[2])
EvidenceBlock(
    "the SMC² here and the `particles` library's agree with the exact posterior of a scalar model",
    notes=[f"tools/static_parameters_particles.py (provenance in book/data/static_parameters/particles_check.json): "
           f"{check['model']}. Exact posterior mean {x_mean:.4f}, sd {x_sd:.4f}.",
           f"pfcourse.static_parameters.smc2 (N_ϑ = {check['pfcourse_smc2']['n_theta']}, N_x = "
           f"{check['pfcourse_smc2']['n_x']}) and particles {check['particles_smc2']['version']} SMC2 (N = "
           f"{check['particles_smc2']['N']}, N_x = {check['particles_smc2']['init_Nx']}, "
           f"{check['particles_smc2']['moves']}), {their_means.size} seeds each, run in its own environment.",
           f"Mean over the seeds of the posterior mean, minus the exact mean, in exact sds (bootstrap 95 % "
           f"intervals over the seeds): pfcourse {ours_err[0]:.2f} ({ours_err[1]:.2f} to {ours_err[2]:.2f}); "
           f"particles {their_err[0]:.2f} ({their_err[1]:.2f} to {their_err[2]:.2f}).",
           f"pfcourse minus particles: {(ours_means.mean() - their_means.mean()) / x_sd:.3f} exact sds, Welch 95 % "
           f"interval {diff_ci.low:.3f} to {diff_ci.high:.3f} (p = {diff.pvalue:.2f}), on {their_means.size} seeds each."],
    tables=[],
)

# %% [markdown]
# A second implementation: on a scalar model, the SMC² of Chopin's `particles` library has its
# posterior mean {glue:text}`particles_error:.2f` exact standard deviations from the exact one, on
# average over its seeds ({glue:text}`particles_error_low:.2f` to
# {glue:text}`particles_error_high:.2f`); the chapter's SMC² gives {glue:text}`pf_smc2_error:.2f`
# on the same data.
#
# The two differ by {glue:text}`pf_minus_particles:.2f`
# ({glue:text}`pf_minus_particles_low:.2f` to {glue:text}`pf_minus_particles_high:.2f`): their
# {glue:text}`particles_runs:d` seeds each do not separate them, and differences beyond that interval are excluded by the data.
#
# ## Exercises
#
# ```{exercise} 28.1 The sufficient-statistic step for a process-noise scale
# :label: ex-sp-storvik
# :nonumber:
# (Coding.) Another parameter: a scalar random walk $x_k = x_{k-1} + w_k$ whose process noise
# $w_k \sim \mathcal N(0, \vartheta)$ has an unknown variance, $\vartheta \sim \mathrm{IG}(a_0, b_0)$,
# read by $z_k = x_k + v_k$ with $v_k \sim \mathcal N(0, r)$, $r = 0.5$ known. Given the path,
# $\vartheta$ is again inverse gamma: find its statistic. Here $\vartheta$ enters the **move**, so it
# cannot simply be integrated out of the weight: write the step of {cite:t}`storvik2002`,
# `storvik_step(x, a, b, z, rng)`, that draws $\vartheta^i \sim \mathrm{IG}(a, b^i)$ for each particle
# ($\mathrm{IG}(a, b)$ is $b / \mathrm{Gamma}(a, 1)$; NumPy's `rng.gamma` takes a scale, not a rate),
# moves it, weights it by $\log \mathcal N(z; x', r)$, and updates the statistics. Return
# `(x_new, a_new, b_new, log_w)`; draw every random number from `rng`. The checker tests the law of
# your moves and names the mistake it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_storvik_step

r = 0.5


def storvik_step(x, a, b, z, rng):
    """Your step: (x_new, a_new, b_new, log_w)."""
    ...  # replace with your code


print(check_storvik_step(storvik_step))

# %% [markdown]
# ```{solution} ex-sp-storvik
# :class: dropdown
# Given the path, the moves $x_j - x_{j-1}$ are independent $\mathcal N(0, \vartheta)$, so
# $\vartheta \mid x_{0:k} \sim \mathrm{IG}(a_0 + k/2,\ b_0 + \sum_j (x_j - x_{j-1})^2 / 2)$: each step
# adds $1/2$ to $a$ and half the particle's squared move to its $b$. An inverse-gamma draw is
# $b / G$ with $G \sim \mathrm{Gamma}(a, 1)$. The code is in the folded cell below.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def storvik_step(x, a, b, z, rng):
    theta = b / rng.gamma(a, 1.0, x.shape)  # theta_i ~ IG(a, b_i)
    x_new = x + np.sqrt(theta) * rng.standard_normal(x.shape)
    log_w = -0.5 * (np.log(2 * np.pi * r) + (z - x_new) ** 2 / r)
    return x_new, a + 0.5, b + (x_new - x) ** 2 / 2, log_w


print(check_storvik_step(storvik_step))

# %% [markdown]
# ```{exercise} 28.2 Why not more jitter?
# :label: ex-sp-jitter
# :nonumber:
# A student replaces Liu and West's kernel by a plain jitter, $u^i \leftarrow u^i + h\, s_u\,
# \varepsilon^i$, with the same $h$. What happens to the spread of the cloud of $u$ over $K$ steps,
# and why does the shrinkage prevent it?
# ```
#
# ```{solution} ex-sp-jitter
# :class: dropdown
# Each jitter adds $h^2 s_u^2$ to the variance, so without new information the variance is
# multiplied by $1 + h^2$ at every step: over $K$ steps by $(1 + h^2)^K$, and the posterior is
# over-dispersed. Shrinking first multiplies the variance by $a^2$, and $a^2 + h^2 = 1$ keeps it.
# ```

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values(**GLUE)

# %% [markdown]
# ## Takeaways
#
# - A static parameter put into the state is never moved: the filter only re-weights the values drawn
#   from its prior, and the posterior it shows is a few spikes.
# - Liu and West's shrunk kernel keeps the cloud's mean and variance and separates the copies, but it
#   changes the model a little. Over {glue:text}`long_t:d` steps with $N = 1000$ its posterior
#   ends {glue:text}`lw_long_sd_ratio:.2f` times as wide as the exact one, and off centre;
#   five times more particles shrink the error, so here too $N$ must grow with the data.
# - When the parameter is conjugate given the path, each particle can carry a sufficient statistic
#   and integrate the parameter out (the sufficient-statistic filter): exact and cheap, but the statistics
#   degenerate with the paths, so $N$ must grow with the length of the data.
# - SMC² needs only a likelihood estimate: exact for every $N_x$, and the most expensive, because each
#   PMMH move re-runs the filters from the first step.
#
# :::{admonition} From the labs
# :class: dropdown
# The labs tune the noise levels a filter assumes by hand, from single runs ({doc}`../labs`), and
# the landmark lab asks what goes wrong with static landmarks and how to fix it. {doc}`likelihood`
# learns a noise level offline; this chapter learns it while the filter runs, and the cure for the
# static noise scale is the cure {doc}`../part1/sir` applies to the static landmarks.
# :::
