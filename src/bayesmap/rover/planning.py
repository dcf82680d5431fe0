"""Path costs on the map around the rover: which cells it can reach, and by which way.

The paper steers straight at its target (eq. 40), so a target behind a wall pulls the rover
into the wall. Here the cost of reaching each cell of the local area (radius ``d_max``) is
the length of the shortest 8-connected path through passable cells, computed with
scikit-image's minimum-cost-path solver (:class:`skimage.graph.MCP_Geometric`, Dijkstra).
A cell is passable when the footprint centred on it would not overlap a hazard (a likely
obstacle or its doubtful neighbour, :func:`~bayesmap.rover.safety.hazard_cells`) and it lies
on the map; a passable cell within the safety margin of a hazard costs ``_NEAR_COST`` times
as much to cross, so paths keep to open ground and squeeze through a narrow gap only when
there is no other way. Cells never observed count as passable (optimistic planning: the
footprint check of :mod:`bayesmap.rover.safety` guards the drive).
The rover then steers toward a waypoint along that path instead of at the target itself.
Cost depends on ``d_max`` only, never on the size of the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from skimage.graph import MCP_Geometric

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import local_patch
from bayesmap.rover.params import RoverParams
from bayesmap.rover.safety import hazard_cells, square_distance

_WAYPOINT_AHEAD = 1.5
"""Path length [m] from the rover to the waypoint it steers toward."""

_NEAR_COST = 5.0
"""Cost per metre of crossing a cell within the safety margin of a hazard (1 elsewhere)."""


def footprint_kernel(radius: float, resolution: float) -> BoolArray:
    """Cell offsets whose square comes closer than ``radius`` [m] to a cell's centre."""
    k = int(math.ceil(radius / resolution))
    di, dj = np.mgrid[-k : k + 1, -k : k + 1] * resolution
    return np.asarray(square_distance(di, dj, 0.0, 0.0, resolution / 2) < radius)


def crossing_costs(
    probability: npt.ArrayLike, on_map: npt.ArrayLike, params: RoverParams, resolution: float
) -> FloatArray:
    """Cost per metre of each cell: ``inf`` where the footprint would overlap a hazard or
    leave the map, ``_NEAR_COST`` within the safety margin of a hazard, 1 elsewhere."""
    hazard = hazard_cells(probability, params)
    blocked = hazard | ~np.asarray(on_map, dtype=bool)
    kernel = footprint_kernel(params.footprint_radius, resolution)
    near_kernel = footprint_kernel(params.footprint_radius + params.safety_margin, resolution)
    costs = np.where(ndimage.binary_dilation(hazard, structure=near_kernel), _NEAR_COST, 1.0)
    return np.asarray(np.where(ndimage.binary_dilation(blocked, structure=kernel), np.inf, costs))


@dataclass
class LocalPlan:
    """Shortest path costs from the rover over the square of half-side ``d_max`` around it.

    Attributes
    ----------
    xc, yc
        ``(n, n)`` cell centres [m].
    cost
        ``(n, n)`` path cost [m] from the rover's cell (length, with cells near hazards
        counting ``_NEAR_COST`` times); ``inf`` where unreachable.
    row0, col0
        Grid indices of the patch's first cell (may be negative, off the map).
    resolution
        Cell side [m].
    """

    xc: FloatArray
    yc: FloatArray
    cost: FloatArray
    row0: int
    col0: int
    resolution: float
    _solver: MCP_Geometric

    def _index(self, x: float, y: float) -> tuple[int, int] | None:
        i = int(math.floor((y - self.yc[0, 0]) / self.resolution + 0.5))
        j = int(math.floor((x - self.xc[0, 0]) / self.resolution + 0.5))
        n = self.cost.shape[0]
        return (i, j) if 0 <= i < n and 0 <= j < n else None

    def cost_to(self, x: float, y: float) -> float:
        """Path length [m] to the cell holding ``(x, y)``; ``nan`` outside the patch."""
        index = self._index(x, y)
        return math.nan if index is None else float(self.cost[index])

    def waypoint(self, target: tuple[float, float]) -> tuple[float, float] | None:
        """The point to steer toward on the way to ``target``, or ``None`` if unreachable.

        Inside the patch: the cell ``1.5 m`` along the shortest path (or the target itself
        when closer). Outside: the same along the path to the patch cell that minimises path
        cost plus straight-line distance to the target.
        """
        index = self._index(*target)
        if index is None:
            remaining = self.cost + np.hypot(self.xc - target[0], self.yc - target[1])
            flat = int(np.argmin(remaining))
            if not np.isfinite(remaining.flat[flat]):
                return None
            index = (flat // self.cost.shape[1], flat % self.cost.shape[1])
        elif not np.isfinite(self.cost[index]):
            return None
        path = self._solver.traceback(index)
        lengths = np.array([self.cost[cell] for cell in path])
        ahead = int(np.searchsorted(lengths, _WAYPOINT_AHEAD))
        i, j = path[min(ahead, len(path) - 1)]
        return float(self.xc[i, j]), float(self.yc[i, j])


def local_plan(grid: OccupancyGrid, x: float, y: float, params: RoverParams) -> LocalPlan:
    """Path costs from ``(x, y)`` [m] over the local area of radius ``d_max`` (Dijkstra)."""
    xc, yc, prob = local_patch(grid, grid.probability, x, y, params.d_max, np.nan)
    on_map = np.isfinite(prob)
    costs = crossing_costs(np.nan_to_num(prob, nan=0.0), on_map, params, grid.resolution)
    n = prob.shape[0]
    i0 = int(np.clip(math.floor((y - yc[0, 0]) / grid.resolution + 0.5), 0, n - 1))
    j0 = int(np.clip(math.floor((x - xc[0, 0]) / grid.resolution + 0.5), 0, n - 1))
    costs[i0, j0] = 1.0  # the rover's own cell: it is there, whatever the map says
    solver = MCP_Geometric(costs, fully_connected=True)
    cumulative, _ = solver.find_costs([(i0, j0)])
    rows0, cols0 = grid.world_to_cell(float(xc[0, 0]), float(yc[0, 0]))
    return LocalPlan(
        np.asarray(xc),
        np.asarray(yc),
        np.asarray(cumulative) * grid.resolution,
        int(rows0),
        int(cols0),
        grid.resolution,
        solver,
    )
