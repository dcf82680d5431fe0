"""Markov-blanket log ratios (eqs. 20–21) equal differences of the full joint (eq. 14)."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.blackboard import Blackboard, BlackboardParams, log_joint
from bayesmap.blackboard import proposals as q
from bayesmap.blackboard.blanket import Move, MoveKind, apply, log_ratio

from .synth import three_leg_shapelets


@pytest.mark.parametrize("seed", [0, 1])
def test_every_move_ratio_is_the_joint_difference(seed: int) -> None:
    p = BlackboardParams()
    board = Blackboard(p)
    board.set_shapelets(three_leg_shapelets(p, (1.0, 2.0, 0.3)))
    rng = np.random.default_rng(seed)
    kinds: set[MoveKind] = set()
    for _ in range(250):
        keys = [*board.tables_, *board.legs_]
        if rng.random() < 0.3 or not keys:
            move: Move | None = q.propose_leg_for_shapelet(rng, board, p, int(rng.integers(3)))
        else:
            key = keys[int(rng.integers(len(keys)))]
            if key in board.tables_:
                move = (q.propose_death if rng.random() < 0.2 else q.propose_child)(
                    rng, board, p, key
                )
            else:
                pick = (
                    q.propose_death,
                    q.propose_parent_change,
                    q.propose_parent,
                    q.propose_parent,
                )
                move = pick[int(rng.integers(4))](rng, board, p, key)
        if move is None:
            continue
        before = log_joint(board)
        ratio = log_ratio(board, move)
        apply(board, move)
        assert log_joint(board) - before == pytest.approx(ratio, abs=1e-8)
        kinds.add(move.kind)
    assert kinds == set(MoveKind)
    assert len(board.tables_) > 2 and len(board.legs_) > 5  # a busy board was exercised


def test_table_death_drops_only_its_unsupported_legs() -> None:
    p = BlackboardParams()
    board = Blackboard(p)
    board.set_shapelets(three_leg_shapelets(p, (0.0, 0.0, 0.0)))
    rng = np.random.default_rng(0)
    leg = board.legs_  # alias
    apply(board, q.propose_leg_for_shapelet(rng, board, p, 0))
    observed = next(iter(leg))
    parent = q.propose_parent(rng, board, p, observed)
    apply(board, parent)
    table = board.parent_[observed]
    for _ in range(3):
        apply(board, q.propose_child(rng, board, p, table))
    assert board.missing(table) == 0 and len(board.legs_) == 4
    supported = [k for k in board.legs_ if board.supports(k)]
    assert observed in supported and len(supported) < 4
    apply(board, Move(MoveKind.DEATH, table))
    assert list(board.legs_) == supported
    assert all(board.parent_[k] == -1 for k in supported)
    assert not board.tables_
