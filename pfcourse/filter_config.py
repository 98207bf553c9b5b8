"""Named filter configurations: one registry per scenario, looked up by name.

A study or a chapter that compares filters names them (``"rbpf_optimal"``, ``"bootstrap N=3000"``,
``"kld_mixture"``) and needs, for each name, a label to print and the filter itself.  A
:class:`FilterConfig` holds the three: ``name``, ``label``, and ``build``, the function that makes
the filter of that configuration from the scenario's objects.  A scenario's configurations are one
dict made by :func:`configurations` (``{name: FilterConfig}``, in the order given); :func:`lookup`
finds one by name or raises a :class:`~pfcourse.errors.ParameterError` that lists the known names.
Adding a configuration is adding one entry to its dict.

``build``'s arguments are the scenario's own (each registry's docstring states them): for
instance ``build(scenario, n_particles) -> ParticleFilter`` for scenario A's filters, or
``build(scenario, terrain) -> ParticleFilter`` for the terrain filters, whose particle count is
part of the configuration (``n_particles``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pfcourse.errors import ParameterError


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


def labels(registry: Mapping[str, FilterConfig]) -> dict[str, str]:
    """``{name: label}`` of ``registry``, in its order (the legends and tables of a comparison)."""
    return {name: config.label for name, config in registry.items()}
