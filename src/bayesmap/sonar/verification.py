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
from enum import IntEnum

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.sonar.traits import point_segment_distance

__all__ = [
    "TVReason",
    "axis_segment_hits",
    "certainty",
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
    so only pairs whose bounding boxes, grown by ``match_offset``, meet are tested. A ring
    has a few traits against a few dozen in ``L``: plain floats beat numpy's per-call cost.
    """
    out = np.zeros((len(v), len(ell)), dtype=bool)
    if len(v) == 0 or len(ell) == 0:
        return out
    reach = match_offset + 1e-9
    lines = ell.tolist()
    for i, (vx0, vy0, vx1, vy1) in enumerate(v.tolist()):
        if math.hypot(vx1 - vx0, vy1 - vy0) <= 1e-3:
            continue
        angle = math.atan2(vy1 - vy0, vx1 - vx0)
        left = (vx0 if vx0 < vx1 else vx1) - reach
        right = (vx1 if vx0 < vx1 else vx0) + reach
        bottom = (vy0 if vy0 < vy1 else vy1) - reach
        top = (vy1 if vy0 < vy1 else vy0) + reach
        for j, (x0, y0, x1, y1) in enumerate(lines):
            if (
                (x0 < left and x1 < left)
                or (x0 > right and x1 > right)
                or (y0 < bottom and y1 < bottom)
                or (y0 > top and y1 > top)
            ):
                continue
            dx, dy = x1 - x0, y1 - y0
            length = math.hypot(dx, dy)
            turn = abs((angle - math.atan2(dy, dx) + math.pi / 2) % math.pi - math.pi / 2)
            if length <= 1e-3 or turn > match_angle:
                continue
            ux, uy = dx / length, dy / length
            r0x, r0y, r1x, r1y = vx0 - x0, vy0 - y0, vx1 - x0, vy1 - y0
            if max(abs(r0x * uy - r0y * ux), abs(r1x * uy - r1y * ux)) > match_offset:
                continue
            t0, t1 = r0x * ux + r0y * uy, r1x * ux + r1y * uy
            out[i, j] = min(max(t0, t1), length) - max(min(t0, t1), 0.0) > 0.0
    return out


def axis_segment_hits(centres: FloatArray, axis: FloatArray, segments: FloatArray) -> FloatArray:
    """``(n, m)`` distance [m] along each beam axis to each segment (``inf``: not crossed)."""
    cos, sin = np.cos(axis)[:, None], np.sin(axis)[:, None]
    px, py = segments[:, 0], segments[:, 1]
    ex, ey = segments[:, 2] - px, segments[:, 3] - py
    wx, wy = px - centres[:, :1], py - centres[:, 1:]
    denom = cos * ey - sin * ex
    crossed = np.abs(denom) > 1e-12
    # Parallel pairs divide by 1 instead of ~0 and are masked out below.
    safe = np.where(crossed, denom, 1.0)
    t = (wx * ey - wy * ex) / safe
    u = (wx * sin - wy * cos) / safe
    return np.where(crossed & (t > 0) & (u >= 0) & (u <= 1), t, np.inf)


def head_on(axis: FloatArray, segments: FloatArray, critical_angle: float) -> BoolArray:
    """``(n, m)``: beam axis ``axis[i]`` [rad] meets segment ``j`` within ``critical_angle``
    [rad] of its normal, so a wall there would certainly echo (the axis ray itself returns)."""
    ex, ey = segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1]
    length = np.maximum(np.hypot(ex, ey), 1e-12)
    # |cos| of the angle between the axis and the wall's normal = |sin| of the angle to the wall.
    cross = np.cos(axis)[:, None] * ey - np.sin(axis)[:, None] * ex
    return np.abs(cross) / length >= math.cos(critical_angle)


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

    Returns
    -------
    ``(n,)`` :class:`TVReason` codes; ``KEPT`` for readings not discarded.
    """
    n = len(ranges)
    reason = np.full(n, TVReason.KEPT, dtype=np.int64)
    on_trait = labels >= 0
    trait_supported = np.asarray(
        equivalent(v_segments, l_segments, match_angle=match_angle, match_offset=match_offset).any(
            axis=1
        )
    )
    supported = np.zeros(n, dtype=bool)
    supported[on_trait] = trait_supported[labels[on_trait]]
    crossing = np.full(n, np.inf)
    if len(l_segments):
        quiet = np.flatnonzero(~echo)
        spread = (-no_echo_spread, no_echo_spread) if no_echo_spread > 0.0 and len(quiet) else ()
        # Every axis, then each spread ray of the no-echo readings, in one pass.
        rays = np.concatenate([axis, *(axis[quiet] + side for side in spread)])
        starts = np.concatenate([centres, *(centres[quiet] for _ in spread)])
        hits = axis_segment_hits(starts, rays, l_segments)
        quiet_hits = hits[quiet]
        for j in range(len(spread)):
            quiet_hits = np.minimum(quiet_hits, hits[n + j * len(quiet) : n + (j + 1) * len(quiet)])
        if critical_angle is not None and len(quiet):
            quiet_hits = np.where(
                head_on(axis[quiet], l_segments, critical_angle), np.inf, quiet_hits
            )
        hits[quiet] = quiet_hits
        crossing = hits[:n].min(axis=1)
    reach = np.where(echo, ranges, max_range)
    contradicted = crossing < reach - margin
    loose = echo & ~on_trait
    if np.any(loose) and len(l_segments):
        points = centres[loose] + ranges[loose, None] * np.column_stack(
            [np.cos(axis[loose]), np.sin(axis[loose])]
        )
        supported[loose] = point_segment_distance(points, l_segments).min(axis=1) <= match_offset
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
                overruled &= _supported_echoes(
                    echo & contradicted,
                    on_trait,
                    labels,
                    ranges,
                    centres,
                    axis,
                    v_segments,
                    l_segments[anchors],
                    match_angle,
                    match_offset,
                )
        reason[contradicted & ~overruled] = TVReason.CONTRADICTS_L
    elif contradict_in_case_a:
        # In case A only the silent readings: a no-echo reading whose cone crosses a known
        # trait that its axis does not meet head-on lost its echo (the wall was too oblique).
        reason[contradicted & ~echo] = TVReason.CONTRADICTS_L
    reason[~candidate] = TVReason.KEPT
    return reason


def _supported_echoes(
    asked: BoolArray,
    on_trait: BoolArray,
    labels: IntArray,
    ranges: FloatArray,
    centres: FloatArray,
    axis: FloatArray,
    v_segments: FloatArray,
    l_segments: FloatArray,
    match_angle: float,
    match_offset: float,
) -> BoolArray:
    """Which ``asked`` echoes agree with ``l_segments``: their trait of ``V`` is equivalent
    to one, or (an echo on no trait) their echo point lies within ``match_offset`` of one."""
    out = np.zeros(len(ranges), dtype=bool)
    if not np.any(asked) or len(l_segments) == 0:
        return out
    matched = np.asarray(
        equivalent(v_segments, l_segments, match_angle=match_angle, match_offset=match_offset).any(
            axis=1
        )
    )
    traited = asked & on_trait
    out[traited] = matched[labels[traited]]
    loose = asked & ~on_trait
    if np.any(loose):
        points = centres[loose] + ranges[loose, None] * np.column_stack(
            [np.cos(axis[loose]), np.sin(axis[loose])]
        )
        out[loose] = point_segment_distance(points, l_segments).min(axis=1) <= match_offset
    return out
