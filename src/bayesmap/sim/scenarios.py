"""The one registry of simulated worlds and scenarios, by versioned name.

Names read ``<robot or sensor>-<world>-v<N>`` (``"rover-field-obstacles-v1"``,
``"sonar-office-v2"``, ``"whisker-tables-v1"``), and every result records the name it ran
on. Each world module registers its own entries when it is imported
(:func:`register`): :mod:`~bayesmap.sim.world2d` the rover's box fields,
:mod:`~bayesmap.sim.polygons` the sonar buildings, :mod:`~bayesmap.sim.tables_world` the
whisker scenarios. :func:`scenario` looks a name up and checks that it is of the kind the
caller wants; each of those modules also offers that lookup typed for its own kind
(``box_world``, ``world``, ``scenario``).

Examples
--------
>>> from bayesmap.sim.world2d import BoxWorld
>>> scenario("rover-field-empty-v1", BoxWorld).width
20.0
>>> names(BoxWorld)
('rover-field-empty-v1', 'rover-field-obstacles-v1')
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any, TypeVar

from bayesmap.errors import ConfigError

__all__ = ["SCENARIOS", "names", "register", "scenario"]

T = TypeVar("T")

_PROVIDERS = ("bayesmap.sim.world2d", "bayesmap.sim.polygons", "bayesmap.sim.tables_world")
"""The modules that register scenarios, imported before any lookup."""

SCENARIOS: dict[str, tuple[type, Callable[[], Any]]] = {}
"""Versioned name → (the kind of object it gives, the factory that builds it)."""


def register(name: str, kind: type[T], factory: Callable[[], T]) -> None:
    """Register ``factory`` (called on every lookup) under ``name``, giving a ``kind``."""
    if name in SCENARIOS:
        raise ConfigError(f"scenario {name!r} is registered twice")
    SCENARIOS[name] = (kind, factory)


def _load() -> None:
    for module in _PROVIDERS:
        importlib.import_module(module)


def names(kind: type) -> tuple[str, ...]:
    """The registered names that give a ``kind``, in registration order."""
    _load()
    return tuple(name for name, (given, _) in SCENARIOS.items() if given is kind)


def scenario(name: str, kind: type[T]) -> T:
    """The ``kind`` registered as ``name``; :class:`ConfigError` naming the choices if none."""
    _load()
    entry = SCENARIOS.get(name)
    if entry is None or entry[0] is not kind:
        raise ConfigError(
            f"unknown {kind.__name__} scenario {name!r}; choose from: {', '.join(names(kind))}"
        )
    value: T = entry[1]()
    return value
