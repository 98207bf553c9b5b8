"""Chapter 10's coding exercise (the velocity motion model) and Part II's capstone (bearing-only
tracking): the reference answers pass, each typical mistake gets its own sentence, the generator is checked."""

import numpy as np
import pytest

from pfcourse.exercises import VELOCITY_MISTAKES, check_velocity_motion, velocity_motion


def wrap(a):
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def student_motion(x, u, sd, dt, rng, mistake=None):
    """The velocity model as a student writes it, with one typical mistake switched on."""
    draw = np.random if mistake == "global" else rng
    n = 1 if mistake == "shared" else len(x)
    v = u[0] + sd[0] * draw.standard_normal(n)
    w = u[1] + sd[1] * draw.standard_normal(n)
    th = x[:, 2]
    new = th + w * dt
    px = x[:, 0] + v / w * (np.sin(new) - np.sin(th))
    py = x[:, 1] + v / w * (np.cos(th) - np.cos(new))
    return np.column_stack([px, py, new if mistake == "no_wrap" else wrap(new)])


def test_the_reference_answers_pass():
    assert check_velocity_motion(velocity_motion).ok, str(check_velocity_motion(velocity_motion))
    for seed in (0, 1, 2):
        report = check_velocity_motion(student_motion, seed=seed)
        assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(VELOCITY_MISTAKES))
def test_each_statistical_mistake_gets_its_own_sentence(mistake):
    report = check_velocity_motion(lambda x, u, sd, dt, rng: velocity_motion(x, u, sd, dt, rng, mistake=mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert VELOCITY_MISTAKES[mistake] in report.problems[0]


@pytest.mark.parametrize("mistake, says", [
    ("shared", "one noise pair per particle"),
    ("no_wrap", "outside (-pi, pi]"),
    ("global", "NumPy's global generator"),
])
def test_the_direct_mistakes_are_named(mistake, says):
    report = check_velocity_motion(lambda x, u, sd, dt, rng: student_motion(x, u, sd, dt, rng, mistake))
    assert not report.ok and says in report.problems[0], str(report)


@pytest.mark.parametrize("feed, says", [
    (lambda rng: np.random.default_rng(), "same seed gave different"),
    (lambda rng: np.random.default_rng(7), "whatever the generator's seed"),
])
def test_a_generator_of_its_own_is_named(feed, says):
    report = check_velocity_motion(lambda x, u, sd, dt, rng: student_motion(x, u, sd, dt, feed(rng)))
    assert not report.ok and says in report.problems[0], str(report)


def test_the_motion_checker_leaves_numpys_global_state_alone():
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    check_velocity_motion(lambda x, u, sd, dt, rng: student_motion(x, u, sd, dt, rng, "global"))
    assert np.random.random() == expected


def test_a_straight_step_is_the_arc_for_a_small_turn():
    """The arc's limit: as omega dt -> 0 the velocity model moves v dt along the heading."""
    x = np.array([[1.0, 2.0, 0.3]])
    out = velocity_motion(x, np.array([2.0, 1e-7]), np.zeros(2), 1.5, np.random.default_rng(0))
    assert np.allclose(out[0, :2], [1 + 3 * np.cos(0.3), 2 + 3 * np.sin(0.3)], atol=1e-6)
