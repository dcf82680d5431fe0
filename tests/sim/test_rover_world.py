"""Tests of the rover simulator: box worlds, ray casting, kinematics, IR rangers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.errors import ConfigError
from bayesmap.geometry import cast_on_boxes
from bayesmap.sensing.ir import range_from_raw
from bayesmap.sim import ir
from bayesmap.sim import rover as sim_rover
from bayesmap.sim.rover import observable_cells
from bayesmap.sim.world2d import (
    BoxWorld,
    box_world,
    circle_hits,
    occupancy_truth,
    world_distance,
    world_ray_cast,
)

BOXES = box_world("rover-field-obstacles-v1").boxes


def test_worlds_match_the_paper() -> None:
    assert box_world("rover-field-empty-v1").boxes.shape == (0, 4)
    np.testing.assert_allclose(
        BOXES, [[13.5, 15.5, 14.5, 16.5], [6.5, 9.5, 7.5, 10.5], [12.25, 2.5, 12.75, 3.5]]
    )
    with pytest.raises(ConfigError):
        box_world("nope")


def _march(x: float, y: float, angle: float, grow: float) -> float:
    steps = np.arange(0.0, 30.0, 0.001)
    px, py = x + steps * math.cos(angle), y + steps * math.sin(angle)
    inside = np.zeros(steps.shape, dtype=bool)
    for xmin, ymin, xmax, ymax in BOXES:
        inside |= (
            (px >= xmin - grow) & (px <= xmax + grow) & (py >= ymin - grow) & (py <= ymax + grow)
        )
    return float(steps[np.argmax(inside)]) if inside.any() else np.inf


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 20), st.floats(0, 20), st.floats(-math.pi, math.pi))
def test_ray_cast_matches_marching(x: float, y: float, angle: float) -> None:
    d = float(cast_on_boxes(BOXES, [[x, y]], [angle])[0])
    # grazing rays are ambiguous: the answer must lie between shrunk and grown boxes
    near, far = _march(x, y, angle, 1e-6), _march(x, y, angle, -1e-6)
    assert near - 2e-3 <= d <= far + 2e-3


def test_occupancy_truth_and_contact() -> None:
    truth = occupancy_truth(BOXES, (40, 40), 0.5, (0.0, 0.0))
    assert truth.sum() == 12  # three boxes, 2 x 2 cells each
    assert truth[31, 27] and truth[20, 13] and truth[5, 24] and truth[6, 25]
    assert circle_hits(BOXES, 13.3, 16.0, 0.2) and not circle_hits(BOXES, 13.2, 16.0, 0.2)


def test_transition_respects_turning_radius_and_pivots() -> None:
    params = sim_rover.SimulatedRoverParams(gps_sigma=0.0)
    rng = np.random.default_rng(0)
    state = sim_rover.initial([0.0, 0.0, 0.0], params, rng=rng)
    for _ in range(200):
        state = sim_rover.transition(state, (params.speed, 100.0), params, rng=rng)
    # driving at the yaw limit traces a circle of radius min_turn_radius about (0, R)
    assert math.hypot(state.pose[0], state.pose[1] - params.min_turn_radius) == pytest.approx(
        params.min_turn_radius, abs=1e-9
    )
    pivot = sim_rover.transition(state, (0.0, -5.0), params, rng=rng)
    np.testing.assert_allclose(pivot.pose[:2], state.pose[:2])
    assert math.remainder(pivot.pose[2] - state.pose[2], 2 * math.pi) == pytest.approx(
        -params.pivot_rate * params.dt
    )


def test_ir_reads_the_box_ahead() -> None:
    rangers = ir.IRRangers(sigma_r=0.0)
    pose = np.array([5.35, 10.0, 0.0])  # the box at (7, 10) starts at x = 6.5
    ranges = ir.true_ranges(BOXES, pose, rangers)
    assert ranges[1] == pytest.approx(6.5 - 5.35 - rangers.offset)
    raw = ir.observe(BOXES, pose, rangers, rng=np.random.default_rng(1))
    assert float(range_from_raw(raw[1])) == pytest.approx(1.0, abs=0.05)  # 8-bit quantisation
    assert ranges[2] > ranges[1]  # the -30 degree ranger sees the same box farther off
    far = ir.observe(BOXES, [2.0, 2.0, 0.0], rangers, rng=np.random.default_rng(1))
    assert far.tolist() == [0.0, 0.0, 0.0]  # nothing in reach: the ADC floor


FAR_WALL = (5.0, -3.0, 5.2, 3.0)
"""A wall 5 m ahead of a ranger at the origin looking along +x: beyond its 2 m range."""
NEAR_BOX = (0.95, 0.15, 1.05, 0.30)
"""A box 1 m ahead, 0.2 rad off the axis: the 1.6 m located there reaches it."""


@pytest.mark.parametrize(
    ("boxes", "expected"),
    [
        ([FAR_WALL, NEAR_BOX], pytest.approx(0.97, abs=0.02)),
        # 1.5 m away at the fan's edge (0.3 rad): past the 1.21 m located there
        ([FAR_WALL, (1.40, 0.40, 1.60, 0.60)], pytest.approx(5.0)),
        # the axis's own hit within range wins over a nearer one off the axis
        ([(1.5, -3.0, 1.6, 3.0), NEAR_BOX], pytest.approx(1.5)),
    ],
)
def test_a_surface_out_of_range_does_not_mask_one_in_the_fan(
    boxes: list[tuple[float, ...]], expected: object
) -> None:
    rangers = ir.IRRangers(angles=(0.0,), offset=0.0, sigma_r=0.0)
    assert float(ir.true_ranges(np.array(boxes), [0.0, 0.0, 0.0], rangers)[0]) == expected


def test_detection_range_shrinks_off_the_axis() -> None:
    rangers = ir.IRRangers()
    reach = ir.detection_range([0.0, rangers.w_r], rangers)
    assert reach[0] == pytest.approx(rangers.r_max)
    assert reach[1] == pytest.approx(rangers.r_max * math.exp(-0.5))
    with pytest.raises(ConfigError, match="r_max"):
        ir.IRRangers(r_max=0.0)


def test_same_seed_same_readings() -> None:
    params = sim_rover.SimulatedRoverParams()
    world = box_world("rover-field-obstacles-v1")
    runs = []
    for _ in range(2):
        rng = np.random.default_rng(7)
        state = sim_rover.initial([5.3, 10.0, 0.0], params, rng=rng)
        runs.append([sim_rover.observe(world, state, params, rng=rng).raw for _ in range(5)])
    np.testing.assert_array_equal(runs[0], runs[1])
    clean = sim_rover.h(world, state, params)
    assert clean.pose.tolist() == state.pose.tolist()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"speed": 0.0}, "speed"),
        ({"gps_sigma": -0.1}, "gps_sigma"),
        ({"compass_sigma": math.nan}, "compass_sigma"),
    ],
)
def test_bad_rover_params_name_the_field(kwargs: dict[str, float], field: str) -> None:
    with pytest.raises(ConfigError, match=field):
        sim_rover.SimulatedRoverParams(**kwargs)


def test_observable_cells_leave_out_interiors_and_shut_off_ground() -> None:
    # a 4 m x 4 m field; a 2 m x 2 m box in the middle; then a room closed by walls
    box = BoxWorld("box", 4.0, 4.0, np.array([[1.0, 1.0, 3.0, 3.0]]))
    seen = observable_cells(box, (8, 8), 0.5, (0.5, 0.5), clearance=0.2, sense_range=1.4)
    assert not seen[3:5, 3:5].any()  # the box's inner cells: no ray enters them
    assert seen[2, 2:6].all() and seen[0].all()  # its faces and the ground around it
    # a wall across the field with a gap of 0.8 m: wide enough for clearance 0.2, not 0.5
    wall = BoxWorld("wall", 8.0, 4.0, np.array([[3.9, 0.0, 4.1, 1.6], [3.9, 2.4, 4.1, 4.0]]))
    open_ = observable_cells(wall, (8, 16), 0.5, (1.0, 2.0), clearance=0.2, sense_range=1.4)
    shut = observable_cells(wall, (8, 16), 0.5, (1.0, 2.0), clearance=0.5, sense_range=1.4)
    assert open_[:, 14:].all()  # the far side, reached through the gap
    assert not shut[:, 12:].any()  # beyond the sensing range of the near side
    assert shut[:, :8].all()


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 20), st.floats(0, 20), st.floats(-math.pi, math.pi))
def test_polygon_edges_cast_like_the_boxes_they_outline(x: float, y: float, angle: float) -> None:
    outlines = tuple(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) for x0, y0, x1, y1 in BOXES)
    as_polygons = BoxWorld("p", 20.0, 20.0, np.zeros((0, 4)), outlines)
    if world_distance(as_polygons, x, y) == 0.0:
        return  # inside a box the slab test says 0, the edges the far side
    d = float(world_ray_cast(as_polygons, [[x, y]], [angle])[0])
    expected = float(cast_on_boxes(BOXES, [[x, y]], [angle])[0])
    assert d == pytest.approx(expected, abs=1e-9) or (np.isinf(d) and np.isinf(expected))
