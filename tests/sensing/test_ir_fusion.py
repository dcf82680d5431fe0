"""Tests of IR evidence fusion and the map update (Post et al. 2016 eqs. 35–36)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.mapping import IRMapper
from bayesmap.rover.params import RoverParams
from bayesmap.sensing.fusion import bayes_map_update, ir_cell_evidence, opinion_pool
from bayesmap.sim import ir
from bayesmap.sim.rover import SimulatedRoverParams

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


def test_contact_spread_stops_where_the_beam_was_free() -> None:
    """A contact at 1.0 m spreads over cells at least r - sigma_xy away, never in front."""
    sensors = np.array([[0.0, 0.0, 0.0]])
    xs = np.array([0.6, 0.8, 1.0, 1.2])  # 0.4 and 0.2 m in front of the face, at it, behind
    s, g = ir_cell_evidence(xs, np.zeros(4), sensors, [1.0], [True], **KW)
    free, _ = ir_cell_evidence(xs[:1], np.zeros(1), sensors, [7.0], [False], **KW)
    assert s[0] == pytest.approx(free[0]) and g[0] > 0.9  # the contact does not dilute it
    assert s[1] > 0.2 and s[2] > 0.2 and s[3] > 0.2  # within sigma_xy of the face or behind
    assert g[2] == pytest.approx(1.0)


def test_cell_in_front_of_a_face_becomes_certain_free() -> None:
    """Repeated noisy readings of a wall whose face lies 0.1 m into a cell: the cell in front
    of the face's cell ends certainly free and the face's cell certainly occupied."""
    params, rangers = RoverParams(), SimulatedRoverParams().rangers
    face = 5.1
    wall = np.array([[face, 2.0, face + 0.4, 8.0]])
    grid = OccupancyGrid(10, 10, 0.5, prior=params.prior)
    mapper = IRMapper(grid, params)
    rng = np.random.default_rng(3)
    for _ in range(400):
        x, y, psi = face - rng.uniform(0.6, 1.3), rng.uniform(3.5, 6.5), rng.uniform(-0.8, 0.8)
        raw = ir.observe(wall, np.array([x, y, psi]), rangers, rng=rng)
        gps = rng.normal(0.0, params.position_sigma, 2)
        mapper.update(raw, (x + gps[0], y + gps[1], psi))
    rows = slice(8, 12)  # y in 4..6 m, well inside the wall's length
    assert np.all(grid.probability[rows, 9] < 0.053)  # x in 4.5..5.0: free, certain
    assert np.all(grid.entropy[rows, 9] < params.h_desired)
    assert np.all(grid.probability[rows, 10] > 0.947)  # the face's cell: occupied, certain
