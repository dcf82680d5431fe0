"""Where the transducers of common sonar rings sit on the robot.

Each layout is a tuple of ``(x [m], y [m], bearing [rad])`` per transducer in ring order, in
the robot frame (x forward, y left, origin at the robot's centre). The Pioneer values are
those of ARIA's ``p3dx.p`` parameter file (``SonarUnit n x_mm y_mm heading_deg``, as listed
in docs/sonar.md): units 0–7 are the front array of 8-sonar robots, 8–15 the rear array of
16-sonar robots. Both the simulator (:mod:`bayesmap.sim.sonar`) and the ring files of
:mod:`bayesmap.sonar.ring` read them from here.
"""

from __future__ import annotations

import math

__all__ = ["PIONEER_FRONT8", "PIONEER_RING16", "PIONEER_SIZE", "Layout"]

Layout = tuple[tuple[float, float, float], ...]

_P3DX_MM_DEG = (
    (69, 136, 90),
    (114, 119, 50),
    (148, 78, 30),
    (166, 27, 10),
    (166, -27, -10),
    (148, -78, -30),
    (114, -119, -50),
    (69, -136, -90),
    (-157, -136, -90),
    (-203, -119, -130),
    (-237, -78, -150),
    (-255, -27, -170),
    (-255, 27, 170),
    (-237, 78, 150),
    (-203, 119, 130),
    (-157, 136, 90),
)


def _si(rows: tuple[tuple[int, int, int], ...]) -> Layout:
    return tuple((x / 1000.0, y / 1000.0, math.radians(a)) for x, y, a in rows)


PIONEER_FRONT8: Layout = _si(_P3DX_MM_DEG[:8])
"""The Pioneer 3-DX front array, units 0–7 (±90°, ±50°, ±30°, ±10°)."""
PIONEER_RING16: Layout = _si(_P3DX_MM_DEG)
"""The Pioneer 3-DX front and rear arrays, units 0–15, in ring order."""
PIONEER_SIZE: tuple[float, float] = (0.511, 0.425)
"""Length and width of a Pioneer 3-DX [m] (ARIA ``RobotLength``, ``RobotWidth``)."""
