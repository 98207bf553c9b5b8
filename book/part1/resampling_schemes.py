# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Resampling schemes
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** the four ways of drawing the resampled cloud (multinomial, residual, stratified,
# systematic) as one picture, uniforms against the cumulative weights; how much randomness each
# adds, measured against its closed form; and how to test a resampler, on a library that fails.
#
# **You need** {doc}`sir`; the binomial and multinomial distributions; NumPy's `cumsum` and
# `searchsorted`.
#
# **Time:** about fourteen minutes to read, plus about seventeen minutes for the folded blocks; the exercises are extra.
# :::
#
# ## The idea: one picture, four ways of drawing the uniforms
#
# Resampling replaces a weighted cloud by an unweighted one. Everything in this chapter happens
# at one step, so we drop the step from the notation: $W_i$ is particle $i$'s normalised weight
# ($W_k^i$ of {doc}`sir`), $N$ the number of particles before resampling and $n$ the number
# drawn. Lay the weights end to end on the
# bar $[0, 1)$: particle $i$ owns a segment of length $W_i$. Throw $n$ uniforms on the bar;
# each picks the particle whose segment it falls in. The figure shows eight particles and
# four ways of throwing the uniforms (the ticks above each bar). Multinomial uniforms are
# independent, so they may cluster and leave a heavy particle without offspring; stratified
# resampling puts one uniform in each eighth of the bar; systematic resampling uses one
# offset for all eight, evenly spaced. Residual resampling first gives $\lfloor 8 W_i \rfloor$
# sure copies and draws only the rest from the leftover weights (lower bar). Each scheme's
# uniforms come from its own generator seeded with $7$, as in the code further down.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
import timeit

import filterpy.monte_carlo as fp
import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from IPython.display import display

from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.panels import control_panel, scheme_dropdown, seed_box
from pfcourse.resampling import SCHEMES
from pfcourse.book.style import use_style

use_style()
SCHEME_COLORS = dict(zip(SCHEMES, ("tab:blue", "tab:orange", "tab:green", "tab:purple")))

# %% tags=["hide-input"] jupyter={"source_hidden": true}
w8 = np.array([0.04, 0.21, 0.02, 0.30, 0.08, 0.15, 0.05, 0.15])
n8 = len(w8)
edges = np.concatenate([[0.0], np.cumsum(w8)])
cmap = plt.get_cmap("tab10")
draws = {
    "multinomial": np.random.default_rng(7).random(n8),
    "stratified": (np.arange(n8) + np.random.default_rng(7).random(n8)) / n8,
    "systematic": (np.arange(n8) + np.random.default_rng(7).random()) / n8,
}
copies = np.floor(n8 * w8).astype(int)
R = n8 - copies.sum()
resid = (n8 * w8 - copies) / R
fig, ax = plt.subplots(figsize=(9, 3.8))
for row, (name, u) in enumerate(draws.items()):
    y = 3 - row
    for i in range(n8):
        ax.barh(y, w8[i], left=edges[i], height=0.35, color=cmap(i), alpha=0.6)
    ax.vlines(u, y + 0.2, y + 0.45, color="k", lw=1.5)
    if name != "multinomial":
        ax.vlines(np.arange(n8 + 1) / n8, y - 0.2, y + 0.2, color="k", lw=0.5, ls=":")
    counts = np.bincount(np.searchsorted(edges[1:], u, side="right"), minlength=n8)
    ax.text(1.02, y, f"{name}\ncopies {counts.tolist()}", va="center")
redges = np.concatenate([[0.0], np.cumsum(resid)])
u_res = np.random.default_rng(7).random(R)
for i in range(n8):
    ax.barh(0, resid[i], left=redges[i], height=0.35, color=cmap(i), alpha=0.6)
ax.vlines(u_res, 0.2, 0.45, color="k", lw=1.5)
extra = np.bincount(np.searchsorted(redges[1:], u_res, side="right"), minlength=n8)
ax.text(1.02, 0, f"residual: sure {copies.tolist()}\n+ drawn {extra.tolist()}", va="center")
ax.set_yticks([])
ax.set_xlim(0, 1.4)
ax.set_xticks(np.linspace(0, 1, 6))
ax.set_xlabel("cumulative weight (dimensionless)")
ax.set_title("Uniforms (ticks) falling on the cumulative weights of 8 particles")
plt.show()

# %% [markdown]
# Writing $N_i$ for the number of copies ("offspring") of particle $i$ among the $n$ new
# particles (a count, not to be confused with $N$), every scheme here is **unbiased**, $\mathbb E[N_i] = n W_i$, so the resampled
# cloud estimates the same expectations as the weighted one. They differ in how much
# randomness they add, measured by $\operatorname{Var} N_i$: that variance is the resampling
# step's own contribution, Monte Carlo noise added to the estimates that follow it
# {cite:p}`douc2005,hol2006`.
#
# In symbols, the bar is cut at the cumulative weights $C_i = W_1 + \dots + W_i$ ($C_0 = 0$),
# and a uniform $u \in [0, 1)$ selects the index $i$ with $C_{i-1} \le u < C_i$. The schemes
# differ only in the uniforms.
#
# :::{admonition} Algorithm 7.1: resampling by inverting the cumulative weights
# :class: algorithm
# Given normalised weights $W_1, \dots, W_N$ and the number $n$ of particles to draw:
# 1. **Cumulate:** $C_i = W_1 + \dots + W_i$ for $i = 1, \dots, N$.
# 2. **Draw the uniforms** $u^1, \dots, u^n$ in $[0, 1)$, by one of:
#    - *multinomial:* $u^j \sim \mathcal U[0, 1)$, independent of each other;
#    - *stratified:* $u^j = (j - 1 + U^j)/n$ with $U^j \sim \mathcal U[0, 1)$ independent, one uniform in each stratum;
#    - *systematic:* $u^j = (j - 1 + U)/n$ with one $U \sim \mathcal U[0, 1)$ for all $j$, evenly spaced;
#    - *residual:* first $\lfloor n W_i \rfloor$ sure copies of each particle, then
#      $n_\mathrm{r} = n - \sum_i \lfloor n W_i \rfloor$ multinomial uniforms on the
#      remainders $\rho_i = (n W_i - \lfloor n W_i \rfloor)/n_\mathrm{r}$, cumulated and inverted like the weights.
# 3. **Invert:** the ancestor $a^j$ is the $i$ with $C_{i-1} \le u^j < C_i$, that is `np.searchsorted(C, u, side="right")`,
#    capped at $N$ against round-off (a $C_N$ that ends just below $1$).
# 4. **Copy:** the $j$-th new particle is $x_{a^j}$, with weight $1/n$, for every $j$.
# :::
#
# (resampling-numpy)=
# ## The algorithm in NumPy, checked against the package
#
# Algorithm 7.1 in a few lines, for three of the schemes, drawing $n = N$ particles (the
# stratified one, for any $n$, is Exercise 7.3): one function inverts the cumulative weights, and each scheme only makes its
# uniforms.

# %%
import numpy as np


def invert(W, u):
    """Step 3: the i with C_{i-1} <= u < C_i for each u (sorted indices)."""
    C = np.cumsum(W)
    i = np.searchsorted(C, np.sort(u), side="right")
    return np.minimum(i, len(W) - 1)


def my_multinomial(W, rng):
    return invert(W, rng.random(len(W)))


def my_systematic(W, rng):
    n = len(W)
    return invert(W, (np.arange(n) + rng.random()) / n)


def my_residual(W, rng):
    n = len(W)
    sure = np.floor(n * W).astype(int)  # sure copies
    n_r = n - sure.sum()  # copies left to draw
    rho = (n * W - sure) / max(n_r, 1)  # remainders, sum one
    drawn = invert(rho, rng.random(n_r))
    extra = np.bincount(drawn, minlength=n)
    return np.repeat(np.arange(n), sure + extra)


W = np.array([0.04, 0.21, 0.02, 0.30, 0.08, 0.15, 0.05, 0.15])
print(my_systematic(W, np.random.default_rng(7)))

# %% [markdown]
# The package's functions in `pfcourse.resampling` draw the same uniforms from the same
# generator, so with the same seed they must return the same indices; they do, for every one
# of {glue:text}`numpy_seeds:d` seeds. The package adds checks of the weights, an `n` different
# from $N$, and a single merge pass over the sorted uniforms instead of a binary search for each.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
mine = {"multinomial": my_multinomial, "systematic": my_systematic, "residual": my_residual}
W_test = np.random.default_rng(3).lognormal(0.0, 1.0, 50)
W_test /= W_test.sum()
n_seeds = 200
same = {name: all(np.array_equal(mine[name](W_test, np.random.default_rng(s)),
                                 SCHEMES[name](W_test, np.random.default_rng(s))) for s in range(n_seeds))
        for name in mine}
assert all(same.values())
glue_values(numpy_seeds=n_seeds)
# %% [markdown]
# ## How much randomness each scheme adds
#
# Counting the uniforms that fall on particle $i$'s segment gives each scheme's
# $\operatorname{Var} N_i$:
#
# | scheme | $\operatorname{Var} N_i$ |
# |---|---|
# | multinomial | $n W_i (1 - W_i)$ |
# | stratified | $\sum_j p_{ij}(1 - p_{ij})$ |
# | systematic | $\delta_i (1 - \delta_i)$, $\delta_i = n W_i - \lfloor n W_i \rfloor$ |
# | residual | $n_\mathrm{r}\, \rho_i (1 - \rho_i)$ |
#
# Here $p_{ij} = n\,\lvert [(j-1)/n, j/n) \cap [C_{i-1}, C_i) \rvert$ is the chance that the
# uniform of stratum $j$ lands on particle $i$: for stratified resampling $N_i$ is a sum of
# independent Bernoulli variables, one per stratum, hence its variance. Multinomial counts are
# binomial; systematic counts are $\lfloor n W_i \rfloor$ or one more (Exercise 7.1).
#
# A lower $\operatorname{Var} N_i$ does not by itself order the filters' estimator variances:
# residual and stratified resampling provably add no more conditional variance than
# multinomial resampling, but systematic resampling, whose counts are the least variable
# here, can give a larger estimator variance than multinomial resampling on some weights,
# since its counts are correlated across particles {cite:p}`douc2005`.
#
# %% [markdown]
# ### Measured against the closed forms
#
# For a fixed set of $n = 50$ weights (drawn once, fairly uneven: effective sample size
# $\mathrm{ESS} = 1 / \sum_i W_i^2$, as in {doc}`sir`,
# {glue:text}`weights_ess:.1f`), each scheme is run {glue:text}`n_reps:d` times, one seed each
# (seeds $0, 1, 2, \dots$), and each particle's copies are counted.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
n = 50
w = np.random.default_rng(3).lognormal(0.0, 1.0, n)
w /= w.sum()
n_reps = 10_000
counts = {name: np.array([np.bincount(f(w, np.random.default_rng(s)), minlength=n) for s in range(n_reps)])
          for name, f in SCHEMES.items()}  # (repetition, particle)

C = np.concatenate([[0.0], np.cumsum(w)])
lo_j, hi_j = np.arange(n) / n, np.arange(1, n + 1) / n
overlap = np.clip(np.minimum(hi_j[None], C[1:, None]) - np.maximum(lo_j[None], C[:-1, None]), 0, None)
p_ij = n * overlap  # (particle, stratum)
r = n * w - np.floor(n * w)
R = n - np.floor(n * w).sum()
closed = {
    "multinomial": n * w * (1 - w),
    "stratified": (p_ij * (1 - p_ij)).sum(axis=1),
    "systematic": r * (1 - r),
    "residual": R * (r / R) * (1 - r / R),
}
measured = {name: counts[name].var(axis=0, ddof=1) for name in SCHEMES}

fig, axes = plt.subplots(1, 4, figsize=(10, 3.3), sharex=True, sharey=True, layout="constrained")
for ax, name in zip(axes, SCHEMES):
    ax.plot(closed[name], measured[name], "o", ms=3, color=SCHEME_COLORS[name])
    ax.plot([0, 4], [0, 4], "k:", lw=1)
    ax.set_title(name)
    ax.set_xlabel(r"closed-form Var $N_i$")
axes[0].set_ylabel(r"measured Var $N_i$")
fig.suptitle(f"Each dot: one of {n} particles; {n_reps} resamplings per scheme")
plt.show()

# %% [markdown]
# The dots sit on the diagonal: every particle of every scheme is within
# {glue:text}`var_z_max:.1f` standard errors of its closed form. Multinomial resampling adds
# {glue:text}`multinomial_var_factor_min:.1f` to {glue:text}`multinomial_var_factor_max:.1f`
# times more offspring variance in total than the others; systematic has the smallest total,
# and never more than $1/4$ for any particle.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
n_batches = 20
z_scores = {}
for name in SCHEMES:
    batch_var = counts[name].reshape(n_batches, -1, n).var(axis=1, ddof=1)
    se = batch_var.std(axis=0, ddof=1) / np.sqrt(n_batches)
    z_scores[name] = np.divide(measured[name] - closed[name], se, out=np.zeros(n), where=se > 0)
ratio_to_multinomial = [closed["multinomial"].sum() / closed[m].sum() for m in SCHEMES if m != "multinomial"]
n_beyond = sum(int(np.sum(np.abs(z) > 2)) for z in z_scores.values())
glue_values(weights_ess=1 / np.sum(w**2), n_reps=n_reps, n_weights=n,
            var_z_max=max(np.abs(z).max() for z in z_scores.values()), var_z_beyond2=n_beyond,
            var_z_count=n * len(SCHEMES), multinomial_var_factor_min=min(ratio_to_multinomial),
            multinomial_var_factor_max=max(ratio_to_multinomial))
EvidenceBlock(
    "the measured offspring variances are the closed forms",
    notes=[f"{n} weights, lognormal (sd 1 of the log), ESS {1 / np.sum(w**2):.1f}; {n_reps} resamplings per "
           f"scheme, seeds 0 to {n_reps - 1}, the same for every scheme.",
           f"z: each particle's measured variance minus its closed form, divided by its standard error (the "
           f"spread of the variance over {n_batches} batches of {n_reps // n_batches} resamplings). Over the "
           f"{n * len(SCHEMES)} particle-scheme pairs, {n_beyond} lie beyond |z| = 2, where chance puts about "
           f"5 % ({0.05 * n * len(SCHEMES):.0f}). The closed forms are exact, so the comparison of the schemes' "
           "totals needs no test (see Reading the evidence).",
           "Unbiasedness: the largest |mean N_i - n W_i| over the particles is in the last column, against a "
           f"largest standard error sqrt(Var N_i / repetitions) of "
           f"{np.sqrt(max(measured[m].max() for m in SCHEMES) / n_reps):.3f} copies."],
    tables=[("Offspring counts per scheme", pd.DataFrame({
        "scheme": list(SCHEMES),
        "sum of Var N_i, measured": [measured[m].sum() for m in SCHEMES],
        "sum of Var N_i, closed form": [closed[m].sum() for m in SCHEMES],
        "largest |z|": [np.abs(z_scores[m]).max() for m in SCHEMES],
        "particles beyond |z| = 2": [int(np.sum(np.abs(z_scores[m]) > 2)) for m in SCHEMES],
        "largest |mean N_i - n W_i|": [np.abs(counts[m].mean(axis=0) - n * w).max() for m in SCHEMES]}),
        {"sum of Var N_i, measured": ".2f", "sum of Var N_i, closed form": ".2f", "largest |z|": ".1f",
         "largest |mean N_i - n W_i|": ".3f"})],
)
# %% [markdown]
# ## Variance of the resampled estimate
#
# What matters for the filter is the noise resampling adds to estimates. Take particle
# positions $x_i$ (here $x_i = i / n$) and the estimate of the mean after resampling,
# $\hat\mu = \frac1n \sum_i N_i x_i$, whose variance is $\frac{1}{n^2} x^\top \operatorname{Cov}(N) x$.
# Closed forms: multinomial $\frac1n \operatorname{Var}_W(x)$; residual
# $\frac{n_\mathrm{r}}{n^2} \operatorname{Var}_\rho(x)$; stratified $\frac{1}{n^2}\sum_j \operatorname{Var}(x \mid \text{stratum } j)$
# (strata are independent). Systematic has no simple general formula, but $N$ depends on the
# single offset $U$ only, so we integrate over $U$ numerically ($20\,000$ values of $U$).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
x = np.arange(n) / n
rho = r / R
U = (np.arange(20_000) + 0.5) / 20_000
idx = np.searchsorted(C[1:-1], (np.arange(n)[None] + U[:, None]) / n, side="right")  # (U, j): systematic


def estimate_variances(xs):
    """Var(mu_hat) of every scheme from the closed forms (systematic: integrated over U) for positions xs."""
    m = w @ xs
    return {"multinomial": (w @ xs**2 - m**2) / n,
            "residual": R / n**2 * (rho @ xs**2 - (rho @ xs) ** 2),
            "stratified": ((p_ij * xs[:, None] ** 2).sum(axis=0) - (p_ij * xs[:, None]).sum(axis=0) ** 2).sum() / n**2,
            "systematic": xs[idx].mean(axis=1).var()}


theory = estimate_variances(x)
mu_hats = {name: counts[name] @ x / n for name in SCHEMES}
estimate_var = {name: mu_hats[name].var(ddof=1) for name in SCHEMES}
for name in SCHEMES:
    print(f"{name:12s} Var(mu_hat): measured {estimate_var[name]:.2e}, theory {theory[name]:.2e}")

# %% [markdown]
# The measured variances match theory (evidence below). Against multinomial resampling,
# residual resampling cuts the variance of this estimate by a factor of
# {glue:text}`residual_estimate_var_factor:.1f`, systematic resampling by
# {glue:text}`systematic_estimate_var_factor:.0f` and stratified resampling by
# {glue:text}`stratified_estimate_var_factor:.0f`: here $x_i$ increases with $i$, so
# neighbouring strata see neighbouring values, the case in which stratification helps most.
# Systematic resampling gains less than stratified here because its strata share one offset
# $U$: a large $U$ moves every stratum's pick to a larger $x_i$ at once, so its errors are
# positively correlated across strata and add up instead of cancelling.
#
# For positions that jump around with $i$ ($x_i$ drawn uniformly, once) the gains of stratified
# and systematic resampling are much smaller, factors of {glue:text}`jumpy_stratified_factor:.1f`
# and {glue:text}`jumpy_systematic_factor:.1f`, while residual resampling's, which does not
# depend on the order of the particles, stays about the same
# ({glue:text}`jumpy_residual_factor:.1f`).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
x_jumpy = np.random.default_rng(0).random(n)
jumpy = estimate_variances(x_jumpy)
jumpy_worst = max(jumpy[m] / jumpy["multinomial"] for m in SCHEMES if m != "multinomial")


def fourth_moment_se(mu_hat):
    """Standard error of a sample variance, from the sample's fourth central moment."""
    v = mu_hat.var(ddof=1)
    return np.sqrt(max(np.mean((mu_hat - mu_hat.mean()) ** 4) - v**2, 0) / mu_hat.size)


glue_values(**{f"{m}_estimate_var_factor": theory["multinomial"] / theory[m] for m in SCHEMES},
            **{f"jumpy_{m}_factor": jumpy["multinomial"] / jumpy[m] for m in SCHEMES})
EvidenceBlock(
    "the variance of the resampled mean follows the closed forms, and depends on the order of the particles",
    notes=[f"The same {n_reps} resamplings per scheme as above (seeds 0 to {n_reps - 1}). The standard error "
           "of a measured variance comes from the fourth central moment of the estimates.",
           "Jumpy positions: x = np.random.default_rng(0).random(n), from the closed forms only; the largest "
           f"ratio to multinomial over the other schemes is {jumpy_worst:.3f}"
           + (", so no scheme does worse than multinomial on these weights." if jumpy_worst < 1 else ".")],
    tables=[("Var of the resampled mean, x_i = i / n", pd.DataFrame({
        "scheme": list(SCHEMES),
        "measured": [estimate_var[m] for m in SCHEMES],
        "theory": [theory[m] for m in SCHEMES],
        "(measured - theory) / SE": [(estimate_var[m] - theory[m]) / fourth_moment_se(mu_hats[m]) for m in SCHEMES],
        "ratio to multinomial": [theory[m] / theory["multinomial"] for m in SCHEMES]}),
        {"measured": ".2e", "theory": ".2e", "(measured - theory) / SE": "+.1f", "ratio to multinomial": ".3f"}),
        ("Var of the resampled mean, jumpy positions (theory)", pd.DataFrame({
            "scheme": list(SCHEMES), "theory": [jumpy[m] for m in SCHEMES],
            "ratio to multinomial": [jumpy[m] / jumpy["multinomial"] for m in SCHEMES]}),
         {"theory": ".2e", "ratio to multinomial": ".3f"})],
)
# %% [markdown]
# ## Run time against N
#
# Each scheme here costs a cumulative sum and one merge pass of sorted uniforms along it
# (`pfcourse.kernels.inverse_cdf_sorted`), $O(n)$: stratified and systematic uniforms are
# born sorted, multinomial resampling sorts its $n$ uniforms first ($O(n \log n)$), and
# residual resampling sorts only the uniforms of its random remainder. The figure shows, for
# each size, the fastest of $7$ timings after a warm-up call, each timing averaged over enough
# calls to last about a millisecond (timings vary between machines and runs, so only the
# figure is shown). Below about $n = 10^3$ the fixed cost of a call dominates. From $10^3$ to
# $10^5$ the time grows roughly in proportion to $n$ (the dotted line), as the operation count
# says. Beyond, on the machine that stored this figure, it grows faster: not more arithmetic but
# slower memory, as the arrays (megabytes long) outgrow the processor's caches, at a size that
# depends on the machine.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
sizes = [10**e for e in range(2, 7)]
times = {name: [] for name in SCHEMES}
for m in sizes:
    wm = np.random.default_rng(0).random(m)
    wm /= wm.sum()
    g = np.random.default_rng(1)
    for name, f in SCHEMES.items():
        f(wm, g)  # warm-up
        calls = max(1, 100_000 // m)
        best = min(timeit.repeat(lambda: f(wm, g), number=calls, repeat=7)) / calls
        times[name].append(best)
fig, ax = plt.subplots(figsize=(6, 3.6))
for name in SCHEMES:
    ax.loglog(sizes, times[name], "o-", color=SCHEME_COLORS[name], label=name)
ax.loglog(sizes, np.array(sizes) * times["systematic"][2] / sizes[2], "k:", label=r"$\propto n$")
ax.set_xlabel("number of particles n")
ax.set_ylabel("time per resampling (s)")
ax.set_title("Fastest of 7 timings per size")
ax.legend()
plt.show()

# %% [markdown]
# (resampling-filterpy)=
# ## Testing a resampler: filterpy's residual resampling is biased
#
# Unbiasedness, $\mathbb E[N_i] = n W_i$, is the property every scheme must have, and it can be
# tested: over many seeded resamplings of fixed weights, the mean number of copies of each
# particle must equal $n W_i$ within a few standard errors. `filterpy.monte_carlo.residual_resample`
# (version 2.0.0) fails it. It computes the leftover weights as `weights - num_copies` instead
# of `n * weights - num_copies`, so the leftover copies go almost only to the particles with
# sure copies: the light ones get too few, and the heaviest too many. Below, ten weights, {glue:text}`filterpy_reps:d`
# resamplings each (one seed each, from $0$ up; filterpy uses NumPy's global generator, which
# we seed).

# %% tags=["hide-input"] jupyter={"source_hidden": true}
w10 = np.array([0.31, 0.22, 0.15, 0.09, 0.08, 0.06, 0.04, 0.03, 0.015, 0.005])
reps = 20_000
ours = np.array([np.bincount(SCHEMES["residual"](w10, np.random.default_rng(s)), minlength=10)
                 for s in range(reps)])
theirs = []
for s in range(reps):
    np.random.seed(s)
    theirs.append(np.bincount(fp.residual_resample(w10), minlength=10))
theirs = np.array(theirs)

fig, ax = plt.subplots(figsize=(7, 3.2))
pos = np.arange(10)
ax.bar(pos - 0.2, ours.mean(axis=0), 0.4, color=SCHEME_COLORS["residual"], label="pfcourse residual")
ax.bar(pos + 0.2, theirs.mean(axis=0), 0.4, color="tab:gray", label="filterpy 2.0.0 residual_resample")
ax.plot(pos, 10 * w10, "k_", ms=20, mew=2, label=r"$n W_i$ (unbiased target)")
ax.set_xticks(pos, [f"{i + 1}" for i in pos])
ax.set_xlabel("particle i")
ax.set_ylabel("mean number of copies")
ax.set_title(f"Mean offspring over {reps} resamplings")
ax.legend()
plt.show()

# %% [markdown]
# Particles {glue:text}`filterpy_no_copy_first:d` to {glue:text}`filterpy_no_copy_last:d`
# ($n W_i < 1$) get {glue:text}`filterpy_no_copy_total:d` copies from filterpy's version in
# all the resamplings, where they should get $n W_i$ on average.
#
# That is {glue:text}`filterpy_no_copy_se_min:.0f` to {glue:text}`filterpy_no_copy_se_max:.0f`
# standard errors too few. Particle $3$ ($n W_i = 1.5$) gets too few as well,
# {glue:text}`filterpy_third_mean:.2f` copies on average.
#
# Only the {glue:text}`filterpy_too_many:d` heaviest get too many, up to
# {glue:text}`filterpy_residual_max_se:.0f` standard errors away. Inside a filter this is
# a systematic shrinking of the posterior towards its heaviest particles.
#
# `pfcourse.resampling.residual` matches $n W_i$ to within sampling error (largest deviation
# {glue:text}`pfcourse_residual_max_se:.1f` standard errors over the ten particles).

# %% tags=["remove-input"] jupyter={"source_hidden": true}
se = np.sqrt(np.maximum(ours.var(axis=0, ddof=1), 1e-12) / reps)
dev_ours, dev_theirs = (ours.mean(0) - 10 * w10) / se, (theirs.mean(0) - 10 * w10) / se
no_sure_copy = np.flatnonzero(10 * w10 < 1)
no_copy_se = np.abs(dev_theirs[no_sure_copy])
assert dev_theirs[2] < -3 and np.isclose(10 * w10[2], 1.5)
glue_values(filterpy_no_copy_se_min=no_copy_se.min(), filterpy_no_copy_se_max=no_copy_se.max(),
            filterpy_third_mean=theirs[:, 2].mean(), filterpy_too_many=int((dev_theirs > 3).sum()))
glue_values(filterpy_reps=reps, pfcourse_residual_max_se=np.abs(dev_ours).max(),
            filterpy_residual_max_se=np.abs(dev_theirs).max(), filterpy_no_copy_first=int(no_sure_copy[0] + 1),
            filterpy_no_copy_last=int(no_sure_copy[-1] + 1), filterpy_no_copy_total=int(theirs[:, no_sure_copy].sum()))
EvidenceBlock(
    "filterpy's residual resampling is biased, pfcourse's is not",
    notes=[f"{reps} resamplings of the ten weights per implementation, seeds 0 to {reps - 1} (pfcourse: a "
           "Generator per seed; filterpy: np.random.seed). Deviation in standard errors: (mean copies - n W_i) / SE, "
           "SE = sd of pfcourse's counts / sqrt(resamplings), the unbiased scheme's own spread "
           "(see Reading the evidence)."],
    tables=[("Mean copies per particle", pd.DataFrame({
        "particle": np.arange(1, 11), "n W_i": 10 * w10, "pfcourse mean": ours.mean(0), "pfcourse (SE)": dev_ours,
        "filterpy mean": theirs.mean(0), "filterpy (SE)": dev_theirs}),
        {"n W_i": ".3f", "pfcourse mean": ".3f", "pfcourse (SE)": "+.1f", "filterpy mean": ".3f",
         "filterpy (SE)": "+.0f"})],
)
# %% [markdown]
# ## Try it
#
# The panel resamples {glue:text}`n_weights:d` particles with the chosen scheme and seed, for weights of chosen
# unevenness, and shows each particle's offspring count against $n W_i$.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_offspring(scheme, spread, seed):
    ww = np.random.default_rng(3).lognormal(0.0, spread, n)
    ww /= ww.sum()
    got = np.bincount(SCHEMES[scheme](ww, np.random.default_rng(seed)), minlength=n)
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.bar(np.arange(n), got, color=SCHEME_COLORS[scheme], label=f"{scheme} copies")
    ax.plot(np.arange(n), n * ww, "k_", ms=8, mew=2, label=r"$n W_i$")
    ax.set_xlabel("particle i")
    ax.set_ylabel("number of copies")
    ax.legend()


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(draw_offspring, grid={"scheme": tuple(SCHEMES), "spread": (0.0, 1.0, 3.0)},
                      scheme=scheme_dropdown(),
                      spread=widgets.FloatSlider(value=1.0, min=0.0, max=3.0, step=0.1, description="log-weight sd"),
                      seed=seed_box(0)))

# %% [markdown]
# ## Exercises
#
# ```{exercise} 7.1 Systematic offspring counts
# :label: ex-resampling-systematic
# :nonumber:
# Show that with systematic resampling $N_i \in \{\lfloor n W_i \rfloor, \lfloor n W_i \rfloor + 1\}$,
# and deduce its variance.
# ```
#
# ```{solution} ex-resampling-systematic
# :class: dropdown
# The points $(j - 1 + U)/n$ are spaced exactly $1/n$ apart, so an interval of length $W_i$
# contains either $\lfloor n W_i \rfloor$ or $\lfloor n W_i \rfloor + 1$ of them. Since the
# mean is $n W_i$, the second happens with probability $\delta_i = n W_i - \lfloor n W_i \rfloor$:
# a Bernoulli($\delta_i$) on top of a constant, variance $\delta_i (1 - \delta_i) \le 1/4$.
# ```
#
# ```{exercise} 7.2 A test that catches the bug
# :label: ex-resampling-bias
# :nonumber:
# Design a test that would have caught filterpy's residual bug,
# using only the property that every scheme must satisfy.
# ```
#
# ```{solution} ex-resampling-bias
# :class: dropdown
# Unbiasedness: for fixed weights, the mean offspring count over many seeded resamplings
# must equal $n W_i$ within a few standard errors $\sqrt{\operatorname{Var} N_i / \text{reps}}$.
# Use weights with some $n W_i < 1$: filterpy gives them no copies in the run above,
# {glue:text}`filterpy_no_copy_se_min:.0f` to {glue:text}`filterpy_no_copy_se_max:.0f` standard
# errors too few.
# ```
#
# ```{exercise} 7.3 Stratified resampling to a new cloud size, and have it checked
# :label: ex-resampling-code
# :nonumber:
# (Coding.) A filter sometimes changes its number of particles, drawing $n$ new particles from
# $N$ weighted ones (more particles when the cloud is spread out, fewer when it is tight). The
# chapter's code always draws $n = N$, and not with the stratified scheme. Write
# `my_stratified(W, n, rng)`: $n$ strata, one independent uniform in each, drawn from the
# generator `rng` it is given, returning the $n$ ancestor indices as integers (each in
# $0, \dots, N - 1$). The checker draws $12$ particles from eight weights thousands of times. One
# particle's segment lies astride two strata, half in each, so stratified resampling gives it
# $0$, $1$ or $2$ copies while systematic resampling always gives it exactly one: the checker
# tells the schemes apart by that count's variance. It also checks the generator (same seed,
# same answer; another seed, another; NumPy's global generator untouched) and names what it sees.
# ```

# %% tags=["answer"]
from pfcourse.book.exercises import check_stratified_resampler


def my_stratified(W, n, rng):
    """Your stratified resampler: n ancestor indices (integers in [0, N))."""
    ...  # replace with your code


print(check_stratified_resampler(my_stratified))

# %% [markdown]
# ```{solution} ex-resampling-code
# :class: dropdown
# Algorithm 7.1 with $n$ strata of width $1/n$ and one uniform in each, `rng.random(n)`; the
# strata are cut by the number drawn, $n$, while the cumulative weights have $N$ entries. The
# code is in the folded cell below (in JupyterLab, click its margin to unfold it). Capping the
# index at $N - 1$ guards against a cumulative sum that ends just below $1$.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def my_stratified(W, n, rng):
    u = (np.arange(n) + rng.random(n)) / n
    i = np.searchsorted(np.cumsum(W), u, side="right")
    return np.minimum(i, len(W) - 1)


print("same as pfcourse.resampling.stratified:", all(
    np.array_equal(my_stratified(W_test, m, np.random.default_rng(s)),
                   SCHEMES["stratified"](W_test, np.random.default_rng(s), n=m))
    for s in range(n_seeds) for m in (30, 50, 80)))
print(check_stratified_resampler(my_stratified))

# %% [markdown]
# ## Takeaways
#
# - Every scheme inverts the cumulative weights; they differ only in how the uniforms are
#   drawn: independent (multinomial), one per stratum (stratified), evenly spaced
#   (systematic), or only for the remainders after the sure copies (residual).
# - All four are unbiased, $\mathbb E[N_i] = n W_i$; multinomial adds the most offspring
#   variance, and the closed forms of $\operatorname{Var} N_i$ match what is measured.
# - A smaller $\operatorname{Var} N_i$ is the resampling step's own noise, not a ranking of
#   the filters: the gains of stratified and systematic resampling both depend on the order of
#   the particles, and on ordered positions systematic resampling gains less than stratified
#   (its errors are positively correlated across strata); it has no general guarantee against
#   multinomial resampling.
# - Test a resampler for unbiasedness on weights with some $n W_i < 1$: filterpy's residual
#   resampling fails that test.
#
# :::{dropdown} From the labs
# The labs ask how a resampler can be tested. This chapter's answer is in
# {ref}`resampling-filterpy`: the unbiasedness test, on weights some of which get no sure
# copy, and the bias it finds in filterpy's residual resampling. {doc}`../labs` describes the labs.
# :::
