"""The tables microworld of Fox & Prescott (2011) §III, under a versioned scenario name.

A square arena closed by four walls holds six four-legged tables of one fixed size, with
identical leg width and texture (§III: "tables are all of a fixed size and have identical
leg width and texture parameters"). A table is a ``table_length`` × ``table_width``
rectangle centred at ``(x, y)`` with its long side along ``theta``; its four square legs of
side ``leg_width`` sit inside the rectangle, flush with its corners (the convention of
``notes/blackboard-interface.md``), so a table is the same under ``theta → theta + π``.

The world is the truth the whisker simulator (:mod:`bayesmap.sim.whiskers`) touches: every
leg face and wall as a segment with its outward normal, texture and the label of what it
belongs to. World construction is a pure function of a seeded generator
(:func:`initial`); the robot's 10 × 10 × 4 poses are fixed (:func:`pose_sequence`).

Registered scenario: ``"whisker-tables-v1"`` — a 6 m × 6 m arena, tables 1.2 m × 0.8 m
with 0.10 m legs, placed uniformly at random (centre and angle) without overlapping one
another, the walls or a robot position.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayesmap._typing import FloatArray, IntArray, Poses
from bayesmap.errors import ConfigError, ModelError
from bayesmap.sim import scenarios

__all__ = [
    "WALL",
    "TablesWorld",
    "WorldParams",
    "build",
    "build_mixed",
    "initial",
    "leg_centres",
    "pose_sequence",
    "rectangle_corners",
    "world_params",
]

WALL = -1
"""Label of a wall segment (tables are labelled 0, 1, …)."""


@dataclass(frozen=True)
class WorldParams:
    """Geometry of the tables microworld (all lengths [m], angles [rad]).

    Parameters
    ----------
    arena_size
        Side of the square arena; walls run along its border.
    n_tables
        Number of tables (the paper's six).
    table_length, table_width
        Outer size of every table; the long side lies along the table's ``theta``.
    leg_width
        Side of the square legs, flush with the table's corners.
    leg_texture
        Texture τ ∈ (0, 1) of every leg (identical for all tables, §III).
    wall_texture
        Texture of the walls. Default: the legs' texture, so that — as in the paper, whose
        model has no wall concept — a wall contact looks like a leg contact.
    grid_margin
        Distance from the walls of the outermost row and column of robot positions.
    grid_size
        Robot positions per side (the paper's 10 × 10).
    wall_clearance
        Minimum gap between a table's outline and a wall.
    table_gap
        Minimum gap between two tables' outlines (circumscribed circles, conservative).
    pose_clearance
        Minimum distance from a robot position to any leg (the robot never starts inside
        or against a leg).
    """

    arena_size: float = 6.0
    n_tables: int = 6
    table_length: float = 1.2
    table_width: float = 0.8
    leg_width: float = 0.1
    leg_texture: float = 0.3
    wall_texture: float = 0.3
    grid_margin: float = 0.48
    grid_size: int = 10
    wall_clearance: float = 0.3
    table_gap: float = 0.1
    pose_clearance: float = 0.15

    def __post_init__(self) -> None:
        positive = ("arena_size", "table_length", "table_width", "leg_width", "grid_margin")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ConfigError(f"WorldParams.{name} must be > 0, got {getattr(self, name)!r}")
        if not 2 * self.leg_width <= self.table_width <= self.table_length:
            raise ConfigError(
                "WorldParams: need 2 × leg_width <= table_width <= table_length, got "
                f"leg_width={self.leg_width}, table_width={self.table_width}, "
                f"table_length={self.table_length}"
            )
        if not 0 < self.leg_texture < 1 or not 0 < self.wall_texture < 1:
            raise ConfigError("WorldParams: leg_texture and wall_texture must lie in (0, 1)")
        if self.n_tables < 0 or self.grid_size < 1:
            raise ConfigError("WorldParams: n_tables must be >= 0 and grid_size >= 1")
        if 2 * self.grid_margin >= self.arena_size:
            raise ConfigError("WorldParams: grid_margin must be below half the arena_size")


@dataclass(frozen=True)
class TablesWorld:
    """A tables microworld: the truth the whiskers touch and the metrics read.

    Attributes
    ----------
    name
        Versioned scenario name (e.g. ``"whisker-tables-v1"``) that results record.
    params
        The geometry it was built from.
    tables
        ``(n_tables, 3)`` true tables ``x, y`` [m] centre, ``theta`` [rad] in [0, π).
    segments
        ``(n, 4)`` segments ``(x0, y0, x1, y1)`` [m]: every leg's four faces, then the
        four walls; each runs counter-clockwise around its leg (clockwise around the
        arena), so its outward normal is its direction turned by −90°.
    normal
        ``(n,)`` angle [rad] of each segment's normal, pointing out of the solid (out of
        a leg; into the arena for a wall).
    texture
        ``(n,)`` texture τ of each segment.
    table
        ``(n,)`` index of the table a segment belongs to, or :data:`WALL`.
    leg
        ``(n,)`` index 0–3 of the leg (corner) a segment belongs to, or :data:`WALL`.
    """

    name: str
    params: WorldParams
    tables: FloatArray
    segments: FloatArray = field(repr=False)
    normal: FloatArray = field(repr=False)
    texture: FloatArray = field(repr=False)
    table: IntArray = field(repr=False)
    leg: IntArray = field(repr=False)
    sizes: FloatArray | None = field(default=None, repr=False)
    arena: tuple[float, float] | None = None

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` [m] of the arena."""
        if self.arena is not None:
            return (0.0, 0.0, self.arena[0], self.arena[1])
        return (0.0, 0.0, self.params.arena_size, self.params.arena_size)

    @property
    def table_sizes(self) -> FloatArray:
        """``(n_tables, 3)`` size of each table: ``length, width, leg_width`` [m]."""
        if self.sizes is not None:
            return self.sizes
        p = self.params
        return np.tile([p.table_length, p.table_width, p.leg_width], (len(self.tables), 1))


def rectangle_corners(
    x: FloatArray,
    y: FloatArray,
    theta: FloatArray,
    length: float | FloatArray,
    width: float | FloatArray,
) -> FloatArray:
    """Corners of rectangles centred at ``(x, y)``, long side along ``theta``.

    ``length`` and ``width`` are one size for all or one per rectangle. Returns
    ``(..., 4, 2)`` corners [m] in counter-clockwise order, starting at the
    ``(+length/2, +width/2)`` corner of the rectangle's own frame.
    """
    half_l = 0.5 * np.asarray(length, dtype=np.float64)[..., None] * np.array([1, -1, -1, 1])
    half_w = 0.5 * np.asarray(width, dtype=np.float64)[..., None] * np.array([1, 1, -1, -1])
    c, s = np.cos(theta)[..., None], np.sin(theta)[..., None]
    xs = np.asarray(x)[..., None] + c * half_l - s * half_w
    ys = np.asarray(y)[..., None] + s * half_l + c * half_w
    return np.stack([xs, ys], axis=-1)


def leg_centres(tables: FloatArray, length: float, width: float, leg_width: float) -> FloatArray:
    """``(k, 4, 2)`` leg centres [m] of ``(k, ≥3)`` tables ``x, y, theta``.

    Legs are flush with the corners, so their centres are the corners of the rectangle
    shrunk by ``leg_width`` in both directions.
    """
    tables = np.atleast_2d(np.asarray(tables, dtype=np.float64))
    return rectangle_corners(
        tables[:, 0], tables[:, 1], tables[:, 2], length - leg_width, width - leg_width
    )


def pose_sequence(params: WorldParams) -> Poses:
    """The robot's fixed tour (Fox & Prescott 2011 Fig. 4): ``(grid_size² · 4, 3)`` poses.

    Positions form a ``grid_size`` × ``grid_size`` grid ``grid_margin`` from the walls,
    visited row by row in a serpentine (boustrophedon) order so consecutive positions are
    neighbours; at each position the robot faces east, north, west and south in turn.
    Rows are ``x`` [m], ``y`` [m], heading [rad].
    """
    ticks = np.linspace(
        params.grid_margin, params.arena_size - params.grid_margin, params.grid_size
    )
    positions = []
    for row, y in enumerate(ticks):
        for x in ticks if row % 2 == 0 else ticks[::-1]:
            positions.append((x, y))
    xy = np.repeat(np.asarray(positions), 4, axis=0)
    heading = np.tile(np.arange(4) * (np.pi / 2), len(positions))
    return np.column_stack([xy, heading])


def _fits(
    candidate: FloatArray, placed: list[FloatArray], positions: FloatArray, params: WorldParams
) -> bool:
    """Whether a table ``(x, y, theta)`` keeps its gaps to walls, other tables and poses."""
    x, y, theta = candidate
    corners = rectangle_corners(x, y, theta, params.table_length, params.table_width)
    low, high = params.wall_clearance, params.arena_size - params.wall_clearance
    if corners.min() < low or corners.max() > high:
        return False
    diagonal = float(np.hypot(params.table_length, params.table_width))
    if any(np.hypot(x - t[0], y - t[1]) < diagonal + params.table_gap for t in placed):
        return False
    legs = leg_centres(candidate[None], params.table_length, params.table_width, params.leg_width)
    gaps = np.linalg.norm(positions[:, None, :] - legs[0][None], axis=-1)
    reach = params.leg_width / np.sqrt(2.0) + params.pose_clearance
    return bool(gaps.min() >= reach)


def _segments(
    tables: FloatArray,
    sizes: FloatArray,
    textures: FloatArray,
    arena: tuple[float, float],
    wall_texture: float,
) -> tuple[FloatArray, FloatArray, FloatArray, IntArray, IntArray]:
    """Leg faces and walls as segments with normals, textures and labels.

    ``sizes`` holds each table's ``length, width, leg_width`` [m], ``textures`` its legs'
    texture, ``arena`` the ``width, height`` [m] of the walled rectangle.
    """
    k = len(tables)
    legs = rectangle_corners(
        tables[:, 0],
        tables[:, 1],
        tables[:, 2],
        sizes[:, 0] - sizes[:, 2],
        sizes[:, 1] - sizes[:, 2],
    )
    theta = np.repeat(tables[:, 2], 4)
    side = np.repeat(sizes[:, 2], 4)
    squares = rectangle_corners(legs[..., 0].ravel(), legs[..., 1].ravel(), theta, side, side)
    leg_segments = np.concatenate([squares, np.roll(squares, -1, axis=1)], axis=-1).reshape(-1, 4)
    width, height = arena
    box = np.array([[0.0, 0.0], [0.0, height], [width, height], [width, 0.0]])
    wall_segments = np.concatenate([box, np.roll(box, -1, axis=0)], axis=-1)
    segments = np.concatenate([leg_segments, wall_segments])
    direction = segments[:, 2:] - segments[:, :2]
    normal = np.arctan2(-direction[:, 0], direction[:, 1])
    texture = np.concatenate([np.repeat(textures, 16), np.full(4, wall_texture)])
    table = np.concatenate([np.repeat(np.arange(k), 16), np.full(4, WALL)]).astype(np.int64)
    leg = np.concatenate([np.tile(np.repeat(np.arange(4), 4), k), np.full(4, WALL)]).astype(
        np.int64
    )
    return segments, normal, texture, table, leg


_DRAWS_PER_TABLE = 2_000
"""Rejected draws in a row after which :func:`initial` starts its layout again."""
_MAX_DRAWS = 100_000
"""Draws :func:`initial` makes before giving up."""


def initial(
    params: WorldParams, *, rng: np.random.Generator, name: str = "whisker-tables-v1"
) -> TablesWorld:
    """Build a tables world from a seeded generator (the simulator's ``initial``).

    Tables are drawn uniformly (centre in the arena, angle in [0, π)) and rejected until
    each keeps ``wall_clearance`` from the walls, ``table_gap`` from the others and
    ``pose_clearance`` from every robot position. Tables placed early can leave no room
    for the rest; after :data:`_DRAWS_PER_TABLE` rejected draws in a row the layout is
    started again (from the same stream, so a seed always gives the same world).

    Raises
    ------
    ModelError
        If ``n_tables`` tables cannot be placed in :data:`_MAX_DRAWS` draws (arena too small).
    """
    positions = pose_sequence(params)[::4, :2]
    placed: list[FloatArray] = []
    rejected = 0
    for _ in range(_MAX_DRAWS):
        if len(placed) == params.n_tables:
            break
        candidate = np.array(
            [
                rng.uniform(0.0, params.arena_size),
                rng.uniform(0.0, params.arena_size),
                rng.uniform(0.0, np.pi),
            ]
        )
        if _fits(candidate, placed, positions, params):
            placed.append(candidate)
            rejected = 0
        else:
            rejected += 1
            if rejected == _DRAWS_PER_TABLE:
                placed, rejected = [], 0
    if len(placed) < params.n_tables:
        raise ModelError(
            f"could not place {params.n_tables} tables of {params.table_length} m × "
            f"{params.table_width} m in a {params.arena_size} m arena in {_MAX_DRAWS} draws; "
            "enlarge the arena or reduce n_tables"
        )
    return build(np.asarray(placed, dtype=np.float64).reshape(-1, 3), params, name=name)


def build(
    tables: FloatArray, params: WorldParams, *, name: str = "whisker-tables-v1"
) -> TablesWorld:
    """A tables world holding the given ``(k, 3)`` tables ``x, y, theta`` (no checks of gaps)."""
    tables = np.array(tables, dtype=np.float64).reshape(-1, 3)
    tables[:, 2] = np.mod(tables[:, 2], np.pi)
    sizes = np.tile([params.table_length, params.table_width, params.leg_width], (len(tables), 1))
    textures = np.full(len(tables), params.leg_texture)
    arena = (params.arena_size, params.arena_size)
    segments, normal, texture, table, leg = _segments(
        tables, sizes, textures, arena, params.wall_texture
    )
    return TablesWorld(name, params, tables, segments, normal, texture, table, leg)


def build_mixed(
    tables: FloatArray,
    sizes: FloatArray,
    textures: FloatArray,
    arena: tuple[float, float],
    *,
    wall_texture: float = 0.3,
    name: str = "whisker-tables-file",
) -> TablesWorld:
    """A tables world of tables of several sizes in a ``width × height`` [m] arena.

    ``tables`` are ``(k, 3)`` rows ``x, y, theta``, ``sizes`` ``(k, 3)`` rows ``length,
    width, leg_width`` [m] and ``textures`` ``(k,)`` leg textures (no checks of gaps; see
    :mod:`bayesmap.sim.whisker_worlds` for validated worlds).
    """
    tables = np.array(tables, dtype=np.float64).reshape(-1, 3)
    tables[:, 2] = np.mod(tables[:, 2], np.pi)
    sizes = np.array(sizes, dtype=np.float64).reshape(-1, 3)
    textures = np.asarray(textures, dtype=np.float64).reshape(-1)
    segments, normal, texture, table, leg = _segments(tables, sizes, textures, arena, wall_texture)
    params = WorldParams(
        arena_size=max(arena),
        n_tables=len(tables),
        table_length=float(sizes[:, 0].max()) if len(sizes) else 1.2,
        table_width=float(sizes[:, 1].max()) if len(sizes) else 0.8,
        leg_width=float(sizes[:, 2].max()) if len(sizes) else 0.1,
        wall_texture=wall_texture,
        grid_margin=min(0.48, 0.25 * min(arena)),
    )
    return TablesWorld(
        name, params, tables, segments, normal, texture, table, leg, sizes, (arena[0], arena[1])
    )


scenarios.register("whisker-tables-v1", WorldParams, WorldParams)


def world_params(name: str) -> WorldParams:
    """The :class:`WorldParams` of scenario ``name`` (:mod:`bayesmap.sim.scenarios`).

    :class:`ConfigError` if unknown.
    """
    return scenarios.scenario(name, WorldParams)
