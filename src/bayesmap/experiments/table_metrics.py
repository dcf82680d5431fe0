"""Scores of mapped tables against the true tables (the blackboard experiment's metrics).

Tables are compared by pose ``x, y`` [m], ``theta`` [rad]. A rectangle is the same under
``theta → theta + π``, so every angle difference is taken modulo π, in [0, π/2].

- **Match.** A mapped table matches a true table when their centres are within
  ``position_tol`` (default 0.2 m, a quarter of the 0.8 m table width) and their angles
  within ``angle_tol`` (default 15°, modulo π). Mapped and true tables are paired one to
  one by the Hungarian algorithm on the pose distance below, among the pairs that match.
- **Pose distance** (for pairing and GOSPA):
  ``d = sqrt(Δx² + Δy² + (angle_scale · Δθ)²)`` with Δθ the symmetric angle difference
  and ``angle_scale`` [m/rad] (default 0.6 m, half a table length): a rotation by Δθ
  counts as the distance a table's end moves. It is a metric (a weighted Euclidean
  product of metrics).
- **GOSPA** (Rahmathullah, García-Fernández & Svensson 2017, "Generalized optimal
  sub-pattern assignment metric"), with cut-off ``c`` (default 0.5 m), order ``p = 2`` and
  ``α = 2``: ``(min_γ Σ_{(i,j)∈γ} d(x_i, y_j)^p + c^p/2 · (|X| + |Y| − 2|γ|))^{1/p}``
  over assignments γ of pairs closer than c — each miss or phantom costs c^p / 2.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from bayesmap._typing import FloatArray, IntArray
from bayesmap.errors import InputError

__all__ = [
    "MatchTolerance",
    "angle_difference",
    "gospa",
    "match_tables",
    "near_wall",
    "fused_scores",
    "pose_distance",
    "score_run",
    "symmetry_period",
]


@dataclass(frozen=True)
class MatchTolerance:
    """When a mapped table counts as a true one, and the GOSPA parameters.

    Parameters
    ----------
    position_tol
        Largest centre distance of a match [m].
    angle_tol
        Largest angle difference of a match [rad], modulo π.
    angle_scale
        Metres per radian of angle error in :func:`pose_distance` [m/rad].
    c
        GOSPA cut-off [m].
    p
        GOSPA order.
    """

    position_tol: float = 0.2
    angle_tol: float = np.pi / 12
    angle_scale: float = 0.6
    c: float = 0.5
    p: float = 2.0


def _poses(tables: FloatArray, what: str) -> FloatArray:
    array = np.asarray(tables, dtype=np.float64)
    if array.size == 0:
        return np.zeros((0, 3))
    if array.ndim != 2 or array.shape[1] < 3:
        raise InputError(f"{what} must be a (k, >=3) array of x, y, theta rows, got {array.shape}")
    return array[:, :3]


def angle_difference(
    a: FloatArray, b: FloatArray, period: float | FloatArray = np.pi
) -> FloatArray:
    """Symmetric angle difference [rad] of rectangles at angles ``a``, ``b``.

    ``period`` is the shape's rotational symmetry: π for a rectangle (difference in
    [0, π/2]), π/2 for a square (in [0, π/4]); one value or an array that broadcasts.
    """
    d = np.mod(np.asarray(a) - np.asarray(b), period)
    return np.asarray(np.minimum(d, period - d))


def symmetry_period(sizes: FloatArray) -> FloatArray:
    """``(n,)`` rotational symmetry [rad] of rectangles ``(n, ≥2)`` ``length, width``."""
    sizes = np.asarray(sizes, dtype=np.float64).reshape(
        -1, sizes.shape[-1] if np.ndim(sizes) else 2
    )
    return np.where(np.isclose(sizes[:, 0], sizes[:, 1]), np.pi / 2, np.pi)


def pose_distance(
    a: FloatArray, b: FloatArray, angle_scale: float = 0.6, periods: FloatArray | None = None
) -> FloatArray:
    """``(k, m)`` pose distances [m] between tables ``a`` (k, ≥3) and ``b`` (m, ≥3).

    ``periods`` (m,): the symmetry of each table of ``b`` (default π, rectangles).
    """
    a, b = _poses(a, "a"), _poses(b, "b")
    dxy = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    period = np.pi if periods is None else np.asarray(periods)[None, :]
    dtheta = angle_difference(a[:, None, 2], b[None, :, 2], period)
    return np.asarray(np.hypot(dxy, angle_scale * dtheta))


def match_tables(
    estimated: FloatArray,
    truth: FloatArray,
    tol: MatchTolerance = MatchTolerance(),
    periods: FloatArray | None = None,
) -> tuple[IntArray, IntArray]:
    """One-to-one matches of mapped to true tables within the tolerances.

    ``periods`` (n,): the rotational symmetry of each true table (default π; π/2 for a
    square). Returns index arrays ``(i, j)``: ``estimated[i[k]]`` matches ``truth[j[k]]``.
    """
    est, tru = _poses(estimated, "estimated"), _poses(truth, "truth")
    if not len(est) or not len(tru):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    dxy = np.hypot(est[:, None, 0] - tru[None, :, 0], est[:, None, 1] - tru[None, :, 1])
    period = np.pi if periods is None else np.asarray(periods)[None, :]
    ok = (dxy <= tol.position_tol) & (
        angle_difference(est[:, None, 2], tru[None, :, 2], period) <= tol.angle_tol
    )
    cost = np.where(ok, pose_distance(est, tru, tol.angle_scale, periods), 1e6)
    rows, cols = linear_sum_assignment(cost)
    keep = ok[rows, cols]
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)


def gospa(
    estimated: FloatArray,
    truth: FloatArray,
    tol: MatchTolerance = MatchTolerance(),
    periods: FloatArray | None = None,
) -> float:
    """GOSPA distance [m] (α = 2) between two sets of tables (Rahmathullah et al. 2017).

    ``periods``: the true tables' symmetries, as in :func:`match_tables`.
    """
    est, tru = _poses(estimated, "estimated"), _poses(truth, "truth")
    c, p = tol.c, tol.p
    unassigned = (len(est) + len(tru)) * c**p / 2.0
    if len(est) and len(tru):
        d = np.minimum(pose_distance(est, tru, tol.angle_scale, periods), c) ** p
        rows, cols = linear_sum_assignment(d - c**p)
        paired = d[rows, cols]
        unassigned -= c**p * len(rows)
        total = paired.sum() + unassigned
    else:
        total = unassigned
    return float(total ** (1.0 / p))


def near_wall(
    tables: FloatArray, bounds: tuple[float, float, float, float], margin: float
) -> np.ndarray:
    """Whether each table's centre lies within ``margin`` [m] of the arena's walls."""
    xy = _poses(tables, "tables")[:, :2]
    xmin, ymin, xmax, ymax = bounds
    gap = np.minimum.reduce([xy[:, 0] - xmin, xy[:, 1] - ymin, xmax - xy[:, 0], ymax - xy[:, 1]])
    return np.asarray(gap <= margin)


def score_run(
    maps: Sequence[FloatArray],
    touched: Sequence[IntArray],
    truth: FloatArray,
    bounds: tuple[float, float, float, float],
    wall_margin: float,
    tol: MatchTolerance = MatchTolerance(),
) -> dict[str, float]:
    """Score every pose's MAP tables against the true tables.

    Parameters
    ----------
    maps
        Per pose, the ``(k, ≥3)`` MAP tables.
    touched
        Per pose, the indices of the true tables its whiskers touched.
    truth
        ``(n, ≥3)`` true tables.
    bounds
        Arena ``(xmin, ymin, xmax, ymax)`` [m].
    wall_margin
        A phantom (unmatched mapped table) within this distance [m] of a wall counts in
        ``phantom_near_walls`` (the experiment uses one table length).

    Returns
    -------
    dict
        ``map_tables`` (count over all poses), ``matched``, ``precision`` (matched / map
        tables, any true table), ``recall`` (over (pose, touched table) pairs, the
        fraction whose pose's MAP holds that table), ``position_error_mean`` [m] and
        ``angle_error_mean`` [rad] over matches, ``gospa_mean`` [m] (MAP tables against
        the touched tables, averaged over all poses), ``phantoms`` and
        ``phantom_near_walls``.
    """
    if len(maps) != len(touched):
        raise InputError(
            f"maps ({len(maps)}) and touched ({len(touched)}) must have one entry per pose"
        )
    tru = _poses(truth, "truth")
    n_map = n_matched = n_pairs = n_found = n_phantom = n_wall = 0
    pos_err: list[float] = []
    ang_err: list[float] = []
    scores: list[float] = []
    for tables, hit in zip(maps, touched, strict=True):
        est = _poses(tables, "map tables")
        hit = np.unique(np.asarray(hit, dtype=np.int64))
        i, j = match_tables(est, tru, tol)
        n_map += len(est)
        n_matched += len(i)
        pos_err.extend(np.hypot(*(est[i, :2] - tru[j, :2]).T).tolist())
        ang_err.extend(angle_difference(est[i, 2], tru[j, 2]).tolist())
        phantom = np.ones(len(est), bool)
        phantom[i] = False
        n_phantom += int(phantom.sum())
        n_wall += int(near_wall(est[phantom], bounds, wall_margin).sum())
        n_pairs += len(hit)
        n_found += int(np.isin(hit, j).sum())
        scores.append(gospa(est, tru[hit], tol))
    nan = float("nan")
    return {
        "map_tables": n_map,
        "matched": n_matched,
        "precision": n_matched / n_map if n_map else nan,
        "recall": n_found / n_pairs if n_pairs else nan,
        "position_error_mean": float(np.mean(pos_err)) if pos_err else nan,
        "angle_error_mean": float(np.mean(ang_err)) if ang_err else nan,
        "gospa_mean": float(np.mean(scores)) if scores else nan,
        "phantoms": n_phantom,
        "phantom_near_walls": n_wall,
    }


def recall_by_support(
    maps: Sequence[FloatArray],
    touched: Sequence[IntArray],
    support: Sequence[IntArray],
    truth: FloatArray,
    tol: MatchTolerance = MatchTolerance(),
) -> dict[str, float]:
    """Recall split by how many distinct legs of the touched table the mapper could see.

    One leg fits eight tables and two legs on one side fit two (Fox & Prescott 2011,
    Fig. 3), so recall can only be high where three or more legs are in working memory;
    this breakdown separates that inherent ambiguity from search failures.

    Parameters
    ----------
    maps, touched, truth, tol
        As in :func:`score_run`.
    support
        Per pose, aligned with ``touched``: the number of distinct legs of each touched
        table among the shapelets in the mapper's working memory.

    Returns
    -------
    dict
        ``{"1": recall, "2": …, "3": …, "4": …}`` over (pose, touched table) pairs with
        that many legs in memory (NaN where there are none), plus ``"pairs_<k>"`` counts.
    """
    found = np.zeros(5)
    pairs = np.zeros(5)
    tru = _poses(truth, "truth")
    for tables, hit, legs in zip(maps, touched, support, strict=True):
        hit = np.asarray(hit, dtype=np.int64)
        legs = np.asarray(legs, dtype=np.int64)
        if hit.shape != legs.shape:
            raise InputError(f"support {legs.shape} must align with the touched tables {hit.shape}")
        _, j = match_tables(_poses(tables, "map tables"), tru, tol)
        bins = np.clip(legs, 0, 4)
        np.add.at(pairs, bins, 1)
        np.add.at(found, bins, np.isin(hit, j))
    result: dict[str, float] = {}
    for k in range(1, 5):
        result[str(k)] = float(found[k] / pairs[k]) if pairs[k] else float("nan")
        result[f"pairs_{k}"] = int(pairs[k])
    return result


def fused_scores(
    estimated: FloatArray,
    estimated_sizes: FloatArray,
    truth: FloatArray,
    truth_sizes: FloatArray,
    bounds: tuple[float, float, float, float],
    tol: MatchTolerance = MatchTolerance(),
    wall_margin: float = 0.3,
) -> dict[str, float]:
    """Score one fused map of the whole room against the true tables.

    Parameters
    ----------
    estimated, truth
        ``(k, ≥3)`` and ``(n, ≥3)`` tables ``x, y, theta``.
    estimated_sizes, truth_sizes
        ``(k, 2)`` and ``(n, 2)`` their ``length, width`` [m]; a true square table matches
        modulo π/2 (the rectangle's symmetry), others modulo π.
    bounds
        Arena ``(xmin, ymin, xmax, ymax)`` [m].
    wall_margin
        An unmatched mapped table with a corner within this distance [m] of a wall, or
        beyond one, is a wall phantom.

    Returns
    -------
    dict
        ``fused_precision``, ``fused_recall``, ``fused_wall_phantoms``, ``fused_gospa`` [m],
        ``fused_position_error_mean`` [m], ``fused_angle_error_mean`` [rad],
        ``type_accuracy`` (matched tables whose size is right to 1 cm), ``fused_objects``,
        ``fused_matched``.
    """
    est, tru = _poses(estimated, "estimated"), _poses(truth, "truth")
    est_sizes = np.asarray(estimated_sizes, dtype=np.float64).reshape(-1, 2)
    tru_sizes = np.asarray(truth_sizes, dtype=np.float64).reshape(-1, 2)
    if len(est_sizes) != len(est) or len(tru_sizes) != len(tru):
        raise InputError("fused_scores: one size row per table is needed")
    periods = symmetry_period(tru_sizes)
    i, j = match_tables(est, tru, tol, periods)
    phantom = np.ones(len(est), bool)
    phantom[i] = False
    corners = rectangle_outline(est, est_sizes)
    xmin, ymin, xmax, ymax = bounds
    gap = (
        np.minimum.reduce(
            [
                corners[..., 0] - xmin,
                corners[..., 1] - ymin,
                xmax - corners[..., 0],
                ymax - corners[..., 1],
            ]
        ).min(axis=1)
        if len(est)
        else np.zeros(0)
    )
    nan = float("nan")
    right_type = np.all(np.abs(est_sizes[i] - tru_sizes[j]) <= 0.01, axis=1)
    return {
        "fused_objects": len(est),
        "fused_matched": len(i),
        "fused_precision": len(i) / len(est) if len(est) else nan,
        "fused_recall": len(j) / len(tru) if len(tru) else nan,
        "fused_wall_phantoms": int((phantom & (gap <= wall_margin)).sum()),
        "fused_gospa": gospa(est, tru, tol, periods),
        "fused_position_error_mean": float(np.hypot(*(est[i, :2] - tru[j, :2]).T).mean())
        if len(i)
        else nan,
        "fused_angle_error_mean": float(angle_difference(est[i, 2], tru[j, 2], periods[j]).mean())
        if len(i)
        else nan,
        "type_accuracy": float(right_type.mean()) if len(i) else nan,
    }


def rectangle_outline(tables: FloatArray, sizes: FloatArray) -> FloatArray:
    """``(k, 4, 2)`` corners [m] of tables ``(k, ≥3)`` with sizes ``(k, 2)`` length, width."""
    tables = _poses(tables, "tables")
    half = 0.5 * np.asarray(sizes, dtype=np.float64).reshape(-1, 2)
    signs = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    local = signs[None] * half[:, None, :]
    c, s = np.cos(tables[:, 2])[:, None], np.sin(tables[:, 2])[:, None]
    x = tables[:, :1] + c * local[..., 0] - s * local[..., 1]
    y = tables[:, 1:2] + s * local[..., 0] + c * local[..., 1]
    return np.stack([x, y], axis=-1)
