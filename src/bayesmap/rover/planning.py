"""Path costs on the map around the rover: which cells it can reach, and by which way.

The paper steers straight at its target (eq. 40), so a target behind a wall pulls the rover
into the wall. Here the cost of reaching each cell of the local area (radius ``d_max``) is
the length of the shortest 8-connected path through passable cells, computed with
scikit-image's minimum-cost-path solver (:class:`skimage.graph.MCP_Geometric`, Dijkstra).
A cell is passable when the footprint centred on it keeps the safety margin from every
hazard (a likely obstacle or its doubtful neighbour,
:func:`~bayesmap.rover.safety.hazard_cells`) and lies on the map, as the footprint check
demands of the drive; a passable cell within one more cell of a hazard costs
``_NEAR_COST`` times as much to cross, so paths keep to open ground and squeeze through a
narrow gap only when there is no other way. A target is reached from any cell within
``view_range`` of it with a line of sight past every likely obstacle (the rover looks at
it from there), so cells beside an obstacle are reachable targets, but not from the far
side of a thin wall. Cells never observed count as passable (optimistic planning: the
footprint check of :mod:`bayesmap.rover.safety` guards the drive).
The rover then steers toward a waypoint along that path instead of at the target itself.
Cost depends on ``d_max`` only, never on the size of the map.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from skimage.graph import MCP_Geometric

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.grid import OccupancyGrid
from bayesmap.grid.entropy import probability_at_entropy
from bayesmap.rover.mapping import local_patch
from bayesmap.rover.params import RoverParams
from bayesmap.rover.safety import hazard_cells, square_distance

_WAYPOINT_AHEAD = 1.5
"""Path length [m] from the rover to the waypoint it steers toward."""

_NEAR_COST = 5.0
"""Cost per metre of crossing a cell within one cell beyond the safety margin of a hazard."""

_DOUBTFUL_COST = 25.0
"""Cost per metre of crossing a cell within the safety margin of a doubtful cell only.

A doubtful cell (an uncertain neighbour of a likely obstacle) may be free: a corridor
1.2–2.5 m wide is mapped as likely walls lined with doubtful cells until the rover has
looked into it, so the plan may lead there, at a price, and the footprint check decides
on the spot, once the rangers have resolved the doubt."""

_AVOID_COST = 25.0
"""Cost per metre of crossing a cell where the rover was recently hemmed in once.

Where no heading kept the safety margin (a corridor or pocket narrower than the body plus
two margins on the map as it stood), the rover retreats; without a memory of it the next
plan, on the same map, leads straight back in. Such cells cost as much as doubtful ones,
so that the plan goes there again only when nothing cheaper is left. A cell where the rover
was hemmed in twice or more within its memory is not crossed at all: a corridor lined with
doubtful cells costs 25 per metre already, so a price alone did not keep the rover out of
one that hemmed it in again and again (world 00 of the generated worlds: half of a run)."""


@functools.lru_cache(maxsize=16)
def footprint_kernel(radius: float, resolution: float) -> BoolArray:
    """Cell offsets whose square comes closer than ``radius`` [m] to a cell's centre (read-only:
    one array per radius is shared by every cycle)."""
    k = int(math.ceil(radius / resolution))
    di, dj = np.mgrid[-k : k + 1, -k : k + 1] * resolution
    kernel = np.asarray(square_distance(di, dj, 0.0, 0.0, resolution / 2) < radius)
    kernel.flags.writeable = False
    return kernel


def crossing_costs(
    probability: npt.ArrayLike,
    on_map: npt.ArrayLike,
    params: RoverParams,
    resolution: float,
    rover: tuple[int, int] | None = None,
    avoid: npt.ArrayLike | None = None,
) -> FloatArray:
    """Cost per metre of each cell: ``inf`` where the footprint would come within the safety
    margin of a hazard or leave the map, ``_NEAR_COST`` within one more cell of a hazard,
    1 elsewhere; cells in ``avoid`` (how often the rover was recently hemmed in there)
    cost at least ``_AVOID_COST`` when it was once, ``inf`` when it was more often.

    The rover's own cell ``rover`` (patch indices) costs 1 whatever the map says, and its
    8 neighbours, when only the margin closes them, ``_NEAR_COST``: it can always step
    away from where it stands. Passable cells are those where the footprint check of
    :mod:`bayesmap.rover.safety` lets the rover's centre be, so a path never leads
    through a gap the drive would refuse.
    """
    likely = np.asarray(probability) >= params.p_block
    hazard = hazard_cells(probability, params)
    body = ndimage.binary_dilation(
        likely | ~np.asarray(on_map, dtype=bool),
        structure=footprint_kernel(params.footprint_radius, resolution),
    )
    keep_off = params.footprint_radius + params.safety_margin
    margin = ndimage.binary_dilation(likely, structure=footprint_kernel(keep_off, resolution))
    doubtful = ndimage.binary_dilation(hazard, structure=footprint_kernel(keep_off, resolution))
    near = ndimage.binary_dilation(
        hazard, structure=footprint_kernel(keep_off + resolution, resolution)
    )
    costs = np.where(near, _NEAR_COST, 1.0)
    costs[doubtful] = _DOUBTFUL_COST
    if avoid is not None:
        times = np.asarray(avoid, dtype=np.float64)
        costs[times >= 1] = _AVOID_COST
        costs[times >= 2] = np.inf
    costs[margin] = np.inf
    if rover is not None:
        i, j = rover
        around = costs[max(i - 1, 0) : i + 2, max(j - 1, 0) : j + 2]
        around[np.isinf(around)] = _NEAR_COST
    costs[body] = np.inf
    if rover is not None:
        costs[rover] = 1.0
    return np.asarray(costs)


@dataclasses.dataclass
class LocalPlan:
    """Shortest path costs from the rover over the square of half-side ``d_max`` around it.

    Attributes
    ----------
    xc, yc
        ``(n, n)`` cell centres [m].
    cost
        ``(n, n)`` path cost [m] from the rover's cell (length, with cells near hazards
        counting ``_NEAR_COST`` times); ``inf`` where unreachable.
    view
        ``(n, n)`` cost [m] of reaching a cell from which the rover sees each cell: the
        smallest ``cost`` within ``view_range`` of it whose line of sight to it crosses no
        likely obstacle (:func:`view_costs`).
    row0, col0
        Grid indices of the patch's first cell (may be negative, off the map).
    resolution
        Cell side [m].
    view_range
        How close [m] the rover must come to a target to look at it.
    costs
        ``(n, n)`` crossing cost per metre the plan was solved on (:func:`crossing_costs`).
    start
        Patch indices of the rover's cell, where the paths begin.
    blocked
        ``(n, n)`` likely obstacles (``p >= p_block``), which block a line of sight.
    terrain
        ``(n, n)`` what the plan depends on, per cell (:func:`terrain_classes`): equal
        terrain gives an equal plan.

    A plan is reused for as long as the map around the rover gives the same one
    (:func:`local_plan`), so each target's viewpoint and the path to it are worked out once
    per plan, whichever of :meth:`waypoint`, :meth:`path_length` and :meth:`remaining`
    asks first.
    """

    xc: FloatArray
    yc: FloatArray
    cost: FloatArray
    view: FloatArray
    row0: int
    col0: int
    resolution: float
    view_range: float
    costs: FloatArray
    start: tuple[int, int]
    blocked: BoolArray
    terrain: npt.NDArray[np.int8]
    _solver: MCP_Geometric
    _viewpoints: dict[tuple[float, float], tuple[int, int] | None] = dataclasses.field(
        default_factory=dict, repr=False
    )
    _paths: dict[tuple[int, int], list[tuple[int, int]]] = dataclasses.field(
        default_factory=dict, repr=False
    )

    def _index(self, x: float, y: float) -> tuple[int, int] | None:
        i = int(math.floor((y - self.yc[0, 0]) / self.resolution + 0.5))
        j = int(math.floor((x - self.xc[0, 0]) / self.resolution + 0.5))
        n = self.cost.shape[0]
        return (i, j) if 0 <= i < n and 0 <= j < n else None

    def cost_to(self, x: float, y: float) -> float:
        """Path length [m] to a point within ``view_range`` of ``(x, y)``; ``nan`` outside
        the patch, ``inf`` if no such point is reachable."""
        index = self._index(x, y)
        return math.nan if index is None else float(self.view[index])

    def _viewpoint(self, target: tuple[float, float]) -> tuple[int, int] | None:
        """The patch cell the rover heads for on the way to ``target``, or ``None``
        (:meth:`_find_viewpoint`, once per target and plan)."""
        if target not in self._viewpoints:
            self._viewpoints[target] = self._find_viewpoint(target)
        return self._viewpoints[target]

    def _path(self, index: tuple[int, int]) -> list[tuple[int, int]]:
        """Patch cells of the shortest path from the rover's cell to ``index`` (once per plan)."""
        if index not in self._paths:
            self._paths[index] = [(int(i), int(j)) for i, j in self._solver.traceback(index)]
        return self._paths[index]

    def _find_viewpoint(self, target: tuple[float, float]) -> tuple[int, int] | None:
        """The patch cell the rover heads for on the way to ``target``, or ``None``.

        Inside the patch: the cheapest reachable cell within ``view_range`` of the target
        that sees it (no likely obstacle on the line between them). Outside: the cell on the
        patch's border that minimises path cost plus straight-line distance to it, since
        every way there crosses the border. (Over all the patch's cells that sum is never
        smaller than at the rover's own cell, by the triangle inequality, so the rover was
        sent to where it stood and circled its own cell; no border cell reachable means no
        way out of the patch toward the target.)
        """
        index = self._index(*target)
        if index is None:
            remaining = self.cost + np.hypot(self.xc - target[0], self.yc - target[1])
            remaining[1:-1, 1:-1] = np.inf
        else:
            if not np.isfinite(self.view[index]):
                return None
            within = np.hypot(self.xc - target[0], self.yc - target[1]) <= self.view_range + 1e-9
            for i, j in zip(*np.nonzero(within), strict=True):
                within[i, j] = _sight(self.blocked, (int(i), int(j)), index)
            remaining = np.where(within, self.cost, np.inf)
        flat = int(np.argmin(remaining))
        if not np.isfinite(remaining.flat[flat]):
            return None
        return flat // self.cost.shape[1], flat % self.cost.shape[1]

    def waypoint(self, target: tuple[float, float]) -> tuple[float, float] | None:
        """The point to steer toward on the way to ``target``, or ``None`` if unreachable.

        The cell ``1.5 m`` along the shortest path to the viewpoint (:meth:`_viewpoint`),
        measured in metres of path, not in its cost (next to a hazard, where a metre costs
        five, a cost of 1.5 lay 0.3 m ahead, inside the turning circle, which a forward arc
        never reaches); or, once there, the target itself, so that the rover turns to look
        at it.
        """
        index = self._viewpoint(target)
        if index is None:
            return None
        if self._index(*target) is not None and self.cost[index] <= self.resolution:
            return target
        path = self._path(index)
        ahead = int(np.searchsorted(self._along(path), _WAYPOINT_AHEAD))
        i, j = path[min(ahead, len(path) - 1)]
        return float(self.xc[i, j]), float(self.yc[i, j])

    def _along(self, path: list[tuple[int, int]]) -> FloatArray:
        """Distance [m] along ``path`` from its first cell to each of its cells (cells
        counted at their length, whatever they cost)."""
        steps = np.diff(np.asarray(path, dtype=np.float64), axis=0)
        along = np.cumsum(np.hypot(steps[:, 0], steps[:, 1])) * self.resolution
        return np.concatenate([[0.0], along])

    def _beyond(self, index: tuple[int, int], target: tuple[float, float]) -> float:
        """Straight-line distance [m] from viewpoint cell ``index`` to a ``target`` outside the
        patch; 0 for a target inside it."""
        if self._index(*target) is not None:
            return 0.0
        return math.hypot(self.xc[index] - target[0], self.yc[index] - target[1])

    def path_length(self, target: tuple[float, float]) -> float:
        """Length [m] of the shortest path to ``target``'s viewpoint (cells counted at their
        length, whatever they cost), plus the straight line beyond the patch; ``inf`` if
        unreachable."""
        index = self._viewpoint(target)
        if index is None:
            return math.inf
        return float(self._along(self._path(index))[-1]) + self._beyond(index, target)

    def remaining(self, x: float, y: float, target: tuple[float, float]) -> float:
        """Path cost [m] still to go from the rover's exact position ``(x, y)`` to ``target``.

        :meth:`cost_to` counts from the centre of the rover's cell, so it changes only when
        the rover crosses into another cell (every five cycles at full speed on 0.5 m
        cells). Here the first step is measured from ``(x, y)`` to the next cell of the
        shortest path, so that driving along the path lowers the cost every cycle. Beyond
        the patch the plan's cost to its edge is added to the straight line from there.
        ``inf`` if the target is unreachable; 0 at the viewpoint.
        """
        index = self._viewpoint(target)
        if index is None:
            return math.inf
        beyond = self._beyond(index, target)
        path = self._path(index)
        if len(path) < 2:
            return beyond
        step = path[1]
        first = math.hypot(x - float(self.xc[step]), y - float(self.yc[step]))
        return first + float(self.cost[index] - self.cost[step]) + beyond


def terrain_classes(
    probability: FloatArray,
    on_map: BoolArray,
    avoid: FloatArray | None,
    params: RoverParams,
) -> npt.NDArray[np.int8]:
    """Each cell's class in all that :func:`crossing_costs` and the line of sight read.

    ``probability`` enters only through two thresholds (``p_block`` for likely obstacles
    and the probability of entropy ``h_desired`` for doubtful ones,
    :func:`~bayesmap.rover.safety.hazard_cells`), ``avoid`` through whether the rover was
    hemmed in once or more often, and whether the cell is on the map. Classes: the
    number of thresholds ``p`` reaches (0–2), 3 off the map, plus 4 per hemmed-in level.
    """
    p = np.asarray(probability)
    level = (p >= probability_at_entropy(params.h_desired)).astype(np.int8)
    level += p >= params.p_block
    level[~on_map] = 3
    if avoid is not None:
        level += 4 * ((avoid >= 1).astype(np.int8) + (avoid >= 2))
    return level


def local_plan(
    grid: OccupancyGrid,
    x: float,
    y: float,
    params: RoverParams,
    avoid: FloatArray | None = None,
    previous: LocalPlan | None = None,
) -> LocalPlan:
    """Path costs from ``(x, y)`` [m] over the local area of radius ``d_max`` (Dijkstra).

    ``avoid`` is a map-sized layer, how often the rover was recently hemmed in on each cell
    (:func:`crossing_costs`), 0 elsewhere; only its local patch is read.

    ``previous`` is the last cycle's plan: when the patch, the rover's cell and every
    crossing cost are the same (the map changed only within its thresholds, or not at
    all, and the rover has not left its cell), it is returned as it is, since solving
    again would give the same plan. A rover pivoting or looking at a target from its
    viewpoint re-plans only when its readings move a cell across a threshold. Whether a
    cell crossed a threshold is seen from the patch's :func:`terrain_classes` before any
    crossing cost is worked out, so a cycle that keeps the plan costs a few comparisons.
    """
    xc, yc, prob = local_patch(grid, grid.probability, x, y, params.d_max, np.nan)
    on_map = np.isfinite(prob)
    n = prob.shape[0]
    i0 = int(np.clip(math.floor((y - yc[0, 0]) / grid.resolution + 0.5), 0, n - 1))
    j0 = int(np.clip(math.floor((x - xc[0, 0]) / grid.resolution + 0.5), 0, n - 1))
    prob = np.nan_to_num(prob, nan=0.0)
    near_avoid = None
    if avoid is not None:
        near_avoid = local_patch(grid, avoid, x, y, params.d_max, 0.0)[2]
    terrain = terrain_classes(prob, on_map, near_avoid, params)
    rows0, cols0 = grid.world_to_cell(float(xc[0, 0]), float(yc[0, 0]))
    same_place = previous is not None and (previous.row0, previous.col0, previous.start) == (
        int(rows0),
        int(cols0),
        (i0, j0),
    )
    if previous is not None and same_place and np.array_equal(previous.terrain, terrain):
        return previous
    costs = crossing_costs(prob, on_map, params, grid.resolution, rover=(i0, j0), avoid=near_avoid)
    if previous is not None and same_place and np.array_equal(previous.costs, costs):
        previous.terrain = terrain  # a class changed, no cost did: the same plan
        return previous
    solver = MCP_Geometric(costs, fully_connected=True)
    cumulative, _ = solver.find_costs([(i0, j0)])
    cost = np.asarray(cumulative) * grid.resolution
    blocked = prob >= params.p_block
    view = view_costs(cost, blocked, params.view_range, grid.resolution)
    return LocalPlan(
        np.asarray(xc),
        np.asarray(yc),
        cost,
        np.asarray(view),
        int(rows0),
        int(cols0),
        grid.resolution,
        params.view_range,
        costs,
        (i0, j0),
        blocked,
        terrain,
        solver,
    )


@functools.lru_cache(maxsize=1024)
def _steps(di: int, dj: int) -> tuple[tuple[int, int], ...]:
    """Cell offsets strictly between ``(0, 0)`` and ``(di, dj)`` on the straight line
    (sampled at a quarter cell; shared, computed once per offset)."""
    n = 4 * max(abs(di), abs(dj))
    between = {(round(di * k / n), round(dj * k / n)) for k in range(1, n)}
    return tuple(sorted(between - {(0, 0), (di, dj)}))


def _sight(blocked: BoolArray, a: tuple[int, int], b: tuple[int, int]) -> bool:
    """No blocked cell lies strictly between cells ``a`` and ``b`` on the line joining them."""
    n = blocked.shape
    for si, sj in _steps(b[0] - a[0], b[1] - a[1]):
        i, j = a[0] + si, a[1] + sj
        if 0 <= i < n[0] and 0 <= j < n[1] and blocked[i, j]:
            return False
    return True


def _shifted(layer: npt.NDArray[np.generic], di: int, dj: int, fill: object) -> npt.NDArray[Any]:
    """``out[i, j] = layer[i + di, j + dj]``, ``fill`` where that falls off the array."""
    out = np.full_like(layer, fill)
    n, m = layer.shape
    out[max(-di, 0) : n - max(di, 0), max(-dj, 0) : m - max(dj, 0)] = layer[
        max(di, 0) : n + min(di, 0), max(dj, 0) : m + min(dj, 0)
    ]
    return out


def view_costs(
    cost: FloatArray, blocked: BoolArray, view_range: float, resolution: float
) -> FloatArray:
    """For every cell, the smallest path ``cost`` of a cell within ``view_range`` [m] that
    sees it: no ``blocked`` cell lies strictly between the two on the line joining their
    centres. A target behind a thin wall is not looked at from the wall's other side,
    where the rangers would read the wall and never the target."""
    view = cost.copy()
    offsets = np.argwhere(_disk(view_range, resolution)) - int(math.floor(view_range / resolution))
    for di, dj in offsets.tolist():
        if di == 0 and dj == 0:
            continue
        clear = np.ones(cost.shape, dtype=bool)
        for si, sj in _steps(di, dj):
            clear &= ~_shifted(blocked, si, sj, False)
        view = np.minimum(view, np.where(clear, _shifted(cost, di, dj, np.inf), np.inf))
    return view


@functools.lru_cache(maxsize=4)
def _disk(radius: float, resolution: float) -> BoolArray:
    """Cell offsets whose centre lies within ``radius`` [m] of the middle cell's centre
    (read-only, shared)."""
    k = int(math.floor(radius / resolution))
    di, dj = np.mgrid[-k : k + 1, -k : k + 1] * resolution
    disk = np.asarray(np.hypot(di, dj) <= radius + 1e-9)
    disk.flags.writeable = False
    return disk
