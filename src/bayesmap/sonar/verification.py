"""Trait Verification: the top-down stage of the ICINCO 2007 fragment (p. 494).

``V`` holds the traits fitted to the current readings, ``L`` the traits of past readings
along the path, extended to the robot's current position. Certainty values in [0, 1] are
computed for the readings behind traits of ``V`` and ``V`` is reconciled with ``L``.

The fragment stops mid-sentence; the choices below are ours (docs/sonar.md):

- *certainty* ``c = exp(-½ e² / sigma_c²)`` (eq. 1 scaled to peak 1), with ``e`` the
  reading's distance to its trait's line and ``sigma_c = sigma + d (1 - cos(beta/2))``
  (Elfes' range error plus the displacement of a reading across its cone);
- *equivalent traits*: both of positive length, directions within ``match_angle``, both
  ends of the ``V`` trait within ``match_offset`` of the ``L`` trait's line, and their
  projections overlapping by a positive length (a point-like trait has no direction, so it
  is equivalent to nothing);
- a reading is *supported* by ``L`` when its trait has an equivalent in ``L``; an echo on no
  trait when its echo point lies within ``match_offset`` of an ``L`` trait; a no-echo
  reading when no ``L`` trait crosses its axis;
- a reading is *contradicted* by ``L`` when its axis crosses an ``L`` trait more than
  ``margin`` before the range it reports (it claims free space through a known wall);
- *not enough state for L* (case A, as the fragment says): discard a reading that is flagged
  or below the certainty threshold and not supported;
- *enough state* (case B): discard contradicted readings; a supported reading is accepted
  unless flagged with certainty below the threshold (the fragment's missing rule, mirroring
  case A); an unsupported one is judged as in case A.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.sonar.traits import point_segment_distance

__all__ = [
    "ConeHits",
    "TVReason",
    "axis_segment_hits",
    "certainty",
    "coincide",
    "cone_hits",
    "head_on",
    "equivalent",
    "extend_segments",
    "reconcile",
]


class TVReason(IntEnum):
    """Why Trait Verification kept or discarded a reading."""

    KEPT = 0
    UNSUPPORTED_FLAGGED = 1
    """Case A (or unsupported in case B): flagged, and no equivalent trait in L."""
    UNSUPPORTED_UNCERTAIN = 2
    """Case A (or unsupported in case B): certainty below the threshold, no equivalent in L."""
    CONTRADICTS_L = 3
    """Case B (and case A for a no-echo reading, with ``contradict_in_case_a``): the reading
    claims free space through a trait of L."""
    FLAGGED_UNCERTAIN = 4
    """Case B: coincides with L but flagged and below the certainty threshold."""


def certainty(
    residual: FloatArray, distance: FloatArray, *, sigma: float, half_width: float
) -> FloatArray:
    """Certainty in [0, 1] of readings behind traits (our reading of the fragment's rule).

    ``c = exp(-½ e² / sigma_c²)``, ``sigma_c = sigma + distance · (1 - cos(half_width))``.

    Parameters
    ----------
    residual
        Distance of each reading's echo point from its trait's line [m] (``nan``: no trait).
    distance
        Range of each reading [m].
    sigma
        Range standard deviation [m].
    half_width
        Half the cone width [rad].
    """
    sigma_c = sigma + np.asarray(distance) * (1.0 - math.cos(half_width))
    return np.asarray(np.exp(-0.5 * (np.asarray(residual) / sigma_c) ** 2))


def extend_segments(segments: FloatArray, length: float) -> FloatArray:
    """Lengthen each segment ``(m, 4)`` by ``length`` [m] at both ends."""
    a, b = segments[:, :2], segments[:, 2:]
    d = b - a
    norm = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)[:, None]
    u = d / norm
    return np.hstack([a - length * u, b + length * u])


def equivalent(
    v: FloatArray, ell: FloatArray, *, match_angle: float, match_offset: float
) -> BoolArray:
    """``(m, k)``: trait ``v[i]`` coincides with trait ``ell[j]`` (angle, offset, overlap).

    Sound for short traits: a segment shorter than 1 mm has no direction and matches nothing;
    both ends of ``v[i]`` must lie near ``ell[j]``'s line and the two must share a stretch.

    Such a pair always has a point within ``match_offset`` of both traits (the offset of
    ``v[i]`` from the line varies linearly between its ends and the projections overlap),
    so the pairs whose bounding boxes, grown by ``match_offset``, miss each other are
    screened out for all pairs at once; the few left (a trait of ``V`` lies near one or two
    of the few dozen in ``L``) are tested by :func:`coincide` on plain floats.
    """
    out = np.zeros((len(v), len(ell)), dtype=bool)
    if len(v) == 0 or len(ell) == 0:
        return out
    reach = match_offset + 1e-9
    vx0, vy0, vx1, vy1 = v[:, 0:1], v[:, 1:2], v[:, 2:3], v[:, 3:4]
    x0, y0, x1, y1 = ell[:, 0], ell[:, 1], ell[:, 2], ell[:, 3]
    # The grown box of v[i] and the box of ell[j] meet on both axes.
    meet = (np.maximum(x0, x1) >= np.minimum(vx0, vx1) - reach) & (
        np.minimum(x0, x1) <= np.maximum(vx0, vx1) + reach
    )
    meet &= np.maximum(y0, y1) >= np.minimum(vy0, vy1) - reach
    meet &= np.minimum(y0, y1) <= np.maximum(vy0, vy1) + reach
    rows, cols = np.nonzero(meet)
    if len(rows):
        vs, lines = v.tolist(), ell.tolist()
        for i, j in zip(rows.tolist(), cols.tolist(), strict=True):
            out[i, j] = coincide(vs[i], lines[j], match_angle, match_offset)
    return out


def coincide(
    v: Sequence[float], ell: Sequence[float], match_angle: float, match_offset: float
) -> bool:
    """Whether trait ``v`` ``(x0, y0, x1, y1)`` coincides with trait ``ell`` (see
    :func:`equivalent`), on plain floats: one pair costs less than numpy's call overhead.

    Pairs whose bounding boxes, ``v``'s grown by ``match_offset``, miss each other are out
    at once (a coinciding pair always has a point within ``match_offset`` of both).
    """
    vx0, vy0, vx1, vy1 = v
    x0, y0, x1, y1 = ell
    reach = match_offset + 1e-9
    if (
        max(x0, x1) < min(vx0, vx1) - reach
        or min(x0, x1) > max(vx0, vx1) + reach
        or max(y0, y1) < min(vy0, vy1) - reach
        or min(y0, y1) > max(vy0, vy1) + reach
    ):
        return False  # the boxes, v's grown by match_offset, do not meet
    dx, dy = x1 - x0, y1 - y0
    length = math.hypot(dx, dy)
    if math.hypot(vx1 - vx0, vy1 - vy0) <= 1e-3 or length <= 1e-3:
        return False
    angle = math.atan2(vy1 - vy0, vx1 - vx0)
    turn = abs((angle - math.atan2(dy, dx) + math.pi / 2) % math.pi - math.pi / 2)
    if turn > match_angle:
        return False
    ux, uy = dx / length, dy / length
    r0x, r0y, r1x, r1y = vx0 - x0, vy0 - y0, vx1 - x0, vy1 - y0
    if max(abs(r0x * uy - r0y * ux), abs(r1x * uy - r1y * ux)) > match_offset:
        return False
    t0, t1 = r0x * ux + r0y * uy, r1x * ux + r1y * uy
    return min(max(t0, t1), length) - max(min(t0, t1), 0.0) > 0.0


def axis_segment_hits(centres: FloatArray, axis: FloatArray, segments: FloatArray) -> FloatArray:
    """``(n, m)`` distance [m] along each beam axis to each segment (``inf``: not crossed)."""
    return cone_hits(centres, axis, segments, 0.0).axis


def head_on(axis: FloatArray, segments: FloatArray, critical_angle: float) -> BoolArray:
    """``(n, m)``: beam axis ``axis[i]`` [rad] meets segment ``j`` within ``critical_angle``
    [rad] of its normal, so a wall there would certainly echo (the axis ray itself returns)."""
    ex, ey = segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1]
    cross = np.cos(axis)[:, None] * ey - np.sin(axis)[:, None] * ex
    return _facing(cross, np.maximum(np.hypot(ex, ey), 1e-12), critical_angle)


def _facing(cross: FloatArray, length: FloatArray, critical_angle: float) -> BoolArray:
    """:func:`head_on` from the cross products of the unit axes with the segments' vectors
    (``length`` long): |cos| of the angle to the wall's normal = |sin| of the angle to the
    wall."""
    return np.asarray(np.abs(cross) / length >= math.cos(critical_angle))


class ConeHits(NamedTuple):
    """Where each reading's beam meets each of ``k`` segments (from :func:`cone_hits`).

    Attributes
    ----------
    axis
        ``(n, k)`` distance [m] along each reading's axis to each segment (``inf``: missed).
    edges
        ``(n, k)`` the nearer of the two crossings of the rays ``spread`` either side of the
        axis (with ``spread`` 0, the axis crossings).
    cross
        ``(n, k)`` cross product of each unit axis with each segment's vector [m].
    length
        ``(k,)`` length of each segment [m] (at least 1e-12).
    spread
        Angle of the side rays off the axis [rad].
    """

    axis: FloatArray
    edges: FloatArray
    cross: FloatArray
    length: FloatArray
    spread: float

    def head_on(
        self, rows: IntArray, critical_angle: float, columns: slice | IntArray = slice(None)
    ) -> BoolArray:
        """:func:`head_on` for the readings ``rows`` and the segments ``columns``, from the
        crossings already computed."""
        return _facing(self.cross[rows][:, columns], self.length[columns], critical_angle)


def cone_hits(
    centres: FloatArray, axis: FloatArray, segments: FloatArray, spread: float
) -> ConeHits:
    """Ray crossings of every reading's axis and of the rays ``±spread`` [rad] beside it
    with every segment, in one pass (``spread`` 0: the axis only).

    A ray from ``c`` along unit ``d`` meets segment ``p + u e`` (``0 <= u <= 1``) at
    distance ``t > 0`` where ``c + t d = p + u e``; parallel pairs never meet.
    """
    n = len(axis)
    if spread > 0.0:
        rays = np.concatenate([axis, axis + (-spread), axis + spread])
        starts = np.concatenate([centres] * 3)
    else:
        rays, starts = axis, centres
    cos, sin = np.cos(rays)[:, None], np.sin(rays)[:, None]
    px, py = segments[:, 0], segments[:, 1]
    ex, ey = segments[:, 2] - px, segments[:, 3] - py
    wx, wy = px - starts[:, :1], py - starts[:, 1:]
    denom = cos * ey - sin * ex
    crossed = np.abs(denom) > 1e-12
    # Parallel pairs divide by 1 instead of ~0 and are masked out below.
    safe = np.where(crossed, denom, 1.0)
    t = (wx * ey - wy * ex) / safe
    u = (wx * sin - wy * cos) / safe
    hits = np.where(crossed & (t > 0) & (u >= 0) & (u <= 1), t, np.inf)
    length = np.maximum(np.hypot(ex, ey), 1e-12)
    # With no spread the side rays are the axis itself.
    edges = np.minimum(hits[n : 2 * n], hits[2 * n :]) if spread > 0.0 else hits
    return ConeHits(hits[:n], edges, denom[:n], length, max(spread, 0.0))


def reconcile(
    *,
    candidate: BoolArray,
    echo: BoolArray,
    flagged: BoolArray,
    ranges: FloatArray,
    centres: FloatArray,
    axis: FloatArray,
    labels: IntArray,
    certainties: FloatArray,
    v_segments: FloatArray,
    l_segments: FloatArray,
    enough_state: bool,
    max_range: float,
    certainty_threshold: float,
    match_angle: float,
    match_offset: float,
    margin: float,
    no_echo_spread: float = 0.0,
    critical_angle: float | None = None,
    keep_supported_echoes: bool = False,
    anchors: BoolArray | None = None,
    contradict_in_case_a: bool = False,
    hits: ConeHits | None = None,
    echo_points: FloatArray | None = None,
) -> IntArray:
    """Reconcile the current readings' traits ``V`` with the local view ``L``.

    Parameters
    ----------
    candidate
        ``(n,)`` readings still in play (not discarded by earlier stages).
    echo, flagged
        ``(n,)`` obstacle readings; readings flagged by earlier stages.
    ranges, centres, axis
        ``(n,)`` ranges [m], ``(n, 2)`` transducer positions [m], ``(n,)`` bearings [rad].
    labels, certainties
        ``(n,)`` index of each reading's trait in ``v_segments`` (−1: none) and its certainty.
    v_segments, l_segments
        ``V`` and the (extended) ``L`` as ``(m, 4)`` and ``(k, 4)`` segments [m].
    enough_state
        Whether ``L`` spans four perceptual lengths (case B) or not (case A).
    max_range, certainty_threshold, match_angle, match_offset, margin
        See :class:`~bayesmap.sonar.filter.SpecularFilter`.
    no_echo_spread
        A no-echo reading is also tested along the rays ``±no_echo_spread`` [rad] off its
        axis: a known wall anywhere across its cone within range means its echo was lost.
    critical_angle
        If given [rad], a trait whose normal the axis of a no-echo reading meets within this
        angle does not contradict it: a wall there would have echoed, so the silence speaks
        against the trait (a person who walked on), not against the reading.
    keep_supported_echoes
        If true, an echo whose range agrees with ``L`` (supported) is not contradicted by
        another trait in front of it (the filter then stops its free space before that
        trait). Off by default (docs/sonar.md, *Support / contradiction*).
    anchors
        ``(k,)`` the traits of ``L`` that can keep an echo so (default: all of them); the
        filter passes the ones that look like static structure (``static_span``).
    contradict_in_case_a
        If true, a contradicted reading is discarded in case A too (``L`` then holds the
        traits within the max range), not only when it is also flagged: a no-echo reading
        whose cone crosses a known wall lost its echo, whether or not a neighbour noticed.
    hits
        ``cone_hits(centres, axis, l_segments, s)`` if the caller has it (the filter shares
        it with :meth:`~bayesmap.sonar.filter.SpecularFilter`'s free-space stops); used when
        ``s`` is ``no_echo_spread`` (or only its axis part when that is 0), else recomputed.
    echo_points
        ``(n, 2)`` each reading's echo point ``centres + ranges (cos axis, sin axis)`` [m], if
        the caller has it (the filter computes them for a batch of rings at once).

    Returns
    -------
    ``(n,)`` :class:`TVReason` codes; ``KEPT`` for readings not discarded.
    """
    n = len(ranges)
    reason = np.zeros(n, dtype=np.int64)  # TVReason.KEPT
    on_trait = labels >= 0
    # Which trait of V is equivalent to which of L, and which loose echo lies near which
    # trait of L: once, for the support of every reading and for the anchored subset.
    matches = equivalent(v_segments, l_segments, match_angle=match_angle, match_offset=match_offset)
    supported = np.zeros(n, dtype=bool)
    supported[on_trait] = np.asarray(matches.any(axis=1))[labels[on_trait]]
    crossing = np.full(n, np.inf)
    if len(l_segments):
        if hits is None or not (hits.spread == no_echo_spread or no_echo_spread <= 0.0):
            hits = cone_hits(centres, axis, l_segments, no_echo_spread)
        crossing = hits.axis.min(axis=1)
        quiet = (~echo).nonzero()[0]
        if len(quiet):
            quiet_hits = hits.axis[quiet]
            if no_echo_spread > 0.0:
                quiet_hits = np.minimum(quiet_hits, hits.edges[quiet])
            if critical_angle is not None:
                quiet_hits = np.where(hits.head_on(quiet, critical_angle), np.inf, quiet_hits)
            crossing[quiet] = quiet_hits.min(axis=1)
    reach = np.where(echo, ranges, max_range)
    contradicted = crossing < reach - margin
    loose = echo & ~on_trait
    near_loose = np.zeros((0, len(l_segments)), dtype=bool)
    if len(l_segments) and loose.any():
        if echo_points is None:
            points = centres[loose] + ranges[loose, None] * np.column_stack(
                [np.cos(axis[loose]), np.sin(axis[loose])]
            )
        else:
            points = echo_points[loose]
        near_loose = point_segment_distance(points, l_segments) <= match_offset
        supported[loose] = near_loose.any(axis=1)
    supported[~echo] = ~contradicted[~echo]
    uncertain = on_trait & (certainties < certainty_threshold)
    unsupported_flagged = ~supported & flagged
    unsupported_uncertain = ~supported & uncertain & ~flagged
    reason[unsupported_flagged] = TVReason.UNSUPPORTED_FLAGGED
    reason[unsupported_uncertain] = TVReason.UNSUPPORTED_UNCERTAIN
    if enough_state:
        reason[supported & flagged & uncertain] = TVReason.FLAGGED_UNCERTAIN
        overruled = np.zeros(n, dtype=bool)
        if keep_supported_echoes:
            overruled = echo & supported
            if anchors is not None and not anchors.all():
                # Only agreement with an anchor keeps a contradicted echo.
                asked = echo & contradicted
                anchored = np.zeros(n, dtype=bool)
                traited = asked & on_trait
                anchored[traited] = np.asarray(matches[:, anchors].any(axis=1))[labels[traited]]
                if len(near_loose):
                    anchored[loose] = near_loose[:, anchors].any(axis=1) & asked[loose]
                overruled &= anchored
        reason[contradicted & ~overruled] = TVReason.CONTRADICTS_L
    elif contradict_in_case_a:
        # In case A only the silent readings: a no-echo reading whose cone crosses a known
        # trait that its axis does not meet head-on lost its echo (the wall was too oblique).
        reason[contradicted & ~echo] = TVReason.CONTRADICTS_L
    reason[~candidate] = TVReason.KEPT
    return reason
