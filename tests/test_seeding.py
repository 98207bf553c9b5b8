"""pfcourse.seeding: every named stream is the entropy list its docstring gives, the streams of
one run differ, replicate seeds are SeedSequence's, and bad seeds are refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.checks import check_seed
from pfcourse.errors import ParameterError, PfcourseError
from pfcourse.seeding import (
    data_rng,
    filter_rng,
    kidnap_rng,
    map_error_rng,
    likelihood_rng,
    reference_rng,
    replicate_seed,
    sized_filter_rng,
)


def draws(rng: np.random.Generator) -> np.ndarray:
    """A few draws of two kinds, enough to tell two streams apart."""
    return np.concatenate([rng.standard_normal(5), rng.uniform(size=3), rng.integers(0, 2**31, 4)])


# (named stream, the entropy list the table of pfcourse/seeding.py documents)
STREAMS = [
    (lambda: data_rng(0, 3), [0, 3, 0]),
    (lambda: data_rng(5, 0), [5, 0, 0]),
    (lambda: filter_rng(0, 3), [0, 3, 1]),
    (lambda: filter_rng(2026, 41), [2026, 41, 1]),
    (lambda: likelihood_rng(0, 17), [0, 17, 2]),
    (lambda: reference_rng(0, 4, 1), [0, 4, 101]),
    (lambda: reference_rng(0, 4, 2), [0, 4, 102]),
    (lambda: sized_filter_rng(1, 300), [1, 300]),
    (lambda: sized_filter_rng(12, 1000, run=3), [12, 3, 1000]),
    (lambda: kidnap_rng(9), [9, 7]),
    (lambda: map_error_rng(0, 5), [0, 5, 3]),
]


@pytest.mark.parametrize("index", range(len(STREAMS)))
def test_each_named_stream_is_its_documented_entropy_list(index):
    make, key = STREAMS[index]
    np.testing.assert_array_equal(draws(make()), draws(np.random.default_rng(key)))


def test_numpy_integers_give_the_same_stream_as_python_ints():
    np.testing.assert_array_equal(draws(data_rng(np.int64(3), np.int32(8))), draws(data_rng(3, 8)))
    np.testing.assert_array_equal(draws(sized_filter_rng(np.int64(2), np.int64(30))), draws(sized_filter_rng(2, 30)))


def test_the_streams_of_one_run_are_different():
    seed, run = 0, 5
    streams = {
        "data": data_rng(seed, run), "filter": filter_rng(seed, run), "likelihood": likelihood_rng(seed, run),
        "reference 1": reference_rng(seed, run, 1), "reference 2": reference_rng(seed, run, 2),
        "N = 100": sized_filter_rng(seed, 100, run=run), "N = 100, no run": sized_filter_rng(seed, 100),
        "kidnap": kidnap_rng(seed),
    }
    values = {name: draws(rng) for name, rng in streams.items()}
    names = list(values)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert not np.array_equal(values[a], values[b]), (a, b)
    # and runs and seeds are told apart
    assert not np.array_equal(draws(data_rng(0, 1)), draws(data_rng(0, 2)))
    assert not np.array_equal(draws(filter_rng(0, 1)), draws(filter_rng(1, 1)))


@pytest.mark.parametrize("base, replicate", [(0, 0), (0, 1), (0, 99), (7, 2), (3, 1000), (2026, 5)])
def test_replicate_seed_is_seedsequence_state(base, replicate):
    state = np.random.SeedSequence([base, replicate]).generate_state(1, np.uint64)[0]
    expected = int(state) >> 1
    got = replicate_seed(base, replicate)
    assert type(got) is int and got == expected and 0 <= got < 2**63


def test_replicate_seeds_differ_across_replicates_and_bases():
    seeds = {replicate_seed(b, r) for b in range(3) for r in range(50)}
    assert len(seeds) == 150


BAD = [-1, -(2**40), 1.0, 2.5, np.float64(3.0), None, True, np.bool_(False), "3", [1, 2]]


@pytest.mark.parametrize("bad", BAD, ids=repr)
def test_bad_seeds_are_refused_by_name(bad):
    for call in (lambda: check_seed(bad), lambda: data_rng(bad, 0), lambda: filter_rng(0, bad),
                 lambda: likelihood_rng(bad, 1), lambda: reference_rng(0, 1, bad),
                 lambda: sized_filter_rng(bad, 100), lambda: sized_filter_rng(0, bad),
                 lambda: kidnap_rng(bad), lambda: replicate_seed(bad, 0), lambda: replicate_seed(0, bad),
                 # run=None is sized_filter_rng's documented "no run" (the key [seed, N])
                 *([] if bad is None else [lambda: sized_filter_rng(0, 100, run=bad)])):
        with pytest.raises(ParameterError) as info:
            call()
        assert isinstance(info.value, PfcourseError) and isinstance(info.value, ValueError)
        assert "non-negative integer" in str(info.value)


def test_the_message_names_the_argument():
    with pytest.raises(ParameterError, match="run"):
        filter_rng(0, -3)
    with pytest.raises(ParameterError, match="n_particles"):
        sized_filter_rng(0, 2.0)
    with pytest.raises(ParameterError, match="base_seed"):
        replicate_seed(None, 0)


def test_the_documented_coincidences_of_keys():
    """Keys of different rows of the table that coincide (the module docstring lists them):
    a new use of two such streams together would correlate them."""
    coincident = [(sized_filter_rng(4, 1, run=9), filter_rng(4, 9)), (sized_filter_rng(4, 7), kidnap_rng(4)),
                  (sized_filter_rng(4, 0, run=9), data_rng(4, 9)), (sized_filter_rng(4, 2, run=9), likelihood_rng(4, 9)),
                  (sized_filter_rng(4, 3, run=9), map_error_rng(4, 9))]
    for a, b in coincident:
        np.testing.assert_array_equal(draws(a), draws(b))


def test_plain_seed_offsets_are_named_and_checked():
    from pfcourse.seeding import run_filter_seed, study_filter_seed

    assert run_filter_seed(4) == 5 and study_filter_seed(4) == 1_000_004
    for bad in (-1, 1.5, None, True):
        with pytest.raises(ParameterError):
            run_filter_seed(bad)
        with pytest.raises(ParameterError):
            study_filter_seed(bad)
