"""The evidence behind a comparison of seeded runs: rates with intervals, paired tests.

Every study of the book runs each setting on the same seeds (common random numbers), so two
settings are compared run by run. This module turns such paired runs into the sentence the
book may write, always with the number of runs and an interval, and only through
``scipy.stats`` (nothing here re-implements a test that scipy does right):

- a **rate** (share of runs that diverged, locked on, ...) with its Wilson score interval
  (``binomtest(k, n).proportion_ci(method="wilson")``):

  .. math:: \\frac{\\hat p + z^2/2n \\pm z\\sqrt{\\hat p(1-\\hat p)/n + z^2/4n^2}}{1 + z^2/n};

- two **paired rates** (the same runs under settings A and B) by the exact McNemar test: only
  the discordant runs carry information, and under "no difference" the runs that only A gets
  right are ``Binomial(b + c, 1/2)`` among the ``b + c`` discordant ones
  (``binomtest(b, b + c, 0.5)``); the difference of the two rates gets an interval built on the
  same binomial, which covers 0 exactly when that test does not reject (:func:`paired_difference_interval`);
- two **paired samples** (errors of the same runs under A and B) by the Wilcoxon signed-rank
  test on the differences ``d_i = a_i - b_i``, with a bootstrap interval for the median of
  ``d`` (``scipy.stats.bootstrap``, percentile method); ``ratio=True`` compares
  ``log a_i - log b_i`` instead and reports the median ratio ``a/b``;
- the **sign test** (``binomtest`` on the count of ``a_i < b_i`` among non-ties), for when only the
  direction of each pair is trusted;
- the interval of **any statistic of the runs** (a log-log slope fitted over runs, a difference of
  two such slopes on the same runs): ``scipy.stats.bootstrap`` resamples the runs themselves
  (their indices), so every array indexed by run is resampled together (:func:`run_interval`);
- the **rate of a power law** ``e = a N^b``: the least-squares slope of ``log`` (median error over
  the runs) against ``log N``, with its interval over the runs (:func:`log_slope`);
- the slope of a **regression through a few points** that are not runs to resample, with the
  parametric ``t`` interval of the least-squares slope (:func:`regression_slope`);
- a **family of comparisons** (every level of a sweep against one reference): Holm's step-down
  adjustment of their p-values (:func:`holm`), which keeps the chance of any false "difference"
  in the family at most ``alpha``, and the verdicts it allows (:func:`holm_verdicts`).

A claim of "no difference" is worded from the interval, not from a p-value above 0.05: the
interval says how large a difference could hide in the study (``Paired.detectable``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import stats

from pfcourse.errors import PfcourseError

__all__ = [
    "EvidenceError",
    "Rate",
    "PairedRates",
    "Paired",
    "rate",
    "paired_rates",
    "paired_difference_interval",
    "paired",
    "sign_test",
    "median_interval",
    "run_interval",
    "log_slope",
    "regression_slope",
    "holm",
    "holm_verdicts",
]

CONFIDENCE = 0.95
N_RESAMPLES = 9999


class EvidenceError(PfcourseError, ValueError):
    """Runs that cannot support the requested statistic (empty, unpaired, NaN, negative counts)."""


def _fraction(level: float) -> str:
    return f"{100 * level:g} %"


def _percent(p: float) -> str:
    return f"{100 * p:.0f} %"


def _points(d: float) -> str:
    """A difference of rates in points; under one point with a decimal, so that a limit above 0 never reads +0."""
    return f"{100 * d:+.1f}" if 0 < abs(100 * d) < 1 else f"{100 * d:+.0f}"


def _samples(x, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise EvidenceError(f"{name}: expected numbers, got {type(x).__name__}") from exc
    if a.ndim != 1:
        raise EvidenceError(f"{name}: expected one value per run (1-D), got shape {a.shape}")
    if a.size == 0:
        raise EvidenceError(f"{name}: no runs")
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.isfinite(a))
        raise EvidenceError(f"{name}: {bad.size} non-finite value(s), first at run {bad[0]}")
    return a


def _pair(a, b) -> tuple[np.ndarray, np.ndarray]:
    a, b = _samples(a, "a"), _samples(b, "b")
    if a.shape != b.shape:
        raise EvidenceError(f"paired runs need the same number of runs, got {a.size} and {b.size}")
    return a, b


def _booleans(x, name: str) -> np.ndarray:
    a = np.asarray(x)
    if a.ndim != 1 or a.size == 0:
        raise EvidenceError(f"{name}: expected a non-empty 1-D array of outcomes, got shape {a.shape}")
    if a.dtype != bool:
        if not np.all(np.isin(a, (0, 1))):
            raise EvidenceError(f"{name}: outcomes must be booleans (or 0/1), got values such as {a[~np.isin(a, (0, 1))][0]!r}")
        a = a.astype(bool)
    return a


@dataclass(frozen=True)
class Rate:
    """``successes`` of ``n`` runs, with the Wilson interval ``(low, high)`` at ``confidence``."""

    successes: int
    n: int
    low: float
    high: float
    confidence: float = CONFIDENCE

    @property
    def estimate(self) -> float:
        return self.successes / self.n

    def __str__(self) -> str:
        return (f"{_percent(self.estimate)} ({self.successes}/{self.n}; {_fraction(self.confidence)} Wilson "
                f"interval {_percent(self.low)}-{_percent(self.high)})")


def rate(successes: int | np.ndarray, n: int | None = None, confidence: float = CONFIDENCE) -> Rate:
    """Share of runs with the outcome, and its Wilson score interval.

    ``rate(k, n)`` for counts, or ``rate(outcomes)`` for a boolean array of runs.
    """
    if n is None:
        outcomes = _booleans(successes, "outcomes")
        k, n = int(outcomes.sum()), int(outcomes.size)
    else:
        k, n = successes, n
        if isinstance(k, (float, np.floating)) and not float(k).is_integer():
            raise EvidenceError(f"successes must be a whole number, got {k}")
        if isinstance(n, (float, np.floating)) and not float(n).is_integer():
            raise EvidenceError(f"n must be a whole number, got {n}")
        k, n = int(k), int(n)
        if n <= 0 or not 0 <= k <= n:
            raise EvidenceError(f"need 0 <= successes <= n and n > 0, got successes={k}, n={n}")
    if not 0 < confidence < 1:
        raise EvidenceError(f"confidence must be in (0, 1), got {confidence}")
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return Rate(k, n, float(ci.low), float(ci.high), confidence)


@dataclass(frozen=True)
class PairedRates:
    """The same runs under A and B: rates, discordant counts, exact McNemar p, interval of A - B."""

    a: Rate
    b: Rate
    only_a: int
    only_b: int
    pvalue: float
    difference_low: float
    difference_high: float
    confidence: float = CONFIDENCE

    @property
    def difference(self) -> float:
        return self.a.estimate - self.b.estimate

    def __str__(self) -> str:
        return (f"{_percent(self.a.estimate)} vs {_percent(self.b.estimate)} of {self.a.n} paired runs: "
                f"{self.only_a} only A, {self.only_b} only B, exact McNemar p = {self.pvalue:.2g}; "
                f"difference {100 * self.difference:+.0f} points ({_fraction(self.confidence)} interval "
                f"{_points(self.difference_low)} to {_points(self.difference_high)})")


def _bootstrap(data: tuple[np.ndarray, ...], statistic: Callable, confidence: float, seed: int,
               paired: bool = False) -> tuple[float, float]:
    """Percentile bootstrap interval; a constant sample gives the degenerate interval (x, x).

    ``statistic`` takes ``axis`` (``np.mean``, ``np.median``), so scipy resamples in one array.
    """
    value = float(statistic(*data))
    if all(np.ptp(d) == 0 for d in data):
        return value, value
    res = stats.bootstrap(data, statistic, paired=paired, vectorized=True, confidence_level=confidence,
                          n_resamples=N_RESAMPLES, method="percentile", random_state=np.random.default_rng(seed))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def paired_difference_interval(only_a: int, only_b: int, n: int,
                               confidence: float = CONFIDENCE) -> tuple[float, float]:
    r"""Interval of the difference of two paired rates, consistent with the exact McNemar test.

    Of ``n`` runs, ``only_a = b`` succeed under A only and ``only_b = c`` under B only. With
    the cell probabilities ``p10`` (A only) and ``p01`` (B only), the difference of the rates is

    .. math:: \Delta = p_A - p_B = p_{10} - p_{01} = \psi\,\tau, \qquad
              \psi = p_{10} + p_{01}, \quad \tau = 2\pi - 1, \quad \pi = p_{10} / \psi,

    the share ``psi`` of discordant runs times the contrast ``tau`` among them. The count of
    discordant runs is ``m = b + c ~ Binomial(n, psi)`` and, given ``m``, ``b ~ Binomial(m, pi)``:
    ``pi`` is what the exact McNemar test is about (``pi = 1/2`` under "no difference"), and its
    estimate ``b / m`` is unbiased given ``m``, so it is uncorrelated with ``m / n``.

    1. ``pi`` gets the Clopper-Pearson interval ``(pi_L, pi_U)`` on ``b`` of ``m``
       (``binomtest(b, m).proportion_ci(method="exact")``; Clopper and Pearson 1934, Biometrika
       26, 404-413), hence ``tau`` the interval ``(tau_L, tau_U) = (2 pi_L - 1, 2 pi_U - 1)``.
       Both come from the binomial tails of the exact McNemar test: for ``pi = 1/2`` its two-sided p-value is twice
       the smaller tail, so ``tau_L > 0`` (or ``tau_U < 0``) exactly when ``p < 1 - confidence``.
    2. ``psi`` gets the Wilson interval ``(psi_L, psi_U)`` on ``m`` of ``n`` (:func:`rate`).
    3. The two are combined by square-and-add, the method of variance estimates recovery
       (MOVER; Zou and Donner 2008, Statistics in Medicine 27, 1693-1702), which reads the spread
       of each estimate on the side of the limit from its own interval. Near the lower limit,
       ``Delta`` moves by ``psi^ (tau - tau^)`` through ``tau`` and by ``tau_L (psi - psi^)``
       through ``psi``, so

       .. math:: L = \hat\Delta - \sqrt{\hat\psi^2 (\hat\tau - \tau_L)^2
                     + \tau_L^2 (\hat\psi - \psi_\ast)^2},\qquad
                 U = \hat\Delta + \sqrt{\hat\psi^2 (\tau_U - \hat\tau)^2
                     + \tau_U^2 (\psi^\ast - \hat\psi)^2},

       with ``psi_* = psi_L`` if ``tau_L > 0`` else ``psi_U`` (the side of ``psi`` that lowers
       ``Delta``), and ``psi^* = psi_U`` if ``tau_U > 0`` else ``psi_L``; ``tau^ = 0`` when ``m = 0``.

    **Consistency.** ``L`` has the sign of ``tau_L`` (estimates written without hats): for
    ``tau_L > 0``, ``Delta^2 - psi^2 (tau - tau_L)^2 = psi^2 tau_L (2 tau - tau_L)``, which
    exceeds ``tau_L (psi - psi_L)^2`` as ``tau >= tau_L`` and ``psi >= psi - psi_L >= 0``, so
    ``L > 0``; for ``tau_L < 0``, ``L <= Delta - psi (tau - tau_L) = psi tau_L < 0`` (and
    ``L = tau_L psi_U < 0`` when ``m = 0``); for ``tau_L = 0``, ``L = 0``. Likewise for ``U``. So
    the interval covers 0 exactly when the exact McNemar test does not reject at level
    ``1 - confidence``. A percentile bootstrap of the mean difference does not: 4 discordant runs
    of 100, all for A, give ``p = 0.125`` and a bootstrap interval of ``(0.01, 0.08)``, which
    excludes 0 (a resample holding none of the 4 runs comes up in fewer than 2.5 % of resamples).
    The conditional interval alone, ``(m / n) (tau_L, tau_U)``, ignores the spread of ``m`` and
    is one-sided when ``b`` or ``c`` is 0 (its upper limit is then the estimate itself), which
    Newcombe (1998, Statistics in Medicine 17, 2635-2650) measured as poor coverage; the ``psi``
    term repairs both.

    **Coverage.** The interval lies inside the box ``psi`` times ``tau`` of the two intervals
    (``U <= tau_U psi_U`` for ``tau_U > 0``, and so on), so it stays inside ``[-1, 1]``.
    By simulation (``tests/test_paired_difference.py``) its coverage is at least nominal over a
    grid of rates, correlations and ``n`` from 30 to 300, near nominal when many runs differ and
    conservative, like the exact test itself, when few do. No discordant run (``m = 0``) gives
    ``(-psi_U, psi_U)``: the difference is 0 in these runs, and no larger than the share of runs
    that could still differ.
    """
    for name, v in (("only_a", only_a), ("only_b", only_b), ("n", n)):
        if isinstance(v, (float, np.floating)) and not float(v).is_integer():
            raise EvidenceError(f"{name} must be a whole number, got {v}")
    b, c, n = int(only_a), int(only_b), int(n)
    if n <= 0 or b < 0 or c < 0 or b + c > n:
        raise EvidenceError(f"need only_a, only_b >= 0 and only_a + only_b <= n, got {b}, {c} of n={n}")
    if not 0 < confidence < 1:
        raise EvidenceError(f"confidence must be in (0, 1), got {confidence}")
    m = b + c
    psi = m / n
    discordant = rate(m, n, confidence)
    if m == 0:
        tau, tau_low, tau_high = 0.0, -1.0, 1.0
    else:
        pi = stats.binomtest(b, m).proportion_ci(confidence_level=confidence, method="exact")
        tau, tau_low, tau_high = (b - c) / m, 2 * float(pi.low) - 1, 2 * float(pi.high) - 1
    delta = psi * tau
    psi_for_low = discordant.low if tau_low > 0 else discordant.high
    psi_for_high = discordant.high if tau_high > 0 else discordant.low
    low = delta - float(np.hypot(psi * (tau - tau_low), tau_low * (psi - psi_for_low)))
    high = delta + float(np.hypot(psi * (tau_high - tau), tau_high * (psi_for_high - psi)))
    return max(low, -1.0), min(high, 1.0)


def paired_rates(a, b, confidence: float = CONFIDENCE, seed: int = 0) -> PairedRates:
    """Exact McNemar test of paired outcomes (``binomtest`` on the discordant runs), and its interval.

    ``a[i]`` and ``b[i]`` are the outcomes of run ``i`` under A and B (same seed, same truth). The
    interval of the difference of the rates is :func:`paired_difference_interval`, which covers 0
    exactly when the test does not reject at ``1 - confidence``. ``seed`` is accepted, so that
    older calls still run, and unused: the interval draws no random numbers (it was a bootstrap one).
    """
    a, b = _booleans(a, "a"), _booleans(b, "b")
    if a.shape != b.shape:
        raise EvidenceError(f"paired runs need the same number of runs, got {a.size} and {b.size}")
    only_a, only_b = int(np.sum(a & ~b)), int(np.sum(~a & b))
    p = 1.0 if only_a + only_b == 0 else float(stats.binomtest(only_a, only_a + only_b, 0.5).pvalue)
    low, high = paired_difference_interval(only_a, only_b, a.size, confidence)
    return PairedRates(rate(a, confidence=confidence), rate(b, confidence=confidence), only_a, only_b, p,
                       low, high, confidence)


@dataclass(frozen=True)
class Paired:
    """Paired samples A, B: median of ``d = a - b`` (or of ``log(a/b)`` if ``ratio``), its interval, Wilcoxon p."""

    n: int
    median: float
    low: float
    high: float
    pvalue: float
    ratio: bool = False
    confidence: float = CONFIDENCE

    @property
    def detectable(self) -> float:
        """The largest difference (or, for a ratio, factor) the interval leaves possible, either way.

        "No difference" is only as strong as this: a difference smaller than it could hide in the study.
        """
        if self.ratio:
            return float(max(self.high, 1.0 / self.low))
        return float(max(abs(self.low), abs(self.high)))

    def verdict(self, alpha: float | None = None) -> str:
        """``"A lower"``, ``"A higher"`` or ``"no difference detected"``: decided by the interval.

        The interval at ``confidence`` excludes "no difference" (0, or a ratio of 1) or does not;
        ``alpha`` defaults to ``1 - confidence``, and the Wilcoxon p-value must agree (both below).
        """
        alpha = 1 - self.confidence if alpha is None else alpha
        null = 1.0 if self.ratio else 0.0
        if self.high < null and self.pvalue < alpha:
            return "A lower"
        if self.low > null and self.pvalue < alpha:
            return "A higher"
        return "no difference detected"

    def __str__(self) -> str:
        what = "median ratio A/B" if self.ratio else "median difference A - B"
        fmt = (lambda v: f"{v:.3g}")
        return (f"{what} {fmt(self.median)} ({_fraction(self.confidence)} interval {fmt(self.low)} to "
                f"{fmt(self.high)}), Wilcoxon signed-rank p = {self.pvalue:.2g}, {self.n} paired runs")


def paired(a, b, ratio: bool = False, confidence: float = CONFIDENCE, seed: int = 0) -> Paired:
    """Wilcoxon signed-rank test and a bootstrap interval of the median paired difference.

    With ``ratio=True`` the samples must be positive (errors, costs) and the comparison is on
    ``log a - log b``; ``median``, ``low`` and ``high`` are then reported as ratios ``a/b``.
    Zero differences are dropped by the test (``zero_method="wilcox"``); if every pair is tied,
    ``p = 1`` and the interval is ``(0, 0)`` (or ``(1, 1)``).
    """
    a, b = _pair(a, b)
    if ratio:
        if np.any(a <= 0) or np.any(b <= 0):
            raise EvidenceError("ratio=True needs positive samples (errors, costs), got a value <= 0")
        d = np.log(a) - np.log(b)
    else:
        d = a - b
    median = float(np.median(d))
    if np.all(d == 0):
        p, low, high = 1.0, 0.0, 0.0
    else:
        p = float(stats.wilcoxon(d).pvalue)
        low, high = _bootstrap((d,), np.median, confidence, seed)
    if ratio:
        median, low, high = float(np.exp(median)), float(np.exp(low)), float(np.exp(high))
    return Paired(int(d.size), median, low, high, p, ratio, confidence)


def sign_test(a, b) -> tuple[int, int, float]:
    """Sign test: ``(runs where a < b, runs where a > b, two-sided exact p)``; ties are dropped."""
    a, b = _pair(a, b)
    below, above = int(np.sum(a < b)), int(np.sum(a > b))
    p = 1.0 if below + above == 0 else float(stats.binomtest(below, below + above, 0.5).pvalue)
    return below, above, p


def median_interval(x, confidence: float = CONFIDENCE, seed: int = 0) -> tuple[float, float, float]:
    """``(median, low, high)``: the sample median and its percentile-bootstrap interval."""
    x = _samples(x, "x")
    low, high = _bootstrap((x,), np.median, confidence, seed)
    return float(np.median(x)), low, high


def run_interval(statistic: Callable[[np.ndarray], float | np.ndarray], n_runs: int,
                 confidence: float = CONFIDENCE, seed: int = 0, n_resamples: int = N_RESAMPLES,
                 vectorized: bool = False):
    """``(value, low, high)``: ``statistic(runs)`` on all runs, and its percentile-bootstrap interval.

    ``statistic`` receives an array of run indices (all of them, then resamples drawn with
    replacement) and returns a float, e.g. ``lambda r: slope(errors[:, r])``, or a 1-D array of
    several statistics (then ``value``, ``low`` and ``high`` are arrays); statistics of several
    arrays indexed by run (two filters on the same simulations) are resampled together, paired.
    Resampling is ``scipy.stats.bootstrap`` over the indices ``0 .. n_runs - 1``.

    With ``vectorized=True`` a float ``statistic`` also takes a 2-D array of indices, one resample
    per row, and returns one value per row (reducing over the last axis): one call instead of one
    per resample, and the same interval (the same resamples).
    """
    if int(n_runs) != n_runs or n_runs < 2:
        raise EvidenceError(f"an interval over runs needs at least 2 runs, got {n_runs!r}")
    runs = np.arange(int(n_runs))
    value = np.asarray(statistic(runs), dtype=float)
    if not np.all(np.isfinite(value)):
        raise EvidenceError(f"the statistic of all {n_runs} runs is {value}")
    res = stats.bootstrap((runs,), lambda r, axis=-1: np.asarray(statistic(r.astype(int)), dtype=float),
                          vectorized=vectorized, confidence_level=confidence, n_resamples=n_resamples,
                          method="percentile", random_state=np.random.default_rng(seed))
    low, high = np.asarray(res.confidence_interval.low), np.asarray(res.confidence_interval.high)
    if value.ndim == 0:
        return float(value), float(low), float(high)
    return value, low, high


def log_slope(values, sizes, center: Callable = np.median, against=None, confidence: float = CONFIDENCE,
              seed: int = 0) -> tuple[float, float, float]:
    r"""``(b, low, high)``: the log-log slope of a statistic of the runs against a size, and its interval.

    ``values[j, r]`` is run ``r``'s result (an error) with size ``sizes[j]`` (particles ``N_j``),
    the same runs for every size. With ``c_j = center(values[j, :])`` (the median over the runs),
    ``x_j = log N_j`` and ``y_j = log c_j``, the slope is the least-squares fit of ``y = a + b x``:

    .. math:: \hat b = \frac{\sum_j (x_j - \bar x)(y_j - \bar y)}{\sum_j (x_j - \bar x)^2},

    so ``c_j \approx e^a N_j^b`` (``b = -1/2`` is the Monte Carlo rate). With ``against`` (a second
    array of the same shape, the same runs under another filter) the statistic is the difference
    ``b(values) - b(against)``. The interval resamples the runs (:func:`run_interval`, ``N_RESAMPLES``
    resamples), every size's column of a run together, and both arrays together (paired).
    """
    x = np.log(_samples(sizes, "sizes"))
    arrays = [np.asarray(values, dtype=float)] + ([] if against is None else [np.asarray(against, dtype=float)])
    for a in arrays:
        if a.ndim != 2 or a.shape[0] != x.size:
            raise EvidenceError(f"values must be (sizes, runs) = ({x.size}, runs), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise EvidenceError("values: non-finite entries")
    if len(arrays) == 2 and arrays[0].shape != arrays[1].shape:
        raise EvidenceError(f"against must have the shape of values, got {arrays[1].shape} and {arrays[0].shape}")
    if x.size < 2 or np.ptp(x) == 0:
        raise EvidenceError("a slope needs at least two different sizes")

    dx = (x - x.mean()).reshape(-1, 1)

    def fit(a: np.ndarray) -> np.ndarray:  # a: (sizes, runs) or (sizes, resamples, runs)
        y = np.log(center(a, axis=-1)).reshape(x.size, -1)
        return np.sum(dx * (y - y.mean(axis=0)), axis=0) / np.sum(dx**2)

    def statistic(r: np.ndarray) -> np.ndarray:  # one slope per row of r (vectorized)
        b = fit(arrays[0][:, r])
        b = b - fit(arrays[1][:, r]) if against is not None else b
        return b.reshape(np.shape(r)[:-1])

    return run_interval(statistic, arrays[0].shape[1], confidence=confidence, seed=seed, vectorized=True)


def regression_slope(x, y, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    r"""``(b, low, high)``: the least-squares slope of ``y`` on ``x`` and its parametric interval.

    For points ``(x_j, y_j)``, ``j = 1 .. n``, with residuals ``r_j`` about the fitted line,

    .. math:: \hat b \pm t_{n-2,\,(1+c)/2} \sqrt{\frac{\sum_j r_j^2 / (n - 2)}{\sum_j (x_j - \bar x)^2}},

    the interval of the normal linear model (independent errors of equal variance about the line).
    For a fit whose points are statistics of the same runs, :func:`run_interval` (resampling the
    runs) is the sounder interval; this one serves where resampling the runs makes the statistic
    undefined (the logarithm of a difference that some resampled sets make negative).
    """
    x, y = _samples(x, "x"), _samples(y, "y")
    if x.size != y.size or x.size < 3 or np.ptp(x) == 0:
        raise EvidenceError(f"a slope with an interval needs at least 3 points at 2 or more x values, got "
                            f"{x.size} x and {y.size} y")
    slope, intercept = np.polyfit(x, y, 1)
    residuals = y - (intercept + slope * x)
    se = float(np.sqrt(np.sum(residuals**2) / (x.size - 2) / np.sum((x - x.mean()) ** 2)))
    half = float(stats.t.ppf(0.5 + confidence / 2, x.size - 2)) * se
    return float(slope), float(slope) - half, float(slope) + half


def log_mean_exp(x, order: int = 3) -> float:
    r"""``log E[e^X]`` from the first ``order`` (2 or 3) cumulants of the sample ``x``.

    .. math:: \log \mathbb E[e^X] = \kappa_1 + \kappa_2 / 2 + \kappa_3 / 6 + \dots,

    with the cumulants estimated by their unbiased k-statistics (``scipy.stats.kstat``). With
    ``order=2`` this is the Gaussian value ``mean + var / 2``; the third-order term corrects it for
    skewness (a left-skewed ``X``, as the log of a particle likelihood estimate, makes
    ``mean + var / 2`` too high). For ``X = log p^ - log p``, an unbiased ``p^`` gives 0.
    """
    x = _samples(x, "x")
    if order not in (2, 3):
        raise EvidenceError(f"order must be 2 or 3, got {order!r}")
    if x.size < 4:
        raise EvidenceError(f"cumulants up to the third need at least 4 values, got {x.size}")
    value = stats.kstat(x, 1) + stats.kstat(x, 2) / 2
    return float(value + (stats.kstat(x, 3) / 6 if order == 3 else 0.0))


def iact_relative_sd(tau: float, n: int, c: float = 5.0) -> float:
    r"""Relative standard deviation of an integrated autocorrelation time estimated from one chain.

    Sokal's approximation for a window of ``M`` lags (``M`` about ``c tau``, the window of
    :func:`pfcourse.pmmh.integrated_autocorrelation_time`) on ``n`` draws:

    .. math:: \frac{\mathrm{sd}(\hat\tau)}{\tau} \approx \sqrt{\frac{2 (2M + 1)}{n}}.
    """
    if not (np.isfinite(tau) and tau >= 1):
        raise EvidenceError(f"an autocorrelation time is at least 1, got {tau!r}")
    if int(n) != n or n < 2:
        raise EvidenceError(f"a chain needs at least 2 draws, got {n!r}")
    window = int(np.ceil(c * tau))
    return float(np.sqrt(2 * (2 * window + 1) / n))


def holm(pvalues) -> np.ndarray:
    r"""Holm's step-down adjusted p-values, in the order given.

    With the ``m`` p-values sorted, :math:`p_{(1)} \le \dots \le p_{(m)}`, the adjusted value of the
    ``i``-th is :math:`\max_{j \le i} \min(1, (m - j + 1)\, p_{(j)})`; rejecting every hypothesis
    whose adjusted value is below ``alpha`` keeps the family-wise error rate (the chance of one or
    more false rejections) at most ``alpha`` whatever the dependence between the tests (Holm, 1979).
    """
    p = _samples(pvalues, "pvalues")
    if np.any((p < 0) | (p > 1)):
        raise EvidenceError(f"p-values must lie in [0, 1], got {p}")
    order = np.argsort(p, kind="stable")
    m = p.size
    adjusted = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adjusted
    return out


def holm_verdicts(comparisons: dict, alpha: float | None = None) -> dict:
    """``{key: (verdict, Holm-adjusted p)}`` for a family of :class:`Paired` comparisons.

    The verdict is :meth:`Paired.verdict`'s with each Wilcoxon p replaced by its Holm-adjusted
    value (:func:`holm` over the whole family): a difference is declared only where the interval
    excludes "no difference" and the adjusted p is below ``alpha`` (default ``1 - confidence``), so
    the chance of declaring any false difference in the family is at most ``alpha``.
    """
    if not comparisons or not all(isinstance(c, Paired) for c in comparisons.values()):
        raise EvidenceError("holm_verdicts needs a non-empty dict of pfcourse.evidence.Paired")
    keys = list(comparisons)
    adjusted = holm([comparisons[k].pvalue for k in keys])
    out = {}
    for key, p in zip(keys, adjusted):
        c = comparisons[key]
        level = 1 - c.confidence if alpha is None else alpha
        out[key] = (Paired(c.n, c.median, c.low, c.high, float(p), c.ratio, c.confidence).verdict(level), float(p))
    return out
