"""Studies: the Monte Carlo runner, the stored studies (registry, store, provenance) and the comparisons of particle filters with references.

* :mod:`pfcourse.studies.record` - one filter on one run, recorded (setting, scores, status, error);
* :mod:`pfcourse.studies.study` - seeded studies over a grid of settings, on any executor;
* :mod:`pfcourse.studies.landmarks` - scenario A's particle filters scored against the Kalman filter;
* :mod:`pfcourse.studies.robot` - one seeded robot run through the particle filter, EKF and UKF;
* :mod:`pfcourse.studies.terrain` - Monte Carlo runs of the terrain scenario;
* :mod:`pfcourse.studies.comparison` - innovations, NIS and filter-against-filter comparisons.
* :mod:`pfcourse.studies.rb_study` - the Rao-Blackwell study stored in ``book/data/rao_blackwell.csv``;
* :mod:`pfcourse.studies.sir_fixes_study` - SIR's fixes over N, stored in ``book/data/sir_fixes.csv``;
* :mod:`pfcourse.studies.registry` - every stored study as one record, run by ``python3 tasks.py study NAME``;
* :mod:`pfcourse.studies.store` - a stored table read and written one way (floats round-trip exactly).
"""
