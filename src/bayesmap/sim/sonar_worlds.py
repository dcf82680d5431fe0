"""Sonar world files (``WORLD.json``): polygon worlds of smooth walls, read, written, generated.

A world file holds the outline of the free space, the solid obstacles inside it and the
robot's closed waypoint path, all in metres::

    {"name": "my-corridor",
     "outline": [[0, 0], [12, 0], [12, 2], [0, 2]],
     "obstacles": [[[5, 0.8], [5.6, 0.8], [5.6, 1.2], [5, 1.2]]],
     "waypoints": [[0.8, 1.0], [11.2, 1.0]]}

The outline and each obstacle are simple polygons of positive area, and an obstacle must
touch the outline (one wholly outside it is most likely in another unit). The free space is
the outline minus the obstacles; it must be one connected region, and every waypoint must
lie in it. Every wall is acoustically smooth (see
:mod:`bayesmap.sim.sonar`). :func:`generate_world` draws the random buildings of
:func:`bayesmap.sim.polygons.random_building`. Every failure to read a file is a
:class:`~bayesmap.errors.FormatError` naming the file and the element.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from shapely.geometry import Polygon

from bayesmap._io import write_json
from bayesmap._rng import RNGLike, as_generator
from bayesmap.errors import ConfigError, FormatError
from bayesmap.sim.polygons import PolygonWorld, _make, random_building
from bayesmap.sim.world_files import check_schema, polygon_problem, read_document

__all__ = ["WORLD_SCHEMA", "generate_world", "load_world", "parse_world", "save_world", "to_json"]

_POINT = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}
_RING = {"type": "array", "items": _POINT, "minItems": 3}
WORLD_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "bayesmap sonar world",
    "type": "object",
    "required": ["outline", "waypoints"],
    "additionalProperties": False,
    "properties": {
        "name": {"type": "string", "description": "Name recorded by every result."},
        "outline": {**_RING, "description": "Outer walls [m], a simple polygon."},
        "obstacles": {
            "type": "array",
            "items": _RING,
            "description": "Solid obstacles [m] inside the outline.",
        },
        "waypoints": {
            "type": "array",
            "items": _POINT,
            "minItems": 2,
            "description": "Closed path [m] the robot drives.",
        },
    },
}
"""JSON Schema (draft 2020-12) of a sonar world file."""

GENERATOR_ATTEMPTS = 20
"""Draws :func:`generate_world` makes before giving up on a building that will not join."""


def to_json(world: PolygonWorld) -> dict[str, Any]:
    """The world file's JSON object of ``world`` (the inverse of :func:`parse_world`)."""
    return {
        "name": world.name,
        "outline": np.asarray(world.free.exterior.coords)[:-1].tolist(),
        "obstacles": [np.asarray(ring.coords)[:-1].tolist() for ring in world.free.interiors],
        "waypoints": np.asarray(world.waypoints).tolist(),
    }


def parse_world(obj: Any, source: str = "world") -> PolygonWorld:
    """Check a world file's JSON object against :data:`WORLD_SCHEMA` and the geometry.

    Raises
    ------
    FormatError
        Naming ``source`` and the offending element.
    """
    check_schema(obj, WORLD_SCHEMA, source)
    outline = _polygon(obj["outline"], "outline", source)
    holes = []
    for k, ring in enumerate(obj.get("obstacles", [])):
        hole = _polygon(ring, f"obstacles[{k}]", source)
        if not hole.intersects(outline):
            raise FormatError(
                "lies wholly outside the outline (are its vertices in another unit?)",
                path=source,
                element=f"obstacles[{k}]",
            )
        holes.append(hole)
    name = str(obj.get("name", Path(source).stem))
    try:
        return _make(name, outline, holes, [tuple(p) for p in obj["waypoints"]])
    except ConfigError as error:
        raise FormatError(str(error), path=source) from None


def _polygon(ring: list[list[float]], element: str, source: str) -> Polygon:
    """A simple polygon of positive area, or a :class:`FormatError` saying what is wrong."""
    polygon = Polygon(ring)
    problem = polygon_problem(polygon)
    if problem is not None:
        raise FormatError(problem, path=source, element=element)
    return polygon


def load_world(path: str | Path) -> PolygonWorld:
    """Read and check a world file; :class:`FormatError` naming the file and element if bad."""
    return parse_world(read_document(path), str(Path(path)))


def save_world(world: PolygonWorld, path: str | Path) -> Path:
    """Write ``world`` as a world file, atomically."""
    return write_json(path, to_json(world))


def generate_world(rng: RNGLike = None) -> PolygonWorld:
    """A random building (:func:`~bayesmap.sim.polygons.random_building`) drawn from ``rng``
    (a seed or a generator).

    A draw whose rooms do not join the corridor is drawn again from the same generator,
    up to :data:`GENERATOR_ATTEMPTS` times.
    """
    generator = as_generator(rng)
    for _ in range(GENERATOR_ATTEMPTS - 1):
        try:
            return random_building(generator)
        except ConfigError:
            continue
    return random_building(generator)
