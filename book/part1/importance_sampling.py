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
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** why draws from one density, weighted, estimate expectations under another; how
# accurate the weighted estimate is (its asymptotic variance, and the effective sample size) and
# when it fails (a proposal with lighter tails than the target); and a particle filter with any
# proposal, in NumPy, that also estimates the likelihood of the data.
#
# **You need** {doc}`model` and {doc}`kalman` (the exact answers we check against); Gaussian
# densities, the law of large numbers and the central limit theorem; NumPy arrays and a random
# generator.
#
# **Time:** about twenty-six minutes to read; the notebook runs in under half a minute.
# :::
#
# ## The idea: weight draws from another density
#
# We want an expectation under a target density $\pi$, $I = \mathbb E_\pi \varphi =
# \int \varphi(x)\, \pi(x)\, dx$, for a function $\varphi$ (the state itself, an indicator, ...), but
# we cannot draw from $\pi$. Take any density $q$, the *proposal*, positive wherever $\pi$ is, and
# multiply and divide by it:
#
# $$
# \mathbb E_\pi \varphi = \int \varphi(x)\, \frac{\pi(x)}{q(x)}\, q(x)\, dx
#   = \mathbb E_q\big[ w(x)\, \varphi(x) \big], \qquad w(x) = \frac{\pi(x)}{q(x)} .
# $$
#
# An expectation under $q$ is what an average of draws $x^i \sim q$ estimates (law of large
# numbers), so $\frac1N \sum_i w(x^i)\, \varphi(x^i) \to I$: each draw counts in proportion to
# its *weight* $w(x^i)$, large where $\pi$ puts more mass than $q$. In filtering, $\pi$ is a posterior
# known up to a constant, $\pi = \tilde\pi / Z$ with $\tilde\pi(x) = p(z \mid x)\, p(x)$ and
# $Z = p(z)$. The constant is itself an expectation under $q$, $Z = \int \tilde\pi = \mathbb E_q[\tilde\pi / q]$,
# so with the unnormalised weights $\tilde w^i = \tilde\pi(x^i) / q(x^i)$:
#
# $$
# \hat Z = \frac1N \sum_i \tilde w^i, \qquad
# W^i = \frac{\tilde w^i}{\sum_j \tilde w^j}, \qquad
# \hat I_N = \sum_i W^i\, \varphi(x^i) .
# $$
#
# $\hat Z$ is unbiased; the *self-normalised* estimator $\hat I_N$, a ratio of two averages, is
# biased by $O(1/N)$ but consistent. With the prior as proposal, $q(x) = p(x)$, the weight is the
# likelihood, $\tilde w^i = p(z \mid x^i)$: the choice of the particle filters of the next chapters.
#
# :::{admonition} Algorithm 3.1: self-normalised importance sampling
# :class: algorithm
# 1. **Draw** $x^i \sim q$ for $i = 1, \dots, N$.
# 2. **Weight** in the log domain: $\log \tilde w^i = \log \tilde\pi(x^i) - \log q(x^i)$.
# 3. **Normalise:** $\log W^i = \log \tilde w^i - \operatorname{logsumexp}_j \log \tilde w^j$, and
#    $\log \hat Z = \operatorname{logsumexp}_j \log \tilde w^j - \log N$.
# 4. **Estimate:** $\hat I_N = \sum_i W^i \varphi(x^i)$; effective sample size $\mathrm{ESS} = 1 / \sum_i (W^i)^2$.
# :::
#
# The toy problem of this chapter has an exact answer: prior $x \sim \mathcal N(0, 1)$, one
# measurement $z = x + v$ with $v \sim \mathcal N(0, \sigma_v^2)$, so the posterior is
# $\mathcal N\big(z / (1 + \sigma_v^2),\ \sigma_v^2 / (1 + \sigma_v^2)\big)$ and
# $Z = \mathcal N(z; 0, 1 + \sigma_v^2)$. Here is Algorithm 3.1 with the prior as proposal, for
# $z = 1$, $\sigma_v = 0.3$ and $N = 30$ draws, against the exact answers:

# %%
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy import integrate, stats
from scipy.special import gammaln, logsumexp

from pfcourse import ParticleFilter, evidence
from pfcourse.exercises import check_resampler, check_weight_update
from pfcourse.figures.report import EvidenceBlock, glue_values
from pfcourse.proposals import DensityProposal
from pfcourse.kalman import kalman_filter
from pfcourse.landmarks.scenario import quadrant_scenario, simulate
from pfcourse.linear_gaussian import LinearGaussianModel
from pfcourse.seeding import data_rng, filter_rng, study_filter_seed
from pfcourse.style import plain_log_axis, use_style

use_style()
z, sd_v, N = 1.0, 0.3, 30
rng = np.random.default_rng(0)
x = rng.standard_normal(N)                                # 1. x^i ~ q = p(x) = N(0, 1)
log_w = stats.norm.logpdf(z, loc=x, scale=sd_v)           # 2. log w~ = log p(z | x) + log p(x) - log q(x)
log_W = log_w - logsumexp(log_w)                          # 3. normalise
log_Z = logsumexp(log_w) - np.log(N)
W = np.exp(log_W)
estimate, ess = W @ x, 1.0 / np.sum(W**2)                 # 4. estimate (phi(x) = x) and ESS
post_mean, post_sd = z / (1 + sd_v**2), np.sqrt(sd_v**2 / (1 + sd_v**2))
print(f"posterior mean: estimate {estimate:.3f}, exact {post_mean:.3f}; "
      f"Z: estimate {np.exp(log_Z):.3f}, exact {stats.norm.pdf(z, 0, np.sqrt(1 + sd_v**2)):.3f}; ESS {ess:.1f} of {N}")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
grid = np.linspace(-3, 3, 400)
fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 4.2), sharex=True, height_ratios=(3, 2))
ax.plot(grid, stats.norm.pdf(grid), color="tab:blue", label=r"proposal $q$ = prior N(0, 1)")
ax.plot(grid, stats.norm.pdf(grid, post_mean, post_sd), color="tab:green", label=r"target $\pi$ = posterior")
ax.plot(x, np.zeros(N), "|", color="tab:red", ms=10, label=r"draws $x^i \sim q$")
ax.set_ylabel("density (1/unit of x)")
ax.set_ylim(-0.1, 1.8)
ax.legend(loc="upper left")
ax.set_title(f"Importance sampling: N = {N} prior draws, z = {z}, measurement sd {sd_v}", fontsize=10)
ax2.vlines(x, 0, W, color="tab:red", lw=1.5)
ax2.plot(x, W, "o", color="tab:red", ms=4)
ax2.set_xlabel("state x (no unit)")
ax2.set_ylabel(r"weight $W^i$")
fig.tight_layout()
plt.show()

# %% [markdown]
# The draws fall where the prior puts them; the weights keep those that explain $z$ and all but
# erase the others. The weighted mean is near the exact one, yet a few draws carry most of the
# weight: the thirty draws are worth far fewer draws from the posterior itself. How many, exactly?
#
# ## How accurate: the asymptotic variance, and the ESS
#
# Take $w = \pi / q$ normalised, so $\mathbb E_q w = 1$ (the constant cancels in $\hat I_N$), and
# write the error as a ratio of two averages:
#
# $$
# \hat I_N - I = \frac{\frac1N \sum_i w(x^i)\,\big(\varphi(x^i) - I\big)}{\frac1N \sum_i w(x^i)} .
# $$
#
# The numerator averages independent terms of mean $\mathbb E_q[w\,(\varphi - I)] = \mathbb E_\pi[\varphi - I] = 0$
# and variance $\mathbb E_q[w^2 (\varphi - I)^2]$, so by the central limit theorem $\sqrt N$ times it
# tends to a Gaussian; the denominator tends to $\mathbb E_q w$. Hence {cite:p}`geweke1989`
#
# $$
# \sqrt N\, (\hat I_N - I) \;\to\; \mathcal N(0, \sigma^2), \qquad
# \sigma^2 = \frac{\mathbb E_q\big[w(x)^2\, (\varphi(x) - I)^2\big]}{(\mathbb E_q w)^2},
# $$
#
# finite when $\mathbb E_q[w^2 (\varphi - I)^2]$ is. Replace $(\varphi - I)^2$ by its average under
# $\pi$, as if the weight and the function did not vary together, and
# $\sigma^2 \approx \operatorname{Var}_\pi(\varphi)\, \mathbb E_q[w^2]$, with
# $\mathbb E_q[w^2] = 1 + \operatorname{Var}_q(w)$. This is the approximation of {cite:t}`kong1994`:
#
# $$
# \operatorname{Var}(\hat I_N) \approx \frac{\operatorname{Var}_\pi(\varphi)}{\mathrm{ESS}}, \qquad
# \mathrm{ESS} = \frac{N}{1 + \operatorname{cv}^2(w)} \approx \frac{1}{\sum_i (W^i)^2},
# $$
#
# where $\operatorname{cv}$ is the coefficient of variation of the weights (the exercise {ref}`ex-is-ess` derives the
# last identity): $N$ weighted draws are worth ESS draws from $\pi$. It looks at the weights only,
# not at $\varphi$. We check both formulas on the toy with $N = 100$ and $\varphi(x) = x$,
# {glue:text}`is_toy_reps:,d` seeded repetitions for each $\sigma_v$, and $\sigma^2$ computed by quadrature
# ({doc}`../evidence` explains the intervals).

# %%
def asymptotic_variance(sd_v, z=1.0):
    """sigma^2 = E_q[w^2 (x - I)^2] and E_q[w^2], w = pi / q, pi the posterior, q = N(0, 1) (quadrature)."""
    mean, sd = z / (1 + sd_v**2), np.sqrt(sd_v**2 / (1 + sd_v**2))
    w2 = lambda x: stats.norm.pdf(x, mean, sd) ** 2 / stats.norm.pdf(x)  # w^2 q = pi^2 / q
    lo, hi = mean - 12 * sd, mean + 12 * sd
    return (integrate.quad(lambda x: w2(x) * (x - mean) ** 2, lo, hi)[0], integrate.quad(w2, lo, hi)[0])


N, reps = 100, 2000
toy = {}
for sd_v in (1.0, 0.3, 0.1):
    x = rng.standard_normal((reps, N))
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v)
    W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
    post_var = sd_v**2 / (1 + sd_v**2)
    sigma2, Ew2 = asymptotic_variance(sd_v)
    toy[sd_v] = dict(estimate=np.sum(W * x, axis=1), ess=1.0 / np.sum(W**2, axis=1), post_var=post_var,
                     sigma2=sigma2, Ew2=Ew2)
    t = toy[sd_v]
    print(f"sd_v = {sd_v}: N Var(estimates) = {N * t['estimate'].var(ddof=1):.4f}, sigma^2 = {sigma2:.4f}; "
          f"Var / (Var_pi / mean ESS) = {t['estimate'].var(ddof=1) * t['ess'].mean() / post_var:.2f}, "
          f"predicted sigma^2 / (Var_pi E_q w^2) = {sigma2 / (post_var * Ew2):.2f}")

# %% [markdown]
# The asymptotic formula predicts the spread of the estimates: at $\sigma_v = 1$ the measured
# variance is {glue:text}`is_var_ratio_sd1:.2f` times $\sigma^2 / N$ (95 % interval
# {glue:text}`is_var_ratio_sd1_low:.2f` to {glue:text}`is_var_ratio_sd1_high:.2f`).

# %% [markdown]
# When few draws count, $N = 100$ is not yet the limit: at $\sigma_v = 0.1$, where the hundred
# draws are worth about {glue:text}`is_ess_sd01:.0f`, the measured variance is
# {glue:text}`is_var_ratio_sd01:.2f` times $\sigma^2 / N$. The terms of order $1/N^2$ that the limit
# drops are not negligible next to $\sigma^2 / N$ when the ESS is a handful.

# %% [markdown]
# The ESS rule overstates the variance: the measured variance is only
# {glue:text}`kong_ratio_r1:.2f` of $\operatorname{Var}_\pi / \mathrm{ESS}$ at $\sigma_v = 1$, where
# the asymptotic formula predicts {glue:text}`is_kong_predicted_sd1:.2f`. The reason: the weight
# $w = \pi / q$ is largest near the posterior mean, where $(\varphi - I)^2$ is smallest, so
# $\mathbb E_q[w^2 (\varphi - I)^2]$ is smaller than $\operatorname{Var}_\pi(\varphi)\, \mathbb E_q[w^2]$.
# For Gaussians the ratio of the two tends to $1/2$ as $\sigma_v \to 0$; the measured
# {glue:text}`kong_ratio_r01:.2f` at $\sigma_v = 0.1$ is that half times the finite-$N$ excess above.
# The ESS is a rule of thumb on the safe side, and still the number the filters monitor.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def toy_row(sd_v):
    t = toy[sd_v]
    var_ratio = evidence.run_interval(lambda r: N * t["estimate"][r].var(ddof=1) / t["sigma2"], reps)
    kong = evidence.run_interval(lambda r: t["estimate"][r].var(ddof=1) * t["ess"][r].mean() / t["post_var"], reps)
    return {"sd_v": sd_v, "exact mean": z / (1 + sd_v**2), "mean of estimates": t["estimate"].mean(),
            "N Var(estimates)": N * t["estimate"].var(ddof=1), "sigma^2 (quadrature)": t["sigma2"],
            "ratio": var_ratio[0], "ratio low": var_ratio[1], "ratio high": var_ratio[2],
            "mean ESS": t["ess"].mean(), "N / E_q w^2": N / t["Ew2"],
            "measured Var ESS / Var_pi": kong[0], "low": kong[1], "high": kong[2],
            "predicted sigma^2 / (Var_pi E_q w^2)": t["sigma2"] / (t["post_var"] * t["Ew2"])}


toy_table = pd.DataFrame([toy_row(s) for s in toy])
row = {s: toy_table.iloc[i] for i, s in enumerate(toy)}
glue_values(is_toy_reps=reps, is_var_ratio_sd1=row[1.0]["ratio"], is_var_ratio_sd1_low=row[1.0]["ratio low"],
            is_var_ratio_sd1_high=row[1.0]["ratio high"],
            is_var_ratio_sd01=row[0.1]["ratio"], is_ess_sd01=row[0.1]["mean ESS"],
            kong_ratio_r1=row[1.0]["measured Var ESS / Var_pi"], kong_ratio_r01=row[0.1]["measured Var ESS / Var_pi"],
            is_kong_predicted_sd1=row[1.0]["predicted sigma^2 / (Var_pi E_q w^2)"])
EvidenceBlock(
    "the asymptotic variance predicts the estimates' spread, and the ESS overstates it",
    notes=[f"N = {N} prior draws, z = {z}, {reps} seeded repetitions per measurement sd (one generator, seed 0, "
           "drawn in turn). 'ratio' is N Var(estimates) / sigma^2, with its 95 % percentile-bootstrap interval over "
           f"the repetitions ({evidence.N_RESAMPLES} resamples, see Reading the evidence); 'measured Var ESS / Var_pi' is the "
           "variance of the estimates over Var_pi / (mean ESS), with its interval (low, high).",
           "The predicted ESS ratio uses the ESS of the limit, N / E_q w^2; the measured one the mean of "
           "1 / sum W^2, which differs at small N, hence the gap at sd 0.1. At N = 100 the estimator's O(1/N) "
           "bias is far below its spread (compare the two means)."],
    tables=[("Self-normalised IS on the Gaussian toy, phi(x) = x", toy_table,
             {"exact mean": ".4f", "mean of estimates": ".4f", "N Var(estimates)": ".4f", "sigma^2 (quadrature)": ".4f",
              "ratio": ".3f", "ratio low": ".3f", "ratio high": ".3f", "mean ESS": ".1f", "N / E_q w^2": ".1f",
              "measured Var ESS / Var_pi": ".2f", "low": ".2f", "high": ".2f",
              "predicted sigma^2 / (Var_pi E_q w^2)": ".2f"})],
)

# %% [markdown]
# ## When the proposal's tails are too light
#
# The variance $\sigma^2$ is finite only if $\mathbb E_q[w^2 (\varphi - I)^2]$ is, and
# $\mathbb E_q[w^2] = \int \pi^2 / q$ diverges when $q$ decays faster than $\pi$ in the tails:
# there the weights are unbounded, with infinite variance. Then the central limit theorem does not
# apply and the ESS cannot be trusted. Take a Student $t$ target with $\nu = 3$ degrees of freedom, whose tails decay
# like $|x|^{-4}$, and estimate the probability of its tails, $\varphi(x) = \mathbb 1\{|x| > 3\}$
# (exact from the $t$ distribution function). The proposal $\mathcal N(0, 1)$ decays like
# $e^{-x^2/2}$: $\pi^2 / q$ grows without bound. The fix is a proposal with heavier tails than the
# target, here a Cauchy ($t$ with one degree of freedom), for which $w$ is bounded. Both run
# $N = 10^2$, $10^3$ and $10^4$ draws, {glue:text}`is_tail_runs:d` seeded runs each.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def log_student(x, nu):
    """log density of Student's t with nu degrees of freedom."""
    return gammaln((nu + 1) / 2) - gammaln(nu / 2) - 0.5 * np.log(nu * np.pi) - (nu + 1) / 2 * np.log1p(x**2 / nu)


nu, runs, sizes = 3, 200, np.array([100, 1000, 10_000])
exact = 2 * stats.t.sf(3, nu)                                  # I = P(|x| > 3) under t_3
proposals = {"normal N(0, 1)": (lambda r, n: r.standard_normal(n), lambda x: stats.norm.logpdf(x)),
             "Cauchy t_1": (lambda r, n: r.standard_cauchy(n), lambda x: log_student(x, 1))}
tail = {}
for name, (draw, log_q) in proposals.items():
    err, ess, covered = (np.empty((runs, len(sizes))) for _ in range(3))
    for s in range(runs):
        r = np.random.default_rng(s)                              # common random numbers: seed s for both
        for j, n in enumerate(sizes):
            x = draw(r, n)
            log_w = log_student(x, nu) - log_q(x)
            W = np.exp(log_w - logsumexp(log_w))
            estimate = W @ (np.abs(x) > 3)
            ess[s, j] = 1.0 / np.sum(W**2)
            err[s, j] = estimate - exact
            covered[s, j] = abs(estimate - exact) < 1.96 * np.sqrt(estimate * (1 - estimate) / ess[s, j])
    tail[name] = dict(err=err, ess=ess, covered=covered.astype(bool))

fig, ax = plt.subplots(figsize=(6, 3.4))
for (name, t), c in zip(tail.items(), ("tab:red", "tab:blue")):
    ax.loglog(sizes, np.sqrt(np.mean(t["err"] ** 2, axis=0)), "o-", color=c, label=f"proposal {name}")
ref = np.sqrt(np.mean(tail["Cauchy t_1"]["err"][:, 0] ** 2)) * np.sqrt(sizes[0] / sizes)
ax.loglog(sizes, ref, ":", color="gray", label=r"$\propto 1/\sqrt{N}$")
plain_log_axis(ax, "xy")
ax.set_xlabel("number of draws N")
ax.set_ylabel(r"RMS error of $P(|x| > 3)$ (probability)")
ax.set_title(rf"Target Student t, $\nu$ = {nu}; {runs} runs per N", fontsize=10)
ax.legend(loc="lower left")
fig.tight_layout()
plt.show()

# %% [markdown]
# With the normal proposal the error hardly shrinks: its root mean square falls as
# $N^{b}$ with $b$ = {glue:text}`is_tail_slope_normal:.2f` (95 % interval
# {glue:text}`is_tail_slope_normal_low:.2f` to {glue:text}`is_tail_slope_normal_high:.2f`), not $-1/2$.
# The draws rarely reach $|x| > 3$, and when one does its weight is huge.

# %% [markdown]
# The ESS does not warn: at $N = 10^3$ the normal proposal's mean ESS is {glue:text}`is_tail_ess_normal:.0%`
# of $N$, which looks healthy, yet the interval it implies, $\hat I_N \pm 1.96 \sqrt{\hat I_N (1 - \hat I_N) / \mathrm{ESS}}$
# (the variance of an indicator is $I (1 - I)$), covers the exact answer in only {glue:text}`is_tail_cover_normal:.0%`
# of the runs (95 % Wilson interval up to {glue:text}`is_tail_cover_normal_high:.0%`). A
# diagnostic made of the draws cannot see the mass the draws never reach.

# %% [markdown]
# The Cauchy proposal restores the rate: slope {glue:text}`is_tail_slope_cauchy:.2f` (95 % interval
# {glue:text}`is_tail_slope_cauchy_low:.2f` to {glue:text}`is_tail_slope_cauchy_high:.2f`). The lesson
# carries over to filters: a proposal must not be narrower than the target in any direction, and
# it is safer too wide than too narrow.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def rms_slope(err):
    """Slope of log RMS error against log N, with its interval over the runs."""
    return evidence.log_slope(err.T, sizes, center=lambda e, axis: np.sqrt(np.mean(e**2, axis=axis)))


slopes = {name: rms_slope(t["err"]) for name, t in tail.items()}
cover = {name: [evidence.rate(t["covered"][:, j]) for j in range(len(sizes))] for name, t in tail.items()}
glue_values("is_tail_", runs=runs, slope_normal=slopes["normal N(0, 1)"][0], slope_normal_low=slopes["normal N(0, 1)"][1],
            slope_normal_high=slopes["normal N(0, 1)"][2], slope_cauchy=slopes["Cauchy t_1"][0],
            slope_cauchy_low=slopes["Cauchy t_1"][1], slope_cauchy_high=slopes["Cauchy t_1"][2],
            ess_normal=tail["normal N(0, 1)"]["ess"][:, 1].mean() / sizes[1],
            cover_normal=cover["normal N(0, 1)"][1].estimate, cover_normal_high=cover["normal N(0, 1)"][1].high)
EvidenceBlock(
    "with a proposal lighter-tailed than the target, the error does not shrink like 1/sqrt(N) and the ESS misleads",
    notes=[f"Target t with {nu} degrees of freedom, phi = 1{{|x| > 3}}, exact I = {exact:.4f}. {runs} runs; run s "
           "draws from the generator of seed s for every N and both proposals (common random numbers).",
           "Slope of log RMS error on log N (least squares over the three N), 95 % percentile-bootstrap interval "
           f"over the runs ({evidence.N_RESAMPLES} resamples): " + "; ".join(f"{n}: {v:.2f} ({lo:.2f} to {hi:.2f})"
                                                           for n, (v, lo, hi) in slopes.items()) + ".",
           "Coverage: share of runs whose interval estimate ± 1.96 sqrt(I^(1 - I^) / ESS) contains I, with its "
           "Wilson interval (see Reading the evidence)."],
    tables=[("RMS error, mean ESS / N and coverage, per proposal and N",
             pd.DataFrame([{"proposal": name, "N": n, "RMS error": np.sqrt(np.mean(t["err"][:, j] ** 2)),
                            "mean error": t["err"][:, j].mean(), "mean ESS / N": t["ess"][:, j].mean() / n,
                            "coverage": cover[name][j].estimate, "low": cover[name][j].low, "high": cover[name][j].high}
                           for name, t in tail.items() for j, n in enumerate(sizes)]),
             {"RMS error": ".4f", "mean error": "+.4f", "mean ESS / N": ".2f", "coverage": ".0%", "low": ".0%",
              "high": ".0%"})],
)

# %% [markdown]
# ## Sequentially: the weight recursion and the likelihood
#
# A filter applies importance sampling to the path $x_{0:k}$, with target $p(x_{0:k} \mid z_{1:k})$
# and a proposal that extends each path by one step, $x_k^i \sim q(x_k \mid x_{k-1}^i, z_k)$. The
# target gains the factor $p(z_k \mid x_k)\, p(x_k \mid x_{k-1})$ and the proposal the factor $q$, so
# the weight is updated by their ratio, the *incremental weight*:
#
# $$
# W_k^i \;\propto\; W_{k-1}^i\, \tilde w_k^i, \qquad
# \tilde w_k^i = \frac{p(z_k \mid x_k^i)\, p(x_k^i \mid x_{k-1}^i)}{q(x_k^i \mid x_{k-1}^i, z_k)}
#   \quad\xrightarrow{\ q\, =\, p(x_k \mid x_{k-1})\ }\quad p(z_k \mid x_k^i) .
# $$
#
# The same step estimates the likelihood increment. Since
# $p(z_k \mid z_{1:k-1}) = \iint p(z_k \mid x_k)\, p(x_k \mid x_{k-1})\, p(x_{k-1} \mid z_{1:k-1})\, dx_k\, dx_{k-1}$,
# an integral of the incremental weight against $q$ and the previous weighted cloud, its estimate is
# the $\hat Z$ of Algorithm 3.1 at step $k$:
#
# $$
# \hat p(z_k \mid z_{1:k-1}) = \sum_i W_{k-1}^i\, \tilde w_k^i ,
# $$
#
# with the transition as proposal the weighted mean of the likelihoods. The product of these
# increments over $k$ is an unbiased estimate of the likelihood $p(z_{1:k})$ {cite:p}`delmoral2004`,
# which Part V uses to estimate parameters. A product of random factors is also why the weights
# degenerate with time ({doc}`sis` measures it), and the reason for resampling.
#
# (write-sis)=
# ## A particle filter in thirty lines
#
# :::{admonition} Algorithm 3.2: a particle filter with importance function $q$
# :class: algorithm
# 1. **Initialise.** $x_0^i \sim p(x_0)$, $\log W_0^i = -\log N$ (weighted by $z_0$ if there is one).
# 2. **For** $k = 1, 2, \dots$:
#    1. *propose:* $x_k^i \sim q(x_k \mid x_{k-1}^i, z_k)$ (the transition when nothing is measured);
#    2. *incremental weight:* $\log \tilde w_k^i = \log p(z_k \mid x_k^i) + \log p(x_k^i \mid x_{k-1}^i) - \log q(x_k^i \mid x_{k-1}^i, z_k)$;
#    3. *likelihood increment:* $\log \hat p(z_k \mid z_{1:k-1}) = \operatorname{logsumexp}_i (\log W_{k-1}^i + \log \tilde w_k^i)$;
#    4. *normalise:* $\log W_k^i = \log W_{k-1}^i + \log \tilde w_k^i - \log \hat p(z_k \mid z_{1:k-1})$;
#    5. *estimate:* $\hat m_k = \sum_i W_k^i x_k^i$ and $\mathrm{ESS}_k = 1 / \sum_i (W_k^i)^2$;
#    6. *resample* if $\mathrm{ESS}_k < \tau N$ (systematic, {doc}`resampling_schemes`), then $\log W_k^i = -\log N$.
# :::
#
# The function below is Algorithm 3.2 for any model of the engine's form (`sample_initial`,
# `sample_transition`, `log_likelihood`, and `transition_log_density` for a proposal other than
# the transition). $\tau = 0$ never resamples (SIS, {doc}`sis`); $\tau = 1/3$ resamples when the
# ESS falls below $N/3$ (SIR, the lab's choice, {doc}`sir`).

# %%
def my_filter(Z, N, rng, model, threshold=0.0, proposal=None):
    """Algorithm 3.2; proposal None is the transition, else q with .sample and .log_density.

    Returns the means (K, d), the ESS (K,) and log p^(z_k | z_{1:k-1}) (K,), 0 where z_k is missing.
    """
    x = model.sample_initial(N, rng)
    log_W = np.full(N, -np.log(N))
    means, esss, log_incs = [], [], []
    for k, z in enumerate(Z):
        measured = not np.isnan(z).all()
        log_inc = 0.0
        if k > 0 and (proposal is None or not measured):   # propose from the transition: ratio 1
            x = model.sample_transition(x, k, rng)
        elif k > 0:                                          # any q: log p(x_k | x_{k-1}) - log q(x_k | x_{k-1}, z_k)
            new = proposal.sample(x, z, k, rng)
            log_inc = model.transition_log_density(new, x, k) - proposal.log_density(new, x, z, k)
            x = new
        if measured:                                         # incremental weight, likelihood increment, normalise
            a = log_W + (model.log_likelihood(x, z, k) + log_inc)
            log_incs.append(logsumexp(a))
            log_W = a - log_incs[-1]
        else:
            log_incs.append(0.0)
        W = np.exp(log_W)
        means.append(W @ x)
        esss.append(1.0 / np.sum(W**2))
        if esss[-1] < threshold * N:                         # resample: systematic, one uniform shared by all
            u = (np.arange(N) + rng.random()) / N
            x = x[np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), N - 1)]
            log_W = np.full(N, -np.log(N))
    return np.array(means), np.array(esss), np.array(log_incs)


# %% [markdown]
# We check it against the engine, `pfcourse.ParticleFilter`, with the same random numbers: on the
# landmark model of {doc}`model` with the transition, and on a scalar linear-Gaussian model,
# $x_k = 0.9\, x_{k-1} + w_k$, $z_k = x_k + v_k$ ($Q = R = 0.5$, $x_0 \sim \mathcal N(0, 1)$), with a
# proposal that looks at $z_k$: $q(x_k \mid x_{k-1}, z_k) = \mathcal N\big(\tfrac12 (0.9\, x_{k-1} + z_k),\ Q\big)$,
# halfway between the prediction and the measurement.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
scalar = LinearGaussianModel(F=[[0.9]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[0.5]], R=[[0.5]])
halfway = DensityProposal(
    sample=lambda x, z, k, rng: 0.5 * (0.9 * x + z) + np.sqrt(0.5) * rng.standard_normal(x.shape),
    log_density=lambda new, x, z, k: stats.norm.logpdf(new[:, 0], 0.5 * (0.9 * x[:, 0] + z[0]), np.sqrt(0.5)))


def simulate_scalar(K, rng):
    """x_0 ~ N(0, 1), x_k = 0.9 x_{k-1} + w_k, z_k = x_k + v_k for k >= 1; z_0 missing (NaN). Shape (K, 1)."""
    x = np.empty(K)
    x[0] = rng.standard_normal()
    for k in range(1, K):
        x[k] = 0.9 * x[k - 1] + np.sqrt(0.5) * rng.standard_normal()
    Z = (x + np.sqrt(0.5) * rng.standard_normal(K))[:, None]
    Z[0] = np.nan
    return Z


landmarks = quadrant_scenario().model()
Z_landmarks = simulate(quadrant_scenario(), rng=2024).measurements
Z_scalar = simulate_scalar(50, np.random.default_rng(7))
ROUND_OFF = 1e-11  # the differences are sums of last-bit roundings: print the bound, not the digits
for name, m, Z, proposal, tau in (("landmarks, transition, SIS", landmarks, Z_landmarks, None, 0.0),
                                  ("landmarks, transition, SIR", landmarks, Z_landmarks, None, 1 / 3),
                                  ("scalar, halfway proposal, SIR", scalar, Z_scalar, halfway, 1 / 3)):
    mine = my_filter(Z, 100, np.random.default_rng(1), m, tau, proposal)
    engine = ParticleFilter(m, 100, threshold=tau, proposal=proposal).run(Z, rng=1)
    gaps = [np.abs(a - b).max() for a, b in zip(mine, (engine.mean, engine.ess, engine.log_likelihood_increments))]
    print(f"{name}: means, ESS and log-likelihood increments equal to the engine's within {ROUND_OFF:.0e}: "
          f"{max(gaps) < ROUND_OFF}")

# %% [markdown]
# The same random numbers in the same order give the engine's means, ESS and likelihood
# increments to round-off (all differences below {glue:text}`mine_vs_engine_bound:.0e`), with either
# proposal. The engine adds what a course needs beyond these lines: named errors that give the
# step when something goes wrong, more proposals and resampling schemes, compiled loops for a
# million particles, and the stored clouds that the figures draw.
#
# Is the likelihood estimate right? For the scalar model the Kalman filter gives the exact
# $\log p(z_{1:K})$. We run both proposals ($N = 100$, SIR) on {glue:text}`is_ll_runs:d` simulated
# data sets, one seeded filter run each, and compare the estimated likelihood with the exact one.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values(mine_vs_engine_bound=ROUND_OFF)

# %% tags=["hide-input"] jupyter={"source_hidden": true}
ll_runs = 100
log_gap = {"transition": np.empty(ll_runs), "halfway": np.empty(ll_runs)}
for s in range(ll_runs):
    Z = simulate_scalar(50, data_rng(0, s))  # data and filter: two streams of run s (pfcourse.seeding)
    exact_ll = kalman_filter(scalar, Z).log_likelihood_increments.sum()  # log p(z_{1:K}), exact
    for name, proposal in (("transition", None), ("halfway", halfway)):
        log_incs = my_filter(Z, 100, filter_rng(0, s), scalar, 1 / 3, proposal)[2]
        log_gap[name][s] = log_incs.sum() - exact_ll                   # log p^(z_{1:K}) - log p(z_{1:K})
ratio = {name: evidence.run_interval(lambda r: np.exp(g[r]).mean(), ll_runs)
         for name, g in log_gap.items()}
var_ratio = evidence.run_interval(  # paired: both proposals on the same data sets
    lambda r: log_gap["halfway"][r].var(ddof=1) / log_gap["transition"][r].var(ddof=1), ll_runs)
print("mean of p^(z_1:K) / p(z_1:K), 95 % interval: "
      + "; ".join(f"{name} {v:.3f} ({lo:.3f} to {hi:.3f})" for name, (v, lo, hi) in ratio.items()))

# %% [markdown]
# The estimated likelihood is unbiased, as the theory says: with the transition, the mean of
# $\hat p(z_{1:K}) / p(z_{1:K})$ over the runs is {glue:text}`is_ll_ratio_transition:.3f` (95 % interval
# {glue:text}`is_ll_ratio_transition_low:.3f` to {glue:text}`is_ll_ratio_transition_high:.3f`), and the
# halfway proposal agrees too. Its logarithm is biased low (the log of a mean exceeds the mean of the
# logs), by half the variance of $\log \hat p$ for a nearly Gaussian error.

# %% [markdown]
# The proposal that looks at $z_k$ estimates the likelihood better: the variance of
# $\log \hat p(z_{1:K})$ with the halfway proposal is {glue:text}`is_ll_var_ratio:.2f` times that with the
# transition (95 % interval {glue:text}`is_ll_var_ratio_low:.2f` to {glue:text}`is_ll_var_ratio_high:.2f`).
# {doc}`proposals` builds the best such proposal.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
log_mean = {name: evidence.run_interval(lambda r: g[r].mean(), ll_runs) for name, g in log_gap.items()}
glue_values("is_ll_", runs=ll_runs, ratio_transition=ratio["transition"][0], ratio_transition_low=ratio["transition"][1],
            ratio_transition_high=ratio["transition"][2], var_ratio=var_ratio[0], var_ratio_low=var_ratio[1],
            var_ratio_high=var_ratio[2])
EvidenceBlock(
    "the estimated likelihood is unbiased, with either proposal",
    notes=[f"Scalar model, K = 50 steps, N = 100, tau = 1/3; data and filter streams data_rng(0, s) and filter_rng(0, s) (pfcourse.seeding), "
           f"s = 0 to {ll_runs - 1}; both proposals on the same data. Variance of log p^ with the halfway proposal over "
           f"that with the transition, paired over the data sets: {var_ratio[0]:.2f} ({var_ratio[1]:.2f} to "
           f"{var_ratio[2]:.2f}). Intervals: 95 % percentile bootstrap over "
           f"the runs, {evidence.N_RESAMPLES} resamples (see Reading the evidence)."],
    tables=[("Estimated against exact (Kalman) likelihood", pd.DataFrame(
        [{"proposal": name, "mean p^/p": ratio[name][0], "low": ratio[name][1], "high": ratio[name][2],
          "mean log p^ - log p": log_mean[name][0], "log low": log_mean[name][1], "log high": log_mean[name][2],
          "var of log p^": log_gap[name].var(ddof=1), "-var / 2": -0.5 * log_gap[name].var(ddof=1)}
         for name in log_gap]),
        {"mean p^/p": ".3f", "low": ".3f", "high": ".3f", "mean log p^ - log p": ".3f", "log low": ".3f",
         "log high": ".3f", "var of log p^": ".3f", "-var / 2": ".3f"})],
)

# %% [markdown]
# (log-domain)=
# ## Why the log domain: measured
#
# The lab multiplied the weights by the likelihoods themselves and normalised at each step.
# That fails when every particle's likelihood underflows to zero at once (below about
# $e^{-745}$ in double precision): the weights become $0/0$. The function below is the SIS
# of `my_filter` in the linear domain, and reports whether that happened. We run it on
# {glue:text}`linear_runs:d` simulations of the lab's landmark model ($N = 100$) with the lab's
# measurement noise ($\sigma_v = 0.1$ m) and with a ten times sharper one ($\sigma_v = 0.01$ m,
# simulator and filter alike).

# %%
def linear_sis_fails(Z, N, rng, model):
    """SIS with linear-domain weights W <- W p(z | x) / sum; True if they all underflow to 0."""
    x = model.sample_initial(N, rng)
    W = np.full(N, 1.0 / N)
    for k, z in enumerate(Z):
        if k > 0:
            x = model.sample_transition(x, k, rng)
        if not np.isnan(z).all():
            W = W * np.exp(model.log_likelihood(x, z, k))
            if W.sum() == 0.0:
                return True
            W = W / W.sum()
    return False


scenario = quadrant_scenario()
n_runs = 100
failures = {}
for sd in (0.1, 0.01):
    sc = scenario.with_(Rv=sd**2 * np.eye(4))
    m = sc.model()
    failures[sd] = evidence.rate(np.array([
        linear_sis_fails(simulate(sc, rng=s).measurements, 100, np.random.default_rng(study_filter_seed(s)), m)
        for s in range(n_runs)]))
    print(f"measurement sd {sd} m: linear-domain weights fail in {failures[sd]}")

# %% [markdown]
# With the lab's noise the linear-domain weights survive ({glue:text}`linear_fail_sd01` of
# {glue:text}`linear_runs:d` runs fail; 95 % Wilson interval up to {glue:text}`linear_fail_sd01_high:.0%`):
# the lab could not have seen the problem.

# %% [markdown]
# With a $1$ cm sensor they fail in {glue:text}`linear_fail_sd001` of {glue:text}`linear_runs:d` runs
# (interval {glue:text}`linear_fail_sd001_low:.0%` to {glue:text}`linear_fail_sd001_high:.0%`). The
# log-domain update of `my_filter` cannot fail this way: subtracting the largest log-weight before
# exponentiating keeps the best particle at weight $e^0$.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values("linear_", runs=n_runs, fail_sd01=failures[0.1].successes, fail_sd01_high=failures[0.1].high,
            fail_sd001=failures[0.01].successes, fail_sd001_low=failures[0.01].low, fail_sd001_high=failures[0.01].high)
EvidenceBlock(
    "linear-domain weights underflow with a sharp sensor",
    notes=[f"Landmark model, N = 100, {n_runs} simulations (seeds 0 to {n_runs - 1}), filter seeds 1000000 + s; "
           "the measurement noise is set in the simulator and the filter alike.",
           *(f"Measurement sd {sd} m: runs whose weights all underflow: {failures[sd]}." for sd in failures)],
)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 3.1 The weight update in the log domain
# :label: ex-is-weights
# :nonumber:
# (Coding.) Write `update(log_W, log_lik)` returning the normalised log-weights
# $\log W^i + \log p(z \mid x^i) - \operatorname{logsumexp}_j(\cdot)$ and check it with
# `check_weight_update(update)`. Then write the linear-domain version
# `np.log(np.exp(log_W) * np.exp(log_lik) / ...)` and read what the check says about it.
# ```

# %% tags=["answer"]
def update(log_W, log_lik):
    """Your weight update: return the normalised log-weights."""
    ...  # replace with your code


print(check_weight_update(update))

# %% [markdown]
# ```{solution} ex-is-weights
# :class: dropdown
# Add, then subtract the logsumexp; the code is in the folded cell below (in JupyterLab, click
# its margin to unfold it). The linear-domain version fails the case whose likelihoods are near
# $e^{-1000}$: they underflow to $0$, the sum is $0$ and the weights are NaN, as the second
# folded cell shows.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def update(log_W, log_lik):
    a = log_W + log_lik
    return a - logsumexp(a)


print(check_weight_update(update))

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def update_linear(log_W, log_lik):
    w = np.exp(log_W) * np.exp(log_lik)
    return np.log(w / w.sum())


print(check_weight_update(update_linear))

# %% [markdown]
# ```{exercise} 3.2 A systematic resampler
# :label: ex-is-resampler
# :nonumber:
# (Coding.) Write a systematic resampler `resample(W, rng)` returning $N$ ancestor indices,
# and check it with `check_resampler(resample)`. Then try the tempting shortcut "copy particle
# $i$ round$(N W^i)$ times" and read what the check says.
# ```

# %% tags=["answer"]
def resample(W, rng):
    """Your systematic resampler: return N ancestor indices (integers)."""
    ...  # replace with your code


print(check_resampler(resample))

# %% [markdown]
# ```{solution} ex-is-resampler
# :class: dropdown
# The systematic resampler is the one inside `my_filter` above (folded cell below). The rounding
# shortcut is biased (a particle with $N W^i = 0.35$ never survives, though it should once in
# three draws on average) and never random; the check says so in the second folded cell.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def resample(W, rng):
    u = (np.arange(len(W)) + rng.random()) / len(W)
    return np.minimum(np.searchsorted(np.cumsum(W), u, side="right"), len(W) - 1)


print(check_resampler(resample))

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def rounding(W, rng):
    idx = np.repeat(np.arange(len(W)), np.round(len(W) * W).astype(int))
    return np.resize(idx, len(W))


print(check_resampler(rounding))

# %% [markdown]
# ```{exercise} 3.3 The ESS and the spread of the weights
# :label: ex-is-ess
# :nonumber:
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
#
# ```{exercise} 3.4 Which tails are heavy enough?
# :label: ex-is-tails
# :nonumber:
# For the target $t_\nu$ and a Student proposal $t_\mu$, for which $\mu$ is $\mathbb E_q[w^2]$
# finite? Is a proposal with slightly lighter tails than the target always a failure?
# ```
#
# ```{solution} ex-is-tails
# :class: dropdown
# The densities decay like $|x|^{-(\nu + 1)}$ and $|x|^{-(\mu + 1)}$, so $\pi^2 / q$ decays like
# $|x|^{-(2\nu + 1 - \mu)}$, integrable when $2\nu + 1 - \mu > 1$, that is $\mu < 2\nu$. A $t$ proposal
# with somewhat lighter tails ($\nu < \mu < 2\nu$) still gives finite variance for a bounded
# $\varphi$; a Gaussian, whose tails are lighter than any power, never does.
# ```
#
# ## Takeaways
#
# - Importance sampling estimates $\mathbb E_\pi \varphi$ from draws of another density $q$, each
#   weighted by $\pi / q$; normalising the weights removes the unknown constant of a posterior.
# - The self-normalised estimator has asymptotic variance
#   $\mathbb E_q[w^2 (\varphi - I)^2] / N$; the ESS, $1 / \sum_i (W^i)^2$, is a rule of thumb
#   for it that looks at the weights only.
# - A proposal with lighter tails than the target gives weights of infinite variance: the error
#   stops shrinking like $1/\sqrt N$ and the ESS does not warn. Propose wider, never narrower.
# - A particle filter is importance sampling repeated at each step with the incremental weight
#   $p(z_k \mid x_k)\, p(x_k \mid x_{k-1}) / q$; the weighted mean of the incremental weights
#   estimates the likelihood increment, and their product the likelihood, without bias.
