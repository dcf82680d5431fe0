"""Probabilities of propositions (Post et al. 2016 §2.4, eqs. 15–21), optionally given a
condition: the joint posterior of the mentioned variables summed where they hold.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from bayesmap._typing import BoolArray, IntArray
from bayesmap.bn import contraction, posteriors
from bayesmap.bn.fixed_point import (
    Fixed,
    FixedResult,
    QFormat,
    constant,
    normalise,
)
from bayesmap.bn.plans import QueryKind
from bayesmap.bn.propositions import Proposition, parse
from bayesmap.errors import InputError

if TYPE_CHECKING:
    from bayesmap.bn.inference import Engine, Evidence


def probability(
    engine: Engine,
    proposition: Proposition | str,
    evidence: Evidence,
    given: Proposition | str | None = None,
) -> float:
    """``P(proposition | given, evidence)`` (§2.4, eqs. 15–21): the joint posterior of
    the mentioned variables summed where both hold, over the sum where ``given`` holds."""
    names, holds, condition = truth(engine, proposition, given)
    joint = posteriors.joint_posterior(engine, names, evidence)
    if condition is None:
        return float(joint[holds].sum())
    total = float(joint[condition].sum())
    if not total > 0.0:
        raise InputError(f"the condition {given} has probability zero given the evidence")
    return float(joint[holds & condition].sum()) / total


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


def fixed_probability(
    engine: Engine,
    proposition: Proposition | str,
    evidence: Evidence,
    q: QFormat,
    given: Proposition | str | None = None,
) -> FixedResult:
    """:func:`probability` in Q-format integers: the unnormalised joint of the mentioned
    variables, summed where the proposition holds and where it does not (within the
    condition, if any), then divided."""
    compiled = engine.compiled
    names, holds, condition = truth(engine, proposition, given)
    ids = tuple(compiled.id(n) for n in names)
    ev = engine.evidence_ids(evidence)
    observed = tuple(ev.get(v, slice(None)) for v in ids)
    mask = holds[observed]
    inside = None if condition is None else condition[observed]
    free = tuple(v for v in ids if v not in ev)
    what = f"probability of {proposition}" + ("" if given is None else f" given {given}")
    if not free:
        posteriors.probability_of_evidence(engine, evidence)
        if inside is not None and not inside:
            raise InputError(f"the condition {given} is false for the evidence")
        return constant(q, np.asarray(float(mask)))
    joint = contraction.fixed_sum(
        engine, engine.plan(QueryKind.MARGINAL, free, frozenset(ev)), ev, evidence, q
    )
    if inside is None:
        yes, no = mask, ~mask
    else:
        if not np.any(joint.raw[inside] > 0):
            raise InputError(f"the condition {given} has probability zero given the evidence")
        yes, no = mask & inside, ~mask & inside
    split = Fixed(
        np.array([joint.raw[yes].sum(), joint.raw[no].sum()]),
        joint.exp.reshape(1),
        np.array([joint.error[yes].sum(), joint.error[no].sum()]),
    )
    answer = normalise(q, split, (0,), what)
    return FixedResult(q, answer.raw[0], answer.values[0], answer.bound[0])
