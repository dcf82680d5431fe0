"""What a sweep asks of an experiment module, beyond ``Config`` and ``run``.

Every experiment can be swept over seeds and settings. The rest is optional; an
experiment module may expose:

``generate_world(rng: numpy.random.Generator) -> dict``
    A new world as JSON-compatible data, drawn from ``rng`` (``--worlds N``).
``load_world(path: pathlib.Path) -> dict``
    The same data read from a world file; raises :class:`~bayesmap.errors.FormatError`
    naming the file and what is wrong (``--worlds DIR``).
``Config.world: dict | None``
    The field (:data:`WORLD_FIELD`) the sweep puts that data in; ``run`` builds its world
    from it instead of its registered scenario. An experiment needs all three for
    ``--worlds``. The data should carry a ``"name"`` the results record.
``canonical_config(config) -> Config``
    The config with settings that cannot change the result reset to their defaults, so
    runs that would be identical hash alike and are computed once.
``metric_rows(result: ExperimentResult) -> list[dict]``
    The run's metrics as tidy rows of scalars. A row may name a ``method`` (what the run
    compares, e.g. the explorer) and a ``unit`` (a part of the run measured on its own,
    e.g. one of the rover's runs); rows of different methods with the same unit, world
    and seed are paired. Without it, every flat metrics JSON the run lists becomes a row.
``KEY_METRICS: tuple[str, ...]``
    The metrics the report draws and tabulates per world (default: every metric).
``KEY_FIGURES: tuple[str, ...]``
    Glob patterns, relative to the run's folder, of the figures the report shows
    (default: the first PNGs found).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pydantic

from bayesmap.errors import ConfigError, FormatError
from bayesmap.experiments import ExperimentResult

__all__ = [
    "TASK_RECORD",
    "WORLD_FIELD",
    "canonical",
    "key_figures",
    "key_metrics",
    "metric_rows",
    "read_task_record",
    "sweep_worlds",
    "task_complete",
]

WORLD_FIELD = "world"
"""The ``Config`` field that carries a generated or loaded world."""

TASK_RECORD = "task.json"
"""The file the sweep writes, last, into a finished task's folder."""

BUILT_IN = "built-in"
"""The world name of grid points that use the experiment's own world."""

WORLD_SUFFIXES = (".json", ".yaml", ".yml")
"""Files of a ``--worlds DIR`` folder that are read as worlds."""


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
) -> list[tuple[str, dict[str, Any] | None]]:
    """The sweep's worlds as ``(name, data)``; ``data`` is ``None`` for the built-in world."""
    if worlds is None:
        return [(BUILT_IN, None)]
    if not supports_worlds(module):
        raise ConfigError(
            f"experiment {experiment!r} cannot take --worlds: its module needs "
            f"generate_world(rng), load_world(path) and a Config field {WORLD_FIELD!r} "
            "(see bayesmap.sweeps.protocol); sweep it over --seeds and --set instead"
        )
    if isinstance(worlds, int):
        if worlds < 1:
            raise ConfigError(f"--worlds must be at least 1 or a folder, got {worlds}")
        out = []
        for index, child in enumerate(seed.spawn(worlds)):
            data = module.generate_world(np.random.default_rng(child))
            out.append((str(data.get("name", f"generated-{index}")), data))
        return out
    folder = Path(worlds)
    if not folder.is_dir():
        raise ConfigError(f"--worlds {folder}: not a number and not a folder")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in WORLD_SUFFIXES)
    if not files:
        raise ConfigError(
            f"--worlds {folder}: no world files ({', '.join(WORLD_SUFFIXES)}) in the folder"
        )
    return [(path.stem, module.load_world(path)) for path in files]


def canonical(module: ModuleType, config: pydantic.BaseModel) -> pydantic.BaseModel:
    """``module.canonical_config(config)`` if the experiment has one, else ``config``."""
    hook = getattr(module, "canonical_config", None)
    return hook(config) if callable(hook) else config


def key_metrics(module: ModuleType) -> tuple[str, ...] | None:
    """The experiment's ``KEY_METRICS``, or ``None`` for all."""
    keys = getattr(module, "KEY_METRICS", None)
    return tuple(keys) if keys else None


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
