"""Regenerate the rover figures of docs/rover.md from runs, and print their numbers.

Runs ``bayesmap reproduce rover`` at its defaults (the paper's four runs and the frontier
baseline) and the literal β_b = 0.2 variant into a temporary folder, copies the figures
the page shows into docs/, and prints the metrics table the page quotes.

Run from the repository root: ``python docs/make_rover_figures.py`` (about 10 min on a
shared 2-core machine).
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

from bayesmap.experiments import rover

DOCS = Path(__file__).resolve().parent


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        rover.run(rover.Config(), out / "paper")
        literal = rover.Config(
            reliability_floor=0.0,
            runs=("obstacles-flat",),
            baseline=False,
            title_note="literal β_b = 0.2: beam tails read as obstacles",
        )
        rover.run(literal, out / "literal")
        for run in rover.RUNS:
            shutil.copyfile(out / "paper" / run / "path.png", DOCS / f"rover_{run}.png")
        shutil.copyfile(
            out / "paper" / "frontier" / "obstacles-flat" / "path.png",
            DOCS / "rover_frontier_obstacles_flat.png",
        )
        shutil.copyfile(out / "paper" / "coverage.png", DOCS / "rover_coverage.png")
        shutil.copyfile(
            out / "literal" / "obstacles-flat" / "path.png", DOCS / "rover_literal_beta.png"
        )
        results = json.loads((out / "paper" / "metrics.json").read_text())
        keys = (
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
            "steps",
            "stop_rule_met",
        )
        for name, by in results.items():
            for explorer, m in by.items():
                print(name, explorer, {k: m.get(k) for k in keys})
        lit = json.loads((out / "literal" / "obstacles-flat" / "metrics.json").read_text())
        print("literal", {k: lit.get(k) for k in keys})


if __name__ == "__main__":
    main()
