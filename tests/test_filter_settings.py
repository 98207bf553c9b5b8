"""A filter's settings as data (pfcourse.filter_config.FilterSettings): one build(model) giving the
filter written by hand float for float, fresh components per filter, a label and a provenance
record derived from the fields, bad fields refused by name when the record is made."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pfcourse import LinearGaussianModel, ParticleFilter
from pfcourse.collectors import Stages
from pfcourse.errors import ModelError, ParameterError
from pfcourse.filter_config import FilterSettings, records
from pfcourse.jitter import RegularisedJitter
from pfcourse.proposals import ProgressiveCorrection
from pfcourse.sample_size import KLDSampling

MODEL = LinearGaussianModel(F=[[1.0]], H=[[1.0]], m0=[0.0], P0=[[100.0]], Q=[[1.0]], R=[[0.01]])
Z = (np.cumsum(np.random.default_rng(0).normal(size=15)))[:, None]


def tempered(n=300):
    return FilterSettings(n, 1.0, "multinomial", ProgressiveCorrection(n_tempered=3, kernel=RegularisedJitter(0.3, (0,))),
                          RegularisedJitter(0.2, (0,)))


def test_build_is_the_filter_written_by_hand_float_for_float():
    by_hand = ParticleFilter(MODEL, 300, threshold=1.0, resampler="multinomial",
                             proposal=ProgressiveCorrection(n_tempered=3, kernel=RegularisedJitter(0.3, (0,))),
                             jitter=RegularisedJitter(0.2, (0,))).run(Z, 4, collect=[Stages()])
    built = tempered().build(MODEL).run(Z, 4, collect=[Stages()])
    assert built.mean.tobytes() == by_hand.mean.tobytes()
    assert built.log_likelihood_increments.tobytes() == by_hand.log_likelihood_increments.tobytes()
    assert built.collected["stages"][1] > 1  # it tempered


def test_every_filter_built_gets_fresh_components():
    # progressive correction counts the readings it saw: a shared one would not temper in a second filter
    settings = tempered()
    first, second = (settings.build(MODEL).run(Z, 4, collect=[Stages()]) for _ in range(2))
    assert first.mean.tobytes() == second.mean.tobytes()
    assert np.array_equal(first.collected["stages"], second.collected["stages"])


def test_label_and_record_come_from_the_fields():
    assert FilterSettings(3000).label == "bootstrap, systematic at ESS < 0.5 N, N = 3000"
    assert tempered(3000).label == "progressive correction, regularised at 0.2 h_opt, multinomial at ESS < 1 N, N = 3000"
    assert FilterSettings(3000, jitter=RegularisedJitter(1.0)).label == "regularised at 1 h_opt, systematic at ESS < 0.5 N, N = 3000"
    assert FilterSettings(20000, sample_size=KLDSampling([1.0])).label == "bootstrap, KLD-sampling, N <= 20000"
    variants = [FilterSettings(3000), FilterSettings(1000), FilterSettings(3000, 0.3), FilterSettings(3000, resampler="stratified"),
                FilterSettings(3000, jitter=RegularisedJitter(0.2)), FilterSettings(3000, jitter=RegularisedJitter(1.0)),
                tempered(3000)]
    assert len({v.label for v in variants}) == len(variants)
    record = tempered(3000).record()
    assert json.loads(json.dumps(record)) == record  # plain data
    assert record["proposal"]["type"] == "ProgressiveCorrection" and record["proposal"]["n_tempered"] == 3
    assert record["jitter"] == {"type": "RegularisedJitter", "scale": 0.2, "angle_indices": [0]}
    kld = FilterSettings(20000, sample_size=KLDSampling([0.5, 0.5])).record()["sample_size"]
    assert kld["type"] == "KLDSampling" and kld["bin_size"] == [0.5, 0.5]
    assert tempered(3000).record() == tempered(3000).record() != tempered(1000).record()


@pytest.mark.parametrize("fields, error, message", [
    ({"n_particles": 0}, ParameterError, "n_particles"),
    ({"n_particles": 10, "threshold": 1.5}, ParameterError, "threshold"),
    ({"n_particles": 10, "resampler": "magic"}, ParameterError, "resampler must be one of"),
    ({"n_particles": 10, "resampler": lambda w, rng: w}, ParameterError, "a name: settings are data"),
    ({"n_particles": 10, "proposal": "optimal"}, ModelError, "proposal must have a propose"),
    ({"n_particles": 10, "jitter": 0.2}, ModelError, "jitter must be a function"),
    ({"n_particles": 10, "sample_size": 100}, ModelError, "sample_size has no callable needed"),
])
def test_bad_settings_are_refused_when_the_record_is_made(fields, error, message):
    with pytest.raises(error, match=message):
        FilterSettings(**fields)


def test_the_terrain_registry_holds_settings_records():
    """Each terrain filter is a FilterSettings record: its N, label and provenance record derived from it
    (tests/test_stored_studies.py re-computes their stored rows float for float)."""
    from pfcourse.studies.terrain_remedies import FILTERS
    from pfcourse.filter_config import records

    assert all(c.settings is not None and c.n_particles == c.settings.n_particles for c in FILTERS.values())
    assert len({c.label for c in FILTERS.values()}) == len(FILTERS)  # the label tells them apart
    written = records(FILTERS)
    assert json.loads(json.dumps(written)) == written
    assert written["regularised h=1 N=3000"]["jitter"]["scale"] == 1.0
    assert written["tempered N=3000"]["proposal"]["type"] == "ProgressiveCorrection"


def test_scenario_a_records_build_the_filters_written_by_hand():
    """The Rao-Blackwellised records change the model (the map integrated out) and build, float for float,
    the filters the registry wrote by hand before it held records; labels tell the six apart."""
    from pfcourse.proposals import FullyAdaptedAuxiliary
    from pfcourse.scenarios.landmarks.rao_blackwell import RaoBlackwellModel, RaoBlackwellProposal
    from pfcourse.scenarios.landmarks.scenario import quadrant_scenario, simulate
    from pfcourse.studies.rb_study import FILTERS, THRESHOLD

    sc = quadrant_scenario()
    z = simulate(sc, rng=3).measurements[:12]
    by_hand = {"sir": ParticleFilter(sc.model(), 200, threshold=THRESHOLD),
               "rbpf_prior": ParticleFilter(RaoBlackwellModel(sc.model()), 200, threshold=THRESHOLD,
                                            proposal=RaoBlackwellProposal(optimal=False)),
               "rb_apf": ParticleFilter(RaoBlackwellModel(sc.model()), 200, threshold=1.0,
                                        proposal=FullyAdaptedAuxiliary(RaoBlackwellProposal(optimal=True)))}
    for name, pf in by_hand.items():
        built = FILTERS[name].settings.with_(n_particles=200).build(sc.model())
        assert type(built.model) is type(pf.model) and built.n_particles == 200
        assert built.run(z, 7).mean.tobytes() == pf.run(z, 7).mean.tobytes(), name
    assert len({c.label for c in FILTERS.values()}) == 6 and FILTERS["sir"].n_particles is None
    assert "n_particles" not in records(FILTERS)["sir"]  # the study's grid gives N


def test_a_model_change_and_a_shared_component_are_data_too():
    from pfcourse.scenarios.maprobot.drive import FILTERS, Injection

    injection = FILTERS["injection"].settings
    assert injection.model_change == Injection(0.1) and injection.record()["model_change"] == {"type": "Injection",
                                                                                               "inject": 0.1}
    with pytest.raises(ModelError, match="model_change must have an apply"):
        FilterSettings(10, model_change="kidnap")
    with pytest.raises(ParameterError):
        FilterSettings(10).with_(n_particles=0)


@pytest.mark.parametrize("study, key, registry", [
    ("rao_blackwell", "filters", "pfcourse.studies.rb_study"),
    ("global_localization/lockon", "filters", "pfcourse.scenarios.robot.mcl"),
    ("global_localization/tracking_cost", "filters", "pfcourse.scenarios.robot.mcl"),
    ("maprobot/tracking", "filters", "pfcourse.scenarios.maprobot.drive"),
    ("maprobot/kld_tracking", "filters", "pfcourse.scenarios.maprobot.drive"),
    ("terrain_remedies", "filters", "pfcourse.studies.terrain_remedies"),
])
def test_a_study_s_provenance_holds_the_records_of_the_filters_it_ran(study, key, registry):
    """The configurations in a stored study's provenance are the records its rows build from, as data: a
    record changed in the code without re-running (or re-recording) the study fails here."""
    import importlib

    from pfcourse.studies.registry import STUDIES

    stored = STUDIES[study].load().attrs["provenance"][key]
    assert stored == json.loads(json.dumps(records(importlib.import_module(registry).FILTERS)))


def test_the_kld_settings_of_the_amcl_study_are_in_its_provenance():
    from pfcourse.studies.global_localization import KLD_SETTINGS
    from pfcourse.studies.registry import STUDIES

    stored = STUDIES["global_localization/kld_amcl"].load().attrs["provenance"]["filters"]
    assert stored == json.loads(json.dumps({name: {"label": s.label, **s.record()} for name, s in KLD_SETTINGS.items()}))
    assert stored["AMCL defaults"]["sample_size"]["n_min"] == 500 and stored["AMCL defaults"]["n_particles"] == 5000
