"""The rover's decision maths as pure functions (Post et al. 2016 §4.4–4.5, eqs. 38–43).

These are the ground truth the decision network of :mod:`bayesmap.rover.network` must agree
with. Angles are world angles [rad]; positions are in the map frame [m].
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.geometry import wrap_angle


def exploration_target(
    entropy: npt.ArrayLike,
    distance: npt.ArrayLike,
    *,
    d_max: float,
    d_min: float = 0.0,
    margin: float = 0.0,
) -> int:
    """Flat index of the exploration target among the given cells, or −1 if none qualifies.

    Eq. 38 takes the cell of largest entropy ``H`` within ``d_max`` of the rover; eq. 39
    prefers, among the cells whose entropy is within ``margin`` (``delta_h``) of that
    largest value, the one nearest the rover. ``distance`` [m] is each cell's distance from
    the rover: the straight line of the paper, or a path length over the map (``inf`` for
    cells that cannot be reached). ``margin = 0`` gives eq. 38 with ties broken toward the
    rover. Cells closer than ``d_min`` are not candidates; nor are cells of NaN entropy.

    Examples
    --------
    >>> H = np.array([0.9, 1.0, 0.97])
    >>> exploration_target(H, [1.0, 5.0, 2.0], d_max=8.0)
    1
    >>> exploration_target(H, [1.0, 5.0, 2.0], d_max=8.0, margin=0.05)
    2
    """
    h = np.asarray(entropy, dtype=np.float64).ravel()
    d = np.asarray(distance, dtype=np.float64).ravel()
    candidate = (d < d_max) & (d >= d_min) & np.isfinite(h)
    if not np.any(candidate):
        return -1
    best = float(h[candidate].max())
    near_best = candidate & (h >= best - margin)
    return int(np.argmin(np.where(near_best, d, np.inf)))


def navigation_goal(theta: npt.ArrayLike, theta_t: float) -> FloatArray:
    """``P(T | R, d, theta_t)`` at headings ``theta`` [rad], eq. 40 as printed.

    ``exp(-(theta - theta_t)^2 / (pi^2 / 4)) / ((pi / 2) sqrt(2 pi))``, with the angle
    difference wrapped to ``[-pi, pi)``.
    """
    diff = wrap_angle(np.asarray(theta, dtype=np.float64) - theta_t)
    return np.asarray(
        np.exp(-(diff**2) / (np.pi**2 / 4.0)) / ((np.pi / 2.0) * math.sqrt(2.0 * np.pi))
    )


def _corridor(
    xc: FloatArray,
    yc: FloatArray,
    rover: tuple[float, float],
    theta: FloatArray,
    d_max: float,
    clearance: float,
) -> tuple[BoolArray, BoolArray, FloatArray, FloatArray]:
    """Cells within ``d_max`` (mask), and for those: in-corridor flags, along-track and range."""
    dx, dy = xc.ravel() - rover[0], yc.ravel() - rover[1]
    distance = np.hypot(dx, dy)
    near = distance <= d_max
    dx, dy, distance = dx[near], dy[near], distance[near]
    c, s = np.cos(theta), np.sin(theta)
    offsets = np.stack([dx, dy])
    along = np.stack([c, s], axis=1) @ offsets
    lateral = np.stack([-s, c], axis=1) @ offsets
    inside = (along > 0.0) & (np.abs(lateral) <= clearance)
    return near, inside, along, distance


def collision_probability(
    probability: npt.ArrayLike,
    xc: npt.ArrayLike,
    yc: npt.ArrayLike,
    rover: tuple[float, float],
    theta: npt.ArrayLike,
    *,
    d_max: float,
    clearance: float,
    distance_weighted: bool = True,
) -> FloatArray:
    """``P(O | R, d, theta_m)`` for each heading ``theta_m`` (eq. 42, or eq. 41).

    The cells swept by a corridor of half-width ``clearance`` [m] along the heading, out to
    ``d_max``, are summed, each weighted by ``d_max - |x - x_bar|`` (eq. 42; weight 1 for
    eq. 41), and normalised by the sum of the weights so that the result is a probability.
    A heading whose corridor holds no cell gets 0. The rover's footprint is checked apart
    from this (:mod:`bayesmap.rover.safety`).
    """
    p = np.asarray(probability, dtype=np.float64).ravel()
    t = np.asarray(theta, dtype=np.float64).ravel()
    near, inside, _, distance = _corridor(
        np.asarray(xc, dtype=np.float64),
        np.asarray(yc, dtype=np.float64),
        rover,
        t,
        d_max,
        clearance,
    )
    p = p[near]
    weight = (d_max - distance) if distance_weighted else np.ones_like(distance)
    weight = inside * weight[None, :]
    total = weight.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = weight @ p / total
    return np.asarray(np.where(total > 0, value, 0.0))


def movement_distribution(p_t: npt.ArrayLike, p_o: npt.ArrayLike) -> FloatArray:
    """``P(M | O, R, d) ∝ P(T | R, d, theta_t) + (1 - P(O | R, d, theta_m))``, eq. 43."""
    score = np.asarray(p_t, dtype=np.float64) + (1.0 - np.asarray(p_o, dtype=np.float64))
    return np.asarray(score / score.sum())


def heading_decision(p_t: npt.ArrayLike, p_o: npt.ArrayLike) -> int:
    """``argmax_M P(M | O, R, r, d)``: index of the heading to drive (§4.5)."""
    return int(np.argmax(movement_distribution(p_t, p_o)))
