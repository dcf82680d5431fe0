"""The whisker table mapper on a world file: one fused map of the room, or per-pose maps.

``bayesmap blackboard run --world WORLD.json`` calls :func:`run`. The robot visits the
file's poses; in ``fused`` mode every pose's sweeps go to one
:class:`~bayesmap.blackboard.fused.FusedMapper` (told the arena and the catalogue of
object types in the file, never the tables), whose final map is scored against the truth
(``fused_*`` metrics) beside per-pose scores of its running map; in ``paper`` mode the
paper's :class:`~bayesmap.blackboard.TableMapper` maps each pose on its own (per-pose
metrics only; the paper's model knows one table size, the catalogue's largest).

Random streams: ``SeedSequence(seed)`` child 0 draws the sensor noise, child 1 runs the
chain. Outputs: ``metrics.json``, ``map.json`` (``objects``: ``type, length, width, x, y,
theta, existence_probability``; ``doubtful``: the MAP objects left off the map — existence
probability below 1/2, or contradicted by the free space — as records of the same form) and
``map.png`` (the doubtful objects dashed).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from bayesmap._io import write_bytes, write_json
from bayesmap._typing import ProgressHook
from bayesmap.blackboard.fused import FusedMap
from bayesmap.blackboard.sweep_model import ObjectType
from bayesmap.errors import ConfigError
from bayesmap.experiments import blackboard as paper
from bayesmap.experiments._common import (
    ExperimentConfig,
    ExperimentResult,
    no_progress,
    run_in_folder,
)
from bayesmap.experiments.fused_run import figure_objects, fused_metrics, fused_params, run_fused
from bayesmap.experiments.table_metrics import MatchTolerance
from bayesmap.sim.tables_world import TablesWorld
from bayesmap.sim.whisker_worlds import WorldFile, load_world
from bayesmap.sim.whiskers import CONDITIONS, condition
from bayesmap.viz.render import figure_png
from bayesmap.viz.tables import fused_map_figure

__all__ = ["Config", "catalogue_of", "map_figure", "run"]


class Config(ExperimentConfig):
    """One run of the table mapper on a world file.

    Attributes
    ----------
    world
        Path of the world file (docs/blackboard.md, "World files").
    condition
        Sensor noise: ``normal``, ``noiseless`` or ``noisy``.
    seed
        Root seed of the sensor noise and the chain.
    mode
        ``fused`` (one map of the room) or ``paper`` (Algorithm 1 per pose).
    fused
        Overrides of :class:`~bayesmap.blackboard.fused.FusedParams` fields.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    world: Path
    condition: str = "normal"
    seed: int = Field(0, ge=0)
    mode: Literal["fused", "paper"] = "fused"
    fused: dict[str, int | float] = Field(default_factory=dict)

    @field_validator("condition")
    @classmethod
    def _known(cls, value: str) -> str:
        if value not in CONDITIONS:
            raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {value!r}")
        return value


def catalogue_of(world: WorldFile) -> tuple[ObjectType, ...]:
    """The object types a world file declares (or the distinct sizes of its tables)."""
    return tuple(ObjectType(*entry) for entry in world.catalogue)


def _per_pose(run: dict[str, Any], world: TablesWorld) -> dict[str, Any]:
    """The paper experiment's per-pose metrics of a run (paper or fused)."""
    return paper.per_pose_metrics(run, paper.Config.model_validate({}), world)


def match_tolerance(world: TablesWorld) -> MatchTolerance:
    """How close a mapped table must come to a true one of ``world`` to match it: the
    paper experiment's tolerances, angles weighed at half its tables' length."""
    config = paper.Config.model_validate({})
    return MatchTolerance(
        position_tol=config.position_tol,
        angle_tol=config.angle_tol,
        angle_scale=world.params.table_length / 2,
        c=config.gospa_c,
    )


def fused_world_run(
    world_file: WorldFile,
    condition_name: str,
    seed: int,
    *,
    name: str = "whisker-tables-file",
    overrides: dict[str, int | float] | None = None,
    progress: ProgressHook = no_progress,
) -> tuple[TablesWorld, dict[str, Any], dict[str, Any]]:
    """The fused mapper over a world file's whole tour under one sensor condition.

    The seed's two :class:`~numpy.random.SeedSequence` children drive the sensor noise and
    the chain. Returns the world, the run (:func:`~bayesmap.experiments.fused_run.run_fused`)
    and its ``fused_*`` metrics.
    """
    world = world_file.world(name=name)
    poses = world_file.robot_poses()
    if not len(poses):
        raise ConfigError(f"{name}: every robot pose is blocked by a table")
    sensor = condition(condition_name)
    sensor_seed, chain_seed = np.random.SeedSequence(seed).spawn(2)
    result = run_fused(
        world,
        poses,
        catalogue_of(world_file),
        sensor,
        fused_params(sensor, overrides),
        np.random.default_rng(sensor_seed),
        np.random.default_rng(chain_seed),
        label=condition_name,
        progress=progress,
    )
    return world, result, fused_metrics(result, world, match_tolerance(world))


def run(
    config: Config,
    out_dir: str | Path,
    *,
    progress: ProgressHook | None = None,
    command: str | None = None,
) -> ExperimentResult:
    """Map the world of ``config.world`` and write ``metrics.json``, ``map.json``, ``map.png``.

    The folder appears only once complete, with a ``manifest.json``
    (:func:`~bayesmap.experiments._common.run_in_folder`).
    """
    world_file = load_world(config.world)  # a bad world fails before any folder is touched
    return run_in_folder(
        "blackboard_world",
        config,
        out_dir,
        lambda folder: _run(config, world_file, folder, progress),
        command=command,
    )


def _run(
    config: Config, world_file: WorldFile, out_dir: Path, progress: ProgressHook | None
) -> ExperimentResult:
    progress = progress or no_progress
    out_dir = Path(out_dir)
    world = world_file.world(name=config.world.name)
    poses = world_file.robot_poses()
    if not len(poses):
        raise ConfigError(f"{config.world}: every robot pose is blocked by a table")
    sensor = condition(config.condition)
    sensor_seed, chain_seed = np.random.SeedSequence(config.seed).spawn(2)
    sensor_rng, chain_rng = np.random.default_rng(sensor_seed), np.random.default_rng(chain_seed)
    catalogue = catalogue_of(world_file)
    metrics: dict[str, Any] = {
        "world": str(config.world),
        "condition": config.condition,
        "seed": config.seed,
        "mode": config.mode,
        "catalogue": [t._asdict() for t in catalogue],
    }
    if config.mode == "fused":
        _, result, scores = fused_world_run(
            world_file,
            config.condition,
            config.seed,
            name=config.world.name,
            overrides=config.fused,
            progress=progress,
        )
        fused: FusedMap = result["fused"]
        metrics.update(scores)
        objects = fused.objects()
        doubtful = fused.objects(doubtful=True)
    else:
        doubtful = []
        largest = max(catalogue, key=lambda kind: kind.length * kind.width)
        params = replace(
            paper.paper_params(world, sensor),
            table_length=largest.length,
            table_width=largest.width,
            leg_width=largest.leg,
        )
        result = paper.run_paper(
            world,
            poses,
            sensor,
            params,
            sensor_rng,
            chain_rng,
            label=config.condition,
            progress=progress,
        )
        last = result["maps"][-1] if result["maps"] else np.zeros((0, 5))
        objects = [
            {
                "type": "paper-table",
                "length": params.table_length,
                "width": params.table_width,
                "leg": params.leg_width,
                "x": float(row[0]),
                "y": float(row[1]),
                "theta": float(row[2]),
                "existence_probability": float("nan"),
            }
            for row in last
        ]
    metrics.update(_per_pose(result, world))
    files = [write_json(out_dir / "metrics.json", metrics)]
    files.append(
        write_json(
            out_dir / "map.json",
            {"objects": objects, "doubtful": doubtful, "arena": world_file.arena},
        )
    )
    title = f"{config.world.name}, {config.condition}, seed {config.seed}: " + (
        f"fused map ({len(objects)} objects)"
        if config.mode == "fused"
        else "paper, last pose's MAP"
    )
    figure = map_figure(world, objects, title, doubtful)
    headline: dict[str, float | int | str] = {
        k: metrics[k]
        for k in ("fused_precision", "fused_recall", "precision", "recall")
        if k in metrics
    }
    if doubtful:
        headline["doubtful (dashed in map.png)"] = len(doubtful)
    unseen = len(world.tables) - int(metrics.get("tables_touched", len(world.tables)))
    if unseen:
        headline["note"] = (
            f"{unseen} of the world's {len(world.tables)} tables were never touched by a "
            f"whisker at any of the {len(poses)} poses (whiskers "
            f"{sensor.whisker_length:g} m long): no contact, so nothing can map them; add "
            "poses within a whisker's length of their legs"
        )
    return ExperimentResult(
        "blackboard-world",
        out_dir,
        (write_bytes(out_dir / "map.png", figure),),
        tuple(files),
        headline,
    )


def map_figure(
    world: TablesWorld,
    objects: list[dict[str, Any]],
    title: str,
    doubtful: list[dict[str, Any]] | None = None,
) -> bytes:
    """PNG of mapped objects (records as in ``map.json``) over the world's true tables, the
    ``doubtful`` ones (left off the map) dashed."""
    fig = fused_map_figure(
        world.tables,
        world.table_sizes,
        figure_objects(objects),
        world.bounds,
        title,
        doubtful=figure_objects(doubtful or []),
    )
    return figure_png(fig)
