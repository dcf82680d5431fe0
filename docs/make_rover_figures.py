"""Regenerate the rover figures of docs/rover.md from runs, and print their numbers.

Runs the paper's four runs (``bayesmap reproduce rover`` at its defaults, one run per
worker process), the frontier baseline on the obstacle field with the flat initialisation,
and the literal β_b = 0.2 variant into a temporary folder; copies the figures the page shows
into docs/, draws the coverage figure from the runs' coverage curves, and prints the
metrics the page quotes.

Run from the repository root: ``python docs/make_rover_figures.py [--jobs N]`` (runs at a
time; default the machine's cores).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from bayesmap._io import write_bytes
from bayesmap.experiments import rover
from bayesmap.viz.rover import coverage_figure

DOCS = Path(__file__).resolve().parent
KEYS = (
    "steps",
    "path_length_m",
    "collisions",
    "min_clearance_m",
    "coverage",
    "distance_to_90",
    "stalled_cycles",
    "off_map_cycles",
    "entropy_bits",
    "roc_auc",
    "obstacle_peak_ratio",
    "coverage_at_100m",
    "coverage_at_200m",
    "stop_rule_met",
    "cycle_ms",
)


def one(name: str, baseline: bool, literal: bool, out: Path) -> Path:
    """One run (and its frontier baseline if asked) into ``out``."""
    config = rover.Config(runs=(name,), baseline=baseline)
    if literal:
        config = rover.Config(
            runs=(name,),
            baseline=False,
            reliability_floor=0.0,
            title_note="literal β_b = 0.2: beam tails read as obstacles",
        )
    rover.run(config, out)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="runs at a time")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        jobs = [(name, name == "obstacles-flat", False, root / name) for name in rover.RUNS]
        jobs.append(("obstacles-flat", False, True, root / "literal"))
        with ProcessPoolExecutor(max_workers=max(1, min(args.jobs, len(jobs)))) as pool:
            list(pool.map(one, *zip(*jobs, strict=True)))
        curves: dict[str, Any] = {}
        for name in rover.RUNS:
            shutil.copyfile(root / name / name / "path.png", DOCS / f"rover_{name}.png")
            metrics = json.loads((root / name / name / "metrics.json").read_text())
            curves[name] = metrics["coverage_curve"]
            print(name, "paper", {k: metrics.get(k) for k in KEYS})
        frontier = root / "obstacles-flat" / "frontier" / "obstacles-flat"
        shutil.copyfile(frontier / "path.png", DOCS / "rover_frontier_obstacles_flat.png")
        metrics = json.loads((frontier / "metrics.json").read_text())
        curves["obstacles-flat (frontier)"] = metrics["coverage_curve"]
        print("obstacles-flat", "frontier", {k: metrics.get(k) for k in KEYS})
        write_bytes(
            DOCS / "rover_coverage.png",
            coverage_figure(curves, title="Coverage against distance driven (seed 2016)"),
        )
        literal = root / "literal" / "obstacles-flat"
        shutil.copyfile(literal / "path.png", DOCS / "rover_literal_beta.png")
        metrics = json.loads((literal / "metrics.json").read_text())
        print("literal", {k: metrics.get(k) for k in KEYS})


if __name__ == "__main__":
    main()
