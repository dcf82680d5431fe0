"""What a sweep asks of an experiment module, beyond ``Config`` and ``run``.

Every experiment can be swept over seeds and settings. The rest is optional; an
experiment module may expose:

``generate_world(rng: numpy.random.Generator) -> dict``
    A new world drawn from ``rng`` by the system's own generator, as the JSON object of
    its world file (``WORLD.json``; ``--worlds N``).
``load_world(path: pathlib.Path)``
    The system's own reader of world files; it raises
    :class:`~bayesmap.errors.FormatError` naming the file and what is wrong
    (``--worlds DIR``). The sweep only uses it to check a file before any task runs.
``Config.world: pathlib.Path | None``
    The field (:data:`WORLD_FIELD`) the sweep sets to a world file; ``run`` maps that
    world instead of its built-in scenario. An experiment needs all three for
    ``--worlds``. The sweep writes every world it uses, generated or read, to
    ``<out>/worlds/<name>.json`` — the same files ``bayesmap blackboard run --world`` and
    ``bayesmap rover run --world`` read — and points ``Config.world`` there.
``canonical_config(config) -> Config``
    The config with settings that cannot change the result reset to their defaults, so
    runs that would be identical hash alike and are computed once.
``metric_rows(result: ExperimentResult) -> list[dict]``
    The run's metrics as tidy rows of scalars. A row may name a ``method`` (what the run
    compares, e.g. the explorer), a ``unit`` (a part of the run measured on its own and
    summarised apart, e.g. one of the rover's runs), a ``replicate`` (an integer: one of
    several repeats the run makes itself, pooled in the summary, e.g. the sonar
    experiment's seeded runs) and, for a run over several built-in worlds, the ``world``
    it measured; rows of different methods with the same world, seed, unit and replicate
    are paired. Without it, every flat metrics JSON the run lists becomes a row.
``KEY_METRICS: tuple[str, ...]``
    The metrics the report draws and tabulates per world (default: every metric).
``METRIC_UNITS: dict[str, str]``
    The unit of each metric the report writes beside its name (``"m"``, ``"bits"``).
``PAIRED_AGAINST: str``
    The method the report compares every other method with (default: every pair).
``KEY_FIGURES: tuple[str, ...]``
    Glob patterns, relative to the run's folder, of the figures the report shows
    (default: the first PNGs found).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pydantic

from bayesmap._io import MANIFEST
from bayesmap.errors import ConfigError, FormatError
from bayesmap.experiments import ExperimentResult

__all__ = [
    "TASK_RECORD",
    "WORLD_FIELD",
    "SweepWorld",
    "canonical",
    "key_figures",
    "key_metrics",
    "metric_rows",
    "metric_units",
    "paired_against",
    "read_task_record",
    "sweep_worlds",
    "task_complete",
]

WORLD_FIELD = "world"
"""The ``Config`` field that carries the path of a world file."""

TASK_RECORD = "task.json"
"""The file the sweep writes, last, into a finished task's folder."""

BUILT_IN = "built-in"
"""The world name of grid points that use the experiment's own world."""

WORLD_FOLDER = "worlds"
"""The folder of a sweep's output where it writes the world files its tasks read."""

WORLD_SUFFIX = ".json"
"""World files of a ``--worlds DIR`` folder (``WORLD.json`` files)."""


@dataclass(frozen=True)
class SweepWorld:
    """One world of a sweep: its name, its world file's text and where the tasks read it.

    ``digest`` (SHA-256 of the text) stands for the world in task keys, so a task is the
    same task wherever the sweep's folder lies.
    """

    name: str
    text: str
    path: Path

    @property
    def digest(self) -> str:
        """SHA-256 of the world file's text."""
        return hashlib.sha256(self.text.encode()).hexdigest()


def supports_worlds(module: ModuleType) -> bool:
    """Whether ``module`` has everything ``--worlds`` needs."""
    return (
        callable(getattr(module, "generate_world", None))
        and callable(getattr(module, "load_world", None))
        and WORLD_FIELD in module.Config.model_fields
    )


def sweep_worlds(
    module: ModuleType,
    experiment: str,
    worlds: int | Path | None,
    seed: np.random.SeedSequence,
    out_dir: Path | None,
) -> list[SweepWorld | None]:
    """The sweep's worlds; ``[None]`` (the built-in world) when ``worlds`` is ``None``.

    Generated worlds are named ``world-000``, ``world-001``, …; files of a folder keep
    their names. Every world will be written to ``<out_dir>/worlds/<name>.json``.
    """
    if worlds is None:
        return [None]
    if not supports_worlds(module):
        raise ConfigError(
            f"experiment {experiment!r} cannot take --worlds: its module needs "
            f"generate_world(rng), load_world(path) and a Config field {WORLD_FIELD!r} "
            "(see bayesmap.sweeps.protocol); sweep it over --seeds and --set instead"
        )
    if out_dir is None:
        raise ConfigError("a sweep over --worlds needs an output folder (--out) for its worlds")
    folder = Path(out_dir).resolve() / WORLD_FOLDER
    if isinstance(worlds, int):
        if worlds < 1:
            raise ConfigError(f"--worlds must be at least 1 or a folder, got {worlds}")
        out: list[SweepWorld | None] = []
        for index, child in enumerate(seed.spawn(worlds)):
            data = module.generate_world(np.random.default_rng(child))
            name = f"world-{index:03d}"
            text = json.dumps(data, indent=2) + "\n"  # as the systems' save_world writes
            out.append(SweepWorld(name, text, folder / f"{name}{WORLD_SUFFIX}"))
        return out
    source = Path(worlds)
    if not source.is_dir():
        raise ConfigError(f"--worlds {source}: not a number and not a folder")
    files = sorted(
        p for p in source.iterdir() if p.suffix.lower() == WORLD_SUFFIX and p.name != MANIFEST
    )  # a folder of generated worlds is a run folder, with its manifest
    if not files:
        raise ConfigError(f"--worlds {source}: no world files (*{WORLD_SUFFIX}) in the folder")
    found: list[SweepWorld | None] = []
    for path in files:
        module.load_world(path)  # a bad file fails here, naming itself, before any task runs
        found.append(SweepWorld(path.stem, path.read_text(encoding="utf-8"), folder / path.name))
    return found


def canonical(module: ModuleType, config: pydantic.BaseModel) -> pydantic.BaseModel:
    """``module.canonical_config(config)`` if the experiment has one, else ``config``."""
    hook = getattr(module, "canonical_config", None)
    return hook(config) if callable(hook) else config


def key_metrics(module: ModuleType) -> tuple[str, ...] | None:
    """The experiment's ``KEY_METRICS``, or ``None`` for all."""
    keys = getattr(module, "KEY_METRICS", None)
    return tuple(keys) if keys else None


def metric_units(module: ModuleType) -> dict[str, str]:
    """The experiment's ``METRIC_UNITS`` (metric → unit), or none."""
    return dict(getattr(module, "METRIC_UNITS", {}))


def paired_against(module: ModuleType) -> str | None:
    """The experiment's ``PAIRED_AGAINST`` method, or ``None`` to show every pair."""
    method = getattr(module, "PAIRED_AGAINST", None)
    return str(method) if method else None


def key_figures(module: ModuleType, folder: Path, limit: int) -> list[Path]:
    """Up to ``limit`` PNG figures of the run in ``folder``: its ``KEY_FIGURES``, or any."""
    folder = Path(folder)
    found: list[Path] = []
    for pattern in getattr(module, "KEY_FIGURES", ()):
        found += [p for p in sorted(folder.glob(pattern)) if p.suffix == ".png"]
    if not found:
        found = sorted(folder.rglob("*.png"))
    return list(dict.fromkeys(found))[:limit]


def metric_rows(module: ModuleType, result: ExperimentResult) -> list[dict[str, Any]]:
    """The run's metrics as tidy rows (the module's ``metric_rows`` or the generic reading)."""
    hook = getattr(module, "metric_rows", None)
    if callable(hook):
        rows: list[dict[str, Any]] = hook(result)
        return [{key: _scalar(value) for key, value in row.items()} for row in rows]
    rows = []
    for path in result.metrics:
        if path.suffix != ".json":
            continue
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        flat = _flatten(data) if isinstance(data, dict) else None
        if flat:
            unit = Path(path).parent.relative_to(result.out_dir).as_posix()
            rows.append({"unit": "" if unit == "." else unit, **flat})
    return rows


def _flatten(data: dict[str, Any], prefix: str = "") -> dict[str, Any] | None:
    """Scalars of a metrics file, nested mappings as ``a.b``; ``None`` if it holds records."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            inner = _flatten(value, f"{name}.")
            if inner is None or any(isinstance(v, dict) for v in value.values()):
                return None
            out.update(inner)
        elif isinstance(value, list):
            if value and isinstance(value[0], dict):
                return None
        else:
            out[name] = _scalar(value)
    return out


def _scalar(value: Any) -> Any:
    """A table cell: numbers and strings as they are, ``None`` as NaN, others as text."""
    if value is None:
        return math.nan
    if isinstance(value, bool | int | float | str):
        return value
    return json.dumps(value)


def task_complete(folder: Path) -> bool:
    """Whether the task in ``folder`` finished: its record is present and parseable.

    The one place that decides completeness, so it can move to a checked manifest of the
    run folder's files without touching the rest of the sweep.
    """
    try:
        read_task_record(folder)
    except FormatError:
        return False
    return True


def read_task_record(folder: Path) -> dict[str, Any]:
    """The record of a finished task; :class:`FormatError` if missing or unreadable."""
    path = Path(folder) / TASK_RECORD
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FormatError("task record missing (the task has not finished)", path=path) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise FormatError(f"unreadable task record: {error}", path=path) from None
    if not isinstance(data, dict) or not isinstance(data.get("rows"), list):
        raise FormatError("task record has no list of 'rows'", path=path)
    return data
