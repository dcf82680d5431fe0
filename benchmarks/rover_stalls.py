"""Why the rover stalls: one generated-world run, every stalled cycle put in a category.

A cycle is *stalled* when it neither lowers the number of uncertain cells nor shortens the
path still to go to an unchanged target (``stalled_cycles`` in the run metrics,
:func:`bayesmap.experiments.rover.simulate`). This script drives one run of
``benchmarks/rover_worlds.py``'s grid (same generator, world seed and code path) with an
observer on every cycle, writes the per-cycle log to ``OUT/<run>.csv``, the map with the
path to ``OUT/<run>.png`` and the run's metrics to ``OUT/<run>.json``, and splits the
stalled cycles by what the rover was doing:

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

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks._report import machine, update_section  # noqa: E402
from benchmarks.rover_worlds import GENERATOR, WORLD_SEED  # noqa: E402

from bayesmap._io import write_bytes, write_json  # noqa: E402
from bayesmap.experiments import rover  # noqa: E402
from bayesmap.experiments.rover_world import EXPLORER_RULES  # noqa: E402
from bayesmap.rover.explorer import Decision  # noqa: E402
from bayesmap.sim.rover_worlds import generate_world  # noqa: E402
from bayesmap.viz.rover import maps_pair_figure  # noqa: E402

CATEGORIES = (
    "no safe heading",
    "retreating",
    "at the viewpoint",
    "pivoting",
    "driving",
    "new target",
)


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
    parser.add_argument("--size", type=float, default=20.0, help="side [m] (default 20)")
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
        f"--init {args.init} --seed {args.seed}"
        + (f" --world-seed {args.world_seed}" if fresh else "")
        + (f" --max-steps {args.max_steps}" if args.max_steps else "")
        + f"`. Machine: {machine()}, load average {load[0]:.1f}. World {spec.world.name} "
        f"({args.size:g} m), {metrics['steps']} of {steps} cycles, path "
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
        "Coverage against distance: "
        + ", ".join(f"{c:.2f} at {d:.0f} m" for d, c in checkpoints if math.isfinite(d))
        + ".",
    ]
    text = "\n".join(lines)
    print(text)
    update_section("rover_stalls", text)


if __name__ == "__main__":
    main()
