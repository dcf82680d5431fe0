"""The explorer's drive: safe headings, backing off, retreats when hemmed in, pivots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayesmap.grid import OccupancyGrid
from bayesmap.rover import explorer as explorer_module
from bayesmap.rover import planning
from bayesmap.rover.decisions import collision_probability, navigation_goal
from bayesmap.rover.explorer import Explorer
from bayesmap.rover.params import RoverParams
from bayesmap.rover.safety import Safety, drive_command, retreat_command
from bayesmap.rover.targets import EntropyTarget, look_cycles
from bayesmap.sensing.ir import raw_from_range
from bayesmap.sim import rover as sim_rover
from bayesmap.sim.world2d import box_world

PARAMS = RoverParams(n_headings=36)


def _explorer() -> Explorer:
    return Explorer(
        OccupancyGrid(10.0, 10.0, 0.5, prior=PARAMS.prior), PARAMS, EntropyTarget(PARAMS)
    )


def _safety(*, retreat: bool, ahead: bool, back_clear: bool, here: float) -> Safety:
    safe = np.zeros(PARAMS.n_headings, dtype=bool)
    safe[18] = True  # only the heading behind
    return Safety(safe, np.zeros(PARAMS.n_headings), here, ahead, back_clear, retreat)


def test_a_retreat_pivots_onto_its_heading_instead_of_arcing() -> None:
    safety = _safety(retreat=True, ahead=False, back_clear=True, here=0.2)
    heading = float(np.asarray(PARAMS.headings)[18])
    psi = heading - 0.2  # the drive law would arc toward it; a retreat pivots onto it
    command = _explorer()._drive(heading, psi, safety, 18)
    assert command == retreat_command(heading, psi, PARAMS)
    assert command[0] == 0.0 and command[1] == pytest.approx(0.2 / PARAMS.dt)
    assert drive_command(heading, psi, PARAMS)[0] > 0.0


def test_backing_off_comes_before_a_retreat_when_the_obstacle_is_ahead() -> None:
    safety = _safety(retreat=True, ahead=True, back_clear=True, here=0.2)
    assert _explorer()._drive(np.pi, 0.0, safety, 18) == (-PARAMS.speed, 0.0)


@pytest.mark.parametrize("here", [-0.05, 0.05])
def test_without_a_safe_heading_or_the_track_behind_the_rover_turns_in_place(here) -> None:
    """No heading safe and backing off would leave the recent track: the rover turns in
    place toward the network's choice, even where the map puts a hazard under its body (a
    disc turning on its centre covers no new ground; a rover that stopped there stood
    still for the rest of its run)."""
    blocked = np.zeros(PARAMS.n_headings, dtype=bool)
    hemmed = Safety(blocked, np.zeros(PARAMS.n_headings), here, True, False, False)
    assert _explorer()._drive(np.pi, 0.0, hemmed, 18) == (0.0, PARAMS.pivot_rate)


def test_a_safe_heading_outside_a_retreat_follows_the_drive_law() -> None:
    safety = _safety(retreat=False, ahead=True, back_clear=True, here=0.5)
    heading = float(np.asarray(PARAMS.headings)[18])
    assert _explorer()._drive(heading, 0.5, safety, 18) == drive_command(heading, 0.5, PARAMS)


class _FixedTarget:
    """A target rule that always answers the same target and records what is rejected."""

    def __init__(self, target: tuple[float, float]) -> None:
        self.target_ = target
        self.rejected: list[tuple[float, float]] = []

    def select(self, grid, pose, plan, uncertain):  # noqa: ANN001, ANN201
        return self.target_

    def reject(self, target: tuple[float, float]) -> None:
        self.rejected.append(target)


def _dead_end_map(params: RoverParams) -> OccupancyGrid:
    """Certainly free ground with a dead-end corridor one cell wide (row 12, x 2–6 m) whose
    walls are certain obstacles: a rover inside cannot keep its margin."""
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=params.prior)
    grid.probability[:] = 0.01
    grid.entropy[:] = 0.05
    grid.probability[11, 4:13] = 0.99
    grid.probability[13, 4:13] = 0.99
    grid.probability[11:14, 12] = 0.99
    return grid


NOTHING_SEEN = raw_from_range(np.full(len(PARAMS.sensor_angles), PARAMS.r_max))


def test_hemmed_in_the_rover_gives_up_its_target_once_and_remembers_the_spot_a_while() -> None:
    params = RoverParams(pivot_rate=8.0)  # a full turn in 2 cycles: a short memory
    rule = _FixedTarget((1.25, 1.25))
    explorer = Explorer(_dead_end_map(params), params, rule)
    inside = (5.5, 6.25, math.pi)
    assert explorer.step(NOTHING_SEEN, inside).safety.retreat
    assert explorer.step(NOTHING_SEEN, inside).safety.retreat
    assert rule.rejected == [(1.25, 1.25)]  # once, on entering, not every hemmed-in cycle
    row, col = explorer.grid.world_to_cell(5.5, 6.25)
    assert explorer.hemmed_[int(row), int(col)] == 1.0
    outside = (5.5, 2.25, 0.0)
    memory = 10 * look_cycles(params)
    for _ in range(memory + 1):  # elsewhere, the memory fades
        explorer.step(NOTHING_SEEN, outside)
    assert explorer.hemmed_.sum() == 0.0


def test_a_place_that_hems_the_rover_in_again_is_closed_and_remembered_longer() -> None:
    params = RoverParams(pivot_rate=8.0)  # a full turn in 2 cycles: a short memory
    explorer = Explorer(_dead_end_map(params), params, _FixedTarget((1.25, 1.25)))
    inside, outside = (5.5, 6.25, math.pi), (5.5, 2.25, 0.0)
    row, col = (int(v) for v in explorer.grid.world_to_cell(5.5, 6.25))
    turns = 10 * look_cycles(params)
    explorer.step(NOTHING_SEEN, inside)
    for _ in range(look_cycles(params) + 1):  # out long enough for a new episode
        explorer.step(NOTHING_SEEN, outside)
    assert explorer.step(NOTHING_SEEN, inside).safety.retreat
    assert explorer.hemmed_[row, col] == 2.0  # hemmed in there a second time
    for _ in range(turns + 1):  # one time's memory is not enough to forget it
        explorer.step(NOTHING_SEEN, outside)
    assert explorer.hemmed_[row, col] == 2.0
    for _ in range(turns):
        explorer.step(NOTHING_SEEN, outside)
    assert explorer.hemmed_[row, col] == 0.0


def test_reusing_the_last_plan_changes_no_decision(monkeypatch: pytest.MonkeyPatch) -> None:
    """The plan is solved again only when the patch, the rover's cell or a crossing cost
    changed; a run re-planning every cycle takes exactly the same decisions."""
    world = box_world("rover-field-obstacles-v1")
    sim = sim_rover.SimulatedRoverParams()

    def run() -> list[tuple[object, ...]]:
        rng = np.random.default_rng(5)
        explorer = Explorer(
            OccupancyGrid(20.0, 20.0, 0.5, prior=PARAMS.prior), PARAMS, EntropyTarget(PARAMS)
        )
        state = sim_rover.initial([1.0, 1.0, 0.8], sim, rng=rng)
        decisions = []
        for _ in range(150):
            obs = sim_rover.observe(world, state, sim, rng=rng)
            d = explorer.step(obs.raw, obs.pose)
            decisions.append((d.command, d.heading, d.target, d.target_cost, d.p_move.tobytes()))
            state = sim_rover.transition(state, d.command, sim, rng=rng)
        return decisions

    reused = run()
    fresh_plan = planning.local_plan
    monkeypatch.setattr(
        explorer_module,
        "local_plan",
        lambda *args, previous=None, **kwargs: fresh_plan(*args, **kwargs),
    )
    assert run() == reused


def test_a_target_without_progress_for_two_turns_is_given_up() -> None:
    params = RoverParams(pivot_rate=8.0)  # a full turn in 2 cycles
    grid = OccupancyGrid(12.0, 12.0, 0.5, prior=params.prior)
    grid.probability[:] = 0.01
    rule = _FixedTarget((9.25, 6.25))
    explorer = Explorer(grid, params, rule)
    pose = (3.0, 6.25, 0.0)  # the rover never moves: the path still to go never shrinks
    for _ in range(2 * look_cycles(params) + 1):
        explorer.step(NOTHING_SEEN, pose)
    assert rule.rejected == []
    explorer.step(NOTHING_SEEN, pose)
    assert rule.rejected == [(9.25, 6.25)]
    moving = Explorer(grid, params, _FixedTarget((9.25, 6.25)))
    for k in range(4 * look_cycles(params)):  # driving toward it: never given up
        moving.step(NOTHING_SEEN, (3.0 + 0.1 * k, 6.25, 0.0))
    assert moving.target_rule.rejected == []


def test_a_retreat_drives_on_once_the_noisy_heading_is_within_half_a_heading_step() -> None:
    safety = _safety(retreat=True, ahead=False, back_clear=True, here=0.2)
    explorer = _explorer()
    step = 2.0 * math.pi / PARAMS.n_headings
    near = explorer._drive(float(PARAMS.headings[18]), math.pi - 0.4 * step, safety, 18)
    assert near == (PARAMS.speed, 0.0)  # 2° of compass noise no longer stops the retreat
    far = explorer._drive(float(PARAMS.headings[18]), math.pi - 0.6 * step, safety, 18)
    assert far[0] == 0.0 and far[1] != 0.0  # farther off: it pivots first


def test_near_a_hazard_a_safe_heading_outside_the_rangers_view_is_turned_to_first() -> None:
    """The check predicted a pivot for a heading 60° off when a hazard was within reach
    (:attr:`Safety.cautious`): the drive turns in place, where in open ground it arcs."""
    safe = np.ones(PARAMS.n_headings, dtype=bool)
    clear = np.full(PARAMS.n_headings, 1.0)
    heading = float(np.asarray(PARAMS.headings)[6])  # 60° left of a rover facing 0
    near = Safety(safe, clear, 1.0, False, False, False, cautious=True)
    open_ground = Safety(safe, clear, 1.0, False, False, False, cautious=False)
    assert _explorer()._drive(heading, 0.0, near, 6) == (0.0, PARAMS.pivot_rate)
    assert _explorer()._drive(heading, 0.0, open_ground, 6)[0] == PARAMS.speed


def test_eq_42_looks_along_each_heading_as_far_as_the_waypoint() -> None:
    """From the look-ahead out to d_max: a far waypoint sets the corridor's length, a near
    one the footprint check's look-ahead, none the paper's local area."""
    here = (2.0, 3.0)
    assert explorer_module.corridor_length(here, (5.0, 7.0), PARAMS) == pytest.approx(5.0)
    assert explorer_module.corridor_length(here, (2.1, 3.0), PARAMS) == PARAMS.lookahead
    assert explorer_module.corridor_length(here, (20.0, 3.0), PARAMS) == PARAMS.d_max
    assert explorer_module.corridor_length(here, None, PARAMS) == PARAMS.d_max


def test_a_wall_beyond_the_waypoint_does_not_turn_the_rover_off_its_way() -> None:
    """Open ground to a waypoint 1.5 m straight ahead and a likely wall 4 m ahead: cut at
    the waypoint, eq. 42 leaves the goal to decide (straight on); over d_max the wall
    draws the rover off the waypoint's bearing by more than the rangers' view."""
    centres = np.arange(-9.75, 10.0, 0.5)
    xc, yc = np.meshgrid(centres, centres)
    probability = np.where((xc > 4.0) & (xc < 5.0), 0.99, 0.02)
    theta = np.asarray(PARAMS.headings)
    p_t = navigation_goal(theta, 0.0)
    chosen = {}
    for name, waypoint in (("to the waypoint", (1.5, 0.0)), ("over d_max", None)):
        length = explorer_module.corridor_length((0.0, 0.0), waypoint, PARAMS)
        p_o = collision_probability(
            probability, xc, yc, (0.0, 0.0), theta, d_max=length, clearance=PARAMS.clearance
        )
        chosen[name] = abs(math.remainder(theta[int(np.argmax(p_t + 1.0 - p_o))], 2 * math.pi))
    assert chosen["to the waypoint"] == 0.0
    assert chosen["over d_max"] > PARAMS.view_half_angle
