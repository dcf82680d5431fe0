"""Tests of the IR mapper and the target rules."""

from __future__ import annotations

import numpy as np

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import IRMapper, UncertainBlocks, local_patch
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import local_plan
from bayesmap.rover.targets import (
    EntropyTarget,
    FrontierTarget,
    _bfs_distance,
    clear_of_obstacles,
)
from bayesmap.sensing.ir import ranger_poses, raw_from_range
from bayesmap.sim.ir import IRRangers

PARAMS = RoverParams()


def _select(rule, grid: OccupancyGrid, pose: tuple[float, float, float]):  # type: ignore[no-untyped-def]
    plan = local_plan(grid, pose[0], pose[1], rule.params)
    blocks = UncertainBlocks(grid.entropy >= rule.params.h_desired)
    return rule.select(grid, pose, plan, blocks)


def _raw(r: float) -> np.ndarray:
    return np.clip(np.rint(raw_from_range(np.array([np.inf, r, np.inf]))), 0, 255)


def test_mapper_marks_obstacle_ahead_and_free_space_before_it() -> None:
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2)
    mapper = IRMapper(grid, PARAMS)
    pose = (2.1, 5.1, 0.0)
    mapper.update(_raw(1.0), pose)
    assert not mapper.last_contacts_.any()  # eq. 33 needs two readings in a row
    for _ in range(7):
        mapper.update(_raw(1.0), pose)
    assert mapper.last_contacts_.tolist() == [False, True, False]
    ahead = grid.world_to_cell(2.1 + 0.15 + 1.0, 5.1)
    before = grid.world_to_cell(2.1 + 0.15 + 0.4, 5.1)
    behind = grid.world_to_cell(1.0, 5.1)
    assert grid.probability[ahead] > 0.5
    assert grid.probability[before] < 0.05 and grid.entropy[before] < 0.3
    assert grid.probability[behind] == 0.2 and grid.entropy[behind] == 1.0
    assert mapper.n_uncertain_ == int(np.count_nonzero(grid.entropy >= PARAMS.h_desired))


def test_update_cost_is_local() -> None:
    small = IRMapper(OccupancyGrid(20.0, 20.0, 0.5, prior=0.2), PARAMS)
    large = IRMapper(OccupancyGrid(200.0, 200.0, 0.5, prior=0.2), PARAMS)
    a = small.update(_raw(1.0), (10.1, 10.1, 0.3))
    b = large.update(_raw(1.0), (100.1, 100.1, 0.3))
    assert a.shape == b.shape
    np.testing.assert_allclose(
        small.grid_.probability[a.rows, a.cols], large.grid_.probability[b.rows, b.cols], atol=1e-12
    )


def test_local_patch_fills_outside_cells() -> None:
    grid = OccupancyGrid(4.0, 4.0, 0.5, prior=0.2)
    grid.probability[:] = 0.7
    xc, yc, values = local_patch(grid, grid.probability, 0.2, 0.2, 1.0, fill=0.2)
    inside = (xc > 0) & (yc > 0)
    assert np.all(values[inside] == 0.7) and np.all(values[~inside] == 0.2)
    assert values.shape == local_patch(grid, grid.probability, 2.0, 2.0, 1.0, 0.2)[2].shape


def test_entropy_target_prefers_high_entropy_then_nearest() -> None:
    grid = OccupancyGrid(20.0, 20.0, 0.5, prior=0.2, initial_entropy=0.1)
    rows, cols = grid.world_to_cell(np.array([5.2, 8.2]), np.array([5.2, 5.2]))
    grid.entropy[rows, cols] = [0.98, 1.0]
    assert _select(EntropyTarget(PARAMS), grid, (3.0, 5.2, 0.0)) == (5.25, 5.25)  # within margin
    tight = EntropyTarget(RoverParams(target_margin=0.0))
    assert _select(tight, grid, (3.0, 5.2, 0.0)) == (8.25, 5.25)
    grid.entropy[:] = 0.1
    assert _select(EntropyTarget(PARAMS), grid, (3.0, 5.2, 0.0)) is None


def test_frontier_target_picks_unknown_next_to_open() -> None:
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2)
    grid.probability[:, :8] = 0.05  # x < 4 m explored and free
    grid.entropy[:, :8] = 0.1
    target = _select(FrontierTarget(PARAMS), grid, (1.0, 5.0, 0.0))
    assert target is not None and target[0] == 4.25  # the first unknown column
    grid.entropy[:] = 0.1
    assert _select(FrontierTarget(PARAMS), grid, (1.0, 5.0, 0.0)) is None


def test_frontier_targets_keep_clear_of_likely_obstacles() -> None:
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2, initial_entropy=0.1)
    grid.probability[grid.world_to_cell(5.7, 5.2)] = 0.9
    clear = clear_of_obstacles(grid.probability, PARAMS, grid.resolution)
    assert not clear[grid.world_to_cell(5.2, 5.2)] and clear[grid.world_to_cell(8.2, 5.2)]


def test_entropy_target_beside_an_obstacle_is_looked_at_from_a_safe_viewpoint() -> None:
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2, initial_entropy=0.1)
    rows, cols = grid.world_to_cell(np.array([5.2, 8.2]), np.array([5.2, 5.2]))
    grid.entropy[rows, cols] = 1.0  # two unseen cells; the nearer sits against an obstacle
    grid.probability[grid.world_to_cell(5.7, 5.2)] = 0.9
    pose = (3.0, 5.2, 0.0)
    target = _select(EntropyTarget(PARAMS), grid, pose)
    assert target == (5.25, 5.25)  # the nearer, though against the obstacle
    plan = local_plan(grid, *pose[:2], PARAMS)
    waypoint = plan.waypoint(target)
    assert waypoint is not None and waypoint != target
    assert np.isfinite(plan.cost[plan._index(*waypoint)])
    assert np.hypot(waypoint[0] - target[0], waypoint[1] - target[1]) <= PARAMS.view_range
    # standing at the viewpoint, the rover steers at the target itself to look at it
    there = local_plan(grid, *waypoint, PARAMS)
    assert there.waypoint(target) == target
    assert np.isinf(there.cost[there._index(*target)])  # the target cell itself is closed


def test_default_ranger_geometry_matches_the_simulated_rover() -> None:
    rangers = IRRangers()
    pose = np.array([3.0, -2.0, 2.5])
    assert (PARAMS.sensor_angles, PARAMS.sensor_offset, PARAMS.w_r) == (
        rangers.angles,
        rangers.offset,
        rangers.w_r,
    )
    np.testing.assert_array_equal(
        rangers.poses(pose), ranger_poses(pose, PARAMS.sensor_angles, PARAMS.sensor_offset)
    )
    expected = pose[:2] + 0.15 * np.array([np.cos(2.5), np.sin(2.5)])
    np.testing.assert_allclose(rangers.poses(pose)[:, :2], np.tile(expected, (3, 1)))
    np.testing.assert_allclose(rangers.poses(pose)[:, 2], 2.5 + np.radians([30.0, 0.0, -30.0]))


def test_uncertain_blocks_track_the_map_incrementally() -> None:
    rng = np.random.default_rng(5)
    grid = OccupancyGrid(23.0, 17.0, 0.5, prior=0.2)
    mapper = IRMapper(grid, PARAMS)
    pose = np.array([2.0, 2.0, 0.3])
    for _ in range(60):
        raw = np.clip(np.rint(raw_from_range(rng.uniform(0.3, 3.0, 3))), 0, 255)
        mapper.update(raw, pose)
        pose = pose + [0.3 * np.cos(pose[2]), 0.3 * np.sin(pose[2]), rng.normal(0, 0.3)]
        fresh = UncertainBlocks(grid.entropy >= PARAMS.h_desired)
        np.testing.assert_array_equal(mapper.uncertain_.counts, fresh.counts)
    assert mapper.n_uncertain_ == int(np.count_nonzero(grid.entropy >= PARAMS.h_desired))


def test_entropy_target_keeps_its_target_then_blacklists_it_on_timeout() -> None:
    grid = OccupancyGrid(20.0, 20.0, 0.5, prior=0.2, initial_entropy=0.1)
    rows, cols = grid.world_to_cell(np.array([6.2, 9.2]), np.array([5.2, 5.2]))
    grid.entropy[rows, cols] = [1.0, 0.99]
    rule = EntropyTarget(RoverParams(target_timeout=5))
    first = _select(rule, grid, (3.0, 5.2, 0.0))
    assert first == (6.25, 5.25)
    grid.entropy[rows[1], cols[1]] = 1.0  # a rival appears: hysteresis keeps the target
    assert _select(rule, grid, (3.0, 5.2, 0.0)) == first
    for _ in range(5 + 2 * 33 + 2):  # timeout + twice the cycles its 3.25 m need
        target = _select(rule, grid, (3.0, 5.2, 0.0))
    assert first in rule.blacklist_ and target == (9.25, 5.25)


def test_the_global_fallback_finds_the_nearest_uncertain_cell_of_a_large_map() -> None:
    grid = OccupancyGrid(200.0, 200.0, 0.5, prior=0.2, initial_entropy=0.1)
    for x, y in [(150.2, 20.2), (30.2, 180.2), (120.2, 120.2)]:
        grid.entropy[grid.world_to_cell(x, y)] = 1.0
    assert _select(EntropyTarget(PARAMS), grid, (100.0, 100.0, 0.0)) == (120.25, 120.25)


def _steps_by_search(passable: np.ndarray, start: tuple[int, int]) -> np.ndarray:
    """Breadth-first search cell by cell, 4-connected: the oracle for the frontier's BFS."""
    distance = np.full(passable.shape, np.inf)
    distance[start] = 0.0
    queue = [start]
    for r, c in queue:
        for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            inside = 0 <= rr < passable.shape[0] and 0 <= cc < passable.shape[1]
            if inside and passable[rr, cc] and distance[rr, cc] == np.inf:
                distance[rr, cc] = distance[r, c] + 1.0
                queue.append((rr, cc))
    return distance


def test_the_frontier_search_counts_the_same_steps_as_a_cell_by_cell_search() -> None:
    rng = np.random.default_rng(21)
    for _ in range(200):
        passable = rng.random(tuple(rng.integers(1, 40, size=2))) < rng.uniform(0.3, 1.0)
        start = (int(rng.integers(passable.shape[0])), int(rng.integers(passable.shape[1])))
        if not passable[start]:
            continue
        np.testing.assert_array_equal(
            _bfs_distance(passable, start), _steps_by_search(passable, start)
        )
