"""The particle MCMC chapter's exercise checker (ancestor sampling for a second-order autoregression, whose
reference's next two states depend on the ancestor): the reference passes, each typical mistake is named in
its own sentence, the last step, underflow and the generator are checked."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.special import logsumexp

from pfcourse.book.exercises.particle_mcmc import (ANCESTOR_CASE, ANCESTOR_MISTAKES, N_DRAWS, UNDERFLOW,
                                                   ancestor_probabilities, check_ancestor_index)


def log_normal(r, var):
    return -0.5 * r ** 2 / var


def drawing(log_terms, linear=False):
    """A student's function: draw j with probability proportional to exp(log_terms(...))."""
    def fn(log_W, past, future, a, b, s, rng):
        t = log_terms(log_W, past, future, a, b, s)
        p = np.exp(t) / np.exp(t).sum() if linear else np.exp(t - logsumexp(t))
        return int(rng.choice(len(past), p=p))
    return fn


def exact_terms(W, past, fut, a, b, s, *, second_lag=False, var=None, swap=False):
    x1, x2 = (past[:, 1], past[:, 0]) if swap else (past[:, 0], past[:, 1])
    var = s ** 2 if var is None else var
    t = W + log_normal(fut[0] - a * x1 - b * x2, var)
    if len(fut) > 1:
        t = t + log_normal(fut[1] - a * fut[0] - b * (x2 if second_lag else x1), var)
    return t


def whole_future(W, past, fut, a, b, s):
    """Correct too: every factor of the grafted path, the ones that do not depend on j included."""
    path = np.concatenate([past[:, ::-1], np.tile(fut, (len(past), 1))], axis=1)
    t = W.copy()
    for m in range(2, path.shape[1]):
        t = t + log_normal(path[:, m] - a * path[:, m - 1] - b * path[:, m - 2], s ** 2)
    return t


reference = drawing(exact_terms)

MISTAKES = {
    # the chapter's one-step formula: only the move to x'_k
    "markov": drawing(lambda W, p, f, a, b, s: W + log_normal(f[0] - a * p[:, 0] - b * p[:, 1], s ** 2)),
    "weights": drawing(lambda W, p, f, a, b, s: W),
    "no_weights": drawing(lambda W, p, f, a, b, s: exact_terms(W, p, f, a, b, s) - W),
    "swapped": drawing(lambda W, p, f, a, b, s: exact_terms(W, p, f, a, b, s, swap=True)),
    "second_lag": drawing(lambda W, p, f, a, b, s: exact_terms(W, p, f, a, b, s, second_lag=True)),
    "variance": drawing(lambda W, p, f, a, b, s: exact_terms(W, p, f, a, b, s, var=s)),
    # -(r / s)**2: the Gaussian's 1/2 left out (review smc_p5x)
    "no_half": drawing(lambda W, p, f, a, b, s: exact_terms(W, p, f, a, b, s, var=s ** 2 / 2)),
    # a stacked state (x_k, x_k-1): its transition's delta keeps only the reference's own past
    "own_past": lambda log_W, past, future, a, b, s, rng: 0,
}


def test_the_reference_passes():
    report = check_ancestor_index(reference)
    assert report.ok, str(report)


def test_the_whole_grafted_path_passes():
    """Multiplying every factor of the reference's future (most of them the same for every j) is right too."""
    report = check_ancestor_index(drawing(whole_future))
    assert report.ok, str(report)


def test_the_printed_solution_passes():
    from pathlib import Path
    import jupytext
    nb = jupytext.read(Path(__file__).resolve().parents[1] / "book/part5/particle_mcmc.py")
    code = [c.source for c in nb.cells if "solution" in c.metadata.get("tags", [])]
    assert len(code) == 1
    namespace = {}
    exec("import numpy as np\nfrom scipy.special import logsumexp\n"
         + code[0].replace("print(check_ancestor_index(ancestor_index))", ""), namespace)
    assert check_ancestor_index(namespace["ancestor_index"]).ok


def test_every_mistake_has_its_own_sentence():
    assert set(MISTAKES) == set(ANCESTOR_MISTAKES)
    assert len(set(ANCESTOR_MISTAKES.values())) == len(ANCESTOR_MISTAKES) >= 4


@pytest.mark.parametrize("mistake", list(MISTAKES))
def test_each_typical_mistake_is_named(mistake):
    report = check_ancestor_index(MISTAKES[mistake])
    assert not report.ok and ANCESTOR_MISTAKES[mistake] in report.problems[0], str(report)


def test_the_mistakes_are_far_apart():
    """Each mistake moves the probabilities enough that N_DRAWS draws tell it from the exact ones and from every
    other mistake (chi-square noncentrality N sum (p - q)^2 / q at least 150; measured 160 at the closest pair,
    the one-step formula against the exact probabilities)."""
    laws = {m: ancestor_probabilities(**ANCESTOR_CASE, mistake=m) for m in [None, *ANCESTOR_MISTAKES]}
    for m1, m2 in itertools.permutations(laws, 2):
        q = np.maximum(laws[m2], 1e-300)
        assert N_DRAWS * np.sum((laws[m1] - laws[m2]) ** 2 / q) > 150, (m1, m2)


def test_the_last_step_is_checked():
    """At the last step future holds x'_T alone: code that reads future[1] fails there, with the reason."""
    report = check_ancestor_index(drawing(lambda W, p, f, a, b, s: W + log_normal(
        f[0] - a * p[:, 0] - b * p[:, 1], s ** 2) + log_normal(f[1] - a * f[0] - b * p[:, 0], s ** 2)))
    assert not report.ok and "last step" in report.problems[0], str(report)

    def keeps_a_factor(log_W, past, future, a, b, s, rng):  # at the last step, uses x'_T twice
        f = future if len(future) > 1 else np.repeat(future, 2)
        return reference(log_W, past, f, a, b, s, rng)
    report = check_ancestor_index(keeps_a_factor)
    assert not report.ok and "only W_j N(x'_T" in report.problems[0], str(report)


def test_the_linear_domain_underflows():
    """Log-weights near -1000 are allowed (the statement: not necessarily normalised); exponentiating before
    normalising is named, whether NumPy's choice then raises (NaN probabilities) or the draws go wrong."""
    report = check_ancestor_index(drawing(exact_terms, linear=True))
    assert not report.ok and len(report.problems) == 1 and UNDERFLOW in report.problems[0], str(report)

    def first_exp_then_normalise(log_W, past, future, a, b, s, rng):  # the student's answer of the review
        p = np.exp(log_W) * np.exp(exact_terms(log_W, past, future, a, b, s) - log_W)
        return int(rng.choice(len(past), p=p / p.sum()))
    report = check_ancestor_index(first_exp_then_normalise)
    assert not report.ok and len(report.problems) == 1 and UNDERFLOW in report.problems[0], str(report)

    def own_normalisation(log_W, past, future, a, b, s, rng):  # right: the weights normalised in the log domain
        return reference(log_W - logsumexp(log_W), past, future, a, b, s, rng)
    assert check_ancestor_index(own_normalisation).ok


def test_the_statement_allows_unnormalised_log_weights():
    """The checker passes log-weights near -1000, so the statement must not call them normalised."""
    import jupytext
    from pathlib import Path
    nb = jupytext.read(Path(__file__).resolve().parents[1] / "book/part5/particle_mcmc.py")
    statement = next(c.source for c in nb.cells if "ex-pmcmc-ancestor" in c.source and "```{exercise}" in c.source)
    assert "not necessarily normalised" in " ".join(statement.split()), statement


def test_the_generator_is_checked():
    def global_state(log_W, past, future, a, b, s, rng):
        return reference(log_W, past, future, a, b, s, np.random.default_rng(np.random.randint(1 << 30)))

    def own_seed(log_W, past, future, a, b, s, rng):
        return reference(log_W, past, future, a, b, s, np.random.default_rng(4))  # always 5

    def most_probable(log_W, past, future, a, b, s, rng):
        return int(np.argmax(exact_terms(log_W, past, future, a, b, s)))

    before = np.random.get_state()
    assert "global" in check_ancestor_index(global_state).problems[0]
    assert np.array_equal(np.random.get_state()[1], before[1])
    assert "same index every time" in check_ancestor_index(most_probable).problems[0]
    assert "another seed" in check_ancestor_index(own_seed).problems[0]
    # the reference leaves NumPy's global state untouched
    check_ancestor_index(reference)
    assert np.array_equal(np.random.get_state()[1], before[1])


def test_a_wrong_return_is_reported():
    assert "not an integer index" in check_ancestor_index(lambda *a: 0.5).problems[0]
    assert "returned None" in check_ancestor_index(lambda *a: None).problems[0]
