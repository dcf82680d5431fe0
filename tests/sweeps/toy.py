"""A tiny experiment for the sweep tests: its metrics are a known function of its config.

Methods ``a`` and ``b`` see the same noise draw, and ``b`` is ``a`` plus one, so a paired
comparison must find a difference of exactly −1. ``ignored`` cannot change the result, so
:func:`canonical_config` resets it and configs differing only there are computed once.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from pydantic import BaseModel, ConfigDict

from bayesmap._io import write_bytes, write_json
from bayesmap.errors import FormatError, InputError
from bayesmap.experiments import ExperimentResult
from bayesmap.viz import figure_png

KEY_METRICS = ("value",)


class Config(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    seed: int = 0
    scale: float = 1.0
    ignored: int = 0
    fail: bool = False
    world: Path | None = None


def generate_world(rng: np.random.Generator) -> dict[str, Any]:
    return {"offset": round(float(rng.uniform(0, 10)), 6)}


def load_world(path: Path) -> float:
    """A toy world file: ``{"offset": number}``; the offset every value is shifted by."""
    data = json.loads(Path(path).read_text())
    if not isinstance(data, dict) or not isinstance(data.get("offset"), int | float):
        raise FormatError("a toy world needs a numeric 'offset'", path=path)
    return float(data["offset"])


def canonical_config(config: Config) -> Config:
    return config.model_copy(update={"ignored": 0})


def run(config: Config, out_dir: Path, *, progress: Any = None) -> ExperimentResult:
    if config.fail:
        raise InputError("the toy experiment was told to fail")
    noise = float(np.random.default_rng(config.seed).normal())
    offset = load_world(config.world) if config.world else 0.0
    paths = []
    for shift, method in enumerate(("a", "b")):
        value = config.scale * noise + offset + shift
        paths.append(write_json(Path(out_dir) / method / "metrics.json", {"value": value}))
    fig = Figure(figsize=(3, 2))
    fig.subplots().bar(["a", "b"], [noise + offset, noise + offset + 1])
    figure = write_bytes(Path(out_dir) / "values.png", figure_png(fig, dpi=60))
    return ExperimentResult("toy", Path(out_dir), (figure,), tuple(paths))


def metric_rows(result: ExperimentResult) -> list[dict[str, Any]]:
    return [{"method": path.parent.name, **json.loads(path.read_text())} for path in result.metrics]
