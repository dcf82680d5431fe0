"""Sonar mapping with specular-reading rejection (ICINCO 2007 fragment) on realistic logs.

For each realistic world and seed the simulator (:func:`bayesmap.sim.sonar_log.simulate_log`)
drives a Pioneer 16-sonar ring round the world as a real robot would: stops, turns in place,
people walking by, odometry drift, a no-echo code above the max range, specular loss and
multipath. The *same* logged readings and odometry go through every pipeline of
:data:`bayesmap.sonar.pipeline.PIPELINES` (the default, the paper's filter as first built, each
stage alone, and the unfiltered baselines: eq. 1 cone, eq. 1 ignoring no-echo readings,
Thrun's ±0.4 and the ROS range layer). Maps are scored against the world's truth; rejections
against the simulator's knowledge of which readings were specular.

Given a world file (``Config.world``, the ``WORLD.json`` of :mod:`bayesmap.sim.sonar_worlds`),
the runs are driven in that world instead of the registered ones.
"""

from __future__ import annotations

import contextlib
import json
import math
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from pydantic import ConfigDict, Field
from scipy.spatial import cKDTree

from bayesmap._io import write_bytes, write_json, write_text
from bayesmap._rng import spawn
from bayesmap._typing import ProgressHook
from bayesmap.errors import ConfigError, FormatError
from bayesmap.experiments._common import (
    ExperimentConfig,
    ExperimentResult,
    no_progress,
    run_in_folder,
)
from bayesmap.grid import OccupancyGrid
from bayesmap.limits import MAX_CELL_SIDE
from bayesmap.sim import sonar_worlds
from bayesmap.sim.polygons import REALISTIC_WORLDS, PolygonWorld, world
from bayesmap.sim.sonar import SonarRing
from bayesmap.sim.sonar_log import Realism, SimulatedLog, simulate_log
from bayesmap.sonar.geometry import SonarGeometry
from bayesmap.sonar.pipeline import DEFAULT_CELL_SIDE, DEFAULT_PIPELINE, PIPELINES, map_log
from bayesmap.viz.sonar import maps_side_by_side

__all__ = [
    "BASELINES",
    "TARGETED",
    "Config",
    "make_ring",
    "truth_layers",
    "map_metrics",
    "path_cells",
    "ring_geometry",
    "run",
    "score_world",
]

BASELINES: tuple[str, ...] = ("elfes", "elfes-ignore-no-echo", "thrun", "ros")
"""The unfiltered pipelines the default must beat."""

TARGETED: tuple[str, ...] = (DEFAULT_PIPELINE, "streaming")
"""The pipelines held to the issue's targets in the summary: the default (with the
forward-model sweep) and the one-pass ``streaming`` pipeline (docs/sonar.md)."""

_METRICS = (
    ("kappa", "κ"),
    ("accuracy", "accuracy"),
    ("false_obstacle_rate", "false obstacle"),
    ("missed_wall_rate", "missed wall"),
    ("path_occupied", "path cells occ."),
    ("rejected_fraction", "rejected"),
    ("rejection_precision", "rej. precision"),
    ("rejection_recall", "rej. recall"),
)


class Config(ExperimentConfig):
    """Settings of ``reproduce sonar``; the fragment gives none, these are ours (docs/sonar.md)."""

    model_config = ConfigDict(frozen=True)

    seed: int = 2007
    worlds: tuple[str, ...] = REALISTIC_WORLDS
    runs: int = Field(3, ge=1, description="Seeded runs per world.")
    pipelines: tuple[str, ...] = tuple(PIPELINES)
    ring: int = Field(16, description="Pioneer ring: 16 (front and rear) or 8 (front).")
    resolution: float = Field(
        DEFAULT_CELL_SIDE, gt=0, le=MAX_CELL_SIDE, description="Map cell side [m]."
    )
    beam_width_deg: float = Field(25.0, gt=0, lt=180)
    sigma: float = Field(0.02, gt=0, description="Range noise [m].")
    max_range: float = Field(5.0, gt=0)
    critical_angle_deg: float = Field(15.0, gt=0, lt=90)
    footprint: float = Field(0.2, gt=0, description="Robot radius for path cells [m].")
    realism: Realism = Field(default_factory=Realism)
    world: Path | None = Field(
        None, description="A world file driven in instead of the registered worlds."
    )
    jobs: int = Field(
        1,
        ge=1,
        description="Worker processes for the (world, run) tasks; results do not depend on it.",
    )


def ring_geometry(ring: SonarRing) -> SonarGeometry:
    """What the mapping code knows of a simulated ring: its layout, cone, range and noise."""
    return SonarGeometry(
        angles=ring.angles,
        beam_width=ring.beam_width,
        max_range=ring.max_range,
        sigma=ring.sigma,
        radius=ring.radius,
        offsets=ring.offsets,
        min_range=ring.min_range,
    )


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


def _cell_centres(grid: OccupancyGrid) -> tuple[np.ndarray, np.ndarray]:
    ny, nx = grid.shape
    rows, cols = np.mgrid[0:ny, 0:nx]
    x, y = grid.cell_centers(rows, cols)
    return np.asarray(x).ravel(), np.asarray(y).ravel()


def path_cells(grid: OccupancyGrid, path: np.ndarray, radius: float) -> np.ndarray:
    """``(ny, nx)``: cells whose centre is within ``radius`` [m] of a point of ``path``."""
    x, y = _cell_centres(grid)
    distance, _ = cKDTree(np.asarray(path)[:, :2]).query(np.column_stack([x, y]))
    return np.asarray(distance <= radius).reshape(grid.shape)


def truth_layers(
    w: PolygonWorld, grid: OccupancyGrid, poses: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(ny, nx)`` true occupancy and the wall cells within ``reach`` [m] of ``poses``."""
    x, y = _cell_centres(grid)
    truth = w.truth_occupancy(x, y, grid.resolution).reshape(grid.shape)
    near_wall = w.near_wall(x, y, grid.resolution / 2.0)
    dist = np.full(x.size, np.inf)
    for px, py in poses[:: max(len(poses) // 200, 1), :2]:
        np.minimum(dist, np.hypot(x - px, y - py), out=dist)
    wall = (near_wall & (dist <= reach)).reshape(grid.shape)
    return truth, wall


def _rejection_metrics(accepted: np.ndarray, specular: np.ndarray) -> dict[str, float]:
    rejected = ~accepted
    hits = int((rejected & specular).sum())
    return {
        "specular_readings": float(specular.sum()),
        "rejected_readings": float(rejected.sum()),
        "rejected_specular": float(hits),
        "rejected_fraction": float(rejected.mean()),
        "rejection_precision": float(hits / rejected.sum()) if rejected.any() else float("nan"),
        "rejection_recall": float(hits / specular.sum()) if specular.any() else float("nan"),
    }


def _ring_label(config: Config) -> str:
    """The simulated ring in words, with how its transducers fire when not all at once."""
    cycle = config.realism.firing_cycle
    turns = f", each bank of 8 firing in turn over {cycle:g} s" if cycle > 0 else ""
    return f"Pioneer {config.ring}-sonar ring{turns}"


def make_ring(config: Config) -> SonarRing:
    """The simulated Pioneer ring of ``config`` (true transducer offsets)."""
    return SonarRing.pioneer(
        config.ring,
        beam_width=math.radians(config.beam_width_deg),
        sigma=config.sigma,
        max_range=config.max_range,
        critical_angle=math.radians(config.critical_angle_deg),
    )


def _map_frame(w: PolygonWorld) -> tuple[tuple[float, float], tuple[float, float]]:
    """The maps' ``(width, height)`` and ``origin`` [m]: the world's bounds and 1 m around."""
    xmin, ymin, xmax, ymax = w.bounds
    pad = 1.0
    return (xmax - xmin + 2 * pad, ymax - ymin + 2 * pad), (xmin - pad, ymin - pad)


def _check_map_size(w: PolygonWorld, config: Config, source: str) -> None:
    """:class:`FormatError` naming the world file ``source`` if ``w``'s map would have more
    cells than the grid allows, before anything is simulated."""
    size, _ = _map_frame(w)
    try:
        OccupancyGrid(*size, config.resolution)
    except ConfigError as error:
        raise FormatError(f"{error} (is the world in cm or mm?)", path=source) from None


def score_world(
    config: Config,
    w: PolygonWorld,
    log: SimulatedLog,
    names: tuple[str, ...],
    ring: SonarRing | None = None,
) -> tuple[dict[str, dict[str, float]], dict[str, np.ndarray], OccupancyGrid, np.ndarray]:
    """Map one simulated log with each named pipeline and score the maps.

    ``ring`` is the ring that logged it (default: ``config``'s Pioneer ring). Returns the
    metrics and (observed-masked) probability map of each pipeline, the grid and the truth.
    """
    ring = make_ring(config) if ring is None else ring
    geometry = ring_geometry(ring)
    size, origin = _map_frame(w)
    template = OccupancyGrid(*size, config.resolution, origin=origin)
    truth, wall = truth_layers(w, template, log.poses, ring.max_range)
    driven = path_cells(template, log.odometry, config.footprint)
    metrics: dict[str, dict[str, float]] = {}
    maps: dict[str, np.ndarray] = {}
    for name in names:
        pipeline = PIPELINES[name]
        grid = OccupancyGrid(*size, config.resolution, origin=origin)
        mapper = pipeline.make_mapper(grid, geometry)
        outcome = map_log(
            log.odometry,
            log.ranges,
            mapper,
            pipeline.make_filter(geometry),
            merge_repeats=pipeline.merge_repeats,
            map_verdict=pipeline.map_verdict if pipeline.filtered else None,
        )
        probability = mapper.probability()
        observed = mapper.observed()
        scores = map_metrics(probability, observed, truth, wall)
        scores["path_occupied"] = float((driven & (probability > 0.5)).sum())
        scores.update(_rejection_metrics(outcome.accepted, log.specular))
        metrics[name] = scores
        maps[name] = np.where(observed, probability, 0.5)
    return metrics, maps, template, truth


def _table(rows: dict[str, dict[str, list[float]]], names: tuple[str, ...]) -> str:
    lines = [
        "| pipeline | " + " | ".join(label for _, label in _METRICS) + " |",
        "|---|" + "---|" * len(_METRICS),
    ]
    for name in names:
        cells = []
        for key, _ in _METRICS:
            values = np.asarray(rows[name][key], dtype=np.float64)
            values = values[np.isfinite(values)]
            if values.size == 0:
                cells.append("–")
            elif key == "path_occupied":
                cells.append(f"{values.mean():.1f}")
            else:
                cells.append(f"{values.mean():.3f} ± {values.std():.3f}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _finite_mean(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.mean(finite)) if finite else float("nan")


def _targets(
    by_world: dict[str, dict[str, dict[str, list[float]]]], pipeline: str = DEFAULT_PIPELINE
) -> dict[str, Any]:
    """The issue's targets per world for ``pipeline``: κ margin over the best baseline,
    missed walls vs ROS, path cells occupied."""
    out: dict[str, Any] = {}
    for name, rows in by_world.items():
        mean = {p: {k: _finite_mean(v) for k, v in m.items()} for p, m in rows.items()}
        if pipeline not in mean:
            continue
        best = max(
            (b for b in BASELINES if b in mean), key=lambda b: mean[b]["kappa"], default=None
        )
        entry: dict[str, Any] = {"kappa": mean[pipeline]["kappa"]}
        if best is not None:
            entry["best_baseline"] = best
            entry["kappa_margin"] = mean[pipeline]["kappa"] - mean[best]["kappa"]
        if "ros" in mean:
            entry["missed_wall_vs_ros"] = (
                mean[pipeline]["missed_wall_rate"] - mean["ros"]["missed_wall_rate"]
            )
        entry["path_cells_occupied"] = mean[pipeline]["path_occupied"]
        out[name] = entry
    return out


class _Task(NamedTuple):
    """What one (world, run) task sends back: its record, scores, maps and what to draw."""

    record: dict[str, Any]
    metrics: dict[str, dict[str, float]]
    maps: dict[str, np.ndarray]
    truth: np.ndarray
    extent: tuple[float, float, float, float]
    path: np.ndarray


def _simulate_and_score(
    task: tuple[Config, PolygonWorld, int, np.random.Generator, tuple[str, ...]],
) -> _Task:
    """Simulate one log of a world and score every pipeline on it (runs in a worker)."""
    config, w, k, rng, names = task
    world_name = w.name
    log = simulate_log(w, make_ring(config), config.realism, rng=rng)
    metrics, maps, grid, truth = score_world(config, w, log, names)
    record = {
        "world": world_name,
        "run": k,
        "rings": len(log.times),
        "readings": int(log.ranges.size),
        "specular_fraction": float(log.specular.mean()),
        "pipelines": metrics,
    }
    return _Task(record, metrics, maps, truth, grid.extent, log.odometry[:, :2])


def _run(
    config: Config,
    out_dir: Path,
    *,
    worlds: list[PolygonWorld],
    progress: ProgressHook | None = None,
) -> ExperimentResult:
    """Run the sonar experiment; write metrics.json, summary.md and figures under ``out_dir``."""
    hook = progress or no_progress
    out = Path(out_dir)
    names = tuple(n for n in PIPELINES if n in config.pipelines)
    jobs = [(w, k) for w in worlds for k in range(config.runs)]
    streams = spawn(config.seed, len(jobs))
    records: list[dict[str, Any]] = []
    by_world: dict[str, dict[str, dict[str, list[float]]]] = {}
    figures: list[Path] = []
    tasks = [(config, w, k, rng, names) for (w, k), rng in zip(jobs, streams, strict=True)]
    hook("simulating and mapping", 0, len(jobs))
    with contextlib.ExitStack() as stack:
        if config.jobs > 1:
            pool = stack.enter_context(ProcessPoolExecutor(min(config.jobs, len(tasks))))
            outcomes: Iterator[_Task] = pool.map(_simulate_and_score, tasks)
        else:
            outcomes = map(_simulate_and_score, tasks)
        for index, task in enumerate(outcomes):
            w, k = jobs[index]
            world_name = w.name
            hook(f"{world_name} run {k}", index + 1, len(jobs))
            records.append(task.record)
            table = by_world.setdefault(world_name, {})
            for name, scores in task.metrics.items():
                for key, value in scores.items():
                    table.setdefault(name, {}).setdefault(key, []).append(value)
            if k == 0:
                panels = [("truth", task.truth.astype(float))] + [(n, task.maps[n]) for n in names]
                path = out / f"maps_{world_name}.png"
                write_bytes(
                    path,
                    maps_side_by_side(
                        panels,
                        task.extent,
                        walls=w.segments,
                        path=task.path,
                        title=f"{world_name}: {_ring_label(config)}, run 0",
                        columns=5,
                    ),
                )
                figures.append(path)
    hook("writing results", len(jobs), len(jobs))
    overall: dict[str, dict[str, list[float]]] = {}
    for table in by_world.values():
        for name, values in table.items():
            for key, series in values.items():
                overall.setdefault(name, {}).setdefault(key, []).extend(series)
    targets = _targets(by_world)
    targeted = [n for n in TARGETED if n in names]
    metrics_path = write_json(
        out / "metrics.json",
        {
            "experiment": "sonar",
            "config": config.model_dump(),
            "pipelines": list(names),
            "default": DEFAULT_PIPELINE,
            "runs": records,
            "targets": targets,
            "targets_by_pipeline": {n: _targets(by_world, n) for n in targeted},
        },
    )
    parts = [
        "# Sonar mapping with specular-reading rejection\n",
        f"Worlds: {', '.join(w.name for w in worlds)}; {config.runs} seeded runs each, "
        f"{_ring_label(config)}, seed {config.seed}. Mean ± standard deviation over runs. "
        "κ and accuracy over observed cells; false obstacle: observed free cells mapped "
        "occupied; missed wall: wall cells within sensor reach not mapped occupied; path "
        "cells occ.: cells within the robot's radius of its logged path mapped occupied "
        "(mean count); rejection precision/recall against the simulator's specular readings.\n",
        "## All worlds\n",
        _table(overall, names),
    ]
    for world_name, table in by_world.items():
        parts += [f"## {world_name}\n", _table(table, names)]
    for pipeline in targeted:
        parts.append(f"## Targets ({pipeline} pipeline)\n")
        for world_name, entry in _targets(by_world, pipeline).items():
            parts.append(
                f"- {world_name}: κ {entry['kappa']:.3f}, margin over best baseline "
                f"({entry.get('best_baseline')}) {entry.get('kappa_margin', float('nan')):+.3f}; "
                f"missed wall minus ROS {entry.get('missed_wall_vs_ros', float('nan')):+.3f}; "
                f"path cells occupied {entry['path_cells_occupied']:.1f}"
            )
        parts.append("")
    summary_path = write_text(out / "summary.md", "\n".join(parts) + "\n")
    best = overall.get(DEFAULT_PIPELINE, {})
    headline: dict[str, float | int | str] = {}
    if best:
        headline = {
            "kappa default": float(np.mean(best["kappa"])),
            "min kappa margin": float(min(e.get("kappa_margin", np.nan) for e in targets.values())),
            "rejection precision": _finite_mean(best["rejection_precision"]),
            "rejection recall": _finite_mean(best["rejection_recall"]),
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
    # a bad world file fails before any folder is touched
    if config.world is None:
        worlds = [world(name) for name in config.worlds]
    else:
        worlds = [sonar_worlds.load_world(config.world)]
        _check_map_size(worlds[0], config, str(config.world))
    return run_in_folder(
        "sonar",
        config,
        out_dir,
        lambda folder: _run(config, folder, worlds=worlds, progress=progress),
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


def generate_world(rng: np.random.Generator) -> dict[str, Any]:
    """A random building from :func:`bayesmap.sim.sonar_worlds.generate_world`, as WORLD.json."""
    return sonar_worlds.to_json(sonar_worlds.generate_world(rng))


load_world = sonar_worlds.load_world
"""The reader of the world files ``Config.world`` names (:mod:`bayesmap.sweeps.protocol`)."""


def metric_rows(result: ExperimentResult) -> list[dict[str, Any]]:
    """One tidy row per world, seeded run (its ``replicate``) and pipeline (its ``method``)."""
    data = json.loads((result.out_dir / "metrics.json").read_text(encoding="utf-8"))
    return [
        {"world": record["world"], "replicate": record["run"], "method": pipeline, **scores}
        for record in data["runs"]
        for pipeline, scores in record["pipelines"].items()
    ]


PAIRED_AGAINST = DEFAULT_PIPELINE
"""The pipeline the report compares every other one with (:mod:`bayesmap.sweeps.protocol`)."""

METRIC_UNITS = {
    "accuracy": "fraction",
    "false_obstacle_rate": "fraction",
    "missed_wall_rate": "fraction",
    "observed_fraction": "fraction",
    "path_occupied": "cells",
    "rejected_fraction": "fraction",
    "specular_readings": "readings",
    "rejected_readings": "readings",
    "rejected_specular": "readings",
    "rejection_precision": "fraction",
    "rejection_recall": "fraction",
}
"""Units of the metrics, for the sweep report (:mod:`bayesmap.sweeps.protocol`)."""


KEY_FIGURES = ("maps_*.png",)
"""The figures a sweep report shows of one run (:mod:`bayesmap.sweeps.protocol`)."""
