"""Plane geometry shared by the simulators and the algorithms: angles, frames, rays.

One convention for each concept, used everywhere in bayesmap:

- **Angles** [rad] are wrapped into the half-open interval ``[-π, π)`` by
  :func:`wrap_angle` (``π`` itself maps to ``-π``). Shapes with a symmetry compare angles
  modulo a shorter period (a square leg: ``π/2``), wrapped into ``[-period/2, period/2)``.
- **Poses** are ``(x [m], y [m], heading [rad])`` in the world frame (``bayesmap._typing.Poses``);
  a point in the robot's own frame has ``x`` ahead and ``y`` to the left.
  :func:`to_world` and :func:`to_robot` move points between the two frames.
- **Tracks** of logged positions are checked by :func:`isolated_jumps`: a row that leaps
  away and straight back is a glitch in the log, not a move.
- **Rays** start at an origin and run along a unit direction; a hit is reported as the
  distance along the ray [m] (``inf``: no hit) and the index of what was hit (``-1``: none).
  :func:`cast_on_segments` casts on wall segments ``(x0, y0, x1, y1)``,
  :func:`cast_on_boxes` on axis-aligned boxes ``(xmin, ymin, xmax, ymax)``.

Examples
--------
>>> float(wrap_angle(3 * np.pi / 2)) == -np.pi / 2
True
>>> to_world([1.0, 2.0, np.pi / 2], [[1.0, 0.0]]).round(12).tolist()
[[1.0, 3.0]]
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray, IntArray

__all__ = [
    "cast_on_boxes",
    "cast_on_segments",
    "is_solid_square",
    "rectangle_fit_problem",
    "to_robot",
    "to_world",
    "wrap_angle",
]

_TWO_PI = 2.0 * math.pi
_CHUNK = 2_000_000
"""Ray × segment pairs held in memory at once by :func:`cast_on_segments`."""


def wrap_angle(angle: npt.ArrayLike, period: float = _TWO_PI) -> FloatArray:
    """Angles [rad] wrapped into ``[-period/2, period/2)``; by default ``[-π, π)``.

    Examples
    --------
    >>> wrap_angle([np.pi, -np.pi, 3 * np.pi / 2]).tolist() == [-np.pi, -np.pi, -np.pi / 2]
    True
    """
    half = 0.5 * period
    return np.asarray((np.asarray(angle, dtype=np.float64) + half) % period - half)


def is_solid_square(length: float, width: float, leg: float) -> bool:
    """Whether a four-legged ``length × width`` object with square legs of side ``leg`` [m]
    flush with its corners is one solid square (a box or pillar): square, its legs half
    its side, so they meet."""
    return math.isclose(length, width) and 2.0 * leg >= width - 1e-12


def rectangle_fit_problem(length: float, width: float, area: tuple[float, float]) -> str | None:
    """Why no ``length × width`` [m] rectangle could stand in a rectangular ``area`` (width,
    height) [m]: wider than the area's shorter side or longer than its diagonal; ``None``
    when it may fit (a bound, not an exact test of every angle)."""
    if width > min(area) or length > math.hypot(*area):
        return (
            f"{length:g} x {width:g} m does not fit in the {area[0]:g} x {area[1]:g} m arena "
            "(are its sizes in cm or mm?)"
        )
    return None


def to_world(pose: npt.ArrayLike, points: npt.ArrayLike) -> FloatArray:
    """Points ``(..., 2)`` in the robot's frame [m] → the world frame, for ``pose`` ``(..., 3)``.

    ``pose`` and ``points`` broadcast over their leading axes: one pose ``(3,)`` with
    ``(n, 2)`` points, or ``(m, 1, 3)`` poses with ``(n, 2)`` points give ``(m, n, 2)``.
    """
    p = np.asarray(pose, dtype=np.float64)
    q = np.asarray(points, dtype=np.float64)
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    x = p[..., 0] + c * q[..., 0] - s * q[..., 1]
    y = p[..., 1] + s * q[..., 0] + c * q[..., 1]
    return np.stack([x, y], axis=-1)


def to_robot(pose: npt.ArrayLike, points: npt.ArrayLike) -> FloatArray:
    """Points ``(..., 2)`` in the world frame [m] → the frame of the robot at ``pose``.

    The inverse of :func:`to_world`, with the same broadcasting.
    """
    p = np.asarray(pose, dtype=np.float64)
    q = np.asarray(points, dtype=np.float64)
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    dx, dy = q[..., 0] - p[..., 0], q[..., 1] - p[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


MAX_POSE_JUMP = 5.0
"""Largest step [m] between consecutive logged positions that :func:`isolated_jumps` takes
for a move: robots these logs come from drive at most a few metres per second, and logs
hold several poses a second."""


def isolated_jumps(xy: npt.ArrayLike, jump: float = MAX_POSE_JUMP) -> BoolArray:
    """Rows of a track of positions ``(n, 2)`` [m] that leap more than ``jump`` from both
    neighbours while the neighbours lie within ``jump`` of each other.

    A robot cannot leave its path and come straight back between two log rows, so such a
    row is a corrupt pose (a dropped decimal point, a wrong field). A real jump, as after a
    gap in the log, does not come back, and is kept; so are the first and last rows, whose
    jump, with one neighbour, cannot be told from a real one.

    >>> isolated_jumps([[0, 0], [0.1, 0], [3000, 1], [0.3, 0], [0.4, 0]]).tolist()
    [False, False, True, False, False]
    >>> isolated_jumps([[0, 0], [0.1, 0], [30, 0], [30.1, 0]]).tolist()
    [False, False, False, False]
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(len(p), dtype=bool)
    if len(p) < 3:
        return out
    step = np.hypot(*np.diff(p, axis=0).T)
    across = np.hypot(*(p[2:] - p[:-2]).T)
    out[1:-1] = (step[:-1] > jump) & (step[1:] > jump) & (across <= jump)
    return out


def cast_on_segments(
    origins: npt.ArrayLike,
    directions: npt.ArrayLike,
    segments: npt.ArrayLike,
    *,
    near: float = 0.0,
    far: float = math.inf,
    parallel: float = 0.0,
) -> tuple[FloatArray, IntArray]:
    """First segment hit by each ray, between ``near`` and ``far`` along it.

    Parameters
    ----------
    origins
        ``(m, 2)`` ray starts [m], or one ``(2,)`` start shared by every ray.
    directions
        ``(m, 2)`` unit directions.
    segments
        ``(s, 4)`` segments ``(x0, y0, x1, y1)`` [m]; their end points count as hits.
    near, far
        The part of each ray searched [m], bounds included (a ``near`` just above 0 keeps
        a ray that starts on a wall from hitting it again).
    parallel
        A ray whose cross product with a segment is at most this in magnitude is treated
        as parallel to it and never hits it.

    Returns
    -------
    (distance, index)
        ``(m,)`` distance to the first hit [m] (``inf`` if none) and the segment's index
        (``-1`` if none).
    """
    o_all = np.asarray(origins, dtype=np.float64)
    d_all = np.asarray(directions, dtype=np.float64).reshape(-1, 2)
    seg = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    m = len(d_all)
    o_all = np.broadcast_to(o_all, (m, 2))
    distance = np.full(m, np.inf)
    index = np.full(m, -1, dtype=np.int64)
    if len(seg) == 0:
        return distance, index
    p = seg[:, :2]
    e = seg[:, 2:] - p
    step = max(_CHUNK // len(seg), 1)
    for start in range(0, m, step):
        o = o_all[start : start + step, None, :]
        d = d_all[start : start + step, None, :]
        denom = d[..., 0] * e[None, :, 1] - d[..., 1] * e[None, :, 0]
        w = p[None] - o
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # masked below
            t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / denom
            u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / denom
        ok = (np.abs(denom) > parallel) & (t >= near) & (t <= far) & (u >= 0.0) & (u <= 1.0)
        t = np.where(ok, t, np.inf)
        best = np.argmin(t, axis=1)
        chunk_t = t[np.arange(len(t)), best]
        distance[start : start + step] = chunk_t
        index[start : start + step] = np.where(np.isfinite(chunk_t), best, -1)
    return distance, index


def cast_on_boxes(
    boxes: npt.ArrayLike, origins: npt.ArrayLike, angles: npt.ArrayLike
) -> FloatArray:
    """Distance [m] from each origin along each angle [rad] to the first box (``inf`` if none).

    Slab test, vectorised over rays ``(n,)`` and boxes ``(k, 4)`` ``(xmin, ymin, xmax, ymax)``.
    A ray starting inside a box reports 0.
    """
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 2)
    a = np.asarray(angles, dtype=np.float64).reshape(-1)
    if b.shape[0] == 0:
        return np.full(a.shape, np.inf)
    dx, dy = np.cos(a)[:, None], np.sin(a)[:, None]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tx1 = (b[None, :, 0] - o[:, 0:1]) / dx
        tx2 = (b[None, :, 2] - o[:, 0:1]) / dx
        ty1 = (b[None, :, 1] - o[:, 1:2]) / dy
        ty2 = (b[None, :, 3] - o[:, 1:2]) / dy
    inside_x = (o[:, 0:1] >= b[None, :, 0]) & (o[:, 0:1] <= b[None, :, 2])
    inside_y = (o[:, 1:2] >= b[None, :, 1]) & (o[:, 1:2] <= b[None, :, 3])
    # a ray parallel to a slab never enters it unless it starts inside
    t_near_x = np.where(dx == 0, np.where(inside_x, -np.inf, np.inf), np.minimum(tx1, tx2))
    t_far_x = np.where(dx == 0, np.where(inside_x, np.inf, -np.inf), np.maximum(tx1, tx2))
    t_near_y = np.where(dy == 0, np.where(inside_y, -np.inf, np.inf), np.minimum(ty1, ty2))
    t_far_y = np.where(dy == 0, np.where(inside_y, np.inf, -np.inf), np.maximum(ty1, ty2))
    t_near = np.maximum(t_near_x, t_near_y)
    t_far = np.minimum(t_far_x, t_far_y)
    entry = np.maximum(t_near, 0.0)
    t = np.where(t_far >= entry, entry, np.inf)
    return np.asarray(t.min(axis=1))
