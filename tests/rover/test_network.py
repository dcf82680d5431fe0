"""The decision network (Fig. 8) must agree with the numpy decision maths."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap import bn
from bayesmap.bn.model import NodeKind
from bayesmap.errors import ConfigError, InputError
from bayesmap.rover.decisions import movement_distribution, navigation_goal
from bayesmap.rover.network import CycleInputs, DecisionNetwork, heading_states
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.fusion import opinion_pool
from bayesmap.sensing.ir import angular_weight, beta_r, sensor_posterior

PARAMS = RoverParams(n_headings=12)
NETWORK = DecisionNetwork(PARAMS)
FAR = np.full(3, 7.1)  # what the rangers read with nothing in range
ALL_SAFE = np.ones(PARAMS.n_headings, dtype=bool)


def _inputs(p_t, p_o, contacts=(False,) * 3, ranges=FAR, heading=0.0, safe=ALL_SAFE):  # type: ignore[no-untyped-def]
    return CycleInputs(
        contacts=np.asarray(contacts, dtype=bool),
        ranges=np.asarray(ranges, dtype=float),
        p_t=np.asarray(p_t, dtype=float),
        p_o=np.asarray(p_o, dtype=float),
        heading=heading,
        safe=np.asarray(safe, dtype=bool),
    )


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_network_heading_distribution_equals_eq_43(seed: int) -> None:
    rng = np.random.default_rng(seed)
    theta = np.asarray(PARAMS.headings)
    p_t = navigation_goal(theta, rng.uniform(-np.pi, np.pi))
    p_o = rng.uniform(size=theta.size) ** rng.uniform(0.2, 3.0)
    p_o[rng.uniform(size=theta.size) < 0.2] = 1.0  # blocked headings
    contacts = rng.uniform(size=3) < 0.5
    ranges = rng.uniform(PARAMS.r_max, 7.0, size=3)  # nothing within r_max
    index, distribution = NETWORK.decide(
        _inputs(p_t, p_o, contacts, ranges, rng.uniform(-np.pi, np.pi))
    )
    expected = movement_distribution(p_t, np.minimum(p_o, 1 - 1e-9))
    np.testing.assert_allclose(distribution, expected, atol=1e-9)
    assert index == int(np.argmax(expected))


def test_fusion_node_is_the_opinion_pool() -> None:
    contacts = np.array([True, False, True])
    ranges = np.array([0.6, 7.0, 1.1])
    beta = np.maximum(beta_r(ranges, beta_b=PARAMS.beta_b), PARAMS.reliability_floor)
    s = sensor_posterior(beta, PARAMS.prior, contacts)
    alpha = angular_weight(np.asarray(PARAMS.sensor_angles), PARAMS.w_r)
    expected = float(opinion_pool(s, alpha))
    assert NETWORK.fused(contacts, ranges) == pytest.approx(expected, abs=1e-12)


def test_network_has_the_node_kinds_of_fig_8(tmp_path: Path) -> None:
    net = NETWORK.net
    kinds = {name: net.kind(name) for name in net.variables}
    assert kinds["ProbabilityMap"] is NodeKind.DATA
    assert kinds["Motors"] is NodeKind.BUS and kinds["IR_0"] is NodeKind.BUS
    assert kinds["MovementModel"] is NodeKind.ABILITY and kinds["SensorModel_1"] is NodeKind.ABILITY
    assert {kinds[n] for n in ("SensorFusion", "CollisionAvoidance", "NavigationGoal")} == {
        NodeKind.CLASSIFICATION
    }
    path = bn.write(net, tmp_path / "rover.xmlbif")
    back = bn.read(path)
    assert set(back.variables) == set(net.variables)
    assert all(back.kind(n) is net.kind(n) for n in net.variables)
    assert back.parents("ProbabilityMap") == ("CollisionAvoidance", "SensorFusion")


def test_an_obstacle_read_straight_ahead_turns_the_rover_through_the_network() -> None:
    """Same map, same target ahead: only the readings differ, and the heading changes."""
    theta = np.asarray(PARAMS.headings)
    p_t = navigation_goal(theta, 0.0)
    p_o = np.full(theta.size, 0.2)
    clear_index, _ = NETWORK.decide(_inputs(p_t, p_o))
    assert clear_index == 0
    blocked_index, distribution = NETWORK.decide(
        _inputs(p_t, p_o, contacts=(False, True, False), ranges=(7.1, 0.4, 7.1))
    )
    assert blocked_index != 0 and distribution[0] < distribution[blocked_index]
    fused = NETWORK.fused([False, True, False], [7.1, 0.4, 7.1])
    assert fused > PARAMS.prior  # the sensor branch carries the contact


def test_unsafe_footprint_headings_are_not_chosen() -> None:
    theta = np.asarray(PARAMS.headings)
    p_t = navigation_goal(theta, 0.0)
    p_o = np.full(theta.size, 0.2)
    safe = ALL_SAFE.copy()
    safe[[0, 1, 11]] = False
    index, distribution = NETWORK.decide(_inputs(p_t, p_o, safe=safe))
    assert index in (2, 10) and distribution[[0, 1, 11]].max() < 1e-6


def test_inputs_of_the_wrong_size_are_an_input_error() -> None:
    with pytest.raises(InputError):
        NETWORK.decide(_inputs(np.ones(5), np.ones(12)))


@pytest.mark.parametrize("n", [3, 361, 720])
def test_heading_count_outside_4_to_360_is_a_config_error(n: int) -> None:
    with pytest.raises(ConfigError, match="n_headings"):
        RoverParams(n_headings=n)


def test_heading_states_are_distinct_up_to_360() -> None:
    for n in (4, 7, 36, 359, 360):
        assert len(set(heading_states(n))) == n
