"""World files for the whiskered table mapper: JSON Schema, load/save, stress-world generator.

A world file (``WORLD.json``) describes a walled rectangular arena, the tables in it (each
with its own size, so rooms can mix desks and stools) and where the robot stops::

    {"arena": {"width": 7.0, "height": 7.0},
     "tables": [{"x": 1.59, "y": 0.58, "theta": 0.01,
                 "length": 1.2, "width": 0.8, "leg": 0.1, "texture": 0.3}],
     "poses": {"grid": 10, "margin": 0.45, "headings": 4}}

``x, y`` are a table's centre [m], ``theta`` its long side's angle from the x axis [rad],
``leg`` the side of its square legs [m] (flush with the corners). The walls are the
arena's four sides. ``poses`` is a grid (``grid`` × ``grid`` positions, or ``[columns,
rows]``, ``margin`` [m] from the walls, visited row by row in serpentine order, ``headings``
equally spaced headings from east, counter-clockwise; ``spacing`` instead of ``grid`` puts
the positions at most that far apart, and without either the tour is
:func:`default_tour`'s) or a list of ``[x, y, heading]``; grid positions inside a table or
closer than :data:`POSE_CLEARANCE` to a leg are skipped. An optional
``catalogue`` lists the object types the mapper may use (``name, length, width, leg``);
without it the catalogue is the distinct table sizes of the file. The mapper is told the
arena and the catalogue, never the tables.

:data:`WORLD_SCHEMA` is the JSON Schema (draft 2020-12) checked by :func:`load_world`;
geometric checks (tables inside the arena, not overlapping, legs at most half the table's
width) follow it. Every failure is a :class:`~bayesmap.errors.FormatError` naming the file
and the element. Legs of exactly half the width meet: a square "table" whose legs fill it
is a solid box or pillar (``"length": 0.3, "width": 0.3, "leg": 0.15``), the way to put
clutter in a world; give its size a catalogue entry to let the mapper name it.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import shapely

from bayesmap._io import write_json
from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import BoolArray, FloatArray, Poses
from bayesmap.errors import ConfigError, FormatError
from bayesmap.geometry import rectangle_fit_problem
from bayesmap.sim.tables_world import TablesWorld, build_mixed, rectangle_corners
from bayesmap.sim.world_files import check_schema, read_document

logger = logging.getLogger(__name__)

__all__ = [
    "MAX_POSES",
    "POSE_CLEARANCE",
    "WORLD_SCHEMA",
    "TOUR_SPACING",
    "StressOptions",
    "TourGrid",
    "WorldFile",
    "default_tour",
    "generate_world",
    "load_world",
    "parse_world",
    "save_world",
]

POSE_CLEARANCE = 0.15
"""Grid positions closer than this [m] to a leg's outline (or inside a table) are skipped."""

TOUR_SPACING = 0.6
"""Farthest apart [m] the positions of :func:`default_tour` stand. The paper's tour (10 × 10
positions in its 6 m arena, 0.48 m from the walls) has them 0.56 m apart, so that no point
of the floor is more than 0.4 m from a position, well within a whisker's 1 m reach."""

MAX_ARENA_SIDE = 100.0
"""Longest arena side [m] a world file may give. A whisker robot maps a room a few metres
across; the contact-vote grid of a 100 m square at its 2.5 cm cells already holds 16
million cells, and a longer side is most likely written in cm or mm."""

MAX_POSES = 100_000
"""Most robot poses a world file may ask for, listed or as a grid (columns × rows ×
headings). The fused mapper takes about 20–35 ms of CPU a pose (docs/benchmarks.md),
so this many already run for about an hour; a grid of tens of thousands a side is most
likely a typo."""

_NUMBER = {"type": "number"}
_POSITIVE = {"type": "number", "exclusiveMinimum": 0}
_COUNT = {"type": "integer", "minimum": 1}
WORLD_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "bayesmap whisker tables world",
    "type": "object",
    "required": ["arena", "tables"],
    "additionalProperties": False,
    "properties": {
        "arena": {
            "type": "object",
            "required": ["width", "height"],
            "additionalProperties": False,
            "properties": {
                "width": _POSITIVE,
                "height": _POSITIVE,
                "wall_texture": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1},
            },
        },
        "tables": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["x", "y", "theta", "length", "width", "leg"],
                "additionalProperties": False,
                "properties": {
                    "x": _NUMBER,
                    "y": _NUMBER,
                    "theta": _NUMBER,
                    "length": _POSITIVE,
                    "width": _POSITIVE,
                    "leg": _POSITIVE,
                    "texture": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1},
                },
            },
        },
        "poses": {
            "default": {},
            "oneOf": [
                {
                    "type": "object",
                    "additionalProperties": False,
                    "properties": {
                        "grid": {
                            "oneOf": [
                                _COUNT,
                                {"type": "array", "items": _COUNT, "minItems": 2, "maxItems": 2},
                            ]
                        },
                        "spacing": _POSITIVE,
                        "margin": _POSITIVE,
                        "headings": _COUNT,
                    },
                },
                {
                    "type": "array",
                    "minItems": 1,
                    "items": {"type": "array", "items": _NUMBER, "minItems": 3, "maxItems": 3},
                },
            ],
        },
        "catalogue": {
            "type": "array",
            "minItems": 1,
            "items": {
                "type": "object",
                "required": ["length", "width", "leg"],
                "additionalProperties": False,
                "properties": {
                    "name": {"type": "string"},
                    "length": _POSITIVE,
                    "width": _POSITIVE,
                    "leg": _POSITIVE,
                },
            },
        },
    },
}
"""JSON Schema of a world file."""

_DEFAULT_TEXTURE = 0.3


class TourGrid(NamedTuple):
    """A grid tour: ``columns`` × ``rows`` positions ``margin`` [m] from the walls, each
    visited at ``headings`` equally spaced headings."""

    columns: int
    rows: int
    margin: float = 0.45
    headings: int = 4


def default_tour(
    arena: tuple[float, float],
    margin: float = 0.45,
    headings: int = 4,
    spacing: float | None = None,
) -> TourGrid:
    """The grid tour of a world file that gives no ``poses.grid``.

    With ``spacing``: on each side as few positions as stand at most ``spacing`` [m] apart.
    Without: the paper's 10 positions a side, but on a side too long for 10 positions
    :data:`TOUR_SPACING` apart as many as that spacing needs (a 12 m room gets 20, where 10
    would stand 1.23 m apart and leave tables between them to a whisker's very tip), and on
    a side too short for 10 positions :data:`POSE_CLEARANCE` apart (a corridor) fewer.
    """
    counts = []
    for side in arena:
        usable = side - 2.0 * margin
        step = spacing or min(max(usable / 9.0, POSE_CLEARANCE), TOUR_SPACING)
        counts.append(math.ceil(usable / step - 1e-9) + 1)
    return TourGrid(counts[0], counts[1], margin, headings)


@dataclass(frozen=True)
class WorldFile:
    """A world file's content.

    Attributes
    ----------
    arena
        ``(width, height)`` [m]; the walls are its four sides.
    tables
        ``(k, 7)`` rows ``x, y, theta, length, width, leg, texture`` [m, m, rad, m, m, m, –].
    poses
        ``(n, 3)`` robot poses ``x, y, heading``, or ``None`` for a grid.
    grid
        The grid tour when ``poses`` is ``None``; ``None``: :func:`default_tour`.
    catalogue
        Object types ``(name, length, width, leg)`` the mapper may use.
    wall_texture
        Texture of the walls.
    """

    arena: tuple[float, float]
    tables: FloatArray
    poses: Poses | None = None
    grid: TourGrid | None = None
    catalogue: tuple[tuple[str, float, float, float], ...] = ()
    wall_texture: float = _DEFAULT_TEXTURE

    def to_json(self) -> dict[str, Any]:
        """The file's JSON object (the inverse of :func:`parse_world`)."""
        keys = ("x", "y", "theta", "length", "width", "leg", "texture")
        poses: Any = np.asarray(self.poses).tolist() if self.poses is not None else None
        if poses is None:
            grid = self.tour()
            counts = grid.columns if grid.columns == grid.rows else [grid.columns, grid.rows]
            poses = {"grid": counts, "margin": grid.margin, "headings": grid.headings}
        return {
            "arena": {
                "width": self.arena[0],
                "height": self.arena[1],
                "wall_texture": self.wall_texture,
            },
            "tables": [dict(zip(keys, map(float, row), strict=True)) for row in self.tables],
            "poses": poses,
            "catalogue": [
                {"name": n, "length": a, "width": b, "leg": c} for n, a, b, c in self.catalogue
            ],
        }

    def world(self, name: str = "whisker-tables-file") -> TablesWorld:
        """The simulator's :class:`~bayesmap.sim.tables_world.TablesWorld` of this file."""
        t = self.tables
        return build_mixed(
            t[:, :3], t[:, 3:6], t[:, 6], self.arena, wall_texture=self.wall_texture, name=name
        )

    def tour(self) -> TourGrid:
        """The grid tour (when ``poses`` is ``None``)."""
        return self.grid or default_tour(self.arena)

    def robot_poses(self) -> Poses:
        """The robot's poses: the given list, or the grid without blocked positions."""
        if self.poses is not None:
            return np.asarray(self.poses, dtype=np.float64)
        columns, rows, margin, headings = self.tour()
        # one position on a side: its middle, not a corner
        xs, ys = (
            np.linspace(margin, side - margin, count) if count > 1 else np.array([side / 2])
            for side, count in ((self.arena[0], columns), (self.arena[1], rows))
        )
        tour = np.array(
            [(x, y) for row, y in enumerate(ys) for x in (xs if row % 2 == 0 else xs[::-1])]
        )
        free = tour[_free_positions(tour, self.tables)]
        turns = np.arange(headings) * 2 * math.pi / headings
        return np.column_stack(
            [np.repeat(free, headings, axis=0), np.tile(turns, len(free))]
        ).reshape(-1, 3)


def _table_polygons(tables: FloatArray) -> list[shapely.Polygon]:
    corners = rectangle_corners(
        tables[:, 0], tables[:, 1], tables[:, 2], tables[:, 3], tables[:, 4]
    )
    return [shapely.Polygon(c) for c in corners]


def _leg_polygons(tables: FloatArray) -> list[shapely.Polygon]:
    legs = rectangle_corners(
        tables[:, 0],
        tables[:, 1],
        tables[:, 2],
        tables[:, 3] - tables[:, 5],
        tables[:, 4] - tables[:, 5],
    )
    polygons = []
    for row, centres in zip(tables, legs, strict=True):
        squares = rectangle_corners(
            centres[:, 0], centres[:, 1], np.full(4, row[2]), row[5], row[5]
        )
        polygons += [shapely.Polygon(s) for s in squares]
    return polygons


def _free_positions(xy: FloatArray, tables: FloatArray) -> BoolArray:
    """Which ``(n, 2)`` positions the robot can stand on: outside every table and at least
    :data:`POSE_CLEARANCE` from every leg (the polygons are built once for all of them)."""
    free = np.ones(len(xy), dtype=bool)
    if not len(tables) or not len(xy):
        return free
    points = shapely.points(xy)
    for table in _table_polygons(tables):
        free &= ~shapely.contains(table, points)
    for leg in _leg_polygons(tables):
        free &= shapely.distance(leg, points) >= POSE_CLEARANCE
    return free


def _fail(source: str, where: str, what: str) -> FormatError:
    return FormatError(what, path=source, element=where)


def parse_world(obj: Any, source: str = "world") -> WorldFile:
    """Check a world file's JSON object against :data:`WORLD_SCHEMA` and the geometry.

    Raises
    ------
    FormatError
        Naming ``source`` and the offending element, e.g. ``tables[2]: crosses the wall``.
    """
    check_schema(obj, WORLD_SCHEMA, source)
    arena = (float(obj["arena"]["width"]), float(obj["arena"]["height"]))
    if not all(math.isfinite(side) for side in arena):
        raise _fail(source, "arena", "the sides must be finite numbers of metres")
    if max(arena) > MAX_ARENA_SIDE:
        raise _fail(
            source,
            "arena",
            f"a side of {max(arena):g} m is longer than the {MAX_ARENA_SIDE:g} m a whisker "
            "map covers (is it in cm or mm? give metres)",
        )
    rows = [
        [t["x"], t["y"], t["theta"], t["length"], t["width"], t["leg"], t.get("texture", 0.3)]
        for t in obj["tables"]
    ]
    tables = np.asarray(rows, dtype=np.float64).reshape(-1, 7)
    if not np.isfinite(tables).all():
        raise _fail(source, "tables", "every number must be finite")
    for i, row in enumerate(tables):
        if row[4] > row[3]:
            raise _fail(
                source,
                f"tables[{i}]",
                f"width {row[4]:g} is more than length {row[3]:g}: length is the longer side "
                "(swap them and turn theta by 90°)",
            )
        if not 2 * row[5] <= min(row[3], row[4]):
            raise _fail(source, f"tables[{i}]", "each leg must be at most half the table's width")
    polygons = _table_polygons(tables)
    box = shapely.box(0.0, 0.0, *arena)
    for i, polygon in enumerate(polygons):
        if not box.contains(polygon):
            raise _fail(source, f"tables[{i}]", "the table crosses a wall of the arena")
        for j in range(i):
            if polygon.intersects(polygons[j]):
                raise _fail(source, f"tables[{i}]", f"the table overlaps tables[{j}]")
    poses_obj = obj.get("poses", {})
    poses: Poses | None = None
    grid: TourGrid | None = None
    if isinstance(poses_obj, list):
        if len(poses_obj) > MAX_POSES:
            raise _fail(
                source,
                "poses",
                f"{len(poses_obj):,} poses are more than a run takes ({MAX_POSES:,})",
            )
        poses = np.asarray(poses_obj, dtype=np.float64)
        outside = (poses[:, 0] <= 0) | (poses[:, 0] >= arena[0])
        outside |= (poses[:, 1] <= 0) | (poses[:, 1] >= arena[1])
        if outside.any() or not np.isfinite(poses).all():
            first = int(np.flatnonzero(outside | ~np.isfinite(poses).all(axis=1))[0])
            raise _fail(source, f"poses[{first}]", "a pose must be finite and inside the arena")
        poses[:, 2] = np.mod(poses[:, 2], 2.0 * math.pi)  # any number of whole turns
        blocked = np.flatnonzero(~_free_positions(poses[:, :2], tables))
        if len(blocked):
            raise _fail(
                source,
                f"poses[{blocked[0]}]",
                f"the robot cannot stand inside a table or within {POSE_CLEARANCE:g} m of a leg",
            )
    else:
        margin = float(poses_obj.get("margin", 0.45))
        headings = int(poses_obj.get("headings", 4))
        if 2 * margin >= min(arena):
            raise _fail(source, "poses.margin", "must be below half the arena's smaller side")
        counts = poses_obj.get("grid")
        if counts is not None and "spacing" in poses_obj:
            raise _fail(source, "poses", "give grid or spacing, not both")
        if counts is None:
            spacing = poses_obj.get("spacing")
            grid = default_tour(
                arena, margin, headings, None if spacing is None else float(spacing)
            )
        else:
            across, up = (counts, counts) if isinstance(counts, int) else counts
            grid = TourGrid(int(across), int(up), margin, headings)
        total = grid.columns * grid.rows * grid.headings
        if total > MAX_POSES:
            asked = next((key for key in ("grid", "spacing") if key in poses_obj), None)
            raise _fail(
                source,
                "poses" if asked is None else f"poses.{asked}",
                f"a {grid.columns:,} x {grid.rows:,} grid of {grid.headings:,} headings is "
                f"{total:,} poses, more than a run takes ({MAX_POSES:,}, about an hour of mapping)"
                + ("; give poses.grid or a wider poses.spacing" if asked is None else ""),
            )
    if "catalogue" in obj:
        catalogue = tuple(
            (str(c.get("name", f"type{k}")), float(c["length"]), float(c["width"]), float(c["leg"]))
            for k, c in enumerate(obj["catalogue"])
        )
    else:
        sizes = sorted({(float(r[3]), float(r[4]), float(r[5])) for r in tables}, reverse=True)
        catalogue = tuple((f"{a:g}x{b:g}", a, b, c) for a, b, c in sizes)
    if not catalogue:
        raise _fail(source, "catalogue", "a world without tables must list its catalogue")
    for k, (_, length, width, leg) in enumerate(catalogue):
        if width > length or not 2 * leg <= width:
            raise _fail(
                source,
                f"catalogue[{k}]",
                "length must be the longer side and each leg at most half the width",
            )
        problem = rectangle_fit_problem(length, width, arena)
        if problem is not None:
            raise _fail(source, f"catalogue[{k}]", problem)
        twin = next((j for j in range(k) if catalogue[j][1:] == (length, width, leg)), None)
        if twin is not None:
            raise _fail(
                source,
                f"catalogue[{k}]",
                f"has the size of catalogue[{twin}]: the mapper could not tell them apart",
            )
        twin = next((j for j in range(k) if catalogue[j][0] == catalogue[k][0]), None)
        if twin is not None:
            raise _fail(
                source,
                f"catalogue[{k}]",
                f"has the name of catalogue[{twin}] ({catalogue[k][0]!r}): the map could not "
                "tell their objects apart",
            )
    known = {entry[1:] for entry in catalogue}
    strangers = [i for i, row in enumerate(tables) if tuple(map(float, row[3:6])) not in known]
    if strangers:
        named = ", ".join(f"tables[{i}]" for i in strangers[:5])
        more = f" and {len(strangers) - 5} more" if len(strangers) > 5 else ""
        logger.warning(
            "%s: no catalogue type has the size of %s%s, so the mapper can report such a "
            "table only as one of its types (or as two, or not at all)",
            source,
            named,
            more,
        )
    wall_texture = float(obj["arena"].get("wall_texture", _DEFAULT_TEXTURE))
    return WorldFile(arena, tables, poses, grid, catalogue, wall_texture)


def load_world(path: str | Path) -> WorldFile:
    """Read and check a world file (see :data:`WORLD_SCHEMA`).

    Raises
    ------
    FormatError
        If the file is missing, is not JSON (with its line) or breaks the schema.
    """
    return parse_world(read_document(path), str(Path(path)))


def save_world(world: WorldFile, path: str | Path) -> Path:
    """Write ``world`` as a world file, atomically."""
    return write_json(path, world.to_json())


@dataclass(frozen=True)
class StressOptions:
    """What :func:`generate_world` puts in a world (lengths [m]).

    Parameters
    ----------
    arena_range
        Range of the arena's sides; each side is drawn uniformly in it.
    tables_range
        Range of the number of tables (capped by what fits: one table per
        ``area_per_table`` m²).
    sizes
        Table sizes ``(length, width, leg)`` drawn uniformly per table (mixed sizes).
    near_wall
        Fraction of tables placed ``wall_gap`` from a wall.
    wall_gap
        Range of the gap between a near-wall table's outline and its wall.
    close_pairs
        Fraction of tables placed ``pair_gap`` from an earlier table.
    pair_gap
        Range of the gap between the outlines of a close pair.
    min_gap
        Smallest gap between any two outlines, and between an outline and a wall.
    area_per_table
        Arena area per table at most (keeps rooms passable).
    """

    arena_range: tuple[float, float] = (4.0, 10.0)
    tables_range: tuple[int, int] = (4, 10)
    sizes: tuple[tuple[float, float, float], ...] = ((1.2, 0.8, 0.1), (0.8, 0.8, 0.08))
    near_wall: float = 0.3
    wall_gap: tuple[float, float] = (0.1, 0.2)
    close_pairs: float = 0.3
    pair_gap: tuple[float, float] = (0.15, 0.4)
    min_gap: float = 0.1
    area_per_table: float = 3.5

    def __post_init__(self) -> None:
        if not 0 < self.arena_range[0] <= self.arena_range[1]:
            raise ConfigError(
                f"StressOptions.arena_range must be increasing, > 0: {self.arena_range}"
            )
        if not 0 <= self.tables_range[0] <= self.tables_range[1]:
            raise ConfigError(f"StressOptions.tables_range must be increasing: {self.tables_range}")
        if not self.sizes:
            raise ConfigError("StressOptions.sizes must list at least one table size")
        if not (0 <= self.near_wall <= 1 and 0 <= self.close_pairs <= 1):
            raise ConfigError("StressOptions.near_wall and close_pairs must lie in [0, 1]")


_ATTEMPTS = 4000


def _distance_to_walls(polygon: shapely.Polygon, arena: tuple[float, float]) -> float:
    x0, y0, x1, y1 = polygon.bounds
    return float(min(x0, y0, arena[0] - x1, arena[1] - y1))


def generate_world(
    rng: RNGLike = None, options: StressOptions = StressOptions(), *, grid: int = 10
) -> WorldFile:
    """Draw a stress world from ``rng`` (a seed or a generator): tables of mixed sizes at
    any angle, some hugging walls, some in pairs.

    The arena's sides are drawn in ``options.arena_range``, the number of tables in
    ``options.tables_range`` (capped by the area). Each table gets a size from
    ``options.sizes`` and a uniform angle; with probability ``near_wall`` it is pushed
    against a random wall to a gap drawn from ``wall_gap``, else with probability
    ``close_pairs`` it is set beside an earlier table at a gap drawn from ``pair_gap``,
    else it is placed uniformly. Placements that break ``min_gap`` are drawn again. Robot
    poses: a ``grid`` × ``grid`` × 4 grid 0.45 m from the walls (positions blocked by a
    table are skipped when the file is read).
    """
    generator = as_generator(rng)
    arena = (
        round(float(generator.uniform(*options.arena_range)), 2),
        round(float(generator.uniform(*options.arena_range)), 2),
    )
    fit = int(arena[0] * arena[1] // options.area_per_table)
    high = max(min(options.tables_range[1], fit), options.tables_range[0])
    n_tables = int(generator.integers(options.tables_range[0], high + 1))
    rows: list[list[float]] = []
    polygons: list[shapely.Polygon] = []
    for _ in range(_ATTEMPTS):
        if len(rows) == n_tables:
            break
        length, width, leg = options.sizes[int(generator.integers(len(options.sizes)))]
        theta = float(generator.uniform(0.0, math.pi))
        x, y = float(generator.uniform(0, arena[0])), float(generator.uniform(0, arena[1]))
        mode = generator.uniform()
        if mode < options.near_wall:
            x, y = _against_wall(generator, x, y, theta, length, width, arena, options.wall_gap)
        elif mode < options.near_wall + options.close_pairs and polygons:
            x, y = _beside(generator, rows, theta, length, width, options.pair_gap)
        polygon = _table_polygons(np.array([[x, y, theta, length, width]]))[0]
        if _distance_to_walls(polygon, arena) < options.min_gap:
            continue
        if any(polygon.distance(p) < options.min_gap for p in polygons):
            continue
        rows.append([x, y, theta, length, width, leg, _DEFAULT_TEXTURE])
        polygons.append(polygon)
    tables = np.round(np.asarray(rows, dtype=np.float64).reshape(-1, 7), 4)
    catalogue = tuple((f"{a:g}x{b:g}", a, b, c) for a, b, c in options.sizes)
    return WorldFile(arena, tables, None, TourGrid(grid, grid), catalogue)


def _against_wall(
    rng: np.random.Generator,
    x: float,
    y: float,
    theta: float,
    length: float,
    width: float,
    arena: tuple[float, float],
    gap: tuple[float, float],
) -> tuple[float, float]:
    """Move a table's centre so its outline lies a gap drawn from ``gap`` from one wall."""
    corners = rectangle_corners(np.array(0.0), np.array(0.0), np.array(theta), length, width)
    half_x, half_y = float(np.abs(corners[:, 0]).max()), float(np.abs(corners[:, 1]).max())
    g = float(rng.uniform(*gap))
    wall = int(rng.integers(4))
    if wall == 0:
        return half_x + g, y
    if wall == 1:
        return arena[0] - half_x - g, y
    if wall == 2:
        return x, half_y + g
    return x, arena[1] - half_y - g


def _beside(
    rng: np.random.Generator,
    rows: list[list[float]],
    theta: float,
    length: float,
    width: float,
    gap: tuple[float, float],
) -> tuple[float, float]:
    """A centre setting a new table a gap drawn from ``gap`` from a random earlier table."""
    other = rows[int(rng.integers(len(rows)))]
    anchor = _table_polygons(np.array([other[:5]]))[0]
    target = float(rng.uniform(*gap))
    heading = float(rng.uniform(0, 2 * math.pi))
    direction = np.array([math.cos(heading), math.sin(heading)])
    low, high = 0.0, float(np.hypot(length, width) + np.hypot(other[3], other[4]))
    for _ in range(30):
        middle = 0.5 * (low + high)
        x, y = np.array(other[:2]) + middle * direction
        polygon = _table_polygons(np.array([[x, y, theta, length, width]]))[0]
        if polygon.distance(anchor) < target:
            low = middle
        else:
            high = middle
    x, y = np.array(other[:2]) + high * direction
    return float(x), float(y)
