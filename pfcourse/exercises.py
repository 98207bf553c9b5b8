"""Statistical checks of code a student writes in the exercises of Part I.

Each ``check_*`` function runs the student's function on cases with a known answer and
returns a :class:`CheckReport`: ``ok`` and a list of ``problems``, each a sentence saying
what is wrong and, where it can, why.  It never raises on a wrong answer (a student's
exception is reported as a problem); ``str(report)`` prints the verdict.

* :func:`check_resampler` - ``fn(weights, rng) -> indices``: right type, shape and range,
  particles of weight 0 never chosen, and *unbiased*: the mean number of copies of particle
  ``i`` over many draws is ``N W_i`` (a z-test per particle at 5 standard errors).
* :func:`check_weight_update` - ``fn(log_weights, log_likelihoods) -> log_weights``: the
  normalised log-domain update ``log W_i + log p(z | x_i) - logsumexp_j(...)``, checked on
  ordinary values and on likelihoods of ``e^{-1000}`` that underflow in the linear domain.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.special import logsumexp


@dataclass
class CheckReport:
    """Outcome of a check: ``ok`` when ``problems`` is empty."""

    name: str
    problems: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems

    def __str__(self) -> str:
        if self.ok:
            return f"{self.name}: every check passed"
        return f"{self.name}: {len(self.problems)} problem(s)\n" + "\n".join(f"- {p}" for p in self.problems)


def check_resampler(fn: Callable, n_draws: int = 4000, seed: int = 0) -> CheckReport:
    """Check a resampler ``fn(weights, rng) -> N ancestor indices`` (see the module docstring).

    Unbiasedness: for weights ``W`` (``N = 7``, one of them 0) the copy counts ``N_i`` of
    ``n_draws`` calls must have mean ``N W_i`` within ``5 SE + 1e-9`` (SE from the sample
    standard deviation of the counts; a deterministic scheme with biased counts has SE 0 and
    fails). A correct unbiased scheme fails one of the 7 tests with probability below 1e-5.
    """
    report = CheckReport("resampler")
    rng = np.random.default_rng(seed)
    w = np.array([0.05, 0.3, 0.0, 0.12, 0.08, 0.25, 0.2])
    n = w.size
    try:
        first = np.asarray(fn(w.copy(), rng))
    except Exception as exc:  # the student's error, reported
        report.problems.append(f"calling fn(weights, rng) raised {type(exc).__name__}: {exc}")
        return report
    if first.shape != (n,):
        report.problems.append(f"returned shape {first.shape}; expected ({n},), one ancestor index per particle")
        return report
    if first.dtype.kind not in "iu":
        report.problems.append(f"returned dtype {first.dtype}; indices must be integers (use astype(int))")
        return report
    counts = np.empty((n_draws, n))
    for t in range(n_draws):
        idx = np.asarray(fn(w.copy(), rng))
        if idx.min() < 0 or idx.max() >= n:
            report.problems.append(
                f"draw {t}: an index is out of range [0, {n}) (got {idx.min()}..{idx.max()}); "
                "a cumulative sum that ends just below 1 needs its last value set to 1"
            )
            return report
        counts[t] = np.bincount(idx, minlength=n)
    if counts[:, 2].any():
        report.problems.append(
            "a particle of weight 0 was chosen: u must select the i with cumsum[i-1] < u <= cumsum[i] "
            "(np.searchsorted(np.cumsum(w), u)), which never lands on a zero-width interval"
        )
    mean, se = counts.mean(axis=0), counts.std(axis=0, ddof=1) / np.sqrt(n_draws)
    bad = np.abs(mean - n * w) > 5 * se + 1e-9
    if bad.any():
        i = int(np.argmax(np.abs(mean - n * w) - 5 * se))
        report.problems.append(
            f"biased: particle {i} of weight {w[i]} should get N W = {n * w[i]:.3f} copies on "
            f"average, it got {mean[i]:.3f} (± {se[i]:.3f}) over {n_draws} draws"
        )
    if np.all(counts.std(axis=0) == 0) and not np.allclose(n * w, np.round(n * w)):
        report.problems.append("the result never changes: the rng is not used")
    try:
        idx = np.asarray(fn(np.full(n, 1.0 / n), rng))
        if idx.shape != (n,) or idx.min() < 0 or idx.max() >= n:
            report.problems.append("uniform weights give indices of the wrong shape or out of range")
    except Exception as exc:
        report.problems.append(f"uniform weights raised {type(exc).__name__}: {exc}")
    return report


def check_weight_update(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(log_weights, log_likelihoods) -> new normalised log-weights`` (module docstring)."""
    report = CheckReport("weight update")
    rng = np.random.default_rng(seed)
    cases = {
        "ordinary values": (np.log(rng.dirichlet(np.ones(50))), rng.normal(-3.0, 2.0, 50)),
        "likelihoods near e^-1000 (they underflow to 0 in the linear domain)": (
            np.full(50, -np.log(50)), rng.normal(-1000.0, 3.0, 50)),
        "one particle with weight 0 (log-weight -inf)": (
            np.concatenate([[-np.inf], np.full(49, -np.log(49))]), rng.normal(-3.0, 1.0, 50)),
    }
    for name, (logw, loglik) in cases.items():
        expected = logw + loglik - logsumexp(logw + loglik)
        try:
            with np.errstate(all="ignore"):
                got = np.asarray(fn(logw.copy(), loglik.copy()), dtype=float)
        except Exception as exc:
            report.problems.append(f"{name}: raised {type(exc).__name__}: {exc}")
            continue
        if got.shape != expected.shape:
            report.problems.append(f"{name}: returned shape {got.shape}, expected {expected.shape}")
        elif np.isnan(got).any():
            report.problems.append(
                f"{name}: NaN in the result; subtract the largest log-weight before exponentiating "
                "(or use scipy.special.logsumexp)")
        elif not np.allclose(np.exp(got), np.exp(expected), atol=1e-12, rtol=1e-9):
            total = np.exp(got).sum()
            hint = " (they do not sum to 1: normalise)" if abs(total - 1) > 1e-9 else ""
            report.problems.append(f"{name}: wrong weights{hint}; largest error "
                                   f"{np.abs(np.exp(got) - np.exp(expected)).max():.2e}")
    return report
