"""Bounded 2-D worlds with axis-aligned rectangular obstacles, under versioned names.

A world is a rectangle ``[0, width] x [0, height]`` [m] (the mapped area; nothing stops a
robot from leaving it) holding boxes ``(xmin, ymin, xmax, ymax)`` [m].

Registered worlds (Post et al. 2016 §5):

- ``"rover-field-empty-v1"``: the 20 m x 20 m field with no obstacles (§5.2);
- ``"rover-field-obstacles-v1"``: the same field with two 1 m x 1 m boxes centred at
  (14, 16) and (7, 10) and a 0.5 m x 1 m box centred at (12.5, 3) (§5.3).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.sim.scenarios import register, scenario

__all__ = [
    "BoxWorld",
    "box_distance",
    "box_world",
    "circle_hits",
    "occupancy_truth",
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
    """

    name: str
    width: float
    height: float
    boxes: FloatArray


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
