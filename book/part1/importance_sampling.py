# ---
# jupyter:
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Importance sampling
#
# :::{admonition} In this chapter
# :class: chapter-header
# **You learn** why draws from one density, weighted, estimate expectations under another; why
# the weights concentrate on a few draws when the target is much narrower than the proposal;
# how accurate the weighted estimate is, what the effective sample size says and does not say,
# and why a proposal must not have much lighter tails than its target.
#
# **You need** Gaussian densities, the law of large numbers and the central limit theorem;
# NumPy arrays and a random generator.
#
# **Time:** about twenty-one minutes to read, plus about twenty minutes for the folded blocks; the exercises are extra.
# :::

# %% tags=["remove-input"] jupyter={"source_hidden": true}
# Setup: the book's style, evidence and glue helpers (not needed to follow the chapter).
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from scipy import integrate, stats
from scipy.special import gammaln, logsumexp

from pfcourse import evidence
from pfcourse.book.exercises import (
    check_evidence_increment, check_importance_sampler, evidence_increment_case)
from pfcourse.book.panels import control_panel, seed_box
from pfcourse.book.report import EvidenceBlock, glue_values
from pfcourse.book.style import plain_log_axis, use_style

import ipywidgets as widgets
from IPython.display import display

use_style()

# %% [markdown]
# ## The picture: a few draws take the weight
#
# You want the posterior of a state $x$ after a measurement $z$, and you can draw from the prior
# but not from the posterior. Draw from the prior anyway, then let each draw count in proportion
# to how well it explains $z$. That is importance sampling, and every particle filter of this
# book does it at every step.
#
# The toy of this chapter: a prior $x \sim \mathcal N(0, 1)$ and one measurement $z = x + v$,
# $v \sim \mathcal N(0, \sigma_v^2)$, here $z = 1$. The figure draws the same $100$ points from
# the prior, the *proposal* (blue), and stands on each a bar as tall as its *weight*: the ratio
# of the posterior, the *target* (green), to the proposal at that point, scaled so that the
# bars sum to one. On the left the
# measurement is coarse, $\sigma_v = 1$, and the target is about as wide as the proposal; on the
# right it is sharp, $\sigma_v = 0.1$, and the target is ten times narrower.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
z = 1.0
x_grid = np.linspace(-3.5, 3.5, 500)


def log_t3(x):
    """log density of Student's t with 3 degrees of freedom."""
    return stats.t.logpdf(x, 3)


def weigh(x, sd_v, tails="Gaussian"):
    """Normalised weights of the draws x for the toy, z = 1, proposal N(0, 1) or t_3."""
    log_q = stats.norm.logpdf(x) if tails == "Gaussian" else log_t3(x)
    lw = stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x) - log_q
    return np.exp(lw - logsumexp(lw))


def draw_weights(top, bottom, x, sd_v, tails="Gaussian"):
    """Proposal, target and draws above; the draws' weights as bars below."""
    W = weigh(x, sd_v, tails)
    m, sd = z / (1 + sd_v**2), np.sqrt(sd_v**2 / (1 + sd_v**2))
    q = stats.norm.pdf(x_grid) if tails == "Gaussian" else np.exp(log_t3(x_grid))
    label = "proposal q = prior N(0, 1)" if tails == "Gaussian" else "proposal q = Student t3"
    top.plot(x_grid, q, color="tab:blue", label=label)
    top.fill_between(x_grid, stats.norm.pdf(x_grid, m, sd), color="tab:green",
                     alpha=0.3, lw=0, label="target")
    high = 1.15 * max(stats.norm.pdf(0), 1 / (sd * np.sqrt(2 * np.pi)))
    top.plot(x, np.full(len(x), -0.07 * high), "|", color="tab:red", ms=8,
             label="draws")
    top.set_ylim(-0.14 * high, high)
    top.set_ylabel("density")
    bottom.vlines(x, 0, W, color="tab:red", lw=1.2)
    bottom.set_ylabel("weight $W^i$")
    bottom.set_xlabel("state x (no unit)")
    bottom.set_xlim(x_grid[0], x_grid[-1])
    ess = 1.0 / np.sum(W**2)
    top.set_title(rf"$\sigma_v$ = {sd_v:g}: ESS {ess:.1f} of {len(x)}",
                  fontsize=10)
    return ess


x100 = np.random.default_rng(1).standard_normal(100)  # the same 100 draws for every panel
picture_ess = {s: 1.0 / np.sum(weigh(x100, s) ** 2) for s in (1.0, 0.3, 0.1)}
fig, axes = plt.subplots(2, 2, figsize=(7, 4.6), sharex=True, height_ratios=(3, 2))
for col, s in enumerate((1.0, 0.1)):
    draw_weights(axes[0, col], axes[1, col], x100, s)
axes[1, 0].set_ylim(0, axes[1, 1].get_ylim()[1])  # the same weight scale in both columns
axes[0, 0].legend(loc="upper left", fontsize=8)
axes[0, 1].set_ylabel("")
axes[1, 1].set_ylabel("")
fig.tight_layout()
plt.show()

# %% tags=["remove-input"] jupyter={"source_hidden": true}
glue_values("is_picture_ess_", sd1=picture_ess[1.0], sd01=picture_ess[0.1])

# %% [markdown]
# On the left most draws land where the target has mass and share the weight. On the right a
# few draws land in the narrow target, and they take all of it. The *effective sample size*
# (ESS, defined below) counts the draws that still count: with $\sigma_v = 1$ the hundred draws
# are worth {glue:text}`is_picture_ess_sd1:.0f`; with $\sigma_v = 0.1$,
# {glue:text}`is_picture_ess_sd01:.1f`, just under ten. Nothing went wrong on the right: the
# target is simply narrow, and a blind proposal puts only a few draws in it. On the left the bars are tallest
# near $x = z = 1$ while the target peaks at the posterior mean, $z / (1 + \sigma_v^2) = 1/2$
# (derived below): the draws already follow the prior, so the weights carry only the likelihood. A particle filter meets this at
# every step, and the weights of a whole path multiply these ratios together ({doc}`sis`).

# %% [markdown]
# ## Try it
#
# The panel redraws the picture above for the chosen measurement noise $\sigma_v$ (the
# target's width), number of draws $N$, proposal (the prior, Gaussian, or a Student $t$ with
# three degrees of freedom, heavier-tailed: it puts more draws far out, where the target has
# almost no mass, and its weights stay bounded; the section on tails says why that matters) and
# seed, with the ESS in the title. How sharp can the measurement get before a hundred draws are
# worth fewer than ten?

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def draw_panel(sd_v, n_draws, tails, seed):
    r = np.random.default_rng(seed)
    x = r.standard_normal(n_draws) if tails == "Gaussian" else r.standard_t(3, n_draws)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 4.2), sharex=True, height_ratios=(3, 2))
    draw_weights(top, bottom, x, sd_v, tails)
    top.legend(loc="upper left", fontsize=8)
    fig.tight_layout()


# %% tags=["nbval-ignore-output", "hide-input"] jupyter={"source_hidden": true}
display(control_panel(
    draw_panel, grid={"sd_v": (0.1, 0.3, 1.0), "n_draws": (10, 100, 1000)},
    sd_v=widgets.SelectionSlider(options=[0.03, 0.1, 0.3, 1.0, 2.0], value=0.3,
                                 description="measurement sd"),
    n_draws=widgets.SelectionSlider(options=[10, 30, 100, 300, 1000], value=100, description="draws N"),
    tails=widgets.Dropdown(options=["Gaussian", "Student t3"], value="Gaussian", description="proposal"),
    seed=seed_box(1)))

# %% [markdown]
# ## The derivation
#
# In general: we want $I = \mathbb E_\pi \varphi = \int \varphi(x)\, \pi(x)\, dx$ under a
# *target* density $\pi$, for a function $\varphi$ (the state itself, an indicator, ...), and
# we can draw from another density $q$, the *proposal*, positive wherever $\pi$ is. Multiply
# and divide by it:
#
# $$
# \mathbb E_\pi \varphi = \int \varphi(x)\, \frac{\pi(x)}{q(x)}\, q(x)\, dx
#   = \mathbb E_q\big[ w(x)\, \varphi(x) \big], \qquad w(x) = \frac{\pi(x)}{q(x)} .
# $$
#
# An average of draws $x^i \sim q$ estimates an expectation under $q$, so
# $\frac1N \sum_i w(x^i)\, \varphi(x^i) \to I$: each draw counts in proportion to its weight,
# large where $\pi$ puts more mass than $q$. A posterior is known only up to a constant,
# $\pi = \tilde\pi / Z$ with $\tilde\pi(x) = p(z \mid x)\, p(x)$ and $Z = p(z)$. The constant is
# itself an expectation under $q$, $Z = \mathbb E_q[\tilde\pi / q]$, so with the unnormalised
# weights $\tilde w^i = \tilde\pi(x^i) / q(x^i)$:
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
# 3. **Normalise:** $\log W^i = \log \tilde w^i - \operatorname{logsumexp}_j \log \tilde w^j$,
#    and $\log \hat Z = \operatorname{logsumexp}_j \log \tilde w^j - \log N$.
# 4. **Estimate:** $\hat I_N = \sum_i W^i \varphi(x^i)$, and
#    $\mathrm{ESS} = 1 / \sum_i (W^i)^2$.
# :::
#
# On the toy the answer is exact: the posterior is
# $\mathcal N\big(z / (1 + \sigma_v^2),\ \sigma_v^2 / (1 + \sigma_v^2)\big)$ and
# $Z = \mathcal N(z; 0, 1 + \sigma_v^2)$. Here is Algorithm 3.1 with the prior as proposal, for
# $z = 1$, $\sigma_v = 0.3$ and $N = 30$ draws, against the exact answers. The weights stay in
# the log domain: `logsumexp` subtracts the largest before exponentiating, so they cannot all
# underflow to zero.

# %%
# the checkers of exercises 3.1 and 3.2, at the end of the chapter
from pfcourse.book.exercises import (
    check_evidence_increment, check_importance_sampler)
import numpy as np
from scipy import stats
from scipy.special import logsumexp

z, sd_v, N = 1.0, 0.3, 30
rng = np.random.default_rng(0)
# 1. draw from the proposal, the prior N(0, 1)
x = rng.standard_normal(N)
# 2. log w~ = log p(z | x) + log p(x) - log q(x): the log-likelihood
log_w = stats.norm.logpdf(z, loc=x, scale=sd_v)
# 3. normalise, and estimate log Z
log_W = log_w - logsumexp(log_w)
log_Z = logsumexp(log_w) - np.log(N)
W = np.exp(log_W)
# 4. estimate the posterior mean (phi(x) = x), and the ESS
estimate, ess = W @ x, 1.0 / np.sum(W**2)

post_mean = z / (1 + sd_v**2)
post_sd = np.sqrt(sd_v**2 / (1 + sd_v**2))
Z_exact = stats.norm.pdf(z, 0, np.sqrt(1 + sd_v**2))
print(f"posterior mean: estimate {estimate:.3f}, exact {post_mean:.3f}")
print(f"Z: estimate {np.exp(log_Z):.3f}, exact {Z_exact:.3f}")
print(f"ESS {ess:.1f} of {N}")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
grid = np.linspace(-3, 3, 400)
fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7, 4.2), sharex=True, height_ratios=(3, 2))
ax.plot(grid, stats.norm.pdf(grid), color="tab:blue", label=r"proposal $q$ = prior N(0, 1)")
ax.plot(grid, stats.norm.pdf(grid, post_mean, post_sd), color="tab:green", label=r"target $\pi$ = posterior")
ax.plot(x, np.zeros(N), "|", color="tab:red", ms=10, label=r"draws $x^i \sim q$")
ax.set_ylabel("density")
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
# weight: the thirty draws are worth far fewer draws from the posterior itself. How many,
# and how accurate is the estimate?
#
# ## How accurate: the variance, and the ESS
#
# The picture suggests the answer: $N$ weighted draws behave like
# $\mathrm{ESS} = 1 / \sum_i (W^i)^2$ draws from the target (Algorithm 3.1), so the estimate
# should scatter like an average of ESS independent draws,
# $\operatorname{Var}_\pi(\varphi) / \mathrm{ESS}$. The derivation below shows how far this
# holds, and when it fails.
#
# Take $w = \pi / q$ with $\pi$ the normalised posterior, so $\mathbb E_q w = 1$ (the constant
# cancels in $\hat I_N$), and
# write the error as a ratio of two averages:
#
# $$
# \hat I_N - I = \frac{\frac1N \sum_i w(x^i)\,\big(\varphi(x^i) - I\big)}{\frac1N \sum_i w(x^i)} .
# $$
#
# The numerator averages independent terms of mean $\mathbb E_\pi[\varphi - I] = 0$ and variance
# $\mathbb E_q[w^2 (\varphi - I)^2]$; the denominator tends to $1$. By the central limit theorem
# {cite:p}`geweke1989`, $\sqrt N\, (\hat I_N - I)$ tends to a Gaussian of variance
#
# $$
# V(\varphi) = \mathbb E_q\big[w^2\, (\varphi - I)^2\big] = \mathbb E_\pi\big[w\, (\varphi - I)^2\big],
# $$
#
# finite when that expectation is. Replace $(\varphi - I)^2$ by its average under $\pi$, as if
# the weight and the function did not vary together, and
# $V(\varphi) \approx \operatorname{Var}_\pi(\varphi)\, \mathbb E_q[w^2]$. This is the approximation
# of {cite:t}`kong1992` and {cite:t}`kong1994`:
#
# $$
# \operatorname{Var}(\hat I_N) \approx \frac{\operatorname{Var}_\pi(\varphi)}{\mathrm{ESS}_\infty}, \qquad
# \mathrm{ESS}_\infty = \frac{N}{\mathbb E_q[w^2]} \approx \frac{1}{\sum_i (W^i)^2} .
# $$
#
# The last form is the one measured from the weights. The normalised weights $W^i$ do not
# depend on the constant, so write them with $w^i = w(x^i)$; by the law of large numbers,
#
# $$
# \frac{1}{N \sum_i (W^i)^2} = \frac{\big(\frac1N \sum_i w^i\big)^2}{\frac1N \sum_i (w^i)^2}
# \;\longrightarrow\; \frac{(\mathbb E_q w)^2}{\mathbb E_q[w^2]} = \frac{1}{\mathbb E_q[w^2]}
# \quad \text{almost surely.}
# $$
#
# The limit is $1$ only when $q = \pi$, and it falls as the weights spread:
# $\mathbb E_q[w^2] = 1 + \operatorname{Var}_q w$, so $\mathrm{ESS}_\infty = N / (1 + \mathrm{cv}^2)$,
# with $\mathrm{cv}$ the coefficient of variation of the weights {cite:p}`kong1992,liu2001`;
# $\operatorname{Var}_q w$ is the $\chi^2$ divergence of $\pi$ from $q$. When
# $\mathbb E_q[w^2] = \infty$, ESS / $N$ tends to $0$, the symptom the section on tails meets.
# So $N$ weighted draws are worth about ESS draws from $\pi$, for a $\varphi$ that does not vary
# with the weights: the ESS looks at the weights only.
#
# On the toy, with $N = 100$ and $\varphi(x) = x$, the asymptotic variance holds at
# $\sigma_v = 1$: the variance of the estimates over {glue:text}`is_toy_reps:,d` seeded
# repetitions is {glue:text}`is_var_ratio_sd1:.2f`
# ({glue:text}`is_var_ratio_sd1_low:.2f`-{glue:text}`is_var_ratio_sd1_high:.2f`) times
# $V(\varphi) / N$, with $V(\varphi)$ by quadrature; call this the *CLT ratio*.
#
# It is only a limit: at $\sigma_v = 0.3$, where the hundred draws are worth about
# {glue:text}`is_ess_sd03:.0f`, the CLT ratio is already {glue:text}`is_var_ratio_sd03:.2f`
# ({glue:text}`is_var_ratio_sd03_low:.2f`-{glue:text}`is_var_ratio_sd03_high:.2f`): the
# terms of order $1/N^2$ that the limit drops grow as the ESS falls, and are no longer
# negligible.

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def quad(f, lo, hi, at):
    """Integral of f over [lo, hi], split at the points where f may jump."""
    return integrate.quad(f, lo, hi, points=[p for p in at if lo < p < hi], limit=200)[0]


def kong_ratio(sd_v, z, phi):
    """V(phi) / (Var_pi(phi) E_q w^2) on the toy, by quadrature; w = pi / q, q = N(0, 1).

    phi(x, m, s) may use the posterior mean m and sd s. Returns the ratio, V(phi), Var_pi(phi) and E_q w^2.
    """
    m, s = z / (1 + sd_v**2), np.sqrt(sd_v**2 / (1 + sd_v**2))
    pi = lambda x: stats.norm.pdf(x, m, s)
    w2q = lambda x: pi(x) ** 2 / stats.norm.pdf(x)  # w^2 q = pi^2 / q
    lo, hi, at = m - 12 * s, m + 12 * s, (m + s, m + 1.5 * s)
    I = quad(lambda x: phi(x, m, s) * pi(x), lo, hi, at)
    var_pi = quad(lambda x: (phi(x, m, s) - I) ** 2 * pi(x), lo, hi, at)
    V_phi = quad(lambda x: w2q(x) * (phi(x, m, s) - I) ** 2, lo, hi, at)
    Ew2 = quad(w2q, lo, hi, at)
    return V_phi / (var_pi * Ew2), V_phi, var_pi, Ew2


identity = lambda x, m, s: x
above_1sd = lambda x, m, s: 1.0 * (x > m + s)
above_15sd = lambda x, m, s: 1.0 * (x > m + 1.5 * s)

N, reps = 100, 2000
toy_rng = np.random.default_rng(0)  # its own generator: editing the code above does not change it
toy = {}
for sd_v in (1.0, 0.3, 0.1):
    x = toy_rng.standard_normal((reps, N))
    log_w = stats.norm.logpdf(z, loc=x, scale=sd_v)
    W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
    post_var = sd_v**2 / (1 + sd_v**2)
    kong, V_phi, _, Ew2 = kong_ratio(sd_v, z, identity)
    toy[sd_v] = dict(estimate=np.sum(W * x, axis=1), ess=1.0 / np.sum(W**2, axis=1), post_var=post_var,
                     V_phi=V_phi, Ew2=Ew2, kong=kong)

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def toy_row(sd_v):
    t = toy[sd_v]
    var_ratio = evidence.run_interval(lambda r: N * t["estimate"][r].var(ddof=1) / t["V_phi"], reps)
    kong = evidence.run_interval(lambda r: t["estimate"][r].var(ddof=1) * t["ess"][r].mean() / t["post_var"], reps)
    return {"sd_v": sd_v, "exact mean": z / (1 + sd_v**2), "mean of estimates": t["estimate"].mean(),
            "N Var(estimates)": N * t["estimate"].var(ddof=1), "V(phi) (quadrature)": t["V_phi"],
            "CLT ratio": var_ratio[0], "CLT ratio low": var_ratio[1], "CLT ratio high": var_ratio[2],
            "mean ESS": t["ess"].mean(), "N / E_q w^2": N / t["Ew2"],
            "Kong's ratio (measured)": kong[0], "low": kong[1], "high": kong[2],
            "Kong's ratio (limit)": t["kong"]}


toy_table = pd.DataFrame([toy_row(s) for s in toy])
# the 1/N^2 terms at sd_v = 0.3: the same ratio with ten times more draws (its own generator, seed 1)
x_big = np.random.default_rng(1).standard_normal((reps, 10 * N))
log_w_big = stats.norm.logpdf(z, loc=x_big, scale=0.3)
est_big = np.sum(np.exp(log_w_big - logsumexp(log_w_big, axis=1, keepdims=True)) * x_big, axis=1)
ratio_big = evidence.run_interval(lambda r: 10 * N * est_big[r].var(ddof=1) / toy[0.3]["V_phi"], reps)
row = {s: toy_table.iloc[i] for i, s in enumerate(toy)}
glue_values(is_toy_reps=reps, is_var_ratio_sd1=row[1.0]["CLT ratio"], is_var_ratio_sd1_low=row[1.0]["CLT ratio low"],
            is_var_ratio_sd1_high=row[1.0]["CLT ratio high"],
            is_var_ratio_sd03=row[0.3]["CLT ratio"], is_var_ratio_sd03_low=row[0.3]["CLT ratio low"],
            is_var_ratio_sd03_high=row[0.3]["CLT ratio high"], is_ess_sd03=row[0.3]["mean ESS"],
            kong_ratio_r1=row[1.0]["Kong's ratio (measured)"],
            is_kong_predicted_sd1=row[1.0]["Kong's ratio (limit)"])
EvidenceBlock(
    "the asymptotic variance predicts the estimates' spread",
    notes=[f"N = {N} prior draws, z = {z}, {reps} seeded repetitions per measurement sd (one generator of its own, "
           "seed 0, drawn in turn). The CLT ratio is N Var(estimates) / V(phi), with its 95 % percentile-bootstrap interval "
           f"over the repetitions ({evidence.N_RESAMPLES} resamples, see Reading the evidence); Kong's ratio (measured) is "
           "the variance of the estimates over Var_pi / (mean ESS), with its interval (low, high), and Kong's ratio (limit) "
           "is V(phi) / (Var_pi E_q w^2) by quadrature.",
           f"At sd 0.1, where the hundred draws are worth about {row[0.1]['mean ESS']:.0f}, the measured variance is "
           f"{row[0.1]['CLT ratio']:.2f} times V(phi) / N: the terms of order 1/N^2 that the limit drops are not "
           "negligible when the ESS is a handful. "
           f"At sd 0.3 and N = {10 * N} (seed 1) the ratio is {ratio_big[0]:.2f} ({ratio_big[1]:.2f} to {ratio_big[2]:.2f}), "
           f"against {row[0.3]['CLT ratio']:.2f} at N = {N}: the excess shrinks as N grows. Kong's ratio (limit) uses the ESS of the limit, N / E_q w^2; "
           "the measured one the mean of 1 / sum W^2, which differs at small N. At N = 100 the estimator's O(1/N) "
           "bias is far below its spread (compare the two means)."],
    tables=[("The CLT ratio on the Gaussian toy, phi(x) = x",
             toy_table[["sd_v", "exact mean", "mean of estimates", "N Var(estimates)", "V(phi) (quadrature)",
                        "CLT ratio", "CLT ratio low", "CLT ratio high"]],
             {"exact mean": ".4f", "mean of estimates": ".4f", "N Var(estimates)": ".4f", "V(phi) (quadrature)": ".4f",
              "CLT ratio": ".3f", "CLT ratio low": ".3f", "CLT ratio high": ".3f"}),
            ("Kong's ratio on the Gaussian toy, phi(x) = x",
             toy_table[["sd_v", "mean ESS", "N / E_q w^2", "Kong's ratio (measured)", "low", "high",
                        "Kong's ratio (limit)"]],
             {"mean ESS": ".1f", "N / E_q w^2": ".1f", "Kong's ratio (measured)": ".2f", "low": ".2f", "high": ".2f",
              "Kong's ratio (limit)": ".2f"})],
)

# %% [markdown]
# The rule $\operatorname{Var}_\pi(\varphi) / \mathrm{ESS}$ can err either way; here is why, then
# both cases. Since $w = \pi / q$, $\mathbb E_q[w^2] = \int \pi^2 / q = \mathbb E_\pi[w]$, so the exact ratio
# of $V(\varphi)$ to Kong's $\operatorname{Var}_\pi(\varphi)\, \mathbb E_q[w^2]$, *Kong's ratio*, is
# $\mathbb E_\pi[w\, (\varphi - I)^2] / (\mathbb E_\pi[w]\, \operatorname{Var}_\pi \varphi)$: the
# average of $(\varphi - I)^2$ under the density $\pi^2 / q$ (normalised), over its average
# under $\pi$. It is above $1$ when the large weights fall where $\varphi$ is far from its mean,
# below $1$ when they fall where it is close. Take $\varphi(x) = x$, $z = 1$, $\sigma_v = 1$:
# the weight $w \propto p(z \mid x)$ peaks at $x = z = 1$, only $1/\sqrt 2$ of a posterior
# standard deviation above the posterior mean $1/2$, where $(x - I)^2 = 1/4$ is below
# $\operatorname{Var}_\pi = 1/2$. Exactly: with $\pi = \mathcal N(1/2,\ 1/2)$ and
# $q = \mathcal N(0, 1)$, $\pi^2 / q$ has precision $2 \cdot 2 - 1 = 3$ (twice $\pi$'s, minus
# $q$'s) and mean $(2 \cdot 2 \cdot \frac12) / 3 = 2/3$, so $\pi^2 / q \propto \mathcal N(2/3,\ 1/3)$.
# The average of $(x - 1/2)^2$ under it is its variance, $1/3$, plus the square of its mean's
# offset, $(2/3 - 1/2)^2 = 1/36$; so the ratio is $(1/3 + 1/36) / (1/2) = 13/18$, or
# {glue:text}`is_kong_predicted_sd1:.2f` by quadrature (measured:
# {glue:text}`kong_ratio_r1:.2f`): here the rule overstates the variance.

# %% [markdown]
# The rule can err the other way too, and being a tail probability does not decide which: where
# the large weights fall does. With $m$ and $s$ the posterior mean and standard deviation,
# $\varphi = \mathbb 1\{x > m + s\}$ at $\sigma_v = 1$, $z = 1$ gives the ratio
# {glue:text}`is_kong_tail_z1:.2f`. A surprising measurement, $z = 3$, puts the posterior where
# the prior proposal is thin and the large weights in its upper tail: for
# $\varphi = \mathbb 1\{x > m + 1.5 s\}$ the ratio is {glue:text}`is_kong_tail_z3:.2f`, so
# in the limit the true variance is about twice $\operatorname{Var}_\pi(\varphi) / \mathrm{ESS}$.
#
# At $N = 100$ the measured ratio, {glue:text}`is_kong_tail_z3_mc:.2f`
# ({glue:text}`is_kong_tail_z3_mc_low:.2f`-{glue:text}`is_kong_tail_z3_mc_high:.2f`), is still
# below its limit: the hundred draws are worth about {glue:text}`is_kong_tail_z3_ess:.0f`, and
# the terms of order $1/N^2$, which grow as the ESS falls, are not negligible.
#
# With $N = 1000$ the measured ratio is {glue:text}`is_kong_tail_z3_mc_big:.2f`, close to its
# limit. The next section meets the opposite case, a tail probability whose rule overstates the
# variance.
#
# What the ESS does bound is the error of every bounded function: for $|\varphi| \le 1$ the mean
# square error of $\hat I_N$ is at most $4\, \mathbb E_q[w^2] / N = 4 / \mathrm{ESS}_\infty$
# {cite:p}`agapiou2017`; {cite:t}`chopin2020` (their chapter on importance sampling) give this and the CLT above. The bound
# is on the population ESS; the ESS measured from the weights is an estimate of it, and the
# next section shows when that estimate fails.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
tail_cases = {"1{x > m + s}, z = 1": (1.0, 1.0, above_1sd), "1{x > m + 1.5 s}, z = 3": (1.0, 3.0, above_15sd)}
kong_tail = {name: kong_ratio(*case) for name, case in tail_cases.items()}
check_rng = np.random.default_rng(3)  # a seeded Monte Carlo check of the quadrature, N = 100
t1 = toy[1.0]
tail_ess = {"x, z = 1": t1["ess"].mean()}
tail_mc = {"x, z = 1": evidence.run_interval(lambda r: N * t1["estimate"][r].var(ddof=1) / (t1["post_var"] * t1["Ew2"]),
                                             reps)}
for name, (s_v, z_c, phi) in tail_cases.items():
    x = check_rng.standard_normal((reps, N))
    log_w = stats.norm.logpdf(z_c, loc=x, scale=s_v)
    W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
    m, s = z_c / (1 + s_v**2), np.sqrt(s_v**2 / (1 + s_v**2))
    est = np.sum(W * phi(x, m, s), axis=1)
    tail_mc[name] = evidence.run_interval(lambda r: N * est[r].var(ddof=1) / (kong_tail[name][2] * kong_tail[name][3]),
                                          reps)
    tail_ess[name] = (1.0 / np.sum(W**2, axis=1)).mean()
# the z = 3 case again with ten times more draws (its own generator, seed 4): the 1/N^2 terms fade
z3 = "1{x > m + 1.5 s}, z = 3"
x = np.random.default_rng(4).standard_normal((reps, 10 * N))
log_w = stats.norm.logpdf(3.0, loc=x, scale=1.0)
W = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True))
est = np.sum(W * above_15sd(x, 1.5, np.sqrt(0.5)), axis=1)
z3_big = evidence.run_interval(lambda r: 10 * N * est[r].var(ddof=1) / (kong_tail[z3][2] * kong_tail[z3][3]), reps)
glue_values("is_kong_", tail_z1=kong_tail["1{x > m + s}, z = 1"][0], tail_z3=kong_tail[z3][0],
            tail_z3_mc=tail_mc[z3][0], tail_z3_mc_low=tail_mc[z3][1], tail_z3_mc_high=tail_mc[z3][2],
            tail_z3_ess=tail_ess[z3], tail_z3_mc_big=z3_big[0])
EvidenceBlock(
    "the ESS rule errs either way: where the large weights fall decides",
    notes=["Kong's ratio V(phi) / (Var_pi(phi) E_q w^2) on the toy (sd_v = 1, prior proposal), by quadrature; the "
           "identity V(phi) = E_q[w^2 (phi - I)^2] = E_pi[w (phi - I)^2] holds for w = pi / q with E_q w = 1.",
           f"Monte Carlo check: N = {N}, {reps} repetitions (seed 3), N Var(estimates) over Var_pi(phi) E_q w^2, "
           "with its 95 % percentile-bootstrap interval over the repetitions.",
           f"The z = 3 case at N = {10 * N} ({reps} repetitions, seed 4): {z3_big[0]:.2f} ({z3_big[1]:.2f} to "
           f"{z3_big[2]:.2f}), against {tail_mc[z3][0]:.2f} at N = {N} and the limit {kong_tail[z3][0]:.2f}."],
    tables=[("Kong's approximation against the exact asymptotic variance", pd.DataFrame(
        [{"phi": "x, z = 1", "Kong's ratio (quadrature)": t1["kong"], "E_q w^2": t1["Ew2"],
          "mean ESS (N = 100)": tail_ess["x, z = 1"], "Kong's ratio (N = 100)": tail_mc["x, z = 1"][0],
          "low": tail_mc["x, z = 1"][1], "high": tail_mc["x, z = 1"][2]}]
        + [{"phi": name, "Kong's ratio (quadrature)": kong_tail[name][0], "E_q w^2": kong_tail[name][3],
            "mean ESS (N = 100)": tail_ess[name], "Kong's ratio (N = 100)": tail_mc[name][0],
            "low": tail_mc[name][1], "high": tail_mc[name][2]}
           for name in tail_cases]),
        {"Kong's ratio (quadrature)": ".3f", "E_q w^2": ".2f", "mean ESS (N = 100)": ".1f",
         "Kong's ratio (N = 100)": ".2f", "low": ".2f", "high": ".2f"})],
)

# %% [markdown]
# ## When the proposal's tails are too light
#
# The variance $V(\varphi)$ is finite only if $\mathbb E_q[w^2 (\varphi - I)^2]$ is, and
# $\mathbb E_q[w^2] = \int \pi^2 / q$ is infinite when $\pi^2 / q$ is not integrable, that is
# when $q$ has much lighter tails than $\pi$. Slightly lighter tails are not enough to break it:
# the weights are then unbounded but can keep a finite variance (a Gaussian $q$ with
# $\sigma_q^2 > \sigma_\pi^2 / 2$ does, and {ref}`exercise 3.4 <ex-is-tails>` finds the same for
# Student proposals). With infinite variance the central limit theorem does not
# apply and the ESS cannot be trusted. Take a Student $t$ target with $\nu = 3$ degrees of freedom, whose tails
# decay like $|x|^{-4}$, and estimate the probability of its tails, $\varphi(x) = \mathbb 1\{|x| > 3\}$
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
ax.set_ylim(top=0.15)
ax.set_yticks([0.003, 0.01, 0.03, 0.05, 0.1], ["0.003", "0.01", "0.03", "0.05", "0.1"])
ax.set_xlabel("number of draws N")
ax.set_ylabel(r"RMS error of $P(|x| > 3)$ (probability)")
ax.set_title(rf"Target Student t, $\nu$ = {nu}; {runs} runs per N", fontsize=10)
ax.legend(loc="lower left")
fig.tight_layout()
plt.show()

# %% [markdown]
# With the normal proposal the error hardly shrinks: its root mean square falls as $N^{b}$ with
# $b$ = {glue:text}`is_tail_slope_normal:.2f`
# ({glue:text}`is_tail_slope_normal_low:.2f`-{glue:text}`is_tail_slope_normal_high:.2f`),
# not $-1/2$. The draws rarely reach $|x| > 3$, and when one does its weight is huge.

# %% [markdown]
# A single ESS does not warn: at $N = 10^3$ the normal proposal's mean ESS is
# {glue:text}`is_tail_ess_normal:.0%` of $N$, which looks healthy, yet the interval it implies,
# $\hat I_N \pm 1.96 \sqrt{\hat I_N (1 - \hat I_N) / \mathrm{ESS}}$ (the variance of an indicator
# is $I (1 - I)$), covers the exact answer in only {glue:text}`is_tail_cover_normal:.0%` of the
# runs (at most {glue:text}`is_tail_cover_normal_high:.0%`). A diagnostic made of the draws
# cannot see the mass the draws never reach.
#
# The fall of the ESS as $N$ grows does give the trouble away:
# the mean ESS is {glue:text}`is_tail_ess_normal_small:.0%` of $N$ at $N = 10^2$ and
# {glue:text}`is_tail_ess_normal_large:.0%` at $N = 10^4$, while with the Cauchy proposal it
# stays at {glue:text}`is_tail_ess_cauchy_large:.0%`, near its limit $1 / \mathbb E_q[w^2]$. A
# falling ESS / $N$ is the symptom of $\mathbb E_q[w^2] = \infty$.
#
# At $N = 10^2$ the Cauchy's mean ESS is also {glue:text}`is_tail_ess_cauchy_small:.0%` of $N$,
# yet the normal's RMS error is {glue:text}`is_tail_rms_ratio_small:.1f` times the Cauchy's:
# equal ESS, unequal accuracy.

# %% [markdown]
# The Cauchy proposal restores the rate: slope {glue:text}`is_tail_slope_cauchy:.2f`
# ({glue:text}`is_tail_slope_cauchy_low:.2f`-{glue:text}`is_tail_slope_cauchy_high:.2f`).
#
# Here the ESS rule errs the other way: the interval covers the exact answer in
# {glue:text}`is_tail_cover_cauchy:.0%` of the runs at $N = 10^3$, more than the nominal $95\,\%$,
# because the Cauchy spreads its large weights over the tails and the ratio of the true variance
# to the rule's is {glue:text}`is_tail_kong_cauchy:.2f` by quadrature.
#
# The lesson carries over to filters: heavier tails than the target's are always safe in the
# tails (the proposal must still not be thin where the target has mass); somewhat lighter tails
# cost variance
# (a Gaussian's $\mathbb E_q[w^2]$ blows up as $\sigma_q^2$ falls to $\sigma_\pi^2 / 2$); much
# lighter tails give infinite variance. Too wide costs ESS; too narrow costs the rate and the
# error bars, not the limit: the normal proposal's mean error still shrinks, from
# {glue:text}`is_tail_bias_normal_small:+.3f` at $N = 10^2$ to
# {glue:text}`is_tail_bias_normal_large:+.3f` at $N = 10^4$, but its RMS error falls far slower
# than $1/\sqrt N$ and its intervals cover too rarely.

# %% tags=["remove-input"] jupyter={"source_hidden": true}
def rms_slope(err):
    """Slope of log RMS error against log N, with its interval over the runs."""
    return evidence.log_slope(err.T, sizes, center=lambda e, axis: np.sqrt(np.mean(e**2, axis=axis)))


slopes = {name: rms_slope(t["err"]) for name, t in tail.items()}
# Kong's ratio V(phi) / (Var_pi(phi) E_q w^2) for the Cauchy proposal, by quadrature (pi^2 / q integrable)
pi2_q = lambda x: np.exp(2 * log_student(x, nu) - log_student(x, 1))
cuts = (-np.inf, -3.0, 3.0, np.inf)
Ew2_cauchy = sum(integrate.quad(pi2_q, a, b)[0] for a, b in zip(cuts[:-1], cuts[1:]))
V_phi_cauchy = sum(integrate.quad(lambda x: pi2_q(x) * ((abs(x) > 3) - exact) ** 2, a, b)[0]
                    for a, b in zip(cuts[:-1], cuts[1:]))
kong_cauchy = V_phi_cauchy / (exact * (1 - exact) * Ew2_cauchy)
cover = {name: [evidence.rate(t["covered"][:, j]) for j in range(len(sizes))] for name, t in tail.items()}
glue_values("is_tail_", runs=runs, slope_normal=slopes["normal N(0, 1)"][0], slope_normal_low=slopes["normal N(0, 1)"][1],
            slope_normal_high=slopes["normal N(0, 1)"][2], slope_cauchy=slopes["Cauchy t_1"][0],
            slope_cauchy_low=slopes["Cauchy t_1"][1], slope_cauchy_high=slopes["Cauchy t_1"][2],
            ess_normal=tail["normal N(0, 1)"]["ess"][:, 1].mean() / sizes[1],
            cover_normal=cover["normal N(0, 1)"][1].estimate, cover_normal_high=cover["normal N(0, 1)"][1].high,
            ess_normal_small=tail["normal N(0, 1)"]["ess"][:, 0].mean() / sizes[0],
            ess_normal_large=tail["normal N(0, 1)"]["ess"][:, 2].mean() / sizes[2],
            ess_cauchy_large=tail["Cauchy t_1"]["ess"][:, 2].mean() / sizes[2],
            ess_cauchy_small=tail["Cauchy t_1"]["ess"][:, 0].mean() / sizes[0],
            rms_ratio_small=np.sqrt(np.mean(tail["normal N(0, 1)"]["err"][:, 0] ** 2)
                                    / np.mean(tail["Cauchy t_1"]["err"][:, 0] ** 2)),
            bias_normal_small=tail["normal N(0, 1)"]["err"][:, 0].mean(),
            bias_normal_large=tail["normal N(0, 1)"]["err"][:, 2].mean(),
            cover_cauchy=cover["Cauchy t_1"][1].estimate, kong_cauchy=kong_cauchy)
EvidenceBlock(
    "with a proposal lighter-tailed than the target, the error does not shrink like 1/sqrt(N) and the ESS falls with N",
    notes=[f"Target t with {nu} degrees of freedom, phi = 1{{|x| > 3}}, exact I = {exact:.4f}. {runs} runs; run s "
           "draws from the generator of seed s for every N and both proposals (common random numbers).",
           "Slope of log RMS error on log N (least squares over the three N), 95 % percentile-bootstrap interval "
           f"over the runs ({evidence.N_RESAMPLES} resamples): " + "; ".join(f"{n}: {v:.2f} ({lo:.2f} to {hi:.2f})"
                                                           for n, (v, lo, hi) in slopes.items()) + ".",
           "Coverage: share of runs whose interval estimate ± 1.96 sqrt(I^(1 - I^) / ESS) contains I, with its "
           "Wilson interval (see Reading the evidence).",
           f"Cauchy proposal, by quadrature: E_q w^2 = {Ew2_cauchy:.4f} (so ESS / N tends to {1 / Ew2_cauchy:.2f}); "
           f"Kong's ratio V(phi) / (Var_pi(phi) E_q w^2) = {kong_cauchy:.3f}, below 1: the ESS rule overstates the variance."],
    tables=[("RMS error, mean ESS / N and coverage, per proposal and N",
             pd.DataFrame([{"proposal": name, "N": n, "RMS error": np.sqrt(np.mean(t["err"][:, j] ** 2)),
                            "mean error": t["err"][:, j].mean(), "mean ESS / N": t["ess"][:, j].mean() / n,
                            "coverage": cover[name][j].estimate, "low": cover[name][j].low, "high": cover[name][j].high}
                           for name, t in tail.items() for j, n in enumerate(sizes)]),
             {"RMS error": ".4f", "mean error": "+.4f", "mean ESS / N": ".2f", "coverage": ".0%", "low": ".0%",
              "high": ".0%"})],
)

# %% [markdown]
# ## Exercises
#
# ```{exercise} 3.1 A proposal that is not the prior
# :label: ex-is-proposal
# :nonumber:
# (Coding.) On the toy, propose from $q = \mathcal N(z/2,\ 1)$, halfway between the prior mean and
# the measurement, instead of the prior. Write `estimate_mean(z, sd_v, n, rng)`: draw $n$ particles
# from $q$ with the generator `rng`, weight them by $\tilde\pi / q$ in the log domain, and return
# the self-normalised estimate of the posterior mean and the ESS. The checker runs it at $z = 3$,
# $\sigma_v = 0.5$, compares it with the exact mean $z / (1 + \sigma_v^2)$ and names the
# mistake it sees; then at $z = 60$, $\sigma_v = 1$, a measurement so surprising that
# $p(z \mid x)\, p(x)$ is about $e^{-900}$ at every draw, below the smallest positive float;
# there $q = \mathcal N(30, 1)$ sits on the posterior $\mathcal N(30, 1/2)$, so only the
# arithmetic can fail.
# ```

# %% tags=["answer"]
def estimate_mean(z, sd_v, n, rng):
    """Your sampler: return (estimate of the posterior mean, ESS)."""
    ...  # replace with your code


print(check_importance_sampler(estimate_mean))

# %% [markdown]
# ```{solution} ex-is-proposal
# :class: dropdown
# The weight has three terms now: $\log \tilde w^i = \log p(z \mid x^i) + \log p(x^i) - \log q(x^i)$;
# with the prior as proposal the last two cancel, here they do not. The code is in the folded cell
# below (in JupyterLab, click its margin to unfold it).
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def estimate_mean(z, sd_v, n, rng):
    x = z / 2 + rng.standard_normal(n)
    log_w = (stats.norm.logpdf(z, loc=x, scale=sd_v) + stats.norm.logpdf(x)
             - stats.norm.logpdf(x, z / 2, 1.0))
    W = np.exp(log_w - logsumexp(log_w))
    return W @ x, 1.0 / np.sum(W**2)


print(check_importance_sampler(estimate_mean))

# %% [markdown]
# ```{exercise} 3.2 How likely was the new measurement?
# :label: ex-is-weights
# :nonumber:
# (Coding.) A filter holds particles $x^i$ with normalised log-weights $\log W^i$ and receives a
# measurement $z_k$. Before it reweights, the same sums estimate how likely $z_k$ was given the
# past, $p(z_k \mid z_{1:k-1}) \approx \sum_i W^i\, p(z_k \mid x^i)$, the factor the filters of
# later chapters multiply into the likelihood of a whole sequence. Write
# `log_evidence_increment(log_W, log_lik)` returning its log, with `log_lik[i]` $= \log p(z_k \mid x^i)$,
# and check it with `check_evidence_increment`: its particles represent a Gaussian, so the exact
# value is known. Then write it in the linear domain, `np.log(np.sum(np.exp(...)))`, and read what
# the check says when the likelihoods are near $e^{-1000}$.
# ```

# %% tags=["answer"]
def log_evidence_increment(log_W, log_lik):
    """Your estimate of log p(z_k | z_1:k-1) from weighted particles."""
    ...  # replace with your code


print(check_evidence_increment(log_evidence_increment))

# %% [markdown]
# ```{solution} ex-is-weights
# :class: dropdown
# The increment is a weighted average of the likelihoods, so its log is the logsumexp of
# $\log W^i + \log p(z_k \mid x^i)$; no $1/N$, since the $W^i$ already sum to one. The code is
# in the folded cell below (in JupyterLab, click its margin to unfold it), with the exact Gaussian
# value beside it. The linear-domain version fails the case whose likelihoods are near
# $e^{-1000}$: every term underflows to $0$ and the log of the sum is $-\infty$, as the second
# folded cell shows.
# ```

# %% tags=["solution", "hide-input"] jupyter={"source_hidden": true}
def log_evidence_increment(log_W, log_lik):
    return logsumexp(log_W + log_lik)


print(check_evidence_increment(log_evidence_increment))
case_W, case_lik, case_exact = evidence_increment_case(0)
print(f"estimate {log_evidence_increment(case_W, case_lik):.4f}, exact {case_exact:.4f}")

# %% tags=["hide-input"] jupyter={"source_hidden": true}
def increment_linear(log_W, log_lik):
    return np.log(np.sum(np.exp(log_W) * np.exp(log_lik)))


print(check_evidence_increment(increment_linear))

# %% [markdown]
# ```{exercise} 3.3 What the ESS counts
# :label: ex-is-ess
# :nonumber:
# Show that $1 \le 1/\sum_i (W^i)^2 \le N$ for normalised weights, with $N$ only when they are
# all equal and $1$ only when one draw has all the weight. If $k$ of the draws share the weight
# equally and the others have none, what is the ESS? For weights proportional to
# $1, 2, \dots, N$, what fraction of $N$ does it tend to as $N$ grows?
# ```
#
# ```{solution} ex-is-ess
# :class: dropdown
# The $W^i$ are at least $0$ and sum to $1$, so $\sum_i (W^i)^2 \le \max_i W^i \le 1$; the first
# step is an equality only if every non-zero weight equals $\max_i W^i$, the second only if
# $\max_i W^i = 1$, so $\sum_i (W^i)^2 = 1$ exactly when one weight is $1$. By Cauchy-Schwarz
# $1 = \big(\sum_i W^i\big)^2 \le N \sum_i (W^i)^2$, with equality exactly when $W$ is
# proportional to $(1, \dots, 1)$, that is all $W^i = 1/N$. With $k$ weights $1/k$,
# $\sum_i (W^i)^2 = k / k^2$ and the ESS is $k$: it counts the draws that share the weight. With
# $W^i \propto i$, $\mathrm{ESS} = \big(\sum_i i\big)^2 / \sum_i i^2
# = \frac{3 N (N + 1)}{2 (2N + 1)} \to \frac34 N$.
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
# - When the target is much narrower than the proposal, a few draws take all the weight: the
#   ESS, $1 / \sum_i (W^i)^2$, counts how many still count.
# - The estimate's variance is about $V(\varphi) / N$, $V(\varphi) = \mathbb E_q[w^2 (\varphi - I)^2]$;
#   the ESS rule $\operatorname{Var}_\pi(\varphi) / \mathrm{ESS}$ ignores $\varphi$, and in this
#   chapter's examples it was off by up to about twofold either way; for $|\varphi| \le 1$ the
#   mean square error is at most $4 / \mathrm{ESS}_\infty$.
# - A proposal with much lighter tails than the target ($\pi^2 / q$ not integrable) gives weights
#   of infinite variance: the error stops shrinking like $1/\sqrt N$. A single ESS does not warn;
#   its fall as $N$ grows does. Tails heavier than the target's are always safe there, much
#   lighter ones never.
#
# :::{admonition} From the labs
# :class: dropdown
# Lab A ({doc}`../labs`) asks which importance function to use (its question 4). This chapter gives
# the ground the answer stands on: the lab's choice, the prior (the transition) as proposal,
# makes the weight the likelihood; it works when the likelihood is not much sharper than the
# prior, and its weights concentrate when it is (the opening picture). {doc}`sis` and
# {doc}`proposals` finish the answer.
# :::
