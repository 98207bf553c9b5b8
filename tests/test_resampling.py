"""Tests of pfcourse.resampling.

The statistical tests draw each scheme R = 20000 times with a fixed seed and
look at the offspring counts N_i = bincount(indices).  For all four schemes
N_i is a constant plus a sum of independent Bernoulli variables (see
``bernoulli_decomposition``), which gives its exact mean, variance and fourth
central moment.  Tolerances follow from these: 5 standard errors for a mean
and 6 standard deviations of the sample variance for a variance.  Nothing was
tuned to make the tests pass.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import filterpy.monte_carlo.resampling as filterpy_resampling
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfcourse.errors import ParameterError, WeightError
from pfcourse.resampling import SCHEMES, get_resampler

R = 20_000
N = 10
SEED = 20240611
TINY_VARIANCE = 1e-12  # lower bound on a variance, so a deterministic count gets a tolerance
WEIGHT_SETS = {
    # N w = 3, 2.5, 1.5, 1.2, 1, 0.5, 0.2, 0.099, 0.001, 0 (float sum 1 + 2e-16)
    "hand": np.array([0.3, 0.25, 0.15, 0.12, 0.1, 0.05, 0.02, 0.0099, 0.0001, 0.0]),
    # N w from 0.0074 to 2.03
    "dirichlet": np.random.default_rng(0).dirichlet(np.full(N, 0.7)),
}


def offspring_counts(draw: Callable[[], np.ndarray], size: int, repeats: int) -> np.ndarray:
    """Offspring counts of ``repeats`` calls of ``draw``, shape ``(repeats, size)``."""
    return np.array([np.bincount(draw(), minlength=size) for _ in range(repeats)])


@functools.cache
def simulated_counts(scheme: str, weight_set: str, n: int = N, repeats: int = R) -> np.ndarray:
    """Offspring counts of ``repeats`` runs of ``scheme`` on a weight set (cached)."""
    weights = WEIGHT_SETS[weight_set]
    rng = np.random.default_rng(SEED)
    return offspring_counts(lambda: SCHEMES[scheme](weights, rng, n), weights.size, repeats)


def bernoulli_decomposition(scheme: str, w: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Write ``N_i = c_i + sum_k B_ik`` with independent ``B_ik ~ Bernoulli(p_ik)``.

    Returns ``(c, p)`` with ``p`` of shape ``(len(w), K)``:

    * multinomial: ``n`` draws, each picks particle ``i`` with probability ``w_i``;
    * residual: ``floor(n w_i)`` plus ``L = n - sum_j floor(n w_j)`` draws with
      probability ``(n w_i - floor(n w_i)) / L``;
    * systematic: ``floor(n w_i)`` plus one draw with probability ``frac(n w_i)``;
    * stratified: uniform ``k`` falls in particle ``i``'s interval
      ``[n C_{i-1}, n C_i)`` with probability the length of that interval's
      overlap with ``[k, k + 1)``.
    """
    expected = n * w
    floor = np.floor(expected)
    if scheme == "multinomial":
        return np.zeros_like(w), np.repeat(w[:, None], n, axis=1)
    if scheme == "residual":
        left = n - int(floor.sum())
        return floor, np.repeat(((expected - floor) / left)[:, None], left, axis=1)
    if scheme == "systematic":
        return floor, (expected - floor)[:, None]
    upper = n * np.cumsum(w)
    lower = upper - expected
    k = np.arange(n)
    overlap = np.minimum(upper[:, None], k + 1) - np.maximum(lower[:, None], k)
    return np.zeros_like(w), np.clip(overlap, 0.0, 1.0)


def theoretical_moments(
    scheme: str, w: np.ndarray, n: int = N
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact mean, variance and fourth central moment of every offspring count."""
    offset, p = bernoulli_decomposition(scheme, w, n)
    pq = p * (1 - p)
    variance = pq.sum(axis=1)
    fourth = (pq * (1 - 6 * pq)).sum(axis=1) + 3 * variance**2
    return offset + p.sum(axis=1), variance, fourth


def sample_variance_sd(variance: np.ndarray, fourth: np.ndarray, repeats: int = R) -> np.ndarray:
    """Standard deviation of the unbiased sample variance of ``repeats`` iid draws."""
    return np.sqrt((fourth - variance**2 * (repeats - 3) / (repeats - 1)) / repeats)


# --- statistical properties ---------------------------------------------------


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
def test_bernoulli_decomposition_reproduces_closed_forms(weight_set):
    w = WEIGHT_SETS[weight_set]
    floor = np.floor(N * w)
    r = N * w - floor
    left = N - floor.sum()
    moments = {scheme: theoretical_moments(scheme, w) for scheme in SCHEMES}
    for mean, _, _ in moments.values():
        np.testing.assert_allclose(mean, N * w, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(moments["multinomial"][1], N * w * (1 - w), atol=1e-12)
    np.testing.assert_allclose(moments["systematic"][1], r * (1 - r), atol=1e-12)
    p = r / left
    np.testing.assert_allclose(moments["residual"][1], left * p * (1 - p), atol=1e-12)
    assert np.all(moments["stratified"][1] <= moments["multinomial"][1] + 1e-12)


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_offspring_counts_are_unbiased(scheme, weight_set):
    w = WEIGHT_SETS[weight_set]
    _, variance, _ = theoretical_moments(scheme, w)
    standard_error = np.sqrt(np.maximum(variance, TINY_VARIANCE) / R)
    error = simulated_counts(scheme, weight_set).mean(axis=0) - N * w
    np.testing.assert_array_less(np.abs(error), 5 * standard_error)


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_offspring_count_variance_matches_closed_form(scheme, weight_set):
    _, variance, fourth = theoretical_moments(scheme, WEIGHT_SETS[weight_set])
    sample_variance = simulated_counts(scheme, weight_set).var(axis=0, ddof=1)
    tolerance = 6 * sample_variance_sd(variance, fourth) + TINY_VARIANCE
    np.testing.assert_array_less(np.abs(sample_variance - variance), tolerance)


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
def test_stratified_variance_at_most_multinomial(weight_set):
    w = WEIGHT_SETS[weight_set]
    sample, sd = {}, {}
    for scheme in ("stratified", "multinomial"):
        sample[scheme] = simulated_counts(scheme, weight_set).var(axis=0, ddof=1)
        _, variance, fourth = theoretical_moments(scheme, w)
        sd[scheme] = sample_variance_sd(variance, fourth)
    tolerance = 6 * np.hypot(sd["stratified"], sd["multinomial"]) + TINY_VARIANCE
    np.testing.assert_array_less(sample["stratified"], sample["multinomial"] + tolerance)


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
def test_offspring_count_bounds(weight_set):
    floor = np.floor(N * WEIGHT_SETS[weight_set])
    systematic = simulated_counts("systematic", weight_set) - floor
    stratified = simulated_counts("stratified", weight_set) - floor
    residual = simulated_counts("residual", weight_set) - floor
    assert set(np.unique(systematic)) <= {0, 1}
    assert stratified.min() >= -1 and stratified.max() <= 2
    assert residual.min() >= 0


@pytest.mark.parametrize("n", [1, 3, 25])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_n_different_from_number_of_weights(scheme, n):
    repeats = 2_000
    w = WEIGHT_SETS["dirichlet"]
    counts = simulated_counts(scheme, "dirichlet", n=n, repeats=repeats)
    assert np.all(counts.sum(axis=1) == n)
    _, variance, _ = theoretical_moments(scheme, w, n)
    standard_error = np.sqrt(np.maximum(variance, TINY_VARIANCE) / repeats)
    np.testing.assert_array_less(np.abs(counts.mean(axis=0) - n * w), 5 * standard_error)


# --- edge cases -----------------------------------------------------------------


class ConstantUniforms:
    """Stand-in for a Generator whose uniforms all equal ``value``."""

    def __init__(self, value: float) -> None:
        self.value = value

    def random(self, size: int | None = None) -> np.ndarray:
        return np.full(() if size is None else size, self.value)


LARGEST_UNIFORM = np.nextafter(1.0, 0.0)
ROUND_OFF_WEIGHTS = {
    "sum-below-one": np.full(10, 0.1) * (1 - 1e-12),
    # float sum 1.0 but cumsum ends at 1 - 1.1e-16, then a zero weight
    "cumsum-below-one": np.append(np.full(10, 0.1), 0.0),
    "leading-zero": np.array([0.0, 0.5, 0.5]),
}


@pytest.mark.parametrize("n", [None, 4])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_single_unit_weight_selects_only_that_particle(scheme, n):
    w = np.zeros(7)
    w[3] = 1.0
    indices = SCHEMES[scheme](w, np.random.default_rng(SEED), n)
    np.testing.assert_array_equal(indices, np.full(n or 7, 3))


@pytest.mark.parametrize("size", [1, 3, 10, 49, 1000])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_uniform_weights(scheme, size):
    indices = SCHEMES[scheme](np.full(size, 1 / size), np.random.default_rng(SEED))
    if scheme == "multinomial":
        assert indices.shape == (size,) and np.all((indices >= 0) & (indices < size))
    else:
        np.testing.assert_array_equal(indices, np.arange(size))


@pytest.mark.parametrize("n", [None, 5])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_single_particle(scheme, n):
    indices = SCHEMES[scheme](np.array([1.0]), np.random.default_rng(SEED), n)
    np.testing.assert_array_equal(indices, np.zeros(n or 1, dtype=np.int64))


@pytest.mark.parametrize("weight_set", ROUND_OFF_WEIGHTS)
@pytest.mark.parametrize("n", [None, 3, 7])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_round_off_and_extreme_uniforms_give_valid_indices(scheme, n, weight_set):
    weights = ROUND_OFF_WEIGHTS[weight_set]
    generators = (
        ConstantUniforms(0.0),
        ConstantUniforms(LARGEST_UNIFORM),
        np.random.default_rng(SEED),
    )
    for rng in generators:
        indices = SCHEMES[scheme](weights, rng, n)
        assert indices.shape == (n or weights.size,)
        assert np.all((indices >= 0) & (indices < weights.size))
        assert np.all(weights[indices] > 0)


def test_filterpy_systematic_and_stratified_index_past_the_end(monkeypatch):
    """The trap the guard above avoids: filterpy 2.0.0 walks off the cumulative sum."""
    monkeypatch.setattr(
        filterpy_resampling, "random", ConstantUniforms(LARGEST_UNIFORM).random
    )
    weights = ROUND_OFF_WEIGHTS["sum-below-one"]
    for resample in (
        filterpy_resampling.systematic_resample,
        filterpy_resampling.stratified_resample,
    ):
        with pytest.raises(IndexError):
            resample(weights)


@st.composite
def weight_vectors(draw: st.DrawFn) -> np.ndarray:
    raw = draw(
        st.lists(st.floats(0.0, 1.0, allow_subnormal=False), min_size=1, max_size=40).filter(
            lambda values: sum(values) > 0
        )
    )
    w = np.array(raw)
    return w / w.sum()


@pytest.mark.parametrize("scheme", SCHEMES)
@settings(max_examples=100, deadline=None, database=None)
@given(weights=weight_vectors(), n=st.integers(1, 100), seed=st.integers(0, 2**32 - 1))
def test_valid_indices_for_any_valid_weights(scheme, weights, n, seed):
    resample = SCHEMES[scheme]
    indices = resample(weights, np.random.default_rng(seed), n)
    assert indices.dtype == np.int64 and indices.shape == (n,)
    assert np.all((indices >= 0) & (indices < weights.size))
    assert np.all(weights[indices] > 0)
    np.testing.assert_array_equal(indices, resample(weights, np.random.default_rng(seed), n))


@pytest.mark.parametrize("scheme", SCHEMES)
def test_same_seed_gives_same_indices(scheme):
    weights = WEIGHT_SETS["dirichlet"].copy()
    first = SCHEMES[scheme](weights, np.random.default_rng(SEED))
    second = SCHEMES[scheme](weights, np.random.default_rng(SEED))
    np.testing.assert_array_equal(first, second)
    np.testing.assert_array_equal(weights, WEIGHT_SETS["dirichlet"])


# --- errors -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("weights", "message"),
    [
        (np.full((2, 5), 0.1), "1-D"),
        (np.array([]), "empty"),
        (np.array([0.6, 0.5, -0.1]), "non-negative"),
        (np.array([0.5, np.nan, 0.5]), "finite"),
        (np.array([0.5, np.inf]), "finite"),
        (np.array([0.2, 0.3]), r"sum to 1 .*got sum 0\.5"),
        (np.array([0.5, 0.5 + 1e-6]), "sum to 1"),
    ],
    ids=["2-D", "empty", "negative", "nan", "inf", "sum-0.5", "sum-1+1e-6"],
)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_bad_weights_raise_weight_error(scheme, weights, message):
    with pytest.raises(WeightError, match=message):
        SCHEMES[scheme](weights, np.random.default_rng(SEED))


@pytest.mark.parametrize(
    ("n", "message"), [(0, "n must be at least 1"), (-3, "n must be at least 1"), (2.5, "n must be an integer")]
)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_bad_n_raises_parameter_error(scheme, n, message):
    with pytest.raises(ParameterError, match=message):
        SCHEMES[scheme](np.array([0.5, 0.5]), np.random.default_rng(SEED), n)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_sum_within_tolerance_is_accepted(scheme):
    weights = np.full(4, 0.25) * (1 - 1e-12)
    assert SCHEMES[scheme](weights, np.random.default_rng(SEED)).shape == (4,)


def test_get_resampler():
    for name, resample in SCHEMES.items():
        assert get_resampler(name) is resample
    assert get_resampler(np.sort) is np.sort
    valid = "valid names are multinomial, stratified, systematic, residual"
    with pytest.raises(ParameterError, match=valid):
        get_resampler("bootstrap")


# --- filterpy comparison --------------------------------------------------------------


@pytest.fixture
def seeded_global_numpy():
    """Seed np.random's global state (filterpy uses it) and restore it afterwards."""
    state = np.random.get_state()
    np.random.seed(SEED)
    yield
    np.random.set_state(state)


@pytest.mark.parametrize("weight_set", WEIGHT_SETS)
def test_filterpy_residual_is_biased_pfcourse_residual_is_not(weight_set, seeded_global_numpy):
    """filterpy 2.0.0 uses ``weights - copies`` instead of ``N * weights - copies``.

    When ``sum_i floor(N w_i) >= 2`` the residual weights of the particles with
    ``N w_i < 1`` come out negative, so those particles never get an offspring.
    Under residual resampling their offspring total is Binomial(L, P), with
    ``L`` the number of residual draws and ``P`` the sum of their residual
    weights, which gives the standard error.
    """
    w = WEIGHT_SETS[weight_set]
    small = N * w < 1
    left = N - np.floor(N * w).sum()
    p_small = (N * w[small]).sum() / left
    standard_error = np.sqrt(left * p_small * (1 - p_small) / R)

    theirs = offspring_counts(lambda: filterpy_resampling.residual_resample(w), N, R).mean(axis=0)
    ours = simulated_counts("residual", weight_set).mean(axis=0)

    assert np.all(theirs[small] == 0)
    assert abs(theirs[small].sum() - (N * w[small]).sum()) > 20 * standard_error
    assert abs(ours[small].sum() - (N * w[small]).sum()) < 5 * standard_error
