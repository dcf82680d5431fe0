"""BlackboardParams: defaults are valid, every bad value is a ConfigError."""

from __future__ import annotations

import dataclasses
import math

import pytest

from bayesmap.blackboard import BlackboardParams
from bayesmap.errors import ConfigError


def test_defaults_satisfy_the_papers_orderings() -> None:
    p = BlackboardParams()
    assert p.c_S < p.c_L < p.c_T  # eq. 10
    assert 0 < p.r1 < p.r2 < p.r3 < 1  # Algorithm 1
    assert p.memory_size == 7  # §II-C
    a, b = p.corner_offset
    assert a == pytest.approx((p.table_length - p.leg_width) / 2)
    assert b == pytest.approx((p.table_width - p.leg_width) / 2)
    assert p.log_box == pytest.approx(3 * math.log(2 * p.delta))
    assert p.parent_radius > math.hypot(a, b)


@pytest.mark.parametrize(
    "change",
    [
        {"table_length": 0.0},
        {"leg_width": -0.1},
        {"sigma_r_shapelet": 0.0},
        {"delta": float("nan")},
        {"alpha_S": float("inf")},
        {"epsilon": 1.0},
        {"epsilon_a": 0.0},
        {"r1": 0.5, "r2": 0.4},
        {"r3": 1.0},
        {"beta_min": 5.0, "beta_max": 1.0},
        {"c_L": 0.5},  # breaks c_L < c_T (eq. 10)
        {"c_S": 0.005},  # breaks c_S < c_L
        {"n_temperatures": 0},
        {"memory_size": 2.5},
        {"max_hypotheses": True},
        {"table_width": 1.5},  # wider than long
        {"leg_width": 0.4},  # two legs no longer fit
        {"table_jitter_xy": -1.0},
        {"parent_fit_weight": -1.0},
    ],
)
def test_bad_params_raise_config_error(change: dict[str, float]) -> None:
    with pytest.raises(ConfigError):
        dataclasses.replace(BlackboardParams(), **change)


def test_params_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        BlackboardParams().delta = 0.1  # type: ignore[misc]
