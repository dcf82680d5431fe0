"""The joint log density of a blackboard, eq. 14, computed from scratch (Fox & Prescott 2011).

log P(B) = Σ_T [log (2δ)³ c_T + m_T log ε_a]                       (eqs. 4, 15, 19)
         + Σ_L log (2δ)³ (α_L e^{−Δ_TL} [pa(L) ≠ ∅] + c_L)          (eqs. 5, 6, 8, 12, 19)
         + Σ_S log (c_S + Σ_L α_S e^{−Δ_LS})                          (eqs. 7, 9, 12)
         + (pairs of legs at one corner of one table) log ε           (eq. 17)
         + (overlapping pairs of tables or of legs) log ε             (eq. 16)

up to the normalising constant Z. It is built from the factors φ_a, φ_b, φ_c and the
box probability of :mod:`bayesmap.blackboard.densities` (so a test can swap one of them)
and their other vectorised functions, independently of the cached scalar bookkeeping the
sampler uses, so tests can check every move's Markov-blanket ratio against it.
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap.blackboard.densities import (
    box_probability,
    delta_leg_shapelet,
    delta_table_leg,
    density_leg_given_table,
    density_shapelet,
    phi_a,
    phi_b,
    phi_c,
    rectangles_overlap,
)
from bayesmap.blackboard.hypotheses import NULL, Blackboard


def log_joint(board: Blackboard) -> float:
    """log P(B) of eq. 14 (up to log Z) for ``board``'s hypotheses and shapelets."""
    p = board.params
    tables = board.table_array()
    legs = board.leg_array()
    table_keys = list(board.tables_)
    total = float(np.sum(np.log(box_probability(np.full(len(table_keys), p.c_T), p.delta))))

    # legs given their explicit parent, and which corner they sit at
    corner_of = np.full((len(board.legs_), 2), NULL, dtype=np.int64)  # (parent, corner)
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
            corner_of[row] = parent, int(corner)
        total += math.log(float(box_probability(np.asarray(density), p.delta)))

    # φ_a: each table's corners without a leg (eq. 15)
    used = {(int(t), int(c)) for t, c in corner_of if t != NULL}
    missing = np.array([sum((key, i) not in used for i in range(4)) for key in table_keys])
    total += float(np.sum(np.log(phi_a(missing, p.epsilon_a))))

    # φ_b: pairs of legs at one corner of one table (eq. 17)
    i, j = np.triu_indices(len(corner_of), k=1)
    same_corner = np.all(corner_of[i] == corner_of[j], axis=1) & (corner_of[i, 0] != NULL)
    total += float(np.sum(np.log(phi_b(same_corner, p.epsilon))))

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

    # φ_c: overlapping pairs of one type (eq. 16)
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
            total += float(np.sum(np.log(phi_c(rectangles_overlap(rects[i], rects[j]), p.epsilon))))
    return total
