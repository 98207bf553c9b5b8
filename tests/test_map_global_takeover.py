"""Exercise 15.1's checker (pfcourse.book.exercises.map_global.check_takeover): how often a look-alike stratum takes
over a right cloud under hysteresis.  The reference passes, each typical mistake is named with its own message, the
generator is checked, a broken answer is reported, and the exact rate is checked against brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pfcourse.book.exercises.map_global import (TAKEOVER_MISTAKES, check_takeover, exact_takeover,
                                                exact_takeover_case, takeover_answer)


def test_the_reference_passes():
    report = check_takeover(takeover_answer)
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake", list(TAKEOVER_MISTAKES))
def test_each_mistake_is_named_with_its_own_message(mistake):
    report = check_takeover(lambda *a: takeover_answer(*a, mistake=mistake))
    assert report.problems == [TAKEOVER_MISTAKES[mistake]]


def test_a_loop_over_runs_with_its_own_draws_is_accepted():
    """A student who loops over runs and draws each run's T injections with rng.normal (another layout of the
    draws than the reference's) is right, and passes on the exact rates."""
    def per_run(log_odds, sd, confirm, T, runs, rng):
        hits = 0
        for _ in range(runs):
            streak = 0
            for e in rng.normal(log_odds, sd, size=T):
                streak = streak + 1 if e > 0 else 0
                if streak >= confirm:
                    hits += 1
                    break
        return hits / runs

    assert check_takeover(per_run, runs=4000).ok


def test_a_mistake_with_other_draws_is_named_by_its_limit():
    """Total wins instead of a streak, drawn column by column (no replay possible): named by its exact limit."""
    def total_by_columns(log_odds, sd, confirm, T, runs, rng):
        wins = np.zeros(runs, dtype=int)
        for _ in range(T):
            wins += log_odds + sd * rng.standard_normal(runs) > 0
        return float(np.mean(wins >= confirm))

    assert check_takeover(total_by_columns).problems == [TAKEOVER_MISTAKES["total"]]


def test_the_global_generator_is_named():
    state = np.random.get_state()
    report = check_takeover(lambda *a: takeover_answer(*a[:-1], np.random.default_rng(np.random.randint(1 << 30))))
    assert len(report.problems) == 1 and "global np.random" in report.problems[0]
    assert np.array_equal(np.random.get_state()[1], state[1])


def test_a_fixed_seed_inside_is_named():
    report = check_takeover(lambda *a: takeover_answer(*a[:-1], np.random.default_rng(0)))
    assert len(report.problems) == 1 and "another seed gave the same share" in report.problems[0]


def test_a_broken_or_empty_answer_is_reported_not_raised():
    def broken(*a):
        raise RuntimeError("not written yet")

    assert check_takeover(broken).problems == ["the function raised RuntimeError: not written yet"]
    assert "returned None" in check_takeover(lambda *a: None).problems[0]


@pytest.mark.parametrize("p, confirm, T", [(0.3, 1, 5), (0.3, 2, 6), (0.7, 3, 7), (0.5, 3, 3), (0.2, 4, 3)])
def test_the_exact_rate_is_brute_force(p, confirm, T):
    """The streak recursion against all 2^T win/loss sequences."""
    total = 0.0
    for seq in itertools.product([0, 1], repeat=T):
        run, hit = 0, False
        for s in seq:
            run = run + 1 if s else 0
            hit |= run >= confirm
        total += hit * p ** sum(seq) * (1 - p) ** (T - sum(seq))
    assert exact_takeover(p, confirm, T) == pytest.approx(total, abs=1e-12)


def test_hysteresis_lowers_the_takeover_rate_as_the_chapter_says():
    """With the chapter's prior odds (xi_k = 4e-3) three wins in a row make a takeover far rarer than one."""
    lo = float(np.log(4e-3 / (1 - 4e-3)))
    one, three = exact_takeover_case(lo, 3.0, 1, 45), exact_takeover_case(lo, 3.0, 3, 45)
    assert three < one / 100


def test_a_closed_form_that_ignores_the_draws_is_told_to_simulate():
    """A closed form, (T - confirm + 1) p^confirm, that draws the numbers but does not use them."""
    from scipy.stats import norm

    def closed_form(log_odds, sd, confirm, T, runs, rng):
        rng.standard_normal((runs, T))
        return min(1.0, (T - confirm + 1) * norm.cdf(log_odds / sd) ** confirm)

    problems = check_takeover(closed_form).problems
    assert len(problems) == 1 and "another seed gave the same share" in problems[0]
    assert "do not compute a closed form" in problems[0]


def test_the_share_of_injections_won_is_not_called_last_only():
    """win.mean() with the reference's draws: the review's mistake, named as the share of injections won."""
    def share_of_wins(log_odds, sd, confirm, T, runs, rng):
        return float((log_odds + sd * rng.standard_normal((runs, T)) > 0).mean())

    assert check_takeover(share_of_wins).problems == [TAKEOVER_MISTAKES["share_of_wins"]]
