"""States proven possible without computing a prior: witnesses of positive probability.

A question whose evidence lies partly in a part of the network d-separated from its targets
does not contract that evidence, so it must check otherwise that each such observed state
is possible — ``P(X = x) > 0`` (:meth:`~bayesmap.bn.inference.Engine.check_dropped`). A
prior marginal answers that, but computing one costs a contraction over the variable's
ancestors. Most states are proven possible more cheaply, once per network:

A *witness* is a full assignment built in topological order, each variable taking a state
of positive probability given its parents' states in the witness; its joint probability, the
product of those CPT entries, is then positive (Post et al. 2016, eq. 2: the joint is the
product of the CPTs). For a variable ``X`` with parents ``pa``, any state ``x`` with
``P(x | pa_w) > 0`` for some witness ``w`` is possible: the witness's ancestors of ``X``
with ``X = x`` have positive probability, and ``P(X = x)`` is at least that. A batch of
witnesses, each taking a different positive state where it can, proves most states of most
networks; a state not proven is checked by its prior as before (the test is sufficient,
not necessary). Variables at or below a data node (whose table is known only at query time)
are never proven here.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bayesmap.bn.compiled import Compiled, bits

BoolArray = npt.NDArray[np.bool_]

WITNESSES = 64
"""Witnesses per network: assignments built side by side, one numpy call per variable."""


class Witnesses:
    """The witnesses of one network version, built variable by variable as questions need
    them (a variable's after its ancestors'), and the states they prove possible.

    Witness ``j`` gives variable ``X`` the ``(j + X)``-th (cyclically) of the states that
    are positive given the witness's parent states, so the witnesses spread over the states
    rather than all taking the likeliest.
    """

    def __init__(self, compiled: Compiled) -> None:
        self._compiled = compiled
        n = len(compiled.names)
        self._states: list[npt.NDArray[np.intp] | None] = [None] * n
        self._proven: list[BoolArray | None] = [None] * n
        self._done = 0  # bit mask of the variables built
        self._turn = np.arange(WITNESSES)

    def proven(self, var: int) -> BoolArray:
        """Which states of ``var`` a witness proves possible (``var`` must not be at or
        below a data node)."""
        compiled = self._compiled
        if compiled.source_mask & compiled.lineage_masks[var]:
            raise AssertionError("a data node's table is known only at query time")
        if not (self._done >> var) & 1:
            todo = compiled.lineage_masks[var] & ~self._done
            for v in sorted(bits(todo), key=compiled.topo_pos.__getitem__):
                self._build(v)
            self._done |= todo
        proven = self._proven[var]
        assert proven is not None
        return proven

    def _build(self, v: int) -> None:
        """Variable ``v``'s state in every witness (its parents' are built)."""
        compiled = self._compiled
        parents = compiled.parents[v]
        table = compiled.cpts[v]
        if parents:
            positive = table[(slice(None), *[self._states[p] for p in parents])] > 0.0
        else:
            positive = np.repeat((table > 0.0)[:, None], WITNESSES, axis=1)
        self._proven[v] = np.asarray(positive.any(axis=1))
        ranks = np.cumsum(positive, axis=0)  # (states, witnesses)
        wanted = (self._turn + v) % ranks[-1] + 1  # every CPT column has a positive state
        self._states[v] = np.argmax(ranks >= wanted, axis=0)
