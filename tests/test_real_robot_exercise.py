"""The real-robot chapter's checker (pfcourse.book.exercises.real_robot): the beam model on beams drawn at
random. The reference passes, each typical mistake is named with its own message, the generator is
checked, and a broken answer is reported, never raised."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises import check_random_beams
from pfcourse.book.exercises.real_robot import (
    RANDOM_BEAM_MISTAKES, beam_terms, beams_summed, random_beam_case, random_beams_log_likelihood)


def reference(z, z_star, beam, k, rng):
    drawn = rng.choice(np.flatnonzero(z < beam.z_max), size=k, replace=False)
    hit = np.exp(-0.5 * ((z[drawn] - z_star[:, drawn]) / beam.sigma) ** 2) / (np.sqrt(2 * np.pi) * beam.sigma)
    return np.log(beam.z_hit * hit + beam.z_rand / beam.z_max).sum(axis=1)


def test_the_reference_passes():
    report = check_random_beams(reference)
    assert report.ok and str(report) == "beam model on random beams: every check passed"


def test_the_module_reference_passes_and_draws_as_the_exercise_says():
    assert check_random_beams(lambda z, zs, b, k, rng: random_beams_log_likelihood(z, zs, b, k, rng)).ok
    # another way to draw k distinct beams uniformly (a permutation) passes too
    assert check_random_beams(lambda z, zs, b, k, rng: beam_terms(z, zs, b)[
        :, rng.permutation(np.flatnonzero(z < b.z_max))[:k]].sum(axis=1)).ok


@pytest.mark.parametrize("mistake", list(RANDOM_BEAM_MISTAKES))
def test_each_mistake_is_named_with_its_own_message(mistake):
    report = check_random_beams(lambda z, zs, b, k, rng: random_beams_log_likelihood(z, zs, b, k, rng, mistake))
    assert report.problems == [f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[mistake]}"] or (
        mistake == "global_rng" and report.problems == [RANDOM_BEAM_MISTAKES["global_rng"]])


def test_the_messages_differ():
    assert len(set(RANDOM_BEAM_MISTAKES.values())) == len(RANDOM_BEAM_MISTAKES) >= 4


def test_the_sum_is_solved_for_the_beams_it_holds():
    z, z_star, beam = random_beam_case(0)
    echo = z < beam.z_max
    terms = beam_terms(z, z_star, beam)
    chosen = np.flatnonzero(echo)[[1, 4, 5]]
    s, m = beams_summed(terms[:, chosen].sum(axis=1) + 2 * np.log(beam.z_none), terms, echo, beam.z_none)
    assert m == 2 and np.array_equal(np.flatnonzero(s), np.searchsorted(np.flatnonzero(echo), chosen))
    # a constant that is no whole number of no-echo beams: not a sum of whole beams
    assert beams_summed(terms[:, chosen].sum(axis=1) + 0.3, terms, echo, beam.z_none)[0].dtype.kind == "f"
    assert beams_summed(np.random.default_rng(0).normal(size=len(z_star)), terms, echo, beam.z_none) is None


def test_a_generator_used_twice_or_a_biased_draw_is_reported():
    calls = iter(range(10**6))
    # a fresh generator seeded by a counter: the same seed does not give the same answer
    report = check_random_beams(lambda z, zs, b, k, rng: reference(z, zs, b, k, np.random.default_rng(next(calls))))
    assert report.problems and "same seed" in report.problems[0]

    def biased(z, zs, b, k, rng):  # the first beams favoured
        pool = np.flatnonzero(z < b.z_max)
        p = np.linspace(8.0, 1.0, len(pool))
        return beam_terms(z, zs, b)[:, rng.choice(pool, k, replace=False, p=p / p.sum())].sum(axis=1)
    report = check_random_beams(biased)
    assert report.problems and "far more often" in report.problems[0]


def test_broken_answers_are_reported_not_raised():
    assert "raised ZeroDivisionError" in check_random_beams(lambda z, zs, b, k, rng: 1 / 0).problems[0]
    assert "returned None" in check_random_beams(lambda z, zs, b, k, rng: None).problems[0]
    assert "shape" in check_random_beams(lambda z, zs, b, k, rng: reference(z, zs, b, k, rng)[:3]).problems[0]
    assert "NaN" in check_random_beams(lambda z, zs, b, k, rng: np.full(len(zs), np.nan)).problems[0]
    other = check_random_beams(lambda z, zs, b, k, rng: reference(z, zs, b, k, rng) ** 2 / 100)
    assert other.problems and "per-beam log-density is not" in other.problems[0]
    fewer = check_random_beams(lambda z, zs, b, k, rng: reference(z, zs, b, k - 1, rng))
    assert fewer.problems and "not k = 12" in fewer.problems[0]


def test_dropping_the_no_echo_beams_after_the_draw_is_named_whatever_the_first_draw_holds():
    def dropped(z, zs, b, k, rng):
        drawn = rng.choice(len(z), k, replace=False)
        drawn = drawn[z[drawn] < b.z_max]
        return beam_terms(z, zs, b)[:, drawn].sum(axis=1)
    for seed in range(6):  # first draws with and without a no-echo beam among them
        report = check_random_beams(dropped, seed=seed)
        assert report.problems == [f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES['dropped']}"]
    # one wrong number of beams, the same at every seed, keeps the generic message
    fewer = check_random_beams(lambda z, zs, b, k, rng: reference(z, zs, b, k - 2, rng))
    assert fewer.problems == ["the answer sums 10 beams, not k = 12: draw exactly k beams"]


def test_the_checker_leaves_the_global_generator_as_it_found_it():
    np.random.seed(7)
    state = np.random.get_state()[1].copy()
    check_random_beams(reference)
    check_random_beams(lambda z, zs, b, k, rng: random_beams_log_likelihood(z, zs, b, k, rng, "global_rng"))
    assert np.array_equal(np.random.get_state()[1], state)


def _formula_on(z, zs, b, drawn):
    d = (z[drawn] - zs[:, drawn]) / b.sigma
    hit = np.exp(-0.5 * d**2) / (np.sqrt(2 * np.pi) * b.sigma)
    return np.log(b.z_hit * hit + b.z_rand / b.z_max)


@pytest.mark.parametrize("variant, mistake", [
    # the natural no-echo mistake: all beams drawn, each scored by the stated formula
    (lambda z, zs, b, k, rng: _formula_on(z, zs, b, rng.choice(len(z), k, replace=False)).sum(axis=1), "no_echo"),
    # the same with log z_none for a beam without an echo
    (lambda z, zs, b, k, rng: beam_terms(z, zs, b)[:, rng.choice(len(z), k, replace=False)].sum(axis=1),
     "no_echo"),
    # normalised by the largest value, and by the log-sum-exp
    (lambda z, zs, b, k, rng: (lambda t: t - t.max())(reference(z, zs, b, k, rng)), "normalised"),
    (lambda z, zs, b, k, rng: (lambda t: t - np.logaddexp.reduce(t))(reference(z, zs, b, k, rng)), "normalised"),
    # a constant added outside the sum (log of the normal's constant counted once more)
    (lambda z, zs, b, k, rng: reference(z, zs, b, k, rng) - np.log(np.sqrt(2 * np.pi)), "shift"),
    # z_rand not divided by z_max
    (lambda z, zs, b, k, rng: np.log(b.z_hit * np.exp(-0.5 * ((z - zs) / b.sigma) ** 2)
                                      / (np.sqrt(2 * np.pi) * b.sigma) + b.z_rand)[
        :, rng.choice(np.flatnonzero(z < b.z_max), k, replace=False)].sum(axis=1), "no_zmax"),
])
def test_constant_offsets_and_a_missing_z_max_get_their_own_message(variant, mistake):
    report = check_random_beams(variant)
    assert report.problems == [f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[mistake]}"]


def _drawn(z, b, k, rng):
    return rng.choice(np.flatnonzero(z < b.z_max), size=k, replace=False)


def _gauss(z, zs, b, drawn):
    return np.exp(-0.5 * ((z[drawn] - zs[:, drawn]) / b.sigma) ** 2)


@pytest.mark.parametrize("variant, mistake", [
    # the Gaussian without its normaliser 1 / (sqrt(2 pi) sigma)
    (lambda z, zs, b, k, rng: (lambda d: np.log(b.z_hit * _gauss(z, zs, b, d) + b.z_rand / b.z_max).sum(axis=1))(
        _drawn(z, b, k, rng)), "no_norm"),
    # z_hit left out
    (lambda z, zs, b, k, rng: (lambda d: np.log(_gauss(z, zs, b, d) / (np.sqrt(2 * np.pi) * b.sigma)
                                                 + b.z_rand / b.z_max).sum(axis=1))(_drawn(z, b, k, rng)), "no_zhit"),
    # the normaliser written 1 / sqrt(2 pi sigma)
    (lambda z, zs, b, k, rng: (lambda d: np.log(b.z_hit * _gauss(z, zs, b, d) / np.sqrt(2 * np.pi * b.sigma)
                                                 + b.z_rand / b.z_max).sum(axis=1))(_drawn(z, b, k, rng)),
     "sqrt_sigma"),
    # the log of a sum split into a sum of logs
    (lambda z, zs, b, k, rng: (lambda d: (np.log(b.z_hit * _gauss(z, zs, b, d) / (np.sqrt(2 * np.pi) * b.sigma))
                                          + np.log(b.z_rand / b.z_max)).sum(axis=1))(_drawn(z, b, k, rng)),
     "split_log"),
    # per-pose draws, written as a student would
    (lambda z, zs, b, k, rng: np.array([_formula_on(z, zs[i:i + 1], b, _drawn(z, b, k, rng)).sum()
                                        for i in range(len(zs))]), "per_pose"),
])
def test_density_slips_and_per_pose_draws_are_named_as_such(variant, mistake):
    report = check_random_beams(variant)
    assert report.problems == [f"your function computes a known mistake: {RANDOM_BEAM_MISTAKES[mistake]}"]


def test_a_correct_draw_with_another_wrong_density_is_not_blamed_on_the_draw():
    # a density slip the checker does not list (sigma squared twice): named as the density, not the draws
    def sigma_twice(z, zs, b, k, rng):
        d = _drawn(z, b, k, rng)
        hit = np.exp(-0.5 * ((z[d] - zs[:, d]) / b.sigma**2) ** 2) / (np.sqrt(2 * np.pi) * b.sigma)
        return np.log(b.z_hit * hit + b.z_rand / b.z_max).sum(axis=1)
    report = check_random_beams(sigma_twice)
    assert report.problems and report.problems[0].startswith("the per-beam log-density is not")
    assert "beams of its own" not in report.problems[0]
