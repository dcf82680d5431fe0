"""Bounded 2-D worlds with box and polygon obstacles, under versioned names.

A world is a rectangle ``[0, width] x [0, height]`` [m] (the mapped area; nothing stops a
robot from leaving it) holding boxes ``(xmin, ymin, xmax, ymax)`` [m] and polygons (any
simple polygon, convex or not, as its vertices [m]). Boxes have a fast slab ray caster;
polygons are cast against their edges. The ``world_*`` functions take both.

Registered worlds (Post et al. 2016 §5):

- ``"rover-field-empty-v1"``: the 20 m x 20 m field with no obstacles (§5.2);
- ``"rover-field-obstacles-v1"``: the same field with two 1 m x 1 m boxes centred at
  (14, 16) and (7, 10) and a 0.5 m x 1 m box centred at (12.5, 3) (§5.3).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.geometry import cast_on_boxes, cast_on_segments
from bayesmap.sim.scenarios import register, scenario

__all__ = [
    "BoxWorld",
    "box_distance",
    "box_world",
    "circle_hits",
    "occupancy_truth",
    "world_distance",
    "world_ray_cast",
    "world_truth",
]


@dataclass(frozen=True)
class BoxWorld:
    """A rectangular field with box obstacles.

    Attributes
    ----------
    name
        Versioned name (e.g. ``"rover-field-obstacles-v1"``).
    width, height
        Size of the field [m]; its lower-left corner is the origin.
    boxes
        ``(k, 4)`` obstacles ``(xmin, ymin, xmax, ymax)`` [m].
    polygons
        Further obstacles, each a ``(v, 2)`` array of a simple polygon's vertices [m].
    """

    name: str
    width: float
    height: float
    boxes: FloatArray
    polygons: tuple[FloatArray, ...] = ()

    @functools.cached_property
    def segments(self) -> FloatArray:
        """``(n, 4)`` edges ``(x0, y0, x1, y1)`` [m] of all the polygons."""
        edges = [np.hstack([p, np.roll(p, -1, axis=0)]) for p in self.polygons]
        return np.vstack(edges) if edges else np.zeros((0, 4))

    @functools.cached_property
    def solid(self) -> shapely.Geometry:
        """The polygons as one shapely geometry (empty without polygons)."""
        return shapely.union_all([shapely.Polygon(p) for p in self.polygons])

    @property
    def n_obstacles(self) -> int:
        """Boxes plus polygons."""
        return int(self.boxes.shape[0]) + len(self.polygons)


def _centred(cx: float, cy: float, sx: float, sy: float) -> tuple[float, float, float, float]:
    return (cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2)


_FIELDS = (
    BoxWorld("rover-field-empty-v1", 20.0, 20.0, np.zeros((0, 4))),
    BoxWorld(
        "rover-field-obstacles-v1",
        20.0,
        20.0,
        np.array(
            [
                _centred(14.0, 16.0, 1.0, 1.0),
                _centred(7.0, 10.0, 1.0, 1.0),
                _centred(12.5, 3.0, 0.5, 1.0),
            ]
        ),
    ),
)


def _constant(world: BoxWorld) -> Callable[[], BoxWorld]:
    def factory() -> BoxWorld:
        return world

    return factory


for _field in _FIELDS:
    register(_field.name, BoxWorld, _constant(_field))


def box_world(name: str) -> BoxWorld:
    """The registered world ``name``; :class:`ConfigError` if there is none.

    The registry is :mod:`bayesmap.sim.scenarios`.
    """
    return scenario(name, BoxWorld)


def box_distance(boxes: npt.ArrayLike, x: float, y: float) -> float:
    """Distance [m] from ``(x, y)`` to the nearest box (0 inside one, ``inf`` with none)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if b.shape[0] == 0:
        return math.inf
    nx = np.clip(x, b[:, 0], b[:, 2])
    ny = np.clip(y, b[:, 1], b[:, 3])
    return float(np.min(np.hypot(nx - x, ny - y)))


def circle_hits(boxes: npt.ArrayLike, x: float, y: float, radius: float) -> bool:
    """Whether a disc of ``radius`` [m] at ``(x, y)`` touches any box."""
    return box_distance(boxes, x, y) <= radius


def occupancy_truth(
    boxes: npt.ArrayLike, shape: tuple[int, int], resolution: float, origin: tuple[float, float]
) -> BoolArray:
    """``(ny, nx)`` cells (row = y) that overlap a box by a positive area: the ground truth."""
    ny, nx = shape
    x0 = origin[0] + np.arange(nx) * resolution
    y0 = origin[1] + np.arange(ny) * resolution
    truth = np.zeros(shape, dtype=bool)
    for xmin, ymin, xmax, ymax in np.asarray(boxes, dtype=np.float64).reshape(-1, 4):
        cols = (x0 < xmax) & (x0 + resolution > xmin)
        rows = (y0 < ymax) & (y0 + resolution > ymin)
        truth |= rows[:, None] & cols[None, :]
    return truth


def world_ray_cast(world: BoxWorld, origins: npt.ArrayLike, angles: npt.ArrayLike) -> FloatArray:
    """Distance [m] along each ray to the first box or polygon edge (``inf`` if none)."""
    d = cast_on_boxes(world.boxes, origins, angles)
    if world.polygons:
        a = np.asarray(angles, dtype=np.float64).reshape(-1)
        directions = np.column_stack([np.cos(a), np.sin(a)])
        on_edges, _ = cast_on_segments(
            np.asarray(origins, dtype=np.float64).reshape(-1, 2), directions, world.segments
        )
        d = np.minimum(d, on_edges)
    return d


def world_distance(world: BoxWorld, x: float, y: float) -> float:
    """Distance [m] from ``(x, y)`` to the nearest obstacle (0 inside one, ``inf`` with none)."""
    d = box_distance(world.boxes, x, y)
    if world.polygons:
        d = min(d, float(shapely.distance(world.solid, shapely.Point(x, y))))
    return d


def world_truth(
    world: BoxWorld, shape: tuple[int, int], resolution: float, origin: tuple[float, float]
) -> BoolArray:
    """``(ny, nx)`` cells that overlap a box or a polygon by a positive area."""
    truth = occupancy_truth(world.boxes, shape, resolution, origin)
    for polygon in world.polygons:
        xmin, ymin = polygon.min(axis=0)
        xmax, ymax = polygon.max(axis=0)
        c0 = max(int(math.floor((xmin - origin[0]) / resolution)), 0)
        r0 = max(int(math.floor((ymin - origin[1]) / resolution)), 0)
        c1 = min(int(math.ceil((xmax - origin[0]) / resolution)), shape[1])
        r1 = min(int(math.ceil((ymax - origin[1]) / resolution)), shape[0])
        if c1 <= c0 or r1 <= r0:
            continue
        rows, cols = np.mgrid[r0:r1, c0:c1]
        x0 = origin[0] + cols * resolution
        y0 = origin[1] + rows * resolution
        cells = shapely.box(x0, y0, x0 + resolution, y0 + resolution)
        area = shapely.area(shapely.intersection(cells, shapely.Polygon(polygon)))
        truth[r0:r1, c0:c1] |= area > 1e-9 * resolution**2
    return truth
