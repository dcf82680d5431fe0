"""The kernel and annealing: statistics on known answers, determinism, snapshots."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayesmap.blackboard import (
    Blackboard,
    BlackboardParams,
    SamplerState,
    Snapshot,
    TableMapper,
    accept,
    make_leg,
    schedule,
    step,
)
from bayesmap.blackboard.blanket import Move, MoveKind, apply, log_ratio

from .synth import leg_contact, three_leg_shapelets


def test_acceptance_samples_the_two_state_posterior_at_beta_one() -> None:
    """Birth/death of one leg with Barker acceptance visits 'present' with probability
    π(present) / (π(present) + π(absent)) = σ(log ratio) — eq. 14's answer at β = 1."""
    p = BlackboardParams()
    board = Blackboard(p)
    board.set_shapelets(np.array([[0.025, 0.0, 0.0, 0.5]]))
    # a leg that explains the shapelet, with a misfit chosen so the answer is not 0 or 1
    leg = make_leg(0.0, 0.01, 0.02, p.leg_width, p.leg_width, 0.5)
    value = log_ratio(board, Move(MoveKind.BIRTH, 0, leg=leg))
    expected = 1.0 / (1.0 + math.exp(-value))
    assert 0.05 < expected < 0.95
    rng = np.random.default_rng(5)
    present, n = 0, 20000
    for _ in range(n):
        move = (
            Move(MoveKind.DEATH, next(iter(board.legs_)))
            if board.legs_
            else Move(MoveKind.BIRTH, 0, leg=leg)
        )
        if accept(rng, log_ratio(board, move), 1.0):
            apply(board, move)
        present += bool(board.legs_)
    # successive states are correlated (lag-1 ~ 1 − 2·p·q); 5 σ of the widened binomial
    sd = math.sqrt(expected * (1 - expected) / n) * 2.0
    assert present / n == pytest.approx(expected, abs=5 * sd)


def test_schedule_is_geometric() -> None:
    p = BlackboardParams(beta_min=0.1, beta_max=10.0, n_temperatures=3)
    assert np.allclose(schedule(p), [0.1, 1.0, 10.0])


def test_step_is_deterministic_and_tracks_the_joint() -> None:
    from bayesmap.blackboard import log_joint

    p = BlackboardParams()
    shapelets = three_leg_shapelets(p, (0.5, 0.5, 1.0))
    results = []
    for _ in range(2):
        board = Blackboard(p)
        board.set_shapelets(shapelets)
        state = SamplerState(board, 0.3, log_joint(board))
        rng = np.random.default_rng(42)
        for _ in range(15):
            state, info = step(rng, state, p)
        assert state.log_joint == pytest.approx(log_joint(board), abs=1e-6)
        assert sum(info.accepted.values()) <= sum(info.proposed.values())
        results.append((board.table_array().tolist(), board.leg_array().tolist()))
    assert results[0] == results[1]


def _close(table: np.ndarray, pose: tuple[float, float, float], tol: float = 0.05) -> bool:
    angle = abs((table[2] - pose[2] + math.pi / 2) % math.pi - math.pi / 2)
    return math.hypot(table[0] - pose[0], table[1] - pose[1]) < tol and angle < 0.1


def test_three_legs_give_one_table_at_the_right_pose() -> None:
    p = BlackboardParams()
    truth = (1.0, 2.0, 0.3)
    shapelets = three_leg_shapelets(p, truth)
    found = 0
    for seed in range(8):
        tables = TableMapper(p).step(shapelets, rng=seed).tables
        found += len(tables) == 1 and _close(tables[0], truth)
    assert found >= 6  # the sampler is stochastic; ~9 in 10 runs find the table


def test_two_legs_give_the_fig3_ambiguity() -> None:
    """Two contacts on the two legs of one long side fit the true table and its mirror image
    across that side equally (Fig. 3); the MAP is one of them, and seeds find both."""
    p = BlackboardParams()
    truth = (1.0, 2.0, 0.3)
    shapelets = np.array([leg_contact(truth, 0, 1, 0.0, p), leg_contact(truth, 1, 1, 0.1, p)])
    offset = p.table_width - p.leg_width
    mirror = (1.0 - math.sin(0.3) * offset, 2.0 + math.cos(0.3) * offset, 0.3)
    seen = {"truth": 0, "mirror": 0}
    for seed in range(10):
        tables = TableMapper(p).step(shapelets, rng=seed).tables
        assert len(tables) <= 1
        if len(tables):
            which = "truth" if _close(tables[0], truth) else "mirror"
            assert _close(tables[0], truth if which == "truth" else mirror)
            seen[which] += 1
    assert seen["truth"] >= 2 and seen["mirror"] >= 2


def test_a_single_contact_does_not_pay_for_a_table() -> None:
    p = BlackboardParams()
    shapelet = np.array([leg_contact((0.0, 0.0, 0.0), 0, 0, 0.0, p)])
    assert all(len(TableMapper(p).step(shapelet, rng=s).tables) == 0 for s in range(3))


def test_callback_gets_one_snapshot_per_temperature() -> None:
    p = BlackboardParams(n_temperatures=12)
    snaps: list[Snapshot] = []
    TableMapper(p).step(three_leg_shapelets(p, (0.0, 0.0, 0.0)), rng=1, callback=snaps.append)
    assert [s.index for s in snaps] == list(range(12))
    assert np.allclose([s.beta for s in snaps], schedule(p))
    for s in snaps:
        assert s.tables.shape[1] == 5 and s.legs.shape[1] == 6 and s.shapelets.shape == (3, 4)
        assert s.leg_parent.shape == (len(s.legs),) and s.shapelet_parent.shape == (3,)
        assert np.all(s.leg_parent < len(s.tables)) and np.all(s.shapelet_parent < len(s.legs))
