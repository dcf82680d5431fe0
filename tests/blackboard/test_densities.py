"""The factor functions against hand computations and brute force (Fox & Prescott 2011)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from bayesmap.blackboard import BlackboardParams, make_leg, make_table
from bayesmap.blackboard import densities as d
from bayesmap.geometry import wrap_angle

P = BlackboardParams()
A, B = P.corner_offset
SIG = (P.sigma_r_leg, P.sigma_theta_leg, P.sigma_w, P.sigma_tau_leg)
SIG_S = (P.sigma_r_shapelet, P.sigma_theta_shapelet, P.sigma_tau_shapelet)


def test_table_corners_by_hand() -> None:
    corners = d.table_corners(np.array([1.0, 2.0, 0.0]), A, B)
    assert np.allclose(corners, [[1 + A, 2 + B], [1 - A, 2 + B], [1 - A, 2 - B], [1 + A, 2 - B]])
    turned = d.table_corners(np.array([0.0, 0.0, math.pi / 2]), A, B)
    assert np.allclose(turned[0], [-B, A])


@pytest.mark.parametrize("theta", [0.0, 0.4, 1.3, 2.9])
def test_table_is_symmetric_under_half_turn(theta: float) -> None:
    c1 = d.table_corners(np.array([0.3, -0.2, theta]), A, B)
    c2 = d.table_corners(np.array([0.3, -0.2, theta + math.pi]), A, B)
    assert np.allclose(c1, c2[[2, 3, 0, 1]])  # same four corners, relabelled
    table = np.array([0.3, -0.2, theta, P.leg_width, 0.5])
    flipped = table.copy()
    flipped[2] += math.pi
    legs = np.array([[0.1, 0.2, theta + 0.05, 0.05, 0.05, 0.4], [0.9, -0.5, 0.3, 0.05, 0.06, 0.5]])
    assert np.allclose(
        d.delta_table_leg(table, legs, A, B, *SIG)[0],
        d.delta_table_leg(flipped, legs, A, B, *SIG)[0],
    )


def test_delta_table_leg_by_hand() -> None:
    table = np.array([0.0, 0.0, 0.2, P.leg_width, 0.5])
    corners = d.table_corners(table, A, B)
    for i in range(4):
        leg = np.array([*corners[i], 0.2, P.leg_width, P.leg_width, 0.5])
        delta, corner = d.delta_table_leg(table, leg, A, B, *SIG)
        assert delta == pytest.approx(0.0, abs=1e-12) and corner == i
    # displaced 1 cm, rotated 0.05 rad, 1 cm wider in x, texture 0.1 off
    leg = np.array(
        [corners[2][0] + 0.01, corners[2][1], 0.25, P.leg_width + 0.01, P.leg_width, 0.6]
    )
    delta, corner = d.delta_table_leg(table, leg, A, B, *SIG)
    expected = (
        (0.01 / SIG[0]) ** 2 + (0.05 / SIG[1]) ** 2 + (0.01 / SIG[2]) ** 2 + (0.1 / SIG[3]) ** 2
    )
    assert delta == pytest.approx(expected) and corner == 2
    # a square leg turned by a quarter turn is the same leg
    quarter = leg.copy()
    quarter[2] += math.pi / 2
    assert d.delta_table_leg(table, quarter, A, B, *SIG)[0] == pytest.approx(expected)


def test_delta_leg_shapelet_by_hand() -> None:
    w = 0.1
    leg = np.array([0.0, 0.0, 0.0, w, w, 0.5])
    on_face = np.array([0.05, 0.01, 0.0, 0.5])  # on the +x face, normal +x
    assert d.delta_leg_shapelet(leg, on_face, *SIG_S) == pytest.approx(0.0, abs=1e-12)
    out = np.array([0.07, 0.0, 0.0, 0.6])  # 2 cm out, texture 0.1 off
    expected = (0.02 / SIG_S[0]) ** 2 + (0.1 / SIG_S[2]) ** 2
    assert d.delta_leg_shapelet(leg, out, *SIG_S) == pytest.approx(expected)
    # beyond a corner: distance to the corner point, best face by angle
    corner = np.array([0.08, 0.09, math.pi / 2, 0.5])
    r2 = (0.03**2 + 0.04**2) / SIG_S[0] ** 2
    assert d.delta_leg_shapelet(leg, corner, *SIG_S) == pytest.approx(r2)
    # wrong normal on the +x face: the +y face (5 cm away, right normal) may win
    wrong = np.array([0.05, 0.0, math.pi / 2, 0.5])
    candidates = [(math.pi / 2 / SIG_S[1]) ** 2, (0.05 / SIG_S[0]) ** 2]
    assert d.delta_leg_shapelet(leg, wrong, *SIG_S) == pytest.approx(min(candidates))


def _brute_force_delta_ls(leg: np.ndarray, s: np.ndarray) -> float:
    """min over dense perimeter points of (r/σ_r)² + (angle to that face's normal/σ_θ)²."""
    x, y, theta, wx, wy, tau = leg
    best = math.inf
    t = np.linspace(-0.5, 0.5, 4001)
    for k, (u, v) in enumerate(
        [
            (0.5 * wx + 0 * t, t * wy),
            (t * wx, 0.5 * wy + 0 * t),
            (-0.5 * wx + 0 * t, t * wy),
            (t * wx, -0.5 * wy + 0 * t),
        ]
    ):
        px = x + math.cos(theta) * u - math.sin(theta) * v
        py = y + math.sin(theta) * u + math.cos(theta) * v
        r2 = (px - s[0]) ** 2 + (py - s[1]) ** 2
        ang = float(wrap_angle(s[2] - theta - k * math.pi / 2))
        best = min(best, float(np.min(r2)) / SIG_S[0] ** 2 + (ang / SIG_S[1]) ** 2)
    return best + ((tau - s[3]) / SIG_S[2]) ** 2


def test_delta_leg_shapelet_matches_brute_force() -> None:
    rng = np.random.default_rng(7)
    for _ in range(25):
        leg = np.array(
            [*rng.uniform(-1, 1, 2), rng.uniform(0, 3), *rng.uniform(0.04, 0.12, 2), rng.uniform()]
        )
        s = np.array([*(leg[:2] + rng.normal(0, 0.08, 2)), rng.uniform(-4, 4), rng.uniform()])
        assert d.delta_leg_shapelet(leg, s, *SIG_S) == pytest.approx(
            _brute_force_delta_ls(leg, s), rel=1e-4, abs=1e-4
        )


def test_scalar_versions_agree_with_vectorised() -> None:
    rng = np.random.default_rng(3)
    for _ in range(50):
        t = make_table(*rng.uniform(-1, 1, 2), rng.uniform(-4, 4), P.leg_width, rng.uniform(), P)
        leg = make_leg(
            *(np.array(t.corners[1]) + rng.normal(0, 0.05, 2)),
            rng.uniform(-4, 4),
            *rng.uniform(0.04, 0.06, 2),
            rng.uniform(),
        )
        s = (*(np.array(leg[:2]) + rng.normal(0, 0.05, 2)), rng.uniform(-4, 4), rng.uniform())
        vec, corner = d.delta_table_leg(np.array(t[:5]), np.array(leg), A, B, *SIG)
        sca, corner_s = d.delta_table_leg_scalar(t.theta, t.w, t.tau, t.corners, leg, *SIG)
        assert sca == pytest.approx(float(vec)) and corner_s == int(corner)
        assert d.delta_leg_shapelet_scalar(leg, s, *SIG_S) == pytest.approx(
            float(d.delta_leg_shapelet(np.array(leg), np.array(s), *SIG_S))
        )
        lr = rng.normal(0, 5)
        beta = rng.uniform(0.01, 10)
        assert d.acceptance_probability_scalar(lr, beta) == pytest.approx(
            float(d.acceptance_probability(lr, beta))
        )


def test_noisy_or_is_a_sum_of_densities() -> None:
    """Eq. 12 (appendix eqs. 21–24): densities of parents add, plus the null prior."""
    deltas = np.array([[0.0, 1.0], [2.0, np.inf]])
    out = d.density_shapelet(deltas, alpha_S=10.0, c_S=0.5, axis=0)
    assert np.allclose(out, [0.5 + 10 + 10 * math.exp(-2), 0.5 + 10 * math.exp(-1)])
    # the appendix's limit: 1 − Π(1 − δ³p_i) → δ³ Σ p_i as δ → 0
    p_i = np.array([3.0, 5.0, 7.0])
    for delta in (1e-2, 1e-3):
        noisy_or = 1 - np.prod(1 - delta**3 * p_i)
        assert noisy_or / delta**3 == pytest.approx(p_i.sum(), rel=1e-4)
    assert d.density_leg_given_table(np.inf, 5.0, 0.25) == pytest.approx(0.25)
    assert d.density_leg_given_table(0.0, 5.0, 0.25) == pytest.approx(5.25)


def test_constraint_factors() -> None:
    eps = 0.1
    assert np.allclose(d.phi_a(np.array([0, 1, 4]), eps), [1, 0.1, 1e-4])  # eq. 15
    assert np.allclose(d.phi_b(np.array([True, False]), eps), [0.1, 1.0])  # eq. 17
    assert np.allclose(d.phi_c(np.array([True, False]), eps), [0.1, 1.0])  # eq. 16
    assert d.box_probability(3.0, 0.5) == pytest.approx(3.0)  # eq. 19: (2δ)³ p


def _polygon(r: np.ndarray) -> Polygon:
    x, y, th, hl, hw = r
    c, s = math.cos(th), math.sin(th)
    return Polygon(
        [
            (x + c * u - s * v, y + s * u + c * v)
            for u, v in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))
        ]
    )


def test_rectangle_overlap_matches_shapely() -> None:
    rng = np.random.default_rng(11)
    first = np.column_stack(
        [rng.uniform(-1, 1, (400, 2)), rng.uniform(0, 4, 400), rng.uniform(0.05, 0.6, (400, 2))]
    )
    second = np.column_stack(
        [rng.uniform(-1, 1, (400, 2)), rng.uniform(0, 4, 400), rng.uniform(0.05, 0.6, (400, 2))]
    )
    got = d.rectangles_overlap(first, second)
    want = np.array(
        [
            _polygon(p).intersection(_polygon(q)).area > 1e-12
            for p, q in zip(first, second, strict=True)
        ]
    )
    assert np.array_equal(got, want)
    assert 50 < want.sum() < 350  # both outcomes exercised
    for p, q, w in zip(first[:50], second[:50], want[:50], strict=True):
        assert d.rectangles_overlap_scalar(tuple(p), tuple(q)) == w
    touching = np.array([[0, 0, 0, 0.5, 0.5], [1.0, 0, 0, 0.5, 0.5]])
    assert not d.rectangles_overlap(touching[0], touching[1])


def test_acceptance_is_annealed_gibbs() -> None:
    """Eqs. 20–21: P(candidate) = π_c^β / (π_c^β + π_0^β)."""
    for lr, beta in [(0.0, 1.0), (2.0, 1.0), (-3.0, 0.5), (1.0, 40.0), (-1.0, 40.0), (800, 1.0)]:
        expected = 1.0 / (1.0 + math.exp(-beta * lr)) if beta * lr > -700 else 0.0
        assert float(d.acceptance_probability(lr, beta)) == pytest.approx(expected)
        assert d.acceptance_probability_scalar(-800.0, 1.0) == pytest.approx(0.0)
    assert float(d.acceptance_probability(1.0, 40.0)) > 1 - 1e-15
