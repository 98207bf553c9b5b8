"""The package's systematic resampler draws what the map robot's global localization drew with its own copy
(``global_mcl.systematic`` until issue 44's remainder: ``np.searchsorted`` on ``cumsum(W)`` with the last entry
set to 1), index for index, on normalised weights with underflowed (zero) weights and with ``m != N`` draws
(KLD-sampling resamples to another size), from the same single uniform: so global_mcl can call
``pfcourse.resampling.systematic(W, rng, m)`` without changing its stored floats.  They can differ only when
a uniform falls within rounding of a step of the CDF, or beyond the last positive weight's (where the copy
picks a zero-weight particle and the package does not): measured 0 of 8,931 calls on six stored drives."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.resampling import systematic


def copied_rule(W, m, rng):
    """global_mcl's copy, as it was."""
    c = np.cumsum(W)
    c[-1] = 1.0
    return np.searchsorted(c, (rng.random() + np.arange(m)) / m, side="right").clip(max=len(W) - 1)


@pytest.mark.parametrize("seed", range(40))
def test_the_package_s_systematic_draws_the_copied_rule_s_indices(seed):
    rng = np.random.default_rng([44, seed])
    n = int(rng.integers(2, 5000))
    log_w = rng.normal(0.0, float(rng.choice([1.0, 30.0, 400.0])), n)  # 400: most weights underflow to 0
    W = np.exp(log_w - logsumexp(log_w))
    m = int(rng.integers(1, 3 * n))
    state = np.random.default_rng([7, seed])
    a = copied_rule(W, m, np.random.default_rng([7, seed]))
    b = systematic(W, state, m)
    assert np.array_equal(a, b)
    assert state.random() == (lambda r: (r.random(), r.random())[1])(np.random.default_rng([7, seed]))  # one draw each
