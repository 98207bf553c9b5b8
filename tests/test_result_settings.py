"""A run's settings are the record its filter was built from, in one schema (review pkg44b, SHOULD 5 and 8).

``FilterResult.settings`` is :meth:`FilterSettings.record` for a filter built from a record, and the same
fields read from the filter for one built directly, so the two ways to make one filter say the same thing.
Every collector of :mod:`pfcourse.collectors` is exported from ``pfcourse``, or none is.
"""

from __future__ import annotations

import inspect

import numpy as np

import pfcourse
from pfcourse import LinearGaussianModel, ParticleFilter
from pfcourse import collectors
from pfcourse.filter_config import FilterSettings
from pfcourse.jitter import RegularisedJitter
from pfcourse.proposals import OptimalProposal, ProgressiveCorrection
from pfcourse.sample_size import KLDSampling

WALK = LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[1.0]], Q=[[1.0]], R=[[0.5]])
Z = np.linspace(0.0, 2.0, 6)[:, None]


def test_a_built_filter_s_result_carries_its_record():
    for settings in (FilterSettings(50), FilterSettings(40, threshold=1.0, resampler="multinomial",
                                                        proposal=ProgressiveCorrection(kernel=RegularisedJitter(0.5))),
                     FilterSettings(60, jitter=RegularisedJitter(0.2)), FilterSettings(30, proposal=OptimalProposal()),
                     FilterSettings(80, sample_size=KLDSampling((0.5,), n_min=20, batch=20))):
        assert settings.build(WALK).run(Z, 1).settings == settings.record()


def test_a_filter_built_directly_says_what_its_record_would():
    pairs = [(ParticleFilter(WALK, 50), FilterSettings(50)),
             (ParticleFilter(WALK, 60, jitter=RegularisedJitter(0.2)), FilterSettings(60, jitter=RegularisedJitter(0.2))),
             (ParticleFilter(WALK, 30, threshold=1.0, resampler="stratified", proposal=OptimalProposal()),
              FilterSettings(30, threshold=1.0, resampler="stratified", proposal=OptimalProposal()))]
    for pf, settings in pairs:
        assert pf.run(Z, 1).settings == settings.record()


def test_every_collector_is_exported():
    public = {name for name, obj in vars(collectors).items() if inspect.isclass(obj) and obj.__module__ == collectors.__name__
              and not name.startswith("_") and callable(getattr(obj, "collect", None))
              and not getattr(obj, "_is_protocol", False)}  # (the protocol is a type, not a collector)
    assert public >= {"Clouds", "LastCloud", "ESS", "LogLikelihood", "Resampled", "Sizes", "Moments", "Stages"}
    assert public <= set(pfcourse.__all__), sorted(public - set(pfcourse.__all__))
