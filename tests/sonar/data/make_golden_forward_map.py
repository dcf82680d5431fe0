"""Record two short logs and the forward-model map made of them (run from the repository root).

``golden_forward_map.npz`` holds 300 rings of a realistic simulated log of the open hall
(``sonar-openhall-v2``, seed 8) and of the L corridor (``sonar-lcorridor-v2``, seed 9),
Pioneer 16-sonar ring: odometry poses and ranges (so the test does not depend on the
simulator), and for each the log-odds layer, ``swept_`` and the map's verdict (stage per
reading) that the pipeline with the forward-model sweep made of it.

It was first written at commit 0a9079a, where that pipeline was called ``forward`` (now
``default``), before the sweep and the cone cells were rewritten for speed; a change for
speed must leave every value equal. ``python tests/sonar/data/make_golden_forward_map.py
NAME`` records the pipeline ``NAME`` (default ``default``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from bayesmap.experiments.sonar import ring_geometry
from bayesmap.sim.polygons import world
from bayesmap.sim.sonar import SonarRing
from bayesmap.sim.sonar_log import simulate_log
from bayesmap.sonar.pipeline import PIPELINES, build_map

HERE = Path(__file__).resolve().parent
LOGS, RINGS = (("sonar-openhall-v2", 8), ("sonar-lcorridor-v2", 9)), 300


def mapped(name: str, poses: np.ndarray, ranges: np.ndarray) -> dict[str, np.ndarray]:
    """Map the log with pipeline ``name`` at 0.1 m: its log-odds, swept cells and stages."""
    built = build_map(
        poses, ranges, ring_geometry(SonarRing.pioneer(16)), 0.1, pipeline=PIPELINES[name]
    )
    mapper = built.mapper
    return {
        "log_odds": mapper.log_odds_,  # type: ignore[attr-defined]
        "swept": mapper.swept_,  # type: ignore[attr-defined]
        "stage": built.run.stage,
    }


def main(name: str) -> None:
    record: dict[str, np.ndarray] = {}
    for world_name, seed in LOGS:
        log = simulate_log(world(world_name), SonarRing.pioneer(16), rng=seed)
        poses, ranges = log.odometry[:RINGS], log.ranges[:RINGS]
        record[f"{world_name}/poses"], record[f"{world_name}/ranges"] = poses, ranges
        for key, value in mapped(name, poses, ranges).items():
            record[f"{world_name}/{key}"] = value
    np.savez_compressed(HERE / "golden_forward_map.npz", **record)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "default")
