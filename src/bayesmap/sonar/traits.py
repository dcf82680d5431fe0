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
    centroid = points.sum(axis=0) / len(points)
    rel = points - centroid
    (sxx, sxy), (_, syy) = (rel.T @ rel).tolist()
    # The major axis of the 2x2 scatter matrix (its leading eigenvector), in closed form.
    angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
    return centroid, np.array([math.cos(angle), math.sin(angle)])


def _residuals(points: FloatArray, centroid: FloatArray, direction: FloatArray) -> FloatArray:
    rel = points - centroid
    return np.asarray(np.abs(rel[:, 0] * direction[1] - rel[:, 1] * direction[0]))


def _split(
    points: FloatArray, start: int, stop: int, tolerance: float, out: list[tuple[int, int]]
) -> None:
    stack = [(start, stop)]
    while stack:
        a, b = stack.pop()
        if b - a <= 2:
            out.append((a, b))
            continue
        p, q = points[a], points[b - 1]
        chord = q - p
        length = float(np.hypot(*chord))
        rel = points[a:b] - p
        if length > 0:
            dist = np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]) / length
        else:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        worst = int(np.argmax(dist))
        if dist[worst] <= tolerance or worst in (0, b - a - 1):
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
    step = np.hypot(*np.diff(pts, axis=0).T) if n > 1 else np.zeros(0)
    cuts = np.concatenate([[0], np.flatnonzero(step > max_gap) + 1, [n]])
    pieces: list[tuple[int, int]] = []
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        _split(pts, int(a), int(b), tolerance, pieces)
    pieces.sort()
    kept = [(a, b) for a, b in pieces if b - a >= min_points]
    # Each merged piece: first and last index, its members and its line (centroid, direction).
    merged: list[tuple[int, int, list[int], tuple[FloatArray, FloatArray]]] = []
    for a, b in kept:
        members = list(range(a, b))
        if merged:
            pa, pb, prev, _ = merged[-1]
            joint = prev + members
            if float(np.hypot(*(pts[a] - pts[pb - 1]))) <= max_gap:
                line = fit_line(pts[joint])
                if _residuals(pts[joint], *line).max() <= tolerance:
                    merged[-1] = (pa, b, joint, line)
                    continue
        merged.append((a, b, members, fit_line(pts[members])))
    segments = []
    for _, _, members, (centroid, direction) in merged:
        sel = pts[members]
        t = np.sort((sel - centroid) @ direction)
        distinct = 1 + int(np.count_nonzero(np.diff(t) > min_spacing))
        if distinct < min_points or t[-1] - t[0] < min_length:
            continue
        segments.append(np.concatenate([centroid + t[0] * direction, centroid + t[-1] * direction]))
        labels[members] = len(segments) - 1
        residuals[members] = _residuals(sel, centroid, direction)
    return Traits(np.asarray(segments).reshape(-1, 4), labels, residuals)


def point_segment_distance(points: FloatArray, segments: FloatArray) -> FloatArray:
    """``(n, m)`` distance [m] from each point ``(n, 2)`` to each segment ``(m, 4)``."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 1, 2)
    a = segments[None, :, :2]
    e = segments[None, :, 2:] - a
    length2 = np.maximum((e**2).sum(axis=-1), 1e-12)
    t = np.clip(((p - a) * e).sum(axis=-1) / length2, 0.0, 1.0)
    closest = a + t[..., None] * e
    return np.asarray(np.hypot(*(p - closest).transpose(2, 0, 1)))
