"""Regularised kernel (bandwidth formula, covariance of the move) and progressive correction
(its final target is the posterior)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from pfcourse.errors import ParameterError
from pfcourse.filter import ParticleFilter, StateSpaceModel
from pfcourse.jitter import RegularisedJitter, optimal_bandwidth
from pfcourse.collectors import Stages
from pfcourse.proposals import ProgressiveCorrection, tempering_exponent


def test_optimal_bandwidth_formula():
    # Musso et al. 2001: A = (4 / (d + 2))^(1/(d+4)), h = A N^(-1/(d+4)); d = 1: (4/3)^(1/5) N^(-1/5)
    assert optimal_bandwidth(1, 1) == pytest.approx((4 / 3) ** 0.2)
    assert optimal_bandwidth(3000, 4) == pytest.approx((4 / 6) ** 0.125 * 3000 ** -0.125)
    # Silverman's rule for d = 1 is 1.06 N^(-1/5): the same constant
    assert optimal_bandwidth(10**6, 1) / (10**6) ** -0.2 == pytest.approx(1.0592, abs=1e-4)
    with pytest.raises(ParameterError):
        optimal_bandwidth(0, 2)


def test_jitter_adds_h2_S_to_the_covariance():
    rng = np.random.default_rng(0)
    n, d = 200_000, 3
    A = np.array([[2.0, 0, 0], [1.0, 1.0, 0], [0.0, 0.5, 0.3]])
    x = rng.standard_normal((n, d)) @ A.T
    S = np.cov(x, rowvar=False)
    jit = RegularisedJitter(scale=3.0)
    h = jit.bandwidth(n, d)
    moved = jit(x, rng)
    # Cov(x + h S^(1/2) e) = S + h^2 S, to sampling error O(1/sqrt(n))
    np.testing.assert_allclose(np.cov(moved, rowvar=False), (1 + h**2) * S, atol=5 * np.abs(S).max() / np.sqrt(n) * 4)


def test_tempering_exponent_keeps_the_ess():
    ll = np.random.default_rng(1).normal(0.0, 30.0, 5000)
    lam = tempering_exponent(ll, 1.0, 0.5)
    w = np.exp(lam * ll - np.max(lam * ll))
    assert 0 < lam < 1
    assert w.sum() ** 2 / np.sum(w**2) == pytest.approx(2500, rel=1e-3)
    assert tempering_exponent(np.zeros(10), 0.7, 0.5) == 0.7


def test_progressive_correction_targets_the_posterior():
    # x ~ N(0, 10^2), one reading z = x + N(0, 0.1^2): posterior N(m, s^2) far sharper than the prior
    z = np.array([[np.nan], [3.0]])
    model = StateSpaceModel(
        dim_x=1,
        sample_initial=lambda n, rng: rng.normal(0.0, 10.0, (n, 1)),
        sample_transition=lambda x, k, rng: x.copy(),
        log_likelihood=lambda x, z, k: norm.logpdf(z[0], x[:, 0], 0.1),
    )
    v = 1 / (1 / 100 + 1 / 0.01)
    m = v * 3.0 / 0.01
    means, sds = [], []
    for seed in range(20):
        pc = ProgressiveCorrection(n_tempered=1, kernel=RegularisedJitter(0.2))
        res = ParticleFilter(model, 4000, threshold=1.0, proposal=pc).run(z, rng=seed, collect=[Stages()])
        assert res.collected["stages"][1] > 2  # it did temper
        means.append(res.mean[1, 0])
        sds.append(np.sqrt(res.cov[1, 0, 0]))
    # posterior sd 0.0995; the regularisation inflates it by a factor sqrt(1 + h^2) ~ 1.0007 per stage
    assert abs(np.mean(means) - m) < 4 * np.std(means) / np.sqrt(20) + 1e-3
    assert np.mean(sds) == pytest.approx(np.sqrt(v), rel=0.05)


def test_the_fresh_flight_studies_use_flights_no_other_study_used_and_record_their_criterion():
    """The pre-registered studies (terrain_remedies.FRESH_FLIGHTS) run on flights of their own; their
    stored provenance names the criterion decided before the flights were run."""
    import json

    import pandas as pd

    from pfcourse.studies.registry import STUDIES
    from pfcourse.studies.store import DATA
    from pfcourse.studies.terrain_remedies import FILTERS, FRESH_FLIGHTS

    used = {r for name in ("terrain_remedies", "terrain_studies") for r in pd.read_csv(DATA / f"{name}.csv")["flight"]}
    seen: set[int] = set()
    for name, fresh in FRESH_FLIGHTS.items():
        flights = set(STUDIES[name].layout()["seed"])
        assert flights == set(fresh.flights) and not flights & used and not flights & seen, name
        seen |= flights
        assert json.loads((DATA / f"{name}.json").read_text())["criterion"] == fresh.criterion
        assert set(fresh.settings.values()) <= set(FILTERS)
