"""Polygon worlds with smooth walls for the sonar simulator, under versioned names.

A world is a free-space region (a shapely polygon: the outer walls with solid obstacles as
holes), its walls as an ``(n, 4)`` array of segments ``(x0, y0, x1, y1)`` [m], and a
closed waypoint path for the robot. Every wall is acoustically smooth: the simulator in
:mod:`bayesmap.sim.sonar` reflects the pulse specularly off it.

Registered worlds (all rich in walls met at glancing angles by a ring of sonars):

- ``"sonar-corridor-v1"``: a 1.8 m wide L-shaped corridor, 12 m by 9 m, driven down its
  centre line and back;
- ``"sonar-room-v1"``: a 10 m by 7 m room with a 35° chamfered corner and a box rotated 25°,
  driven around the box;
- ``"sonar-hall-v1"``: a 12 m by 6 m hall with slanted end walls, two pillars rotated 15°
  and 40° and a long cabinet at 10°, driven in a loop between them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.affinity import rotate
from shapely.geometry import Polygon, box

from bayesmap._typing import FloatArray, Poses
from bayesmap.errors import ConfigError

__all__ = ["WORLDS", "PolygonWorld", "path_poses", "world"]


@dataclass(frozen=True)
class PolygonWorld:
    """A polygon world: free space, its wall segments and the robot's path.

    Attributes
    ----------
    name
        Versioned name (e.g. ``"sonar-room-v1"``) that results record.
    free
        Free space as a shapely polygon (holes are solid obstacles).
    segments
        ``(n, 4)`` wall segments ``(x0, y0, x1, y1)`` [m].
    waypoints
        ``(m, 2)`` closed path [m] (the robot returns to the first point).
    """

    name: str
    free: Polygon
    segments: FloatArray
    waypoints: FloatArray

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` [m] of the world."""
        xmin, ymin, xmax, ymax = self.free.bounds
        return (float(xmin), float(ymin), float(xmax), float(ymax))

    def truth_occupancy(self, x: FloatArray, y: FloatArray, resolution: float) -> np.ndarray:
        """Ground truth: ``True`` where a cell centred at ``(x, y)`` holds solid or a wall.

        A cell is occupied when its centre is outside free space or within half a cell
        (``resolution / 2`` [m]) of a wall.
        """
        inside = shapely.contains_xy(self.free, x, y)
        return np.asarray(~inside | self.near_wall(x, y, resolution / 2.0))

    def near_wall(self, x: FloatArray, y: FloatArray, distance: float) -> np.ndarray:
        """``True`` where the point ``(x, y)`` [m] is within ``distance`` [m] of a wall."""
        return np.asarray(shapely.distance(self.free.boundary, shapely.points(x, y)) <= distance)


def _segments(polygon: Polygon) -> FloatArray:
    rings = [polygon.exterior, *polygon.interiors]
    parts = []
    for ring in rings:
        xy = np.asarray(ring.coords)
        parts.append(np.hstack([xy[:-1], xy[1:]]))
    return np.vstack(parts)


def _make(
    name: str, outer: Polygon, holes: list[Polygon], waypoints: list[tuple[float, float]]
) -> PolygonWorld:
    free = outer
    for hole in holes:
        free = free.difference(hole)
    if not isinstance(free, Polygon):
        raise ConfigError(f"world {name!r}: free space must be one connected polygon")
    free = shapely.normalize(free)
    path = np.asarray(waypoints, dtype=np.float64)
    if not all(free.contains(shapely.points(path))):
        raise ConfigError(f"world {name!r}: every waypoint must lie in free space")
    return PolygonWorld(name=name, free=free, segments=_segments(free), waypoints=path)


def _corridor() -> PolygonWorld:
    outer = box(0.0, 0.0, 12.0, 1.8).union(box(10.2, 0.0, 12.0, 9.0))
    if not isinstance(outer, Polygon):
        raise ConfigError("corridor outline must be one polygon")
    return _make("sonar-corridor-v1", outer, [], [(0.9, 0.9), (11.1, 0.9), (11.1, 8.1)])


def _room() -> PolygonWorld:
    outer = Polygon([(0.0, 0.0), (10.0, 0.0), (10.0, 4.2), (6.0, 7.0), (0.0, 7.0)])
    crate = rotate(box(4.0, 2.6, 6.2, 4.2), 25.0, origin="centroid")
    return _make(
        "sonar-room-v1",
        outer,
        [crate],
        [(1.5, 1.5), (8.5, 1.5), (8.3, 4.2), (5.5, 5.9), (1.5, 5.5)],
    )


def _hall() -> PolygonWorld:
    outer = Polygon([(0.0, 0.0), (12.0, 0.0), (11.0, 6.0), (1.2, 6.0)])
    pillar_a = rotate(box(3.2, 2.4, 4.2, 3.4), 15.0, origin="centroid")
    pillar_b = rotate(box(7.6, 2.5, 8.6, 3.5), 40.0, origin="centroid")
    cabinet = rotate(box(5.0, 4.6, 7.4, 4.9), 10.0, origin="centroid")
    return _make(
        "sonar-hall-v1",
        outer,
        [pillar_a, pillar_b, cabinet],
        [(1.4, 1.2), (10.6, 1.2), (10.0, 3.1), (6.0, 3.9), (2.1, 4.4), (2.0, 2.0)],
    )


WORLDS: dict[str, Callable[[], PolygonWorld]] = {
    "sonar-corridor-v1": _corridor,
    "sonar-room-v1": _room,
    "sonar-hall-v1": _hall,
}
"""Factories of the registered worlds, by versioned name."""


def world(name: str) -> PolygonWorld:
    """Build the registered world ``name``; :class:`ConfigError` if unknown."""
    if name not in WORLDS:
        raise ConfigError(f"unknown sonar world {name!r}; choose from: {', '.join(WORLDS)}")
    return WORLDS[name]()


def path_poses(waypoints: FloatArray, step: float, *, laps: int = 1, closed: bool = True) -> Poses:
    """Poses every ``step`` [m] along a waypoint path, heading along the path [rad].

    Parameters
    ----------
    waypoints
        ``(m, 2)`` points [m].
    step
        Distance between consecutive poses [m].
    laps
        How many times to drive the path.
    closed
        Whether the path returns to its first point (otherwise it is driven there and back).

    Returns
    -------
    ``(n, 3)`` poses ``(x, y, heading)``.
    """
    if not step > 0:
        raise ConfigError(f"pose step must be positive metres, got {step!r}")
    points = np.asarray(waypoints, dtype=np.float64)
    route = np.vstack([points, points[:1]]) if closed else np.vstack([points, points[-2::-1]])
    poses = []
    for _ in range(laps):
        for start, end in zip(route[:-1], route[1:], strict=True):
            delta = end - start
            length = float(np.hypot(*delta))
            if length == 0.0:
                continue
            heading = float(np.arctan2(delta[1], delta[0]))
            s = np.arange(0.0, length, step)
            xy = start + s[:, None] * (delta / length)
            poses.append(np.column_stack([xy, np.full(len(s), heading)]))
    return np.vstack(poses)
