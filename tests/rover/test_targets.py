"""The target rules (the paper's eqs. 38–39 on path costs, and the frontier baseline):
giving up what looking cannot resolve."""

from __future__ import annotations

import numpy as np

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import UncertainBlocks
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import local_plan
from bayesmap.rover.targets import EntropyTarget, FrontierTarget, look_cycles

PARAMS = RoverParams()


def _select(
    rule: EntropyTarget | FrontierTarget, grid: OccupancyGrid, pose: tuple[float, float, float]
) -> tuple[float, float] | None:
    plan = local_plan(grid, pose[0], pose[1], PARAMS)
    return rule.select(grid, pose, plan, UncertainBlocks(grid.entropy >= PARAMS.h_desired))


def test_a_face_target_looked_at_in_vain_gives_up_its_band_but_not_open_ground() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=PARAMS.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.probability[12, 4:20] = 0.95  # a wall at y = 6.0..6.5, certain
    grid.probability[11, 4:20] = 0.45  # the band in front of its face: mixed readings
    grid.entropy[11, 4:20] = 0.99
    grid.entropy[10, 13] = 0.9  # open ground, uncertain, next to the band (6.75, 5.25)
    pose = (6.25, 4.75, 1.57)  # at the viewpoint of the band, facing it
    rule = EntropyTarget(PARAMS)
    blocks = UncertainBlocks(grid.entropy >= PARAMS.h_desired)
    plan = local_plan(grid, pose[0], pose[1], PARAMS)
    target = rule.select(grid, pose, plan, blocks)
    assert target is not None and abs(target[1] - 5.75) < 1e-9  # a cell of the band
    for _ in range(look_cycles(PARAMS) + 1):  # looked at for a full turn, still uncertain
        rule.select(grid, pose, plan, blocks)
    assert target in rule.blacklist_
    band = {(x, 5.75) for x in (target[0] - 0.5, target[0] + 0.5)}
    assert band <= rule.blacklist_  # its neighbours in the band go with it
    assert (6.75, 5.25) not in rule.blacklist_  # open ground may still be resolved
    assert rule.target_ not in band


def test_when_all_that_is_left_was_given_up_the_blacklist_is_forgiven() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=PARAMS.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.entropy[20, 20] = 1.0  # one uncertain cell left, (10.25, 10.25)
    pose = (3.0, 3.0, 0.0)
    blocks = UncertainBlocks(grid.entropy >= PARAMS.h_desired)
    plan = local_plan(grid, pose[0], pose[1], PARAMS)
    rule = EntropyTarget(PARAMS)
    rule.reject((10.25, 10.25))
    assert rule.select(grid, pose, plan, blocks) == (10.25, 10.25)  # not a stop at 0.99
    assert rule.blacklist_ == set()
    grid.entropy[20, 20] = 0.05
    assert rule.select(grid, pose, plan, UncertainBlocks(grid.entropy >= PARAMS.h_desired)) is None


def test_frontier_endgame_looks_at_a_cell_beside_an_obstacle_then_gives_it_up() -> None:
    # no frontier left; two uncertain cells, the nearer against an obstacle: the baseline
    # goes to look at it (it used to stop, with the obstacle's face unseen)
    grid = OccupancyGrid(10.0, 10.0, 0.5, prior=0.2, initial_entropy=0.1)
    grid.probability[:] = 0.05
    grid.probability[grid.world_to_cell(5.7, 5.2)] = 0.9
    rows, cols = grid.world_to_cell(np.array([5.2, 8.2]), np.array([5.2, 8.2]))
    grid.entropy[rows, cols] = 1.0
    rule = FrontierTarget(PARAMS)
    target = _select(rule, grid, (3.0, 5.2, 0.0))
    assert target == (5.25, 5.25)
    viewpoint = local_plan(grid, 3.0, 5.2, PARAMS).waypoint(target)
    assert viewpoint is not None and viewpoint != target
    # still uncertain after a full turn's cycles at its viewpoint: given up for the other
    at = (*viewpoint, 0.0)
    chosen = [_select(rule, grid, at) for _ in range(look_cycles(PARAMS) + 1)]
    assert chosen[:-1] == [target] * look_cycles(PARAMS)
    assert chosen[-1] == (8.25, 8.25) and target in rule.blacklist_
