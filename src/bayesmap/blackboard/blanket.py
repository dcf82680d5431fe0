"""Moves on the blackboard and their Markov-blanket log ratios (Fox & Prescott 2011 eqs. 14, 20–21).

A :class:`Move` is a candidate change of the blackboard B. :func:`log_ratio` returns
log P(B') − log P(B) for the factor graph of eq. 14, computed from the factors that touch
the hypotheses the move changes — their Markov blanket — and nothing else:

- a table's prior (2δ)³ c_T (eqs. 4, 19) and its missing-leg factor φ_a = ε^m (eq. 15);
- a leg's (2δ)³ (α_L e^{−Δ_TL} + c_L) given its explicit parent, or (2δ)³ c_L without one
  (eqs. 5, 6, 8, 12, 19);
- every shapelet's noisy-OR density c_S + Σ_L α_S e^{−Δ_LS} (eqs. 7, 9, 12);
- φ_b = ε for two legs at one corner of one table (eq. 17) and φ_c = ε for two overlapping
  tables or legs (eq. 16).

An absent hypothesis contributes P(¬H | pa) = 1 − (2δ)³ p ≈ 1 (the denominator of eq. 21).
:func:`apply` performs an accepted move; :func:`bayesmap.blackboard.scoring.log_joint`
recomputes eq. 14 from scratch so tests can check the two agree.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import NamedTuple

from bayesmap.blackboard.hypotheses import NULL, Blackboard, Leg, Table


class MoveKind(Enum):
    """The five proposals of Algorithm 1."""

    BIRTH = "birth"
    """A shapelet's new parent leg (``propose and test parent H_i from Q(pa(S_i))``)."""
    DEATH = "death"
    """Removal of a hypothesis."""
    PARENT_CHANGE = "parent_change"
    """A leg's explicit parent replaced by a nearby table or by the null cause."""
    CHILD = "child"
    """A new leg at a corner of a table (``Q(ch(H_i) | H_i)``)."""
    PARENT = "parent"
    """A new table as a leg's parent (``Q(pa(H_i) | H_i)``)."""


class Move(NamedTuple):
    """A candidate change of the blackboard.

    Attributes
    ----------
    kind
        Which proposal made it.
    target
        The hypothesis it changes (a shapelet index for BIRTH, else a table or leg id).
    leg
        The new leg (BIRTH, CHILD), else ``None``.
    table
        The new table (PARENT), else ``None``.
    parent
        The new parent id (PARENT_CHANGE; CHILD: the table), else :data:`NULL`.
    """

    kind: MoveKind
    target: int
    leg: Leg | None = None
    table: Table | None = None
    parent: int = NULL


def _shapelet_gain(board: Blackboard, contrib: list[float], sign: float) -> float:
    """Change of Σ_k log(noisy-OR density of shapelet k) when a leg's densities are added
    (``sign = 1``) or removed (``sign = -1``) (eq. 12)."""
    total = 0.0
    for s, v in zip(board.shapelet_density_, contrib, strict=True):
        if v > 1e-12 * s:
            total += math.log1p(sign * v / s)
    return total


def _leaving(board: Blackboard, leg: int, log_eps: float, log_eps_a: float) -> float:
    """φ_a, φ_b change when ``leg`` leaves its parent's corner (eqs. 15, 17)."""
    parent = board.parent_[leg]
    if parent == NULL:
        return 0.0
    n = len(board.children_[parent][board.corner_[leg]])
    return log_eps_a if n == 1 else -(n - 1) * log_eps


def _joining(board: Blackboard, table: int, corner: int, log_eps: float, log_eps_a: float) -> float:
    """φ_a, φ_b change when a leg joins ``corner`` of ``table`` (eqs. 15, 17)."""
    n = len(board.children_[table][corner])
    return -log_eps_a if n == 0 else n * log_eps


def _log_ratio_birth(board: Blackboard, move: Move, log_eps: float, log_eps_a: float) -> float:
    leg = move.leg
    assert leg is not None
    return (
        board.leg_term(leg, NULL)[0]
        + _shapelet_gain(board, board.leg_contributions(leg), 1.0)
        + board.overlapping_legs(leg) * log_eps
    )


def _log_ratio_child(board: Blackboard, move: Move, log_eps: float, log_eps_a: float) -> float:
    leg = move.leg
    assert leg is not None
    term, corner = board.leg_term(leg, move.parent)
    return (
        term
        + _shapelet_gain(board, board.leg_contributions(leg), 1.0)
        + board.overlapping_legs(leg) * log_eps
        + _joining(board, move.parent, corner, log_eps, log_eps_a)
    )


def _log_ratio_parent(board: Blackboard, move: Move, log_eps: float, log_eps_a: float) -> float:
    table = move.table
    assert table is not None
    p = board.params
    leg_id = move.target
    leg = board.legs_[leg_id]
    term, _ = board.leg_term_given(leg, table)
    return (
        p.log_box
        + math.log(p.c_T)
        + 3 * log_eps_a  # the new table has one leg: three corners missing (eq. 15)
        + board.overlapping_tables(table) * log_eps
        + term
        - board.leg_log_term_[leg_id]
        + _leaving(board, leg_id, log_eps, log_eps_a)
    )


def _log_ratio_parent_change(
    board: Blackboard, move: Move, log_eps: float, log_eps_a: float
) -> float:
    leg_id = move.target
    term, corner = board.leg_term(board.legs_[leg_id], move.parent)
    value = term - board.leg_log_term_[leg_id] + _leaving(board, leg_id, log_eps, log_eps_a)
    if move.parent != NULL:
        value += _joining(board, move.parent, corner, log_eps, log_eps_a)
    return value


def _log_ratio_death(board: Blackboard, move: Move, log_eps: float, log_eps_a: float) -> float:
    key = move.target
    p = board.params
    if key in board.legs_:
        leg = board.legs_[key]
        return (
            -board.leg_log_term_[key]
            + _shapelet_gain(board, board.contrib_[key], -1.0)
            - board.overlapping_legs(leg, exclude=key) * log_eps
            + _leaving(board, key, log_eps, log_eps_a)
        )
    table = board.tables_[key]
    value = -(p.log_box + math.log(p.c_T))
    value -= board.missing(key) * log_eps_a + board.shared_corner_pairs(key) * log_eps
    value -= board.overlapping_tables(table, exclude=key) * log_eps
    null_term = p.log_box + math.log(p.c_L)
    dropped = board.unsupported_children(key)
    for legs in board.children_[key]:
        for leg_id in legs:
            value -= board.leg_log_term_[leg_id]
            if leg_id not in dropped:
                value += null_term
    if dropped:
        removed = [0.0] * len(board.shapelet_density_)
        overlaps = 0
        for i, leg_id in enumerate(dropped):
            for k, v in enumerate(board.contrib_[leg_id]):
                removed[k] += v
            leg = board.legs_[leg_id]
            overlaps += board.overlapping_legs(leg, exclude=leg_id)
            overlaps -= sum(board.legs_overlap(leg_id, other) for other in dropped[:i])
        value -= overlaps * log_eps
        value += _shapelet_gain(board, removed, -1.0)
    return value


_LOG_RATIO = {
    MoveKind.BIRTH: _log_ratio_birth,
    MoveKind.CHILD: _log_ratio_child,
    MoveKind.PARENT: _log_ratio_parent,
    MoveKind.PARENT_CHANGE: _log_ratio_parent_change,
    MoveKind.DEATH: _log_ratio_death,
}


def log_ratio(board: Blackboard, move: Move) -> float:
    """log P(B after ``move``) − log P(B) under eq. 14, from the move's Markov blanket."""
    p = board.params
    return _LOG_RATIO[move.kind](board, move, math.log(p.epsilon), math.log(p.epsilon_a))


def apply(board: Blackboard, move: Move) -> None:
    """Perform ``move`` on ``board`` (in place)."""
    kind = move.kind
    if kind is MoveKind.BIRTH:
        assert move.leg is not None
        board.add_leg(move.leg)
    elif kind is MoveKind.CHILD:
        assert move.leg is not None
        board.add_leg(move.leg, move.parent)
    elif kind is MoveKind.PARENT:
        assert move.table is not None
        board.set_parent(move.target, board.add_table(move.table))
    elif kind is MoveKind.PARENT_CHANGE:
        board.set_parent(move.target, move.parent)
    elif move.target in board.legs_:
        board.remove_leg(move.target)
    else:
        for leg_id in board.unsupported_children(move.target):
            board.remove_leg(leg_id)
        board.remove_table(move.target)
