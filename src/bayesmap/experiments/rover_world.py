"""One rover run on a world file: ``bayesmap rover run --world WORLD.json``.

The world (:mod:`bayesmap.sim.rover_worlds`) gives the area, the obstacles, the map resolution
and the start; the run uses the paper's §5 parameters (:class:`bayesmap.experiments.rover.Config`)
with the chosen explorer, entropy initialisation and seed, and writes ``metrics.json``,
the figures and the ROS map to its folder. The default step budget grows with the area the
rover can observe (:func:`bayesmap.experiments.rover.world_budget`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import ConfigDict, Field

from bayesmap._typing import ProgressHook
from bayesmap.experiments import rover
from bayesmap.experiments._common import (
    ExperimentConfig,
    ExperimentResult,
    no_progress,
    run_in_folder,
)
from bayesmap.sim.rover_worlds import WorldSpec, load_world

__all__ = ["Config", "run", "run_spec"]

EXPLORER_RULES = {"paper": "entropy", "frontier": "frontier"}
"""CLI explorer name → the rover experiment's target rule."""


class Config(ExperimentConfig):
    """Settings of one run on a world file."""

    model_config = ConfigDict(frozen=True)

    world: Path
    explorer: Literal["paper", "frontier"] = "paper"
    entropy_init: Literal["flat", "random"] = "flat"
    seed: int = 0
    max_steps: int | None = Field(None, ge=1)


def run_spec(
    spec: WorldSpec,
    out_dir: Path | None,
    *,
    explorer: str = "paper",
    entropy_init: str = "flat",
    seed: int = 0,
    max_steps: int | None = None,
    progress: ProgressHook | None = None,
) -> dict[str, object]:
    """Run the rover on ``spec``; write figures, map and metrics to ``out_dir`` if given."""
    steps = rover.world_budget(spec) if max_steps is None else max_steps
    config = rover.Config.model_validate(
        {"seed": seed, "resolution": spec.resolution, "max_steps": steps, "start": spec.start}
    )
    stage = f"{spec.world.name} {explorer}/{entropy_init}"
    trace = rover.simulate(
        spec.world,
        config,
        EXPLORER_RULES[explorer],
        entropy_init == "random",
        progress or no_progress,
        stage,
    )
    metrics = rover.run_metrics(trace, spec.world, config, EXPLORER_RULES[explorer])
    metrics.update({"explorer": explorer, "entropy_init": entropy_init, "seed": seed})
    if out_dir is not None:
        rover.write_run(Path(out_dir), trace, spec.world, metrics, stage)
    return metrics


def run(
    config: Config,
    out_dir: str | Path,
    *,
    progress: ProgressHook | None = None,
    command: str | None = None,
) -> ExperimentResult:
    """Load the world, run the rover, write ``out_dir``; see the module docstring.

    The folder appears only once complete, with a ``manifest.json``
    (:func:`~bayesmap.experiments._common.run_in_folder`).
    """
    spec = load_world(config.world)  # a bad world fails before any folder is touched
    return run_in_folder(
        "rover_world",
        config,
        out_dir,
        lambda folder: _run(config, spec, folder, progress),
        command=command,
    )


def _run(
    config: Config, spec: WorldSpec, out_dir: Path, progress: ProgressHook | None
) -> ExperimentResult:
    out = Path(out_dir)
    metrics = run_spec(
        spec,
        out,
        explorer=config.explorer,
        entropy_init=config.entropy_init,
        seed=config.seed,
        max_steps=config.max_steps,
        progress=progress,
    )
    figures = (out / "path.png",)
    headline: dict[str, float | int | str] = {
        key: value  # type: ignore[misc]
        for key, value in metrics.items()
        if key in ("collisions", "coverage", "min_clearance_m", "distance_to_90")
        and value is not None
    }
    return ExperimentResult("rover-world", out, figures, (out / "metrics.json",), headline)
