"""Record the filter's verdicts on a realistic simulated log (run from the repository root).

``golden_verdicts.txt`` holds, for the ``default`` and ``paper`` pipelines' filters on 700
rings of ``sonar-lcorridor-v2`` (Pioneer 16-sonar ring, one lap, seed 3), one line per ring:
the pipeline, the ring number and each reading's stage code (0 accepted, 1 Acceptability,
2 Agreeability, 3 Trait Verification). It was first written by the filter as it stood before
the per-ring Trait Verification was rewritten for speed (commit ef25945), and rewritten when
the default pipeline began keeping echoes on static traits of L (``keep_supported_echoes``,
``static_span``) and again when it let ``L`` judge silent readings in case A
(``l_in_case_a``) and tested silent readings out to the cone's edges, so the
test that reads it holds later versions to the same verdicts.
"""

from __future__ import annotations

from pathlib import Path

from bayesmap.experiments.sonar import ring_geometry
from bayesmap.sim.polygons import world
from bayesmap.sim.sonar import SonarRing
from bayesmap.sim.sonar_log import Realism, simulate_log
from bayesmap.sonar.pipeline import PIPELINES

HERE = Path(__file__).resolve().parent
WORLD, SEED, RINGS, PIPELINE_NAMES = "sonar-lcorridor-v2", 3, 700, ("default", "paper")


def main() -> None:
    ring = SonarRing.pioneer(16)
    log = simulate_log(world(WORLD), ring, Realism(laps=1), rng=SEED)
    lines = []
    for name in PIPELINE_NAMES:
        filt = PIPELINES[name].make_filter(ring_geometry(ring))
        assert filt is not None
        stages = filt.process_many(log.odometry[:RINGS], log.ranges[:RINGS]).stage
        lines += [f"{name} {i} {''.join(map(str, row))}" for i, row in enumerate(stages.tolist())]
    (HERE / "golden_verdicts.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
