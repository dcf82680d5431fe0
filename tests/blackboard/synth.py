"""Synthetic shapelets touching the legs of known tables (test helper, no simulator)."""

from __future__ import annotations

import math

import numpy as np

from bayesmap.blackboard import BlackboardParams, make_table


def leg_contact(
    table: tuple[float, float, float],
    corner: int,
    face: int,
    along: float,
    params: BlackboardParams,
    tau: float = 0.5,
) -> tuple[float, float, float, float]:
    """A noiseless shapelet on ``face`` (0: +x, 1: +y, 2: -x, 3: -y of the table frame) of the
    leg at ``corner``, ``along`` in [-0.5, 0.5] leg widths from the face's middle."""
    t = make_table(*table, params.leg_width, tau, params)
    cx, cy = t.corners[corner]
    normal = t.theta + face * 0.5 * math.pi
    c, s = math.cos(normal), math.sin(normal)
    w = params.leg_width
    x = cx + 0.5 * w * c - along * w * s
    y = cy + 0.5 * w * s + along * w * c
    return (x, y, math.atan2(s, c), tau)


def three_leg_shapelets(params: BlackboardParams, table: tuple[float, float, float]) -> np.ndarray:
    """Three shapelets on the outward faces of corners 0, 1 and 3 of ``table``."""
    return np.array(
        [
            leg_contact(table, 0, 0, 0.1, params),
            leg_contact(table, 1, 1, -0.2, params),
            leg_contact(table, 3, 3, 0.0, params),
        ]
    )
