"""The whiskered robot mapping tables with a Bayesian blackboard (Fox & Prescott 2011 §III).

The robot visits the 10 × 10 × 4 poses of the ``"whisker-tables-v1"`` world in a fixed
order (Fig. 4); at each pose its six whiskers' shapelets go to one
:class:`~bayesmap.blackboard.TableMapper` time step (Algorithm 1), whose MAP tables
(eq. 18) are scored against the true tables. This is done under three sensor conditions:
``normal`` (Fig. 5), ``noiseless`` (Fig. 6) and ``noisy`` (Fig. 7: σ_r = 0.5 m,
σ_θ = π/8).

Every random stream comes from one ``SeedSequence(seed)``: child 0 builds the world, and
condition ``k`` (its position in :data:`~bayesmap.sim.whiskers.CONDITIONS`) draws its
sensor noise from child ``1 + 2k`` and runs its chain on child ``2 + 2k`` — so a condition's
result does not depend on which other conditions run.

Past the paper, each condition's readings also go to the fused mapper, which keeps every
sweep and builds one map of the room (``fused_*`` metrics; its chain runs on child
``1 + 2·3 + k``).

Outputs under ``out_dir``: ``ground_truth.png`` (Fig. 4); per condition
``<condition>/montage.png`` (Figs. 5–7), ``<condition>/fused_map.png`` and
``<condition>/metrics.json``;
``snapshot_high.png`` and ``snapshot_low.png`` (Figs. 1–2) and ``annealing.gif`` for one
pose of the ``normal`` run; ``summary.md``.

Given a world file (``Config.world``, the ``WORLD.json`` of :mod:`bayesmap.sim.whisker_worlds`
that ``bayesmap blackboard run --world`` reads), the robot visits that room's poses and the
fused mapper is told its catalogue; the paper's one-size model gets the largest table.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ConfigDict, Field, field_validator

from bayesmap._io import write_bytes, write_json, write_text
from bayesmap._typing import ProgressHook
from bayesmap.blackboard import BlackboardParams, Snapshot, TableMapper
from bayesmap.blackboard.fused import FusedParams
from bayesmap.blackboard.sweep_model import ObjectType
from bayesmap.errors import ConfigError
from bayesmap.experiments._common import (
    ExperimentConfig,
    ExperimentResult,
    no_progress,
    run_in_folder,
)
from bayesmap.experiments.fused_run import (
    figure_objects,
    fused_metrics,
    fused_params,
    run_fused,
)
from bayesmap.experiments.table_metrics import MatchTolerance, recall_by_support, score_run
from bayesmap.sim import whisker_worlds
from bayesmap.sim.tables_world import TablesWorld, initial, pose_sequence, world_params
from bayesmap.sim.whiskers import CONDITIONS, WhiskerParams, h, observe
from bayesmap.viz.render import figure_png
from bayesmap.viz.tables import (
    TableShape,
    annealing_gif,
    fused_map_figure,
    ground_truth_figure,
    montage_figure,
    snapshot_figure,
)

__all__ = ["KEY_METRICS", "Config", "generate_world", "load_world", "metric_rows", "run"]

PAPER = {
    "contacts": "4.2 ± 1.7",
    "normal": "tables usually found in the right place; many ambiguous tables (Fig. 3) "
    "and phantoms along the walls (Fig. 5)",
    "noiseless": "same approximate locations, sharper poses (Fig. 6)",
    "noisy": "same approximate locations, less accurate poses (Fig. 7)",
}


class Config(ExperimentConfig):
    """Settings of the blackboard experiment (paper defaults where the paper gives them).

    Attributes
    ----------
    seed
        Root seed of every random stream.
    scenario
        Versioned world name.
    conditions
        Sensor conditions to run, from ``normal``, ``noiseless``, ``noisy``.
    poses
        How many poses of the fixed tour to visit (the paper's 400).
    sigmas
        Per condition, the whisker noise ``(sigma_r [m], sigma_theta [rad], sigma_tau)``.
    mapper
        Overrides of :class:`~bayesmap.blackboard.BlackboardParams` fields. The table
        size always comes from the world, and each condition raises the model's shapelet
        σ's (``sigma_*_shapelet``) to at least the sensor's σ's.
    snapshot_pose
        Pose index whose annealing is drawn (Figs. 1–2, GIF); ``None`` picks the first
        pose whose whiskers touch three legs of one table (chosen from the truth alone,
        never from the mapper's result).
    position_tol, angle_tol, gospa_c
        Match tolerances [m], [rad] and the GOSPA cut-off [m]
        (:mod:`~bayesmap.experiments.table_metrics`).
    loose_position_tol, loose_angle_tol
        Looser tolerances [m], [rad] for the secondary ``precision_loose`` and
        ``recall_loose`` ("roughly the right place", as the paper judges its Fig. 7).
    world
        A world file (``WORLD.json``, :mod:`bayesmap.sim.whisker_worlds`) mapped instead
        of drawing the scenario's tables from ``seed``: its arena, tables of their own
        sizes, poses (the first ``poses`` of them) and catalogue.
    fused
        Also run the fused mapper (:class:`~bayesmap.blackboard.fused.FusedMapper`) on each
        condition's readings — the same readings the paper's mapper saw — and add its map
        (``<condition>/fused_map.png``) and ``fused_*`` metrics.
    fused_mapper
        Overrides of :class:`~bayesmap.blackboard.fused.FusedParams` fields.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    seed: int = 2011
    scenario: str = "whisker-tables-v1"
    conditions: tuple[str, ...] = ("normal", "noiseless", "noisy")
    poses: int = Field(400, ge=1, le=400)
    sigmas: dict[str, tuple[float, float, float]] = Field(
        default_factory=lambda: {
            name: (v["sigma_r"], v["sigma_theta"], v["sigma_tau"]) for name, v in CONDITIONS.items()
        }
    )
    mapper: dict[str, int | float] = Field(default_factory=dict)
    snapshot_pose: int | None = None
    position_tol: float = Field(0.2, gt=0)
    angle_tol: float = Field(float(np.pi / 12), gt=0)
    gospa_c: float = Field(0.5, gt=0)
    loose_position_tol: float = Field(0.5, gt=0)
    loose_angle_tol: float = Field(float(np.pi / 6), gt=0)
    world: Path | None = None
    fused: bool = True
    fused_mapper: dict[str, int | float] = Field(default_factory=dict)

    @field_validator("mapper", "fused_mapper")
    @classmethod
    def _known_fields(cls, value: dict[str, int | float], info: Any) -> dict[str, int | float]:
        """Unknown overrides stop a run (or a sweep) before it starts, not at its first pose."""
        params = BlackboardParams if info.field_name == "mapper" else FusedParams
        unknown = sorted(set(value) - {f.name for f in fields(params)})
        if unknown:
            raise ValueError(f"{', '.join(unknown)} not a field of {params.__name__}")
        return value

    @field_validator("conditions")
    @classmethod
    def _known_conditions(cls, value: tuple[str, ...]) -> tuple[str, ...]:
        unknown = [c for c in value if c not in CONDITIONS]
        if unknown or len(set(value)) != len(value):
            raise ValueError(
                f"conditions must be distinct names from {list(CONDITIONS)}; got {value}"
            )
        return value


def paper_params(
    world: TablesWorld, sensor: WhiskerParams, overrides: dict[str, float] | None = None
) -> BlackboardParams:
    """Blackboard constants for one condition: the world's table size, the sensor's σ's.

    A world of several table sizes gives the paper's one-size model its largest table.
    """
    geometry = world.params
    fields: dict[str, Any] = dict(overrides or {})
    try:
        base = replace(
            BlackboardParams(),
            table_length=geometry.table_length,
            table_width=geometry.table_width,
            leg_width=geometry.leg_width,
            **fields,
        )
    except TypeError as error:
        raise ConfigError(
            f"Config.mapper has an unknown BlackboardParams field: {error}"
        ) from error
    return replace(
        base,
        sigma_r_shapelet=max(base.sigma_r_shapelet, sensor.sigma_r),
        sigma_theta_shapelet=max(base.sigma_theta_shapelet, sensor.sigma_theta),
        sigma_tau_shapelet=max(base.sigma_tau_shapelet, sensor.sigma_tau),
    )


def _snapshot_pose(world: TablesWorld, poses: np.ndarray, whiskers: WhiskerParams) -> int:
    """The first pose whose whiskers touch three legs of one table (0 if none does)."""
    for index, pose in enumerate(poses):
        contacts = h(world, pose, whiskers)
        for table in np.unique(contacts.table[contacts.table >= 0]):
            if len(np.unique(contacts.leg[contacts.table == table])) >= 3:
                return index
    return 0


def _sensor(config: Config, name: str) -> WhiskerParams:
    sigma_r, sigma_theta, sigma_tau = config.sigmas.get(name, tuple(CONDITIONS[name].values()))
    return WhiskerParams(sigma_r=sigma_r, sigma_theta=sigma_theta, sigma_tau=sigma_tau)


def _run_condition(
    name: str,
    config: Config,
    world: TablesWorld,
    poses: np.ndarray,
    seeds: list[np.random.SeedSequence],
    snapshot_at: int,
    progress: ProgressHook,
) -> dict[str, Any]:
    """One condition's 400-pose run: MAP tables per pose, timings, contacts, snapshots."""
    k = list(CONDITIONS).index(name)
    sensor = _sensor(config, name)
    return run_paper(
        world,
        poses,
        sensor,
        paper_params(world, sensor, config.mapper),
        np.random.default_rng(seeds[1 + 2 * k]),
        np.random.default_rng(seeds[2 + 2 * k]),
        label=name,
        snapshot_at=snapshot_at,
        progress=progress,
    )


def run_paper(
    world: TablesWorld,
    poses: np.ndarray,
    sensor: WhiskerParams,
    params: BlackboardParams,
    sensor_rng: np.random.Generator,
    chain_rng: np.random.Generator,
    *,
    label: str,
    snapshot_at: int = -1,
    progress: ProgressHook = no_progress,
) -> dict[str, Any]:
    """The paper's per-pose mapper over a tour: MAP tables per pose, timings, contacts.

    ``snapshot_at``: the pose whose annealing is recorded (−1: none).
    """
    mapper = TableMapper(params)
    maps, touched, support, contacts, step_s = [], [], [], [], []
    memory = np.zeros((0, 2), dtype=np.int64)
    snapshots: list[Snapshot] = []
    whisker_points = np.zeros((0, 2))
    start = time.perf_counter()
    for index, pose in enumerate(poses):
        reading = observe(world, pose, sensor, rng=sensor_rng)
        callback = snapshots.append if index == snapshot_at else None
        tic = time.perf_counter()
        result = mapper.step(reading.shapelets, rng=chain_rng, callback=callback)
        step_s.append(time.perf_counter() - tic)
        maps.append(result.tables)
        hit = np.unique(reading.table[reading.table >= 0])
        touched.append(hit)
        memory = np.vstack([memory, np.column_stack([reading.table, reading.leg])])
        memory = memory[-mapper.params.memory_size :]
        support.append(np.array([len(np.unique(memory[memory[:, 0] == t, 1])) for t in hit]))
        contacts.append(int((reading.table >= 0).sum()))
        if index == snapshot_at:
            whisker_points = reading.contacts.point
        progress(label, index + 1, len(poses))
    return {
        "maps": maps,
        "touched": touched,
        "support": support,
        "contacts": np.asarray(contacts),
        "step_ms": 1e3 * np.asarray(step_s),
        "wall_s": time.perf_counter() - start,
        "snapshots": snapshots,
        "whisker_points": whisker_points,
        "sensor": sensor,
    }


def per_pose_metrics(run: dict[str, Any], config: Config, world: TablesWorld) -> dict[str, Any]:
    """The per-pose metrics of a run (docs/blackboard-results.md, "Metrics")."""
    tol = MatchTolerance(
        position_tol=config.position_tol,
        angle_tol=config.angle_tol,
        angle_scale=world.params.table_length / 2,
        c=config.gospa_c,
    )
    scores = score_run(
        run["maps"], run["touched"], world.tables, world.bounds, world.params.table_length, tol
    )
    loose = replace(tol, position_tol=config.loose_position_tol, angle_tol=config.loose_angle_tol)
    rough = score_run(
        run["maps"], run["touched"], world.tables, world.bounds, world.params.table_length, loose
    )
    by_legs = recall_by_support(run["maps"], run["touched"], run["support"], world.tables, tol)
    contacts = run["contacts"][run["contacts"] > 0]
    sensor: WhiskerParams = run["sensor"]
    return {
        "scenario": world.name,
        "poses": len(run["maps"]),
        "sigma_r": sensor.sigma_r,
        "sigma_theta": sensor.sigma_theta,
        "sigma_tau": sensor.sigma_tau,
        "poses_with_table_contact": len(contacts),
        "contacts_mean": float(contacts.mean()) if len(contacts) else float("nan"),
        "contacts_std": float(contacts.std()) if len(contacts) else float("nan"),
        **scores,
        "position_tol": tol.position_tol,
        "angle_tol": tol.angle_tol,
        "gospa_c": tol.c,
        "gospa_p": tol.p,
        "gospa_alpha": 2.0,
        "gospa_angle_scale": tol.angle_scale,
        "recall_by_legs_in_memory": by_legs,
        "precision_loose": rough["precision"],
        "recall_loose": rough["recall"],
        "loose_position_tol": loose.position_tol,
        "loose_angle_tol": loose.angle_tol,
        "per_pose_ms_median": float(np.median(run["step_ms"])),
        "per_pose_ms_p95": float(np.percentile(run["step_ms"], 95)),
        "wall_s": float(run["wall_s"]),
    }


def _summary(metrics: dict[str, dict[str, Any]], world: TablesWorld, config: Config) -> str:
    rows: list[tuple[str, Callable[[dict[str, Any]], str]]] = [
        (
            "contacts per contacting pose",
            lambda m: f"{m['contacts_mean']:.2f} ± {m['contacts_std']:.2f}",
        ),
        ("MAP tables (all poses)", lambda m: f"{m['map_tables']}"),
        ("precision", lambda m: f"{m['precision']:.3f}"),
        ("recall", lambda m: f"{m['recall']:.3f}"),
        (
            "precision / recall, loose match",
            lambda m: f"{m['precision_loose']:.3f} / {m['recall_loose']:.3f}",
        ),
        (
            "recall with 1 / 2 / 3 / 4 legs in memory",
            lambda m: " / ".join(
                f"{m['recall_by_legs_in_memory'][str(k)]:.2f}" for k in range(1, 5)
            ),
        ),
        ("position error mean [m]", lambda m: f"{m['position_error_mean']:.3f}"),
        ("angle error mean [°]", lambda m: f"{np.degrees(m['angle_error_mean']):.1f}"),
        ("GOSPA mean [m]", lambda m: f"{m['gospa_mean']:.3f}"),
        ("phantoms / near walls", lambda m: f"{m['phantoms']} / {m['phantom_near_walls']}"),
        (
            "per-pose ms median / p95",
            lambda m: f"{m['per_pose_ms_median']:.1f} / {m['per_pose_ms_p95']:.1f}",
        ),
        ("wall time [s]", lambda m: f"{m['wall_s']:.1f}"),
    ]
    if all("fused_precision" in m for m in metrics.values()):
        rows += [
            (
                "fused map: precision / recall",
                lambda m: f"{m['fused_precision']:.3f} / {m['fused_recall']:.3f}",
            ),
            (
                "fused map: objects / wall phantoms",
                lambda m: f"{m['fused_objects']} / {m['fused_wall_phantoms']}",
            ),
            (
                "fused map: position / angle error",
                lambda m: (
                    f"{m['fused_position_error_mean']:.3f} m / "
                    f"{np.degrees(m['fused_angle_error_mean']):.1f}°"
                ),
            ),
            ("fused map: GOSPA [m]", lambda m: f"{m['fused_gospa']:.3f}"),
            (
                "fused: per-pose ms median / p95, whole run [s]",
                lambda m: (
                    f"{m['fused_per_pose_ms_median']:.1f} / "
                    f"{m['fused_per_pose_ms_p95']:.1f}, {m['fused_wall_s']:.1f}"
                ),
            ),
        ]
    names = list(metrics)
    lines = [
        "# Blackboard experiment (Fox & Prescott 2011)",
        "",
        f"World `{world.name}`, seed {config.seed}, {config.poses} poses. Matches: within "
        f"{config.position_tol} m and {np.degrees(config.angle_tol):.0f}° (mod 180°). GOSPA: "
        f"c = {config.gospa_c} m, p = 2, α = 2, "
        f"angle weight {world.params.table_length / 2} m/rad. Loose match: within "
        f"{config.loose_position_tol} m and {np.degrees(config.loose_angle_tol):.0f}°.",
        "",
        "| metric | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
    ]
    for label, fmt in rows:
        lines.append(f"| {label} | " + " | ".join(fmt(metrics[n]) for n in names) + " |")
    lines += [
        "",
        "What the paper shows (qualitatively; it gives no numbers but the contacts):",
        "",
        f"- contacts per pose with a table contact: {PAPER['contacts']};",
    ]
    lines += [f"- `{n}`: {PAPER[n]}." for n in names]
    lines += [
        "",
        "Figures: `ground_truth.png` (Fig. 4), `<condition>/montage.png` (Figs. 5–7), "
        "`snapshot_high.png`, `snapshot_low.png` (Figs. 1–2), `annealing.gif`.",
        "",
    ]
    return "\n".join(lines)


def _run(
    config: Config,
    out_dir: Path,
    *,
    world_file: whisker_worlds.WorldFile | None = None,
    progress: ProgressHook | None = None,
) -> ExperimentResult:
    """Run the blackboard experiment and write its figures, metrics and summary.

    Parameters
    ----------
    config
        The settings.
    out_dir
        Folder for the outputs (created if missing).
    world_file
        The world file of ``config.world``, read, or ``None`` for the scenario's world.
    progress
        Called as ``progress(condition, poses_done, poses_total)`` after every pose.
    """
    progress = progress or no_progress
    out_dir = Path(out_dir)
    seeds = _streams(config)
    if world_file is None:
        world, poses, catalogue = _shipped_world(config, seeds)
    else:
        world = world_file.world(name=Path(str(config.world)).stem)
        poses = world_file.robot_poses()[: config.poses]
        catalogue = tuple(ObjectType(*entry) for entry in world_file.catalogue)
        if not len(poses):
            raise ConfigError(f"{config.world}: every robot pose is blocked by a table")
    shape = TableShape(world.params.table_length, world.params.table_width, world.params.leg_width)
    snapshot_at = config.snapshot_pose
    if snapshot_at is None:
        snapshot_at = _snapshot_pose(world, poses, WhiskerParams())
    if not 0 <= snapshot_at < len(poses):
        raise ConfigError(f"Config.snapshot_pose {snapshot_at} must lie in [0, {len(poses)})")
    figures = [
        write_bytes(
            out_dir / "ground_truth.png",
            figure_png(
                ground_truth_figure(
                    world.tables, shape, world.bounds, poses, truth_sizes=world.table_sizes
                )
            ),
        )
    ]
    metric_files: list[Path] = []
    metrics: dict[str, dict[str, Any]] = {}
    snap_run = None
    for name in config.conditions:
        result = _run_condition(name, config, world, poses, seeds, snapshot_at, progress)
        metrics[name] = per_pose_metrics(result, config, world)
        metric_files.append(write_json(out_dir / name / "metrics.json", metrics[name]))
        title = (
            f"{name}: MAP tables of {len(poses)} poses (σ_r = {result['sensor'].sigma_r:g} m, "
            f"σ_θ = {result['sensor'].sigma_theta:.3g} rad)"
        )
        figures.append(
            write_bytes(
                out_dir / name / "montage.png",
                figure_png(
                    montage_figure(
                        world.tables,
                        result["maps"],
                        shape,
                        world.bounds,
                        title,
                        truth_sizes=world.table_sizes,
                    )
                ),
            )
        )
        if config.fused:
            figures.append(
                _fused_condition(
                    name, config, world, catalogue, poses, seeds, metrics, progress, out_dir
                )
            )
            metric_files[-1] = write_json(out_dir / name / "metrics.json", metrics[name])
        if snap_run is None or name == "normal":
            snap_run = result
    if snap_run is not None and snap_run["snapshots"]:
        figures += _snapshot_figures(snap_run, world, shape, poses[snapshot_at], out_dir)
    metric_files.append(write_text(out_dir / "summary.md", _summary(metrics, world, config)))
    headline: dict[str, float | int | str] = {"scenario": world.name}
    keys = ("precision", "recall", "gospa_mean", "fused_precision", "fused_recall")
    for name, values in metrics.items():
        headline.update({f"{name}_{k}": values[k] for k in keys if k in values})
    return ExperimentResult("blackboard", out_dir, tuple(figures), tuple(metric_files), headline)


def _streams(config: Config) -> list[np.random.SeedSequence]:
    """The run's random streams: the world, then per condition its sensor noise and per-pose
    chain, then per condition its fused chain — so a condition's numbers do not depend on
    which other conditions run."""
    return np.random.SeedSequence(config.seed).spawn(1 + 3 * len(CONDITIONS))


def _shipped_world(
    config: Config, seeds: list[np.random.SeedSequence]
) -> tuple[TablesWorld, np.ndarray, tuple[ObjectType, ...]]:
    """The scenario's world drawn from the world stream, its pose tour and its one table type."""
    world = initial(
        world_params(config.scenario), rng=np.random.default_rng(seeds[0]), name=config.scenario
    )
    p = world.params
    catalogue = (ObjectType("table", p.table_length, p.table_width, p.leg_width),)
    return world, pose_sequence(p)[: config.poses], catalogue


def fused_condition(
    name: str,
    config: Config | None = None,
    *,
    progress: ProgressHook = no_progress,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The fused run of condition ``name`` on the scenario's world, exactly as ``run`` makes it
    (same world, sensor noise and chain): the run (:func:`run_fused`) and its fused metrics."""
    config = Config.model_validate({}) if config is None else config
    seeds = _streams(config)
    world, poses, catalogue = _shipped_world(config, seeds)
    return _fused_run(name, config, world, catalogue, poses, seeds, progress)


def _fused_run(
    name: str,
    config: Config,
    world: TablesWorld,
    catalogue: tuple[ObjectType, ...],
    poses: np.ndarray,
    seeds: list[np.random.SeedSequence],
    progress: ProgressHook,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The fused mapper on condition ``name``'s readings, from the condition's own sensor and
    fused-chain streams, and its fused metrics (``fused_precision``, ``fused_recall``, …)."""
    k = list(CONDITIONS).index(name)
    sensor = _sensor(config, name)
    result = run_fused(
        world,
        poses,
        catalogue,
        sensor,
        fused_params(sensor, config.fused_mapper),
        np.random.default_rng(seeds[1 + 2 * k]),
        np.random.default_rng(seeds[1 + 2 * len(CONDITIONS) + k]),
        label=f"{name} fused",
        progress=progress,
    )
    p = world.params
    tol = MatchTolerance(config.position_tol, config.angle_tol, p.table_length / 2, config.gospa_c)
    return result, fused_metrics(result, world, tol)


def _fused_condition(
    name: str,
    config: Config,
    world: TablesWorld,
    catalogue: tuple[ObjectType, ...],
    poses: np.ndarray,
    seeds: list[np.random.SeedSequence],
    metrics: dict[str, dict[str, Any]],
    progress: ProgressHook,
    out_dir: Path,
) -> Path:
    """The fused mapper on the condition's readings: metrics into ``metrics[name]``, figure."""
    result, scores = _fused_run(name, config, world, catalogue, poses, seeds, progress)
    metrics[name].update(scores)
    metrics[name].update(
        {
            "fused_per_pose_ms_median": float(np.median(result["step_ms"])),
            "fused_per_pose_ms_p95": float(np.percentile(result["step_ms"], 95)),
            "fused_wall_s": float(result["wall_s"]),
        }
    )
    fused = result["fused"]
    m = metrics[name]
    title = (
        f"{name}: fused map of {len(poses)} poses — precision {m['fused_precision']:.2f}, "
        f"recall {m['fused_recall']:.2f}"
    )
    figure = fused_map_figure(
        world.tables,
        world.table_sizes,
        figure_objects(fused.objects()),
        world.bounds,
        title,
        doubtful=figure_objects(fused.objects(doubtful=True)),
    )
    return write_bytes(out_dir / name / "fused_map.png", figure_png(figure))


def _snapshot_figures(
    run: dict[str, Any], world: TablesWorld, shape: TableShape, pose: np.ndarray, out_dir: Path
) -> list[Path]:
    """Figs. 1–2 (the busiest early blackboard and the last) and the annealing GIF."""
    snapshots: list[Snapshot] = run["snapshots"]
    early = snapshots[: max(1, len(snapshots) // 2)]
    busiest = max(early, key=lambda s: len(s.tables) + len(s.legs))
    points = run["whisker_points"]
    args = (shape, world.tables, pose, points, world.bounds)
    return [
        write_bytes(
            out_dir / "snapshot_high.png",
            figure_png(snapshot_figure(busiest, *args, label="high temperature")),
        ),
        write_bytes(
            out_dir / "snapshot_low.png",
            figure_png(snapshot_figure(snapshots[-1], *args, label="low temperature")),
        ),
        write_bytes(out_dir / "annealing.gif", annealing_gif(snapshots, *args)),
    ]


def run(
    config: Config,
    out_dir: str | Path,
    *,
    progress: ProgressHook | None = None,
    command: str | None = None,
) -> ExperimentResult:
    """Run the blackboard experiment and write its figures, metrics and summary.

    Everything is written into a fresh folder that replaces ``out_dir`` only once the run
    is complete, with a ``manifest.json`` (:func:`~bayesmap.experiments._common.run_in_folder`).
    """
    # a bad world file fails before any folder is touched
    world_file = None if config.world is None else whisker_worlds.load_world(config.world)
    return run_in_folder(
        "blackboard",
        config,
        out_dir,
        lambda folder: _run(config, folder, world_file=world_file, progress=progress),
        command=command,
    )


KEY_METRICS = ("precision", "recall", "gospa_mean", "position_error_mean", "phantoms")
"""The metrics a sweep report draws per world (:mod:`bayesmap.sweeps.protocol`)."""


def generate_world(rng: np.random.Generator) -> dict[str, Any]:
    """A stress room from :func:`bayesmap.sim.whisker_worlds.generate_world`, as WORLD.json."""
    return whisker_worlds.generate_world(rng).to_json()


load_world = whisker_worlds.load_world
"""The reader of the world files ``Config.world`` names (:mod:`bayesmap.sweeps.protocol`)."""

METRIC_UNITS = {
    "precision": "fraction",
    "recall": "fraction",
    "precision_loose": "fraction",
    "recall_loose": "fraction",
    "gospa_mean": "m",
    "position_error_mean": "m",
    "angle_error_mean": "rad",
    "phantoms": "tables",
    "fused_precision": "fraction",
    "fused_recall": "fraction",
    "fused_gospa": "m",
    "fused_position_error_mean": "m",
    "fused_angle_error_mean": "rad",
    "per_pose_ms_median": "ms",
    "per_pose_ms_p95": "ms",
    "wall_s": "s",
}
"""Units of the metrics, for the sweep report (:mod:`bayesmap.sweeps.protocol`)."""


def metric_rows(result: ExperimentResult) -> list[dict[str, Any]]:
    """One tidy row per sensor condition (its ``method``), scalars only."""
    rows = []
    for path in result.metrics:
        if path.name != "metrics.json":
            continue
        metrics = json.loads(path.read_text(encoding="utf-8"))
        by_legs = metrics.pop("recall_by_legs_in_memory", {})
        row = {"method": path.parent.name, **metrics}
        row.update({f"recall_by_legs_{k}": v for k, v in by_legs.items() if k.isdigit()})
        rows.append(row)
    return rows


KEY_FIGURES = ("ground_truth.png", "*/montage.png", "snapshot_high.png", "snapshot_low.png")
"""The figures a sweep report shows of one run (:mod:`bayesmap.sweeps.protocol`)."""
