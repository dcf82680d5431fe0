"""The rover's decision network (Post et al. 2016 Fig. 8), built with :mod:`bayesmap.bn`.

Nodes (kind in brackets, §3.4):

- ``IR_k`` [B]: the contact flag of ranger ``k`` (eq. 33), observed every cycle;
- ``SensorModel_k`` [A]: obstacle at the read range given the flag, eq. 32 at the current
  reading (its table comes from the current reading at query time);
- ``SensorFusion`` [C]: the linear opinion pool of the rangers toward the heading, eq. 35,
  with the angular weights of eq. 34;
- ``CollisionAvoidance`` [C]: a candidate heading ``theta_m`` (uniform a priori);
- ``ProbabilityMap`` [D]: whether the way along the candidate heading is ``clear`` or
  holds an ``obstacle``. Given ``SensorFusion = free`` it is read from the probability map
  (``P(obstacle | theta_m)`` = eq. 42); given ``SensorFusion = obstacle`` the current
  readings add an obstacle ahead: ``P(clear | theta_m) = (1 - P_O(theta_m)) (1 - a(theta_m))``
  with ``a`` a Gaussian of the heading's angle from the rover's heading over the rangers'
  view, scaled by how close the nearest reading is (1 at the rangers, 0 at ``r_max``).
  Observed ``clear``, it turns the candidate heading's distribution into
  ``∝ P(clear | theta_m)``, so a reading straight ahead steers the rover through the network;
- ``NavigationGoal`` [C]: a heading toward the target (eq. 40), or ``any``, with the weights
  of the two terms of eq. 43;
- ``MovementModel`` [A]: follows the navigation goal's heading, or the collision-avoidance
  heading when the goal says ``any``; so ``P(M) ∝ P(T) + (1 - P(O))``, eq. 43, when no
  ranger reads anything within ``r_max``;
- ``Footprint`` [D]: whether the rover's body stays clear of likely obstacles on the way
  to each heading (:mod:`bayesmap.rover.safety`, ours), observed ``clear``: headings whose
  swept footprint is unsafe get likelihood ``1e-9``;
- ``Motors`` [B]: the heading commanded.

A cycle's question is ``P(Motors | IR_k = o_k, ProbabilityMap = clear, Footprint = clear)``;
its argmax is the heading (§4.5). The inputs of a cycle (readings, map, goal, footprint)
are handed to :meth:`DecisionNetwork.decide` as one :class:`CycleInputs`; the data nodes'
sources read them from there. :func:`bayesmap.rover.decisions.movement_distribution` is the
same number computed directly when nothing is in range and every heading is safe; the
tests check they agree.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bayesmap._typing import BoolArray, FloatArray
from bayesmap.bn.model import BayesNet, DataSource, NodeKind
from bayesmap.errors import InputError
from bayesmap.geometry import wrap_angle
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.fusion import opinion_pool
from bayesmap.sensing.ir import angular_weight, beta_r, sensor_posterior

_P_O_MAX = 1.0 - 1e-9
"""``P(O | theta)`` is capped below 1 so that ``clear`` never has probability zero."""

_UNSAFE = 1e-9
"""Likelihood of ``Footprint = clear`` for a heading whose swept footprint is unsafe."""

Evaluator = Callable[[BayesNet, str, Mapping[str, str]], npt.ArrayLike]
"""Answers ``P(target | evidence)`` on the network, e.g. through generated C code
(:func:`bayesmap.rover.native.compiled_evaluator`); the default asks the Python engine."""


@dataclass(frozen=True)
class CycleInputs:
    """Everything one query reads: the readings, the map's answer, the goal, the footprint.

    Attributes
    ----------
    contacts
        ``(n,)`` contact flags of the rangers (eq. 33).
    ranges
        ``(n,)`` read ranges [m].
    p_t
        ``(M,)`` ``P(T | R, d, theta_t)`` at the headings (eq. 40).
    p_o
        ``(M,)`` ``P(O | theta_m)`` read off the probability map (eq. 42).
    heading
        The rover's heading [rad], to place the readings among the world headings.
    safe
        ``(M,)`` headings whose swept footprint is clear (:mod:`bayesmap.rover.safety`).
    """

    contacts: BoolArray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    ranges: FloatArray = field(default_factory=lambda: np.zeros(0))
    p_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    p_o: FloatArray = field(default_factory=lambda: np.zeros(0))
    heading: float = 0.0
    safe: BoolArray = field(default_factory=lambda: np.zeros(0, dtype=bool))


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
        self._theta = np.asarray(params.headings)
        self._view = float(np.max(np.abs(params.sensor_angles))) + params.w_r
        self._evidence: dict[str, str] = {"ProbabilityMap": "clear", "Footprint": "clear"}
        self.observed = (*(f"IR_{k}" for k in range(self.n_sensors)), *self._evidence)
        """The nodes :meth:`decide` observes: the rangers, the map and the footprint."""

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
            "Footprint",
            ["clear", "blocked"],
            parents=["MovementModel"],
            kind=NodeKind.DATA,
            cpt=np.full((2, m), 0.5),
            source=self._footprint_source,
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

    def reading_ahead(self) -> FloatArray:
        """``a(theta_m)``: how strongly the current readings put an obstacle on each heading.

        A Gaussian of the heading's angle from the rover's heading, of width the rangers'
        view (widest mounting angle + ``w_r``), times ``1 - r / r_max`` for the nearest read
        range ``r`` (0 when nothing is read within ``r_max``).
        """
        inputs = self.inputs_
        nearest = float(np.min(inputs.ranges, initial=np.inf))
        closeness = float(np.clip(1.0 - nearest / self.params.r_max, 0.0, 1.0))
        offset = wrap_angle(self._theta - inputs.heading)
        return np.asarray(closeness * np.exp(-((offset / self._view) ** 2)))

    def _map_source(self, evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        clear = 1.0 - self.inputs_.p_o
        with_reading = clear * (1.0 - self.reading_ahead())
        table = np.stack([np.stack([clear, with_reading], axis=1)])
        return np.concatenate([table, 1.0 - table])

    def _goal_source(self, evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        p_t = self.inputs_.p_t
        free = float(np.sum(1.0 - self.inputs_.p_o))
        return np.asarray(np.append(p_t, free) / (p_t.sum() + free))

    def _footprint_source(self, evidence: Mapping[str, str]) -> FloatArray:
        del evidence
        clear = np.where(self.inputs_.safe, 1.0, _UNSAFE)
        return np.stack([clear, 1.0 - clear])

    # --------------------------------------------------------------- queries
    def decide(self, inputs: CycleInputs) -> tuple[int, FloatArray]:
        """Ask ``P(Motors | readings, map clear, footprint clear)``: (argmax, distribution)."""
        m = self.params.n_headings
        shapes = {"p_t": inputs.p_t.shape, "p_o": inputs.p_o.shape, "safe": inputs.safe.shape}
        wrong = {k: v for k, v in shapes.items() if v != (m,)}
        if wrong or inputs.contacts.shape != (self.n_sensors,):
            raise InputError(
                f"decision inputs need {m} headings and {self.n_sensors} rangers, got "
                f"{shapes} and contacts {inputs.contacts.shape}"
            )
        self.inputs_ = CycleInputs(
            contacts=inputs.contacts,
            ranges=inputs.ranges,
            p_t=inputs.p_t,
            p_o=np.minimum(inputs.p_o, _P_O_MAX),
            heading=inputs.heading,
            safe=inputs.safe,
        )
        for k, o in enumerate(inputs.contacts.astype(bool)):
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
        flags = np.asarray(contacts).astype(bool)
        self.inputs_ = CycleInputs(contacts=flags, ranges=np.asarray(ranges, dtype=np.float64))
        evidence = {f"IR_{k}": ("contact" if o else "no_contact") for k, o in enumerate(flags)}
        return float(self.net.posterior("SensorFusion", evidence)["obstacle"])
