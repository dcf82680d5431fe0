"""The paper's target rule (eqs. 38–39) on path costs: giving up what looking cannot resolve."""

from __future__ import annotations

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import UncertainBlocks
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import local_plan
from bayesmap.rover.targets import EntropyTarget, look_cycles

PARAMS = RoverParams()


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


def _ringed_target() -> tuple[OccupancyGrid, EntropyTarget, tuple[float, float]]:
    """A map with an uncertain cell (10.25, 10.25) inside a ring of likely obstacles, and two
    less uncertain cells elsewhere; the ringed cell was given up."""
    grid = OccupancyGrid(14.0, 14.0, 0.5, prior=PARAMS.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.probability[19:22, 19:22] = 0.95  # the ring around cell (20, 20)
    grid.probability[20, 20] = 0.3
    grid.entropy[20, 20] = 1.0
    grid.entropy[8, 12] = 0.9  # (6.25, 4.25)
    grid.entropy[16, 4] = 0.8  # (2.25, 8.25)
    rule = EntropyTarget(PARAMS)
    rule.reject((10.25, 10.25))
    return grid, rule, (6.0, 6.0, 0.0)


def _next_target(grid: OccupancyGrid, rule: EntropyTarget, pose: tuple[float, ...]) -> object:
    blocks = UncertainBlocks(grid.entropy >= PARAMS.h_desired)
    return rule.select(grid, pose, local_plan(grid, pose[0], pose[1], PARAMS), blocks)


def test_a_given_up_target_gets_a_second_chance_when_the_ground_around_it_opens() -> None:
    grid, rule, pose = _ringed_target()
    assert _next_target(grid, rule, pose) == (6.25, 4.25)  # the ringed cell stays given up
    grid.entropy[8, 12] = 0.05  # that target resolved
    grid.probability[19:22, 19:22] = 0.01  # the ring turned out free: its approach opened
    grid.probability[20, 20] = 0.3
    assert _next_target(grid, rule, pose) == (10.25, 10.25)
    assert (10.25, 10.25) not in rule.blacklist_


def test_a_given_up_target_stays_given_up_while_nothing_around_it_opens() -> None:
    grid, rule, pose = _ringed_target()
    assert _next_target(grid, rule, pose) == (6.25, 4.25)
    grid.entropy[8, 12] = 0.05
    grid.probability[5, 5] = 0.01  # elsewhere the map changes
    assert _next_target(grid, rule, pose) == (2.25, 8.25)
    assert (10.25, 10.25) in rule.blacklist_
