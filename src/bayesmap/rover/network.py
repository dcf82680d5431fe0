"""The rover's decision network (Post et al. 2016 Fig. 8), built with :mod:`bayesmap.bn`.

Nodes (kind in brackets, §3.4):

- ``IR_k`` [B]: the contact flag of ranger ``k`` (eq. 33), observed every cycle;
- ``SensorModel_k`` [A]: obstacle at the read range given the flag, eq. 32 at the current
  reading (its table comes from the current reading at query time);
- ``SensorFusion`` [C]: the linear opinion pool of the rangers toward the heading, eq. 35,
  with the angular weights of eq. 34;
- ``CollisionAvoidance`` [C]: a candidate heading ``theta_m`` (uniform a priori);
- ``ProbabilityMap`` [D]: whether the corridor along the candidate heading is ``clear`` or
  holds an ``obstacle``, read from the live probability map at query time
  (``P(obstacle | theta_m)`` = eq. 42); observed ``clear``, it turns the candidate heading's
  distribution into ``∝ 1 - P(O | theta_m)``. Its parent ``SensorFusion`` records that the
  map is what the fused readings were written into; the table does not depend on it;
- ``NavigationGoal`` [C]: a heading toward the target (eq. 40), or ``any``, with the weights
  of the two terms of eq. 43;
- ``MovementModel`` [A]: follows the navigation goal's heading, or the collision-avoidance
  heading when the goal says ``any``; so ``P(M) ∝ P(T) + (1 - P(O))``, eq. 43;
- ``Motors`` [B]: the heading commanded.

A cycle's question is ``P(Motors | IR_k = o_k, ProbabilityMap = clear)``; its argmax is the
heading (§4.5). :func:`bayesmap.rover.decisions.movement_distribution` is the same number
computed directly; the tests check they agree.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.bn.model import BayesNet, DataSource, NodeKind
from bayesmap.errors import InputError
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.fusion import opinion_pool
from bayesmap.sensing.ir import angular_weight, beta_r, sensor_posterior

_P_O_MAX = 1.0 - 1e-9
"""``P(O | theta)`` is capped below 1 so that ``clear`` never has probability zero."""


MapReader = Callable[[], npt.ArrayLike]
"""Reads ``P(O | theta_m)`` for the ``M`` headings off the live probability map (eq. 42)."""

Evaluator = Callable[[BayesNet, str, Mapping[str, str]], npt.ArrayLike]
"""Answers ``P(target | evidence)`` on the network, e.g. through generated C code
(:func:`bayesmap.rover.native.compiled_evaluator`); the default asks the Python engine."""


@dataclass
class CycleInputs:
    """What the data sources read during one query (set by :meth:`DecisionNetwork.decide`).

    ``p_o`` is filled from ``read_map`` the first time a node's source needs it.
    """

    ranges: FloatArray = field(default_factory=lambda: np.zeros(0))
    p_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    p_o: FloatArray | None = None
    read_map: MapReader | None = None


def heading_states(n: int) -> tuple[str, ...]:
    """State names of the heading variables: ``h000`` … in degrees."""
    return tuple(f"h{round(360.0 * m / n):03d}" for m in range(n))


class DecisionNetwork:
    """Builds the Fig. 8 network for ``params`` and answers one heading question per cycle.

    Attributes
    ----------
    net
        The :class:`~bayesmap.bn.model.BayesNet`.
    inputs_
        The current cycle's inputs, read by the nodes' sources at query time.
    """

    def __init__(self, params: RoverParams, evaluator: Evaluator | None = None) -> None:
        self.params = params
        self.evaluator = evaluator
        self.inputs_ = CycleInputs()
        self.n_sensors = len(params.sensor_angles)
        self.net = self._build()
        self._evidence: dict[str, str] = {"ProbabilityMap": "clear"}

    def _build(self) -> BayesNet:
        p = self.params
        m = p.n_headings
        headings = heading_states(m)
        net = BayesNet("micro_rover_mapping")
        net.properties["source"] = "Post, Li & Quine 2016, Acta Astronautica 120, Fig. 8"
        sensor_names = []
        for k in range(self.n_sensors):
            net.add_variable(
                f"IR_{k}",
                ["no_contact", "contact"],
                kind=NodeKind.BUS,
                properties={"angle_rad": f"{p.sensor_angles[k]:.6f}"},
            )
            name = f"SensorModel_{k}"
            net.add_variable(
                name,
                ["free", "obstacle"],
                parents=[f"IR_{k}"],
                kind=NodeKind.ABILITY,
                cpt=self._sensor_table(p.r_max),
                source=self._sensor_source(k),
            )
            sensor_names.append(name)
        net.add_variable(
            "SensorFusion",
            ["free", "obstacle"],
            parents=sensor_names,
            kind=NodeKind.CLASSIFICATION,
            cpt=self._fusion_table(),
        )
        net.add_variable("CollisionAvoidance", headings, kind=NodeKind.CLASSIFICATION)
        net.add_variable(
            "ProbabilityMap",
            ["clear", "obstacle"],
            parents=["CollisionAvoidance", "SensorFusion"],
            kind=NodeKind.DATA,
            cpt=np.full((2, m, 2), 0.5),
            source=self._map_source,
        )
        net.add_variable(
            "NavigationGoal",
            [*headings, "any"],
            kind=NodeKind.CLASSIFICATION,
            source=self._goal_source,
        )
        follow = np.zeros((m, m + 1, m))
        for t in range(m):
            follow[t, t, :] = 1.0
        follow[:, m, :] = np.eye(m)
        net.add_variable(
            "MovementModel",
            headings,
            parents=["NavigationGoal", "CollisionAvoidance"],
            kind=NodeKind.ABILITY,
            cpt=follow,
        )
        net.add_variable(
            "Motors", headings, parents=["MovementModel"], kind=NodeKind.BUS, cpt=np.eye(m)
        )
        return net

    # ------------------------------------------------------------ node tables
    def _sensor_table(self, read_range: float) -> FloatArray:
        """``P(SensorModel | IR)``: eq. 32 at ``read_range`` [m], rows ``free``, ``obstacle``."""
        p = self.params
        beta = beta_r(read_range, r_max=p.r_max, beta_b=p.beta_b, floor=p.reliability_floor)
        s = sensor_posterior(beta, p.prior, np.array([0, 1]))
        return np.stack([1.0 - s, s])

    def _sensor_source(self, k: int) -> DataSource:
        def source(evidence: Mapping[str, str]) -> FloatArray:
            del evidence
            return self._sensor_table(float(self.inputs_.ranges[k]))

        return source

    def _fusion_table(self) -> FloatArray:
        """``P(obstacle | sensor states) = sum_n alpha_n [state_n = obstacle] / sum_n alpha_n``."""
        n = self.n_sensors
        alpha = angular_weight(np.asarray(self.params.sensor_angles), self.params.w_r)
        states = np.indices((2,) * n).reshape(n, -1).T
        obstacle = opinion_pool(states.T.astype(float), alpha[:, None], axis=0)
        return np.stack([1.0 - obstacle, obstacle]).reshape((2,) + (2,) * n)

    def collision(self) -> FloatArray:
        """This cycle's ``P(O | theta_m)``, read off the map on first use (capped below 1)."""
        inputs = self.inputs_
        if inputs.p_o is None:
            if inputs.read_map is None:
                raise InputError("the decision network has no map to read this cycle")
            inputs.p_o = np.minimum(np.asarray(inputs.read_map(), dtype=np.float64), _P_O_MAX)
        return inputs.p_o

    def _map_source(self, evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        p_o = self.collision()
        column = np.stack([1.0 - p_o, p_o])
        return np.repeat(column[:, :, None], 2, axis=2)

    def _goal_source(self, evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        p_t = self.inputs_.p_t
        free = float(np.sum(1.0 - self.collision()))
        return np.asarray(np.append(p_t, free) / (p_t.sum() + free))

    # --------------------------------------------------------------- queries
    def decide(
        self,
        p_t: npt.ArrayLike,
        p_o: npt.ArrayLike | MapReader,
        contacts: npt.ArrayLike,
        ranges: npt.ArrayLike,
    ) -> tuple[int, FloatArray]:
        """Ask the network ``P(Motors | readings, map clear)``; return (argmax, distribution).

        Parameters
        ----------
        p_t
            ``P(T | R, d, theta_t)`` at the ``M`` headings (eq. 40).
        p_o
            ``P(O | theta_m)`` at the headings, or a :data:`MapReader` that the
            ``ProbabilityMap`` data node calls to read them off the live map (eq. 42).
        contacts, ranges
            The rangers' contact flags (eq. 33) and read ranges [m].
        """
        reader = p_o if callable(p_o) else None
        self.inputs_ = CycleInputs(
            ranges=np.asarray(ranges, dtype=np.float64),
            p_t=np.asarray(p_t, dtype=np.float64),
            p_o=None if callable(p_o) else np.minimum(np.asarray(p_o, dtype=np.float64), _P_O_MAX),
            read_map=reader,
        )
        for k, o in enumerate(np.asarray(contacts).astype(bool)):
            self._evidence[f"IR_{k}"] = "contact" if o else "no_contact"
        if self.evaluator is not None:
            distribution = np.asarray(self.evaluator(self.net, "Motors", self._evidence), float)
        else:
            distribution = np.fromiter(
                self.net.posterior("Motors", self._evidence).values(), dtype=float
            )
        return int(np.argmax(distribution)), distribution

    def fused(self, contacts: npt.ArrayLike, ranges: npt.ArrayLike) -> float:
        """``P(SensorFusion = obstacle | readings)``: eq. 35 straight ahead, from the network."""
        self.inputs_ = CycleInputs(
            ranges=np.asarray(ranges, dtype=np.float64), p_t=self.inputs_.p_t, p_o=self.inputs_.p_o
        )
        evidence = {
            f"IR_{k}": ("contact" if o else "no_contact")
            for k, o in enumerate(np.asarray(contacts).astype(bool))
        }
        return float(self.net.posterior("SensorFusion", evidence)["obstacle"])
