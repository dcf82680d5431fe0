"""The footprint check: the body's swept path, turning included, against map and readings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayesmap.geometry import to_robot
from bayesmap.rover.params import RoverParams
from bayesmap.rover.safety import (
    back_off_on_track,
    drive_command,
    footprint_safety,
    hazard_cells,
    predicted_centres,
    predicted_points,
    reading_points,
    recent_track,
    retreat_command,
    segment_distance,
    square_distance,
)
from bayesmap.sensing.ir import ranger_poses
from bayesmap.sim import rover as sim_rover

PARAMS = RoverParams(n_headings=36)
THETA = np.asarray(PARAMS.headings)
FIELD = (-50.0, 50.0, -50.0, 50.0)


def _safety(cells: list[tuple[float, float]], params: RoverParams = PARAMS, hits=None):  # type: ignore[no-untyped-def]
    return footprint_safety(
        (0.0, 0.0, 0.0),
        THETA,
        np.array(cells, dtype=float).reshape(-1, 2),
        0.5,
        np.zeros((0, 2)) if hits is None else hits,
        FIELD,
        params,
    )


def test_straight_path_drives_lookahead_and_pivot_stays_in_place() -> None:
    centres = predicted_centres((1.0, 2.0, 0.0), [0.0, math.pi], PARAMS)
    straight, behind = centres
    np.testing.assert_allclose(straight[0], [1.0, 2.0])
    assert straight[-1, 0] == pytest.approx(1.0 + PARAMS.lookahead, abs=1e-9)
    np.testing.assert_allclose(straight[:, 1], 2.0, atol=1e-12)
    # a heading behind: the rover first pivots in place, then drives
    assert np.allclose(behind[:5], [1.0, 2.0])
    driven = np.hypot(*np.diff(behind, axis=0).T).sum()
    assert driven == pytest.approx(PARAMS.lookahead, rel=0.05)
    assert behind[-1, 0] < 1.0  # and it ends up behind where it started


def test_turning_arc_respects_the_turning_radius() -> None:
    centres = predicted_centres((0.0, 0.0, 0.0), [math.radians(35)], PARAMS)[0]
    # the first 0.2 s at the full turning rate lie on the circle of radius R about (0, R)
    r = PARAMS.min_turn_radius
    assert np.hypot(centres[1, 0], centres[1, 1] - r) == pytest.approx(r, abs=1e-9)


def test_a_corner_beside_the_rover_blocks_turning_into_it() -> None:
    """The issue's case: an obstacle beside the body, outside the rangers' view."""
    side = _safety([(0.25, -0.85)])  # a cell right of the rover, 0.4 m from its edge
    right = int(np.argmin(np.abs(np.angle(np.exp(1j * (THETA - math.radians(-80)))))))
    assert not side.safe[right]  # turning right sweeps the body into it
    assert side.safe[0] and side.safe[9]  # straight on and left are fine


def test_margin_grows_with_position_uncertainty() -> None:
    cell = [(1.0, 0.75)]  # its edge is 0.5 m from the straight path's centre line
    assert _safety(cell, RoverParams(position_sigma=0.05)).safe[0]
    assert not _safety(cell, RoverParams(position_sigma=0.2)).safe[0]


def test_a_reading_ahead_blocks_driving_ahead() -> None:
    sensors = ranger_poses((0.0, 0.0, 0.0), PARAMS.sensor_angles, PARAMS.sensor_offset)
    hits = reading_points(sensors, [7.0, 0.45, 7.0], [False, True, False], PARAMS)
    safety = _safety([], hits=hits)
    assert not safety.safe[0] and safety.safe[18] and safety.ahead
    assert reading_points(sensors, [7.0, 7.0, 7.0], [True] * 3, PARAMS).shape == (0, 2)


def test_paths_may_not_leave_the_map() -> None:
    safety = footprint_safety(
        (0.3, 5.0, math.pi), THETA, np.zeros((0, 2)), 0.5, np.zeros((0, 2)), (0, 10, 0, 10), PARAMS
    )
    assert not safety.safe[18] and safety.safe[0]


def test_square_distance_brute_force() -> None:
    rng = np.random.default_rng(3)
    px, py = rng.uniform(-2, 2, (2, 200))
    edge = np.linspace(-0.25, 0.25, 401)
    gx, gy = np.meshgrid(edge, edge)
    brute = np.array([np.hypot(gx - x, gy - y).min() for x, y in zip(px, py, strict=True)])
    np.testing.assert_allclose(square_distance(px, py, 0.0, 0.0, 0.25), brute, atol=2e-3)


def test_drive_command_pivots_beyond_90_degrees() -> None:
    assert drive_command(math.pi, 0.0, PARAMS)[0] == 0.0
    assert drive_command(math.radians(80), 0.0, PARAMS)[0] == PARAMS.speed
    v, w = drive_command(0.2, 0.0, PARAMS)
    assert v == PARAMS.speed and w == pytest.approx(0.4)


def test_near_a_hazard_the_drive_pivots_toward_a_heading_outside_the_rangers_view() -> None:
    """Near a hazard a forward arc toward a heading outside the rangers' view (±38.6° with
    the paper's rangers) would sweep the body's inner side over ground nobody is reading:
    the rover turns in place until the heading is in view, then arcs."""
    view = PARAMS.view_half_angle
    assert view == pytest.approx(math.radians(30.0) + PARAMS.w_r / 2)
    assert drive_command(view + 0.01, 0.0, PARAMS, cautious=True) == (0.0, PARAMS.pivot_rate)
    assert drive_command(-view - 0.01, 0.0, PARAMS, cautious=True) == (0.0, -PARAMS.pivot_rate)
    assert drive_command(view - 0.01, 0.0, PARAMS, cautious=True)[0] == PARAMS.speed


def test_the_predicted_path_pivots_where_the_drive_law_does() -> None:
    """The footprint check predicts the drive law's path: near a hazard, toward a heading
    outside the rangers' view, the centre stays put while the rover turns; within the view,
    or in open ground, the rover moves from the first step."""
    view = PARAMS.view_half_angle
    pose = (0.0, 0.0, 0.0)
    outside, inside = predicted_centres(pose, [view + 0.05, view - 0.05], PARAMS, cautious=True)
    np.testing.assert_allclose(outside[1], [0.0, 0.0])
    assert np.hypot(*inside[1]) > 0.0
    assert np.hypot(*predicted_centres(pose, [view + 0.05], PARAMS)[0, 1]) > 0.0


def test_a_hazard_within_reach_makes_the_check_cautious() -> None:
    """The wall end of world 2026/00's collision: beside the rover, 61° off its heading,
    with only the wall's far part on the map. Arcing toward it was allowed; now the check
    predicts (and the drive takes) a pivot first, so the rangers look where the body goes."""
    wall = [(1.25, 0.75)]  # the mapped part of the wall, ahead and to the left
    assert _safety(wall).cautious and not _safety([]).cautious
    left = int(np.argmin(np.abs(np.angle(np.exp(1j * (THETA - math.radians(60)))))))
    np.testing.assert_allclose(
        predicted_centres((0.0, 0.0, 0.0), THETA[left : left + 1], PARAMS, cautious=True)[0, 1],
        [0.0, 0.0],
    )


def test_the_body_may_not_sweep_unseen_cells_unless_already_on_them() -> None:
    under = [(0.25, 0.25)]  # overlaps the footprint now: allowed
    beside = [(0.25, -0.75)]  # never seen, on the way when turning right
    safety = footprint_safety(
        (0.0, 0.0, 0.0),
        THETA,
        np.zeros((0, 2)),
        0.5,
        np.zeros((0, 2)),
        FIELD,
        PARAMS,
        np.array(under + beside),
    )
    right = int(np.argmin(np.abs(np.angle(np.exp(1j * (THETA - math.radians(-80)))))))
    assert safety.safe[0] and not safety.safe[right]


def test_hazards_are_likely_cells_and_their_doubtful_neighbours() -> None:
    p = np.full((5, 5), 0.01)
    p[2, 2] = 0.9
    p[2, 3] = 0.3  # clipped by the obstacle's edge: mixed evidence
    p[0, 0] = 0.3  # far from any likely cell
    hazard = hazard_cells(p, PARAMS)
    assert hazard[2, 2] and hazard[2, 3] and not hazard[0, 0] and not hazard[1, 1]


FORWARD = [(PARAMS.speed, 0.0)] * 5
"""Five cycles straight ahead: the track behind the rover is 0.5 m of straight line."""


def test_backing_off_is_allowed_only_onto_the_recent_track() -> None:
    track = recent_track(FORWARD, PARAMS)
    np.testing.assert_allclose(track[-1], [-5 * PARAMS.speed * PARAMS.dt, 0.0], atol=1e-12)
    cells = np.array([[3.6, 1.0]])
    no_hits = np.zeros((0, 2))
    pose = (3.0, 1.0, 0.0)
    ahead = footprint_safety(pose, THETA, cells, 0.5, no_hits, FIELD, PARAMS, None, track)
    assert ahead.ahead and ahead.back_clear and ahead.here < PARAMS.safety_margin
    # without a track (a rover that has not moved), it never backs off
    assert not footprint_safety(pose, THETA, cells, 0.5, no_hits, FIELD, PARAMS).back_clear
    # after turning in place by a quarter turn the ground straight behind was never occupied
    turned = recent_track([*FORWARD, (0.0, PARAMS.pivot_rate)], PARAMS)
    assert not back_off_on_track(turned, np.zeros((0, 2)), PARAMS)
    # a remembered ranger point on the track behind contradicts it; one under the body not
    assert not back_off_on_track(track, np.array([[-0.25, 0.05]]), PARAMS)
    assert back_off_on_track(track, np.array([[0.15, 0.0]]), PARAMS)


def test_the_track_is_the_body_s_own_path_dead_reckoned_backward() -> None:
    """The track retraces the commands exactly: it matches the simulator's own integration of
    arcs and pivots, expressed in the body frame at the end."""
    rng = np.random.default_rng(5)
    sim = sim_rover.SimulatedRoverParams(gps_sigma=1e-9)
    limit = PARAMS.speed / PARAMS.min_turn_radius
    commands = [
        (PARAMS.speed, float(rng.uniform(-limit, limit)))
        if rng.random() < 0.7
        else (0.0, float(rng.uniform(-1, 1) * PARAMS.pivot_rate))
        for _ in range(12)
    ]
    state = sim_rover.initial((2.0, -1.0, 0.4), sim, rng=rng)
    centres = [state.pose[:2].copy()]
    for command in commands:
        state = sim_rover.transition(state, command, sim, rng=rng)
        centres.append(state.pose[:2].copy())
    track = recent_track(commands, PARAMS)
    # every cycle's end is a vertex of the track (the pivots' centres repeat)
    expected = to_robot(state.pose, np.array(centres[::-1]))
    for point in expected:
        assert np.hypot(*(track - point).T).min() < 1e-9


def test_a_back_off_never_leaves_the_recent_track() -> None:
    """Random drives (arcs, pivots, back-offs whenever allowed) in the simulator: each
    back-off's centre stays within the tolerance of where the centre truly was in the last
    ``track_cycles`` cycles, sampled along the true path."""
    rng = np.random.default_rng(11)
    sim = sim_rover.SimulatedRoverParams(gps_sigma=1e-9)
    fine = sim_rover.SimulatedRoverParams(gps_sigma=1e-9, dt=PARAMS.dt / 20)
    limit = PARAMS.speed / PARAMS.min_turn_radius
    state = sim_rover.initial((0.0, 0.0, 0.0), sim, rng=rng)
    commands: list[tuple[float, float]] = []
    paths: list[np.ndarray] = []  # per cycle, the true centres along it
    backed = refused = 0
    for _ in range(600):
        track = recent_track(commands[-PARAMS.track_cycles :], PARAMS)
        if rng.random() < 0.5:
            if back_off_on_track(track, np.zeros((0, 2)), PARAMS):
                command = (-PARAMS.speed, 0.0)
                backed += 1
            else:
                refused += 1
                continue
        elif rng.random() < 0.7:
            command = (PARAMS.speed, float(rng.uniform(-limit, limit)))
        else:
            command = (0.0, float(rng.uniform(-1, 1) * PARAMS.pivot_rate))
        path = [state.pose[:2].copy()]
        moved = state
        for _ in range(20):
            moved = sim_rover.transition(moved, command, fine, rng=rng)
            path.append(moved.pose[:2].copy())
        if command[0] < 0:
            recent = np.concatenate(paths[-PARAMS.track_cycles :])
            gap = segment_distance(np.array(path), recent[:-1], recent[1:]).min(axis=1)
            assert gap.max() <= PARAMS.track_tolerance + 1e-9
        state = sim_rover.transition(state, command, sim, rng=rng)
        commands.append(command)
        paths.append(np.array(path))
    assert backed > 50 and refused > 50  # both verdicts were exercised


def _corridor(lower: float, upper: float, x_end: float) -> np.ndarray:
    """Wall cells (0.5 m squares) along y = ``lower`` and ``upper`` from x = -3.5 to
    ``x_end``, closed at ``x_end``: a dead end opening toward -x."""
    xs = np.arange(-3.5, x_end + 1e-9, 0.5)
    walls = [(x, y) for x in xs for y in (lower, upper)]
    return np.array(walls + [(x_end + 0.5, y) for y in np.arange(lower, upper + 1e-9, 0.5)])


@pytest.mark.parametrize(("lower", "y0", "psi0"), [(-0.7, 0.0, 0.0), (-0.8, 0.02, 0.3)])
def test_hemmed_in_a_corridor_narrower_than_the_margin_it_backs_out(
    lower: float, y0: float, psi0: float
) -> None:
    """No heading keeps the margin: only retreats that never lose clearance are allowed, and
    following them (the goal lies behind, outside) the rover backs out of the dead end."""
    walls = _corridor(lower, 0.7, 1.5)  # wall edges 0.45-0.55 m from the axis: gap < margin
    pose = np.array([1.0, y0, psi0])  # deep inside, facing the dead end
    start = footprint_safety(tuple(pose), THETA, walls, 0.5, np.zeros((0, 2)), FIELD, PARAMS)
    assert start.retreat and start.here < PARAMS.safety_margin
    assert not start.safe[0]  # driving on toward the dead end would lose clearance
    here, safety = start.here, start
    for _ in range(100):
        safety = footprint_safety(tuple(pose), THETA, walls, 0.5, np.zeros((0, 2)), FIELD, PARAMS)
        assert safety.here >= here - 1e-9  # the clearance never shrinks
        here = safety.here
        if not safety.retreat:
            break
        assert safety.safe.any()
        assert (safety.clearance[safety.safe] >= safety.here - 1e-9).all()
        allowed = np.flatnonzero(safety.safe)  # the one nearest the goal's direction, -x
        k = allowed[np.argmin(np.abs(np.angle(np.exp(1j * (THETA[allowed] - math.pi)))))]
        v, w = retreat_command(float(THETA[k]), float(pose[2]), PARAMS)
        pose[2] += w * PARAMS.dt
        pose[:2] += v * PARAMS.dt * np.array([math.cos(pose[2]), math.sin(pose[2])])
    assert not safety.retreat, "the rover stayed hemmed in"
    assert pose[0] < -3.0  # out past the corridor's mouth
    assert (safety.clearance[safety.safe] >= PARAMS.safety_margin).all()


def test_a_retreat_is_offered_only_when_no_heading_keeps_the_margin() -> None:
    free = _safety([(3.0, 0.0)])
    assert not free.retreat and (free.clearance[free.safe] >= PARAMS.safety_margin).all()


def test_a_retreat_pivots_onto_its_heading_then_drives_straight() -> None:
    v, w = retreat_command(math.pi, 0.1, PARAMS)
    assert v == 0.0 and abs(w) == PARAMS.pivot_rate
    v, w = retreat_command(0.2, 0.1, PARAMS)  # lands exactly on it
    assert v == 0.0 and 0.1 + w * PARAMS.dt == pytest.approx(0.2, abs=1e-12)
    assert retreat_command(0.2, 0.2, PARAMS) == (PARAMS.speed, 0.0)


def test_each_distinct_point_of_the_paths_is_measured_once_with_the_same_verdicts() -> None:
    """The check measures distances per distinct centre (the centre repeats while the rover
    pivots); every path's clearance and verdict equal the per-sample computation's."""
    rng = np.random.default_rng(3)
    pose = (0.3, -0.2, 0.7)

    def around(n: int) -> np.ndarray:  # points clear of the rover where it stands
        points = rng.uniform(-2.0, 2.0, size=(8 * n, 2))
        return points[np.hypot(points[:, 0] - pose[0], points[:, 1] - pose[1]) > 0.9][:n]

    cells, hits, unknown = around(40), around(6), around(25)
    safety = footprint_safety(pose, THETA, cells, 0.5, hits, FIELD, PARAMS, unknown)
    assert not safety.retreat  # else only ``here`` would be compared
    # (M, K, 2), every sample of the paths the check predicts (cautious: hazards in view)
    centres = predicted_centres(pose, THETA, PARAMS, cautious=safety.cautious)
    px, py = centres[..., 0:1], centres[..., 1:2]
    gap = (
        np.minimum(
            square_distance(px, py, cells[:, 0], cells[:, 1], 0.25).min(axis=-1),
            np.hypot(px - hits[:, 0], py - hits[:, 1]).min(axis=-1),
        )
        - PARAMS.footprint_radius
    )
    distance = square_distance(px, py, unknown[:, 0], unknown[:, 1], 0.25)
    unseen = (distance[:, 1:, :] < PARAMS.footprint_radius) & ~(
        distance[0, 0, :] < PARAMS.footprint_radius
    )
    allowed = ~unseen.any(axis=(1, 2))
    assert safety.here == gap[0, 0]
    np.testing.assert_array_equal(safety.clearance, gap.min(axis=1))
    np.testing.assert_array_equal(safety.safe, (gap.min(axis=1) >= PARAMS.safety_margin) & allowed)
    assert safety.safe.any() and not safety.safe.all()  # both verdicts are compared


def test_the_distinct_points_known_from_the_templates_give_back_every_sample() -> None:
    """Each cycle's distinct path points come from the templates, without sorting; indexed
    by their inverse they are every predicted sample, to the bit, the position first."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        pose = (float(rng.uniform(-30, 30)), float(rng.uniform(-30, 30)), float(rng.uniform(-7, 7)))
        points, inverse = predicted_points(pose, THETA, PARAMS)
        centres = predicted_centres(pose, THETA, PARAMS)
        np.testing.assert_array_equal(points[inverse], centres)
        assert (inverse[:, 0] == 0).all()
        assert len(points) < centres.shape[0] * centres.shape[1] / 2


def test_walls_beside_the_rover_are_not_ahead_however_the_nearest_cell_falls() -> None:
    """In a corridor narrower than body plus two margins, backing off gains no clearance:
    whether the nearest wall cell's centre lies just ahead or just behind, the rover is not
    told to back off from it (it did so on the spot, back and forth, for 1600 cycles)."""
    walls = [(x, y) for x in np.arange(-3.0, 3.01, 0.5) for y in (0.75, -0.75)]
    for x in (-0.2, -0.05, 0.05, 0.2):
        pose = (x, 0.0, 0.03)
        safety = footprint_safety(
            pose, THETA, np.array(walls), 0.5, np.zeros((0, 2)), FIELD, PARAMS
        )
        assert safety.here < PARAMS.safety_margin
        assert not safety.ahead
    # a wall across the way is ahead
    across = np.array([[0.75, y] for y in np.arange(-2.0, 2.01, 0.5)])
    safety = footprint_safety((0.0, 0.0, 0.0), THETA, across, 0.5, np.zeros((0, 2)), FIELD, PARAMS)
    assert safety.ahead


def test_a_hazard_beneath_the_body_never_opens_a_retreat_through_a_wall() -> None:
    """The rover stands on a hazard cell (a start cell still at the prior beside a wall's
    cell): its clearance is at its floor, which every path matched, so a retreat straight
    through the wall was allowed. Measured against the hazards not beneath it, a retreat
    may head away from the wall, never into it, and a reading ahead keeps binding."""
    under, wall = (0.0, 0.0), [(0.5, y) for y in (-0.5, 0.0, 0.5)]
    safety = _safety([under, *wall])
    assert safety.retreat and safety.here == pytest.approx(-PARAMS.footprint_radius)
    into, away = 0, int(np.argmin(np.abs(THETA - math.pi)))
    assert not safety.safe[into] and safety.safe[away]
    hits = np.array([[-0.6, 0.0]])  # something read behind, within the margin of the path
    assert not _safety([under, *wall], hits=hits).safe[away]
