"""Experiments: the Monte Carlo runner and the comparisons of particle filters with references.

* :mod:`pfcourse.experiments.record` - one filter on one run, recorded (setting, scores, status, error);
* :mod:`pfcourse.experiments.study` - seeded studies over a grid of settings, on any executor;
* :mod:`pfcourse.experiments.landmarks` - scenario A's particle filters scored against the Kalman filter;
* :mod:`pfcourse.experiments.robot` - one seeded robot run through the particle filter, EKF and UKF;
* :mod:`pfcourse.experiments.terrain` - Monte Carlo runs of the terrain scenario;
* :mod:`pfcourse.experiments.comparison` - innovations, NIS and filter-against-filter comparisons.
* :mod:`pfcourse.experiments.rb_study` - the Rao-Blackwell study stored in ``book/data/rao_blackwell.csv``;
* :mod:`pfcourse.experiments.sir_fixes_study` - SIR's fixes over N, stored in ``book/data/sir_fixes.csv``;
* :mod:`pfcourse.experiments.registry` - every stored study as one record, run by ``python3 tasks.py study NAME``;
* :mod:`pfcourse.experiments.store` - a stored table read and written one way (floats round-trip exactly).
"""
