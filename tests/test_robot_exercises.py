"""Chapter 10's coding exercise (the velocity motion model) and the bearing exercises of chapter 12: the
reference answers pass, each typical mistake gets its own sentence, the generator is checked (Part II's
capstone, bearing-only tracking, is tested in tests/test_capstone_part2.py)."""

import numpy as np
import pytest

from pfcourse.book.exercises import VELOCITY_MISTAKES, check_velocity_motion, velocity_motion


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


# ----------------------------------------------------------------------------- chapter 12's exercise
from pfcourse.book.exercises import RELATIVE_MISTAKES, check_relative_jacobian, relative_landmark_jacobian  # noqa: E402


def relative(state, landmark):
    c, s = np.cos(state[2]), np.sin(state[2])
    return np.array([[c, s], [-s, c]]) @ (np.asarray(landmark) - state[:2])


def test_the_relative_jacobian_is_the_derivative():
    """A central difference of z = R(theta)^T (l - p) agrees with the reference, and passes the checker."""
    def numeric(state, landmark, h=1e-6):
        cols = []
        for i in range(3):
            e = np.zeros(3)
            e[i] = h
            cols.append((relative(state + e, landmark) - relative(state - e, landmark)) / (2 * h))
        return np.column_stack(cols)
    state, landmark = np.array([1.0, -2.0, 0.7]), np.array([12.0, 5.0])
    assert np.allclose(numeric(state, landmark), relative_landmark_jacobian(state, landmark), atol=1e-7)
    assert check_relative_jacobian(numeric).ok
    assert check_relative_jacobian(relative_landmark_jacobian).ok


@pytest.mark.parametrize("mistake", list(RELATIVE_MISTAKES))
def test_each_jacobian_mistake_gets_its_own_sentence(mistake):
    report = check_relative_jacobian(lambda st, lm: relative_landmark_jacobian(st, lm, mistake))
    assert not report.ok and len(report.problems) == 1 and RELATIVE_MISTAKES[mistake] in report.problems[0]


def test_a_wrong_shape_and_an_unknown_mistake_are_reported():
    assert "2, 3" in check_relative_jacobian(lambda st, lm: np.zeros(3)).problems[0]
    other = check_relative_jacobian(lambda st, lm: 2 * relative_landmark_jacobian(st, lm))
    assert "differentiate each" in other.problems[0]


# ----------------------------------------------------------------------------- chapter 11's exercise
from pfcourse.book.exercises import (BEARING_POSE_CASE, BEARING_POSE_MISTAKES, bearing_pose_draw,  # noqa: E402
                                check_bearing_pose_draw)


def student_pose(b, landmark, sd_b, r_max, n, rng, mistake=None):
    draw = np.random if mistake == "global" else rng
    r = r_max * np.sqrt(draw.random(n))
    phi = draw.uniform(-np.pi, np.pi, n)
    theta = phi + np.pi - (b + sd_b * draw.standard_normal(n))
    return np.column_stack([landmark[0] + r * np.cos(phi), landmark[1] + r * np.sin(phi),
                            theta if mistake == "no_wrap" else wrap(theta)])


def test_the_pose_draw_references_pass():
    assert check_bearing_pose_draw(lambda *a: bearing_pose_draw(*a)).ok
    for seed in (0, 1, 2):
        report = check_bearing_pose_draw(student_pose, seed=seed)
        assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(BEARING_POSE_MISTAKES))
def test_each_pose_draw_mistake_gets_its_own_sentence(mistake):
    report = check_bearing_pose_draw(lambda *a: bearing_pose_draw(*a, mistake=mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert BEARING_POSE_MISTAKES[mistake] in report.problems[0]


@pytest.mark.parametrize("mistake, says", [("no_wrap", "outside (-pi, pi]"), ("global", "NumPy's global generator")])
def test_the_direct_pose_draw_mistakes_are_named(mistake, says):
    report = check_bearing_pose_draw(lambda *a: student_pose(*a, mistake=mistake))
    assert not report.ok and says in report.problems[0], str(report)


def test_the_pose_draw_names_a_generator_of_its_own_and_leaves_the_global_state():
    own = check_bearing_pose_draw(lambda b, l, s, r, n, rng: student_pose(b, l, s, r, n, np.random.default_rng(7)))
    assert "whatever the generator's seed" in own.problems[0]
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    check_bearing_pose_draw(lambda *a: student_pose(*a, mistake="global"))
    assert np.random.random() == expected


def test_the_drawn_poses_see_the_landmark_at_the_bearing():
    """Without bearing noise every drawn pose sees the landmark exactly at b."""
    case = BEARING_POSE_CASE
    x = bearing_pose_draw(case["b"], case["landmark"], 0.0, case["r_max"], 1000, np.random.default_rng(1))
    d = case["landmark"] - x[:, :2]
    assert np.allclose(wrap(np.arctan2(d[:, 1], d[:, 0]) - x[:, 2] - case["b"]), 0.0, atol=1e-9)
