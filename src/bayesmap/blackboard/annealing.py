"""The annealing schedule and the driver loop over temperatures (Fox & Prescott 2011 Algorithm 1).

:func:`schedule` gives the inverse temperatures; :func:`anneal` runs one kernel sweep
(:func:`bayesmap.blackboard.kernel.step`) per temperature, calls an optional callback with a
:class:`Snapshot` after each (for figures and animations), and keeps the best blackboard it
has seen under eq. 14 — so the answer is the most probable state the sampler visited, even
if a late uphill move was accepted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bayesmap._typing import FloatArray, IntArray
from bayesmap.blackboard.hypotheses import NULL, Blackboard
from bayesmap.blackboard.kernel import SamplerState, step
from bayesmap.blackboard.params import BlackboardParams


def schedule(params: BlackboardParams) -> FloatArray:
    """Inverse temperatures β: ``n_temperatures`` values, geometric from ``beta_min`` to
    ``beta_max``."""
    return np.geomspace(params.beta_min, params.beta_max, params.n_temperatures)


@dataclass(frozen=True)
class Snapshot:
    """The blackboard after one annealing temperature.

    Attributes
    ----------
    beta
        Inverse temperature of the sweep just done.
    index, n_temperatures
        Which temperature this is (0-based) and how many there are.
    tables
        ``(k, 5)`` rows ``x, y, theta, w_L, tau``.
    legs
        ``(m, 6)`` rows ``x, y, theta, w_x, w_y, tau``.
    leg_parent
        ``(m,)`` row index into ``tables`` of each leg's parent, -1 for none.
    shapelets
        ``(n, 4)`` rows ``x, y, theta, tau`` in working memory.
    shapelet_parent
        ``(n,)`` row index into ``legs`` of the leg contributing most to each shapelet's
        density (eq. 12) if it explains it better than chance (α_S e^{−Δ} ≥ c_S), else -1.
    log_joint
        log P(B) (eq. 14) up to a constant.
    """

    beta: float
    index: int
    n_temperatures: int
    tables: FloatArray
    legs: FloatArray
    leg_parent: IntArray
    shapelets: FloatArray
    shapelet_parent: IntArray
    log_joint: float


def snapshot(
    board: Blackboard, beta: float, index: int, n_temperatures: int, log_joint: float
) -> Snapshot:
    """A :class:`Snapshot` of ``board`` as arrays."""
    table_row = {key: i for i, key in enumerate(board.tables_)}
    leg_keys = list(board.legs_)
    leg_parent = np.array(
        [table_row.get(board.parent_[k], -1) if board.parent_[k] != NULL else -1 for k in leg_keys],
        dtype=np.int64,
    )
    n = len(board.shapelets_)
    shapelet_parent = np.full(n, -1, dtype=np.int64)
    best = [board.params.c_S] * n
    for row, key in enumerate(leg_keys):
        for k, v in enumerate(board.contrib_[key]):
            if v >= best[k]:
                best[k] = v
                shapelet_parent[k] = row
    return Snapshot(
        beta=beta,
        index=index,
        n_temperatures=n_temperatures,
        tables=board.table_array(),
        legs=board.leg_array(),
        leg_parent=leg_parent,
        shapelets=np.array(board.shapelets_, dtype=np.float64).reshape(n, 4),
        shapelet_parent=shapelet_parent,
        log_joint=log_joint,
    )


@dataclass(frozen=True)
class AnnealResult:
    """Outcome of :func:`anneal`.

    Attributes
    ----------
    best
        The most probable blackboard seen (eq. 14), a copy.
    best_log_joint
        Its log P(B), relative to the blackboard the run started from.
    proposed, accepted
        Proposal and acceptance counts by move kind over the whole run.
    """

    best: Blackboard
    best_log_joint: float
    proposed: dict[str, int]
    accepted: dict[str, int]


def anneal(
    rng: np.random.Generator,
    board: Blackboard,
    params: BlackboardParams,
    *,
    callback: Callable[[Snapshot], None] | None = None,
) -> AnnealResult:
    """Run Algorithm 1's loop over the annealing temperatures on ``board`` (edited in place)."""
    betas = schedule(params)
    state = SamplerState(board, float(betas[0]), 0.0)
    best, best_value = board.copy(), 0.0
    proposed: dict[str, int] = {}
    accepted: dict[str, int] = {}
    for index, beta in enumerate(betas):
        state, info = step(rng, state._replace(beta=float(beta)), params)
        for key, value in info.proposed.items():
            proposed[key] = proposed.get(key, 0) + value
        for key, value in info.accepted.items():
            accepted[key] = accepted.get(key, 0) + value
        if state.log_joint > best_value + 1e-9:
            best, best_value = board.copy(), state.log_joint
        if callback is not None:
            callback(snapshot(board, float(beta), index, len(betas), state.log_joint))
    return AnnealResult(best, best_value, proposed, accepted)
