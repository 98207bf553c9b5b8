"""Compiled inner loops of the particle filter (numba), one pass over the particles each.

The readable NumPy definitions live in :mod:`pfcourse.diagnostics` and
:mod:`pfcourse.resampling`; the engine (:class:`pfcourse.filter.ParticleFilter`) calls
these loops instead, because a vectorized NumPy expression walks the ``N`` particles
once per operation and allocates a temporary each time, while a loop does all the
arithmetic of a particle while it sits in a register.  Each loop is tested against its
NumPy definition (tests/test_kernels.py):

* :func:`normalize_step` gives the *same floats* as
  :func:`~pfcourse.diagnostics.normalize_log_weights` and
  :func:`~pfcourse.diagnostics.effective_sample_size` (it sums in NumPy's pairwise
  order, :func:`pairwise_sum`), so the weights, the resampling decisions and the
  resampled indices of a seeded run do not depend on which implementation ran;
* :func:`inverse_cdf_sorted` gives the indices of a ``searchsorted`` of sorted uniforms in
  the cumulative weights, in one ``O(N)`` merge pass instead of ``O(N log N)`` (it serves
  every scheme of :mod:`pfcourse.resampling`);
* :func:`weighted_moments` sums relative to the first particle and in another order than
  the BLAS products of :func:`~pfcourse.diagnostics.weighted_mean` /
  :func:`~pfcourse.diagnostics.weighted_covariance`, so it agrees with them to rounding,
  not bit for bit (and gives a collapsed cloud an exactly zero covariance).

The loops run on one core.  Compiled code is cached on disk (``cache=True``, in
``pfcourse/__pycache__``), so only the first import on a machine pays the compilation
(about 10 s).
"""

from __future__ import annotations

import math

import numpy as np

from pfcourse.angles import wrap  # noqa: F401  (used by the loops below)
from pfcourse.compiled import jit

TWO_PI = 2.0 * np.pi
_LARGEST_BELOW_ONE = float(np.nextafter(1.0, 0.0))

@jit
def _pairwise_block(a, start, n):
    # a block of at most 128 values, summed as NumPy does (numpy/_core/src/umath/loops_utils.h.src)
    if n < 8:
        total = -0.0
        for i in range(start, start + n):
            total += a[i]
        return total
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = 8
    stop = n - n % 8
    while i < stop:
        j = start + i
        r0 += a[j]
        r1 += a[j + 1]
        r2 += a[j + 2]
        r3 += a[j + 3]
        r4 += a[j + 4]
        r5 += a[j + 5]
        r6 += a[j + 6]
        r7 += a[j + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        total += a[start + i]
        i += 1
    return total


@jit
def pairwise_sum(a: np.ndarray) -> float:
    """``sum_i a_i`` of a contiguous 1-D float64 array, in the order (and to the float) of ``np.sum``.

    NumPy splits a range longer than 128 into halves (cut at a multiple of 8) and adds
    the two halves' sums; the recursion is unrolled here with an explicit stack (numba
    cannot cache recursive functions).
    """
    depth = 64
    starts = np.empty(depth, dtype=np.int64)
    sizes = np.empty(depth, dtype=np.int64)
    stages = np.empty(depth, dtype=np.int64)
    lefts = np.empty(depth)
    starts[0], sizes[0], stages[0] = 0, a.size, 0
    top = 0
    result = 0.0
    while top >= 0:
        n = sizes[top]
        if n <= 128:
            result = _pairwise_block(a, starts[top], n)
            top -= 1
            continue
        half = n // 2
        half -= half % 8
        if stages[top] == 0:  # sum the left half first
            stages[top] = 1
            starts[top + 1], sizes[top + 1], stages[top + 1] = starts[top], half, 0
            top += 1
        elif stages[top] == 1:  # left half done: keep it, sum the right half
            stages[top] = 2
            lefts[top] = result
            starts[top + 1], sizes[top + 1], stages[top + 1] = starts[top] + half, n - half, 0
            top += 1
        else:
            result = lefts[top] + result
            top -= 1
    return result


@jit
def finite_minimum(a: np.ndarray):
    """``(every entry finite, smallest entry)`` of a 1-D array, in one pass."""
    finite = True
    smallest = math.inf
    for i in range(a.size):
        v = a[i]
        if not math.isfinite(v):
            finite = False
        elif v < smallest:
            smallest = v
    return finite, smallest


@jit
def sum_of_squares(a: np.ndarray) -> float:
    """``sum_i a_i^2`` in NumPy's order, the float of ``np.sum(a**2)``."""
    squares = np.empty(a.size)
    for i in range(a.size):
        squares[i] = a[i] * a[i]
    return pairwise_sum(squares)


# ----------------------------------------------------------------------------- weights
@jit
def normalize_step(log_weights: np.ndarray, log_increments: np.ndarray, weights: np.ndarray, scratch: np.ndarray):
    """One weight update, in place: ``l_i <- l_i + log inc_i - L``, ``W_i = exp(l_i)``.

    ``L = logsumexp_i(l_i + log inc_i)`` is computed as SciPy does,
    ``a* + log(m) + log1p(sum_{a_i < a*} exp(a_i - a*) / m)`` with ``a*`` the largest value
    and ``m`` its multiplicity, the sum in NumPy's order.  Returns ``(L, ess)`` with
    ``ess = 1 / sum W_i^2``; ``L = -inf`` when every weight is zero (``log_weights`` then
    holds the unnormalised sums).  The increments must be free of NaN and ``+inf`` (the
    filter checks them first).  All arrays are contiguous float64 of one length ``N``;
    ``scratch`` is work space.
    """
    n = log_weights.size
    top = -math.inf
    for i in range(n):
        a = log_weights[i] + log_increments[i]
        log_weights[i] = a
        if a > top:
            top = a
    if top == -math.inf:
        return -math.inf, math.nan
    copies = 0.0
    for i in range(n):  # exp(a_i - a*) below the top, 0 for the copies of the top
        a = log_weights[i]
        if a == top:
            copies += 1.0
            scratch[i] = 0.0
        else:
            scratch[i] = math.exp(a - top)
    s = pairwise_sum(scratch)
    if s != 0.0:
        s = s / copies
    log_total = math.log1p(s) + math.log(copies) + top
    if not math.isfinite(log_total):
        # SciPy's fallback (the largest value is +inf): log(sum exp(a)) in NumPy's order
        for i in range(n):
            scratch[i] = math.exp(log_weights[i])
        log_total = math.log(pairwise_sum(scratch))
    for i in range(n):
        a = log_weights[i]
        w = math.exp(a - log_total)
        weights[i] = w
        scratch[i] = w * w
        log_weights[i] = a - log_total
    return log_total, 1.0 / pairwise_sum(scratch)


# ----------------------------------------------------------------------------- moments
@jit
def weighted_moments(particles: np.ndarray, weights: np.ndarray, is_angle: np.ndarray):
    """Weighted mean ``m = sum_i W_i x_i`` and covariance ``sum_i W_i (x_i - m)(x_i - m)^T``.

    Components with ``is_angle[j]`` get the circular mean ``atan2(sum W_i sin, sum W_i cos)``
    (NaN when the resultant is below ``1e-12 sum |W_i|``) and wrapped deviations, as in
    :func:`pfcourse.diagnostics.weighted_covariance`.  Both are taken relative to the first
    particle, ``x_0 + sum_i W_i (x_i - x_0)`` and
    ``wrap(x_0 + atan2(sum W_i sin(x_i - x_0), sum W_i cos(x_i - x_0)))``, so a cloud
    collapsed onto one point has exactly that point as mean and a zero covariance.
    Returns ``(mean, cov)``.
    """
    n, d = particles.shape
    origin = particles[0].copy()
    linear, sines, cosines = np.zeros(d), np.zeros(d), np.zeros(d)
    magnitude = 0.0
    for i in range(n):
        w = weights[i]
        magnitude += abs(w)
        for j in range(d):
            x = particles[i, j] - origin[j]
            if is_angle[j]:
                sines[j] += w * math.sin(x)
                cosines[j] += w * math.cos(x)
            else:
                linear[j] += w * x
    mean = np.empty(d)
    for j in range(d):
        if not is_angle[j]:
            mean[j] = origin[j] + linear[j]
        elif math.hypot(sines[j], cosines[j]) > 1e-12 * magnitude:
            mean[j] = wrap(origin[j] + math.atan2(sines[j], cosines[j]))
        else:
            mean[j] = math.nan
    cov = np.zeros((d, d))
    dev = np.empty(d)
    for i in range(n):
        w = weights[i]
        for j in range(d):
            dev[j] = particles[i, j] - mean[j]
            if is_angle[j]:
                dev[j] = wrap(dev[j])
        for a in range(d):
            wa = w * dev[a]
            for b in range(a, d):
                cov[a, b] += wa * dev[b]
    for a in range(d):
        for b in range(a):
            cov[a, b] = cov[b, a]
    return mean, cov


@jit
def inverse_cdf_sorted(w: np.ndarray, u: np.ndarray) -> np.ndarray:
    """For *sorted* uniforms ``u`` in [0, 1), the indices ``i`` with ``C_{i-1} <= u < C_i``.

    ``C`` is the cumulative sum of ``w`` capped at 1 and set to exactly 1 from the last
    positive weight on (so no index points at a zero weight), as in
    :mod:`pfcourse.resampling`; one merge pass over ``C`` and ``u``.
    """
    n = w.size
    last = n - 1
    while last > 0 and w[last] == 0.0:
        last -= 1
    cdf = np.empty(n)
    c = 0.0
    for i in range(n):
        c += w[i]
        cdf[i] = min(c, 1.0)
    for i in range(last, n):
        cdf[i] = 1.0
    out = np.empty(u.size, dtype=np.int64)
    i = 0
    for k in range(u.size):
        v = min(u[k], _LARGEST_BELOW_ONE)
        while cdf[i] <= v:
            i += 1
        out[k] = i
    return out


@jit
def gather_rows(particles: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """``particles[indices]`` for a 2-D array (one pass, no index checks beyond numba's)."""
    n, d = indices.size, particles.shape[1]
    out = np.empty((n, d))
    for k in range(n):
        src = indices[k]
        for j in range(d):
            out[k, j] = particles[src, j]
    return out
