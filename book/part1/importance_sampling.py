# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Importance sampling, and a filter you write
#
# A particle filter is importance sampling done again at every step. This chapter shows the
# three facts the next chapters rely on, each measured on a one-dimensional problem whose
# answer is known exactly: the self-normalised estimator works, its accuracy is measured by
# the effective sample size, and the weights' variance grows with time and with dimension.
# Then it writes SIS and SIR in twenty lines of NumPy and checks them against the engine
# the rest of the book uses.
#
# ## The self-normalised estimator
#
# We want $\mathbb E_\pi[f(x)] = \int f(x)\, \pi(x)\, dx$ for a target $\pi$ known only up to
# a constant, $\pi(x) = \tilde\pi(x) / Z$ (a posterior: $\tilde\pi(x) = p(z \mid x)\, p(x)$,
# $Z = p(z)$). Draw $x^i \sim q$, any density that is positive where $\pi$ is, and weight:
#
# $$
# \tilde w^i = \frac{\tilde\pi(x^i)}{q(x^i)}, \qquad W^i = \frac{\tilde w^i}{\sum_j \tilde w^j},
# \qquad \widehat{\mathbb E_\pi f} = \sum_i W^i f(x^i), \qquad
# \hat Z = \frac1N \sum_i \tilde w^i .
# $$
#
# $\hat Z$ is unbiased; the ratio $\sum_i W^i f(x^i)$ is biased by $O(1/N)$ but consistent.
# With $q$ the prior, $\tilde w^i = p(z \mid x^i)$: the likelihood. Its accuracy is summarised
# by the **effective sample size** {cite:p}`kong1994`:
#
# $$
# \operatorname{Var}\big[\widehat{\mathbb E_\pi f}\big] \approx \frac{\operatorname{Var}_\pi(f)}{\mathrm{ESS}},
# \qquad \mathrm{ESS} = \frac{N}{1 + \operatorname{cv}^2(\tilde w)} \approx \frac{1}{\sum_i (W^i)^2},
# $$
#
# so $N$ weighted draws are worth ESS draws from $\pi$ itself. The toy: prior
# $x \sim \mathcal N(0, 1)$, one measurement $z = x + v$, $v \sim \mathcal N(0, r^2)$; the
# posterior is $\mathcal N\big(z/(1 + r^2),\ r^2/(1 + r^2)\big)$. We estimate its mean with
# $N = 100$ prior draws, {glue:text}`is_toy_reps:,d` times for each $r$ (same $z = 1$).

# %%
import matplotlib.pyplot as plt
import numpy as np
from myst_nb import glue
from scipy import stats
from scipy.special import logsumexp

from pfcourse import ParticleFilter
from pfcourse.exercises import check_resampler, check_weight_update
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.style import use_style

use_style()
rng = np.random.default_rng(0)
N, reps, z = 100, 2000, 1.0
print(f"{'r':>5} {'exact mean':>11} {'mean of estimates':>18} {'var of estimates':>17} "
      f"{'Var_pi / mean ESS':>18} {'ratio':>6} {'mean ESS':>9}")
kong, kong_ci = {}, {}
for r in (1.0, 0.3, 0.1):
    x = rng.standard_normal((reps, N))                      # x^i ~ q = prior
    log_w = stats.norm.logpdf(z, loc=x, scale=r)            # log w~ = log p(z | x)
    W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
    estimate = np.sum(W * x, axis=1)                        # sum_i W^i x^i
    ess = 1.0 / np.sum(W**2, axis=1)
    post_mean, post_var = z / (1 + r**2), r**2 / (1 + r**2)
    predicted = post_var / ess.mean()
    kong[r] = estimate.var(ddof=1) / predicted
    kong_ci[r] = stats.bootstrap(  # paired over the repetitions: the estimate and its mean ESS
        (estimate, ess), lambda e, w, axis: np.var(e, ddof=1, axis=axis) * np.mean(w, axis=axis) / post_var,
        paired=True, vectorized=True, n_resamples=2000, batch=200, method="percentile",
        random_state=np.random.default_rng(1)).confidence_interval
    print(f"{r:5.1f} {post_mean:11.4f} {estimate.mean():18.4f} {estimate.var(ddof=1):17.2e} "
          f"{predicted:18.2e} {kong[r]:6.2f} {ess.mean():9.1f}")
print(f"ratio, 95 % bootstrap interval over the {reps} repetitions: "
      + ", ".join(f"r = {r}: {ci.low:.2f}-{ci.high:.2f}" for r, ci in kong_ci.items()))
glue("kong_ratio_r1", float(kong[1.0]), display=False)
glue("kong_ratio_low_min", float(min(ci.low for ci in kong_ci.values())), display=False)
glue("kong_ratio_high_max", float(max(ci.high for ci in kong_ci.values())), display=False)
glue("kong_ratio_r01", float(kong[0.1]), display=False)
glue("kong_ess_r01", float(ess.mean()), display=False)
glue("is_toy_reps", reps, display=False)

# %% [markdown]
# The estimates are centred on the exact mean, and their variance follows
# $\operatorname{Var}_\pi / \mathrm{ESS}$ within a factor of two, on the safe side (ratio
# {glue:text}`kong_ratio_r1:.2f` at $r = 1$, {glue:text}`kong_ratio_r01:.2f` at $r = 0.1$, where
# the hundred draws are worth {glue:text}`kong_ess_r01:.1f` on average; the three 95 % bootstrap
# intervals lie between {glue:text}`kong_ratio_low_min:.2f` and {glue:text}`kong_ratio_high_max:.2f`). The ESS is a rule of
# thumb, not an identity: it looks at the weights only, not at the function $f$ being
# estimated. It is still the number the filters monitor, and a sharper likelihood leaves fewer
# effective draws.
#
# ## Sequentially: the weight recursion, and why it degenerates
#
# For a state sequence the target is $p(x_{0:k} \mid z_{1:k})$ and the proposal builds a path
# one step at a time, $q(x_{0:k}) = q(x_{0:k-1})\, q(x_k \mid x_{k-1}, z_k)$. The weight then
# updates by one factor per step:
#
# $$
# \tilde w_k^i = \tilde w_{k-1}^i\,
#   \frac{p(z_k \mid x_k^i)\, p(x_k^i \mid x_{k-1}^i)}{q(x_k^i \mid x_{k-1}^i, z_k)}
#   \quad\xrightarrow{\ q = p(x_k \mid x_{k-1})\ }\quad \tilde w_{k-1}^i\, p(z_k \mid x_k^i).
# $$
#
# A product of more and more random factors: the spread of $\log \tilde w$ grows with $k$,
# and the largest weight takes over. Measured on a random walk
# $x_k = x_{k-1} + w_k$, $w_k \sim \mathcal N(0, 0.1^2)$, seen as $z_k = x_k + v_k$,
# $v_k \sim \mathcal N(0, 0.5^2)$, $N = 1000$, {glue:text}`is_walk_runs:d` runs, with the squared coefficient of
# variation of the weights $\operatorname{cv}^2 = N \sum_i (W^i)^2 - 1 = N / \mathrm{ESS} - 1$.
# For dimension, $d$ independent copies of the first step: the weight is a product over
# coordinates.

# %%
n_runs, N, K, q_sd, r_sd = 200, 1000, 30, 0.1, 0.5
truth = np.cumsum(np.r_[[rng.standard_normal(n_runs)], rng.normal(0, q_sd, (K - 1, n_runs))], axis=0)
zs = truth + rng.normal(0, r_sd, truth.shape)
x = rng.standard_normal((n_runs, N))
log_w = np.full((n_runs, N), -np.log(N))
ess_k = np.empty((K, n_runs))
for k in range(K):
    if k > 0:
        x = x + rng.normal(0, q_sd, x.shape)
    log_w = log_w + stats.norm.logpdf(zs[k][:, None], x, r_sd)
    log_w -= logsumexp(log_w, axis=1, keepdims=True)
    ess_k[k] = 1.0 / np.exp(logsumexp(2 * log_w, axis=1))
cv2 = N / ess_k - 1

dims = np.array([1, 2, 4, 8, 16, 32])
ess_d = []
for d in dims:
    xd = rng.standard_normal((n_runs, N, d))
    zd = rng.standard_normal((n_runs, 1, d)) + rng.normal(0, r_sd, (n_runs, 1, d))
    lw = stats.norm.logpdf(zd, xd, r_sd).sum(axis=2)
    lw -= logsumexp(lw, axis=1, keepdims=True)
    ess_d.append(1.0 / np.exp(logsumexp(2 * lw, axis=1)))
ess_d = np.array(ess_d)
rho = np.exp(np.polyfit(dims[:4], np.log(np.median(ess_d[:4], axis=1) / N), 1)[0])

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7, 3.0))
ax1.semilogy(np.arange(K), np.median(cv2, axis=1), color="tab:red", label="median")
ax1.fill_between(np.arange(K), *np.percentile(cv2, [10, 90], axis=1), color="tab:red", alpha=0.2,
                 label="10-90 %")
ax1.set_xlabel("time step k")
ax1.set_ylabel(r"cv$^2$ of the weights")
ax1.set_title(f"SIS, N = {N}, {n_runs} runs", fontsize=10)
ax1.legend(fontsize=8)
ax2.semilogy(dims, np.median(ess_d, axis=1) / N, "o-", color="tab:blue", label="median")
ax2.fill_between(dims, *np.percentile(ess_d, [10, 90], axis=1) / N, color="tab:blue", alpha=0.2)
ax2.semilogy(dims, rho**dims, ":", color="gray", label=rf"$\rho^d$, $\rho$ = {rho:.2f}")
ax2.axhline(1 / N, color="black", lw=0.8, ls="--", label="ESS = 1")
ax2.set_ylim(3e-4, 1.5)
ax2.set_xlabel("dimension d")
ax2.set_ylabel("ESS / N after one step")
ax2.set_title(f"one step, N = {N}, {n_runs} runs", fontsize=10)
ax2.legend(fontsize=8)
fig.tight_layout()
plt.show()
print("median ESS at k = 0, 5, 10, 29:", np.round(np.median(ess_k[[0, 5, 10, 29]], axis=1), 1))
print("median ESS/N after one step for d =", dims.tolist(), ":", np.round(np.median(ess_d, axis=1) / N, 4).tolist())
glue("is_ess_k0", float(np.median(ess_k[0])), display=False)
glue("is_ess_k29", float(np.median(ess_k[-1])), display=False)
glue("is_rho", float(rho), display=False)
glue("is_ess_d32", float(np.median(ess_d[-1])), display=False)
glue("is_walk_runs", n_runs, display=False)

# %% [markdown]
# The median ESS falls from {glue:text}`is_ess_k0:.0f` at the first measurement to
# {glue:text}`is_ess_k29:.1f` thirty steps later: the weights' variance grows steadily, the
# degeneracy {doc}`sis` meets on the landmark model. In dimension $d$ the one-step ESS
# shrinks geometrically, about $\rho^d$ with $\rho$ = {glue:text}`is_rho:.2f` per coordinate
# (fitted on $d \le 8$) until it reaches its floor of one particle; at $d = 32$ the median is
# {glue:text}`is_ess_d32:.1f` particle out of a thousand. Both are reasons to sample as few coordinates as possible, which is what the
# Rao-Blackwellised filter of {doc}`rao_blackwell` does.
#
# (write-sis)=
# ## SIS and SIR in twenty lines
#
# Here is the whole filter of the next two chapters, for a linear-Gaussian model, with the
# weights in the log domain. `threshold = 0` never resamples (SIS); `threshold = 1/3`
# resamples when the ESS falls below $N/3$ (SIR, the lab's choice), by systematic
# resampling ({doc}`resampling_schemes`).

# %%
def my_filter(Z, N, rng, model, threshold=0.0):
    """SIS (threshold 0) or SIR with the prior as proposal; returns means (K, d) and ESS (K,)."""
    F, B, H, R = model.F, model.B, model.H, model.R
    x = model.m0 + rng.standard_normal((N, model.dim_x)) @ np.linalg.cholesky(model.P0).T
    log_W = np.full(N, -np.log(N))
    means, esss = [], []
    for k, z in enumerate(Z):
        if k > 0:  # propose from the prior: x_k = F x_{k-1} + B + w_k
            x = x @ F.T + B + rng.standard_normal(x.shape) @ np.linalg.cholesky(model.Q).T
        seen = ~np.isnan(z)
        if seen.any():  # weight: log W += log N(z_k; H_k x, R_k), then normalise
            log_W = log_W + stats.multivariate_normal(cov=R[np.ix_(seen, seen)]).logpdf(z[seen] - x @ H[seen].T)
            log_W = log_W - logsumexp(log_W)
        W = np.exp(log_W)
        means.append(W @ x)
        esss.append(1.0 / np.sum(W**2))
        if esss[-1] < threshold * N:  # resample: systematic, one uniform shared by all
            u = (np.arange(N) + rng.random()) / N
            x = x[np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), N - 1)]
            log_W = np.full(N, -np.log(N))
    return np.array(means), np.array(esss)


scenario = quadrant_scenario()
model = scenario.model()
sim = simulate(scenario, rng=2024)
ROUND_OFF = 1e-12  # the differences are sums of last-bit roundings: print the bound, not the digits
for name, theta in (("SIS", 0.0), ("SIR", 1 / 3)):
    mine_mean, mine_ess = my_filter(sim.measurements, 100, np.random.default_rng(1), model, theta)
    engine = ParticleFilter(model, 100, threshold=theta).run(sim.measurements, rng=1)
    same = np.abs(mine_mean - engine.mean).max() < ROUND_OFF and np.abs(mine_ess - engine.ess).max() < ROUND_OFF
    print(f"{name}, N = 100, same seed: means and ESS equal to the engine's within {ROUND_OFF:.0e}: {same}; "
          f"final ESS {mine_ess[-1]:.2f} vs {engine.ess[-1]:.2f}")
glue("mine_vs_engine_bound", ROUND_OFF, display=False)

# %% [markdown]
# The same random numbers in the same order give the engine's numbers to round-off
# (the means and the ESS of both SIS and SIR differ by less than
# {glue:text}`mine_vs_engine_bound:.0e`: the order of a few floating-point operations differs).
# The engine adds what a course needs beyond these lines: named errors that give the step
# when something goes wrong, other proposals and resampling schemes, compiled loops for a
# million particles, and the stored clouds that the figures draw.
#
# (log-domain)=
# ## Why the log domain: measured
#
# The lab multiplied the weights by the likelihoods themselves and normalised at each step.
# That fails when every particle's likelihood underflows to zero at once (below about
# $e^{-745}$ in double precision): the weights become $0/0$. The function below is the SIS
# of `my_filter` in the linear domain, and reports whether that happened. We run it on
# {glue:text}`linear_runs:d` simulations of the lab's model ($N = 100$) with the lab's measurement
# noise (sd $0.1$ m) and with a ten times sharper one (sd $0.01$ m, simulator and filter alike).

# %%
def linear_sis_fails(Z, N, rng, model):
    """SIS with linear-domain weights W <- W p(z | x) / sum; True if they all underflow to 0."""
    x = model.m0 + rng.standard_normal((N, model.dim_x)) @ np.linalg.cholesky(model.P0).T
    W = np.full(N, 1.0 / N)
    for k, z in enumerate(Z):
        if k > 0:
            x = x @ model.F.T + model.B + rng.standard_normal(x.shape) @ np.linalg.cholesky(model.Q).T
        seen = ~np.isnan(z)
        if seen.any():
            W = W * stats.multivariate_normal(cov=model.R[np.ix_(seen, seen)]).pdf(z[seen] - x @ model.H[seen].T)
            if W.sum() == 0.0:
                return True
            W = W / W.sum()
    return False


n_runs = 100
failures = {}
for sd in (0.1, 0.01):
    sc = scenario.with_(Rv=sd**2 * np.eye(4))
    m = sc.model()
    failures[sd] = sum(linear_sis_fails(simulate(sc, rng=s).measurements, 100, np.random.default_rng(10**6 + s), m)
                       for s in range(n_runs))
    ci = stats.binomtest(failures[sd], n_runs).proportion_ci(method="wilson")
    print(f"measurement sd {sd} m: linear-domain weights fail in {failures[sd]} of {n_runs} runs "
          f"(95 % Wilson interval {ci.low:.0%}-{ci.high:.0%})")
    glue(f"linear_fail_sd{str(sd).replace('.', '')}", int(failures[sd]), display=False)
    glue(f"linear_fail_sd{str(sd).replace('.', '')}_low", float(ci.low), display=False)
    glue(f"linear_fail_sd{str(sd).replace('.', '')}_high", float(ci.high), display=False)
glue("linear_runs", n_runs, display=False)

# %% [markdown]
# With the lab's noise the linear-domain weights survive ({glue:text}`linear_fail_sd01` of
# {glue:text}`linear_runs:d` runs fail; 95 % Wilson interval up to {glue:text}`linear_fail_sd01_high:.0%`): the
# lab could not have seen the problem. With a $1$ cm sensor they fail in
# {glue:text}`linear_fail_sd001` of {glue:text}`linear_runs:d` runs (interval {glue:text}`linear_fail_sd001_low:.0%`
# to {glue:text}`linear_fail_sd001_high:.0%`). The log-domain update of `my_filter` cannot fail
# this way: subtracting the largest log-weight before exponentiating keeps the best particle
# at weight $e^0$.
#
# ## Exercises
#
# ```{exercise}
# :label: ex-is-weights
# (Coding.) Write `update(log_W, log_lik)` returning the normalised log-weights
# $\log W^i + \log p(z \mid x^i) - \operatorname{logsumexp}_j(\cdot)$ and check it with
# `pfcourse.exercises.check_weight_update(update)`. Then write the linear-domain version
# `np.log(np.exp(log_W) * np.exp(log_lik) / ...)` and read what the check says about it.
# ```
#
# ```{solution} ex-is-weights
# :class: dropdown
# The linear-domain version fails the case whose likelihoods are near $e^{-1000}$: they
# underflow to $0$, the sum is $0$ and the weights are NaN. The log-domain one passes:
# ```

# %% tags=["hide-input"]
def update(log_W, log_lik):
    a = log_W + log_lik
    return a - logsumexp(a)


def update_linear(log_W, log_lik):
    w = np.exp(log_W) * np.exp(log_lik)
    return np.log(w / w.sum())


print(check_weight_update(update))
print(check_weight_update(update_linear))

# %% [markdown]
# ```{exercise}
# :label: ex-is-resampler
# (Coding.) Write a systematic resampler `resample(W, rng)` returning $N$ ancestor indices,
# and check it with `pfcourse.exercises.check_resampler(resample)`. Then try the tempting
# shortcut "copy particle $i$ round$(N W^i)$ times" and read what the check says.
# ```
#
# ```{solution} ex-is-resampler
# :class: dropdown
# The systematic resampler is the one inside `my_filter` above. The rounding shortcut is
# biased (a particle with $N W^i = 0.35$ never survives, though it should once in three
# draws on average) and never random; the check says so:
# ```

# %% tags=["hide-input"]
def resample(W, rng):
    u = (np.arange(len(W)) + rng.random()) / len(W)
    return np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), len(W) - 1)


def rounding(W, rng):
    idx = np.repeat(np.arange(len(W)), np.round(len(W) * W).astype(int))
    return np.resize(idx, len(W))


print(check_resampler(resample))
print(check_resampler(rounding))

# %% [markdown]
# ```{exercise}
# :label: ex-is-ess
# Show that $1/\sum_i (W^i)^2 = N / (1 + \operatorname{cv}^2)$ where $\operatorname{cv}^2$ is
# the squared coefficient of variation of the unnormalised weights over the $N$ draws.
# ```
#
# ```{solution} ex-is-ess
# :class: dropdown
# With $\bar w = \frac1N \sum_i \tilde w^i$ and $W^i = \tilde w^i / (N \bar w)$,
# $\sum_i (W^i)^2 = \frac{1}{N^2 \bar w^2} \sum_i (\tilde w^i)^2
# = \frac1N \cdot \frac{\frac1N \sum_i (\tilde w^i)^2}{\bar w^2} = \frac{1 + \operatorname{cv}^2}{N}$,
# since $\frac1N \sum_i (\tilde w^i)^2 = \bar w^2 (1 + \operatorname{cv}^2)$.
# ```
