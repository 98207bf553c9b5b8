"""The real-robot chapter's checker (pfcourse.book.exercises.real_robot): the reference answer passes, each
typical mistake is named with its own message, and a broken answer is reported, never raised."""

from __future__ import annotations

import numpy as np
import pytest

from pfcourse.book.exercises.real_robot import BEAM_MISTAKES, beam_cases, beam_log_likelihood, check_beam_model


def reference(z, z_star, beam):
    echo = z < beam.z_max
    hit = beam.z_hit * np.exp(-0.5 * ((z - z_star) / beam.sigma) ** 2) / (np.sqrt(2 * np.pi) * beam.sigma)
    return np.log(np.where(echo, hit + beam.z_rand / beam.z_max, beam.z_none)).sum(axis=1)


def test_the_reference_passes():
    report = check_beam_model(reference)
    assert report.ok and str(report) == "beam model: every check passed"


@pytest.mark.parametrize("mistake", list(BEAM_MISTAKES))
def test_each_mistake_is_named_with_its_own_message(mistake):
    report = check_beam_model(lambda z, zs, b: beam_log_likelihood(z, zs, b, mistake))
    assert report.problems == [f"your function computes a known mistake: {BEAM_MISTAKES[mistake]}"]


def test_the_mistakes_differ_from_the_answer_and_from_each_other_on_the_cases():
    answers = {m: [beam_log_likelihood(z, zs, b, m) for z, zs, b in beam_cases(30, 0)] for m in [None, *BEAM_MISTAKES]}
    names = list(answers)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            assert not all(np.allclose(x, y, equal_nan=True) for x, y in zip(answers[a], answers[b])), (a, b)
    # the cases hold beams with no echo, poses that expect none, and a product that underflows
    z, z_star, beam = beam_cases(30, 0)[1]
    assert (z >= beam.z_max).any() and (z_star >= beam.z_max).any()
    assert np.isinf(beam_log_likelihood(z, z_star, beam, "product")).any()


def test_a_beam_with_no_echo_changes_no_normalised_weight():
    # the exercise's claim: log z_none is added to every pose alike, so leaving those beams out is the same
    # filter (hence not a named mistake)
    for z, z_star, beam in beam_cases(30, 1):
        full = beam_log_likelihood(z, z_star, beam)
        echo = z < beam.z_max
        part = beam_log_likelihood(z[echo], z_star[:, echo], beam)
        assert (~echo).any()
        assert np.allclose(full - part, (~echo).sum() * np.log(beam.z_none), rtol=0, atol=1e-9)
        assert np.allclose(full - full.max(), part - part.max(), rtol=0, atol=1e-9)


def test_broken_answers_are_reported_not_raised():
    assert "raised ZeroDivisionError" in check_beam_model(lambda z, zs, b: 1 / 0).problems[0]
    assert "returned None" in check_beam_model(lambda z, zs, b: None).problems[0]
    assert "shape" in check_beam_model(lambda z, zs, b: reference(z, zs, b)[:3]).problems[0]
    assert "NaN" in check_beam_model(lambda z, zs, b: np.full(len(zs), np.nan)).problems[0]
    other = check_beam_model(lambda z, zs, b: reference(z, zs, b) + 1.0)
    assert other.problems and "differ from the beam model" in other.problems[0]


def test_the_checker_draws_nothing_from_the_global_generator():
    state = np.random.get_state()[1].copy()
    check_beam_model(reference)
    assert np.array_equal(np.random.get_state()[1], state)
