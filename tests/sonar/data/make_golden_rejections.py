"""Record a log and the filter's full outcome on it (run from the repository root).

``golden_rejections.npz`` holds 600 rings of a realistic simulated log of a second world,
``sonar-office-v2`` (Pioneer 16-sonar ring, one lap, seed 6: odometry poses and ranges, so the
test does not depend on the simulator), and what the filter with the options below made of
it: every reading's stage, the rejection log (ring, transducer, stage, reason), the
free-space limits and the final local view ``L`` (traits, where each was first and last
seen, how many readings passed through it). The options are written out rather than taken
from the ``default`` pipeline, so the record tests the filter, not the pipeline's choice.

It was first written by the filter as it stood before Trait Verification was restructured
for speed (one ray pass per ring, the match table for new traits of ``L``); a change for
speed must leave every value equal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayesmap.experiments.sonar import ring_geometry
from bayesmap.sim.polygons import world
from bayesmap.sim.sonar import SonarRing
from bayesmap.sim.sonar_log import Realism, simulate_log
from bayesmap.sonar.filter import SpecularFilter

HERE = Path(__file__).resolve().parent
WORLD, SEED, RINGS = "sonar-office-v2", 6, 600
REASONS = (
    "obstacle reading outside the bounds from both neighbours",
    "free-space reading and neither neighbour reports free space",
    "flagged and no equivalent trait in L",
    "certainty below threshold and no equivalent trait in L",
    "claims free space through a trait of L",
    "coincides with L but flagged and below the certainty threshold",
)
# The filter options of both pipelines this records: the paper's filter, and the one that
# keeps echoes on static traits of L and lets L judge silent readings in case A.
OPTIONS: dict[str, dict[str, object]] = {
    "paper": {},
    "keeping": {
        "no_echo_spread": None,
        "certainty_threshold": 0.3,
        "keep_supported_echoes": True,
        "static_span": 0.5,
        "l_in_case_a": True,
    },
}


def outcome(filt: SpecularFilter, poses: np.ndarray, ranges: np.ndarray) -> dict[str, np.ndarray]:
    """Run ``filt`` over the log in two batches; its stages, rejections, free limits and L."""
    verdicts = [filt.process_many(poses[a:b], ranges[a:b]) for a, b in ((0, 250), (250, None))]
    return {
        "stage": np.vstack([v.stage for v in verdicts]),
        "free_limit": np.vstack([v.free_limit for v in verdicts]),
        "rejections": np.array(
            [(r.ring, r.sensor, int(r.stage), REASONS.index(r.reason)) for r in filt.rejections_],
            dtype=np.int64,
        ).reshape(-1, 4),
        "l": np.column_stack(
            [filt.l_segments_, filt.l_first_, filt.l_seen_, filt.l_passes_.astype(np.float64)]
        ),
    }


def main() -> None:
    ring = SonarRing.pioneer(16)
    log = simulate_log(world(WORLD), ring, Realism(laps=1), rng=SEED)
    poses, ranges = log.odometry[:RINGS], log.ranges[:RINGS]
    record = {"poses": poses, "ranges": ranges}
    for name, options in OPTIONS.items():
        filt = SpecularFilter(ring_geometry(ring), **options)  # type: ignore[arg-type]
        for key, value in outcome(filt, poses, ranges).items():
            record[f"{name}/{key}"] = value
    np.savez_compressed(HERE / "golden_rejections.npz", **record)


if __name__ == "__main__":
    main()
