"""pfcourse.metrics: the values, the broadcasting, and the floats of the formulas it replaced."""

from __future__ import annotations

import numpy as np

from pfcourse.angles import wrap_angle
from pfcourse.metrics import heading_error, position_error, position_spread


def test_values_on_a_small_case():
    truth = np.array([[0.0, 0.0, np.pi - 0.1], [1.0, 2.0, 0.0]])
    estimate = np.array([[3.0, 4.0, -np.pi + 0.1], [1.0, 2.0, 0.5]])
    np.testing.assert_array_equal(position_error(truth, estimate), [5.0, 0.0])
    np.testing.assert_allclose(heading_error(truth, estimate), [0.2, 0.5])
    cov = np.array([np.diag([9.0, 16.0, 1.0]), np.diag([0.0, 0.0, 1.0])])
    np.testing.assert_array_equal(position_spread(cov), [5.0, 0.0])


def test_one_state_against_a_cloud_broadcasts():
    rng = np.random.default_rng(1)
    cloud, truth = rng.normal(size=(50, 3)), rng.normal(size=3)
    e = position_error(truth, cloud)
    assert e.shape == (50,)
    assert position_error(truth, cloud[7]) == e[7]
    assert heading_error(truth, cloud).shape == (50,)


def test_same_floats_as_the_formulas_it_replaced():
    """``hypot`` of either difference (``truth - estimate`` or ``estimate - truth``), the wrapped
    ``estimate - truth``, ``sqrt(P_xx + P_yy)``: the stored studies' numbers do not move."""
    rng = np.random.default_rng(2)
    for scale in (1e-200, 1.0, 1e150):
        truth, estimate = rng.normal(size=(300, 3)) * scale, rng.normal(size=(300, 3)) * scale
        truth[::37] = np.nan
        old_terrain = np.hypot(truth[:, 0] - estimate[:, 0], truth[:, 1] - estimate[:, 1])
        d = estimate - truth
        new = position_error(truth, estimate)
        assert np.array_equal(old_terrain.view(np.uint64), new.view(np.uint64))
        assert np.array_equal(np.hypot(d[:, 0], d[:, 1]).view(np.uint64), new.view(np.uint64))
        old_heading = np.abs(wrap_angle(d[:, 2]))
        assert np.array_equal(old_heading.view(np.uint64), heading_error(truth, estimate).view(np.uint64))
        cov = rng.normal(size=(40, 3, 3)) ** 2 * scale
        old_sd = np.sqrt(cov[:, 0, 0] + cov[:, 1, 1])
        assert np.array_equal(old_sd.view(np.uint64), position_spread(cov).view(np.uint64))


def test_locked_on_is_within_both_tolerances_over_the_whole_last_window():
    from pfcourse.metrics import LOCK_HEADING_RAD, LOCK_POSITION_M, locked_on, within_tolerances_from
    pos = np.full(60, 0.5 * LOCK_POSITION_M)
    head = np.full(60, 0.5 * LOCK_HEADING_RAD)
    assert locked_on(pos, head, dt=1.0) and within_tolerances_from(pos, head) == 0
    pos[40] = 2 * LOCK_POSITION_M  # off 20 s before the end: the last 20 s window starts at step 40
    assert not locked_on(pos, head, dt=1.0) and within_tolerances_from(pos, head) == 41
    assert locked_on(pos, head, dt=1.0, window_s=19.0)
    head[-1] = 2 * LOCK_HEADING_RAD  # a heading off at the last step is not locked on
    assert not locked_on(np.full(60, 0.1), head, dt=1.0)
    assert locked_on(np.full(10, 0.1), np.full(10, 0.01), dt=0.5)  # window longer than the run: all steps


def test_rmse_over_points_averages_each_points_squared_error():
    """``points = L``: the RMS over ``L`` points of each point's error, bit for bit the study's arithmetic."""
    import pytest
    from pfcourse.errors import ParameterError
    from pfcourse.metrics import rmse
    g = np.random.default_rng(3).normal(size=(40, 4))
    assert rmse(g, components=1, points=2) == np.sqrt(np.mean(np.sum(g ** 2, axis=1) / 2))
    each = (np.sum(g[:, :2] ** 2, axis=1) + np.sum(g[:, 2:] ** 2, axis=1)) / 2  # the two points' mean squared error
    assert np.isclose(rmse(g, components=1, points=2) ** 2, np.mean(each))
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ParameterError, match="points"):
            rmse(g, components=1, points=bad)
