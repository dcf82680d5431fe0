"""One rover cycle: sense, map, choose a target, ask the decision network, command the drive.

:class:`Explorer` is the rover's brain. It sees only what the rover's own sensors give it —
IR readings and an estimated pose — so a real rover's log drives the same code as the
simulator.
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.grid import OccupancyGrid
from bayesmap.rover.decisions import collision_probability, navigation_goal
from bayesmap.rover.mapping import IRMapper, local_patch
from bayesmap.rover.network import CycleInputs, DecisionNetwork, Evaluator
from bayesmap.rover.params import RoverParams
from bayesmap.rover.planning import LocalPlan, local_plan
from bayesmap.rover.safety import (
    Safety,
    drive_command,
    footprint_safety,
    hazard_cells,
    reading_points,
    recent_track,
    retreat_command,
)
from bayesmap.rover.targets import TargetRule, look_cycles
from bayesmap.sensing.ir import ranger_poses

_HEMMED_IN = 9
"""With fewer reachable cells than this, the plan is not trusted to reject targets."""

_HEMMED_TURNS = 10
"""Full turns' worth of cycles (:func:`~bayesmap.rover.targets.look_cycles`) for which the
plan avoids the cells where the rover was hemmed in, per time it was hemmed in there: long
enough to explore elsewhere, short enough that a corridor the map has since opened is tried
again. A place that hemmed the rover in twice is closed to the plan and remembered twice
as long, and so on (:func:`~bayesmap.rover.planning.crossing_costs`)."""

_STUCK_TURNS = 2
"""Full turns' worth of cycles without progress after which a target is given up."""


@dataclass(frozen=True)
class Decision:
    """The outcome of one cycle.

    Attributes
    ----------
    command
        ``(speed [m/s], yaw_rate [rad/s])`` for the drive; a negative speed backs off.
    heading
        The chosen world heading [rad].
    target
        The exploration target ``(x, y)`` [m], or ``None`` when mapping is complete.
    p_move
        ``P(Motors)`` over the ``M`` headings, as the network answered.
    p_collision
        ``P(O | theta_m)`` over the headings (eq. 42).
    safety
        The footprint check of the headings (:mod:`bayesmap.rover.safety`).
    target_cost
        Path cost [m] still to go from the rover's position to the target's viewpoint over
        the local map, plus the straight line beyond it (:meth:`LocalPlan.remaining`);
        ``inf`` when unreachable, ``nan`` without a target.
    """

    command: tuple[float, float]
    heading: float
    target: tuple[float, float] | None
    p_move: FloatArray
    p_collision: FloatArray
    safety: Safety
    target_cost: float


def corridor_length(
    position: tuple[float, float], waypoint: tuple[float, float] | None, params: RoverParams
) -> float:
    """How far [m] eq. 42 looks along each heading: to the waypoint the rover steers at.

    Post et al. 2016 sum eq. 42 out to ``d_max``, the local area. The rover drives to
    the waypoint along its plan and decides again every cycle, and the way beyond it turns
    with the plan, so cells farther along a straight heading are not where it is going;
    read out to 8 m they outweighed eq. 40's goal term within ±40° of the waypoint and
    flipped the chosen heading from cycle to cycle (docs/rover.md). The distance from
    ``position`` to ``waypoint`` (both ``(x, y)`` [m]), kept between the footprint check's
    ``lookahead`` and ``d_max``; ``d_max`` when there is no waypoint.
    """
    if waypoint is None:
        return params.d_max
    distance = math.hypot(waypoint[0] - position[0], waypoint[1] - position[1])
    return min(max(distance, params.lookahead), params.d_max)


class Explorer:
    """The rover's brain for mapping an area (Post et al. 2016 §4, made safe and complete).

    Each cycle: fold the readings into the maps (eqs. 31–37); plan path costs over the local
    area (:mod:`bayesmap.rover.planning`); let the target rule pick or keep a target;
    steer toward a waypoint on the path to it (eq. 40); read eq. 42 off the map as far as
    the waypoint (:func:`corridor_length`); check the footprint along every heading
    (:mod:`bayesmap.rover.safety`); ask the decision network; drive. When no heading is
    safe the rover stops and turns in place, or backs off when its footprint is already
    within the margin of an obstacle ahead.

    Parameters
    ----------
    grid
        The map to build; its prior should equal ``params.prior``.
    params
        Sensor model, decision and drive parameters.
    target_rule
        The exploration rule (:class:`~bayesmap.rover.targets.EntropyTarget` is the paper's).
    evaluator
        How the decision network is asked (default: the Python engine); e.g.
        :func:`bayesmap.rover.native.compiled_evaluator` runs it through generated C.

    Attributes
    ----------
    mapper_
        The IR mapper holding the maps.
    network_
        The decision network queried every cycle.
    recent_hits_
        The points read by the rangers in the last ``hit_memory`` cycles [m]: the footprint
        keeps its margin from them as from the map, without the map's cell quantisation.
    commands_
        The commands of the last ``track_cycles`` cycles, oldest first: the rover's recent
        track, which a back-off may reverse into (:func:`~bayesmap.rover.safety.recent_track`).
    hemmed_
        Map-sized layer: on the cells where the rover was hemmed in (inside the margin, no
        heading keeping it), the number of times it was hemmed in there, for
        ``_HEMMED_TURNS`` full turns' cycles per time; 0 elsewhere. The plan crosses a
        cell hemmed in once only at a price, and not at all one hemmed in more often
        (:func:`~bayesmap.rover.planning.local_plan`).
    """

    def __init__(
        self,
        grid: OccupancyGrid,
        params: RoverParams,
        target_rule: TargetRule,
        evaluator: Evaluator | None = None,
    ) -> None:
        self.params = params
        self.target_rule = target_rule
        self.mapper_ = IRMapper(grid, params)
        self.network_ = DecisionNetwork(params, evaluator)
        self.recent_hits_: deque[FloatArray] = deque(maxlen=params.hit_memory)
        self.commands_: deque[tuple[float, float]] = deque(maxlen=params.track_cycles)
        self._theta = np.asarray(params.headings)
        self._retreat: int | None = None
        self.hemmed_ = np.zeros(grid.shape)
        self._hemmed_times = np.zeros(grid.shape, dtype=np.int64)
        self._hemmed_at = np.zeros(grid.shape, dtype=np.int64)
        self._hemmed_log: list[tuple[int, int, tuple[int, int]]] = []  # heap: expiry, mark, cell
        self._cycle = 0
        self._was_hemmed = False
        self._last_hemmed = -(10**9)
        self._progress: tuple[tuple[float, float] | None, float, int] = (None, math.inf, 0)
        self._plan: LocalPlan | None = None

    @property
    def grid(self) -> OccupancyGrid:
        """The map being built."""
        return self.mapper_.grid_

    @property
    def done(self) -> bool:
        """Every cell's entropy is below ``h_desired`` (the stop rule of §4.4)."""
        return self.mapper_.n_uncertain_ == 0

    def step(self, raw: npt.ArrayLike, pose: npt.ArrayLike) -> Decision:
        """Run one cycle on ADC readings ``raw`` taken at estimated ``pose = (x, y, heading)``."""
        p = self.params
        x, y, psi = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
        mapper = self.mapper_
        mapper.update(raw, (x, y, psi))
        self._cycle += 1
        self._forget_hemmed()
        plan = self._plan = local_plan(self.grid, x, y, p, avoid=self.hemmed_, previous=self._plan)
        target, waypoint = self._target(plan, (x, y, psi))
        theta_t = psi if waypoint is None else math.atan2(waypoint[1] - y, waypoint[0] - x)
        safety = self._safety((x, y, psi))
        if safety.retreat:
            self._remember_hemmed(x, y, target)
        self._was_hemmed = safety.retreat
        safe = safety.safe
        if safety.retreat and self._retreat is not None and safe[self._retreat]:
            safe = np.arange(safe.size) == self._retreat  # a retreat once begun is kept
        xc, yc, prob = local_patch(self.grid, self.grid.probability, x, y, p.d_max, p.prior)
        p_o = collision_probability(
            prob,
            xc,
            yc,
            (x, y),
            self._theta,
            d_max=corridor_length((x, y), waypoint, p),
            clearance=p.clearance,
            distance_weighted=p.distance_weighted,
        )
        inputs = CycleInputs(
            contacts=mapper.last_contacts_,
            ranges=mapper.last_ranges_,
            p_t=navigation_goal(self._theta, theta_t),
            p_o=p_o,
            heading=psi,
            safe=safe,
        )
        index, p_move = self.network_.decide(inputs)
        self._retreat = index if safety.retreat and safe[index] else None
        heading = float(self._theta[index])
        command = (0.0, 0.0) if target is None else self._drive(heading, psi, safety, index)
        self.commands_.append(command)
        cost = math.nan if target is None else plan.remaining(x, y, target)
        self._check_progress(target, cost)
        return Decision(command, heading, target, p_move, p_o, safety, cost)

    def _remember_hemmed(self, x: float, y: float, target: tuple[float, float] | None) -> None:
        """Mark the cells around a hemmed-in rover for the plan to avoid, and give up the
        target that led it there (once per episode: not again while the rover has been
        hemmed in within the last full turn's cycles, as it is on and off while it backs
        out). Each new episode counts once more on the cells it marks, so a corridor that
        keeps drawing the rover back in is closed to the plan, for longer each time."""
        grid = self.grid
        row, col = (int(v) for v in grid.world_to_cell(x, y))
        new_episode = self._cycle - self._last_hemmed > look_cycles(self.params)
        turns = look_cycles(self.params) * _HEMMED_TURNS
        for r in range(max(row - 1, 0), min(row + 2, grid.shape[0])):
            for c in range(max(col - 1, 0), min(col + 2, grid.shape[1])):
                times = self._hemmed_times[r, c] + 1 if new_episode else 1
                self._hemmed_times[r, c] = times = max(times, self._hemmed_times[r, c])
                self.hemmed_[r, c] = times
                self._hemmed_at[r, c] = self._cycle
                heapq.heappush(self._hemmed_log, (self._cycle + times * turns, self._cycle, (r, c)))
        if target is not None and new_episode:
            self.target_rule.reject(target)
        self._last_hemmed = self._cycle

    def _forget_hemmed(self) -> None:
        """Stop avoiding cells whose memory (``_HEMMED_TURNS`` full turns per time the rover
        was hemmed in there) has run out since they were last marked."""
        while self._hemmed_log and self._hemmed_log[0][0] <= self._cycle:
            _, cycle, cell = heapq.heappop(self._hemmed_log)
            if self._hemmed_at[cell] == cycle:  # not marked again since
                self.hemmed_[cell] = 0.0

    def _check_progress(self, target: tuple[float, float] | None, to_go: float) -> None:
        """Give up a target whose path still to go has not shrunk for ``_STUCK_TURNS`` full
        turns' cycles while the rover is not yet at its viewpoint (where the target rule's
        own look timeout applies)."""
        previous, best, since = self._progress
        if target is None or target != previous:
            self._progress = (target, to_go, 0)
            return
        if to_go < best - 1e-6:
            self._progress = (target, to_go, 0)
            return
        since += 1
        self._progress = (target, best, since)
        if since > _STUCK_TURNS * look_cycles(self.params) and to_go > self.grid.resolution:
            self.target_rule.reject(target)
            self._progress = (None, math.inf, 0)

    def _target(
        self, plan: LocalPlan, pose: tuple[float, float, float]
    ) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
        """The rule's target and the waypoint toward it; unreachable targets are rejected.

        When the plan reaches next to nothing (the rover hemmed in by hazards on a noisy
        map), or the rover was hemmed in on the last cycle (inside the margin, the plan
        from where it stands reaches only the cells around it), nothing is rejected: the
        rover steers at the target and the footprint check keeps it safe while it turns,
        looks around and backs out. Rejecting there gave up up to eight targets a cycle,
        hundreds in one episode, and the rover then left whole regions unexplored.
        """
        if self._was_hemmed or int(np.isfinite(plan.cost).sum()) < _HEMMED_IN:
            target = self.target_rule.select(self.grid, pose, plan, self.mapper_.uncertain_)
            return target, target
        for _ in range(8):
            target = self.target_rule.select(self.grid, pose, plan, self.mapper_.uncertain_)
            if target is None:
                return None, None
            waypoint = plan.waypoint(target)
            if waypoint is not None:
                return target, waypoint
            self.target_rule.reject(target)
        return target, None

    def _safety(self, pose: tuple[float, float, float]) -> Safety:
        """The footprint check of every heading against the map and the current readings."""
        p = self.params
        grid = self.grid
        reach = p.lookahead + p.footprint_radius + p.safety_margin + grid.resolution
        xc, yc, prob = local_patch(grid, grid.probability, pose[0], pose[1], reach, 0.0)
        likely = hazard_cells(prob, p)
        unknown = prob == grid.prior
        sensors = ranger_poses(pose, p.sensor_angles, p.sensor_offset)
        self.recent_hits_.append(
            reading_points(sensors, self.mapper_.last_ranges_, self.mapper_.last_above_noise_, p)
        )
        hits = np.concatenate(list(self.recent_hits_))
        hits = hits[np.hypot(hits[:, 0] - pose[0], hits[:, 1] - pose[1]) <= reach]
        cells = np.stack([xc[likely], yc[likely]], axis=1)
        unseen = np.stack([xc[unknown], yc[unknown]], axis=1)
        track = recent_track(self.commands_, p)
        return footprint_safety(
            pose, self._theta, cells, grid.resolution, hits, grid.extent, p, unseen, track
        )

    def _drive(self, heading: float, psi: float, safety: Safety, index: int) -> tuple[float, float]:
        """Drive toward a safe heading; otherwise back off along the recent track, retreat
        along the heading when it is a retreat (:attr:`Safety.retreat`), or turn in place
        (a round body turning on its centre covers no new ground).

        A retreat drives straight on once the estimated heading is within half the spacing
        of the discrete headings of it: the compass's noise (2° in the simulator) never lets
        the estimate land on it exactly, and a pivot waiting for that turned in place for
        thousands of cycles. The footprint check of the next cycle sees the small offset.
        """
        p = self.params
        if safety.safe[index] and not safety.retreat:
            return drive_command(heading, psi, p, cautious=safety.cautious)
        if safety.here < p.safety_margin and safety.ahead and safety.back_clear:
            return (-p.speed, 0.0)
        error = math.remainder(heading - psi, 2.0 * math.pi)
        if safety.safe[index] and abs(error) <= math.pi / p.n_headings:
            return (p.speed, 0.0)
        if safety.safe[index]:
            return retreat_command(heading, psi, p)
        return (0.0, math.copysign(p.pivot_rate, error if error != 0 else 1.0))
