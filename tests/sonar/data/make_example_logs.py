"""Regenerate the example real-format sonar logs in this folder (run from the repository root).

The readings come from the simulator (16-sonar ring, ``sonar-room-v1``, one lap, seed 4);
untidy lines are then spliced in by hand below, as a real robot's log would have them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bayesmap._io import write_text
from bayesmap.sim.polygons import path_poses, world
from bayesmap.sim.sonar import SonarRing, observe
from bayesmap.sonar.logs import LogUnits, write_sonar_log

HERE = Path(__file__).resolve().parent


def main() -> None:
    w = world("sonar-room-v1")
    ring = SonarRing.ring(16)
    poses = path_poses(w.waypoints, 0.15)
    scan = observe(w, poses, ring, rng=4)
    ranges = np.round(scan.ranges, 3)  # whole millimetres, as a real ring reports
    t = 100.0 + 0.25 * np.arange(len(poses))
    units = LogUnits(range_unit="mm", position_unit="mm", heading_unit="deg")
    one = write_sonar_log(
        HERE / "example_log.txt",
        t,
        ranges,
        poses,
        units=units,
        comments=[
            "sonar-room-v1, 16-sonar ring, simulated; t x y heading r0..r15",
            "units: mm, mm, deg, mm; max range 5000 mm",
        ],
    )
    lines = one.read_text().split("\n")
    body = [line for line in lines if line]
    n = 16 + 4
    body.insert(5, "")
    body.insert(9, "   % a comment written by another logger")
    body.insert(12, " ".join(["101.9", "1500", "1500", "0"] + ["nan"] + ["1000"] * 15))
    body.insert(20, " ".join(["abc"] * n))
    body.insert(30, " ".join(["105.0", "1", "2"]))
    body.insert(40, body[38])  # a repeated row: timestamp not after the previous one
    body[50] = body[50] + "\r"
    body[60] = body[60].replace(" ", ", ", 3) + "  # inline note"
    write_text(HERE / "example_log.txt", "\n".join(body))  # no newline at the end
    cm = LogUnits(range_unit="cm", position_unit="cm", heading_unit="rad")
    write_sonar_log(HERE / "example_ranges.csv", t, ranges, units=cm, delimiter=",")
    keep = np.ones(len(t), dtype=bool)
    keep[[7, 8]] = False
    write_sonar_log(
        HERE / "example_poses.csv",
        t[keep],
        np.zeros((int(keep.sum()), 0)),
        poses[keep],
        units=cm,
        delimiter=",",
        comments=["t,x,y,heading (cm, cm, rad)"],
    )


if __name__ == "__main__":
    main()
