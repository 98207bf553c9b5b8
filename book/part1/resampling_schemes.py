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
# Resampling replaces a weighted cloud by an unweighted one. Writing $N_i$ for the number of
# copies ("offspring") of particle $i$ among the $n$ new particles, every scheme here is
# **unbiased**, $\mathbb E[N_i] = n W_i$, so the resampled cloud estimates the same
# expectations as the weighted one. They differ in how much randomness they add, measured by
# $\operatorname{Var} N_i$: that variance is the resampling step's own contribution, Monte Carlo
# noise added to the estimates that follow it {cite:p}`douc2005,hol2006`. A lower
# $\operatorname{Var} N_i$ does not by itself order the filters' estimator variances: residual
# and stratified resampling provably add no more conditional variance than multinomial
# resampling, but systematic resampling, whose offspring counts are the least variable here,
# can give a larger estimator variance than multinomial resampling on some weights, since its
# counts are correlated across particles {cite:p}`douc2005`. All four invert the cumulative
# weights $C_i = W_1 + \dots + W_i$: a uniform $u \in [0, 1)$ selects the index $i$ with
# $C_{i-1} \le u < C_i$. They differ only in the uniforms.
#
# | scheme | uniforms | $\operatorname{Var} N_i$ |
# |---|---|---|
# | multinomial | $u_k$ i.i.d. $\mathcal U[0,1)$ | $n W_i (1 - W_i)$ |
# | stratified | $u_k = (k + U_k)/n$, $U_k$ i.i.d. | $\sum_k p_{ik}(1 - p_{ik})$ |
# | systematic | $u_k = (k + U)/n$, one $U$ | $r_i (1 - r_i)$, $r_i = n W_i - \lfloor n W_i \rfloor$ |
# | residual | $\lfloor n W_i \rfloor$ sure copies, then $R$ multinomial draws on the remainders | $R\, \rho_i (1 - \rho_i)$, $\rho_i = r_i / R$ |
#
# Here $p_{ik} = n\,\lvert [k/n, (k+1)/n) \cap [C_{i-1}, C_i) \rvert$ is the chance that the
# uniform of stratum $k$ lands on particle $i$; $R = n - \sum_i \lfloor n W_i \rfloor$.
# For stratified resampling $N_i$ is a sum of independent Bernoulli variables, one per
# stratum, hence its variance.

# %%
import timeit

import filterpy.monte_carlo as fp
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import display
from myst_nb import glue

from pfcourse.style import COLORS, use_style
from pfcourse.resampling import SCHEMES
from pfcourse.figures.widgets import control_panel, scheme_dropdown, seed_box

use_style()
SCHEME_COLORS = dict(zip(SCHEMES, ("tab:blue", "tab:orange", "tab:green", "tab:purple")))

# %% [markdown]
# ## How each scheme maps uniforms to indices
#
# The bar is $[0, 1)$ cut into the cumulative weights of eight particles (the width of segment $i$
# is $W_i$); the ticks above it are the uniforms each scheme draws ($n = 8$), and each uniform
# picks the segment it falls in. Multinomial uniforms may cluster and leave a heavy particle
# without offspring; stratified puts one uniform in each eighth; systematic uses one offset
# for all eight, evenly spaced. Residual first gives $\lfloor 8 W_i \rfloor$ copies (the count
# on each segment) and draws only the remaining $R$ from the leftover weights (lower bar).

# %%
rng = np.random.default_rng(7)
w8 = np.array([0.04, 0.21, 0.02, 0.30, 0.08, 0.15, 0.05, 0.15])
n8 = len(w8)
edges = np.concatenate([[0.0], np.cumsum(w8)])
cmap = plt.get_cmap("tab10")
draws = {
    "multinomial": rng.random(n8),
    "stratified": (np.arange(n8) + rng.random(n8)) / n8,
    "systematic": (np.arange(n8) + rng.random()) / n8,
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
    ax.text(1.02, y, f"{name}\ncopies {counts.tolist()}", va="center", fontsize=8)
redges = np.concatenate([[0.0], np.cumsum(resid)])
u_res = rng.random(R)
for i in range(n8):
    ax.barh(0, resid[i], left=redges[i], height=0.35, color=cmap(i), alpha=0.6)
ax.vlines(u_res, 0.2, 0.45, color="k", lw=1.5)
extra = np.bincount(np.searchsorted(redges[1:], u_res, side="right"), minlength=n8)
ax.text(1.02, 0, f"residual: sure {copies.tolist()}\n+ drawn {extra.tolist()}", va="center", fontsize=8)
ax.set_yticks([])
ax.set_xlim(0, 1.4)
ax.set_xticks(np.linspace(0, 1, 6))
ax.set_xlabel("cumulative weight (dimensionless)")
ax.set_title("Uniforms (ticks) falling on the cumulative weights of 8 particles")
plt.show()

# %% [markdown]
# ## Offspring-count variance: measured against the closed forms
#
# For a fixed set of $n = 50$ weights (drawn once, fairly uneven: ESS
# {glue:text}`weights_ess:.1f`), each scheme is run {glue:text}`n_reps:d` times, one seed each
# (seeds $0, 1, 2, \dots$). The measured $\operatorname{Var} N_i$ should match the closed form
# of the table to within sampling error (the sample variance of $10^4$ draws has a relative
# standard error of about $\sqrt{2/10^4} \approx 1.4\,\%$ for Gaussian-like counts). Below
# the table, each particle's measured variance minus its closed form is divided by its standard
# error (from the spread of the variance over $20$ batches of $500$ resamplings): the largest
# of these $z$-scores over the $n$ particles, with the number of particles beyond $|z| = 2$
# (about $5\,\%$ of them expected).

# %%
n = 50
w = np.random.default_rng(3).lognormal(0.0, 1.0, n)
w /= w.sum()
n_reps = 10_000
counts = {name: np.array([np.bincount(f(w, np.random.default_rng(s)), minlength=n) for s in range(n_reps)])
          for name, f in SCHEMES.items()}

C = np.concatenate([[0.0], np.cumsum(w)])
lo_k, hi_k = np.arange(n) / n, np.arange(1, n + 1) / n
overlap = np.clip(np.minimum(hi_k[None], C[1:, None]) - np.maximum(lo_k[None], C[:-1, None]), 0, None)
p_ik = n * overlap  # (particle, stratum)
r = n * w - np.floor(n * w)
R = n - np.floor(n * w).sum()
closed = {
    "multinomial": n * w * (1 - w),
    "stratified": (p_ik * (1 - p_ik)).sum(axis=1),
    "systematic": r * (1 - r),
    "residual": R * (r / R) * (1 - r / R),
}
print(f"ESS of the weights: {1 / np.sum(w**2):.1f}")
glue("weights_ess", float(1 / np.sum(w**2)), display=False)
glue("n_reps", n_reps, display=False)
glue("n_weights", n, display=False)
print(f"{'scheme':12s} {'sum Var N_i measured':>21s} {'closed form':>12s} {'max |E N_i - n W_i|':>20s}")
for name in SCHEMES:
    v = counts[name].var(axis=0, ddof=1)
    bias = np.abs(counts[name].mean(axis=0) - n * w).max()
    print(f"{name:12s} {v.sum():21.2f} {closed[name].sum():12.2f} {bias:20.3f}")
z_max, n_beyond, n_batches = {}, 0, 20
for name in SCHEMES:
    v = counts[name].var(axis=0, ddof=1)
    batch_var = counts[name].reshape(n_batches, -1, n).var(axis=1, ddof=1)
    se = batch_var.std(axis=0, ddof=1) / np.sqrt(n_batches)
    z = np.divide(v - closed[name], se, out=np.zeros(n), where=se > 0)
    z_max[name] = float(np.abs(z).max())
    n_beyond += int(np.sum(np.abs(z) > 2))
    print(f"{name:12s} measured - closed form, in standard errors: largest |z| {z_max[name]:.1f}, "
          f"{int(np.sum(np.abs(z) > 2))} of {n} particles beyond 2")
glue("var_z_max", max(z_max.values()), display=False)
glue("var_z_beyond2", n_beyond, display=False)
glue("var_z_count", n * len(SCHEMES), display=False)
glue("multinomial_var_factor_min", float(min(closed["multinomial"].sum() / closed[m].sum()
                                             for m in SCHEMES if m != "multinomial")), display=False)
glue("multinomial_var_factor_max", float(max(closed["multinomial"].sum() / closed[m].sum()
                                             for m in SCHEMES if m != "multinomial")), display=False)

# %%
fig, axes = plt.subplots(1, 4, figsize=(10, 3.3), sharex=True, sharey=True, layout="constrained")
for ax, name in zip(axes, SCHEMES):
    ax.plot(closed[name], counts[name].var(axis=0, ddof=1), "o", ms=3, color=SCHEME_COLORS[name])
    ax.plot([0, 4], [0, 4], "k:", lw=1)
    ax.set_title(name)
    ax.set_xlabel(r"closed-form Var $N_i$")
axes[0].set_ylabel(r"measured Var $N_i$")
fig.suptitle(f"Each dot: one of {n} particles; {n_reps} resamplings per scheme")
plt.show()

# %% [markdown]
# The dots sit on the diagonal: the measured variances are the closed forms, every particle
# of every scheme within {glue:text}`var_z_max:.1f` standard errors, and
# {glue:text}`var_z_beyond2:d` of the {glue:text}`var_z_count:d` beyond two, about the
# $5\,\%$ that chance gives. Multinomial resampling adds
# {glue:text}`multinomial_var_factor_min:.1f` to {glue:text}`multinomial_var_factor_max:.1f`
# times more offspring variance in total than the others (closed forms, sums above);
# systematic has the smallest total, and never more than $1/4$ for any particle.
#
# ## Variance of the resampled estimate
#
# What matters for the filter is the noise resampling adds to estimates. Take particle
# positions $x_i$ (here $x_i = i / n$) and the estimate of the mean after resampling,
# $\hat\mu = \frac1n \sum_i N_i x_i$, whose variance is $\frac{1}{n^2} x^\top \operatorname{Cov}(N) x$.
# Closed forms: multinomial $\frac1n \operatorname{Var}_W(x)$; residual
# $\frac{R}{n^2} \operatorname{Var}_\rho(x)$; stratified $\frac{1}{n^2}\sum_k \operatorname{Var}(x \mid \text{stratum } k)$
# (strata are independent). Systematic has no simple general formula, but $N$ depends on the
# single offset $U$ only, so we integrate over $U$ numerically ($20\,000$ values of $U$). The
# measured variance of each scheme is again compared with its theory in standard errors.

# %%
x = np.arange(n) / n
mu = w @ x
estimate_var = {name: (counts[name] @ x / n).var(ddof=1) for name in SCHEMES}
rho = r / R
theory = {
    "multinomial": (w @ x**2 - mu**2) / n,
    "residual": R / n**2 * (rho @ x**2 - (rho @ x) ** 2),
    "stratified": ((p_ik * x[:, None] ** 2).sum(axis=0) - (p_ik * x[:, None]).sum(axis=0) ** 2).sum() / n**2,
}
U = (np.arange(20_000) + 0.5) / 20_000
idx = np.searchsorted(C[1:-1], (np.arange(n)[None] + U[:, None]) / n, side="right")
theory["systematic"] = x[idx].mean(axis=1).var()
for name in SCHEMES:
    mu_hat = counts[name] @ x / n
    se = np.sqrt(max(np.mean((mu_hat - mu_hat.mean()) ** 4) - estimate_var[name] ** 2, 0) / n_reps)
    print(f"{name:12s} Var(mu_hat): measured {estimate_var[name]:.2e}, theory {theory[name]:.2e} "
          f"({(estimate_var[name] - theory[name]) / se:+.1f} standard errors), "
          f"ratio to multinomial {theory[name] / theory['multinomial']:.3f}")
    glue(f"{name}_estimate_var_factor", float(theory["multinomial"] / theory[name]), display=False)


def estimate_variances(xs):
    """Var(mu_hat) of every scheme from the closed forms (systematic: integrated over U) for positions xs."""
    m = w @ xs
    return {"multinomial": (w @ xs**2 - m**2) / n,
            "residual": R / n**2 * (rho @ xs**2 - (rho @ xs) ** 2),
            "stratified": ((p_ik * xs[:, None] ** 2).sum(axis=0) - (p_ik * xs[:, None]).sum(axis=0) ** 2).sum() / n**2,
            "systematic": xs[idx].mean(axis=1).var()}


x_jumpy = np.random.default_rng(0).random(n)
jumpy = estimate_variances(x_jumpy)
print("x = np.random.default_rng(0).random(n), theory, ratio to multinomial: "
      + ", ".join(f"{name} {jumpy[name] / jumpy['multinomial']:.3f}" for name in SCHEMES))
glue("jumpy_worst_ratio", float(max(jumpy[m] / jumpy["multinomial"] for m in SCHEMES)), display=False)
for name in SCHEMES:
    glue(f"jumpy_{name}_factor", float(jumpy["multinomial"] / jumpy[name]), display=False)

# %% [markdown]
# The measured values match theory within sampling error (the standard errors printed above).
# Against multinomial resampling, residual resampling cuts the variance of this estimate by a
# factor of {glue:text}`residual_estimate_var_factor:.1f`, systematic resampling by
# {glue:text}`systematic_estimate_var_factor:.0f` and stratified resampling by
# {glue:text}`stratified_estimate_var_factor:.0f`: here $x_i$ increases with $i$, so
# neighbouring strata see neighbouring values, the case in which stratification helps most.
# For a function that jumps around with $i$ (`x = np.random.default_rng(0).random(n)`, last
# line above, from the closed forms) the gains of stratified and systematic resampling are
# much smaller, factors of {glue:text}`jumpy_stratified_factor:.1f` and
# {glue:text}`jumpy_systematic_factor:.1f`, while residual resampling's, which does not depend
# on the order of the particles, stays about the same ({glue:text}`jumpy_residual_factor:.1f`);
# no scheme does worse than multinomial on these weights.
#
# ## Run time against N
#
# Each scheme here costs a cumulative sum and one merge pass of sorted uniforms along it
# (`pfcourse.kernels.inverse_cdf_sorted`), $O(n)$: stratified and systematic uniforms are
# born sorted, multinomial resampling sorts its $n$ uniforms first ($O(n \log n)$), and
# residual resampling sorts only the uniforms of its random remainder. The figure shows the median of
# $5$ timings per size on this machine (timings vary between machines and runs, so only the
# figure is shown; its shape, not its numbers, is the point).

# %%
sizes = [10**e for e in range(2, 7)]
times = {name: [] for name in SCHEMES}
for m in sizes:
    wm = np.random.default_rng(0).random(m)
    wm /= wm.sum()
    g = np.random.default_rng(1)
    for name, f in SCHEMES.items():
        times[name].append(np.median(timeit.repeat(lambda: f(wm, g), number=1, repeat=5)))
fig, ax = plt.subplots(figsize=(6, 3.6))
for name in SCHEMES:
    ax.loglog(sizes, times[name], "o-", color=SCHEME_COLORS[name], label=name)
ax.loglog(sizes, np.array(sizes) * times["systematic"][-1] / sizes[-1], "k:", label=r"$\propto n$")
ax.set_xlabel("number of particles n")
ax.set_ylabel("time per resampling (s)")
ax.set_title("Median of 5 runs per size")
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# ## filterpy's residual resampling is biased
#
# `filterpy.monte_carlo.residual_resample` (version 2.0.0) computes the leftover weights as
# `weights - num_copies` instead of `n * weights - num_copies`, so a particle with
# $n W_i < 1$ (no sure copy) gets too few copies (none at all in the run below) and heavy
# particles get too many.
# Below, ten weights, {glue:text}`filterpy_reps:d` resamplings each (one seed each, from $0$ up;
# filterpy uses numpy's global generator, which we seed), the mean offspring counts against
# $n W_i$:

# %%
w10 = np.array([0.31, 0.22, 0.15, 0.09, 0.08, 0.06, 0.04, 0.03, 0.015, 0.005])
reps = 20_000
glue("filterpy_reps", reps, display=False)
ours = np.array([np.bincount(SCHEMES["residual"](w10, np.random.default_rng(s)), minlength=10)
                 for s in range(reps)])
theirs = []
for s in range(reps):
    np.random.seed(s)
    theirs.append(np.bincount(fp.residual_resample(w10), minlength=10))
theirs = np.array(theirs)
se = np.sqrt(np.maximum(ours.var(axis=0), 1e-12) / reps)
print("n W_i             :", np.round(10 * w10, 3))
print("pfcourse residual :", np.round(ours.mean(axis=0), 3))
print("filterpy residual :", np.round(theirs.mean(axis=0), 3))
print(f"largest deviation in standard errors: pfcourse {np.max(np.abs(ours.mean(0) - 10 * w10) / se):.1f}, "
      f"filterpy {np.max(np.abs(theirs.mean(0) - 10 * w10) / se):.0f}")
no_sure_copy = np.flatnonzero(10 * w10 < 1)
print(f"particles with n W_i < 1: {(no_sure_copy + 1).tolist()}; filterpy gives them "
      f"{int(theirs[:, no_sure_copy].sum())} copies in {reps} resamplings")
glue("pfcourse_residual_max_se", float(np.max(np.abs(ours.mean(0) - 10 * w10) / se)), display=False)
glue("filterpy_residual_max_se", float(np.max(np.abs(theirs.mean(0) - 10 * w10) / se)), display=False)
glue("filterpy_no_copy_first", int(no_sure_copy[0] + 1), display=False)
glue("filterpy_no_copy_last", int(no_sure_copy[-1] + 1), display=False)
glue("filterpy_no_copy_total", int(theirs[:, no_sure_copy].sum()), display=False)

fig, ax = plt.subplots(figsize=(7, 3.2))
pos = np.arange(10)
ax.bar(pos - 0.2, ours.mean(axis=0), 0.4, color=SCHEME_COLORS["residual"], label="pfcourse residual")
ax.bar(pos + 0.2, theirs.mean(axis=0), 0.4, color="tab:gray", label="filterpy 2.0.0 residual_resample")
ax.plot(pos, 10 * w10, "k_", ms=20, mew=2, label=r"$n W_i$ (unbiased target)")
ax.set_xticks(pos, [f"{i + 1}" for i in pos])
ax.set_xlabel("particle i")
ax.set_ylabel("mean number of copies")
ax.set_title(f"Mean offspring over {reps} resamplings")
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# Particles {glue:text}`filterpy_no_copy_first:d` to {glue:text}`filterpy_no_copy_last:d`
# ($n W_i < 1$) get {glue:text}`filterpy_no_copy_total:d` copies from filterpy's version in
# all {glue:text}`filterpy_reps:d` resamplings, where they should get $n W_i$ on average; the
# first ones get too many, up to {glue:text}`filterpy_residual_max_se:.0f` standard errors
# away. Inside a filter this is a systematic shrinking of the posterior towards its heaviest
# particles. `pfcourse.resampling.residual` matches $n W_i$ to within sampling error (largest
# deviation {glue:text}`pfcourse_residual_max_se:.1f` standard errors over the ten
# particles); `tests/test_resampling.py` checks both.
#
# ## Try it
#
# The panel resamples {glue:text}`n_weights:d` particles with the chosen scheme and seed, for weights of chosen
# unevenness, and shows each particle's offspring count against $n W_i$.

# %%
import ipywidgets as widgets


def draw_offspring(scheme, spread, seed):
    ww = np.random.default_rng(3).lognormal(0.0, spread, n)
    ww /= ww.sum()
    got = np.bincount(SCHEMES[scheme](ww, np.random.default_rng(seed)), minlength=n)
    fig, ax = plt.subplots(figsize=(8, 3))
    ax.bar(np.arange(n), got, color=SCHEME_COLORS[scheme], label=f"{scheme} copies")
    ax.plot(np.arange(n), n * ww, "k_", ms=8, mew=2, label=r"$n W_i$")
    ax.set_xlabel("particle i")
    ax.set_ylabel("number of copies")
    ax.legend(fontsize=8)


# %% tags=["nbval-ignore-output"]
display(control_panel(draw_offspring, grid={"scheme": tuple(SCHEMES), "spread": (0.0, 1.0, 3.0)},
                      scheme=scheme_dropdown(),
                      spread=widgets.FloatSlider(value=1.0, min=0.0, max=3.0, step=0.1, description="log-weight sd"),
                      seed=seed_box(0)))

# %% [markdown]
# ## Exercises
#
# ```{exercise}
# :label: ex-resampling-systematic
# Show that with systematic resampling $N_i \in \{\lfloor n W_i \rfloor, \lfloor n W_i \rfloor + 1\}$,
# and deduce its variance.
# ```
#
# ```{solution} ex-resampling-systematic
# :class: dropdown
# The points $(k + U)/n$ are spaced exactly $1/n$ apart, so an interval of length $W_i$
# contains either $\lfloor n W_i \rfloor$ or $\lfloor n W_i \rfloor + 1$ of them. Since the
# mean is $n W_i$, the second happens with probability $r_i = n W_i - \lfloor n W_i \rfloor$:
# a Bernoulli($r_i$) on top of a constant, variance $r_i (1 - r_i) \le 1/4$.
# ```
#
# ```{exercise}
# :label: ex-resampling-bias
# (Lab question 7, testing.) Design a test that would have caught filterpy's residual bug,
# using only the property that every scheme must satisfy.
# ```
#
# ```{solution} ex-resampling-bias
# :class: dropdown
# Unbiasedness: for fixed weights, the mean offspring count over many seeded resamplings
# must equal $n W_i$ within a few standard errors $\sqrt{\operatorname{Var} N_i / \text{reps}}$.
# Use weights with some $n W_i < 1$: filterpy gives them no copies in the run above, hundreds of
# standard errors away ({glue:text}`filterpy_residual_max_se:.0f` above).
# ```
#
# ```{exercise}
# :label: ex-resampling-code
# (Coding.) Write stratified resampling, one uniform in each stratum $[(k-1)/n, k/n)$, check
# it with `pfcourse.exercises.check_resampler`, and measure $\operatorname{Var} N_i$ over
# $10\,000$ draws against `pfcourse.resampling.multinomial` for the weights of this chapter.
# ```
#
# ````{solution} ex-resampling-code
# :class: dropdown
# ```{code} python
# def my_stratified(W, rng):
#     n = len(W)
#     u = (np.arange(n) + rng.random(n)) / n
#     return np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), n - 1)
#
# from pfcourse.exercises import check_resampler
# print(check_resampler(my_stratified))          # every check passed
# ```
#
# Counting copies with `np.bincount(idx, minlength=n)` over the draws, its variance per
# particle is at most that of multinomial resampling, as the table of this chapter shows.
# ````
