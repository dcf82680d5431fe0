"""Rover world files (``WORLD.json``) and a generator of stress worlds.

A world file is JSON checked against :data:`WORLD_SCHEMA`::

    {"size": [20.0, 20.0], "resolution": 0.5,
     "obstacles": [[[14.0, 16.0], [15.0, 16.0], [15.0, 17.0], [14.0, 17.0]]],
     "start": [1.0, 1.0, 0.0]}

``size`` is the mapped area [m] (lower-left corner at the origin), ``resolution`` the map's
cell side [m], ``obstacles`` polygons in metres and ``start`` the rover's ``x, y`` [m] and
heading [rad]. An obstacle may be any simple polygon of positive area, convex or not
(axis-aligned rectangles are kept as boxes, for the fast ray caster); a self-intersecting or
degenerate one is refused with a :class:`~bayesmap.errors.FormatError` naming it.

:func:`generate_world` draws worlds from walls, L-shapes, corridors, walls with a narrow
passage (at least 1.2 m wide), random boxes, and boxes and walls at any angle, on 20–60 m
areas, keeping at least
``passage`` metres between separate obstacles and from the edge of the area.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from bayesmap._io import write_json
from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import FloatArray
from bayesmap.errors import ConfigError, FormatError
from bayesmap.limits import cell_side_problem
from bayesmap.sim.world2d import BoxWorld, world_distance
from bayesmap.sim.world_files import check_schema, polygon_problem, read_document

__all__ = [
    "FINEST_CELL_SIDE",
    "MAX_WORLD_SIDE",
    "WORLD_SCHEMA",
    "WorldSpec",
    "generate_world",
    "load_world",
    "rover_cell_side_problem",
    "save_world",
]

logger = logging.getLogger(__name__)

MAX_WORLD_SIDE = 200.0
"""Longest side [m] of a rover world. Setting a world up rasterises its free space at
0.1 m to find the ground the rangers can see (:func:`bayesmap.sim.rover.observable_cells`):
a 200 m world takes about 15 s and 0.3 GB before the first cycle, and both grow with the
area; a longer side is most likely given in cm or mm."""

FINEST_CELL_SIDE = 0.1
"""Finest map cell side [m] the rover accepts. Looking for a viewpoint of a target
(:func:`bayesmap.rover.planning.view_costs`) tries every cell within the rangers' reach
and checks the line of sight, so a cycle's cost grows with about the fifth power of one
over the cell side: 200 cycles of a 20 m world took 6.6 s on the paper's 0.5 m grid, 8.3 s
at 0.25 m and 33 s at 0.1 m; 20 cycles at 0.05 m took 42 s."""

WORLD_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "bayesmap rover world",
    "type": "object",
    "required": ["size", "obstacles", "start"],
    "additionalProperties": False,
    "properties": {
        "name": {"type": "string", "description": "Name recorded by every result."},
        "size": {
            "description": "Width and height of the mapped area [m]; its corner is (0, 0).",
            "type": "array",
            "items": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_WORLD_SIDE},
            "minItems": 2,
            "maxItems": 2,
        },
        "resolution": {
            "description": "Cell side of the map [m], 0.1–2 (FINEST_CELL_SIDE, "
            "bayesmap.limits.MAX_CELL_SIDE).",
            "type": "number",
            "exclusiveMinimum": 0,
            "default": 0.5,
        },
        "obstacles": {
            "description": "Obstacles: simple polygons [m] (convex or not), vertices in order.",
            "type": "array",
            "items": {
                "type": "array",
                "minItems": 3,
                "items": {
                    "type": "array",
                    "items": {"type": "number"},
                    "minItems": 2,
                    "maxItems": 2,
                },
            },
        },
        "start": {
            "description": "Rover start: x [m], y [m], heading [rad].",
            "type": "array",
            "items": {"type": "number"},
            "minItems": 3,
            "maxItems": 3,
        },
    },
}
"""JSON Schema (draft 2020-12) of a rover world file."""

FILE_DIGITS = 3
"""Decimals of a metre a world file keeps: millimetres."""

START_CLEARANCE = 0.5
"""A start must be at least this far [m] from every obstacle."""


@dataclass(frozen=True)
class WorldSpec:
    """A rover world: the field with its boxes, the map resolution and the start pose."""

    world: BoxWorld
    resolution: float
    start: tuple[float, float, float]

    def to_json(self) -> dict[str, Any]:
        """The world as a JSON document that :func:`load_world` reads back.

        Lengths are written to the millimetre (:data:`FILE_DIGITS` decimals of a metre), the
        start heading to the microradian.
        """
        polygons = [
            [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
            for x0, y0, x1, y1 in np.round(self.world.boxes, FILE_DIGITS).tolist()
        ] + [np.round(p, FILE_DIGITS).tolist() for p in self.world.polygons]
        x, y, heading = self.start
        return {
            "name": self.world.name,
            "size": [round(self.world.width, FILE_DIGITS), round(self.world.height, FILE_DIGITS)],
            "resolution": self.resolution,
            "obstacles": polygons,
            "start": [round(x, FILE_DIGITS), round(y, FILE_DIGITS), round(heading, 6)],
        }


def _rectangle(corners: list[tuple[float, float]]) -> tuple[float, ...] | None:
    """``(xmin, ymin, xmax, ymax)`` when the corners form an axis-aligned rectangle."""
    xs = sorted({x for x, _ in corners})
    ys = sorted({y for _, y in corners})
    ring = corners + corners[:1]
    rectangle = (
        len(corners) == 4
        and len(xs) == 2
        and len(ys) == 2
        and set(corners) == {(x, y) for x in xs for y in ys}
        and all((a[0] == b[0]) != (a[1] == b[1]) for a, b in zip(ring, ring[1:], strict=False))
    )
    return (xs[0], ys[0], xs[1], ys[1]) if rectangle else None


def _obstacle(polygon: list[list[float]], where: str, path: Path) -> tuple[float, ...] | FloatArray:
    """A box ``(xmin, ymin, xmax, ymax)`` for an axis-aligned rectangle, else the checked
    ``(v, 2)`` vertices of a simple polygon of positive area (convex or not)."""
    corners = [(float(x), float(y)) for x, y in polygon]
    if len(corners) > 3 and corners[0] == corners[-1]:
        corners = corners[:-1]
    if not all(math.isfinite(v) for corner in corners for v in corner):
        raise FormatError("has a vertex that is not a finite number", path=path, element=where)
    box = _rectangle(corners)
    if box is not None:
        return box
    problem = polygon_problem(shapely.Polygon(corners))
    if problem is not None:
        raise FormatError(problem, path=path, element=where)
    return np.asarray(corners, dtype=np.float64)


def load_world(path: str | Path) -> WorldSpec:
    """Read and check a world file; :class:`FormatError` naming the file and field if bad."""
    file = Path(path)
    document = read_document(file)
    check_schema(document, WORLD_SCHEMA, file)
    width, height = (float(v) for v in document["size"])
    obstacles = [
        _obstacle(polygon, f"obstacles[{k}]", file)
        for k, polygon in enumerate(document["obstacles"])
    ]
    boxes = np.array([o for o in obstacles if isinstance(o, tuple)], dtype=np.float64)
    polygons = tuple(o for o in obstacles if not isinstance(o, tuple))
    x, y, heading = (float(v) for v in document["start"])
    if not (0.0 <= x <= width and 0.0 <= y <= height):
        raise FormatError(f"start ({x}, {y}) lies outside the {width} x {height} m area", path=file)
    name = str(document.get("name", file.stem))
    world = BoxWorld(name, width, height, boxes.reshape(-1, 4), polygons)
    if world_distance(world, x, y) < START_CLEARANCE:
        raise FormatError(
            f"start ({x}, {y}) is within {START_CLEARANCE} m of an obstacle", path=file
        )
    resolution = float(document.get("resolution", 0.5))
    problem = rover_cell_side_problem(resolution)
    if problem is not None:
        raise FormatError(f"the cell side {problem}", path=file, element="resolution")
    mapped = [max(round(side / resolution), 1) * resolution for side in (width, height)]
    if any(m < side - 1e-6 for m, side in zip(mapped, (width, height), strict=True)):
        logger.warning(
            "%s: the %g x %g m area is not a whole number of %g m cells; the map covers "
            "only %g x %g m of it (the rest is never mapped)",
            file,
            width,
            height,
            resolution,
            *mapped,
        )
    for k, obstacle in enumerate(obstacles):
        x0, y0, x1, y1 = _bounds(obstacle)
        if x1 < 0.0 or y1 < 0.0 or x0 > width or y0 > height:
            logger.warning(
                "%s, obstacles[%d]: lies wholly outside the %g x %g m area (corner at 0, 0), "
                "so the rover never meets it; are its vertices in cm or mm?",
                file,
                k,
                width,
                height,
            )
    return WorldSpec(world, resolution, (x, y, heading))


def rover_cell_side_problem(resolution: float) -> str | None:
    """What is wrong with ``resolution`` as the rover's map cell side [m], or ``None``:
    :func:`bayesmap.limits.cell_side_problem`, and no finer than :data:`FINEST_CELL_SIDE`."""
    problem = cell_side_problem(resolution)
    if problem is None and resolution < FINEST_CELL_SIDE:
        problem = (
            f"is {resolution:g} m, finer than the {FINEST_CELL_SIDE:g} m the rover can plan "
            "on (its planning cost grows with the fifth power of one over the cell side; "
            "the paper's grid is 0.5 m)"
        )
    return problem


def _bounds(obstacle: tuple[float, ...] | FloatArray) -> tuple[float, float, float, float]:
    """``(xmin, ymin, xmax, ymax)`` of a box or a polygon's vertices."""
    if isinstance(obstacle, tuple):
        x0, y0, x1, y1 = obstacle
        return x0, y0, x1, y1
    (x0, y0), (x1, y1) = obstacle.min(axis=0), obstacle.max(axis=0)
    return float(x0), float(y0), float(x1), float(y1)


def save_world(path: str | Path, spec: WorldSpec) -> Path:
    """Write ``spec`` as a world file (atomically)."""
    return write_json(Path(path), spec.to_json())


def _wall(rng: np.random.Generator, x: float, y: float, length: float) -> FloatArray:
    thickness = rng.uniform(0.3, 0.6)
    if rng.uniform() < 0.5:
        return np.array([[x, y, x + length, y + thickness]])
    return np.array([[x, y, x + thickness, y + length]])


Group = tuple[FloatArray, tuple[FloatArray, ...]]
"""An obstacle group: ``(k, 4)`` boxes and polygons (``(v, 2)`` vertices)."""


def _tilted(rng: np.random.Generator, x: float, y: float) -> FloatArray:
    """A box of sides 0.5–2 m (or a wall 3–6 m by 0.3–0.6 m) at any angle, lower-left near
    ``(x, y)`` [m]."""
    if rng.uniform() < 0.5:
        sides = rng.uniform(0.5, 2.0, size=2)
    else:
        sides = np.array([rng.uniform(3.0, 6.0), rng.uniform(0.3, 0.6)])
    angle = rng.uniform(0.0, math.pi)
    c, s = math.cos(angle), math.sin(angle)
    corners = np.array([[0, 0], [sides[0], 0], [sides[0], sides[1]], [0, sides[1]]])
    turned = corners @ np.array([[c, s], [-s, c]])
    return np.asarray(turned - turned.min(axis=0) + np.array([x, y]))


def _group(rng: np.random.Generator, kind: str, x: float, y: float, passage: float) -> Group:
    """One obstacle group with its lower-left near ``(x, y)`` [m]."""
    if kind == "tilted":
        return np.zeros((0, 4)), (_tilted(rng, x, y),)
    length = rng.uniform(3.0, 8.0)
    t = rng.uniform(0.3, 0.6)
    if kind == "wall":
        return _wall(rng, x, y, length), ()
    if kind == "l-shape":
        other = rng.uniform(2.0, 5.0)
        return np.array([[x, y, x + length, y + t], [x, y, x + t, y + other]]), ()
    if kind == "corridor":
        gap = rng.uniform(passage, 2.5)
        if rng.uniform() < 0.5:
            return np.array(
                [[x, y, x + length, y + t], [x, y + t + gap, x + length, y + 2 * t + gap]]
            ), ()
        return np.array(
            [[x, y, x + t, y + length], [x + t + gap, y, x + 2 * t + gap, y + length]]
        ), ()
    if kind == "passage":
        gap = rng.uniform(passage, 2.0)
        half = length / 2
        if rng.uniform() < 0.5:
            return np.array(
                [[x, y, x + half, y + t], [x + half + gap, y, x + length + gap, y + t]]
            ), ()
        return np.array([[x, y, x + t, y + half], [x, y + half + gap, x + t, y + length + gap]]), ()
    side = rng.uniform(0.5, 2.0, size=2)
    return np.array([[x, y, x + side[0], y + side[1]]]), ()


def _shape(group: Group) -> shapely.Geometry:
    boxes, polygons = group
    parts = [shapely.box(*b) for b in boxes] + [shapely.Polygon(p) for p in polygons]
    return shapely.union_all(parts)


GENERATED_SIDES = (5.0, MAX_WORLD_SIDE)
"""Sides [m] a generated world may have: below 5 m the 1.2 m passages leave no room for an
obstacle; above :data:`MAX_WORLD_SIDE` a rover world is refused (placing the obstacle
groups of a 200 m world already takes a while; the rover's speed is measured on fields of
20 and 200 m)."""


def generate_world(
    rng: RNGLike = None,
    *,
    size: float | None = None,
    n_groups: int | None = None,
    passage: float = 1.2,
    resolution: float = 0.5,
    name: str = "rover-generated-v2",
) -> WorldSpec:
    """Draw a stress world: walls, L-shapes, corridors, narrow passages, random boxes, and
    boxes and walls at any angle (polygons).

    Version 2 of the generator (``v1`` had no tilted obstacles).

    Parameters
    ----------
    rng
        Seed or generator.
    size
        Side of the square area [m], within :data:`GENERATED_SIDES`; drawn from 20–60 m
        when ``None``.
    n_groups
        Obstacle groups to place; about one per 40 m² when ``None``.
    passage
        Narrowest gap [m] left between separate obstacles, inside corridors and passages,
        and between an obstacle and the edge of the area (at least 1.2 m by default).
    resolution
        Map cell side [m] recorded in the world.
    name
        Versioned name recorded by results.
    """
    if size is not None and not GENERATED_SIDES[0] <= size <= GENERATED_SIDES[1]:
        raise ConfigError(
            f"a generated world's side must be {GENERATED_SIDES[0]:g}–{GENERATED_SIDES[1]:g} m, "
            f"got {size!r}"
        )
    problem = rover_cell_side_problem(resolution)
    if problem is not None:
        raise ConfigError(f"a generated world's cell side {problem}")
    generator = as_generator(rng)
    side = float(generator.uniform(20.0, 60.0)) if size is None else float(size)
    wanted = max(int(side * side / 40.0), 3) if n_groups is None else n_groups
    kinds = ("wall", "l-shape", "corridor", "passage", "box", "tilted")
    start = (1.0, 1.0, float(generator.uniform(-math.pi, math.pi)))
    groups: list[Group] = []
    shapes: list[shapely.Geometry] = []
    area = shapely.box(passage, passage, side - passage, side - passage)
    here = shapely.Point(start[0], start[1])
    for _ in range(wanted * 20):
        if len(groups) == wanted:
            break
        x, y = generator.uniform(passage, side - passage, size=2)
        group = _group(generator, str(generator.choice(kinds)), float(x), float(y), passage)
        shape = _shape(group)
        inside = area.contains(shape)
        apart = all(shapely.distance(shape, other) >= passage for other in shapes)
        if inside and apart and shapely.distance(shape, here) >= passage + 0.5:
            groups.append(group)
            shapes.append(shape)
    boxes = np.vstack([g[0] for g in groups] + [np.zeros((0, 4))])
    polygons = tuple(p for g in groups for p in g[1])
    return WorldSpec(BoxWorld(name, side, side, boxes, polygons), resolution, start)
