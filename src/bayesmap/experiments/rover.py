"""Micro-rover IR mapping with entropy-driven exploration (Post et al. 2016 §5, Figs. 11–14).

Four runs on the 20 m x 20 m field with a 0.5 m grid, β_b = 0.2, d_max = 8 m, P(R) = 0.2:
``empty-flat``, ``empty-random``, ``obstacles-flat`` and ``obstacles-random`` (no obstacles or
the three boxes of §5.3; entropy initialised to 1 or to 1 − δ_h U(0, 1) with δ_h = 0.1). Each
run drives the simulated rover with the paper's exploration rule and, on the same world and
seeds, with a frontier explorer (Yamauchi 1997) for comparison. Every run records its world
name (``rover-field-empty-v1`` / ``rover-field-obstacles-v1``).

Given a world file (``Config.world``, the ``WORLD.json`` of :mod:`bayesmap.sim.rover_worlds`
that ``bayesmap rover run --world`` reads), every run drives in that world instead, from its
start, on its resolution, with the world's step budget (:func:`world_budget`, the same as
``bayesmap rover run``) unless ``max_steps`` is given; the runs are then named by their entropy
initialisation, ``flat`` and ``random``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ConfigDict, Field
from scipy.stats import rankdata

from bayesmap import bn
from bayesmap._io import write_bytes, write_json, write_text
from bayesmap._rng import spawn
from bayesmap._typing import BoolArray, FloatArray, ProgressHook
from bayesmap.errors import ConfigError
from bayesmap.experiments._common import (
    ExperimentConfig,
    ExperimentResult,
    no_progress,
    run_in_folder,
)
from bayesmap.grid import OccupancyGrid
from bayesmap.grid.ros import write_ros_map
from bayesmap.limits import MAX_CELL_SIDE
from bayesmap.rover.explorer import Decision, Explorer
from bayesmap.rover.network import DecisionNetwork
from bayesmap.rover.params import RoverParams
from bayesmap.rover.targets import EntropyTarget, FrontierTarget, TargetRule
from bayesmap.sensing.ir import informative_range
from bayesmap.sim import rover as sim_rover
from bayesmap.sim import rover_worlds
from bayesmap.sim.world2d import BoxWorld, box_world, world_truth
from bayesmap.viz.rover import coverage_figure, maps_pair_figure

__all__ = ["RUNS", "Config", "map_metrics", "roc_auc", "run"]

RUNS: dict[str, tuple[str, bool]] = {
    "empty-flat": ("rover-field-empty-v1", False),
    "empty-random": ("rover-field-empty-v1", True),
    "obstacles-flat": ("rover-field-obstacles-v1", False),
    "obstacles-random": ("rover-field-obstacles-v1", True),
}
"""Run name → (world name, pseudo-random entropy initialisation)."""

EXPLORERS = ("entropy", "frontier")


class Config(ExperimentConfig):
    """Settings of ``reproduce rover``: the paper's §5 values, and ours where it gives none."""

    model_config = ConfigDict(frozen=True)

    seed: int = 2016
    runs: tuple[str, ...] = tuple(RUNS)
    resolution: float = Field(0.5, ge=rover_worlds.FINEST_CELL_SIDE, le=MAX_CELL_SIDE)
    prior: float = Field(0.2, gt=0, lt=1)
    beta_b: float = Field(0.2, ge=0, le=1)
    reliability_floor: float = Field(0.5, ge=0, lt=1)
    d_max: float = Field(8.0, gt=0)
    delta_h: float = Field(0.1, ge=0, lt=1)
    target_margin: float = Field(0.05, ge=0)
    h_desired: float = Field(0.3, gt=0, le=1)
    n_headings: int = Field(36, ge=4, le=360)
    max_steps: int = Field(5000, ge=1)
    start: tuple[float, float, float] = (1.0, 1.0, math.pi / 4)
    gps_sigma: float = Field(0.1, ge=0)
    compass_sigma_deg: float = Field(2.0, ge=0)
    baseline: bool = True
    curve_every: int = Field(20, ge=1)
    title_note: str = ""
    """Appended to every figure title, to say what a variant run shows."""
    world: Path | None = None
    """A world file driven in instead of the paper's field (see the module docstring)."""

    def rover_params(self) -> RoverParams:
        """The rover brain's parameters."""
        return RoverParams(
            prior=self.prior,
            beta_b=self.beta_b,
            reliability_floor=self.reliability_floor,
            d_max=self.d_max,
            target_margin=self.target_margin,
            h_desired=self.h_desired,
            n_headings=self.n_headings,
        )

    def sim_params(self) -> sim_rover.SimulatedRoverParams:
        """The simulated rover's parameters."""
        return sim_rover.SimulatedRoverParams(
            gps_sigma=self.gps_sigma, compass_sigma=math.radians(self.compass_sigma_deg)
        )


CycleObserver = Callable[[int, FloatArray, Decision, bool], None]
"""Called each cycle with the step, the estimated pose, the decision and whether it stalled."""


@dataclass
class Trace:
    """What one simulated run produced."""

    explorer: Explorer
    path: list[FloatArray] = field(default_factory=list)
    distance: float = 0.0
    steps: int = 0
    collisions: int = 0
    curve: list[tuple[float, float]] = field(default_factory=list)
    seconds: float = 0.0
    min_clearance: float = math.inf
    stalled_cycles: int = 0
    off_map_cycles: int = 0
    observable: BoolArray | None = None
    """The cells coverage counts (:func:`observable_mask`)."""


def roc_auc(scores: FloatArray, labels: BoolArray) -> float | None:
    """Area under the ROC curve (Mann–Whitney, ties counted half); ``None`` without both classes."""
    s = np.asarray(scores, dtype=float).ravel()
    y = np.asarray(labels, dtype=bool).ravel()
    n_pos, n_neg = int(y.sum()), int((~y).sum())
    if n_pos == 0 or n_neg == 0:
        return None
    ranks = rankdata(s)
    return float((ranks[y].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def observable_mask(
    world: BoxWorld, grid: OccupancyGrid, params: RoverParams, start: Any
) -> BoolArray:
    """The cells a rover keeping its margin could make certain: what coverage counts.

    Cells a ranger can see (within the range where eq. 31 still informs,
    :func:`~bayesmap.sensing.ir.informative_range`, plus the rangers' offset) from where the
    rover's centre keeps its footprint and safety margin from every obstacle, connected to
    the start (:func:`bayesmap.sim.rover.observable_cells`). Obstacle interiors and ground
    shut off by gaps narrower than the footprint plus two margins are left out.
    """
    return sim_rover.observable_cells(
        world,
        grid.shape,
        grid.resolution,
        (float(start[0]), float(start[1])),
        clearance=params.footprint_radius + params.safety_margin,
        sense_range=params.sensor_offset
        + informative_range(r_max=params.r_max, beta_b=params.beta_b),
    )


SWEEPS = 12.0
"""How many times the step budget lets the rangers' swath cover the observable area."""


def step_budget(observable_area: float, params: RoverParams) -> int:
    """Cycles a run may take on a world with ``observable_area`` [m²] to map.

    ``SWEEPS * A / (W * v * dt)``: the rangers, turning with the rover, sweep a swath of
    width ``W = 2 (sensor_offset + informative_range)`` (2.79 m with the paper's values) per
    metre driven, and a cycle drives at most ``v * dt`` (0.1 m). One sweep of the paper's
    20 m field takes 1434 cycles; on it the rover reaches 90 % after about 2.5 sweeps of
    driving (docs/rover.md). On cluttered worlds a cycle drives 0.05–0.07 m (pivots, stops
    where no heading is safe) and every face must be looked at from close by: runs cut at
    six sweeps were still gaining coverage there, a few points short of 90 %. The budget
    allows :data:`SWEEPS` (17 200 cycles for 400 m²); it caps a run, the stop rule ends it.
    """
    swath = 2.0 * (
        params.sensor_offset + informative_range(r_max=params.r_max, beta_b=params.beta_b)
    )
    return max(math.ceil(SWEEPS * observable_area / (swath * params.speed * params.dt)), 1)


def world_budget(spec: rover_worlds.WorldSpec) -> int:
    """The step budget of a world file (:func:`step_budget` over its observable area)."""
    params = Config.model_validate({}).rover_params()
    grid = OccupancyGrid(spec.world.width, spec.world.height, spec.resolution)
    observable = observable_mask(spec.world, grid, params, spec.start)
    return step_budget(float(observable.sum()) * spec.resolution**2, params)


def coverage(grid: OccupancyGrid, observable: BoolArray, h_desired: float) -> float:
    """Fraction of the observable cells whose entropy is below ``h_desired``."""
    if not observable.any():
        return 1.0
    return float(np.mean(grid.entropy[observable] < h_desired))


def map_metrics(
    grid: OccupancyGrid, truth: BoolArray, h_desired: float, observable: BoolArray | None = None
) -> dict[str, Any]:
    """Coverage, summed entropy [bits], ROC AUC and obstacle peak ratio of a finished map.

    ``coverage`` counts the ``observable`` cells (all cells when ``None``);
    ``coverage_all_cells`` every cell, as the paper's stop rule does.
    """
    free = ~truth
    ratio = None
    if truth.any():
        ratio = float(grid.probability[truth].mean() / grid.probability[free].mean())
    seen = np.ones(grid.shape, dtype=bool) if observable is None else observable
    return {
        "coverage": coverage(grid, seen, h_desired),
        "coverage_all_cells": float(np.mean(grid.entropy < h_desired)),
        "observable_fraction": float(np.mean(seen)),
        "entropy_bits": float(grid.entropy.sum()),
        "roc_auc": roc_auc(grid.probability, truth),
        "obstacle_peak_ratio": ratio,
    }


def _initial_grid(
    world: BoxWorld, config: Config, randomised: bool, rng: np.random.Generator
) -> OccupancyGrid:
    grid = OccupancyGrid(world.width, world.height, config.resolution, prior=config.prior)
    if randomised:
        grid.entropy[...] = 1.0 - config.delta_h * rng.uniform(size=grid.shape)
    return grid


def simulate(
    world: BoxWorld,
    config: Config,
    explorer_name: str,
    randomised: bool,
    progress: ProgressHook,
    stage: str,
    observer: CycleObserver | None = None,
    target_rule: TargetRule | None = None,
) -> Trace:
    """Drive one run: sense → map → decide → move, until the stop rule or the step budget.

    Besides the path it counts, on the true pose, collisions, the smallest clearance, the
    cycles off the mapped area, and the *stalled* cycles: those that neither lower the
    number of uncertain cells nor shorten the path still to go to an unchanged target
    (:meth:`~bayesmap.rover.planning.LocalPlan.remaining`, measured from the rover's
    position). ``observer`` is told every cycle's estimated pose, decision and whether the
    cycle stalled (for diagnosis, e.g. ``benchmarks/rover_stalls.py``). ``target_rule``, when
    given, replaces the rule ``explorer_name`` names (e.g. an adversarial rule that tests
    safety apart from the explorer, ``benchmarks/rover_safety.py``).
    """
    init_rng, sensor_rng, drive_rng = spawn(config.seed, 3)
    params = config.rover_params()
    sim_params = config.sim_params()
    grid = _initial_grid(world, config, randomised, init_rng)
    rule: TargetRule = target_rule or (
        EntropyTarget(params) if explorer_name == "entropy" else FrontierTarget(params)
    )
    trace = Trace(Explorer(grid, params, rule))
    trace.observable = observable = observable_mask(world, grid, params, config.start)
    state = sim_rover.initial(config.start, sim_params, rng=drive_rng)
    trace.path.append(state.pose.copy())
    trace.min_clearance = sim_rover.clearance(world, state, sim_params)
    touching = False
    previous: tuple[tuple[float, float] | None, float, int] = (None, math.inf, -1)
    started = time.perf_counter()
    for step in range(config.max_steps):
        if step % config.curve_every == 0:
            trace.curve.append((trace.distance, coverage(grid, observable, config.h_desired)))
            progress(stage, step, config.max_steps)
        observation = sim_rover.observe(world, state, sim_params, rng=sensor_rng)
        decision = trace.explorer.step(observation.raw, observation.pose)
        trace.steps = step + 1
        n_uncertain = trace.explorer.mapper_.n_uncertain_
        progressed = decision.target == previous[0] and decision.target_cost < previous[1] - 1e-6
        stalled = n_uncertain >= previous[2] >= 0 and not progressed
        trace.stalled_cycles += int(stalled)
        if observer is not None:
            observer(step, observation.pose, decision, stalled)
        previous = (decision.target, decision.target_cost, n_uncertain)
        if trace.explorer.done or decision.target is None:
            break
        moved = sim_rover.transition(state, decision.command, sim_params, rng=drive_rng)
        trace.distance += float(np.hypot(*(moved.pose[:2] - state.pose[:2])))
        state = moved
        trace.path.append(state.pose.copy())
        trace.min_clearance = min(
            trace.min_clearance, sim_rover.clearance(world, state, sim_params)
        )
        trace.off_map_cycles += int(sim_rover.off_map(world, state))
        now_touching = sim_rover.collides(world, state, sim_params)
        trace.collisions += int(now_touching and not touching)
        touching = now_touching
    trace.seconds = time.perf_counter() - started
    trace.curve.append((trace.distance, coverage(grid, observable, config.h_desired)))
    progress(stage, config.max_steps, config.max_steps)
    return trace


def run_metrics(
    trace: Trace, world: BoxWorld, config: Config, explorer_name: str
) -> dict[str, Any]:
    grid = trace.explorer.grid
    truth = world_truth(world, grid.shape, grid.resolution, grid.origin)
    curve = [[round(d, 3), round(c, 5)] for d, c in trace.curve]
    to_90 = next((d for d, c in trace.curve if c >= 0.9), None)
    metrics: dict[str, Any] = {
        "world": world.name,
        "explorer": explorer_name,
        "steps": trace.steps,
        "stop_rule_met": trace.explorer.done,
        "path_length_m": round(trace.distance, 3),
        "collisions": trace.collisions,
        "min_clearance_m": round(trace.min_clearance, 4)
        if math.isfinite(trace.min_clearance)
        else None,
        "stalled_cycles": trace.stalled_cycles,
        "off_map_cycles": trace.off_map_cycles,
        **map_metrics(grid, truth, config.h_desired, trace.observable),
        "coverage_curve": curve,
        "distance_to_90": None if to_90 is None else round(to_90, 3),
        "h_desired_bits": config.h_desired,
        "cycle_ms": round(1000.0 * trace.seconds / max(trace.steps, 1), 3),
    }
    metrics["coverage_per_metre"] = metrics["coverage"] / max(trace.distance, 1e-9)
    for metres in (100, 200):
        reached = [c for d, c in trace.curve if d <= metres]
        metrics[f"coverage_at_{metres}m"] = reached[-1] if trace.distance >= metres else None
    return metrics


def write_run(
    folder: Path, trace: Trace, world: BoxWorld, metrics: dict[str, Any], title: str
) -> list[Path]:
    grid = trace.explorer.grid
    path = np.asarray(trace.path)[:, :2]
    boxes = world.boxes if world.boxes.size else None
    figures = [
        write_bytes(
            folder / "path.png",
            maps_pair_figure(
                grid.probability,
                grid.entropy,
                grid.extent,
                title=title,
                path=path,
                boxes=boxes,
                polygons=world.polygons,
            ),
        ),
    ]
    grid.save_npz(folder / "map.npz")
    write_ros_map(
        folder / "map",
        grid.probability,
        grid.resolution,
        grid.origin,
        unknown_mask=grid.unobserved(),
        entropy=grid.entropy,
        certain_below=float(metrics["h_desired_bits"]),
    )
    write_json(folder / "metrics.json", metrics)
    return figures


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.{digits}g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def _summary(config: Config, results: dict[str, dict[str, dict[str, Any]]], field_name: str) -> str:
    lines = [
        "# Micro-rover mapping runs (Post et al. 2016 §5)",
        "",
        f"{field_name}, {config.resolution} m grid, β_b = {config.beta_b}, "
        f"d_max = {config.d_max} m, "
        f"P(R) = {config.prior}, δ_h = {config.delta_h}, H_desired = {config.h_desired} bits, "
        f"M = {config.n_headings} headings, seed {config.seed}, at most {config.max_steps} cycles "
        "(0.1 m each at full speed). Coverage = fraction of the observable cells (those a "
        "ranger can see from where the rover may go with its margin) with entropy below "
        "H_desired; on this field every cell is observable.",
        "",
        "## The paper's exploration rule (eqs. 38–39)",
        "",
        "| run | world | steps | path [m] | collisions | coverage | distance to 90 % [m] | "
        "entropy [bits] | ROC AUC | obstacle peak ratio |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, by in results.items():
        m = by["entropy"]
        lines.append(
            f"| {name} | {m['world']} | {m['steps']} | {_fmt(m['path_length_m'], 4)} | "
            f"{m['collisions']} | "
            f"{_fmt(m['coverage'])} | {_fmt(m['distance_to_90'], 4)} | "
            f"{_fmt(m['entropy_bits'], 4)} | "
            f"{_fmt(m['roc_auc'])} | {_fmt(m['obstacle_peak_ratio'])} |"
        )
    if config.baseline:
        lines += [
            "",
            "## Against a frontier explorer (Yamauchi 1997), same worlds and seeds",
            "",
            "Only the target rule differs: the frontier explorer drives to the nearest group of "
            "unknown cells next to open ones; sensing, map update, collision avoidance and the "
            "movement model are shared. The frontier rule reads the entropy map only through "
            "H ≥ H_desired, which no initial value (≥ 1 − δ_h) fails, so its -flat and -random "
            "runs drive the same path and build the same probability map; their entropy maps "
            "differ where the random initial values were never overwritten, so both are driven "
            "and their entropy [bits] differs. "
            "Coverage per metre = final coverage / path length.",
            "",
            "| run | explorer | path [m] | collisions | coverage at 100 m | coverage at 200 m | "
            "coverage | coverage per metre [1/m] | distance to 90 % [m] | ROC AUC |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for name, by in results.items():
            for explorer_name in EXPLORERS:
                m = by[explorer_name]
                label = "paper (entropy)" if explorer_name == "entropy" else "frontier"
                lines.append(
                    f"| {name} | {label} | {_fmt(m['path_length_m'], 4)} | {m['collisions']} | "
                    f"{_fmt(m['coverage_at_100m'])} | {_fmt(m['coverage_at_200m'])} | "
                    f"{_fmt(m['coverage'])} | {_fmt(m['coverage_per_metre'])} | "
                    f"{_fmt(m['distance_to_90'], 4)} | {_fmt(m['roc_auc'])} |"
                )
    lines += [
        "",
        "Figures: `<run>/path.png` (both maps with the path), `coverage.png`. "
        "Maps: `<run>/map.npz`, `<run>/map.yaml` + `map.pgm` (ROS map_server, trinary: free "
        "or occupied only below H_desired). The decision network: `decision_network.xmlbif`.",
        "",
    ]
    return "\n".join(lines)


def _run(
    config: Config,
    out_dir: Path,
    *,
    spec: rover_worlds.WorldSpec | None = None,
    progress: ProgressHook | None = None,
) -> ExperimentResult:
    """Run the four mapping runs (and the frontier baseline); write figures, maps and metrics."""
    hook = progress or no_progress
    unknown = [name for name in config.runs if name not in RUNS]
    if unknown:
        raise ConfigError(f"unknown rover run(s) {unknown}; choose from {list(RUNS)}")
    if spec is None:
        plan = [(name, box_world(RUNS[name][0]), RUNS[name][1]) for name in config.runs]
        field_name = "20 m x 20 m field"
    else:
        steps = config.max_steps if "max_steps" in config.model_fields_set else world_budget(spec)
        config = config.model_copy(
            update={"resolution": spec.resolution, "start": spec.start, "max_steps": steps}
        )
        inits = dict.fromkeys(RUNS[name][1] for name in config.runs)
        plan = [("random" if r else "flat", spec.world, r) for r in inits]
        field_name = f"{spec.world.width:g} m x {spec.world.height:g} m world {spec.world.name}"
    out = Path(out_dir)
    explorers = EXPLORERS if config.baseline else EXPLORERS[:1]
    results: dict[str, dict[str, dict[str, Any]]] = {}
    figures: list[Path] = []
    metric_files: list[Path] = []
    curves: dict[str, list[tuple[float, float]]] = {}
    for name, world, randomised in plan:
        results[name] = {}
        for explorer_name in explorers:
            stage = name if explorer_name == "entropy" else f"{name} (frontier)"
            # the frontier explorer's -flat and -random runs drive alike but end with
            # different entropy maps (see _summary), so both are driven
            trace = simulate(world, config, explorer_name, randomised, hook, stage)
            metrics = run_metrics(trace, world, config, explorer_name)
            folder = out / name if explorer_name == "entropy" else out / "frontier" / name
            title = name if explorer_name == "entropy" else f"{name}, frontier explorer"
            title += f" ({config.title_note})" if config.title_note else ""
            figures += write_run(folder, trace, world, metrics, title)
            metric_files.append(folder / "metrics.json")
            results[name][explorer_name] = metrics
            curves[stage] = trace.curve
    figures.append(
        write_bytes(
            out / "coverage.png", coverage_figure(curves, title="Coverage against distance driven")
        )
    )
    bn.write(DecisionNetwork(config.rover_params()).net, out / "decision_network.xmlbif")
    summary = write_text(out / "summary.md", _summary(config, results, field_name))
    metric_files.append(write_json(out / "metrics.json", results))
    paper = [by["entropy"] for by in results.values()]
    headline: dict[str, float | int | str] = {
        "collisions": int(sum(m["collisions"] for m in paper)),
        "mean coverage": float(np.mean([m["coverage"] for m in paper])),
    }
    return ExperimentResult("rover", out, tuple(figures), (*metric_files, summary), headline)


def run(
    config: Config,
    out_dir: str | Path,
    *,
    progress: ProgressHook | None = None,
    command: str | None = None,
) -> ExperimentResult:
    """Run the four mapping runs (and the frontier baseline); write figures, maps and metrics.

    Everything is written into a fresh folder that replaces ``out_dir`` only once the run
    is complete, with a ``manifest.json`` (:func:`~bayesmap.experiments._common.run_in_folder`).
    """
    # a bad world file fails before any folder is touched
    spec = None if config.world is None else rover_worlds.load_world(config.world)
    return run_in_folder(
        "rover",
        config,
        out_dir,
        lambda folder: _run(config, folder, spec=spec, progress=progress),
        command=command,
    )


KEY_METRICS = ("coverage", "path_length_m", "collisions", "roc_auc", "distance_to_90")
"""The metrics a sweep report draws per world (:mod:`bayesmap.sweeps.protocol`)."""


def canonical_config(config: Config) -> Config:
    """``config`` with ``delta_h`` at its default when no run uses the random entropy init,
    so sweeps compute such runs once whatever ``delta_h`` they were given."""
    if any(RUNS[name][1] for name in config.runs if name in RUNS):
        return config
    return config.model_copy(update={"delta_h": Config.model_fields["delta_h"].default})


def generate_world(rng: np.random.Generator) -> dict[str, Any]:
    """A stress world from :func:`bayesmap.sim.rover_worlds.generate_world`, as WORLD.json."""
    return rover_worlds.generate_world(rng).to_json()


load_world = rover_worlds.load_world
"""The reader of the world files ``Config.world`` names (:mod:`bayesmap.sweeps.protocol`)."""


PAIRED_AGAINST = "entropy"
"""The report compares the frontier explorer with the paper's (:mod:`bayesmap.sweeps.protocol`)."""

METRIC_UNITS = {
    "path_length_m": "m",
    "min_clearance_m": "m",
    "distance_to_90": "m",
    "entropy_bits": "bits",
    "h_desired_bits": "bits",
    "coverage_per_metre": "1/m",
    "cycle_ms": "ms",
    "coverage": "fraction",
    "coverage_at_100m": "fraction",
    "coverage_at_200m": "fraction",
}
"""Units of the metrics, for the sweep report (:mod:`bayesmap.sweeps.protocol`)."""


def metric_rows(result: ExperimentResult) -> list[dict[str, Any]]:
    """One tidy row per run (its ``unit``) and explorer (its ``method``), scalars only."""
    path = result.out_dir / "metrics.json"
    runs: dict[str, dict[str, dict[str, Any]]] = json.loads(path.read_text(encoding="utf-8"))
    return [
        {
            "unit": run_name,
            "method": explorer_name,
            **{k: v for k, v in m.items() if k != "coverage_curve"},
        }
        for run_name, by_explorer in runs.items()
        for explorer_name, m in by_explorer.items()
    ]


KEY_FIGURES = (
    "coverage.png",
    "obstacles-*/path.png",
    "frontier/obstacles-*/path.png",
    "*/path.png",
    "frontier/*/path.png",
)
"""The figures a sweep report shows of one run (:mod:`bayesmap.sweeps.protocol`)."""
