"""Property test (hypothesis): malformed models, measurements and settings thrown at the filter
give either a valid result (finite weights summing to 1, finite moments, a finite or -inf
log-likelihood) or a named PfcourseError, never another exception and never a NaN."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pfcourse import ParticleFilter, StateSpaceModel
from pfcourse.errors import PfcourseError

BAD_VALUES = st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1e308, 1e9, 0.0, 1.0, -5.0])


def _output(kind: str, shape, fill: float, rng_value):
    if kind == "good":
        return rng_value
    if kind == "none":
        return None
    if kind == "complex":
        return np.zeros(shape) + 1j
    if kind == "object":
        return np.full(shape, None, dtype=object)
    if kind == "int":
        return np.zeros(shape, dtype=int)
    if kind == "fill":
        return np.full(shape, fill)
    if kind == "short":
        return np.zeros((shape[0] - 1,) + tuple(shape[1:])) if shape[0] > 1 else np.zeros((2,) + tuple(shape[1:]))
    if kind == "wide":
        return np.zeros(tuple(shape) + (2,))
    raise AssertionError(kind)


KINDS = st.sampled_from(["good", "good", "good", "none", "complex", "object", "int", "fill", "short", "wide"])
SETTING = st.one_of(st.integers(-2, 30), st.floats(allow_nan=True, allow_infinity=True), st.none(), st.booleans(),
                    st.just("10"))
MEASUREMENT = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True, width=64).map(lambda v: np.array([v])),
    st.just(np.array([0.0, 1.0])),
    st.just(np.array([1j])),
    st.just("z"),
)


@settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=SETTING, threshold=st.one_of(SETTING, st.floats(0, 1)), dim_x=SETTING,
    init_kind=KINDS, trans_kind=KINDS, lik_kind=KINDS, lik_step=st.integers(0, 3), fill=BAD_VALUES,
    measurements=st.lists(MEASUREMENT, min_size=1, max_size=4),
    resampler=st.sampled_from(["systematic", "multinomial", "bad_range", "bad_dtype", "good_custom"]),
)
def test_filter_never_crashes_nor_returns_nan(n, threshold, dim_x, init_kind, trans_kind, lik_kind, lik_step, fill,
                                                measurements, resampler):
    def sample_initial(m, rng):
        return _output(init_kind, (m, 1), fill, rng.normal(size=(m, 1)))

    def sample_transition(x, k, rng):
        return _output(trans_kind, x.shape, fill, x + rng.normal(0, 0.3, x.shape))

    def log_likelihood(x, z, k):
        good = -0.5 * np.nansum((z[None, :1] - x[:, :1]) ** 2, axis=1)
        return _output(lik_kind, (len(x),), fill, good) if k == lik_step else good

    if resampler == "bad_range":
        resampler = lambda w, rng: np.full(len(w), 10**12)  # noqa: E731
    elif resampler == "bad_dtype":
        resampler = lambda w, rng: np.zeros(len(w))  # noqa: E731
    elif resampler == "good_custom":
        resampler = lambda w, rng: rng.integers(0, len(w), len(w))  # noqa: E731
    model = StateSpaceModel(dim_x, sample_initial, sample_transition, log_likelihood)
    try:
        with np.errstate(all="ignore"):
            result = ParticleFilter(model, n, threshold=threshold, resampler=resampler).run(
                measurements, 0, store_particles=True)
    except PfcourseError:
        return
    assert np.all(np.isfinite(result.weights))
    np.testing.assert_allclose(result.weights.sum(axis=1), 1.0, atol=1e-9)
    assert np.all(np.isfinite(result.mean)) and np.all(np.isfinite(result.particles))
    assert np.all(np.isfinite(result.cov))  # an overflowing covariance is a NumericalError
    assert not np.isnan(result.log_likelihood)
    assert np.all(np.isfinite(result.ess))
