"""Path costs over the local map (scikit-image MCP) against a scipy.sparse.csgraph oracle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import crossing_costs, footprint_kernel, local_plan

PARAMS = RoverParams(d_max=4.0)


def _oracle(costs: np.ndarray, start: tuple[int, int], res: float) -> np.ndarray:
    """Shortest 8-connected paths where an edge costs the mean of its two cells (MCP_Geometric)."""
    passable = np.isfinite(costs)
    ny, nx = passable.shape
    index = np.arange(ny * nx).reshape(ny, nx)
    rows, cols, weights = [], [], []
    for di, dj in [(0, 1), (1, 0), (1, 1), (1, -1)]:
        for i in range(ny):
            for j in range(nx):
                k, m = i + di, j + dj
                if 0 <= k < ny and 0 <= m < nx and passable[i, j] and passable[k, m]:
                    rows.append(index[i, j])
                    cols.append(index[k, m])
                    weights.append(np.hypot(di, dj) * res * (costs[i, j] + costs[k, m]) / 2)
    graph = coo_matrix((weights, (rows, cols)), shape=(ny * nx, ny * nx))
    return dijkstra(graph, directed=False, indices=index[start]).reshape(ny, nx)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_path_costs_match_dijkstra(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2)
    grid.probability[rng.uniform(size=grid.shape) < 0.06] = 0.9
    x, y = 5.1, 4.9
    grid.probability[grid.world_to_cell(x, y)] = 0.2
    plan = local_plan(grid, x, y, PARAMS)
    rows = slice(plan.row0, plan.row0 + plan.cost.shape[0])
    cols = slice(plan.col0, plan.col0 + plan.cost.shape[1])
    patch = grid.probability[rows, cols]  # the patch lies inside the map here
    start = grid.world_to_cell(x, y)
    i, j = int(start[0]) - plan.row0, int(start[1]) - plan.col0
    costs = crossing_costs(patch, np.ones(patch.shape, dtype=bool), PARAMS, 0.5, rover=(i, j))
    np.testing.assert_allclose(plan.cost, _oracle(costs, (i, j), 0.5))
    assert np.isinf(plan.cost[patch >= PARAMS.p_block]).all()


def test_waypoint_leads_around_a_wall_and_unreachable_is_none() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[8:16, 12] = 0.95  # a wall at x = 6..6.5 from y = 4 to 8
    plan = local_plan(grid, 4.0, 6.0, PARAMS)
    target = (8.0, 6.0)
    assert plan.cost_to(*target) > 4.0 + 0.5  # longer than the straight line
    waypoint = plan.waypoint(target)
    assert waypoint is not None and (waypoint[1] > 7.5 or waypoint[1] < 4.5 or waypoint[0] < 6.0)
    grid.probability[2:22, 18] = 0.95  # close the target into a pocket
    grid.probability[2:22, 12] = 0.95
    grid.probability[2, 12:19] = 0.95
    grid.probability[21, 12:19] = 0.95
    closed = local_plan(grid, 4.0, 6.0, PARAMS)
    assert closed.waypoint((7.5, 6.0)) is None
    assert np.isnan(closed.cost_to(30.0, 30.0))


def test_footprint_kernel_grows_with_the_radius() -> None:
    assert footprint_kernel(0.2, 0.5).sum() == 1
    assert footprint_kernel(0.3, 0.5).sum() == 5
    assert footprint_kernel(0.4, 0.5).sum() == 9


def test_paths_keep_the_margin_the_footprint_check_demands() -> None:
    # two walls across the field (rows of likely obstacles) with a gap of `width` free cells
    def plan_through(width: int):  # type: ignore[no-untyped-def]
        grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
        grid.probability[:] = 0.01  # certainly free around
        grid.probability[12, :] = 0.95  # a wall at y = 6.0..6.5
        grid.probability[12, 10 : 10 + width] = 0.01  # its gap, x = 5.0 ..
        return local_plan(grid, 5.6, 4.0, PARAMS)

    keep_off = PARAMS.footprint_radius + PARAMS.safety_margin
    assert keep_off == 0.5  # a passable centre needs no hazard among its 8 neighbours
    behind = (5.6, 7.75)  # seen only from beyond the wall (view_range 1 m)
    assert np.isinf(plan_through(2).cost_to(*behind))  # 1.0 m mapped gap: body + 2 margins
    assert np.isfinite(plan_through(3).cost_to(*behind))


def test_a_corridor_lined_with_doubtful_cells_is_planned_through_at_a_price() -> None:
    # two walls 2 cells apart (mapped gap 1.0 m plus the walls' cells), the cells along
    # them still doubtful (p = 0.3): the plan may enter, paying for it; likely cells close it
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[:] = 0.01
    grid.probability[4:20, 9] = 0.95  # walls at x = 4.5..5.0 and x = 6.5..7.0
    grid.probability[4:20, 13] = 0.95
    grid.probability[4:20, 10:13] = 0.3  # the corridor between them, not yet seen free
    plan = local_plan(grid, 5.75, 1.0, PARAMS)
    inside = (5.75, 4.5)  # 2.5 m into the corridor
    assert np.isfinite(plan.cost_to(*inside))
    assert plan.cost_to(*inside) > 2 * (4.5 - 1.0 - PARAMS.view_range)  # it pays to enter
    grid.probability[4:20, 10:13] = 0.95  # the same corridor mapped as obstacle: closed
    assert np.isinf(local_plan(grid, 5.75, 1.0, PARAMS).cost_to(*inside))


def test_remaining_path_shrinks_as_the_rover_drives_within_its_cell() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[:] = 0.01
    target = (6.75, 6.25)
    before = local_plan(grid, 3.1, 6.25, PARAMS)
    after = local_plan(grid, 3.2, 6.25, PARAMS)  # the same cell, 0.1 m closer
    assert before.cost_to(*target) == after.cost_to(*target)  # cell-centred: no change
    assert after.remaining(3.2, 6.25, target) < before.remaining(3.1, 6.25, target)
    assert before.remaining(3.1, 6.25, target) == pytest.approx(6.75 - 3.1 - 1.0, abs=0.26)
    assert before.path_length(target) == pytest.approx(before.cost_to(*target))


def test_cells_where_the_rover_was_hemmed_in_are_crossed_only_at_a_price() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[:] = 0.01
    grid.probability[12, 0:20] = 0.95  # a wall at y = 6.0..6.5 with a gap at x = 10..12
    avoid = np.zeros(grid.shape)
    target = (3.25, 9.25)  # behind the wall, reached only through the gap
    wide = RoverParams(d_max=8.0)
    free = local_plan(grid, 3.25, 3.25, wide).cost_to(*target)
    avoid[10:15, 20:24] = 1.0  # hemmed in at the gap a moment ago
    avoided = local_plan(grid, 3.25, 3.25, wide, avoid=avoid)
    assert np.isfinite(free) and avoided.cost_to(*target) > free  # still possible, dearer
    costs = crossing_costs(
        np.full((5, 5), 0.01), np.ones((5, 5), bool), PARAMS, 0.5, avoid=np.eye(5, dtype=bool)
    )
    assert np.array_equal(costs, np.where(np.eye(5, dtype=bool), 25.0, 1.0))
    twice = crossing_costs(
        np.full((5, 5), 0.01), np.ones((5, 5), bool), PARAMS, 0.5, avoid=2.0 * np.eye(5)
    )
    assert np.array_equal(twice, np.where(np.eye(5, dtype=bool), np.inf, 1.0))  # closed
    avoid[10:15, 20:24] = 2.0  # hemmed in there twice: the gap is closed to the plan
    assert local_plan(grid, 3.25, 3.25, wide, avoid=avoid).cost_to(*target) == np.inf


def test_the_last_plan_is_reused_only_while_nothing_it_rests_on_changed() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[:] = 0.01
    first = local_plan(grid, 3.2, 3.2, PARAMS)
    assert local_plan(grid, 3.3, 3.3, PARAMS, previous=first) is first  # same cell and map
    grid.probability[8, 8] = 0.3  # below p_block: no crossing cost changes
    assert local_plan(grid, 3.3, 3.3, PARAMS, previous=first) is first
    moved = local_plan(grid, 3.8, 3.3, PARAMS, previous=first)  # into the next cell
    assert moved is not first
    np.testing.assert_array_equal(moved.cost, local_plan(grid, 3.8, 3.3, PARAMS).cost)
    grid.probability[8, 8] = 0.95  # a new obstacle near the rover
    replanned = local_plan(grid, 3.8, 3.3, PARAMS, previous=moved)
    assert replanned is not moved
    assert np.isinf(replanned.cost[8 - replanned.row0, 8 - replanned.col0])


def _wall_with_gap(width: float, offset: float) -> OccupancyGrid:
    """A certain map of a wall across a 12 m field (y = 6.0..6.5) with a gap ``width`` [m]
    wide starting at x = 5 + ``offset``: a cell any part of which the wall covers is a
    likely obstacle, every other cell certainly free (the best a 0.5 m map can do)."""
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=0.2)
    grid.probability[:] = 0.01
    left, right = 5.0 + offset, 5.0 + offset + width
    x0 = np.arange(grid.shape[1]) * 0.5  # cells' left edges
    covered = (x0 < left - 1e-9) | (x0 + 0.5 > right + 1e-9)
    grid.probability[12, covered] = 0.95
    return grid


@pytest.mark.parametrize("offset", np.arange(0.0, 0.5, 0.05))
def test_the_narrowest_passage_open_by_construction_is_two_metres(offset: float) -> None:
    """Body 0.4 m wide plus a 0.3 m margin on each side needs 1.0 m; the plan puts the
    rover's centre on cell centres at least body + margin (0.5 m) from a likely cell, so a
    mapped gap needs three free cells (1.5 m), which a true gap of 2.0 m always leaves
    wherever it lies on the grid, 1.5 m only when aligned with it, and 1.2 m never (two
    free cells at best: 1.0 m, no room for the centre at a cell centre)."""
    wide = RoverParams(d_max=8.0)
    assert 2 * (wide.footprint_radius + wide.safety_margin) == pytest.approx(1.0)
    behind = (6.75, 9.25)  # seen only from beyond the wall (view_range 1 m)
    opened = local_plan(_wall_with_gap(2.0, offset), 6.25, 2.25, wide).cost_to(*behind)
    assert np.isfinite(opened)
    middling = local_plan(_wall_with_gap(1.5, offset), 6.25, 2.25, wide).cost_to(*behind)
    assert np.isfinite(middling) == (offset < 1e-9)  # only when cell-aligned
    narrow = local_plan(_wall_with_gap(1.2, offset), 6.25, 2.25, wide).cost_to(*behind)
    assert np.isinf(narrow)


def test_view_costs_without_obstacles_are_the_smallest_cost_within_view_range() -> None:
    from scipy import ndimage

    from bayesmap.rover.planning import _disk, view_costs

    rng = np.random.default_rng(3)
    cost = rng.uniform(0.0, 10.0, (15, 15))
    cost[rng.uniform(size=cost.shape) < 0.2] = np.inf
    expected = ndimage.minimum_filter(cost, footprint=_disk(1.0, 0.5), mode="constant", cval=np.inf)
    got = view_costs(cost, np.zeros(cost.shape, dtype=bool), 1.0, 0.5)
    np.testing.assert_array_equal(got, expected)


def test_a_target_is_not_viewed_through_a_thin_wall() -> None:
    """The only cheap cell within view range lies behind a one-cell wall: the target's view
    cost comes from its own side, and the plan's viewpoint is there too."""
    from bayesmap.rover.planning import view_costs

    cost = np.full((9, 9), 50.0)
    cost[4, 2] = 1.0  # two cells left of the target, beyond the wall
    blocked = np.zeros((9, 9), dtype=bool)
    blocked[:, 3] = True  # a wall between column 2 and the target's column 4
    view = view_costs(cost, blocked, 1.0, 0.5)
    assert view[4, 4] == 50.0
    assert view_costs(cost, np.zeros_like(blocked), 1.0, 0.5)[4, 4] == 1.0


def test_a_target_beyond_the_patch_is_headed_for_across_its_border() -> None:
    """Open ground: the waypoint lies 1.5 m along the way toward a target beyond the patch,
    not at the rover's own cell (over all cells, path cost plus straight line is least
    where the rover stands, and the rover circled there). A wall between them: the way
    leads round its end. Shut in: no way out of the patch, no waypoint."""
    grid = OccupancyGrid(30.0, 30.0, 0.5, prior=0.2)
    x, y = 10.1, 10.1
    plan = local_plan(grid, x, y, PARAMS)
    assert plan.cost_to(25.0, 10.0) != plan.cost_to(25.0, 10.0)  # nan: outside the patch
    waypoint = plan.waypoint((25.0, 10.0))
    assert waypoint is not None
    assert np.hypot(waypoint[0] - x, waypoint[1] - y) > 1.0 and waypoint[0] > x + 1.0
    grid.probability[10:35, 26] = 0.95  # a wall at x = 13..13.5 from y = 5 to 17.5
    walled = local_plan(grid, x, y, PARAMS)
    waypoint = walled.waypoint((25.0, 10.0))
    assert waypoint is not None and np.hypot(waypoint[0] - x, waypoint[1] - y) > 1.0
    assert 0 < walled.remaining(x, y, (25.0, 10.0)) < np.inf
    grid.probability[14:27, 14] = 0.95  # walls round the rover: a room inside the patch
    grid.probability[14, 14:27] = 0.95
    grid.probability[26, 14:27] = 0.95
    assert local_plan(grid, x, y, PARAMS).waypoint((25.0, 10.0)) is None
