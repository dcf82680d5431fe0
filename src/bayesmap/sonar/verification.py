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
    """Case B: the reading claims free space through a trait of L."""
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
    """
    if len(v) == 0 or len(ell) == 0:
        return np.zeros((len(v), len(ell)), dtype=bool)
    dv = v[:, 2:] - v[:, :2]
    dl = ell[:, 2:] - ell[:, :2]
    len_v = np.hypot(dv[:, 0], dv[:, 1])[:, None]
    length = np.hypot(dl[:, 0], dl[:, 1])[None, :]
    av = np.arctan2(dv[:, 1], dv[:, 0])[:, None]
    al = np.arctan2(dl[:, 1], dl[:, 0])[None, :]
    diff = np.abs((av - al + math.pi / 2) % math.pi - math.pi / 2)
    ul = dl / np.maximum(length[0], 1e-12)[:, None]

    def offset(points: FloatArray) -> FloatArray:
        rel = points[:, None, :] - ell[None, :, :2]
        return np.asarray(np.abs(rel[..., 0] * ul[None, :, 1] - rel[..., 1] * ul[None, :, 0]))

    near = np.maximum(offset(v[:, :2]), offset(v[:, 2:])) <= match_offset
    t0 = ((v[:, None, :2] - ell[None, :, :2]) * ul[None]).sum(-1)
    t1 = ((v[:, None, 2:] - ell[None, :, :2]) * ul[None]).sum(-1)
    shared = np.minimum(np.maximum(t0, t1), length) - np.maximum(np.minimum(t0, t1), 0.0)
    real = (len_v > 1e-3) & (length > 1e-3)
    return np.asarray(real & (diff <= match_angle) & near & (shared > 0.0))


def axis_segment_hits(centres: FloatArray, axis: FloatArray, segments: FloatArray) -> FloatArray:
    """``(n, m)`` distance [m] along each beam axis to each segment (``inf``: not crossed)."""
    d = np.column_stack([np.cos(axis), np.sin(axis)])[:, None, :]
    p = segments[None, :, :2]
    e = segments[None, :, 2:] - p
    w = p - centres[:, None, :]
    denom = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / denom
        u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / denom
    ok = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    return np.asarray(np.where(ok, t, np.inf))


def head_on(axis: FloatArray, segments: FloatArray, critical_angle: float) -> BoolArray:
    """``(n, m)``: beam axis ``axis[i]`` [rad] meets segment ``j`` within ``critical_angle``
    [rad] of its normal, so a wall there would certainly echo (the axis ray itself returns)."""
    e = segments[:, 2:] - segments[:, :2]
    length = np.maximum(np.hypot(e[:, 0], e[:, 1]), 1e-12)
    # |cos| of the angle between the axis and the wall's normal = |sin| of the angle to the wall.
    cross = np.cos(axis)[:, None] * e[None, :, 1] - np.sin(axis)[:, None] * e[None, :, 0]
    return np.asarray(np.abs(cross) / length[None, :] >= math.cos(critical_angle))


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
        another trait in front of it. This raises rejection precision but lowers κ in the
        walled worlds (docs/sonar.md, *Support / contradiction*), so it is off by default.

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
        overruled = echo & supported if keep_supported_echoes else np.zeros(n, dtype=bool)
        reason[contradicted & ~overruled] = TVReason.CONTRADICTS_L
    reason[~candidate] = TVReason.KEPT
    return reason
