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

The realistic worlds (v2) add what buildings have: door recesses 0.15 m deep, open
doorways into side rooms, furniture and clutter (see :mod:`bayesmap.sim.sonar_log` for the
logs driven through them):

- ``"sonar-doors-v2"``: a 16 m by 2 m corridor with nine door recesses and an open door into
  a 3 m by 3 m office, driven there and back;
- ``"sonar-office-v2"``: a 9 m by 7 m office with four desks, a cabinet, a pillar and door
  recesses, driven round the desks;
- ``"sonar-clutter-v2"``: a 7 m by 6 m store room with ten boxes and bins at assorted angles;
- ``"sonar-lcorridor-v2"``: a 1.8 m wide L-shaped corridor, 24 m by 14 m, door recesses
  every 3 m, driven there and back;
- ``"sonar-openhall-v2"``: an 18 m by 12 m hall with one slanted wall and four pillars,
  most of it beyond the sonars' reach from the path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.affinity import rotate
from shapely.geometry import Polygon, box

from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import FloatArray, Poses
from bayesmap.errors import ConfigError
from bayesmap.sim.scenarios import register, scenario

__all__ = [
    "REALISTIC_WORLDS",
    "PolygonWorld",
    "path_poses",
    "random_building",
    "random_hall",
    "random_office",
    "world",
]


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
    inside = free.contains(shapely.points(path))
    if not all(inside):
        k = int(np.flatnonzero(~inside)[0])
        raise ConfigError(
            f"world {name!r}: waypoints[{k}] ({path[k, 0]:g}, {path[k, 1]:g}) must lie in free "
            "space, not in an obstacle, on a wall or outside the outline"
        )
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


def _recesses(xs: tuple[float, ...], y: float, depth: float, width: float = 0.9) -> list[Polygon]:
    """Door recesses ``width`` [m] wide centred at ``xs``, reaching ``depth`` [m] from ``y``."""
    lo, hi = sorted((y, y + depth))
    return [box(x - width / 2, lo, x + width / 2, hi) for x in xs]


def _union(parts: list[Polygon]) -> Polygon:
    shape = shapely.union_all(parts)
    if not isinstance(shape, Polygon):
        raise ConfigError("a world's outline must be one polygon")
    return shape


def _doors() -> PolygonWorld:
    corridor = box(0.0, 0.0, 16.0, 2.0)
    south = _recesses((1.5, 4.5, 7.5, 10.5, 13.5), 0.0, -0.15)
    north = _recesses((3.0, 6.0, 12.0, 14.6), 2.0, 0.15)
    office = [box(8.05, 2.0, 8.95, 2.3), box(6.5, 2.3, 9.5, 5.3)]
    outer = _union([corridor, *south, *north, *office])
    bin_ = rotate(box(10.9, 1.45, 11.3, 1.85), 20.0, origin="centroid")
    desk = box(6.9, 4.3, 8.1, 5.0)
    waypoints = [(0.8, 1.0), (8.5, 1.0), (8.5, 3.4), (8.5, 1.0), (15.2, 1.0)]
    return _make("sonar-doors-v2", outer, [bin_, desk], waypoints)


def _office() -> PolygonWorld:
    room = box(0.0, 0.0, 9.0, 7.0)
    recesses = _recesses((2.0, 6.5), 0.0, -0.15) + _recesses((4.5,), 7.0, 0.15)
    outer = _union([room, *recesses])
    desks = [
        box(2.0, 2.2, 3.6, 3.0),
        box(2.0, 4.0, 3.6, 4.8),
        rotate(box(5.4, 2.2, 7.0, 3.0), 5.0, origin="centroid"),
        rotate(box(5.4, 4.0, 7.0, 4.8), -8.0, origin="centroid"),
    ]
    cabinet = box(0.0, 5.6, 0.5, 6.8)
    pillar = rotate(box(4.35, 3.25, 4.75, 3.65), 30.0, origin="centroid")
    waypoints = [(1.0, 1.1), (8.0, 1.1), (8.0, 5.9), (1.2, 5.9), (1.2, 3.5), (3.9, 3.5), (3.9, 1.7)]
    return _make("sonar-office-v2", outer, [*desks, cabinet, pillar], waypoints)


def _clutter() -> PolygonWorld:
    room = box(0.0, 0.0, 7.0, 6.0)
    outer = _union([room, *_recesses((3.5,), 0.0, -0.15)])
    items = [
        ((1.8, 1.9), (0.5, 0.4), 15.0),
        ((3.2, 2.6), (0.6, 0.6), 40.0),
        ((5.0, 1.9), (0.4, 0.4), 0.0),
        ((5.6, 3.4), (0.7, 0.4), -25.0),
        ((2.2, 4.0), (0.4, 0.6), 10.0),
        ((3.9, 4.2), (0.5, 0.5), 60.0),
        ((6.5, 5.5), (0.5, 0.5), 0.0),
        ((0.3, 3.0), (0.4, 0.8), 0.0),
        ((4.6, 5.7), (0.8, 0.3), 0.0),
        ((2.6, 0.25), (0.6, 0.3), 0.0),
    ]
    holes = [
        rotate(box(x - w / 2, y - h / 2, x + w / 2, y + h / 2), a, origin="centroid")
        for (x, y), (w, h), a in items
    ]
    free_room = room.difference(shapely.union_all(holes))
    if not isinstance(free_room, Polygon):
        raise ConfigError("sonar-clutter-v2: clutter splits the room")
    waypoints = [(0.9, 0.9), (6.45, 0.9), (6.45, 4.6), (4.9, 4.9), (1.0, 5.2), (1.1, 2.5)]
    return _make("sonar-clutter-v2", outer, holes, waypoints)


def _lcorridor() -> PolygonWorld:
    leg_a = box(0.0, 0.0, 24.0, 1.8)
    leg_b = box(22.2, 0.0, 24.0, 14.0)
    along_a = _recesses((2.0, 5.0, 8.0, 11.0, 14.0, 17.0, 20.0), 1.8, 0.15)
    along_a += _recesses((3.5, 9.5, 15.5), 0.0, -0.15)
    along_b = [box(22.05, y - 0.45, 22.2, y + 0.45) for y in (4.0, 7.0, 10.0)]
    along_b += [box(24.0, y - 0.45, 24.15, y + 0.45) for y in (5.5, 11.5)]
    outer = _union([leg_a, leg_b, *along_a, *along_b])
    waypoints = [(0.8, 0.9), (23.1, 0.9), (23.1, 13.2), (23.1, 0.9), (0.8, 0.9)]
    return _make("sonar-lcorridor-v2", outer, [], waypoints)


def _openhall() -> PolygonWorld:
    outer = Polygon([(0.0, 0.0), (18.0, 0.0), (18.0, 9.0), (15.0, 12.0), (0.0, 12.0)])
    pillars = [
        rotate(box(x - 0.3, y - 0.3, x + 0.3, y + 0.3), a, origin="centroid")
        for x, y, a in ((5.0, 4.0, 0.0), (13.0, 4.0, 45.0), (5.0, 8.0, 45.0), (13.0, 8.0, 0.0))
    ]
    waypoints = [
        (2.0, 2.0),
        (16.0, 2.0),
        (16.0, 8.5),
        (9.0, 10.0),
        (2.0, 10.0),
        (2.0, 6.0),
        (9.0, 6.0),
        (9.0, 2.5),
    ]
    return _make("sonar-openhall-v2", outer, pillars, waypoints)


for _name, _factory in (
    ("sonar-corridor-v1", _corridor),
    ("sonar-room-v1", _room),
    ("sonar-hall-v1", _hall),
    ("sonar-doors-v2", _doors),
    ("sonar-office-v2", _office),
    ("sonar-clutter-v2", _clutter),
    ("sonar-lcorridor-v2", _lcorridor),
    ("sonar-openhall-v2", _openhall),
):
    register(_name, PolygonWorld, _factory)

REALISTIC_WORLDS: tuple[str, ...] = (
    "sonar-doors-v2",
    "sonar-office-v2",
    "sonar-clutter-v2",
    "sonar-lcorridor-v2",
    "sonar-openhall-v2",
)
"""The worlds with door recesses, furniture and clutter that ``reproduce sonar`` measures on."""


def random_building(rng: RNGLike = None) -> PolygonWorld:
    """A stress world nobody tuned on: a random corridor with recesses, side rooms and clutter.

    The corridor is 10–20 m long and 1.6–2.4 m wide, with door recesses (0.1–0.25 m deep,
    0.8–1.0 m wide) at random along both walls and one or two open doors into rooms of
    2.5–4 m, each holding a box at a random angle. The path runs along the corridor, into
    each room and back.
    """
    generator = as_generator(rng)
    length = float(generator.uniform(10.0, 20.0))
    width = float(generator.uniform(1.6, 2.4))
    parts: list[Polygon] = [box(0.0, 0.0, length, width)]
    for y, sign in ((0.0, -1.0), (width, 1.0)):
        x = float(generator.uniform(0.8, 2.5))
        while x < length - 1.0:
            depth = sign * float(generator.uniform(0.1, 0.25))
            parts += _recesses((x,), y, depth, float(generator.uniform(0.8, 1.0)))
            x += float(generator.uniform(1.8, 4.0))
    holes: list[Polygon] = []
    mid = width / 2
    waypoints: list[tuple[float, float]] = [(0.8, mid)]
    rooms = int(generator.integers(1, 3))
    spots = np.sort(generator.uniform(3.0, length - 3.0, size=rooms))
    for k, x in enumerate(spots):
        if k and x - spots[k - 1] < 4.5:
            continue
        side = 1.0 if generator.random() < 0.5 else -1.0
        size = float(generator.uniform(2.5, 4.0))
        wall = width if side > 0 else 0.0
        door = box(x - 0.45, min(wall, wall + side * 0.3), x + 0.45, max(wall, wall + side * 0.3))
        near, far = wall + side * 0.3, wall + side * (0.3 + size)
        room = box(x - size / 2, min(near, far), x + size / 2, max(near, far))
        parts += [door, room]
        centre = (x + size / 4, (near + far) / 2)
        angle = float(generator.uniform(0.0, 90.0))
        holes.append(
            rotate(box(centre[0] - 0.3, centre[1] - 0.2, centre[0] + 0.3, centre[1] + 0.2), angle)
        )
        inside = near + side * min(1.0, size / 3)
        waypoints += [(float(x), mid), (float(x), inside), (float(x), mid)]
    waypoints.append((length - 0.8, mid))
    outer = shapely.union_all(parts)
    if not isinstance(outer, Polygon):
        raise ConfigError("random building: the outline split (unlucky draw); use another seed")
    return _make("sonar-random-building", outer, holes, waypoints)


def _scatter(
    generator: np.random.Generator,
    room: Polygon,
    path: shapely.LineString,
    sizes: list[tuple[float, float]],
    angle: tuple[float, float],
    clearance: float,
) -> list[Polygon]:
    """Place boxes of ``sizes`` [m] at random in ``room``, ``clearance`` [m] off ``path``.

    Each box turns by a uniform angle in ``angle`` [deg], keeps ``clearance`` from the
    path, the room's walls and every box placed before it, and is drawn again (up to 50
    times, then left out) where it does not fit.
    """
    x0, y0, x1, y1 = room.bounds
    placed: list[Polygon] = []
    inner = room.buffer(-clearance)
    for w, h in sizes:
        for _ in range(50):
            x = float(generator.uniform(x0, x1))
            y = float(generator.uniform(y0, y1))
            turn = float(generator.uniform(*angle))
            item = rotate(box(x - w / 2, y - h / 2, x + w / 2, y + h / 2), turn, origin="centroid")
            if (
                inner.contains(item)
                and item.distance(path) > clearance
                and all(item.distance(other) > clearance for other in placed)
            ):
                placed.append(item)
                break
    return placed


def random_hall(rng: RNGLike = None) -> PolygonWorld:
    """A stress world nobody tuned on: an open hall with pillars and clutter.

    The hall is 12–22 m by 8–14 m, with a chamfered corner (1–4 m) half the time; 2–6
    pillars (0.4–0.8 m square, at any angle) and 0–4 boxes or bins (0.3–1.2 m) stand at
    random, at least 0.7 m off the path (those that do not fit are left out). The path is
    a loop 1.5–3 m inside the walls with a leg across the middle, so most walls are
    farther than the sonars reach from much of it (the logs add people walking through).
    """
    generator = as_generator(rng)
    length = float(generator.uniform(12.0, 22.0))
    depth = float(generator.uniform(8.0, 14.0))
    corners = [(0.0, 0.0), (length, 0.0), (length, depth), (0.0, depth)]
    if generator.random() < 0.5:
        cut = float(generator.uniform(1.0, 4.0))
        corners[2:3] = [(length, depth - cut), (length - cut, depth)]
    outer = Polygon(corners)
    inset = float(generator.uniform(1.5, 3.0))
    middle = float(generator.uniform(0.4, 0.6)) * length
    waypoints = [
        (inset, inset),
        (length - inset, inset),
        (length - inset, depth - inset - 1.0),
        (middle, depth - inset),
        (inset, depth - inset),
        (inset, depth / 2),
        (middle, depth / 2),
        (middle, inset + 0.5),
    ]
    path = shapely.LineString([*waypoints, waypoints[0]])
    pillars = [(side, side) for side in generator.uniform(0.4, 0.8, size=generator.integers(2, 7))]
    clutter = [
        tuple(pair) for pair in generator.uniform(0.3, 1.2, size=(generator.integers(0, 5), 2))
    ]
    holes = _scatter(generator, outer, path, [*pillars, *clutter], (0.0, 90.0), 0.7)
    return _make("sonar-random-hall", outer, holes, waypoints)


def random_office(rng: RNGLike = None) -> PolygonWorld:
    """A stress world nobody tuned on: an office with desks, cabinets and door recesses.

    The room is 7–12 m by 6–9 m with 1–4 door recesses (0.1–0.25 m deep) in its walls;
    of 3–7 desks (1.2–1.8 m by 0.6–0.9 m, turned up to ±10° from the walls' directions)
    and 0–2 cabinets (0.4–0.6 m by 0.8–1.4 m) drawn, those that fit stand at random at
    least 0.5 m off the path (a loop 1–1.5 m inside the walls with a leg across the
    middle), from the walls and from each other — in a small room, often only one or two.
    """
    generator = as_generator(rng)
    length = float(generator.uniform(7.0, 12.0))
    depth = float(generator.uniform(6.0, 9.0))
    room = box(0.0, 0.0, length, depth)
    recesses: list[Polygon] = []
    for _ in range(int(generator.integers(1, 5))):
        x = float(generator.uniform(1.0, length - 1.0))
        wall, sign = (0.0, -1.0) if generator.random() < 0.5 else (depth, 1.0)
        recesses += _recesses((x,), wall, sign * float(generator.uniform(0.1, 0.25)))
    outer = _union([room, *recesses])
    inset = float(generator.uniform(1.0, 1.5))
    middle = depth / 2
    waypoints = [
        (inset, inset),
        (length - inset, inset),
        (length - inset, depth - inset),
        (inset, depth - inset),
        (inset, middle),
        (length / 2, middle),
        (length / 2, inset + 0.6),
    ]
    path = shapely.LineString([*waypoints, waypoints[0]])
    desks = [
        (float(generator.uniform(1.2, 1.8)), float(generator.uniform(0.6, 0.9)))
        for _ in range(int(generator.integers(3, 8)))
    ]
    cabinets = [
        (float(generator.uniform(0.4, 0.6)), float(generator.uniform(0.8, 1.4)))
        for _ in range(int(generator.integers(0, 3)))
    ]
    turn = (-10.0, 10.0) if generator.random() < 0.5 else (80.0, 100.0)
    holes = _scatter(generator, room, path, [*desks, *cabinets], turn, 0.5)
    return _make("sonar-random-office", outer, holes, waypoints)


def world(name: str) -> PolygonWorld:
    """Build the registered world ``name``; :class:`ConfigError` if unknown.

    The registry is :mod:`bayesmap.sim.scenarios`.
    """
    return scenario(name, PolygonWorld)


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
