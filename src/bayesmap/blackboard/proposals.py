"""The proposal distributions Q of Algorithm 1 (Fox & Prescott 2011 §II-C).

The paper chooses its Q's "heuristically" and does not state them; these are ours. Each is a
function ``propose(rng, board, params, target) -> Move | None`` (``None``: nothing to
propose), drawing only from ``rng``:

- :func:`propose_leg_for_shapelet` — Q(pa(S)): a leg placed so that the shapelet lies on its
  perimeter with the shapelet's normal as the face's outward normal; where along the face
  the contact is, is uniform, and the normal gets a little angle noise.
- :func:`propose_death` — the hypothesis removed.
- :func:`propose_parent_change` — a leg's parent replaced by a table within
  ``parent_radius`` (spatial-hash look-up) or by the null cause, uniformly among those that
  differ from the current one.
- :func:`propose_child` — Q(ch(T) | T): a leg exactly at a corner of the table, with the
  table's angle, leg width and texture; the corner is uniform among the corners that have no
  leg yet (among all four if none is free).
- :func:`propose_parent` — Q(pa(L) | L): a table with the leg at one of its four corners
  and its long side along one of the leg's two face directions — the eight tables a single
  leg allows (a table is symmetric under θ → θ + π) — then jittered by a small Gaussian in
  position and angle so that repeated proposals can fit several legs at once. The paper's
  choice is uniform (``parent_fit_weight = 0``); by default the eight are weighted by how
  many shapelets lie near the table's other corners, a cheap "smart proposal" in the sense
  of the paper's §IV: without it the sampler spends most of its time on tables that cannot
  explain the other contacts.
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap.blackboard.blanket import Move, MoveKind
from bayesmap.blackboard.densities import CORNER_SIGNS
from bayesmap.blackboard.hypotheses import NULL, Blackboard, Leg, make_leg, make_table
from bayesmap.blackboard.params import BlackboardParams

_HALF_PI = 0.5 * math.pi


def propose_leg_for_shapelet(
    rng: np.random.Generator, board: Blackboard, params: BlackboardParams, target: int
) -> Move:
    """A new null-caused leg for shapelet ``target`` (its parent proposal, Q(pa(S_i)))."""
    x, y, theta, tau = board.shapelets_[target]
    normal = theta + params.leg_jitter_theta * rng.standard_normal()
    w = params.leg_width
    along = (rng.random() - 0.5) * w
    c, s = math.cos(normal), math.sin(normal)
    leg = make_leg(x - 0.5 * w * c - along * s, y - 0.5 * w * s + along * c, normal, w, w, tau)
    return Move(MoveKind.BIRTH, target, leg=leg)


def propose_death(
    rng: np.random.Generator, board: Blackboard, params: BlackboardParams, target: int
) -> Move:
    """Removal of hypothesis ``target`` (a table or a leg)."""
    return Move(MoveKind.DEATH, target)


def propose_parent_change(
    rng: np.random.Generator, board: Blackboard, params: BlackboardParams, target: int
) -> Move | None:
    """Leg ``target``'s parent replaced by a nearby table or the null cause (uniform)."""
    current = board.parent_[target]
    options = board.candidate_parents(board.legs_[target], params.parent_radius)
    options.append(NULL)
    options = [t for t in options if t != current]
    if not options:
        return None
    return Move(MoveKind.PARENT_CHANGE, target, parent=options[int(rng.random() * len(options))])


def propose_child(
    rng: np.random.Generator, board: Blackboard, params: BlackboardParams, target: int
) -> Move:
    """A new leg at a corner of table ``target``, preferring corners without a leg."""
    table = board.tables_[target]
    free = [i for i, legs in enumerate(board.children_[target]) if not legs] or [0, 1, 2, 3]
    cx, cy = table.corners[free[int(rng.random() * len(free))]]
    leg = make_leg(cx, cy, table.theta, table.w, table.w, table.tau)
    return Move(MoveKind.CHILD, target, leg=leg, parent=target)


def _config_fits(board: Blackboard, leg: Leg, a: float, b: float, radius: float) -> list[int]:
    """For each of the eight tables a leg allows (turn 0/1 × corner), how many shapelets
    lie within ``radius`` [m] of one of the table's other three corners."""
    r2 = radius * radius
    counts = [0] * 8
    for turn in (0, 1):
        theta = leg.theta + _HALF_PI * turn
        c, s = math.cos(theta), math.sin(theta)
        rel = [
            (c * (sx - leg.x) + s * (sy - leg.y), -s * (sx - leg.x) + c * (sy - leg.y))
            for sx, sy, _, _ in board.shapelets_
        ]
        for i, (gx, gy) in enumerate(CORNER_SIGNS):
            # the other corners sit at (−2a gx, 0), (0, −2b gy), (−2a gx, −2b gy) from the leg
            du, dv = -2.0 * a * gx, -2.0 * b * gy
            n = 0
            for u, v in rel:
                if (
                    (u - du) ** 2 + v * v <= r2
                    or u * u + (v - dv) ** 2 <= r2
                    or (u - du) ** 2 + (v - dv) ** 2 <= r2
                ):
                    n += 1
            counts[4 * turn + i] = n
    return counts


def propose_parent(
    rng: np.random.Generator, board: Blackboard, params: BlackboardParams, target: int
) -> Move:
    """A new table with leg ``target`` at one of its corners (Q(pa(L_i) | L_i)).

    The eight tables with the leg at a corner (four corners × the leg's two face directions
    for the long side) are weighted by exp(λ n), n the number of shapelets near the
    table's other three corners and λ = ``params.parent_fit_weight`` (λ = 0: uniform), one
    is drawn, and its pose is jittered.
    """
    leg = board.legs_[target]
    w = 0.5 * (leg.wx + leg.wy)
    a = 0.5 * (params.table_length - w)
    b = 0.5 * (params.table_width - w)
    configs: list[tuple[float, float, float]] = []
    for turn in (0, 1):
        theta = leg.theta + _HALF_PI * turn
        c, s = math.cos(theta), math.sin(theta)
        for sx, sy in CORNER_SIGNS:
            configs.append(
                (leg.x - (c * sx * a - s * sy * b), leg.y - (s * sx * a + c * sy * b), theta)
            )
    if params.parent_fit_weight > 0.0 and board.shapelets_:
        radius = w + 2.0 * params.sigma_r_shapelet
        weights = [
            math.exp(params.parent_fit_weight * n) for n in _config_fits(board, leg, a, b, radius)
        ]
        u = rng.random() * sum(weights)
        index = 0
        while index < 7 and u >= weights[index]:
            u -= weights[index]
            index += 1
    else:
        index = int(rng.random() * 8)
    x, y, theta = configs[index]
    dtheta = params.table_jitter_theta * rng.standard_normal()
    # rotate the table about the leg by the angle jitter, then shift it
    c, s = math.cos(dtheta), math.sin(dtheta)
    x, y = leg.x + c * (x - leg.x) - s * (y - leg.y), leg.y + s * (x - leg.x) + c * (y - leg.y)
    x += params.table_jitter_xy * rng.standard_normal()
    y += params.table_jitter_xy * rng.standard_normal()
    return Move(MoveKind.PARENT, target, table=make_table(x, y, theta + dtheta, w, leg.tau, params))
