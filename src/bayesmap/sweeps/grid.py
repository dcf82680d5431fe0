"""A sweep's grid: worlds × seeds × conditions, expanded into tasks keyed by their config.

A *grid point* is one cell of the grid (a world, a seed index, a condition); a *task* is one
call of an experiment's ``run(config)``. Points whose effective configs are identical share
one task: the task's key is a hash of the experiment's name and its normalised config (see
:func:`task_key`), so the same run is computed once and a finished task is found again when
a sweep is resumed.

Seeds come from ``numpy.random.SeedSequence(root_seed).spawn``: child 0 draws the generated
worlds, child 1 the run seeds. Seed index ``k`` gets the same run seed on every world and
under every condition (common random numbers, so conditions can be compared pairwise), and
nothing depends on how many workers run the tasks or in which order. A task's config points
at a world file by path; its key holds the file's SHA-256 instead, so moving the sweep's
folder keeps every task's key.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pydantic
import yaml

from bayesmap.errors import ConfigError
from bayesmap.experiments._common import validation_problems
from bayesmap.sweeps import protocol

__all__ = [
    "Condition",
    "GridPoint",
    "SweepPlan",
    "Task",
    "expand",
    "parse_condition",
    "parse_setting",
    "task_key",
]

DEFAULT_CONDITION = "default"
"""Name of the one condition of a sweep given no ``--condition``."""


@dataclass(frozen=True)
class Condition:
    """A named set of config overrides (``--condition NAME:KEY=VALUE``)."""

    name: str
    settings: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Task:
    """One run of an experiment: what a worker receives (names and plain data, no objects).

    Attributes
    ----------
    key
        :func:`task_key` of ``experiment`` and ``config``; also the task's folder name.
    experiment
        The experiment's name (a key of :data:`bayesmap.experiments.EXPERIMENTS`).
    config
        The experiment's normalised ``Config`` as JSON-compatible data.
    """

    key: str
    experiment: str
    config: dict[str, Any]


@dataclass(frozen=True)
class GridPoint:
    """One cell of the grid and the task that computes it."""

    condition: str
    world: str
    world_index: int
    seed_index: int
    seed: int
    task: str


@dataclass(frozen=True)
class SweepPlan:
    """A sweep, expanded: its grid points, the distinct tasks, and how it was asked for.

    ``worlds`` are the world files the tasks read (written by
    :func:`~bayesmap.sweeps.runner.run_sweep` before any task runs); empty for a sweep on
    the experiment's built-in world, and for a plan read back from ``sweep.json``.
    """

    experiment: str
    points: tuple[GridPoint, ...]
    tasks: dict[str, Task]
    spec: dict[str, Any]
    worlds: tuple[protocol.SweepWorld, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The plan as JSON-compatible data (written to ``sweep.json``)."""
        return {
            "experiment": self.experiment,
            "spec": self.spec,
            "points": [point.__dict__ for point in self.points],
            "tasks": {key: task.config for key, task in self.tasks.items()},
            "world_files": {
                world.name: f"{protocol.WORLD_FOLDER}/{world.path.name}" for world in self.worlds
            },
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> SweepPlan:
        """Rebuild a plan written by :meth:`to_json`."""
        experiment = data["experiment"]
        return cls(
            experiment=experiment,
            points=tuple(GridPoint(**point) for point in data["points"]),
            tasks={key: Task(key, experiment, config) for key, config in data["tasks"].items()},
            spec=data["spec"],
        )


def parse_setting(text: str, *, where: str = "--set") -> tuple[str, Any]:
    """``"KEY=VALUE"`` → ``(KEY, value)``; the value is read as YAML (``40``, ``[normal]``).

    Examples
    --------
    >>> parse_setting("conditions=[normal, noisy]")
    ('conditions', ['normal', 'noisy'])
    >>> parse_setting("mapper.n_temperatures=10")
    ('mapper.n_temperatures', 10)
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"{where} {text!r}: expected KEY=VALUE, e.g. poses=40")
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError as error:
        first = str(error).splitlines()[0]
        raise ConfigError(f"{where} {text!r}: the value is not valid YAML ({first})") from None
    return key, value


def parse_condition(text: str) -> tuple[str, tuple[str, Any] | None]:
    """``"NAME"`` or ``"NAME:KEY=VALUE"`` → ``(NAME, setting or None)``."""
    name, sep, rest = text.partition(":")
    name = name.strip()
    if not name or "/" in name:
        raise ConfigError(f"--condition {text!r}: expected NAME or NAME:KEY=VALUE")
    return name, (parse_setting(rest, where=f"--condition {name}") if sep else None)


def merge_settings(base: dict[str, Any], settings: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``settings`` applied; a dotted key (``mapper.n_iter``) sets inside a dict."""
    merged: dict[str, Any] = json.loads(json.dumps(base))
    for dotted, value in settings.items():
        *parents, leaf = dotted.split(".")
        target = merged
        for part in parents:
            child = target.get(part)
            if child is None:
                child = target[part] = {}
            if not isinstance(child, dict):
                raise ConfigError(f"setting {dotted!r}: {part!r} is not a mapping")
            target = child
        target[leaf] = value
    return merged


def build_config(module: ModuleType, data: dict[str, Any], *, where: str) -> pydantic.BaseModel:
    """Validate ``data`` as ``module.Config``; unknown keys and bad values raise ConfigError."""
    config_type: type[pydantic.BaseModel] = module.Config
    unknown = sorted(set(data) - set(config_type.model_fields))
    if unknown:
        known = ", ".join(config_type.model_fields)
        raise ConfigError(f"{where}: unknown setting(s) {', '.join(unknown)}; known: {known}")
    try:
        return config_type(**data)  # an ExperimentConfig raises one ConfigError line itself
    except ConfigError as error:
        raise ConfigError(f"{where}: {error}") from None
    except pydantic.ValidationError as error:  # a plain pydantic model of a user's experiment
        raise ConfigError(f"{where}: {validation_problems(error)}") from None


def task_key(experiment: str, config: dict[str, Any], world: str | None = None) -> str:
    """16 hex digits of SHA-256 over the experiment name and its config (canonical JSON).

    ``world``, the SHA-256 of the task's world file, replaces the file's path in the
    config, so the key names the world's content rather than where it lies.
    """
    if world is not None:
        config = {**config, protocol.WORLD_FIELD: f"sha256:{world}"}
    text = json.dumps(
        {"experiment": experiment, "config": config}, sort_keys=True, separators=(",", ":")
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _seed_int(sequence: np.random.SeedSequence) -> int:
    """A 63-bit integer seed drawn from a spawned :class:`~numpy.random.SeedSequence`."""
    return int(sequence.generate_state(1, np.uint64)[0] >> np.uint64(1))


def expand(
    experiment: str,
    module: ModuleType,
    *,
    worlds: int | Path | None,
    seeds: int,
    root_seed: int,
    settings: dict[str, Any] | None = None,
    conditions: dict[str, dict[str, Any]] | None = None,
    out_dir: Path | None = None,
) -> SweepPlan:
    """Expand worlds × seeds × conditions into grid points and distinct tasks.

    Parameters
    ----------
    experiment, module
        The experiment's name and module (:func:`bayesmap.experiments.load`).
    worlds
        ``None``: the experiment's own world; an int ``N``: ``N`` worlds from the
        experiment's ``generate_world``; a folder: every ``*.json`` world file in it (a
        run's ``manifest.json`` aside), checked by the experiment's ``load_world`` (see
        :mod:`bayesmap.sweeps.protocol`).
    seeds
        Run seeds per world and condition (``K``); each from ``SeedSequence.spawn``.
    root_seed
        The sweep's seed: the same value gives the same worlds and run seeds.
    settings
        Overrides applied to every task (``--set``).
    conditions
        Condition name → overrides applied on top of ``settings`` (``--condition``).
    out_dir
        The sweep's folder; needed with ``worlds``, whose files the tasks will read from
        ``<out_dir>/worlds/``.
    """
    if seeds < 1:
        raise ConfigError(f"--seeds must be at least 1, got {seeds}")
    settings = dict(settings or {})
    conditions = dict(conditions or {DEFAULT_CONDITION: {}})
    if "seed" in settings or any("seed" in c for c in conditions.values()):
        raise ConfigError("the sweep sets each task's 'seed'; use --seeds and --root-seed")
    world_seeds, run_seeds = np.random.SeedSequence(root_seed).spawn(2)
    named_worlds = protocol.sweep_worlds(module, experiment, worlds, world_seeds, out_dir)
    run_seed_values = [_seed_int(child) for child in run_seeds.spawn(seeds)]
    base = module.Config().model_dump(mode="json")
    points: list[GridPoint] = []
    tasks: dict[str, Task] = {}
    for condition, overrides in conditions.items():
        where = f"{experiment}, condition {condition!r}"
        merged = merge_settings(base, {**settings, **overrides})
        for world_index, world in enumerate(named_worlds):
            world_name = protocol.BUILT_IN if world is None else world.name
            for seed_index, seed in enumerate(run_seed_values):
                data = dict(merged, seed=seed)
                if world is not None:
                    data[protocol.WORLD_FIELD] = str(world.path)
                config = protocol.canonical(module, build_config(module, data, where=where))
                normalised = config.model_dump(mode="json")
                key = task_key(experiment, normalised, None if world is None else world.digest)
                tasks.setdefault(key, Task(key, experiment, normalised))
                points.append(GridPoint(condition, world_name, world_index, seed_index, seed, key))
    spec = {
        "worlds": str(worlds) if isinstance(worlds, Path) else worlds,
        "seeds": seeds,
        "root_seed": root_seed,
        "settings": settings,
        "conditions": conditions,
    }
    files = tuple(world for world in named_worlds if world is not None)
    return SweepPlan(experiment, tuple(points), tasks, json.loads(json.dumps(spec)), files)
