"""Where to go next: the paper's entropy rule (eqs. 38–39) and a frontier baseline (Yamauchi 1997).

Both are target rules with ``select(grid, pose) -> (x, y) | None``; ``None`` means nothing
is left to explore.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Protocol

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.decisions import exploration_target
from bayesmap.rover.params import RoverParams


class TargetRule(Protocol):
    """Chooses the next exploration target on the map."""

    def select(self, grid: OccupancyGrid, pose: npt.ArrayLike) -> tuple[float, float] | None:
        """The target ``(x, y)`` [m], or ``None`` when exploration is complete."""
        ...


def clear_of_obstacles(
    probability: npt.ArrayLike, params: RoverParams, resolution: float
) -> npt.NDArray[np.bool_]:
    """Cells farther than ``clearance`` from every likely obstacle (``p >= p_block``).

    Targets are chosen among these only: a cell inside or against an obstacle can never be
    seen by forward-looking rangers, so its entropy stays high and, as a target, it would
    pull the rover into the obstacle (an addition to the paper's rule).
    """
    likely = np.asarray(probability) >= params.p_block
    k = int(math.ceil(params.clearance / resolution))
    disk = (
        np.hypot(*np.mgrid[-k : k + 1, -k : k + 1]) * resolution
        <= params.clearance + resolution / 2
    )
    return np.asarray(~ndimage.binary_dilation(likely, structure=disk))


class EntropyTarget:
    """The paper's rule: largest entropy within ``d_max``, nearest within ``delta_h`` (eqs. 38–39).

    Only the local area of radius ``d_max`` is searched (§4.4), and only cells clear of
    likely obstacles (:func:`clear_of_obstacles`). When nothing there is above
    ``h_desired`` the nearest such cell of the whole map is taken instead (the paper does
    not say what happens then); ``None`` when no such cell is left.
    """

    def __init__(self, params: RoverParams) -> None:
        self.params = params

    def select(self, grid: OccupancyGrid, pose: npt.ArrayLike) -> tuple[float, float] | None:
        p = self.params
        x, y = float(np.asarray(pose)[0]), float(np.asarray(pose)[1])
        window = grid.window(x, y, p.d_max)
        if window.size:
            xc, yc = grid.window_centers(window)
            clear = clear_of_obstacles(
                grid.probability[window.rows, window.cols], p, grid.resolution
            )
            entropy = np.where(clear, grid.entropy[window.rows, window.cols], np.nan)
            pick = exploration_target(
                entropy, xc, yc, (x, y), d_max=p.d_max, d_min=p.d_min, margin=p.target_margin
            )
            if pick >= 0 and entropy.flat[pick] >= p.h_desired:
                return float(xc.flat[pick]), float(yc.flat[pick])
        clear = clear_of_obstacles(grid.probability, p, grid.resolution)
        rows, cols = np.nonzero((grid.entropy >= p.h_desired) & clear)
        if rows.size == 0:
            return None
        xs, ys = grid.cell_centers(rows, cols)
        k = int(np.argmin(np.hypot(xs - x, ys - y)))
        return float(xs[k]), float(ys[k])


class FrontierTarget:
    """Frontier-based exploration after Yamauchi (1997), the baseline.

    Cells are classified as in Yamauchi's evidence grids: *unknown* if their probability is
    still exactly the prior (no reading has informed them), *open* if below it, *passable*
    if below ``p_block``. Frontier cells are the unknown cells next (4-neighbour) to an open
    cell (the explore_lite variant: the IR rangers look ahead, so the rover drives into the
    unknown side). They are grouped 8-connected; groups smaller than ``min_size`` cells wait
    until no larger group is left; the goal is the cell nearest the centroid of the group
    nearest to the rover by a breadth-first search through passable cells, skipping cells
    closer than ``d_min`` or not clear of likely obstacles (:func:`clear_of_obstacles`).
    A goal is kept while it is unknown or above ``h_desired``, for at most ``replan_every``
    calls (Yamauchi's timeout). With no frontier left, the nearest cell whose
    entropy is still at least ``h_desired`` is the goal, so that the stop rule can be met;
    ``None`` when no such cell is clear of obstacles.

    Attributes
    ----------
    target_
        The current target ``(x, y)`` [m], or ``None``.
    """

    def __init__(self, params: RoverParams, *, min_size: int = 8, replan_every: int = 150) -> None:
        self.params = params
        self.min_size = min_size
        self.replan_every = replan_every
        self.target_: tuple[float, float] | None = None
        self._age = 0

    def select(self, grid: OccupancyGrid, pose: npt.ArrayLike) -> tuple[float, float] | None:
        uncertain = grid.entropy >= self.params.h_desired
        if not uncertain.any():
            self.target_ = None
            return None
        unknown = grid.unobserved()
        self._age += 1
        if self.target_ is not None and self._age < self.replan_every:
            rows, cols = grid.world_to_cell(*self.target_)
            if unknown[int(rows), int(cols)] or uncertain[int(rows), int(cols)]:
                return self.target_
        self._age = 0
        x, y = float(np.asarray(pose)[0]), float(np.asarray(pose)[1])
        self.target_ = self._plan(grid, unknown, uncertain, x, y)
        return self.target_

    def _plan(
        self,
        grid: OccupancyGrid,
        unknown: npt.NDArray[np.bool_],
        uncertain: npt.NDArray[np.bool_],
        x: float,
        y: float,
    ) -> tuple[float, float] | None:
        p = self.params
        open_ = grid.probability < grid.prior
        passable = grid.probability < p.p_block
        four = ndimage.generate_binary_structure(2, 1)
        frontier = unknown & ndimage.binary_dilation(open_, structure=four)
        rows, cols = np.indices(unknown.shape)
        xs, ys = grid.cell_centers(rows, cols)
        distance_to_rover = np.hypot(xs - x, ys - y)
        clear = clear_of_obstacles(grid.probability, p, grid.resolution)
        far = (distance_to_rover >= p.d_min) & clear
        labels, n = ndimage.label(frontier, structure=np.ones((3, 3), dtype=bool))
        if n:
            distance = _bfs_distance(passable, grid.world_to_cell(x, y))
            ids = np.arange(1, n + 1)
            sizes = ndimage.sum_labels(frontier, labels, index=ids)
            cx = ndimage.mean(xs, labels, index=ids)
            cy = ndimage.mean(ys, labels, index=ids)
            order = np.argsort(ndimage.minimum(distance, labels, index=ids), kind="stable")
            big = sizes >= self.min_size
            for k in order[big[order]] if big.any() else order:
                members = (labels == k + 1) & far
                if members.any():
                    mx, my = xs[members], ys[members]
                    j = int(np.argmin(np.hypot(mx - cx[k], my - cy[k])))
                    return float(mx[j]), float(my[j])
        d = np.where(uncertain & clear, distance_to_rover, np.inf)
        d = np.where(far, d, d + 1e6)  # near cells only when nothing else is left
        k = int(np.argmin(d))
        return None if np.isinf(d.flat[k]) else (float(xs.flat[k]), float(ys.flat[k]))


def _bfs_distance(
    passable: npt.NDArray[np.bool_], start: tuple[npt.ArrayLike, npt.ArrayLike]
) -> npt.NDArray[np.float64]:
    """Grid steps (4-connected) from ``start`` through ``passable`` cells; ``inf`` if unreachable.

    A start off the map or on an impassable cell begins from the nearest passable cell.
    """
    ny, nx = passable.shape
    distance = np.full(passable.shape, np.inf)
    r0 = int(np.clip(np.asarray(start[0]), 0, ny - 1))
    c0 = int(np.clip(np.asarray(start[1]), 0, nx - 1))
    if not passable[r0, c0]:
        rows, cols = np.nonzero(passable)
        if rows.size == 0:
            return distance
        k = int(np.argmin(np.hypot(rows - r0, cols - c0)))
        r0, c0 = int(rows[k]), int(cols[k])
    distance[r0, c0] = 0.0
    queue = deque([(r0, c0)])
    while queue:
        r, c = queue.popleft()
        step = distance[r, c] + 1.0
        for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            if 0 <= rr < ny and 0 <= cc < nx and passable[rr, cc] and distance[rr, cc] == np.inf:
                distance[rr, cc] = step
                queue.append((rr, cc))
    return distance
