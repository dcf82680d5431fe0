"""The factors of the blackboard's factor graph as small pure functions (Fox & Prescott 2011 §II-B).

Each equation comes twice where the sampler needs it: a vectorised numpy version (arrays
broadcast against each other; the reference that tests check against hand computations and
brute force) and, with a ``_scalar`` suffix, a plain-``math`` version for one pair of
hypotheses, which is what the sampler's hot path calls (numpy costs microseconds per call
on scalars). Tests check that the two agree.

Conventions: a table row is ``(x, y, theta, w_L, tau)``, a leg row
``(x, y, theta, w_x, w_y, tau)``, a shapelet row ``(x, y, theta, tau)``; positions [m],
angles [rad]. Densities are returned as logs where products of many small numbers meet.
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap._typing import BoolArray, FloatArray, IntArray
from bayesmap.geometry import wrap_angle

#: Corner signs ``(s_x, s_y)`` of the four legs in the table frame, in corner-index order.
CORNER_SIGNS: tuple[tuple[float, float], ...] = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
_SIGNS = np.array(CORNER_SIGNS)
_HALF_PI = 0.5 * math.pi
_QUARTER_PI = 0.25 * math.pi
_TWO_PI = 2.0 * math.pi


def table_corners(tables: FloatArray, a: float, b: float) -> FloatArray:
    """Leg-centre corners ``(x_T^i, y_T^i)`` of tables (eq. 6), shape ``(..., 4, 2)`` [m].

    Parameters
    ----------
    tables
        ``(..., ≥3)`` rows starting ``x, y, theta``.
    a, b
        Offsets [m] of the leg centres from the table centre along its long and short axes
        (:attr:`BlackboardParams.corner_offset`).
    """
    t = np.asarray(tables, dtype=np.float64)
    c, s = np.cos(t[..., 2]), np.sin(t[..., 2])
    u = _SIGNS[:, 0] * a
    v = _SIGNS[:, 1] * b
    x = t[..., 0, None] + c[..., None] * u - s[..., None] * v
    y = t[..., 1, None] + s[..., None] * u + c[..., None] * v
    return np.stack([x, y], axis=-1)


def delta_table_leg(
    tables: FloatArray,
    legs: FloatArray,
    a: float,
    b: float,
    sigma_r: float,
    sigma_theta: float,
    sigma_w: float,
    sigma_tau: float,
) -> tuple[FloatArray, IntArray]:
    """Distance Δ_TL between tables and legs, and the corner it is taken at (eq. 6).

    Δ_TL = min_i [(x_T^i − x_L)² + (y_T^i − y_L)²]/σ_r² + ((θ_T − θ_L)/σ_θ)²
    + ((w_T^L − w_L^x)/σ_w)² + ((w_T^L − w_L^y)/σ_w)² + ((τ_T − τ_L)/σ_τ)².

    The paper's last width term reads ``w_T − w_L^y``; a table has one leg width, so it is
    ``w_T^L`` in both. A square leg is unchanged by a quarter turn, so θ_T − θ_L is wrapped
    with period π/2.

    Parameters
    ----------
    tables
        ``(..., 5)`` table rows ``x, y, theta, w_L, tau``.
    legs
        ``(..., 6)`` leg rows ``x, y, theta, w_x, w_y, tau`` (broadcast against tables).

    Returns
    -------
    delta, corner
        Δ_TL (unitless) and the index of the minimising corner (see :data:`CORNER_SIGNS`).
    """
    t = np.asarray(tables, dtype=np.float64)
    leg = np.asarray(legs, dtype=np.float64)
    corners = table_corners(t, a, b)
    d2 = (corners[..., 0] - leg[..., 0, None]) ** 2 + (corners[..., 1] - leg[..., 1, None]) ** 2
    corner = np.argmin(d2, axis=-1)
    pos = np.min(d2, axis=-1) / sigma_r**2
    ang = (wrap_angle(t[..., 2] - leg[..., 2], _HALF_PI) / sigma_theta) ** 2
    wid = ((t[..., 3] - leg[..., 3]) / sigma_w) ** 2 + ((t[..., 3] - leg[..., 4]) / sigma_w) ** 2
    tex = ((t[..., 4] - leg[..., 5]) / sigma_tau) ** 2
    return pos + ang + wid + tex, corner.astype(np.int64)


def delta_leg_shapelet(
    legs: FloatArray,
    shapelets: FloatArray,
    sigma_r: float,
    sigma_theta: float,
    sigma_tau: float,
) -> FloatArray:
    """Distance Δ_LS between legs and shapelets (eq. 7).

    Δ_LS = min_r (r/σ_r)² + ((θ_L − θ_S)/σ_θ)² + ((τ_L − τ_S)/σ_τ)², with r the distance
    from the shapelet's point to the leg's perimeter. A square's θ_L is only defined up to
    quarter turns, so the angle term compares the shapelet's normal θ_S with the outward
    normal of a face, and the minimum runs over the four faces jointly: the face that best
    explains both where the contact is and which way its normal points. For the nearest
    face this is eq. 7 exactly.

    Parameters
    ----------
    legs
        ``(..., 6)`` leg rows ``x, y, theta, w_x, w_y, tau``.
    shapelets
        ``(..., 4)`` shapelet rows ``x, y, theta, tau`` (broadcast against legs).
    """
    leg = np.asarray(legs, dtype=np.float64)
    s = np.asarray(shapelets, dtype=np.float64)
    c, sn = np.cos(leg[..., 2]), np.sin(leg[..., 2])
    dx, dy = s[..., 0] - leg[..., 0], s[..., 1] - leg[..., 1]
    u = c * dx + sn * dy
    v = -sn * dx + c * dy
    hx, hy = 0.5 * leg[..., 3], 0.5 * leg[..., 4]
    over_v = np.maximum(np.abs(v) - hy, 0.0)
    over_u = np.maximum(np.abs(u) - hx, 0.0)
    dist = np.stack(
        [
            np.hypot(u - hx, over_v),
            np.hypot(v - hy, over_u),
            np.hypot(u + hx, over_v),
            np.hypot(v + hy, over_u),
        ],
        axis=-1,
    )
    normals = leg[..., 2, None] + np.arange(4) * _HALF_PI
    ang = wrap_angle(s[..., 2, None] - normals)
    per_face = (dist / sigma_r) ** 2 + (ang / sigma_theta) ** 2
    tex = ((leg[..., 5] - s[..., 3]) / sigma_tau) ** 2
    return np.asarray(np.min(per_face, axis=-1) + tex, dtype=np.float64)


def density_leg_given_table(delta_tl: FloatArray, alpha_L: float, c_L: float) -> FloatArray:
    """Density of a leg given its parent table or chance, α_L e^{−Δ_TL} + c_L (eqs. 5, 8, 12).

    The leg's two causes (its table, eq. 5, and the null prior, eq. 8) combine by the
    continuous noisy-OR of eq. 12: their densities add. ``delta_tl = inf`` is a leg with
    no parent (density c_L).
    """
    return np.asarray(alpha_L * np.exp(-np.asarray(delta_tl)) + c_L, dtype=np.float64)


def density_shapelet(
    delta_ls: FloatArray, alpha_S: float, c_S: float, axis: int = -1
) -> FloatArray:
    """Density of shapelets given all legs, c_S + Σ_L α_S e^{−Δ_LS} (eqs. 7, 9, 12).

    Continuous noisy-OR (eq. 12, proved in the paper's appendix, eqs. 21–24): every leg on
    the blackboard and the null prior (eq. 9) may cause a shapelet, and their densities
    add. ``delta_ls`` holds Δ_LS with the legs along ``axis``.
    """
    return np.asarray(c_S + np.sum(alpha_S * np.exp(-np.asarray(delta_ls)), axis=axis))


def phi_a(missing: IntArray, epsilon: float) -> FloatArray:
    """Missing-leg factor φ_a = ε^m (eq. 15); m is a table's number of corners without a leg."""
    return np.asarray(epsilon ** np.asarray(missing, dtype=np.float64), dtype=np.float64)


def phi_b(same_corner: BoolArray, epsilon: float) -> FloatArray:
    """Shared-corner factor φ_b = ε^r (eq. 17), r true for two legs at one corner of one table.

    The paper's r is "legs that share the same parent"; constraint (b) it models is "each
    table leg is at a different corner", so r is true when two legs have the same parent
    table *and* the same (eq. 6 minimising) corner of it.
    """
    return np.asarray(np.where(np.asarray(same_corner), epsilon, 1.0), dtype=np.float64)


def phi_c(overlap: BoolArray, epsilon: float) -> FloatArray:
    """Overlap factor φ_c = ε^v (eq. 16), v true for two objects of one type that overlap."""
    return np.asarray(np.where(np.asarray(overlap), epsilon, 1.0), dtype=np.float64)


def rectangles_overlap(first: FloatArray, second: FloatArray) -> BoolArray:
    """Whether oriented rectangles overlap with positive area (separating-axis test).

    Rows are ``(x, y, theta, half_length, half_width)``; touching edges do not overlap.
    Used for constraint (c) (eq. 16) between two tables or two legs.
    """
    p = np.asarray(first, dtype=np.float64)
    q = np.asarray(second, dtype=np.float64)
    dx, dy = q[..., 0] - p[..., 0], q[..., 1] - p[..., 1]
    separated = np.zeros(np.broadcast_shapes(p.shape[:-1], q.shape[:-1]), dtype=bool)
    for axis_angle in (p[..., 2], p[..., 2] + _HALF_PI, q[..., 2], q[..., 2] + _HALF_PI):
        ax, ay = np.cos(axis_angle), np.sin(axis_angle)
        reach = 0.0
        for r in (p, q):
            ca = np.abs(np.cos(r[..., 2]) * ax + np.sin(r[..., 2]) * ay)
            sa = np.abs(-np.sin(r[..., 2]) * ax + np.cos(r[..., 2]) * ay)
            reach = reach + r[..., 3] * ca + r[..., 4] * sa
        separated |= np.abs(dx * ax + dy * ay) >= reach
    return ~separated


def box_probability(density: FloatArray, delta: float) -> FloatArray:
    """Probability of a discrete hypothesis of half-width δ in x, y, θ: (2δ)³ p (eq. 19)."""
    return np.asarray((2.0 * delta) ** 3 * np.asarray(density), dtype=np.float64)


def acceptance_probability(log_ratio: FloatArray, beta: float) -> FloatArray:
    """Annealed Gibbs acceptance of a candidate state (eqs. 20–21).

    The Markov-blanket conditional of eq. 21 compares the candidate (e.g. H_i true) with
    the current state (H_i false): with ``log_ratio`` = log P(candidate) − log P(current)
    over the factors that touch H_i, the annealed conditional P^β of the candidate among
    the two is 1 / (1 + exp(−β · log_ratio)). This is Barker's rule, whose chain leaves
    P^β invariant for symmetric proposals; as β → ∞ it accepts exactly the improvements.
    """
    z = -beta * np.asarray(log_ratio, dtype=np.float64)
    return np.asarray(0.5 * (1.0 + np.tanh(-0.5 * z)), dtype=np.float64)


# --- scalar versions for the sampler's hot path ---------------------------------------


def delta_table_leg_scalar(
    theta_T: float,
    w_T: float,
    tau_T: float,
    corners: tuple[tuple[float, float], ...],
    leg: tuple[float, float, float, float, float, float],
    sigma_r: float,
    sigma_theta: float,
    sigma_w: float,
    sigma_tau: float,
) -> tuple[float, int]:
    """Scalar :func:`delta_table_leg` for one table (angle, leg width, texture and its
    precomputed leg-centre corners) and one leg."""
    lx, ly = leg[0], leg[1]
    best = math.inf
    corner = 0
    for i, (cx, cy) in enumerate(corners):
        d2 = (cx - lx) ** 2 + (cy - ly) ** 2
        if d2 < best:
            best, corner = d2, i
    ang = (theta_T - leg[2] + _QUARTER_PI) % _HALF_PI - _QUARTER_PI
    w = w_T
    value = (
        best / sigma_r**2
        + (ang / sigma_theta) ** 2
        + ((w - leg[3]) / sigma_w) ** 2
        + ((w - leg[4]) / sigma_w) ** 2
        + ((tau_T - leg[5]) / sigma_tau) ** 2
    )
    return value, corner


def delta_leg_shapelet_scalar(
    leg: tuple[float, float, float, float, float, float],
    shapelet: tuple[float, float, float, float],
    sigma_r: float,
    sigma_theta: float,
    sigma_tau: float,
) -> float:
    """Scalar :func:`delta_leg_shapelet` for one leg and one shapelet."""
    x, y, theta, wx, wy, tau = leg
    c, s = math.cos(theta), math.sin(theta)
    dx, dy = shapelet[0] - x, shapelet[1] - y
    u = c * dx + s * dy
    v = -s * dx + c * dy
    hx, hy = 0.5 * wx, 0.5 * wy
    over_v = max(abs(v) - hy, 0.0)
    over_u = max(abs(u) - hx, 0.0)
    inv_r2 = 1.0 / sigma_r**2
    inv_t2 = 1.0 / sigma_theta**2
    best = math.inf
    for k, d in enumerate(
        (
            math.hypot(u - hx, over_v),
            math.hypot(v - hy, over_u),
            math.hypot(u + hx, over_v),
            math.hypot(v + hy, over_u),
        )
    ):
        ang = (shapelet[2] - theta - k * _HALF_PI + math.pi) % _TWO_PI - math.pi
        value = d * d * inv_r2 + ang * ang * inv_t2
        if value < best:
            best = value
    return best + ((tau - shapelet[3]) / sigma_tau) ** 2


def rectangles_overlap_scalar(
    p: tuple[float, float, float, float, float], q: tuple[float, float, float, float, float]
) -> bool:
    """Scalar :func:`rectangles_overlap` for rows ``(x, y, theta, half_length, half_width)``."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    cp, sp = math.cos(p[2]), math.sin(p[2])
    cq, sq = math.cos(q[2]), math.sin(q[2])
    for ax, ay in ((cp, sp), (-sp, cp), (cq, sq), (-sq, cq)):
        reach = (
            p[3] * abs(cp * ax + sp * ay)
            + p[4] * abs(-sp * ax + cp * ay)
            + q[3] * abs(cq * ax + sq * ay)
            + q[4] * abs(-sq * ax + cq * ay)
        )
        if abs(dx * ax + dy * ay) >= reach:
            return False
    return True


def acceptance_probability_scalar(log_ratio: float, beta: float) -> float:
    """Scalar :func:`acceptance_probability`."""
    z = beta * log_ratio
    if z >= 0.0:
        return 1.0 / (1.0 + math.exp(-z))
    e = math.exp(z)
    return e / (1.0 + e)
