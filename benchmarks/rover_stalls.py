"""Why the rover stalls: one generated-world run, every stalled cycle put in a category.

A cycle is *stalled* when it neither lowers the number of uncertain cells nor shortens the
path still to go to an unchanged target (``stalled_cycles`` in the run metrics,
:func:`bayesmap.experiments.rover.simulate`). This script drives one run of
``benchmarks/rover_worlds.py``'s grid (same generator, world seed and code path) with an
observer on every cycle, writes the per-cycle log to ``OUT/<run>.csv``, the final maps
and the true path to ``OUT/<run>.npz``, the map with the path to ``OUT/<run>.png`` and
the run's metrics to ``OUT/<run>.json``, and splits the stalled cycles by what the rover
was doing:

- *no safe heading*: the footprint check refused every heading, retreats included (the
  rover stops, pivots or backs off);
- *retreating*: hemmed in (inside the margin, no heading keeps it), backing out along a
  retreat that never lowers the clearance;
- *at the viewpoint*: the path still to go is at most a cell: the rover stands where it
  looks at its target and turns to face it;
- *pivoting*: turning in place toward a heading more than 90° off (a new target behind it);
- *driving*: moving with the same target but the path still to go did not shrink (a detour
  around a hazard the map just grew, or waiting at a gap);
- *new target*: the target changed this cycle.

At the end of the run every observable cell still uncertain (entropy >= H_desired) is put
in the first class that fits (``uncertain_by_cause`` in the JSON, :func:`uncertain_causes`):

- *mixed readings* (the face band): the rangers' axes, cast on the true world along the
  driven path within informative reach (:func:`reads_per_cell`), both crossed the cell
  free and ended in it, each at least ``MIXED_READS`` times;
- *behind a gap*: no cell the plan can reach on the final map (the planner's crossing
  costs over the whole map, connected to where the rover stands) is within the rangers'
  informative reach of it (line of sight ignored);
- *never read*: no ranger axis entered it within informative reach (line of sight kept);
- *given up*: on the explorer's blacklist (timed out, looked at in vain, unreachable);
- *other*: read, but only one way or a few times, reachable, not given up.

Each cause's cells are also counted by what they truly hold (``uncertain_holding_obstacle``
in the JSON, :func:`holding_obstacle`): a cell that an obstacle overlaps by a positive
area (the coverage truth, :func:`~bayesmap.sim.world2d.world_truth`) is a wall's own cell,
partly free and partly not; the others are wholly free ground. ``map_errors`` in the JSON
(:func:`map_honesty`) counts what the final map gets wrong: free cells mapped likely,
occupied cells mapped certainly free, and passages the likely cells close.

It rewrites its section of docs/benchmarks.md. Run from the repository root, e.g.::

    python benchmarks/rover_stalls.py --world 0 --explorer paper --init flat --seed 0
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.random import SeedSequence
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.rover_worlds import GENERATOR, WORLD_SEED, side_arg  # noqa: E402

from bayesmap._io import write_bytes, write_json  # noqa: E402
from bayesmap.experiments import rover  # noqa: E402
from bayesmap.experiments.rover_world import EXPLORER_RULES  # noqa: E402
from bayesmap.grid import OccupancyGrid  # noqa: E402
from bayesmap.rover.explorer import Decision  # noqa: E402
from bayesmap.rover.params import RoverParams  # noqa: E402
from bayesmap.rover.planning import crossing_costs  # noqa: E402
from bayesmap.sensing.ir import informative_range  # noqa: E402
from bayesmap.sim.rover_worlds import generate_world  # noqa: E402
from bayesmap.sim.world2d import world_ray_cast, world_truth  # noqa: E402
from bayesmap.viz.rover import maps_pair_figure  # noqa: E402

CATEGORIES = (
    "no safe heading",
    "retreating",
    "at the viewpoint",
    "pivoting",
    "driving",
    "new target",
)

UNCERTAIN_CAUSES = ("mixed readings", "behind a gap", "never read", "given up", "other")
MIXED_READS = 3
"""Reads of each kind (free, ending in the cell) that make a cell's readings *mixed*."""


def reads_per_cell(
    world: Any, path: np.ndarray, grid: OccupancyGrid, params: RoverParams
) -> tuple[np.ndarray, np.ndarray]:
    """How often each cell was crossed free and how often a read ended in it.

    Every ranger's axis is cast on the true world from every pose of the path (true
    poses), out to the informative reach of eq. 31; samples every 0.1 m before the
    obstacle count as free reads of their cell, the obstacle's cell as a contact read.
    """
    res = grid.resolution
    reach = informative_range(r_max=params.r_max, beta_b=params.beta_b)
    poses = np.asarray(path, dtype=np.float64)
    angles = (poses[:, 2:3] + np.asarray(params.sensor_angles)[None, :]).ravel()
    heads = np.repeat(poses[:, :2], len(params.sensor_angles), axis=0)
    origins = heads + params.sensor_offset * np.stack(
        [
            np.cos(np.repeat(poses[:, 2], len(params.sensor_angles))),
            np.sin(np.repeat(poses[:, 2], len(params.sensor_angles))),
        ],
        axis=1,
    )
    ranges = world_ray_cast(world, origins, angles)
    along = np.arange(0.05, reach, 0.1)
    before = along[None, :] < np.minimum(ranges, reach)[:, None]
    sx = origins[:, :1] + np.cos(angles)[:, None] * along[None, :]
    sy = origins[:, 1:] + np.sin(angles)[:, None] * along[None, :]
    free = np.zeros(grid.shape, dtype=np.int64)
    ended = np.zeros(grid.shape, dtype=np.int64)

    def count(into: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> None:
        i = np.floor((ys - grid.origin[1]) / res).astype(np.int64)
        j = np.floor((xs - grid.origin[0]) / res).astype(np.int64)
        ok = (i >= 0) & (i < grid.shape[0]) & (j >= 0) & (j < grid.shape[1])
        np.add.at(into, (i[ok], j[ok]), 1)

    count(free, sx[before], sy[before])
    hit = ranges <= reach
    count(
        ended,
        origins[hit, 0] + ranges[hit] * np.cos(angles[hit]),
        origins[hit, 1] + ranges[hit] * np.sin(angles[hit]),
    )
    return free, ended


def uncertain_causes(
    world: Any,
    grid: OccupancyGrid,
    observable: np.ndarray,
    path: np.ndarray,
    blacklist: set[tuple[float, float]],
    params: RoverParams,
) -> dict[str, np.ndarray]:
    """Observable cells still uncertain at the end of a run, by the first cause that fits.

    Returns a mask per cause, in the order of :data:`UNCERTAIN_CAUSES`.

    The causes are the module docstring's, in its order. *Reach* is the ranger offset plus
    the informative range of eq. 31 (:func:`~bayesmap.sensing.ir.informative_range`), as in
    the coverage definition.
    """
    res = grid.resolution
    uncertain = observable & (grid.entropy >= params.h_desired)
    free_reads, contact_reads = reads_per_cell(world, path, grid, params)
    mixed = (free_reads >= MIXED_READS) & (contact_reads >= MIXED_READS)
    reach = params.sensor_offset + informative_range(r_max=params.r_max, beta_b=params.beta_b)
    x, y = path[-1, :2]
    i = min(max(int((y - grid.origin[1]) // res), 0), grid.shape[0] - 1)
    j = min(max(int((x - grid.origin[0]) // res), 0), grid.shape[1] - 1)
    on_map = np.pad(np.ones(grid.shape, dtype=bool), 1, constant_values=False)
    probability = np.pad(grid.probability, 1, constant_values=params.prior)
    costs = crossing_costs(probability, on_map, params, res, rover=(i + 1, j + 1))[1:-1, 1:-1]
    labels, _ = ndimage.label(np.isfinite(costs))
    reachable = (labels == labels[i, j]) if labels[i, j] else np.zeros(grid.shape, dtype=bool)
    reachable[i, j] = True
    in_view = ndimage.distance_transform_edt(~reachable, sampling=res) <= reach
    read = (free_reads + contact_reads) > 0
    given_up = np.zeros(grid.shape, dtype=bool)
    for bx, by in blacklist:
        bi, bj = int((by - grid.origin[1]) // res), int((bx - grid.origin[0]) // res)
        if 0 <= bi < grid.shape[0] and 0 <= bj < grid.shape[1]:
            given_up[bi, bj] = True
    left = uncertain.copy()
    by_cause: dict[str, np.ndarray] = {}
    for cause, cells in zip(
        UNCERTAIN_CAUSES, (mixed, ~in_view, ~read, given_up, left), strict=True
    ):
        by_cause[cause] = left & cells
        left &= ~cells
    return by_cause


def holding_obstacle(
    world: Any, grid: OccupancyGrid, by_cause: dict[str, np.ndarray]
) -> dict[str, int]:
    """How many of each cause's cells an obstacle truly overlaps by a positive area."""
    truth = world_truth(world, grid.shape, grid.resolution, grid.origin)
    return {cause: int((cells & truth).sum()) for cause, cells in by_cause.items()}


def map_honesty(
    world: Any, grid: OccupancyGrid, observable: np.ndarray, params: RoverParams
) -> dict[str, int]:
    """What the final map gets wrong against the truth (any part occupied = occupied).

    ``free_mapped_likely``: observable free cells at ``p >= p_block`` (the planner's
    walls); ``occupied_mapped_certain_free``: observable cells an obstacle overlaps, mapped
    certainly free; ``free_regions_split``: how many more 4-connected pieces the free
    ground falls into when the cells mapped likely are taken out of it (a passage closed
    on the map; 0 when none is).
    """
    truth = world_truth(world, grid.shape, grid.resolution, grid.origin)
    likely = grid.probability >= params.p_block
    certain_free = (grid.entropy < params.h_desired) & ~likely
    _, pieces_true = ndimage.label(~truth)
    _, pieces_mapped = ndimage.label(~truth & ~likely)
    return {
        "free_mapped_likely": int((observable & ~truth & likely).sum()),
        "occupied_mapped_certain_free": int((observable & truth & certain_free).sum()),
        "free_regions_split": int(pieces_mapped - pieces_true),
    }


def category(row: dict[str, Any], resolution: float) -> str:
    """What a stalled cycle was doing (the module docstring's categories, first match)."""
    if not row["any_safe"]:
        return "no safe heading"
    if row["retreat"]:
        return "retreating"
    if row["new_target"]:
        return "new target"
    if row["to_go"] <= resolution:
        return "at the viewpoint"
    if row["speed"] == 0.0:
        return "pivoting"
    return "driving"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--world", type=int, default=0, help="world index (default 0)")
    parser.add_argument("--world-seed", type=int, default=WORLD_SEED)
    parser.add_argument(
        "--size",
        type=side_arg,
        default=20.0,
        help="side [m] (default 20), or 'any': the side the generator draws, 20-60 m, as in "
        "rover_worlds.py's full-size grid",
    )
    parser.add_argument("--explorer", choices=tuple(EXPLORER_RULES), default="paper")
    parser.add_argument("--init", choices=("flat", "random"), default="flat")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-steps", type=int, default=None, help="default: the world's budget")
    parser.add_argument("--out", type=Path, default=Path("results/rover_stalls"))
    args = parser.parse_args()
    fresh = "" if args.world_seed == WORLD_SEED else f"-w{args.world_seed}"
    spec = generate_world(
        SeedSequence([args.world_seed, args.world]),
        size=args.size,
        name=f"{GENERATOR}{fresh}-{args.world:02d}",
    )
    steps = rover.world_budget(spec) if args.max_steps is None else args.max_steps
    config = rover.Config.model_validate(
        {"seed": args.seed, "resolution": spec.resolution, "max_steps": steps, "start": spec.start}
    )
    rows: list[dict[str, Any]] = []
    previous: list[tuple[float, float] | None] = [None]

    def observe(step: int, pose: np.ndarray, decision: Decision, stalled: bool) -> None:
        row = {
            "step": step,
            "x": float(pose[0]),
            "y": float(pose[1]),
            "heading": float(pose[2]),
            "target_x": None if decision.target is None else decision.target[0],
            "target_y": None if decision.target is None else decision.target[1],
            "to_go": decision.target_cost,
            "chosen": decision.heading,
            "speed": decision.command[0],
            "yaw_rate": decision.command[1],
            "any_safe": bool(decision.safety.safe.any()),
            "retreat": decision.safety.retreat,
            "new_target": decision.target != previous[0],
            "stalled": stalled,
        }
        previous[0] = decision.target
        row["category"] = category(row, spec.resolution) if stalled else ""
        rows.append(row)

    rule = EXPLORER_RULES[args.explorer]
    trace = rover.simulate(
        spec.world, config, rule, args.init == "random", rover.no_progress, "", observe
    )
    metrics = rover.run_metrics(trace, spec.world, config, rule)
    name = f"{spec.world.name}-{args.explorer}-{args.init}-seed{args.seed}"
    args.out.mkdir(parents=True, exist_ok=True)
    log = pd.DataFrame(rows)
    log.to_csv(args.out / f"{name}.csv", index=False)
    stalled = log[log["stalled"]]
    counts = stalled["category"].value_counts()
    summary = {k: v for k, v in metrics.items() if k != "coverage_curve"}
    summary["stalled_by_cause"] = {c: int(counts.get(c, 0)) for c in CATEGORIES}
    blacklist = getattr(trace.explorer.target_rule, "blacklist_", set())
    cells_by_cause = uncertain_causes(
        spec.world,
        trace.explorer.grid,
        trace.observable,
        np.asarray(trace.path),
        blacklist,
        config.rover_params(),
    )
    causes = {cause: int(cells.sum()) for cause, cells in cells_by_cause.items()}
    holding = holding_obstacle(spec.world, trace.explorer.grid, cells_by_cause)
    summary["uncertain_by_cause"] = causes
    summary["uncertain_holding_obstacle"] = holding
    honesty = map_honesty(spec.world, trace.explorer.grid, trace.observable, config.rover_params())
    summary["map_errors"] = honesty
    np.savez_compressed(
        args.out / f"{name}.npz",
        probability=trace.explorer.grid.probability,
        entropy=trace.explorer.grid.entropy,
        observable=trace.observable,
        path=np.asarray(trace.path),
        blacklist=np.asarray(sorted(blacklist), dtype=np.float64).reshape(-1, 2),
    )
    n_left = max(sum(causes.values()), 1)
    write_json(args.out / f"{name}.json", summary)
    grid = trace.explorer.grid
    write_bytes(
        args.out / f"{name}.png",
        maps_pair_figure(
            grid.probability,
            grid.entropy,
            grid.extent,
            title=f"{name}: coverage {metrics['coverage']:.3f}",
            path=np.asarray(trace.path)[:, :2],
            boxes=spec.world.boxes if spec.world.boxes.size else None,
            polygons=spec.world.polygons,
        ),
    )
    checkpoints = trace.curve[:: max(len(trace.curve) // 5, 1)] + trace.curve[-1:]
    load = os.getloadavg()
    lines = [
        "## rover_stalls: where the stalled cycles of one generated-world run go",
        "",
        f"`python benchmarks/rover_stalls.py --world {args.world} --explorer {args.explorer} "
        + ("--size any " if args.size is None else f"--size {args.size:g} ")
        + f"--init {args.init} --seed {args.seed}"
        + (f" --world-seed {args.world_seed}" if fresh else "")
        + (f" --max-steps {args.max_steps}" if args.max_steps else "")
        + f"`. Machine: {machine()}, load average {load[0]:.1f}. World {spec.world.name} "
        f"({spec.world.width:g} m), {metrics['steps']} of {steps} cycles, path "
        f"{metrics['path_length_m']:.1f} m, coverage {metrics['coverage']:.3f} ("
        + (
            "90 % not reached"
            if metrics["distance_to_90"] is None
            else f"90 % after {metrics['distance_to_90']:.1f} m"
        )
        + f"), collisions "
        f"{metrics['collisions']}, min clearance {metrics['min_clearance_m']} m; stalled "
        f"{len(stalled)} cycles ({len(stalled) / max(len(log), 1):.0%}).",
        "",
        "| stalled while | cycles | share of the stalled |",
        "|---|---|---|",
        *(
            f"| {c} | {int(counts.get(c, 0))} | {counts.get(c, 0) / max(len(stalled), 1):.0%} |"
            for c in CATEGORIES
        ),
        "",
        "| observable cell still uncertain at the end | cells | share | holding an obstacle |",
        "|---|---|---|---|",
        *(f"| {c} | {n} | {n / n_left:.0%} | {holding[c]} |" for c, n in causes.items()),
        "",
        f"ROC AUC {metrics['roc_auc']:.3f}; final map against the truth (observable cells): "
        f"{honesty['free_mapped_likely']} free cells mapped likely, "
        f"{honesty['occupied_mapped_certain_free']} occupied cells mapped certainly free, "
        f"free ground split into {honesty['free_regions_split']} more pieces.",
        "",
        "Coverage against distance: "
        + ", ".join(f"{c:.2f} at {d:.0f} m" for d, c in checkpoints if math.isfinite(d))
        + ".",
    ]
    text = "\n".join(lines)
    print(text)
    update_section("rover_stalls", text)


if __name__ == "__main__":
    main()
