"""How every random number of the book is seeded: one table, one function per stream.

Every random draw of pfcourse, the chapters and the studies goes through a
:class:`numpy.random.Generator` (PCG64) made from a key.  A key is either a plain integer
seed or a short list of integers (the entropy of a :class:`numpy.random.SeedSequence`); the
streams of one run are told apart by the last entry of the list.  The keys are:

========================  ================================  ==============================  =================================================
stream                    key (entropy)                     used by                         why it gives common random numbers
========================  ================================  ==============================  =================================================
:func:`replicate_seed`    ``SeedSequence([base, r])``,      ``run_study``: replicate ``r``  replicate ``r`` has the same seed in every
                          its first 63 bits as an ``int``   of each setting of a grid       setting: the same simulated world and noise
:func:`data_rng`          ``[seed, r, 0]``                  the terrain flights: truth and  flight ``r`` is the same for every filter,
                                                            altimeter noise of run ``r``    ``N`` and remedy
:func:`filter_rng`        ``[seed, r, 1]``                  the particle filter on flight   the filters of every setting start from the same
                                                            ``r`` (and its initial cloud)   stream (for one ``N``: the same initial cloud)
:func:`likelihood_rng`    ``[seed, r, 2]``                  the filter estimating the       one stream per flight for every value of the
                                                            likelihood of a noise scale     scale: the likelihood is a smooth function of it
:func:`map_error_rng`     ``[seed, r, 3]``                  the error field of the terrain  flight ``r``'s filter map is the same for every
                                                            filter's map on flight ``r``    filter, ``N`` and measurement period
:func:`reference_rng`     ``[seed, r, 100 + i]``            the large-``N`` reference       independent of the studies' filter streams, one
                                                            filters, repeat ``i``           per repeat ``i``
:func:`sized_filter_rng`  ``[seed, N]``, ``[seed, r, N]``   a filter run once per particle  the data are shared; each ``N`` (and run) has
                                                            count ``N`` on shared data      its own filter stream
:func:`kidnap_rng`        ``[seed, 7]``                     the kidnapped robot's new pose  the same kidnapping for every method and ``N``
plain seed                ``s`` (an ``int``) for the data;  single runs of the chapters;    the same ``s`` in every setting; the offset keeps
:func:`run_filter_seed`   ``s + 1`` for its filter;         a run's filter next to its      the filter's stream apart from the data's
:func:`study_filter_seed` ``s + 10**6`` in the landmark     simulation
                          studies
========================  ================================  ==============================  =================================================

``seed`` is a study's base seed (``0`` in the book's terrain studies), ``r`` the run (or
flight), ``N`` the number of particles.  Within a run, the data and the filter never share a
stream, so changing a filter setting cannot change the data it is compared on.  Keys of
different rows can coincide (``sized_filter_rng(s, 1, run=r)`` is ``filter_rng(s, r)``,
``sized_filter_rng(s, 7)`` is ``kidnap_rng(s)``, and ``N`` = 0, 2 or 3 with a run meets
``data_rng``, ``likelihood_rng`` and ``map_error_rng``); no study of the book uses two such streams
together, and ``tests/test_seeding.py`` lists the coincidences so that a new use can be
checked against them.  The keys
are fixed: a stream changed here changes every stored result of the book.  Provenance
records written before these names existed describe :func:`data_rng` as
``pfcourse.studies.terrain.flight_seed`` and the other list keys by their entropy lists,
as in the table.

Every function refuses a seed, run or count that is not a non-negative integer
(``None``, a float, a boolean, a negative number) with a
:class:`~pfcourse.errors.ParameterError`.
"""

from __future__ import annotations

import numpy as np

from pfcourse.checks import check_seed


def _rng(*key) -> np.random.Generator:
    return np.random.default_rng(list(key))


def _run_stream(seed: int, run: int, stream: int) -> np.random.Generator:
    """Stream ``stream`` of run ``run``: ``default_rng([seed, run, stream])``."""
    return _rng(check_seed(seed), check_seed(run, "run"), stream)


def replicate_seed(base_seed: int, replicate: int) -> int:
    """The seed of replicate ``r``: a 63-bit integer drawn from ``SeedSequence([base_seed, r])``."""
    entropy = [check_seed(base_seed, "base_seed"), check_seed(replicate, "replicate")]
    return int(np.random.SeedSequence(entropy).generate_state(1, np.uint64)[0] >> np.uint64(1))


def data_rng(seed: int, run: int) -> np.random.Generator:
    """The simulated data of run ``run`` (a terrain flight): ``default_rng([seed, run, 0])``."""
    return _run_stream(seed, run, 0)


def filter_rng(seed: int, run: int) -> np.random.Generator:
    """The particle filter of run ``run``: ``default_rng([seed, run, 1])``."""
    return _run_stream(seed, run, 1)


def likelihood_rng(seed: int, run: int) -> np.random.Generator:
    """The filter estimating a likelihood on the data of run ``run``: ``default_rng([seed, run, 2])``."""
    return _run_stream(seed, run, 2)


def map_error_rng(seed: int, run: int) -> np.random.Generator:
    """The random error field of the filter's terrain map on run ``run``: ``default_rng([seed, run, 3])``."""
    return _run_stream(seed, run, 3)


def reference_rng(seed: int, run: int, repeat: int) -> np.random.Generator:
    """Repeat ``repeat`` of a reference filter on run ``run``: ``default_rng([seed, run, 100 + repeat])``."""
    return _run_stream(seed, run, 100 + check_seed(repeat, "repeat"))


def sized_filter_rng(seed: int, n_particles: int, run: int | None = None) -> np.random.Generator:
    """The filter with ``n_particles`` particles: ``default_rng([seed, N])``, or
    ``default_rng([seed, run, N])`` when one data set is filtered by several runs per ``N``."""
    n = check_seed(n_particles, "n_particles")
    if run is None:
        return _rng(check_seed(seed), n)
    return _rng(check_seed(seed), check_seed(run, "run"), n)


def kidnap_rng(seed: int) -> np.random.Generator:
    """Where the robot of run ``seed`` is carried when kidnapped: ``default_rng([seed, 7])``."""
    return _rng(check_seed(seed), 7)


def run_filter_seed(seed: int) -> int:
    """The plain integer seed of the filter of a chapter's single run ``seed``: ``seed + 1`` (the data use ``seed``)."""
    return check_seed(seed) + 1


def study_filter_seed(seed: int) -> int:
    """The plain integer seed of the filter of run ``seed`` in the landmark studies: ``seed + 10**6``, far from
    every data seed of a study (the stored landmark tables were computed with it)."""
    return check_seed(seed) + 10**6
