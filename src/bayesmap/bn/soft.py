"""Soft (likelihood) evidence: a sensor's reading as a weight on each state of a variable.

A likelihood ``λ(x) = P(reading | X = x)`` up to a constant enters a question as one more
factor on ``X``: ``P(T | e, λ) ∝ Σ Π_i P(X_i | Pa_i) · λ(x)``, the posterior of Post et al.
2016 eq. 24 with the sensor's CPT column put in place of an observed child's. This is Pearl's
*virtual evidence*, which is what pyAgrum calls soft or likelihood evidence: only the ratios
of λ matter.

One case is asked of a *shadow network*: the network plus one virtual binary child per
softly observed variable, observed in its first state, whose table ``[λ/max λ, 1 − λ/max λ]``
is a data node (§3.4, "D") read at query time. So every question — posteriors, joints,
MAP, marginal MAP, propositions, each in float or fixed point — takes soft evidence with
the engine's own plans and caches (the shadow keeps its caches while the network is
unchanged). A batch with a likelihood per case weights the joint posterior of the target
and the softly observed variables instead (see
:meth:`~bayesmap.bn.inference.Engine.posterior_batch`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray
from bayesmap.bn.tables import DataSource
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.model import BayesNet

Likelihoods = Mapping[str, npt.ArrayLike | Mapping[str, float]]
"""Soft evidence: ``{variable: likelihood}``, one non-negative weight per state (an array in
state order, or ``{state: weight}`` naming every state). Only the ratios matter."""

SEEN = "seen"
"""The observed state of a virtual child."""


def likelihood(name: str, states: Sequence[str], value: object) -> FloatArray:
    """The checked likelihood vector of variable ``name`` (one weight per state).

    Raises
    ------
    InputError
        Wrong length, a missing or unknown state, a negative, NaN or infinite weight, or
        all weights zero.
    """
    if isinstance(value, Mapping):
        unknown = [s for s in value if s not in states]
        missing = [s for s in states if s not in value]
        if unknown or missing:
            raise InputError(
                f"soft evidence on {name!r}: give a weight for each state {list(states)}"
                + (f"; unknown {unknown}" if unknown else "")
                + (f"; missing {missing}" if missing else "")
            )
        value = [value[s] for s in states]
    try:
        weights = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"soft evidence on {name!r}: {value!r} is not numeric") from None
    if weights.shape != (len(states),):
        raise InputError(
            f"soft evidence on {name!r}: need {len(states)} weights (states {list(states)}), "
            f"got shape {weights.shape}"
        )
    check_weights(name, weights)
    return weights


def check_weights(name: str, weights: FloatArray) -> None:
    """Raise unless each likelihood (last axis: states; a leading axis: cases) is finite,
    non-negative and not all zero; the message names the variable and the case."""
    rows = np.atleast_2d(weights)
    bad = ~(np.isfinite(rows).all(axis=1) & (rows >= 0.0).all(axis=1))
    bad |= ~(rows.max(axis=1, initial=0.0) > 0.0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        where = f"soft evidence on {name!r}" + (f", case {i}" if weights.ndim > 1 else "")
        raise InputError(
            f"{where}: weights {rows[i].tolist()} must be finite, non-negative and not all zero"
        )


class Shadow:
    """A copy of a network with a virtual child per softly observed variable.

    Parameters
    ----------
    net
        The network; the shadow is stale once ``net.version`` moves on.
    variables
        The softly observed variables.
    """

    def __init__(self, net: BayesNet, variables: Sequence[str]) -> None:
        self.version = net.version
        self.net = net.copy()
        self._weights: dict[str, FloatArray] = {}
        self.children: dict[str, str] = {}
        taken = set(net.variables)
        for x in variables:
            child = f"likelihood({x})"
            while child in taken:
                child += "'"
            taken.add(child)
            self.children[x] = child
            self.net.add_variable(child, (SEEN, "not " + SEEN), parents=[x], source=self._table(x))

    def _table(self, x: str) -> DataSource:
        def table(_evidence: Mapping[str, str]) -> FloatArray:
            weights = self._weights[x]
            return np.stack([weights, 1.0 - weights])

        return table

    def evidence(
        self, evidence: Mapping[str, str | int], weights: Mapping[str, FloatArray]
    ) -> dict[str, str | int]:
        """Set the virtual children's tables to ``weights``; the evidence to ask with."""
        clash = sorted(set(weights) & set(evidence))
        if clash:
            raise InputError(f"{clash[0]!r} has both an observed state and soft evidence")
        for x, w in weights.items():
            self._weights[x] = w / w.max()
        return {**evidence, **{self.children[x]: SEEN for x in weights}}
