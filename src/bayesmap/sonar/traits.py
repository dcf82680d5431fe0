"""Traits: line segments fitted to sonar echo points by split-and-merge.

The fragment leaves the line fitting open; we use split-and-merge (iterative end-point
fit), the fastest of the common 2-D line extractors with good accuracy (Nguyen et al.
2005). Points are taken in order of bearing around the robot, cut into runs where
consecutive points are more than ``max_gap`` apart, and each run is split recursively at
the point farthest from the chord until every point is within ``tolerance`` of it. Pieces
with fewer than ``min_points`` points are left unexplained; consecutive pieces whose
total-least-squares lines agree (every point of both within ``tolerance`` of the joint
line) are merged. A trait is the joint line clipped to its points' projections.

Trait hygiene (what real logs taught us): a standing robot repeats the same echo point, so a
trait must have ``min_points`` *distinct* points (more than ``min_spacing`` apart along the
line) and be at least ``min_length`` long; anything less is not a line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import pairwise
from typing import NamedTuple

import numpy as np

from bayesmap._typing import FloatArray, IntArray

__all__ = ["Traits", "fit_line", "fit_traits", "point_segment_distance"]


class Traits(NamedTuple):
    """Line segments and which points support them.

    Attributes
    ----------
    segments
        ``(m, 4)`` segments ``(x0, y0, x1, y1)`` [m].
    labels
        ``(n,)`` index of the trait each input point supports; −1 for none.
    residuals
        ``(n,)`` perpendicular distance of each point to its trait's line [m] (``nan`` for none).
    """

    segments: FloatArray
    labels: IntArray
    residuals: FloatArray


def fit_line(points: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Total-least-squares line through ``points`` ``(n, 2)``: its centroid and unit direction."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    cx, cy, dx, dy = _line(pts[:, 0].tolist(), pts[:, 1].tolist(), range(len(pts)))
    return np.array([cx, cy]), np.array([dx, dy])


def _line(
    xs: list[float], ys: list[float], members: Sequence[int]
) -> tuple[float, float, float, float]:
    """:func:`fit_line` of the points ``members`` of ``xs, ys`` as plain floats (a trait has
    a few dozen points, where numpy's per-call overhead outweighs the arithmetic)."""
    sx = sy = 0.0
    for i in members:
        sx += xs[i]
        sy += ys[i]
    cx, cy = sx / len(members), sy / len(members)
    sxx = sxy = syy = 0.0
    for i in members:
        rx, ry = xs[i] - cx, ys[i] - cy
        sxx += rx * rx
        sxy += rx * ry
        syy += ry * ry
    # The major axis of the 2x2 scatter matrix (its leading eigenvector), in closed form.
    angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
    return cx, cy, math.cos(angle), math.sin(angle)


def _residuals(
    xs: list[float], ys: list[float], members: Sequence[int], line: tuple[float, ...]
) -> list[float]:
    """Distance of each member point from ``line`` ``(cx, cy, dx, dy)`` [m]."""
    cx, cy, dx, dy = line
    return [abs((xs[i] - cx) * dy - (ys[i] - cy) * dx) for i in members]


def _split(
    xs: list[float],
    ys: list[float],
    start: int,
    stop: int,
    tolerance: float,
    out: list[tuple[int, int]],
) -> None:
    """Split ``[start, stop)`` at the point farthest from the chord until all are within
    ``tolerance`` (iterative end-point fit). Plain floats: a run has a few dozen points, where
    numpy's per-call overhead would outweigh the arithmetic."""
    stack = [(start, stop)]
    while stack:
        a, b = stack.pop()
        if b - a <= 2:
            out.append((a, b))
            continue
        px, py = xs[a], ys[a]
        cx, cy = xs[b - 1] - px, ys[b - 1] - py
        length = float(np.hypot(cx, cy))
        if length > 0:
            dist = [
                abs((x - px) * cy - (y - py) * cx) / length
                for x, y in zip(xs[a:b], ys[a:b], strict=True)
            ]
        else:
            dist = np.hypot(np.subtract(xs[a:b], px), np.subtract(ys[a:b], py)).tolist()
        far = max(dist)
        worst = dist.index(far)
        if far <= tolerance or worst in (0, b - a - 1):
            out.append((a, b))
            continue
        stack.append((a + worst, b))
        stack.append((a, a + worst))


def fit_traits(
    points: FloatArray,
    *,
    tolerance: float = 0.1,
    min_points: int = 3,
    max_gap: float = 1.0,
    min_length: float = 0.0,
    min_spacing: float = 0.0,
) -> Traits:
    """Split-and-merge line traits over ``points`` ``(n, 2)`` given in scan (bearing) order.

    Parameters
    ----------
    points
        Echo points [m], ordered by bearing around the robot.
    tolerance
        Largest distance of a point from its trait's line [m].
    min_points
        Fewest points a trait needs.
    max_gap
        Consecutive points farther apart than this [m] never share a trait.
    min_length
        Shortest trait kept [m].
    min_spacing
        Points closer than this [m] along the line count as one towards ``min_points``.

    Returns
    -------
    :class:`Traits`.

    Examples
    --------
    A corner: the point where a split falls (here the corner) starts the second piece.

    >>> pts = np.array([[0, 1], [1, 1], [2, 1], [3, 1], [3, 2], [3, 3], [3, 4]], dtype=float)
    >>> traits = fit_traits(pts, tolerance=0.05, max_gap=1.5)
    >>> len(traits.segments), traits.labels.tolist()
    (2, [0, 0, 0, 1, 1, 1, 1])
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = len(pts)
    labels = np.full(n, -1, dtype=np.int64)
    residuals = np.full(n, np.nan)
    if n == 0:
        return Traits(np.zeros((0, 4)), labels, residuals)
    xs, ys = pts[:, 0].tolist(), pts[:, 1].tolist()
    step = np.hypot(pts[1:, 0] - pts[:-1, 0], pts[1:, 1] - pts[:-1, 1]).tolist()
    cuts = [0, *(i + 1 for i, s in enumerate(step) if s > max_gap), n]
    pieces: list[tuple[int, int]] = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        _split(xs, ys, a, b, tolerance, pieces)
    pieces.sort()
    kept = [(a, b) for a, b in pieces if b - a >= min_points]
    # Each merged piece: first and last index, its members and its line (cx, cy, dx, dy).
    merged: list[tuple[int, int, list[int], tuple[float, float, float, float]]] = []
    for a, b in kept:
        members = list(range(a, b))
        if merged:
            pa, pb, prev, _ = merged[-1]
            joint = prev + members
            if math.hypot(xs[a] - xs[pb - 1], ys[a] - ys[pb - 1]) <= max_gap:
                line = _line(xs, ys, joint)
                if max(_residuals(xs, ys, joint, line)) <= tolerance:
                    merged[-1] = (pa, b, joint, line)
                    continue
        merged.append((a, b, members, _line(xs, ys, members)))
    segments = []
    label_list = labels.tolist()
    residual_list = residuals.tolist()
    for _, _, members, line in merged:
        cx, cy, dx, dy = line
        t = sorted((xs[i] - cx) * dx + (ys[i] - cy) * dy for i in members)
        distinct = 1 + sum(1 for u, v in pairwise(t) if v - u > min_spacing)
        if distinct < min_points or t[-1] - t[0] < min_length:
            continue
        segments.append((cx + t[0] * dx, cy + t[0] * dy, cx + t[-1] * dx, cy + t[-1] * dy))
        for i, e in zip(members, _residuals(xs, ys, members, line), strict=True):
            label_list[i] = len(segments) - 1
            residual_list[i] = e
    return Traits(
        np.array(segments, dtype=np.float64).reshape(-1, 4),
        np.array(label_list, dtype=np.int64),
        np.array(residual_list, dtype=np.float64),
    )


def point_segment_distance(points: FloatArray, segments: FloatArray) -> FloatArray:
    """``(n, m)`` distance [m] from each point ``(n, 2)`` to each segment ``(m, 4)``."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    ax, ay = segments[:, 0], segments[:, 1]
    ex, ey = segments[:, 2] - ax, segments[:, 3] - ay
    length2 = np.maximum(ex * ex + ey * ey, 1e-12)
    rx, ry = p[:, :1] - ax, p[:, 1:] - ay
    t = np.minimum(np.maximum((rx * ex + ry * ey) / length2, 0.0), 1.0)
    return np.hypot(rx - t * ex, ry - t * ey)
