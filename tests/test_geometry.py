"""Tests of the shared plane geometry: one angle convention, frames, ray casts."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.geometry import cast_on_boxes, cast_on_segments, to_robot, to_world, wrap_angle

finite = st.floats(-50.0, 50.0, allow_nan=False)


def test_wrap_angle_is_half_open_at_plus_pi() -> None:
    wrapped = wrap_angle([0.0, math.pi, -math.pi, 3 * math.pi / 2, -3 * math.pi / 2])
    np.testing.assert_allclose(wrapped, [0.0, -math.pi, -math.pi, -math.pi / 2, math.pi / 2])


@settings(max_examples=200, deadline=None)
@given(finite, st.sampled_from([2 * math.pi, math.pi / 2]))
def test_wrap_angle_lands_in_the_interval_and_keeps_the_direction(
    angle: float, period: float
) -> None:
    wrapped = float(wrap_angle(angle, period))
    assert -period / 2 <= wrapped < period / 2
    turns = (angle - wrapped) / period
    assert abs(turns - round(turns)) < 1e-9


@settings(max_examples=100, deadline=None)
@given(finite, finite, finite, finite, finite)
def test_to_robot_undoes_to_world(x: float, y: float, heading: float, u: float, v: float) -> None:
    pose = np.array([x, y, heading])
    world = to_world(pose, [[u, v]])
    np.testing.assert_allclose(to_robot(pose, world), [[u, v]], atol=1e-9)
    # a rigid motion: distances from the robot are kept
    assert np.isclose(math.hypot(world[0, 0] - x, world[0, 1] - y), math.hypot(u, v), atol=1e-9)


def test_to_world_faces_the_heading_and_broadcasts_over_poses() -> None:
    ahead_left = [[1.0, 0.0], [0.0, 2.0]]
    turned = to_world([1.0, 1.0, math.pi / 2], ahead_left)
    np.testing.assert_allclose(turned, [[1.0, 2.0], [-1.0, 1.0]], atol=1e-12)
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, math.pi / 2]])
    both = to_world(poses[:, None, :], ahead_left)
    assert both.shape == (2, 2, 2)
    np.testing.assert_allclose(both[1], turned)


def test_cast_on_segments_finds_the_nearest_wall_within_reach() -> None:
    walls = np.array([[2.0, -1.0, 2.0, 1.0], [1.0, -1.0, 1.0, 1.0], [-1.0, 5.0, 1.0, 5.0]])
    directions = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0]])
    distance, index = cast_on_segments([0.0, 0.0], directions, walls)
    np.testing.assert_allclose(distance, [1.0, np.inf, 5.0])
    assert index.tolist() == [1, -1, 2]
    short, which = cast_on_segments([0.0, 0.0], directions, walls, far=4.0)
    assert short[2] == np.inf and which[2] == -1
    # a ray starting on a wall hits it at 0, unless the search starts beyond
    on_wall, _ = cast_on_segments([[1.0, 0.0]], [[1.0, 0.0]], walls)
    beyond, hit = cast_on_segments([[1.0, 0.0]], [[1.0, 0.0]], walls, near=1e-7)
    assert on_wall[0] == 0.0 and beyond[0] == 1.0 and hit[0] == 0


def test_cast_on_segments_ignores_parallel_walls_and_handles_none() -> None:
    along = np.array([[1.0, 0.0, 3.0, 0.0]])
    distance, index = cast_on_segments([0.0, 0.0], [[1.0, 0.0]], along)
    assert distance[0] == np.inf and index[0] == -1
    distance, index = cast_on_segments([0.0, 0.0], [[1.0, 0.0]], np.zeros((0, 4)))
    assert distance[0] == np.inf and index[0] == -1


def test_cast_on_boxes_agrees_with_cast_on_their_edges() -> None:
    rng = np.random.default_rng(5)
    boxes = np.array([[2.0, 2.0, 3.0, 4.0], [-4.0, -1.0, -3.0, 1.0]])
    edges = np.concatenate(
        [
            [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]
            for x0, y0, x1, y1 in boxes
        ]
    )
    angles = rng.uniform(-math.pi, math.pi, 500)
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    by_slabs = cast_on_boxes(boxes, np.zeros((500, 2)), angles)
    by_edges, _ = cast_on_segments(np.zeros(2), directions, edges)
    np.testing.assert_allclose(by_slabs, by_edges, rtol=1e-9)
    assert np.isfinite(by_slabs).any() and np.isinf(by_slabs).any()
