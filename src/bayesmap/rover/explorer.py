"""One rover cycle: sense, map, choose a target, ask the decision network, command the drive.

:class:`Explorer` is the rover's brain. It sees only what the rover's own sensors give it —
IR readings and an estimated pose — so a real rover's log drives the same code as the
simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.grid import OccupancyGrid
from bayesmap.rover.decisions import collision_probability, navigation_goal, wrap
from bayesmap.rover.mapping import IRMapper, local_patch
from bayesmap.rover.network import DecisionNetwork, Evaluator
from bayesmap.rover.params import RoverParams
from bayesmap.rover.targets import TargetRule


@dataclass(frozen=True)
class Decision:
    """The outcome of one cycle.

    Attributes
    ----------
    command
        ``(speed [m/s], yaw_rate [rad/s])`` for the drive.
    heading
        The chosen world heading [rad].
    target
        The exploration target ``(x, y)`` [m], or ``None`` when mapping is complete.
    p_move
        ``P(Motors)`` over the ``M`` headings, as the network answered.
    p_collision
        ``P(O | theta_m)`` over the headings (eq. 42, blocked headings at 1).
    """

    command: tuple[float, float]
    heading: float
    target: tuple[float, float] | None
    p_move: FloatArray
    p_collision: FloatArray


class Explorer:
    """The rover's brain for mapping an area (Post et al. 2016 §4).

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
        self._theta = np.asarray(params.headings)

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
        self.mapper_.update(raw, (x, y, psi))
        target = self.target_rule.select(self.grid, (x, y, psi))
        theta_t = psi if target is None else math.atan2(target[1] - y, target[0] - x)
        blocked = np.zeros(p.n_headings, dtype=bool)

        def read_map() -> FloatArray:
            """The data node's view of the map: eq. 42 per heading, blocked headings at 1."""
            xc, yc, prob = local_patch(self.grid, self.grid.probability, x, y, p.d_max, p.prior)
            p_o, blocked[:] = collision_probability(
                prob,
                xc,
                yc,
                (x, y),
                self._theta,
                d_max=p.d_max,
                clearance=p.clearance,
                distance_weighted=p.distance_weighted,
                stop_distance=p.stop_distance,
                p_block=p.p_block,
            )
            return np.asarray(np.where(blocked, 1.0, p_o))

        p_t = navigation_goal(self._theta, theta_t)
        index, p_move = self.network_.decide(
            p_t, read_map, self.mapper_.last_contacts_, self.mapper_.last_ranges_
        )
        p_o = self.network_.collision()
        heading = float(self._theta[index])
        if target is None:
            command = (0.0, 0.0)
        else:
            facing = int(np.argmin(np.abs(wrap(self._theta - psi))))
            command = self._drive(heading, psi, bool(blocked[index] or blocked[facing]))
        return Decision(command, heading, target, p_move, p_o)

    def _drive(self, heading: float, psi: float, blocked: bool) -> tuple[float, float]:
        """Turn toward ``heading``; pivot in place when blocked or facing away (skid steer)."""
        p = self.params
        error = float(wrap(heading - psi))
        if blocked or abs(error) > math.pi / 2:
            return (0.0, math.copysign(p.pivot_rate, error if error != 0 else 1.0))
        limit = p.speed / p.min_turn_radius
        return (p.speed, float(np.clip(2.0 * error, -limit, limit)))
