"""Probabilities of propositions (Post et al. 2016 §2.4, eqs. 15–21), optionally given a
condition: the joint posterior of the mentioned variables summed where they hold.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from bayesmap._typing import BoolArray, IntArray
from bayesmap.bn import contraction, posteriors
from bayesmap.bn.plans import QueryKind
from bayesmap.bn.propositions import Proposition, parse

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine, Evidence
    from bayesmap.bn.numbers import Numbers, S


def probability(
    engine: Engine,
    proposition: Proposition | str,
    evidence: Evidence,
    given: Proposition | str | None,
    numbers: Numbers[Any, Any, S],
) -> S:
    """``P(proposition | given, evidence)`` (§2.4, eqs. 15–21) in ``numbers``: the joint of
    the mentioned variables summed where both hold, over the sum where ``given`` holds."""
    names, holds, condition = truth(engine, proposition, given)
    ev, ids, free = posteriors.joint_query(engine, names, evidence)
    observed = tuple(ev.get(v, slice(None)) for v in ids)
    mask = holds[observed]
    inside = None if condition is None else condition[observed]
    joint = None
    if free:
        plan = engine.plan(QueryKind.MARGINAL, free, frozenset(ev))
        joint = numbers.sum_product(engine, plan, ev, evidence)
    else:
        posteriors.probability_of_evidence(engine, evidence)
    what = f"probability of {proposition}" + ("" if given is None else f" given {given}")
    card = engine.compiled.card
    return numbers.share(
        joint,
        (holds, condition),
        (mask, inside),
        lambda a: contraction.embed(a, ids, free, ev, card),
        evidence,
        (what, None if given is None else str(given)),
    )


def truth(
    engine: Engine, proposition: Proposition | str, given: Proposition | str | None
) -> tuple[tuple[str, ...], BoolArray, BoolArray | None]:
    """Variables mentioned by a proposition and its condition, and where each holds on
    the grid of their joint states (condition ``None`` when there is none)."""
    prop = parse(proposition) if isinstance(proposition, str) else proposition
    cond = parse(given) if isinstance(given, str) else given
    names = prop.variables() if cond is None else (*prop.variables(), *cond.variables())
    names = tuple(dict.fromkeys(names))
    compiled = engine.compiled
    ids = [compiled.id(n) for n in names]
    shape = [compiled.card[v] for v in ids]
    grids: dict[str, IntArray] = dict(zip(names, np.indices(shape), strict=True))

    def index(var: str, state: str) -> int:
        return compiled.state(compiled.id(var), state)

    holds = np.broadcast_to(prop.holds(grids, index), shape)
    if cond is None:
        return names, holds, None
    return names, holds, np.broadcast_to(cond.holds(grids, index), shape)
