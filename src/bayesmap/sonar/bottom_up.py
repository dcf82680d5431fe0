"""Acceptability and Agreeability: the bottom-up stages of the ICINCO 2007 fragment (p. 494).

Both judge a reading ``s`` of one ring against its neighbours ``s-1`` and ``s+1`` in the
same reading set.

*Acceptability* (readings that report an obstacle). The fragment translates ``s`` to the
position of the neighbour and computes "upper and lower bound profiles for s ... by scaling
the original distance ... by the amount of translation ... taking cognisance of the natural
error range of the sensor". Our reading (documented in docs/sonar.md): ``s`` says a wall
stands at range ``d`` in its cone, facing it within the angles that return an echo (normal
within ``beta/2 + critical_angle`` of the axis). For wall tilts sampled over that range we
predict what the neighbour, from its own position, would report: its perpendicular distance
to the wall when the wall's normal is inside its cone, the distance along its nearest cone
edge when it is within the critical angle beyond, and anything from the perpendicular
distance up to no echo when the wall is specular for the neighbour. The union over tilts
gives the bounds ``[lower, upper]``; the neighbour's reading, under the eq. 1 Gaussian,
"encompasses" them when it is within ``k sigma`` of the interval.

*Agreeability* (readings that report free space, i.e. no echo). Ranges are compared
directly: a neighbour agrees when it too reports no echo.

Both stages discard ``s`` only when *both* neighbours refute it and flag it (as "possibly
erroneous", for Trait Verification) when one does; at the ends of an open arc the single
neighbour can flag, never discard.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.geometry import wrap_angle
from bayesmap.sensing.sonar import reading_likelihood

__all__ = ["Verdict", "acceptability", "agreeability", "neighbour_bounds"]


class Verdict(NamedTuple):
    """Outcome of a bottom-up stage per reading: ``discard`` and ``flag`` ``(n,)`` booleans."""

    discard: BoolArray
    flag: BoolArray


def neighbour_bounds(
    d: FloatArray,
    centre: FloatArray,
    axis: FloatArray,
    neighbour_centre: FloatArray,
    neighbour_axis: FloatArray,
    *,
    half_width: float,
    critical_angle: float,
    tilts: int = 9,
) -> tuple[FloatArray, FloatArray]:
    """Bounds on a neighbour's reading if reading ``s`` (range ``d``) is a true wall echo.

    Parameters
    ----------
    d
        ``(n,)`` ranges of ``s`` [m].
    centre, axis
        ``(n, 2)`` positions [m] and ``(n,)`` bearings [rad] of the transducers of ``s``.
    neighbour_centre, neighbour_axis
        The same for the neighbour.
    half_width
        Half the cone width [rad].
    critical_angle
        Largest incidence off a wall's normal that still echoes [rad].
    tilts
        Wall orientations sampled.

    Returns
    -------
    (lower, upper)
        ``(n,)`` bounds [m]; ``upper`` is ``inf`` when some tilt leaves the neighbour
        without a direct echo.
    """
    limit = half_width + critical_angle
    psi = np.linspace(-limit, limit, tilts)[None, :]
    # Perpendicular distance from s to the wall: the cone edge echoes beyond half_width.
    offcone = np.maximum(np.abs(psi) - half_width, 0.0)
    wall_distance = d[:, None] * np.cos(offcone)
    normal_angle = axis[:, None] + psi
    normal = np.stack([np.cos(normal_angle), np.sin(normal_angle)], axis=-1)
    shift = neighbour_centre - centre
    neighbour_distance = wall_distance - (normal * shift[:, None, :]).sum(axis=-1)
    incidence = np.abs(wrap_angle(normal_angle - neighbour_axis[:, None]))
    beyond = np.maximum(incidence - half_width, 0.0)
    direct = (incidence <= limit) & (neighbour_distance > 0)
    with np.errstate(divide="ignore"):
        predicted = neighbour_distance / np.cos(np.minimum(beyond, math.pi / 2 - 1e-9))
    low = np.where(direct, predicted, np.maximum(neighbour_distance, 0.0))
    high = np.where(direct, predicted, np.inf)
    return low.min(axis=1), high.max(axis=1)


def _combine(
    refuted_left: BoolArray, refuted_right: BoolArray, left: IntArray, right: IntArray
) -> Verdict:
    has_left, has_right = left >= 0, right >= 0
    rl = refuted_left & has_left
    rr = refuted_right & has_right
    discard = rl & rr
    return Verdict(discard=discard, flag=(rl | rr) & ~discard)


def acceptability(
    ranges: FloatArray,
    echo: BoolArray,
    centres: FloatArray,
    axis: FloatArray,
    left: IntArray,
    right: IntArray,
    *,
    sigma: float,
    half_width: float,
    critical_angle: float,
    k: float = 3.0,
    tilts: int = 9,
) -> Verdict:
    """Acceptability of obstacle readings against their neighbours (ICINCO 2007, p. 494).

    Parameters
    ----------
    ranges
        ``(n,)`` readings of one ring [m].
    echo
        ``(n,)`` which readings report an obstacle; only those are judged.
    centres, axis
        ``(n, 2)`` transducer positions [m] and ``(n,)`` bearings [rad].
    left, right
        ``(n,)`` indices of the neighbours (−1: none).
    sigma
        Range standard deviation of eq. 1 [m].
    half_width, critical_angle
        Half cone width and critical incidence [rad].
    k
        Width of the sensor's "natural error range" in standard deviations.
    tilts
        Wall orientations sampled for the bounds.

    Returns
    -------
    :class:`Verdict` (non-echo readings are never discarded or flagged here).
    """
    threshold = reading_likelihood(k * sigma, sigma)

    n = len(ranges)
    # Both neighbours in one pass: the left ones, then the right ones.
    idx = np.where(np.concatenate([left, right]) >= 0, np.concatenate([left, right]), 0)
    lower, upper = neighbour_bounds(
        np.tile(ranges, 2),
        np.tile(centres, (2, 1)),
        np.tile(axis, 2),
        centres[idx],
        axis[idx],
        half_width=half_width,
        critical_angle=critical_angle,
        tilts=tilts,
    )
    value = ranges[idx]
    gap = np.maximum(np.maximum(lower - value, value - upper), 0.0)
    refuted = (reading_likelihood(gap, sigma) < threshold) & np.tile(echo, 2)
    return _combine(refuted[:n], refuted[n:], left, right)


def agreeability(echo: BoolArray, left: IntArray, right: IntArray) -> Verdict:
    """Agreeability of free-space (no-echo) readings (ICINCO 2007, p. 494).

    A neighbour agrees with a no-echo reading when it also reports no echo. ``s`` is
    discarded when neither neighbour reports free space and flagged for Trait
    Verification when one disagrees.
    """
    free = ~echo
    disagree_left = free & echo[np.where(left >= 0, left, 0)]
    disagree_right = free & echo[np.where(right >= 0, right, 0)]
    return _combine(disagree_left, disagree_right, left, right)
