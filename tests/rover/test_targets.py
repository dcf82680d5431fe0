"""The paper's target rule (eqs. 38–39) on path costs: giving up what looking cannot resolve."""

from __future__ import annotations

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import UncertainBlocks
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import local_plan
from bayesmap.rover.targets import EntropyTarget, face_stretch, look_cycles

PARAMS = RoverParams()


def test_a_face_target_looked_at_in_vain_gives_up_its_face_but_not_open_ground() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=PARAMS.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.probability[12, 4:20] = 0.95  # a wall at y = 6.0..6.5, certain
    grid.probability[11, 4:20] = 0.45  # the band in front of its face: mixed readings
    grid.entropy[11, 4:20] = 0.99
    grid.probability[13, 4:20] = 0.45  # the band in front of its far face
    grid.entropy[13, 4:20] = 0.95
    grid.entropy[10, 13] = 0.9  # open ground, uncertain, next to the band (6.75, 5.25)
    grid.entropy[2, 20] = 0.9  # open ground far away (10.25, 1.25)
    pose = (6.25, 4.75, 1.57)  # at the viewpoint of the band, facing it
    rule = EntropyTarget(PARAMS)
    blocks = UncertainBlocks(grid.entropy >= PARAMS.h_desired)
    plan = local_plan(grid, pose[0], pose[1], PARAMS)
    target = rule.select(grid, pose, plan, blocks)
    assert target is not None and abs(target[1] - 5.75) < 1e-9  # a cell of the band
    for _ in range(look_cycles(PARAMS) + 1):  # looked at for a full turn, still uncertain
        rule.select(grid, pose, plan, blocks)
    band = {(0.25 + 0.5 * j, 5.75) for j in range(4, 20)}
    assert band <= rule.blacklist_  # the whole stretch in front of that face goes with it
    assert not {(0.25 + 0.5 * j, 6.75) for j in range(4, 20)} & rule.blacklist_  # far face
    assert (6.75, 5.25) not in rule.blacklist_  # open ground may still be resolved
    assert rule.target_ not in band


def test_the_face_stretch_follows_one_face_and_stops_at_its_end() -> None:
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=PARAMS.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.probability[12, 4:10] = 0.95  # a wall from x = 2 to 5 m
    grid.entropy[11:14, 3:11] = 0.99  # uncertain all round it
    stretch = face_stretch(grid, (3.25, 5.75), PARAMS)
    assert stretch == {(0.25 + 0.5 * j, 5.75) for j in range(4, 10)}  # not round the ends
    assert face_stretch(grid, (8.25, 8.25), PARAMS) == {(8.25, 8.25)}  # no face: alone


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
