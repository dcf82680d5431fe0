"""Rover world files (``WORLD.json``) and a generator of stress worlds.

A world file is JSON checked against :data:`WORLD_SCHEMA`::

    {"size": [20.0, 20.0], "resolution": 0.5,
     "obstacles": [[[14.0, 16.0], [15.0, 16.0], [15.0, 17.0], [14.0, 17.0]]],
     "start": [1.0, 1.0, 0.0]}

``size`` is the mapped area [m] (lower-left corner at the origin), ``resolution`` the map's
cell side [m], ``obstacles`` polygons in metres and ``start`` the rover's ``x, y`` [m] and
heading [rad]. The rover simulator's ray caster works on axis-aligned boxes, so every
polygon must be an axis-aligned rectangle (an L-shape is written as two overlapping
rectangles); anything else is refused with a :class:`~bayesmap.errors.FormatError`.

:func:`generate_world` draws worlds from walls, L-shapes, corridors, walls with a narrow
passage (at least 1.2 m wide) and random boxes, on 20–60 m areas, keeping at least
``passage`` metres between separate obstacles and from the edge of the area.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jsonschema
import numpy as np

from bayesmap._io import write_json
from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import FloatArray
from bayesmap.errors import FormatError
from bayesmap.sim.world2d import BoxWorld, box_distance

__all__ = ["WORLD_SCHEMA", "WorldSpec", "generate_world", "load_world", "save_world"]

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
            "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 10000},
            "minItems": 2,
            "maxItems": 2,
        },
        "resolution": {
            "description": "Cell side of the map [m].",
            "type": "number",
            "exclusiveMinimum": 0,
            "default": 0.5,
        },
        "obstacles": {
            "description": "Polygons [m]; each an axis-aligned rectangle of 4 corners.",
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

START_CLEARANCE = 0.5
"""A start must be at least this far [m] from every obstacle."""


@dataclass(frozen=True)
class WorldSpec:
    """A rover world: the field with its boxes, the map resolution and the start pose."""

    world: BoxWorld
    resolution: float
    start: tuple[float, float, float]

    def to_json(self) -> dict[str, Any]:
        """The world as a JSON document that :func:`load_world` reads back."""
        polygons = [
            [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
            for x0, y0, x1, y1 in np.round(self.world.boxes, 4).tolist()
        ]
        return {
            "name": self.world.name,
            "size": [self.world.width, self.world.height],
            "resolution": self.resolution,
            "obstacles": polygons,
            "start": [round(v, 6) for v in self.start],
        }


def _rectangle(polygon: list[list[float]], where: str, path: Path) -> tuple[float, ...]:
    """``(xmin, ymin, xmax, ymax)`` of an axis-aligned rectangle given by its 4 corners."""
    corners = [tuple(corner) for corner in polygon]
    if len(corners) == 5 and corners[0] == corners[-1]:
        corners = corners[:4]
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
    if not rectangle:
        raise FormatError(
            f"{where} must be an axis-aligned rectangle of 4 corners (split other shapes "
            "into rectangles)",
            path=path,
            element=where,
        )
    return (xs[0], ys[0], xs[1], ys[1])


def load_world(path: str | Path) -> WorldSpec:
    """Read and check a world file; :class:`FormatError` naming the file and field if bad."""
    file = Path(path)
    try:
        document = json.loads(file.read_text(encoding="utf-8"))
    except OSError as error:
        raise FormatError(f"cannot read the world file ({error.strerror})", path=file) from None
    except UnicodeDecodeError:
        raise FormatError("the world file is not UTF-8 text", path=file) from None
    except json.JSONDecodeError as error:
        raise FormatError(f"not JSON: {error.msg}", path=file, line=error.lineno) from None
    try:
        jsonschema.validate(document, WORLD_SCHEMA)
    except jsonschema.ValidationError as error:
        where = "/".join(str(part) for part in error.absolute_path) or "the document"
        raise FormatError(error.message, path=file, element=where) from None
    width, height = (float(v) for v in document["size"])
    boxes = np.array(
        [
            _rectangle(polygon, f"obstacles/{k}", file)
            for k, polygon in enumerate(document["obstacles"])
        ],
        dtype=np.float64,
    ).reshape(-1, 4)
    x, y, heading = (float(v) for v in document["start"])
    if not (0.0 <= x <= width and 0.0 <= y <= height):
        raise FormatError(f"start ({x}, {y}) lies outside the {width} x {height} m area", path=file)
    if box_distance(boxes, x, y) < START_CLEARANCE:
        raise FormatError(
            f"start ({x}, {y}) is within {START_CLEARANCE} m of an obstacle", path=file
        )
    name = str(document.get("name", file.stem))
    resolution = float(document.get("resolution", 0.5))
    return WorldSpec(BoxWorld(name, width, height, boxes), resolution, (x, y, heading))


def save_world(path: str | Path, spec: WorldSpec) -> Path:
    """Write ``spec`` as a world file (atomically)."""
    return write_json(Path(path), spec.to_json())


def _wall(rng: np.random.Generator, x: float, y: float, length: float) -> FloatArray:
    thickness = rng.uniform(0.3, 0.6)
    if rng.uniform() < 0.5:
        return np.array([[x, y, x + length, y + thickness]])
    return np.array([[x, y, x + thickness, y + length]])


def _group(rng: np.random.Generator, kind: str, x: float, y: float, passage: float) -> FloatArray:
    """One obstacle group with its lower-left near ``(x, y)`` [m]."""
    length = rng.uniform(3.0, 8.0)
    t = rng.uniform(0.3, 0.6)
    if kind == "wall":
        return _wall(rng, x, y, length)
    if kind == "l-shape":
        other = rng.uniform(2.0, 5.0)
        return np.array([[x, y, x + length, y + t], [x, y, x + t, y + other]])
    if kind == "corridor":
        gap = rng.uniform(passage, 2.5)
        if rng.uniform() < 0.5:
            return np.array(
                [[x, y, x + length, y + t], [x, y + t + gap, x + length, y + 2 * t + gap]]
            )
        return np.array([[x, y, x + t, y + length], [x + t + gap, y, x + 2 * t + gap, y + length]])
    if kind == "passage":
        gap = rng.uniform(passage, 2.0)
        half = length / 2
        if rng.uniform() < 0.5:
            return np.array([[x, y, x + half, y + t], [x + half + gap, y, x + length + gap, y + t]])
        return np.array([[x, y, x + t, y + half], [x, y + half + gap, x + t, y + length + gap]])
    side = rng.uniform(0.5, 2.0, size=2)
    return np.array([[x, y, x + side[0], y + side[1]]])


def _gap(a: FloatArray, b: FloatArray) -> float:
    """Smallest distance [m] between the boxes of two groups."""
    dx = np.maximum(np.maximum(a[:, None, 0] - b[None, :, 2], b[None, :, 0] - a[:, None, 2]), 0)
    dy = np.maximum(np.maximum(a[:, None, 1] - b[None, :, 3], b[None, :, 1] - a[:, None, 3]), 0)
    return float(np.hypot(dx, dy).min())


def generate_world(
    rng: RNGLike = None,
    *,
    size: float | None = None,
    n_groups: int | None = None,
    passage: float = 1.2,
    resolution: float = 0.5,
    name: str = "rover-generated-v1",
) -> WorldSpec:
    """Draw a stress world: walls, L-shapes, corridors, narrow passages and random boxes.

    Parameters
    ----------
    rng
        Seed or generator.
    size
        Side of the square area [m]; drawn from 20–60 m when ``None``.
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
    gen = as_generator(rng)
    side = float(gen.uniform(20.0, 60.0)) if size is None else float(size)
    wanted = max(int(side * side / 40.0), 3) if n_groups is None else n_groups
    kinds = ("wall", "l-shape", "corridor", "passage", "box", "box")
    start = (1.0, 1.0, float(gen.uniform(-math.pi, math.pi)))
    groups: list[FloatArray] = []
    for _ in range(wanted * 20):
        if len(groups) == wanted:
            break
        x, y = gen.uniform(passage, side - passage, size=2)
        group = _group(gen, str(gen.choice(kinds)), float(x), float(y), passage)
        inside = (group[:, :2] >= passage).all() and (group[:, 2:] <= side - passage).all()
        apart = all(_gap(group, other) >= passage for other in groups)
        if inside and apart and box_distance(group, start[0], start[1]) >= passage + 0.5:
            groups.append(group)
    boxes = np.vstack(groups) if groups else np.zeros((0, 4))
    return WorldSpec(BoxWorld(name, side, side, boxes), resolution, start)
