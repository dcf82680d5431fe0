"""Record what three pipelines make of a log of a few thousand rings (run from the repository root).

``golden_whole_log.json`` holds, for a realistic simulated log of ``sonar-office-v2`` (four
laps, seed 23, Pioneer 16-sonar ring, stops and people, so repeated stationary rings are
merged), the SHA-256 of the log itself and of everything the ``default``, ``streaming``
and ``paper`` pipelines return: each reading's ``accepted`` and ``stage``, the merged
rings, the log-odds layer, the swept cells, the filter's rejection log (ring, transducer,
stage, reason) and its counts. Digests keep the record small; the log is simulated again
by the test, and its own digest tells a change of the simulator from one of the mapping.

It was written at commit a3c633a, before the outcomes, the rejection log and the map's
verdict were kept in compact arrays and judged in chunks of rings (bounded memory for a
whole log); that change must leave every value equal. The log-odds layer is digested
rounded to 1e-6: NumPy releases may sum in another order (with NumPy 2.4 some values moved
by 1e-14), and a digest of raw floats cannot tell that from a change of the mapping. Its
digests were rewritten on 2026-12-04 from the code that had matched the unrounded record
of a3c633a bit for bit under the NumPy before (the other digests are a3c633a's).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from bayesmap.experiments.sonar import ring_geometry
from bayesmap.sim.polygons import world
from bayesmap.sim.sonar import SonarRing
from bayesmap.sim.sonar_log import Realism, simulate_log
from bayesmap.sonar.pipeline import PIPELINES, build_map

HERE = Path(__file__).resolve().parent
WORLD, SEED, LAPS = "sonar-office-v2", 23, 4
NAMES = ("default", "streaming", "paper")


def digest(array: np.ndarray) -> str:
    """SHA-256 of an array's dtype, shape and bytes."""
    a = np.ascontiguousarray(array)
    return hashlib.sha256(f"{a.dtype.str}{a.shape}".encode() + a.tobytes()).hexdigest()


def log() -> tuple[np.ndarray, np.ndarray]:
    """The recorded log: odometry poses ``(m, 3)`` and ranges ``(m, 16)``."""
    simulated = simulate_log(world(WORLD), SonarRing.pioneer(16), Realism(laps=LAPS), rng=SEED)
    return simulated.odometry, simulated.ranges


def outcome(name: str, poses: np.ndarray, ranges: np.ndarray) -> dict[str, str]:
    """Digests of what pipeline ``name`` returns for the log, mapped at 0.1 m."""
    built = build_map(
        poses, ranges, ring_geometry(SonarRing.pioneer(16)), 0.1, pipeline=PIPELINES[name]
    )
    mapper, filt = built.mapper, built.filt
    assert filt is not None
    rejections = np.array(
        [(r.ring, r.sensor, int(r.stage)) for r in filt.rejections_],
        dtype=np.int64,
    ).reshape(-1, 3)
    reasons = "\n".join(r.reason for r in filt.rejections_)
    return {
        "accepted": digest(built.run.accepted),
        "stage": digest(built.run.stage),
        "repeat": digest(built.run.repeat),
        "log_odds": digest(np.round(mapper.log_odds_, 6)),  # type: ignore[attr-defined]
        "swept": digest(mapper.swept_),  # type: ignore[attr-defined]
        "rejections": digest(rejections),
        "reasons": hashlib.sha256(reasons.encode()).hexdigest(),
        "counts": json.dumps(filt.counts_, sort_keys=True),
    }


def main() -> None:
    poses, ranges = log()
    record = {
        "rings": len(poses),
        "log": {"poses": digest(poses), "ranges": digest(ranges)},
        **{name: outcome(name, poses, ranges) for name in NAMES},
    }
    (HERE / "golden_whole_log.json").write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
