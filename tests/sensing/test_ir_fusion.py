"""Tests of IR evidence fusion and the map update (Post et al. 2016 eqs. 35–36)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bayesmap.sensing.fusion import bayes_map_update, ir_cell_evidence, opinion_pool

KW = dict(prior=0.2, r_max=2.0, beta_b=0.2, w_r=0.3, sigma_xy=0.25)


def test_opinion_pool_is_weighted_mean() -> None:
    s = np.array([[0.1, 0.9], [0.5, 0.5], [0.3, 0.1]])
    w = np.array([[1.0, 0.0], [1.0, 1.0], [2.0, 1.0]])
    expected = (w * s).sum(axis=0) / w.sum(axis=0)
    np.testing.assert_allclose(opinion_pool(s, w), expected)


@given(st.floats(0.05, 0.95), st.floats(0.1, 0.3), st.floats(0.1, 0.3))
def test_map_update_is_odds_product(p: float, s1: float, s2: float) -> None:
    prior = 0.2
    one = bayes_map_update(bayes_map_update(p, s1, prior), s2, prior)
    other = bayes_map_update(bayes_map_update(p, s2, prior), s1, prior)
    assert float(one) == pytest.approx(float(other), abs=1e-9)  # order does not matter
    assert float(bayes_map_update(p, prior, prior)) == pytest.approx(p)  # prior = no information
    # Bayes' rule with the likelihoods the evidence stands for: P(R | O) ∝ s / P(O) and
    # P(R | not O) ∝ (1 - s) / (1 - P(O)), the inverse model's constant prior divided out
    yes, no = p * s1 / prior, (1 - p) * (1 - s1) / (1 - prior)
    assert float(bayes_map_update(p, s1, prior)) == pytest.approx(yes / (yes + no), rel=1e-12)


def test_map_update_by_hand() -> None:
    assert float(bayes_map_update(0.5, 0.8, 0.5)) == pytest.approx(0.8)
    # prior 0.2: evidence 0.5 is odds 1 against the prior's 1/4, four times the map's odds
    assert float(bayes_map_update(0.2, 0.5, 0.2)) == pytest.approx(0.5)
    assert float(bayes_map_update(0.6, 0.1, 0.2)) == pytest.approx(0.4)  # 1.5 · 1/9 · 4 = 2/3


def test_free_beam_lowers_and_contact_raises_evidence() -> None:
    xs = np.array([0.5, 1.0, 1.0, 1.0, 3.0])
    ys = np.array([0.0, 0.0, 1.8, -1.8, 0.0])
    sensors = np.array([[0.0, 0.0, 0.0]])
    # no contact: cells on the beam within r_max are evidence of free space
    s, g = ir_cell_evidence(xs, ys, sensors, [7.0], [False], **KW)
    assert s[0] < 0.2 and s[1] < 0.2 and g[0] > 0.9
    assert g[2] < 1e-3 and g[3] < 1e-3  # 60 degrees off the axis: untouched
    assert g[4] == 0.0  # beyond r_max
    # contact at 0.8 m: the cell there is evidence of an obstacle, the one behind untouched
    s, g = ir_cell_evidence(np.array([0.8, 0.3, 1.6]), np.zeros(3), sensors, [0.8], [True], **KW)
    assert s[0] > 0.2 and g[0] == pytest.approx(1.0)
    assert s[1] < 0.2
    assert g[2] < 1e-2


def test_reliability_floor_removes_reversed_evidence() -> None:
    sensors = np.array([[0.0, 0.0, 0.0]])
    literal, _ = ir_cell_evidence(
        np.array([1.8]), np.zeros(1), sensors, [1.8], [True], reliability_floor=0.0, **KW
    )
    floored, _ = ir_cell_evidence(np.array([1.8]), np.zeros(1), sensors, [1.8], [True], **KW)
    assert literal[0] < 0.2  # beta_r < 1/2: the literal paper reads a contact as free space
    assert floored[0] == pytest.approx(0.2)


@pytest.mark.parametrize("gap", [0.26, 0.3, 0.4, 0.5])
def test_a_contact_puts_no_obstacle_evidence_in_front_of_its_free_part(gap: float) -> None:
    """A cell more than sigma_xy in front of the read range gets the free opinion alone,
    exactly what a beam that read nothing would give it; within sigma_xy it is evidence of
    an obstacle."""
    sensors = np.array([[0.0, 0.0, 0.0]])
    r = 0.9
    front = np.array([r - gap])
    read, weight = ir_cell_evidence(front, np.zeros(1), sensors, [r], [True], **KW)
    empty, _ = ir_cell_evidence(front, np.zeros(1), sensors, [7.0], [False], **KW)
    assert read[0] == pytest.approx(empty[0]) and read[0] < 0.2 and weight[0] == 1.0
    face, _ = ir_cell_evidence(np.array([r - 0.2]), np.zeros(1), sensors, [r], [True], **KW)
    assert face[0] > 0.2
