"""Resampling schemes for particle filters.

Given normalised weights ``w_1, ..., w_N`` a resampler draws ``n`` ancestor
indices ``A_1, ..., A_n``.  Writing ``N_i = #{j : A_j = i}`` for the number of
offspring of particle ``i``, every scheme here is unbiased,

    E[N_i] = n w_i,

and the schemes differ only in how much extra randomness they add, that is in
``Var N_i``.  Multinomial resampling is the reference; residual, stratified and
systematic resampling are cheaper in variance and (except residual) as cheap in
time.  Douc, Cappe and Moulines (2005, "Comparison of resampling schemes for
particle filtering") prove that residual and stratified resampling never
increase the conditional variance of a Monte Carlo estimate compared with
multinomial resampling, while systematic resampling has no such general
guarantee.  Hol, Schon and Gustafsson (2006, "On resampling algorithms for
particle filters") compare the four schemes and recommend systematic
resampling for its low variance and its speed.

All four functions share one signature::

    scheme(weights, rng, n=None) -> indices

``weights`` is a 1-D array of finite, non-negative weights summing to one
(within 1e-8; they are renormalised by their sum internally), ``rng`` a
``numpy.random.Generator`` (or an integer seed; it must be given) and ``n`` the number of
indices to draw (default ``len(weights)``; an integer, as for every count of the package,
:func:`~pfcourse.checks.check_count`, small enough for the machine's memory).  The result is a sorted ``int64`` array of ``n`` indices in
``[0, len(weights))``; a particle of weight zero is never selected.  Bad
weights raise :class:`~pfcourse.errors.WeightError` and a bad ``n`` raises
:class:`~pfcourse.errors.ParameterError`.

The inverse-CDF step guards against round-off: the cumulative sum is capped at
1 and forced to exactly 1.0 from the last positive weight on, and uniforms are
kept strictly below 1, so no index can fall past the end of the array (the
stratified and systematic resamplers of filterpy 2.0.0 can, when the
cumulative sum ends just below 1).  The uniforms are sorted (systematic and
stratified ones are born sorted), so the indices come from one merge pass over
the cumulative sum (:func:`pfcourse.kernels.inverse_cdf_sorted`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from pfcourse.checks import as_generator, check_count, check_fits
from pfcourse.errors import ParameterError, WeightError
from pfcourse.kernels import finite_minimum, inverse_cdf_sorted, pairwise_sum

Resampler = Callable[..., np.ndarray]

_SUM_TOLERANCE = 1e-8
# n * w_i is only known to a few ulps: 0.9999999999999998 must count as one
# full copy in residual resampling, or uniform weights would lose their copies.
_SNAP = 8 * np.finfo(np.float64).eps


def _validated(weights: np.ndarray, n: int | None, rng) -> tuple[np.ndarray, int, np.random.Generator]:
    """Check the weights, ``n`` and ``rng``; return the renormalised weights, ``n`` and the generator."""
    raw = np.asarray(weights) if weights is not None else None
    if raw is None or raw.dtype.kind not in "fiu" or raw.dtype == bool:
        kind = "None" if raw is None else f"dtype {raw.dtype}"
        raise WeightError(f"weights must be a real array, got {kind}")
    w = raw.astype(np.float64, copy=False)
    if w.ndim != 1:
        raise WeightError(f"weights must be a 1-D array, got shape {w.shape}")
    if w.size == 0:
        raise WeightError("weights must not be empty")
    finite, smallest = finite_minimum(w)
    if not finite:
        raise WeightError("weights must be finite, found NaN or inf")
    if smallest < 0:
        raise WeightError(f"weights must be non-negative, smallest is {smallest:.17g}")
    total = pairwise_sum(w)
    if abs(total - 1.0) > _SUM_TOLERANCE:
        raise WeightError(
            f"weights must sum to 1 (within {_SUM_TOLERANCE:g}), got sum {total:.17g}; "
            "normalise them first"
        )
    if n is not None:
        n = check_count(n, "n")
        check_fits(n, "n", 16 * n, "the indices and their uniforms")
    else:
        n = w.size
    if not callable(getattr(rng, "random", None)):  # a Generator (or a stand-in with .random) is used as is
        rng = as_generator(rng)
    return w / total, n, rng


def multinomial(
    weights: np.ndarray, rng: np.random.Generator | int | None = None, n: int | None = None
) -> np.ndarray:
    """Multinomial resampling: ``n`` iid draws from the weights by inverse CDF.

    ``(N_1, ..., N_N) ~ Multinomial(n; w)``, so ``E N_i = n w_i`` and
    ``Var N_i = n w_i (1 - w_i)``.
    """
    w, n, rng = _validated(weights, n, rng)
    return inverse_cdf_sorted(w, np.sort(rng.random(n)))


def stratified(
    weights: np.ndarray, rng: np.random.Generator | int | None = None, n: int | None = None
) -> np.ndarray:
    """Stratified resampling: one uniform in each stratum, ``u_k = (k + U_k) / n``.

    The ``U_k`` are iid uniform; ``E N_i = n w_i``,
    ``Var N_i <= n w_i (1 - w_i)`` and
    ``floor(n w_i) - 1 <= N_i <= floor(n w_i) + 2``.
    """
    w, n, rng = _validated(weights, n, rng)
    return inverse_cdf_sorted(w, (np.arange(n) + rng.random(n)) / n)


def systematic(
    weights: np.ndarray, rng: np.random.Generator | int | None = None, n: int | None = None
) -> np.ndarray:
    """Systematic resampling: one shared offset, ``u_k = (k + U) / n``.

    ``N_i`` is ``floor(n w_i)`` or ``floor(n w_i) + 1``, the latter with
    probability ``r_i = frac(n w_i)``, so ``E N_i = n w_i`` and
    ``Var N_i = r_i (1 - r_i)``.
    """
    w, n, rng = _validated(weights, n, rng)
    return inverse_cdf_sorted(w, (np.arange(n) + rng.random()) / n)


def residual(
    weights: np.ndarray, rng: np.random.Generator | int | None = None, n: int | None = None
) -> np.ndarray:
    """Residual resampling: ``floor(n w_i)`` sure copies, the rest multinomial.

    ``N_i = floor(n w_i) + M_i`` with ``(M_1, ..., M_N) ~ Multinomial(R; p)``,
    ``R = n - sum_i floor(n w_i)`` and ``p_i = (n w_i - floor(n w_i)) / R``, so
    ``E N_i = n w_i`` and ``Var N_i = R p_i (1 - p_i)``.
    """
    w, n, rng = _validated(weights, n, rng)
    expected = n * w
    copies = np.floor(expected * (1.0 + _SNAP)).astype(np.int64)
    remaining = n - int(copies.sum())
    if remaining > 0:
        fractions = np.maximum(expected - copies, 0.0)
        drawn = inverse_cdf_sorted(fractions / fractions.sum(), np.sort(rng.random(remaining)))
        copies += np.bincount(drawn, minlength=w.size)
    return np.repeat(np.arange(w.size, dtype=np.int64), copies)


SCHEMES: dict[str, Resampler] = {
    "multinomial": multinomial,
    "stratified": stratified,
    "systematic": systematic,
    "residual": residual,
}


def get_resampler(name_or_callable: str | Resampler) -> Resampler:
    """Return the resampler called ``name_or_callable``, or the callable itself."""
    if callable(name_or_callable):
        return name_or_callable
    try:
        return SCHEMES[name_or_callable]
    except (KeyError, TypeError):
        raise ParameterError(
            f"unknown resampling scheme {name_or_callable!r}; "
            f"valid names are {', '.join(SCHEMES)}"
        ) from None
