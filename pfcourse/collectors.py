"""What a particle filter run records: collectors, shown every step of :meth:`ParticleFilter.steps`.

:meth:`pfcourse.filter.ParticleFilter.run` is the loop ``for step in pf.steps(z, rng)`` with
collectors: at the end of each step every collector is shown the :class:`~pfcourse.filter.Step`
(the weighted cloud, its log-weights, the ancestors its resampling drew, the ESS, the
log-likelihood increment, ``k``) and keeps what it needs; after the last step its ``result()`` is
its record.  The protocol (the idea of ``particles``' ``SMC(fk, collect=[...])``):

* ``name``: the key of the record in ``result.collected``;
* ``collect(step)``: called at the end of every step;
* ``result()``: called once, after the last step: the record;
* ``start(pf, n_steps)`` (optional): called when the run is built, before the first step, with
  the filter and the number of steps: to reset the collector (so one object can serve many runs),
  to allocate its arrays, or to refuse a filter it cannot serve with a named error.

:class:`Collector` is the short way: a subclass writes ``name`` and ``fetch(step)``, one value
per step, and its record is the array of those values.

Always collected (the fields of :class:`~pfcourse.results.FilterResult`): :class:`Moments`
(``mean``, ``cov``), :class:`ESS`, :class:`Resampled`, :class:`LogLikelihood`
(``log_likelihood_increments``) and :class:`Sizes`.  On request: :class:`Clouds` (the weighted
clouds, for the smoothers and the animations), :class:`Ancestors` (the ancestral lines, for the
fixed-lag smoother) and :class:`Stages` (the proposal's stages, the cost of progressive correction).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from pfcourse import kernels
from pfcourse.checks import Array, check_moments
from pfcourse.errors import ModelError, ParameterError

if TYPE_CHECKING:  # the engine imports this module
    from pfcourse.filter import ParticleFilter, Step


def _empty(shape: tuple[int, ...], pf: ParticleFilter, n_steps: int, dtype=float) -> Array:
    """``np.empty(shape)``, or a :class:`~pfcourse.errors.ParameterError` before step 0 when it does not fit."""
    try:
        return np.empty(shape, dtype=dtype)
    except (MemoryError, ValueError):
        raise ParameterError(
            f"before step 0: n_particles={pf.n_particles}, dim_x={pf.dim_x} and {n_steps} steps need more "
            "memory than this machine has"
        ) from None


def _fixed_size(pf: ParticleFilter, what: str) -> None:
    if pf.sample_size is not None:
        raise ParameterError(f"{what} needs a fixed number of particles (this filter has a sample_size policy)")


@runtime_checkable
class CollectorProtocol(Protocol):
    """What a run's ``collect=[...]`` takes (module docstring): a ``name``, ``collect(step)`` at the end of
    every step and ``result()`` after the last; ``start(pf, n_steps)`` is optional, so it is not part of the
    protocol (:func:`start_collectors` calls it when the collector has it)."""

    name: str

    def collect(self, step: Step) -> None: ...

    def result(self) -> Any: ...


class Collector:
    """A collector of one value per step: a subclass sets ``name`` and writes ``fetch(step)``;
    its record is ``np.array`` of the values, in the order of the steps."""

    name: str = ""

    def fetch(self, step: Step) -> Any:
        """The step's value (a subclass writes it)."""
        raise NotImplementedError(f"{type(self).__name__} must define fetch(step)")

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        self.values: list = []

    def collect(self, step: Step) -> None:
        self.values.append(self.fetch(step))

    def result(self) -> Array:
        return np.array(self.values)


class _PerStep:
    """A built-in collector of one number per step into an array allocated at the start."""

    name = ""
    dtype: type = float

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        self.values = _empty((n_steps,), pf, n_steps, self.dtype)

    def collect(self, step: Step) -> None:
        self.values[step.k] = self.fetch(step)

    def result(self) -> Array:
        return self.values


class ESS(_PerStep):
    """``ess`` ``(K,)``: ``1 / sum_i (W_k^i)^2`` after the update of each step."""

    name = "ess"

    def fetch(self, step: Step) -> float:
        return step.ess


class LogLikelihood(_PerStep):
    """``log_likelihood_increments`` ``(K,)``: ``log p^(z_k | z_{0:k-1})`` (0 without a measurement);
    their sum is the log-likelihood estimate."""

    name = "log_likelihood_increments"

    def fetch(self, step: Step) -> float:
        return step.log_likelihood_increment


class Resampled(_PerStep):
    """``resampled`` ``(K,)``: whether the cloud of each step was resampled after it: by the step's own
    resampling, or by the first stage of the next step's proposal (:attr:`~pfcourse.filter.Step.parents`,
    the auxiliary filter)."""

    name = "resampled"
    dtype = bool

    def fetch(self, step: Step) -> bool:
        return step.resampled

    def collect(self, step: Step) -> None:
        self.values[step.k] = step.resampled
        if step.parents is not None and step.k > 0:
            self.values[step.k - 1] = True


class Sizes(_PerStep):
    """``sizes`` ``(K,)``: the number of particles ``N_k`` of each step."""

    name = "sizes"
    dtype = np.int64

    def fetch(self, step: Step) -> int:
        return step.size


class Stages(_PerStep):
    """``stages`` ``(K,)``: how many times the proposal weighted the cloud at each step (the stages of
    progressive correction, 1 otherwise): ``sizes * stages`` is the step's likelihood evaluations."""

    name = "stages"
    dtype = np.int64

    def fetch(self, step: Step) -> int:
        return step.stages


class Moments:
    """``moments``: the weighted mean ``m_k = sum_i W_k^i x_k^i`` ``(K, d)`` and covariance
    ``P_k = sum_i W_k^i (x_k^i - m_k)(x_k^i - m_k)^T`` ``(K, d, d)`` of each step (circular mean and
    wrapped deviations for the model's ``angle_indices``); a covariance that overflows is refused
    (:func:`pfcourse.checks.check_moments`)."""

    name = "moments"

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        d = pf.dim_x
        self.is_angle = np.zeros(d, dtype=bool)
        self.is_angle[list(pf.angle_indices)] = True
        self.linear = ~self.is_angle if self.is_angle.any() else None  # the variances that must stay finite
        self.mean = _empty((n_steps, d), pf, n_steps)
        self.cov = _empty((n_steps, d, d), pf, n_steps)

    def collect(self, step: Step) -> None:
        k = step.k
        self.mean[k], self.cov[k] = kernels.weighted_moments(step.particles, step.weights, self.is_angle)
        check_moments(step.particles, self.cov[k], self.linear, k)

    def result(self) -> tuple[Array, Array]:
        return self.mean, self.cov


class Clouds:
    """``clouds``: ``(particles, weights)``, the weighted cloud of every step, ``(K, N, d)`` and
    ``(K, N)`` (before any resampling).  Needs a fixed ``N``."""

    name = "clouds"

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        _fixed_size(pf, "the clouds collector")
        self.particles = _empty((n_steps, pf.n_particles, pf.dim_x), pf, n_steps)
        self.weights = _empty((n_steps, pf.n_particles), pf, n_steps)

    def collect(self, step: Step) -> None:
        self.particles[step.k] = step.particles
        self.weights[step.k] = step.weights

    def result(self) -> tuple[Array, Array]:
        return self.particles, self.weights


class LastCloud:
    """``last_cloud``: the :class:`~pfcourse.filter.Step` of the last step only (its ``k``, ``particles``
    and ``weights``): what a figure of the end of a run draws, where :class:`Clouds` would keep every step."""

    name = "last_cloud"

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        self.step = None

    def collect(self, step: Step) -> None:
        self.step = step

    def result(self) -> Step | None:
        return self.step


class Ancestors:
    """``ancestors``: ``A`` ``(K, N)``, particle ``i`` of step ``k`` descends from particle ``A[k, i]`` of
    step ``k - 1`` (the identity where no resampling came between them, and at ``k = 0``): the
    ancestral lines of :func:`pfcourse.smoothing.fixed_lag_means`.  The ancestors a proposal drew
    before its move (:attr:`~pfcourse.filter.Step.parents`, the auxiliary filter) are composed
    with those of the previous step's resampling.  Needs a fixed ``N``."""

    name = "ancestors"

    def start(self, pf: ParticleFilter, n_steps: int) -> None:
        _fixed_size(pf, "the ancestors collector")
        self.lines = _empty((n_steps, pf.n_particles), pf, n_steps, np.int64)
        self.lines[:] = np.arange(pf.n_particles)

    def collect(self, step: Step) -> None:
        if step.parents is not None and step.k > 0:
            self.lines[step.k] = self.lines[step.k][step.parents]
        if step.ancestors is not None and step.k + 1 < len(self.lines):
            self.lines[step.k + 1] = step.ancestors

    def result(self) -> Array:
        return self.lines


#: The collectors of every run, whose records are the fields of :class:`~pfcourse.results.FilterResult`.
ALWAYS = (Moments, ESS, Resampled, LogLikelihood, Sizes)


def start_collectors(pf: ParticleFilter, n_steps: int, collect: Sequence[CollectorProtocol]) -> list[CollectorProtocol]:
    """The run's collectors: fresh ones of :data:`ALWAYS`, then those of ``collect``, checked and started.

    A :class:`~pfcourse.errors.ModelError` for a collector without a ``name`` or a callable
    ``collect``, ``result`` (or ``start``); a :class:`~pfcourse.errors.ParameterError` for a name
    given twice or taken by one always collected, and for a collector whose ``start`` refuses the filter.
    """
    if not isinstance(collect, (list, tuple)):
        raise ModelError(f"collect must be a list of collectors (pfcourse.collectors), got {collect!r:.80}")
    collectors = [cls() for cls in ALWAYS]
    taken = {c.name for c in collectors}
    for c in collect:
        name = getattr(c, "name", None)
        if isinstance(c, type):
            raise ModelError(f"collect takes collector objects, got the class {c.__name__} (write {c.__name__}())")
        if not isinstance(name, str) or not name:
            raise ModelError(f"a collector needs a name (a non-empty string), got {c!r:.80}")
        for method in ("collect", "result"):
            if not callable(getattr(c, method, None)):
                raise ModelError(f"collector {name!r} has no callable {method} (see pfcourse.collectors)")
        if isinstance(c, Collector) and type(c).fetch is Collector.fetch:
            raise ModelError(f"collector {name!r} has no fetch(step) (a Collector writes one)")
        if getattr(c, "start", None) is not None and not callable(c.start):
            raise ModelError(f"collector {name!r}: start must be a method start(pf, n_steps)")
        if name in taken:
            always = ", ".join(cls.name for cls in ALWAYS)
            raise ParameterError(f"two collectors are named {name!r} (each run collects {always} already; "
                                 "the others need distinct names)")
        taken.add(name)
        collectors.append(c)
    for c in collectors:
        if getattr(c, "start", None) is not None:
            c.start(pf, n_steps)
    return collectors
