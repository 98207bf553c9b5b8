"""Part V's capstone checker (the smoothed squared innovations of the stochastic volatility model, a smoother of
PAIRS of states): the reference answers pass (FFBSm's pair weights, backward simulation, clouds stored after
resampling), each typical mistake gets its own sentence (the logsumexp axis flip of student_p5 included), the
ancestral lines are named by their spread, the grid is converged, the printed solution passes."""

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises import SVModel, check_sv_pairs, sv_grid, sv_grid_pairs, sv_pairs
from pfcourse.book.exercises.capstones import SV_SMOOTHER_DATA_SEED, SV_STEPS


def student(y, n, rng, model, mistake=None, trajectories=None):
    """A bootstrap filter and a backward pass over pairs as a student writes them, one variant switched on."""
    draw = np.random if mistake == "global" else rng
    x = model.sigma / np.sqrt(1 - model.phi ** 2) * draw.standard_normal(n)
    xs, log_ws, ancestors = [], [], []
    if mistake == "from_x0":  # the cloud of x_0, before the first return, stored as a step: pairs one step late
        xs.append(x)
        log_ws.append(np.full(n, -np.log(n)))
        ancestors.append(np.arange(n))
    for yk in y:
        x = model.phi * x + model.sigma * draw.standard_normal(n)
        var = model.beta ** 2 * np.exp(x)
        log_w = -0.5 * (np.log(2 * np.pi * var) + yk ** 2 / var)
        log_w -= logsumexp(log_w)
        a = draw.choice(n, size=n, p=np.exp(log_w))
        if mistake == "after_resampling":  # valid: the resampled cloud, equal weights
            xs.append(x[a])
            log_ws.append(np.full(n, -np.log(n)))
        else:
            xs.append(x)
            log_ws.append(log_w)
        ancestors.append(a)
        x = x[a]
    T = len(xs)
    if mistake == "naive":  # the ancestral lines of the last cloud
        idx, w, out = np.arange(n), np.exp(log_ws[-1]), np.empty(T - 1)
        for k in range(T - 2, -1, -1):
            parent = ancestors[k][idx]
            out[k] = w @ (xs[k + 1][idx] - model.phi * xs[k][parent]) ** 2
            idx = parent
        return out
    if trajectories:  # backward simulation (FFBSi), the functional averaged along the trajectories
        b = rng.choice(n, size=trajectories, p=np.exp(log_ws[-1]))
        path = [xs[-1][b]]
        for k in range(T - 2, -1, -1):
            lp = log_ws[k][None, :] - 0.5 * ((path[0][:, None] - model.phi * xs[k][None, :]) / model.sigma) ** 2
            p = np.exp(lp - logsumexp(lp, axis=1, keepdims=True))
            b = np.array([rng.choice(n, p=row) for row in p])
            path.insert(0, xs[k][b])
        path = np.array(path)
        return np.mean((path[1:] - model.phi * path[:-1]) ** 2, axis=1)
    phi = 1.0 if mistake == "no_phi" else model.phi
    var = model.sigma if mistake == "sigma_variance" else model.sigma ** 2
    log_s, out = log_ws[-1], []
    for k in range(T - 2, -1, -1):
        d = xs[k + 1][:, None] - model.phi * xs[k][None, :]
        ell = -0.5 * (xs[k + 1][:, None] - phi * xs[k][None, :]) ** 2 / var
        if mistake == "no_normaliser":
            log_c = 0.0
        else:
            log_c = logsumexp(log_ws[k][None, :] + ell, axis=0 if mistake in ("wrong_axis", "index_flip") else 1)
            # wrong_axis: the sums over j used per particle i (keepdims=True flipped to axis 0); index_flip
            # (student_p5): axis=1 flipped to axis=0 in the line of log_c, the sums still used per j
            log_c = log_c[None, :] if mistake == "wrong_axis" else log_c[:, None]
        log_pair = log_ws[k][None, :] + ell - log_c + log_s[:, None]
        log_pair -= logsumexp(log_pair)
        new = logsumexp(log_pair, axis=0)
        if mistake == "marginals":
            out.insert(0, float(np.exp(log_s) @ (d ** 2 @ np.exp(new))))
        elif mistake == "means":
            out.insert(0, float((np.exp(log_s) @ xs[k + 1] - model.phi * np.exp(new) @ xs[k]) ** 2))
        elif mistake == "filter":  # the filter weights of step k+1 in place of the smoothed ones
            lp = log_ws[k][None, :] + ell - log_c + log_ws[k + 1][:, None]
            out.insert(0, float(np.sum(np.exp(lp - logsumexp(lp)) * d ** 2)))
        else:
            out.insert(0, float(np.sum(np.exp(log_pair) * d ** 2)))
        log_s = new
    if mistake == "from_x0":
        return np.array(out[:len(y) - 1])
    if mistake == "reversed":  # the backward pass's values in the order it meets them
        return np.array(out[::-1])
    if mistake == "early":  # e[k] holds the pair (x_k+2, x_k+3)
        return np.array(out[1:] + out[-1:])
    return np.array(out)


def answer(mistake=None, **kw):
    return lambda y, n, rng, model: student(y, n, rng, model, mistake, **kw)


def data():
    model = SVModel()
    return model, model.simulate(SV_STEPS, np.random.default_rng(SV_SMOOTHER_DATA_SEED))[1]


def test_the_reference_answers_pass():
    assert check_sv_pairs(sv_pairs).ok
    report = check_sv_pairs(answer(), seed=100)
    assert report.ok, str(report)


def test_backward_simulation_passes():
    """FFBSi with as many trajectories as particles: not biased, its spread 2.4 times FFBSm's (PAIRS_SPREAD 3.5)."""
    report = check_sv_pairs(answer(trajectories=300))
    assert report.ok, str(report)


def test_clouds_stored_after_resampling_with_equal_weights_pass():
    report = check_sv_pairs(answer("after_resampling"))
    assert report.ok, str(report)


@pytest.mark.parametrize("mistake, says, n_runs", [
    ("marginals", "product of the smoothed marginals", 30),
    ("means", "square of the expectation", 10),
    ("filter", "filter weights W_k+1^j", 20),
    ("no_normaliser", "predictive density c^j", 20),
    ("index_flip", "logsumexp over the wrong axis", 30),
    ("wrong_axis", "summed over j it cancels", 30),
    ("no_phi", "N(x_k+1; phi x_k, sigma^2)", 20),
    ("sigma_variance", "variance sigma where", 20),
    ("global", "NumPy's global generator", 2),
])
def test_each_typical_mistake_gets_its_own_sentence(mistake, says, n_runs):
    """Each mistake is named from the first ``n_runs`` of the checker's runs (the same draws): a mistake is named
    only when the answers lie within PAIRS_MISTAKE_Z standard errors of its own large-N limit at every step.
    Measured over 30 runs: the product of the marginals 5.1 from its own limit (52 from the exact answer); the
    axis flip of the review (index_flip) has no limit of its own and lies 2.6 from the omitted normaliser's (38
    from the exact), whose sentence names both; the sums over j used per i (wrong_axis) within its own."""
    report = check_sv_pairs(answer(mistake), n_runs=n_runs)
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0], report.problems[0]


@pytest.mark.parametrize("mistake, says", [
    ("from_x0", "one step late"), ("early", "one step early"), ("reversed", "reverse order")])
def test_right_values_in_the_wrong_places_are_named(mistake, says):
    """Right values one step late (the cloud of x_0 stored as a step, as in review student_p5x), one step early,
    or in the backward pass's order: named as misaligned, not by the generic symptom."""
    report = check_sv_pairs(answer(mistake))
    assert not report.ok and len(report.problems) == 1, str(report)
    assert says in report.problems[0] and "e[0] must be the pair (x_1, x_2)" in report.problems[0], report.problems[0]


def test_misalignment_is_far_from_the_exact_values():
    """Shifted by one step or reversed, the exact values are far from themselves (so a right answer is never
    called misaligned, and a misaligned one never passes): at least 0.05 at some step, ten times the bias a valid
    particle answer may have."""
    model, y = data()
    exact = sv_grid_pairs(y, model)
    assert np.max(np.abs(exact[1:] - exact[:-1])) > 0.05
    assert np.max(np.abs(exact[::-1] - exact)) > 0.05


def test_the_ancestral_lines_are_named_by_their_spread():
    report = check_sv_pairs(answer("naive"))
    assert not report.ok and "ancestral lines" in report.problems[0], str(report)


@pytest.mark.parametrize("feed, says", [
    (lambda rng: np.random.default_rng(), "same seed gave different"),
    (lambda rng: np.random.default_rng(7), "whatever the generator's seed"),
])
def test_a_generator_of_its_own_is_named(feed, says):
    report = check_sv_pairs(lambda y, n, rng, model: student(y, n, feed(rng), model), n_runs=2)
    assert not report.ok and says in report.problems[0], str(report)


def test_shapes_and_nans_are_named():
    assert "one value per pair" in check_sv_pairs(lambda y, n, rng, m: np.zeros(len(y))).problems[0]
    assert "log domain" in check_sv_pairs(lambda y, n, rng, m: np.full(len(y) - 1, np.nan)).problems[0]


def test_the_grid_is_converged_and_its_mistakes_are_far():
    model, y = data()
    exact = sv_grid_pairs(y, model)
    assert np.max(np.abs(exact - sv_grid_pairs(y, model, n_grid=3201))) < 1e-8
    # the average is near sigma^2 (the data come from the model), and each mistake's limit is away from it
    assert abs(exact.mean() - model.sigma ** 2) < 0.05
    assert len(sv_grid(y, model)[0]) == len(exact) + 1
    for mistake in ["marginals", "means", "filter", "no_normaliser", "wrong_axis", "no_phi", "sigma_variance"]:
        assert np.max(np.abs(sv_grid_pairs(y, model, mistake) - exact)) > 0.05, mistake


def test_the_checker_leaves_numpys_global_state_alone():
    np.random.seed(5)
    expected = np.random.random()
    np.random.seed(5)
    check_sv_pairs(answer("global"), n_runs=2)
    assert np.random.random() == expected


def test_the_solution_printed_in_part_five_passes():
    text = (Path(__file__).resolve().parents[1] / "book/part5/index.md").read_text()
    solution = text.split(":::{admonition} A solution", 1)[1]
    code = re.search(r"```\{code\} python\n(.*?)```", solution, re.S).group(1)
    namespace = {}
    exec(code, namespace)
    assert check_sv_pairs(namespace["my_sv_pairs"]).ok


def test_the_self_check_in_part_five_uses_the_checkers_returns():
    """Part V's text offers a self-check on the checker's returns, written out as a call of SVModel.simulate."""
    text = " ".join((Path(__file__).resolve().parents[1] / "book/part5/index.md").read_text().split())
    assert "from pfcourse.book.exercises import SVModel" in text
    assert f"model.simulate({SV_STEPS}, np.random.default_rng({SV_SMOOTHER_DATA_SEED}))[1]" in text
