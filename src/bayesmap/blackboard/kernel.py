"""One sweep of Algorithm 1 at one temperature, as a kernel ``step(rng, state, params)``.

The sweep follows Fox & Prescott (2011) Algorithm 1: first, for each shapelet, a new parent
leg is proposed and tested; then, for each hypothesis on the blackboard (in id order, as the
sweep began), ``r ~ U(0, 1)`` picks death (r < r1), parent change (r < r2), child (r < r3,
the paper's second "r < r2") or a new parent. Moves a hypothesis cannot make are dropped
and the thresholds renormalised over the rest: a table (no parent) dies with probability
r1 / (r1 + r3 − r2) and otherwise proposes a child; a leg (whose children are observed
shapelets) never proposes a child. Every candidate passes the one acceptance rule,
:func:`accept` — annealed Gibbs on the Markov blanket (eqs. 20–21).

The blackboard is large and mutable, so the kernel edits ``state.board`` in place and
returns the updated state; all randomness comes from ``rng``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from bayesmap.blackboard.blanket import Move, MoveKind, apply, log_ratio
from bayesmap.blackboard.densities import acceptance_probability_scalar
from bayesmap.blackboard.hypotheses import Blackboard
from bayesmap.blackboard.params import BlackboardParams
from bayesmap.blackboard.proposals import (
    propose_child,
    propose_death,
    propose_leg_for_shapelet,
    propose_parent,
    propose_parent_change,
)

Proposal = Callable[[np.random.Generator, Blackboard, BlackboardParams, int], Move | None]
"""``propose(rng, board, params, target) -> Move | None``."""

_ADDS = (MoveKind.BIRTH, MoveKind.CHILD, MoveKind.PARENT)


class SamplerState(NamedTuple):
    """The sampler's state.

    Attributes
    ----------
    board
        The blackboard B (edited in place by :func:`step`).
    beta
        Inverse temperature β of the current sweep.
    log_joint
        log P(B) of eq. 14 up to a constant, tracked by adding accepted log ratios.
    """

    board: Blackboard
    beta: float
    log_joint: float


class StepInfo(NamedTuple):
    """What one sweep did: proposals and acceptances by move kind (``MoveKind.value`` keys)."""

    proposed: dict[str, int]
    accepted: dict[str, int]


def accept(rng: np.random.Generator, log_ratio_value: float, beta: float) -> bool:
    """Accept a candidate with the annealed Gibbs probability of eqs. 20–21."""
    return rng.random() < acceptance_probability_scalar(log_ratio_value, beta)


def step(
    rng: np.random.Generator, state: SamplerState, params: BlackboardParams
) -> tuple[SamplerState, StepInfo]:
    """One sweep of Algorithm 1 at inverse temperature ``state.beta``."""
    board, beta, log_joint = state
    proposed = dict.fromkeys((k.value for k in MoveKind), 0)
    accepted = dict.fromkeys((k.value for k in MoveKind), 0)

    def attempt(move: Move | None) -> None:
        nonlocal log_joint
        if move is None:
            return
        if move.kind in _ADDS and len(board) >= params.max_hypotheses:
            return
        proposed[move.kind.value] += 1
        value = log_ratio(board, move)
        if accept(rng, value, beta):
            apply(board, move)
            log_joint += value
            accepted[move.kind.value] += 1

    for k in range(len(board.shapelets_)):
        attempt(propose_leg_for_shapelet(rng, board, params, k))

    r1, r2, r3 = params.r1, params.r2, params.r3
    table_death = r1 / (r1 + r3 - r2)
    leg_norm = r2 + 1.0 - r3
    for key in sorted((*board.tables_, *board.legs_)):
        r = rng.random()
        propose: Proposal
        if key in board.tables_:
            propose = propose_death if r < table_death else propose_child
        elif key in board.legs_:
            r *= leg_norm
            if r < r1:
                propose = propose_death
            elif r < r2:
                propose = propose_parent_change
            else:
                propose = propose_parent
        else:
            continue  # removed earlier in this sweep
        attempt(propose(rng, board, params, key))
    return SamplerState(board, beta, log_joint), StepInfo(proposed, accepted)
