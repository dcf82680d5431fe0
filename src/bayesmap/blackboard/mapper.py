"""TableMapper: Algorithm 1 over a sequence of poses (Fox & Prescott 2011 §II-C).

At each time step the mapper updates its working memory (the seven most recent shapelets),
anneals the blackboard over the temperature schedule, keeps the most probable blackboard it
saw, prunes every hypothesis not linked to a shapelet directly or via a common ancestor, and
returns the tables of that blackboard: the MAP set of tables (eq. 18). The blackboard left
after pruning is where the next time step starts.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from bayesmap._rng import RNGLike, as_generator
from bayesmap._typing import FloatArray
from bayesmap.blackboard.annealing import Snapshot, anneal
from bayesmap.blackboard.hypotheses import NULL, Blackboard
from bayesmap.blackboard.params import BlackboardParams
from bayesmap.errors import InputError

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class StepResult:
    """The outcome of one time step.

    Attributes
    ----------
    tables
        ``(k, 5)`` MAP tables (eq. 18): ``x, y`` [m] centre, ``theta`` [rad] in [0, π),
        ``leg_width`` [m], ``tau``.
    info
        Counters: ``proposed_<kind>`` and ``accepted_<kind>`` for each move kind,
        ``n_shapelets`` (in memory), ``n_tables``, ``n_legs`` (after pruning),
        ``n_temperatures``, and ``log_joint_gain`` (log P of the best blackboard relative
        to the one the step started from).
    """

    tables: FloatArray
    info: dict[str, float] = field(default_factory=dict)


def check_shapelets(shapelets: FloatArray) -> FloatArray:
    """Validate shapelets as a float ``(n, 4)`` array of finite ``x, y, theta, tau`` rows."""
    array = np.asarray(shapelets, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 4:
        raise InputError(
            f"shapelets must be an (n, 4) array of x, y, theta, tau rows, got shape {array.shape}"
        )
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        raise InputError(
            f"shapelets rows {np.flatnonzero(bad).tolist()} contain NaN or inf; drop "
            "non-contacting whiskers before calling TableMapper.step"
        )
    return array


def prune(board: Blackboard) -> None:
    """Remove hypotheses linked to no shapelet directly or via a common ancestor (Algorithm 1).

    A leg is linked directly if it explains some shapelet better than chance
    (α_S e^{−Δ_LS} ≥ c_S, eqs. 7, 9); a table is kept if one of its legs is linked, and
    then so are all its legs (they share the table as ancestor).
    """
    c_S = board.params.c_S
    linked = {key for key, values in board.contrib_.items() if any(v >= c_S for v in values)}
    kept_tables = {board.parent_[key] for key in linked} - {NULL}
    for key in [t for t in board.tables_ if t not in kept_tables]:
        board.remove_table(key)
    for key in [k for k in board.legs_ if k not in linked and board.parent_[k] == NULL]:
        board.remove_leg(key)


class TableMapper:
    """The Bayesian-blackboard table mapper of Fox & Prescott (2011).

    Parameters
    ----------
    params
        Model and sampler constants (:class:`BlackboardParams`).

    Attributes
    ----------
    board_
        The blackboard B carried between time steps.
    memory_
        ``(n, 4)`` working memory: the ``params.memory_size`` most recent shapelets.

    Examples
    --------
    >>> import numpy as np
    >>> mapper = TableMapper(BlackboardParams())
    >>> result = mapper.step(np.zeros((0, 4)), rng=0)
    >>> result.tables.shape
    (0, 5)
    """

    def __init__(self, params: BlackboardParams) -> None:
        self.params = params
        self.reset()

    def reset(self) -> None:
        """Forget every hypothesis and shapelet (start a new run)."""
        self.board_ = Blackboard(self.params)
        self.memory_: FloatArray = np.zeros((0, 4))

    def step(
        self,
        shapelets: FloatArray,
        *,
        rng: RNGLike = None,
        callback: Callable[[Snapshot], None] | None = None,
    ) -> StepResult:
        """One time step of Algorithm 1 with this pose's ``(n, 4)`` shapelets.

        Parameters
        ----------
        shapelets
            Rows ``x, y`` [m], ``theta`` [rad] (surface normal, world frame, pointing out
            of the touched surface), ``tau``; ``n`` may be 0.
        rng
            Seed or generator; the same seed gives the same result.
        callback
            Called with a :class:`Snapshot` after every annealing temperature.
        """
        new = check_shapelets(shapelets)
        generator = as_generator(rng)
        self.memory_ = np.concatenate([self.memory_, new])[-self.params.memory_size :]
        board = self.board_
        board.set_shapelets(self.memory_)
        counters: dict[str, float] = {}
        gain = 0.0
        if len(self.memory_):
            result = anneal(generator, board, self.params, callback=callback)
            board = result.best
            gain = result.best_log_joint
            for key, value in result.proposed.items():
                counters[f"proposed_{key}"] = value
            for key, value in result.accepted.items():
                counters[f"accepted_{key}"] = value
        prune(board)
        self.board_ = board
        counters.update(
            n_shapelets=len(self.memory_),
            n_tables=len(board.tables_),
            n_legs=len(board.legs_),
            n_temperatures=self.params.n_temperatures,
            log_joint_gain=gain,
        )
        logger.debug("blackboard step: %s", counters)
        return StepResult(tables=board.table_array(), info=counters)
