"""The joint log density of a blackboard, eq. 14, computed from scratch (Fox & Prescott 2011).

log P(B) = Σ_T [log (2δ)³ c_T + m_T log ε_a]                       (eqs. 4, 15, 19)
         + Σ_L log (2δ)³ (α_L e^{−Δ_TL} [pa(L) ≠ ∅] + c_L)          (eqs. 5, 6, 8, 12, 19)
         + Σ_S log (c_S + Σ_L α_S e^{−Δ_LS})                          (eqs. 7, 9, 12)
         + (pairs of legs at one corner of one table) log ε           (eq. 17)
         + (overlapping pairs of tables or of legs) log ε             (eq. 16)

up to the normalising constant Z. It uses the vectorised functions of
:mod:`bayesmap.blackboard.densities`, independently of the cached scalar bookkeeping the
sampler uses, so tests can check every move's Markov-blanket ratio against it.
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap.blackboard.densities import (
    delta_leg_shapelet,
    delta_table_leg,
    density_leg_given_table,
    density_shapelet,
    rectangles_overlap,
)
from bayesmap.blackboard.hypotheses import NULL, Blackboard


def log_joint(board: Blackboard) -> float:
    """log P(B) of eq. 14 (up to log Z) for ``board``'s hypotheses and shapelets."""
    p = board.params
    log_eps = math.log(p.epsilon)
    tables = board.table_array()
    legs = board.leg_array()
    table_keys = list(board.tables_)
    total = len(table_keys) * (p.log_box + math.log(p.c_T))

    # legs given their explicit parent, and which corner they sit at
    corners_used: dict[tuple[int, int], int] = {}
    for row, key in enumerate(board.legs_):
        parent = board.parent_[key]
        if parent == NULL:
            density = p.c_L
        else:
            t = tables[table_keys.index(parent)]
            a = 0.5 * (p.table_length - t[3])
            b = 0.5 * (p.table_width - t[3])
            delta, corner = delta_table_leg(
                t, legs[row], a, b, p.sigma_r_leg, p.sigma_theta_leg, p.sigma_w, p.sigma_tau_leg
            )
            density = float(density_leg_given_table(delta, p.alpha_L, p.c_L))
            corners_used[(parent, int(corner))] = corners_used.get((parent, int(corner)), 0) + 1
        total += p.log_box + math.log(density)

    # φ_a: missing legs; φ_b: pairs of legs sharing a corner
    for key in table_keys:
        missing = sum(1 for i in range(4) if corners_used.get((key, i), 0) == 0)
        total += missing * math.log(p.epsilon_a)
    total += sum(n * (n - 1) // 2 for n in corners_used.values()) * log_eps

    # shapelets: noisy-OR sum of densities
    shapelets = np.array(board.shapelets_, dtype=np.float64).reshape(-1, 4)
    if len(shapelets):
        d = delta_leg_shapelet(
            legs[:, None, :],
            shapelets[None, :, :],
            p.sigma_r_shapelet,
            p.sigma_theta_shapelet,
            p.sigma_tau_shapelet,
        )
        total += float(np.sum(np.log(density_shapelet(d, p.alpha_S, p.c_S, axis=0))))

    # φ_c: overlapping pairs of one type
    for rects in (
        np.column_stack(
            [
                tables[:, :3],
                np.full(len(tables), 0.5 * p.table_length),
                np.full(len(tables), 0.5 * p.table_width),
            ]
        ),
        np.column_stack([legs[:, :3], 0.5 * legs[:, 3], 0.5 * legs[:, 4]]),
    ):
        if len(rects) > 1:
            i, j = np.triu_indices(len(rects), k=1)
            total += int(np.sum(rectangles_overlap(rects[i], rects[j]))) * log_eps
    return total
