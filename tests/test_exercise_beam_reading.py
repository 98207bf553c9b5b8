"""Chapter 13's coding exercise: a reading drawn from the beam model (check_beam_reading)."""

import numpy as np
import pytest

from pfcourse.book.exercises import BEAM_MISTAKES, beam_reading_reference, check_beam_reading


def student_reading(z_star, scanner, rng):
    """A correct answer written another way than the reference (other draws, other order)."""
    n = len(z_star)
    part = rng.choice(4, size=n, p=[scanner.z_hit, scanner.z_short, scanner.z_max, scanner.z_rand])
    hit = np.clip(rng.normal(z_star, scanner.sigma_hit), 0.0, scanner.max_range)
    u = rng.random(n)
    short = -np.log(1 - u * (1 - np.exp(-scanner.lambda_short * z_star))) / scanner.lambda_short
    rand = rng.uniform(0.0, scanner.max_range, n)
    return np.select([part == 0, part == 1, part == 2], [hit, short, np.full(n, scanner.max_range)], rand)


def test_the_reference_and_another_correct_answer_pass():
    assert check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, r)).ok
    report = check_beam_reading(student_reading)
    assert report.ok, str(report)
    assert check_beam_reading(student_reading, seed=11).ok


SAYS = {"hit_unclipped": "clipped to z_max", "global_rng": "global np.random", "no_max": "no-echo part",
        "rand_to_z_star": "uniform on [0, z_max], not on [0, z*]", "short_untruncated": "truncated to [0, z*]",
        "short_scale": "rate lambda_short", "hit_no_noise": "has no noise", "hit_variance_as_sd": "too tight",
        "hit_double_sd": "too wide", "max_rand_swapped": "swapped",
        "one_part_per_scan": "one part for the whole scan"}


@pytest.mark.parametrize("mistake", BEAM_MISTAKES)
def test_each_typical_mistake_gets_its_own_sentence(mistake):
    report = check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, r, mistake))
    assert not report.ok and len(report.problems) == 1
    assert SAYS[mistake] in report.problems[0], report.problems[0]
    others = [SAYS[m] for m in BEAM_MISTAKES if m != mistake]
    assert not any(o in report.problems[0] for o in others)


def test_the_generator_is_the_one_given_and_the_global_state_is_left_alone():
    state = np.random.get_state()
    assert check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, r, "global_rng")).problems
    assert all(np.array_equal(a, b) for a, b in zip(np.random.get_state()[1:2], state[1:2]))
    fixed = np.random.default_rng(5)
    said = check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, fixed)).problems[0]
    assert "same seed gave different readings" in said
    said = check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, np.random.default_rng(5))).problems[0]
    assert "another seed gave the same readings" in said


def test_odd_answers_are_explained():
    assert "returned None" in check_beam_reading(lambda z, s, r: None).problems[0]
    assert "shape" in check_beam_reading(lambda z, s, r: z[:10]).problems[0]
    assert "negative" in check_beam_reading(lambda z, s, r: z - 10.0).problems[0]
    assert "raised ZeroDivisionError" in check_beam_reading(lambda z, s, r: 1 / 0).problems[0]
    only_hits = check_beam_reading(lambda z, s, r: np.clip(r.normal(z, s.sigma_hit), 0, s.max_range)).problems[0]
    assert "readings" in only_hits


def test_the_hit_spread_and_the_parts_are_checked_each_with_its_own_sentence():
    says = {"hit_no_noise": "standard deviation sigma_hit", "hit_variance_as_sd": "standard deviation sigma_hit",
            "hit_double_sd": "standard deviation sigma_hit", "max_rand_swapped": "swapped",
            "one_part_per_scan": "one part for the whole scan"}
    for mistake, said in says.items():
        report = check_beam_reading(lambda z, s, r, m=mistake: beam_reading_reference(z, s, r, m))
        assert not report.ok and len(report.problems) == 1, mistake
        assert said in report.problems[0], (mistake, report.problems[0])
    narrow = check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, r, "hit_no_noise")).problems[0]
    wide = check_beam_reading(lambda z, s, r: beam_reading_reference(z, s, r, "hit_double_sd")).problems[0]
    assert float(narrow.split()[0]) > 0.9 and float(wide.split()[0]) < 0.5
