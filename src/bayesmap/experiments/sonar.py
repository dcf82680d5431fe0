"""Sonar mapping with specular-reading rejection (ICINCO 2007 fragment) on simulated rings.

For each world and seed the simulator drives a 16-transducer ring (and, once per world, the
8-transducer front arc) around a polygon world of smooth walls. The *same* readings are
mapped with no filter, each stage alone, all stages (Elfes-style eq. 1 cone model), and,
unfiltered, with Thrun's ±0.4 log-odds model and the ROS ``range_sensor_layer`` model.
Maps are scored against the world's truth; rejections against the simulator's knowledge of
which readings were specular.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field

from bayesmap._io import write_bytes, write_json, write_text
from bayesmap._rng import spawn
from bayesmap.experiments._common import (
    ExperimentResult,
    ProgressHook,
    no_progress,
    run_in_folder,
)
from bayesmap.grid import OccupancyGrid
from bayesmap.sim.polygons import PolygonWorld, path_poses, world
from bayesmap.sim.sonar import SonarRing, SonarScan, observe
from bayesmap.sonar.filter import SpecularFilter
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.mapping import ElfesMapper, RosRangeLayerMapper, ThrunMapper
from bayesmap.sonar.pipeline import RingMapper, map_log
from bayesmap.viz.sonar import maps_side_by_side

__all__ = ["VARIANTS", "Config", "map_metrics", "ring_geometry", "run"]

VARIANTS: tuple[str, ...] = (
    "no filter",
    "acceptability",
    "agreeability",
    "trait verification",
    "all stages",
    "Thrun log-odds",
    "ROS range layer",
)
"""The mapping variants compared on the same readings."""

_STAGES: dict[str, tuple[bool, bool, bool]] = {
    "acceptability": (True, False, False),
    "agreeability": (False, True, False),
    "trait verification": (False, False, True),
    "all stages": (True, True, True),
}


class Config(BaseModel):
    """Settings of ``reproduce sonar``; the fragment gives none, these are ours (docs/sonar.md)."""

    model_config = ConfigDict(frozen=True)

    seed: int = 2007
    worlds: tuple[str, ...] = ("sonar-corridor-v1", "sonar-room-v1", "sonar-hall-v1")
    runs: int = Field(3, ge=1, description="Seeded runs per world (16-transducer ring).")
    front_arc_runs: int = Field(
        1, ge=0, description="Runs per world with the 8-transducer front arc."
    )
    laps: int = Field(2, ge=1)
    step: float = Field(0.1, gt=0, description="Distance between rings [m].")
    resolution: float = Field(0.1, gt=0, description="Map cell side [m].")
    beam_width_deg: float = Field(25.0, gt=0, lt=180)
    sigma: float = Field(0.02, gt=0, description="Range noise [m].")
    max_range: float = Field(5.0, gt=0)
    critical_angle_deg: float = Field(15.0, gt=0, lt=90)
    path_jitter: float = Field(
        0.3, ge=0, description="Each run moves every waypoint by up to this much [m] (seeded)."
    )


def ring_geometry(ring: SonarRing) -> SonarGeometry:
    """What the mapping code knows of a simulated ring: its layout, cone, range and noise."""
    return SonarGeometry(
        angles=ring.angles,
        beam_width=ring.beam_width,
        max_range=ring.max_range,
        sigma=ring.sigma,
        radius=ring.radius,
    )


def _mappers(
    grid_factory: Callable[[], OccupancyGrid], geometry: SonarGeometry
) -> dict[str, RingMapper]:
    out: dict[str, RingMapper] = {}
    for name in VARIANTS:
        if name == "Thrun log-odds":
            out[name] = ThrunMapper(grid_factory(), geometry)
        elif name == "ROS range layer":
            out[name] = RosRangeLayerMapper(grid_factory(), geometry)
        else:
            out[name] = ElfesMapper(grid_factory(), geometry)
    return out


def map_metrics(
    probability: np.ndarray, observed: np.ndarray, truth: np.ndarray, wall: np.ndarray
) -> dict[str, float]:
    """Scores of a map against the truth.

    Parameters
    ----------
    probability, observed
        ``(ny, nx)`` map and the cells any reading changed.
    truth
        ``(ny, nx)`` true occupancy (solid or wall).
    wall
        ``(ny, nx)`` true wall cells within sensor reach of the path.

    Returns
    -------
    ``accuracy`` and ``kappa`` over observed cells (occupied: p > 0.5), ``false_obstacle_rate``
    (observed free cells mapped occupied), ``missed_wall_rate`` (wall cells not mapped
    occupied), ``observed_fraction``.
    """
    occupied = probability > 0.5
    obs = observed.astype(bool)
    pred, real = occupied[obs], truth[obs]
    n = max(int(obs.sum()), 1)
    accuracy = float((pred == real).sum() / n)
    p_yes = pred.mean() if pred.size else 0.0
    t_yes = real.mean() if real.size else 0.0
    expected = p_yes * t_yes + (1 - p_yes) * (1 - t_yes)
    kappa = float((accuracy - expected) / (1 - expected)) if expected < 1 else 0.0
    free_obs = obs & ~truth
    false_obstacle = float((occupied & free_obs).sum() / max(int(free_obs.sum()), 1))
    missed = float((wall & ~occupied).sum() / max(int(wall.sum()), 1))
    return {
        "accuracy": accuracy,
        "kappa": kappa,
        "false_obstacle_rate": false_obstacle,
        "missed_wall_rate": missed,
        "observed_fraction": float(obs.mean()),
    }


def _truth(
    w: PolygonWorld, grid: OccupancyGrid, poses: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    ny, nx = grid.shape
    rows, cols = np.mgrid[0:ny, 0:nx]
    x, y = grid.cell_centers(rows, cols)
    truth = w.truth_occupancy(x.ravel(), y.ravel(), grid.resolution).reshape(ny, nx)
    near_wall = w.near_wall(x.ravel(), y.ravel(), grid.resolution / 2.0)
    dist = np.full(x.size, np.inf)
    for px, py in poses[:: max(len(poses) // 200, 1), :2]:
        np.minimum(dist, np.hypot(x.ravel() - px, y.ravel() - py), out=dist)
    wall = (near_wall & (dist <= reach)).reshape(ny, nx)
    return truth, wall


def _rejection_metrics(accepted: np.ndarray, scan: SonarScan) -> dict[str, float]:
    rejected = ~accepted
    specular = scan.specular
    hits = int((rejected & specular).sum())
    return {
        "rejected_fraction": float(rejected.mean()),
        "rejection_precision": float(hits / rejected.sum()) if rejected.any() else float("nan"),
        "rejection_recall": float(hits / specular.sum()) if specular.any() else float("nan"),
    }


def _jitter(w: PolygonWorld, amount: float, rng: np.random.Generator) -> np.ndarray:
    """The waypoints, each moved by up to ``amount`` [m] if it stays clear of the walls."""
    moved = w.waypoints + rng.uniform(-amount, amount, size=w.waypoints.shape)
    inside = shapely.contains_xy(w.free.buffer(-0.3), moved[:, 0], moved[:, 1])
    return np.where(inside[:, None], moved, w.waypoints)


def _one_run(
    config: Config, w: PolygonWorld, ring: SonarRing, rng: np.random.Generator
) -> tuple[dict[str, dict[str, float]], dict[str, np.ndarray], OccupancyGrid, dict[str, Any]]:
    poses = path_poses(_jitter(w, config.path_jitter, rng), config.step, laps=config.laps)
    scan = observe(poses, w, ring, rng=rng)
    geometry = ring_geometry(ring)
    xmin, ymin, xmax, ymax = w.bounds
    pad = 0.5

    def grid_factory() -> OccupancyGrid:
        return OccupancyGrid(
            xmax - xmin + 2 * pad,
            ymax - ymin + 2 * pad,
            config.resolution,
            origin=(xmin - pad, ymin - pad),
        )

    template = grid_factory()
    truth, wall = _truth(w, template, poses, ring.max_range)
    metrics: dict[str, dict[str, float]] = {}
    maps: dict[str, np.ndarray] = {}
    for name, mapper in _mappers(grid_factory, geometry).items():
        filt = None
        if name in _STAGES:
            acc, agr, tv = _STAGES[name]
            filt = SpecularFilter(
                geometry,
                acceptability=acc,
                agreeability=agr,
                trait_verification=tv,
                critical_angle=math.radians(config.critical_angle_deg),
            )
        outcome = map_log(poses, scan.ranges, mapper, filt)
        probability = mapper.probability()
        metrics[name] = map_metrics(probability, mapper.observed(), truth, wall)
        metrics[name].update(_rejection_metrics(outcome.accepted, scan))
        maps[name] = np.where(mapper.observed(), probability, 0.5)
    info = {
        "rings": len(poses),
        "readings": int(scan.ranges.size),
        "specular_fraction": float(scan.specular.mean()),
    }
    return metrics, maps, template, {**info, "truth": truth}


def _summary_table(rows: dict[str, dict[str, list[float]]], title: str) -> str:
    keys = [
        ("accuracy", "accuracy"),
        ("kappa", "κ"),
        ("false_obstacle_rate", "false obstacle"),
        ("missed_wall_rate", "missed wall"),
        ("rejected_fraction", "rejected"),
        ("rejection_precision", "rej. precision"),
        ("rejection_recall", "rej. recall"),
    ]
    lines = [
        f"### {title}",
        "",
        "| variant | " + " | ".join(label for _, label in keys) + " |",
        "|---|" + "---|" * len(keys),
    ]
    for variant in VARIANTS:
        if variant not in rows:
            continue
        cells = []
        for key, _ in keys:
            values = np.asarray(rows[variant][key], dtype=np.float64)
            values = values[np.isfinite(values)]
            cells.append("–" if values.size == 0 else f"{values.mean():.3f} ± {values.std():.3f}")
        lines.append(f"| {variant} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _run(
    config: Config, out_dir: Path, *, progress: ProgressHook | None = None
) -> ExperimentResult:
    """Run the sonar experiment; write metrics.json, summary.md and figures under ``out_dir``."""
    hook = progress or no_progress
    out = Path(out_dir)
    jobs: list[tuple[str, str, int]] = []
    for name in config.worlds:
        jobs += [(name, "ring16", k) for k in range(config.runs)]
        jobs += [(name, "front8", k) for k in range(config.front_arc_runs)]
    streams = spawn(config.seed, len(jobs))
    records: list[dict[str, Any]] = []
    by_world: dict[tuple[str, str], dict[str, dict[str, list[float]]]] = {}
    figures: list[Path] = []
    kwargs = {
        "beam_width": math.radians(config.beam_width_deg),
        "sigma": config.sigma,
        "max_range": config.max_range,
        "critical_angle": math.radians(config.critical_angle_deg),
    }
    for index, ((world_name, ring_name, k), rng) in enumerate(zip(jobs, streams, strict=True)):
        hook(f"{world_name} {ring_name} run {k}", index, len(jobs))
        w = world(world_name)
        ring = (
            SonarRing.ring(16, **kwargs) if ring_name == "ring16" else SonarRing.front_arc(**kwargs)
        )
        metrics, maps, grid, info = _one_run(config, w, ring, rng)
        truth = info.pop("truth")
        records.append(
            {"world": world_name, "ring": ring_name, "run": k, **info, "variants": metrics}
        )
        table = by_world.setdefault((world_name, ring_name), {})
        for variant, scores in metrics.items():
            for key, value in scores.items():
                table.setdefault(variant, {}).setdefault(key, []).append(value)
        if k == 0 and ring_name == "ring16":
            panels = [("truth", truth.astype(float))] + [
                (name, maps[name])
                for name in (
                    "no filter",
                    "all stages",
                    "Thrun log-odds",
                    "ROS range layer",
                    "trait verification",
                )
            ]
            path = out / f"maps_{world_name}.png"
            write_bytes(
                path,
                maps_side_by_side(
                    panels,
                    grid.extent,
                    walls=w.segments,
                    title=f"{world_name}: 16-sonar ring, seed stream {k}",
                ),
            )
            figures.append(path)
    hook("writing results", len(jobs), len(jobs))
    overall: dict[str, dict[str, list[float]]] = {}
    for (_, ring_name), table in by_world.items():
        if ring_name != "ring16":
            continue
        for variant, values in table.items():
            for key, series in values.items():
                overall.setdefault(variant, {}).setdefault(key, []).extend(series)
    metrics_path = write_json(
        out / "metrics.json",
        {
            "experiment": "sonar",
            "config": config.model_dump(),
            "worlds": list(config.worlds),
            "variants": list(VARIANTS),
            "runs": records,
        },
    )
    parts = [
        "# Sonar mapping with specular-reading rejection\n",
        f"Worlds: {', '.join(config.worlds)}; {config.runs} seeded runs each with the 16-sonar "
        f"ring and {config.front_arc_runs} with the 8-sonar front arc; seed {config.seed}. "
        "Mean ± standard deviation over runs. Accuracy and κ over observed cells; false "
        "obstacle: observed free cells mapped occupied; missed wall: wall cells within sensor "
        "reach not mapped occupied; rejection precision/recall against the simulator's "
        "specular readings.\n",
        _summary_table(overall, "All worlds, 16-sonar ring"),
    ]
    for (world_name, ring_name), table in by_world.items():
        parts.append(_summary_table(table, f"{world_name}, {ring_name}"))
    summary_path = write_text(out / "summary.md", "\n".join(parts))
    best = overall["all stages"]
    base = overall["no filter"]
    headline: dict[str, float | int | str] = {
        "kappa no filter": float(np.mean(base["kappa"])),
        "kappa all stages": float(np.mean(best["kappa"])),
        "rejection precision": float(np.nanmean(best["rejection_precision"])),
        "rejection recall": float(np.nanmean(best["rejection_recall"])),
    }
    return ExperimentResult(
        name="sonar",
        out_dir=out,
        figures=tuple(figures),
        metrics=(metrics_path, summary_path),
        headline=headline,
    )


def run(
    config: Config,
    out_dir: str | Path,
    *,
    progress: ProgressHook | None = None,
    command: str | None = None,
) -> ExperimentResult:
    """Run the sonar experiment; write metrics.json, summary.md and figures under ``out_dir``.

    Everything is written into a fresh folder that replaces ``out_dir`` only once the run
    is complete, with a ``manifest.json`` (:func:`~bayesmap.experiments._common.run_in_folder`).
    """
    return run_in_folder(
        "sonar",
        config,
        out_dir,
        lambda folder: _run(config, folder, progress=progress),
        command=command,
    )


KEY_METRICS = (
    "kappa",
    "accuracy",
    "false_obstacle_rate",
    "rejection_precision",
    "rejection_recall",
)
"""The metrics a sweep report draws per world (:mod:`bayesmap.sweeps.protocol`)."""


def metric_rows(result: ExperimentResult) -> list[dict[str, Any]]:
    """One tidy row per run (its ``unit``: world, ring, run) and mapping variant (``method``)."""
    data = json.loads((result.out_dir / "metrics.json").read_text(encoding="utf-8"))
    rows = []
    for record in data["runs"]:
        unit = f"{record['world']} {record['ring']} run {record['run']}"
        for variant, scores in record["variants"].items():
            rows.append({"unit": unit, "method": variant, **scores})
    return rows


KEY_FIGURES = ("maps_*.png",)
"""The figures a sweep report shows of one run (:mod:`bayesmap.sweeps.protocol`)."""
