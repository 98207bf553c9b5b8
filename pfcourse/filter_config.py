"""Named filter configurations: one registry per scenario, looked up by name.

A study or a chapter that compares filters names them (``"rbpf_optimal"``, ``"bootstrap N=3000"``,
``"kld_mixture"``) and needs, for each name, a label to print and the filter itself.  A
:class:`FilterConfig` holds the three: ``name``, ``label``, and ``build``, the function that makes
the filter of that configuration from the scenario's objects.  A scenario's configurations are one
dict made by :func:`configurations` (``{name: FilterConfig}``, in the order given); :func:`lookup`
finds one by name or raises a :class:`~pfcourse.errors.ParameterError` that lists the known names.
Adding a configuration is adding one entry to its dict.

:class:`FilterSettings` is a filter's settings as a typed record (``N``, threshold, resampler,
proposal, jitter, sample-size policy, and the change the filter makes to the scenario's model)
with one ``build(model)``, a label derived from its fields and a provenance record of plain data
(:meth:`FilterSettings.record`).  Every registry holds such records: a configuration made by
:meth:`FilterConfig.of` builds its filter with ``build(model)``, ``model`` the scenario's model
of one run (scenario A's landmark model, the robot's ``RobotModel``, the map robot's
``MapRobotModel``); where a study's grid gives ``N``, the record's ``N`` is nominal and the row
builds ``config.settings.with_(n_particles=N).build(model)``.  The terrain registry builds from
``(scenario, terrain)``: its configurations also change the scenario (``Q_f / 3``).
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from pfcourse.checks import check_count, check_probability
from pfcourse.errors import ModelError, ParameterError
from pfcourse.checks import Array
from pfcourse.filter import Model, ParticleFilter, Proposal
from pfcourse.resampling import SCHEMES


@dataclass(frozen=True)
class FilterConfig:
    """One named filter configuration: its ``label`` (for tables and legends) and its ``build``.

    ``n_particles`` is the configuration's own particle count, when it fixes one (``None``: the
    caller gives it to ``build``).
    """

    name: str
    label: str
    build: Callable[..., Any]
    n_particles: int | None = None
    settings: FilterSettings | None = None  # the filter's settings as data, when the configuration has them

    @classmethod
    def of(cls, name: str, settings: FilterSettings, *, n_from_grid: bool = False) -> FilterConfig:
        """The configuration ``name`` of ``settings``: ``build(model)`` is ``settings.build``, the label
        ``settings.label`` (``settings.kind`` with ``n_from_grid``: the study's grid gives ``N``, the
        record's is nominal)."""
        return cls(name, settings.kind if n_from_grid else settings.label, settings.build,
                   None if n_from_grid else settings.n_particles, settings)

    def record(self) -> dict[str, Any]:
        """The configuration as plain data for a study's provenance: its label, and its settings'
        record when it has one (:meth:`FilterSettings.record`; without ``n_particles`` when the
        study's grid gives ``N``)."""
        out: dict[str, Any] = {"label": self.label}
        if self.n_particles is not None:
            out["n_particles"] = self.n_particles
        if self.settings is not None:
            out.update(self.settings.record())
            if self.n_particles is None:
                out.pop("n_particles")
        return out

    def __post_init__(self) -> None:
        if not self.name or not callable(self.build):
            raise ParameterError(f"a filter configuration needs a name and a callable build, got {self.name!r}, "
                                 f"{self.build!r:.80}")
        if self.n_particles is not None and self.n_particles < 1:
            raise ParameterError(f"filter configuration {self.name!r}: n_particles must be >= 1, got {self.n_particles}")


def configurations(*configs: FilterConfig) -> dict[str, FilterConfig]:
    """The registry ``{name: config}`` of ``configs``, in the order given (names must be distinct)."""
    names = [c.name for c in configs]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ParameterError(f"filter configurations named twice: {repeated}")
    return {c.name: c for c in configs}


def lookup(registry: Mapping[str, FilterConfig], name: str, what: str = "filter configuration") -> FilterConfig:
    """The configuration ``name`` of ``registry`` (else a :class:`~pfcourse.errors.ParameterError` naming
    the known ones, the configurations called ``what``: a method, a setting)."""
    if name not in registry:
        raise ParameterError(f"unknown {what} {name!r}; known: {list(registry)}")
    return registry[name]


def records(registry: Mapping[str, FilterConfig]) -> dict[str, dict[str, Any]]:
    """``{name: record}`` of ``registry`` (:meth:`FilterConfig.record`): a comparison's filters in its provenance."""
    return {name: config.record() for name, config in registry.items()}


def labels(registry: Mapping[str, FilterConfig]) -> dict[str, str]:
    """``{name: label}`` of ``registry``, in its order (the legends and tables of a comparison)."""
    return {name: config.label for name, config in registry.items()}


# ---------------------------------------------------------------------------------------------------
# A filter's settings as data (issue 44, item 2): one typed record, one ``build(model)``, its label
# and its provenance record derived from its fields (the terrain registry holds them).

_NAMES = {"TransitionProposal": "bootstrap", "ProgressiveCorrection": "progressive correction",
          "RegularisedJitter": "regularised", "Roughening": "roughened", "KLDSampling": "KLD-sampling",
          "OptimalProposal": "optimal proposal", "LinearGaussianOptimal": "optimal proposal",
          "FullyAdaptedAuxiliary": "fully adapted auxiliary", "AltitudeKalmanProposal": "altitude Kalman update",
          "BiasKalmanProposal": "altitude and map-bias Kalman update"}


def _name(component: Any) -> str:
    """A component's name in a label: its own ``label`` if it has one, else its kind's."""
    own = getattr(component, "label", None)
    return own if isinstance(own, str) else _NAMES.get(type(component).__name__, type(component).__name__)


def describe(component: Any) -> Any:
    """A component of a filter (proposal, jitter, sample-size policy) as plain data: ``None``, or
    ``{"type": class name, field: value, ...}`` of its public dataclass fields (nested components
    described the same way, arrays as lists), or of another object's public attributes that are
    numbers, names, tuples or arrays."""
    if component is None or isinstance(component, (bool, int, float, str)):
        return component
    if isinstance(component, (tuple, list)):
        return [describe(c) for c in component]
    if hasattr(component, "tolist"):
        return component.tolist()
    out: dict[str, Any] = {"type": type(component).__name__}
    fields = getattr(component, "settings_fields", None)  # a stateful component names its settings
    if fields is not None:
        out.update({name: describe(getattr(component, name)) for name in fields})
    elif dataclasses.is_dataclass(component):
        out.update({f.name: describe(getattr(component, f.name)) for f in dataclasses.fields(component)
                    if not f.name.startswith("_")})
    else:  # its public settings that are data (numbers, names, arrays), not its state or its model
        out.update({name: describe(value) for name, value in vars(component).items()
                    if not name.startswith("_") and (value is None or hasattr(value, "tolist")
                                                     or isinstance(value, (bool, int, float, str, tuple)))})
    return out


class Jitter(Protocol):
    """A move after resampling (:mod:`pfcourse.jitter`): ``jitter(particles, rng) -> particles``."""

    def __call__(self, particles: Array, rng) -> Array: ...


class SampleSizePolicy(Protocol):
    """A variable number of particles (:mod:`pfcourse.sample_size`): ``needed(new_particles)`` after each batch."""

    def needed(self, new_particles: Array) -> int: ...


class ModelChange(Protocol):
    """The change a filter makes to the scenario's model: ``apply(model)`` is the filter's own model (e.g. the
    map integrated out, a probability of being kidnapped, another process noise)."""

    def apply(self, model: Model) -> Model: ...


@dataclass(frozen=True)
class FilterSettings:
    """A particle filter's settings as a typed record: ``N``, the resampling rule (``threshold``,
    ``resampler``, a name of :data:`pfcourse.resampling.SCHEMES`), and the components as
    templates: ``proposal`` (``None``: the transition, the bootstrap filter), ``jitter`` (``None``:
    none), ``sample_size`` (``None``: a fixed ``N``) and ``model_change`` (``None``: the filter
    runs on the model it is given; else an object whose ``apply(model)`` is the filter's own model,
    e.g. the model with the map integrated out, or with a probability of being kidnapped).

    :meth:`build` makes the filter of a model, with fresh copies of the components (a stateful
    one, such as progressive correction, which counts the readings it saw, starts anew in every
    filter; one template given as two components, a proposal that is also the jitter, stays one
    object); a component template with a ``for_model(model)`` method is replaced by what it returns
    for the filter's model.  :attr:`label` and :meth:`record` are derived from the fields (the
    label for legends, the record, plain data, for a study's provenance).  Checked when the record
    is made.
    """

    n_particles: int
    threshold: float = 0.5
    resampler: str = "systematic"
    proposal: Proposal | None = None  # or a template with for_model(model) -> Proposal
    jitter: Jitter | None = None
    sample_size: SampleSizePolicy | None = None
    model_change: ModelChange | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "n_particles", check_count(self.n_particles, "n_particles"))
        object.__setattr__(self, "threshold", check_probability(self.threshold, "threshold"))
        if not isinstance(self.resampler, str) or self.resampler not in SCHEMES:
            raise ParameterError(f"resampler must be one of {list(SCHEMES)} (a name: settings are data), "
                                 f"got {self.resampler!r}")
        if self.proposal is not None and not any(callable(getattr(self.proposal, m, None))
                                                 for m in ("propose", "for_model")):
            raise ModelError(f"proposal must have a propose(model, particles, z, k, rng) method, got {self.proposal!r}")
        if self.jitter is not None and not callable(self.jitter):
            raise ModelError(f"jitter must be a function (particles, rng) -> particles, got {self.jitter!r}")
        if self.sample_size is not None and not callable(getattr(self.sample_size, "needed", None)):
            raise ModelError(f"sample_size has no callable needed (see pfcourse.sample_size), got {self.sample_size!r}")
        if self.model_change is not None and not callable(getattr(self.model_change, "apply", None)):
            raise ModelError(f"model_change must have an apply(model) method, got {self.model_change!r}")

    def with_(self, **changes: Any) -> FilterSettings:
        """These settings with ``changes`` (e.g. ``n_particles=...``), checked again."""
        return dataclasses.replace(self, **changes)

    def build(self, model) -> ParticleFilter:
        """The particle filter of ``model`` with these settings (fresh copies of the components)."""
        if self.model_change is not None:
            model = self.model_change.apply(model)
        memo: dict = {}  # one deep copy for every component: a template given twice stays one object
        fresh: dict[int, Any] = {}
        for template in (self.proposal, self.jitter, self.sample_size):
            if template is not None and id(template) not in fresh:
                component = copy.deepcopy(template, memo)
                for_model = getattr(component, "for_model", None)
                fresh[id(template)] = for_model(model) if callable(for_model) else component
        made = {name: None if (t := getattr(self, name)) is None else fresh[id(t)]
                for name in ("proposal", "jitter", "sample_size")}
        pf = ParticleFilter(model, self.n_particles, threshold=self.threshold, resampler=self.resampler, **made)
        pf.settings = self  # its results' settings are this record (FilterResult.settings)
        return pf

    @property
    def kind(self) -> str:
        """The label without ``N``: ``"[<model change>, ]<proposal>[, <jitter>], <resampler> at ESS <
        <threshold> N"`` (the transition proposal named "bootstrap" when nothing moves the particles
        after resampling; a component with a ``label`` attribute named by it)."""
        parts = [_name(self.model_change)] if self.model_change is not None else []
        parts += ([_name(self.proposal)] if self.proposal is not None
                  else [] if self.jitter is not None else ["bootstrap"])
        if self.jitter is not None and self.jitter is not self.proposal:
            name = _name(self.jitter)
            if type(self.jitter).__name__ == "RegularisedJitter":  # its kernel's width, a multiple of h_opt
                name += f" at {self.jitter.scale:g} h_opt"
            parts.append(name)
        if self.sample_size is not None:
            parts.append(_name(self.sample_size))
        else:
            parts.append(f"{self.resampler} at ESS < {self.threshold:.3g} N")
        return ", ".join(parts)

    @property
    def label(self) -> str:
        """:attr:`kind` and ``N`` (``N <= n`` with a sample-size policy), e.g.
        ``"progressive correction, regularised at 0.2 h_opt, multinomial at ESS < 1 N, N = 3000"``."""
        return self.kind + (f", N <= {self.n_particles}" if self.sample_size is not None else f", N = {self.n_particles}")

    def record(self) -> dict[str, Any]:
        """The settings as plain data (JSON-ready): what a study's provenance writes of its filter."""
        return {"n_particles": self.n_particles, "threshold": self.threshold, "resampler": self.resampler,
                "proposal": describe(self.proposal), "jitter": describe(self.jitter),
                "sample_size": describe(self.sample_size), "model_change": describe(self.model_change)}
