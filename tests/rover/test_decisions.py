"""Tests of the decision maths (Post et al. 2016 eqs. 38–43) against brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bayesmap.rover.decisions import (
    collision_probability,
    exploration_target,
    heading_decision,
    movement_distribution,
    navigation_goal,
)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.3), st.floats(0.0, 2.0))
def test_exploration_target_brute_force(seed: int, margin: float, d_min: float) -> None:
    rng = np.random.default_rng(seed)
    xc, yc = rng.uniform(-10, 10, 40), rng.uniform(-10, 10, 40)
    h = np.round(rng.uniform(0.5, 1.0, 40), 2)
    d = np.hypot(xc, yc)
    pick = exploration_target(h, d, d_max=8.0, d_min=d_min, margin=margin)
    ok = [i for i in range(40) if d_min <= d[i] < 8.0]
    if not ok:
        assert pick == -1
        return
    best = max(h[i] for i in ok)
    near = [i for i in ok if h[i] >= best - margin]
    assert pick in near and d[pick] == min(d[i] for i in near)


def test_navigation_goal_peaks_at_target_and_wraps() -> None:
    theta = np.linspace(0, 2 * np.pi, 36, endpoint=False)
    p = navigation_goal(theta, math.radians(350))
    assert np.argmax(p) == 35 and p[0] == pytest.approx(p[34])
    assert p.max() == pytest.approx(1 / ((np.pi / 2) * math.sqrt(2 * np.pi)), rel=1e-3)
    assert float(navigation_goal(np.pi / 2, 0.0)) == pytest.approx(p.max() * math.exp(-1), rel=1e-3)


def _brute_collision(p, xc, yc, theta, d_max, clearance, weighted):  # type: ignore[no-untyped-def]
    out = []
    for t in theta:
        num = den = 0.0
        for pi, x, y in zip(p, xc, yc, strict=True):
            d = math.hypot(x, y)
            along = x * math.cos(t) + y * math.sin(t)
            lateral = -x * math.sin(t) + y * math.cos(t)
            if d <= d_max and along > 0 and abs(lateral) <= clearance:
                w = (d_max - d) if weighted else 1.0
                num += w * pi
                den += w
        out.append(num / den if den else 0.0)
    return np.array(out)


@pytest.mark.parametrize("weighted", [True, False])
def test_collision_probability_brute_force(weighted: bool) -> None:
    rng = np.random.default_rng(1)
    xc, yc = rng.uniform(-9, 9, 300), rng.uniform(-9, 9, 300)
    p = rng.uniform(size=300)
    theta = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    got = collision_probability(
        p, xc, yc, (0.0, 0.0), theta, d_max=8.0, clearance=0.5, distance_weighted=weighted
    )
    np.testing.assert_allclose(got, _brute_collision(p, xc, yc, theta, 8.0, 0.5, weighted))


def test_closer_obstacles_count_more() -> None:
    xc = np.arange(0.25, 8.0, 0.5)
    yc = np.zeros_like(xc)
    near, far = np.full(xc.size, 0.02), np.full(xc.size, 0.02)
    near[1], far[12] = 0.9, 0.9
    theta = np.array([0.0])
    p_near = collision_probability(near, xc, yc, (0.0, 0.0), theta, d_max=8.0, clearance=0.3)
    p_far = collision_probability(far, xc, yc, (0.0, 0.0), theta, d_max=8.0, clearance=0.3)
    assert p_near[0] > p_far[0]
    flat_near = collision_probability(
        near, xc, yc, (0.0, 0.0), theta, d_max=8.0, clearance=0.3, distance_weighted=False
    )
    flat_far = collision_probability(
        far, xc, yc, (0.0, 0.0), theta, d_max=8.0, clearance=0.3, distance_weighted=False
    )
    assert flat_near[0] == pytest.approx(flat_far[0])  # eq. 41 ignores distance


def test_movement_distribution_is_eq_43() -> None:
    p_t = np.array([0.25, 0.1, 0.0, 0.1])
    p_o = np.array([0.9, 0.1, 0.2, 0.2])
    m = movement_distribution(p_t, p_o)
    np.testing.assert_allclose(m, (p_t + 1 - p_o) / (p_t + 1 - p_o).sum())
    assert heading_decision(p_t, p_o) == 1  # the target heading is blocked by an obstacle
